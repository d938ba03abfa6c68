//! How errors are said, whatever the command: each names the flag or the file and the cause
//! (a value that is not a number as such, a folder as a folder, a code volmap does not know as
//! one), says each of its parts once, and shows numbers of many digits in exponent form.

use super::flag_values::MEASURED_X;
use super::{machine_with, refused, strs, succeeds, volmap};

#[test]
fn messages_name_the_flag_and_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let test = |kind: &str, extra: &[&str]| {
        let mut args = vec!["test", kind, "--machine", "vmc-li2015"];
        args.extend_from_slice(extra);
        args.into_iter().map(String::from).collect::<Vec<_>>()
    };
    // Values that are not numbers, named as such (not as positions outside the travel), also
    // where the test would not have used them.
    for (args, flag) in [
        (
            test("diagonal", &["--from", "nan,0,0", "--to", "100,100,100"]),
            "--from",
        ),
        (
            test("circular", &["--plane", "XY", "--centre", "500,inf,100"]),
            "--centre",
        ),
        (
            test("positioning", &["--axis", "X", "--at", "nan,0,0"]),
            "--at",
        ),
        (
            test("positioning", &["--axis", "Y", "--at", "0,0,-inf"]),
            "--at",
        ),
    ] {
        let stderr = refused(&strs(&args), d, &[flag, "is not a finite number"]);
        assert!(!stderr.contains("outside"), "{stderr}");
    }
    // A diagonal given by its ends alone is `the diagonal`, once.
    let stderr = refused(
        &strs(&test(
            "diagonal",
            &["--from", "-5,0,0", "--to", "100,100,100"],
        )),
        d,
        &["the diagonal, its start: X=-5"],
    );
    assert!(!stderr.contains("diagonal diagonal"), "{stderr}");
    let out = succeeds(
        &strs(&test(
            "diagonal",
            &["--from", "0,0,0", "--to", "100,100,100"],
        )),
        d,
    );
    assert!(
        out.contains("ISO 230-6 diagonal: (0.000, 0.000, 0.000)"),
        "{out}"
    );
    assert!(!out.contains("diagonal diagonal"), "{out}");

    // `build --axis`: the flag in every message of its files and letters.
    std::fs::write(d.join("x.csv"), MEASURED_X).unwrap();
    let build = |axis: &str| {
        vec![
            "build".to_string(),
            "--base".into(),
            "vmc-li2015".into(),
            "--out".into(),
            "b.toml".into(),
            "--axis".into(),
            axis.into(),
        ]
    };
    refused(&strs(&build("A=x.csv")), d, &["--axis", "has no A axis"]);
    refused(&strs(&build("X=")), d, &["--axis", "no file named"]);
    refused(
        &strs(&build("X=x.csv,Y=x.csv")),
        d,
        &["--axis", "repeat --axis"],
    );
    refused(
        &strs(&build("X=nothing.csv")),
        d,
        &["--axis", "nothing.csv"],
    );
    let mut interp = build("X=x.csv");
    interp.extend(["--interp".into(), "EQQ=linear".into()]);
    refused(&strs(&interp), d, &["--interp", "EQQ"]);
    // A component of an axis that is not measured: the library's check, named by the flag.
    let mut unmeasured = build("X=x.csv");
    unmeasured.extend(["--interp".into(), "EXY=cubic".into()]);
    refused(
        &strs(&unmeasured),
        d,
        &["--interp", "EXY: not a component of a measured axis"],
    );

    // A folder given as a field is said to be one.
    std::fs::create_dir(d.join("folder")).unwrap();
    refused(&["info", "folder"], d, &["a folder, not a file"]);
    refused(
        &["plot", "slice", "--field", "folder", "--out", "s.svg"],
        d,
        &["--field", "a folder, not a file"],
    );

    // A quantity in lower case is the quantity; one that is none says what there is.
    succeeds(
        &[
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "3x3x3",
            "--device",
            "cpu",
            "--out",
            "f.exr",
        ],
        d,
    );
    succeeds(
        &[
            "plot",
            "slice",
            "--field",
            "f.exr",
            "--quantity",
            "ve",
            "--out",
            "ve.svg",
        ],
        d,
    );
    refused(
        &[
            "plot",
            "slice",
            "--field",
            "f.exr",
            "--quantity",
            "speed",
            "--out",
            "s.svg",
        ],
        d,
        &["--quantity: `speed` is not a quantity", "VE, OE"],
    );
    // A grid of one point has no line to draw.
    refused(
        &[
            "plot",
            "grid",
            "--machine",
            "vmc-li2015",
            "--grid",
            "1x1x1",
            "--out",
            "g.svg",
        ],
        d,
        &["--grid", "no line to draw"],
    );

    // An axis set only beside a code volmap does not know (`X1E3`: X1 and E3, an exponent
    // being no G-code) is said to be so, not "never set".
    std::fs::write(d.join("e.nc"), "G90 G0 X1E3 Y0 Z0\nG1 X10 F100\nM30\n").unwrap();
    refused(
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "e.nc",
            "--out",
            "c.nc",
        ],
        d,
        &["e.nc: line 1", "`E3`, a code volmap does not know"],
    );
}

