//! `volmap export --format isg`: the ISO 230-1 error parameters as the ISG kernel's volumetric
//! compensation takes them (ISG CSV blocks, the configuration list), read back here with the
//! documented grammar, rebuilt into the control's model (the machine's nominal kinematics with
//! every parameter linear between the written nodes) and applied over a dense grid: the
//! residual the export reports. Hand-derived blocks; machines the written nodes hold exactly;
//! the line syntax; what it refuses.

use std::collections::BTreeMap;

use super::export::{dense, machine};
use volmap::export::{self, format::WrittenFile, Field, Request, TableSize};
use volmap::io::embedded;
use volmap::model::inputs::Inputs;
use volmap::model::table2d::Table2d;
use volmap::model::{AxisLetter, Command, ErrorFunction, Interp, Machine, Table};
use volmap::reference::Twin;

fn isg() -> &'static dyn export::Format {
    export::format_named("isg").unwrap()
}

fn request<'a>(m: &'a Machine, inputs: &'a Inputs, size: TableSize, pose: Command) -> Request<'a> {
    Request {
        machine: m,
        inputs,
        pose,
        size,
        evaluation_points: None,
        written_by: "Written by the tests".into(),
        file_name: None,
        tool_length_mm: None,
        control: None,
        point_numbers: None,
        probe_offset_mm: None,
    }
}

fn file<'a>(files: &'a [WrittenFile], name: &str) -> &'a str {
    &files.iter().find(|f| f.name == name).expect(name).text
}

/// One block of an ISG CSV file: its header and rows.
type Block = (Vec<String>, Vec<Vec<f64>>);

