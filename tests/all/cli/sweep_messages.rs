//! The rest of what the sweep of the command line found (README "Inputs, outputs and their
//! limits"): names given twice, a failed run that left a file, messages that named neither the
//! flag nor the cause, numbers of hundreds of digits, empty list items, values for axes a
//! machine lacks, a travel of nothing, and writers that disagreed on a missing folder.

use super::{refused, succeeds};

/// `base` then `extra`.
fn with<'a>(base: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
    base.iter().chain(extra).copied().collect()
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

const MEASURED_X: &str = "position_mm,EXX_um\n0,0\n500,2\n1000,3\n";

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
fn a_failed_allocation_leaves_no_per_sample_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A tolerance of zero width: the allocated factor could grow without limit.
    std::fs::write(d.join("zero.toml"), "[axes.X]\nEXX = { uniform = 0 }\n").unwrap();
    let budget = |allocate: bool| {
        let mut args = vec![
            "budget",
            "--machine",
            "vmc-li2015",
            "--tolerances",
            "zero.toml",
            "--grid",
            "2x2x2",
            "--device",
            "cpu",
            "--samples",
            "3",
            "--spec",
            "0.1",
            "--per-sample",
            "ps.csv",
        ];
        if allocate {
            args.push("--allocate");
        }
        args
    };
    refused(&budget(true), d, &["--allocate"]);
    assert!(!d.join("ps.csv").exists());
    // Without the allocation the same run writes it.
    succeeds(&budget(false), d);
    assert!(d.join("ps.csv").exists());
}

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
    assert!(out.contains("ISO 230-6 diagonal: (0.0, 0.0, 0.0)"), "{out}");
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
    assert!(out.contains("B=1e-320"), "{out}");
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
    assert!(out.contains("radius 1e-300 mm"), "{out}");
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

#[test]
fn values_for_what_a_machine_lacks_and_a_travel_of_nothing_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G90 G0 X100 Y100 Z100\nG1 X200 F100\nM30\n").unwrap();
    let compensate = |offset: &[&'static str]| {
        with(
            &[
                "compensate",
                "--machine",
                "vmc-li2015",
                "--program",
                "p.nc",
                "--out",
                "c.nc",
            ],
            offset,
        )
    };
    refused(
        &compensate(&["--work-offset", "G54=100,100,100,30,0,0"]),
        d,
        &["--work-offset", "G54 turns A by 30°", "has no A axis"],
    );
    std::fs::write(d.join("offsets.toml"), "G55 = [100, 100, 100, 0, 0, 15]\n").unwrap();
    refused(
        &compensate(&["--work-offset-file", "offsets.toml"]),
        d,
        &["--work-offset-file", "G55 turns C by 15°", "has no C axis"],
    );
    assert!(!d.join("c.nc").exists());
    // Zero for an axis the machine lacks says nothing of it: taken.
    succeeds(&compensate(&["--work-offset", "G54=10,10,10,0,0,0"]), d);

    for range in ["[0.0, 1e-300]", "[0.0, 5e-324]", "[10.0, 10.0005]"] {
        std::fs::write(
            d.join("tiny.toml"),
            format!(
                "name = \"tiny\"\nchain = \"FFXYZ\"\n[axes.X]\nrange = {range}\n[axes.Y]\nrange = [0.0, 100.0]\n[axes.Z]\nrange = [0.0, 100.0]\n"
            ),
        )
        .unwrap();
        refused(
            &[
                "map",
                "--machine",
                "tiny.toml",
                "--grid",
                "2x2x2",
                "--device",
                "cpu",
                "--out",
                "f.exr",
            ],
            d,
            &["tiny.toml", "axes.X.range", "less than 0.001"],
        );
    }
}

#[test]
fn an_output_in_a_folder_that_does_not_exist_is_refused_by_every_writer() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.csv"), "X,Y,Z\n1,2,3\n").unwrap();
    std::fs::write(d.join("tol.toml"), "[axes.X]\nEXX = { uniform = 1e-3 }\n").unwrap();
    let runs: [&[&str]; 5] = [
        &[
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "2x2x2",
            "--device",
            "cpu",
            "--out",
            "nodir/f.exr",
        ],
        &[
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "p.csv",
            "--out",
            "nodir/s.csv",
        ],
        &[
            "plot",
            "grid",
            "--machine",
            "vmc-li2015",
            "--grid",
            "3x3x3",
            "--out",
            "nodir/g.svg",
        ],
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
            "--per-sample",
            "nodir/ps.csv",
        ],
        &[
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--json",
            "nodir/c.json",
        ],
    ];
    for args in runs {
        refused(args, d, &["nodir", "does not exist"]);
        assert!(!d.join("nodir").exists(), "{args:?}");
    }
}

/// Two outputs of one run through a link to one file: one file, refused as two flags naming it.
#[cfg(unix)]
#[test]
fn two_outputs_through_a_link_are_one_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("real")).unwrap();
    std::os::unix::fs::symlink(d.join("real"), d.join("alias")).unwrap();
    std::fs::write(d.join("p.nc"), "G90 G0 X100 Y100 Z100\nG1 X200 F100\nM30\n").unwrap();
    let compensate = |out: &'static str, json: &'static str| {
        [
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "p.nc",
            "--out",
            out,
            "--json",
            json,
        ]
    };
    // The folder through a link, the file not there yet.
    refused(
        &compensate("real/c.nc", "alias/c.nc"),
        d,
        &["--json", "is also the output of --out"],
    );
    // A hard link to a file that is there.
    std::fs::write(d.join("real/old.nc"), "old").unwrap();
    std::fs::hard_link(d.join("real/old.nc"), d.join("hard.nc")).unwrap();
    refused(
        &compensate("real/old.nc", "hard.nc"),
        d,
        &["--json", "is also the output of --out"],
    );
    assert_eq!(std::fs::read_to_string(d.join("hard.nc")).unwrap(), "old");
    succeeds(&compensate("real/c.nc", "alias/c.json"), d);
}
