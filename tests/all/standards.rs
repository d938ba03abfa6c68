//! Standard tests from the model against hand-computed values, ISO 230-2 figures on a worked
//! example, and bad measured data.

use std::path::PathBuf;

use volmap::io::csv::CsvError;
use volmap::model::{AxisLetter, ErrorFunction, Machine};
use volmap::standards::{
    self, CircularSpec, DiagonalSpec, PositioningSpec, RTestSpec, Setup, StandardsError,
};
use AxisLetter::*;

/// An error-free 3-axis machine (X-Y table, Z head) with travels straddling zero.
pub fn three_axis() -> Machine {
    Machine::nominal(
        "three-axis",
        "FYXFZ",
        &[
            (X, [-400.0, 400.0]),
            (Y, [-300.0, 300.0]),
            (Z, [-250.0, 250.0]),
        ],
    )
    .unwrap()
}

fn circular_spec(plane: &str, radius: f64) -> CircularSpec {
    CircularSpec {
        plane: plane.into(),
        centre_mm: None,
        radius_mm: Some(radius),
        points: 72,
        direction: "ccw".into(),
        start_deg: 0.0,
        pose: String::new(),
        csv: None,
    }
}

#[test]
fn a_squareness_alone_draws_the_known_ellipse() {
    // EC0Y = S: the angle between +X and +Y is 90° + S, so the 45° diameter shortens and the
    // 135° one lengthens: dr(θ) = −(S·r/2)·sin 2θ about the least-squares centre, G = |S|·r,
    // to first order (the second-order terms are below S²·r = 6e-8 mm here).
    let s = 2.0e-5;
    let r = 150.0;
    let mut machine = three_axis();
    machine.axis_mut(Y).unwrap().location[5] = s;
    let setup = Setup::new(&machine, "").unwrap();
    let result = standards::circular(&setup, &circular_spec("XY", r)).unwrap();
    let (_, residuals) =
        standards::least_squares_circle(&result.positions, &result.predicted[0]).unwrap();
    for (t, e) in result.positions.iter().zip(&residuals) {
        let expected = -(s * r / 2.0) * (2.0 * t.to_radians()).sin();
        assert!(
            (e - expected).abs() < 1e-7,
            "θ = {t}: {e} against {expected}"
        );
    }
    let g = result.figures.iter().find(|f| f.name == "G").unwrap();
    assert!(
        (g.predicted_mm - s * r).abs() < 1e-7,
        "G = {}",
        g.predicted_mm
    );
    // Clockwise from 90°, the same circle in the other order: the model has no reversal error.
    let cw = CircularSpec {
        direction: "cw".into(),
        start_deg: 90.0,
        ..circular_spec("XY", r)
    };
    let clockwise = standards::circular(&setup, &cw).unwrap();
    assert_eq!(clockwise.positions[..3], [90.0, 85.0, 80.0]);
    for (t, dr) in clockwise.positions.iter().zip(&clockwise.predicted[0]) {
        let k = result
            .positions
            .iter()
            .position(|a| (a - t.rem_euclid(360.0)).abs() < 1e-9)
            .unwrap();
        assert!((dr - result.predicted[0][k]).abs() < 1e-12);
    }
    assert!((clockwise.figures[0].predicted_mm - g.predicted_mm).abs() < 1e-12);
    // A clockwise measurement comes with falling angles.
    let dir = tempfile::tempdir().unwrap();
    let rising = CircularSpec {
        csv: Some(write(
            &dir,
            "cw.csv",
            "angle_deg,deviation_um\n0,1\n10,2\n20,3\n",
        )),
        ..cw
    };
    expect_csv_error(standards::circular(&setup, &rising), 3, "falling");
    // The other planes see nothing of an XY squareness but a shift of the centre.
    for plane in ["YZ", "ZX"] {
        let other = standards::circular(&setup, &circular_spec(plane, r)).unwrap();
        assert!(
            other.figures[0].predicted_mm < 1e-9,
            "{plane}: {:?}",
            other.figures[0]
        );
    }
}