/// The blocks of an ISG CSV text: `//` rows skipped, `#` breaks.
fn blocks(text: &str) -> Vec<Block> {
    let mut out: Vec<Block> = Vec::new();
    let mut open = false;
    for line in text.lines() {
        if line.starts_with("//") {
            continue;
        }
        if line == "#" {
            open = false;
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        if !open {
            out.push((words.iter().map(|w| w.to_string()).collect(), Vec::new()));
            open = true;
        } else {
            let row = words.iter().map(|w| w.parse().unwrap()).collect();
            out.last_mut().unwrap().1.push(row);
        }
    }
    out
}

fn letter(c: char) -> AxisLetter {
    AxisLetter::from_char(c).unwrap()
}

/// The control's model: `nominal` (errors cleared) with every parameter of `text` linear
/// between its nodes, the end values outside; the tool vector N0 a direction, the tool as long
/// as `nominal`'s (the active tool's data).
fn model(nominal: &Machine, text: &str) -> Machine {
    let length = nominal
        .tool_offset_mm
        .iter()
        .map(|c| c * c)
        .sum::<f64>()
        .sqrt();
    let mut m = nominal.without_errors();
    for (header, rows) in blocks(text) {
        let args: Vec<usize> = (0..header.len())
            .filter(|&i| header[i].len() == 1)
            .collect();
        for (p, name) in header.iter().enumerate().filter(|(_, n)| n.len() == 3) {
            let chars: Vec<char> = name.chars().collect();
            if args.is_empty() {
                let v = rows[0][p];
                match chars[..] {
                    ['N', '0', c] => m.tool_offset_mm["XYZ".find(c).unwrap()] = v * length,
                    [c, '0', a] => {
                        m.axis_mut(letter(a)).unwrap().location["XYZABC".find(c).unwrap()] = v
                    }
                    _ => panic!("{name}"),
                }
                continue;
            }
            let own = letter(chars[2]);
            let index = "XYZABC".find(chars[1]).unwrap();
            let f = match args[..] {
                [a] => {
                    let nodes: Vec<(f64, f64)> = rows.iter().map(|r| (r[a], r[p])).collect();
                    let t = ErrorFunction::Table(Table::new(nodes, Interp::Linear, false).unwrap());
                    let axis = letter(header[a].chars().next().unwrap());
                    if axis == own {
                        t
                    } else {
                        ErrorFunction::Of {
                            axis,
                            form: Box::new(t),
                        }
                    }
                }
                [a, b] => {
                    // Rows: the first argument outermost.
                    let mut x: Vec<f64> = rows.iter().map(|r| r[a]).collect();
                    x.dedup();
                    let ny = rows.len() / x.len();
                    let y: Vec<f64> = rows[..ny].iter().map(|r| r[b]).collect();
                    let values = rows
                        .chunks(ny)
                        .map(|c| c.iter().map(|r| r[p]).collect())
                        .collect();
                    let axes =
                        [args[0], args[1]].map(|i| letter(header[i].chars().next().unwrap()));
                    ErrorFunction::Table2d(Table2d::new(axes, x, y, values).unwrap())
                }
                _ => panic!("{name}: {args:?}"),
            };
            m.axis_mut(own).unwrap().components[index] = Some(f);
        }
    }
    m
}

/// Largest and RMS of `|p_real(c(t)) − p_ideal(t)|` over `targets` at `pose`, with `c` the
/// command that puts the tip of `control`'s model on target.
fn residual(real: &Machine, control: Machine, pose: Command, targets: &[[f64; 3]]) -> (f64, f64) {
    let twin = Twin::new(real.clone());
    let field = Field::new(control, pose).unwrap();
    let (mut max, mut sum): (f64, f64) = (0.0, 0.0);
    for &t in targets {
        let d = field.correction(t).unwrap();
        let at = |p: [f64; 3]| -> Command { [p[0], p[1], p[2], pose[3], pose[4], pose[5]] };
        let c = [t[0] + d[0], t[1] + d[1], t[2] + d[2]];
        let miss = (twin.real_tip(&at(c)) - twin.ideal_tip(&at(t))).norm();
        max = max.max(miss);
        sum += miss * miss;
    }
    (max, (sum / targets.len() as f64).sqrt())
}

const HAND: &str = r#"
name = "hand"
chain = "FYXFZ"
[tool]
offset = [0.0, 0.0, -100.0]
[axes.X]
range = [0.0, 400.0]
EXX = { poly = [0.0, 1.0e-5] }
EBX = 3.0e-6
[axes.Y]
range = [0.0, 300.0]
EC0Y = 2.0e-5
[axes.Z]
range = [0.0, 200.0]
"#;

#[test]
fn isg_writes_the_errors_themselves_by_hand() {
    // The ERRORS, unchanged in sign: EXX 4 µm at 400 mm (a straight line: two nodes suffice),
    // EBX a constant, the squareness EC0Y as position error C0Y, the tool's direction as the
    // unit vector N0 (the control takes the length from its tool data).
    let m = machine(HAND);
    let inputs = Inputs::default();
    let exported =
        export::export(isg(), &request(&m, &inputs, TableSize::Default, [0.0; 6])).unwrap();
    let files = &exported.files;
    let words: Vec<Vec<&str>> = file(files, "volcomp_errors.csv")
        .lines()
        .filter(|l| !l.starts_with("//"))
        .map(|l| l.split_whitespace().collect())
        .collect();
    let expected: Vec<Vec<&str>> = vec![
        vec!["C0Y", "N0X", "N0Y", "N0Z"],
        vec![
            "0.000020000000",
            "0.000000000",
            "0.000000000",
            "-1.000000000",
        ],
        vec!["#"],
        vec!["X", "EXX"],
        vec!["0.000000", "0.000000000"],
        vec!["400.000000", "0.004000000"],
        vec!["#"],
        vec!["X", "EBX"],
        vec!["0.000000", "0.000003000000"],
        vec!["400.000000", "0.000003000000"],
    ];
    assert_eq!(words, expected);
    let config = file(files, "vol_comp_0.lis");
    for (key, value) in [
        ("X", "1"),
        ("Y", "2"),
        ("Z", "3"),
        ("chain", "XYZ"),
        ("workpiece_axes", "2"),
        ("interpolation", "GRID"),
        ("file[0]", "C:\\volcomp\\volcomp_errors.csv"),
        ("file_format[0]", "ISG_CSV"),
    ] {
        let line = format!("{key:<24} {value}");
        assert!(config.lines().any(|l| l == line), "{line}:\n{config}");
    }
    let startup = file(files, "hochlauf_volcomp.lis");
    for (key, value) in [
        ("vol_comp[0].max_records", "5"),
        ("vol_comp[0].file_name", "C:\\volcomp\\vol_comp_0.lis"),
    ] {
        let line = format!("{key:<32} {value}");
        assert!(startup.lines().any(|l| l == line), "{line}:\n{startup}");
    }
    // Everything here is linear between the nodes: the control's model is the machine's over
    // the travels. Only where the correction takes X 2 µm past the end of its travel (Y = 300:
    // the squareness) does the table hold its end value while the polynomial goes on:
    // 1e-5 × 2 µm = 2e-8 mm.
    let r = &exported.report;
    assert!(r.before.max_mm > 0.005);
    assert!(r.residual.max_mm < 3e-8, "{:?}", r.residual);
}

#[test]
fn isg_writes_the_tool_direction_and_measures_the_residual_for_the_tool_length_asked() {
    // EBX = 3 µrad tilts the tool: 0.3 µm at 100 mm, 1.2 µm at 400 mm. The files say the same
    // for both lengths (N0 a unit vector); the control applies them with its tool's length.
    let m = machine(HAND);
    let inputs = Inputs::default();
    let mut asked = request(&m, &inputs, TableSize::Default, [0.0; 6]);
    asked.tool_length_mm = Some(400.0);
    let long = export::export(isg(), &asked).unwrap();
    let short = export::export(isg(), &request(&m, &inputs, TableSize::Default, [0.0; 6])).unwrap();
    let errors = |e: &export::Export| {
        file(&e.files, "volcomp_errors.csv")
            .lines()
            .filter(|l| !l.starts_with("//"))
            .map(String::from)
            .collect::<Vec<_>>()
    };
    assert_eq!(errors(&long), errors(&short));
    assert!(long
        .report
        .tool
        .starts_with("400.000 mm along (0.000000, 0.000000, -1.000000)"));
    assert!(
        long.report.tool.ends_with("(the length asked for)"),
        "{}",
        long.report.tool
    );
    assert!(
        short.report.tool.starts_with("100.000 mm"),
        "{}",
        short.report.tool
    );
    assert!(file(&long.files, "volcomp_errors.csv").contains("tool: 400.000 mm"));
    // The error the tool's tilt adds grows with its length: EBX·L along X.
    let tilt = |e: &export::Export| e.report.before.max_mm;
    assert!(
        tilt(&long) - tilt(&short) > 0.0008,
        "{} {}",
        tilt(&long),
        tilt(&short)
    );
    // The squareness's end effect (the correction takes X past its travel) at the longer tool.
    assert!(
        long.report.residual.max_mm < 5e-8,
        "{:?}",
        long.report.residual
    );
    // A tool vector that is not a unit vector does not read: the control would scale the tool.
    let mut files = long.files.clone();
    for f in files.iter_mut().filter(|f| f.name == "volcomp_errors.csv") {
        f.text = f.text.replace("-1.000000000", "-400.000000000");
    }
    let fitting = export::Fitting::new(&m, &inputs, [0.0; 6], Vec::new()).unwrap();
    let error = isg()
        .read_for(&files, &fitting)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        error.contains("volcomp_errors.csv") && error.contains("not a unit vector"),
        "{error}"
    );
    // A length that is not one is refused.
    asked.tool_length_mm = Some(-1.0);
    let error = export::export(isg(), &asked)
        .err()
        .expect("refused")
        .to_string();
    assert!(error.contains("a tool length of -1 mm"), "{error}");
}

