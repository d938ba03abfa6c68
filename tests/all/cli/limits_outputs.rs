//! Outputs (docs/inputs-and-limits.md, "Every output is written whole or not at all"): every
//! output's folder is checked before any work, the outputs of a run are put in place together at
//! its end or none of them, a file the user could not write is never replaced, a link is written
//! through, a pipe is never read as a file, a part's deviation files stay in its folder, and
//! nothing read from an input reaches the terminal as a control character.

use std::path::Path;
use std::time::Duration;

use super::{s, volmap};

/// A program of a few moves.
const PROGRAM: &str = "G21 G90 G17\nG0 X100 Y100 Z100\nG1 X200 F500\nG1 Y150\nM30\n";

/// A command's arguments, and its output flags with a file name each.
type Run = (Vec<String>, Vec<(&'static str, &'static str)>);

/// Each command with several outputs.
fn runs(dir: &Path) -> Vec<Run> {
    std::fs::write(dir.join("p.nc"), PROGRAM).unwrap();
    let tolerances = format!(
        "{}/examples/tolerances/vmc-li2015.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let v = |a: &[&str]| a.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    vec![
        (
            v(&[
                "export",
                "--machine",
                "vmc-li2015",
                "--format",
                "grid-csv",
                "--points",
                "3",
            ]),
            vec![("--out", "t.csv"), ("--json", "j.json")],
        ),
        (
            v(&["compensate", "--machine", "vmc-li2015", "--program", "p.nc"]),
            vec![("--out", "c.nc"), ("--json", "j.json")],
        ),
        (
            v(&["trace", "--machine", "vmc-li2015", "--program", "p.nc"]),
            vec![
                ("--out", "t.csv"),
                ("--plot", "t.svg"),
                ("--json", "j.json"),
            ],
        ),
        (
            v(&[
                "budget",
                "--machine",
                "vmc-li2015",
                "--tolerances",
                &tolerances,
                "--grid",
                "3x3x3",
                "--samples",
                "8",
                "--device",
                "cpu",
            ]),
            vec![
                ("--per-sample", "s.csv"),
                ("--plot", "b.svg"),
                ("--json", "j.json"),
            ],
        ),
    ]
}

/// Every file of `dir` and its content.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut all: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    all.sort();
    all
}

/// `args` with every output flag of `outputs`, each over an old file in `d`, but output `bad`
/// named `bad_name(name)`.
fn with_outputs(
    d: &Path,
    args: &[String],
    outputs: &[(&str, &str)],
    bad: usize,
    bad_name: impl Fn(&str) -> String,
) -> Vec<String> {
    let mut all = args.to_vec();
    for (k, (flag, name)) in outputs.iter().enumerate() {
        std::fs::write(d.join(name), "old").unwrap();
        all.push(flag.to_string());
        all.push(if k == bad {
            bad_name(name)
        } else {
            name.to_string()
        });
    }
    all
}

#[test]
fn a_missing_folder_of_any_output_is_refused_before_the_work_and_nothing_is_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (args, outputs) in runs(d) {
        // The machine is a file that is not there: the folder's error, not the machine's, says
        // the outputs were checked before anything was read, let alone worked on.
        let args: Vec<String> = args
            .into_iter()
            .map(|a| {
                if a == "vmc-li2015" {
                    "no-such-machine.toml".into()
                } else {
                    a
                }
            })
            .collect();
        assert!(args.iter().any(|a| a == "no-such-machine.toml"), "{args:?}");
        // Each output in turn in a folder that is not there, the others over old files.
        for bad in 0..outputs.len() {
            let all = with_outputs(d, &args, &outputs, bad, |name| {
                format!("no-such-folder/{name}")
            });
            let before = contents(d);
            let output = volmap().args(&all).current_dir(d).output().unwrap();
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert_eq!(output.status.code(), Some(2), "{all:?}: {stderr}");
            assert!(
                stderr.starts_with(&format!("error: {}: no-such-folder/", outputs[bad].0))
                    && stderr.contains("its folder `no-such-folder` does not exist"),
                "{all:?}: {stderr}"
            );
            // Refused before any work: no progress shown, no file touched.
            assert!(!stderr.contains('%'), "{all:?}: {stderr}");
            assert_eq!(contents(d), before, "{all:?}");
        }
    }
}

