//! Programs written for tool-centre-point control (G43.4, G234, G43.5): X Y Z are the tool tip in
//! the workpiece frame and the control solves the axes with its nominal kinematics. The
//! compensated program, solved here by an independent nominal inverse (Newton steps on the
//! reference model's ideal machine, or the hand-solved chain of the embedded `5axis-hwang2014`)
//! and run on the real model, puts the tip and the tool axis where the program says.

use nalgebra::{Matrix3, Vector3};
use volmap::io::embedded;
use volmap::model::inputs::Inputs;
use volmap::model::Machine;
use volmap::nc::{self, Options};
use volmap::reference::tool_pose;

use crate::common::fixture;

/// The tool tip and unit tool axis of `machine` at `command`.
fn pose(machine: &Machine, command: &[f64; 6]) -> (Vector3<f64>, Vector3<f64>) {
    let (tip, r) = tool_pose(machine, command);
    (tip, r.column(2).into_owned())
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// The control's nominal inverse, solved here without volmap's compensation: the rotary axes at
/// `p`'s, X Y Z such that the ideal machine's tip is where it is with the rotary axes at 0 and
/// the linear axes at `p + offset` (the workpiece frame of the README: at rotary 0 a TCPM program
/// and an ordinary one say the same). The ideal tip is affine in X Y Z at fixed rotary positions
/// (docs/model.md), so two Newton steps with a unit-step Jacobian are exact to rounding.
fn nominal_command(ideal: &Machine, p: &[f64; 6], offset: &[f64; 3]) -> [f64; 6] {
    let mut at_zero = [0.0; 6];
    for d in 0..3 {
        at_zero[d] = p[d] + offset[d];
    }
    let target = pose(ideal, &at_zero).0;
    let mut q = *p;
    for d in 0..3 {
        q[d] += offset[d];
    }
    for _ in 0..2 {
        let base = pose(ideal, &q).0;
        let column = |d: usize| {
            let mut s = q;
            s[d] += 1.0;
            pose(ideal, &s).0 - base
        };
        let j = Matrix3::from_columns(&[column(0), column(1), column(2)]);
        let step = j.lu().solve(&(target - base)).unwrap();
        for d in 0..3 {
            q[d] += step[d];
        }
    }
    q
}

/// The words X Y Z A B C standing after every line of `text` that names one, once all of
/// `letters` have been named (modal: the last value stands); `None` for the other lines. With
/// `vector` (the ideal machine and its two rotary axes), a tool vector I J K (G43.5) sets the
/// rotary axes as the control solves it: Gauss-Newton steps on the two rotary positions from where
/// they stand, which end on the solution nearest them.
fn points(
    text: &str,
    letters: &str,
    vector: Option<(&Machine, [usize; 2])>,
) -> Vec<Option<[f64; 6]>> {
    let mut at = [f64::NAN; 6];
    let mut out = Vec::new();
    for line in text.lines() {
        let code = line.split('(').next().unwrap();
        let mut moved = false;
        let mut v = Vector3::from_element(f64::NAN);
        for word in code.split_whitespace() {
            let (letter, value) = word.split_at(1);
            if let Some(d) = "XYZABC".find(letter) {
                at[d] = value.parse().unwrap();
                moved = true;
            }
            if let Some(k) = "IJK".find(letter).filter(|_| vector.is_some()) {
                v[k] = value.parse().unwrap();
                moved = true;
            }
        }
        if let (Some((ideal, axes)), false) = (vector, v[0].is_nan()) {
            at = solve_vector(ideal, axes, &v.normalize(), at);
        }
        let all = letters
            .chars()
            .all(|l| !at["XYZABC".find(l).unwrap()].is_nan());
        out.push((moved && all).then_some(at));
    }
    out
}

/// `from` with its rotary axes `axes` where the ideal tool axis is `v` (Gauss-Newton from
/// `from`'s, central differences of 1e-4°, to 1e-12°).
fn solve_vector(ideal: &Machine, axes: [usize; 2], v: &Vector3<f64>, from: [f64; 6]) -> [f64; 6] {
    let axis = |q: &[f64; 6]| pose(ideal, q).1;
    let mut q = from;
    for _ in 0..50 {
        let r = axis(&q) - v;
        let column = |d: usize| {
            let (mut plus, mut minus) = (q, q);
            plus[d] += 1e-4;
            minus[d] -= 1e-4;
            (axis(&plus) - axis(&minus)) / 2e-4
        };
        let j = nalgebra::Matrix3x2::from_columns(&[column(axes[0]), column(axes[1])]);
        let step = (j.transpose() * j)
            .lu()
            .solve(&(j.transpose() * r))
            .unwrap();
        q[axes[0]] -= step[0];
        q[axes[1]] -= step[1];
        if step.norm() < 1e-12 {
            break;
        }
    }
    assert!(angle(&axis(&q), v) < 1e-12, "{v:?} not reached: {q:?}");
    q
}

/// Runs every block of `input` with a point from the output (its last block for that line: a
/// split move's last piece) on the real model at the nominal inverse of the written words, and
/// compares it with the ideal machine at the nominal inverse of the input's words: the largest
/// tip miss (mm) and axis miss (rad), after and before.
fn landing(
    machine: &Machine,
    input: &str,
    output: &nc::Compensated,
    offset: &[f64; 3],
    letters: &str,
    vector: Option<[usize; 2]>,
) -> [f64; 4] {
    let ideal = machine.without_errors();
    let real = machine.at(&Inputs::default());
    let vector = vector.map(|axes| (&ideal, axes));
    let landed = points(&output.text, letters, vector);
    let [mut tip, mut axis, mut tip_before, mut axis_before] = [0.0f64; 4];
    let mut compared = 0;
    for (index, meant) in points(input, letters, vector).into_iter().enumerate() {
        let Some(p) = meant else { continue };
        let last = output
            .origins
            .iter()
            .rposition(|&o| o == index + 1)
            .unwrap();
        let w = landed[last].unwrap_or_else(|| panic!("line {}: {}", index + 1, output.text));
        let (want_tip, want_axis) = pose(&ideal, &nominal_command(&ideal, &p, offset));
        let (got_tip, got_axis) = pose(&real, &nominal_command(&ideal, &w, offset));
        tip = tip.max((got_tip - want_tip).norm());
        axis = axis.max(angle(&got_axis, &want_axis));
        let (was_tip, was_axis) = pose(&real, &nominal_command(&ideal, &p, offset));
        tip_before = tip_before.max((was_tip - want_tip).norm());
        axis_before = axis_before.max(angle(&was_axis, &want_axis));
        compared += 1;
    }
    assert!(compared >= 3, "{compared} points compared");
    [tip, axis, tip_before, axis_before]
}

/// Along every piece of the output's feed moves (G1) under the interpolation the README states
/// (the words, X Y Z and rotary positions, linear between the piece's ends, each point solved by
/// the nominal inverse), sampled 16 times a piece: the largest distance (mm) of the real tip from
/// the intended straight line between the input's programmed tips (the distance to the line, not
/// to the point at the same fraction, keeps this independent of how volmap pairs fractions), and
/// the largest angle (rad) of the real tool axis from the intended one at the same fraction, the
/// rotary positions linear between the programmed ones (the fraction of each piece's end read
/// from where its real tip lands along the line, to 2e-6 mm over at least 20 mm: 1e-7 of the
/// move, 6e-8 rad of its turn at most).
fn largest_distance_between(
    machine: &Machine,
    input: &str,
    output: &nc::Compensated,
    offset: &[f64; 3],
    letters: &str,
    vector: Option<[usize; 2]>,
) -> (f64, f64) {
    let ideal = machine.without_errors();
    let real = machine.at(&Inputs::default());
    let vector = vector.map(|axes| (&ideal, axes));
    let meant = points(input, letters, vector);
    let landed = points(&output.text, letters, vector);
    let feed = |text: &str| -> Vec<bool> {
        let mut g1 = false;
        text.lines()
            .map(|l| {
                for w in l.split_whitespace() {
                    match w {
                        "G0" | "G00" => g1 = false,
                        "G1" | "G01" => g1 = true,
                        _ => {}
                    }
                }
                g1
            })
            .collect()
    };
    let (input_feed, output_feed) = (feed(input), feed(&output.text));
    let tip_of = |p: &[f64; 6]| pose(&ideal, &nominal_command(&ideal, p, offset)).0;
    let (mut worst, mut worst_angle) = (0.0f64, 0.0f64);
    let mut previous_meant = None;
    let mut pieces = 0;
    for (index, p) in meant.iter().enumerate() {
        let Some(p) = p else { continue };
        let Some(from) = previous_meant.replace(*p) else {
            continue;
        };
        if !input_feed[index] {
            continue;
        }
        let (t0, t1) = (tip_of(&from), tip_of(p));
        let along = (t1 - t0).normalize();
        let lines: Vec<usize> = (0..output.origins.len())
            .filter(|&o| output.origins[o] == index + 1 && landed[o].is_some())
            .collect();
        let before = (0..lines[0]).rev().find_map(|o| landed[o]).unwrap();
        let length = (t1 - t0).norm();
        let fraction = |w: &[f64; 6]| {
            let tip = pose(&real, &nominal_command(&ideal, w, offset)).0;
            (tip - t0).dot(&along) / length
        };
        let mut a = before;
        for &o in &lines {
            let b = landed[o].unwrap();
            assert!(output_feed[o], "{}", output.text);
            let (fa, fb) = (fraction(&a), fraction(&b));
            for k in 0..=16 {
                let s = k as f64 / 16.0;
                let w: [f64; 6] = std::array::from_fn(|d| a[d] + (b[d] - a[d]) * s);
                let (tip, axis) = pose(&real, &nominal_command(&ideal, &w, offset));
                let r = tip - t0;
                let t = r.dot(&along).clamp(0.0, length);
                worst = worst.max((r - along * t).norm());
                let f = fa + (fb - fa) * s;
                let meant: [f64; 6] = std::array::from_fn(|d| from[d] + (p[d] - from[d]) * f);
                worst_angle = worst_angle.max(angle(&axis, &pose(&ideal, &meant).1));
            }
            a = b;
            pieces += 1;
        }
    }
    assert!(pieces >= 2, "{pieces} pieces");
    (worst, worst_angle)
}

fn tcpm_options(decimals: usize, offset: [f64; 3]) -> Options {
    Options {
        decimals: Some(decimals),
        orientation_tolerance_rad: Some(1e-5),
        work_offsets: [(54, [offset[0], offset[1], offset[2], 0.0, 0.0, 0.0])]
            .into_iter()
            .collect(),
        ..Options::default()
    }
}

/// A five-axis program as a post writes it for the head-table `5axis-hwang2014` (B head, C
/// table), under G43.4 with the tool length of the machine file.
const HWANG_PROGRAM: &str = "%
O1000 (TCPM)
G90 G21 G17 G54
G0 B30. C45.
G43.4 H1
G0 X0. Y0. Z50.
G1 Z10. F500.
X20. Y10. B35. C30.
X30. Y-10. Z5. B20. C60.
G0 Z50.
G49
M30
%
";

/// Compensates `program` with the orientation at 12 decimals (the solve itself) and 7 (the
/// rounding of the words: 0.5e-7 mm on three axes, 2 × 0.5e-7° = 1.7e-9 rad of turn over at most
/// 500 mm from the rotary axes, 0.9e-6 mm in all), and checks every programmed point: the tip
/// within 2e-6 mm and the tool axis within 1e-7 rad of the program's, a thousand times closer
/// than before (the machines' errors put the tip tens of µm and the axis tens of µrad off).
fn check_lands(machine: &Machine, program: &str, offset: [f64; 3], letters: &str) {
    check_lands_with(machine, program, offset, letters, None)
}

/// [`check_lands`], the tool vectors of G43.5 solved for the rotary axes `vector`.
fn check_lands_with(
    machine: &Machine,
    program: &str,
    offset: [f64; 3],
    letters: &str,
    vector: Option<[usize; 2]>,
) {
    for decimals in [12, 7] {
        let options = tcpm_options(decimals, offset);
        let out = nc::compensate(machine, program.as_bytes(), "t.nc", &options)
            .unwrap_or_else(|e| panic!("{}: {e}", machine.name));
        let [tip, axis, tip_before, axis_before] =
            landing(machine, program, &out, &offset, letters, vector);
        let name = &machine.name;
        assert!(tip < 2e-6, "{name}: tip {tip}\n{}", out.text);
        assert!(axis < 1e-7, "{name}: axis {axis}\n{}", out.text);
        assert!(
            tip_before > 1e-3 && tip_before > 1e3 * tip,
            "{name}: {tip_before}"
        );
        assert!(
            axis_before > 1e-5 && axis_before > 1e2 * axis,
            "{name}: {axis_before}"
        );
        // Between the points the control moves the tip straight and the rotary axes linearly:
        // the library's own check of the pieces against that stays within the tolerances.
        let report = &out.report;
        assert!(report.largest_error_after_mm <= options.chord_tolerance_mm);
        // Checked independently here: 1e-3 mm, the chord tolerance, plus the rounding of the
        // words (under 1e-6 mm, see above); 1e-5 rad, the angular tolerance, plus the rounding
        // (2e-9 rad) and the fraction's estimate (6e-8 rad).
        let (between, turned) =
            largest_distance_between(machine, program, &out, &offset, letters, vector);
        assert!(
            turned < 1e-5 + 1e-7,
            "{name}: {turned} rad between\n{}",
            out.text
        );
        assert!(turned > 0.0);
        assert!(
            between < 1e-3 + 1e-6,
            "{name}: {between} mm between\n{}",
            out.text
        );
        assert!(report.largest_orientation_error_after_rad <= 1e-5);
    }
}

#[test]
fn g43_4_on_the_head_table_machine_lands_tip_and_axis() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    check_lands(&machine, HWANG_PROGRAM, [100.0, 400.0, 200.0], "XYZBC");
}

