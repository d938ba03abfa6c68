//! The machine files `build --out` and `fit --out` write: the base file with its comments and
//! order, only the measured or fitted values changed, numbers without arithmetic noise, headed
//! by where the file came from; and they load and map.

use predicates::prelude::*;

use super::volmap;

const BASE: &str = include_str!("../../../machines/vmc-li2015.toml");

/// The file's header (the comment lines before the first blank line) and the rest.
fn split_header(text: &str) -> (&str, &str) {
    text.split_once("\n\n").expect("a header and a blank line")
}

/// The significant digits of a number written in TOML: `0.0021` has 2, `1.5e-6` 2.
fn significant_digits(number: &str) -> usize {
    let mantissa = number
        .trim_start_matches('-')
        .split(['e', 'E'])
        .next()
        .unwrap();
    let digits: String = mantissa.chars().filter(char::is_ascii_digit).collect();
    let digits = digits.trim_start_matches('0');
    // Trailing zeros after a decimal point (`250.0`) say nothing.
    let digits = if mantissa.contains('.') {
        digits.trim_end_matches('0')
    } else {
        digits
    };
    digits.len().max(1)
}

fn numbers_in(text: &str) -> Vec<&str> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '-' || c == '+'))
        .filter(|w| {
            w.parse::<f64>().is_ok() && w.starts_with(|c: char| c.is_ascii_digit() || c == '-')
        })
        .collect()
}

fn assert_header(header: &str, command: &str) {
    assert!(
        header.lines().all(|l| l.starts_with("# ")),
        "the header is comments:\n{header}"
    );
    let first = header.lines().next().unwrap();
    assert!(first.starts_with("# Written by volmap "), "{first}");
    assert!(first.contains(command), "{first}");
    // The date and time, UTC: `on 2026-11-23T22:44:03Z:`.
    let date = first.split(" on ").nth(1).unwrap();
    let date = &date[..date.find(": ").unwrap()];
    assert!(
        date.len() == 20 && date.ends_with('Z') && date.as_bytes()[10] == b'T',
        "{date}"
    );
}

#[test]
fn build_edits_the_base_file_in_place() {
    let dir = tempfile::tempdir().unwrap();
    // 2.1 µm in mm is 0.0021000000000000003 in f64 arithmetic; 1.5 µrad is 1.5e-6 rad.
    std::fs::write(
        dir.path().join("x.csv"),
        "position_mm,EXX_um,EBX_urad\n0,0,0\n250,2.1,1\n500,5,1.5\n750,6,1\n1000,6.5,0\n",
    )
    .unwrap();
    let out = dir.path().join("built.toml");
    volmap()
        .current_dir(dir.path())
        .args([
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=x.csv",
            "--interp",
            "EXX=linear,EBX=cubic",
            "--out",
            "built.toml",
        ])
        .assert()
        .success();
    let text = std::fs::read_to_string(&out).unwrap();
    let (header, body) = split_header(&text);
    assert_header(header, "volmap build --base vmc-li2015 --axis X=x.csv");
    assert!(
        header.contains("X=x.csv") && header.contains("EXX linear, EBX cubic"),
        "{header}"
    );
    // Everything but the two measured components byte for byte as in the base file, comments
    // (theirs too) and order included.
    let old_exx = "EXX = { poly = [0.0, 2.0e-5] }";
    let old_ebx = "EBX = { poly = [-2.0e-5, 4.0e-8] }";
    assert!(BASE.contains(old_exx) && BASE.contains(old_ebx));
    let expected = BASE
        .replace(
            old_exx,
            "EXX = { interp = \"linear\", table = [\n    [0.0, 0.0],\n    [250.0, 0.0021],\n    [500.0, 0.005],\n    [750.0, 0.006],\n    [1000.0, 0.0065],\n] }",
        )
        .replace(
            old_ebx,
            "EBX = { interp = \"cubic\", table = [\n    [0.0, 0.0],\n    [250.0, 1e-6],\n    [500.0, 1.5e-6],\n    [750.0, 1e-6],\n    [1000.0, 0.0],\n] }",
        );
    assert_eq!(body, expected);
    let machine = volmap::model::Machine::from_path(&out).unwrap();
    let x = machine.axis(volmap::model::AxisLetter::X).unwrap();
    assert_eq!(x.component_values(250.0)[0], 0.0021);
    volmap()
        .args(["map", "--grid", "3x3x3", "--device", "cpu", "--machine"])
        .arg(&out)
        .arg("--out")
        .arg(dir.path().join("built.exr"))
        .assert()
        .success();
}