#[cfg(target_os = "linux")]
#[test]
fn an_output_that_fails_while_written_leaves_every_other_output_as_it_was() {
    // /dev/full takes the open and fails the write (no space): the failure comes after the
    // work, when the other outputs are complete. None of them replaces its old file.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (args, outputs) in runs(d) {
        for bad in 0..outputs.len() {
            let all = with_outputs(d, &args, &outputs, bad, |_| "/dev/full".to_string());
            // A plot's format is its extension: /dev/full has none, so plots stay files here.
            if outputs[bad].0 == "--plot" {
                continue;
            }
            let before = contents(d);
            let output = volmap().args(&all).current_dir(d).output().unwrap();
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert_eq!(output.status.code(), Some(1), "{all:?}: {stderr}");
            assert!(stderr.contains("/dev/full"), "{all:?}: {stderr}");
            assert_eq!(contents(d), before, "{all:?}");
        }
    }
}

#[cfg(unix)]
#[test]
fn write_protected_outputs_are_refused_and_links_are_written_through() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), PROGRAM).unwrap();
    let compensate = |out: &str| {
        volmap()
            .current_dir(d)
            .args([
                "compensate",
                "--machine",
                "vmc-li2015",
                "--program",
                "p.nc",
                "--out",
                out,
            ])
            .output()
            .unwrap()
    };
    // Read-only for its owner, for everyone: refused, untouched.
    for mode in [0o400, 0o444, 0o500] {
        std::fs::write(d.join("ro.nc"), "old").unwrap();
        std::fs::set_permissions(d.join("ro.nc"), std::fs::Permissions::from_mode(mode)).unwrap();
        let output = compensate("ro.nc");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{mode:o}: {stderr}");
        assert!(
            stderr.contains("--out: ro.nc") && stderr.contains("write-protected"),
            "{stderr}"
        );
        assert_eq!(std::fs::read_to_string(d.join("ro.nc")).unwrap(), "old");
        std::fs::set_permissions(d.join("ro.nc"), std::fs::Permissions::from_mode(0o600)).unwrap();
    }
    // A link: its file replaced, the link kept; a link to a link too.
    std::fs::create_dir(d.join("elsewhere")).unwrap();
    std::fs::write(d.join("elsewhere/real.nc"), "old").unwrap();
    std::os::unix::fs::symlink(d.join("elsewhere/real.nc"), d.join("link.nc")).unwrap();
    std::os::unix::fs::symlink("link.nc", d.join("link2.nc")).unwrap();
    for link in ["link.nc", "link2.nc"] {
        std::fs::write(d.join("elsewhere/real.nc"), "old").unwrap();
        let output = compensate(link);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        assert!(std::fs::symlink_metadata(d.join(link))
            .unwrap()
            .file_type()
            .is_symlink());
        let written = std::fs::read_to_string(d.join("elsewhere/real.nc")).unwrap();
        assert!(written.contains("G1"), "{written}");
        assert_eq!(std::fs::read_to_string(d.join(link)).unwrap(), written);
    }
    // A link to nothing: refused, nothing created where it points.
    std::os::unix::fs::symlink(d.join("elsewhere/none.nc"), d.join("dangling.nc")).unwrap();
    let output = compensate("dangling.nc");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("a symbolic link to") && stderr.contains("does not exist"),
        "{stderr}"
    );
    assert!(!d.join("elsewhere/none.nc").exists());
}

