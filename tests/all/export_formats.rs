//! `volmap export` to LinuxCNC, Klipper and Marlin: each table read back here as its control
//! documents it (LinuxCNC's compensation files and matrixkins, Klipper's and Marlin's skew
//! transform), applied to the model over a dense grid: the residual is the one reported, and a
//! machine whose errors the format holds fully leaves rounding; hand-derived values.

use volmap::export::{self, ExportError, TableSize};
use volmap::io::embedded;
use volmap::model::inputs::{Approach, Inputs};
use volmap::model::Machine;
use volmap::reference::Twin;

use super::export::{dense, machine, request, residual};

fn exported(
    m: &Machine,
    inputs: &Inputs,
    format: &str,
    size: TableSize,
    n: usize,
) -> export::Export {
    let mut r = request(m, inputs, size);
    r.evaluation_points = Some(n);
    // LinuxCNC with matrixkins, unless a test asks for 2.9 itself.
    if format == "linuxcnc" {
        r.control = Some("2.10".into());
    }
    export::export(export::format_named(format).unwrap(), &r).unwrap()
}

fn text<'a>(e: &'a export::Export, name: &str) -> &'a str {
    &e.files.iter().find(|f| f.name == name).unwrap().text
}

/// A LinuxCNC joint table as its docs describe it: `nominal forward reverse` rows until the
/// first line that is not three numbers; linear between nominals, end values outside.
struct Comp(Vec<[f64; 3]>);

impl Comp {
    fn read(text: &str) -> Comp {
        Comp(
            text.lines()
                .map_while(|l| {
                    let v: Vec<f64> = l.split_whitespace().map_while(|w| w.parse().ok()).collect();
                    (v.len() == 3).then(|| [v[0], v[1], v[2]])
                })
                .collect(),
        )
    }

    fn trim(&self, j: f64, forward: bool) -> f64 {
        let c = if forward { 1 } else { 2 };
        let rows = &self.0;
        if j <= rows[0][0] {
            return rows[0][c];
        }
        for w in rows.windows(2) {
            if j < w[1][0] {
                let u = (j - w[0][0]) / (w[1][0] - w[0][0]);
                return w[0][c] + u * (w[1][c] - w[0][c]);
            }
        }
        rows[rows.len() - 1][c]
    }
}

/// matrixkins' C from `setp matrixkins.C_xy 0.1` lines (identity where a file has none).
fn matrixkins(text: Option<&str>) -> [[f64; 3]; 3] {
    let mut c = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for line in text
        .unwrap_or("")
        .lines()
        .filter(|l| l.starts_with("setp "))
    {
        let w: Vec<&str> = line.split_whitespace().collect();
        let name: Vec<usize> = w[1]
            .trim_start_matches("matrixkins.C_")
            .chars()
            .map(|ch| "xyz".find(ch).unwrap())
            .collect();
        c[name[0]][name[1]] = w[2].parse().unwrap();
    }
    c
}

/// The command LinuxCNC sends for target `t`: joints `j = C·t`, each plus its trim.
fn linuxcnc_command(e: &export::Export, t: [f64; 3], forward: [bool; 3]) -> [f64; 3] {
    let c = matrixkins(
        e.files
            .iter()
            .find(|f| f.name == "volmap_matrixkins.hal")
            .map(|f| f.text.as_str()),
    );
    std::array::from_fn(|k| {
        let j: f64 = (0..3).map(|i| c[k][i] * t[i]).sum();
        let name = format!("volmap_joint{k}_{}.comp", ["X", "Y", "Z"][k]);
        j + Comp::read(text(e, &name)).trim(j, forward[k])
    })
}

#[test]
fn linuxcnc_round_trip_gives_the_reported_residual_in_both_directions() {
    let gantry = embedded::load("gantry-2m").unwrap();
    for approach in ["Y=+", "Y=-,X=-"] {
        let inputs = Inputs::parse("x_scale=24", approach, &gantry).unwrap();
        let e = exported(&gantry, &inputs, "linuxcnc", TableSize::Points(17), 21);
        let twin = Twin::of(&gantry.at(&inputs));
        let forward = std::array::from_fn(|k| inputs.approach[k] == Approach::Positive);
        let (max, rms) = residual(&twin, &dense(&gantry, 21), |t| {
            linuxcnc_command(&e, t, forward)
        });
        let r = &e.report;
        assert!(
            (max - r.residual.max_mm).abs() < 1e-8,
            "{max} vs {:?}",
            r.residual
        );
        assert!((rms - r.residual.rms_mm).abs() < 1e-8);
        assert!(max < 0.6 * r.before.max_mm, "{max} of {}", r.before.max_mm);
        // Each joint file holds at most the 17 entries asked for, nominals increasing.
        for k in 0..3 {
            let name = format!("volmap_joint{k}_{}.comp", ["X", "Y", "Z"][k]);
            let rows = Comp::read(text(&e, &name)).0;
            assert!(rows.len() <= 17 && rows.len() >= 2);
            assert!(rows.windows(2).all(|w| w[1][0] > w[0][0]));
        }
        // The Y backlash of 6 µm is the difference of the columns.
        let y = Comp::read(text(&e, "volmap_joint1_Y.comp")).0;
        assert!(
            y.iter().all(|r| ((r[1] - r[2]) - 0.006).abs() < 2e-6),
            "{y:?}"
        );
    }
}

