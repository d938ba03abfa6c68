//! The standard tests at poses of work-side rotary axes: each instrument reads along the way the
//! tool really moves relative to the workpiece (the ideal tool tip in the workpiece frame), the
//! ballbar about the centre ball where the set-up put it, and measured positions rounded a little
//! beyond the ends.

use nalgebra::Vector3;
use volmap::io::embedded;
use volmap::model::inputs::Approach;
use volmap::model::{AxisLetter, ErrorFunction, Machine};
use volmap::reference::tool_pose;
use volmap::standards::ballbar::circle_directions;
use volmap::standards::{self, CircularSpec, DiagonalSpec, PositioningSpec, Setup};
use AxisLetter::*;

use super::standards::{expect_csv_error, write};

/// An error-free FYXCFZB machine: the C table on X, the B head on Z, the tool 250 mm below B.
fn five_axis() -> Machine {
    let mut m = Machine::nominal(
        "five-axis",
        "FYXCFZB",
        &[
            (X, [0.0, 800.0]),
            (Y, [0.0, 600.0]),
            (Z, [0.0, 500.0]),
            (B, [-110.0, 110.0]),
            (C, [0.0, 360.0]),
        ],
    )
    .unwrap();
    m.axis_mut(C).unwrap().offset_mm = [0.0, 0.0, 150.0];
    m.tool_offset_mm = [0.0, 0.0, -250.0];
    m
}

/// An error-free table-table machine FYXACFZ: the A cradle on X, the C table on A.
fn table_table() -> Machine {
    let mut m = Machine::nominal(
        "table-table",
        "FYXACFZ",
        &[
            (X, [-300.0, 300.0]),
            (Y, [-250.0, 250.0]),
            (Z, [-200.0, 300.0]),
            (A, [-120.0, 120.0]),
            (C, [0.0, 360.0]),
        ],
    )
    .unwrap();
    m.axis_mut(A).unwrap().offset_mm = [0.0, 0.0, 100.0];
    m.tool_offset_mm = [0.0, 0.0, -150.0];
    m
}

/// The table-table machine with errors of every kind: scale and straightness of the linear
/// axes, squareness, rotary location errors and an indexing error of C.
fn table_table_with_errors() -> Machine {
    let mut m = table_table();
    let poly = |c: &[f64]| Some(ErrorFunction::Poly(c.to_vec()));
    m.axis_mut(X).unwrap().components[0] = poly(&[0.0, 1.5e-5]);
    m.axis_mut(X).unwrap().components[1] = poly(&[0.0, 0.0, 2.0e-8]);
    m.axis_mut(Y).unwrap().components[1] = poly(&[0.0, -1.0e-5]);
    m.axis_mut(Y).unwrap().location[5] = 2.0e-5;
    m.axis_mut(Z).unwrap().components[2] = poly(&[0.0, 8.0e-6]);
    m.axis_mut(Z).unwrap().location[3] = -1.5e-5;
    m.axis_mut(A).unwrap().location[1] = 0.012;
    m.axis_mut(A).unwrap().location[4] = 3.0e-5;
    m.axis_mut(C).unwrap().location[0] = 0.008;
    m.axis_mut(C).unwrap().components[5] = poly(&[0.0, 1.0e-7]);
    m
}

fn positioning_spec(axis: &str, pose: &str) -> PositioningSpec {
    PositioningSpec {
        axis: axis.into(),
        targets: Some(7),
        runs: 1,
        at_mm: None,
        pose: pose.into(),
        csv: None,
    }
}

#[test]
fn positioning_at_a_turned_table_reads_the_axis_own_scale_error() {
    // EXX = k·X (EYY = k·Y): the error of the relative motion along the axis itself. With the
    // table turned, the tool moves relative to the workpiece along the turned axis, and the
    // laser along that motion reads k·(t − t0) at every pose; VE·e_x is then a straightness.
    let k = 2.5e-5;
    for (machine, poses) in [
        (five_axis(), vec!["C=30", "C=90", "B=-30,C=200"]),
        (table_table(), vec!["A=-30", "A=-30,C=60", "C=90"]),
    ] {
        for (axis, letter, index) in [("X", X, 0), ("Y", Y, 1)] {
            let mut m = machine.clone();
            m.axis_mut(letter).unwrap().components[index] = Some(ErrorFunction::Poly(vec![0.0, k]));
            for pose in &poses {
                let setup = Setup::new(&m, pose).unwrap();
                let result = standards::positioning(&setup, &positioning_spec(axis, pose)).unwrap();
                let t0 = result.positions[0];
                assert_eq!(result.predicted[0].len(), result.positions.len());
                for (t, x) in result.positions.iter().zip(&result.predicted[0]) {
                    let expected = k * (t - t0);
                    assert!(
                        (x - expected).abs() < 1e-12,
                        "{} {axis} at {pose}, {t}: {x} against {expected}",
                        m.chain.hwang_notation()
                    );
                }
                let e = result.figures.iter().find(|f| f.name == "E").unwrap();
                let travel = m.axis(letter).unwrap().range;
                assert!((e.predicted - k * (travel[1] - travel[0])).abs() < 1e-12);
            }
        }
    }
    // At C = 90 on FYXCFZB the X motion runs along the workpiece's −y: VE has no x part.
    let mut m = five_axis();
    m.axis_mut(X).unwrap().components[0] = Some(ErrorFunction::Poly(vec![0.0, k]));
    let setup = Setup::new(&m, "C=90").unwrap();
    let ve = setup
        .deviation(
            &setup.command(Vector3::new(800.0, 300.0, 250.0)),
            &[None; 6],
        )
        .volumetric_mm;
    assert!(
        ve.x.abs() < 1e-12 && (ve.norm() - k * 800.0).abs() < 1e-12,
        "{ve}"
    );
}

