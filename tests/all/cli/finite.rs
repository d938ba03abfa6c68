//! Results that are not numbers: every output that would hold NaN or an infinity is an error
//! naming the input that caused it (exit code 2, nothing written), and every plot of finite
//! values is drawn with finite coordinates and short labels.

use std::path::{Path, PathBuf};

use super::volmap;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
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

/// Exit code 2, the error naming each of `named`, and no panic.
fn assert_refused(cmd: &mut assert_cmd::Command, named: &[&str]) {
    let output = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    for n in named {
        assert!(stderr.contains(n), "`{n}` not named in {stderr}");
    }
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
fn inputs_that_leave_no_number_are_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.exr");
    // A temperature no thermal term survives, refused before anything is computed (more than
    // 200 K from the reference).
    assert_refused(
        volmap()
            .args([
                "map",
                "--machine",
                "gantry-2m",
                "--grid",
                "4x4x4",
                "--device",
                "cpu",
            ])
            .args(["--temperatures", "x_scale=1e308", "--out", s(&out)]),
        &["--temperatures", "x_scale=1e308", "more than 200 K"],
    );
    assert!(!out.exists());
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    assert_refused(
        volmap()
            .args([
                "test",
                "positioning",
                "--axis",
                "X",
                "--machine",
                "gantry-2m",
            ])
            .args(["--temperatures", "x_scale=1e308"]),
        &["--temperatures", "more than 200 K"],
    );
    assert_refused(
        volmap()
            .args([
                "map",
                "--machine",
                "gantry-2m",
                "--grid",
                "4x4x4",
                "--device",
                "cpu",
            ])
            .args(["--temperatures", "x_scale=-300", "--out", s(&out)]),
        &["--temperatures", "absolute zero"],
    );
    // Positions far beyond the travel.
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n100,100,100\n1.7e308,1.7e308,1.7e308\n").unwrap();
    let sampled = dir.path().join("s.csv");
    assert_refused(
        volmap()
            .args([
                "sample",
                "--machine",
                "vmc-li2015",
                "--exact",
                "--points",
                s(&points),
            ])
            .args(["--out", s(&sampled)]),
        &["--points", "line 3"],
    );
    assert!(!sampled.exists());
    let program = dir.path().join("p.nc");
    std::fs::write(&program, "G0 X10 Y10 Z10\nG1 X500 Y300 Z200 F1000\n").unwrap();
    assert_refused(
        volmap()
            .args(["trace", "--machine", "vmc-li2015", "--program", s(&program)])
            .args(["--work-offset", "G54=1e308,0,0"]),
        &[
            "p.nc",
            "line 1",
            "X=1e308 (machine), outside the travel of X",
        ],
    );
    let part = dir.path().join("part.toml");
    std::fs::write(
        &part,
        "name = \"p\"\n[placement]\nzero_mm = [1e300, 0.0, 0.0]\n[cutter]\nradius_mm = 8.0\n\
         length_mm = 60.0\n[[features]]\nkind = \"hole\"\nname = \"h\"\n\
         centre_mm = [50.0, 100.0, -20.0]\ndiameter_mm = 20.0\ndepth_mm = 30.0\n\
         tolerance_mm = 0.04\n",
    )
    .unwrap();
    assert_refused(
        volmap().args(["features", "--machine", "vmc-li2015", "--part", s(&part)]),
        &["part.toml", "`h`", "zero_mm"],
    );
}

#[test]
fn plot_values_that_are_not_numbers_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    for scale in ["nan", "inf", "-5", "0"] {
        let svg = dir.path().join("g.svg");
        let scale_flag = format!("--scale={scale}");
        assert_refused(
            volmap().args([
                "plot",
                "grid",
                "--grid",
                "3x3x3",
                &scale_flag,
                "--out",
                s(&svg),
            ]),
            &["--scale"],
        );
        assert!(!svg.exists(), "{scale}");
    }
    let field = dir.path().join("f.exr");
    volmap()
        .args([
            "map",
            "--grid",
            "5x5x5",
            "--device",
            "cpu",
            "--out",
            s(&field),
        ])
        .assert()
        .success();
    for at in ["nan", "inf", "-inf"] {
        let svg = dir.path().join("s.svg");
        assert_refused(
            volmap().args([
                "plot",
                "slice",
                "--field",
                s(&field),
                "--at",
                at,
                "--out",
                s(&svg),
            ]),
            &["--at"],
        );
        assert!(!svg.exists());
    }
}

