//! RepRapFirmware's `M556` and height map (`rrf`, `rrf-heightmap`), read here as the firmware's
//! source reads them (`GCodes2.cpp` case 556 and `Move::AxisTransform`; `HeightMap::LoadFromFile`
//! and `GetInterpolatedHeightError`), against hand-derived cases.

use super::export::{dense, machine, request, residual};
use super::export_formats::{pure_skew, squareness_machine};
use volmap::export::{self, format::WrittenFile, ExportError, TableSize};
use volmap::model::inputs::{Approach, Inputs};
use volmap::model::Machine;
use volmap::reference::Twin;

fn exported(m: &Machine, format: &str, size: TableSize) -> Result<export::Export, ExportError> {
    let inputs = Inputs::default();
    let mut r = request(m, &inputs, size);
    r.evaluation_points = Some(21);
    export::export(export::format_named(format).unwrap(), &r)
}

fn file<'a>(e: &'a [WrittenFile], name: &str) -> &'a str {
    &e.iter().find(|f| f.name == name).unwrap().text
}

/// The tangents `M556` sets, as the firmware stores them (deviation / S in 32-bit floats):
/// `[tanXY, tanYZ, tanXZ]`.
fn m556(text: &str) -> [f64; 3] {
    let line = text.lines().find(|l| l.starts_with("M556 ")).unwrap();
    let word = |w: char| -> f32 {
        let v = line.split_whitespace().find(|x| x.starts_with(w)).unwrap();
        v[1..].parse().unwrap()
    };
    let s = word('S');
    assert_eq!(word('P'), 0.0, "{line}");
    [
        (word('X') / s) as f64,
        (word('Y') / s) as f64,
        (word('Z') / s) as f64,
    ]
}

/// `AxisTransform` with P0: what the firmware sends for target `t`.
fn rrf_command([xy, yz, xz]: [f64; 3], t: [f64; 3]) -> [f64; 3] {
    [t[0] + xy * t[1] + xz * t[2], t[1] + yz * t[2], t[2]]
}

#[test]
fn rrf_holds_a_pure_skew_to_the_rounding_of_its_floats() {
    // The machine is p_real = M·raw with M = [[1, xy, xz], [0, 1, yz], [0, 0, 1]] (Klipper's
    // factors): the firmware must send raw = M⁻¹·t, x − xy·y − (xz − xy·yz)·z and y − yz·z, which
    // is its own form with tanXY = −xy, tanYZ = −yz, tanXZ = −(xz − xy·yz).
    let (m, [xy, xz, yz]) = pure_skew();
    let e = exported(&m, "rrf", TableSize::Default).unwrap();
    let text = file(&e.files, "volmap_skew.g");
    let t = m556(text);
    let hand = [-xy, -yz, -(xz - xy * yz)];
    for d in 0..3 {
        assert!((t[d] - hand[d]).abs() < 1e-10, "{t:?} vs {hand:?}");
    }
    assert!(!text
        .lines()
        .find(|l| l.starts_with("M556"))
        .unwrap()
        .contains('e'));
    let twin = Twin::of(&m);
    let (max, rms) = residual(&twin, &dense(&m, 21), |p| rrf_command(t, p));
    assert!(max < 1e-8, "{max}");
    assert!((e.report.residual.max_mm - max).abs() < 1e-12);
    assert!((e.report.residual.rms_mm - rms).abs() < 1e-12);
    assert!(e.report.before.max_mm > 0.09);
    // The report after the line, as comments.
    let after = &text[text.find("\nM556 ").unwrap() + 1..];
    assert!(
        after.lines().skip(1).all(|l| l.starts_with("; ")),
        "{after}"
    );
}

#[test]
fn rrf_squareness_alone_is_a_positive_x_for_an_obtuse_angle() {
    // EC0Y = c > 0 turns Y's travel towards −X: the angle between +X and +Y is 90° + c, obtuse,
    // which RepRapFirmware's documentation gives a positive X; X = S·tan c.
    let c: f64 = 2.0e-4;
    let e = exported(&squareness_machine(c), "rrf", TableSize::Default).unwrap();
    let text = file(&e.files, "volmap_skew.g");
    let line = text.lines().find(|l| l.starts_with("M556 ")).unwrap();
    assert_eq!(
        line,
        format!(
            "M556 S100 X{:.10} Y0.0000000000 Z0.0000000000 P0",
            100.0 * c.tan()
        )
    );
    assert!(m556(text)[0] > 0.0);
}

