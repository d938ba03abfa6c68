//! The f64 reference against hand-derived results and chain identities.

use nalgebra::{Matrix4, Vector3};
use proptest::prelude::*;
use volmap::model::{AxisLetter, Chain, ErrorFunction, Machine};
use volmap::reference::{self, deviation, relative_transform};

use super::common::{all_five_axis_chains, ranges, with_random_errors, Rng};
use AxisLetter::*;

fn vmc() -> Machine {
    Machine::nominal(
        "vmc",
        "FYXFZ",
        &[(X, [0.0, 600.0]), (Y, [0.0, 400.0]), (Z, [0.0, 300.0])],
    )
    .unwrap()
}

fn close(a: Vector3<f64>, b: Vector3<f64>, tol: f64) -> bool {
    (a - b).norm() <= tol
}

#[test]
fn squareness_alone() {
    // EC0Y = ε tilts +Y towards −X: p = (x − y sin ε, y cos ε, z), OE = (0, 0, ε).
    let eps = 1.5e-4;
    let mut m = vmc();
    m.axis_mut(Y).unwrap().location[5] = eps;
    let (x, y, z) = (123.0, 345.0, 67.0);
    let d = deviation(&m, &[x, y, z, 0.0, 0.0, 0.0]);
    let want = Vector3::new(-y * eps.sin(), y * (eps.cos() - 1.0), 0.0);
    assert!(
        close(d.volumetric_mm, want, 1e-13),
        "{:?} vs {want:?}",
        d.volumetric_mm
    );
    assert!(close(d.orientation_rad, Vector3::new(0.0, 0.0, eps), 1e-16));
    // The angle between the real +X and +Y motions is 90° + ε.
    let ex = deviation(&m, &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]).volumetric_mm + Vector3::x();
    let ey = deviation(&m, &[0.0, 1.0, 0.0, 0.0, 0.0, 0.0]).volumetric_mm + Vector3::y();
    let angle = (ex.dot(&ey) / (ex.norm() * ey.norm())).acos();
    assert!((angle - (std::f64::consts::FRAC_PI_2 + eps)).abs() < 1e-12);
}

#[test]
fn pitch_error_with_its_abbe_offset() {
    // EBX(x) = b0 + b1·x pitches everything X carries; the tool tip sits h = z − L from the X
    // guideway line, so VE = (h sin β, 0, h (cos β − 1)).
    let (b0, b1, l) = (2e-5, 3e-8, 150.0);
    let mut m = vmc();
    m.tool_offset_mm = [0.0, 0.0, -l];
    m.axis_mut(X).unwrap().components[4] = Some(ErrorFunction::Poly(vec![b0, b1]));
    for (x, y, z) in [(0.0, 0.0, 0.0), (500.0, 100.0, 250.0), (300.0, 399.0, 10.0)] {
        let beta: f64 = b0 + b1 * x;
        let h = z - l;
        let d = deviation(&m, &[x, y, z, 0.0, 0.0, 0.0]);
        let want = Vector3::new(h * beta.sin(), 0.0, h * (beta.cos() - 1.0));
        assert!(
            close(d.volumetric_mm, want, 1e-13),
            "x={x}: {:?} vs {want:?}",
            d.volumetric_mm
        );
        assert!(close(
            d.orientation_rad,
            Vector3::new(0.0, beta, 0.0),
            1e-16
        ));
    }
}

#[test]
fn rotary_axis_location_error() {
    // A C table on the bed whose average line is off by δ in x and tilted by α about x:
    // A_C = Trans(δ x̂)·Rx(α)·Rz(θ), so VE = δ x̂ + (Rx(α) − I)·Rz(θ)·p and OE = (α, 0, 0).
    let (delta, alpha) = (0.004, 3e-5);
    let mut m = Machine::nominal(
        "rt",
        "FCFXYZ",
        &[
            (C, [0.0, 360.0]),
            (X, [0.0, 500.0]),
            (Y, [0.0, 500.0]),
            (Z, [0.0, 500.0]),
        ],
    )
    .unwrap();
    let c = m.axis_mut(C).unwrap();
    c.location[0] = delta;
    c.location[3] = alpha;
    for theta in [0.0f64, 30.0, 135.0, 270.0] {
        let p = Vector3::new(210.0, -80.0, 120.0);
        let d = deviation(&m, &[p.x, p.y, p.z, 0.0, 0.0, theta]);
        let rz = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), theta.to_radians());
        let rx = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), alpha);
        let want = Vector3::new(delta, 0.0, 0.0)
            + (rx.matrix() - nalgebra::Matrix3::identity()) * (rz * p);
        assert!(
            close(d.volumetric_mm, want, 1e-13),
            "θ={theta}: {:?} vs {want:?}",
            d.volumetric_mm
        );
        assert!(close(
            d.orientation_rad,
            Vector3::new(alpha, 0.0, 0.0),
            1e-16
        ));
    }
}

