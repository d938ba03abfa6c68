//! A Monte Carlo study split into shards (`budget --shard K/M --per-sample FILE.json`), run as
//! separate processes as a batch scheduler runs them, and put together by `merge-samples`: the
//! statistics of one run of all the samples, byte for byte; shards missing, repeated or of
//! another study refused naming the file.

use std::path::{Path, PathBuf};

use predicates::prelude::*;

use super::volmap;

const SAMPLES: &str = "100";

fn tolerances() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/tolerances/vmc-li2015.toml")
}

/// The arguments of `budget` of vmc-li2015 on a small grid with `extra` (CPU engine: the same
/// figures on every machine the suite runs on).
fn budget_args(extra: &[&str]) -> Vec<std::ffi::OsString> {
    let mut args: Vec<std::ffi::OsString> = [
        "budget",
        "--machine",
        "vmc-li2015",
        "--grid",
        "9x8x7",
        "--samples",
        SAMPLES,
        "--spec",
        "0.14",
        "--device",
        "cpu",
        "--tolerances",
    ]
    .iter()
    .map(Into::into)
    .collect();
    args.push(tolerances().into());
    args.extend(extra.iter().map(Into::into));
    args
}

fn budget(extra: &[&str]) -> assert_cmd::Command {
    let mut command = volmap();
    command.args(budget_args(extra));
    command
}

/// The JSON block of the key `monte_carlo`, as written.
/// Waits for every shard running as its own process; each must succeed.
fn wait_for_all(jobs: Vec<std::process::Child>) {
    for job in jobs {
        let done = job.wait_with_output().unwrap();
        assert!(
            done.status.success(),
            "{}",
            String::from_utf8_lossy(&done.stderr)
        );
    }
}

fn monte_carlo_text(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let start = text
        .find("\"monte_carlo\": {")
        .expect("a monte_carlo block");
    // The block ends at the brace indented as its key is.
    let indent = &text[text[..start].rfind('\n').map_or(0, |n| n + 1)..start];
    let end = start
        + text[start..]
            .find(&format!("\n{indent}}}"))
            .expect("the block's end");
    text[start..end].to_string()
}

/// Three shards started at once as separate processes (a job array), merged in another order:
/// the `monte_carlo` block equals that of one run of the 100 samples byte for byte; the shards
/// hold samples 0..33, 33..66 and 66..100.
#[test]
fn three_shards_merge_to_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let shard = |k: usize| dir.path().join(format!("shard-{k}.json"));
    let jobs: Vec<std::process::Child> = (0..3)
        .map(|k| {
            std::process::Command::new(assert_cmd::cargo::cargo_bin("volmap"))
                .args(budget_args(&["--shard", &format!("{k}/3")]))
                .arg("--per-sample")
                .arg(shard(k))
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    wait_for_all(jobs);
    let one = dir.path().join("one.json");
    budget(&["--json"]).arg(&one).assert().success();
    let merged = dir.path().join("merged.json");
    volmap()
        .arg("merge-samples")
        .args([shard(2), shard(0), shard(1)])
        .arg("--out")
        .arg(&merged)
        .assert()
        .success()
        .stderr(predicate::str::contains("error").not())
        .stdout(predicate::str::contains("100 machines"));
    assert_eq!(monte_carlo_text(&merged), monte_carlo_text(&one));
    let firsts: Vec<(u64, usize)> = (0..3)
        .map(|k| {
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(shard(k)).unwrap()).unwrap();
            (
                v["first"].as_u64().unwrap(),
                v["results"]["fields"].as_array().unwrap().len(),
            )
        })
        .collect();
    assert_eq!(firsts, [(0, 33), (33, 33), (66, 34)]);
}

/// A shard's per-sample CSV numbers its samples from the shard's first, and its rows (draws and
/// statistics) are those of the same samples in one run.
#[test]
fn a_shards_csv_rows_are_those_of_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let (one, part) = (dir.path().join("one.csv"), dir.path().join("part.csv"));
    budget(&["--per-sample"]).arg(&one).assert().success();
    budget(&["--shard", "1/3", "--per-sample"])
        .arg(&part)
        .assert()
        .success();
    let one = std::fs::read_to_string(one).unwrap();
    let part = std::fs::read_to_string(part).unwrap();
    let rows: Vec<&str> = one.lines().skip(1 + 33).take(33).collect();
    assert_eq!(part.lines().skip(1).collect::<Vec<_>>(), rows);
    assert!(rows[0].starts_with("33,"), "{}", rows[0]);
}