const POSITIONING: &str = r#"
name = "positioning only"
chain = "FYXFZ"
[axes.X]
range = [0.0, 600.0]
EXX = { table = [[0, 0.0], [200, 0.012], [450, 0.015], [600, 0.005]], interp = "linear", reverse = { table = [[0, 0.004], [300, 0.018], [600, 0.011]], interp = "linear" } }
[axes.Y]
range = [0.0, 400.0]
EYY = { poly = [0.0, 2.5e-5] }
[axes.Z]
range = [-300.0, 0.0]
EZZ = { poly = [0.002, -1.0e-5] }
"#;

#[test]
fn linuxcnc_holds_a_pure_positioning_error_to_rounding() {
    let m = machine(POSITIONING);
    for approach in ["X=+", "X=-,Y=-,Z=-"] {
        let inputs = Inputs::parse("", approach, &m).unwrap();
        let e = exported(&m, &inputs, "linuxcnc", TableSize::Points(33), 41);
        let r = &e.report;
        assert!(r.before.max_mm > 0.015);
        // Trims to 7 decimals: 5e-8 mm each; the nominals' rounding moves them by less.
        assert!(r.residual.max_mm < 1e-7, "{approach}: {:?}", r.residual);
        assert!(r.not_held.is_empty(), "{:?}", r.not_held);
        // The piecewise-linear X needs only its kinks, in both columns.
        let rows = Comp::read(text(&e, "volmap_joint0_X.comp")).0;
        assert!(rows.len() <= 7, "{rows:?}");
        assert!(!e.files.iter().any(|f| f.name == "volmap_matrixkins.hal"));
        assert!(text(&e, "linuxcnc.ini").contains("the kinematics stay trivkins"));
    }
}

#[test]
fn linuxcnc_trims_of_a_linear_error_are_derived_by_hand() {
    // EXX = b + k·x (reverse) or k·x (forward): the real tip c + EXX(c) lands on x for
    // c = (x − b)/(1 + k), so the trim c − x is −(b + k·x)/(1 + k): linear, two entries.
    let (k, b) = (1.2e-4, 0.005);
    let m = machine(&format!(
        r#"
name = "linear"
chain = "FFXYZ"
[axes.X]
range = [0.0, 500.0]
EXX = {{ poly = [0.0, {k:e}], reverse = {{ poly = [{b}, {k:e}] }} }}
[axes.Y]
range = [0.0, 300.0]
[axes.Z]
range = [0.0, 200.0]
"#
    ));
    let inputs = Inputs::default();
    let e = exported(&m, &inputs, "linuxcnc", TableSize::Points(50), 21);
    let rows = Comp::read(text(&e, "volmap_joint0_X.comp")).0;
    assert_eq!(rows.len(), 2, "{rows:?}");
    for row in &rows {
        let x = row[0];
        assert!((row[1] - (-k * x / (1.0 + k))).abs() <= 5e-8, "{row:?}");
        assert!(
            (row[2] - (-(b + k * x) / (1.0 + k))).abs() <= 5e-8,
            "{row:?}"
        );
    }
    assert_eq!((rows[0][0], rows[1][0]), (0.0, 500.0));
    // Y and Z have no error: zero trims.
    let y = Comp::read(text(&e, "volmap_joint1_Y.comp")).0;
    assert!(y.iter().all(|r| r[1] == 0.0 && r[2] == 0.0));
}

pub fn squareness_machine(c: f64) -> Machine {
    machine(&format!(
        r#"
name = "square"
chain = "FFXYZ"
[axes.X]
range = [0.0, 500.0]
[axes.Y]
range = [0.0, 600.0]
EC0Y = {c:e}
[axes.Z]
range = [0.0, 200.0]
"#
    ))
}

