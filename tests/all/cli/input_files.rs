//! How every input file is read, whatever the command: with a size bound (an input that never
//! ends is refused, exit 2 naming the file and the limit); CSV files named in machine files and
//! fit files stay in the file's folder unless `--allow-outside-paths` says otherwise; no message
//! quotes more than a few characters of any line; a byte-order mark is read past.

use std::path::{Path, PathBuf};
use std::time::Duration;

use predicates::prelude::*;

use super::{succeeds, volmap};

const MACHINE: &str = include_str!("../../../machines/vmc-li2015.toml");

/// `vmc-li2015` written to `folder/name` with its `EXX` read from the CSV `csv` (as written in
/// the file).
fn machine_with_csv(folder: &Path, name: &str, csv: &str) -> PathBuf {
    let lines: Vec<String> = MACHINE
        .lines()
        .map(|l| {
            if l.starts_with("EXX = ") {
                format!("EXX = {{ csv = \"{csv}\", column = \"EXX\" }}")
            } else {
                l.to_string()
            }
        })
        .collect();
    let text = lines.join("\n");
    assert_ne!(text.trim_end(), MACHINE.trim_end());
    std::fs::create_dir_all(folder).unwrap();
    let path = folder.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs volmap with `args` (a generous limit: an input read without a bound would run until
/// memory ran out) and requires exit 2 with stderr naming `file` and `limit`.
fn refused(dir: &Path, args: &[&str], file: &str, limit: &str) {
    let output = volmap()
        .current_dir(dir)
        .args(args)
        .timeout(Duration::from_secs(120))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(
        stderr.contains(file) && stderr.contains(limit),
        "{args:?}: {stderr}"
    );
}

#[cfg(unix)]
#[test]
fn every_input_given_an_endless_device_is_refused_at_its_size_limit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G0 X10 Y10 Z10\nG1 X20 F100\n").unwrap();
    std::fs::write(d.join("part.toml"), "name = \"zero\"\n[placement]\nzero_mm = [100.0, 100.0, 100.0]\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 5.0\n[[features]]\nkind = \"profile\"\nname = \"skin\"\nmesh = \"/dev/zero\"\ntolerance_mm = 0.1\n").unwrap();
    machine_with_csv(&d.join("m"), "m.toml", "/dev/zero");
    std::fs::write(
        d.join("fit.toml"),
        "estimate = [\"EC0Y\"]\n[[circular]]\nplane = \"XY\"\ncsv = \"/dev/zero\"\n",
    )
    .unwrap();
    let text = "larger than 64 MiB, the most a text input may hold";
    let m = ["--machine", "vmc-li2015"];
    let runs: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["map", "--grid", "2x2x2", "--machine", "/dev/zero"],
            text,
        ),
        (
            vec!["compensate", "--program", "/dev/zero", "--out", "o.nc"],
            "larger than 256 MiB, the most an NC program may hold",
        ),
        (vec!["trace", "--program", "/dev/zero"], "256 MiB"),
        (vec!["features", "--part", "/dev/zero"], text),
        (vec!["fit", "--measurements", "/dev/zero"], text),
        (
            vec![
                "test",
                "positioning",
                "--axis",
                "X",
                "--measured",
                "/dev/zero",
            ],
            text,
        ),
        (vec!["budget", "--tolerances", "/dev/zero"], text),
        (
            vec![
                "compensate",
                "--program",
                "p.nc",
                "--work-offset-file",
                "/dev/zero",
                "--out",
                "o.nc",
            ],
            text,
        ),
        (
            // A mesh lies in the part's folder: a device elsewhere is refused by its name.
            vec!["features", "--part", "part.toml"],
            "`/dev/zero` lies outside the folder",
        ),
        (
            vec!["fit", "--measurements", "fit.toml", "--allow-outside-paths"],
            text,
        ),
        (
            vec!["sample", "--exact", "--points", "/dev/zero"],
            "longer than 64 KiB, the most a line may hold",
        ),
    ];
    for (args, limit) in runs {
        let mut all: Vec<&str> = args.clone();
        if !matches!(args[0], "map") {
            all.extend(m);
        }
        refused(d, &all, "/dev/zero", limit);
    }
    // A CSV table of a machine file, and an axis of `build`.
    refused(
        d,
        &[
            "map",
            "--grid",
            "2x2x2",
            "--machine",
            "m/m.toml",
            "--allow-outside-paths",
        ],
        "/dev/zero",
        text,
    );
    refused(
        d,
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=/dev/zero",
            "--out",
            "b.toml",
        ],
        "/dev/zero",
        text,
    );
    // Random bytes are no better: refused, never read to the end.
    for args in [
        vec!["map", "--grid", "2x2x2", "--machine", "/dev/urandom"],
        vec![
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "/dev/urandom",
            "--out",
            "o.nc",
        ],
        vec![
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "/dev/urandom",
        ],
    ] {
        let output = volmap()
            .current_dir(d)
            .args(&args)
            .timeout(Duration::from_secs(120))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("/dev/urandom") && stderr.len() < 400,
            "{args:?}: {stderr}"
        );
    }
    assert!(!d.join("o.nc").exists() && !d.join("b.toml").exists());
}