/// Where the ideal machine puts the tool tip (workpiece frame).
fn ideal_tip(machine: &Machine, setup: &Setup, xyz: Vector3<f64>) -> Vector3<f64> {
    tool_pose(&machine.without_errors(), &setup.command(xyz)).0
}

#[test]
fn diagonals_and_circles_at_poses_are_the_ideal_tip_plus_ve() {
    let hwang = embedded::load("5axis-hwang2014").unwrap();
    let cases = [
        (hwang.clone(), "C=30"),
        (hwang.clone(), "C=60"),
        (hwang.clone(), "C=90"),
        (hwang, "B=20,C=90"),
        (table_table_with_errors(), "A=-30"),
        (table_table_with_errors(), "A=-30,C=60"),
        (table_table_with_errors(), "C=90"),
    ];
    let mut largest_change = 0f64;
    for (machine, pose) in &cases {
        let setup = Setup::new(machine, pose).unwrap();
        let name = machine.chain.hwang_notation();
        // The body diagonal PPP: every axis moving +.
        let spec = DiagonalSpec {
            diagonal: Some("PPP".into()),
            from_mm: None,
            to_mm: None,
            points: 9,
            pose: pose.to_string(),
            csv: None,
        };
        let result = standards::diagonal(&setup, &spec).unwrap();
        let (lo, hi) = setup.travel_box().unwrap();
        let (from, to) = standards::diagonal_ends("PPP", lo, hi).unwrap();
        let length = (to - from).norm();
        let direction = (to - from) / length;
        // The ideal tip's path from start to end, in the workpiece frame.
        let laser = (ideal_tip(machine, &setup, to) - ideal_tip(machine, &setup, from)) / length;
        assert!((laser.norm() - 1.0).abs() < 1e-12);
        let mut moving = [None; 6];
        for l in [X, Y, Z] {
            moving[l.index()] = Some(Approach::Positive);
        }
        let ve = |s: f64| {
            setup
                .deviation(&setup.command(from + s * direction), &moving)
                .volumetric_mm
        };
        assert_eq!(result.predicted[0].len(), result.positions.len());
        assert!(!result.positions.is_empty());
        for (s, e) in result.positions.iter().zip(&result.predicted[0]) {
            let expected = (ve(*s) - ve(0.0)).dot(&laser);
            assert!(
                (e - expected).abs() < 1e-12,
                "{name} {pose} diagonal at {s}: {e} against {expected}"
            );
            largest_change = largest_change.max((e - (ve(*s) - ve(0.0)).dot(&direction)).abs());
        }
        // A circle in XY about the middle of the travels: the tool ball at the ideal tip plus
        // VE, the centre ball where the set-up put it (VE at the centre, axes approaching +).
        let r = 120.0;
        let circle = CircularSpec {
            plane: "XY".into(),
            centre_mm: None,
            radius_mm: Some(r),
            points: 24,
            direction: "ccw".into(),
            start_deg: 0.0,
            pose: pose.to_string(),
            csv: None,
            pitch_mm: None,
        };
        let result = standards::circular(&setup, &circle).unwrap();
        let centre = (lo + hi) / 2.0;
        let centre_ball = ideal_tip(machine, &setup, centre)
            + setup
                .deviation(&setup.command(centre), &[None; 6])
                .volumetric_mm;
        assert_eq!(result.predicted[0].len(), result.positions.len());
        assert!(!result.positions.is_empty());
        for (t, dr) in result.positions.iter().zip(&result.predicted[0]) {
            let (s, c) = t.to_radians().sin_cos();
            let p = centre + r * Vector3::new(c, s, 0.0);
            let (dx, dy) = circle_directions(*t, 1.0);
            let mut directions = [None; 6];
            directions[X.index()] = Some(dx);
            directions[Y.index()] = Some(dy);
            let tool_ball = ideal_tip(machine, &setup, p)
                + setup
                    .deviation(&setup.command(p), &directions)
                    .volumetric_mm;
            let expected = (tool_ball - centre_ball).norm() - r;
            assert!(
                (dr - expected).abs() < 1e-11,
                "{name} {pose} circle at {t}°: {dr} against {expected}"
            );
        }
    }
    // Reading along the commanded diagonal instead would be off by micrometres.
    assert!(largest_change > 1e-3, "{largest_change}");
}

