//! Nothing lost: two runs on one output each write a whole file under a temporary name of their
//! own (the file left is one of them, whole); an output that is one of the run's inputs is
//! refused before anything is written; a full disk (a file-size limit) and an interruption leave
//! no temporary file.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use predicates::prelude::*;

use super::volmap;

/// The files in `dir` whose names end in `.part`.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".part"))
        .collect()
}

/// A points file of `count` positions inside vmc-li2015's travels, with a label column `tag`.
fn points(path: &Path, count: usize, tag: &str) {
    let mut text = String::from("X,Y,Z,tag\n");
    for n in 0..count {
        text += &format!("{},{},{},{tag}{n}\n", n % 997, n % 593, n % 487);
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn two_runs_on_one_output_leave_one_whole_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    points(&d.join("a.csv"), 60_000, "a");
    points(&d.join("b.csv"), 40_000, "b");
    let sample = |points: &str, out: &str| {
        Command::new(assert_cmd::cargo::cargo_bin("volmap"))
            .current_dir(d)
            .args([
                "sample",
                "--exact",
                "--machine",
                "vmc-li2015",
                "--points",
                points,
            ])
            .args(["--out", out])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    // Each run's whole answer, alone.
    for (p, out) in [("a.csv", "a.out"), ("b.csv", "b.out")] {
        assert!(sample(p, out).wait().unwrap().success());
    }
    let whole = [
        std::fs::read(d.join("a.out")).unwrap(),
        std::fs::read(d.join("b.out")).unwrap(),
    ];
    for _ in 0..3 {
        let _ = std::fs::remove_file(d.join("s.csv"));
        let (a, b) = (sample("a.csv", "s.csv"), sample("b.csv", "s.csv"));
        for child in [a, b] {
            let output = child.wait_with_output().unwrap();
            assert!(
                output.status.success(),
                "{}",
                String::from_utf8_lossy(&output.stderr)
            );
        }
        let left = std::fs::read(d.join("s.csv")).unwrap();
        assert!(
            left == whole[0] || left == whole[1],
            "the file left is neither run's whole answer ({} bytes)",
            left.len()
        );
        assert!(temporaries(d).is_empty(), "{:?}", temporaries(d));
    }
}

const SQUARE_STL: &str = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 50 0 0\nvertex 50 50 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 50 50 0\nvertex 0 50 0\nendloop\nendfacet\nendsolid s\n";

/// A part file with one meshed profile, its mesh `skin.stl` and its PLY output `ply`.
fn profile_part(dir: &Path, ply: &str) -> std::path::PathBuf {
    std::fs::write(dir.join("skin.stl"), SQUARE_STL).unwrap();
    let path = dir.join("part.toml");
    std::fs::write(
        &path,
        format!("name = \"skin\"\n[placement]\nzero_mm = [100.0, 100.0, 100.0]\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 5.0\n[[features]]\nkind = \"profile\"\nname = \"skin\"\nmesh = \"skin.stl\"\ntolerance_mm = 1.0\nply = \"{ply}\"\n"),
    )
    .unwrap();
    path
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let features = |part: &Path| {
        let mut command = volmap();
        command
            .current_dir(d)
            .args(["features", "--machine", "vmc-li2015", "--part"])
            .arg(part);
        command.assert()
    };
    // The profile's PLY written over its own mesh, or over the part file.
    let part = profile_part(d, "skin.stl");
    features(&part)
        .code(2)
        .stderr(predicate::str::contains("skin.stl is an input of this run"));
    assert_eq!(
        std::fs::read_to_string(d.join("skin.stl")).unwrap(),
        SQUARE_STL
    );
    let part = profile_part(d, "part.toml");
    let before = std::fs::read_to_string(&part).unwrap();
    features(&part).code(2).stderr(predicate::str::contains(
        "part.toml is an input of this run",
    ));
    assert_eq!(std::fs::read_to_string(&part).unwrap(), before);
    let part = profile_part(d, "skin.ply");
    features(&part).success();
    assert!(d.join("skin.ply").exists());
    // `build --out` on the measurements of an axis.
    let measured = "position_mm,EXX_um\n0,0\n500,2\n1000,3\n";
    std::fs::write(d.join("x.csv"), measured).unwrap();
    volmap()
        .current_dir(d)
        .args([
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=x.csv",
            "--out",
            "x.csv",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "--out: x.csv is an input of this run",
        ));
    assert_eq!(std::fs::read_to_string(d.join("x.csv")).unwrap(), measured);
    // `sample --out` on its points, `map --out` on its machine file, `--json` on a measured
    // file, a hard link to the program.
    std::fs::write(d.join("p.csv"), "X,Y,Z\n1,2,3\n").unwrap();
    volmap()
        .current_dir(d)
        .args([
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "p.csv",
            "--out",
            "./p.csv",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "./p.csv is an input of this run (read as p.csv)",
        ));
    assert_eq!(
        std::fs::read_to_string(d.join("p.csv")).unwrap(),
        "X,Y,Z\n1,2,3\n"
    );
    let machine = volmap()
        .args(["machines", "--show", "vmc-li2015"])
        .output()
        .unwrap()
        .stdout;
    std::fs::write(d.join("m.toml"), &machine).unwrap();
    volmap()
        .current_dir(d)
        .args([
            "test",
            "circular",
            "--plane",
            "XY",
            "--machine",
            "m.toml",
            "--json",
            "m.toml",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("never writes over its inputs"));
    assert_eq!(std::fs::read(d.join("m.toml")).unwrap(), machine);
    std::fs::write(
        d.join("pos.csv"),
        "target_mm,direction,run,deviation_mm\n0,+,1,0\n500,+,1,0.001\n1000,+,1,0.002\n1000,-,1,0.002\n500,-,1,0.001\n0,-,1,0\n",
    )
    .unwrap();
    volmap()
        .current_dir(d)
        .args([
            "test",
            "positioning",
            "--machine",
            "vmc-li2015",
            "--axis",
            "X",
        ])
        .args(["--measured", "pos.csv", "--json", "pos.csv"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("pos.csv is an input of this run"));
    #[cfg(unix)]
    {
        std::fs::write(d.join("prog.nc"), "G0 X10 Y10 Z10\nG1 X20 F100\n").unwrap();
        std::fs::hard_link(d.join("prog.nc"), d.join("link.nc")).unwrap();
        volmap()
            .current_dir(d)
            .args([
                "compensate",
                "--machine",
                "vmc-li2015",
                "--program",
                "prog.nc",
                "--out",
                "link.nc",
            ])
            .assert()
            .code(2)
            .stderr(predicate::str::contains(
                "link.nc is an input of this run (read as prog.nc)",
            ));
        assert_eq!(
            std::fs::read_to_string(d.join("prog.nc")).unwrap(),
            "G0 X10 Y10 Z10\nG1 X20 F100\n"
        );
    }
    assert!(temporaries(d).is_empty(), "{:?}", temporaries(d));
}

/// Runs volmap with `args` in `dir` under a file-size limit of `bytes` (a full disk, as a
/// process meets one without root); SIGXFSZ keeps its default action: volmap itself ignores it.
#[cfg(unix)]
fn with_file_size_limit(dir: &Path, bytes: u64, args: &[&str]) -> std::process::Output {
    use std::os::unix::process::CommandExt;
    let mut command = Command::new(assert_cmd::cargo::cargo_bin("volmap"));
    command.current_dir(dir).args(args);
    // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        command.pre_exec(move || {
            let limit = libc::rlimit {
                rlim_cur: bytes as libc::rlim_t,
                rlim_max: bytes as libc::rlim_t,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    command.output().unwrap()
}

#[cfg(unix)]
#[test]
fn a_full_disk_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G0 X10 Y10 Z10\nG1 X20 F100\nG1 Y30\n").unwrap();
    let runs: [&[&str]; 3] = [
        &["plot", "grid", "--grid", "6x6x6", "--out", "g.svg"],
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "p.nc",
            "--out",
            "o.nc",
        ],
        &[
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--plot",
            "c.png",
        ],
    ];
    for args in runs {
        let output = with_file_size_limit(d, 100, args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains("cannot write"), "{args:?}: {stderr}");
        let left: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n != "p.nc")
            .collect();
        assert!(left.is_empty(), "{args:?} left {left:?}");
    }
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
