//! Standard tests at evaluation inputs, against hand-derived values: a backlash gives ISO 230-2
//! its reversal value, a ballbar its step where the axis reverses, a diagonal the reverse slope
//! of an axis moving `−`, an R-test the backlash of a linear axis following the sphere; the
//! temperatures hold for every run; an axis the test does not move approaches as the inputs say.

use volmap::model::inputs::Inputs;
use volmap::model::Machine;
use volmap::standards::{self, CircularSpec, DiagonalSpec, PositioningSpec, RTestSpec, Setup};

use super::standards::circular_spec;

/// The three-axis machine of the standards tests (X-Y table, Z head, no offsets and no tool, so
/// a translational component error alone is VE itself), with the lines of `x`, `y`, `z` in
/// its axis sections and the thermal input `x_scale` at a reference of 20 °C.
fn machine(x: &str, z: &str) -> Machine {
    let text = format!(
        r#"
name = "three-axis"
chain = "FYXFZ"
[thermal]
reference_C = 20.0
inputs = ["x_scale"]
[axes.X]
range = [-400.0, 400.0]
{x}
[axes.Y]
range = [-300.0, 300.0]
[axes.Z]
range = [-250.0, 250.0]
{z}
"#
    );
    Machine::from_toml(&text, "three-axis.toml", None).unwrap()
}

fn figure(result: &standards::TestResult, name: &str) -> f64 {
    result
        .figures
        .iter()
        .find(|f| f.name == name)
        .unwrap_or_else(|| panic!("no figure {name}"))
        .predicted
}

fn positioning_of_x() -> PositioningSpec {
    PositioningSpec {
        axis: "X".into(),
        targets: Some(5),
        runs: 5,
        at_mm: None,
        pose: String::new(),
        csv: None,
    }
}

#[test]
fn a_backlash_gives_the_iso230_2_reversal_value_equal_to_its_width() {
    // EXX = 1e-5·X approaching +, 0.004 + 1e-5·X approaching −: a backlash of w = 4 µm. The ↑
    // runs read x↑(t) = 1e-5·(t + 400), the ↓ runs x↓(t) = w + 1e-5·(t + 400) (zeroed at the
    // first target of the ↑ run, t = −400), every run alike: B_i = x↑ − x↓ = −w, s = 0.
    let w = 0.004;
    let m = machine(
        "EXX = { poly = [0.0, 1.0e-5], reverse = { poly = [0.004, 1.0e-5] } }",
        "",
    );
    let setup = Setup::new(&m, "").unwrap();
    let result = standards::positioning(&setup, &positioning_of_x()).unwrap();
    assert_eq!(result.positions, [-400.0, -200.0, 0.0, 200.0, 400.0]);
    for (n, t) in result.positions.iter().enumerate() {
        let up = 1e-5 * (t + 400.0);
        assert!((result.predicted[0][n] - up).abs() < 1e-12, "↑ at {t}");
        assert!(
            (result.predicted[1][n] - (up + w)).abs() < 1e-12,
            "↓ at {t}"
        );
    }
    let span = 1e-5 * 800.0;
    for (name, expected) in [
        ("B", w),
        ("B̄", -w),
        // R_i = 2s↑ + 2s↓ + |B_i| = w; the runs of one direction repeat exactly.
        ("R", w),
        ("R↑", 0.0),
        ("R↓", 0.0),
        ("E↑", span),
        ("E↓", span),
        ("A↑", span),
        ("A↓", span),
        // Over both directions: from x↑(−400) = 0 to x↓(400) = w + span.
        ("E", w + span),
        ("A", w + span),
        // The mean of ↑ and ↓ runs: w/2 + 1e-5·(t + 400).
        ("M", span),
    ] {
        let value = figure(&result, name);
        assert!(
            (value - expected).abs() < 1e-12,
            "{name} = {value}, not {expected}"
        );
    }
    assert_eq!(result.moving_axes, ['X']);
    assert!(result.inputs.contains("Y+ Z+"), "{}", result.inputs);
    // Another axis's direction changes nothing here (X's errors are X's own).
    let inputs = Inputs::parse("", "Y=-,Z=-", &m).unwrap();
    let other = standards::positioning(
        &Setup::with_inputs(&m, "", &inputs).unwrap(),
        &positioning_of_x(),
    )
    .unwrap();
    assert_eq!(other.predicted, result.predicted);
    assert!(other.inputs.contains("Y- Z-"), "{}", other.inputs);
}

