//! Ballbar diagnostics of circular tests: squareness, scale mismatch, backlash and reversal
//! steps from machines with known errors, cyclic error and spikes from synthetic runs.

use volmap::model::Machine;
use volmap::standards::ballbar::{diagnose, Circle, Diagnostics};
use volmap::standards::{self, Setup};

use super::standards::circular_spec;

fn three_axis_with(errors: &str) -> Machine {
    let text = format!(
        "name = \"b\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [-400.0, 400.0]\n{}\n[axes.Y]\nrange = [-300.0, 300.0]\n{}\n[axes.Z]\nrange = [-250.0, 250.0]\n",
        errors.split('|').next().unwrap(),
        errors.split('|').nth(1).unwrap_or("")
    );
    Machine::from_toml(&text, "b.toml", None).unwrap()
}

fn diagnostics(machine: &Machine, direction: &str) -> Diagnostics {
    let setup = Setup::new(machine, "").unwrap();
    let spec = standards::CircularSpec {
        points: 360,
        direction: direction.into(),
        ..circular_spec("XY", 100.0)
    };
    let result = standards::circular(&setup, &spec).unwrap();
    result.ballbar.unwrap().predicted
}

#[test]
fn a_squareness_is_read_as_the_angle_between_the_axes() {
    // EC0Y > 0: the angle between +X and +Y is 90° + EC0Y (docs/model.md).
    let machine = three_axis_with("|EC0Y = 2.0e-5");
    // The diagnostics read the first-order circle; its second-order terms are S² = 4e-4 µrad
    // (and ppm) of the figures and S²·r = 4e-5 µm of the radius (measured: 2e-10 µrad, 2e-11
    // ppm, 1.5e-7 µm of backlash, a residual of 1.8e-6 µm).
    for direction in ["ccw", "cw"] {
        let d = diagnostics(&machine, direction);
        assert!((d.squareness_urad - 20.0).abs() < 1e-3, "{d:?}");
        assert!(d.scale_mismatch_ppm.abs() < 1e-3, "{d:?}");
        assert!(d.backlash_um.iter().all(|b| b.abs() < 1e-4), "{d:?}");
        assert!(d.residual_um < 1e-4, "{d:?}");
    }
}

#[test]
fn scale_errors_give_their_mismatch() {
    // X long by 30 µm/m, Y by 10: 20 µm/m, 2 µm over the 100 mm radius.
    let machine = three_axis_with("EXX = { poly = [0.0, 3.0e-5] }|EYY = { poly = [0.0, 1.0e-5] }");
    let d = diagnostics(&machine, "ccw");
    // Second-order terms: k² = 9e-4 ppm (and µrad), k²·r = 9e-5 µm (measured: 2e-10 ppm,
    // 2e-11 µm, 4e-11 µrad).
    assert!((d.scale_mismatch_ppm - 20.0).abs() < 2e-3, "{d:?}");
    assert!((d.scale_mismatch_um - 2.0).abs() < 2e-4, "{d:?}");
    assert!(d.squareness_urad.abs() < 2e-3, "{d:?}");
}

#[test]
fn a_backlash_is_a_step_where_its_axis_turns() {
    // X's ↑ error 0, ↓ error −4 µm: B = +4 µm. X turns at 0° (at its largest, from + to −)
    // and at 180° (from − to +); both steps of dr are −4 µm (dr ≈ VE_x cos θ).
    let machine = three_axis_with("EXX = { poly = [0.0], reverse = { poly = [-0.004] } }|");
    for direction in ["ccw", "cw"] {
        let d = diagnostics(&machine, direction);
        assert!((d.backlash_um[0] - 4.0).abs() < 0.01, "{direction}: {d:?}");
        assert!(d.backlash_um[1].abs() < 0.01, "{d:?}");
        assert!(!d.reversals.is_empty(), "{d:?}");
        for r in &d.reversals {
            let expected = if r.axis == 'X' { -4.0 } else { 0.0 };
            assert!(
                (r.step_um - expected).abs() < 0.01,
                "{direction}: {r:?} against {expected}"
            );
            assert!(r.spike_um.abs() < 0.01, "{r:?}");
            // The fit holds the backlash exactly: X's steps are found, nothing else.
            assert_eq!(r.step_detected, r.axis == 'X', "{r:?}");
            assert!(!r.spike_detected, "{r:?}");
        }
        assert!(d.squareness_urad.abs() < 0.01, "{d:?}");
    }
}