#[test]
fn rrf_reads_m556_as_the_firmware_does() {
    let (m, _) = pure_skew();
    let inputs = Inputs::default();
    let fitting = export::Fitting::new(&m, &inputs, [0.0; 6], Vec::new()).unwrap();
    let rrf = export::format_named("rrf").unwrap();
    let written = rrf.write(&fitting, None, None).unwrap();
    let approach = [Approach::Positive; 6];
    let t = [120.0, 80.0, 150.0, 0.0, 0.0, 0.0];
    let with = |from: &str, to: &str| {
        let mut files = written.clone();
        assert!(files[0].text.contains(from), "{from}");
        files[0].text = files[0].text.replacen(from, to, 1);
        rrf.read_for(&files, &fitting)
    };
    let tan = m556(&written[0].text);
    let c = with("P0", "P0").unwrap().command(&t, &approach);
    let hand = rrf_command(tan, [t[0], t[1], t[2]]);
    for d in 0..3 {
        assert!((c[d] - hand[d]).abs() < 1e-12);
    }
    // P1: the XY term corrects Y from X.
    let c = with(" P0\n", " P1\n").unwrap().command(&t, &approach);
    assert!((c[0] - (t[0] + tan[2] * t[2])).abs() < 1e-12);
    assert!((c[1] - (t[1] + tan[0] * t[0] + tan[1] * t[2])).abs() < 1e-12);
    // Deviations without S are ignored: nothing is corrected.
    let c = with("M556 S100 ", "M556 ").unwrap().command(&t, &approach);
    assert_eq!(c, t);
    // S must be positive.
    let e = with("M556 S100 ", "M556 S0 ")
        .err()
        .expect("S0 refused")
        .to_string();
    assert!(e.contains("the length must be greater than zero"), "{e}");
}

/// A machine whose Z error is linear in X and Y (a tilted bed seen from the tool).
fn tilted() -> Machine {
    machine(
        r#"
name = "tilted"
chain = "FYXFZ"
[axes.X]
range = [0.0, 300.0]
EZX = { poly = [0.0, 2.1234e-4] }
[axes.Y]
range = [0.0, 200.0]
EZY = { poly = [0.0, -1.3711e-4] }
[axes.Z]
range = [0.0, 100.0]
"#,
    )
}

/// The grid of a height map as `LoadFromFile` reads it: mins, spacings, nums, heights (row Y).
struct Map {
    mins: [f64; 2],
    spacings: [f64; 2],
    nums: [usize; 2],
    heights: Vec<f64>,
}

fn read_map(text: &str) -> Map {
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("RepRapFirmware height map file v2"));
    assert_eq!(
        lines[1],
        "axis0,axis1,min0,max0,min1,max1,radius,spacing0,spacing1,num0,num1"
    );
    let p: Vec<&str> = lines[2].split(',').collect();
    assert_eq!((p[0], p[1], p[6]), ("X", "Y", "-1.00"));
    let f = |k: usize| p[k].parse::<f32>().unwrap() as f64;
    let nums = [p[9].parse().unwrap(), p[10].parse().unwrap()];
    let mut heights = Vec::new();
    for row in &lines[3..3 + nums[1]] {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells.len(), nums[0], "{row}");
        for c in cells {
            // `%7.3f`, never a bare 0 (a point not probed).
            assert_eq!(c.len(), 7, "{row}");
            assert_eq!(c.trim().split('.').nth(1).map(str::len), Some(3), "{row}");
            heights.push(c.trim().parse::<f32>().unwrap() as f64);
        }
    }
    assert_eq!(lines.len(), 3 + nums[1]);
    Map {
        mins: [f(2), f(4)],
        spacings: [f(7), f(8)],
        nums,
        heights,
    }
}

impl Map {
    /// Bilinear, each position clamped to [min, last − 0.01].
    fn height(&self, x: f64, y: f64) -> f64 {
        let at = |v: f64, d: usize| {
            let last = self.mins[d] + (self.nums[d] - 1) as f64 * self.spacings[d];
            let f = (v.clamp(self.mins[d], last - 0.01) - self.mins[d]) / self.spacings[d];
            (f.floor() as usize, f - f.floor())
        };
        let ((i, u), (j, v)) = (at(x, 0), at(y, 1));
        let h = |i: usize, j: usize| self.heights[j * self.nums[0] + i];
        (1.0 - u) * (1.0 - v) * h(i, j)
            + u * (1.0 - v) * h(i + 1, j)
            + (1.0 - u) * v * h(i, j + 1)
            + u * v * h(i + 1, j + 1)
    }
}

