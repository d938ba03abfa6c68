//! Machine files: what parses, and a clear error naming the file and key for what does not.

use std::path::Path;

use volmap::io::embedded;
use volmap::io::machine_file::MachineError;
use volmap::model::{AxisLetter, ErrorFunction, Interp, Machine};
use volmap::nc;

const GOOD: &str = r#"
name = "3-axis VMC"
chain = "FYXFZ"
[tool]
offset = [0.0, 0.0, -150.0]
[axes.X]
range = [0.0, 600.0]
offset = [0.0, 0.0, 0.0]
EXX = { table = [[0, 0.0], [300, 0.012], [600, 0.020]], interp = "linear" }
EBX = 2.0e-5
[axes.Y]
range = [0.0, 400.0]
EC0Y = 1.5e-5
[axes.Z]
range = [0.0, 300.0]
EA0Z = -1.0e-5
EB0Z = 2.0e-5
[spindle]
EXS = 0.002
"#;

fn parse(text: &str) -> Result<Machine, MachineError> {
    Machine::from_toml(text, "bad.toml", None)
}

/// Parses `GOOD` with `from` replaced by `to` and returns the error message.
fn error_of(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from}");
    match parse(&GOOD.replacen(from, to, 1)) {
        Ok(_) => panic!("`{to}` was accepted"),
        Err(e) => e.to_string(),
    }
}

fn assert_mentions(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(
            message.contains(part),
            "`{message}` does not mention `{part}`"
        );
    }
}

#[test]
fn the_model_md_example_parses() {
    let m = parse(GOOD).unwrap();
    assert_eq!(m.chain.hwang_notation(), "FYXFZ");
    assert_eq!(m.tool_offset_mm, [0.0, 0.0, -150.0]);
    assert_eq!(m.axis(AxisLetter::Y).unwrap().location[5], 1.5e-5);
    assert_eq!(
        m.axis(AxisLetter::X).unwrap().components[4],
        Some(ErrorFunction::Constant(2.0e-5))
    );
    assert_eq!(m.spindle[0], 0.002);
}

#[test]
fn every_embedded_machine_parses() {
    for (name, _) in embedded::EMBEDDED {
        let m = embedded::embedded(name)
            .unwrap()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!m.description.is_empty(), "{name}");
    }
    let li = embedded::load("vmc-li2015").unwrap();
    assert_eq!(li.chain.hwang_notation(), "FFXYZ");
    let dobariya = embedded::load("vmc-dobariya2015").unwrap();
    let z = dobariya.axis(AxisLetter::Z).unwrap();
    match &z.components[2] {
        Some(ErrorFunction::Table(t)) => assert_eq!(t.interp(), Interp::Quadratic),
        other => panic!("EZZ should be a quadratic table: {other:?}"),
    }
    assert!(matches!(
        embedded::load("no-such-machine"),
        Err(MachineError::UnknownMachine { .. })
    ));
}

#[test]
fn unknown_keys_are_errors() {
    assert_mentions(
        &error_of("name =", "colour = 1\nname ="),
        &["bad.toml", "colour"],
    );
    assert_mentions(
        &error_of("EBX = 2.0e-5", "EBX = 2.0e-5\nspeed = 3"),
        &["bad.toml", "axes.X.speed", "unknown key"],
    );
    assert_mentions(
        &error_of("EBX = 2.0e-5", "EBX = 2.0e-5\nEXY = 0.1"),
        &["axes.X.EXY", "belongs in [axes.Y]"],
    );
    assert_mentions(
        &error_of("interp = \"linear\"", "interp = \"linear\", smooth = true"),
        &["axes.X.EXX.smooth"],
    );
    assert_mentions(
        &error_of("EXS = 0.002", "EXS = 0.002\nECS = 0.1"),
        &["bad.toml", "ECS"],
    );
    assert_mentions(
        &error_of(
            "offset = [0.0, 0.0, -150.0]",
            "offset = [0.0, 0.0, -150.0]\nlength = 3",
        ),
        &["length"],
    );
}

