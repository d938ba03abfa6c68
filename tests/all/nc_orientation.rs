//! Five-axis tool orientation compensation: the compensated program, fed back to the model, puts
//! the real tool tip and the real tool axis where the ideal machine puts them at the programmed
//! points, on a table-table, a head-table and a head-head machine.

use nalgebra::Vector3;
use volmap::io::embedded;
use volmap::model::inputs::Inputs;
use volmap::model::Machine;
use volmap::nc::{self, Options};
use volmap::reference::tool_pose;

/// A table-table machine: an A trunnion on X carries the C table; Z carries the tool.
pub const TABLE_TABLE: &str = r#"
name = "table-table"
chain = "FYXACFZ"
[tool]
offset = [0.0, 0.0, -150.0]
[axes.Y]
range = [-300.0, 300.0]
EAY = { poly = [1.0e-5, 2.0e-8] }
[axes.X]
range = [-400.0, 400.0]
EC0X = 1.5e-5
EBX = { poly = [-8.0e-6, 1.5e-8] }
EXX = { poly = [0.0, 1.0e-5] }
[axes.A]
range = [-120.0, 30.0]
offset = [0.0, 0.0, 100.0]
EY0A = 0.006
EZ0A = -0.004
EB0A = 3.0e-5
EC0A = -2.0e-5
EAA = { poly = [0.0, 1.0e-7] }
[axes.C]
range = [-720.0, 720.0]
EX0C = 0.005
EA0C = 2.5e-5
EB0C = -1.5e-5
[axes.Z]
range = [-300.0, 500.0]
EAZ = { poly = [6.0e-6] }
EBZ = { poly = [-9.0e-6] }
"#;

/// A head-head machine: the C head on Z carries the A head, which carries the tool.
pub const HEAD_HEAD: &str = r#"
name = "head-head"
chain = "FFXYZCA"
[tool]
offset = [0.0, 0.0, -120.0]
[axes.X]
range = [-500.0, 500.0]
EBX = { poly = [7.0e-6, -1.0e-8] }
[axes.Y]
range = [-500.0, 500.0]
EC0Y = 2.0e-5
[axes.Z]
range = [-500.0, 500.0]
EXZ = { poly = [0.0, 5.0e-6] }
[axes.C]
range = [-360.0, 360.0]
EX0C = 0.004
EA0C = 2.0e-5
[axes.A]
range = [-100.0, 100.0]
offset = [0.0, 0.0, -80.0]
EY0A = -0.005
EB0A = 3.0e-5
EC0A = 1.0e-5
"#;

const ANGULAR_TOLERANCE_RAD: f64 = 1e-5;

fn orientation_options(decimals: usize) -> Options {
    Options {
        decimals: Some(decimals),
        orientation_tolerance_rad: Some(ANGULAR_TOLERANCE_RAD),
        ..Options::default()
    }
}

