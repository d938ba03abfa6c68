//! Machines that hold few errors, on every GPU kernel against the f64 reference: one with no
//! component error (a designer's first model, every location-only term of an error budget), one
//! with no location error, the ideal machine. Their buffers are the smallest a machine packs
//! into; every binding must still meet the kernel's minimum size, and the values the reference's.

use volmap::engine::map::{oe_tolerance_rad, ve_tolerance_mm};
use volmap::engine::variants::Variants;
use volmap::engine::Engine;
use volmap::io::embedded;
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;
use volmap::model::perturbation::{ErrorTarget, Perturbation, Shape};
use volmap::model::{AxisLetter, Machine};
use volmap::reference::Twin;

use super::common::gpu;

/// The embedded machine `name` as given, without its component errors, without its location
/// errors, and with no error at all (the spindle's and the thermal and reversal values too).
fn sparse_machines(name: &str) -> Vec<(String, Machine)> {
    let machine = embedded::load(name).unwrap();
    let mut no_components = machine.clone();
    no_components.dependent.clear();
    for axis in &mut no_components.axes {
        axis.components = Default::default();
    }
    assert!(
        no_components.axes.iter().any(|a| a.location != [0.0; 6]),
        "{name}: location errors remain"
    );
    let mut no_locations = machine.clone();
    for axis in &mut no_locations.axes {
        axis.location = [0.0; 6];
    }
    let mut ideal = no_components.clone();
    ideal.spindle = [0.0; 5];
    for axis in &mut ideal.axes {
        axis.location = [0.0; 6];
    }
    vec![
        (format!("{name} without component errors"), no_components),
        (format!("{name} without location errors"), no_locations),
        (format!("{name}, ideal"), ideal),
    ]
}

/// The rotary pose each machine is mapped at.
fn pose_of(name: &str) -> [f64; 6] {
    match name {
        "5axis-hwang2014" => [0.0, 0.0, 0.0, 0.0, 30.0, 60.0],
        "4axis-hwang2014" => [0.0, 0.0, 0.0, 0.0, 0.0, 40.0],
        _ => [0.0; 6],
    }
}

const MACHINES: [&str; 3] = ["vmc-li2015", "5axis-hwang2014", "4axis-hwang2014"];

#[test]
fn maps_of_machines_with_few_errors_match_the_reference() {
    let Some(gpu) = gpu() else { return };
    for name in MACHINES {
        for (what, machine) in sparse_machines(name) {
            let grid = Grid::full_travel(&machine, [9, 7, 5], pose_of(name)).unwrap();
            let twin = Twin::of(&machine);
            let nx = grid.dims[0];
            let (mut ve, mut oe, mut lines) = (0.0f64, 0.0f64, 0);
            gpu.run(
                &machine,
                &grid,
                None,
                |first, count, data| -> Result<(), volmap::gpu::GpuError> {
                    for line in 0..count as usize {
                        let base = line * CHANNELS.len() * nx;
                        for i in 0..nx {
                            let p = (first as usize + line) * nx + i;
                            let want = volmap::engine::reference::point_values(
                                &twin,
                                &grid,
                                grid.indices(p as u64),
                            );
                            let d = |c: std::ops::Range<usize>| -> f64 {
                                c.map(|c| (data[base + c * nx + i] as f64 - want[c]).powi(2))
                                    .sum::<f64>()
                                    .sqrt()
                            };
                            // Each difference over its tolerance at the point (the one rule).
                            let norm = |c: std::ops::Range<usize>| {
                                c.map(|c| want[c] * want[c]).sum::<f64>().sqrt()
                            };
                            oe = oe.max(d(0..3) / oe_tolerance_rad(norm(0..3)));
                            ve = ve.max(d(3..6) / ve_tolerance_mm(norm(3..6)));
                        }
                    }
                    lines += count;
                    Ok(())
                },
            )
            .unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_eq!(lines, grid.lines(), "{what}");
            assert!(
                ve <= 1.0 && oe <= 1.0,
                "{what}: {ve} and {oe} of their tolerances"
            );
        }
    }
}

/// A tolerance of every kind the machine's axes take: a component of one shape, a location, the
/// spindle.
fn perturbations(machine: &Machine) -> Vec<Perturbation> {
    let first = machine.axes[0].letter;
    vec![
        Perturbation {
            target: ErrorTarget::Component {
                axis: first,
                index: 0,
            },
            shape: Shape::Bow,
        },
        Perturbation {
            target: ErrorTarget::Location {
                axis: machine.axes[machine.axes.len() - 1].letter,
                index: 4,
            },
            shape: Shape::Constant,
        },
        Perturbation {
            target: ErrorTarget::Spindle { index: 0 },
            shape: Shape::Constant,
        },
    ]
}

