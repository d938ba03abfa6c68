//! Every command's `--json`: one envelope (docs/json.md) around the command's result, the machine
//! named by one hash wherever it is read from, and each file valid against its command's JSON
//! Schema in docs/schema/, checked with the Python jsonschema package as a user's script would.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::{s, volmap};

fn example(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(path)
        .display()
        .to_string()
}

/// The reports a test wrote, by command, to validate together.
#[derive(Default)]
struct Reports {
    dir: PathBuf,
    files: BTreeMap<String, Vec<PathBuf>>,
}

impl Reports {
    fn new(dir: &Path) -> Reports {
        Reports {
            dir: dir.to_path_buf(),
            files: BTreeMap::new(),
        }
    }

    /// Runs `volmap ARGS --json NAME.json` in the folder (exit code 0, or one of `codes`) and
    /// returns the report, its envelope checked.
    fn run(&mut self, name: &str, args: &[&str], codes: &[i32]) -> Value {
        let path = self.dir.join(format!("{name}.json"));
        let mut all: Vec<&str> = args.to_vec();
        all.extend(["--json", s(&path)]);
        self.read(&path, &all, codes)
    }

    /// Runs `volmap ARGS` that writes its report to `path` itself (`merge-samples --out`).
    fn read(&mut self, path: &Path, args: &[&str], codes: &[i32]) -> Value {
        let output = volmap().args(args).current_dir(&self.dir).output().unwrap();
        let code = output.status.code().unwrap_or(-1);
        assert!(
            code == 0 || codes.contains(&code),
            "{args:?}: exit {code}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        let report: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        let command = args[0];
        assert_eq!(report["schema"], 1, "{args:?}");
        assert_eq!(report["volmap"], env!("CARGO_PKG_VERSION"), "{args:?}");
        assert_eq!(report["command"]["name"], command, "{args:?}");
        let arguments: Vec<&str> = report["command"]["arguments"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a.as_str().unwrap())
            .collect();
        assert_eq!(arguments, args, "the arguments as given");
        assert!(report.get("result").is_some(), "{args:?}");
        self.files
            .entry(command.to_string())
            .or_default()
            .push(path.to_path_buf());
        report
    }

    /// Validates every report against its command's schema.
    fn validate(&self) {
        for (command, files) in &self.files {
            if let Some(output) = validated(command, files) {
                assert!(
                    output.status.success(),
                    "{command}: {}{}",
                    String::from_utf8_lossy(&output.stdout),
                    String::from_utf8_lossy(&output.stderr)
                );
            }
        }
    }
}

/// `tests/python/validate_json.py` on `files` against docs/schema/COMMAND.json; `None` (the test
/// skips) where Python's jsonschema is missing, unless `VOLMAP_REQUIRE_READERS` makes that a
/// failure.
pub(super) fn validated(command: &str, files: &[PathBuf]) -> Option<std::process::Output> {
    if !crate::field::tool_available(
        std::process::Command::new("python3").args(["-c", "import jsonschema"]),
        "the Python jsonschema package",
    ) {
        return None;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Some(
        std::process::Command::new("python3")
            .arg(root.join("tests/python/validate_json.py"))
            .arg(root.join("docs/schema").join(format!("{command}.json")))
            .args(files)
            .output()
            .unwrap(),
    )
}

fn sha(report: &Value) -> &str {
    report["machine"]["sha256"].as_str().unwrap()
}

#[test]
fn maps_fields_and_samples_name_one_machine_by_one_hash() {
    let dir = tempfile::tempdir().unwrap();
    let mut reports = Reports::new(dir.path());
    let list = reports.run("machines", &["machines"], &[]);
    assert!(list["machine"].is_null());
    let listed = list["result"]["machines"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == "vmc-li2015")
        .unwrap()["sha256"]
        .clone();
    let shown = reports.run("show", &["machines", "--show", "vmc-li2015"], &[]);
    assert_eq!(shown["machine"]["sha256"], listed);
    let map = reports.run(
        "map",
        &[
            "map",
            "--machine",
            "vmc-li2015",
            "--grid",
            "6x5x4",
            "--device",
            "cpu",
            "--check",
            "5",
            "--approach",
            "X=-",
            "--out",
            "f.exr",
        ],
        &[],
    );
    assert_eq!(map["machine"]["sha256"], listed);
    assert_eq!(map["inputs"]["approach"]["X"], "-");
    assert_eq!(map["inputs"]["approach"]["Y"], "+");
    assert_eq!(map["result"]["grid"]["dims"], serde_json::json!([6, 5, 4]));
    assert_eq!(map["result"]["stats"]["points"], 120);
    assert_eq!(map["result"]["check"]["passed"], true);
    let info = reports.run("info", &["info", "f.exr"], &[]);
    assert_eq!(
        sha(&info),
        sha(&map),
        "the field records the machine's files"
    );
    assert_eq!(info["inputs"], map["inputs"]);
    assert_eq!(info["result"]["stats"], map["result"]["stats"]);
    let points = example("points.csv");
    let sampled = reports.run(
        "sample",
        &[
            "sample",
            "--points",
            &points,
            "--field",
            "f.exr",
            "--approach",
            "X=-",
            "--outside",
            "nan",
            "--out",
            "s.csv",
        ],
        &[],
    );
    assert_eq!(sha(&sampled), sha(&map));
    assert_eq!(sampled["result"]["precision"], "f32");
    let lines = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    assert_eq!(sampled["result"]["points"], lines.lines().count() - 1);
    let exact = reports.run(
        "exact",
        &[
            "sample",
            "--points",
            &points,
            "--exact",
            "--machine",
            "vmc-li2015",
            "--outside",
            "nan",
        ],
        &[],
    );
    assert_eq!(sha(&exact), sha(&map));
    assert_eq!(exact["result"]["precision"], "f64");
    let part = example("li2015-part.toml");
    let features = reports.run(
        "features",
        &["features", "--part", &part, "--machine", "vmc-li2015"],
        &[3],
    );
    assert_eq!(sha(&features), sha(&map));
    let rows = features["result"].as_array().unwrap();
    assert!(!rows.is_empty() && rows.iter().all(|r| r["name"].is_string()));
    reports.validate();
}

#[test]
fn tests_fits_builds_and_studies_say_what_they_were_computed_from() {
    let dir = tempfile::tempdir().unwrap();
    let mut reports = Reports::new(dir.path());
    let circle = example("fit/circle-xy.csv");
    let test = reports.run(
        "circular",
        &[
            "test",
            "circular",
            "--machine",
            "vmc-li2015",
            "--plane",
            "XY",
            "--points",
            "24",
            "--measured",
            &circle,
        ],
        &[],
    );
    assert!(test["result"]["figures"].is_array());
    assert!(test["result"]["ballbar"].is_object());
    reports.run(
        "rtest",
        &[
            "test",
            "rtest",
            "--machine",
            "5axis-hwang2014",
            "--axis",
            "C",
            "--pose",
            "B=10",
        ],
        &[],
    );
    let rtest = &reports.files["test"][1];
    let rtest: Value = serde_json::from_str(&std::fs::read_to_string(rtest).unwrap()).unwrap();
    assert_eq!(rtest["inputs"]["pose_deg"]["B"], 10.0);
    let fit = reports.run(
        "fit",
        &[
            "fit",
            "--machine",
            "vmc-li2015",
            "--measurements",
            &example("fit/fit.toml"),
            "--out",
            "fitted.toml",
        ],
        &[],
    );
    assert_eq!(sha(&fit), sha(&test));
    let built = reports.run(
        "build",
        &[
            "build",
            "--base",
            "vmc-li2015",
            "--axis",
            &format!("X={}", example("build/x-axis.csv")),
            "--out",
            "built.toml",
        ],
        &[],
    );
    assert_eq!(sha(&built), sha(&test), "the base");
    let written = built["result"]["written"]["sha256"].as_str().unwrap();
    assert_ne!(written, sha(&test));
    // What the written file's report names is what every command reads from it.
    let mapped = reports.run(
        "built-map",
        &[
            "map",
            "--machine",
            "built.toml",
            "--grid",
            "3x3x3",
            "--device",
            "cpu",
            "--out",
            "b.exr",
        ],
        &[],
    );
    assert_eq!(sha(&mapped), written);
    // A study in two shards merges to the statistics of one run, under the same machine.
    let tolerances = example("tolerances/vmc-li2015.toml");
    let study = [
        "budget",
        "--machine",
        "vmc-li2015",
        "--tolerances",
        &tolerances,
        "--grid",
        "4x4x4",
        "--samples",
        "12",
        "--spec",
        "0.14",
        "--device",
        "cpu",
    ];
    let whole = reports.run("budget", &study, &[]);
    for k in 0..2 {
        let shard = format!("{k}/2");
        let file = format!("s{k}.json");
        let mut args = study.to_vec();
        args.extend(["--shard", &shard, "--per-sample", &file]);
        reports.run(&format!("budget{k}"), &args, &[]);
    }
    let merged_path = dir.path().join("merged.json");
    let merged = reports.read(
        &merged_path,
        &[
            "merge-samples",
            "s0.json",
            "s1.json",
            "--out",
            s(&merged_path),
        ],
        &[],
    );
    assert_eq!(merged["machine"]["sha256"], whole["machine"]["sha256"]);
    assert_eq!(
        merged["result"]["monte_carlo"],
        whole["result"]["monte_carlo"]
    );
    reports.validate();
}

#[test]
fn programs_exports_sweeps_and_benchmarks_have_their_envelope() {
    let dir = tempfile::tempdir().unwrap();
    let mut reports = Reports::new(dir.path());
    let machine = example("dobariya2015/machine.toml");
    let program = example("dobariya2015/test-piece.nc");
    let nc = [
        "--machine",
        &machine,
        "--program",
        &program,
        "--work-offset",
        "G54=0,0,10",
    ];
    let mut compensate = vec!["compensate"];
    compensate.extend(nc);
    compensate.extend(["--out", "c.nc"]);
    let compensated = reports.run("compensate", &compensate, &[]);
    assert!(compensated["inputs"]["pose_deg"].is_null());
    let mut trace = vec!["trace"];
    trace.extend(nc);
    trace.push("--compensate");
    let traced = reports.run("trace", &trace, &[]);
    assert_eq!(sha(&traced), sha(&compensated));
    assert_eq!(traced["result"].as_array().unwrap().len(), 2);
    let export = reports.run(
        "export",
        &[
            "export",
            "--machine",
            "gantry-2m",
            "--format",
            "grid-csv",
            "--out",
            "g.csv",
        ],
        &[],
    );
    assert!(export["result"]["report"].is_object());
    reports.run(
        "sweep-points",
        &[
            "export",
            "--machine",
            "vmc-li2015",
            "--format",
            "linuxcnc",
            "--sweep-points",
            "2,3",
        ],
        &[],
    );
    let sweep = [
        "map",
        "--machine",
        "5axis-hwang2014",
        "--grid",
        "3x3x3",
        "--poses",
        "B=0:30:15",
        "--device",
        "cpu",
    ];
    let mut whole = sweep.to_vec();
    whole.extend(["--out", "w.exr"]);
    let mapped = reports.run("sweep", &whole, &[]);
    assert_eq!(mapped["inputs"]["pose_deg"].as_array().unwrap().len(), 3);
    assert_eq!(mapped["result"]["poses"].as_array().unwrap().len(), 3);
    for k in 0..2 {
        let (shard, out) = (format!("{k}/2"), format!("m{k}.exr"));
        let mut args = sweep.to_vec();
        args.extend(["--shard", &shard, "--out", &out]);
        volmap()
            .args(&args)
            .current_dir(dir.path())
            .assert()
            .success();
    }
    let merged = reports.run(
        "merge-maps",
        &["merge-maps", "m0.exr", "m1.exr", "--out", "merged.exr"],
        &[],
    );
    assert_eq!(merged["inputs"]["pose_deg"], mapped["inputs"]["pose_deg"]);
    let info = reports.run("info-sweep", &["info", "merged.exr"], &[]);
    assert_eq!(info["result"]["poses"].as_array().unwrap().len(), 3);
    assert_eq!(info["result"]["worst_pose"], mapped["result"]["worst_pose"]);
    let bench = reports.run(
        "bench",
        &[
            "bench",
            "--machines",
            "vmc-li2015",
            "--grid",
            "8x8x8",
            "--runs",
            "1",
            "--device",
            "cpu",
            "--reference-points",
            "100",
        ],
        &[],
    );
    assert!(bench["machine"].is_null(), "several machines: none named");
    reports.validate();
}

/// The check can fail: a report without its result, or of another schema version, is refused.
#[test]
fn a_report_off_its_schema_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut reports = Reports::new(dir.path());
    let report = reports.run("machines", &["machines"], &[]);
    let mut broken = Vec::new();
    for (name, edit) in [
        (
            "no-result",
            &(|r: &mut Value| {
                r.as_object_mut().unwrap().remove("result");
            }) as &dyn Fn(&mut Value),
        ),
        ("schema-2", &|r: &mut Value| r["schema"] = 2.into()),
        ("bad-hash", &|r: &mut Value| {
            r["result"]["machines"][0]["sha256"] = "sha256:00".into()
        }),
    ] {
        let mut copy = report.clone();
        edit(&mut copy);
        let path = dir.path().join(format!("{name}.json"));
        std::fs::write(&path, serde_json::to_string(&copy).unwrap()).unwrap();
        broken.push(path);
    }
    for path in &broken {
        if let Some(output) = validated("machines", std::slice::from_ref(path)) {
            assert!(!output.status.success(), "{} passed", path.display());
        }
    }
}

/// The hash as docs/json.md defines it, computed here from the files: the machine file's text,
/// then each table's path as written and its text, each part after its length (8 bytes,
/// little-endian). A change to a table's values changes it; the same files give the same hash.
#[test]
fn the_machine_hash_is_that_of_its_file_and_tables() {
    use sha2::{Digest, Sha256};
    let dir = tempfile::tempdir().unwrap();
    let machine = super::machine_with(
        dir.path(),
        "m.toml",
        "EXY",
        "EXY = { csv = \"tables/y.csv\", interp = \"quadratic\" }",
    );
    let text = std::fs::read_to_string(machine).unwrap();
    std::fs::create_dir_all(dir.path().join("tables")).unwrap();
    let expected = |table: &str| {
        let mut hasher = Sha256::new();
        for part in [text.as_str(), "tables/y.csv", table] {
            hasher.update((part.len() as u64).to_le_bytes());
            hasher.update(part.as_bytes());
        }
        let hex: String = hasher
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        format!("sha256:{hex}")
    };
    let mut reports = Reports::new(dir.path());
    let mut hashes = Vec::new();
    for (n, table) in [
        "position_mm,EXY\n0,0.0\n300,0.03\n600,0.0\n",
        "position_mm,EXY\n0,0.0\n300,0.031\n600,0.0\n",
    ]
    .into_iter()
    .enumerate()
    {
        std::fs::write(dir.path().join("tables/y.csv"), table).unwrap();
        let out = format!("t{n}.exr");
        let report = reports.run(
            &format!("t{n}"),
            &[
                "map",
                "--machine",
                "m.toml",
                "--grid",
                "3x3x3",
                "--device",
                "cpu",
                "--out",
                &out,
            ],
            &[],
        );
        assert_eq!(sha(&report), expected(table));
        let info = reports.run(&format!("i{n}"), &["info", &out], &[]);
        assert_eq!(sha(&info), expected(table), "the field's copy of the files");
        hashes.push(sha(&report).to_string());
    }
    assert_ne!(hashes[0], hashes[1]);
    reports.validate();
}
