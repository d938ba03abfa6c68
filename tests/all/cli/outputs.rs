//! How results are written, whatever the command: two runs on one output each write a whole
//! file under a temporary name of their own (the file left is one of them, whole); an output
//! that is one of the run's inputs, or two outputs of one run on one file (through a link too),
//! are refused before anything is written; a full disk (a file-size limit) leaves no temporary
//! file and a failed run no partial one; a device stays a device; a closed or full standard
//! output ends the command without a panic.

use std::path::Path;
use std::process::{Command, Stdio};

use predicates::prelude::*;

use super::{refused, succeeds, temporaries, volmap};

/// A points file of `count` positions inside vmc-li2015's travels, with a label column `tag`.
pub fn points(path: &Path, count: usize, tag: &str) {
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
        // The output is declared before the measurements are read: reading them is refused.
        .stderr(predicate::str::contains(
            "--axis: x.csv is an input of this run and one of its outputs",
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
        // The output is declared before the points are read: reading them is refused.
        .stderr(predicate::str::contains(
            "--points: p.csv is an input of this run and one of its outputs (written as ./p.csv)",
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
            // The output is declared before the program is read: reading it is refused.
            .stderr(predicate::str::contains(
                "--program: prog.nc is an input of this run and one of its outputs (written as link.nc)",
            ));
        assert_eq!(
            std::fs::read_to_string(d.join("prog.nc")).unwrap(),
            "G0 X10 Y10 Z10\nG1 X20 F100\n"
        );
    }
    assert!(temporaries(d).is_empty(), "{:?}", temporaries(d));
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

/// `--out /dev/null` as root renamed a file over the device; it is written directly now.
#[cfg(unix)]
#[test]
fn an_output_that_is_a_device_stays_a_device() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("q.csv"), "X,Y,Z\n100,100,100\n").unwrap();
    volmap()
        .args([
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "q.csv",
            "--out",
            "/dev/null",
        ])
        .current_dir(dir.path())
        .assert()
        .success();
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());
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
            // Every row: more than a pipe holds, so the closed pipe is met while writing.
            "--table",
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
