//! `volmap view`: the page's data equal the field's values at the nodes it shows (read without a
//! browser), and in a real browser (Chromium, headless) the page loads without an error, draws,
//! answers its slider, and reports at grid nodes what `volmap sample` gives there.

use std::path::{Path, PathBuf};
use std::process::Command;

use base64::Engine as _;
use predicates::prelude::*;
use volmap::io::field::FieldFile;

use super::{s, volmap};

/// The page's data: the JSON inside its `#volmap-data` element.
fn page_data(page: &Path) -> serde_json::Value {
    let html = std::fs::read_to_string(page).unwrap();
    let start = html.find("id=\"volmap-data\"").expect("the data element");
    let open = html[start..].find('>').unwrap() + start + 1;
    let close = html[open..].find("</script>").unwrap() + open;
    serde_json::from_str(&html[open..close]).unwrap()
}

fn decode(b64: &str) -> Vec<f32> {
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(b64)
        .unwrap();
    bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

fn indices(value: &serde_json::Value) -> Vec<usize> {
    value
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as usize)
        .collect()
}

/// A sweep of two poses of the five-axis machine over a 20x15x9 grid, written into `dir`.
fn sweep(dir: &Path) -> PathBuf {
    let field = dir.join("f.exr");
    volmap()
        .args(["map", "--machine", "5axis-hwang2014", "--device", "cpu"])
        .args(["--grid", "20x15x9", "--poses", "C=0:45:45", "--out"])
        .arg(&field)
        .assert()
        .success();
    field
}

#[test]
fn the_page_holds_the_fields_values_at_the_nodes_it_shows() {
    let dir = tempfile::tempdir().unwrap();
    let field = sweep(dir.path());
    let page = dir.path().join("f.html");
    volmap()
        .args(["view", s(&field), "--max-nodes", "8", "--out", s(&page)])
        .assert()
        .success()
        .stderr("")
        .stdout(predicate::str::contains(
            "2 poses, 8x8x8 nodes shown of 20x15x9",
        ));
    let data = page_data(&page);
    let file = FieldFile::open(&field).unwrap();
    let parts = data["parts"].as_array().unwrap();
    assert_eq!(parts.len(), 2);
    for (p, part) in parts.iter().enumerate() {
        assert_eq!(part["name"], file.name(p));
        let info = file.info(p);
        // Evenly spaced nodes, both ends included, derived by hand for 20, 15 and 9 nodes.
        let shown: Vec<Vec<usize>> = (0..3).map(|d| indices(&part["node_indices"][d])).collect();
        assert_eq!(shown[0], [0, 3, 5, 8, 11, 14, 16, 19]);
        assert_eq!(shown[1], [0, 2, 4, 6, 8, 10, 12, 14]);
        assert_eq!(shown[2], [0, 1, 2, 3, 5, 6, 7, 8]);
        let values = decode(part["values"].as_str().unwrap());
        assert_eq!(values.len(), 8 * 8 * 8 * 6);
        let mut reader = file.reader(p).unwrap();
        let mut line = vec![0.0f32; 6 * 20];
        let mut largest = 0.0f64;
        for k in 0..9 {
            for j in 0..15 {
                reader.read_line((j + 15 * k) as u64, &mut line).unwrap();
                for i in 0..20 {
                    let ve = (3..6)
                        .map(|c| (line[c * 20 + i] as f64).powi(2))
                        .sum::<f64>();
                    largest = largest.max(ve.sqrt());
                }
                let (Some(jj), Some(kk)) = (
                    shown[1].iter().position(|&x| x == j),
                    shown[2].iter().position(|&x| x == k),
                ) else {
                    continue;
                };
                for (ii, &i) in shown[0].iter().enumerate() {
                    let at = 6 * (ii + 8 * (jj + 8 * kk));
                    for c in 0..6 {
                        // Bit for bit: the page holds the field's f32 values.
                        assert_eq!(
                            values[at + c],
                            line[c * 20 + i],
                            "part {p} node {i},{j},{k}"
                        );
                    }
                }
            }
        }
        assert_eq!(part["largest_ve_mm"].as_f64().unwrap(), largest);
        for d in 0..3 {
            let coords = part["coords_mm"][d].as_array().unwrap();
            assert_eq!(coords.len(), 8);
            for (n, &i) in shown[d].iter().enumerate() {
                let want = info.origin_mm[d] + i as f64 * info.spacing_mm[d];
                assert!((coords[n].as_f64().unwrap() - want).abs() < 1e-9);
            }
        }
        assert!(part["uncertainty"].is_null());
    }
}

