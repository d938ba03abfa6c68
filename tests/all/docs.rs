//! The documentation holds together: `docs/cli.md` is what the binary generates from its own
//! command-line definitions (`VOLMAP_BLESS=1 cargo test docs` writes it again), every relative link
//! of the README and the book resolves to a file and a heading, every command and every export
//! format is in the README's command table and in the reference, the README stays short, and the
//! number of tests docs/testing.md states is the number there are.

use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};

use assert_cmd::Command;

/// The README is the front page: longer than this and its text belongs in a chapter of `docs/`.
const README_MOST_LINES: usize = 400;

fn repository() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn volmap(args: &[&str]) -> String {
    let output = Command::cargo_bin("volmap")
        .unwrap()
        .args(args)
        .output()
        .unwrap();
    assert!(output.status.success(), "volmap {args:?} failed");
    String::from_utf8(output.stdout).unwrap()
}

#[test]
fn the_command_line_reference_is_what_the_binary_generates() {
    let generated = volmap(&["cli-reference"]);
    let page = repository().join("docs/cli.md");
    if std::env::var_os("VOLMAP_BLESS").is_some() {
        fs::write(&page, &generated).unwrap();
    }
    let committed = fs::read_to_string(&page).unwrap_or_default();
    assert!(
        committed == generated,
        "docs/cli.md differs from what `volmap cli-reference` prints; after a change to the \
         command line, write it again with VOLMAP_BLESS=1 cargo test docs"
    );
}

/// The Markdown files of the documentation: the README and every page under `docs/`.
fn markdown_files() -> Vec<PathBuf> {
    let root = repository();
    let mut files = vec![root.join("README.md")];
    let mut folders = vec![root.join("docs")];
    while let Some(folder) = folders.pop() {
        for entry in fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                folders.push(path);
            } else if path.extension().is_some_and(|e| e == "md") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// The lines of a Markdown text outside fenced code blocks, with their numbers from 1.
fn prose_lines(text: &str) -> Vec<(usize, &str)> {
    let mut fence: Option<&str> = None;
    let mut lines = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let marker = ["```", "~~~"].into_iter().find(|m| trimmed.starts_with(m));
        match (fence, marker) {
            (None, Some(m)) => fence = Some(m),
            (Some(open), Some(m)) if open == m => fence = None,
            (None, None) => lines.push((n + 1, line)),
            _ => {}
        }
    }
    lines
}

/// A line without its inline code spans (`` `…` ``), so a `[x](y)` in code is no link.
fn without_code(line: &str) -> String {
    let mut out = String::new();
    let mut in_code = false;
    for c in line.chars() {
        if c == '`' {
            in_code = !in_code;
        } else if !in_code {
            out.push(c);
        }
    }
    out
}

/// The targets of the inline links and images of a line: what stands between `](` and `)`.
fn link_targets(line: &str) -> Vec<String> {
    let line = without_code(line);
    let mut targets = Vec::new();
    let mut rest = line.as_str();
    while let Some(start) = rest.find("](") {
        let after = &rest[start + 2..];
        let Some(end) = after.find(')') else { break };
        targets.push(after[..end].trim().to_string());
        rest = &after[end..];
    }
    targets
}

/// The anchor GitHub gives a heading: lower case, letters, digits, `-` and `_` kept, spaces
/// turned into `-`, everything else (punctuation, backticks, symbols) dropped; a heading met
/// before gets `-1`, `-2`, … after it.
fn slug(heading: &str) -> String {
    let mut slug = String::new();
    for c in heading.trim().chars() {
        if c.is_alphanumeric() || c == '-' || c == '_' {
            slug.extend(c.to_lowercase());
        } else if c == ' ' {
            slug.push('-');
        }
    }
    slug
}

/// The anchors of a Markdown file's headings, as GitHub numbers repeated ones. A link in a
/// heading counts by its text.
fn anchors(text: &str) -> Vec<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut anchors = Vec::new();
    for (_, line) in prose_lines(text) {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if !(1..=6).contains(&hashes) || !line[hashes..].starts_with(' ') {
            continue;
        }
        let mut heading = line[hashes..].trim().to_string();
        while let (Some(open), Some(mid)) = (heading.find('['), heading.find("](")) {
            let Some(close) = heading[mid..].find(')') else {
                break;
            };
            heading = format!(
                "{}{}{}",
                &heading[..open],
                &heading[open + 1..mid],
                &heading[mid + close + 1..]
            );
        }
        let base = slug(&heading);
        let count = seen.entry(base.clone()).or_insert(0);
        anchors.push(if *count == 0 {
            base.clone()
        } else {
            format!("{base}-{count}")
        });
        *count += 1;
    }
    anchors
}