#[cfg(unix)]
#[test]
fn pipes_named_as_inputs_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = d.join("table.csv");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let machine = volmap()
        .args(["machines", "--show", "vmc-li2015"])
        .output()
        .unwrap()
        .stdout;
    let text: String = String::from_utf8(machine)
        .unwrap()
        .lines()
        .map(|l| {
            if l.starts_with("EXX = ") {
                "EXX = { csv = \"table.csv\", column = \"EXX\" }\n".to_string()
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    std::fs::write(d.join("m.toml"), text).unwrap();
    std::fs::write(d.join("p.csv"), "X,Y,Z\n1,2,3\n").unwrap();
    // Nobody writes the pipe: opening it would wait for ever.
    for (args, says) in [
        (
            vec![
                "sample",
                "--exact",
                "--machine",
                "m.toml",
                "--points",
                "p.csv",
            ],
            "axes.X.EXX",
        ),
        (
            vec!["map", "--grid", "2x2x2", "--machine", "table.csv"],
            "--machine",
        ),
        (vec!["info", "table.csv"], "table.csv"),
        (
            vec![
                "budget",
                "--machine",
                "vmc-li2015",
                "--tolerances",
                "table.csv",
            ],
            "--tolerances",
        ),
    ] {
        let output = volmap()
            .args(&args)
            .current_dir(d)
            .timeout(Duration::from_secs(30))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("a pipe (FIFO), not a file") && stderr.contains(says),
            "{args:?}: {stderr}"
        );
    }
}

#[test]
fn deviation_files_stay_in_the_part_folder_and_each_has_its_own_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let part_dir = d.join("part");
    std::fs::create_dir(&part_dir).unwrap();
    std::fs::write(d.join("notes.txt"), "mine").unwrap();
    let stl = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 40 0 0\nvertex 40 40 0\nendloop\nendfacet\nendsolid s\n";
    std::fs::write(part_dir.join("a.stl"), stl).unwrap();
    std::fs::write(d.join("outside.stl"), stl).unwrap();
    let feature = |name: &str, mesh: &str, ply: &str| {
        format!("[[features]]\nkind = \"profile\"\nname = \"{name}\"\nmesh = \"{mesh}\"\ntolerance_mm = 1.0\nply = \"{ply}\"\n")
    };
    let head = "name = \"p\"\n[placement]\nzero_mm = [100.0, 100.0, 100.0]\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 10.0\n";
    let absolute_notes = s(&d.join("notes.txt")).to_string();
    let absolute_mesh = s(&d.join("outside.stl")).to_string();
    let cases: Vec<(String, Vec<&str>, String)> = vec![
        (
            feature("f", "a.stl", &absolute_notes),
            vec![],
            "ply: `".to_string(),
        ),
        (
            feature("f", "a.stl", "../notes.txt"),
            vec![],
            "`../notes.txt` lies outside".to_string(),
        ),
        (
            feature("f", "a.stl", "sub/../../notes.txt"),
            vec![],
            "lies outside".to_string(),
        ),
        (
            feature("f", &absolute_mesh, "f.ply"),
            vec![],
            "mesh: `".to_string(),
        ),
        (
            feature("f", "a.stl", "same.ply") + &feature("g", "a.stl", "./same.ply"),
            vec![],
            "feature `g`: ply: `./same.ply` is also the deviation file of feature `f`".to_string(),
        ),
        (
            feature("f", "a.stl", "f.ply"),
            vec!["--json", "part/f.ply"],
            "is also the output of".to_string(),
        ),
    ];
    for (features, extra, says) in cases {
        std::fs::write(part_dir.join("p.toml"), format!("{head}{features}")).unwrap();
        let mut args = vec![
            "features",
            "--machine",
            "vmc-li2015",
            "--part",
            "part/p.toml",
        ];
        args.extend(extra);
        let output = volmap().args(&args).current_dir(d).output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{features}: {stderr}");
        assert!(stderr.contains(&says), "{features}: {stderr}");
        assert_eq!(
            std::fs::read_to_string(d.join("notes.txt")).unwrap(),
            "mine"
        );
        assert!(!part_dir.join("f.ply").exists() && !part_dir.join("same.ply").exists());
    }
}

#[test]
fn control_characters_from_inputs_never_reach_the_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A feature whose name would erase its row and print `fit` over it.
    let name = "hole\\u001b[2K\\rA fit\\u001b[8m";
    std::fs::write(
        d.join("p.toml"),
        format!("name = \"p\\u0007\"\n[placement]\nzero_mm = [100.0, 100.0, 100.0]\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 10.0\n[[features]]\nkind = \"end_milled_plane\"\nname = \"{name}\"\ncorner_mm = [0.0, 0.0, 0.0]\nsize_mm = [50.0, 50.0]\ntolerance_mm = 0.0001\n"),
    )
    .unwrap();
    // A CSV field with an escape, a NUL and a carriage return in it.
    std::fs::write(d.join("p.csv"), "X,Y,Z\n1,\u{1b}]0;x\u{7}\0\r,3\n").unwrap();
    // A tolerance file's key with an escape in it.
    std::fs::write(d.join("t.toml"), "[axes.X]\n\"E\\u001bXX\" = 0.001\n").unwrap();
    for args in [
        vec!["features", "--machine", "vmc-li2015", "--part", "p.toml"],
        vec![
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "p.csv",
        ],
        vec![
            "budget",
            "--machine",
            "vmc-li2015",
            "--tolerances",
            "t.toml",
        ],
    ] {
        let output = volmap().args(&args).current_dir(d).output().unwrap();
        for (stream, bytes) in [("stdout", &output.stdout), ("stderr", &output.stderr)] {
            let text = String::from_utf8_lossy(bytes);
            assert!(
                !text
                    .chars()
                    .any(|c| c.is_control() && c != '\n' && c != '\t'),
                "{args:?}: {stream}: {text:?}"
            );
        }
        assert!(
            !output.status.success() || args[0] == "features",
            "{args:?}"
        );
    }
    // What the row says is shown, escaped.
    let output = volmap()
        .args(["features", "--machine", "vmc-li2015", "--part", "p.toml"])
        .current_dir(d)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("hole\\u{1b}[2K\\u{d}A fit\\u{1b}[8m"),
        "{stdout}"
    );
}