#[test]
fn rrf_heightmap_of_a_tilted_bed_holds_it_to_the_micrometre() {
    let m = tilted();
    let twin = Twin::of(&m);
    let e = exported(&m, "rrf-heightmap", TableSize::Points(21)).unwrap();
    let text = file(&e.files, "heightmap.csv");
    assert_eq!(
        text.lines().nth(2).unwrap(),
        "X,Y,0.00,300.00,0.00,200.00,-1.00,15.00,10.00,21,21"
    );
    let map = read_map(text);
    // A Z error alone, independent of Z: the correction is its negation, the bed's height.
    for j in 0..21 {
        for i in 0..21 {
            let (x, y) = (15.0 * i as f64, 10.0 * j as f64);
            let c = [x, y, 50.0, 0.0, 0.0, 0.0];
            let error = twin.real_tip(&c) - twin.ideal_tip(&c);
            let hand = ((-error.z * 1000.0).round() / 1000.0) as f32 as f64;
            assert_eq!(map.heights[j * 21 + i], hand, "node {i}, {j}");
        }
    }
    // The first row is the least Y: the heights change along a row by X's slope alone.
    assert!((map.heights[1] - map.heights[0]).abs() > 2e-3);
    let (max, rms) = residual(&twin, &dense(&m, 21), |t| {
        [t[0], t[1], t[2] + map.height(t[0], t[1])]
    });
    assert!(max <= 5e-4 + 1e-9, "{max}");
    assert!((e.report.residual.max_mm - max).abs() < 1e-9);
    assert!((e.report.residual.rms_mm - rms).abs() < 1e-9);
    assert!(e.report.before.max_mm > 0.06);
    let report = e.report_file.as_ref().expect("a report beside the folder");
    assert_eq!(report.name, "volmap-report.txt");
    assert!(report.text.contains("residual"), "{}", report.text);
}

#[test]
fn rrf_heightmap_keeps_the_firmwares_limits_and_reading() {
    let m = tilted();
    let refused = exported(&m, "rrf-heightmap", TableSize::Points(22))
        .err()
        .unwrap();
    assert!(
        refused.to_string().starts_with(
            "484 points over X and Y together (22 x 22) is more than a rrf-heightmap table holds: at most 441"
        ),
        "{refused}"
    );
    assert!(exported(&m, "rrf-heightmap", TableSize::Points(42)).is_err());
    let inputs = Inputs::default();
    let fitting = export::Fitting::new(&m, &inputs, [0.0; 6], Vec::new()).unwrap();
    let format = export::format_named("rrf-heightmap").unwrap();
    let written = format.write(&fitting, Some([5, 3, 5]), None).unwrap();
    let approach = [Approach::Positive; 6];
    let control = format.read_for(&written, &fitting).unwrap();
    // Outside the grid the edge holds: beyond X's end as at its last node.
    let at = |x: f64, y: f64| control.command(&[x, y, 10.0, 0.0, 0.0, 0.0], &approach)[2] - 10.0;
    let map = read_map(&written[0].text);
    assert!((at(400.0, 100.0) - map.height(300.0, 100.0)).abs() < 1e-12);
    assert!((at(-50.0, -50.0) - map.heights[0]).abs() < 1e-12);
    let broken = |from: &str, to: &str| -> String {
        let mut files = written.clone();
        assert!(files[0].text.contains(from), "{from}");
        files[0].text = files[0].text.replacen(from, to, 1);
        match format.read_for(&files, &fitting) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("`{to}` read"),
        }
    };
    let first = written[0]
        .text
        .lines()
        .nth(3)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .to_string();
    assert_eq!(
        broken(&format!("\n{first},"), "\n0,"),
        "reading back heightmap.csv: line 4: column 1: a bare 0 is a point not probed (write 0.000)"
    );
    assert_eq!(
        broken("-1.00,", "-1.00,\n"),
        "reading back heightmap.csv: line 3: the grid needs 11 parameters"
    );
    let rows = written[0].text.lines().nth(4).unwrap().to_string();
    assert_eq!(
        broken(&format!("{rows}\n"), &format!("\n{rows}\n")),
        "reading back heightmap.csv: line 5: an empty line where a row of heights belongs"
    );
    assert!(broken("axis0,axis1,min0", "xmin,xmax").contains("line 2: the labels must read"));
    assert!(broken(",5,3\n", ",50,3\n").contains("50 x 3 points"));
}
