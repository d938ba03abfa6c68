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

pub(super) fn circular_spec(plane: &str, radius: f64) -> CircularSpec {
    CircularSpec {
        plane: plane.into(),
        centre_mm: None,
        radius_mm: Some(radius),
        points: 72,
        direction: "ccw".into(),
        start_deg: 0.0,
        pose: String::new(),
        csv: None,
        pitch_mm: None,
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
    assert_eq!(residuals.len(), result.positions.len());
    assert!(!residuals.is_empty());
    for (t, e) in result.positions.iter().zip(&residuals) {
        let expected = -(s * r / 2.0) * (2.0 * t.to_radians()).sin();
        assert!(
            (e - expected).abs() < 1e-7,
            "θ = {t}: {e} against {expected}"
        );
    }
    let g = result.figures.iter().find(|f| f.name == "G").unwrap();
    assert!((g.predicted - s * r).abs() < 1e-7, "G = {}", g.predicted);
    // Clockwise from 90°, the same circle in the other order: the model has no reversal error.
    let cw = CircularSpec {
        direction: "cw".into(),
        start_deg: 90.0,
        ..circular_spec("XY", r)
    };
    let clockwise = standards::circular(&setup, &cw).unwrap();
    assert_eq!(clockwise.positions[..3], [90.0, 85.0, 80.0]);
    assert_eq!(clockwise.predicted[0].len(), clockwise.positions.len());
    for (t, dr) in clockwise.positions.iter().zip(&clockwise.predicted[0]) {
        let k = result
            .positions
            .iter()
            .position(|a| (a - t.rem_euclid(360.0)).abs() < 1e-9)
            .unwrap();
        assert!((dr - result.predicted[0][k]).abs() < 1e-12);
    }
    assert!((clockwise.figures[0].predicted - g.predicted).abs() < 1e-12);
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
            other.figures[0].predicted < 1e-9,
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
        assert_eq!(
            (result.positions.len(), result.predicted[0].len()),
            (11, 11)
        );
        for (s, e) in result.positions.iter().zip(&result.predicted[0]) {
            let expected = k * s * direction.x * direction.x;
            assert!(
                (e - expected).abs() < 1e-12,
                "{name} at {s}: {e} against {expected}"
            );
        }
        let length = (to - from).norm();
        let d = result.figures.iter().find(|f| f.name == "D").unwrap();
        assert!((d.predicted - k * length * direction.x.powi(2)).abs() < 1e-12);
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
    assert_eq!(result.predicted[0].len(), 6);
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
            .predicted
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

pub(super) fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
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
    assert_eq!(f.named().len(), expected.len());
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
    assert_eq!(m.predicted, 0.0);
    assert!((m.measured.unwrap() - 0.0045).abs() < 1e-12);
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

pub(super) fn expect_csv_error<E: CsvCause + std::fmt::Debug>(
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
pub(super) trait CsvCause {
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