#[test]
fn zero_errors_give_zero_error_for_all_720_five_axis_orders() {
    let chains = all_five_axis_chains([X, Y, Z, B, C]);
    assert_eq!(chains.len(), 720);
    let mut rng = Rng::new(7);
    for chain in &chains {
        let mut m = Machine::nominal("m", chain, &ranges(&[X, Y, Z, B, C])).unwrap();
        m.tool_offset_mm = [5.0, -3.0, -120.0];
        let mut offsets = Vector3::from(m.tool_offset_mm);
        for axis in &mut m.axes {
            axis.offset_mm = [
                rng.uniform(-50.0, 50.0),
                rng.uniform(-50.0, 50.0),
                rng.uniform(-50.0, 50.0),
            ];
            offsets += Vector3::from(axis.offset_mm);
        }
        let command = [
            rng.uniform(-900.0, 900.0),
            rng.uniform(-900.0, 900.0),
            rng.uniform(-900.0, 900.0),
            0.0,
            rng.uniform(-180.0, 180.0),
            rng.uniform(-180.0, 180.0),
        ];
        let d = deviation(&m, &command);
        assert_eq!(d.volumetric_mm, Vector3::zeros(), "{chain}");
        assert_eq!(d.orientation_rad, Vector3::zeros(), "{chain}");
        // Rotary axes at zero: the tip is the commanded linear position plus the nominal offsets.
        let at_zero = [command[0], command[1], command[2], 0.0, 0.0, 0.0];
        let (tip, _) = reference::tool_pose(&m, &at_zero);
        let want = Vector3::new(command[0], command[1], command[2]) + offsets;
        assert!(close(tip, want, 1e-9), "{chain}: {tip:?} vs {want:?}");
    }
}

const FIVE_AXIS_BODY: &str = r#"
name = "five"
[tool]
offset = [0.0, 0.0, -200.0]
[axes.X]
range = [0.0, 800.0]
EXX = { table = [[0, 0.0], [400, 0.006], [800, 0.01]], interp = "quadratic" }
EBX = 1.0e-5
[axes.Y]
range = [0.0, 600.0]
EC0Y = 2.0e-5
[axes.Z]
range = [0.0, 500.0]
EA0Z = -1.0e-5
[axes.B]
range = [-110.0, 110.0]
EX0B = 0.005
EBB = { poly = [0.0, 1.0e-7] }
[axes.C]
range = [0.0, 360.0]
offset = [0.0, 0.0, 150.0]
EA0C = 2.0e-5
ECC = { table = [[0, 0.0], [90, 1.0e-5], [180, 0.0], [270, -1.0e-5]], interp = "cubic", periodic = true }
"#;

#[test]
fn hwang_and_iso10791_chains_are_the_same_machine() {
    let hwang = Machine::from_toml(
        &format!("chain = \"FYXCFZB\"\n{FIVE_AXIS_BODY}"),
        "hwang.toml",
        None,
    )
    .unwrap();
    let iso = Machine::from_toml(
        &format!("chain = \"w C' X' Y' b Z B t\"\n{FIVE_AXIS_BODY}"),
        "iso.toml",
        None,
    )
    .unwrap();
    assert_eq!(hwang.chain, iso.chain);
    assert_eq!(hwang.chain.product_order(), vec![C, X, Y, Z, B]);
    let mut rng = Rng::new(3);
    for _ in 0..50 {
        let c = [
            rng.uniform(0.0, 800.0),
            rng.uniform(0.0, 600.0),
            rng.uniform(0.0, 500.0),
            0.0,
            rng.uniform(-110.0, 110.0),
            rng.uniform(0.0, 360.0),
        ];
        assert_eq!(deviation(&hwang, &c), deviation(&iso, &c));
        assert_eq!(relative_transform(&hwang, &c), relative_transform(&iso, &c));
    }
}

