//! The values flags take, on every command: counts and values that would abort, loop for ever
//! or give output that is not a number are bounded (exit 2 naming the flag); a name given twice,
//! an empty list item or a bare value beside named ones is refused, not taken silently.

use super::{refused, s, succeeds, volmap, with};

/// Measured positioning errors of X, as `build --axis` reads them.
pub const MEASURED_X: &str = "position_mm,EXX_um\n0,0\n500,2\n1000,3\n";

/// Counts and values that made an abort, an endless loop or output that is not a number.
#[test]
fn unbounded_values_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 5000³ points of residual grid: an allocation of 3 TB and an abort.
    refused(
        &[
            "export",
            "--machine",
            "vmc-li2015",
            "--format",
            "grid-csv",
            "--out",
            "e.csv",
            "--points",
            "3",
            "--residual-grid",
            "5000",
        ],
        d,
        &["--residual-grid", "at most 201"],
    );
    assert!(!d.join("e.csv").exists());
    // A pitch whose phase overflows: an endless cyclic-error fit.
    refused(
        &[
            "test",
            "circular",
            "--plane",
            "XY",
            "--machine",
            "vmc-li2015",
            "--points",
            "16",
            "--pitch",
            "1e-308",
        ],
        d,
        &["pitch", "between 0.001 and 1e6 mm"],
    );
    // No reference points: NaN and inf in the benchmark's table.
    refused(
        &["bench", "--reference-points", "0"],
        d,
        &["--reference-points"],
    );
    // An infinite chord tolerance, printed as `inf mm`.
    std::fs::write(d.join("p.nc"), "G90 G0 X0 Y0 Z10\nG1 X50 F500\nM30\n").unwrap();
    for value in ["inf", "1e400", "1e7"] {
        refused(
            &[
                "compensate",
                "--machine",
                "vmc-li2015",
                "--program",
                "p.nc",
                "--out",
                "c.nc",
                "--work-offset",
                "G54=100,100,100",
                "--chord-tolerance",
                value,
            ],
            d,
            &["--chord-tolerance", "at most 1000000 mm"],
        );
    }
    // A thousand trillion degrees: VE of 1e13 mm with exit 0.
    std::fs::write(d.join("q.csv"), "X,Y,Z\n100,100,100\n").unwrap();
    refused(
        &[
            "sample",
            "--exact",
            "--machine",
            "gantry-2m",
            "--points",
            "q.csv",
            "--temperatures",
            "hall=1e15",
        ],
        d,
        &[
            "--temperatures",
            "more than 200 K from the machine's reference_C (20 °C)",
        ],
    );
    volmap()
        .args([
            "sample",
            "--exact",
            "--machine",
            "gantry-2m",
            "--points",
            "q.csv",
            "--temperatures",
            "hall=210",
        ])
        .current_dir(d)
        .assert()
        .success();
    // A reference temperature below absolute zero, or of 309 digits.
    let machine = String::from_utf8(
        volmap()
            .args(["machines", "--show", "gantry-2m"])
            .output()
            .unwrap()
            .stdout,
    )
    .unwrap();
    assert!(
        machine.contains("reference_C = 20.0"),
        "the embedded gantry's thermal section"
    );
    for value in ["-300", "1e308"] {
        std::fs::write(
            d.join("g.toml"),
            machine.replace("reference_C = 20.0", &format!("reference_C = {value}")),
        )
        .unwrap();
        refused(
            &[
                "sample",
                "--exact",
                "--machine",
                "g.toml",
                "--points",
                "q.csv",
            ],
            d,
            &["g.toml", "thermal.reference_C", "between absolute zero"],
        );
    }
}

/// Tool lengths of 1e12 mm gave deviations of 2e7 mm; two bare lengths, a bare one beside
/// per-tool ones, an empty item or a tool twice were taken silently.
#[test]
fn tool_lengths_are_bounded_and_unambiguous() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G90 G0 X0 Y0 Z10\nG1 X50 F500\nM30\n").unwrap();
    let trace = |lengths: &str| -> Vec<String> {
        [
            "trace",
            "--machine",
            "vmc-li2015",
            "--program",
            "p.nc",
            "--work-offset",
            "G54=100,100,100",
            "--tool-length",
            lengths,
        ]
        .map(String::from)
        .to_vec()
    };
    for (lengths, says) in [
        ("1e12", "is not a length of at most 1000000 mm"),
        ("1,500", "one length for every tool stands alone"),
        ("500,T1=1", "one length for every tool stands alone"),
        (",500", "an empty item"),
        ("T1=5,T1=6", "T1 is given twice"),
    ] {
        let args = trace(lengths);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&args, d, &["--tool-length", says]);
    }
    let args = trace("120");
    volmap().args(&args).current_dir(d).assert().success();
}

/// One work offset given twice, or two outputs of one run on one file, were taken silently (the
/// last won).
#[test]
fn a_work_offset_twice_and_two_outputs_on_one_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G90 G0 X0 Y0 Z10\nG1 X50 F500\nM30\n").unwrap();
    let base = [
        "compensate",
        "--machine",
        "vmc-li2015",
        "--program",
        "p.nc",
        "--out",
        "c.nc",
    ];
    let with =
        |more: &[&'static str]| -> Vec<&'static str> { base.iter().chain(more).copied().collect() };
    refused(
        &with(&[
            "--work-offset",
            "G54=100,100,100",
            "--work-offset",
            "G54=0,0,0",
        ]),
        d,
        &["--work-offset: G54 is given twice"],
    );
    std::fs::write(d.join("o.toml"), "G54 = [100.0, 100.0, 100.0]\n").unwrap();
    refused(
        &with(&["--work-offset-file", "o.toml", "--work-offset", "G54=0,0,0"]),
        d,
        &["G54 is given twice (here or in --work-offset-file)"],
    );
    refused(
        &with(&["--work-offset", "G54=100,100,100", "--json", "c.nc"]),
        d,
        &["--json", "is also the output of --out"],
    );
    assert!(!d.join("c.nc").exists());
    volmap()
        .args(with(&[
            "--work-offset",
            "G54=100,100,100",
            "--json",
            "c.json",
        ]))
        .current_dir(d)
        .assert()
        .success();
}

