//! Machine design: error budgets, Monte Carlo over sampled machines and the probability that a
//! part conforms, against cases derived by hand and against the f64 reference.

use std::path::Path;

use volmap::design::budget::budget;
use volmap::design::conformance::conformance;
use volmap::design::monte_carlo::{MonteCarlo, Study};
use volmap::engine::{DeviceChoice, Engine};
use volmap::io::embedded;
use volmap::io::tolerance_file::ToleranceFile;
use volmap::model::grid::Grid;
use volmap::model::poses::parse_sweep;
use volmap::model::statistics::FieldStats;
use volmap::model::{AxisLetter::*, Machine};
use volmap::part::{PartFile, Verdict};
use volmap::reference::Twin;

use super::common::gpu;

/// Every engine these tests hold to the same answers: the CPU engine, and the GPU where there is
/// an adapter.
fn engines() -> Vec<Engine> {
    let mut engines = vec![Engine::Cpu];
    if gpu().is_some() {
        engines.push(Engine::select(DeviceChoice::Gpu).unwrap().0);
    }
    engines
}

fn tolerances(text: &str, machine: &Machine) -> ToleranceFile {
    ToleranceFile::parse(text, Path::new("t.toml"), machine).unwrap()
}

/// The statistics of a machine's field over grids, point by point with the f64 reference.
fn reference_stats(machine: &Machine, grids: &[Grid]) -> FieldStats {
    let twin = Twin::of(machine);
    let mut total = FieldStats::default();
    for (pose, grid) in grids.iter().enumerate() {
        let mut stats = FieldStats::default();
        for p in 0..grid.points() {
            let d = twin.deviation(&grid.command(grid.indices(p)));
            let (ve, oe) = (d.volumetric_mm, d.orientation_rad);
            stats.add_point(p, [oe.x, oe.y, oe.z], [ve.x, ve.y, ve.z]);
        }
        total.merge(&stats, pose);
    }
    total
}

fn assert_stats_close(got: &FieldStats, want: &FieldStats, what: &str) {
    let close = |a: f64, b: f64, tol: f64, name: &str| {
        assert!((a - b).abs() <= tol, "{what}: {name} {a} vs {b}");
    };
    close(got.max_ve_mm, want.max_ve_mm, 1e-6, "max |VE|");
    close(got.rms_ve_mm(), want.rms_ve_mm(), 1e-6, "RMS |VE|");
    close(got.max_oe_rad, want.max_oe_rad, 1e-9, "max |OE|");
    for d in 0..3 {
        close(
            got.max_axis_mm[d],
            want.max_axis_mm[d],
            1e-6,
            "max |VE| along an axis",
        );
    }
    assert_eq!(got.points, want.points, "{what}: points");
}

/// The 5-axis machine with only `key = value` in the section of `axis`, every other error value
/// removed: a machine file written by hand.
fn five_axis_with_only(axis: &str, line: &str) -> Machine {
    let mut text =
        String::from("name = \"bare\"\nchain = \"FYXCFZB\"\n[tool]\noffset = [0.0, 0.0, -250.0]\n");
    for (letter, range, offset) in [
        ("Y", "[0.0, 600.0]", None),
        ("X", "[0.0, 800.0]", None),
        ("C", "[0.0, 360.0]", Some("[0.0, 0.0, 150.0]")),
        ("Z", "[0.0, 500.0]", None),
        ("B", "[-110.0, 110.0]", None),
    ] {
        text += &format!("[axes.{letter}]\nrange = {range}\n");
        if let Some(o) = offset {
            text += &format!("offset = {o}\n");
        }
        if letter == axis {
            text += &format!("{line}\n");
        }
    }
    if axis == "spindle" {
        text += &format!("[spindle]\n{line}\n");
    }
    Machine::from_toml(&text, "bare.toml", None).unwrap()
}

