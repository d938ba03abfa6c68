//! Reading the `siemens` programs back as the SINUMERIK loads them: the program header line,
//! `;` comments, `CHANDATA(1)`, one system-variable assignment per line, `M17` last. A table
//! has `(MAX − MIN)/STEP + 1` points (an integer count: volmap writes nothing else); values at
//! points beyond that count have no effect; a point of the range without a value is refused
//! (the control would keep whatever an earlier load left there).

use std::collections::BTreeMap;

use super::tables::{
    Grid, Loaded, Sinumerik, CEC_FILE, CEC_PROGRAM, MACHINE_AXES, MSEC_FILE, MSEC_PROGRAM,
};
use crate::export::error::{read_error, ExportError};
use crate::export::format::WrittenFile;
use crate::export::nodes::{equidistant, Pwl};

/// One assignment `$NAME[i,j,..]=value` and the line it is on.
struct Assignment {
    line: usize,
    name: String,
    indices: Vec<String>,
    value: String,
}

/// The assignments of one program, checked for its frame.
fn assignments(file: &WrittenFile, program: &str) -> Result<Vec<Assignment>, ExportError> {
    let name = file.name.as_str();
    let mut lines = file.text.lines().enumerate();
    match lines.next() {
        Some((_, first)) if first.trim_end() == program => {}
        _ => {
            return Err(read_error(
                name,
                1,
                format!("the program does not start with {program}"),
            ))
        }
    }
    let mut out = Vec::new();
    let mut ended = false;
    for (n, raw) in lines {
        let line = n + 1;
        let code = raw.split(';').next().unwrap_or("").trim();
        if code.is_empty() {
            continue;
        }
        if ended {
            return Err(read_error(
                name,
                line,
                "a block after M17, the program's end",
            ));
        }
        match code {
            "CHANDATA(1)" => {}
            "M17" => ended = true,
            _ => out.push(assignment(code, line).ok_or_else(|| {
                read_error(
                    name,
                    line,
                    format!("`{code}` is not an assignment $NAME[..]=VALUE"),
                )
            })?),
        }
    }
    if !ended {
        return Err(read_error(
            name,
            file.text.lines().count(),
            "the program does not end with M17",
        ));
    }
    Ok(out)
}

fn assignment(code: &str, line: usize) -> Option<Assignment> {
    let rest = code.strip_prefix('$')?;
    let (name, rest) = rest.split_once('[')?;
    let (indices, rest) = rest.split_once(']')?;
    let value = rest.trim_start().strip_prefix('=')?.trim();
    let name = name.trim();
    if name.is_empty() || value.is_empty() {
        return None;
    }
    Some(Assignment {
        line,
        name: name.to_string(),
        indices: indices.split(',').map(|i| i.trim().to_string()).collect(),
        value: value.to_string(),
    })
}

/// What one table's assignments gave.
#[derive(Default)]
struct Pending {
    line: usize,
    values: BTreeMap<usize, f64>,
    step: Option<f64>,
    min: Option<f64>,
    max: Option<f64>,
    input: Option<usize>,
    output: Option<usize>,
    direction: i8,
    at_actual: bool,
}

fn number(file: &str, a: &Assignment) -> Result<f64, ExportError> {
    a.value
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            read_error(
                file,
                a.line,
                format!("${}: `{}` is not a number", a.name, a.value),
            )
        })
}

fn index(file: &str, a: &Assignment, at: usize, what: &str) -> Result<usize, ExportError> {
    a.indices
        .get(at)
        .and_then(|i| i.parse().ok())
        .ok_or_else(|| {
            read_error(
                file,
                a.line,
                format!("${}: the {what} index is not a number", a.name),
            )
        })
}

/// The linear axis of a machine axis name, as volmap writes them.
fn axis(file: &str, a: &Assignment, name: &str) -> Result<usize, ExportError> {
    MACHINE_AXES.iter().position(|m| *m == name).ok_or_else(|| {
        read_error(
            file,
            a.line,
            format!(
                "${}: `{name}` is not a machine axis volmap writes ({})",
                a.name,
                MACHINE_AXES.join(", ")
            ),
        )
    })
}

fn indices(file: &str, a: &Assignment, count: usize) -> Result<(), ExportError> {
    if a.indices.len() == count {
        Ok(())
    } else {
        Err(read_error(
            file,
            a.line,
            format!("${} takes {count} indices, not {}", a.name, a.indices.len()),
        ))
    }
}

/// A flag that must be zero: volmap reads no modulo or product tables.
fn zero(file: &str, a: &Assignment) -> Result<(), ExportError> {
    if number(file, a)? == 0.0 {
        Ok(())
    } else {
        Err(read_error(
            file,
            a.line,
            format!("${}={}: volmap reads only 0 here", a.name, a.value),
        ))
    }
}