/// `file:line: target: what is wrong` for every relative link of `files` that does not resolve.
fn broken_links(root: &Path, files: &[PathBuf]) -> Vec<String> {
    let mut broken = Vec::new();
    for file in files {
        let text = fs::read_to_string(file).unwrap();
        let shown = file
            .strip_prefix(root)
            .unwrap_or(file)
            .display()
            .to_string();
        for (n, line) in prose_lines(&text) {
            for target in link_targets(line) {
                let target = target.split_whitespace().next().unwrap_or("").to_string();
                if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                let (path, anchor) = match target.split_once('#') {
                    Some((path, anchor)) => (path, Some(anchor)),
                    None => (target.as_str(), None),
                };
                let linked = if path.is_empty() {
                    file.clone()
                } else {
                    file.parent().unwrap().join(path)
                };
                let mut problem = None;
                if !linked.exists() {
                    problem = Some("no such file".to_string());
                } else if let Some(anchor) = anchor {
                    let heads = fs::read_to_string(&linked).map(|t| anchors(&t));
                    if !heads.is_ok_and(|h| h.iter().any(|a| a == anchor)) {
                        problem = Some(format!("no heading #{anchor} in it"));
                    }
                }
                if let Some(problem) = problem {
                    broken.push(format!("{shown}:{n}: {target}: {problem}"));
                }
            }
        }
    }
    broken
}

