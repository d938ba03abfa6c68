//! Decisions with uncertainty: `features` gives each error's expanded uncertainty (k = 2) and the
//! decision by ISO 14253-1 with its exit code (0 all conform, 3 one does not, 5 none fails but
//! one is undecided); `compensate` says whether the largest error left is within U.
//!
//! The machine: FYXFZ with a squareness `EC0Y = v` alone. `E_rel = A_X·A_Y·A_Z·Trans(tool)` with
//! `A_Y = Rz(v)·Trans(y·ŷ)` puts the tip at `x·x̂ + Rz(v)·(EXS, y, z − 100)`, so
//! `VE.x = EXS·cos v − y·sin v`, `VE.y = y·(cos v − 1) + EXS·sin v`, `VE.z = 0`.
//!
//! The part: one triangle of a profile in the plane x = 0 of the part (corners (0,0,0), (0,30,0),
//! (0,0,−30), outward normal −x), sampled at 50 mm: one sample, at its centroid (0, 10, −10),
//! commanded (100, 210, 190) with the zero at (100, 200, 200). Its deviation is
//! `d = −VE.x = y·sin v − EXS·cos v` with y = 210, and the profile (judged nominally) is
//! `F = 2|d|`: with EXS = 0, `F = 2·y·sin v` and `dF/dv = 2·y·cos v`.

use std::path::{Path, PathBuf};

use super::{s, volmap};

const Y_MM: f64 = 210.0;
const V_RAD: f64 = 1.8e-5;
const W_RAD: f64 = 2e-6;

/// The machine with `EC0Y = { value = V_RAD, u }` (`u` empty: exact) and `extra` after `[axes.Z]`.
fn machine(dir: &Path, name: &str, u: Option<f64>, extra: &str) -> PathBuf {
    let squareness = match u {
        Some(u) => format!("{{ value = {V_RAD:e}, u = {u:e} }}"),
        None => format!("{V_RAD:e}"),
    };
    let text = format!(
        "name = \"u\"\nchain = \"FYXFZ\"\n[tool]\noffset = [0.0, 0.0, -100.0]\n\
         [axes.X]\nrange = [0.0, 500.0]\n\
         [axes.Y]\nrange = [0.0, 400.0]\nEC0Y = {squareness}\n\
         [axes.Z]\nrange = [0.0, 300.0]\n{extra}\n"
    );
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The part of the module's documentation with the profile's tolerance.
fn part(dir: &Path, tolerance_mm: f64) -> PathBuf {
    let stl = "solid t\nfacet normal -1 0 0\nouter loop\nvertex 0 0 0\nvertex 0 30 0\n\
               vertex 0 0 -30\nendloop\nendfacet\nendsolid t\n";
    std::fs::write(dir.join("wall.stl"), stl).unwrap();
    let path = dir.join(format!("part-{tolerance_mm}.toml"));
    std::fs::write(
        &path,
        format!(
            "name = \"p\"\n[placement]\nzero_mm = [100.0, 200.0, 200.0]\n[cutter]\n\
             radius_mm = 8.0\nlength_mm = 60.0\n[sampling]\nspacing_mm = 50.0\n[[features]]\n\
             kind = \"profile\"\nname = \"wall\"\nmesh = \"wall.stl\"\ntolerance_mm = {tolerance_mm}\n"
        ),
    )
    .unwrap();
    path
}

/// `features` on `machine` and `part`: its exit code, its standard output and its one row.
fn features(dir: &Path, machine: &Path, part: &Path) -> (i32, String, serde_json::Value) {
    let json = dir.join("rows.json");
    let output = volmap()
        .args([
            "features",
            "--machine",
            s(machine),
            "--part",
            s(part),
            "--json",
        ])
        .arg(&json)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    let rows = super::json_result(&json);
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 1, "{rows:?}");
    (
        output.status.code().unwrap(),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        rows[0].clone(),
    )
}

fn close(got: f64, want: f64) {
    assert!((got - want).abs() <= 1e-9 * want.abs(), "{got} vs {want}");
}

