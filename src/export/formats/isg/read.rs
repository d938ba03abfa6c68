//! Reading an `isg` export back as the ISG kernel reads it: the configuration list (`key value`
//! lines, `#` comment lines), the ISG CSV parameter file (a header row naming arguments and
//! parameters, rows of numbers, `//` comment rows, `#` file breaks; with GRID interpolation
//! every block on the full grid of its arguments), and the control's model: volmap's nominal
//! machine (the control's own kinematic configuration) with every error parameter replaced by
//! its piecewise-linear interpolation from the nodes read, end values held outside them.

use std::collections::{BTreeMap, BTreeSet};

use super::parameters::{axis_numbers, isg_chain, Parameter, CONFIG, ERRORS};
use crate::export::error::{read_error, ExportError};
use crate::export::fitting::{Field, Fitting};
use crate::export::format::{self, Control, TableInfo, WrittenFile};
use crate::model::inputs::Approach;
use crate::model::table2d::Table2d;
use crate::model::{AxisLetter, Command, ErrorFunction, Interp, Table, COMPONENT_NAMES};

/// The configuration list: lower-case key → (line, value).
pub type Config = BTreeMap<String, (usize, String)>;

/// A parameter read back and the line of its block's header.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadParameter {
    pub parameter: Parameter,
    pub line: usize,
}

fn find<'a>(files: &'a [WrittenFile], name: &str) -> Result<&'a WrittenFile, ExportError> {
    files
        .iter()
        .find(|f| f.name == name)
        .ok_or_else(|| read_error(name, 0, "the file is missing"))
}

/// Reads the configuration list.
pub fn read_config(file: &WrittenFile) -> Result<Config, ExportError> {
    let mut out = BTreeMap::new();
    for (i, raw) in file.text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        // End-of-line comments follow a blank: `#`, `/*` or `(`.
        let mut words = Vec::new();
        for word in line.split_whitespace() {
            if word.starts_with('#') || word.starts_with("/*") || word.starts_with('(') {
                break;
            }
            words.push(word);
        }
        let [key, value] = words[..] else {
            return Err(read_error(
                &file.name,
                i + 1,
                format!("`{line}`: expected a key and a value"),
            ));
        };
        if out
            .insert(key.to_ascii_lowercase(), (i + 1, value.to_string()))
            .is_some()
        {
            return Err(read_error(
                &file.name,
                i + 1,
                format!("`{key}` given twice"),
            ));
        }
    }
    Ok(out)
}

/// Whether `name` names an argument: an axis position.
fn argument(name: &str) -> Option<AxisLetter> {
    let mut chars = name.chars();
    match (chars.next(), chars.next()) {
        (Some(c), None) => AxisLetter::from_char(c),
        _ => None,
    }
}

/// What an ISG parameter name is: `Ok(())` for those volmap writes (component errors,
/// position errors, the tool vector), an error message for the rest.
fn check_name(name: &str) -> Result<(), String> {
    let axis = |c: u8| b"XYZABC".contains(&c);
    let linear = |c: u8| b"XYZ".contains(&c);
    match name.as_bytes() {
        [b'E', c, a] if axis(*c) && axis(*a) => Ok(()),
        [c, b'0', a] if axis(*c) && axis(*a) => Ok(()),
        [b'N', b'0', c] if linear(*c) => Ok(()),
        [b'P', b'0', c] | [b'I', b'D', c] if linear(*c) => Err(format!(
            "`{name}` is an ISG parameter volmap does not write"
        )),
        [b'P', c, a] | [b'V', c, a] if linear(*c) && axis(*a) => Err(format!(
            "`{name}` is an ISG parameter volmap does not write"
        )),
        [b'L', b'N', a] if axis(*a) => Err(format!(
            "`{name}` is an ISG parameter volmap does not write"
        )),
        _ => Err(format!(
            "`{name}` is not an identifier of the ISG volumetric compensation"
        )),
    }
}