const PIECEWISE: &str = r#"
name = "piecewise linear 5-axis"
chain = "FYXCFZB"
[tool]
offset = [0.0, 0.0, -200.0]
[axes.X]
range = [0.0, 500.0]
EXX = { table = [[0, 0.0], [180, 0.004], [500, 0.006]], interp = "linear" }
EBX = { table = [[0, 0.0], [250, 1.0e-5], [500, 0.0]], interp = "linear" }
EZX = { table = [[0, 0.0], [200, -0.003]], interp = "linear", of = "Z" }
[axes.Y]
range = [0.0, 300.0]
EC0Y = 1.5e-5
EYY = { table2d = { of = ["Y", "Z"], x = [0.0, 300.0], y = [0.0, 400.0], values = [[0.0, 0.002], [0.003, 0.001]] } }
[axes.C]
range = [0.0, 360.0]
offset = [0.0, 0.0, 100.0]
EX0C = 0.005
EB0C = 1.0e-5
EZC = { table = [[0, 0.0], [90, 0.002], [180, 0.0], [270, -0.002], [360, 0.0]], interp = "linear" }
[axes.Z]
range = [0.0, 400.0]
EXZ = { table = [[0, 0.0], [400, 0.005]], interp = "linear" }
[axes.B]
range = [-90.0, 90.0]
EAB = { table = [[-90, 2.0e-5], [0, 0.0], [90, 1.0e-5]], interp = "linear" }
EYB = 0.002
"#;