#[test]
fn a_budget_of_one_term_equals_that_terms_own_map() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let grids: Vec<Grid> = parse_sweep("B=-30:30:60,C=0:90:90", &machine)
        .unwrap()
        .into_iter()
        .map(|pose| Grid::full_travel(&machine, [7, 6, 5], pose).unwrap())
        .collect();
    // (tolerance, the same term written into a bare machine file at its limit by hand)
    let cases = [
        ("[axes.C]\nEB0C = { uniform = 2e-5 }", "C", "EB0C = 2e-5"),
        (
            "[axes.Y]\nEXY = { normal = 0.002, shape = \"line\" }",
            "Y",
            "EXY = { poly = [0.0, 6.666666666666667e-6] }",
        ),
        // A bow over [0, 800] reaching 0.003 mid-travel: 4s(q − 0)(800 − q)/800².
        (
            "[axes.X]\nEZX = { uniform = 0.003, shape = \"bow\" }",
            "X",
            "EZX = { poly = [0.0, 1.5e-5, -1.875e-8] }",
        ),
        ("[axes.B]\nEBB = { uniform = 1.5e-5 }", "B", "EBB = 1.5e-5"),
        (
            "[spindle]\nEZS = { normal = 0.002 }",
            "spindle",
            "EZS = 0.004",
        ),
        (
            "[axes.Z]\nEA0Z = { uniform = 1.2e-5 }",
            "Z",
            "EA0Z = 1.2e-5",
        ),
    ];
    for engine in engines() {
        for (tolerance, axis, line) in cases {
            let file = tolerances(tolerance, &machine);
            let b = budget(&engine, &machine, &file.tolerances, &grids, |_| {}).unwrap();
            assert_eq!(b.rows.len(), 1);
            let want = reference_stats(&five_axis_with_only(axis, line), &grids);
            let what = format!("{tolerance} on {}", engine.name());
            assert_stats_close(&b.rows[0].stats, &want, &what);
            assert!(want.max_ve_mm > 1e-4, "{what}: the term moves the tip");
            assert_eq!(b.rows[0].share, 1.0);
            assert!((b.total_rss_mm - b.rows[0].stats.max_ve_mm).abs() < 1e-15);
            // Where it is worst: the reference's |VE| there is the largest.
            let at = b.rows[0].worst_at;
            let twin = Twin::of(&five_axis_with_only(axis, line));
            let there = twin.deviation(&at).volumetric_mm.norm();
            assert!(
                (there - want.max_ve_mm).abs() < 1e-6,
                "{what}: worst at {at:?}"
            );
        }
    }
}

#[test]
fn budget_rows_are_sorted_with_shares_of_the_root_sum_of_squares() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let grids = [Grid::full_travel(&machine, [6, 5, 4], [0.0; 6]).unwrap()];
    let file = tolerances(
        "[axes.Y]\nEC0Y = { uniform = 1e-5 }\nEYY = { normal = 0.004 }\n[spindle]\nEXS = { uniform = 0.003 }",
        &machine,
    );
    let b = budget(&Engine::Cpu, &machine, &file.tolerances, &grids, |_| {}).unwrap();
    let keys: Vec<String> = b
        .rows
        .iter()
        .map(|r| r.tolerance.perturbation.target.key())
        .collect();
    // EC0Y: 1e-5 · 600 mm of Y travel = 0.006; EYY at 2σ = 0.008; EXS 0.003.
    assert_eq!(keys, ["axes.Y.EYY", "axes.Y.EC0Y", "spindle.EXS"]);
    let max: Vec<f64> = b.rows.iter().map(|r| r.stats.max_ve_mm).collect();
    for (m, want) in max.iter().zip([0.008, 0.006, 0.003]) {
        assert!((m - want).abs() < 1e-9, "{m} vs {want}");
    }
    let total = (0.008f64.powi(2) + 0.006f64.powi(2) + 0.003f64.powi(2)).sqrt();
    assert!((b.total_rss_mm - total).abs() < 1e-9);
    for (row, m) in b.rows.iter().zip(&max) {
        assert!((row.share - m * m / b.total_rss_mm.powi(2)).abs() < 1e-12);
        assert!((row.share - want_share(*m, total)).abs() < 1e-6);
    }
    assert!((b.rows.iter().map(|r| r.share).sum::<f64>() - 1.0).abs() < 1e-12);
}

fn want_share(max_ve_mm: f64, total_mm: f64) -> f64 {
    max_ve_mm * max_ve_mm / (total_mm * total_mm)
}

#[test]
fn zero_widths_give_every_sample_the_nominal_machines_statistics_exactly() {
    let machine = embedded::load("4axis-hwang2014").unwrap();
    let grids: Vec<Grid> = parse_sweep("C=0:180:90", &machine)
        .unwrap()
        .into_iter()
        .map(|pose| Grid::full_travel(&machine, [9, 5, 4], pose).unwrap())
        .collect();
    let file = tolerances(
        "[axes.C]\nEX0C = { normal = 0.0 }\nEA0C = { uniform = 0.0 }\n[axes.X]\nEXX = { normal = 0, shape = \"line\" }\nEZX = { uniform = 0.0, shape = \"bow\" }\n[spindle]\nEZS = { uniform = 0.0 }",
        &machine,
    );
    let nominal = reference_stats(&machine, &grids);
    for engine in engines() {
        let study = Study {
            machine: &machine,
            tolerances: &file.tolerances,
            grids: &grids,
            seed: 9,
        };
        let stats = study.sample_stats(&engine, 40, &[1.0; 5], |_| {}).unwrap();
        let first = &stats[0];
        for s in &stats {
            assert_eq!(
                s,
                first,
                "every sample the same machine on {}",
                engine.name()
            );
        }
        // The engine's own map of the nominal machine, sample by sample exactly.
        let own = engine
            .variant_stats(
                &volmap::engine::variants::Variants {
                    base: &machine,
                    perturbations: &[],
                },
                &[vec![]],
                &grids,
                |_| {},
            )
            .unwrap();
        assert_eq!(first, &own[0], "{}", engine.name());
        assert_stats_close(first, &nominal, &engine.name());
        let mc = MonteCarlo::of(&stats, 9, Some(first.max_ve_mm));
        assert_eq!(mc.max_ve_mm.std, 0.0);
        assert_eq!(mc.max_ve_mm.p5, first.max_ve_mm);
        assert_eq!(mc.within_spec.unwrap().fraction.fraction, 1.0);
    }
}

