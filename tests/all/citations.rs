//! The repository stands on its own: no file names a document outside it (the specification the
//! project was first written from, the text files its papers were kept in), the model is in
//! `docs/model.md`, the papers are cited by authors, title, venue and year, and the README asks
//! for the Rust version `Cargo.toml` declares.

use std::fs;
use std::path::{Path, PathBuf};

/// The names the repository must not use, built here so this file does not hold them itself.
fn forbidden_names() -> Vec<String> {
    vec![
        ["MODEL", ".md"].concat(),
        ["../", "shared"].concat(),
        ["shared", "/seeds"].concat(),
    ]
}

/// Whether `line` names a paper's text file, `NNN_` and sixteen hex digits (`004_ef45…`), or
/// calls a paper "seed NNN".
fn names_a_paper_file(line: &str) -> bool {
    let bytes = line.as_bytes();
    let file_name = bytes.windows(20).any(|w| {
        w[..3].iter().all(u8::is_ascii_digit)
            && w[3] == b'_'
            && w[4..]
                .iter()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(b))
    });
    let lower = line.to_ascii_lowercase();
    let seed_number = lower.match_indices("seed ").any(|(i, _)| {
        let rest = &lower.as_bytes()[i + 5..];
        rest.len() >= 3 && rest[..3].iter().all(u8::is_ascii_digit)
    });
    file_name || seed_number
}

/// Every text file under `root`, skipping build output (`target/`) and hidden folders other than
/// `.ci/` (git's own, virtual environments).
fn text_files(root: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut folders = vec![root.to_path_buf()];
    while let Some(folder) = folders.pop() {
        for entry in fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            if path.is_dir() {
                let hidden = name.starts_with('.') && name != ".ci";
                let build_output = folder == root && name == "target";
                if !(hidden || build_output) {
                    folders.push(path);
                }
            } else {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// `file:line: text` for every line under `root` that names a document outside the repository.
fn outside_references(root: &Path) -> Vec<String> {
    let forbidden = forbidden_names();
    let mut found = Vec::new();
    for path in text_files(root) {
        let Ok(text) = fs::read_to_string(&path) else {
            continue; // not UTF-8: an image or a field, which cite nothing
        };
        for (n, line) in text.lines().enumerate() {
            if forbidden.iter().any(|f| line.contains(f.as_str())) || names_a_paper_file(line) {
                let shown = path.strip_prefix(root).unwrap().display();
                found.push(format!("{shown}:{}: {}", n + 1, line.trim()));
            }
        }
    }
    found
}

fn repository() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn no_file_names_a_document_outside_the_repository() {
    let found = outside_references(&repository());
    assert!(
        found.is_empty(),
        "these lines name documents outside the repository; cite the papers by authors, title, \
         venue and year and the model as docs/model.md:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_check_finds_planted_names_and_skips_build_output() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    fs::create_dir_all(root.join("src")).unwrap();
    fs::create_dir_all(root.join("target/debug")).unwrap();
    fs::create_dir_all(root.join(".ci")).unwrap();
    let spec = ["MODEL", ".md"].concat();
    let paper = ["004", "_ef458cc1c67e6c63.txt"].concat();
    let numbered = ["Seed", " 001"].concat();
    fs::write(root.join("src/a.rs"), format!("// fine\n// see {spec}\n")).unwrap();
    fs::write(root.join("machines.toml"), format!("# from {paper}\n")).unwrap();
    fs::write(root.join(".ci/run"), format!("# the {numbered} case\n")).unwrap();
    fs::write(root.join("target/debug/x.rs"), format!("// {spec}\n")).unwrap();
    fs::write(
        root.join("ok.md"),
        "the seed 7 of Monte Carlo, docs/model.md, 2015_a\n",
    )
    .unwrap();
    let found = outside_references(root);
    assert_eq!(
        found,
        vec![
            format!(".ci/run:1: # the {numbered} case"),
            format!("machines.toml:1: # from {paper}"),
            format!("src/a.rs:2: // see {spec}"),
        ]
    );
}

#[test]
fn the_model_document_cites_every_paper_and_the_readme_points_to_it() {
    let root = repository();
    let model = fs::read_to_string(root.join("docs/model.md")).unwrap();
    let model = model.split_whitespace().collect::<Vec<_>>().join(" ");
    for citation in [
        "Hai Li, Yingguang Li, Wei Wang, \"Feature Based Machine Tool Accuracy Analysis method\"",
        "*Procedia CIRP* 27",
        "\"Estimation and Evaluation of Volumetric Position Errors for Multi-axis Machine Tools\"",
        "*Journal of the Korean Society for Precision Engineering*, 2014",
        "H. M. Dobariya, Y. D. Patel, D. A. Jani, \"Improving dimensional accuracy by error modelling",
        "(iNaCoMM 2015), India, 2015",
    ] {
        assert!(model.contains(citation), "docs/model.md lacks {citation:?}");
    }
    let readme = fs::read_to_string(root.join("README.md")).unwrap();
    assert!(
        readme.contains("](docs/model.md)"),
        "the README should link the model, docs/model.md"
    );
}

#[test]
fn the_readme_asks_for_the_rust_version_cargo_toml_declares() {
    let root = repository();
    let manifest: toml::Table = fs::read_to_string(root.join("Cargo.toml"))
        .unwrap()
        .parse()
        .unwrap();
    let version = manifest["package"]["rust-version"].as_str().unwrap();
    let readme = fs::read_to_string(root.join("README.md")).unwrap();
    assert!(
        readme.contains(&format!("Rust {version} or newer")),
        "the README should ask for Rust {version} or newer, as Cargo.toml's rust-version does"
    );
}
