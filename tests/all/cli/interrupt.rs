//! An interrupted command leaves no temporary file; a later run removes those of gone processes.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::outputs::points;
use super::{temporaries, volmap};

/// Starts a map large enough to be interrupted (with `extra` arguments), waits for its
/// temporary file, sends `signal` and returns the exit code. 300³ points take seconds on two
/// cores; stored as HALF they need 325 MB free, which map checks before it starts.
fn interrupted_map(dir: &Path, signal: &str, extra: &[&str]) -> Option<i32> {
    let mut child = Command::new(assert_cmd::cargo::cargo_bin("volmap"))
        .args(["map", "--grid", "300x300x300", "--device", "cpu"])
        .args(extra)
        .arg("--out")
        .arg(dir.join("big.exr"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while temporaries(dir).is_empty() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no temporary file appeared"
        );
        assert!(child.try_wait().unwrap().is_none(), "the map ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    child.wait().unwrap().code()
}

#[test]
fn sigterm_removes_the_temporary_file_and_exits_143() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(interrupted_map(dir.path(), "-TERM", &["--half"]), Some(143));
    assert!(
        temporaries(dir.path()).is_empty(),
        "{:?}",
        temporaries(dir.path())
    );
    assert!(!dir.path().join("big.exr").exists());
}

#[test]
fn sigint_removes_the_temporary_file_and_exits_130() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(interrupted_map(dir.path(), "-INT", &["--half"]), Some(130));
    assert!(
        temporaries(dir.path()).is_empty(),
        "{:?}",
        temporaries(dir.path())
    );
    assert!(!dir.path().join("big.exr").exists());
}

#[test]
fn an_interrupted_compressed_map_leaves_nothing() {
    for extra in [
        &["--compression", "zip"][..],
        &["--compression", "pxr24", "--half"],
    ] {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(interrupted_map(dir.path(), "-INT", extra), Some(130));
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
        assert!(left.is_empty(), "{extra:?}: {left:?}");
    }
}

#[test]
fn an_interrupted_bench_removes_its_scratch_folder() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(assert_cmd::cargo::cargo_bin("volmap"))
        .env("TMPDIR", dir.path())
        .args(["bench", "--machines", "vmc-li2015", "--grid", "64x64x64"])
        .args([
            "--device",
            "cpu",
            "--reference-points",
            "100",
            "--runs",
            "50",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let scratch = dir.path().join(format!("volmap-bench-{}", child.id()));
    let start = Instant::now();
    // Until a field is being written in the scratch folder.
    while std::fs::read_dir(&scratch).map_or(true, |d| d.count() == 0) {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no scratch field appeared"
        );
        assert!(child.try_wait().unwrap().is_none(), "the bench ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    assert_eq!(child.wait().unwrap().code(), Some(130));
    assert!(!scratch.exists(), "the scratch folder is left behind");
}

#[test]
fn a_later_run_removes_stale_temporaries_of_gone_processes_only() {
    let dir = tempfile::tempdir().unwrap();
    // A process that has ended: its id names no process now.
    let mut gone = Command::new("true").spawn().unwrap();
    let gone_pid = gone.id();
    gone.wait().unwrap();
    let stale = dir.path().join(format!(".f.exr.{gone_pid}.part"));
    // This test's own process is alive: its temporary is some other run's work in progress.
    let alive = dir
        .path()
        .join(format!(".f.exr.{}.part", std::process::id()));
    // Another output's temporary is not this run's to judge.
    let other = dir.path().join(format!(".g.exr.{gone_pid}.part"));
    for path in [&stale, &alive, &other] {
        std::fs::write(path, "half a field").unwrap();
    }
    volmap()
        .args(["map", "--grid", "4x4x4", "--device", "cpu", "--out"])
        .arg(dir.path().join("f.exr"))
        .assert()
        .success();
    assert!(!stale.exists());
    assert!(alive.exists());
    assert!(other.exists());
    assert!(dir.path().join("f.exr").exists());
}

/// A writer other than a map's, interrupted while it writes: `sample` streams its answer into
/// its temporary file batch by batch.
#[cfg(unix)]
#[test]
fn an_interrupted_sample_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    points(&d.join("many.csv"), 3_000_000, "p");
    for (signal, code) in [("-TERM", 143), ("-HUP", 129)] {
        let mut child = Command::new(assert_cmd::cargo::cargo_bin("volmap"))
            .current_dir(d)
            .args([
                "sample",
                "--exact",
                "--machine",
                "vmc-li2015",
                "--points",
                "many.csv",
            ])
            .args(["--out", "s.csv"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while temporaries(d).is_empty() {
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "no temporary file"
            );
            assert!(child.try_wait().unwrap().is_none(), "the run ended early");
            std::thread::sleep(Duration::from_millis(5));
        }
        let killed = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        assert_eq!(child.wait().unwrap().code(), Some(code));
        assert!(temporaries(d).is_empty(), "{:?}", temporaries(d));
        assert!(!d.join("s.csv").exists());
    }
}