/// The table a pending one makes, checked as the control's loading would.
fn table(file: &str, name: String, p: Pending) -> Result<Loaded, ExportError> {
    let missing = |what: &str| read_error(file, p.line, format!("{name}: no {what}"));
    let step = p.step.ok_or_else(|| missing("STEP"))?;
    let min = p.min.ok_or_else(|| missing("MIN"))?;
    let max = p.max.ok_or_else(|| missing("MAX"))?;
    let input = p.input.ok_or_else(|| missing("INPUT_AXIS"))?;
    let output = p.output.ok_or_else(|| missing("OUTPUT_AXIS"))?;
    if !(step > 0.0 && max > min) {
        return Err(read_error(
            file,
            p.line,
            format!("{name}: STEP {step} and MIN {min} < MAX {max} are needed"),
        ));
    }
    let k = (max - min) / step;
    if (k - k.round()).abs() > 1e-6 * k.max(1.0) {
        return Err(read_error(
            file,
            p.line,
            format!("{name}: (MAX - MIN) / STEP = {k} is not a whole number of steps"),
        ));
    }
    let points = k.round() as usize + 1;
    let mut values = Vec::with_capacity(points);
    for n in 0..points {
        values.push(*p.values.get(&n).ok_or_else(|| {
            read_error(
                file,
                p.line,
                format!("{name}: interpolation point {n} has no value (the control would keep an earlier one)"),
            )
        })?);
    }
    let grid = Grid { min, step, points };
    Ok(Loaded {
        name,
        input,
        output,
        direction: p.direction,
        at_actual: p.at_actual,
        grid,
        error: Pwl {
            q: equidistant(min, step, points),
            v: values,
        },
    })
}

fn read_msec(file: &WrittenFile) -> Result<Vec<Loaded>, ExportError> {
    let f = file.name.as_str();
    let mut pending: BTreeMap<usize, Pending> = BTreeMap::new();
    for a in assignments(file, MSEC_PROGRAM)? {
        let per_point = a.name == "AA_ENC_COMP";
        indices(f, &a, if per_point { 3 } else { 2 })?;
        if index(f, &a, 0, "measuring system")? != 0 {
            return Err(read_error(
                f,
                a.line,
                format!(
                    "${}: volmap writes measuring system 1 (index 0) only",
                    a.name
                ),
            ));
        }
        let k = axis(f, &a, a.indices.last().expect("counted"))?;
        let p = pending.entry(k).or_insert_with(|| Pending {
            line: a.line,
            input: Some(k),
            output: Some(k),
            at_actual: true,
            ..Pending::default()
        });
        match a.name.as_str() {
            "AA_ENC_COMP" => {
                let n = index(f, &a, 1, "interpolation point")?;
                p.values.insert(n, number(f, &a)?);
            }
            "AA_ENC_COMP_STEP" => p.step = Some(number(f, &a)?),
            "AA_ENC_COMP_MIN" => p.min = Some(number(f, &a)?),
            "AA_ENC_COMP_MAX" => p.max = Some(number(f, &a)?),
            "AA_ENC_COMP_IS_MODULO" => zero(f, &a)?,
            other => {
                return Err(read_error(
                    f,
                    a.line,
                    format!(
                        "${other} is not a variable of the measuring-system error compensation"
                    ),
                ))
            }
        }
    }
    pending
        .into_iter()
        .map(|(k, p)| table(f, format!("MSEC {}", MACHINE_AXES[k]), p))
        .collect()
}

fn read_cec(file: &WrittenFile) -> Result<Vec<Loaded>, ExportError> {
    let f = file.name.as_str();
    let mut pending: BTreeMap<usize, Pending> = BTreeMap::new();
    for a in assignments(file, CEC_PROGRAM)? {
        let per_point = a.name == "AN_CEC";
        indices(f, &a, if per_point { 2 } else { 1 })?;
        let t = index(f, &a, 0, "table")?;
        let p = pending.entry(t).or_insert_with(|| Pending {
            line: a.line,
            ..Pending::default()
        });
        let axis_value = || {
            a.value
                .strip_prefix('(')
                .and_then(|v| v.strip_suffix(')'))
                .map(str::trim)
                .ok_or_else(|| {
                    read_error(
                        f,
                        a.line,
                        format!("${}: `{}` is not an axis `(NAME)`", a.name, a.value),
                    )
                })
        };
        match a.name.as_str() {
            "AN_CEC" => {
                let n = index(f, &a, 1, "interpolation point")?;
                p.values.insert(n, number(f, &a)?);
            }
            "AN_CEC_INPUT_AXIS" => p.input = Some(axis(f, &a, axis_value()?)?),
            "AN_CEC_OUTPUT_AXIS" => p.output = Some(axis(f, &a, axis_value()?)?),
            "AN_CEC_STEP" => p.step = Some(number(f, &a)?),
            "AN_CEC_MIN" => p.min = Some(number(f, &a)?),
            "AN_CEC_MAX" => p.max = Some(number(f, &a)?),
            "AN_CEC_DIRECTION" => {
                p.direction = match a.value.as_str() {
                    "0" => 0,
                    "1" => 1,
                    "-1" => -1,
                    other => {
                        return Err(read_error(
                            f,
                            a.line,
                            format!("$AN_CEC_DIRECTION: `{other}` is not -1, 0 or 1"),
                        ))
                    }
                }
            }
            "AN_CEC_MULT_BY_TABLE" | "AN_CEC_IS_MODULO" => zero(f, &a)?,
            other => {
                return Err(read_error(
                    f,
                    a.line,
                    format!("${other} is not a variable of the sag/cross compensation"),
                ))
            }
        }
    }
    pending
        .into_iter()
        .map(|(t, p)| table(f, format!("CEC {t}"), p))
        .collect()
}

/// Reads the programs of a `siemens` export.
pub fn read(files: &[WrittenFile]) -> Result<Sinumerik, ExportError> {
    let mut tables = Vec::new();
    let mut msec = false;
    for file in files {
        match file.name.as_str() {
            MSEC_FILE => {
                msec = true;
                tables.extend(read_msec(file)?);
            }
            CEC_FILE => tables.extend(read_cec(file)?),
            other => return Err(read_error(other, 1, "not a program of a siemens export")),
        }
    }
    if !msec {
        return Err(read_error(MSEC_FILE, 1, "the program is missing"));
    }
    Ok(Sinumerik { tables })
}
