//! Messages that say where, and nothing accepted in silence: errors inside a fit file's tests
//! name the file and the test, a bad work offset names the offset, a byte-order mark is read
//! past, nesting limits name the line, and every value a machine cannot take is an error.

use std::path::Path;

use predicates::prelude::*;

use super::volmap;

/// Runs volmap in `dir` and requires exit 2 with stderr containing `says`.
fn fails(dir: &Path, args: &[&str], says: &str) {
    let output = volmap().current_dir(dir).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(stderr.contains(says), "{args:?}: {stderr}");
}

/// Runs volmap in `dir` and requires success.
fn runs(dir: &Path, args: &[&str]) -> String {
    super::succeeds(args, dir)
}

/// A measured circle of 8 points.
const CIRCLE: &str = "angle_deg,deviation_mm\n0,0.001\n45,0.0005\n90,0.0\n135,-0.0005\n180,-0.001\n225,-0.0005\n270,0.0\n315,0.0005\n";

#[test]
fn errors_inside_a_fit_files_tests_name_the_file_and_the_test() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("c.csv"), CIRCLE).unwrap();
    std::fs::write(
        d.join("pos.csv"),
        "target_mm,direction,run,deviation_mm\n0,+,1,0\n1000,+,1,0.002\n1000,-,1,0.002\n0,-,1,0\n",
    )
    .unwrap();
    let fit = |name: &str, body: &str, says: &str| {
        std::fs::write(d.join(name), format!("estimate = [\"EC0Y\"]\n{body}")).unwrap();
        fails(
            d,
            &["fit", "--machine", "vmc-li2015", "--measurements", name],
            says,
        );
    };
    fit(
        "a.toml",
        "[[circular]]\nplane = \"XQ\"\ncsv = \"c.csv\"\n",
        "a.toml: [[circular]] number 1: plane `XQ`: XY, YZ or ZX",
    );
    fit(
        "b.toml",
        "[[circular]]\nplane = \"XY\"\npoints = 8\ncsv = \"c.csv\"\n[[circular]]\nplane = \"XY\"\nradius_mm = 5000.0\npoints = 8\ncsv = \"c.csv\"\n",
        "b.toml: [[circular]] number 2: circle in XY",
    );
    fit(
        "c.toml",
        "[[diagonal]]\ndiagonal = \"PPP\"\ncsv = \"absent.csv\"\n",
        "c.toml: [[diagonal]] number 1: ",
    );
    fit(
        "d.toml",
        "[[positioning]]\naxis = \"X\"\npose = \"B=30\"\ncsv = \"pos.csv\"\n",
        "d.toml: [[positioning]] number 1: B is not an axis of this machine",
    );
    fit(
        "e.toml",
        "[[circular]]\nplane = \"XY\"\npoints = 8\ncsv = \"pos.csv\"\n",
        "e.toml: [[circular]] number 1: ",
    );
}

#[test]
fn a_work_offset_that_is_not_a_number_names_the_offset() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G54 G0 X10 Y10 Z10\nG1 X20 F100\n").unwrap();
    let compensate = [
        "compensate",
        "--machine",
        "vmc-li2015",
        "--program",
        "p.nc",
        "--out",
        "o.nc",
    ];
    fn with<'a>(compensate: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
        [compensate, extra].concat()
    }
    fails(
        d,
        &with(&compensate, &["--work-offset", "G54=nan,0,0"]),
        "--work-offset: work offset `G54=nan,0,0`: G54: its X value is not a finite number",
    );
    std::fs::write(
        d.join("w.toml"),
        "G55 = [0.0, 0.0, 0.0]\nG54 = [0.0, inf, 0.0]\n",
    )
    .unwrap();
    fails(
        d,
        &with(&compensate, &["--work-offset-file", "w.toml"]),
        "w.toml: work offset `G54=0,inf,0`: G54: its Y value is not a finite number",
    );
    fails(
        d,
        &with(&compensate, &["--tool-length", "T1=nan"]),
        "--tool-length",
    );
    assert!(!d.join("o.nc").exists());
}

