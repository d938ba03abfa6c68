//! The measurements of one axis for `volmap build`: the CSV an interferometer's software exports,
//! a header row naming the position (`position_mm`, or `position_deg` for a rotary axis) and any
//! of the axis's six component errors with their unit (`EXX_um EYX_mm ECX_urad EAX_arcsec EBX_rad`),
//! and optionally the standard uncertainty of each row's translational components (`u_um`, `u_mm`)
//! and of its angular ones (`u_urad`, `u_rad`, `u_arcsec`); one row per measured position, rising.

use std::path::Path;

use super::CalibrateError;
use crate::io::csv::Csv;
use crate::io::read_text;
use crate::model::{AxisLetter, COMPONENT_NAMES};

/// A measured component of one axis's CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredComponent {
    /// Its index among the six.
    pub index: usize,
    /// `(position, value)`: mm or degrees, and mm or rad.
    pub nodes: Vec<(f64, f64)>,
    /// The standard uncertainty of each node (mm or rad) and the column it came from, where the
    /// file has a `u_um` (or `u_urad`, …) column for the component's kind.
    pub u: Option<(String, Vec<f64>)>,
}

/// A column of standard uncertainties, `u_um` (translational components) or `u_urad`
/// (angular ones): for which kind, and the factor to mm or rad.
struct UColumn {
    /// Its position among the columns after the position.
    column: usize,
    name: String,
    angular: bool,
    factor: f64,
}

/// Reads one axis's CSV: its components as node lists.
pub fn read_axis_csv(
    path: &Path,
    axis: AxisLetter,
) -> Result<Vec<MeasuredComponent>, CalibrateError> {
    let text = read_text(path)?;
    let name = path.display().to_string();
    let mut csv = Csv::new(&text, &name);
    let position_unit = if axis.is_linear() { "mm" } else { "deg" };
    let header = csv.header(&format!("naming position_{position_unit} and the errors"))?;
    let position_column = format!("position_{position_unit}");
    if header.names.first() != Some(&position_column) {
        return Err(csv
            .error(
                header.line,
                format!("the first column must be `{position_column}` (the {axis} position)"),
            )
            .into());
    }
    // (component index, factor to mm or rad)
    let mut components: Vec<(usize, f64)> = Vec::new();
    // Where each component's column is among those after the position.
    let mut at: Vec<usize> = Vec::new();
    let mut u_columns: Vec<UColumn> = Vec::new();
    for (n, column) in header.names[1..].iter().enumerate() {
        if let Some((angular, factor)) = u_column(column).map_err(|m| csv.error(header.line, m))? {
            if u_columns.iter().any(|u| u.angular == angular) {
                let kind = if angular { "angular" } else { "translational" };
                return Err(csv
                    .error(
                        header.line,
                        format!(
                            "two columns of the {kind} components' standard uncertainty: give one"
                        ),
                    )
                    .into());
            }
            u_columns.push(UColumn {
                column: n,
                name: column.clone(),
                angular,
                factor,
            });
            continue;
        }
        let component = component_column(column, axis).map_err(|m| csv.error(header.line, m))?;
        if components.iter().any(|&(i, _)| i == component.0) {
            let key = column.split_once('_').map_or(column.as_str(), |(k, _)| k);
            return Err(csv
                .error(header.line, format!("{key} appears twice"))
                .into());
        }
        components.push(component);
        at.push(n);
    }
    if components.is_empty() {
        return Err(csv
            .error(header.line, "no error column after the position")
            .into());
    }
    for u in &u_columns {
        if !components.iter().any(|&(i, _)| (i >= 3) == u.angular) {
            let kind = if u.angular {
                format!("angular component (EA{axis}_urad, …)")
            } else {
                format!("translational component (EX{axis}_um, …)")
            };
            return Err(csv
                .error(
                    header.line,
                    format!("column `{}`: the file has no {kind} for it", u.name),
                )
                .into());
        }
    }
    let names: Vec<String> = header.names.iter().map(|n| format!("`{n}`")).collect();
    let mut nodes: Vec<Vec<(f64, f64)>> = vec![Vec::new(); components.len()];
    let mut u_values: Vec<Vec<f64>> = vec![Vec::new(); u_columns.len()];
    let mut previous: Option<f64> = None;
    for row in csv.rows() {
        row.require_fields(names.len())?;
        let q = row.number(0, &names[0])?;
        if let Some(p) = previous.filter(|&p| q <= p) {
            return Err(row
                .error(format!(
                    "position {q} after {p}: rows must be sorted by position, rising"
                ))
                .into());
        }
        previous = Some(q);
        for (c, &(_, factor)) in components.iter().enumerate() {
            let n = at[c] + 1;
            nodes[c].push((q, row.number(n, &names[n])? * factor));
        }
        for (values, u) in u_values.iter_mut().zip(&u_columns) {
            let n = u.column + 1;
            let value = row.number(n, &names[n])?;
            if value < 0.0 {
                return Err(row
                    .error(format!(
                        "`{}` in column {} is negative: a standard uncertainty is zero or positive",
                        row.fields[n], names[n]
                    ))
                    .into());
            }
            values.push(value * u.factor);
        }
    }
    if nodes[0].len() < 2 {
        return Err(csv
            .error(
                header.line,
                format!(
                    "{} measured position(s): a table needs at least 2",
                    nodes[0].len()
                ),
            )
            .into());
    }
    Ok(components
        .iter()
        .zip(nodes)
        .map(|(&(index, _), nodes)| {
            let u = u_columns
                .iter()
                .zip(&u_values)
                .find(|(u, _)| u.angular == (index >= 3))
                .map(|(u, values)| (u.name.clone(), values.clone()));
            MeasuredComponent { index, nodes, u }
        })
        .collect())
}