fn xy_circle(centre: [f64; 3], r: f64, pose: &str) -> CircularSpec {
    CircularSpec {
        plane: "XY".into(),
        centre_mm: Some(centre),
        radius_mm: Some(r),
        points: 72,
        direction: "ccw".into(),
        start_deg: 0.0,
        pose: pose.into(),
        csv: None,
        pitch_mm: None,
    }
}

#[test]
fn a_constant_offset_moves_both_balls_alike() {
    // Location errors of the linear axes and a spindle offset: a VE constant over the circle at
    // any fixed pose, which moves the centre ball as it moves the tool ball: F = G = 0.
    let mut m = five_axis();
    m.axis_mut(X).unwrap().location[0] = 0.010;
    m.axis_mut(Y).unwrap().location[1] = -0.020;
    m.axis_mut(Z).unwrap().location[2] = 0.005;
    m.spindle[0] = 0.003;
    for pose in ["", "C=90", "B=30,C=45"] {
        let setup = Setup::new(&m, pose).unwrap();
        let centre = Vector3::new(300.0, 250.0, 200.0);
        let ve = setup
            .deviation(&setup.command(centre), &[None; 6])
            .volumetric_mm;
        assert!(ve.norm() > 0.02, "{pose}: {ve}");
        let result = standards::circular(&setup, &xy_circle(centre.into(), 150.0, pose)).unwrap();
        assert!(!result.figures.is_empty(), "{pose}");
        for f in &result.figures {
            assert!(f.predicted.abs() < 1e-11, "{pose}: {f:?}");
        }
        let range = result.predicted[0].iter().fold(0f64, |a, v| a.max(v.abs()));
        assert!(range < 1e-11, "{pose}: {range}");
    }
}

#[test]
fn a_squareness_gives_f_and_g_about_the_centre_ball() {
    // EC0Y = S on an X-Y table: the tool ball relative to the centre ball is
    // (r cos θ − S·r sin θ, r sin θ) to first order, wherever the centre stands, so
    // dr = −(S·r/2)·sin 2θ: F max = S·r/2, F min = −S·r/2, G = S·r (second-order terms below
    // S²·r = 6e-8 mm). About the commanded centre at Y = 150 mm, F would carry −S·150·cos θ.
    let (s, r) = (2.0e-5, 150.0);
    let mut m = super::standards::three_axis();
    m.axis_mut(Y).unwrap().location[5] = s;
    let setup = Setup::new(&m, "").unwrap();
    let result = standards::circular(&setup, &xy_circle([100.0, 150.0, 0.0], r, "")).unwrap();
    let value = |name: &str| {
        result
            .figures
            .iter()
            .find(|f| f.name == name)
            .unwrap()
            .predicted
    };
    assert!(
        (value("F max") - s * r / 2.0).abs() < 1e-7,
        "{}",
        value("F max")
    );
    assert!(
        (value("F min") + s * r / 2.0).abs() < 1e-7,
        "{}",
        value("F min")
    );
    assert!((value("G") - s * r).abs() < 1e-7, "{}", value("G"));
}

#[test]
fn the_geometric_circle_fits_points_on_an_offset_circle_exactly() {
    // Readings about a centre ball 0.05 mm off the circle's centre (a, b) = (0.03, −0.04),
    // radius r + 0.002: dr(θ) = |(a, b) + (r + ρ)(cos φ, sin φ)| − r at the angle θ of that
    // point. The geometric fit finds (ρ, a, b) and zero residuals; the linearised one leaves
    // second-order residuals of about (a² + b²)/(2r).
    let (r, rho, a, b) = (300.0, 0.002, 0.03, -0.04);
    let mut angles = Vec::new();
    let mut radial = Vec::new();
    for i in 0..36 {
        let phi = (10.0 * i as f64 + 3.0).to_radians();
        let (x, y) = (a + (r + rho) * phi.cos(), b + (r + rho) * phi.sin());
        angles.push(y.atan2(x).to_degrees());
        radial.push(x.hypot(y) - r);
    }
    let ([fit_rho, fit_a, fit_b], residuals) =
        standards::geometric_circle(&angles, &radial, r).unwrap();
    assert!((fit_rho - rho).abs() < 1e-12 && (fit_a - a).abs() < 1e-12);
    assert!((fit_b - b).abs() < 1e-12);
    assert!(residuals.iter().all(|e| e.abs() < 1e-12), "{residuals:?}");
    let (_, linear) = standards::least_squares_circle(&angles, &radial).unwrap();
    assert!(linear.iter().any(|e| e.abs() > 1e-7));
}