#[test]
fn the_temperatures_hold_for_every_run() {
    // A scale growing by α = 11.5 µm/m per kelvin of x_scale: at 30 °C every run reads
    // α·10·(t + 400), both directions alike.
    let alpha = 11.5e-6;
    let m = machine(
        "EXX = { value = 0.0, per_kelvin = { x_scale = { poly = [0.0, 11.5e-6] } } }",
        "",
    );
    let warm = Inputs::parse("x_scale=30", "", &m).unwrap();
    let result = standards::positioning(
        &Setup::with_inputs(&m, "", &warm).unwrap(),
        &positioning_of_x(),
    )
    .unwrap();
    assert_eq!(result.positions.len(), 5);
    for (n, t) in result.positions.iter().enumerate() {
        let expected = alpha * 10.0 * (t + 400.0);
        for curve in &result.predicted {
            assert!((curve[n] - expected).abs() < 1e-12, "{t}: {}", curve[n]);
        }
    }
    assert!((figure(&result, "E") - alpha * 10.0 * 800.0).abs() < 1e-12);
    assert_eq!(figure(&result, "B"), 0.0);
    assert!(result.inputs.contains("x_scale=30 °C"), "{}", result.inputs);
    // At the reference temperature the scale is exact.
    let cold = standards::positioning(&Setup::new(&m, "").unwrap(), &positioning_of_x()).unwrap();
    assert!(cold.predicted.iter().flatten().all(|x| x.abs() < 1e-12));
}

/// `|p + (w, 0, 0) − c| − r` at angle θ on a circle of radius r: the radial deviation of a
/// constant VE of w along X.
fn shifted(r: f64, w: f64, t_deg: f64) -> f64 {
    (r * r + 2.0 * r * w * t_deg.to_radians().cos() + w * w).sqrt() - r
}

#[test]
fn a_ballbar_steps_where_a_backlashed_axis_reverses() {
    // EXX = w while X approaches −, 0 while it approaches +: VE = (w, 0, 0) where X moves −,
    // so dr(θ) = √(r² + 2rw·cos θ + w²) − r there (≈ w·cos θ) and 0 elsewhere. Counter-clockwise
    // X moves − for 0° < θ < 180° and arrives at 180° moving −: the ballbar jumps by ≈ +w just
    // after 0°, where X reverses at its + end, and back by ≈ w just after 180°.
    let (w, r) = (0.003, 150.0);
    let m = machine("EXX = { value = 0.0, reverse = 0.003 }", "");
    let setup = Setup::new(&m, "").unwrap();
    let ccw = standards::circular(&setup, &circular_spec("XY", r)).unwrap();
    assert_eq!(ccw.predicted[0].len(), ccw.positions.len());
    assert!(!ccw.positions.is_empty());
    for (t, dr) in ccw.positions.iter().zip(&ccw.predicted[0]) {
        let minus = *t > 0.0 && *t <= 180.0;
        let expected = if minus { shifted(r, w, *t) } else { 0.0 };
        assert!(
            (dr - expected).abs() < 1e-12,
            "ccw θ = {t}: {dr} against {expected}"
        );
    }
    assert!((ccw.predicted[0][1] - shifted(r, w, 5.0)).abs() < 1e-12);
    assert!(ccw.predicted[0][1] > 0.99 * w);
    // Clockwise, X moves − below the X axis: 180° ≤ θ < 360° (at 180° it arrives moving −, at
    // 0° moving +).
    let cw = CircularSpec {
        direction: "cw".into(),
        ..circular_spec("XY", r)
    };
    let cw = standards::circular(&setup, &cw).unwrap();
    assert_eq!(cw.predicted[0].len(), cw.positions.len());
    assert!(!cw.positions.is_empty());
    for (t, dr) in cw.positions.iter().zip(&cw.predicted[0]) {
        let t = t.rem_euclid(360.0);
        let minus = (180.0 - 1e-9..360.0 - 1e-9).contains(&t);
        let expected = if minus { shifted(r, w, t) } else { 0.0 };
        assert!(
            (dr - expected).abs() < 1e-12,
            "cw θ = {t}: {dr} against {expected}"
        );
    }
    // A circle that does not move X sees X approaching as the inputs say: + by default.
    let yz = standards::circular(&setup, &circular_spec("YZ", 100.0)).unwrap();
    assert!(yz.predicted[0].iter().all(|dr| dr.abs() < 1e-12));
    assert_eq!(ccw.moving_axes, ['X', 'Y']);
}

#[test]
fn an_axis_the_circle_does_not_move_approaches_as_the_inputs_say() {
    // EXZ = k·X while Z approaches −: an XY circle with Z standing at `−` moves the tool ball
    // by k·(X − X_centre) = k·r·cos θ along X from the centre ball (which the set-up put at
    // k·X_centre), a stretch of X: |(r(1 + k) cos θ, r sin θ)| − r; at `+` it is not.
    let (k, r) = (2.0e-5, 120.0);
    let m = machine(
        "",
        "EXZ = { value = 0.0, reverse = { poly = [0.0, 2.0e-5], of = \"X\" } }",
    );
    let down = Inputs::parse("", "Z=-", &m).unwrap();
    let result = standards::circular(
        &Setup::with_inputs(&m, "", &down).unwrap(),
        &circular_spec("XY", r),
    )
    .unwrap();
    assert_eq!(result.predicted[0].len(), result.positions.len());
    assert!(!result.positions.is_empty());
    for (t, dr) in result.positions.iter().zip(&result.predicted[0]) {
        let (s, c) = t.to_radians().sin_cos();
        let expected = (r * (1.0 + k) * c).hypot(r * s) - r;
        assert!(
            (dr - expected).abs() < 1e-12,
            "θ = {t}: {dr} against {expected}"
        );
    }
    assert!(result.figures[1].predicted > 0.9 * k * r);
    assert!(result.inputs.contains("Z-"), "{}", result.inputs);
    let up = standards::circular(&Setup::new(&m, "").unwrap(), &circular_spec("XY", r)).unwrap();
    assert!(up.predicted[0].iter().all(|dr| dr.abs() < 1e-12));
}