/// F = 2·y·sin v = 7.56 µm, U = 2·(2·y·cos v)·w = 1.68 µm: a tolerance of 10 µm holds F + U
/// (conforms, 0), one of 5 µm lies below F − U (does not conform, 3), one of 8 µm between
/// (undecided, 5).
#[test]
fn the_decision_takes_the_expanded_uncertainty_and_sets_the_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    let m = machine(dir.path(), "m.toml", Some(W_RAD), "");
    let error = 2.0 * Y_MM * V_RAD.sin();
    let u = 2.0 * (2.0 * Y_MM * V_RAD.cos()).abs() * W_RAD;
    for (tolerance, code, decision) in [
        (0.010, 0, "conforms"),
        (0.005, 3, "does_not_conform"),
        (0.008, 5, "undecided"),
    ] {
        // The three tolerances are where the derivation says they are.
        match code {
            0 => assert!(error + u <= tolerance),
            3 => assert!(error - u > tolerance),
            _ => assert!(error - u <= tolerance && tolerance < error + u),
        }
        let (got, stdout, row) = features(dir.path(), &m, &part(dir.path(), tolerance));
        assert_eq!(got, code, "{tolerance}: {stdout}");
        close(row["error_mm"].as_f64().unwrap(), error);
        close(row["u_expanded_mm"].as_f64().unwrap(), u);
        assert_eq!(row["conformance"], decision, "{row}");
        let words = decision.replace('_', " ");
        assert!(stdout.contains(&words), "{words} not in {stdout}");
        assert!(
            stdout.contains("U µm (k=2)") && stdout.contains("1.680"),
            "{stdout}"
        );
    }
}

/// Without `u` the same machine gives U = 0 and the decisions of the error against the tolerance
/// alone: 8 µm holds 7.56 µm (conforms, 0) and 7 µm does not (3); never undecided.
#[test]
fn a_machine_without_uncertainty_decides_on_the_error_alone() {
    let dir = tempfile::tempdir().unwrap();
    let m = machine(dir.path(), "m.toml", None, "");
    let error = 2.0 * Y_MM * V_RAD.sin();
    for (tolerance, code, decision, verdict) in [
        (0.008, 0, "conforms", "inspect"),
        (0.007, 3, "does_not_conform", "unfit"),
    ] {
        let (got, stdout, row) = features(dir.path(), &m, &part(dir.path(), tolerance));
        assert_eq!(got, code, "{stdout}");
        close(row["error_mm"].as_f64().unwrap(), error);
        assert_eq!(row["u_expanded_mm"].as_f64(), Some(0.0), "{row}");
        assert_eq!(row["conformance"], decision, "{row}");
        assert_eq!(row["verdict"], verdict, "{row}");
    }
}

/// Correlated quantities: EC0Y and the spindle's EXS = {0, u = s} with covariance c. With
/// `dF/dv = 2·y·cos v` and `dF/dEXS = −2·cos v` (F = 2·d, d > 0),
/// `u²(F) = (2y·cos v)²·w² + (2·cos v)²·s² + 2·(2y·cos v)·(−2·cos v)·c`.
#[test]
fn correlated_quantities_enter_with_their_covariance() {
    let dir = tempfile::tempdir().unwrap();
    let (sigma, correlation) = (3e-4, -0.6);
    let c = correlation * W_RAD * sigma;
    let extra = format!(
        "[spindle]\nEXS = {{ value = 0.0, u = {sigma:e} }}\n[covariance]\n\"axes.Y.EC0Y spindle.EXS\" = {c:e}\n"
    );
    let m = machine(dir.path(), "m.toml", Some(W_RAD), &extra);
    let (dv, ds) = (2.0 * Y_MM * V_RAD.cos(), -2.0 * V_RAD.cos());
    let variance = (dv * W_RAD).powi(2) + (ds * sigma).powi(2) + 2.0 * dv * ds * c;
    let (_, stdout, row) = features(dir.path(), &m, &part(dir.path(), 0.1));
    close(
        row["u_expanded_mm"].as_f64().unwrap(),
        2.0 * variance.sqrt(),
    );
    // The covariance counts: with it U is larger than without (the correlation is negative,
    // the derivatives of opposite signs).
    let independent = 2.0 * ((dv * W_RAD).powi(2) + (ds * sigma).powi(2)).sqrt();
    assert!(
        row["u_expanded_mm"].as_f64().unwrap() > independent * 1.01,
        "{stdout}"
    );
}