#[test]
fn linuxcnc_puts_a_squareness_into_matrixkins() {
    // EC0Y = c tilts Y towards −X: the tip at command (x, y) is (x − y·sin c, y·cos c), so the
    // command for target (x, y) is x + y·tan c, y/cos c: C_xy = tan c, and Y's own y/cos c − y
    // (2e-8 · y) is Y's table.
    let c: f64 = 2.0e-4;
    let m = squareness_machine(c);
    let inputs = Inputs::default();
    let e = exported(&m, &inputs, "linuxcnc", TableSize::Points(9), 21);
    let hal = text(&e, "volmap_matrixkins.hal");
    assert!(
        hal.contains(&format!("setp matrixkins.C_xy {:.12}\n", c.tan())),
        "{hal}"
    );
    assert!(hal.contains("setp matrixkins.C_yx 0.000000000000\n"));
    assert!(hal.contains("setp matrixkins.C_xx 1.000000000000\n"));
    let ini = text(&e, "linuxcnc.ini");
    for line in [
        "KINEMATICS = matrixkins",
        "JOINTS = 3",
        "HALFILE = volmap_matrixkins.hal",
        "COMP_FILE_TYPE = 1",
    ] {
        assert!(ini.contains(line), "{ini}");
    }
    assert!(e.report.residual.max_mm < 1.2e-7, "{:?}", e.report.residual);
    assert!(e.report.before.max_mm > 0.11);
}

/// Klipper's skew transform of target `t` with factors `[xy, xz, yz]`.
fn skewed(f: [f64; 3], t: [f64; 3]) -> [f64; 3] {
    let [xy, xz, yz] = f;
    [
        t[0] - t[1] * xy - t[2] * (xz - xy * yz),
        t[1] - t[2] * yz,
        t[2],
    ]
}

/// The factors of a `[skew_correction volmap]` profile.
fn klipper_factors(text: &str) -> [f64; 3] {
    let profile = text.split("[skew_correction volmap]").nth(1).unwrap();
    let value = |key: &str| -> f64 {
        let line = profile.lines().find(|l| l.starts_with(key)).unwrap();
        line.split('=').nth(1).unwrap().trim().parse().unwrap()
    };
    [value("xy_skew"), value("xz_skew"), value("yz_skew")]
}

#[test]
fn klipper_skew_of_a_squareness_alone_is_minus_tan_c() {
    let c: f64 = 2.0e-4;
    let m = squareness_machine(c);
    let inputs = Inputs::default();
    let e = exported(&m, &inputs, "klipper", TableSize::Default, 21);
    let f = klipper_factors(text(&e, "volmap_skew.cfg"));
    assert_eq!(f, [(-c.tan() * 1e12).round() / 1e12, 0.0, 0.0]);
    // Klipper cannot scale Y: the tip lands (cos c − 1)·y·(−tan c, 1, 0) off, |y|(1 − cos c)/cos c.
    let hand = 600.0 * (1.0 - c.cos()) / c.cos();
    let twin = Twin::of(&m);
    let (max, _) = residual(&twin, &dense(&m, 21), |t| skewed(f, t));
    assert!((max - hand).abs() < 1e-9, "{max} vs {hand}");
    assert!((e.report.residual.max_mm - max).abs() < 1e-12);
}

/// Squareness of Y to X and of Z to both, with the scale errors that make the axis directions
/// unit upper triangular (`d_Y = (xy, 1, 0)`, `d_Z = (xz, yz, 1)`): a pure skew.
pub fn pure_skew() -> (Machine, [f64; 3]) {
    let (c, a, b): (f64, f64, f64) = (3.0e-4, -2.0e-4, 5.0e-4);
    let m = machine(&format!(
        r#"
name = "pure skew"
chain = "FFXYZ"
[axes.X]
range = [0.0, 300.0]
[axes.Y]
range = [0.0, 250.0]
EC0Y = {c:e}
EYY = {{ poly = [0.0, {:e}] }}
[axes.Z]
range = [0.0, 200.0]
EA0Z = {a:e}
EB0Z = {b:e}
EZZ = {{ poly = [0.0, {:e}] }}
"#,
        1.0 / c.cos() - 1.0,
        1.0 / (a.cos() * b.cos()) - 1.0
    ));
    let hand = [
        -c.tan(),
        c.cos() * b.tan() / a.cos() + c.sin() * a.tan(),
        c.sin() * b.tan() / a.cos() - c.cos() * a.tan(),
    ];
    (m, hand)
}