#[test]
fn csv_files_named_in_machine_and_fit_files_stay_in_their_folder_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("outside.csv"),
        "position_mm,EXX\n0,0.0\n500,0.01\n1000,0.02\n",
    )
    .unwrap();
    let inside = d.join("machines");
    let machine = machine_with_csv(&inside, "m.toml", "../outside.csv");
    let map = |extra: &[&str]| {
        let mut command = volmap();
        command
            .args(["map", "--grid", "3x3x3", "--device", "cpu", "--machine"])
            .arg(&machine)
            .arg("--out")
            .arg(d.join("f.exr"))
            .args(extra);
        command.assert()
    };
    map(&[]).code(2).stderr(
        predicate::str::contains("axes.X.EXX: `../outside.csv` lies outside the folder")
            .and(predicate::str::contains("hint: --allow-outside-paths")),
    );
    assert!(!d.join("f.exr").exists());
    map(&["--allow-outside-paths"]).success();
    // A link inside the folder to a file outside it lies outside.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(d.join("outside.csv"), inside.join("link.csv")).unwrap();
        let linked = machine_with_csv(&inside, "linked.toml", "link.csv");
        std::fs::write(d.join("x.csv"), "X,Y,Z\n1,2,3\n").unwrap();
        volmap()
            .current_dir(d)
            .args(["sample", "--exact", "--points", "x.csv", "--machine"])
            .arg(&linked)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(
                "`link.csv` lies outside the folder",
            ));
    }
    // A table below the folder is in it.
    std::fs::create_dir_all(inside.join("tables")).unwrap();
    std::fs::copy(d.join("outside.csv"), inside.join("tables/x.csv")).unwrap();
    let below = machine_with_csv(&inside, "below.toml", "tables/x.csv");
    volmap()
        .args(["map", "--grid", "3x3x3", "--device", "cpu", "--machine"])
        .arg(&below)
        .arg("--out")
        .arg(d.join("g.exr"))
        .assert()
        .success();
    // A fit file's measured results likewise.
    let fits = d.join("fits");
    std::fs::create_dir_all(&fits).unwrap();
    std::fs::write(
        fits.join("fit.toml"),
        "estimate = [\"EC0Y\"]\n[[diagonal]]\ndiagonal = \"PPP\"\ncsv = \"../outside.csv\"\n",
    )
    .unwrap();
    volmap()
        .args(["fit", "--machine", "vmc-li2015", "--measurements"])
        .arg(fits.join("fit.toml"))
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains(
                "fit.toml: [[diagonal]] number 1, csv: `../outside.csv` lies outside the folder",
            )
            .and(predicate::str::contains("hint: --allow-outside-paths")),
        );
    // Allowed, it is read (and found to hold something else than a diagonal).
    volmap()
        .args([
            "fit",
            "--machine",
            "vmc-li2015",
            "--allow-outside-paths",
            "--measurements",
        ])
        .arg(fits.join("fit.toml"))
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("[[diagonal]] number 1: ")
                .and(predicate::str::contains("outside.csv: line 1")),
        );
}

