//! Minimum-zone form tolerances on point sets with known answers.

use nalgebra::{Rotation3, Vector3};
use volmap::part::zone::{
    cylindricity_min_zone, flatness_least_squares, flatness_min_zone, ZoneError,
};

use super::common::Rng;

#[test]
fn two_parallel_planes_give_their_distance() {
    // Points on two parallel planes 0.004 mm apart, tilted 2e-4 rad against the nominal plane,
    // with points between them.
    let mut rng = Rng::new(1);
    let tilt = Rotation3::from_axis_angle(&Vector3::x_axis(), 2e-4)
        * Rotation3::from_axis_angle(&Vector3::y_axis(), -1e-4);
    let points: Vec<Vector3<f64>> = (0..400)
        .map(|n| {
            let h = match n % 4 {
                0 => 0.0,
                1 => 0.004,
                _ => rng.uniform(0.0, 0.004),
            };
            tilt * Vector3::new(rng.uniform(-300.0, 300.0), rng.uniform(-100.0, 100.0), h)
                + Vector3::new(10.0, 20.0, 250.0)
        })
        .collect();
    let zone = flatness_min_zone(&points, &Vector3::z()).unwrap();
    assert!((zone.width_mm - 0.004).abs() < 1e-12, "{}", zone.width_mm);
    assert!(
        (zone.normal - tilt * Vector3::z()).norm() < 1e-12,
        "{:?}",
        zone.normal
    );
}

#[test]
fn the_minimum_zone_beats_least_squares_and_every_other_orientation() {
    // A pocket floor: flat but for one corner raised by 0.01 mm. Least squares tilts towards the
    // corner and its zone is wider than the minimum zone.
    let mut points = Vec::new();
    for i in 0..=10 {
        for j in 0..=10 {
            let h = if i == 10 && j == 10 { 0.01 } else { 0.0 };
            points.push(Vector3::new(i as f64 * 10.0, j as f64 * 10.0, h));
        }
    }
    let minimum = flatness_min_zone(&points, &Vector3::z()).unwrap();
    let least_squares = flatness_least_squares(&points, &Vector3::z()).unwrap();
    assert!(
        least_squares.width_mm > minimum.width_mm + 1e-4,
        "{} vs {}",
        least_squares.width_mm,
        minimum.width_mm
    );
    // No other orientation does better.
    let mut rng = Rng::new(2);
    for _ in 0..2000 {
        let normal =
            Vector3::new(rng.uniform(-2e-4, 2e-4), rng.uniform(-2e-4, 2e-4), 1.0).normalize();
        let heights: Vec<f64> = points.iter().map(|p| normal.dot(p)).collect();
        let width = heights.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - heights.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(
            width >= minimum.width_mm - 1e-12,
            "{width} < {}",
            minimum.width_mm
        );
    }
    // The raised corner lies on the upper plane.
    let corner = Vector3::new(100.0, 100.0, 0.01);
    assert!(
        (minimum.normal.dot(&corner) - minimum.normal.dot(&points[minimum.highest])).abs() < 1e-12
    );
}

fn cylinder_points(
    mut radius: impl FnMut(f64, f64) -> f64,
    axis_point: Vector3<f64>,
    tilt: Rotation3<f64>,
) -> Vec<Vector3<f64>> {
    let mut points = Vec::new();
    for k in 0..9 {
        let z = k as f64 * 5.0;
        for n in 0..72 {
            let theta = n as f64 * std::f64::consts::TAU / 72.0 + 0.01 * k as f64;
            let r = radius(theta, z);
            points.push(axis_point + tilt * Vector3::new(r * theta.cos(), r * theta.sin(), z));
        }
    }
    points
}

#[test]
fn a_true_cylinder_off_the_nominal_axis_has_no_form_error() {
    let tilt = Rotation3::from_axis_angle(&Vector3::y_axis(), 3e-4);
    let points = cylinder_points(|_, _| 8.0, Vector3::new(0.05, -0.03, 0.0), tilt);
    let zone = cylindricity_min_zone(&points, &Vector3::zeros(), &Vector3::z()).unwrap();
    assert!(zone.width_mm < 1e-9, "{}", zone.width_mm);
    assert!((zone.inner_radius_mm - 8.0).abs() < 1e-9);
    assert!((zone.axis_direction - tilt * Vector3::z()).norm() < 1e-9);
}

