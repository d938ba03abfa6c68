//! What the fuzzing campaigns found in calibration (`fit` and `build`, docs/testing.md, "Fuzzing"), each
//! kept as the input that showed it (`tests/fuzz-regressions/`) or a hand-made one like it, with
//! the error volmap now gives.

use std::path::PathBuf;

use volmap::model::Machine;

use super::common::{fuzz_regression as regression, write_input_files as write_files};

fn machine() -> Machine {
    volmap::io::embedded::embedded("vmc-li2015")
        .unwrap()
        .unwrap()
}

/// A circle with one deviation of 387 mm (micrometres written as mm) fitted a squareness of
/// 0.29 rad, reported as an estimate and written by `fit --out` into a file no reader takes:
/// such an estimate is refused, naming the fit file.
#[test]
fn estimates_no_machine_can_have_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_files(dir.path(), "fit.toml", &regression("fit-implausible.toml"));
    let file = volmap::calibrate::fit::FitFile::read(&path).unwrap();
    let error = volmap::calibrate::fit::fit(&machine(), &file)
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "{}: estimate: the estimate of EC0Y is -0.29",
            path.display()
        )) && error.contains("more than any machine tool has (at most 1e-2 rad)"),
        "{error}"
    );
}

/// A test's value written as a string of 4 kB over several lines (`to_deg = """a…"""`) was
/// quoted whole in the message saying it is not a number.
#[test]
fn a_long_string_where_a_number_belongs_is_quoted_in_part() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_files(dir.path(), "fit.toml", &regression("fit-long-string.toml"));
    let error = match volmap::calibrate::fit::FitFile::read(&path) {
        Ok(_) => panic!("a string where degrees belong was read"),
        Err(e) => e.to_string(),
    };
    assert!(
        error.starts_with(&format!(
            "{}: [[rtest]] number 1: invalid type: string",
            path.display()
        )),
        "{error}"
    );
    assert!(
        error.contains('…') && error.len() < 400,
        "{} bytes: {error}",
        error.len()
    );
}

/// What the tests cannot tell apart was said without the file it is about.
#[test]
fn errors_of_the_estimation_name_the_fit_file() {
    let dir = tempfile::tempdir().unwrap();
    let seed = std::fs::read(
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fuzz-corpus/fit/diagonal-positioning.toml"),
    )
    .unwrap();
    let two = String::from_utf8(seed)
        .unwrap()
        .replace("estimate = [\"EC0Y\"]", "estimate = [\"EC0Y\", \"EB0Z\"]");
    let path = write_files(dir.path(), "fit.toml", two.as_bytes());
    let file = volmap::calibrate::fit::FitFile::read(&path).unwrap();
    let error = volmap::calibrate::fit::fit(&machine(), &file)
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "{}: estimate: EC0Y and EB0Z cannot be told apart",
            path.display()
        )),
        "{error}"
    );
}

/// 2³² µrad of pitch at one position (a count where the angle belonged) was built into a
/// machine file that no command then read: `build` refuses it, naming the measurements and
/// the component.
#[test]
fn measured_tables_no_machine_can_have_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.csv");
    std::fs::write(&path, regression("interferometer-implausible.csv")).unwrap();
    let axes = [(volmap::model::AxisLetter::X, path.as_path())];
    let error = volmap::calibrate::build::build(&machine(), &axes, &[])
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "{}: axes.X.EBX: an angular error of 4294.9673 rad at X=200.000 mm is more than any machine tool has",
            path.display()
        )),
        "{error}"
    );
}

/// A CSV name of 4 kB in a fit file (newlines in it) was quoted whole in the message: a path is
/// shown with its control characters as `?` and cut in the middle beyond 320 characters.
#[test]
fn a_long_csv_name_is_shown_cut_in_the_message() {
    let dir = tempfile::tempdir().unwrap();
    let fit = dir.path().join("fit.toml");
    std::fs::write(
        &fit,
        format!(
            "estimate = [\"EX0C\", \"EY0C\"]\n[[rtest]]\naxis = \"C\"\nsphere_mm = [100.0, 200.0, 250.0]\nfrom_deg = 0.0\nto_deg = 30.0\nstep_deg = 10.0\ncsv = \"\"\"a\n{}\nb\"\"\"\n",
            "0,".repeat(2000)
        ),
    )
    .unwrap();
    let out = crate::cli::volmap()
        .args(["fit", "--machine", "5axis-hwang2014", "--measurements"])
        .arg(&fit)
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    let message = String::from_utf8(out).unwrap();
    assert!(message.len() < 1200, "{} bytes: {message}", message.len());
    assert!(message.contains("[[rtest]] number 1: "), "{message}");
    assert!(message.contains("a?0,0,0,"), "{message}");
    assert!(message.contains(",0,…0,0,"), "{message}");
    assert!(
        message
            .trim_end()
            .ends_with(",?b: cannot read: File name too long (os error 36)"),
        "{message}"
    );
}