/// The same program shape on the table-table (A trunnion, C table) and head-head (C head, A
/// head) fixtures, under G43.4 and Haas's G234.
#[test]
fn tcpm_lands_tip_and_axis_on_table_table_and_head_head() {
    let body = |code: &str, a: [&str; 3]| {
        format!(
            "G90 G21 G17 G54\nG0 A{} C10.\n{code}\nG0 X20. Y10. Z40.\nG1 Z5. F500.\nX40. A{} C40.\nX-20. Y-10. Z10. A{} C75.\nG0 Z60.\nG49\nM30\n",
            a[0], a[1], a[2]
        )
    };
    let table_table = Machine::from_toml(&fixture("table-table-ac"), "tt.toml", None).unwrap();
    let head_head = Machine::from_toml(&fixture("head-head-ca"), "hh.toml", None).unwrap();
    for code in ["G43.4 H1", "G234"] {
        check_lands(
            &table_table,
            &body(code, ["-30.", "-45.", "-40."]),
            [0.0, 0.0, 50.0],
            "XYZAC",
        );
        check_lands(
            &head_head,
            &body(code, ["30.", "45.", "40."]),
            [0.0, 0.0, 200.0],
            "XYZAC",
        );
    }
}

/// The nominal inverse solved by hand for one pose of `5axis-hwang2014` (FYXCFZB, docs/model.md):
/// `E_rel = Trans(0, 0, 150) · Rz(C) · Trans(X, Y, Z) · Ry(B) · Trans(0, 0, -250)`, so with the
/// rotary axes at 0 the tip is `(X, Y, Z - 100)`, and the TCPM point P (work offset o) at B, C
/// needs `(X, Y, Z) = Rz(-C)·(P + o - (0, 0, 250)) + (250 sin B, 0, 250 cos B)`. P = (20, 10,
/// 10), o = (100, 400, 200), B30 C60: `Rz(-60)·(120, 410, -40) = (60 + 355.0704156,
/// -103.9230485 + 205, -40)`, plus (125, 0, 216.5063509): X 540.0704156, Y 101.0769515, Z
/// 176.5063509. The tool axis `Rz(C)·(sin B, 0, cos B)` = (0.25, 0.4330127, 0.8660254); under
/// G43.5 that vector is solved back to B30 C60 from near it, and to B-30 C240 (the same axis)
/// from near that one: the solution nearest the previous pose.
#[test]
fn the_nominal_inverse_matches_a_pose_solved_by_hand() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let options = Options {
        work_offsets: [(54, [100.0, 400.0, 200.0, 0.0, 0.0, 0.0])]
            .into_iter()
            .collect(),
        ..Options::default()
    };
    let expected = [540.0704155516198, 101.07695154586736, 176.50635094610965];
    let end = |program: &str| {
        let points = nc::trace(&machine, program.as_bytes(), "h.nc", &options)
            .unwrap_or_else(|e| panic!("{e}"));
        points.last().unwrap().command
    };
    // The arithmetic above is exact to 1e-12 mm; the solve, one exact step, to rounding.
    for code in ["G43.4", "G234"] {
        let c = end(&format!(
            "G90 G54\nG0 B30. C60.\n{code}\nG0 X20. Y10. Z10.\n"
        ));
        for d in 0..3 {
            assert!((c[d] - expected[d]).abs() < 1e-9, "{code}: {c:?}");
        }
        assert_eq!([c[4], c[5]], [30.0, 60.0]);
    }
    // G43.5: the same tip with the tool vector; the rotary axes solved nearest where they stand
    // (to 1e-9°: the vector is given to 10 digits).
    let vector = "I0.25 J0.4330127019 K0.8660254038";
    for (from, b, c_deg) in [("B25. C50.", 30.0, 60.0), ("B-25. C230.", -30.0, 240.0)] {
        let c = end(&format!(
            "G90 G54\nG0 {from}\nG43.5\nG0 X20. Y10. Z10. {vector}\n"
        ));
        assert!(
            (c[4] - b).abs() < 1e-7 && (c[5] - c_deg).abs() < 1e-7,
            "{from}: {c:?}"
        );
        if b > 0.0 {
            for d in 0..3 {
                assert!((c[d] - expected[d]).abs() < 1e-6, "{c:?}");
            }
        }
    }
}