/// A hole narrower than its axis is displaced (a 1 µm hole moved by 50 µm, far from the origin,
/// its axis tilted): the zone is its lobes' and nothing of the displacement.
#[test]
fn a_hole_narrower_than_its_displacement_has_its_own_form_error() {
    for radius in [0.05, 5e-4, 5e-7] {
        let e = radius * 1e-3;
        let tilt = Rotation3::from_axis_angle(&Vector3::y_axis(), 1e-5);
        let points = cylinder_points(
            |theta, _| radius + e * (2.0 * theta).cos(),
            Vector3::new(250.05, 249.97, 280.0),
            tilt,
        );
        let zone =
            cylindricity_min_zone(&points, &Vector3::new(250.0, 250.0, 280.0), &Vector3::z())
                .unwrap();
        // The points lie near 250 mm, whose f64 steps are 2.8e-14 mm: 1e-12 mm is 35 of them
        // (measured: at most 3e-14 mm, at every radius).
        assert!(
            (zone.width_mm - 2.0 * e).abs() < 1e-12,
            "radius {radius}: {} against {}",
            zone.width_mm,
            2.0 * e
        );
    }
}

#[test]
fn a_three_lobed_hole_has_twice_its_lobe_height() {
    let e = 0.002;
    let tilt = Rotation3::from_axis_angle(&Vector3::x_axis(), -2e-4);
    let points = cylinder_points(
        |theta, _| 6.0 + e * (3.0 * theta).cos(),
        Vector3::new(-0.02, 0.04, 1.0),
        tilt,
    );
    let zone = cylindricity_min_zone(&points, &Vector3::new(0.0, 0.0, 1.0), &Vector3::z()).unwrap();
    assert!((zone.width_mm - 2.0 * e).abs() < 1e-9, "{}", zone.width_mm);
    // A taper (radius growing along the axis) adds its growth: the zone about the true axis is
    // the spread of the radii sampled, and no other axis does better.
    let radius = |theta: f64, z: f64| 6.0 + e * (3.0 * theta).cos() + 1e-4 * z;
    let tapered = cylinder_points(radius, Vector3::zeros(), Rotation3::identity());
    let sampled: Vec<f64> = tapered.iter().map(|p| p.xy().norm()).collect();
    let spread = sampled.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - sampled.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(spread > 2.0 * e + 1e-4 * 40.0 - 1e-4, "{spread}");
    let zone = cylindricity_min_zone(
        &tapered,
        &Vector3::new(0.01, 0.0, 0.0),
        &Vector3::new(1e-4, 0.0, 1.0),
    )
    .unwrap();
    assert!(
        (zone.width_mm - spread).abs() < 1e-9,
        "{} vs {spread}",
        zone.width_mm
    );
}

#[test]
fn no_other_axis_holds_an_irregular_hole_in_a_thinner_zone() {
    let mut rng = Rng::new(9);
    let noise: Vec<f64> = (0..9 * 72).map(|_| rng.uniform(-0.001, 0.001)).collect();
    let mut n = 0;
    let points = cylinder_points(
        |theta, z| {
            n += 1;
            5.0 + 0.003 * (2.0 * theta + 0.3).cos() + 2e-5 * z + noise[n - 1]
        },
        Vector3::new(0.03, 0.01, 0.0),
        Rotation3::from_axis_angle(&Vector3::x_axis(), 1e-4),
    );
    let zone = cylindricity_min_zone(&points, &Vector3::zeros(), &Vector3::z()).unwrap();
    for _ in 0..500 {
        let point =
            zone.axis_point + Vector3::new(rng.uniform(-2e-3, 2e-3), rng.uniform(-2e-3, 2e-3), 0.0);
        let direction = (zone.axis_direction
            + Vector3::new(rng.uniform(-1e-4, 1e-4), rng.uniform(-1e-4, 1e-4), 0.0))
        .normalize();
        let radii: Vec<f64> = points
            .iter()
            .map(|p| {
                let d = p - point;
                (d - direction * direction.dot(&d)).norm()
            })
            .collect();
        let width = radii.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - radii.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(
            width >= zone.width_mm - 1e-12,
            "{width} < {}",
            zone.width_mm
        );
    }
}

#[test]
fn bad_point_sets_are_errors() {
    assert_eq!(
        flatness_min_zone(&[Vector3::zeros(), Vector3::x()], &Vector3::z()),
        Err(ZoneError::TooFewPoints {
            feature: "flatness",
            needed: 3,
            got: 2
        })
    );
    let nan = [
        Vector3::zeros(),
        Vector3::x(),
        Vector3::new(f64::NAN, 0.0, 0.0),
    ];
    assert_eq!(
        flatness_min_zone(&nan, &Vector3::z()),
        Err(ZoneError::NotFinite {
            feature: "flatness"
        })
    );
    let three = [Vector3::zeros(), Vector3::x(), Vector3::y()];
    assert_eq!(
        flatness_min_zone(&three, &Vector3::zeros()),
        Err(ZoneError::ZeroDirection {
            feature: "flatness"
        })
    );
}