#[test]
fn fit_edits_only_the_fitted_values_of_the_machine_file() {
    let dir = tempfile::tempdir().unwrap();
    // The circle of the machine with a squareness of 20 µrad, fitted on the file that says 15.
    let truth = dir.path().join("truth.toml");
    std::fs::write(&truth, BASE.replace("EC0Y = 1.5e-5 ", "EC0Y = 2.0e-5 ")).unwrap();
    let json = dir.path().join("xy.json");
    volmap()
        .args([
            "test", "circular", "--plane", "XY", "--points", "24", "--json",
        ])
        .arg(&json)
        .arg("--machine")
        .arg(&truth)
        .assert()
        .success();
    let report: serde_json::Value = super::json_result(&json);
    let mut csv = String::from("angle_deg,deviation_mm\n");
    assert_eq!(
        report["positions"].as_array().unwrap().len(),
        report["predicted"][0].as_array().unwrap().len()
    );
    for (a, r) in report["positions"]
        .as_array()
        .unwrap()
        .iter()
        .zip(report["predicted"][0].as_array().unwrap())
    {
        csv += &format!("{a},{r}\n");
    }
    std::fs::write(dir.path().join("xy.csv"), csv).unwrap();
    std::fs::write(
        dir.path().join("fit.toml"),
        "estimate = [\"EC0Y\"]\n[[circular]]\nplane = \"XY\"\npoints = 24\ncsv = \"xy.csv\"\n",
    )
    .unwrap();
    let base = dir.path().join("base.toml");
    std::fs::write(&base, BASE).unwrap();
    volmap()
        .current_dir(dir.path())
        .args([
            "fit",
            "--machine",
            "base.toml",
            "--measurements",
            "fit.toml",
            "--out",
            "fitted.toml",
        ])
        .assert()
        .success()
        .stdout(predicate::str::contains("EC0Y"));
    let text = std::fs::read_to_string(dir.path().join("fitted.toml")).unwrap();
    let (header, body) = split_header(&text);
    assert_header(
        header,
        "volmap fit --machine base.toml --measurements fit.toml",
    );
    assert!(
        header.contains("EC0Y") && header.contains("fit.toml"),
        "{header}"
    );
    // Line for line the base file, but for EC0Y's value and u (its comment and spacing kept).
    let (old, new): (Vec<&str>, Vec<&str>) = (BASE.lines().collect(), body.lines().collect());
    assert_eq!(old.len(), new.len());
    let mut fitted = None;
    for (a, b) in old.iter().zip(&new) {
        if a.starts_with("EC0Y = ") {
            let comment = &a[a.find('#').unwrap()..];
            assert!(b.starts_with("EC0Y = ") && b.ends_with(comment), "{b}");
            fitted = Some(b["EC0Y = ".len()..b.find('#').unwrap()].trim().to_string());
        } else {
            assert_eq!(a, b);
        }
    }
    // `{ value = …, u = … }`: the estimate with its standard uncertainty.
    let fitted = fitted.expect("EC0Y written");
    let form: toml::Table = toml::from_str(&format!("v = {fitted}")).unwrap();
    assert!(form["v"]["u"].as_float().unwrap() >= 0.0, "{fitted}");
    let fitted = fitted
        .split("value = ")
        .nth(1)
        .and_then(|rest| rest.split(',').next())
        .unwrap()
        .trim();
    assert!(significant_digits(fitted) <= 12, "{fitted}");
    let value: f64 = fitted.parse().unwrap();
    assert!((value - 2.0e-5).abs() < 1e-12, "{value}");
    assert!(volmap::model::Machine::from_path(&dir.path().join("fitted.toml")).is_ok());
}

#[test]
fn significant_digits_are_counted_as_written() {
    assert_eq!(significant_digits("0.0021000000000000003"), 17);
    assert_eq!(significant_digits("0.0021"), 2);
    assert_eq!(significant_digits("1.5e-6"), 2);
    assert_eq!(significant_digits("250.0"), 2);
    assert_eq!(significant_digits("1000.0"), 1);
    assert_eq!(numbers_in("[250.0, 1e-6]"), ["250.0", "1e-6"]);
}

#[test]
fn built_numbers_carry_no_arithmetic_noise() {
    let dir = tempfile::tempdir().unwrap();
    // Unit conversions whose f64 products end in noise: 0.1 µm, 0.3 µm, 2.1 µm, 0.7 arcsec.
    std::fs::write(
        dir.path().join("x.csv"),
        "position_mm,EXX_um,EYX_um,EAX_arcsec\n0,0.1,0.3,0.7\n333.3,2.1,0.7,0.1\n1000,0.3,2.1,0.3\n",
    )
    .unwrap();
    volmap()
        .current_dir(dir.path())
        .args([
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=x.csv",
            "--out",
            "b.toml",
        ])
        .assert()
        .success();
    let text = std::fs::read_to_string(dir.path().join("b.toml")).unwrap();
    let (_, body) = split_header(&text);
    let written: String = body
        .lines()
        .filter(|l| !BASE.lines().any(|b| b == *l))
        .collect::<Vec<_>>()
        .join("\n");
    let numbers = numbers_in(&written);
    assert!(numbers.len() >= 18, "{written}");
    for n in numbers {
        assert!(significant_digits(n) < 15, "{n} in\n{written}");
    }
    assert!(written.contains("[333.3, 0.0021]"), "{written}");
}
