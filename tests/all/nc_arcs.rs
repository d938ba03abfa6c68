//! Arcs that stay arcs, and the program as written: on the embedded machines, where errors vary
//! along every arc, a compensated arc becomes a few compensated arcs, every end point lands, and
//! the real tool tip along the written (rounded) program stays within the chord tolerance.

use volmap::io::embedded;
use volmap::model::Machine;
use volmap::nc::{self, Options};

/// Arcs of every kind: a full circle by I J, an R arc, a quarter by I J, a half circle in G18, a
/// helical full turn, between straight moves.
const ARCS: &str = "G90 G17 G21 G54
G0 X0 Y0 Z5.
G1 Z-2. F300
G1 X40. F800
G3 X40. Y0 I-40. J0
G2 X0 Y40. R40.
G1 X-30.
G3 X-60. Y10. I-15. J-15.
G18 G2 X-90. Z-2. I-15. K0
G17 G2 X-90. Y10. Z-5. I20. J0
G0 Z5.
M30
";

/// The arcs' lines, and the turns (quarter turns, rounded up) each sweeps.
const ARC_LINES: [(usize, usize); 5] = [(5, 4), (6, 1), (8, 2), (9, 2), (10, 4)];

fn options(decimals: usize) -> Options {
    let mut options = Options {
        decimals: Some(decimals),
        ..Options::default()
    };
    options
        .work_offsets
        .insert(54, [400.0, 300.0, 100.0, 0.0, 0.0, 0.0]);
    options
}

/// The largest distance of the real end point of each input block, run from the output, from
/// the ideal end point of the input block (mm).
fn largest_landing_error(machine: &Machine, out: &nc::Compensated, options: &Options) -> f64 {
    let meant = nc::trace(machine, ARCS.as_bytes(), "in.nc", options).unwrap();
    let landed = nc::trace(machine, out.text.as_bytes(), "out.nc", options).unwrap();
    meant
        .iter()
        .map(|m| {
            let last = out.origins.iter().rposition(|&o| o == m.line).unwrap() + 1;
            let l = landed.iter().find(|p| p.line == last).unwrap();
            (l.real - m.ideal).norm()
        })
        .fold(0.0, f64::max)
}

#[test]
fn arcs_on_the_embedded_machines_become_a_few_compensated_arcs() {
    for name in ["gantry-2m", "vmc-li2015"] {
        let machine = embedded::load(name).unwrap();
        let options = options(4);
        let out = nc::compensate(&machine, ARCS.as_bytes(), "arcs.nc", &options).unwrap();
        let lines: Vec<&str> = out.text.lines().collect();
        assert_eq!(lines.len(), out.origins.len());
        for (line, quarters) in ARC_LINES {
            let written: Vec<&str> = lines
                .iter()
                .zip(&out.origins)
                .filter(|(_, &o)| o == line)
                .map(|(l, _)| *l)
                .collect();
            // Stated bound: at most 4 blocks per quarter turn the arc sweeps, and 1 more (an arc
            // piece sweeps at most 90° and is halved at most once on these machines; a turning
            // point adds a take-up and a short straight edge where it lies inside the arc).
            assert!(
                written.len() <= 4 * quarters + 1,
                "{name}: line {line} became {} blocks:\n{}",
                written.len(),
                written.join("\n")
            );
            // The arc pieces are arcs, their centre words as the program has them: R stays R,
            // I J K stay I J K; straight pieces have none.
            let uses_r = ARCS.lines().nth(line - 1).unwrap().contains('R');
            let centre_words = |w: &str| (w.contains('R'), w.contains('I') || w.contains('K'));
            let arcs = written
                .iter()
                .filter(|w| centre_words(w) != (false, false))
                .count();
            assert!(
                2 * arcs >= written.len(),
                "{name}: line {line}: {written:?}"
            );
            for w in &written {
                let (r, ijk) = centre_words(w);
                assert!(if uses_r { !ijk } else { !r }, "{name}: line {line}: {w}");
            }
        }
        assert!(
            out.report.largest_error_before_mm > 5.0 * options.chord_tolerance_mm,
            "{name}: errors too small to test: {:?}",
            out.report
        );
    }
}

#[test]
fn the_written_program_lands_and_stays_within_the_tolerance_after_rounding() {
    for name in ["gantry-2m", "vmc-li2015"] {
        let machine = embedded::load(name).unwrap();
        for decimals in [4, 7] {
            let options = options(decimals);
            let out = nc::compensate(&machine, ARCS.as_bytes(), "arcs.nc", &options).unwrap();
            // A written coordinate is within half a unit of its last decimal of the exact one:
            // at most √3/2 units in space.
            let rounding = 3f64.sqrt() / 2.0 * 10f64.powi(-(decimals as i32));
            let landing = largest_landing_error(&machine, &out, &options);
            assert!(
                landing <= 1e-6 + rounding,
                "{name} at {decimals} decimals: {landing}"
            );
            // The real tip along the program as written (its words read back), against the
            // intended path of the block each line comes from.
            let samples =
                nc::trace_compensated(&machine, (ARCS.as_bytes(), &out), "arcs.nc", &options, 0.05)
                    .unwrap();
            // (Take-ups, where the tip stands while the command crosses a reversal, are left out.)
            let after = samples
                .iter()
                .filter(|s| s.motion != 0)
                .map(|s| s.deviation_mm)
                .fold(0.0, f64::max);
            assert!(
                after <= options.chord_tolerance_mm + rounding,
                "{name} at {decimals} decimals: {after} mm along the written program"
            );
            // The report is about the written program, measured as the trace measures it (from
            // the intended point at the same fraction): they agree to the rounding (the trace
            // takes a piece's fractions from where its real ends land, the compensation from
            // its plan).
            assert!(
                (after - out.report.largest_error_after_mm).abs() <= rounding
                    && out.report.largest_error_after_mm <= options.chord_tolerance_mm,
                "{name}: {after} mm checked, {:?} reported",
                out.report
            );
            assert!(
                after >= 0.5 * out.report.largest_error_after_mm,
                "{name}: {after} mm checked, {:?} reported",
                out.report
            );
        }
    }
}