/// `trace` follows a TCPM program as the control runs it: at every programmed point the ideal tip
/// is the program's (the workpiece frame at rotary 0) and the real tip is the real model's at the
/// nominal inverse solved here; without `--orientation` `compensate` puts the tip back (within
/// 2e-6 mm at 7 decimals, as above) and leaves the rotary words as programmed.
#[test]
fn trace_and_compensate_without_orientation_follow_tcpm() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let offset = [100.0, 400.0, 200.0];
    let options = Options {
        orientation_tolerance_rad: None,
        ..tcpm_options(7, offset)
    };
    let ideal = machine.without_errors();
    let real = machine.at(&Inputs::default());
    let traced = nc::trace(&machine, HWANG_PROGRAM.as_bytes(), "t.nc", &options).unwrap();
    let meant = points(HWANG_PROGRAM, "XYZBC", None);
    let mut compared = 0;
    for t in &traced {
        let Some(p) = meant[t.line - 1] else { continue };
        let q = nominal_command(&ideal, &p, &offset);
        // One exact step each, so agreeing to the rounding of 1e-9 mm.
        assert!(
            (t.ideal - pose(&ideal, &q).0).norm() < 1e-9,
            "line {}",
            t.line
        );
        assert!(
            (t.real - pose(&real, &q).0).norm() < 1e-9,
            "line {}",
            t.line
        );
        assert!((t.real - t.ideal).norm() > 1e-3, "line {}", t.line);
        compared += 1;
    }
    assert!(compared >= 5, "{compared}");
    let out = nc::compensate(&machine, HWANG_PROGRAM.as_bytes(), "t.nc", &options).unwrap();
    let landed = points(&out.text, "XYZBC", None);
    for (index, p) in meant.iter().enumerate() {
        let Some(p) = p else { continue };
        let last = out.origins.iter().rposition(|&o| o == index + 1).unwrap();
        let w = landed[last].unwrap();
        let tip = pose(&real, &nominal_command(&ideal, &w, &offset)).0;
        let want = pose(&ideal, &nominal_command(&ideal, p, &offset)).0;
        assert!(
            (tip - want).norm() < 2e-6,
            "line {}: {}",
            index + 1,
            out.text
        );
        assert_eq!([w[4], w[5]], [p[4], p[5]], "{}", out.text);
    }
}