/// A column of standard uncertainties, `u_` and a unit (`u_um`, `u_mm` for the translational
/// components; `u_urad`, `u_rad`, `u_arcsec` for the angular ones): whether angular and the
/// factor to mm or rad; `None` for any other column.
fn u_column(column: &str) -> Result<Option<(bool, f64)>, String> {
    let Some(unit) = column.strip_prefix("u_") else {
        return Ok(None);
    };
    let (angular, factor) = match unit {
        "mm" => (false, 1.0),
        "um" => (false, 1e-3),
        "rad" => (true, 1.0),
        "urad" => (true, 1e-6),
        "arcsec" => (true, std::f64::consts::PI / (180.0 * 3600.0)),
        _ => {
            return Err(format!(
                "column `{column}`: a standard uncertainty is u_um or u_mm (translational components), u_urad, u_rad or u_arcsec (angular ones)"
            ))
        }
    };
    Ok(Some((angular, factor)))
}

/// A component column of `axis` with its unit, `EXX_um` or `EAX_urad`: the component's index
/// among the six and the factor to mm or rad (else the message why not).
fn component_column(column: &str, axis: AxisLetter) -> Result<(usize, f64), String> {
    let (key, unit) = column.split_once('_').unwrap_or((column, ""));
    let chars: Vec<char> = key.chars().collect();
    let index = match chars.as_slice() {
        ['E', c, a] if *a == axis.as_char() => COMPONENT_NAMES.iter().position(|n| n == c),
        _ => None,
    }
    .ok_or_else(|| {
        format!(
            "column `{column}`: expected a component error of {axis} with its unit, such as EX{axis}_um or EA{axis}_urad"
        )
    })?;
    let factor = match (index < 3, unit) {
        (true, "mm") => 1.0,
        (true, "um") => 1e-3,
        (false, "rad") => 1.0,
        (false, "urad") => 1e-6,
        (false, "arcsec") => std::f64::consts::PI / (180.0 * 3600.0),
        (true, _) => {
            return Err(format!(
                "column `{column}`: unit `{unit}` — translational errors are in mm or um"
            ))
        }
        (false, _) => {
            return Err(format!(
                "column `{column}`: unit `{unit}` — angular errors are in rad, urad or arcsec"
            ))
        }
    };
    Ok((index, factor))
}