#[test]
fn a_field_with_a_part_lists_its_features_as_features_evaluates_them() {
    let dir = tempfile::tempdir().unwrap();
    let field = dir.path().join("vmc.exr");
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--device",
            "cpu",
            "--grid",
            "24x24x24",
        ])
        .arg("--out")
        .arg(&field)
        .assert()
        .success();
    let part = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/li2015-part.toml");
    let page = dir.path().join("p.html");
    volmap()
        .args(["view", s(&field), "--part", s(&part), "--out", s(&page)])
        .assert()
        .success()
        .stdout(predicate::str::contains("5 features"));
    let json = dir.path().join("features.json");
    // `features` exits 0 or with its verdicts' codes; its report is what the page must list.
    volmap()
        .args([
            "features",
            "--field",
            s(&field),
            "--part",
            s(&part),
            "--json",
            s(&json),
        ])
        .output()
        .unwrap();
    let report: serde_json::Value = super::json_result(&json);
    let want = report.as_array().unwrap();
    let data = page_data(&page);
    let got = data["features"].as_array().unwrap();
    assert_eq!(got.len(), 5);
    assert_eq!(want.len(), got.len());
    for (g, w) in got.iter().zip(want) {
        assert_eq!(g["name"], w["name"]);
        assert_eq!(g["error_mm"], w["error_mm"]);
        assert_eq!(g["verdict"], w["verdict"]);
    }
    assert!(!data["cutter_points_mm"].as_array().unwrap().is_empty());
}

#[test]
fn a_field_with_uncertainties_shows_them_at_its_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("u.toml");
    std::fs::write(
        &machine,
        "name = \"u\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -100.0]\n\
         [axes.X]\nrange = [0.0, 500.0]\n[axes.Y]\nrange = [0.0, 400.0]\n\
         EC0Y = { value = 1.8e-5, u = 2e-6 }\n[axes.Z]\nrange = [0.0, 300.0]\n",
    )
    .unwrap();
    let field = dir.path().join("u.exr");
    volmap()
        .args([
            "map",
            "--machine",
            s(&machine),
            "--device",
            "cpu",
            "--grid",
            "9x7x5",
        ])
        .args(["--uncertainty", "--out", s(&field)])
        .assert()
        .success();
    let page = dir.path().join("u.html");
    volmap()
        .args(["view", s(&field), "--max-nodes", "4", "--out", s(&page)])
        .assert()
        .success();
    let data = page_data(&page);
    let part = &data["parts"][0];
    assert!(part["uncertainty_method"]
        .as_str()
        .unwrap()
        .contains("first order"));
    let u = decode(part["uncertainty"].as_str().unwrap());
    assert_eq!(u.len(), 4 * 4 * 4 * 6);
    let file = FieldFile::open(&field).unwrap();
    let mut reader = file.uncertainty_reader(0).unwrap().unwrap();
    let shown: Vec<Vec<usize>> = (0..3).map(|d| indices(&part["node_indices"][d])).collect();
    assert_eq!(shown[0], [0, 3, 5, 8]);
    let mut line = vec![0.0f32; 6 * 9];
    for (kk, &k) in shown[2].iter().enumerate() {
        for (jj, &j) in shown[1].iter().enumerate() {
            reader.read_line((j + 7 * k) as u64, &mut line).unwrap();
            for (ii, &i) in shown[0].iter().enumerate() {
                let at = 6 * (ii + 4 * (jj + 4 * kk));
                for c in 0..6 {
                    assert_eq!(u[at + c], line[c * 9 + i], "node {i},{j},{k}");
                }
                // u(VE.X) = |y|·u (derived by hand for the squareness alone).
                let y = part["coords_mm"][1][jj].as_f64().unwrap();
                assert!((u[at + 3] as f64 - y * 2e-6).abs() < 1e-9, "y {y}");
            }
        }
    }
}