/// A 3-axis machine without errors: X, Y, Z on the tool side (FFXYZ), Y over 600 mm.
fn bare_gantry() -> Machine {
    Machine::nominal(
        "gantry",
        "FFXYZ",
        &[(X, [0.0, 1000.0]), (Y, [0.0, 600.0]), (Z, [0.0, 500.0])],
    )
    .unwrap()
}

#[test]
fn a_uniform_squareness_alone_gives_max_ve_uniform_from_zero_to_a_times_the_travel() {
    let machine = bare_gantry();
    let a = 2e-5;
    let length = 600.0;
    let grids = [Grid::full_travel(&machine, [5, 7, 3], [0.0; 6]).unwrap()];
    let file = tolerances("[axes.Y]\nEC0Y = { uniform = 2e-5 }", &machine);
    let study = Study {
        machine: &machine,
        tolerances: &file.tolerances,
        grids: &grids,
        seed: 2024,
    };
    let n = 4000;
    for engine in engines() {
        let stats = study.sample_stats(&engine, n, &[1.0], |_| {}).unwrap();
        // Sample by sample: a rotation s about z of Y's motion moves the tip by 2 sin(|s|/2)·y.
        let draws = study.amplitudes(0, n, &[1.0]);
        assert_eq!((stats.len(), draws.len()), (n, n));
        for (s, row) in stats.iter().zip(&draws) {
            let want = 2.0 * (row[0].abs() / 2.0).sin() * length;
            assert!(
                (s.max_ve_mm - want).abs() < 1e-6,
                "{} vs {want}",
                s.max_ve_mm
            );
        }
        // Over the samples: uniform on [0, a·L].
        let mc = MonteCarlo::of(&stats, 2024, Some(0.25 * a * length));
        let top = a * length;
        let sigma = |p: f64| (p * (1.0 - p) / n as f64).sqrt() * top;
        for (got, p) in [
            (mc.max_ve_mm.p5, 0.05),
            (mc.max_ve_mm.p50, 0.5),
            (mc.max_ve_mm.p95, 0.95),
            (mc.max_ve_mm.p99, 0.99),
        ] {
            assert!(
                (got - p * top).abs() < 4.5 * sigma(p),
                "P{}: {got} vs {}",
                p * 100.0,
                p * top
            );
        }
        assert!((mc.max_ve_mm.mean - top / 2.0).abs() < 4.5 * top / (12.0 * n as f64).sqrt());
        assert!((mc.max_ve_mm.std - top / 12f64.sqrt()).abs() < 0.05 * top / 12f64.sqrt());
        let within = mc.within_spec.unwrap().fraction;
        assert!((within.fraction - 0.25).abs() < 4.5 * sigma(0.25) / top);
        assert!(within.ci95[0] < 0.25 && 0.25 < within.ci95[1], "{within:?}");
    }
}

#[test]
fn the_same_seed_gives_the_same_machines_on_every_engine_and_another_seed_others() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let grids: Vec<Grid> = parse_sweep("B=0:45:45,C=30", &machine)
        .unwrap()
        .into_iter()
        .map(|pose| Grid::full_travel(&machine, [9, 5, 4], pose).unwrap())
        .collect();
    let file = ToleranceFile::load(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("examples/tolerances/5axis-hwang2014.toml")
            .as_path(),
        &machine,
    )
    .unwrap();
    let ones = vec![1.0; file.tolerances.len()];
    let study = |seed| Study {
        machine: &machine,
        tolerances: &file.tolerances,
        grids: &grids,
        seed,
    };
    let cpu = study(5)
        .sample_stats(&Engine::Cpu, 30, &ones, |_| {})
        .unwrap();
    for engine in engines() {
        let got = study(5).sample_stats(&engine, 30, &ones, |_| {}).unwrap();
        assert_eq!((got.len(), cpu.len()), (30, 30));
        for (s, (g, c)) in got.iter().zip(&cpu).enumerate() {
            assert_stats_close(g, c, &format!("sample {s} on {}", engine.name()));
            assert_eq!(g.max_ve_pose, c.max_ve_pose);
        }
    }
    let other = study(6)
        .sample_stats(&Engine::Cpu, 30, &ones, |_| {})
        .unwrap();
    assert_ne!(other[0].max_ve_mm, cpu[0].max_ve_mm);
    // A sample's draws do not depend on how many samples are drawn.
    let fewer = study(5)
        .sample_stats(&Engine::Cpu, 7, &ones, |_| {})
        .unwrap();
    assert_eq!(&fewer[..], &cpu[..7]);
}