#[test]
fn export_spacings_beyond_any_use_name_the_spacing() {
    // vmc-li2015's longest travel is X's 1000 mm: a spacing wider than that, or so small that its
    // nodes outnumber any integer, is the spacing's fault, exit 2 naming --spacing.
    let dir = tempfile::tempdir().unwrap();
    for (format, spacing, says) in [
        (
            "grid-csv",
            "1e9",
            "a spacing of 1000000000 mm is wider than every travel",
        ),
        (
            "linuxcnc",
            "1001",
            "a spacing of 1001 mm is wider than every travel",
        ),
        (
            "linuxcnc",
            "1e-310",
            "points along X (1000 mm at 1e-310 mm) is more than",
        ),
        (
            "linuxcnc",
            "5e-324",
            "points along X (1000 mm at 5e-324 mm) is more than",
        ),
    ] {
        let output = volmap()
            .args(["export", "--machine", "vmc-li2015", "--format", format])
            .args(["--spacing", spacing, "--out", "out"])
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{format} {spacing}: {stderr}"
        );
        assert!(
            stderr.starts_with("error: --spacing: ")
                && stderr.contains(says)
                && !stderr.contains("NaN"),
            "{format} {spacing}: {stderr}"
        );
    }
}

#[test]
fn messages_name_the_flag_or_line_at_fault() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A negative number is a value, refused by its flag's own check (not taken for a flag).
    for (args, says) in [
        (
            vec![
                "export",
                "--machine",
                "vmc-li2015",
                "--format",
                "linuxcnc",
                "--spacing",
                "-5",
                "--out",
                "o",
            ],
            "error: --spacing: ",
        ),
        (
            vec![
                "export",
                "--machine",
                "vmc-li2015",
                "--format",
                "grid-csv",
                "--spacing",
                "-0",
                "--out",
                "o.csv",
            ],
            "error: --spacing: ",
        ),
    ] {
        let output = volmap().args(&args).current_dir(d).output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.starts_with(says) && !stderr.contains("unexpected argument"),
            "{args:?}: {stderr}"
        );
    }
    // Text that is not UTF-8: the line it is on.
    std::fs::write(d.join("p.csv"), b"X,Y,Z\n1,2,3\n4,\xff,6\n").unwrap();
    std::fs::write(d.join("t.toml"), b"[axes.X]\nEXX = 0.001\n# \xfe\n").unwrap();
    for (args, says) in [
        (
            vec![
                "sample",
                "--exact",
                "--machine",
                "vmc-li2015",
                "--points",
                "p.csv",
            ],
            "p.csv: line 3: not UTF-8 text",
        ),
        (
            vec![
                "budget",
                "--machine",
                "vmc-li2015",
                "--tolerances",
                "t.toml",
            ],
            "line 3, column 3: not UTF-8 text",
        ),
    ] {
        let output = volmap().args(&args).current_dir(d).output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
    // A plot that cannot be written names --plot (a link to /dev/full: written directly, and
    // the write fails after the work).
    #[cfg(target_os = "linux")]
    {
        std::fs::write(d.join("p.nc"), PROGRAM).unwrap();
        std::os::unix::fs::symlink("/dev/full", d.join("full.svg")).unwrap();
        let output = volmap()
            .args([
                "trace",
                "--machine",
                "vmc-li2015",
                "--program",
                "p.nc",
                "--plot",
                "full.svg",
            ])
            .current_dir(d)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{stderr}");
        assert!(stderr.starts_with("error: --plot: "), "{stderr}");
    }
}
