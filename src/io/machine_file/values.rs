//! Error values in a machine file (docs/model.md, "Error values"): the forms (a number, `poly`,
//! `table` or `csv`, each with an optional `of`; `table2d`; `sum`), the general form `{ value,
//! reverse, per_kelvin }` and its shorthand beside a `poly` or `table`, and the constant values of
//! location and spindle errors with their `per_kelvin` terms. The standard uncertainties forms
//! carry (`u`, `u_column`, `u_scale`) are read in `uncertainty.rs`.

use super::{MachineError, Reader};
use crate::error::excerpt;
use crate::io::csv::{Csv, CsvError};
use crate::io::read_text;
use crate::io::source::confined;
use crate::model::errorfn::{ErrorFunction, Interp, Table};
use crate::model::inputs::Approach;
use crate::model::perturbation::ErrorTarget;
use crate::model::table2d::Table2d;
use crate::model::AxisLetter;

/// What an error value says: its value at the default inputs, its reverse form and its
/// per-kelvin forms (by input index).
#[derive(Clone)]
pub(super) struct ValueSpec {
    pub value: ErrorFunction,
    pub reverse: Option<ErrorFunction>,
    pub per_kelvin: Vec<(usize, ErrorFunction)>,
}

/// Whether an error value is a component error (a function, with a reverse form) or a location
/// or spindle error (a constant, without one).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum ValueKind {
    Component,
    Constant,
}

/// The keys of a `poly`, `table` or `csv` form, before they are checked against each other.
pub(super) struct FormSpec {
    pub poly: Option<Vec<f64>>,
    pub nodes: Option<Vec<(f64, f64)>>,
    pub csv: Option<String>,
    pub column: Option<String>,
    pub interp: Interp,
    pub periodic: bool,
    pub of: Option<AxisLetter>,
    /// `u`, `u_column` and `u_scale`, checked once the form is known.
    pub u: Option<toml::Value>,
    pub u_column: Option<String>,
    pub u_scale: Option<f64>,
}

impl Reader {
    /// An error value of axis `letter` (or of the spindle, `letter` `None`), `key` its name
    /// (the CSV column it defaults to).
    pub(super) fn error_value(
        &mut self,
        target: ErrorTarget,
        key: &str,
        path: &str,
        value: &toml::Value,
        kind: ValueKind,
    ) -> Result<ValueSpec, MachineError> {
        let letter = match target {
            ErrorTarget::Spindle { .. } => None,
            ErrorTarget::Component { axis, .. } | ErrorTarget::Location { axis, .. } => Some(axis),
        };
        let plain = |value| ValueSpec {
            value,
            reverse: None,
            per_kelvin: Vec::new(),
        };
        let Some(table) = value.as_table() else {
            return Ok(plain(ErrorFunction::Constant(self.number(path, value)?)));
        };
        let general = table.contains_key("value");
        if !general && !table.contains_key("reverse") && !table.contains_key("per_kelvin") {
            if kind == ValueKind::Constant {
                return Err(self.constant_error(path));
            }
            let mark = self.found.len();
            let spec = plain(self.form(letter, key, path, value)?);
            self.adopt(mark, target, None, None);
            return Ok(spec);
        }
        // The general form, or its shorthand beside a poly or table's own keys.
        let mut own = table.clone();
        let reverse = own.remove("reverse");
        let per_kelvin = own.remove("per_kelvin");
        let mark = self.found.len();
        let value = if general {
            if let Some(other) = own.keys().find(|k| *k != "value" && *k != "u") {
                return Err(self.key_error(
                    &format!("{path}.{other}"),
                    "unknown key (the general form takes value, u, reverse and per_kelvin)",
                ));
            }
            let at = format!("{path}.value");
            let form = self.form(letter, key, &at, &own["value"])?;
            if let Some(u) = own.get("u") {
                self.general_u(path, &form, mark, u)?;
            }
            form
        } else {
            if !own.contains_key("poly") && !own.contains_key("table") && !own.contains_key("csv") {
                return Err(self.key_error(
                    path,
                    "`reverse` and `per_kelvin` go beside a poly or table, or in the general form { value = …, reverse = …, per_kelvin = { … } }",
                ));
            }
            self.form(letter, key, path, &toml::Value::Table(own))?
        };
        if kind == ValueKind::Constant && !matches!(value, ErrorFunction::Constant(_)) {
            return Err(self.constant_error(&format!("{path}.value")));
        }
        // `value` holds for the positive approach alone where a `reverse` stands beside it.
        let value_approach = reverse.is_some().then_some(Approach::Positive);
        self.adopt(mark, target, value_approach, None);
        let reverse = match reverse {
            None => None,
            Some(_) if kind == ValueKind::Constant => {
                return Err(self.key_error(
                    &format!("{path}.reverse"),
                    "`reverse` is for component errors: location and spindle errors have no approach direction",
                ))
            }
            Some(r) => {
                let mark = self.found.len();
                let form = self.form(letter, key, &format!("{path}.reverse"), &r)?;
                self.adopt(mark, target, Some(Approach::Negative), None);
                Some(form)
            }
        };
        let per_kelvin = match per_kelvin {
            None => Vec::new(),
            Some(p) => self.per_kelvin(target, key, &format!("{path}.per_kelvin"), &p, kind)?,
        };
        Ok(ValueSpec {
            value,
            reverse,
            per_kelvin,
        })
    }

