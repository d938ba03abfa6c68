//! `volmap features` with profiles judged in datum frames and after a best fit: what the table
//! and the JSON say, and bad datums refused with exit code 2.

use predicates::prelude::*;

use super::volmap;

/// The example part with a meshed square (100 mm, at the part's z = 0) judged three ways, and
/// `extra` appended.
fn part(dir: &std::path::Path, extra: &str) -> std::path::PathBuf {
    let example =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/li2015-part.toml");
    let stl = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 100 0 0\nvertex 100 100 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 100 100 0\nvertex 0 100 0\nendloop\nendfacet\nendsolid s\n";
    std::fs::write(dir.join("skin.stl"), stl).unwrap();
    let profile = |name: &str, keys: &str| {
        format!("\n[[features]]\nkind = \"profile\"\nname = \"{name}\"\nmesh = \"skin.stl\"\ntolerance_mm = 0.5\n{keys}\n")
    };
    let text = [
        std::fs::read_to_string(example).unwrap(),
        profile("skin", ""),
        profile(
            "skin to datums",
            "datums = [\"pocket floor\", \"hole 1\", \"pocket wall\"]",
        ),
        profile("skin form", "evaluation = \"best_fit\""),
        extra.to_string(),
    ]
    .concat();
    let path = dir.join("part.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn the_table_and_the_json_say_what_each_feature_was_judged_against() {
    let dir = tempfile::tempdir().unwrap();
    let path = part(dir.path(), "");
    let json = dir.path().join("rows.json");
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part"])
        .arg(&path)
        .arg("--json")
        .arg(&json)
        .assert()
        .code(0)
        .stdout(
            predicate::str::contains("against")
                .and(predicate::str::contains(
                    "datums pocket floor hole 1 pocket wall",
                ))
                .and(predicate::str::contains("best fit"))
                .and(predicate::str::contains("minimum zone"))
                .and(predicate::str::contains("datums hole 1")),
        );
    let rows: serde_json::Value = super::json_result(&json);
    let by_name = |name: &str| {
        rows.as_array()
            .unwrap()
            .iter()
            .find(|r| r["name"] == name)
            .unwrap()
            .clone()
    };
    assert_eq!(by_name("skin")["evaluation"], "nominal");
    assert!(by_name("skin").get("datums").is_none());
    assert_eq!(by_name("skin to datums")["evaluation"], "datums");
    assert_eq!(
        by_name("skin to datums")["datums"],
        serde_json::json!(["pocket floor", "hole 1", "pocket wall"])
    );
    assert_eq!(by_name("skin form")["evaluation"], "best_fit");
    assert_eq!(by_name("pocket floor")["evaluation"], "minimum_zone");
    assert_eq!(by_name("hole 2")["datums"], serde_json::json!(["hole 1"]));
    // The rows keep the order of the file.
    assert_eq!(rows[5]["name"], "skin");
}

#[test]
fn bad_datums_are_input_errors_naming_the_file_and_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let unknown = "\n[[features]]\nkind = \"profile\"\nname = \"lid\"\nmesh = \"skin.stl\"\ntolerance_mm = 0.5\ndatums = [\"pocket floor\", \"datum X\"]\n";
    let path = part(dir.path(), unknown);
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part"])
        .arg(&path)
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("part.toml")
                .and(predicate::str::contains("feature `lid`"))
                .and(predicate::str::contains(
                    "datums: `datum X` names no feature",
                )),
        );
    // A rib's top is no datum of a profile.
    let rib = unknown.replace("datum X", "rib top");
    let path = part(dir.path(), &rib);
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part"])
        .arg(&path)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "datums: `rib top` is a rib_height",
        ));
    // A datum named twice.
    let twice = unknown.replace("\"datum X\"", "\"pocket floor\", \"pocket wall\"");
    let path = part(dir.path(), &twice);
    volmap()
        .args(["features", "--machine", "vmc-li2015", "--part"])
        .arg(&path)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("`pocket floor` is named twice"));
}