#[test]
fn the_fraction_of_conforming_floors_under_a_z_straightness_tolerance_is_its_analytic_value() {
    // A floor over the whole X travel on an error-free gantry; EZX a bow of amplitude s ~ U(−h, h)
    // over X makes the floor's flatness |s|, so it conforms with probability tolerance/h.
    let machine = Machine::nominal(
        "gantry",
        "FFXYZ",
        &[(X, [0.0, 400.0]), (Y, [0.0, 300.0]), (Z, [-100.0, 100.0])],
    )
    .unwrap();
    let part = PartFile::parse(
        r#"
name = "floor"
[placement]
zero_mm = [0.0, 0.0, 0.0]
[cutter]
radius_mm = 5.0
length_mm = 40.0
[sampling]
spacing_mm = 10.0
[[features]]
kind = "end_milled_plane"
name = "floor"
corner_mm = [0.0, 0.0, -10.0]
size_mm = [400.0, 100.0]
tolerance_mm = 0.005
"#,
        "part.toml",
    )
    .unwrap();
    let h = 0.02;
    let file = tolerances(
        "[axes.X]\nEZX = { uniform = 0.02, shape = \"bow\" }",
        &machine,
    );
    let study = Study {
        machine: &machine,
        tolerances: &file.tolerances,
        grids: &[],
        seed: 77,
    };
    let n = 2000;
    for engine in engines() {
        let rows = conformance(&engine, &study, &part, "part.toml", n, 0.2, |_| {}).unwrap();
        let floor = &rows[0];
        let p: f64 = 0.005 / h;
        let sigma = (p * (1.0 - p) / n as f64).sqrt();
        assert!(
            (floor.conforming_fraction - p).abs() < 4.5 * sigma,
            "{} on {}",
            floor.conforming_fraction,
            engine.name()
        );
        assert!(floor.conforming_ci95[0] < p && p < floor.conforming_ci95[1]);
        // |s| is uniform on [0, h]: its median is h/2, its P95 0.95h.
        assert!((floor.error_p50_mm - 0.5 * h).abs() < 4.5 * (0.25 / n as f64).sqrt() * h);
        assert!((floor.error_p95_mm - 0.95 * h).abs() < 4.5 * (0.0475 / n as f64).sqrt() * h);
        assert_eq!(
            floor.error_mm, 0.0,
            "the nominal machine makes a flat floor"
        );
        assert_eq!(floor.verdict, Verdict::Fit, "0.25 of the floors reach 0.2");
        let strict = conformance(&engine, &study, &part, "part.toml", n, 0.3, |_| {}).unwrap();
        assert_eq!(strict[0].verdict, Verdict::Unfit);
    }
}

#[test]
fn sampled_machines_with_errors_of_other_axes_give_the_same_statistics_on_every_engine() {
    // The gantry's cross-rail sag is a table of Y and Z and its roll an error of Y's position:
    // the GPU folds each sampled machine into tables of its parts; every sample against the
    // reference.
    let machine = embedded::load("gantry-2m").unwrap();
    assert!(machine.has_cross_axis_errors());
    let grids = vec![Grid::full_travel(&machine, [7, 5, 4], [0.0; 6]).unwrap()];
    let file = ToleranceFile::load(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("examples/tolerances/gantry-2m.toml")
            .as_path(),
        &machine,
    )
    .unwrap();
    let ones = vec![1.0; file.tolerances.len()];
    let study = Study {
        machine: &machine,
        tolerances: &file.tolerances,
        grids: &grids,
        seed: 3,
    };
    let variants = volmap::engine::variants::Variants {
        base: &machine,
        perturbations: &study.perturbations(),
    };
    let rows = study.amplitudes(0, 12, &ones);
    for engine in engines() {
        let got = engine
            .variant_stats(&variants, &rows, &grids, |_| {})
            .unwrap();
        assert_eq!((got.len(), rows.len()), (12, 12));
        for (s, (g, row)) in got.iter().zip(&rows).enumerate() {
            let want = reference_stats(&variants.machine(row), &grids);
            assert_stats_close(g, &want, &format!("sample {s} on {}", engine.name()));
        }
    }
}