#[test]
fn positions_rounded_past_the_ends_are_the_ends() {
    let mut m = super::standards::three_axis();
    m.axis_mut(X).unwrap().components[0] = Some(ErrorFunction::Poly(vec![0.0, 1.0e-5]));
    let setup = Setup::new(&m, "").unwrap();
    let dir = tempfile::tempdir().unwrap();
    // From (0, 0, 0) to (100, 100, 100): 173.2050808 mm, written to the µm as 173.206.
    let spec = |csv: &str| DiagonalSpec {
        diagonal: None,
        from_mm: Some([0.0; 3]),
        to_mm: Some([100.0; 3]),
        points: 5,
        pose: String::new(),
        csv: Some(write(&dir, "d.csv", csv)),
    };
    let length = 30000f64.sqrt();
    let result = standards::diagonal(
        &setup,
        &spec("position_mm,deviation_um\n-0.0004,0\n100,0.33\n173.206,0.58\n"),
    )
    .unwrap();
    assert_eq!(result.positions[0], 0.0);
    assert!((result.positions[2] - length).abs() < 1e-12);
    // e(s) = k·s·d_x² = 1e-5·s/3 at the end.
    assert!((result.predicted[0][2] - 1.0e-5 * length / 3.0).abs() < 1e-12);
    // Beyond the tolerance: the file and line, and the tolerance.
    let error = standards::diagonal(
        &setup,
        &spec("position_mm,deviation_um\n0,0\n173.207,0.58\n"),
    );
    expect_csv_error(error, 3, "off the diagonal");
    let text = standards::diagonal(
        &setup,
        &spec("position_mm,deviation_um\n0,0\n173.207,0.58\n"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        text.contains("d.csv") && text.contains("0.001 mm"),
        "{text}"
    );
    // Positioning targets rounded past the travel's ends (X: −400 to 400).
    let runs = "target_mm,direction,run,deviation_mm\n\
                -400.0004,+,1,0\n0,+,1,0\n400.0003,+,1,0\n\
                400.0003,-,1,0\n0,-,1,0\n-400.0004,-,1,0\n";
    let positioning = PositioningSpec {
        csv: Some(write(&dir, "x.csv", runs)),
        ..positioning_spec("X", "")
    };
    let result = standards::positioning(&setup, &positioning).unwrap();
    assert_eq!(result.positions, [-400.0, 0.0, 400.0]);
    assert!((result.predicted[0][2] - 1.0e-5 * 800.0).abs() < 1e-12);
}

#[test]
fn the_r_test_at_a_tilted_cradle_reads_the_sphere_from_the_nest() {
    // C turning with A at −30°: at each angle the linear axes put the ideal tip on the sphere
    // s; the nest reads the sphere against the real tip in the spindle frame,
    // R_idealᵀ·(s − p_real), zeroed at the first angle: the ideal tip in the workpiece frame,
    // as the other tests read.
    let m = table_table_with_errors();
    let setup = Setup::new(&m, "A=-30").unwrap();
    let sphere = Vector3::new(40.0, -30.0, 120.0);
    let spec = volmap::standards::RTestSpec {
        axis: "C".into(),
        sphere_mm: Some(sphere.into()),
        from_deg: Some(0.0),
        to_deg: Some(90.0),
        step_deg: 30.0,
        pose: "A=-30".into(),
        csv: None,
    };
    let result = standards::rtest(&setup, &spec).unwrap();
    let ideal = m.without_errors();
    let reading = |angle: f64| {
        let mut pose = setup.pose;
        pose[C.index()] = angle;
        let command = setup.nominal_command_for_tip(sphere, &pose).unwrap();
        let (p_ideal, r_ideal) = tool_pose(&ideal, &command);
        assert!((p_ideal - sphere).norm() < 1e-9);
        r_ideal.transpose() * (sphere - tool_pose(&m, &command).0)
    };
    let zero = reading(0.0);
    for (n, angle) in result.positions.iter().enumerate() {
        let expected = reading(*angle) - zero;
        for d in 0..3 {
            assert!(
                (result.predicted[d][n] - expected[d]).abs() < 1e-12,
                "C = {angle}, {d}: {} against {}",
                result.predicted[d][n],
                expected[d]
            );
        }
    }
    assert!(result.predicted[0].iter().any(|v| v.abs() > 1e-3));
}
