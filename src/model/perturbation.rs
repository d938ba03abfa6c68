//! Deviations added to a machine's error values: what a tolerance allows (docs/model.md,
//! "Tolerances and sampled machines"). A sampled machine is the machine with `s·shape(q)` added to
//! each toleranced error value, `s` the sample's amplitude for that term.

use super::{AxisLetter, ErrorFunction, Machine, COMPONENT_NAMES};

/// The spindle's error values, in [`Machine::spindle`] order.
pub const SPINDLE_NAMES: [&str; 5] = ["EXS", "EYS", "EZS", "EAS", "EBS"];

/// Which error value of a machine a deviation is added to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorTarget {
    /// Component error `index` (`EXk EYk EZk EAk EBk ECk`) of an axis.
    Component { axis: AxisLetter, index: usize },
    /// Location error `index` (`EX0k … EC0k`) of an axis.
    Location { axis: AxisLetter, index: usize },
    /// Spindle error `index` (`EXS EYS EZS EAS EBS`).
    Spindle { index: usize },
}

impl ErrorTarget {
    /// Its key as a tolerance file or a report names it: `axes.Y.EC0Y`, `spindle.EZS`.
    pub fn key(&self) -> String {
        match *self {
            ErrorTarget::Component { axis, index } => {
                format!("axes.{axis}.E{}{axis}", COMPONENT_NAMES[index])
            }
            ErrorTarget::Location { axis, index } => {
                format!("axes.{axis}.E{}0{axis}", COMPONENT_NAMES[index])
            }
            ErrorTarget::Spindle { index } => format!("spindle.{}", SPINDLE_NAMES[index]),
        }
    }

    /// Whether the error is an angle (rad) rather than a length (mm).
    pub fn is_angular(&self) -> bool {
        match *self {
            ErrorTarget::Component { index, .. } | ErrorTarget::Location { index, .. } => {
                index >= 3
            }
            ErrorTarget::Spindle { index } => index >= 3,
        }
    }
}

/// The shape of a deviation over its axis's travel `[a, b]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Shape {
    /// `δ(q) = s`.
    Constant,
    /// `δ(q) = s·(q − a)/(b − a)`: zero at the start, `s` at the end.
    Line,
    /// `δ(q) = 4s·(q − a)(b − q)/(b − a)²`: zero at both ends, `s` in the middle.
    Bow,
}

impl Shape {
    pub fn parse(name: &str) -> Option<Shape> {
        match name {
            "constant" => Some(Shape::Constant),
            "line" => Some(Shape::Line),
            "bow" => Some(Shape::Bow),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Shape::Constant => "constant",
            Shape::Line => "line",
            Shape::Bow => "bow",
        }
    }

    /// `δ(q)` for amplitude `s` over the travel `[a, b]`.
    pub fn value(self, s: f64, [a, b]: [f64; 2], q: f64) -> f64 {
        let u = (q - a) / (b - a);
        match self {
            Shape::Constant => s,
            Shape::Line => s * u,
            Shape::Bow => 4.0 * s * u * (1.0 - u),
        }
    }

    /// `δ` for amplitude `s` over `[a, b]` as polynomial coefficients in `q`.
    pub fn polynomial(self, s: f64, [a, b]: [f64; 2]) -> Vec<f64> {
        let w = b - a;
        match self {
            Shape::Constant => vec![s],
            Shape::Line => vec![-s * a / w, s / w],
            Shape::Bow => {
                let k = 4.0 * s / (w * w);
                vec![-k * a * b, k * (a + b), -k]
            }
        }
    }
}

/// A deviation of one error value with its shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Perturbation {
    pub target: ErrorTarget,
    pub shape: Shape,
}

/// How a tolerance's amplitude `s` is distributed over the machines built to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distribution {
    /// `s ~ U(−h, +h)`.
    Uniform { half_width: f64 },
    /// `s ~ N(0, σ²)`.
    Normal { sigma: f64 },
}

impl Distribution {
    /// The amplitude of an error budget's row: `+h` for uniform, `+2σ` for normal.
    pub fn limit(self) -> f64 {
        match self {
            Distribution::Uniform { half_width } => half_width,
            Distribution::Normal { sigma } => 2.0 * sigma,
        }
    }

    /// The width as the tolerance file writes it (`h` or `σ`).
    pub fn width(self) -> f64 {
        match self {
            Distribution::Uniform { half_width } => half_width,
            Distribution::Normal { sigma } => sigma,
        }
    }