#[test]
fn klipper_holds_a_pure_skew_to_rounding() {
    let (m, hand) = pure_skew();
    let inputs = Inputs::default();
    let e = exported(&m, &inputs, "klipper", TableSize::Default, 21);
    let f = klipper_factors(text(&e, "volmap_skew.cfg"));
    for d in 0..3 {
        assert!((f[d] - hand[d]).abs() <= 5e-13, "{f:?} vs {hand:?}");
    }
    let twin = Twin::of(&m);
    let (max, rms) = residual(&twin, &dense(&m, 21), |t| skewed(f, t));
    assert!(max < 1e-9, "{max}");
    assert!((e.report.residual.max_mm - max).abs() < 1e-12);
    assert!((e.report.residual.rms_mm - rms).abs() < 1e-12);
    assert!(e.report.before.max_mm > 0.09);
}

#[test]
fn marlin_holds_a_pure_skew_where_it_corrects_and_nothing_elsewhere() {
    let (m, hand) = pure_skew();
    let inputs = Inputs::default();
    let e = exported(&m, &inputs, "marlin", TableSize::Default, 21);
    let gcode = text(&e, "volmap_skew.gcode");
    let line = gcode.lines().find(|l| l.starts_with("M852 ")).unwrap();
    assert!(
        gcode.contains("\nG21\nM852 ") && gcode.contains("\nM500\n"),
        "{gcode}"
    );
    // After M500 only the report, as comments.
    let after = &gcode[gcode.find("\nM500\n").unwrap() + 6..];
    assert!(after.lines().all(|l| l.starts_with("; ")), "{after}");
    assert!(
        after.contains("; residual with these tables: largest "),
        "{after}"
    );
    // Fixed decimals (Marlin reads no exponent) into 32-bit floats.
    assert!(!line.contains('e') && !line.contains('E'));
    let word = |w: char| -> f64 {
        let v = line.split_whitespace().find(|x| x.starts_with(w)).unwrap();
        v[1..].parse::<f32>().unwrap() as f64
    };
    let f = [word('I'), word('J'), word('K')];
    for d in 0..3 {
        assert!((f[d] - hand[d]).abs() < 1e-10, "{f:?} vs {hand:?}");
    }
    // Marlin's gate: X from X_MIN_POS + 1 to X_MAX_POS, Y likewise, the skewed X, Y in the travel.
    let corrects = |t: [f64; 3]| {
        let s = skewed(f, t);
        (1.0..=300.0).contains(&t[0])
            && (1.0..=250.0).contains(&t[1])
            && (0.0..=300.0).contains(&s[0])
            && (0.0..=250.0).contains(&s[1])
    };
    let twin = Twin::of(&m);
    let targets = dense(&m, 21);
    let (inside, outside): (Vec<[f64; 3]>, Vec<[f64; 3]>) =
        targets.iter().partition(|&&t| corrects(t));
    assert!(!inside.is_empty() && !outside.is_empty());
    let (max_inside, _) = residual(&twin, &inside, |t| skewed(f, t));
    assert!(max_inside < 5e-8, "{max_inside}");
    let (all, _) = residual(
        &twin,
        &targets,
        |t| if corrects(t) { skewed(f, t) } else { t },
    );
    let (before_outside, _) = residual(&twin, &outside, |t| t);
    assert!((e.report.residual.max_mm - all).abs() < 1e-12);
    assert!((all - before_outside).abs() < 1e-12);
}

#[test]
fn skew_formats_refuse_a_machine_without_squareness_and_take_no_table_size() {
    let dobariya = embedded::load("vmc-dobariya2015").unwrap();
    let inputs = Inputs::default();
    for format in ["klipper", "marlin"] {
        let f = export::format_named(format).unwrap();
        match export::export(f, &request(&dobariya, &inputs, TableSize::Default)) {
            Err(ExportError::NothingHeld { .. }) => {}
            other => panic!("{format}: {:?}", other.map(|e| e.report)),
        }
        let e = export::export(f, &request(&dobariya, &inputs, TableSize::Points(5)))
            .err()
            .unwrap();
        assert_eq!(
            e.to_string(),
            format!("{format} holds fixed factors, not tables: there is no table size to choose")
        );
    }
}

