//! volmap in the shell: completion scripts, man pages and "did you mean" for a machine name.

use predicates::prelude::*;

use super::volmap;

/// Every visible subcommand's name, nested ones as `test circular`.
fn subcommands() -> Vec<Vec<String>> {
    let out = volmap().arg("cli-reference").assert().success();
    let text = String::from_utf8(out.get_output().stdout.clone()).unwrap();
    // The reference's headings are `## volmap map`, `### volmap test circular`.
    text.lines()
        .filter(|l| l.starts_with('#'))
        .filter_map(|l| l.trim_start_matches('#').trim().strip_prefix("volmap "))
        .map(|rest| rest.split_whitespace().map(str::to_string).collect())
        .collect()
}

#[test]
fn bash_completion_is_valid_bash_and_names_every_command() {
    let out = volmap().args(["completions", "bash"]).assert().success();
    let script = String::from_utf8(out.get_output().stdout.clone()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("volmap.bash");
    std::fs::write(&path, &script).unwrap();
    // `bash -n` parses without running: a syntax error fails.
    let status = std::process::Command::new("bash")
        .arg("-n")
        .arg(&path)
        .status()
        .expect("bash runs");
    assert!(status.success());
    let names = subcommands();
    assert!(names.len() >= 20, "{names:?}");
    for name in &names {
        assert!(
            script.contains(name.last().unwrap().as_str()),
            "{name:?} not completed"
        );
    }
    assert!(script.contains("--machine") && script.contains("--probe-offset"));
    for shell in ["zsh", "fish", "powershell", "elvish"] {
        let out = volmap().args(["completions", shell]).assert().success();
        let text = String::from_utf8(out.get_output().stdout.clone()).unwrap();
        assert!(
            text.contains("volmap") && text.contains("export"),
            "{shell}"
        );
    }
    volmap()
        .args(["completions", "tcsh"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("invalid value 'tcsh'"));
}

#[test]
fn man_writes_a_page_per_command_with_its_options() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("man1");
    volmap()
        .args(["man", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::is_empty());
    let names = subcommands();
    let mut pages: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    pages.sort();
    // One page for volmap itself and one per command, nested ones included.
    assert_eq!(pages.len(), names.len() + 1, "{pages:?}");
    for name in &names {
        let page = format!("volmap-{}.1", name.join("-"));
        let text = std::fs::read_to_string(out.join(&page)).expect(&page);
        let title = format!(".TH volmap-{} 1", name.join("-"));
        assert!(text.contains(&title), "{page}: no `{title}`");
        assert!(
            text.contains(".SH NAME") && text.contains(".SH OPTIONS"),
            "{page}"
        );
    }
    let map = std::fs::read_to_string(out.join("volmap-map.1")).unwrap();
    for option in ["\\-\\-machine", "\\-\\-grid", "\\-\\-compression"] {
        assert!(map.contains(option), "{option}");
    }
    assert!(!out.read_dir().unwrap().any(|e| e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .ends_with(".part")));
}

#[test]
fn a_misspelled_machine_gets_did_you_mean() {
    volmap()
        .args(["map", "--machine", "vmc-li2105", "--out", "x.exr"])
        .assert()
        .code(2)
        .stderr(predicate::str::starts_with(
            "error: --machine: no embedded machine is called `vmc-li2105` and no file `vmc-li2105` exists; did you mean `vmc-li2015`?",
        ));
    // Nothing near: no guess.
    volmap()
        .args(["map", "--machine", "lathe", "--out", "x.exr"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("did you mean").not());
    volmap()
        .args(["machines", "--show", "gantry2m"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("did you mean `gantry-2m`?"));
}