/// With `--tool-length`, G43.4 H1 applies the length as G43 does (README): the control stands the
/// axes at the TCPM solution for the work offset plus the length along Z, with the tool of that
/// length. Solved here with the machine's tool replaced by 200 mm and 200 mm added to the offset's
/// Z, the compensated program lands within the same tolerances.
#[test]
fn g43_4_applies_the_tool_length() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let offset = [100.0, 400.0, 200.0];
    let options = Options {
        tool_lengths: nc::ToolLengths {
            all: Some(200.0),
            ..Default::default()
        },
        ..tcpm_options(7, offset)
    };
    let out = nc::compensate(&machine, HWANG_PROGRAM.as_bytes(), "t.nc", &options).unwrap();
    let mut with_tool = machine.clone();
    with_tool.tool_offset_mm = [0.0, 0.0, -200.0];
    let lengthened = [offset[0], offset[1], offset[2] + 200.0];
    let [tip, axis, tip_before, _] =
        landing(&with_tool, HWANG_PROGRAM, &out, &lengthened, "XYZBC", None);
    assert!(tip < 2e-6 && axis < 1e-7, "{tip} {axis}\n{}", out.text);
    assert!(tip_before > 1e-3, "{tip_before}");
    // Without the length in the solve, the output misses by far more: the check can fail.
    let [off, ..] = landing(&machine, HWANG_PROGRAM, &out, &offset, "XYZBC", None);
    assert!(off > 1e-3, "{off}");
}

