//! `volmap sample`: columns carried through, positions outside the grid, the digits written and
//! memory that does not grow with the number of points.

use std::io::Write;
use std::path::Path;

use predicates::prelude::*;
use volmap::io::field::LoadedField;
use volmap::io::points::parse_points;
use volmap::query;

use super::sweep::{map, swept};
use super::{refused, volmap};

/// A 5×5×5 field of `vmc-li2015` (X 0 to 1000, Y 0 to 600, Z 0 to 500 mm).
fn field(dir: &Path) -> std::path::PathBuf {
    let field = dir.join("f.exr");
    volmap()
        .args(["map", "--machine", "vmc-li2015", "--grid", "5x5x5"])
        .args(["--device", "cpu", "--out"])
        .arg(&field)
        .assert()
        .success();
    field
}

#[test]
fn other_columns_pass_through_and_outside_positions_follow_outside() {
    let dir = tempfile::tempdir().unwrap();
    let field = field(dir.path());
    let points = dir.path().join("p.csv");
    std::fs::write(
        &points,
        "id,x,y,z,note\np1,500,300,250,first\n# a comment\np2,5000,0,0,far\np3,0.5,0,0,\n",
    )
    .unwrap();
    let out = dir.path().join("s.csv");
    let run = |outside: &str| {
        volmap()
            .args(["sample", "--device", "cpu", "--outside", outside, "--field"])
            .arg(&field)
            .arg("--points")
            .arg(&points)
            .arg("--out")
            .arg(&out)
            .assert()
    };
    let rows = || -> Vec<Vec<String>> {
        std::fs::read_to_string(&out)
            .unwrap()
            .lines()
            .map(|l| l.split(',').map(String::from).collect())
            .collect()
    };
    run("skip")
        .success()
        .stderr(predicate::str::contains("1 position(s)").and(predicate::str::contains("line 4")));
    let skipped = rows();
    assert_eq!(
        skipped[0].join(","),
        "id,x,y,z,note,VE.X,VE.Y,VE.Z,OE.X,OE.Y,OE.Z"
    );
    assert_eq!(skipped.len(), 3);
    assert_eq!(skipped[1][..5].join(","), "p1,500,300,250,first");
    assert_eq!(skipped[2][..5].join(","), "p3,0.5,0,0,");
    run("nan").success();
    let nan = rows();
    assert_eq!(nan.len(), 4);
    assert_eq!(nan[2][..5].join(","), "p2,5000,0,0,far");
    assert!(nan[2][5..].iter().all(|v| v == "NaN"), "{:?}", nan[2]);
    assert_eq!(nan[1], skipped[1]);
    assert_eq!(nan[3], skipped[2]);
    std::fs::remove_file(&out).unwrap();
    run("error").code(2).stderr(predicate::str::contains(
        "p.csv: line 4: X=5000 lies outside",
    ));
    // Nothing half written under the name asked for, nor a temporary file left.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    // Without --outside a position outside is an error too; with --exact, a position outside
    // the machine's travels likewise (the model is not evaluated where the machine cannot go).
    volmap()
        .args(["sample", "--device", "cpu", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("line 4"));
    let exact = |extra: &[&str]| {
        let mut command = volmap();
        command
            .args(["sample", "--exact", "--machine", "vmc-li2015"])
            .args(extra)
            .arg("--points")
            .arg(&points);
        command.assert()
    };
    exact(&[]).code(2).stderr(predicate::str::contains(
        "p.csv: line 4: X=5000 lies outside the machine's travel (0 to 1000)",
    ));
    let skipped = exact(&["--outside", "skip"]).success();
    let text = String::from_utf8(skipped.get_output().stdout.clone()).unwrap();
    assert_eq!(text.lines().count(), 3, "{text}");
    assert!(!text.lines().any(|l| l.starts_with("p2,")), "{text}");
}

#[test]
fn values_are_the_shortest_decimals_that_read_back_to_the_same_value() {
    let dir = tempfile::tempdir().unwrap();
    let field = field(dir.path());
    let text = "X,Y,Z\n500,300,250\n123.25,77.5,401.125\n999.9,0.1,0.3\n";
    let points = dir.path().join("p.csv");
    std::fs::write(&points, text).unwrap();
    let parsed = parse_points(text, "p.csv").unwrap();
    let sampled =
        query::sample_field(&LoadedField::open(&field).unwrap(), &parsed, "p.csv").unwrap();
    let output = volmap()
        .args(["sample", "--device", "cpu", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .output()
        .unwrap();
    assert!(output.status.success());
    let text = String::from_utf8(output.stdout).unwrap();
    // A header and a row per point, each row the position's 3 columns and 6 values.
    assert_eq!(sampled.len(), 3);
    assert_eq!(text.lines().count(), sampled.len() + 1, "{text}");
    for (line, expected) in text.lines().skip(1).zip(&sampled) {
        assert_eq!(line.split(',').count(), 3 + expected.len(), "{line}");
        for (value, &expected) in line.split(',').skip(3).zip(expected) {
            let expected = expected as f32;
            assert_eq!(value.parse::<f32>().unwrap(), expected, "{line}");
            // An f32 needs at most 9 significant digits; f64's 17 are noise.
            let digits = value
                .trim_start_matches(['-', '0', '.'])
                .split(['e', 'E'])
                .next()
                .unwrap()
                .chars()
                .filter(char::is_ascii_digit)
                .count();
            assert!(digits <= 9, "{value} in {line}");
            // And none shorter reads back the same: one digit fewer changes the value.
            if digits > 1 {
                let shorter = format!("{:.*e}", digits - 2, expected);
                assert_ne!(shorter.parse::<f32>().unwrap(), expected, "{value}");
            }
        }
    }
    // Exact values keep f64's shortest round trip.
    let exact = volmap()
        .args(["sample", "--exact", "--machine", "vmc-li2015", "--points"])
        .arg(&points)
        .output()
        .unwrap();
    assert!(
        exact.status.success(),
        "{}",
        String::from_utf8_lossy(&exact.stderr)
    );
    let machine = volmap::io::embedded::load("vmc-li2015").unwrap();
    let expected = query::sample_exact(&machine, &parsed);
    let text = String::from_utf8(exact.stdout).unwrap();
    assert_eq!(expected.len(), 3);
    assert_eq!(text.lines().count(), expected.len() + 1, "{text}");
    for (line, expected) in text.lines().skip(1).zip(&expected) {
        let values: Vec<f64> = line
            .split(',')
            .skip(3)
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(values, expected, "{line}");
    }
}

/// The peak resident memory of `volmap sample` on `count` generated points, in bytes: the
/// child's own `VmHWM`, read from `/proc` while it runs. (`wait4`'s `ru_maxrss` would not do: a
/// child spawned with `CLONE_VM` carries the parent's peak over its `exec`, and this test
/// process, holding other tests' work, can be larger than the bound.)
#[cfg(target_os = "linux")]
fn peak_memory_of_sample(dir: &Path, field: &Path, count: usize) -> u64 {
    let points = dir.join(format!("p{count}.csv"));
    let mut file = std::io::BufWriter::new(std::fs::File::create(&points).unwrap());
    writeln!(file, "id,X,Y,Z").unwrap();
    for n in 0..count {
        let (x, y, z) = (n % 997, n / 997 % 499, n % 401);
        writeln!(file, "{n},{x}.5,{y}.25,{z}.125").unwrap();
    }
    file.flush().unwrap();
    drop(file);
    // The samples go to a pipe, counted as they come: the disk holds only the points.
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("volmap"))
        .args(["sample", "--device", "cpu", "--field"])
        .arg(field)
        .arg("--points")
        .arg(&points)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let counter = std::thread::spawn(move || {
        let mut reader = std::io::BufReader::new(stdout);
        let (mut rows, mut line) = (0usize, Vec::new());
        while std::io::BufRead::read_until(&mut reader, b'\n', &mut line).unwrap() > 0 {
            rows += 1;
            line.clear();
        }
        rows
    });
    let status_file = format!("/proc/{}/status", child.id());
    let mut peak_kb = 0u64;
    let status = loop {
        // Only once the child is volmap: before its exec it shares this process's memory.
        if let Ok(text) = std::fs::read_to_string(&status_file) {
            let field = |key: &str| {
                text.lines()
                    .find_map(|l| l.strip_prefix(key))
                    .map(str::trim)
            };
            if field("Name:") == Some("volmap") {
                if let Some(kb) = field("VmHWM:")
                    .and_then(|v| v.trim_end_matches("kB").trim().parse::<u64>().ok())
                {
                    peak_kb = peak_kb.max(kb);
                }
            }
        }
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    };
    assert!(status.success(), "{count} points: {status}");
    assert!(peak_kb > 0, "the child's memory was never read");
    assert_eq!(counter.join().unwrap(), count + 1);
    std::fs::remove_file(&points).unwrap();
    peak_kb * 1024
}

/// Not timed: 2,000,000 points take no more memory than 200,000 (within 64 MiB, where holding
/// every point, its row and its answer takes about 300 bytes a point, 540 MB more), and neither
/// more than 256 MiB. The allowance is for the allocator's per-thread arenas, which grow with
/// the cores and the load (on a 16-core machine running the suite a peak passed 160 MiB).
#[cfg(target_os = "linux")]
#[test]
fn memory_stays_flat_in_the_number_of_points() {
    let dir = tempfile::tempdir().unwrap();
    let field = field(dir.path());
    let bound = 256 << 20;
    let peaks: Vec<u64> = [200_000, 2_000_000]
        .into_iter()
        .map(|count| {
            let peak = peak_memory_of_sample(dir.path(), &field, count);
            assert!(
                peak < bound,
                "{count} points: {peak} bytes resident at the peak"
            );
            peak
        })
        .collect();
    assert!(
        peaks[1] < peaks[0] + (64 << 20),
        "resident at the peak: {} bytes for 200,000 points, {} for 2,000,000",
        peaks[0],
        peaks[1]
    );
}

/// The samples (CSV rows without the position columns) `volmap sample` writes.
fn sample(field: &Path, points: &Path) -> Vec<String> {
    let output = volmap()
        .args(["sample", "--device", "cpu", "--field"])
        .arg(field)
        .arg("--points")
        .arg(points)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').skip(5).collect::<Vec<_>>().join(","))
        .collect()
}

#[test]
fn sample_picks_the_part_of_each_points_pose() {
    let dir = tempfile::tempdir().unwrap();
    let field = swept(dir.path());
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    map(&["--pose", "B=90,C=180"], "cpu", &a);
    map(&["--pose", "B=-90,C=0"], "cpu", &b);
    let points = dir.path().join("p.csv");
    std::fs::write(
        &points,
        "X,Y,Z,B,C\n100,200,300,90,180\n# a comment\n412.5,37,480,-90,0\n700,550,20,90,180\n",
    )
    .unwrap();
    let from_sweep = sample(&field, &points);
    let only = |keep: &[usize]| {
        let text = std::fs::read_to_string(&points).unwrap();
        let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        let path = dir.path().join("only.csv");
        let mut out = rows[0].to_string();
        for &n in keep {
            out.push('\n');
            out.push_str(rows[n + 1]);
        }
        std::fs::write(&path, out).unwrap();
        path
    };
    let at_a = sample(&a, &only(&[0, 2]));
    let at_b = sample(&b, &only(&[1]));
    assert_eq!(
        from_sweep,
        [at_a[0].clone(), at_b[0].clone(), at_a[1].clone()]
    );

    // A pose the file does not hold: exit 2, naming the line and listing the poses.
    std::fs::write(&points, "X,Y,Z,B,C\n100,200,300,90,180\n100,200,300,45,0\n").unwrap();
    volmap()
        .args(["sample", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("line 3")
                .and(predicate::str::contains("B=45,C=0"))
                .and(predicate::str::contains("B=-90,C=0 B=-90,C=90"))
                .and(predicate::str::contains("B=90,C=270")),
        );
    // Columns that leave several parts: exit 2, saying which column to add.
    std::fs::write(&points, "X,Y,Z,B\n100,200,300,90\n").unwrap();
    volmap()
        .args(["sample", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("line 2").and(predicate::str::contains("column C")));
}

/// A machine without a Y axis: the points file holds X, Y and Z, and Y is 0 on it.
#[test]
fn a_machine_without_a_linear_axis_is_sampled_at_its_zero() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("xz.toml"),
        "name = \"two axes\"\nchain = \"FXFZ\"\n[axes.X]\nrange = [0.0, 100.0]\nEXX = { poly = [0.0, 2.4e-4] }\n[axes.Z]\nrange = [0.0, 100.0]\nEZZ = 1e-7\n",
    )
    .unwrap();
    std::fs::write(d.join("q.csv"), "X,Y,Z\n50,0,20\n").unwrap();
    let output = volmap()
        .args([
            "sample",
            "--exact",
            "--machine",
            "xz.toml",
            "--points",
            "q.csv",
        ])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).unwrap();
    let row: Vec<f64> = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // EXX = 2.4e-4·x at x = 50 and EZZ = 1e-7: VE = (0.012, 0, 1e-7).
    assert!(
        (row[3] - 0.012).abs() < 1e-12 && row[4] == 0.0 && (row[5] - 1e-7).abs() < 1e-12,
        "{text}"
    );
    std::fs::write(d.join("q.csv"), "X,Y,Z\n50,5,20\n").unwrap();
    refused(
        &[
            "sample",
            "--exact",
            "--machine",
            "xz.toml",
            "--points",
            "q.csv",
        ],
        d,
        &["q.csv: line 2: Y=5 lies outside the machine's travel (0 to 0)"],
    );
}

#[test]
fn the_rows_before_a_position_outside_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let field = field(dir.path());
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "X,Y,Z\n10,10,10\n20,20,20\n99999,0,0\n30,30,30\n").unwrap();
    let out = volmap()
        .args(["sample", "--device", "cpu", "--field"])
        .arg(&field)
        .arg("--points")
        .arg(&points)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "line 4: X=99999 lies outside the field's grid",
        ));
    let text = String::from_utf8(out.get_output().stdout.clone()).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // The header and lines 2 and 3, nothing of line 4 or after.
    assert_eq!(lines.len(), 3, "{text}");
    assert!(
        lines[1].starts_with("10,10,10,") && lines[2].starts_with("20,20,20,"),
        "{text}"
    );
}