#[test]
fn chain_and_sections_must_agree() {
    assert_mentions(
        &error_of("chain = \"FYXFZ\"", "chain = \"FYXFZC\""),
        &["bad.toml", "axis C", "no [axes.C] section"],
    );
    assert_mentions(
        &error_of("chain = \"FYXFZ\"", "chain = \"FYXF\""),
        &["bad.toml", "[axes.Z]", "names no axis"],
    );
    assert_mentions(
        &error_of("chain = \"FYXFZ\"", "chain = \"FYQFZ\""),
        &["bad.toml", "chain", "unknown letter `Q`"],
    );
    assert_mentions(
        &error_of("[axes.Z]", "[axes.W]\nrange = [0, 1]\n[axes.Z]"),
        &["[axes.W]"],
    );
    assert_mentions(
        &error_of("chain = \"FYXFZ\"", "chain = \"FYXFX\""),
        &["appears twice"],
    );
}

#[test]
fn bad_tables_are_errors() {
    let unsorted = error_of(
        "[[0, 0.0], [300, 0.012], [600, 0.020]]",
        "[[0, 0.0], [300, 0.012], [250, 0.020]]",
    );
    assert_mentions(
        &unsorted,
        &["bad.toml", "axes.X.EXX", "increase strictly", "250"],
    );
    let even = error_of(
        "[[0, 0.0], [300, 0.012], [600, 0.020]], interp = \"linear\"",
        "[[0, 0.0], [200, 0.01], [400, 0.012], [600, 0.020]], interp = \"quadratic\"",
    );
    assert_mentions(&even, &["axes.X.EXX", "odd number of nodes", "4"]);
    assert_mentions(
        &error_of("interp = \"linear\"", "interp = \"spline\""),
        &["axes.X.EXX.interp", "spline"],
    );
    assert_mentions(
        &error_of(
            "interp = \"linear\"",
            "interp = \"linear\", periodic = true",
        ),
        &["rotary"],
    );
    assert_mentions(
        &error_of("EBX = 2.0e-5", "EBX = { poly = [] }"),
        &["axes.X.EBX.poly"],
    );
}

#[test]
fn non_finite_values_are_errors() {
    assert_mentions(
        &error_of("EBX = 2.0e-5", "EBX = nan"),
        &["bad.toml", "axes.X.EBX", "not a finite number"],
    );
    assert_mentions(&error_of("EC0Y = 1.5e-5", "EC0Y = inf"), &["axes.Y.EC0Y"]);
    assert_mentions(
        &error_of("[300, 0.012]", "[300, -inf]"),
        &["axes.X.EXX.table[1]", "not a finite number"],
    );
    assert_mentions(&error_of("EXS = 0.002", "EXS = nan"), &["spindle.EXS"]);
    assert_mentions(
        &error_of("[0.0, 0.0, -150.0]", "[0.0, nan, -150.0]"),
        &["tool.offset"],
    );
}

