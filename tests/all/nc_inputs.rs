//! NC compensation at evaluation inputs: each move compensated for the approach direction of
//! every axis along it (backlash taken up where an axis reverses, on lines and at an arc's
//! turning points), an axis that does not move keeping its direction, and the temperatures of
//! the whole program; against values derived by hand.

use volmap::model::inputs::{Approach, Inputs};
use volmap::model::Machine;
use volmap::nc::{self, Options};

/// The backlash of X and Y, mm.
const W: f64 = 0.010;
const WY: f64 = 0.004;

/// A gantry with X, Y and Z on the tool side (FFXYZ), no offsets and no tool length: the real
/// tip is the command plus the errors of the axes.
fn gantry(x: &str, y: &str) -> Machine {
    let text = format!(
        r#"
name = "gantry"
chain = "FFXYZ"
[thermal]
reference_C = 20.0
inputs = ["x_scale"]
[axes.X]
range = [0.0, 2000.0]
{x}
[axes.Y]
range = [0.0, 1500.0]
{y}
[axes.Z]
range = [0.0, 800.0]
"#
    );
    Machine::from_toml(&text, "gantry.toml", None).unwrap()
}

fn backlash() -> Machine {
    gantry(
        &format!("EXX = {{ poly = [0.0], reverse = {{ poly = [{W}] }} }}"),
        &format!("EYY = {{ value = 0.0, reverse = {WY} }}"),
    )
}

fn options(machine: &Machine, temperatures: &str, approach: &str) -> Options {
    Options {
        decimals: Some(7),
        inputs: Inputs::parse(temperatures, approach, machine).unwrap(),
        ..Options::default()
    }
}

/// The value of axis word `letter` on a line, if it has one.
fn word(line: &str, letter: char) -> Option<f64> {
    let start = line.find(letter)? + 1;
    let end = line[start..]
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .map_or(line.len(), |e| start + e);
    line[start..end].parse().ok()
}

/// The output lines that come from input line `origin`.
fn lines_of(out: &nc::Compensated, origin: usize) -> Vec<&str> {
    assert_eq!(out.text.lines().count(), out.origins.len());
    out.text
        .lines()
        .zip(&out.origins)
        .filter(|(_, &o)| o == origin)
        .map(|(l, _)| l)
        .collect()
}

