//! The bounds on a TOML file's values, keys and dotted keys (docs/inputs-and-limits.md): every reader
//! of TOML (machine, tolerance, part, fit and work offset files) refuses a file beyond them before
//! parsing it, exit code 2 naming the file and its line, within a bounded address space, whatever
//! shape the elements take (one long array, many keys, many inline tables, many table headers).

use super::{volmap, volmap_under};

/// The most values and keys a TOML file may hold (`volmap::error`).
const MAX_VALUES: usize = volmap::error::MAX_TOML_VALUES;
const MAX_KEYS: usize = volmap::error::MAX_TOML_KEYS;

/// Texts one value or key beyond a bound, each a shape of its own, with what the message says:
/// the bound is passed on the last line.
fn shapes() -> Vec<(&'static str, String, String)> {
    let values = format!("more than {MAX_VALUES} values");
    let keys = format!("more than {MAX_KEYS} keys");
    vec![
        // `[` is one value, each comma one more.
        (
            "one array",
            format!("a = [{}0]\n", "0.5, ".repeat(MAX_VALUES)),
            values.clone(),
        ),
        // After `a = [` (one value), five values a line; the last line passes the bound.
        (
            "rows",
            format!("a = [\n{}", "[1, 2, 3, 4],\n".repeat(MAX_VALUES / 5)),
            values,
        ),
        (
            "keys",
            (0..=MAX_KEYS).map(|k| format!("k{k} = {k}\n")).collect(),
            keys.clone(),
        ),
        // Each line two keys (`=`) and two values (`{`, `[`).
        (
            "inline tables",
            (0..=MAX_KEYS / 2)
                .map(|k| format!("t{k} = {{ v = [1] }}\n"))
                .collect(),
            keys.clone(),
        ),
        // Each header and its key: 2 keys; then one header more.
        (
            "tables",
            (0..MAX_KEYS / 2)
                .map(|k| format!("[s{k}]\nx = 1\n"))
                .collect::<String>()
                + "[last]\n",
            keys,
        ),
    ]
}

/// Every reader of TOML, as the argument list that makes it read `file` (in `dir`, with the
/// helper files it needs).
fn readers(dir: &std::path::Path, file: &str) -> Vec<(&'static str, Vec<String>)> {
    std::fs::write(dir.join("p.csv"), "X,Y,Z\n1,2,3\n").unwrap();
    std::fs::write(dir.join("p.nc"), "G0 X1 Y1 Z1\nM30\n").unwrap();
    let v = |a: &[&str]| a.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    vec![
        (
            "machine",
            v(&["sample", "--exact", "--machine", file, "--points", "p.csv"]),
        ),
        (
            "tolerance",
            v(&["budget", "--machine", "vmc-li2015", "--tolerances", file]),
        ),
        (
            "part",
            v(&["features", "--machine", "vmc-li2015", "--part", file]),
        ),
        (
            "fit",
            v(&["fit", "--machine", "vmc-li2015", "--measurements", file]),
        ),
        (
            "work offset",
            v(&[
                "trace",
                "--machine",
                "vmc-li2015",
                "--work-offset-file",
                file,
                "--program",
                "p.nc",
            ]),
        ),
    ]
}

#[test]
fn toml_files_beyond_the_element_bound_are_refused_by_every_reader_in_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    // The refusal reads the file (under 20 MB here) and scans it: far under 1 GB, where parsing
    // half a million keys would take about 350 MB and the shapes' parse trees more.
    for (shape, text, says) in shapes() {
        let lines = text.lines().count();
        let file = format!("{}.toml", shape.replace(' ', "-"));
        std::fs::write(dir.path().join(&file), &text).unwrap();
        for (reader, args) in readers(dir.path(), &file) {
            let output = volmap_under("-v 1000000")
                .args(&args)
                .current_dir(dir.path())
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert_eq!(output.status.code(), Some(2), "{reader}, {shape}: {stderr}");
            assert!(
                stderr.contains(&file)
                    && stderr.contains(&says)
                    && stderr.contains(&format!("line {lines}, column")),
                "{reader}, {shape}: {stderr}"
            );
            assert_eq!(stderr.lines().count(), 2, "{reader}, {shape}: {stderr}");
        }
    }
}

#[test]
fn a_file_at_the_element_bound_is_parsed_and_refused_for_what_it_says() {
    // At the bound the file is parsed: the reader's own complaint (an unknown key) follows, not
    // the bound's.
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "name = \"m\"\nchain = \"XYZ\"\njunk = [{}0]\n",
        "1, ".repeat(MAX_VALUES - 1)
    );
    std::fs::write(dir.path().join("m.toml"), text).unwrap();
    for (reader, args) in readers(dir.path(), "m.toml").into_iter().take(1) {
        let output = volmap_under("-v 2000000")
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{reader}: {stderr}");
        assert!(stderr.contains("junk"), "{reader}: {stderr}");
        assert!(!stderr.contains("more than"), "{reader}: {stderr}");
    }
}

#[test]
fn dotted_keys_of_too_many_parts_are_refused_with_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let parts = |n: usize| vec!["q"; n].join(".");
    for (k, text) in [
        format!("name = \"m\"\n{} = 1\n", parts(5000)),
        format!("[{}]\n", parts(65)),
        format!("a = 1\nb = 2\nc = {{ {} = 1 }}\n", parts(300)),
    ]
    .iter()
    .enumerate()
    {
        let file = format!("d{k}.toml");
        std::fs::write(dir.path().join(&file), text).unwrap();
        let line = text.lines().count();
        for (reader, args) in readers(dir.path(), &file) {
            let output = volmap()
                .args(&args)
                .current_dir(dir.path())
                .output()
                .unwrap();
            let stderr = String::from_utf8_lossy(&output.stderr);
            assert_eq!(output.status.code(), Some(2), "{reader}: {stderr}");
            assert!(
                stderr.contains(&format!("{file}: line {line}, column"))
                    && stderr.contains("a dotted key of more than 64 parts"),
                "{reader}: {stderr}"
            );
        }
    }
}
