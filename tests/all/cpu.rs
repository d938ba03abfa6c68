//! The CPU engine (the f64 twin of the GPU passes) against the reference at every point: equal
//! up to the rounding of the f32 output.

use volmap::engine::cpu::CpuPlan;
use volmap::engine::reference::point_values;
use volmap::io::embedded;
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;
use volmap::model::{AxisLetter, Chain, Machine};

use super::common::{ranges, with_random_errors, Rng};

fn assert_plan_matches_reference(machine: &Machine, grid: &Grid) {
    let twin = volmap::reference::Twin::of(machine);
    let mut field = vec![0.0f32; grid.points() as usize * CHANNELS.len()];
    CpuPlan::new(machine, grid).compute_lines(0, grid.lines(), &mut field);
    let nx = grid.dims[0];
    for p in 0..grid.points() {
        let [i, j, k] = grid.indices(p);
        let want = point_values(&twin, grid, [i, j, k]);
        let line = j + k * grid.dims[1];
        for c in 0..6 {
            let got = field[(line * 6 + c) * nx + i] as f64;
            // f32 keeps 24 bits; the f64 paths agree far below that.
            assert!(
                (got - want[c]).abs() <= 6e-8 * want[c].abs() + 1e-15,
                "{} at ({i}, {j}, {k}) {}: {got:e} vs {:e}",
                machine.name,
                CHANNELS[c],
                want[c]
            );
        }
    }
}

#[test]
fn cpu_plan_matches_the_reference() {
    for (name, _) in embedded::EMBEDDED {
        let machine = embedded::load(name).unwrap();
        let pose = [0.0, 0.0, 0.0, 0.0, 25.0, 140.0];
        let mut pose_for_machine = [0.0; 6];
        for l in machine.rotary_axes() {
            pose_for_machine[l.index()] = pose[l.index()];
        }
        assert_plan_matches_reference(
            &machine,
            &Grid::full_travel(&machine, [9, 7, 5], pose_for_machine).unwrap(),
        );
    }
    let mut rng = Rng::new(5);
    for chain in ["FYXCFZB", "FCAFZYX", "FFYZ", "FXYZBF"] {
        let letters: Vec<AxisLetter> = Chain::parse(chain).unwrap().axes().collect();
        let machine = with_random_errors(
            Machine::nominal(chain, chain, &ranges(&letters)).unwrap(),
            &mut rng,
        );
        let mut dims = [6, 5, 4];
        let mut pose = [0.0; 6];
        for l in AxisLetter::ALL {
            if !letters.contains(&l) && l.is_linear() {
                dims[l.direction_index()] = 1;
            } else if !l.is_linear() {
                pose[l.index()] = rng.uniform(-180.0, 180.0);
            }
        }
        assert_plan_matches_reference(&machine, &Grid::full_travel(&machine, dims, pose).unwrap());
    }
}
