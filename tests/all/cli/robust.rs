//! A new user's first runs: no noise on a run that went well, a machine named where it matters,
//! unit mistakes refused, each part of an error message said once.

use predicates::prelude::*;

use super::volmap;

/// The embedded example machine's file with the line of `key` replaced by `line`.
fn machine_with(dir: &std::path::Path, name: &str, key: &str, line: &str) -> std::path::PathBuf {
    let output = volmap()
        .args(["machines", "--show", "vmc-li2015"])
        .output()
        .unwrap();
    let text = String::from_utf8(output.stdout).unwrap();
    let prefix = format!("{key} = ");
    assert!(text.lines().any(|l| l.starts_with(&prefix)), "{key}");
    let changed: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with(&prefix) {
                line.to_string()
            } else {
                l.to_string()
            }
        })
        .collect();
    let path = dir.join(name);
    std::fs::write(&path, changed.join("\n")).unwrap();
    path
}

#[test]
fn a_gpu_map_without_a_window_system_prints_no_error() {
    if super::super::common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let output = volmap()
        .args(["map", "--grid", "8x8x8", "--device", "gpu", "--out"])
        .arg(dir.path().join("f.exr"))
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("NODEVICE_SELECT")
        .output()
        .unwrap();
    assert!(output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.to_lowercase().contains("error"), "{stderr}");
}

#[test]
fn commands_that_judge_a_machine_require_it_named() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("p.nc");
    std::fs::write(&program, "G0 X10 Y10 Z10\n").unwrap();
    let fit = dir.path().join("fit.toml");
    std::fs::write(&fit, "estimate = [\"EC0Y\"]\n").unwrap();
    let tolerances = dir.path().join("t.toml");
    std::fs::write(&tolerances, "").unwrap();
    let part = dir.path().join("part.toml");
    std::fs::write(&part, "").unwrap();
    let runs: Vec<Vec<std::ffi::OsString>> = vec![
        vec![
            "compensate".into(),
            "--program".into(),
            program.clone().into(),
            "--out".into(),
            dir.path().join("o.nc").into(),
        ],
        vec!["fit".into(), "--measurements".into(), fit.into()],
        vec![
            "test".into(),
            "positioning".into(),
            "--axis".into(),
            "X".into(),
        ],
        vec![
            "test".into(),
            "circular".into(),
            "--plane".into(),
            "XY".into(),
        ],
        vec!["budget".into(), "--tolerances".into(), tolerances.into()],
    ];
    for args in runs {
        volmap().args(&args).assert().code(2).stderr(
            predicate::str::contains("--machine")
                .and(predicate::str::contains("`volmap machines` lists")),
        );
    }
    assert!(!dir.path().join("o.nc").exists());
    // build names its base machine; features a field or a machine.
    volmap()
        .args(["build", "--axis", "X=x.csv", "--out"])
        .arg(dir.path().join("b.toml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--base"));
    volmap()
        .args(["features", "--part"])
        .arg(&part)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--machine").and(predicate::str::contains("--field")));
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

/// `volmap … | head`: a standard output closed under a command ends it quietly with 141 (128 +
/// SIGPIPE), as Unix tools end, and a full one (`> /dev/full`) with an error and exit 1; never a
/// panic.
#[cfg(unix)]
#[test]
fn a_closed_or_full_standard_output_ends_the_command_without_a_panic() {
    use std::io::Read;
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("p.csv");
    let mut text = String::from("X,Y,Z\n");
    for n in 0..200_000 {
        text += &format!("{},{},{}\n", n % 997, n % 593, n % 487);
    }
    std::fs::write(&points, text).unwrap();
    let volmap = assert_cmd::cargo::cargo_bin("volmap");
    // The values on standard output, the data pipe closed after its first bytes; the text
    // report of `test`, closed before it is read.
    let runs: [Vec<std::ffi::OsString>; 2] = [
        ["sample", "--machine", "vmc-li2015", "--exact", "--points"]
            .iter()
            .map(Into::into)
            .chain([points.clone().into_os_string()])
            .collect(),
        [
            "test",
            "positioning",
            "--machine",
            "gantry-2m",
            "--axis",
            "X",
            "--targets",
            "5000",
        ]
        .iter()
        .map(Into::into)
        .collect(),
    ];
    for args in &runs {
        let mut child = Command::new(&volmap)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut first = [0u8; 16];
        child.stdout.take().unwrap().read_exact(&mut first).unwrap();
        let output = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(141), "{args:?}: {stderr}");
        assert!(stderr.is_empty(), "{args:?}: {stderr}");
    }
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let output = Command::new(&volmap)
        .args(["machines", "--show", "gantry-2m"])
        .stdout(full)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("error: writing to standard output") && !stderr.contains("panicked"),
        "{stderr}"
    );
}
