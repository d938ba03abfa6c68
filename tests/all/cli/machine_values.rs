//! What a machine can take, on every command: values beyond any machine tool (errors, travels,
//! offsets, angles no machine has) refused naming the key on every device; columns, poses,
//! work offsets and positions for axes the machine lacks or beyond its travel refused naming
//! the file or flag; a name with control characters, a travel of nothing refused.

use std::path::{Path, PathBuf};

use predicates::prelude::*;

use super::{assert_refused, machine_with, refused, s, succeeds, volmap, with};

#[test]
fn values_a_machine_cannot_take_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fn sample<'a>(points: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
        [&["sample", "--exact", "--points", points][..], extra].concat()
    }
    // A rotary column for an axis the machine lacks; an axis named twice in a pose; a pose
    // for an axis the machine lacks.
    std::fs::write(d.join("b.csv"), "X,Y,Z,B\n10,10,10,30\n").unwrap();
    refused(
        &sample("b.csv", &["--machine", "vmc-li2015"]),
        d,
        &["b.csv: line 1: column B: the machine (chain FFXYZ) has no B axis"],
    );
    std::fs::write(d.join("p.csv"), "X,Y,Z\n10,10,10\n").unwrap();
    refused(
        &sample(
            "p.csv",
            &["--machine", "5axis-hwang2014", "--pose", "B=30,B=40"],
        ),
        d,
        &["--pose: B is named twice"],
    );
    refused(
        &sample("p.csv", &["--machine", "vmc-li2015", "--pose", "A=5"]),
        d,
        &["--pose: A is not an axis of this machine"],
    );
    // A column named twice, in each kind of CSV.
    std::fs::write(d.join("dup.csv"), "X,Y,Z,id,id\n10,10,10,a,b\n").unwrap();
    refused(
        &sample("dup.csv", &["--machine", "vmc-li2015"]),
        d,
        &["dup.csv: line 1: column `id` appears twice (columns 4 and 5)"],
    );
    std::fs::write(
        d.join("m.csv"),
        "angle_deg,deviation_mm,deviation_mm\n0,0,0\n",
    )
    .unwrap();
    refused(
        &[
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--measured",
            "m.csv",
        ],
        d,
        &["m.csv: line 1: column `deviation_mm` appears twice"],
    );
    std::fs::write(
        d.join("x.csv"),
        "position_mm,EXX_um,EXX_um\n0,0,0\n1000,1,1\n",
    )
    .unwrap();
    refused(
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=x.csv",
            "--out",
            "o.toml",
        ],
        d,
        &["x.csv: line 1: column `EXX_um` appears twice"],
    );
    // A tool number beyond what a control holds.
    std::fs::write(
        d.join("t.nc"),
        "G0 X10 Y10 Z10\nT4294967296 M6\nG1 X20 F100\n",
    )
    .unwrap();
    refused(
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "t.nc",
            "--out",
            "o.nc",
        ],
        d,
        &["t.nc: line 2: `T4294967296`: a tool number is a whole number from 0 to 4294967295"],
    );
    // Positions beyond the travel with --exact (as with a field), unless --outside says.
    std::fs::write(d.join("far.csv"), "X,Y,Z\n10,10,10\n2000,10,10\n").unwrap();
    refused(
        &sample("far.csv", &["--machine", "vmc-li2015"]),
        d,
        &["far.csv: line 3: X=2000 lies outside the machine's travel (0 to 1000)"],
    );
    let skipped = succeeds(
        &sample("far.csv", &["--machine", "vmc-li2015", "--outside", "skip"]),
        d,
    );
    assert_eq!(skipped.lines().count(), 2, "{skipped}");
    // Part features beyond the travel, and a part pose for an axis the machine lacks.
    let part = |zero: &str, pose: &str| {
        format!("name = \"p\"\n[placement]\nzero_mm = {zero}\n{pose}\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 5.0\n[[features]]\nkind = \"end_milled_plane\"\nname = \"floor\"\ncorner_mm = [0.0, 0.0, 0.0]\nsize_mm = [100.0, 50.0]\ntolerance_mm = 0.05\n")
    };
    std::fs::write(d.join("far.toml"), part("[950.0, 100.0, 100.0]", "")).unwrap();
    refused(&["features", "--machine", "vmc-li2015", "--part", "far.toml"], d, &["far.toml: feature `floor`: the cutter position X=1005 mm lies outside the travel of X (0 to 1000)"]);
    std::fs::write(
        d.join("posed.toml"),
        part("[100.0, 100.0, 100.0]", "pose_deg = { B = 30.0 }"),
    )
    .unwrap();
    refused(&["features", "--machine", "vmc-li2015", "--part", "posed.toml"], d, &["posed.toml: feature `(placement)`: pose_deg: B=30°, but the machine (chain FFXYZ) has no B axis"]);
    std::fs::write(d.join("near.toml"), part("[100.0, 100.0, 100.0]", "")).unwrap();
    volmap()
        .current_dir(d)
        .args(["features", "--machine", "vmc-li2015", "--part", "near.toml"])
        .assert()
        .success()
        .stdout(predicate::str::contains("floor"));
}

