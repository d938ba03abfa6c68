//! Standard uncertainties in a machine file (docs/model.md, "Uncertainty of the error values"):
//! `u` beside a constant or a polynomial (`{ value = 1.8e-5, u = 2e-6 }`, `{ poly = […], u = … }`),
//! `u = […]` (one per node), `u_column` (a CSV column) and `u_scale` beside a table, and the
//! `[covariance]` table of pairs of named scalar quantities.
//!
//! A form reports what it carries as [`Found`]; the error value that holds the form then assigns
//! it its target, the approach direction it is used for and its thermal input ([`Reader::adopt`]).
//! A quantity is named by the key of its error value (`axes.Y.EC0Y`, `spindle.EZS`, as
//! [`ErrorTarget::key`] writes it) and, where the `u` stands on a part, the part's path
//! (`axes.X.EXX.reverse`, `spindle.EZS.per_kelvin.spindle`, `axes.X.EXX.sum[1]`).

use super::values::FormSpec;
use super::{MachineError, Reader};
use crate::model::errorfn::{ErrorFunction, PERIOD_DEG};
use crate::model::inputs::Approach;
use crate::model::perturbation::ErrorTarget;
use crate::model::uncertainty::{UncertainKind, UncertainValue, Uncertainty};
use crate::model::AxisLetter;

/// A standard uncertainty a form carries, at the form's path.
pub(super) struct Found {
    path: String,
    kind: UncertainKind,
}

impl Reader {
    /// A standard uncertainty: a finite number, zero or positive.
    pub(super) fn u_number(&self, key: &str, value: &toml::Value) -> Result<f64, MachineError> {
        let u = self.number(key, value)?;
        if u < 0.0 {
            return Err(MachineError::NegativeUncertainty {
                file: self.file.clone(),
                key: key.to_string(),
                value: crate::error::shown(u),
            });
        }
        Ok(u)
    }

    /// Assigns what the forms read since `mark` carry to the error value `target`: used for the
    /// approach `approach` (`None`: both) and times `ΔT` of thermal input `per_kelvin`.
    pub(super) fn adopt(
        &mut self,
        mark: usize,
        target: ErrorTarget,
        approach: Option<Approach>,
        per_kelvin: Option<usize>,
    ) {
        for found in self.found.drain(mark..) {
            let name = found
                .path
                .strip_suffix(".value")
                .unwrap_or(&found.path)
                .to_string();
            self.uncertain.push(UncertainValue {
                name,
                target,
                approach,
                per_kelvin,
                kind: found.kind,
            });
        }
    }

    /// `u` of the general form `{ value = …, u = … }`: for a constant or a polynomial value.
    pub(super) fn general_u(
        &mut self,
        path: &str,
        form: &ErrorFunction,
        mark: usize,
        u: &toml::Value,
    ) -> Result<(), MachineError> {
        let at = format!("{path}.u");
        let u = self.u_number(&at, u)?;
        if self.found.len() > mark {
            return Err(
                self.key_error(&at, "the value's form carries a u of its own: give it once")
            );
        }
        let scalar = match form {
            ErrorFunction::Constant(_) | ErrorFunction::Poly(_) => true,
            ErrorFunction::Of { form, .. } => matches!(**form, ErrorFunction::Poly(_)),
            _ => false,
        };
        if !scalar {
            return Err(self.key_error(
                &at,
                "a single u goes with a constant or a polynomial value; a table takes u = [u0, u1, …] beside its nodes, a sum a u on each term",
            ));
        }
        self.found.push(Found {
            path: path.to_string(),
            kind: UncertainKind::Scalar { u },
        });
        Ok(())
    }

    /// A constant: a number, or `{ value = number, u = number }`.
    pub(super) fn constant_form(
        &mut self,
        path: &str,
        value: &toml::Value,
    ) -> Result<ErrorFunction, MachineError> {
        let Some(table) = value.as_table() else {
            return Ok(ErrorFunction::Constant(self.number(path, value)?));
        };
        if let Some(other) = table.keys().find(|k| *k != "value" && *k != "u") {
            return Err(self.key_error(
                &format!("{path}.{other}"),
                "unknown key: a constant is a number, or { value = number, u = number }",
            ));
        }
        let value = table.get("value").ok_or_else(|| {
            self.key_error(
                path,
                "a constant is a number, or { value = number, u = number }",
            )
        })?;
        let c = self.number(&format!("{path}.value"), value)?;
        if let Some(u) = table.get("u") {
            let u = self.u_number(&format!("{path}.u"), u)?;
            self.found.push(Found {
                path: path.to_string(),
                kind: UncertainKind::Scalar { u },
            });
        }
        Ok(ErrorFunction::Constant(c))
    }

    /// `u` beside a `poly`: one number; `u_column` and `u_scale` are a table's.
    pub(super) fn poly_u(&mut self, path: &str, spec: &FormSpec) -> Result<(), MachineError> {
        for (given, name) in [
            (spec.u_column.is_some(), "u_column"),
            (spec.u_scale.is_some(), "u_scale"),
        ] {
            if given {
                return Err(self.key_error(
                    &format!("{path}.{name}"),
                    format!("`{name}` goes with a table; a polynomial takes one u"),
                ));
            }
        }
        if let Some(u) = &spec.u {
            let at = format!("{path}.u");
            if u.is_array() {
                return Err(self.key_error(
                    &at,
                    "a polynomial's u is one number (a table's is one per node)",
                ));
            }
            let u = self.u_number(&at, u)?;
            self.found.push(Found {
                path: path.to_string(),
                kind: UncertainKind::Scalar { u },
            });
        }
        Ok(())
    }

