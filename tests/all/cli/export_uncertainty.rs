//! `volmap export` with a machine that gives standard uncertainties: each table node's u, the
//! largest node U per table in the report (text and `--json`) and in the files' comments, and
//! whether the residual is below what the measurements can know.
//!
//! The machine: FYXFZ with a squareness `EC0Y = { value = v, u }` alone. The tip is at
//! `x·x̂ + Rz(EC0Y)·(y·ŷ + (z − 100)·ẑ)`, so `VE.x = −y·sin EC0Y`, `VE.y = y·(cos EC0Y − 1)`,
//! `VE.z = 0`; X, Y, Z move the ideal tip along x, y, z (`J = I`), so the correction's
//! `u(dX) = |y|·cos v·u`, `u(dY) = |y|·sin v·u`, `u(dZ) = 0` to first order.

use std::path::{Path, PathBuf};

use volmap::export::{self, Request, TableSize};
use volmap::model::inputs::Inputs;
use volmap::model::Machine;

use super::{json_result, s, volmap};

const V_RAD: f64 = 1.8e-5;

/// The machine text with `EC0Y = { value = V_RAD, u }` (`u` empty: exact).
fn machine_text(u: Option<f64>) -> String {
    let squareness = match u {
        Some(u) => format!("{{ value = {V_RAD:e}, u = {u:e} }}"),
        None => format!("{V_RAD:e}"),
    };
    format!(
        "name = \"u\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -100.0]\n\
         [axes.X]\nrange = [0.0, 500.0]\n\
         [axes.Y]\nrange = [0.0, 400.0]\nEC0Y = {squareness}\n\
         [axes.Z]\nrange = [0.0, 300.0]\n"
    )
}

fn machine(dir: &Path, name: &str, u: Option<f64>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, machine_text(u)).unwrap();
    path
}