#[test]
fn isg_holds_piecewise_linear_errors_on_their_nodes_to_rounding() {
    let m = machine(PIECEWISE);
    let inputs = Inputs::default();
    let mut pose = [0.0; 6];
    pose[AxisLetter::B.index()] = 30.0;
    pose[AxisLetter::C.index()] = 45.0;
    let exported =
        export::export(isg(), &request(&m, &inputs, TableSize::Points(9), pose)).unwrap();
    let r = &exported.report;
    assert!(r.before.max_mm > 0.01, "{:?}", r.before);
    assert!(r.residual.max_mm < 1e-8, "{:?}", r.residual);
    let text = file(&exported.files, "volcomp_errors.csv");
    let found = blocks(text);
    let block = |name: &str| {
        found
            .iter()
            .find(|b| b.0.iter().any(|h| h == name))
            .unwrap()
    };
    // The nodes the errors change slope at, and no more.
    let exx = block("EXX");
    assert_eq!(
        exx.1.iter().map(|r| r[0]).collect::<Vec<_>>(),
        [0.0, 180.0, 500.0]
    );
    let ezc = block("EZC");
    assert_eq!(
        ezc.1.iter().map(|r| r[0]).collect::<Vec<_>>(),
        [0.0, 90.0, 270.0, 360.0],
        "90 to 270 is one straight piece"
    );
    // An error of another axis, tabulated against it; an error of two axes on their full grid.
    assert_eq!(block("EZX").0, ["Z", "EZX"]);
    assert_eq!(block("EYY").0, ["Y", "Z", "EYY"]);
    assert_eq!(block("EYY").1.len(), 4);
    let config = file(&exported.files, "vol_comp_0.lis");
    assert!(config.contains(&format!("{:<24} CXYZB\n", "chain")));
    assert!(config.contains(&format!("{:<24} 3\n", "workpiece_axes")));
}