#[test]
fn linuxcnc_2_9_writes_the_joint_files_alone_and_leaves_the_squareness() {
    // vmc-li2015's squareness EC0Y: matrixkins holds it on 2.10; 2.9 has no matrixkins, so the
    // configuration keeps trivkins, reads back with C the identity, and says what is left.
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let mut r = request(&li, &inputs, TableSize::Points(9));
    r.evaluation_points = Some(21);
    let linuxcnc = export::format_named("linuxcnc").unwrap();
    let stable = export::export(linuxcnc, &r).unwrap();
    r.control = Some("2.10".into());
    let master = export::export(linuxcnc, &r).unwrap();
    let names = |e: &export::Export| e.files.iter().map(|f| f.name.clone()).collect::<Vec<_>>();
    assert!(
        !names(&stable).iter().any(|n| n.ends_with(".hal")),
        "{:?}",
        names(&stable)
    );
    assert!(names(&master).iter().any(|n| n.ends_with(".hal")));
    let ini = text(&stable, "linuxcnc.ini");
    assert!(
        ini.contains("(LinuxCNC 2.9)") && !ini.contains("[KINS]"),
        "{ini}"
    );
    assert!(ini.contains("squareness) are NOT held"));
    assert!(ini.contains("# control: linuxcnc 2.9"));
    assert!(stable.report.controller.starts_with("LinuxCNC 2.9"));
    let named =
        |e: &export::Export, key: &str| e.report.not_held.iter().find(|n| n.error == key).cloned();
    let square = named(&stable, "EC0Y").expect("EC0Y listed on 2.9");
    assert!(square.not_held_mm > 0.001, "{square:?}");
    assert!(named(&master, "EC0Y").is_none());
    assert!(stable.report.residual.max_mm > master.report.residual.max_mm);
    // The versions it knows, and only those.
    r.control = Some("2.8".into());
    let error = export::export(linuxcnc, &r)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        error.contains("`2.8` is not a control linuxcnc is written for (controls: 2.9, 2.10)"),
        "{error}"
    );
}

#[test]
fn every_export_carries_its_residual_where_its_tables_are_kept() {
    // The residual, the error before and what the format cannot hold, with the machine: as
    // comments at the end of a one-file format's file (which still reads as without them), in
    // volmap-report.txt beside a folder format's files.
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    for format in export::formats::FORMATS {
        let name = format.spec().name;
        let mut r = request(&li, &inputs, TableSize::Points(5));
        r.evaluation_points = Some(11);
        if format.spec().limits.nodes == export::Nodes::Fixed {
            r.size = TableSize::Default;
        }
        if format.takes_probe_offset() {
            r.probe_offset_mm = Some([20.0, -30.0]);
        }
        let e = export::export(*format, &r).unwrap();
        let residual = format!(
            "residual with these tables: largest {:.3} um",
            e.report.residual.max_mm * 1e3
        );
        let text = match format.spec().layout {
            export::Layout::File => {
                assert!(e.report_file.is_none(), "{name}");
                e.files[0].text.clone()
            }
            export::Layout::Folder => {
                let report = e.report_file.as_ref().expect("a report file");
                assert_eq!(report.name, "volmap-report.txt");
                assert!(e.report.files.contains(&report.name), "{name}");
                assert!(report.text.contains("machine: 3-axis VMC"), "{name}");
                report.text.clone()
            }
        };
        assert!(text.contains(&residual), "{name}: {residual} in\n{text}");
        assert!(text.contains("error before: largest "), "{name}");
        let cannot = match e.report.not_held.first() {
            Some(n) => format!("cannot hold: {} ", n.error),
            None => "cannot hold: nothing".into(),
        };
        assert!(text.contains(&cannot), "{name}: {cannot} in\n{text}");
    }
}

#[test]
fn what_a_format_cannot_hold_is_named_per_error() {
    // vmc-li2015: a per-joint table cannot hold the straightness EXY; the squareness EC0Y goes to
    // matrixkins, so it is not listed; on the skew formats the positioning EXX is all left.
    let li = embedded::load("vmc-li2015").unwrap();
    let inputs = Inputs::default();
    let lc = exported(&li, &inputs, "linuxcnc", TableSize::Points(9), 21);
    let named =
        |e: &export::Export, key: &str| e.report.not_held.iter().find(|n| n.error == key).cloned();
    let exy = named(&lc, "EXY").expect("EXY listed");
    assert!(exy.not_held_mm > 0.01 && exy.not_held_mm <= exy.alone_mm + 1e-12);
    assert!(named(&lc, "EC0Y").is_none() && named(&lc, "EXX").is_none());
    let kl = exported(&li, &inputs, "klipper", TableSize::Default, 21);
    let exx = named(&kl, "EXX").expect("EXX listed");
    assert!((exx.not_held_mm - exx.alone_mm).abs() < 1e-6, "{exx:?}");
    assert!(named(&kl, "EC0Y").is_none());
}
