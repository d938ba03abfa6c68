//! The limits of `budget` (issue 33): the machine-points of a Monte Carlo run bounded before any
//! work and the time of a long run said when it starts; the same answer from every device for
//! what the GPU's kernels cannot take (checked before the device is chosen); allocations that
//! stop at the widest tolerance a file may give and write only what volmap reads back; a
//! machine's thermal terms checked at the run's temperatures; numbers and shares in messages.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::{refused, s, volmap};
use crate::common::gpu;

fn example(machine: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/tolerances")
        .join(format!("{machine}.toml"))
}

/// The tolerances a tolerance file gives (its lines `KEY = { … }`).
fn terms(path: &Path) -> u64 {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.trim_start().starts_with('E') && l.contains("= {"))
        .count() as u64
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The devices a test runs on: the CPU engine, and the GPU where there is an adapter.
fn devices() -> Vec<&'static str> {
    let mut devices = vec!["cpu"];
    if gpu().is_some() {
        devices.push("gpu");
    }
    devices
}

fn assert_no_long_number(text: &str) {
    let longest = text
        .split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0);
    assert!(longest < 25, "a number of {longest} digits in: {text}");
}

#[test]
fn a_monte_carlo_run_beyond_the_machine_points_limit_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    // 14 terms on vmc-li2015 (counted from the file): (1,000,000 + 14) machines × 3000·2000·1000
    // = 6e9 points × 1 pose = 6.000084e15 > 5e15.
    let tolerances = example("vmc-li2015");
    let t = terms(&tolerances);
    let expected = (1_000_000 + t) as f64 * 6e9;
    let start = Instant::now();
    let stderr = refused(
        &[
            "budget",
            "--machine",
            "vmc-li2015",
            "--tolerances",
            s(&tolerances),
            "--grid",
            "3000x2000x1000",
            "--samples",
            "1000000",
        ],
        dir.path(),
        &[
            "--samples, --grid, --poses",
            "6000000000 grid points × 1 poses",
            &format!("{expected:.3e} machine-points"),
            "the limit of 5.000e15",
        ],
    );
    assert!(start.elapsed() < Duration::from_secs(20), "{stderr}");
    // A sweep: 400³ = 6.4e7 points × (B 0..90 by 1: 91) × (C 0..350 by 10: 36) = 3276 poses ×
    // (30,000 + terms) machines, above 5e15; 20,000 machines would be 4.2e15, below it.
    let tolerances = example("5axis-hwang2014");
    let t = terms(&tolerances);
    let expected = (30_000 + t) as f64 * 6.4e7 * 3276.0;
    assert!(expected > 5e15);
    refused(
        &[
            "budget",
            "--machine",
            "5axis-hwang2014",
            "--tolerances",
            s(&tolerances),
            "--grid",
            "400x400x400",
            "--poses",
            "B=0:90:1,C=0:350:10",
            "--samples",
            "30000",
            "--device",
            "cpu",
        ],
        dir.path(),
        &[
            "× 3276 poses",
            &format!("{expected:.3e} machine-points"),
            &format!("({t} terms + 30000 machines drawn)"),
        ],
    );
}