/// The unit tool axis of `machine` at `command`.
fn tool_axis(machine: &Machine, command: &[f64; 6]) -> Vector3<f64> {
    tool_pose(machine, command).1.column(2).into_owned()
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Every block of `input` run from the output: the largest tip miss (mm), the largest axis miss
/// (rad) of the output's end points, and the largest axis miss of the input as it was.
fn landing(
    machine: &Machine,
    input: &str,
    output: &nc::Compensated,
    options: &Options,
) -> [f64; 3] {
    let meant = nc::trace(machine, input.as_bytes(), "in.nc", options).unwrap();
    let landed = nc::trace(machine, output.text.as_bytes(), "out.nc", options).unwrap();
    let ideal = machine.without_errors();
    let real = |approach| {
        machine.at(&Inputs {
            approach,
            ..Inputs::default()
        })
    };
    let [mut tip, mut after, mut before] = [0.0f64; 3];
    assert!(!meant.is_empty());
    for m in &meant {
        let last = output.origins.iter().rposition(|&o| o == m.line).unwrap() + 1;
        let l = landed.iter().find(|p| p.line == last).unwrap();
        let intended = tool_axis(&ideal, &m.command);
        tip = tip.max((l.real - m.ideal).norm());
        after = after.max(angle(&tool_axis(&real(l.approach), &l.command), &intended));
        before = before.max(angle(&tool_axis(&real(m.approach), &m.command), &intended));
    }
    [tip, after, before]
}

/// Rounding's effect at `decimals` (linear mm; rotary degrees are written with 6 decimals at
/// least): on the tip, the linear rounding of three axes plus two rotary roundings over a lever
/// of at most 1000 mm; on the axis, the two rotary roundings (a rotation turns the axis by no
/// more than its angle).
fn rounding(decimals: i32) -> (f64, f64) {
    let half = 0.5 * 10f64.powi(-decimals);
    let rotary_rad = 2.0 * (0.5 * 10f64.powi(-decimals.max(6))).to_radians();
    (3f64.sqrt() * half + rotary_rad * 1000.0, rotary_rad)
}

fn check_lands(machine: &Machine, program: &str) {
    // 12 decimals show the solve itself (1e-9 mm, 1e-9 rad); the default 4 what a shop gets.
    for decimals in [12, 7, 4] {
        check_lands_at(machine, program, decimals);
    }
}

fn check_lands_at(machine: &Machine, program: &str, decimals: usize) {
    let options = orientation_options(decimals);
    let out = nc::compensate(machine, program.as_bytes(), "five.nc", &options)
        .unwrap_or_else(|e| panic!("{}: {e}", machine.name));
    let [tip, after, before] = landing(machine, program, &out, &options);
    let (tip_rounding, axis_rounding) = rounding(decimals as i32);
    let name = &machine.name;
    let solved = if decimals >= 12 { 1e-9 } else { 1e-6 };
    assert!(
        tip < solved + tip_rounding,
        "{name}: tip {tip}\n{}",
        out.text
    );
    assert!(
        after < 1e-9 + axis_rounding,
        "{name}: axis {after}\n{}",
        out.text
    );
    // The machines' errors tilt the tool by tens of µrad; compensated, by nanoradians.
    assert!(before > 1e-5, "{name}: before {before}");
    // Orders of magnitude: three, or two where 6 decimals of a degree round the rotary words.
    let orders = if decimals >= 7 { 1e3 } else { 1e2 };
    assert!(before > orders * after, "{name}: {before} vs {after}");
    // Along the path (the library's own sampling, rotary words as written): within tolerance.
    let report = &out.report;
    assert!(report.largest_orientation_error_after_rad <= ANGULAR_TOLERANCE_RAD);
    assert!(report.largest_orientation_error_before_rad >= before - 1e-12);
    assert!(report.largest_error_after_mm <= options.chord_tolerance_mm);
    // The rotary words are rewritten with the orientation correction.
    let last = out.text.lines().last().unwrap();
    let programmed = ["A-40.", "A40.", "B20.", "C75.", "C90."];
    assert!(
        last.split(' ').filter(|w| programmed.contains(w)).count() == 0
            && last
                .split(' ')
                .filter(|w| w.starts_with(['A', 'B', 'C']))
                .count()
                == 2,
        "{last}"
    );
}

#[test]
fn orientation_lands_tip_and_axis_on_table_table_head_table_and_head_head() {
    let table_table = Machine::from_toml(TABLE_TABLE, "tt.toml", None).unwrap();
    check_lands(
        &table_table,
        "G90 G0 X50. Y20. Z100. A-30. C10.\nG1 X80. F500\nA-45. C40.\nX60. Y-10. Z90. A-40. C75.\n",
    );
    let head_table = embedded::load("5axis-hwang2014").unwrap();
    check_lands(
        &head_table,
        "G90 G0 X400. Y300. Z300. B30. C45.\nG1 X450. F500\nB35. C60.\nX420. Y320. Z280. B20. C90.\n",
    );
    let head_head = Machine::from_toml(HEAD_HEAD, "hh.toml", None).unwrap();
    check_lands(
        &head_head,
        "G90 G0 X50. Y20. Z100. A30. C10.\nG1 X80. F500\nA45. C40.\nX60. Y-10. Z90. A40. C75.\n",
    );
}

#[test]
fn rotary_moves_stay_within_the_angular_tolerance_between_end_points() {
    // A long turn: the tool axis error varies along it, so it is split; every piece's end is
    // solved, and a tighter angular tolerance needs more pieces.
    let machine = Machine::from_toml(TABLE_TABLE, "tt.toml", None).unwrap();
    let program = "G90 G0 X50. Y20. Z100. A-30. C10.\nG1 A-90. C170. F500\n";
    let pieces = |tolerance: f64| {
        let options = Options {
            orientation_tolerance_rad: Some(tolerance),
            ..orientation_options(7)
        };
        let out = nc::compensate(&machine, program.as_bytes(), "turn.nc", &options).unwrap();
        assert!(out.report.largest_orientation_error_after_rad <= tolerance);
        out.text.lines().count()
    };
    let (loose, tight) = (pieces(1e-4), pieces(1e-6));
    assert!(tight > loose, "{tight} vs {loose}");
}

/// (A singular pose is compensated as far as the bound on the rotary correction allows:
/// `nc_singular`.)
#[test]
fn rotary_limits_and_machines_without_two_rotary_axes_are_refused() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let options = orientation_options(4);
    // Programmed at both ends of B's travel: the correction leaves it at one of them at least.
    let at = |b: &str| {
        let start = if b.starts_with('-') { "-30." } else { "30." };
        let program = format!("G90 G0 X400. Y300. Z300. B{start} C45.\nG1 B{b} F500\n");
        nc::compensate(&machine, program.as_bytes(), "l.nc", &options)
            .err()
            .map(|e| e.to_string())
    };
    let errors: Vec<String> = [at("110."), at("-110.")].into_iter().flatten().collect();
    assert!(!errors.is_empty());
    assert!(
        errors
            .iter()
            .all(|e| e.starts_with("l.nc: line 2: the compensated point: B=")
                && e.contains("outside the travel of B")),
        "{errors:?}"
    );
    // A three-axis machine has no rotary axes to turn.
    let three = embedded::load("vmc-li2015").unwrap();
    let error = nc::compensate(&three, b"G0 X10 Y10 Z10\n", "t.nc", &options)
        .unwrap_err()
        .to_string();
    assert!(error.contains("has 0 rotary axes"), "{error}");
}