#[test]
fn a_cyclic_error_and_a_servo_spike_are_found_in_a_synthetic_run() {
    // A 2 µm cyclic error of pitch 8 mm along Y, and a 1.5 µm spike at 180° where X turns.
    let circle = Circle {
        axes: ['X', 'Y'],
        radius_mm: 100.0,
        centre_mm: [10.0, -20.0],
        sense: 1.0,
        pitch_mm: Some(8.0),
    };
    let angles: Vec<f64> = (0..720).map(|i| i as f64 * 0.5).collect();
    let radial: Vec<f64> = angles
        .iter()
        .map(|&t| {
            let (s, _) = t.to_radians().sin_cos();
            let y = -20.0 + 100.0 * s;
            let cyclic = 0.002 * (std::f64::consts::TAU * y / 8.0 + 0.3).sin() * s;
            let spike = if t == 180.5 { 0.0015 } else { 0.0 };
            cyclic + spike
        })
        .collect();
    let d = diagnose(&angles, &radial, &circle).unwrap();
    let [cx, cy] = d.cyclic_um.unwrap();
    assert!((cy - 2.0).abs() < 0.01 && cx < 0.01, "{d:?}");
    let spike = d
        .reversals
        .iter()
        .find(|r| r.axis == 'X' && r.angle_deg == 180.0)
        .unwrap();
    assert!((spike.spike_um - 1.5).abs() < 0.05, "{spike:?}");
    // Found: each within 5% and above three times what the figures leave.
    assert!(
        spike.spike_detected && d.cyclic_detected == Some([false, true]),
        "{d:?}"
    );
    assert!((spike.spike_um - 1.5).abs() < 0.075 && (cy - 2.0).abs() < 0.1);
    let others = d
        .reversals
        .iter()
        .filter(|r| !(r.axis == 'X' && r.angle_deg == 180.0));
    assert!(others.clone().all(|r| !r.spike_detected), "{d:?}");
}

#[test]
fn a_model_without_reversal_or_cyclic_errors_shows_none() {
    // vmc-li2015 has no reversal and no cyclic error: what the fit leaves near the turning
    // points (its straightness and angular errors) is no spike, and no cyclic error of 10 mm.
    let machine = volmap::io::embedded::load("vmc-li2015").unwrap();
    let setup = Setup::new(&machine, "").unwrap();
    let spec = standards::CircularSpec {
        points: 360,
        pitch_mm: Some(10.0),
        ..circular_spec("XY", 100.0)
    };
    let result = standards::circular(&setup, &spec).unwrap();
    let d = &result.ballbar.as_ref().unwrap().predicted;
    assert!(d.residual_um > 0.1, "{d:?}");
    assert!((d.detection_um - 3.0 * d.residual_um).abs() < 1e-12);
    assert!(!d.reversals.is_empty(), "{d:?}");
    for r in &d.reversals {
        assert!(!r.step_detected && !r.spike_detected, "{r:?}");
        assert!(r.spike_um.abs() <= d.detection_um);
    }
    assert_eq!(d.cyclic_detected, Some([false, false]), "{d:?}");
}

#[test]
fn fit_takes_ballbar_figures() {
    // A ballbar's software reports XY squareness 25 µrad (by hand: EC0Y = 25 µrad) and the ZX
    // figures of a machine with EB0Z = −15 µrad; the fit recovers both from the figures alone.
    let dir = tempfile::tempdir().unwrap();
    let truth = {
        let text = "name = \"t\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [-400.0, 400.0]\n[axes.Y]\nrange = [-300.0, 300.0]\nEC0Y = 2.5e-5\n[axes.Z]\nrange = [-250.0, 250.0]\nEB0Z = -1.5e-5\n";
        Machine::from_toml(text, "t.toml", None).unwrap()
    };
    let setup = Setup::new(&truth, "").unwrap();
    let zx = standards::circular(
        &setup,
        &standards::CircularSpec {
            points: 360,
            ..circular_spec("ZX", 100.0)
        },
    )
    .unwrap()
    .ballbar
    .unwrap()
    .predicted;
    let text = format!(
        "estimate = [\"EC0Y\", \"EB0Z\"]\n[[ballbar]]\nplane = \"XY\"\nradius_mm = 100.0\nsquareness_urad = 25.0\nscale_mismatch_ppm = 0.0\n[[ballbar]]\nplane = \"ZX\"\nradius_mm = 100.0\nsquareness_urad = {}\nscale_mismatch_ppm = {}\nbacklash_um = [0.0, 0.0]\n",
        zx.squareness_urad, zx.scale_mismatch_ppm
    );
    let path = dir.path().join("fit.toml");
    std::fs::write(&path, text).unwrap();
    let given = three_axis_with("|");
    let report = volmap::calibrate::fit::fit(
        &given,
        &volmap::calibrate::fit::FitFile::read(&path).unwrap(),
    )
    .unwrap();
    let value = |name: &str| {
        report
            .estimates
            .iter()
            .find(|e| e.name == name)
            .unwrap()
            .value
    };
    assert!((value("EC0Y") - 2.5e-5).abs() < 1e-9, "{report:?}");
    assert!((value("EB0Z") + 1.5e-5).abs() < 1e-9, "{report:?}");
    // An entry without a figure names itself.
    std::fs::write(
        &path,
        "estimate = [\"EC0Y\"]\n[[ballbar]]\nplane = \"XY\"\nradius_mm = 100.0\n",
    )
    .unwrap();
    let error = volmap::calibrate::fit::fit(
        &given,
        &volmap::calibrate::fit::FitFile::read(&path).unwrap(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("[[ballbar]] number 1") && error.contains("squareness_urad"),
        "{error}"
    );
}