#[test]
fn sampled_machines_with_few_errors_match_the_cpu_engine_on_the_gpu() {
    let Some(gpu) = gpu() else { return };
    for name in MACHINES {
        for (what, machine) in sparse_machines(name) {
            let grids = [Grid::full_travel(&machine, [7, 5, 4], pose_of(name)).unwrap()];
            // A batch of tolerances, and a term alone at its limit (the budget's machines), and
            // no deviation at all.
            for perturbations in [
                perturbations(&machine),
                perturbations(&machine)[1..2].to_vec(),
            ] {
                let rows: Vec<Vec<f64>> = vec![
                    vec![0.0; perturbations.len()],
                    perturbations
                        .iter()
                        .map(|p| if p.target.is_angular() { 3e-5 } else { 0.01 })
                        .collect(),
                ];
                let variants = Variants {
                    base: &machine,
                    perturbations: &perturbations,
                };
                let on_gpu = gpu
                    .variant_stats(&machine, &perturbations, &rows, &grids[0], |_| {})
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
                let on_cpu = Engine::Cpu
                    .variant_stats(&variants, &rows, &grids, |_| {})
                    .unwrap();
                assert_eq!((on_gpu.len(), on_cpu.len()), (rows.len(), rows.len()));
                for (s, (g, c)) in on_gpu.iter().zip(&on_cpu).enumerate() {
                    let close = |a: f64, b: f64, tol: f64, which: &str| {
                        assert!(
                            (a - b).abs() <= tol,
                            "{what} sample {s} {which}: {a} vs {b}"
                        );
                    };
                    let (ve_tol, oe_tol) =
                        (ve_tolerance_mm(c.max_ve_mm), oe_tolerance_rad(c.max_oe_rad));
                    close(g.max_ve_mm, c.max_ve_mm, ve_tol, "max |VE|");
                    close(g.rms_ve_mm(), c.rms_ve_mm(), ve_tol, "RMS |VE|");
                    close(g.max_oe_rad, c.max_oe_rad, oe_tol, "max |OE|");
                    assert_eq!(g.points, c.points, "{what}");
                }
                assert!(on_cpu[1].max_ve_mm > 1e-3, "{what}: the deviation shows");
            }
        }
    }
}

#[test]
fn values_at_positions_of_machines_with_few_errors_match_the_reference_on_the_gpu() {
    let Some(gpu) = gpu() else { return };
    for name in MACHINES {
        for (what, machine) in sparse_machines(name) {
            let perturbations = perturbations(&machine);
            let rows = vec![vec![0.0; 3], vec![0.01, 3e-5, 0.002]];
            let pose = pose_of(name);
            let commands: Vec<[f64; 6]> = (0..5)
                .map(|k| {
                    let mut c = pose;
                    for (d, letter) in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z]
                        .into_iter()
                        .enumerate()
                    {
                        if let Some(axis) = machine.axis(letter) {
                            let [a, b] = axis.range;
                            c[d] = a + (b - a) * k as f64 / 4.0;
                        }
                    }
                    c
                })
                .collect();
            let on_gpu = gpu
                .variant_values(&machine, &perturbations, &rows, &commands, |_| {})
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            // The first row deviates nothing: the machine itself, against the reference.
            let twin = Twin::of(&machine);
            for (p, command) in commands.iter().enumerate() {
                let d = twin.deviation(command);
                let want = [d.volumetric_mm, d.orientation_rad];
                let (ve, oe) = (want[0].norm(), want[1].norm());
                for k in 0..6 {
                    let (tol, w) = if k < 3 {
                        (ve_tolerance_mm(ve), want[0][k])
                    } else {
                        (oe_tolerance_rad(oe), want[1][k - 3])
                    };
                    let g = on_gpu[0][p][k];
                    assert!(
                        (g - w).abs() <= tol,
                        "{what} position {p} value {k}: {g} vs {w}"
                    );
                }
            }
            let variants = Variants {
                base: &machine,
                perturbations: &perturbations,
            };
            let on_cpu = Engine::Cpu
                .variant_values(&variants, &rows, &commands, |_| {})
                .unwrap();
            assert_eq!(
                (on_gpu[1].len(), on_cpu[1].len()),
                (commands.len(), commands.len())
            );
            for (p, (g, c)) in on_gpu[1].iter().zip(&on_cpu[1]).enumerate() {
                let ve = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                let oe = (c[3] * c[3] + c[4] * c[4] + c[5] * c[5]).sqrt();
                for k in 0..6 {
                    let tol = if k < 3 {
                        ve_tolerance_mm(ve)
                    } else {
                        oe_tolerance_rad(oe)
                    };
                    assert!(
                        (g[k] - c[k]).abs() <= tol,
                        "{what} sampled, position {p} value {k}: {} vs {}",
                        g[k],
                        c[k]
                    );
                }
            }
        }
    }
}