const BOM: &str = "\u{feff}";

#[test]
fn a_byte_order_mark_is_read_past_in_every_text_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let machine = runs(d, &["machines", "--show", "vmc-li2015"]);
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
    let with_table = runs(
        d,
        &[
            "sample",
            "--exact",
            "--machine",
            "m.toml",
            "--points",
            "p.csv",
        ],
    );
    let inline = runs(
        d,
        &[
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "p.csv",
        ],
    );
    assert_eq!(with_table, inline);
    // G-code, a part file with an ASCII STL, a fit file with its CSV, a tolerance file, a
    // measured file and a build CSV.
    std::fs::write(
        d.join("p.nc"),
        format!("{BOM}G0 X10 Y10 Z10\nG1 X20 F100\n"),
    )
    .unwrap();
    runs(
        d,
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "p.nc",
            "--out",
            "o.nc",
        ],
    );
    std::fs::write(d.join("s.stl"), format!("{BOM}solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 50 0 0\nvertex 50 50 0\nendloop\nendfacet\nendsolid s\n")).unwrap();
    std::fs::write(d.join("part.toml"), format!("{BOM}name = \"s\"\n[placement]\nzero_mm = [100.0, 100.0, 100.0]\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 5.0\n[[features]]\nkind = \"profile\"\nname = \"skin\"\nmesh = \"s.stl\"\ntolerance_mm = 1.0\n")).unwrap();
    runs(
        d,
        &["features", "--machine", "vmc-li2015", "--part", "part.toml"],
    );
    std::fs::write(d.join("c.csv"), format!("{BOM}{CIRCLE}")).unwrap();
    std::fs::write(d.join("fit.toml"), format!("{BOM}estimate = [\"EC0Y\"]\n[[circular]]\nplane = \"XY\"\npoints = 8\ncsv = \"c.csv\"\n")).unwrap();
    runs(
        d,
        &[
            "fit",
            "--machine",
            "vmc-li2015",
            "--measurements",
            "fit.toml",
        ],
    );
    std::fs::write(
        d.join("t.toml"),
        format!("{BOM}[axes.Y]\nEC0Y = {{ uniform = 20e-6 }}\n"),
    )
    .unwrap();
    runs(
        d,
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
    );
    runs(
        d,
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
    );
    std::fs::write(
        d.join("b.csv"),
        format!("{BOM}position_mm,EXX_um\n0,0\n500,2\n1000,3\n"),
    )
    .unwrap();
    runs(
        d,
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=b.csv",
            "--out",
            "b.toml",
        ],
    );
}