#[test]
fn isg_round_trip_gives_the_reported_residual() {
    for (name, pose, points) in [
        ("gantry-2m", [0.0; 6], 9),
        ("5axis-hwang2014", [0.0, 0.0, 0.0, 0.0, 30.0, 45.0], 7),
    ] {
        let m = embedded::load(name).unwrap();
        let inputs = Inputs::default();
        let exported = export::export(
            isg(),
            &request(&m, &inputs, TableSize::Points(points), pose),
        )
        .unwrap();
        let report = &exported.report;
        let control = model(&m, file(&exported.files, "volcomp_errors.csv"));
        let targets = dense(&m, report.grid.points[0]);
        let (max, rms) = residual(&m.at(&inputs), control, pose, &targets);
        assert!(
            (max - report.residual.max_mm).abs() < 1e-9,
            "{name}: {max} vs {:?}",
            report.residual
        );
        assert!((rms - report.residual.rms_mm).abs() < 1e-9, "{name}");
        assert!(max < report.before.max_mm, "{name}");
    }
}

#[test]
fn isg_folds_the_spindle_errors_into_the_last_axis() {
    // No ISG parameter takes the spindle errors: they go into the errors of the last axis
    // before the tool, exactly (E_Z · S). Z has no errors of its own here: E_Z' = S, so EXZ is
    // EXS and EAZ is EAS; the tilt's effect at the tool tip (100 mm) is held too.
    let m = machine(&HAND.replace("[axes.Z]", "[spindle]\nEXS = 0.003\nEAS = 2.0e-5\n[axes.Z]"));
    let inputs = Inputs::default();
    let exported =
        export::export(isg(), &request(&m, &inputs, TableSize::Default, [0.0; 6])).unwrap();
    let text = file(&exported.files, "volcomp_errors.csv");
    assert!(text.contains("// the spindle errors EXS = 0.003, EAS = 0.00002 have no ISG parameter: they are folded into the component errors of Z"), "{text}");
    let found = blocks(text);
    let block = |name: &str| {
        found
            .iter()
            .find(|b| b.0.iter().any(|h| h == name))
            .unwrap()
    };
    assert_eq!(block("EXZ").1, [[0.0, 0.003], [200.0, 0.003]]);
    assert_eq!(block("EAZ").1, [[0.0, 2.0e-5], [200.0, 2.0e-5]]);
    assert!(
        found.iter().all(|b| !b.0.contains(&"EYZ".to_string())),
        "a zero error not written"
    );
    let r = &exported.report;
    assert!(r.before.max_mm > 0.005);
    // As in the hand case, only the correction taking X past the end of its travel (here 3 µm
    // below 0, where the table holds EXX(0) while the polynomial goes on) leaves 1e-5 × 3 µm.
    assert!(r.residual.max_mm < 4e-8, "{:?}", r.residual);
}