#[test]
fn bad_requests_are_refused_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("p.html");
    volmap()
        .args(["view", "--out", s(&page)])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("say what to show"));
    volmap()
        .args(["view", "missing.exr", "--out", s(&page)])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("missing.exr"));
    let field = dir.path().join("f.exr");
    std::fs::write(&field, b"not a field").unwrap();
    volmap()
        .args([
            "view",
            s(&field),
            "--machine",
            "vmc-li2015",
            "--out",
            s(&page),
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("not both"));
    volmap()
        .args(["view", s(&field), "--out", s(&page)])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("f.exr").and(predicate::str::contains("not")));
    volmap()
        .args([
            "view",
            "--machine",
            "vmc-li2015",
            "--max-nodes",
            "1",
            "--out",
            s(&page),
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--max-nodes"));
    volmap()
        .args([
            "view",
            "--machine",
            "vmc-li2015",
            "--grid",
            "200x200x200",
            "--out",
            s(&page),
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--grid"));
    assert!(!page.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

/// Chromium where it is installed; a missing browser skips the test (recorded), or fails it
/// under `VOLMAP_REQUIRE_READERS`.
fn browser() -> Option<&'static str> {
    let found = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|name| {
            Command::new(name)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        });
    if found.is_none() {
        if crate::skips::readers_required() {
            panic!("VOLMAP_REQUIRE_READERS is set but Chromium is missing");
        }
        crate::skips::skipped("Chromium is not installed");
    }
    found
}

/// Chromium headless, its own profile in `dir`, with `args` and the page's address.
fn headless(browser: &str, dir: &Path, args: &[&str], address: &str) -> std::process::Output {
    Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", dir.join("profile").display()))
        .args([
            "--virtual-time-budget=10000",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .args(args)
        .arg(address)
        .output()
        .unwrap()
}

/// The page's self-test (`#selftest=` with `nodes`, indices among the nodes shown of part 0):
/// what it wrote into `#volmap-selftest`, after checking that the browser logged no error of
/// the page's.
fn selftest(browser: &str, dir: &Path, page: &Path, nodes: &[[usize; 3]]) -> serde_json::Value {
    let list: Vec<String> = nodes
        .iter()
        .map(|n| format!("{},{},{}", n[0], n[1], n[2]))
        .collect();
    let address = format!("file://{}#selftest={}", page.display(), list.join(";"));
    let output = headless(browser, dir, &["--dump-dom"], &address);
    let dom = String::from_utf8_lossy(&output.stdout);
    let log = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{log}");
    for line in log.lines().filter(|l| l.contains("CONSOLE")) {
        assert!(
            !line.contains("Uncaught") && !line.contains("Error"),
            "the page logged: {line}"
        );
    }
    let start = dom
        .find("<pre id=\"volmap-selftest\"")
        .unwrap_or_else(|| panic!("no self-test in the page: {log}"));
    let open = dom[start..].find('>').unwrap() + start + 1;
    let close = dom[open..].find("</pre>").unwrap() + open;
    let text = dom[open..close]
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    assert!(!text.is_empty(), "the self-test wrote nothing: {log}");
    let result: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        result["errors"].as_array().unwrap().len(),
        0,
        "{}",
        result["errors"]
    );
    result
}

/// Every canvas drawn (more than a few pixels not white) and moving the X slider redrew its
/// section.
fn assert_drawn(result: &serde_json::Value) {
    for canvas in [
        "section-x",
        "section-y",
        "section-z",
        "colorbar",
        "deformed",
    ] {
        let drawn = result["canvases"][canvas]["drawn"].as_u64().unwrap();
        assert!(drawn > 2000, "{canvas}: {drawn} pixels drawn");
    }
    let slider = &result["slider"];
    assert_ne!(
        slider["before"]["hash"], slider["after"]["hash"],
        "{slider}"
    );
    assert_ne!(
        result["signed_section_z"]["hash"], result["canvases"]["section-z"]["hash"],
        "colouring by VE.X changed nothing"
    );
}

#[test]
fn in_a_browser_the_page_draws_answers_its_slider_and_shows_what_sample_gives() {
    let Some(browser) = browser() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let field = sweep(dir.path());
    let page = dir.path().join("f.html");
    volmap()
        .args(["view", s(&field), "--max-nodes", "8", "--out", s(&page)])
        .assert()
        .success();
    let nodes = [[0, 0, 0], [7, 7, 7], [3, 5, 2], [6, 1, 4]];
    let result = selftest(browser, dir.path(), &page, &nodes);
    assert_drawn(&result);
    assert_eq!(result["parts"].as_array().unwrap().len(), 2);
    assert!(result["note"]
        .as_str()
        .unwrap()
        .contains("shown at 8×8×8 of the field's 20×15×9"));
    assert!(result["facts"].as_str().unwrap().contains("largest error"));
    // The values the page reports at the nodes, against `volmap sample` there (part 0: C=0).
    let values = result["values"].as_array().unwrap();
    assert_eq!(values.len(), nodes.len());
    let mut csv = String::from("X,Y,Z,B,C\n");
    for v in values {
        csv.push_str(&format!("{},{},{},0,0\n", v["x_mm"], v["y_mm"], v["z_mm"]));
    }
    let points = dir.path().join("points.csv");
    std::fs::write(&points, csv).unwrap();
    let output = volmap()
        .args([
            "sample",
            "--device",
            "cpu",
            "--field",
            s(&field),
            "--points",
            s(&points),
        ])
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), nodes.len());
    for (row, v) in rows.iter().zip(values) {
        for (c, name) in ["VE.X", "VE.Y", "VE.Z"].iter().enumerate() {
            let column = header.iter().position(|h| h == name).unwrap();
            let page = v["ve_mm"][c].as_f64().unwrap();
            // Both the field's f32 at a node: equal within the f32's rounding.
            let tolerance = 2.0 * f32::EPSILON as f64 * page.abs().max(1e-6);
            assert!(
                (row[column] - page).abs() <= tolerance,
                "{name}: sample {} page {page}",
                row[column]
            );
        }
    }
    // The README's picture comes from this run.
    let shot = dir.path().join("view.png");
    let output = headless(
        browser,
        dir.path(),
        &[
            "--window-size=1420,900",
            &format!("--screenshot={}", shot.display()),
        ],
        &format!("file://{}", page.display()),
    );
    assert!(output.status.success());
    let png = std::fs::read(&shot).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    if std::env::var_os("VOLMAP_BLESS").is_some() {
        let to = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/images/view.png");
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::write(to, png).unwrap();
    }
}

#[test]
fn in_a_browser_a_machine_with_uncertainties_and_a_part_shows_both() {
    let Some(browser) = browser() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // vmc-li2015 with a squareness of Y to X carrying u: u(VE.X) = |y|·u at every node (to
    // first order, exactly here: VE.X is linear in it).
    let text = String::from_utf8(
        volmap()
            .args(["machines", "--show", "vmc-li2015"])
            .output()
            .unwrap()
            .stdout,
    )
    .unwrap();
    let u = 2e-6;
    let line = text.lines().find(|l| l.starts_with("EC0Y")).expect("EC0Y");
    let value: f64 = line
        .split(['=', '#'])
        .nth(1)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let text = text.replace(line, &format!("EC0Y = {{ value = {value:e}, u = {u:e} }}"));
    let machine = dir.path().join("m.toml");
    std::fs::write(&machine, text).unwrap();
    let part = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/li2015-part.toml");
    let page = dir.path().join("m.html");
    volmap()
        .args(["view", "--machine", s(&machine), "--grid", "9x7x5"])
        .args(["--part", s(&part), "--out", s(&page)])
        .assert()
        .success()
        .stdout(predicate::str::contains("features"));
    let nodes = [[0, 0, 0], [8, 6, 4], [2, 3, 1]];
    let result = selftest(browser, dir.path(), &page, &nodes);
    assert_drawn(&result);
    let quantities: Vec<&str> = result["quantities"]
        .as_array()
        .unwrap()
        .iter()
        .map(|q| q.as_str().unwrap())
        .collect();
    assert!(
        quantities.contains(&"u") && quantities.contains(&"u(VE.X)"),
        "{quantities:?}"
    );
    assert!(result["facts"].as_str().unwrap().contains("uncertainty"));
    let features = result["features"].as_str().unwrap();
    for name in ["pocket floor", "pocket wall"] {
        assert!(features.contains(name), "{features}");
    }
    // u(VE) at the nodes against `sample --exact --uncertainty` there (the f64 reference's
    // first order; the page holds the CPU engine's, stored as f32).
    let values = result["values"].as_array().unwrap();
    assert_eq!(values.len(), nodes.len());
    let mut csv = String::from("X,Y,Z\n");
    for v in values {
        csv.push_str(&format!("{},{},{}\n", v["x_mm"], v["y_mm"], v["z_mm"]));
    }
    let points = dir.path().join("points.csv");
    std::fs::write(&points, csv).unwrap();
    let output = volmap()
        .args([
            "sample",
            "--exact",
            "--uncertainty",
            "--machine",
            s(&machine),
        ])
        .args(["--points", s(&points)])
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), nodes.len());
    for (row, v) in rows.iter().zip(values) {
        for (c, name) in ["u(VE.X)", "u(VE.Y)", "u(VE.Z)"].iter().enumerate() {
            let column = header.iter().position(|h| h == name).unwrap();
            let page = v["u_ve_mm"][c].as_f64().unwrap();
            // 1e-9 mm: the f32's rounding of a u of about 1 µm, and the engines' differences.
            assert!(
                (row[column] - page).abs() <= 1e-9,
                "{name}: sample {} page {page}",
                row[column]
            );
        }
        // The squareness's lever is Y (with the other errors' few micrometres beside it).
        let y = v["y_mm"].as_f64().unwrap();
        let got = v["u_ve_mm"][0].as_f64().unwrap();
        assert!((got - y.abs() * u).abs() <= 1e-7, "y {y}: u(VE.X) {got}");
    }
}
