//! Five-axis orientation compensation through a singular pose (B0 on the C table of
//! `5axis-hwang2014`, the tool along C): the tip is always compensated, the rotary correction
//! stays within its bound, and the part of the tool axis's error the bound leaves is reported
//! per line, never refused. Every figure is checked with the reference model on the program as
//! written (its words read here, not by volmap's reader).

use nalgebra::Vector3;
use volmap::io::embedded;
use volmap::model::inputs::Inputs;
use volmap::model::Machine;
use volmap::nc::{self, Options};
use volmap::reference::tool_pose;

/// The axis position after every block of a program written with absolute X Y Z B C words
/// (comments and words without a number skipped): what the control is commanded.
fn positions(text: &str) -> Vec<[f64; 6]> {
    let mut at = [f64::NAN; 6];
    let mut out = Vec::new();
    for line in text.lines().filter(|l| !l.starts_with('(')) {
        let mut moved = false;
        for word in line.split(' ') {
            let Some(letter) = word.chars().next() else {
                continue;
            };
            let Some(d) = "XYZABC".find(letter) else {
                continue;
            };
            at[d] = word[1..].parse().unwrap();
            moved = true;
        }
        if moved {
            out.push(at);
        }
    }
    out
}

fn hwang() -> Machine {
    embedded::load("5axis-hwang2014").unwrap()
}