    fn constant_error(&self, path: &str) -> MachineError {
        self.key_error(
            path,
            "a location or spindle error is a number, or { value = number, per_kelvin = { input = number, … } }",
        )
    }

    /// `per_kelvin = { input = form, … }`: each input declared in `[thermal]`.
    fn per_kelvin(
        &mut self,
        target: ErrorTarget,
        key: &str,
        path: &str,
        value: &toml::Value,
        kind: ValueKind,
    ) -> Result<Vec<(usize, ErrorFunction)>, MachineError> {
        let table = value.as_table().ok_or_else(|| {
            self.key_error(
                path,
                "expected a table { input = form, … } of per-kelvin terms",
            )
        })?;
        let mut out = Vec::new();
        for (input, form) in table {
            let at = format!("{path}.{input}");
            let index = self
                .thermal_inputs
                .iter()
                .position(|i| i == input)
                .ok_or_else(|| {
                    self.key_error(
                        &at,
                        if self.thermal_inputs.is_empty() {
                            format!("`{input}` is not a declared thermal input: the file has no [thermal] section with inputs = [\"{input}\", …]")
                        } else {
                            format!(
                                "`{input}` is not a declared thermal input ([thermal] inputs: {})",
                                self.thermal_inputs.join(", ")
                            )
                        },
                    )
                })?;
            let mark = self.found.len();
            let f = match kind {
                ValueKind::Constant => self.constant_form(&at, form)?,
                ValueKind::Component => {
                    let letter = match target {
                        ErrorTarget::Component { axis, .. } => Some(axis),
                        _ => None,
                    };
                    self.form(letter, key, &at, form)?
                }
            };
            self.adopt(mark, target, None, Some(index));
            out.push((index, f));
        }
        Ok(out)
    }

    /// A form: a number, `poly`/`table`/`csv` (with `of`), `table2d` or `sum`. A form carries no
    /// `reverse` or `per_kelvin` of its own.
    fn form(
        &mut self,
        letter: Option<AxisLetter>,
        key: &str,
        path: &str,
        value: &toml::Value,
    ) -> Result<ErrorFunction, MachineError> {
        let Some(table) = value.as_table() else {
            return Ok(ErrorFunction::Constant(self.number(path, value)?));
        };
        // A constant with its uncertainty; `{ value = … }` alone says nothing a number does not.
        if table.contains_key("u") && table.keys().all(|k| k == "value" || k == "u") {
            return self.constant_form(path, value);
        }
        for own in ["value", "reverse", "per_kelvin"] {
            if table.contains_key(own) {
                return Err(self.key_error(
                    &format!("{path}.{own}"),
                    "a form inside an error value carries no value, reverse or per_kelvin of its own (a constant with its uncertainty is { value = number, u = number })",
                ));
            }
        }
        if let Some(terms) = table.get("sum") {
            self.alone(path, table, "sum")?;
            let terms = terms.as_array().filter(|a| !a.is_empty()).ok_or_else(|| {
                self.key_error(
                    &format!("{path}.sum"),
                    "expected a non-empty array of forms",
                )
            })?;
            let forms = terms
                .iter()
                .enumerate()
                .map(|(n, f)| self.form(letter, key, &format!("{path}.sum[{n}]"), f))
                .collect::<Result<Vec<_>, _>>()?;
            return Ok(ErrorFunction::Sum(forms));
        }
        if let Some(t) = table.get("table2d") {
            self.alone(path, table, "table2d")?;
            return self.table2d(&format!("{path}.table2d"), t);
        }
        self.one_axis_form(letter, key, path, table)
    }