#[test]
fn isg_lines_read_as_the_documented_forms() {
    let m = embedded::load("5axis-hwang2014").unwrap();
    let inputs = Inputs::default();
    let exported =
        export::export(isg(), &request(&m, &inputs, TableSize::Default, [0.0; 6])).unwrap();
    let csv = file(&exported.files, "volcomp_errors.csv");
    let known = |w: &str| -> bool {
        let c: Vec<char> = w.chars().collect();
        let axis = |c: char| "XYZABC".contains(c);
        match c[..] {
            [a] => axis(a),
            ['E', a, b] => axis(a) && axis(b),
            ['N', '0', a] => "XYZ".contains(a),
            [a, '0', b] => axis(a) && axis(b),
            _ => false,
        }
    };
    let mut columns = 0;
    let mut rows = 0;
    let mut names: BTreeMap<String, usize> = BTreeMap::new();
    for (n, line) in csv.lines().enumerate() {
        if line.starts_with("//") {
            continue;
        }
        if line == "#" {
            columns = 0;
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        if columns == 0 {
            assert!(words.iter().all(|w| known(w)), "line {}: {line}", n + 1);
            for w in words.iter().filter(|w| w.len() == 3) {
                *names.entry(w.to_string()).or_default() += 1;
            }
            columns = words.len();
        } else {
            assert_eq!(words.len(), columns, "line {}: {line}", n + 1);
            for w in &words {
                assert!(
                    w.parse::<f64>().is_ok() && !w.contains(['e', 'E', ',']),
                    "line {}: `{w}`",
                    n + 1
                );
            }
            rows += 1;
        }
    }
    assert!(
        names.values().all(|&k| k == 1),
        "every parameter in one block: {names:?}"
    );
    assert!(names.contains_key("EZB") && names.contains_key("X0C"));
    let startup = file(&exported.files, "hochlauf_volcomp.lis");
    assert!(startup.contains(&format!("{:<32} {rows}\n", "vol_comp[0].max_records")));
    for list in ["vol_comp_0.lis", "hochlauf_volcomp.lis"] {
        for line in file(&exported.files, list).lines() {
            if line.starts_with("# ") {
                continue;
            }
            let words: Vec<&str> = line.split_whitespace().collect();
            assert_eq!(words.len(), 2, "{list}: {line}");
        }
    }
}

#[test]
fn isg_refuses_an_error_of_three_axes() {
    let m = machine(&HAND.replace(
        "EBX = 3.0e-6",
        "EBX = 3.0e-6\nEZX = { sum = [{ poly = [0.0, 1.0e-6] }, { poly = [0.0, 1.0e-6], of = \"Y\" }, { poly = [0.0, 1.0e-6], of = \"Z\" }] }",
    ));
    let inputs = Inputs::default();
    let e = export::export(isg(), &request(&m, &inputs, TableSize::Default, [0.0; 6]))
        .err()
        .expect("refused")
        .to_string();
    assert_eq!(
        e,
        "the isg export cannot hold this machine's errors: EZX depends on 3 axes at once (X, Y, Z); volmap writes tables of at most two arguments"
    );
}

#[test]
fn isg_reading_back_names_the_file_and_line_of_what_does_not_read() {
    let m = machine(HAND);
    let inputs = Inputs::default();
    let fitting = export::Fitting::new(&m, &inputs, [0.0; 6], Vec::new()).unwrap();
    let written = isg().write(&fitting, Some([5, 5, 5]), None).unwrap();
    assert!(isg().read_for(&written, &fitting).is_ok());
    let broken = |name: &str, from: &str, to: &str| -> String {
        let mut files = written.clone();
        let f = files.iter_mut().find(|f| f.name == name).unwrap();
        assert!(f.text.contains(from), "{from}");
        f.text = f.text.replacen(from, to, 1);
        match isg().read_for(&files, &fitting) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{name}: `{to}` read"),
        }
    };
    let csv = "volcomp_errors.csv";
    let line_of = |text: &str| {
        1 + file(&written, csv)
            .lines()
            .position(|l| l.starts_with(text))
            .unwrap()
    };
    assert_eq!(
        broken(csv, "X                  EXX", "X                  EXQ"),
        format!(
            "reading back {csv}: line {}: `EXQ` is not an identifier of the ISG volumetric compensation",
            line_of("X                  EXX")
        )
    );
    assert_eq!(
        broken(csv, "400.000000         0.004000000", "400.000000"),
        format!(
            "reading back {csv}: line {}: 1 values under a header of 2 columns",
            line_of("400.000000         0.004000000")
        )
    );
    assert_eq!(
        broken(
            csv,
            "400.000000         0.004000000",
            "400.000000         4,0e-3"
        ),
        format!(
            "reading back {csv}: line {}: `4,0e-3` is not a number",
            line_of("400.000000         0.004000000")
        )
    );
    let chain = format!("{:<24} XYZ", "chain");
    assert!(
        broken("vol_comp_0.lis", &chain, &format!("{:<24} XZY", "chain"))
            .ends_with("chain XZY is not the machine's XYZ")
    );
    assert!(broken("vol_comp_0.lis", "ISG_CSV", "ETALON_EXCHANGE")
        .ends_with("file_format[0] ETALON_EXCHANGE: not ISG_CSV"));
}