#[test]
fn a_name_given_twice_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("x.csv"), MEASURED_X).unwrap();
    let build =
        |extra: &[&'static str]| with(&["build", "--base", "vmc-li2015", "--out", "b.toml"], extra);
    refused(
        &build(&["--axis", "X=x.csv", "--axis", "X=x.csv"]),
        d,
        &["--axis", "X is given twice"],
    );
    refused(
        &build(&["--axis", "X=x.csv", "--interp", "EXX=linear,EXX=cubic"]),
        d,
        &["--interp", "EXX is given twice"],
    );
    assert!(!d.join("b.toml").exists());
    // The same measurements once each build a machine.
    succeeds(&build(&["--axis", "X=x.csv", "--interp", "EXX=linear"]), d);

    std::fs::write(
        d.join("tol.toml"),
        "[axes.X]\nEXX = { uniform = 1e-3 }\nEYX = { uniform = 1e-3 }\n",
    )
    .unwrap();
    for terms in ["EXX,EXX", "EXX,axes.X.EXX"] {
        refused(
            &[
                "budget",
                "--machine",
                "vmc-li2015",
                "--tolerances",
                "tol.toml",
                "--grid",
                "2x2x2",
                "--device",
                "cpu",
                "--samples",
                "3",
                "--spec",
                "0.1",
                "--allocate",
                "--allocate-terms",
                terms,
            ],
            d,
            &["--allocate-terms", "names a term already named"],
        );
    }

    // A table of two axes that names one of them twice.
    std::fs::write(
        d.join("t2.toml"),
        "name = \"t2\"\nchain = \"FFXYZ\"\n[axes.X]\nrange = [0.0, 100.0]\n[axes.Y]\nrange = [0.0, 100.0]\n\
         EZY = { table2d = { of = [\"Y\", \"Y\"], x = [0.0, 100.0], y = [0.0, 100.0], values = [[0.0, 1e-3], [1e-3, 2e-3]] } }\n\
         [axes.Z]\nrange = [0.0, 100.0]\n",
    )
    .unwrap();
    refused(
        &[
            "map",
            "--machine",
            "t2.toml",
            "--grid",
            "2x2x2",
            "--device",
            "cpu",
            "--out",
            "f.exr",
        ],
        d,
        &["t2.toml", "axes.Y.EZY", "of", "names Y twice"],
    );
    assert!(!d.join("f.exr").exists());
}

#[test]
fn empty_list_items_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let map = |flag: &str, value: &str, machine: &str| {
        vec![
            "map".to_string(),
            "--machine".into(),
            machine.into(),
            "--grid".into(),
            "2x2x2".into(),
            "--device".into(),
            "cpu".into(),
            "--out".into(),
            "f.exr".into(),
            flag.into(),
            value.into(),
        ]
    };
    for (flag, value, machine) in [
        ("--pose", "B=30,", "5axis-hwang2014"),
        ("--pose", ",B=30", "5axis-hwang2014"),
        ("--pose", "B=30,,C=10", "5axis-hwang2014"),
        ("--temperatures", "x_scale=25,", "gantry-2m"),
        ("--approach", "X=-,", "vmc-li2015"),
    ] {
        let args = map(flag, value, machine);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&args, d, &[flag]);
        assert!(!d.join("f.exr").exists());
        // Without the empty item the value is taken.
        let clean = value.trim_matches(',').replace(",,", ",");
        let args = map(flag, &clean, machine);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        succeeds(&args, d);
        std::fs::remove_file(d.join("f.exr")).unwrap();
    }
}

/// The limits of the counts `refusals` refuses beyond are themselves taken: a positioning test
/// of 100,000 targets and 100 runs, a compensation written with 15 decimals (more than 9 on the
/// compensated G0).
#[test]
fn counts_at_their_limits_are_taken() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("p.nc");
    std::fs::write(&program, "G0 X10 Y10 Z10\nG1 X500 Y300 Z200 F1000\n").unwrap();
    let out = dir.path().join("o.nc");
    let li = ["--machine", "vmc-li2015"];
    // The limits themselves pass.
    volmap()
        .args([
            "test",
            "positioning",
            "--axis",
            "X",
            "--targets",
            "100000",
            "--runs",
            "100",
        ])
        .args(li)
        .assert()
        .success();
    volmap()
        .args([
            "compensate",
            "--program",
            s(&program),
            "--out",
            s(&out),
            "--decimals",
            "15",
        ])
        .args(li)
        .assert()
        .success();
    // The coordinates of the compensated G0 are written with more than 9 decimals.
    let text = std::fs::read_to_string(&out).unwrap();
    let decimals = |word: &str| word.split('.').nth(1).map_or(0, str::len);
    assert!(
        text.split_whitespace()
            .any(|w| w.starts_with('X') && decimals(w) > 9),
        "{text}"
    );
}