/// A program along y = 200 (a move along X and back): compensated at 3 decimals, the rounding
/// leaves up to about 0.5 µm; with u(EC0Y) = 2e-5 rad, U = 2·|u(VE)| ≈ 2·200·2e-5 mm = 8 µm holds
/// it, with u = 1e-9 rad (U ≈ 0.4 nm) it does not. `--json` carries the same figures.
#[test]
fn compensate_says_whether_the_largest_error_left_is_within_u() {
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("p.nc");
    std::fs::write(
        &program,
        "G21 G90 G17\nG0 X10 Y200 Z150\nG1 X310.3 Y200.7 Z150 F1000\nG1 X40.9 Y200.3 Z150\nM30\n",
    )
    .unwrap();
    let run = |u: Option<f64>, name: &str| -> (String, serde_json::Value) {
        let m = machine(dir.path(), &format!("{name}.toml"), u, "");
        let out = dir.path().join(format!("{name}.nc"));
        let json = dir.path().join(format!("{name}.json"));
        let output = volmap()
            .args(["compensate", "--machine", s(&m), "--program", s(&program)])
            .args(["--json", s(&json)])
            .args([
                "--decimals",
                "3",
                "--chord-tolerance",
                "0.002",
                "--out",
                s(&out),
            ])
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
        assert_eq!(
            output.status.code(),
            Some(0),
            "{stdout}{}",
            String::from_utf8_lossy(&output.stderr)
        );
        (stdout, super::json_result(&json))
    };
    let (wide, wide_json) = run(Some(2e-5), "wide");
    assert!(
        wide.contains("within U =") && wide.contains("below what the measurements can know"),
        "{wide}"
    );
    same_figures(&wide, &wide_json, true);
    let (narrow, narrow_json) = run(Some(1e-9), "narrow");
    assert!(
        narrow.contains("beyond U =") && !narrow.contains("within U"),
        "{narrow}"
    );
    same_figures(&narrow, &narrow_json, false);
    // A machine without u says nothing of it, and its JSON has no U.
    let (stdout, json) = run(None, "exact");
    assert!(!stdout.contains("U ="), "{stdout}");
    for key in ["u_expanded_mm", "within_u", "largest_error_left_mm"] {
        assert!(json[key].is_null(), "{key}: {json}");
    }
}

/// The number before ` µm` after `after` in `text`, in µm.
fn um_after(text: &str, after: &str) -> f64 {
    let rest = &text[text
        .find(after)
        .unwrap_or_else(|| panic!("{after}: {text}"))
        + after.len()..];
    rest[..rest.find(" µm").unwrap()].trim().parse().unwrap()
}

/// `compensate --json`'s U and its reading are the text's: `largest error after X µm at line L
/// …, within U = Y µm`.
fn same_figures(text: &str, json: &serde_json::Value, within: bool) {
    assert_eq!(json["within_u"], within, "{json}");
    let u_um = json["u_expanded_mm"].as_f64().unwrap() * 1e3;
    assert!(
        (u_um - um_after(text, "U = ")).abs() <= 0.0005,
        "{text}{json}"
    );
    let left_um = json["largest_error_left_mm"].as_f64().unwrap() * 1e3;
    assert!(
        (left_um - um_after(text, "largest error after")).abs() <= 0.0005,
        "{text}{json}"
    );
    let line = json["largest_error_left_line"].as_u64().unwrap();
    assert!(text.contains(&format!(" at line {line} ")), "{text}{json}");
    assert_eq!(u_um >= left_um, within, "{json}");
}