#[test]
fn a_diagonal_moves_each_axis_one_way() {
    // EXX = k1·X approaching +, k2·X approaching −. PPP moves X +: e(s) = k1·s·dx²; NPP moves
    // X −: e(s) = k2·s·dx² (X(s) − X(0) = s·dx either way).
    let (k1, k2) = (1.0e-5, 3.0e-5);
    let m = machine(
        "EXX = { poly = [0.0, 1.0e-5], reverse = { poly = [0.0, 3.0e-5] } }",
        "",
    );
    let setup = Setup::new(&m, "").unwrap();
    let (lo, hi) = setup.travel_box().unwrap();
    for (name, k) in [
        ("PPP", k1),
        ("NPP", k2),
        ("PNP", k1),
        ("XY-NP", k2),
        ("XY-PP", k1),
    ] {
        let spec = DiagonalSpec {
            diagonal: Some(name.into()),
            from_mm: None,
            to_mm: None,
            points: 11,
            pose: String::new(),
            csv: None,
        };
        let result = standards::diagonal(&setup, &spec).unwrap();
        let (from, to) = standards::diagonal_ends(name, lo, hi).unwrap();
        let d = (to - from).normalize();
        assert_eq!(
            (result.positions.len(), result.predicted[0].len()),
            (11, 11)
        );
        for (s, e) in result.positions.iter().zip(&result.predicted[0]) {
            let expected = k * s * d.x * d.x;
            assert!(
                (e - expected).abs() < 1e-13,
                "{name} at {s}: {e} against {expected}"
            );
        }
        // A face diagonal does not move the third axis.
        let moving: &[char] = if name.starts_with("XY") {
            &['X', 'Y']
        } else {
            &['X', 'Y', 'Z']
        };
        assert_eq!(result.moving_axes, moving, "{name}");
    }
}

#[test]
fn an_r_test_sees_the_backlash_of_a_linear_axis_following_the_sphere() {
    // Table C on X (FYXCFZ): the tip in the workpiece frame is Rz(θ)·(x, y, z), so the sphere
    // at (R, 0, 20) is followed with x = R·cos θ, y = −R·sin θ. X moves − for 0° < θ < 180° and
    // arrives at 180° moving −. EXX = w there gives VE = Rz(θ)·(w, 0, 0), read in the spindle
    // frame as −Rz(θ)ᵀ·VE = (−w, 0, 0): dX = −w on (0°, 180°], 0 elsewhere (zeroed at 0°,
    // where X arrives moving +). The C backlash never shows: the sweep turns C `+`.
    let w = 0.005;
    let text = r#"
name = "table C"
chain = "FYXCFZ"
[axes.X]
range = [-400.0, 400.0]
EXX = { value = 0.0, reverse = 0.005 }
[axes.Y]
range = [-300.0, 300.0]
[axes.Z]
range = [-250.0, 250.0]
[axes.C]
range = [0.0, 360.0]
EXC = { value = 0.0, reverse = 0.05 }
"#;
    let m = Machine::from_toml(text, "table-c.toml", None).unwrap();
    let spec = RTestSpec {
        axis: "C".into(),
        sphere_mm: Some([150.0, 0.0, 20.0]),
        from_deg: None,
        to_deg: None,
        step_deg: 15.0,
        pose: String::new(),
        csv: None,
    };
    let result = standards::rtest(&Setup::new(&m, "").unwrap(), &spec).unwrap();
    assert_eq!(result.positions.len(), 25);
    for (n, t) in result.positions.iter().enumerate() {
        let expected = if *t > 0.0 && *t <= 180.0 { -w } else { 0.0 };
        assert!(
            (result.predicted[0][n] - expected).abs() < 1e-12,
            "dX at {t}"
        );
        assert!(result.predicted[1][n].abs() < 1e-12, "dY at {t}");
        assert!(result.predicted[2][n].abs() < 1e-12, "dZ at {t}");
    }
    assert_eq!(result.moving_axes, ['X', 'Y', 'C']);
    // Asking C to approach − changes nothing: the sweep decides.
    let inputs = Inputs::parse("", "C=-", &m).unwrap();
    let again = standards::rtest(&Setup::with_inputs(&m, "", &inputs).unwrap(), &spec).unwrap();
    assert_eq!(again.predicted, result.predicted);
}
