//! What the fuzzing campaigns found in the measured results of the standard tests (docs/testing.md,
//! "Fuzzing"), each kept as the input that showed it (`tests/fuzz-regressions/`) or a hand-made
//! one like it, with the error volmap now gives.

use std::path::PathBuf;

use volmap::standards::{self, PositioningSpec, Setup};

use super::common::fuzz_regression as regression;

fn five_axis_setup() -> Setup {
    Setup::new(
        &volmap::io::embedded::embedded("5axis-hwang2014")
            .unwrap()
            .unwrap(),
        "",
    )
    .unwrap()
}

fn positioning_error(axis: &str, csv: &[u8]) -> (PathBuf, String, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("measured.csv");
    std::fs::write(&path, csv).unwrap();
    let spec = PositioningSpec {
        axis: axis.into(),
        targets: None,
        runs: 5,
        at_mm: None,
        pose: String::new(),
        csv: Some(path.clone()),
    };
    let error = standards::positioning(&five_axis_setup(), &spec)
        .unwrap_err()
        .to_string();
    (path, error, dir)
}

/// Measured runs of C with a target of 450° (C turns 0 to 360°): the error named the target
/// but not the file; it names the file and the line of the target's first row now.
#[test]
fn a_measured_target_beyond_the_travel_names_its_file_and_line() {
    let (path, error, _dir) =
        positioning_error("C", &regression("measured-rotary-target-beyond-travel.csv"));
    assert_eq!(
        error,
        format!(
            "{}: line 6: positioning of C, target 450°: C=450 lies outside the travel of C (0 to 360)",
            path.display()
        )
    );
    // A linear axis likewise: X to 5000 mm on its second row.
    let mut csv = String::from("target_mm,direction,run,deviation_um\n");
    for run in 1..=5 {
        csv += &format!("0,+,{run},1\n5000,+,{run},2\n5000,-,{run},2\n0,-,{run},1\n");
    }
    let (path, error, _dir) = positioning_error("X", csv.as_bytes());
    let prefix = format!(
        "{}: line 3: positioning of X, target 5000: X=5000 lies outside the travel of X",
        path.display()
    );
    assert!(error.starts_with(&prefix), "{error}");
}

/// Measured results of a circle at one angle: the error said the angles do not determine a
/// circle without saying whose angles; it names the file now.
#[test]
fn a_circle_of_measured_angles_that_determine_none_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.csv");
    std::fs::write(&path, regression("measured-one-angle.csv")).unwrap();
    let spec = volmap::standards::CircularSpec {
        plane: "XY".into(),
        centre_mm: None,
        radius_mm: None,
        points: 36,
        direction: "ccw".into(),
        start_deg: 0.0,
        pose: String::new(),
        csv: Some(path.clone()),
        pitch_mm: None,
    };
    let error = volmap::standards::circular(&five_axis_setup(), &spec)
        .unwrap_err()
        .to_string();
    assert_eq!(
        error,
        format!(
            "{}: the angles do not determine a circle (at least 3 distinct angles spread around it)",
            path.display()
        )
    );
}

/// An R-test measured at C = 30,000,000°: the sphere there lies outside the travel, said
/// without the file or line that asked for it; both are named now.
#[test]
fn an_r_test_angle_beyond_the_travel_names_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.csv");
    std::fs::write(&path, regression("measured-rtest-angle.csv")).unwrap();
    let spec = volmap::standards::RTestSpec {
        axis: "C".into(),
        sphere_mm: Some([300.0, 200.0, 250.0]),
        from_deg: Some(0.0),
        to_deg: Some(30.0),
        step_deg: 10.0,
        pose: String::new(),
        csv: Some(path.clone()),
    };
    let error = volmap::standards::rtest(&five_axis_setup(), &spec)
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "{}: line 5: R-test of C at C=30000000°: Y=",
            path.display()
        )) && error.contains("lies outside the travel of Y (0 to 600)"),
        "{error}"
    );
}