#[test]
fn a_scale_error_shows_in_the_diagonal_as_a_straight_line() {
    let k = 3.0e-5;
    let mut machine = three_axis();
    machine.axis_mut(X).unwrap().components[0] = Some(ErrorFunction::Poly(vec![0.0, k]));
    let setup = Setup::new(&machine, "").unwrap();
    for name in ["PPP", "NPP", "PNP", "PPN", "XY-PP", "XY-NP", "ZX-PP"] {
        let spec = DiagonalSpec {
            diagonal: Some(name.into()),
            from_mm: None,
            to_mm: None,
            points: 11,
            pose: String::new(),
            csv: None,
        };
        let result = standards::diagonal(&setup, &spec).unwrap();
        let (lo, hi) = setup.travel_box().unwrap();
        let (from, to) = standards::diagonal_ends(name, lo, hi).unwrap();
        let direction = (to - from).normalize();
        // e(s) = k·X(s)·d_x − k·X(0)·d_x with X(s) = from_x + s·d_x: a straight line in s.
        for (s, e) in result.positions.iter().zip(&result.predicted[0]) {
            let expected = k * s * direction.x * direction.x;
            assert!(
                (e - expected).abs() < 1e-12,
                "{name} at {s}: {e} against {expected}"
            );
        }
        let length = (to - from).norm();
        let d = result.figures.iter().find(|f| f.name == "D").unwrap();
        assert!((d.predicted_mm - k * length * direction.x.powi(2)).abs() < 1e-12);
    }
}

#[test]
fn positioning_reads_the_axis_own_scale_error() {
    let k = -2.0e-5;
    let mut machine = three_axis();
    machine.axis_mut(Z).unwrap().components[2] = Some(ErrorFunction::Poly(vec![0.001, k]));
    let setup = Setup::new(&machine, "").unwrap();
    let spec = PositioningSpec {
        axis: "Z".into(),
        targets: Some(6),
        runs: 5,
        at_mm: None,
        pose: String::new(),
        csv: None,
    };
    let result = standards::positioning(&setup, &spec).unwrap();
    assert_eq!(result.positions.len(), 6);
    for (t, x) in result.positions.iter().zip(&result.predicted[0]) {
        // Zeroed at the first target, the bottom of the travel.
        assert!((x - k * (t + 250.0)).abs() < 1e-12, "{t}: {x}");
    }
    let value = |name: &str| {
        result
            .figures
            .iter()
            .find(|f| f.name == name)
            .unwrap()
            .predicted_mm
    };
    let span = 500.0 * k.abs();
    for name in ["A", "E", "M", "E↑", "A↓"] {
        assert!(
            (value(name) - span).abs() < 1e-12,
            "{name} = {}",
            value(name)
        );
    }
    for name in ["B", "R", "R↑"] {
        assert_eq!(value(name), 0.0, "{name}");
    }
}

/// The worked example: three targets, two runs each way, deviations in µm.
const WORKED_EXAMPLE: &str = "\
target_mm,direction,run,deviation_um
0,+,1,1
100,+,1,4
200,+,1,-1
200,-,1,-2
100,-,1,2
0,-,1,0
0,+,2,3
100,+,2,4
200,+,2,1
200,-,2,-2
100,-,2,4
0,-,2,0
";

fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn iso230_2_figures_of_a_worked_example() {
    // Means ↑ 2, 4, 0 and ↓ 0, 3, −2 µm; s ↑ √2, 0, √2 and ↓ 0, √2, 0 µm. By hand:
    // B = 2, B̄ = 5/3, R↑ = R↓ = R = 4√2, E↑ = 4, E↓ = 5, E = 6, M = 4.5,
    // A↑ = 2 + 4√2, A↓ = 5 + 2√2, A = 3 + 4√2 (µm).
    let dir = tempfile::tempdir().unwrap();
    let data = standards::read_positioning(&write(&dir, "x.csv", WORKED_EXAMPLE)).unwrap();
    assert_eq!(data.targets_mm, vec![0.0, 100.0, 200.0]);
    let f = data.figures();
    let r2 = 2f64.sqrt();
    let expected = [
        ("A", 3.0 + 4.0 * r2),
        ("A↑", 2.0 + 4.0 * r2),
        ("A↓", 5.0 + 2.0 * r2),
        ("B", 2.0),
        ("B̄", 5.0 / 3.0),
        ("E", 6.0),
        ("E↑", 4.0),
        ("E↓", 5.0),
        ("M", 4.5),
        ("R", 4.0 * r2),
        ("R↑", 4.0 * r2),
        ("R↓", 4.0 * r2),
    ];
    for ((name, value), (expected_name, expected_um)) in f.named().into_iter().zip(expected) {
        assert_eq!(name, expected_name);
        assert!(
            (value * 1000.0 - expected_um).abs() < 1e-9,
            "{name}: {} µm",
            value * 1000.0
        );
    }
    // The same file against a model: predicted and measured side by side, row for row.
    let machine = three_axis();
    let setup = Setup::new(&machine, "").unwrap();
    let spec = PositioningSpec {
        axis: "X".into(),
        targets: None,
        runs: 5,
        at_mm: None,
        pose: String::new(),
        csv: Some(dir.path().join("x.csv")),
    };
    let result = standards::positioning(&setup, &spec).unwrap();
    assert_eq!(result.positions, vec![0.0, 100.0, 200.0]);
    let measured = result.measured.as_ref().unwrap();
    assert!((measured[0][0] - 0.002).abs() < 1e-15 && (measured[1][1] - 0.003).abs() < 1e-15);
    assert!((standards::largest_difference(&result).unwrap() - 0.004).abs() < 1e-15);
    let m = result.figures.iter().find(|f| f.name == "M").unwrap();
    assert_eq!(m.predicted_mm, 0.0);
    assert!((m.measured_mm.unwrap() - 0.0045).abs() < 1e-12);
}

#[test]
fn r_test_of_an_offset_axis_line() {
    // EX0C = δ: with the tool branch linear, the probes read −Rot_C(q)ᵀ·(δ, 0, 0), zeroed at
    // q = 0: dX = δ(1 − cos q), dY = δ sin q, dZ = 0.
    let delta = 0.004;
    let mut machine = Machine::nominal(
        "table C",
        "FYXCFZ",
        &[
            (X, [-400.0, 400.0]),
            (Y, [-300.0, 300.0]),
            (Z, [-250.0, 250.0]),
            (C, [0.0, 360.0]),
        ],
    )
    .unwrap();
    machine.axis_mut(C).unwrap().location[0] = delta;
    let setup = Setup::new(&machine, "").unwrap();
    let spec = RTestSpec {
        axis: "C".into(),
        sphere_mm: Some([150.0, 0.0, 80.0]),
        from_deg: None,
        to_deg: None,
        step_deg: 30.0,
        pose: String::new(),
        csv: None,
    };
    let result = standards::rtest(&setup, &spec).unwrap();
    assert_eq!(result.positions.len(), 13);
    for (n, q) in result.positions.iter().enumerate() {
        let (s, c) = q.to_radians().sin_cos();
        let reading = [
            result.predicted[0][n],
            result.predicted[1][n],
            result.predicted[2][n],
        ];
        let expected = [delta * (1.0 - c), delta * s, 0.0];
        for d in 0..3 {
            assert!(
                (reading[d] - expected[d]).abs() < 1e-12,
                "q = {q}: {reading:?} against {expected:?}"
            );
        }
    }
    // A sphere whose path leaves the travel is an error naming the axis and the angle.
    let far = RTestSpec {
        sphere_mm: Some([350.0, 0.0, 80.0]),
        ..spec
    };
    let error = standards::rtest(&setup, &far).unwrap_err().to_string();
    assert!(
        error.contains("R-test of C at C=") && error.contains("travel of Y"),
        "{error}"
    );
}

fn expect_csv_error<E: CsvCause + std::fmt::Debug>(
    result: Result<impl std::fmt::Debug, E>,
    line: usize,
    words: &str,
) {
    match result.as_ref().map_err(|e| e.csv()) {
        Err(Some(CsvError {
            line: l, message, ..
        })) => {
            assert_eq!(*l, line, "{message}");
            assert!(message.contains(words), "{message}");
        }
        _ => panic!("expected a CSV error at line {line}, got {result:?}"),
    }
}

/// The CSV error behind a standards or calibration error.
trait CsvCause {
    fn csv(&self) -> Option<&CsvError>;
}

impl CsvCause for StandardsError {
    fn csv(&self) -> Option<&CsvError> {
        match self {
            StandardsError::Csv(e) => Some(e),
            _ => None,
        }
    }
}