/// An SVG written by a command: no NaN or infinity anywhere, no label longer than 16 characters.
fn assert_finite_svg(path: &Path) {
    let svg = std::fs::read_to_string(path).unwrap();
    let words = svg.split(|c: char| !(c.is_alphanumeric() || c == '-' || c == '.'));
    for word in words {
        let word = word.trim_start_matches('-');
        assert!(word != "NaN" && word != "inf", "{path:?}: {word}");
    }
    for label in svg.split("<text").skip(1) {
        let text = label.split('>').nth(1).unwrap().split('<').next().unwrap();
        if text.parse::<f64>().is_ok() {
            assert!(text.chars().count() <= 16, "label `{text}`");
        }
    }
}

#[test]
fn test_plots_of_extreme_finite_measurements_are_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let measured = dir.path().join("d.csv");
    std::fs::write(
        &measured,
        "position_mm,deviation_mm\n0,0\n5e-324,5e-324\n1e-323,1e-323\n",
    )
    .unwrap();
    let (svg, png) = (dir.path().join("d.svg"), dir.path().join("d.png"));
    volmap()
        .args([
            "test",
            "diagonal",
            "--machine",
            "vmc-li2015",
            "--diagonal",
            "PPP",
        ])
        .args([
            "--measured",
            s(&measured),
            "--plot",
            s(&svg),
            "--plot",
            s(&png),
        ])
        .assert()
        .success();
    assert_finite_svg(&svg);
    assert!(png.exists());
    // An R-test measured file with a sweep of 20° and values from subnormal to 1e9 mm.
    let rtest = dir.path().join("r.csv");
    std::fs::write(
        &rtest,
        "angle_deg,dX_mm,dY_mm,dZ_mm\n270,0,0,0\n280,1e9,-1e9,5e-324\n290,0,0,1e-320\n",
    )
    .unwrap();
    let args = [
        "test",
        "rtest",
        "--machine",
        "5axis-hwang2014",
        "--axis",
        "C",
    ];
    volmap()
        .args(args)
        .args([
            "--sphere",
            "200,0,100",
            "--measured",
            s(&rtest),
            "--plot",
            s(&svg),
        ])
        .assert()
        .success();
    assert_finite_svg(&svg);
    // Beyond any measurement: the file and line named, not a plot of infinities.
    std::fs::write(
        &rtest,
        "angle_deg,dX_mm,dY_mm,dZ_mm\n270,0,0,0\n280,1e308,-1e308,0\n290,0,0,0\n",
    )
    .unwrap();
    let output = volmap()
        .args(args)
        .args([
            "--sphere",
            "200,0,100",
            "--measured",
            s(&rtest),
            "--plot",
            s(&svg),
        ])
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("r.csv") && stderr.contains("line 3"),
        "{stderr}"
    );
}

#[test]
fn a_field_slice_of_subnormal_spacing_is_drawn_or_refused_never_a_panic() {
    use volmap::engine::map::{map_to_file, MapOptions};
    use volmap::engine::Engine;
    use volmap::model::grid::Grid;
    let dir = tempfile::tempdir().unwrap();
    let machine = volmap::io::embedded::load("vmc-li2015").unwrap();
    let grid = Grid {
        dims: [4, 3, 3],
        origin_mm: [0.0, 0.0, 0.0],
        spacing_mm: [5e-324, 1e-323, 100.0],
        pose: [0.0; 6],
    };
    let field = dir.path().join("f.exr");
    map_to_file(
        &machine,
        &grid,
        &Engine::Cpu,
        &field,
        &MapOptions::default(),
        |_| {},
    )
    .unwrap();
    for normal in ["x", "y", "z"] {
        let svg = dir.path().join(format!("{normal}.svg"));
        let output = volmap()
            .args(["plot", "slice", "--field", s(&field), "--normal", normal])
            .args(["--out", s(&svg)])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        match output.status.code() {
            Some(0) => assert_finite_svg(&svg),
            // A reader that refuses such a spacing says so.
            Some(2) => assert!(stderr.contains("spacing"), "{stderr}"),
            code => panic!("{normal}: exit {code:?}: {stderr}"),
        }
    }
}