/// `E_rel = T_work⁻¹ · T_tool` with the branches built as docs/model.md defines them, inverses
/// and all.
fn e_rel_from_branches(m: &Machine, command: &[f64; 6]) -> Matrix4<f64> {
    let a = |l: AxisLetter| reference::axis_transform(m.axis(l).unwrap(), command[l.index()]);
    let t_work = m
        .chain
        .work
        .iter()
        .fold(Matrix4::<f64>::identity(), |acc, &l| {
            acc * a(l).try_inverse().unwrap()
        });
    let [exs, eys, ezs, eas, ebs] = m.spindle;
    let t_tool = m
        .chain
        .tool
        .iter()
        .fold(Matrix4::<f64>::identity(), |acc, &l| acc * a(l))
        * reference::error_transform([exs, eys, ezs, eas, ebs, 0.0])
        * reference::trans(Vector3::from(m.tool_offset_mm));
    t_work.try_inverse().unwrap() * t_tool
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The product order of docs/model.md equals the definition with the work branch inverted.
    #[test]
    fn chain_product_equals_inverted_work_branch(chain_index in 0usize..720, seed in any::<u64>(), q in prop::array::uniform6(-1.0f64..1.0)) {
        let chain = &all_five_axis_chains([X, Y, Z, A, C])[chain_index];
        let mut rng = Rng::new(seed);
        let m = with_random_errors(Machine::nominal("p", chain, &ranges(&[X, Y, Z, A, C])).unwrap(), &mut rng);
        let command = [q[0] * 1000.0, q[1] * 1000.0, q[2] * 1000.0, q[3] * 180.0, 0.0, q[5] * 180.0];
        let direct = relative_transform(&m, &command);
        let defined = e_rel_from_branches(&m, &command);
        prop_assert!((direct - defined).abs().max() < 1e-9, "{chain}");
    }

    /// An error-free machine deviates by exactly zero, whatever its chain and position.
    #[test]
    fn error_free_machines_have_no_error(chain_index in 0usize..720, q in prop::array::uniform6(-1.0f64..1.0)) {
        let chain = &all_five_axis_chains([X, Y, Z, B, C])[chain_index];
        let m = Machine::nominal("p", chain, &ranges(&[X, Y, Z, B, C])).unwrap();
        let command = [q[0] * 1000.0, q[1] * 1000.0, q[2] * 1000.0, 0.0, q[4] * 180.0, q[5] * 180.0];
        let d = deviation(&m, &command);
        prop_assert_eq!(d.volumetric_mm, Vector3::zeros());
        prop_assert_eq!(d.orientation_rad, Vector3::zeros());
    }

    /// A constant spindle translation error at zero rotation shows one to one in VE.
    #[test]
    fn spindle_offset_shows_one_to_one(e in prop::array::uniform3(-0.01f64..0.01), q in prop::array::uniform3(0.0f64..1.0)) {
        let mut m = Machine::nominal("s", "FYXFZ", &[(X, [0.0, 600.0]), (Y, [0.0, 400.0]), (Z, [0.0, 300.0])]).unwrap();
        m.spindle = [e[0], e[1], e[2], 0.0, 0.0];
        let d = deviation(&m, &[q[0] * 600.0, q[1] * 400.0, q[2] * 300.0, 0.0, 0.0, 0.0]);
        prop_assert!((d.volumetric_mm - Vector3::from(e)).norm() < 1e-12);
    }
}

#[test]
fn iso10791_code_round_trips_for_every_chain() {
    for chain in all_five_axis_chains([X, Y, Z, B, C]) {
        let parsed = Chain::parse(&chain).unwrap();
        assert_eq!(
            Chain::parse(&parsed.iso10791_code()).unwrap(),
            parsed,
            "{chain}"
        );
    }
}

#[test]
fn rotation_vector_is_accurate_for_tiny_rotations() {
    let r = nalgebra::Rotation3::from_scaled_axis(Vector3::new(3e-9, -2e-7, 5e-6));
    let v = reference::rotation_vector(r.matrix());
    assert!((v - Vector3::new(3e-9, -2e-7, 5e-6)).norm() < 1e-20);
}

#[test]
fn a_twin_commands_the_tip_where_it_is_asked_for() {
    // A five-axis machine with errors of every kind, at a pose: the ideal command is one exact
    // step, the real one lands the real tip on the target, and the deviation is the difference
    // of the two tips.
    let chain = "FYXCFZB";
    let letters: Vec<AxisLetter> = Chain::parse(chain).unwrap().axes().collect();
    let machine = with_random_errors(
        Machine::nominal("five", chain, &ranges(&letters)).unwrap(),
        &mut Rng::new(41),
    );
    let twin = reference::Twin::of(&machine);
    let start = [100.0, -200.0, 50.0, 0.0, 30.0, -60.0];
    let target = Vector3::new(250.0, 120.0, -80.0);
    let ideal = twin.ideal_command_for(target, &start).unwrap();
    assert!(close(twin.ideal_tip(&ideal), target, 1e-9));
    assert_eq!(ideal[3..], start[3..], "rotary axes stay");
    let inverse = twin.ideal_jacobian(&start).try_inverse().unwrap();
    let real = twin.real_command_for(target, &ideal, &inverse).unwrap();
    assert!(close(twin.real_tip(&real), target, 1e-9));
    assert_eq!(real[3..], start[3..], "rotary axes stay");
    let d = twin.deviation(&ideal).volumetric_mm;
    assert!(close(
        d,
        twin.real_tip(&ideal) - twin.ideal_tip(&ideal),
        1e-12
    ));
    assert!(close(real_minus_ideal(&twin, &ideal), d, 1e-12));
}

fn real_minus_ideal(twin: &reference::Twin, command: &[f64; 6]) -> Vector3<f64> {
    deviation(twin.real(), command).volumetric_mm
}
