//! The README's tour runs as written: every `$ volmap …` line of its console blocks, run from the
//! repository root (with its outputs in a temporary folder instead of `target/tour/`), succeeds,
//! and every line it shows of the output is a line the command prints, but for the lines that
//! hold timings or name the device. Commands whose numbers come from the device (the GPU where
//! there is one) are only run: their last digits may differ from one adapter to another.

use std::path::PathBuf;

use assert_cmd::Command;

/// Commands whose printed numbers are computed on the device.
const ON_THE_DEVICE: &[&str] = &["map", "info", "sample", "budget", "bench"];

/// One command of the tour: its arguments and the lines of output the README shows.
struct Step {
    args: Vec<String>,
    shown: Vec<String>,
}

fn tour() -> Vec<Step> {
    let readme =
        std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("README.md"))
            .unwrap();
    let mut steps: Vec<Step> = Vec::new();
    let mut in_console = false;
    for line in readme.lines() {
        if line.starts_with("```") {
            in_console = line == "```console";
            continue;
        }
        if !in_console {
            continue;
        }
        if let Some(command) = line.strip_prefix("$ volmap ") {
            steps.push(Step {
                args: command.split_whitespace().map(str::to_string).collect(),
                shown: Vec::new(),
            });
        } else if let Some(step) = steps.last_mut() {
            step.shown.push(line.trim_end().to_string());
        }
    }
    steps
}

/// Lines that differ from run to run or machine to machine: timings, the device, cuts.
fn varies(line: &str) -> bool {
    let trimmed = line.trim_start();
    trimmed == "..."
        || trimmed.starts_with("time ")
        || trimmed.starts_with("device ")
        || line.contains("Mpts/s")
}

#[test]
fn the_readme_tour_runs_as_written() {
    let steps = tour();
    // One step per command of the command table, at the least.
    assert!(steps.len() >= 14, "the tour has {} commands", steps.len());
    let out = tempfile::tempdir().unwrap();
    let folder = format!("{}/", out.path().display());
    for step in &steps {
        let args: Vec<String> = step
            .args
            .iter()
            .map(|a| a.replace("target/tour/", &folder))
            .collect();
        let output = Command::cargo_bin("volmap")
            .unwrap()
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(&args)
            .output()
            .unwrap();
        let printed = format!(
            "{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
        assert!(
            output.status.success(),
            "the tour's `volmap {}` failed:\n{printed}",
            step.args.join(" ")
        );
        if ON_THE_DEVICE.contains(&step.args[0].as_str()) {
            continue;
        }
        let lines: Vec<&str> = printed.lines().map(str::trim_end).collect();
        for shown in step.shown.iter().filter(|l| !varies(l)) {
            let shown = shown.replace("target/tour/", &folder);
            assert!(
                lines.contains(&shown.as_str()),
                "the tour shows `{shown}` for `volmap {}`, which now prints:\n{printed}",
                step.args.join(" ")
            );
        }
    }
}