impl CsvCause for volmap::calibrate::CalibrateError {
    fn csv(&self) -> Option<&CsvError> {
        match self {
            volmap::calibrate::CalibrateError::Csv(e) => Some(e),
            _ => None,
        }
    }
}

#[test]
fn bad_measured_data_names_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let machine = three_axis();
    let setup = Setup::new(&machine, "").unwrap();
    let circle = |text: &str| {
        let spec = CircularSpec {
            csv: Some(write(&dir, "circle.csv", text)),
            ..circular_spec("XY", 100.0)
        };
        standards::circular(&setup, &spec)
    };
    expect_csv_error(
        circle("angle_deg,deviation_mm\n0,0.001\n90,0.002\n45,0.0\n"),
        4,
        "sorted",
    );
    expect_csv_error(
        circle("angle_deg\n0\n90\n"),
        1,
        "missing column `deviation`",
    );
    expect_csv_error(
        circle("angle_deg,deviation_mm,extra\n0,0,0\n"),
        1,
        "unknown column `extra`",
    );
    expect_csv_error(
        circle("angle_deg,deviation_mm\n0,0.001\n90,abc\n"),
        3,
        "not a number",
    );
    expect_csv_error(
        circle("angle_deg,deviation_mm\n0,0.001\n90\n"),
        3,
        "1 fields",
    );
    expect_csv_error(circle(""), 1, "empty file");
    // Positioning: a run out of its order of approach, a run over other targets.
    let runs = |text: &str| standards::read_positioning(&write(&dir, "x.csv", text));
    expect_csv_error(
        runs("target_mm,direction,run,deviation_mm\n0,+,1,0\n100,+,1,0\n50,+,1,0\n"),
        4,
        "order of approach",
    );
    expect_csv_error(
        runs("target_mm,direction,run,deviation_mm\n0,+,1,0\n100,+,1,0\n100,-,1,0\n"),
        2,
        "same targets",
    );
    expect_csv_error(
        runs("target_mm,direction,run,deviation_mm\n0,+,1,0\n0,x,1,0\n"),
        3,
        "direction `x`",
    );
    // A diagonal beyond the travel, a position off the diagonal.
    let spec = DiagonalSpec {
        diagonal: None,
        from_mm: Some([0.0, 0.0, 0.0]),
        to_mm: Some([500.0, 0.0, 0.0]),
        points: 5,
        pose: String::new(),
        csv: None,
    };
    let error = standards::diagonal(&setup, &spec).unwrap_err().to_string();
    assert!(
        error.contains("its end") && error.contains("X=500") && error.contains("-400 to 400"),
        "{error}"
    );
    let on_line = DiagonalSpec {
        to_mm: Some([300.0, 0.0, 0.0]),
        csv: Some(write(
            &dir,
            "d.csv",
            "position_mm,deviation_um\n0,1\n400,2\n",
        )),
        ..spec
    };
    expect_csv_error(standards::diagonal(&setup, &on_line), 3, "off the diagonal");
    assert!(standards::diagonal_ends(
        "PPX",
        -setup.travel_box().unwrap().1,
        setup.travel_box().unwrap().1
    )
    .is_err());
}

/// Writes a test's predicted curves, with noise, as the measured CSV of its kind.
fn write_measured(
    path: &std::path::Path,
    header: &str,
    result: &standards::TestResult,
    noise_mm: f64,
    rng: &mut super::common::Rng,
) {
    let mut text = format!("{header}\n");
    for (n, position) in result.positions.iter().enumerate() {
        text += &format!("{position}");
        for curve in &result.predicted {
            // Uniform noise with standard deviation `noise_mm`.
            let e = noise_mm * 3f64.sqrt() * rng.uniform(-1.0, 1.0);
            text += &format!(",{}", (curve[n] + e) * 1000.0);
        }
        text += "\n";
    }
    std::fs::write(path, text).unwrap();
}

const THREE_AXIS_TOML: &str = r#"
name = "three-axis"
chain = "FYXFZ"
[axes.X]
range = [-400.0, 400.0]
EXX = { poly = [0.0, 1.0e-5] }
[axes.Y]
range = [-300.0, 300.0]
[axes.Z]
range = [-250.0, 250.0]
"#;

