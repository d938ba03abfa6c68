//! `isg`: the input of the ISG kernel's volumetric compensation (Beckhoff TwinCAT 3 CNC, option
//! TF5280): the ISO 230-1 error parameters of the machine themselves, which the control
//! evaluates in its own kinematic model to correct the axis set points, not a grid of
//! corrections.
//!
//! Three files: the configuration list of compensation 0 (`vol_comp_0.lis`: axis assignment,
//! `chain`, `workpiece_axes`, `interpolation GRID`, the parameter file), the error parameters
//! in ISG CSV (`volcomp_errors.csv`: a block of the position errors and the tool vector, then
//! one block per component error tabulated against its arguments, blocks separated by `#`,
//! comment rows `//`), and the two lines of the start-up list that load them.
//!
//! The values are the machine's ERRORS (ISO 230-1, as volmap's model holds them), not
//! corrections: mm and rad, arguments in mm (X, Y, Z) and degrees (A, B, C). Each component
//! error is sampled at nodes chosen for it (free positions: GRID interpolation takes any
//! increasing nodes per argument) so that its piecewise-linear interpolation leaves the
//! smallest largest deviation; an error of two axes (`table2d`, `of`) is written on the full
//! grid of its two arguments. The control is taken to interpolate linearly between nodes and
//! to hold the end values outside them, and to run the same model as volmap: its command puts
//! the tip of volmap's model, with every error replaced by its interpolation from the written
//! nodes, on target ([`IsgControl`]).

use nalgebra::Vector3;

use super::parameters::{axis_numbers, isg_chain, Parameter, CONFIG, ERRORS};
use super::read::{check_files, IsgControl};
use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{breakpoints, Fitting, Structure};
use crate::export::format::{Control, Format, Layout, Limits, Nodes, Spec, WrittenFile};
use crate::export::nodes::{candidates, free_nodes};
use crate::model::{Axis, AxisLetter, Command, ErrorFunction, Machine, COMPONENT_NAMES};
use crate::reference::{error_transform, rot_about, spindle_error, Transform};

pub struct Isg;

const STARTUP: &str = "hochlauf_volcomp.lis";
/// Where the configuration list says the files lie on the control.
const FOLDER: &str = r"C:\volcomp\";
/// Positions of another argument a node choice looks at for an error of two axes.
const SLICES: usize = 11;