/// The embedded vmc-li2015's file with the first line starting with `prefix` replaced by `line`.
fn li_with(dir: &Path, name: &str, prefix: &str, line: &str) -> PathBuf {
    let output = volmap()
        .args(["machines", "--show", "vmc-li2015"])
        .output()
        .unwrap();
    let text = String::from_utf8(output.stdout).unwrap();
    let at = text.find(&format!("\n{prefix}")).expect(prefix) + 1;
    let end = at + text[at..].find('\n').unwrap();
    let changed = format!("{}{line}{}", &text[..at], &text[end..]);
    let path = dir.join(name);
    std::fs::write(&path, changed).unwrap();
    path
}

#[test]
fn machine_values_beyond_any_machine_are_refused_naming_the_key_on_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        (
            li_with(d, "poly.toml", "EXX", "EXX = { poly = [1e300] }"),
            "axes.X.EXX",
        ),
        (
            li_with(d, "grow.toml", "EXX", "EXX = { poly = [0.0, 1e300] }"),
            "axes.X.EXX",
        ),
        (
            li_with(d, "tool.toml", "offset", "offset = [0.0, 0.0, 1e308]"),
            "tool.offset",
        ),
        (
            li_with(d, "range.toml", "range", "range = [-1e308, 1e308]"),
            "axes.X.range",
        ),
        (
            li_with(d, "angle.toml", "EBX", "EBX = { poly = [0.0, 1e300] }"),
            "axes.X.EBX",
        ),
    ];
    let gpu = super::super::common::gpu().is_some();
    let out = d.join("f.exr");
    for (machine, key) in &cases {
        for device in if gpu {
            ["cpu", "gpu"].as_slice()
        } else {
            ["cpu"].as_slice()
        } {
            assert_refused(
                volmap()
                    .args([
                        "map",
                        "--grid",
                        "4x4x4",
                        "--device",
                        device,
                        "--out",
                        s(&out),
                    ])
                    .args(["--machine", s(machine)]),
                &[key, "--machine"],
            );
        }
        assert_refused(
            volmap()
                .args(["test", "positioning", "--axis", "Y"])
                .args(["--machine", s(machine)]),
            &[key],
        );
    }
    assert!(!out.exists());
    // A kilometre of travel is the most a machine file may say.
    let km = d.join("km.toml");
    std::fs::write(
        &km,
        "name = \"km\"\nchain = \"FFXYZ\"\n[axes.X]\nrange = [0.0, 1e6]\nEXX = 0.01\n\
         [axes.Y]\nrange = [-1e6, 0.0]\n[axes.Z]\nrange = [0.0, 500.0]\n[tool]\n\
         offset = [0.0, 0.0, -1e6]\n",
    )
    .unwrap();
    volmap()
        .args([
            "map",
            "--grid",
            "4x4x4",
            "--device",
            "cpu",
            "--out",
            s(&out),
        ])
        .args(["--machine", s(&km)])
        .assert()
        .success();
    // Tolerances as wide.
    let tolerances = d.join("t.toml");
    std::fs::write(&tolerances, "[axes.X]\nEXX = { uniform = 1e300 }\n").unwrap();
    assert_refused(
        volmap()
            .args(["budget", "--machine", "vmc-li2015", "--grid", "3x3x3"])
            .args(["--tolerances", s(&tolerances)]),
        &["--tolerances", "axes.X.EXX"],
    );
}