#[test]
fn fit_recovers_squareness_errors_from_noisy_circles_and_diagonals() {
    let dir = tempfile::tempdir().unwrap();
    let given = Machine::from_toml(THREE_AXIS_TOML, "three-axis.toml", None).unwrap();
    let truth = [
        ("EC0Y", Y, 5, 2.0e-5),
        ("EB0Z", Z, 4, -1.5e-5),
        ("EA0Z", Z, 3, 1.0e-5),
    ];
    let mut machine = given.clone();
    for &(_, axis, index, value) in &truth {
        machine.axis_mut(axis).unwrap().location[index] = value;
    }
    let setup = Setup::new(&machine, "").unwrap();
    let mut rng = super::common::Rng(42);
    let noise = 0.3e-3;
    let mut fit_toml = String::from("estimate = [\"EC0Y\", \"EB0Z\", \"EA0Z\"]\n");
    for plane in ["XY", "YZ", "ZX"] {
        let result = standards::circular(&setup, &circular_spec(plane, 150.0)).unwrap();
        let name = format!("{plane}.csv");
        write_measured(
            &dir.path().join(&name),
            "angle_deg,deviation_um",
            &result,
            noise,
            &mut rng,
        );
        fit_toml += &format!(
            "[[circular]]\nplane = \"{plane}\"\nradius_mm = 150.0\npoints = 72\ncsv = \"{name}\"\n"
        );
    }
    for diagonal in ["PPP", "NPP", "PNP", "PPN"] {
        let spec = DiagonalSpec {
            diagonal: Some(diagonal.into()),
            from_mm: None,
            to_mm: None,
            points: 21,
            pose: String::new(),
            csv: None,
        };
        let result = standards::diagonal(&setup, &spec).unwrap();
        let name = format!("{diagonal}.csv");
        write_measured(
            &dir.path().join(&name),
            "position_mm,deviation_um",
            &result,
            noise,
            &mut rng,
        );
        fit_toml += &format!("[[diagonal]]\ndiagonal = \"{diagonal}\"\ncsv = \"{name}\"\n");
    }
    let fit_path = write(&dir, "fit.toml", &fit_toml);
    let file = volmap::calibrate::fit::FitFile::read(&fit_path).unwrap();
    let report = volmap::calibrate::fit::fit(&given, &file).unwrap();
    assert_eq!(report.points, 3 * 72 + 4 * 21);
    for (estimate, &(name, _, _, value)) in report.estimates.iter().zip(&truth) {
        assert_eq!(estimate.name, name);
        assert_eq!(estimate.initial, 0.0);
        // Noise of 0.3 µm over arms of 150 mm and more: well below 1 µrad.
        assert!(
            estimate.uncertainty > 0.0 && estimate.uncertainty < 1e-6,
            "{estimate:?}"
        );
        assert!(
            (estimate.value - value).abs() < 4.0 * estimate.uncertainty,
            "{estimate:?} against {value}"
        );
    }
    // The residual is the noise, no more (uniform noise of σ 0.3 µm).
    assert!(report.rms_after_mm < 0.4e-3, "{}", report.rms_after_mm);
    assert!(report.rms_before_mm > 3.0 * report.rms_after_mm);
    // The machine file with the estimates reads back with them.
    let text = volmap::calibrate::fit::fitted_machine_toml(&given, &report.estimates).unwrap();
    let fitted = Machine::from_toml(&text, "fitted.toml", None).unwrap();
    for (estimate, &(_, axis, index, _)) in report.estimates.iter().zip(&truth) {
        assert_eq!(fitted.axis(axis).unwrap().location[index], estimate.value);
    }
    assert_eq!(
        fitted.axis(X).unwrap().components,
        given.axis(X).unwrap().components
    );
}