/// A value of a parameter: angles to 1e-12 rad, lengths to 1e-9 mm; `-0` written `0`.
pub fn value_text(v: f64, angular: bool) -> String {
    let text = if angular {
        format!("{v:.12}")
    } else {
        format!("{v:.9}")
    };
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

/// An argument's position: mm or degrees to 1e-6; `-0` written `0`.
pub fn position_text(v: f64) -> String {
    let text = format!("{v:.6}");
    if text == "-0.000000" {
        "0.000000".into()
    } else {
        text
    }
}

const SPEC: Spec = Spec {
    name: "isg",
    title: "ISG kernel / Beckhoff TwinCAT CNC volumetric compensation (ISO 230-1 error parameters, ISG CSV)",
    layout: Layout::Folder,
    limits: Limits {
        nodes: Nodes::Free,
        min_points: 2,
        max_points: 1001,
        min_spacing_mm: 0.0,
        default_points: 21,
        source: "volmap's limit per table; the control reads at most the max_records of its start-up list",
    },
    structure: Structure::Grid,
    holds: "the volumetric compensation holds the machine's geometric errors themselves (component errors as tables, position errors) and corrects the tool position at any pose, to within linear interpolation between the written nodes; not reversal (written at the approach asked), not temperature terms (written at the temperatures asked), not the tool orientation; the spindle errors, which have no ISG parameter, are folded into the errors of the last axis before the tool",
    uses_direction: false,
};

impl Format for Isg {
    fn spec(&self) -> &'static Spec {
        &SPEC
    }

    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError> {
        let points = points.unwrap_or([SPEC.limits.default_points; 3]);
        let machine = fitting.machine.at(fitting.inputs);
        let count = |b: AxisLetter| {
            if b.is_linear() {
                points[b.index()]
            } else {
                points.iter().copied().max().unwrap_or(2)
            }
        };
        let mut constants = Vec::new();
        let mut tables = Vec::new();
        // The spindle error has no ISG parameter: it is folded into the last axis before the
        // tool (in the order the transforms multiply).
        let last = *machine
            .chain
            .product_order()
            .last()
            .expect("a chain has axes");
        let spindle = spindle_error(&machine);
        let spindle_free = machine.spindle == [0.0; 5];
        for letter in AxisLetter::ALL {
            let Some(axis) = machine.axis(letter) else {
                continue;
            };
            for (c, &v) in COMPONENT_NAMES.iter().zip(&axis.location) {
                if v != 0.0 {
                    constants.push(Parameter {
                        name: format!("{c}0{letter}"),
                        arguments: Vec::new(),
                        nodes: Vec::new(),
                        values: vec![v],
                    });
                }
            }
            let folds = (!spindle_free && letter == last).then_some(&spindle);
            let mut args: Vec<AxisLetter> = axis
                .components
                .iter()
                .flatten()
                .flat_map(|f| arguments(f, letter))
                .collect();
            if folds.is_some() && !letter.is_linear() {
                args.push(letter);
            }
            args.sort_by_key(|a| a.index());
            args.dedup();
            for (n, c) in COMPONENT_NAMES.iter().enumerate() {
                let own = axis.components[n].as_ref().filter(|f| !f.is_zero());
                let value = |command: &Command| components(axis, folds, command)[n];
                let args = match (own, folds) {
                    (Some(f), None) => arguments(f, letter),
                    (_, Some(_)) => args.clone(),
                    (None, None) => continue,
                };
                if own.is_none() && {
                    let mut probe = [0.0; 6];
                    probe[letter.index()] = 0.5 * (axis.range[0] + axis.range[1]);
                    value(&probe) == 0.0
                } {
                    continue;
                }
                // A constant: a table of the axis's own two ends.
                let args = if args.is_empty() { vec![letter] } else { args };
                let name = format!("E{c}{letter}");
                tables.push(tabulate(&machine, name, args, &value, &count, spacing_mm)?);
            }
        }
        // The tool vector is a unit vector: the control takes the tool's length from the
        // active tool's data (TF5280, tool vector N0).
        for (d, v) in crate::export::tool_direction(&machine).iter().enumerate() {
            constants.push(Parameter {
                name: format!("N0{}", COMPONENT_NAMES[d]),
                arguments: Vec::new(),
                nodes: Vec::new(),
                values: vec![*v],
            });
        }
        let rows = usize::from(!constants.is_empty())
            + tables.iter().map(|t| t.values.len()).sum::<usize>();
        Ok(vec![
            WrittenFile {
                name: CONFIG.into(),
                text: config_text(fitting, &machine),
            },
            WrittenFile {
                name: ERRORS.into(),
                text: errors_text(fitting, &machine, &constants, &tables),
            },
            WrittenFile {
                name: STARTUP.into(),
                text: startup_text(fitting, rows),
            },
        ])
    }

    fn read(
        &self,
        files: &[WrittenFile],
        _travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError> {
        check_files(files)?;
        Err(read_error(
            CONFIG,
            0,
            "the ISG kernel models the machine with its own nominal kinematics, which these files do not carry: read them for a machine",
        ))
    }

    fn read_for(
        &self,
        files: &[WrittenFile],
        fitting: &Fitting,
    ) -> Result<Box<dyn Control>, ExportError> {
        Ok(Box::new(IsgControl::new(files, fitting)?))
    }
}

/// The axes an error value of axis `own` reads the position of, in the order X Y Z A B C.
pub fn arguments(f: &ErrorFunction, own: AxisLetter) -> Vec<AxisLetter> {
    fn collect(f: &ErrorFunction, own: AxisLetter, out: &mut Vec<AxisLetter>) {
        match f {
            ErrorFunction::Constant(_) => {}
            ErrorFunction::Poly(_) | ErrorFunction::Table(_) => out.push(own),
            ErrorFunction::Sum(terms) => terms.iter().for_each(|t| collect(t, own, out)),
            ErrorFunction::Of { axis, form } => collect(form, *axis, out),
            ErrorFunction::Table2d(t) => out.extend(t.axes),
        }
    }
    let mut out = Vec::new();
    collect(f, own, &mut out);
    out.sort_by_key(|a| a.index());
    out.dedup();
    out
}

/// `value` with the axes `arguments` at `at` (every other axis at 0).
fn eval(value: &dyn Fn(&Command) -> f64, arguments: &[AxisLetter], at: &[f64]) -> f64 {
    let mut command = [0.0; 6];
    for (a, v) in arguments.iter().zip(at) {
        command[a.index()] = *v;
    }
    value(&command)
}

/// The six component errors of `axis` at `command`, times `S` where the spindle error `S` is
/// folded into it (the last axis before the tool): `E'(q) = E(q) · S` for a linear axis,
/// `E(q) · Rot_u(q) · S · Rot_u(q)⁻¹` for a rotary one, so that `A(q) · S = L · Trans(q·u) ·
/// E'(q)`, resp. `L · E'(q) · Rot_u(q)`, exactly.
fn components(axis: &Axis, spindle: Option<&Transform>, command: &Command) -> [f64; 6] {
    let q = command[axis.letter.index()];
    let e = axis.component_values_at(q, command);
    let Some(s) = spindle else {
        return e;
    };
    let folded = if axis.letter.is_linear() {
        error_transform(e) * s
    } else {
        let r = rot_about(Vector3::from(axis.unit_vector()), q.to_radians());
        error_transform(e) * r * s * r.transpose()
    };
    let m = folded;
    // Rot(a, b, c) = Rx(a)·Ry(b)·Rz(c): m02 = sin b, m12 = −sin a cos b, m01 = −cos b sin c.
    [
        m[(0, 3)],
        m[(1, 3)],
        m[(2, 3)],
        (-m[(1, 2)]).atan2(m[(2, 2)]),
        m[(0, 2)].clamp(-1.0, 1.0).asin(),
        (-m[(0, 1)]).atan2(m[(0, 0)]),
    ]
}

/// An error tabulated for the control: `args`, the axes it depends on (at most two), nodes
/// chosen per argument (`count(b)` of them, equidistant at `spacing_mm` along a linear axis
/// where asked), `value` on the full grid of the nodes.
fn tabulate(
    machine: &Machine,
    name: String,
    args: Vec<AxisLetter>,
    value: &dyn Fn(&Command) -> f64,
    count: &dyn Fn(AxisLetter) -> usize,
    spacing_mm: Option<f64>,
) -> Result<Parameter, ExportError> {
    if args.len() > 2 {
        return Err(ExportError::Unrepresentable {
            format: SPEC.name,
            message: format!(
                "{name} depends on {} axes at once ({}); volmap writes tables of at most two arguments",
                args.len(),
                args.iter().map(|a| a.to_string()).collect::<Vec<_>>().join(", ")
            ),
        });
    }
    let range = |b: AxisLetter| machine.axis(b).map_or([0.0, 0.0], |a| a.range);
    let mut nodes = Vec::new();
    for (i, &b) in args.iter().enumerate() {
        let [lo, hi] = range(b);
        let chosen = match spacing_mm {
            Some(s) if b.is_linear() => {
                let n = ((hi - lo) / s - 1e-9).ceil().max(1.0) as usize + 1;
                (0..n).map(|k| lo + k as f64 * s).collect()
            }
            _ => {
                let n = count(b).max(2);
                let m = (4 * (n - 1) + 1).clamp(101, if args.len() == 1 { 401 } else { 201 });
                let q = candidates(lo, hi, m, &breakpoints(machine, b));
                // The curves along `b`: at slices of the other argument, if any.
                let slices: Vec<f64> = match args.get(1 - i) {
                    Some(&other) if args.len() == 2 => {
                        let [olo, ohi] = range(other);
                        candidates(olo, ohi, SLICES, &breakpoints(machine, other))
                    }
                    _ => vec![0.0],
                };
                let curves: Vec<Vec<f64>> = slices
                    .iter()
                    .map(|&s| {
                        q.iter()
                            .map(|&x| {
                                let mut at = vec![0.0; args.len()];
                                at[i] = x;
                                if args.len() == 2 {
                                    at[1 - i] = s;
                                }
                                eval(value, &args, &at)
                            })
                            .collect()
                    })
                    .collect();
                let refs: Vec<&[f64]> = curves.iter().map(Vec::as_slice).collect();
                free_nodes(&q, &refs, n, 0.0, 0.0)
                    .into_iter()
                    .map(|k| q[k])
                    .collect()
            }
        };
        nodes.push(chosen);
    }
    let mut values = Vec::new();
    match nodes.len() {
        1 => {
            for &x in &nodes[0] {
                values.push(eval(value, &args, &[x]));
            }
        }
        _ => {
            for &x in &nodes[0] {
                for &y in &nodes[1] {
                    values.push(eval(value, &args, &[x, y]));
                }
            }
        }
    }
    Ok(Parameter {
        name,
        arguments: args,
        nodes,
        values,
    })
}

fn config_text(fitting: &Fitting, machine: &Machine) -> String {
    let mut text = String::new();
    for line in &fitting.header {
        text += &format!("# {line}\n");
    }
    text += "# volmap isg: configuration list of volumetric compensation 0 (TF5280, P-VOLC parameters)\n";
    text += "# logical axis numbers: set them to the control's (or give LNX... in the parameter file)\n";
    let key = |k: &str, v: &str| format!("{k:<24} {v}\n");
    for (letter, n) in axis_numbers(machine) {
        text += &key(&letter.to_string(), &n.to_string());
    }
    let (chain, workpiece) = isg_chain(machine);
    text += "# the chain from the workpiece to the tool; the first workpiece_axes carry the workpiece\n";
    text += &key("chain", &chain);
    text += &key("workpiece_axes", &workpiece.to_string());
    text += &key("interpolation", "GRID");
    text += &key("enable_splicing", "FALSE");
    text += &key("manual_activation", "FALSE");
    text += &key("alternative_model", "FALSE");
    text += &key("file[0]", &format!("{FOLDER}{ERRORS}"));
    text += &key("file_format[0]", "ISG_CSV");
    text
}

fn errors_text(
    fitting: &Fitting,
    machine: &Machine,
    constants: &[Parameter],
    tables: &[Parameter],
) -> String {
    let mut text = String::new();
    for line in &fitting.header {
        text += &format!("// {line}\n");
    }
    text += "// volmap isg: the ISO 230-1 error parameters of the machine for the ISG volumetric compensation (ISG CSV)\n";
    text += "// values: the machine's ERRORS, not corrections; lengths mm, angles rad; arguments mm (X Y Z), degrees (A B C)\n";
    text += "// between nodes linear (interpolation GRID); every parameter in one block\n";
    let spindle: Vec<String> = machine
        .spindle
        .iter()
        .zip(crate::model::perturbation::SPINDLE_NAMES)
        .filter(|(v, _)| **v != 0.0)
        .map(|(v, name)| format!("{name} = {v}"))
        .collect();
    if !spindle.is_empty() {
        let last = machine.chain.product_order().last().copied();
        text += &format!(
            "// the spindle errors {} have no ISG parameter: they are folded into the component errors of {}, the last axis\n",
            spindle.join(", "),
            last.map_or(String::new(), |a| a.to_string())
        );
        text += "// before the tool (E'(q) = E(q)*S; for a rotary axis E(q)*Rot(q)*S*Rot(q)^-1): those are the errors of both together\n";
    }
    let row = |cells: &[String]| -> String {
        let line: String = cells.iter().map(|c| format!("{c:<18} ")).collect();
        line.trim_end().to_string() + "\n"
    };
    let mut first = true;
    if !constants.is_empty() {
        text +=
            "// position errors and the tool vector N0 (the tool tip in the spindle frame, mm)\n";
        text += &row(&constants.iter().map(|p| p.name.clone()).collect::<Vec<_>>());
        text += &row(&constants
            .iter()
            .map(|p| value_text(p.values[0], p.is_angular()))
            .collect::<Vec<_>>());
        first = false;
    }
    for p in tables {
        if !first {
            text += "#\n";
        }
        first = false;
        let sizes: Vec<String> = p.nodes.iter().map(|n| n.len().to_string()).collect();
        text += &format!(
            "// {}: {} nodes over {}\n",
            p.name,
            sizes.join(" x "),
            p.arguments
                .iter()
                .map(|a| a.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        let mut header: Vec<String> = p.arguments.iter().map(|a| a.to_string()).collect();
        header.push(p.name.clone());
        text += &row(&header);
        let mut k = 0;
        let inner = p.nodes.get(1).map_or(1, Vec::len);
        for (i, &x) in p.nodes[0].iter().enumerate() {
            for j in 0..inner {
                let mut cells = vec![position_text(x)];
                if inner > 1 || p.nodes.len() == 2 {
                    cells.push(position_text(p.nodes[1][j]));
                }
                cells.push(value_text(p.values[k], p.is_angular()));
                debug_assert_eq!(k, i * inner + j);
                k += 1;
                text += &row(&cells);
            }
        }
    }
    text
}

fn startup_text(fitting: &Fitting, rows: usize) -> String {
    let mut text = String::new();
    for line in &fitting.header {
        text += &format!("# {line}\n");
    }
    text += "# volmap isg: the lines of the start-up list (hochlauf.lis) that load volumetric compensation 0\n";
    text +=
        &format!("# max_records: the data rows of {ERRORS} ({rows}); raise it if the file grows\n");
    text += &format!("{:<32} {rows}\n", "vol_comp[0].max_records");
    text += &format!("{:<32} {FOLDER}{CONFIG}\n", "vol_comp[0].file_name");
    text
}
