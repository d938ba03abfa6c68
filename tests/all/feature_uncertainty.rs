//! The library's side of decisions with uncertainty: ISO 14253-1's zones at their edges, and the
//! directions the machine is perturbed along summing to the covariance matrix.

use volmap::model::perturbation::ErrorTarget;
use volmap::model::uncertainty::{UncertainKind, UncertainValue, Uncertainty};
use volmap::part::Conformance;

#[test]
fn the_zones_of_iso_14253_1_at_their_edges() {
    // error + U = tolerance still conforms; error − U = tolerance is not yet beyond it.
    assert_eq!(Conformance::of(0.75, 0.25, 1.0), Conformance::Conforms);
    assert_eq!(Conformance::of(1.25, 0.25, 1.0), Conformance::Undecided);
    assert_eq!(Conformance::of(1.5, 0.25, 1.0), Conformance::DoesNotConform);
    assert_eq!(Conformance::of(0.875, 0.25, 1.0), Conformance::Undecided);
    // Without uncertainty nothing is undecided: the error against the tolerance alone.
    assert_eq!(Conformance::of(1.0, 0.0, 1.0), Conformance::Conforms);
    assert_eq!(
        Conformance::of(1.0 + 1e-12, 0.0, 1.0),
        Conformance::DoesNotConform
    );
}

fn scalar(name: &str, index: usize, u: f64) -> UncertainValue {
    UncertainValue {
        name: name.into(),
        target: ErrorTarget::Spindle { index },
        approach: None,
        per_kelvin: None,
        kind: UncertainKind::Scalar { u },
    }
}

/// Three quantities, the first and third correlated (ρ = 0.5), the second independent, and a
/// fourth without spread: the directions' outer products give back [[4, 0, 3], [0, 9, 0],
/// [3, 0, 9]] and the fourth is never perturbed.
#[test]
fn the_directions_sum_to_the_covariance_matrix() {
    let u = Uncertainty {
        values: vec![
            scalar("a", 0, 2.0),
            scalar("b", 1, 3.0),
            scalar("c", 2, 3.0),
            scalar("d", 3, 0.0),
        ],
        covariance: vec![(0, 2, 3.0)],
    };
    let directions = u.directions().unwrap();
    assert_eq!(directions.len(), 3);
    let want = [
        [4.0, 0.0, 3.0, 0.0],
        [0.0, 9.0, 0.0, 0.0],
        [3.0, 0.0, 9.0, 0.0],
        [0.0; 4],
    ];
    for (i, row) in want.iter().enumerate() {
        for (j, &c) in row.iter().enumerate() {
            let got: f64 = directions.iter().map(|d| d[i] * d[j]).sum();
            assert!((got - c).abs() < 1e-12, "C[{i}][{j}] = {got}, not {c}");
        }
    }
}