    /// Its key in a tolerance file.
    pub fn name(self) -> &'static str {
        match self {
            Distribution::Uniform { .. } => "uniform",
            Distribution::Normal { .. } => "normal",
        }
    }

    /// The same distribution with its width times `factor`.
    pub fn scaled(self, factor: f64) -> Distribution {
        match self {
            Distribution::Uniform { half_width } => Distribution::Uniform {
                half_width: half_width * factor,
            },
            Distribution::Normal { sigma } => Distribution::Normal {
                sigma: sigma * factor,
            },
        }
    }
}

/// A tolerance: how far one error value of the machines built may lie from the machine file's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    pub perturbation: Perturbation,
    pub distribution: Distribution,
}

impl Machine {
    /// The machine with `amplitudes[t]` times the shape of `perturbations[t]` added to each
    /// target error value (over the travel of the target's axis). A zero amplitude changes
    /// nothing, so every amplitude zero gives the machine itself.
    pub fn perturbed(&self, perturbations: &[Perturbation], amplitudes: &[f64]) -> Machine {
        let mut machine = self.clone();
        for (p, &s) in perturbations.iter().zip(amplitudes) {
            if s == 0.0 {
                continue;
            }
            // Location and spindle errors take the constant shape only: its range is moot.
            let range = match p.target {
                ErrorTarget::Component { axis, .. } | ErrorTarget::Location { axis, .. } => {
                    match machine.axis_mut(axis) {
                        Some(a) => a.range,
                        None => continue,
                    }
                }
                ErrorTarget::Spindle { .. } => [0.0, 1.0],
            };
            machine.add_to_error(p.target, ErrorFunction::Poly(p.shape.polynomial(s, range)));
        }
        machine
    }

    /// Adds `delta` to the error value `target` names: a component error gains it as a term of
    /// its sum; a location or spindle error (a constant) gains its value at 0. An axis the
    /// machine lacks changes nothing.
    pub(crate) fn add_to_error(&mut self, target: ErrorTarget, delta: ErrorFunction) {
        match target {
            ErrorTarget::Component { axis, index } => {
                let Some(axis) = self.axis_mut(axis) else {
                    return;
                };
                axis.components[index] = Some(match axis.components[index].take() {
                    None => delta,
                    Some(ErrorFunction::Sum(mut terms)) => {
                        terms.push(delta);
                        ErrorFunction::Sum(terms)
                    }
                    Some(f) => ErrorFunction::Sum(vec![f, delta]),
                });
            }
            ErrorTarget::Location { axis, index } => {
                if let Some(axis) = self.axis_mut(axis) {
                    axis.location[index] += delta.eval(0.0);
                }
            }
            ErrorTarget::Spindle { index } => self.spindle[index] += delta.eval(0.0),
        }
    }

    /// Every axis's location errors and the spindle errors of [`Machine::perturbed`], without
    /// building the machine: `(locations in the order of `axes`, spindle)`.
    pub fn perturbed_constants(
        &self,
        perturbations: &[Perturbation],
        amplitudes: &[f64],
    ) -> (Vec<[f64; 6]>, [f64; 5]) {
        let mut locations: Vec<[f64; 6]> = self.axes.iter().map(|a| a.location).collect();
        let mut spindle = self.spindle;
        for (p, &s) in perturbations.iter().zip(amplitudes) {
            match p.target {
                ErrorTarget::Location { axis, index } => {
                    if let Some(n) = self.axes.iter().position(|a| a.letter == axis) {
                        locations[n][index] += s;
                    }
                }
                ErrorTarget::Spindle { index } => spindle[index] += s,
                ErrorTarget::Component { .. } => {}
            }
        }
        (locations, spindle)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_as_polynomials_equal_their_definitions() {
        let range = [-200.0, 600.0];
        for shape in [Shape::Constant, Shape::Line, Shape::Bow] {
            let p = ErrorFunction::Poly(shape.polynomial(0.003, range));
            for q in [-200.0, -37.5, 200.0, 411.0, 600.0] {
                let want = shape.value(0.003, range, q);
                assert!((p.eval(q) - want).abs() < 1e-15, "{shape:?} at {q}");
            }
        }
        assert_eq!(Shape::Line.value(2.0, range, -200.0), 0.0);
        assert_eq!(Shape::Line.value(2.0, range, 600.0), 2.0);
        assert_eq!(Shape::Bow.value(2.0, range, 200.0), 2.0);
        assert_eq!(Shape::Bow.value(2.0, range, 600.0), 0.0);
    }
}