#[test]
fn fit_recovers_a_rotary_axis_line_from_r_tests() {
    let dir = tempfile::tempdir().unwrap();
    let given = Machine::nominal(
        "table C",
        "FYXCFZ",
        &[
            (X, [-400.0, 400.0]),
            (Y, [-300.0, 300.0]),
            (Z, [-250.0, 250.0]),
            (C, [0.0, 360.0]),
        ],
    )
    .unwrap();
    let truth = [
        ("EX0C", 0, 0.006),
        ("EY0C", 1, -0.004),
        ("EA0C", 3, 3e-5),
        ("EB0C", 4, -2e-5),
    ];
    let mut machine = given.clone();
    for &(_, index, value) in &truth {
        machine.axis_mut(C).unwrap().location[index] = value;
    }
    let setup = Setup::new(&machine, "").unwrap();
    let mut rng = super::common::Rng(7);
    let mut fit_toml = String::from("estimate = [\"EX0C\", \"EY0C\", \"EA0C\", \"EB0C\"]\n");
    // Two spheres at different heights separate the tilt of the line from its position.
    for (n, sphere) in [[150.0, 0.0, 20.0], [150.0, 0.0, 220.0]].iter().enumerate() {
        let spec = RTestSpec {
            axis: "C".into(),
            sphere_mm: Some(*sphere),
            from_deg: None,
            to_deg: None,
            step_deg: 15.0,
            pose: String::new(),
            csv: None,
        };
        let result = standards::rtest(&setup, &spec).unwrap();
        let name = format!("r{n}.csv");
        write_measured(
            &dir.path().join(&name),
            "angle_deg,dX_um,dY_um,dZ_um",
            &result,
            0.2e-3,
            &mut rng,
        );
        fit_toml += &format!(
            "[[rtest]]\naxis = \"C\"\nsphere_mm = [{}, {}, {}]\nstep_deg = 15.0\ncsv = \"{name}\"\n",
            sphere[0], sphere[1], sphere[2]
        );
    }
    let file = volmap::calibrate::fit::FitFile::read(&write(&dir, "fit.toml", &fit_toml)).unwrap();
    let report = volmap::calibrate::fit::fit(&given, &file).unwrap();
    for (estimate, &(name, _, value)) in report.estimates.iter().zip(&truth) {
        assert_eq!(estimate.name, name);
        assert!(
            (estimate.value - value).abs() < 4.0 * estimate.uncertainty,
            "{estimate:?} against {value}"
        );
        assert!(estimate.uncertainty < 0.05 * value.abs(), "{estimate:?}");
    }
}

#[test]
fn fit_says_what_the_measurements_cannot_see() {
    let dir = tempfile::tempdir().unwrap();
    let machine = three_axis();
    let setup = Setup::new(&machine, "").unwrap();
    let result = standards::circular(&setup, &circular_spec("XY", 100.0)).unwrap();
    write_measured(
        &dir.path().join("xy.csv"),
        "angle_deg,deviation_um",
        &result,
        0.0,
        &mut super::common::Rng(1),
    );
    let file = |estimate: &str| {
        let text = format!(
            "estimate = [{estimate}]\n[[circular]]\nplane = \"XY\"\nradius_mm = 100.0\npoints = 72\ncsv = \"xy.csv\"\n"
        );
        volmap::calibrate::fit::FitFile::read(&write(&dir, "fit.toml", &text)).unwrap()
    };
    let error = volmap::calibrate::fit::fit(&machine, &file("\"EA0Z\""))
        .unwrap_err()
        .to_string();
    assert!(error.contains("EA0Z does not change"), "{error}");
    let error = volmap::calibrate::fit::fit(&machine, &file("\"EQ0Z\""))
        .unwrap_err()
        .to_string();
    assert!(error.contains("not a location error"), "{error}");
    let error = volmap::calibrate::fit::fit(&machine, &file("\"EC0B\""))
        .unwrap_err()
        .to_string();
    assert!(error.contains("no B axis"), "{error}");
    let unknown = write(&dir, "bad.toml", "estimate = []\nwobble = 1\n");
    let error = volmap::calibrate::fit::FitFile::read(&unknown)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("bad.toml") && error.contains("wobble"),
        "{error}"
    );
}