/// Asserts a run fails with exit 2 and a short message that still says `says`.
fn short_refusal(dir: &Path, args: &[&str], says: &str) {
    let output = volmap().current_dir(dir).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(stderr.contains(says), "{args:?}: {stderr}");
    assert!(
        stderr.len() < 700,
        "{args:?}: {} bytes: {stderr}",
        stderr.len()
    );
}

#[test]
fn messages_quote_a_few_characters_of_any_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let long = "x".repeat(1 << 20);
    let digits = "9".repeat(400);
    // A CSV table whose header is one long line, read with the flag: its columns are quoted
    // cut short.
    std::fs::write(
        d.join("wide.csv"),
        format!("position_mm,{long}\n0,1\n1,2\n"),
    )
    .unwrap();
    machine_with_csv(d, "wide.toml", "wide.csv");
    short_refusal(
        d,
        &["map", "--grid", "2x2x2", "--machine", "wide.toml"],
        "has no column `EXX`",
    );
    // A points file with a long field and a number of 400 digits.
    let wide = "x".repeat(10_000);
    std::fs::write(d.join("p.csv"), format!("X,Y,Z\n1,2,{wide}\n")).unwrap();
    short_refusal(
        d,
        &[
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "p.csv",
        ],
        "line 2: `xxxx",
    );
    std::fs::write(d.join("q.csv"), format!("X,Y,Z\n1,2,{digits}\n")).unwrap();
    short_refusal(
        d,
        &[
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "q.csv",
        ],
        "not a finite number",
    );
    // A machine file (TOML) with a long line that does not parse.
    std::fs::write(
        d.join("bad.toml"),
        format!("name = \"x\"\nchain = \"FFXYZ\"\ndescription = [{long}\n"),
    )
    .unwrap();
    short_refusal(
        d,
        &["map", "--grid", "2x2x2", "--machine", "bad.toml"],
        "bad.toml: line 3, column",
    );
    // G-code with a long word.
    std::fs::write(
        d.join("long.nc"),
        format!("G0 X10 Y10 Z10\nG1 X{digits} F100\n"),
    )
    .unwrap();
    short_refusal(
        d,
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "long.nc",
            "--out",
            "o.nc",
        ],
        "long.nc: line 2: `X9999",
    );
    std::fs::write(
        d.join("word.nc"),
        format!("G0 X10 Y10 Z10\nG1 X20 {long}\n"),
    )
    .unwrap();
    short_refusal(
        d,
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "word.nc",
            "--out",
            "o.nc",
        ],
        "word.nc: line 2",
    );
    // A command-line value.
    std::fs::write(d.join("ok.csv"), "X,Y,Z\n1,2,3\n").unwrap();
    short_refusal(
        d,
        &[
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "ok.csv",
            "--approach",
            &wide,
        ],
        "--approach",
    );
    // A number far outside a travel is shown as a number, not as 301 digits.
    std::fs::write(
        d.join("c.csv"),
        "angle_deg,deviation_mm\n0,0.001\n90,0.0\n180,-0.001\n270,0.0\n",
    )
    .unwrap();
    std::fs::write(
        d.join("fit.toml"),
        "estimate = [\"EC0Y\"]\n[[circular]]\nplane = \"XY\"\ncentre_mm = [1e300, 0, 0]\npoints = 4\ncsv = \"c.csv\"\n",
    )
    .unwrap();
    short_refusal(
        d,
        &[
            "fit",
            "--machine",
            "vmc-li2015",
            "--measurements",
            "fit.toml",
        ],
        "X=1e300 lies outside the travel of X",
    );
}