    /// Checks that `name` is the only key of a form's table.
    fn alone(&self, path: &str, table: &toml::Table, name: &str) -> Result<(), MachineError> {
        match table.keys().find(|k| *k != name) {
            Some(other) => Err(self.key_error(
                &format!("{path}.{other}"),
                format!("`{name}` stands alone in its form"),
            )),
            None => Ok(()),
        }
    }

    /// The axis `of` names: an axis of the chain.
    fn axis_of(&self, path: &str, value: &toml::Value) -> Result<AxisLetter, MachineError> {
        let name = value.as_str().unwrap_or("");
        match name.chars().collect::<Vec<_>>()[..] {
            [c] => AxisLetter::from_char(c),
            _ => None,
        }
        .filter(|&l| self.chain.contains(l))
        .ok_or_else(|| {
            self.key_error(
                path,
                format!(
                    "`{}` is not an axis of the chain `{}`",
                    value
                        .as_str()
                        .map_or_else(|| value.to_string(), str::to_string),
                    self.chain.hwang_notation()
                ),
            )
        })
    }

    /// `table2d = { of = ["X", "Z"], x = […], y = […], values = [[…], …] }`.
    fn table2d(&self, path: &str, value: &toml::Value) -> Result<ErrorFunction, MachineError> {
        let table = value.as_table().ok_or_else(|| {
            self.key_error(
                path,
                "expected { of = [A, B], x = […], y = […], values = [[…], …] }",
            )
        })?;
        let get = |name: &str| {
            table
                .get(name)
                .ok_or_else(|| self.key_error(&format!("{path}.{name}"), "missing"))
        };
        if let Some(other) = table
            .keys()
            .find(|k| !["of", "x", "y", "values"].contains(&k.as_str()))
        {
            return Err(self.key_error(
                &format!("{path}.{other}"),
                "unknown key (table2d takes of, x, y and values)",
            ));
        }
        let of = get("of")?
            .as_array()
            .filter(|a| a.len() == 2)
            .ok_or_else(|| {
                self.key_error(
                    &format!("{path}.of"),
                    "expected two axes, e.g. [\"X\", \"Z\"]",
                )
            })?;
        let axes = [
            self.axis_of(&format!("{path}.of"), &of[0])?,
            self.axis_of(&format!("{path}.of"), &of[1])?,
        ];
        if axes[0] == axes[1] {
            return Err(self.key_error(
                &format!("{path}.of"),
                format!(
                    "names {} twice: a table of two axes names two (a table of one is `table`, with `of`)",
                    axes[0]
                ),
            ));
        }
        let list = |name: &str, v: &toml::Value| -> Result<Vec<f64>, MachineError> {
            let at = format!("{path}.{name}");
            v.as_array()
                .ok_or_else(|| self.key_error(&at, "expected an array of numbers"))?
                .iter()
                .map(|n| self.number(&at, n))
                .collect()
        };
        let x = list("x", get("x")?)?;
        let y = list("y", get("y")?)?;
        let values = get("values")?
            .as_array()
            .ok_or_else(|| self.key_error(&format!("{path}.values"), "expected an array of rows"))?
            .iter()
            .enumerate()
            .map(|(i, row)| list(&format!("values[{i}]"), row))
            .collect::<Result<Vec<_>, _>>()?;
        Table2d::new(axes, x, y, values)
            .map(ErrorFunction::Table2d)
            .map_err(|e| self.key_error(path, e.to_string()))
    }