#[test]
fn inverted_ranges_are_errors() {
    assert_mentions(
        &error_of("range = [0.0, 400.0]", "range = [400.0, 0.0]"),
        &["bad.toml", "axes.Y.range", "inverted"],
    );
    assert_mentions(
        &error_of("range = [0.0, 400.0]\n", ""),
        &["axes.Y.range", "missing"],
    );
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn csv_tables() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "x-axis.csv",
        "position, EXX, EYX\n0, 0.0, 0.001\n300, 0.012, 0.002\n600, 0.020, 0.0\n",
    );
    let text = GOOD.replace(
        "EXX = { table = [[0, 0.0], [300, 0.012], [600, 0.020]], interp = \"linear\" }",
        "EXX = { csv = \"x-axis.csv\" }\nEYX = { csv = \"x-axis.csv\", column = \"EYX\", interp = \"quadratic\" }",
    );
    let path = write(dir.path(), "m.toml", &text);
    let m = Machine::from_path(&path).unwrap();
    let x = m.axis(AxisLetter::X).unwrap();
    assert!((x.components[0].as_ref().unwrap().eval(150.0) - 0.006).abs() < 1e-15);
    assert!((x.components[1].as_ref().unwrap().eval(300.0) - 0.002).abs() < 1e-15);
    assert_eq!(
        m.source.csv_files.len(),
        1,
        "the CSV travels with the machine, once"
    );

    let missing_column = write(
        dir.path(),
        "m2.toml",
        &text.replace("column = \"EYX\"", "column = \"EZX\""),
    );
    let message = Machine::from_path(&missing_column).unwrap_err().to_string();
    assert_mentions(
        &message,
        &[
            "x-axis.csv",
            "m2.toml",
            "axes.X.EYX",
            "no column `EZX`",
            "position, EXX, EYX",
        ],
    );

    write(dir.path(), "broken.csv", "position,EXX\n0,0.0\n300,abc\n");
    let broken = write(
        dir.path(),
        "m3.toml",
        &text.replace("x-axis.csv\" }", "broken.csv\" }"),
    );
    assert_mentions(
        &Machine::from_path(&broken).unwrap_err().to_string(),
        &["broken.csv", "line 3", "`abc`"],
    );

    let absent = write(
        dir.path(),
        "m4.toml",
        &text.replace("x-axis.csv\" }", "absent.csv\" }"),
    );
    assert_mentions(
        &Machine::from_path(&absent).unwrap_err().to_string(),
        &["absent.csv", "cannot read"],
    );
}

#[test]
fn toml_syntax_errors_name_the_file_and_line() {
    let message = parse("name = \"x\"\nchain = \"FXFY\n")
        .unwrap_err()
        .to_string();
    assert_mentions(&message, &["bad.toml", "line 2"]);
}

/// The embedded vmc-li2015, which tolerance files name the terms of.
fn machine() -> Machine {
    embedded::embedded("vmc-li2015").unwrap().unwrap()
}

/// A misspelt key of 3,000 characters was quoted whole in the message, as the command line
/// shows it (`capped` cuts what is quoted between backticks, not the key's path).
#[test]
fn long_keys_are_quoted_within_80_characters() {
    use volmap::error::capped;
    let key = "k".repeat(3000);
    let text = format!("name = \"m\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [0.0, 100.0]\n\"{key}\" = 1\n[axes.Y]\nrange = [0.0, 100.0]\n[axes.Z]\nrange = [0.0, 100.0]\n");
    let message = capped(
        &Machine::from_toml(&text, "m.toml", None)
            .unwrap_err()
            .to_string(),
    );
    assert!(message.len() < 400, "{message}");
    assert!(message.starts_with("m.toml: axes.X.kkk"), "{message}");
    let tolerances = format!("[\"{key}\"]\nx = 1\n");
    let message = capped(
        &volmap::io::tolerance_file::ToleranceFile::parse(
            &tolerances,
            std::path::Path::new("t.toml"),
            &machine(),
        )
        .unwrap_err()
        .to_string(),
    );
    assert!(message.len() < 400, "{message}");
    assert!(message.starts_with("t.toml: kkk"), "{message}");
}

/// Work offsets of ten thousand unclosed inline tables overflowed the TOML parser's stack (an
/// abort, on the command line too): every TOML reader refuses nesting beyond 64 levels first,
/// naming the line.
#[test]
fn toml_nested_beyond_the_limit_is_refused_before_it_is_parsed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("offsets.toml");
    std::fs::write(&path, "G54 = { [200.0, 200.0, 300.0]\n".repeat(10_000)).unwrap();
    let error = nc::read_work_offsets(&path).unwrap_err().to_string();
    assert!(
        error.ends_with(
            "line 64, column 9: arrays and inline tables nested more than 64 levels deep\n  | G54 = { [200.0, 200.0, 300.0]"
        ),
        "{error}"
    );
    let machine_file = dir.path().join("m.toml");
    std::fs::write(&machine_file, format!("name = {}", "[".repeat(100_000))).unwrap();
    let error = volmap::model::Machine::from_path(&machine_file)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("line 1, column 72: arrays and inline tables nested more than 64"),
        "{error}"
    );
}