/// A measured circle of 8 points.
pub const CIRCLE: &str = "angle_deg,deviation_mm\n0,0.001\n45,0.0005\n90,0.0\n135,-0.0005\n180,-0.001\n225,-0.0005\n270,0.0\n315,0.0005\n";

const BOM: &str = "\u{feff}";

#[test]
fn a_byte_order_mark_is_read_past_in_every_text_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let machine = succeeds(&["machines", "--show", "vmc-li2015"], d);
    // A machine file (TOML) whose CSV table starts with a mark too.
    let table: String = machine
        .lines()
        .map(|l| {
            if l.starts_with("EXX = ") {
                "EXX = { csv = \"x.csv\", column = \"EXX\" }\n".to_string()
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    assert_ne!(table, machine);
    std::fs::write(d.join("m.toml"), format!("{BOM}{table}")).unwrap();
    std::fs::write(
        d.join("x.csv"),
        format!("{BOM}position_mm,EXX\n0,0.0\n1000,0.02\n"),
    )
    .unwrap();
    std::fs::write(d.join("p.csv"), format!("{BOM}X,Y,Z\n100,100,100\n")).unwrap();
    let with_table = succeeds(
        &[
            "sample",
            "--exact",
            "--machine",
            "m.toml",
            "--points",
            "p.csv",
        ],
        d,
    );
    let inline = succeeds(
        &[
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "p.csv",
        ],
        d,
    );
    assert_eq!(with_table, inline);
    // G-code, a part file with an ASCII STL, a fit file with its CSV, a tolerance file, a
    // measured file and a build CSV.
    std::fs::write(
        d.join("p.nc"),
        format!("{BOM}G0 X10 Y10 Z10\nG1 X20 F100\n"),
    )
    .unwrap();
    succeeds(
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "p.nc",
            "--out",
            "o.nc",
        ],
        d,
    );
    std::fs::write(d.join("s.stl"), format!("{BOM}solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 50 0 0\nvertex 50 50 0\nendloop\nendfacet\nendsolid s\n")).unwrap();
    std::fs::write(d.join("part.toml"), format!("{BOM}name = \"s\"\n[placement]\nzero_mm = [100.0, 100.0, 100.0]\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 5.0\n[[features]]\nkind = \"profile\"\nname = \"skin\"\nmesh = \"s.stl\"\ntolerance_mm = 1.0\n")).unwrap();
    succeeds(
        &["features", "--machine", "vmc-li2015", "--part", "part.toml"],
        d,
    );
    std::fs::write(d.join("c.csv"), format!("{BOM}{CIRCLE}")).unwrap();
    std::fs::write(d.join("fit.toml"), format!("{BOM}estimate = [\"EC0Y\"]\n[[circular]]\nplane = \"XY\"\npoints = 8\ncsv = \"c.csv\"\n")).unwrap();
    succeeds(
        &[
            "fit",
            "--machine",
            "vmc-li2015",
            "--measurements",
            "fit.toml",
        ],
        d,
    );
    std::fs::write(
        d.join("t.toml"),
        format!("{BOM}[axes.Y]\nEC0Y = {{ uniform = 20e-6 }}\n"),
    )
    .unwrap();
    succeeds(
        &[
            "budget",
            "--machine",
            "vmc-li2015",
            "--grid",
            "3x3x3",
            "--device",
            "cpu",
            "--tolerances",
            "t.toml",
        ],
        d,
    );
    succeeds(
        &[
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--points",
            "4",
            "--measured",
            "c.csv",
        ],
        d,
    );
    std::fs::write(
        d.join("b.csv"),
        format!("{BOM}position_mm,EXX_um\n0,0\n500,2\n1000,3\n"),
    )
    .unwrap();
    succeeds(
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=b.csv",
            "--out",
            "b.toml",
        ],
        d,
    );
}