/// `export` of `machine` in `format` with `extra` flags to `out` and a JSON report: its
/// standard output and the report's `result`.
fn export(
    dir: &Path,
    machine: &Path,
    format: &str,
    extra: &[&str],
    out: &Path,
) -> (String, serde_json::Value) {
    let json = dir.join(format!("{format}.json"));
    let output = volmap()
        .args(["export", "--machine", s(machine), "--format", format])
        .args(extra)
        .args(["--out", s(out), "--json", s(&json)])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert_eq!(
        output.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    (stdout, json_result(&json))
}

/// The data rows of a CSV text (comment lines dropped): the header, then the numbers.
fn csv(text: &str) -> (String, Vec<Vec<f64>>) {
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn grid_csv_gives_each_node_the_u_of_its_correction() {
    let dir = tempfile::tempdir().unwrap();
    let u = 2e-6;
    let m = machine(dir.path(), "m.toml", Some(u));
    let out = dir.path().join("grid.csv");
    let (stdout, report) = export(dir.path(), &m, "grid-csv", &["--points", "5"], &out);
    let text = std::fs::read_to_string(&out).unwrap();
    let (header, rows) = csv(&text);
    assert_eq!(header, "X,Y,Z,dX,dY,dZ,u(dX),u(dY),u(dZ)");
    assert_eq!(rows.len(), 125);
    let mut ys = Vec::new();
    for row in &rows {
        assert_eq!(row.len(), 9, "{row:?}");
        let y = row[1];
        ys.push(y);
        assert!((row[6] - y.abs() * u).abs() < 1e-9, "{row:?}");
        assert!((row[7] - y.abs() * V_RAD.sin() * u).abs() < 1e-9, "{row:?}");
        assert!(row[8].abs() < 1e-9, "{row:?}");
    }
    // The nodes span Y's travel: the largest u is at y = 400.
    assert_eq!(ys.iter().copied().fold(0.0, f64::max), 400.0);
    let uncertainty = &report["report"]["uncertainty"];
    let tables = uncertainty["tables"].as_array().unwrap();
    assert_eq!(tables.len(), 1, "{uncertainty}");
    assert_eq!(tables[0]["table"], "grid");
    assert_eq!(tables[0]["corrects"], "X Y Z");
    let largest = tables[0]["u_mm"].as_f64().unwrap();
    assert!((largest - 400.0 * u).abs() < 1e-9, "{uncertainty}");
    let expanded = uncertainty["u_expanded_mm"].as_f64().unwrap();
    assert!((expanded - 2.0 * 400.0 * u).abs() < 2e-9, "{uncertainty}");
    // The squareness is linear in y: the grid holds it to its rounding, far within U.
    assert_eq!(uncertainty["within_u"], true, "{uncertainty}");
    assert!(
        stdout.contains("U = 1.600 µm (k = 2)")
            && stdout.contains("the residual is below what the measurements can know"),
        "{stdout}"
    );
    // The report's comments in the file say the same.
    assert!(
        text.lines().any(|l| l.starts_with("# uncertainty of table grid, correcting X Y Z: largest node u 0.8000 um, U = 1.6000 um (k = 2)")),
        "{text}"
    );
}

#[test]
fn grid_csv_of_a_machine_without_u_has_no_u_columns() {
    let dir = tempfile::tempdir().unwrap();
    let m = machine(dir.path(), "m.toml", None);
    let out = dir.path().join("grid.csv");
    let (stdout, report) = export(dir.path(), &m, "grid-csv", &["--points", "5"], &out);
    let text = std::fs::read_to_string(&out).unwrap();
    let (header, rows) = csv(&text);
    assert_eq!(header, "X,Y,Z,dX,dY,dZ");
    assert_eq!(rows.len(), 125);
    assert!(rows.iter().all(|r| r.len() == 6));
    assert!(report["report"]["uncertainty"].is_null(), "{report}");
    assert!(
        !stdout.contains("U =") && !text.contains("uncertainty"),
        "{stdout}"
    );
}

/// LinuxCNC 2.9 holds no squareness: its X table holds the mean of `dX` over Y, and leaves
/// `|y − 200|·v` ≈ 3.6 µm at Y's ends. The X table's largest node U is `2·400·u`: 1.6 µm for
/// u = 2e-6 (the residual beyond it), 8 µm for u = 1e-5 (within it).
#[test]
fn the_report_says_whether_the_residual_is_below_what_the_measurements_can_know() {
    let dir = tempfile::tempdir().unwrap();
    for (u, within) in [(2e-6, false), (1e-5, true)] {
        let m = machine(dir.path(), &format!("m{u}.toml"), Some(u));
        let out = dir.path().join(format!("lcnc{u}"));
        let (stdout, report) = export(dir.path(), &m, "linuxcnc", &["--control", "2.9"], &out);
        let r = &report["report"];
        let residual = r["residual"]["max_mm"].as_f64().unwrap();
        assert!(
            (residual - 200.0 * V_RAD).abs() < 0.2 * 200.0 * V_RAD,
            "{stdout}"
        );
        let uncertainty = &r["uncertainty"];
        let tables = uncertainty["tables"].as_array().unwrap();
        assert_eq!(tables.len(), 3, "{uncertainty}");
        assert_eq!(tables[0]["table"], "joint 0 (X)");
        assert_eq!(tables[0]["corrects"], "X");
        let x_table = tables[0]["u_expanded_mm"].as_f64().unwrap();
        assert!((x_table - 2.0 * 400.0 * u).abs() < 2e-9, "{uncertainty}");
        assert_eq!(tables[2]["u_mm"].as_f64().unwrap(), 0.0, "{uncertainty}");
        assert_eq!(uncertainty["u_expanded_mm"].as_f64().unwrap(), x_table);
        assert_eq!(uncertainty["within_u"], within, "{uncertainty}");
        assert_eq!(
            stdout.contains("the residual is below what the measurements can know"),
            within,
            "{stdout}"
        );
        assert_eq!(
            stdout.contains("beyond the largest node U"),
            !within,
            "{stdout}"
        );
        // The joint's file says its table's U in a comment after its rows.
        let comp = std::fs::read_to_string(out.join("volmap_joint0_X.comp")).unwrap();
        let lines: Vec<&str> = comp.lines().collect();
        let note = lines
            .iter()
            .position(|l| l.starts_with("# uncertainty of table joint 0 (X), correcting X:"))
            .unwrap_or_else(|| panic!("{comp}"));
        let last_row = lines.iter().rposition(|l| !l.starts_with('#')).unwrap();
        assert!(note > last_row, "{comp}");
    }
}

/// The files with the u columns and comments read back with the formats' own readers, as the
/// control reads them: the same tables as the export reported.
#[test]
fn files_with_u_read_back_with_their_readers() {
    let machine = Machine::from_toml(&machine_text(Some(2e-6)), "m.toml", None).unwrap();
    let inputs = Inputs::default();
    for (format, comment) in [("grid-csv", "# uncertainty"), ("linuxcnc", "# uncertainty")] {
        let request = Request {
            machine: &machine,
            inputs: &inputs,
            pose: [0.0; 6],
            size: TableSize::Points(5),
            evaluation_points: None,
            written_by: "# test".into(),
            file_name: None,
            tool_length_mm: None,
            control: None,
            point_numbers: None,
            probe_offset_mm: None,
        };
        let f = export::format_named(format).unwrap();
        let exported = export::export(f, &request).unwrap();
        assert!(
            exported
                .files
                .iter()
                .any(|file| file.text.contains(comment)),
            "{format}"
        );
        let control = f
            .read(&exported.files, &[[0.0, 500.0], [0.0, 400.0], [0.0, 300.0]])
            .unwrap();
        assert_eq!(control.tables(), exported.report.tables, "{format}");
        assert!(exported.report.uncertainty.is_some(), "{format}");
    }
}