    /// `poly`, `table` or `csv`, with `interp`, `periodic`, `column` and `of`.
    fn one_axis_form(
        &mut self,
        letter: Option<AxisLetter>,
        key: &str,
        path: &str,
        table: &toml::Table,
    ) -> Result<ErrorFunction, MachineError> {
        let mut spec = self.form_spec(path, table)?;
        let sources = [
            spec.poly.is_some(),
            spec.nodes.is_some(),
            spec.csv.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if sources != 1 {
            return Err(self.key_error(
                path,
                "give exactly one of `poly`, `table`, `csv`, `table2d`, `sum`, or `value` (the general form)",
            ));
        }
        if spec.column.is_some() && spec.csv.is_none() {
            return Err(self.key_error(&format!("{path}.column"), "`column` goes with `csv`"));
        }
        let argument = spec.of.or(letter);
        if spec.periodic && argument.is_none_or(|l| l.is_linear()) {
            return Err(self.key_error(
                &format!("{path}.periodic"),
                "only tables of a rotary axis's position (A, B, C) are periodic",
            ));
        }
        let form = if let Some(coefficients) = spec.poly.take() {
            if table.contains_key("interp") || table.contains_key("periodic") {
                return Err(self.key_error(
                    path,
                    "`interp` and `periodic` apply to tables, not to `poly`",
                ));
            }
            self.poly_u(path, &spec)?;
            ErrorFunction::Poly(coefficients)
        } else {
            if spec.u_column.is_some() && spec.csv.is_none() {
                return Err(self.key_error(
                    &format!("{path}.u_column"),
                    "`u_column` names a column of the CSV table (`csv`); an inline table takes u = [u0, u1, …]",
                ));
            }
            let (nodes, column_u) = match (spec.nodes.take(), &spec.csv) {
                (Some(nodes), _) => (nodes, None),
                (None, Some(csv)) => {
                    let column = spec.column.clone().unwrap_or_else(|| key.to_string());
                    self.csv_column(path, csv, &column, spec.u_column.as_deref())?
                }
                (None, None) => return Err(self.key_error(path, "give a table")),
            };
            let positions: Vec<f64> = nodes.iter().map(|&(q, _)| q).collect();
            let table = Table::new(nodes, spec.interp, spec.periodic)
                .map(ErrorFunction::Table)
                .map_err(|source| MachineError::Table {
                    file: self.file.clone(),
                    key: path.to_string(),
                    source,
                })?;
            let of = spec.of.filter(|&axis| Some(axis) != letter);
            self.table_u(path, &spec, positions, column_u, of)?;
            table
        };
        Ok(match spec.of {
            Some(axis) if Some(axis) != letter => ErrorFunction::Of {
                axis,
                form: Box::new(form),
            },
            _ => form,
        })
    }

    /// The keys of a `poly`, `table` or `csv` form, each checked on its own.
    fn form_spec(&self, path: &str, table: &toml::Table) -> Result<FormSpec, MachineError> {
        let mut spec = FormSpec {
            poly: None,
            nodes: None,
            csv: None,
            column: None,
            interp: Interp::Linear,
            periodic: false,
            of: None,
            u: None,
            u_column: None,
            u_scale: None,
        };
        for (key, v) in table {
            let sub = format!("{path}.{key}");
            let text = |what: &str| {
                v.as_str()
                    .map(str::to_string)
                    .ok_or_else(|| self.key_error(&sub, format!("expected a {what}")))
            };
            match key.as_str() {
                "poly" => {
                    let array = v.as_array().filter(|a| !a.is_empty()).ok_or_else(|| {
                        self.key_error(&sub, "expected a non-empty array of coefficients [c0, c1, …]")
                    })?;
                    spec.poly = Some(
                        array
                            .iter()
                            .map(|c| self.number(&sub, c))
                            .collect::<Result<Vec<_>, _>>()?,
                    );
                }
                "table" => {
                    let rows = v.as_array().ok_or_else(|| {
                        self.key_error(&sub, "expected an array of [position, value] rows")
                    })?;
                    let mut parsed = Vec::with_capacity(rows.len());
                    for (r, row) in rows.iter().enumerate() {
                        let [q, e] = self.numbers::<2>(&format!("{sub}[{r}]"), row)?;
                        parsed.push((q, e));
                    }
                    spec.nodes = Some(parsed);
                }
                "csv" => spec.csv = Some(text("file name")?),
                "column" => spec.column = Some(text("column name")?),
                "of" => spec.of = Some(self.axis_of(&sub, v)?),
                "interp" => {
                    let name = v.as_str().unwrap_or("");
                    spec.interp = Interp::parse(name).ok_or_else(|| {
                        self.key_error(
                            &sub,
                            format!("unknown interpolation `{v}`: use \"linear\", \"quadratic\" or \"cubic\""),
                        )
                    })?;
                }
                "periodic" => {
                    spec.periodic = v
                        .as_bool()
                        .ok_or_else(|| self.key_error(&sub, "expected true or false"))?;
                }
                "u" => spec.u = Some(v.clone()),
                "u_column" => spec.u_column = Some(text("column name")?),
                "u_scale" => spec.u_scale = Some(self.u_number(&sub, v)?),
                other => {
                    return Err(self.key_error(
                        &sub,
                        format!("unknown key `{other}` (an error value takes poly, table, csv, column, interp, periodic, of, u, u_column, u_scale; table2d; sum; or value, u, reverse, per_kelvin)"),
                    ))
                }
            }
        }
        Ok(spec)
    }

    /// Reads `(position, value)` rows from a CSV file: one header row, first column the position.
    /// With `u_column`, that column's values too, one per row (each a standard uncertainty).
    fn csv_column(
        &mut self,
        key: &str,
        csv: &str,
        column: &str,
        u_column: Option<&str>,
    ) -> Result<ColumnRows, MachineError> {
        let Some(base) = &self.csv_base else {
            return Err(self.key_error(key, "CSV tables need a machine file on disk (embedded machines carry their tables inline)"));
        };
        let file_error = |source| MachineError::CsvFile {
            file: self.file.clone(),
            key: key.to_string(),
            source,
        };
        let path = confined(base, std::path::Path::new(csv), self.reach).map_err(file_error)?;
        let text = read_text(&path).map_err(file_error)?;
        let csv_name = path.display().to_string();
        let rows = read_column(&text, &csv_name, column, u_column).map_err(|source| {
            MachineError::Csv {
                file: self.file.clone(),
                key: key.to_string(),
                source,
            }
        })?;
        if !self.csv_files.iter().any(|(name, _)| name == csv) {
            self.csv_files.push((csv.to_string(), text));
        }
        Ok(rows)
    }
}

/// The `(position, value)` rows of a CSV table's value column, and the standard uncertainties of
/// its `u_column` where one is named.
type ColumnRows = (Vec<(f64, f64)>, Option<Vec<f64>>);

/// The `(position, value)` rows of `column` in a CSV table whose first column is the position,
/// and with `u_column` that column's standard uncertainties (each zero or positive).
fn read_column(
    text: &str,
    path: &str,
    column: &str,
    u_column: Option<&str>,
) -> Result<ColumnRows, CsvError> {
    let mut csv = Csv::new(text, path);
    let header = csv.header("naming the position, then the error columns")?;
    let find = |column: &str| {
        let index = header
            .names
            .iter()
            .position(|n| n == column)
            .ok_or_else(|| {
                csv.error(
                    header.line,
                    format!(
                        "has no column `{}` (its columns: {})",
                        excerpt(column),
                        excerpt(&header.names.join(", "))
                    ),
                )
            })?;
        if index == 0 {
            return Err(csv.error(
                header.line,
                format!(
                    "column `{}` is the position column; name a value column",
                    excerpt(column)
                ),
            ));
        }
        Ok(index)
    };
    let index = find(column)?;
    let u_index = u_column.map(find).transpose()?;
    let position = format!("`{}`", header.names[0]);
    let value = format!("`{column}`");
    let u_name = format!("`{}`", u_column.unwrap_or(""));
    let mut rows = Vec::new();
    let mut u = u_index.map(|_| Vec::new());
    for row in csv.rows() {
        rows.push((row.number(0, &position)?, row.number(index, &value)?));
        if let (Some(u_index), Some(u)) = (u_index, u.as_mut()) {
            let x = row.number(u_index, &u_name)?;
            if x < 0.0 {
                return Err(row.error(format!(
                    "{} in column {u_name} is negative: a standard uncertainty is zero or positive",
                    crate::error::shown(x)
                )));
            }
            u.push(x);
        }
    }
    Ok((rows, u))
}