#[test]
fn nesting_limits_name_the_file_and_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let deep = format!(
        "name = \"deep\"\nchain = \"FFXYZ\"\ndescription = {}{}\n",
        "[".repeat(100_000),
        "]".repeat(100_000)
    );
    std::fs::write(d.join("deep.toml"), deep).unwrap();
    fails(
        d,
        &["map", "--grid", "2x2x2", "--machine", "deep.toml"],
        "deep.toml: line 3, column",
    );
    std::fs::write(
        d.join("self.nc"),
        "G0 X10 Y10 Z10\nM98 P1\nM30\nO1\nG1 X20 F100\nM98 P1\nM99\n",
    )
    .unwrap();
    fails(
        d,
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "self.nc",
            "--out",
            "o.nc",
        ],
        "self.nc: line 6: M98: calls nest deeper than 8 levels",
    );
    // Calls repeated a thousand times at each of three levels: a billion blocks, refused.
    std::fs::write(d.join("many.nc"), "G0 X10 Y10 Z10\nM98 P1 L1000\nM30\nO1\nM98 P2 L1000\nM99\nO2\nM98 P3 L1000\nM99\nO3\nG1 X20 F100\nM99\n").unwrap();
    fails(
        d,
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "many.nc",
            "--out",
            "o.nc",
        ],
        "M98: the calls add more than 4000000 words and blocks to the program",
    );
}

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
    fails(
        d,
        &sample("b.csv", &["--machine", "vmc-li2015"]),
        "b.csv: line 1: column B: the machine (chain FFXYZ) has no B axis",
    );
    std::fs::write(d.join("p.csv"), "X,Y,Z\n10,10,10\n").unwrap();
    fails(
        d,
        &sample(
            "p.csv",
            &["--machine", "5axis-hwang2014", "--pose", "B=30,B=40"],
        ),
        "--pose: B is named twice",
    );
    fails(
        d,
        &sample("p.csv", &["--machine", "vmc-li2015", "--pose", "A=5"]),
        "--pose: A is not an axis of this machine",
    );
    // A column named twice, in each kind of CSV.
    std::fs::write(d.join("dup.csv"), "X,Y,Z,id,id\n10,10,10,a,b\n").unwrap();
    fails(
        d,
        &sample("dup.csv", &["--machine", "vmc-li2015"]),
        "dup.csv: line 1: column `id` appears twice (columns 4 and 5)",
    );
    std::fs::write(
        d.join("m.csv"),
        "angle_deg,deviation_mm,deviation_mm\n0,0,0\n",
    )
    .unwrap();
    fails(
        d,
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
        "m.csv: line 1: column `deviation_mm` appears twice",
    );
    std::fs::write(
        d.join("x.csv"),
        "position_mm,EXX_um,EXX_um\n0,0,0\n1000,1,1\n",
    )
    .unwrap();
    fails(
        d,
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            "X=x.csv",
            "--out",
            "o.toml",
        ],
        "x.csv: line 1: column `EXX_um` appears twice",
    );
    // A tool number beyond what a control holds.
    std::fs::write(
        d.join("t.nc"),
        "G0 X10 Y10 Z10\nT4294967296 M6\nG1 X20 F100\n",
    )
    .unwrap();
    fails(
        d,
        &[
            "compensate",
            "--machine",
            "vmc-li2015",
            "--program",
            "t.nc",
            "--out",
            "o.nc",
        ],
        "t.nc: line 2: `T4294967296`: a tool number is a whole number from 0 to 4294967295",
    );
    // Positions beyond the travel with --exact (as with a field), unless --outside says.
    std::fs::write(d.join("far.csv"), "X,Y,Z\n10,10,10\n2000,10,10\n").unwrap();
    fails(
        d,
        &sample("far.csv", &["--machine", "vmc-li2015"]),
        "far.csv: line 3: X=2000 lies outside the machine's travel (0 to 1000)",
    );
    let skipped = runs(
        d,
        &sample("far.csv", &["--machine", "vmc-li2015", "--outside", "skip"]),
    );
    assert_eq!(skipped.lines().count(), 2, "{skipped}");
    // Part features beyond the travel, and a part pose for an axis the machine lacks.
    let part = |zero: &str, pose: &str| {
        format!("name = \"p\"\n[placement]\nzero_mm = {zero}\n{pose}\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 5.0\n[[features]]\nkind = \"end_milled_plane\"\nname = \"floor\"\ncorner_mm = [0.0, 0.0, 0.0]\nsize_mm = [100.0, 50.0]\ntolerance_mm = 0.05\n")
    };
    std::fs::write(d.join("far.toml"), part("[950.0, 100.0, 100.0]", "")).unwrap();
    fails(d, &["features", "--machine", "vmc-li2015", "--part", "far.toml"], "far.toml: feature `floor`: the cutter position X=1005 mm lies outside the travel of X (0 to 1000)");
    std::fs::write(
        d.join("posed.toml"),
        part("[100.0, 100.0, 100.0]", "pose_deg = { B = 30.0 }"),
    )
    .unwrap();
    fails(d, &["features", "--machine", "vmc-li2015", "--part", "posed.toml"], "posed.toml: feature `(placement)`: pose_deg: B=30°, but the machine (chain FFXYZ) has no B axis");
    std::fs::write(d.join("near.toml"), part("[100.0, 100.0, 100.0]", "")).unwrap();
    volmap()
        .current_dir(d)
        .args(["features", "--machine", "vmc-li2015", "--part", "near.toml"])
        .assert()
        .success()
        .stdout(predicate::str::contains("floor"));
}