#[test]
fn every_relative_link_resolves_to_a_file_and_a_heading() {
    let root = repository();
    let broken = broken_links(&root, &markdown_files());
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_link_check_finds_planted_breaks_and_reads_headings_as_github_does() {
    assert_eq!(
        slug("`grid-csv`: the generic 3-D correction grid"),
        "grid-csv-the-generic-3-d-correction-grid"
    );
    assert_eq!(
        slug("The probability that a part conforms: `features --tolerances`"),
        "the-probability-that-a-part-conforms-features---tolerances"
    );
    assert_eq!(
        slug("The encoders: volmap's, not the `exr` crate's"),
        "the-encoders-volmaps-not-the-exr-crates"
    );
    assert_eq!(
        anchors("# A\n```\n# not a heading\n```\n## A\n## [B](x.md) c\n"),
        ["a", "a-1", "b-c"]
    );
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    fs::write(root.join("b.md"), "# Here\n\n## There and back\n").unwrap();
    fs::write(
        root.join("a.md"),
        "[ok](b.md) [ok](b.md#there-and-back) [ok](#top) [web](https://example.org/x)\n\
         `[in code](nowhere.md)`\n\n# Top\n\n[gone](c.md) [no anchor](b.md#elsewhere)\n\
         ```\n[in a block](nowhere.md)\n```\n",
    )
    .unwrap();
    let found = broken_links(root, &[root.join("a.md")]);
    assert_eq!(
        found,
        [
            "a.md:6: c.md: no such file",
            "a.md:6: b.md#elsewhere: no heading #elsewhere in it"
        ]
    );
}

/// The subcommands `volmap --help` lists, `help` aside.
fn subcommands() -> Vec<String> {
    let help = volmap(&["--help"]);
    let listed = help
        .split("Commands:")
        .nth(1)
        .expect("volmap --help lists its commands");
    listed
        .lines()
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

/// The README's command table: its rows under `## Commands`.
fn readme_command_table() -> Vec<String> {
    let readme = fs::read_to_string(repository().join("README.md")).unwrap();
    let section = readme
        .split("\n## Commands\n")
        .nth(1)
        .expect("the README has a section `## Commands`");
    let section = section.split("\n## ").next().unwrap();
    section
        .lines()
        .filter(|l| l.starts_with('|'))
        .map(str::to_string)
        .collect()
}

/// Whether `text` holds `word` as a word of its own: `fanuc` is not found in `fanuc-3d`.
fn has_word(text: &str, word: &str) -> bool {
    let inside = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_';
    text.match_indices(word).any(|(at, _)| {
        let before = text[..at].chars().next_back();
        let after = text[at + word.len()..].chars().next();
        !before.is_some_and(inside) && !after.is_some_and(inside)
    })
}

#[test]
fn every_command_and_export_format_is_in_the_readme_table_and_the_reference() {
    let commands = subcommands();
    assert!(commands.len() >= 14, "{commands:?}");
    let table = readme_command_table();
    let reference = fs::read_to_string(repository().join("docs/cli.md")).unwrap();
    for command in &commands {
        assert!(
            table
                .iter()
                .any(|row| row.starts_with(&format!("| `{command}` |"))),
            "the README's command table has no row for `{command}`"
        );
        assert!(
            reference.contains(&format!("\n## volmap {command}\n")),
            "docs/cli.md has no section for `volmap {command}`"
        );
    }
    let export_row = table
        .iter()
        .find(|row| row.starts_with("| `export` |"))
        .unwrap();
    let export_section = reference
        .split("\n## volmap export\n")
        .nth(1)
        .unwrap()
        .split("\n## ")
        .next()
        .unwrap();
    for format in volmap::export::formats::FORMATS {
        let name = format.spec().name;
        assert!(
            has_word(export_row, &format!("`{name}`")),
            "the README's export row does not list --format {name}"
        );
        assert!(
            has_word(export_section, name),
            "docs/cli.md's export section does not list --format {name}"
        );
    }
}

#[test]
fn the_readme_is_short() {
    let readme = fs::read_to_string(repository().join("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(
        lines <= README_MOST_LINES,
        "README.md has {lines} lines, at most {README_MOST_LINES}: move the details into docs/"
    );
}

/// The `#[test]` functions in the Rust files under `folder` (each test of a `proptest!` block
/// counts once), build output and hidden folders left out.
fn tests_in(folder: &Path) -> usize {
    let mut count = 0;
    for entry in fs::read_dir(folder).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy();
        if path.is_dir() {
            if name != "target" && !name.starts_with('.') {
                count += tests_in(&path);
            }
        } else if name.ends_with(".rs") {
            let text = fs::read_to_string(&path).unwrap();
            count += text.lines().filter(|l| l.trim() == "#[test]").count();
        }
    }
    count
}

/// The tests of this binary (`tests/all/`) as the harness lists them: a table macro's rows (the
/// refusals) are a test each, under one `#[test]`.
fn tests_of_this_binary() -> usize {
    let output = std::process::Command::new(std::env::current_exe().unwrap())
        .arg("--list")
        .output()
        .unwrap();
    assert!(output.status.success());
    let list = String::from_utf8(output.stdout).unwrap();
    list.lines().filter(|l| l.ends_with(": test")).count()
}

/// The sentence of docs/testing.md that states the suite's size, for these counts of `src/`,
/// `tests/` and `fuzz/`.
fn stated_counts(counts: [usize; 3]) -> String {
    format!(
        "It holds {} tests: {} in `src/`, {} in `tests/` and {} in `fuzz/`.",
        counts.iter().sum::<usize>(),
        counts[0],
        counts[1],
        counts[2]
    )
}

#[test]
fn the_book_states_the_number_of_tests_there_are() {
    let root = repository();
    let listed = tests_of_this_binary();
    // Every `#[test]` of tests/ is in this binary, and the table macro adds its rows.
    assert!(listed >= tests_in(&root.join("tests")), "{listed}");
    let counts = [
        tests_in(&root.join("src")),
        listed,
        tests_in(&root.join("fuzz")),
    ];
    // Every folder holds tests: a count of zero would be the counting gone wrong.
    assert!(counts.iter().all(|&c| c > 0), "{counts:?}");
    let path = root.join("docs/testing.md");
    let raw = fs::read_to_string(&path).unwrap();
    let stated = stated_counts(counts);
    if std::env::var_os("VOLMAP_BLESS").is_some() {
        // The sentence as it stands (wrapped or not), replaced by the counts of this suite.
        let start = raw
            .find("It holds ")
            .expect("docs/testing.md states the count");
        let end = start
            + raw[start..]
                .find("in `fuzz/`.")
                .expect("the sentence ends with fuzz/")
            + "in `fuzz/`.".len();
        let blessed = format!("{}{stated}{}", &raw[..start], &raw[end..]);
        fs::write(&path, blessed).unwrap();
        return;
    }
    // Wrapped lines read as one: whitespace runs become one space.
    let text = raw.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        text.contains(&stated),
        "docs/testing.md must say: {stated} (VOLMAP_BLESS=1 writes it)"
    );
}

#[test]
fn the_test_count_finds_planted_tests_only() {
    let dir = tempfile::tempdir().unwrap();
    let inner = dir.path().join("inner");
    fs::create_dir_all(&inner).unwrap();
    fs::create_dir_all(dir.path().join("target")).unwrap();
    let file = "#[test]\nfn a() {}\n    #[test]\n    fn b() {}\nconst S: &str = \"#[test]\";\n";
    fs::write(dir.path().join("a.rs"), file).unwrap();
    fs::write(
        inner.join("b.rs"),
        "proptest! {\n    #[test]\n    fn c(x in 0..1) {}\n}\n",
    )
    .unwrap();
    // Not Rust, and build output: not counted.
    fs::write(dir.path().join("notes.md"), "#[test]\n").unwrap();
    fs::write(dir.path().join("target/gen.rs"), "#[test]\n").unwrap();
    assert_eq!(tests_in(dir.path()), 3);
    assert_eq!(
        stated_counts([1, 2, 3]),
        "It holds 6 tests: 1 in `src/`, 2 in `tests/` and 3 in `fuzz/`."
    );
}

/// The README's limits table, as its rows' text.
fn readme_limits_table() -> String {
    let readme = fs::read_to_string(repository().join("README.md")).unwrap();
    let start = readme
        .find("## Limits")
        .expect("a limits section in the README");
    let section = &readme[start..];
    let end = section[3..].find("\n## ").map_or(section.len(), |n| n + 3);
    section[..end]
        .lines()
        .filter(|l| l.starts_with('|'))
        .collect::<Vec<_>>()
        .join("\n")
}

/// `n` with commas between thousands, as the README writes counts.
fn with_commas(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (k, c) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[test]
fn the_readme_states_every_bound_the_code_checks() {
    use volmap::{error, io::source, limits};
    let table = readme_limits_table();
    let counts: Vec<(&str, u64)> = vec![
        ("MAX_FEATURE_POINTS", limits::MAX_FEATURE_POINTS),
        ("MAX_PART_POINTS", limits::MAX_PART_POINTS),
        ("MAX_TEST_POINTS", limits::MAX_TEST_POINTS),
        ("MAX_RUNS", limits::MAX_RUNS),
        ("MAX_SAMPLES", limits::MAX_SAMPLES),
        ("MAX_DECIMALS", limits::MAX_DECIMALS as u64),
        ("MAX_TRACE_SAMPLES", limits::MAX_TRACE_SAMPLES),
        ("MAX_PROGRAM_BLOCKS", limits::MAX_PROGRAM_BLOCKS),
        ("MAX_PROGRAM_WORDS", limits::MAX_PROGRAM_WORDS),
        ("MAX_PIECES_PER_MOVE", limits::MAX_PIECES_PER_MOVE),
        ("MAX_COMPENSATED_BLOCKS", limits::MAX_COMPENSATED_BLOCKS),
        ("MAX_DRAWN_POINTS", limits::MAX_DRAWN_POINTS),
        ("MAX_TOML_VALUES", error::MAX_TOML_VALUES as u64),
        ("MAX_TOML_KEYS", error::MAX_TOML_KEYS as u64),
        ("MAX_TOML_KEY_PARTS", error::MAX_TOML_KEY_PARTS as u64),
        ("MAX_TOML_DEPTH", error::MAX_TOML_DEPTH as u64),
        (
            "MAX_AXIS_POINTS",
            volmap::model::grid::MAX_AXIS_POINTS as u64,
        ),
        ("MAX_POSES", volmap::model::poses::MAX_POSES as u64),
        (
            "MAX_RESIDUAL_GRID_POINTS",
            volmap::export::residual::MAX_RESIDUAL_GRID_POINTS as u64,
        ),
        ("MAX_EXPANDED_WORDS", volmap::nc::MAX_EXPANDED_WORDS as u64),
        ("MAX_PECKS", volmap::nc::MAX_PECKS as u64),
    ];
    let mut missing: Vec<String> = counts
        .iter()
        .filter(|(_, n)| !has_word(&table, &with_commas(*n)))
        .map(|(name, n)| format!("{name} = {}", with_commas(*n)))
        .collect();
    let others = [
        (
            "MAX_MACHINE_POINTS",
            format!("{:e}", limits::MAX_MACHINE_POINTS as f64),
        ),
        (
            "MAX_MEASURED_MAGNITUDE",
            format!("{:e}", limits::MAX_MEASURED_MAGNITUDE),
        ),
        (
            "TEXT_LIMIT_BYTES",
            source::describe_bytes(source::TEXT_LIMIT_BYTES),
        ),
        (
            "PROGRAM_LIMIT_BYTES",
            source::describe_bytes(source::PROGRAM_LIMIT_BYTES),
        ),
        (
            "MESH_LIMIT_BYTES",
            source::describe_bytes(source::MESH_LIMIT_BYTES),
        ),
        (
            "LINE_LIMIT_BYTES",
            source::describe_bytes(source::LINE_LIMIT_BYTES as u64),
        ),
        (
            "MAX_COMPENSATED_BYTES",
            source::describe_bytes(limits::MAX_COMPENSATED_BYTES),
        ),
    ];
    missing.extend(
        others
            .iter()
            .filter(|(_, text)| !table.contains(text.as_str()))
            .map(|(name, text)| format!("{name} = {text}")),
    );
    assert!(
        missing.is_empty(),
        "bounds the README's limits table does not state: {missing:?}"
    );
}