#[test]
fn build_chooses_elements_per_component_and_writes_a_machine() {
    use volmap::calibrate::build;
    use volmap::model::Interp;
    let dir = tempfile::tempdir().unwrap();
    let base_path = write(&dir, "base.toml", THREE_AXIS_TOML);
    let base = Machine::from_path(&base_path).unwrap();
    // X: EXX linear in X (every element predicts it: the simplest wins), EBX a parabola
    // (quadratic elements are exact, 5 nodes). Z: EZZ a sine over 9 nodes (the spline wins).
    let mut x_csv = String::from("position_mm,EXX_um,EBX_urad\n");
    for i in 0..5 {
        let q = -400.0 + 200.0 * i as f64;
        x_csv += &format!("{q},{},{}\n", 2.0 + 0.01 * q, 3.0 + 1e-4 * q * q);
    }
    let mut z_csv = String::from("position_mm,EZZ_mm\n");
    for i in 0..9 {
        let q = -250.0 + 62.5 * i as f64;
        z_csv += &format!("{q},{}\n", 0.004 * (q / 80.0).sin());
    }
    let x_path = write(&dir, "x.csv", &x_csv);
    let z_path = write(&dir, "z.csv", &z_csv);
    let (text, built) = build::build(&base, &[(X, &x_path), (Z, &z_path)], &[]).unwrap();
    let chosen: Vec<(&str, &str)> = built
        .iter()
        .map(|c| (c.name.as_str(), c.interp.as_str()))
        .collect();
    assert_eq!(
        chosen,
        [("EXX", "linear"), ("EBX", "quadratic"), ("EZZ", "cubic")],
        "{built:?}"
    );
    let machine = Machine::from_toml(&text, "built.toml", None).unwrap();
    let x = machine.axis(X).unwrap();
    for q in [-400.0, -130.0, 0.0, 77.0, 400.0] {
        let [exx, _, _, _, ebx, _] = x.component_values(q);
        assert!((exx - (2.0 + 0.01 * q) * 1e-3).abs() < 1e-15, "EXX at {q}");
        assert!(
            (ebx - (3.0 + 1e-4 * q * q) * 1e-6).abs() < 1e-15,
            "EBX at {q}"
        );
    }
    let z = machine.axis(Z).unwrap();
    for i in 0..9 {
        let q = -250.0 + 62.5 * i as f64;
        assert!((z.component_values(q)[2] - 0.004 * (q / 80.0).sin()).abs() < 1e-15);
    }
    // Between nodes the spline follows the sine far closer than straight lines would.
    let worst = (0..200)
        .map(|i| -250.0 + 2.5 * i as f64)
        .map(|q| (z.component_values(q)[2] - 0.004 * (q / 80.0).sin()).abs())
        .fold(0.0, f64::max);
    assert!(worst < 2e-5, "{worst}");
    // The base's chain, travels and unmeasured axes stay.
    assert_eq!(machine.chain, base.chain);
    assert_eq!(machine.axis(Y), base.axis(Y));
    // Asked for, an element is used as it is; an even node count cannot be quadratic.
    let (_, asked) =
        build::build(&base, &[(Z, &z_path)], &[("EZZ".into(), Interp::Linear)]).unwrap();
    assert_eq!(
        (asked[0].interp.as_str(), asked[0].reason.as_str()),
        ("linear", "asked for")
    );
    let even = write(
        &dir,
        "even.csv",
        "position_mm,EZZ_um\n0,1\n10,2\n20,1\n30,0\n",
    );
    let error = build::build(&base, &[(Z, &even)], &[("EZZ".into(), Interp::Quadratic)])
        .unwrap_err()
        .to_string();
    assert!(error.contains("odd number of nodes"), "{error}");
}

#[test]
fn build_rejects_bad_measurement_files() {
    use volmap::calibrate::build;
    let dir = tempfile::tempdir().unwrap();
    let check = |text: &str, line: usize, words: &str| {
        let path = write(&dir, "x.csv", text);
        expect_csv_error(build::read_axis_csv(&path, X), line, words);
    };
    check(
        "position_mm,EXX_um\n0,1\n200,2\n100,3\n",
        4,
        "sorted by position",
    );
    check("position_mm,EXX_nm\n0,1\n", 1, "unit `nm`");
    check("position_mm,EYZ_um\n0,1\n", 1, "component error of X");
    check("position_deg,EXX_um\n0,1\n", 1, "position_mm");
    check("position_mm,EXX_um\n0,1\n100,x\n", 3, "not a number");
    check("position_mm,EXX_um\n0,1\n", 1, "at least 2");
    let missing = dir.path().join("missing.csv");
    let error = build::read_axis_csv(&missing, X).unwrap_err().to_string();
    assert!(error.contains("missing.csv"), "{error}");
}