/// G43.5 on the table-table and head-head fixtures: the tool vectors are those of the ideal
/// machine at the rotary positions of the G43.4 test (the reference model's tool axis); the
/// output's I J K, solved here for the rotary axes nearest where they stand, put the tip and the
/// axis where the program says, within the same tolerances (the vector's 9 decimals turn the axis
/// by at most 1e-9 rad).
#[test]
fn g43_5_tool_vectors_land_tip_and_axis() {
    let table_table = Machine::from_toml(&fixture("table-table-ac"), "tt.toml", None).unwrap();
    let head_head = Machine::from_toml(&fixture("head-head-ca"), "hh.toml", None).unwrap();
    for (machine, a, offset) in [
        (&table_table, [-30.0, -45.0, -40.0], [0.0, 0.0, 50.0]),
        (&head_head, [30.0, 45.0, 40.0], [0.0, 0.0, 200.0]),
    ] {
        let ideal = machine.without_errors();
        let ijk = |a: f64, c: f64| {
            let v = pose(&ideal, &[0.0, 0.0, 0.0, a, 0.0, c]).1;
            format!("I{:.10} J{:.10} K{:.10}", v.x, v.y, v.z)
        };
        let program = format!(
            "G90 G21 G17 G54\nG0 A{} C10.\nG43.5\nG0 X20. Y10. Z40. {}\nG1 Z5. F500.\nX40. {}\nX-20. Y-10. Z10. {}\nG0 Z60.\nG49\nM30\n",
            a[0],
            ijk(a[0], 10.0),
            ijk(a[1], 40.0),
            ijk(a[2], 75.0)
        );
        check_lands_with(machine, &program, offset, "XYZAC", Some([3, 5]));
        // The output gives the orientation by whole vectors only, as G43.5 needs (at 12 decimals
        // too, where one component may change alone), and volmap reads it back.
        for decimals in [12, 7] {
            let options = tcpm_options(decimals, offset);
            let out = nc::compensate(machine, program.as_bytes(), "v.nc", &options).unwrap();
            let after: Vec<&str> = out.text.lines().skip_while(|l| *l != "G43.5").collect();
            let words = |l: &str, of: &str| l.chars().filter(|c| of.contains(*c)).count();
            assert!(
                after
                    .iter()
                    .all(|l| words(l, "AC") == 0 && words(l, "IJK") % 3 == 0)
                    && after.iter().filter(|l| l.contains('I')).count() >= 3,
                "{}",
                out.text
            );
            nc::trace(machine, out.text.as_bytes(), "v-out.nc", &options).unwrap();
        }
    }
}