#[test]
fn a_long_run_says_how_long_it_will_take_once_it_has_measured_its_rate() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("stderr.txt");
    // 1,000,000 machines of 21³ = 9261 points: 9.3e9 machine-points, minutes at the CPU
    // engine's rate of about 1e8 a second in a release build, longer in a debug one.
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("volmap"))
        .args(["budget", "--machine", "vmc-li2015", "--tolerances"])
        .arg(example("vmc-li2015"))
        .args([
            "--grid",
            "21x21x21",
            "--samples",
            "1000000",
            "--device",
            "cpu",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let said = loop {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        if text.contains("will take about") || start.elapsed() > Duration::from_secs(120) {
            break text;
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("ended before saying its time: {status}: {text}");
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        said.contains("volmap: sampling 1000000 machines will take about")
            && said.contains("machine-points/s"),
        "{said}"
    );
}

/// A machine without errors along FFXYZ, so that its own angles add nothing.
const NO_ERRORS: &str = r#"
name = "no errors"
chain = "FFXYZ"
[axes.X]
range = [0.0, 800.0]
[axes.Y]
range = [0.0, 600.0]
[axes.Z]
range = [0.0, 400.0]
"#;

/// 12 angular tolerances of 1e-4 rad: 10 uniform, 2 normal.
const TWELVE_ANGLES: &str = r#"
[axes.X]
EAX = { uniform = 1e-4 }
EBX = { uniform = 1e-4 }
ECX = { uniform = 1e-4 }
[axes.Y]
EAY = { uniform = 1e-4 }
EBY = { uniform = 1e-4 }
ECY = { uniform = 1e-4 }
EA0Y = { uniform = 1e-4 }
EB0Y = { uniform = 1e-4 }
EC0Y = { uniform = 1e-4 }
[axes.Z]
EAZ = { normal = 1e-4 }
EBZ = { normal = 1e-4 }
ECZ = { uniform = 1e-4 }
"#;

fn allocation(json: &Path) -> serde_json::Value {
    super::json_result(json)["allocation"].clone()
}

#[test]
fn every_device_allocates_up_to_the_angles_the_kernels_take_and_the_file_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let machine = write(dir.path(), "m.toml", NO_ERRORS);
    let tolerances = write(dir.path(), "t.toml", TWELVE_ANGLES);
    // Each machine drawn has at most 10·h + 2·8.7σ = 27.4e-4 rad per unit of the factor (8.7σ:
    // the farthest a Box–Muller draw of 53-bit uniforms reaches), the machine none: the factor
    // stops at 0.1 / 27.4e-4 = 36.49635 (below the widths' own limit, 0.01 / 1e-4 = 100). A
    // spec of 10 m holds on every machine, so the factor is the ceiling's on every device.
    let mut factors = Vec::new();
    for device in devices() {
        let json = dir.path().join(format!("{device}.json"));
        let out = dir.path().join(format!("{device}.toml"));
        let output = volmap()
            .args(["budget", "--machine", s(&machine), "--tolerances"])
            .arg(&tolerances)
            .args(["--grid", "3x3x3", "--samples", "30", "--spec", "10000"])
            .args(["--allocate", "--device", device, "--json", s(&json)])
            .args(["--out", s(&out)])
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert!(
            output.status.success(),
            "{device}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        assert!(stdout.contains("stopped where the machines drawn could reach 0.1 rad"));
        let a = allocation(&json);
        assert_eq!(a["stopped_at_angle_limit"], true, "{a}");
        let factor = a["factor"].as_f64().unwrap();
        // The ceiling is bisected to f64 resolution, 1e-9 below the limit: 1e-6 relative.
        assert!(
            (factor - 0.1 / 27.4e-4).abs() < 1e-6 * factor,
            "{device}: {factor}"
        );
        factors.push(factor);
        // 1e-4 × 36.49635 = 3.649635e-3 rad, written to 6 significant digits.
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(text.contains("EAX = { uniform = 0.00364964 }"), "{text}");
        volmap()
            .args(["budget", "--machine", s(&machine), "--tolerances", s(&out)])
            .args(["--grid", "3x3x3", "--device", "cpu"])
            .assert()
            .success();
    }
    assert!(factors.windows(2).all(|w| w[0] == w[1]), "{factors:?}");

    // Beyond what the kernels take before any allocation: 12 angular tolerances of 0.009 rad
    // reach 10·0.009 + 2·8.7·0.009 = 0.2466 rad; every device refuses it alike, as bad input.
    let wide = write(
        dir.path(),
        "wide.toml",
        &TWELVE_ANGLES.replace("1e-4", "0.009"),
    );
    for device in devices() {
        refused(
            &[
                "budget",
                "--machine",
                s(&machine),
                "--tolerances",
                s(&wide),
                "--grid",
                "3x3x3",
                "--samples",
                "10",
                "--device",
                device,
            ],
            dir.path(),
            &[
                "--tolerances",
                "0.2466 rad",
                "below 0.1 rad on every device",
            ],
        );
    }
}

#[test]
fn allocations_stop_at_the_widest_tolerance_a_file_may_give_and_write_what_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let tolerances = example("vmc-li2015");
    // (terms allocated, the terms that stop at 0.01 rad, a width written by hand): EC0Y's
    // 20e-6 rad reaches 0.01 at 500; EBX, ECX and EAY's 10e-6 at 1000. On vmc-li2015 an angle of
    // 0.01 rad moves the tip by millimetres, far inside a spec of 100 mm.
    let cases: [(&str, &[&str], &str); 3] = [
        ("EC0Y", &["axes.Y.EC0Y"], "EC0Y = { uniform = 0.01 }"),
        (
            "EBX,ECX,EAY",
            &["axes.X.EBX", "axes.X.ECX", "axes.Y.EAY"],
            "EBX = { uniform = 0.01 }",
        ),
        ("", &[], ""),
    ];
    for (n, (chosen, stopped, line)) in cases.iter().enumerate() {
        let out = dir.path().join(format!("s{n}.toml"));
        let json = dir.path().join(format!("s{n}.json"));
        let mut command = volmap();
        command
            .args(["budget", "--machine", "vmc-li2015", "--tolerances"])
            .arg(&tolerances)
            .args(["--grid", "3x3x3", "--samples", "40", "--spec", "100"])
            .args(["--allocate", "--device", "cpu", "--out", s(&out)])
            .args(["--json", s(&json)]);
        if !chosen.is_empty() {
            command.args(["--allocate-terms", chosen]);
        }
        let output = command.output().unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert!(
            output.status.success(),
            "{chosen}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        let a = allocation(&json);
        if !stopped.is_empty() {
            let said: Vec<&str> = a["stopped_at_limit"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_str().unwrap())
                .collect();
            assert_eq!(said, *stopped, "{a}");
            for key in *stopped {
                assert!(stdout.contains(&format!("{key} (0.01 rad)")), "{stdout}");
            }
            let text = std::fs::read_to_string(&out).unwrap();
            assert!(text.contains(line), "{text}");
        }
        // Every width written is within what the reader takes, and volmap reads it back.
        assert!(!a["widths"].as_array().unwrap().is_empty(), "{a}");
        for w in a["widths"].as_array().unwrap() {
            let key = w["term"].as_str().unwrap();
            let angular = key.rsplit('.').next().unwrap()[1..2]
                .chars()
                .all(|c| "ABC".contains(c));
            let most = if angular { 0.01 } else { 1e6 };
            assert!(w["width"].as_f64().unwrap() <= most, "{w}");
        }
        volmap()
            .args(["budget", "--machine", "vmc-li2015", "--tolerances", s(&out)])
            .args(["--grid", "3x3x3", "--device", "cpu"])
            .assert()
            .success();
    }
}

/// A machine whose pitch of X grows 1.5e-4 rad a kelvin of `bed` and whose scale of X grows
/// 15 mm per mm of travel a kelvin of `ram` (absurd, but within the file's bounds at ±50 K:
/// 1e-5 + 1.5e-4·50 = 0.00751 rad ≤ 0.01, 15·1000·50 = 7.5e5 mm ≤ 1e6).
const WARM: &str = r#"
name = "warm"
chain = "FFXYZ"
[thermal]
reference_C = 20.0
inputs = ["bed", "ram"]
[axes.X]
range = [0.0, 1000.0]
EBX = { value = 1.0e-5, per_kelvin = { bed = 1.5e-4 } }
EXX = { value = 0.0, per_kelvin = { ram = { poly = [0.0, 15.0] } } }
[axes.Y]
range = [0.0, 500.0]
[axes.Z]
range = [0.0, 300.0]
"#;

#[test]
fn thermal_terms_are_checked_at_the_temperatures_of_the_run_on_every_device() {
    let dir = tempfile::tempdir().unwrap();
    let machine = write(dir.path(), "warm.toml", WARM);
    let tolerances = write(
        dir.path(),
        "t.toml",
        "[axes.X]\nEXX = { uniform = 0.001 }\n",
    );
    let field = dir.path().join("f.exr");
    // (temperatures, the figure refused or none): bed=90 is 70 K: 1e-5 + 1.5e-4·70 = 0.01051
    // rad; bed=-50 is -70 K: 1e-5 - 0.0105 = -0.01049, 0.01049 in magnitude; ram=85 is 65 K:
    // 15·1000·65 = 9.75e5 mm, within 1e6; ram=90: 1.05e6 mm. bed=80 (60 K): 0.00901 rad.
    let cases = [
        ("bed=90", Some("0.01051 rad")),
        ("bed=-50", Some("0.01049 rad")),
        ("ram=90", Some("1.050e+6 mm")),
        ("bed=80,ram=85", None),
    ];
    for (temperatures, figure) in cases {
        for device in devices() {
            let map = [
                "map",
                "--machine",
                s(&machine),
                "--grid",
                "3x3x3",
                "--temperatures",
                temperatures,
                "--device",
                device,
                "--out",
                s(&field),
            ];
            let budget = [
                "budget",
                "--machine",
                s(&machine),
                "--tolerances",
                s(&tolerances),
                "--grid",
                "3x3x3",
                "--samples",
                "5",
                "--temperatures",
                temperatures,
                "--device",
                device,
            ];
            for args in [&map[..], &budget[..]] {
                match figure {
                    Some(figure) => {
                        let stderr = refused(
                            args,
                            dir.path(),
                            &["--temperatures", figure, "more than any machine tool has"],
                        );
                        let name = temperatures.split('=').next().unwrap();
                        assert!(stderr.contains(&format!("{name}=")), "{stderr}");
                    }
                    None => {
                        volmap().args(args).assert().success();
                    }
                }
            }
        }
    }
    // `sample --exact` takes the same check: bed=95 is 75 K, 1e-5 + 1.5e-4·75 = 0.01126 rad.
    let points = write(dir.path(), "p.csv", "X,Y,Z\n500,0,0\n");
    refused(
        &[
            "sample",
            "--machine",
            s(&machine),
            "--exact",
            "--points",
            s(&points),
            "--temperatures",
            "bed=95",
        ],
        dir.path(),
        &["--temperatures", "0.01126 rad"],
    );
}

#[test]
fn specifications_and_shares_are_said_in_words() {
    let dir = tempfile::tempdir().unwrap();
    let tolerances = example("vmc-li2015");
    let base = [
        "budget",
        "--machine",
        "vmc-li2015",
        "--tolerances",
        s(&tolerances),
        "--grid",
        "3x3x3",
        "--device",
        "cpu",
        "--samples",
        "20",
    ];
    // A huge specification prints in scientific notation, not 309 digits.
    let output = volmap()
        .args(base)
        .args(["--spec", "1e307"])
        .output()
        .unwrap();
    assert!(output.status.success());
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("within 1e307 mm"), "{stdout}");
    assert_no_long_number(&stdout);
    let stderr = refused(
        &super::with(&base, &["--spec", "-2.5e200"]),
        dir.path(),
        &["--spec", "-2.5e200 mm"],
    );
    assert_no_long_number(&stderr);
    // EXS (2e-3 mm) could grow 5e8 times before a file refuses it; every machine still holds a
    // spec of 1e300 mm at 2^20 times: all of them, said so, not `1 of the machines`.
    let stderr = refused(
        &super::with(
            &base,
            &["--spec", "1e300", "--allocate", "--allocate-terms", "EXS"],
        ),
        dir.path(),
        &["every machine holds 1e300 mm", "1048576 times"],
    );
    assert!(!stderr.contains("1 of the machines"), "{stderr}");
    assert_no_long_number(&stderr);
    // A spec of 1 nm: the machine's own errors (tens of µm) leave no machine within it.
    refused(
        &super::with(&base, &["--spec", "1e-6", "--allocate"]),
        dir.path(),
        &["no machine holds 1e-6 mm"],
    );
}