/// The ISG CSV parameter file, block by block.
pub fn read_errors(file: &WrittenFile) -> Result<Vec<ReadParameter>, ExportError> {
    let name = &file.name;
    let mut out: Vec<ReadParameter> = Vec::new();
    let mut header: Option<(usize, Vec<String>)> = None;
    let mut rows: Vec<(usize, Vec<f64>)> = Vec::new();
    let mut lines: Vec<(usize, &str)> = file
        .text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .collect();
    lines.push((lines.len() + 1, "#"));
    for (n, line) in lines {
        if line.is_empty() || line.starts_with("//") {
            continue;
        }
        if line.starts_with('#') {
            if let Some((at, names)) = header.take() {
                finish_block(name, at, &names, &rows, &mut out)?;
            }
            rows.clear();
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        match &header {
            None => {
                let mut seen = BTreeSet::new();
                for w in &words {
                    if argument(w).is_none() {
                        check_name(w).map_err(|m| read_error(name, n, m))?;
                    }
                    if !seen.insert(*w) {
                        return Err(read_error(name, n, format!("column `{w}` named twice")));
                    }
                }
                header = Some((n, words.iter().map(|w| w.to_string()).collect()));
            }
            Some((_, names)) => {
                if words.len() != names.len() {
                    return Err(read_error(
                        name,
                        n,
                        format!(
                            "{} values under a header of {} columns",
                            words.len(),
                            names.len()
                        ),
                    ));
                }
                let values = words
                    .iter()
                    .map(|w| {
                        w.parse::<f64>()
                            .ok()
                            .filter(|v| v.is_finite())
                            .ok_or_else(|| read_error(name, n, format!("`{w}` is not a number")))
                    })
                    .collect::<Result<Vec<f64>, _>>()?;
                rows.push((n, values));
            }
        }
    }
    Ok(out)
}

/// One block read: its parameters, each on the full grid of the block's arguments.
fn finish_block(
    name: &str,
    at: usize,
    names: &[String],
    rows: &[(usize, Vec<f64>)],
    out: &mut Vec<ReadParameter>,
) -> Result<(), ExportError> {
    let args: Vec<(usize, AxisLetter)> = names
        .iter()
        .enumerate()
        .filter_map(|(i, n)| argument(n).map(|a| (i, a)))
        .collect();
    let params: Vec<usize> = (0..names.len())
        .filter(|&i| argument(&names[i]).is_none())
        .collect();
    if params.is_empty() {
        return Err(read_error(name, at, "a header without a parameter"));
    }
    if rows.is_empty() {
        return Err(read_error(name, at, "a header without rows"));
    }
    let nodes: Vec<Vec<f64>> = args
        .iter()
        .map(|&(i, _)| {
            let mut q: Vec<f64> = rows.iter().map(|r| r.1[i]).collect();
            q.sort_by(f64::total_cmp);
            q.dedup();
            q
        })
        .collect();
    let size: usize = nodes.iter().map(Vec::len).product();
    if rows.len() != size {
        return Err(read_error(
            name,
            at,
            format!(
                "the parameter values are not on a grid: {} rows for {} nodes",
                rows.len(),
                size
            ),
        ));
    }
    let mut index_of = vec![usize::MAX; size];
    for (r, (line, row)) in rows.iter().enumerate() {
        let mut index = 0;
        for (k, &(i, _)) in args.iter().enumerate() {
            let p = nodes[k].partition_point(|&q| q < row[i]);
            index = index * nodes[k].len() + p;
        }
        if index_of[index] != usize::MAX {
            return Err(read_error(name, *line, "a grid point given twice"));
        }
        index_of[index] = r;
    }
    for &p in &params {
        if out.iter().any(|o| o.parameter.name == names[p]) {
            return Err(read_error(
                name,
                at,
                format!("`{}` given in two blocks", names[p]),
            ));
        }
        out.push(ReadParameter {
            parameter: Parameter {
                name: names[p].clone(),
                arguments: args.iter().map(|a| a.1).collect(),
                nodes: nodes.clone(),
                values: index_of.iter().map(|&r| rows[r].1[p]).collect(),
            },
            line: at,
        });
    }
    Ok(())
}

/// Reads and checks the configuration list and the parameter file (what the control can do
/// without the machine).
pub fn check_files(files: &[WrittenFile]) -> Result<(Config, Vec<ReadParameter>), ExportError> {
    let config = read_config(find(files, CONFIG)?)?;
    let get = |key: &str| config.get(key).map(|(l, v)| (*l, v.as_str()));
    match get("interpolation") {
        Some((_, v)) if v.eq_ignore_ascii_case("GRID") => {}
        Some((l, v)) => {
            return Err(read_error(
                CONFIG,
                l,
                format!("interpolation {v}: volmap models GRID"),
            ))
        }
        None => {}
    }
    if let Some((l, v)) = get("file_format[0]") {
        if !v.eq_ignore_ascii_case("ISG_CSV") {
            return Err(read_error(
                CONFIG,
                l,
                format!("file_format[0] {v}: not ISG_CSV"),
            ));
        }
    }
    let (l, path) = get("file[0]").ok_or_else(|| read_error(CONFIG, 0, "no file[0]"))?;
    let file_name = path.rsplit(['\\', '/']).next().unwrap_or(path);
    let errors = files
        .iter()
        .find(|f| f.name == file_name)
        .ok_or_else(|| read_error(CONFIG, l, format!("file[0] {path}: no such file written")))?;
    Ok((config, read_errors(errors)?))
}

/// The parameter as an error function of volmap's model: linear between the nodes, the end
/// values outside; an argument with one node is constant along it.
fn function(p: &ReadParameter, own: AxisLetter) -> Result<ErrorFunction, ExportError> {
    let err = |m: String| read_error(ERRORS, p.line, format!("{}: {m}", p.parameter.name));
    let q = &p.parameter;
    let kept: Vec<usize> = (0..q.arguments.len())
        .filter(|&k| q.nodes[k].len() > 1)
        .collect();
    // The values with the single-node arguments dropped (their index is always 0).
    let values = &q.values;
    match kept[..] {
        [] => Ok(ErrorFunction::Constant(values[0])),
        [k] => {
            let nodes: Vec<(f64, f64)> = q.nodes[k]
                .iter()
                .copied()
                .zip(values.iter().copied())
                .collect();
            let table = Table::new(nodes, Interp::Linear, false).map_err(|e| err(e.to_string()))?;
            let axis = q.arguments[k];
            Ok(if axis == own {
                ErrorFunction::Table(table)
            } else {
                ErrorFunction::Of {
                    axis,
                    form: Box::new(ErrorFunction::Table(table)),
                }
            })
        }
        [a, b] => {
            let rows: Vec<Vec<f64>> = values
                .chunks(q.nodes[b].len())
                .map(<[f64]>::to_vec)
                .collect();
            let t = Table2d::new(
                [q.arguments[a], q.arguments[b]],
                q.nodes[a].clone(),
                q.nodes[b].clone(),
                rows,
            )
            .map_err(|e| err(e.to_string()))?;
            Ok(ErrorFunction::Table2d(t))
        }
        _ => Err(err("volmap reads tables of at most two arguments".into())),
    }
}

/// The control: volmap's nominal machine with the error parameters read.
pub struct IsgControl {
    field: Field,
    tables: Vec<TableInfo>,
}

impl IsgControl {
    /// Reads the files for the machine of `fitting` (its nominal kinematics standing for the
    /// control's own configuration, which must say the same chain).
    pub fn new(files: &[WrittenFile], fitting: &Fitting) -> Result<IsgControl, ExportError> {
        let (config, parameters) = check_files(files)?;
        let nominal = fitting.machine.at(fitting.inputs).without_errors();
        let (chain, workpiece) = isg_chain(&nominal);
        let get = |key: &str| {
            config
                .get(key)
                .ok_or_else(|| read_error(CONFIG, 0, format!("no `{key}`")))
        };
        let (l, c) = get("chain")?;
        if *c != chain {
            return Err(read_error(
                CONFIG,
                *l,
                format!("chain {c} is not the machine's {chain}"),
            ));
        }
        let (l, w) = get("workpiece_axes")?;
        if w.parse::<usize>().ok() != Some(workpiece) {
            return Err(read_error(
                CONFIG,
                *l,
                format!("workpiece_axes {w}: the machine has {workpiece}"),
            ));
        }
        for (letter, _) in axis_numbers(&nominal) {
            get(&letter.to_string().to_ascii_lowercase())?;
        }
        // The tool's length is the active tool's (the machine's, as asked); the files give its
        // direction.
        let tool_length_mm = crate::export::tool_length_mm(fitting.machine);
        let mut machine = nominal;
        machine.tool_offset_mm = [0.0; 3];
        let mut direction: Option<(usize, [f64; 3])> = None;
        let mut tables = Vec::new();
        let mut constants = 0;
        for p in &parameters {
            let q = &p.parameter;
            let err = |m: &str| read_error(ERRORS, p.line, format!("{}: {m}", q.name));
            let b = q.name.as_bytes();
            let index = |c: u8| COMPONENT_NAMES.iter().position(|&n| n as u8 == c);
            let axis_of =
                |c: u8| AxisLetter::from_char(c as char).filter(|&a| machine.chain.contains(a));
            match b {
                [b'E', c, a] => {
                    let own = axis_of(*a).ok_or_else(|| err("no such axis in the chain"))?;
                    for arg in &q.arguments {
                        if !machine.chain.contains(*arg) {
                            return Err(err(&format!(
                                "argument {arg} is not an axis of the chain"
                            )));
                        }
                    }
                    let f = function(p, own)?;
                    let n = index(*c).expect("checked name");
                    machine.axis_mut(own).expect("in the chain").components[n] = Some(f);
                    let sizes: Vec<String> = q.nodes.iter().map(|n| n.len().to_string()).collect();
                    let spans: Vec<String> = q
                        .arguments
                        .iter()
                        .zip(&q.nodes)
                        .map(|(a, n)| format!("{a} {}..{}", n[0], n[n.len() - 1]))
                        .collect();
                    tables.push(TableInfo {
                        name: q.name.clone(),
                        size: format!("{} nodes over {}", sizes.join(" x "), spans.join(", ")),
                        points: q.nodes.iter().map(Vec::len).max().unwrap_or(1),
                        corrects: format::EVERY_COMPONENT,
                    });
                }
                [c, b'0', a] | [b'N', c @ b'0', a]
                    if q.arguments.is_empty() || q.nodes.iter().all(|n| n.len() == 1) =>
                {
                    let v = q.values[0];
                    constants += 1;
                    if b[0] == b'N' {
                        let _ = c;
                        let d = index(*a)
                            .filter(|&d| d < 3)
                            .ok_or_else(|| err("tool vector component"))?;
                        let (_, n) = direction.get_or_insert((p.line, [0.0; 3]));
                        n[d] = v;
                    } else {
                        let own = axis_of(*a).ok_or_else(|| err("no such axis in the chain"))?;
                        let n = index(*c).expect("checked name");
                        machine.axis_mut(own).expect("in the chain").location[n] = v;
                    }
                }
                _ => {
                    return Err(err(
                        "volmap reads position errors and the tool vector as constants only",
                    ))
                }
            }
        }
        if let Some((line, n)) = direction {
            let norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            // Written to 1e-9: a unit vector within rounding.
            if (norm - 1.0).abs() > 1e-6 {
                return Err(read_error(
                    ERRORS,
                    line,
                    format!("the tool vector N0 ({}, {}, {}) is not a unit vector (length {norm}): the control takes the tool's length from its tool data", n[0], n[1], n[2]),
                ));
            }
            machine.tool_offset_mm = n.map(|c| c / norm * tool_length_mm);
        } else if tool_length_mm > 0.0 {
            return Err(read_error(ERRORS, 0, "no tool vector N0X, N0Y, N0Z"));
        }
        if constants > 0 {
            tables.insert(
                0,
                TableInfo {
                    name: "constants".into(),
                    size: format!("{constants} position errors and tool vector components"),
                    points: 1,
                    corrects: format::EVERY_COMPONENT,
                },
            );
        }
        let field = Field::new(machine, fitting.pose)?;
        Ok(IsgControl { field, tables })
    }
}

impl Control for IsgControl {
    fn command(&self, target: &Command, _approach: &[Approach; 6]) -> Command {
        let mut c = *target;
        if let Ok(d) = self.field.correction([target[0], target[1], target[2]]) {
            for k in 0..3 {
                c[k] += d[k];
            }
        }
        c
    }

    fn tables(&self) -> Vec<TableInfo> {
        self.tables.clone()
    }
}
