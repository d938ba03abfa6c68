//! Batches of sampled machines: the GPU's on-device statistics and its values at positions against
//! the CPU engine and the reference, sample by sample.

use volmap::engine::variants::Variants;
use volmap::engine::Engine;
use volmap::io::embedded;
use volmap::model::grid::Grid;
use volmap::model::perturbation::{ErrorTarget, Perturbation, Shape};
use volmap::model::AxisLetter::*;
use volmap::model::Machine;

use super::common::{gpu, Rng};

/// Deviations of every kind on `machine`: components of every shape, locations, the spindle.
fn perturbations(machine: &Machine) -> Vec<Perturbation> {
    let mut out = Vec::new();
    for (k, axis) in machine.axes.iter().enumerate() {
        for index in 0..6 {
            let shape = [Shape::Constant, Shape::Line, Shape::Bow][(index + k) % 3];
            out.push(Perturbation {
                target: ErrorTarget::Component {
                    axis: axis.letter,
                    index,
                },
                shape,
            });
        }
        for index in [0, 4, 5] {
            out.push(Perturbation {
                target: ErrorTarget::Location {
                    axis: axis.letter,
                    index,
                },
                shape: Shape::Constant,
            });
        }
    }
    for index in [0, 2, 3] {
        out.push(Perturbation {
            target: ErrorTarget::Spindle { index },
            shape: Shape::Constant,
        });
    }
    out
}

/// Random amplitudes of realistic size: 20 µm and 40 µrad.
fn rows(perturbations: &[Perturbation], samples: usize, rng: &mut Rng) -> Vec<Vec<f64>> {
    (0..samples)
        .map(|_| {
            perturbations
                .iter()
                .map(|p| {
                    let h = if p.target.is_angular() { 4e-5 } else { 0.02 };
                    rng.uniform(-h, h)
                })
                .collect()
        })
        .collect()
}

#[test]
fn gpu_statistics_of_sampled_machines_match_the_cpu_engine_sample_by_sample() {
    let Some(gpu) = gpu() else { return };
    for (name, pose, dims) in [
        ("vmc-li2015", [0.0; 6], [17, 9, 6]),
        (
            "5axis-hwang2014",
            [0.0, 0.0, 0.0, 0.0, 30.0, 60.0],
            [13, 7, 5],
        ),
        (
            "4axis-hwang2014",
            [0.0, 0.0, 0.0, 0.0, 0.0, 40.0],
            [9, 11, 4],
        ),
    ] {
        let machine = embedded::load(name).unwrap();
        let perturbations = perturbations(&machine);
        let rows = rows(&perturbations, 7, &mut Rng::new(3));
        let variants = Variants {
            base: &machine,
            perturbations: &perturbations,
        };
        let grids = [Grid::full_travel(&machine, dims, pose).unwrap()];
        let on_gpu = gpu
            .variant_stats(&machine, &perturbations, &rows, &grids[0], |_| {})
            .unwrap();
        let on_cpu = Engine::Cpu
            .variant_stats(&variants, &rows, &grids, |_| {})
            .unwrap();
        assert_eq!((on_gpu.len(), on_cpu.len()), (rows.len(), rows.len()));
        for (s, (g, c)) in on_gpu.iter().zip(&on_cpu).enumerate() {
            let close = |a: f64, b: f64, tol: f64, what: &str| {
                assert!((a - b).abs() <= tol, "{name} sample {s} {what}: {a} vs {b}");
            };
            close(g.max_ve_mm, c.max_ve_mm, 1e-6, "max |VE|");
            close(g.rms_ve_mm(), c.rms_ve_mm(), 1e-6, "RMS |VE|");
            close(g.max_oe_rad, c.max_oe_rad, 1e-9, "max |OE|");
            for d in 0..3 {
                close(
                    g.max_axis_mm[d],
                    c.max_axis_mm[d],
                    1e-6,
                    "max |VE| along an axis",
                );
            }
            assert_eq!(g.points, c.points);
            assert!(c.max_ve_mm > 1e-3, "{name}: the samples have errors");
        }
    }
}

#[test]
fn gpu_values_of_sampled_machines_at_positions_match_the_reference_sample_by_sample() {
    let Some(gpu) = gpu() else { return };
    for (name, rotary) in [
        ("vmc-li2015", [0.0, 0.0, 0.0]),
        ("5axis-hwang2014", [0.0, 30.0, 60.0]),
        ("4axis-hwang2014", [0.0, 0.0, 40.0]),
    ] {
        let machine = embedded::load(name).unwrap();
        let perturbations = perturbations(&machine);
        let mut rng = Rng::new(11);
        let rows = rows(&perturbations, 5, &mut rng);
        let ranges: Vec<[f64; 2]> = [X, Y, Z]
            .iter()
            .map(|&l| machine.axis(l).map_or([0.0, 0.0], |a| a.range))
            .collect();
        let commands: Vec<[f64; 6]> = (0..37)
            .map(|_| {
                let mut c = [0.0; 6];
                for d in 0..3 {
                    c[d] = rng.uniform(ranges[d][0], ranges[d][1]);
                }
                c[3..].copy_from_slice(&rotary);
                c
            })
            .collect();
        let variants = Variants {
            base: &machine,
            perturbations: &perturbations,
        };
        let on_gpu = gpu
            .variant_values(&machine, &perturbations, &rows, &commands, |_| {})
            .unwrap();
        let on_cpu = Engine::Cpu
            .variant_values(&variants, &rows, &commands, |_| {})
            .unwrap();
        assert_eq!(on_gpu.len(), rows.len());
        assert_eq!(on_cpu.len(), rows.len());
        for (s, (g, c)) in on_gpu.iter().zip(&on_cpu).enumerate() {
            assert_eq!(g.len(), commands.len());
            assert_eq!(c.len(), commands.len());
            for (p, (gv, cv)) in g.iter().zip(c).enumerate() {
                for k in 0..6 {
                    let tol = if k < 3 { 1e-6 } else { 1e-9 };
                    assert!(
                        (gv[k] - cv[k]).abs() <= tol,
                        "{name} sample {s} position {p} value {k}: {} vs {}",
                        gv[k],
                        cv[k]
                    );
                }
            }
        }
    }
}