    /// `u = […]` (or the CSV's `u_column`, read into `column_u`) and `u_scale` beside a table
    /// with nodes at `positions` (as written).
    pub(super) fn table_u(
        &mut self,
        path: &str,
        spec: &FormSpec,
        mut positions: Vec<f64>,
        column_u: Option<Vec<f64>>,
        of: Option<AxisLetter>,
    ) -> Result<(), MachineError> {
        let at = format!("{path}.u");
        let inline = match &spec.u {
            None => None,
            Some(_) if column_u.is_some() => {
                return Err(self.key_error(&at, "give `u` or `u_column`, not both: one u per node"))
            }
            Some(toml::Value::Array(values)) => Some(
                values
                    .iter()
                    .map(|v| self.u_number(&at, v))
                    .collect::<Result<Vec<_>, _>>()?,
            ),
            Some(_) => {
                return Err(self.key_error(
                    &at,
                    "a table's u is one standard uncertainty per node: u = [u0, u1, …]",
                ))
            }
        };
        let per_node = inline.or(column_u);
        if per_node.is_none() && spec.u_scale.is_none() {
            return Ok(());
        }
        let mut u = match per_node {
            Some(u) if u.len() != positions.len() => {
                return Err(MachineError::UncertaintyCount {
                    file: self.file.clone(),
                    key: at,
                    given: u.len(),
                    nodes: positions.len(),
                })
            }
            Some(u) => u,
            None => vec![0.0; positions.len()],
        };
        // A periodic table that ends at q0 + 360° ends on its first node: the same quantity.
        let closed = spec.periodic
            && ((positions[positions.len() - 1] - positions[0]) - PERIOD_DEG).abs()
                <= 1e-9 * PERIOD_DEG;
        if closed {
            let last = u.pop().unwrap_or(0.0);
            if last != u[0] {
                return Err(self.key_error(
                    &at,
                    format!(
                        "the node at q0 + 360° is the first node again: its u ({}) must be the first's ({})",
                        crate::error::shown(last),
                        crate::error::shown(u[0])
                    ),
                ));
            }
            positions.pop();
        }
        self.found.push(Found {
            path: path.to_string(),
            kind: UncertainKind::Table {
                of,
                positions,
                interp: spec.interp,
                periodic: spec.periodic,
                u,
                u_scale: spec.u_scale.unwrap_or(0.0),
            },
        });
        Ok(())
    }

    /// Every uncertain value read, with `[covariance]`: each key two names of scalar quantities
    /// with a `u`, each pair once, the whole matrix positive semi-definite.
    pub(super) fn uncertainty(
        &mut self,
        covariance: Option<&toml::Table>,
    ) -> Result<Uncertainty, MachineError> {
        let mut uncertainty = Uncertainty {
            values: std::mem::take(&mut self.uncertain),
            covariance: Vec::new(),
        };
        let firsts: Vec<usize> = uncertainty
            .values
            .iter()
            .scan(0, |next, v| {
                let first = *next;
                *next += v.kind.count();
                Some(first)
            })
            .collect();
        let mut keys = Vec::new();
        for (key, value) in covariance.into_iter().flatten() {
            let at = format!("covariance.\"{key}\"");
            let names: Vec<&str> = key.split_whitespace().collect();
            let [a, b] = names[..] else {
                return Err(self.key_error(
                    &at,
                    "a key names two quantities separated by a space, e.g. \"axes.Y.EC0Y axes.Z.EB0Z\"",
                ));
            };
            if a == b {
                return Err(self.key_error(
                    &at,
                    format!("names `{a}` twice: its variance is u², given by its u"),
                ));
            }
            let c = self.number(&at, value)?;
            let number = |name: &str| -> Result<usize, MachineError> {
                match uncertainty.values.iter().position(|v| v.name == name) {
                    Some(v) if matches!(uncertainty.values[v].kind, UncertainKind::Scalar { .. }) => {
                        Ok(firsts[v])
                    }
                    Some(_) => Err(self.key_error(
                        &at,
                        format!("`{name}` is a table: its nodes' u are independent of each other and of every other quantity; [covariance] pairs scalar quantities"),
                    )),
                    None if self.values.iter().any(|e| e.key == name) => Err(self.key_error(
                        &at,
                        format!("`{name}` carries no u: a value without u is exact, and has no covariance"),
                    )),
                    None => {
                        let scalars: Vec<&str> = uncertainty
                            .values
                            .iter()
                            .filter(|v| matches!(v.kind, UncertainKind::Scalar { .. }))
                            .map(|v| v.name.as_str())
                            .collect();
                        Err(self.key_error(
                            &at,
                            format!(
                                "`{}` names no error value with a u ({})",
                                crate::error::excerpt(name),
                                if scalars.is_empty() {
                                    "the file gives none".to_string()
                                } else {
                                    format!("those with one: {}", scalars.join(", "))
                                }
                            ),
                        ))
                    }
                }
            };
            let (i, j) = (number(a)?, number(b)?);
            let pair = (i.min(j), i.max(j));
            if uncertainty
                .covariance
                .iter()
                .any(|&(x, y, _)| (x, y) == pair)
            {
                return Err(self.key_error(&at, "the pair is given twice"));
            }
            uncertainty.covariance.push((pair.0, pair.1, c));
            keys.push((pair, key.clone()));
        }
        if let Err(fault) = uncertainty.correlated_factor() {
            let pairs: Vec<String> = fault
                .pairs
                .iter()
                .filter_map(|p| keys.iter().find(|(k, _)| k == p))
                .map(|(_, key)| format!("\"{key}\""))
                .collect();
            return Err(MachineError::NotPositiveSemidefinite {
                file: self.file.clone(),
                pairs: pairs.join(", "),
            });
        }
        Ok(uncertainty)
    }
}