/// Shards missing, repeated or of another study, and files that are not sample files: exit 2,
/// the file named, nothing written; a shard out of range or empty, or without a file to write
/// its samples to, is refused before any work.
#[test]
fn merge_refuses_what_is_not_one_study() {
    let dir = tempfile::tempdir().unwrap();
    let shard = |k: usize, seed: &str| {
        let path = dir.path().join(format!("s{k}-{seed}.json"));
        budget(&["--shard", &format!("{k}/2"), "--seed", seed, "--per-sample"])
            .arg(&path)
            .assert()
            .success();
        path
    };
    let (a, b, other) = (shard(0, "0"), shard(1, "0"), shard(1, "7"));
    let out = dir.path().join("merged.json");
    let merge = |files: &[&PathBuf], says: &str, names: &PathBuf| {
        volmap()
            .arg("merge-samples")
            .args(files)
            .arg("--out")
            .arg(&out)
            .assert()
            .code(2)
            .stderr(
                predicate::str::contains(says)
                    .and(predicate::str::contains(names.display().to_string())),
            );
        assert!(!out.exists());
    };
    merge(&[&a], "a shard is missing", &a);
    merge(&[&a, &a, &b], "overlap", &a);
    merge(&[&a, &other], "seed differ", &other);
    let not_samples = dir.path().join("budget.json");
    budget(&["--json"]).arg(&not_samples).assert().success();
    merge(&[&a, &not_samples], "not a sample file", &not_samples);
    for (shard, says) in [
        ("2/2", "K < M"),
        (
            "0/200",
            "200 shards of 100 samples or poses leave some empty",
        ),
    ] {
        budget(&["--shard", shard, "--per-sample"])
            .arg(dir.path().join("x.json"))
            .assert()
            .code(2)
            .stderr(predicate::str::contains(says));
    }
    budget(&["--shard", "0/2"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--per-sample"));
}

/// `features --tolerances` in two shards merges into the very file `features --json` writes over
/// all the samples, byte for byte; a budget shard and a features shard are not one study.
#[test]
fn feature_shards_merge_to_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let part = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/li2015-part.toml");
    let features = |extra: &[&str], out: &Path| {
        volmap()
            .args(["features", "--machine", "vmc-li2015", "--samples", "40"])
            .args(["--seed", "4", "--device", "cpu", "--part"])
            .arg(&part)
            .arg("--tolerances")
            .arg(tolerances())
            .args(extra)
            .arg(out)
            .assert()
            .success();
    };
    let shard = |k: usize| dir.path().join(format!("f{k}.json"));
    for k in 0..2 {
        features(&["--shard", &format!("{k}/2"), "--per-sample"], &shard(k));
    }
    let one = dir.path().join("one.json");
    features(&["--json"], &one);
    let merged = dir.path().join("merged.json");
    volmap()
        .arg("merge-samples")
        .args([shard(1), shard(0)])
        .arg("--out")
        .arg(&merged)
        .assert()
        .success();
    // The result as one run writes it; the envelopes name their own commands.
    assert_eq!(super::json_result(&merged), super::json_result(&one));
    let fields = dir.path().join("fields.json");
    budget(&["--shard", "1/2", "--per-sample"])
        .arg(&fields)
        .assert()
        .success();
    volmap()
        .arg("merge-samples")
        .args([&shard(0), &fields])
        .arg("--out")
        .arg(&merged)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("another study"));
}

/// `map --poses … --shard K/M` in three processes, merged: the very file one run over every
/// pose writes, byte for byte. A shard given twice, a field of one pose, another grid: exit 2
/// naming the file, nothing written; `--shard` without `--poses` is refused.
#[test]
fn map_shards_merge_to_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let map = |grid: &str, extra: &[&str], out: &Path| {
        let mut command = std::process::Command::new(assert_cmd::cargo::cargo_bin("volmap"));
        command
            .args(["map", "--machine", "5axis-hwang2014", "--grid", grid])
            .args(["--poses", "B=-30:30:15,C=0:90:45", "--device", "cpu"])
            .args(extra)
            .arg("--out")
            .arg(out)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped());
        command
    };
    let shard = |k: usize| dir.path().join(format!("map-{k}.exr"));
    let jobs: Vec<std::process::Child> = (0..3)
        .map(|k| {
            map("8x7x6", &["--shard", &format!("{k}/3")], &shard(k))
                .spawn()
                .unwrap()
        })
        .collect();
    wait_for_all(jobs);
    let one = dir.path().join("one.exr");
    assert!(map("8x7x6", &[], &one).status().unwrap().success());
    let merged = dir.path().join("merged.exr");
    volmap()
        .arg("merge-maps")
        .args([shard(0), shard(1), shard(2)])
        .arg("--out")
        .arg(&merged)
        .assert()
        .success()
        .stdout(predicate::str::contains("15 poses"));
    assert_eq!(
        std::fs::read(&merged).unwrap(),
        std::fs::read(&one).unwrap()
    );

    let other_grid = dir.path().join("other.exr");
    assert!(map("5x5x5", &["--shard", "2/3"], &other_grid)
        .status()
        .unwrap()
        .success());
    let single = dir.path().join("single.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "4x4x4",
            "--device",
            "cpu",
        ])
        .arg("--out")
        .arg(&single)
        .assert()
        .success();
    let out = dir.path().join("refused.exr");
    for (files, says, names) in [
        (vec![shard(0), shard(0)], "an earlier file too", shard(0)),
        (
            vec![shard(0), other_grid.clone()],
            "another grid",
            other_grid.clone(),
        ),
        (vec![single.clone()], "a field of one pose", single.clone()),
    ] {
        volmap()
            .arg("merge-maps")
            .args(&files)
            .arg("--out")
            .arg(&out)
            .assert()
            .code(2)
            .stderr(
                predicate::str::contains(says)
                    .and(predicate::str::contains(names.display().to_string())),
            );
        assert!(!out.exists());
    }
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "4x4x4",
            "--shard",
            "0/2",
        ])
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--poses"));
}