/// Every input block's end, run from the output with each move's own directions, lands on the
/// ideal tip of that block (mm).
fn largest_landing_error(
    machine: &Machine,
    input: &str,
    out: &nc::Compensated,
    o: &Options,
) -> f64 {
    let meant = nc::trace(machine, input.as_bytes(), "in.nc", o).unwrap();
    let landed = nc::trace(machine, out.text.as_bytes(), "out.nc", o).unwrap();
    meant
        .iter()
        .map(|m| {
            let last = out.origins.iter().rposition(|&l| l == m.line).unwrap() + 1;
            let l = landed.iter().find(|p| p.line == last).unwrap();
            (l.real - m.ideal).norm()
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_backlash_moves_backward_targets_by_its_width_and_every_point_lands() {
    let machine = backlash();
    // X50 forward, X30 backward, X10 backward, X30 forward: X30 from both sides.
    let program = "G90 G0 X10. Y10. Z10.\nG1 X50. F500\nX30.\nX10.\nX30.\n";
    let o = options(&machine, "", "");
    let out = nc::compensate(&machine, program.as_bytes(), "b.nc", &o).unwrap();
    // Hand-derived: approaching `−` the tip lies W beyond the command (tip = q + W), so a
    // backward target x is commanded at x − W; forward at x. At each reversal a take-up moves
    // the command by W with the tip standing at the turning point.
    let x = |origin: usize| -> Vec<f64> {
        lines_of(&out, origin)
            .iter()
            .filter_map(|l| word(l, 'X'))
            .collect()
    };
    assert_eq!(x(2), vec![50.0], "{}", out.text);
    assert_eq!(x(3), vec![50.0 - W, 30.0 - W], "{}", out.text);
    assert_eq!(x(4), vec![10.0 - W], "{}", out.text);
    assert_eq!(x(5), vec![10.0, 30.0], "{}", out.text);
    let (backward, forward) = (x(3)[1], x(5)[1]);
    assert!((forward - backward - W).abs() < 1e-12);
    assert_eq!(out.report.take_ups, 2);
    assert_eq!(out.report.against_direction, 0);
    // Run through the model with the directions of each move of the output, every point lands
    // on the programmed one: block ends and the take-ups (on the turning points).
    assert!(largest_landing_error(&machine, program, &out, &o) < 1e-6);
    let landed = nc::trace(&machine, out.text.as_bytes(), "out.nc", &o).unwrap();
    let tips: Vec<f64> = landed.iter().map(|p| p.real.x).collect();
    let expected = [10.0, 50.0, 50.0, 30.0, 10.0, 10.0, 30.0];
    assert_eq!(tips.len(), expected.len(), "{tips:?}");
    for (tip, x) in tips.iter().zip(expected) {
        assert!((tip - x).abs() < 1e-6, "{tips:?}");
    }
    // The program as written misses the backward targets by W.
    let before = nc::trace(&machine, program.as_bytes(), "in.nc", &o).unwrap();
    assert!((before[2].real.x - (30.0 + W)).abs() < 1e-12);
    assert_eq!(before[2].approach[0], Approach::Negative);
}

#[test]
fn an_axis_that_does_not_move_keeps_its_last_direction() {
    let machine = backlash();
    let program = "G90 G0 X50. Y10. Z10.\nG1 X30. F500\nY40.\nZ20.\n";
    let o = options(&machine, "", "");
    let out = nc::compensate(&machine, program.as_bytes(), "keep.nc", &o).unwrap();
    // X moved `−` on line 2, so the Y and Z moves still have X approaching `−`: X stays at
    // 30 − W and no X word is added (with X `+` it would be X30).
    for origin in [3, 4] {
        let lines = lines_of(&out, origin);
        assert_eq!(lines.len(), 1, "{}", out.text);
        assert_eq!(word(lines[0], 'X'), None, "{}", out.text);
    }
    assert_eq!(word(lines_of(&out, 2)[0], 'X'), Some(50.0 - W));
    assert_eq!(word(lines_of(&out, 2)[1], 'X'), Some(30.0 - W));
    let landed = nc::trace(&machine, out.text.as_bytes(), "out.nc", &o).unwrap();
    let last = landed.last().unwrap();
    assert_eq!(last.approach[0], Approach::Negative);
    assert_eq!(last.approach[1], Approach::Positive);
    assert!((last.real.x - 30.0).abs() < 1e-9 && (last.command[0] - (30.0 - W)).abs() < 1e-9);
    assert!(largest_landing_error(&machine, program, &out, &o) < 1e-6);
    // --approach gives the directions at the start: X `−` from the first point on.
    let o = options(&machine, "", "X=-");
    let out = nc::compensate(
        &machine,
        b"G90 G0 X50. Y10. Z10.\nG1 Y20. F500\n",
        "s.nc",
        &o,
    )
    .unwrap();
    assert_eq!(word(out.text.lines().next().unwrap(), 'X'), Some(50.0 - W));
    assert_eq!(out.report.take_ups, 0, "{}", out.text);
    assert_eq!(out.report.inputs.approach_at_start[&'X'], '-');
}

#[test]
fn an_arc_is_compensated_with_the_direction_at_each_point_and_its_turning_point_taken_up() {
    let machine = backlash();
    // A half circle counter-clockwise from (60, 30) about (50, 30) to (40, 30): X runs `−` all
    // along (a reversal at the start, after X60 forward); Y runs `+` to the top (50, 40), then
    // `−`: a take-up there.
    let program = "G90 G17 G0 X50. Y30. Z10.\nG1 X60. F500\nG3 X40. Y30. I-10. J0\n";
    let o = options(&machine, "", "");
    let out = nc::compensate(&machine, program.as_bytes(), "arc.nc", &o).unwrap();
    assert_eq!(out.report.take_ups, 2, "{}", out.text);
    assert_eq!(out.report.against_direction, 0);
    assert!(
        out.report.largest_error_after_mm <= 1e-3,
        "{:?}",
        out.report
    );
    assert!(
        out.report.largest_error_before_mm > 0.9 * W,
        "{:?}",
        out.report
    );
    // The arc became lines; its first line is the take-up of X (the tip stays at X60).
    let lines = lines_of(&out, 3);
    assert!(lines[0].starts_with("G1 X59.99 Y30."), "{}", lines[0]);
    let landed = nc::trace(&machine, out.text.as_bytes(), "out.nc", &o).unwrap();
    let on_arc: Vec<_> = landed.iter().filter(|p| p.line >= 3).collect();
    assert_eq!(on_arc.len(), lines.len());
    let mut turned = 0;
    for (n, p) in on_arc.iter().enumerate() {
        // Every point of the output lands on the circle, approached as the output moves there.
        let r = (p.real.x - 50.0).hypot(p.real.y - 30.0);
        assert!((r - 10.0).abs() < 1e-6, "line {}: radius {r}", p.line);
        assert_eq!(p.approach[0], Approach::Negative);
        // The take-up at the top: the command steps back by WY, the tip stays at (50, 40).
        if n > 0
            && on_arc[n - 1].approach[1] == Approach::Positive
            && p.approach[1] == Approach::Negative
        {
            turned += 1;
            let top = on_arc[n - 1];
            assert!((top.real.y - 40.0).abs() < 1e-6 && (p.real - top.real).norm() < 1e-6);
            assert!((top.command[1] - p.command[1] - WY).abs() < 1e-6);
        }
    }
    assert_eq!(turned, 1);
    assert!(largest_landing_error(&machine, program, &out, &o) < 1e-6);
}

#[test]
fn temperatures_remove_the_scale_expansion() {
    // A scale growing α per kelvin: at ΔT the tip lies at q·(1 + α·ΔT), so the command for x is
    // x / (1 + α·ΔT) ≈ x − α·x·ΔT.
    let alpha = 11.5e-6;
    let machine = gantry(
        &format!(
            "EXX = {{ value = 0.0, per_kelvin = {{ x_scale = {{ poly = [0.0, {alpha}] }} }} }}"
        ),
        "",
    );
    let program = "G90 G0 X100. Y10. Z10.\nG1 X500. F500\n";
    let cold = options(&machine, "", "");
    let out = nc::compensate(&machine, program.as_bytes(), "t.nc", &cold).unwrap();
    assert_eq!(
        out.text, "G90 G0 X100.0 Y10.0 Z10.0\nG1 X500.0 F500\n",
        "at reference_C nothing changes"
    );
    assert_eq!(out.report.largest_correction_mm, 0.0);
    let warm = options(&machine, "x_scale=30", "");
    let out = nc::compensate(&machine, program.as_bytes(), "t.nc", &warm).unwrap();
    let dt = 10.0;
    let ends: Vec<f64> = out.text.lines().filter_map(|l| word(l, 'X')).collect();
    assert!(
        (ends[0] - 100.0 / (1.0 + alpha * dt)).abs() < 1e-7,
        "{ends:?}"
    );
    assert!((ends.last().unwrap() - 500.0 / (1.0 + alpha * dt)).abs() < 1e-7);
    // To first order the correction is α·x·ΔT (0.0575 mm at X500).
    assert!((500.0 - ends.last().unwrap() - alpha * 500.0 * dt).abs() < 1e-5);
    assert!(largest_landing_error(&machine, program, &out, &warm) < 1e-6);
    let report = &out.report.inputs;
    assert_eq!(report.temperatures_c["x_scale"], 30.0);
    assert_eq!(report.reference_c, Some(20.0));
    assert!(report.description.contains("x_scale=30 °C"), "{report:?}");
}

#[test]
fn a_full_circle_with_reversal_errors_that_vary_along_the_travel_lands_on_its_circle() {
    let machine = gantry(
        "EXX = { poly = [0.0, 2.0e-5], reverse = { poly = [0.008, 3.0e-5] } }\nEYX = { poly = [0.0, 0.0, 1.0e-6] }",
        "EYY = { value = { poly = [0.0, -1.0e-5] }, reverse = { table = [[0, 0.005], [1500, 0.002]], interp = \"linear\" } }",
    );
    // The straightness EYX = 1e-6·x² moves the Y command back (50 − 1e-6·x²) as X runs from 80
    // to 100, so Y turns `−` on the line, Y held still (take-up 1). Clockwise from the right end
    // (100, 50) about (80, 50): X turns `−` at the start (2), Y `+` at the bottom (3), X `+` at
    // the left (4), Y `−` at the top (5); the circle ends arriving at the right end with X `+`,
    // and X70 turns X `−` with the Y command moving forward again as x² shrinks (6).
    let program = "G90 G17 G0 X80. Y50. Z10.\nG1 X100. F500\nG2 X100. Y50. I-20. J0\nG1 X70.\n";
    let o = options(&machine, "", "");
    let out = nc::compensate(&machine, program.as_bytes(), "circle.nc", &o).unwrap();
    assert_eq!(out.report.take_ups, 6, "{}", out.text);
    assert_eq!(out.report.against_direction, 0);
    assert!(
        out.report.largest_error_after_mm <= 1e-3,
        "{:?}",
        out.report
    );
    let landed = nc::trace(&machine, out.text.as_bytes(), "out.nc", &o).unwrap();
    let circle: Vec<_> = landed
        .iter()
        .filter(|p| out.origins[p.line - 1] == 3)
        .collect();
    assert!(!circle.is_empty());
    for p in &circle {
        let r = (p.real.x - 80.0).hypot(p.real.y - 50.0);
        assert!((r - 20.0).abs() < 1e-6, "line {}: radius {r}", p.line);
        assert!((p.real.z - 10.0).abs() < 1e-6);
    }
    let last = circle.last().unwrap();
    assert_eq!(last.approach[..2], [Approach::Positive, Approach::Negative]);
    assert!(largest_landing_error(&machine, program, &out, &o) < 1e-6);
}