#[test]
fn angular_errors_no_machine_has_are_refused_on_every_device() {
    let dir = tempfile::tempdir().unwrap();
    // 15 rad: degrees or µrad written as rad.
    let constant = machine_with(dir.path(), "c.toml", "EAX", "EAX = 15.0");
    // 2e-5 rad/mm over 1000 mm of X: 0.02 rad at the end of the travel.
    let sloped = machine_with(
        dir.path(),
        "s.toml",
        "EBX",
        "EBX = { poly = [0.0, 2.0e-5] }",
    );
    let gpu = super::super::common::gpu().is_some();
    let devices: &[&str] = if gpu { &["cpu", "gpu"] } else { &["cpu"] };
    for device in devices {
        for (machine, key, said) in [
            (&constant, "axes.X.EAX", "15.0000 rad"),
            (&sloped, "axes.X.EBX", "0.0200 rad at X=1000.000 mm"),
        ] {
            volmap()
                .args(["map", "--grid", "4x4x4", "--device", device, "--machine"])
                .arg(machine)
                .arg("--out")
                .arg(dir.path().join("f.exr"))
                .assert()
                .code(2)
                .stderr(predicate::str::contains(key).and(predicate::str::contains(said)));
        }
    }
    assert!(!dir.path().join("f.exr").exists());
    // Thermal terms count at a plausible temperature change: 3e-4 rad/K over 50 K is 0.015 rad.
    let thermal = machine_with(
        dir.path(),
        "t.toml",
        "EC0Y",
        "EC0Y = { value = 0.0, per_kelvin = { hall = 3.0e-4 } }",
    );
    let text = std::fs::read_to_string(&thermal).unwrap();
    std::fs::write(&thermal, text + "\n[thermal]\ninputs = [\"hall\"]\n").unwrap();
    volmap()
        .args(["test", "positioning", "--axis", "X", "--machine"])
        .arg(&thermal)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("axes.Y.EC0Y"));
    // 0.005 rad at the end of the travel is large but real.
    let large = machine_with(
        dir.path(),
        "l.toml",
        "EBX",
        "EBX = { poly = [0.0, 5.0e-6] }",
    );
    for device in devices {
        volmap()
            .args(["map", "--grid", "4x4x4", "--device", device, "--machine"])
            .arg(&large)
            .arg("--out")
            .arg(dir.path().join("f.exr"))
            .assert()
            .success();
    }
}

/// A machine's name with terminal escapes or a NUL was printed whole in every summary.
#[test]
fn a_machine_name_with_control_characters_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("q.csv"), "X,Y,Z\n1,1,1\n").unwrap();
    let machine = "chain = \"FFXYZ\"\n[axes.X]\nrange = [0.0, 10.0]\n[axes.Y]\nrange = [0.0, 10.0]\n[axes.Z]\nrange = [0.0, 10.0]\n";
    for name in ["\\u001b[31mred", "a\\u0000b", &"n".repeat(201)] {
        std::fs::write(d.join("m.toml"), format!("name = \"{name}\"\n{machine}")).unwrap();
        refused(
            &[
                "sample",
                "--exact",
                "--machine",
                "m.toml",
                "--points",
                "q.csv",
            ],
            d,
            &["m.toml", "name", "without control characters"],
        );
    }
    std::fs::write(d.join("m.toml"), format!("name = \"plain\"\n{machine}")).unwrap();
    volmap()
        .args([
            "sample",
            "--exact",
            "--machine",
            "m.toml",
            "--points",
            "q.csv",
        ])
        .current_dir(d)
        .assert()
        .success();
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
