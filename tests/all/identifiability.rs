//! What a fit's measurements can see: sensitivity, independence, correlations, condition number
//! and valuation of each estimate, derived by hand for a circle; unknowns the tests cannot tell
//! from zero refused with the measurement that would see them.

use volmap::calibrate::fit::{fit, FitFile};
use volmap::model::Machine;
use volmap::standards::{self, Setup};

use super::standards::{circular_spec, three_axis, write};

/// Writes a circle of `machine` as measured (µm), and returns its fit-file table.
fn measured_circle(dir: &tempfile::TempDir, machine: &Machine, plane: &str, name: &str) -> String {
    let setup = Setup::new(machine, "").unwrap();
    let spec = standards::CircularSpec {
        points: 72,
        ..circular_spec(plane, 100.0)
    };
    let result = standards::circular(&setup, &spec).unwrap();
    let mut text = String::from("angle_deg,deviation_um\n");
    assert_eq!(
        (result.positions.len(), result.predicted[0].len()),
        (72, 72)
    );
    for (a, r) in result.positions.iter().zip(&result.predicted[0]) {
        text += &format!("{a},{}\n", r * 1000.0);
    }
    std::fs::write(dir.path().join(name), text).unwrap();
    format!("[[circular]]\nplane = \"{plane}\"\nradius_mm = 100.0\npoints = 72\ncsv = \"{name}\"\n")
}

fn with_squareness(ec0y: f64, eb0z: f64) -> Machine {
    let text = format!(
        "name = \"sq\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [-400.0, 400.0]\n[axes.Y]\nrange = [-300.0, 300.0]\nEC0Y = {ec0y:e}\n[axes.Z]\nrange = [-250.0, 250.0]\nEB0Z = {eb0z:e}\n"
    );
    Machine::from_toml(&text, "sq.toml", None).unwrap()
}

#[test]
fn a_squareness_from_one_circle_has_the_hand_derived_figures() {
    // X' = X + α·Y on a circle of radius r: dr = (α r / 2) sin 2θ, orthogonal to the ballbar's
    // length and centring; over 72 even angles its RMS per unit α is r / (2√2).
    let dir = tempfile::tempdir().unwrap();
    let alpha = 3.0e-5;
    let table = measured_circle(&dir, &with_squareness(alpha, 0.0), "XY", "xy.csv");
    let path = write(&dir, "fit.toml", &format!("estimate = [\"EC0Y\"]\n{table}"));
    let report = fit(&three_axis(), &FitFile::read(&path).unwrap()).unwrap();
    // The estimate is the squareness, sign and all: the base machine has none, so the fit
    // recovers the EC0Y the circle was measured with.
    assert_eq!(report.estimates.len(), 1);
    assert_eq!(report.estimates[0].name, "EC0Y");
    assert!(
        (report.estimates[0].value - alpha).abs() < 1e-9,
        "{:?}",
        report.estimates
    );
    let figures = &report.identifiability;
    let r = 100.0;
    let sensitivity = r / (2.0 * 2f64.sqrt());
    // To first order in α: the terms left out are α = 3e-5 of it (measured: 1.7e-10).
    assert!(
        (figures.sensitivity[0] - sensitivity).abs() < 1e-4 * sensitivity,
        "{figures:?}"
    );
    assert!((figures.independence[0] - 1.0).abs() < 1e-12);
    assert!((figures.condition_number - 1.0).abs() < 1e-12);
    assert_eq!(figures.correlation, vec![vec![1.0]]);
    // 10 µrad in standard uncertainties at 1 µm scatter: Δ · s · √n / 1 µm.
    let valuation = 1e-5 * sensitivity * 72f64.sqrt() / 1e-3;
    assert!(
        (figures.valuation[0] - valuation).abs() < 1e-4 * valuation,
        "{figures:?} against {valuation}"
    );
}

#[test]
fn two_squarenesses_from_two_planes_are_independent() {
    let dir = tempfile::tempdir().unwrap();
    let truth = with_squareness(2.0e-5, -1.5e-5);
    let tables = measured_circle(&dir, &truth, "XY", "xy.csv")
        + &measured_circle(&dir, &truth, "ZX", "zx.csv");
    let path = write(
        &dir,
        "fit.toml",
        &format!("estimate = [\"EC0Y\", \"EB0Z\"]\n{tables}"),
    );
    let report = fit(&three_axis(), &FitFile::read(&path).unwrap()).unwrap();
    let c = &report.identifiability.correlation;
    assert_eq!(c.len(), 2);
    assert!((c[0][0] - 1.0).abs() < 1e-12 && (c[1][1] - 1.0).abs() < 1e-12);
    assert_eq!(c[0][1], c[1][0]);
    // Each circle sees one of them only.
    assert!(c[0][1].abs() < 1e-3, "{c:?}");
    assert!(report.identifiability.condition_number < 1.01);
    assert_eq!(report.estimates.len(), 2);
    // Signed as measured: EC0Y = 2e-5, EB0Z = −1.5e-5.
    for (e, (name, v)) in report
        .estimates
        .iter()
        .zip([("EC0Y", 2.0e-5), ("EB0Z", -1.5e-5)])
    {
        assert_eq!(e.name, name);
        assert!((e.value - v).abs() < 1e-9, "{e:?}");
    }
}

#[test]
fn offsets_of_a_linear_axis_are_refused_with_what_would_see_them() {
    // EX0Z and EY0Z move the tool tip of a three-axis machine by a constant: the ballbar's
    // centring and every laser's zero take it out.
    let dir = tempfile::tempdir().unwrap();
    let truth = with_squareness(2.0e-5, -1.5e-5);
    let mut tables = String::new();
    for (plane, name) in [("XY", "xy.csv"), ("YZ", "yz.csv"), ("ZX", "zx.csv")] {
        tables += &measured_circle(&dir, &truth, plane, name);
    }
    let path = write(
        &dir,
        "fit.toml",
        &format!("estimate = [\"EX0Z\", \"EY0Z\"]\n{tables}"),
    );
    let error = fit(&three_axis(), &FitFile::read(&path).unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("EX0Z cannot be told from zero")
            && error.contains("no test of a machine without rotary axes sees it"),
        "{error}"
    );
    let path = write(
        &dir,
        "fit.toml",
        &format!("estimate = [\"EC0Y\", \"EY0Z\"]\n{tables}"),
    );
    let error = fit(&three_axis(), &FitFile::read(&path).unwrap())
        .unwrap_err()
        .to_string();
    assert!(error.contains("EY0Z cannot be told from zero"), "{error}");
}