/// The tool tip and unit tool axis of `machine` at `command` (workpiece frame).
fn pose(machine: &Machine, command: &[f64; 6]) -> (Vector3<f64>, Vector3<f64>) {
    let (tip, rotation) = tool_pose(machine, command);
    (tip, rotation.column(2).into_owned())
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// 12 decimals: the solve itself, not the rounding, is what the figures check (rotary rounding
/// 1e-12° over a lever of 1 m is 2e-11 mm).
fn options(bound_deg: f64) -> Options {
    Options {
        decimals: Some(12),
        orientation_tolerance_rad: Some(nc::DEFAULT_ANGULAR_TOLERANCE_RAD),
        max_rotary_correction_deg: bound_deg,
        ..Options::default()
    }
}

/// The turn (degrees, B and C as a vector) of a written point from the programmed segment
/// `from`–`to` in the B–C plane: the least over the segment, so at most the turn from the
/// programmed point at the same fraction.
fn turn_from_segment(point: &[f64; 6], from: &[f64; 6], to: &[f64; 6]) -> f64 {
    turn_about(point, from, to, [4, 5])
}

/// [`turn_from_segment`] for the rotary axes `[r0, r1]` (program axes 3..6).
fn turn_about(point: &[f64; 6], from: &[f64; 6], to: &[f64; 6], [r0, r1]: [usize; 2]) -> f64 {
    let (p, a, b) = (
        [point[r0], point[r1]],
        [from[r0], from[r1]],
        [to[r0], to[r1]],
    );
    let ab = [b[0] - a[0], b[1] - a[1]];
    let length2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if length2 > 0.0 {
        (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / length2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((p[0] - a[0] - t * ab[0]).powi(2) + (p[1] - a[1] - t * ab[1]).powi(2)).sqrt()
}

/// At B0 exactly the tool lies along C: B turns the tool axis across one direction only (about
/// its own axis), and C hardly at all. By hand: the error left is the real tool axis's
/// component along B's axis, `a_real · n` with `n = a_ideal × (∂a_ideal/∂B)/|∂a_ideal/∂B|`,
/// evaluated with the reference model at the programmed pose. The program compensates, exit 0,
/// and reports it on its line.
#[test]
fn at_b0_the_error_c_cannot_turn_stays_and_is_reported() {
    let machine = hwang();
    let program = "G90 G0 X400. Y300. Z300. B30. C45.\nG1 B0. F500\n";
    let out = nc::compensate(&machine, program.as_bytes(), "b0.nc", &options(1.0)).unwrap();
    let ideal = machine.without_errors();
    let real = machine.at(&Inputs::default());
    let q = [400.0, 300.0, 300.0, 0.0, 0.0, 45.0];
    let (_, a_ideal) = pose(&ideal, &q);
    let mut turned = q;
    turned[4] += 1e-3;
    let (_, a_turned) = pose(&ideal, &turned);
    let n = a_ideal.cross(&(a_turned - a_ideal)).normalize();
    let (_, a_real) = pose(&real, &q);
    let expected = a_real.dot(&n).abs();
    // The machine's tilts give tens of µrad: a figure the test can see.
    assert!(expected > 5e-6, "{expected}");
    // Tolerance: C turns the tool axis there by |c × a| ≈ the machine's tilts summed (< 1e-4
    // rad/rad), over at most the bound (1° = 0.0175 rad): 1.75e-6 rad; B's real axis differs
    // from the ideal one by its tilts (3e-5 rad) times the error (1e-4): 3e-9 rad.
    let tolerance = 2e-6;
    let report = &out.report;
    let left = &report.orientation_left;
    assert_eq!(left.len(), 1, "{report:?}");
    assert_eq!(left[0].line, 2);
    assert!(
        (left[0].left_rad - expected).abs() < tolerance,
        "{} vs {expected}",
        left[0].left_rad
    );
    // The program as written, fed to the reference model: the same angle at the end point, and
    // the tip where the ideal machine puts it (1e-9 mm: the solve's 1e-10 plus rounding).
    let written = positions(&out.text);
    let end = written.last().unwrap();
    let (tip, axis) = pose(&real, end);
    let (ideal_tip, _) = pose(&ideal, &q);
    assert!(
        (tip - ideal_tip).norm() < 1e-9,
        "{}",
        (tip - ideal_tip).norm()
    );
    assert!(
        (angle(&axis, &a_ideal) - expected).abs() < tolerance,
        "{} vs {expected}",
        angle(&axis, &a_ideal)
    );
    // The rotary correction stays within the bound.
    assert!(turn_from_segment(end, &q, &q) <= 1.0 + 1e-9, "{end:?}");
}

/// The move: from B15 C30 to B−20 C75, through B = 0. It compensates; at its programmed
/// end points the tip lands within 1e-6 mm (the solve's 1e-10 mm, 12 decimals); every written
/// point's B and C lie within the bound of the programmed segment; the real tip along every
/// written piece stays within the chord tolerance of the intended path (its distance from a
/// dense sampling of the ideal machine's tip along the programmed move); a tighter bound binds.
#[test]
fn a_move_through_b0_compensates_within_the_bound() {
    let program = "G90 G0 X400. Y300. Z300. B15. C30.\nG1 B-20. C75. F500\n";
    let (from, to) = (
        [400.0, 300.0, 300.0, 0.0, 15.0, 30.0],
        [400.0, 300.0, 300.0, 0.0, -20.0, 75.0],
    );
    for bound in [1.0, 0.3] {
        check_through(&hwang(), program, (from, to), [4, 5], bound);
    }
}

/// The same through A0 on a table-table (A/C trunnion) and a head-head (C head carrying an A
/// head) machine: there too the tool lies along C.
#[test]
fn moves_through_a0_compensate_on_table_table_and_head_head_machines() {
    let table_table =
        Machine::from_toml(crate::nc_orientation::TABLE_TABLE, "tt.toml", None).unwrap();
    let head_head = Machine::from_toml(crate::nc_orientation::HEAD_HEAD, "hh.toml", None).unwrap();
    for machine in [table_table, head_head] {
        let program = "G90 G0 X50. Y20. Z100. A-10. C10.\nG1 A12. C40. F500\n";
        let (from, to) = (
            [50.0, 20.0, 100.0, -10.0, 0.0, 10.0],
            [50.0, 20.0, 100.0, 12.0, 0.0, 40.0],
        );
        check_through(&machine, program, (from, to), [3, 5], 1.0);
    }
}

/// `program` (a rapid to `from`, then a feed move to `to` on line 2, through the singular pose)
/// compensated with `bound` (degrees) on the rotary axes `rotary`: see
/// `a_move_through_b0_compensates_within_the_bound`.
fn check_through(
    machine: &Machine,
    program: &str,
    (from, to): ([f64; 6], [f64; 6]),
    rotary: [usize; 2],
    bound: f64,
) {
    let ideal = machine.without_errors();
    let real = machine.at(&Inputs::default());
    let name = &machine.name;
    // The intended path: the ideal tip along the programmed move, every 1/40000 (a few hundred
    // mm at most: 0.01 mm apart, so the polyline is within 1e-7 mm of the curve).
    let n = 40_000;
    let intended: Vec<Vector3<f64>> = (0..=n)
        .map(|k| {
            let t = k as f64 / n as f64;
            let q: [f64; 6] = std::array::from_fn(|d| from[d] + (to[d] - from[d]) * t);
            pose(&ideal, &q).0
        })
        .collect();
    let distance = |p: &Vector3<f64>| {
        intended
            .windows(2)
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
                (p - (a + (b - a) * t)).norm()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let options = options(bound);
    let out = nc::compensate(machine, program.as_bytes(), "cross.nc", &options)
        .unwrap_or_else(|e| panic!("{name}, bound {bound}: {e}"));
    // Axes the program never names are at 0 (no work offset).
    let written: Vec<[f64; 6]> = positions(&out.text)
        .into_iter()
        .map(|p| p.map(|v| if v.is_nan() { 0.0 } else { v }))
        .collect();
    for (programmed, point) in [(from, written[0]), (to, *written.last().unwrap())] {
        let miss = (pose(&real, &point).0 - pose(&ideal, &programmed).0).norm();
        assert!(
            miss < 1e-6,
            "{name}, bound {bound}: tip {miss} at {point:?}"
        );
    }
    assert!(!written.is_empty(), "{name}");
    for point in &written {
        let turn = turn_about(point, &from, &to, rotary);
        assert!(
            turn <= bound + 1e-9,
            "{name}, bound {bound}: {turn}° at {point:?}"
        );
    }
    // Along every written piece, 20 samples (rounding at 12 decimals is negligible).
    let mut worst = 0.0f64;
    for w in written.windows(2) {
        for k in 1..20 {
            let s = k as f64 / 20.0;
            let c: [f64; 6] = std::array::from_fn(|d| w[0][d] + (w[1][d] - w[0][d]) * s);
            worst = worst.max(distance(&pose(&real, &c).0));
        }
    }
    // Chord tolerance plus the polyline's 1e-7 mm.
    assert!(
        worst <= options.chord_tolerance_mm + 1e-6,
        "{name}, bound {bound}: {worst}\n{}",
        out.text
    );
    let report = &out.report;
    assert_eq!(
        report
            .orientation_left
            .iter()
            .map(|l| l.line)
            .collect::<Vec<_>>(),
        [2],
        "{name}, bound {bound}"
    );
    assert!(report.largest_rotary_correction_deg <= bound + 1e-12);
}

/// Near, not at, the singular pose the full correction is within the bound and is made. The
/// issue's example: at B = 0.3° the axis error (tens of µrad) needs C to turn by e / sin(0.3°),
/// about 0.4°: the tool axis lands within 1e-9 rad (the solve's 1e-10 and 12 decimals) and C
/// turns by more than 0.1° (the hand figure's order) but no more than the bound. Far from it
/// (B30) the same holds with a C turn of a few thousandths of a degree.
#[test]
fn near_the_singular_pose_the_full_correction_is_made_within_the_bound() {
    let machine = hwang();
    let ideal = machine.without_errors();
    let real = machine.at(&Inputs::default());
    for (b, least_c_turn) in [(0.3, 0.1), (30.0, 0.0)] {
        let program = format!("G90 G0 X400. Y300. Z300. B{b} C45.\nG1 X420. F500\n");
        let out = nc::compensate(&machine, program.as_bytes(), "near.nc", &options(1.0)).unwrap();
        let end = *positions(&out.text).last().unwrap();
        let q = [420.0, 300.0, 300.0, 0.0, b, 45.0];
        let (tip, axis) = pose(&real, &end);
        let (ideal_tip, ideal_axis) = pose(&ideal, &q);
        assert!((tip - ideal_tip).norm() < 1e-9, "B{b}");
        assert!(
            angle(&axis, &ideal_axis) < 1e-9,
            "B{b}: {}",
            angle(&axis, &ideal_axis)
        );
        let c_turn = (end[5] - 45.0).abs();
        assert!(
            c_turn > least_c_turn && c_turn <= 1.0,
            "B{b}: C turns {c_turn}°"
        );
        assert!(out.report.orientation_left.is_empty(), "B{b}");
    }
}

#[test]
fn the_rotary_correction_bound_is_checked() {
    let machine = hwang();
    for bound in [0.0, -1.0, 20.0, f64::NAN] {
        let error = nc::compensate(
            &machine,
            b"G0 X400. Y300. Z300. B30. C45.\n",
            "p.nc",
            &options(bound),
        )
        .unwrap_err();
        assert!(
            matches!(
                error,
                nc::NcError::Option {
                    option: nc::NcOption::MaxRotaryCorrection,
                    ..
                }
            ),
            "{error}"
        );
    }
}