#[test]
fn numbers_of_many_digits_are_shown_in_exponent_form() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = succeeds(
        &[
            "map",
            "--machine",
            "5axis-hwang2014",
            "--pose",
            "B=1e-320",
            "--grid",
            "2x2x2",
            "--device",
            "cpu",
            "--out",
            "f.exr",
        ],
        d,
    );
    // Printed positions are rounded to 3 decimals: no run of zeros either.
    assert!(out.contains("B=0.000°"), "{out}");
    assert!(!out.contains("0000000000"), "{out}");
    let out = succeeds(
        &[
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--radius",
            "1e-300",
        ],
        d,
    );
    assert!(out.contains("radius 0.000 mm"), "{out}");
    assert!(!out.contains("0000000000"), "{out}");
    // Sweeps: too many values, and values far beyond the travel, said in words and digits.
    let sweep = |poses: &'static str| {
        [
            "map",
            "--machine",
            "5axis-hwang2014",
            "--poses",
            poses,
            "--grid",
            "2x2x2",
            "--device",
            "cpu",
            "--out",
            "s.exr",
        ]
    };
    refused(
        &sweep("C=0:360:0.001"),
        d,
        &["--poses: C is a sweep of more than 65536 values (`0:360:0.001`)"],
    );
    refused(
        &sweep("B=0:1e308:1e307"),
        d,
        &["--poses: B is 1e307°, outside its range"],
    );
}

/// The parts of an error line (`error: A: B: C`) that appear more than once.
fn repeated_parts(stderr: &str) -> Vec<String> {
    let line = stderr.lines().next().unwrap_or_default();
    let parts: Vec<&str> = line.trim_start_matches("error: ").split(": ").collect();
    parts
        .iter()
        .enumerate()
        .filter(|(i, p)| parts[..*i].contains(p))
        .map(|(_, p)| p.to_string())
        .collect()
}

#[test]
fn each_part_of_an_error_is_said_once() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nothere.toml");
    let output = volmap()
        .args(["map", "--machine"])
        .arg(&missing)
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(stderr.matches("exists").count(), 1, "{stderr}");

    let chain = machine_with(dir.path(), "chain.toml", "chain", "chain = \"FYXACFZZ\"");
    let output = volmap()
        .args(["map", "--device", "cpu", "--machine"])
        .arg(&chain)
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(stderr.matches("appears twice").count(), 1, "{stderr}");
    assert_eq!(stderr.matches("chain").count(), 2, "{stderr}"); // the file's name and the key
    assert!(repeated_parts(&stderr).is_empty(), "{stderr}");

    // A sweep over other bad inputs: missing files behind every flag that reads one.
    let nowhere = dir.path().join("nowhere");
    let runs: Vec<Vec<std::ffi::OsString>> = vec![
        vec!["info".into(), missing.clone().into()],
        vec![
            "map".into(),
            "--grid".into(),
            "2x2x2".into(),
            "--device".into(),
            "cpu".into(),
            "--out".into(),
            nowhere.join("f.exr").into(),
        ],
        vec![
            "sample".into(),
            "--exact".into(),
            "--machine".into(),
            "vmc-li2015".into(),
            "--points".into(),
            missing.clone().into(),
        ],
        vec![
            "fit".into(),
            "--machine".into(),
            "vmc-li2015".into(),
            "--measurements".into(),
            missing.clone().into(),
        ],
        vec![
            "compensate".into(),
            "--machine".into(),
            "vmc-li2015".into(),
            "--program".into(),
            missing.clone().into(),
            "--out".into(),
            dir.path().join("o.nc").into(),
        ],
        vec![
            "build".into(),
            "--base".into(),
            "vmc-li2015".into(),
            "--axis".into(),
            format!("X={}", missing.display()).into(),
            "--out".into(),
            dir.path().join("b.toml").into(),
        ],
        vec![
            "features".into(),
            "--machine".into(),
            "vmc-li2015".into(),
            "--part".into(),
            missing.clone().into(),
        ],
        vec!["map".into(), "--grid".into(), "2x2".into()],
    ];
    for args in runs {
        let output = volmap().args(&args).output().unwrap();
        assert_ne!(output.status.code(), Some(0), "{args:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.starts_with("error: "), "{args:?}: {stderr}");
        assert!(repeated_parts(&stderr).is_empty(), "{args:?}: {stderr}");
        assert!(
            stderr.matches("os error 2").count() <= 1,
            "{args:?}: {stderr}"
        );
    }
}
