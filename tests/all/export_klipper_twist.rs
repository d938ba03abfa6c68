//! Klipper's `[axis_twist_compensation]` (`klipper-twist`), read here as
//! `axis_twist_compensation.py` reads it, against a twisted gantry derived by hand.

use super::export::{machine, request};
use volmap::export::{self, ExportError, TableSize};
use volmap::model::inputs::Inputs;
use volmap::model::Machine;
use volmap::reference::Twin;

/// A bed-slinger: Y carries the bed, X the head on Z; X's carriage rolls in proportion to X (a
/// twisted gantry), 2e-6 rad per mm.
const ROLL_PER_MM: f64 = 2.0e-6;

fn twisted() -> Machine {
    machine(&format!(
        r#"
name = "twisted gantry"
chain = "FYFZX"
[tool]
offset = [0.0, 0.0, -40.0]
[axes.X]
range = [0.0, 300.0]
EAX = {{ poly = [0.0, {ROLL_PER_MM:e}] }}
[axes.Y]
range = [0.0, 200.0]
[axes.Z]
range = [0.0, 100.0]
"#
    ))
}

/// Z's error of the tip of `m` at toolhead X, Y on the bed (Z = 0).
fn z_error(m: &Machine, x: f64, y: f64) -> f64 {
    let twin = Twin::of(m);
    let c = [x, y, 0.0, 0.0, 0.0, 0.0];
    (twin.real_tip(&c) - twin.ideal_tip(&c)).z
}

/// `[axis_twist_compensation]`'s keys as Klipper's config reads them.
fn section(text: &str) -> std::collections::BTreeMap<String, String> {
    let body = text.split("[axis_twist_compensation]\n").nth(1).unwrap();
    body.lines()
        .take_while(|l| !l.starts_with('#') && !l.starts_with('['))
        .map(|l| {
            let (k, v) = l.split_once(':').unwrap();
            (k.trim().to_string(), v.trim().to_string())
        })
        .collect()
}

#[test]
fn klipper_twist_of_a_rolling_carriage_is_the_probes_lift_along_x() {
    let m = twisted();
    let inputs = Inputs::default();
    let offset = [0.0, -30.0];
    let mut r = request(&m, &inputs, TableSize::Points(7));
    r.probe_offset_mm = Some(offset);
    let e = export::export(export::format_named("klipper-twist").unwrap(), &r).unwrap();
    let text = &e.files[0].text;
    let keys = section(text);
    // The probe and the nozzle both reach the bed with the toolhead at Y 30..200, X 0..300.
    assert_eq!(keys["compensation_start_x"], "0.000");
    assert_eq!(keys["compensation_end_x"], "300.000");
    assert!(!keys.contains_key("zy_compensations"), "{text}");
    let values: Vec<f64> = keys["z_compensations"]
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    assert_eq!(values.len(), 7);
    assert!(keys["z_compensations"]
        .split(',')
        .all(|v| v.trim().split('.').nth(1).unwrap().len() == 6));
    // By hand: the roll a(x) = k·x turns the probe, 30 mm beside the roll's axis from the
    // nozzle, by 30·a(x) in Z; the nozzle, on the axis, not. The table is that difference,
    // less its mean: a line of slope ±30·k through the middle of the travel.
    let mut probe = m.clone();
    probe.tool_offset_mm[1] += offset[1];
    let xs: Vec<f64> = (0..7).map(|i| 50.0 * i as f64).collect();
    let d: Vec<f64> = xs
        .iter()
        .map(|&x| z_error(&probe, x, 100.0) - z_error(&m, x + offset[0], 100.0 + offset[1]))
        .collect();
    let slope = (d[6] - d[0]) / 300.0;
    assert!((slope.abs() - 30.0 * ROLL_PER_MM).abs() < 1e-9, "{slope}");
    let mean = d.iter().sum::<f64>() / 7.0;
    for (v, d) in values.iter().zip(&d) {
        assert!(
            (v - (d - mean)).abs() <= 5e-7 + 1e-12,
            "{values:?} vs {d:?}"
        );
    }
    // Linear between values (Klipper's lerp), the table leaves the probe within its rounding.
    let at = |x: f64| {
        let t = x / 50.0;
        let i = (t.floor() as usize).min(5);
        let t = t - i as f64;
        (1.0 - t) * values[i] + t * values[i + 1]
    };
    for x in [0.0, 33.0, 137.5, 300.0] {
        let left = z_error(&probe, x, 60.0) - z_error(&m, x, 30.0) - at(x) - mean;
        assert!(left.abs() < 1e-6, "{x}: {left}");
    }
    assert!(text.contains("um off without the tables"));
}

#[test]
fn klipper_twist_needs_a_probe_offset_and_reads_as_klipper() {
    let m = twisted();
    let inputs = Inputs::default();
    let format = export::format_named("klipper-twist").unwrap();
    let without = export::export(format, &request(&m, &inputs, TableSize::Default));
    assert!(matches!(without, Err(ExportError::NoProbeOffset { .. })));
    let mut r = request(&m, &inputs, TableSize::Default);
    r.probe_offset_mm = Some([0.0, -30.0]);
    let elsewhere = export::export(export::format_named("klipper").unwrap(), &r);
    assert!(matches!(elsewhere, Err(ExportError::NoProbe { .. })));
    let mut fitting = export::Fitting::new(&m, &inputs, [0.0; 6], Vec::new()).unwrap();
    fitting.probe_offset_mm = Some([0.0, -30.0]);
    let written = format.write(&fitting, Some([5, 5, 5]), None).unwrap();
    assert!(format.read_for(&written, &fitting).is_ok());
    let broken = |from: &str, to: &str| -> String {
        let mut files = written.clone();
        assert!(files[0].text.contains(from), "{from}");
        files[0].text = files[0].text.replacen(from, to, 1);
        match format.read_for(&files, &fitting) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("`{to}` read"),
        }
    };
    assert!(broken("compensation_end_x: ", "end_x: ")
        .contains("z_compensations needs compensation_start_x and compensation_end_x"));
    let line = written[0]
        .text
        .lines()
        .find(|l| l.starts_with("z_compensations"))
        .unwrap()
        .to_string();
    assert!(broken(&line, "z_compensations: 0.1").contains("two values or more"));
    assert!(broken(&line, "z_compensations: 0.1, x").contains("not a list of numbers"));
}