/// A rotary axis the program never sets: the correction would turn it from wherever it stands
/// to the model's 0, and in G91 write an increment from nowhere; refused, naming the axis. Set
/// once, the same G91 program is compensated and its output reads back.
#[test]
fn a_rotary_axis_the_program_never_sets_is_refused_with_orientation() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let options = Options {
        work_offsets: [(54, [200.0, 200.0, 300.0, 0.0, 0.0, 0.0])]
            .into_iter()
            .collect(),
        ..orientation_options(4)
    };
    let moves = "G91\nG1 X10. F500\nY10.\nX-10. Y-5.\nZ-5.\nM30\n";
    for first in [
        "G90 G54\nG0 X0 Y0 Z50. B30.\n",
        "G90 G54\nG0 X0 Y0 Z50. B30.\nG90 G1 X5.\n",
    ] {
        let program = format!("{first}{moves}");
        let error = nc::compensate(&machine, program.as_bytes(), "r.nc", &options)
            .unwrap_err()
            .to_string();
        assert!(
            error.starts_with("r.nc: line 1: the program never sets C")
                && error.contains("orientation"),
            "{error}"
        );
    }
    let program = format!("G90 G54\nG0 X0 Y0 Z50. B30. C0\n{moves}");
    let out = nc::compensate(&machine, program.as_bytes(), "r.nc", &options).unwrap();
    assert!(
        out.text
            .lines()
            .any(|l| l.starts_with("G1 ") && l.contains('C')),
        "{}",
        out.text
    );
    nc::trace(&machine, out.text.as_bytes(), "out.nc", &options).unwrap();
    // Without the orientation the rotary words stay as programmed: nothing is assumed of C.
    let plain = Options {
        orientation_tolerance_rad: None,
        ..options.clone()
    };
    let program = format!("G90 G54\nG0 X0 Y0 Z50. B30.\n{moves}");
    let out = nc::compensate(&machine, program.as_bytes(), "r.nc", &plain).unwrap();
    assert!(!out.text.contains('C'), "{}", out.text);
}
