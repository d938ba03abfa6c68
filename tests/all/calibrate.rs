//! Machine models from measurements: location errors fitted to simulated noisy tests, machine
//! files built from sparse component measurements, and their bad input.

use volmap::calibrate::CalibrateError;
use volmap::io::csv::CsvError;
use volmap::model::{AxisLetter, Machine};
use volmap::standards::{self, DiagonalSpec, RTestSpec, Setup};
use AxisLetter::*;

use super::standards::{circular_spec, expect_csv_error, three_axis, write, CsvCause};

impl CsvCause for CalibrateError {
    fn csv(&self) -> Option<&CsvError> {
        match self {
            CalibrateError::Csv(e) => Some(e),
            _ => None,
        }
    }
}

/// Writes a test's predicted curves, with noise, as the measured CSV of its kind.
pub fn write_measured(
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

pub const THREE_AXIS_TOML: &str = r#"
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

/// Measurements that see the three squareness errors of a machine (`setup`): ballbar circles
/// in XY, YZ and ZX (150 mm, 72 points) and the four body diagonals (21 points), each a CSV in
/// `dir` with normal noise of `noise` mm; returns their `[[circular]]` and `[[diagonal]]` tables
/// of a fit file.
pub fn squareness_measurements(
    dir: &std::path::Path,
    setup: &Setup,
    noise: f64,
    rng: &mut super::common::Rng,
) -> String {
    let mut fit_toml = String::new();
    for plane in ["XY", "YZ", "ZX"] {
        let result = standards::circular(setup, &circular_spec(plane, 150.0)).unwrap();
        let name = format!("{plane}.csv");
        write_measured(
            &dir.join(&name),
            "angle_deg,deviation_um",
            &result,
            noise,
            rng,
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
        let result = standards::diagonal(setup, &spec).unwrap();
        let name = format!("{diagonal}.csv");
        write_measured(
            &dir.join(&name),
            "position_mm,deviation_um",
            &result,
            noise,
            rng,
        );
        fit_toml += &format!("[[diagonal]]\ndiagonal = \"{diagonal}\"\ncsv = \"{name}\"\n");
    }
    fit_toml
}

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
    let mut rng = super::common::Rng::new(42);
    let noise = 0.3e-3;
    let mut fit_toml = String::from("estimate = [\"EC0Y\", \"EB0Z\", \"EA0Z\"]\n");
    fit_toml += &squareness_measurements(dir.path(), &setup, noise, &mut rng);
    let fit_path = write(&dir, "fit.toml", &fit_toml);
    let file = volmap::calibrate::fit::FitFile::read(&fit_path).unwrap();
    let report = volmap::calibrate::fit::fit(&given, &file).unwrap();
    assert_eq!(report.points, 3 * 72 + 4 * 21);
    assert_eq!(
        report.estimates.len(),
        truth.len(),
        "{:?}",
        report.estimates
    );
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
    let text = volmap::calibrate::fit::fitted_machine_toml(&given, &report).unwrap();
    let fitted = Machine::from_toml(&text, "fitted.toml", None).unwrap();
    // Each to a thousandth of its uncertainty: moved by at most half of that.
    for (estimate, &(_, axis, index, _)) in report.estimates.iter().zip(&truth) {
        let written = fitted.axis(axis).unwrap().location[index];
        assert!(
            (written - estimate.value).abs() <= 5e-4 * estimate.uncertainty,
            "{written} for {estimate:?}"
        );
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
    let mut rng = super::common::Rng::new(7);
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
    assert_eq!(
        report.estimates.len(),
        truth.len(),
        "{:?}",
        report.estimates
    );
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
        &mut super::common::Rng::new(1),
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
    assert!(
        error.contains("EA0Z cannot be told from zero") && error.contains("YZ plane"),
        "{error}"
    );
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
        // The file holds 12 significant digits: within 1e-14 of values up to 0.01.
        assert!((exx - (2.0 + 0.01 * q) * 1e-3).abs() < 1e-14, "EXX at {q}");
        assert!(
            (ebx - (3.0 + 1e-4 * q * q) * 1e-6).abs() < 1e-14,
            "EBX at {q}"
        );
    }
    let z = machine.axis(Z).unwrap();
    for i in 0..9 {
        let q = -250.0 + 62.5 * i as f64;
        assert!((z.component_values(q)[2] - 0.004 * (q / 80.0).sin()).abs() < 1e-14);
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

pub const THERMAL_TOML: &str = r#"
name = "three-axis, warm hall"
chain = "FYXFZ"
[thermal]
reference_C = 20.0
inputs = ["hall"]
[axes.X]
range = [-400.0, 400.0]
[axes.Y]
range = [-300.0, 300.0]
[axes.Z]
range = [-250.0, 250.0]
"#;

/// Measured circles of the thermal machine with EC0Y = s0 + k·(hall − 20) and EB0Z = b: XY
/// circles at `xy_halls`, a ZX circle at 26 °C, each with its `temperatures`, written beside
/// the fit file whose `estimate` line is `estimate`.
pub fn thermal_measurements(
    dir: &tempfile::TempDir,
    truth: (f64, f64, f64),
    xy_halls: &[f64],
    estimate: &str,
) -> std::path::PathBuf {
    let (s0, k, b) = truth;
    let given = Machine::from_toml(THERMAL_TOML, "thermal.toml", None).unwrap();
    let text = THERMAL_TOML.replace(
        "range = [-300.0, 300.0]",
        &format!(
            "range = [-300.0, 300.0]\nEC0Y = {{ value = {s0:e}, per_kelvin = {{ hall = {k:e} }} }}"
        ),
    ) + &format!("EB0Z = {b:e}\n");
    let truth = Machine::from_toml(&text, "truth.toml", None).unwrap();
    assert_eq!(truth.thermal, given.thermal);
    let mut rng = super::common::Rng::new(11);
    let mut fit_toml = format!("estimate = [{estimate}]\n");
    let circles = xy_halls.iter().map(|&t| ("XY", t)).chain([("ZX", 26.0)]);
    for (n, (plane, hall)) in circles.enumerate() {
        let inputs =
            volmap::model::inputs::Inputs::parse(&format!("hall={hall}"), "", &truth).unwrap();
        let setup = Setup::with_inputs(&truth, "", &inputs).unwrap();
        let spec = standards::CircularSpec {
            points: 180,
            ..circular_spec(plane, 250.0)
        };
        let result = standards::circular(&setup, &spec).unwrap();
        let name = format!("c{n}.csv");
        write_measured(
            &dir.path().join(&name),
            "angle_deg,deviation_um",
            &result,
            0.3e-3,
            &mut rng,
        );
        fit_toml += &format!(
            "[[circular]]\nplane = \"{plane}\"\nradius_mm = 250.0\npoints = 180\ncsv = \"{name}\"\ntemperatures = {{ hall = {hall:?} }}\n"
        );
    }
    write(dir, "fit.toml", &fit_toml)
}

#[test]
fn fit_recovers_a_squareness_and_its_thermal_coefficient_from_circles_at_three_temperatures() {
    use volmap::calibrate::fit;
    let dir = tempfile::tempdir().unwrap();
    // The squareness of Y to X grows by 1.5 µrad per kelvin of the hall from 20 µrad at 20 °C.
    let (s0, k, b) = (2.0e-5, 1.5e-6, -1.5e-5);
    let path = thermal_measurements(
        &dir,
        (s0, k, b),
        &[20.0, 26.0, 32.0],
        "\"EC0Y\", \"EC0Y.per_kelvin.hall\", \"EB0Z\"",
    );
    let given = Machine::from_toml(THERMAL_TOML, "thermal.toml", None).unwrap();
    let report = fit::fit(&given, &fit::FitFile::read(&path).unwrap()).unwrap();
    let names: Vec<&str> = report.estimates.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names, ["EC0Y", "EC0Y.per_kelvin.hall", "EB0Z"]);
    assert_eq!(report.estimates[1].unit, "rad/K");
    // 0.3 µm of noise on 180 points of a 250 mm circle: about 0.25 µrad per circle, and the
    // coefficient from ±6 K about 0.03 µrad/K.
    for (estimate, (value, bound)) in
        report
            .estimates
            .iter()
            .zip([(s0, 1e-6), (k, 1e-7), (b, 1e-6)])
    {
        assert_eq!(estimate.initial, 0.0);
        assert!(
            estimate.uncertainty > 0.0 && estimate.uncertainty < bound,
            "{estimate:?}"
        );
        assert!(
            (estimate.value - value).abs() < 4.0 * estimate.uncertainty,
            "{estimate:?} against {value}"
        );
    }
    assert!(report.rms_after_mm < 0.4e-3, "{}", report.rms_after_mm);
    // The machine file with the estimates carries the coefficient in the general form.
    let text = fit::fitted_machine_toml(&given, &report).unwrap();
    assert!(text.contains("per_kelvin"), "{text}");
    let fitted = Machine::from_toml(&text, "fitted.toml", None).unwrap();
    let (s, c) = (report.estimates[0].value, report.estimates[1].value);
    let at = |hall: f64| {
        let inputs =
            volmap::model::inputs::Inputs::parse(&format!("hall={hall}"), "", &fitted).unwrap();
        fitted.at(&inputs).axis(Y).unwrap().location[5]
    };
    let (us, uc) = (
        report.estimates[0].uncertainty,
        report.estimates[1].uncertainty,
    );
    assert!((at(20.0) - s).abs() <= 5e-4 * us);
    assert!((at(30.0) - (s + 10.0 * c)).abs() <= 5e-4 * (us + 10.0 * uc) + 1e-18);
    assert!(
        (fitted.axis(Z).unwrap().location[4] - report.estimates[2].value).abs()
            <= 5e-4 * report.estimates[2].uncertainty
    );
    assert_eq!(fitted.dependent.len(), 1);
}

#[test]
fn a_fit_file_naming_an_undeclared_input_names_the_file_and_the_key() {
    use volmap::calibrate::fit;
    let dir = tempfile::tempdir().unwrap();
    let given = Machine::from_toml(THERMAL_TOML, "thermal.toml", None).unwrap();
    let truth = (2.0e-5, 1.5e-6, 0.0);
    // The tests' temperatures.
    let path = thermal_measurements(&dir, truth, &[20.0, 30.0], "\"EC0Y\"");
    let text = std::fs::read_to_string(&path).unwrap();
    let bad = write(
        &dir,
        "lobby.toml",
        &text.replacen("hall = 30.0", "lobby = 30.0", 1),
    );
    let error = fit::fit(&given, &fit::FitFile::read(&bad).unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("lobby.toml")
            && error.contains("[[circular]] number 2, temperatures.lobby")
            && error.contains("it declares hall"),
        "{error}"
    );
    let bad = write(
        &dir,
        "hot.toml",
        &text.replacen("hall = 30.0", "hall = \"hot\"", 1),
    );
    let error = fit::FitFile::read(&bad).unwrap_err().to_string();
    assert!(
        error.contains("hot.toml") && error.contains("temperatures.hall"),
        "{error}"
    );
    // The unknowns.
    let unknown = write(
        &dir,
        "unknown.toml",
        &text.replace(
            "estimate = [\"EC0Y\"]",
            "estimate = [\"EC0Y.per_kelvin.lobby\"]",
        ),
    );
    let error = fit::fit(&given, &fit::FitFile::read(&unknown).unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("unknown.toml: estimate")
            && error.contains("`lobby` is not a thermal input"),
        "{error}"
    );
    let error = fit::fit(&three_axis(), &fit::FitFile::read(&unknown).unwrap())
        .unwrap_err()
        .to_string();
    assert!(error.contains("no [thermal] section"), "{error}");
    // A coefficient the tests' temperatures cannot see, or cannot tell from the value.
    let one = thermal_measurements(&dir, truth, &[20.0], "\"EC0Y.per_kelvin.hall\"");
    let error = fit::fit(&given, &fit::FitFile::read(&one).unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("cannot be told from zero") && error.contains("hall"),
        "{error}"
    );
    let same = thermal_measurements(&dir, truth, &[26.0], "\"EC0Y\", \"EC0Y.per_kelvin.hall\"");
    let error = fit::fit(&given, &fit::FitFile::read(&same).unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("cannot be told apart") && error.contains("two or more temperatures"),
        "{error}"
    );
}

#[test]
fn a_value_and_its_coefficient_from_nearly_one_temperature_are_refused_by_name() {
    // Circles at 26 and 26.05 °C: the coefficient moves the readings as the value does, times
    // 6 or 6.05 K; the estimates correlate within 1e-3 of ±1.
    let dir = tempfile::tempdir().unwrap();
    let given = Machine::from_toml(THERMAL_TOML, "thermal.toml", None).unwrap();
    let near = thermal_measurements(
        &dir,
        (2.0e-5, 1.0e-6, -1.0e-5),
        &[26.0, 26.05],
        "\"EC0Y\", \"EC0Y.per_kelvin.hall\"",
    );
    let error = volmap::calibrate::fit::fit(
        &given,
        &volmap::calibrate::fit::FitFile::read(&near).unwrap(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("EC0Y and EC0Y.per_kelvin.hall cannot be told apart")
            && error.contains("correlate")
            && error.contains("two or more temperatures of hall"),
        "{error}"
    );
}
