//! Arcs given by R, as written: each written R arc carries the sign its own sweep needs (R < 0
//! where it turns more than half a turn), so a piece of an arc programmed with R < 0 is written
//! with R > 0, and an arc near a half turn gets the sign its written ends need. The written
//! program is read back by hand here (the centre a control computes from the start, end, R and
//! direction), not by volmap's reader.

use std::f64::consts::{PI, TAU};

use volmap::io::embedded;
use volmap::nc::{self, Options};

/// An arc from (0, 0) to (30, 0) in G17 on the 4th line, and its programmed centre (mm) and
/// sweep (rad, negative clockwise).
fn program(arc: &str) -> String {
    format!("G90 G21 G17\nG0 X0 Y0 Z10\nG1 Z0 F100\n{arc}\nM30\n")
}

/// The arcs: R < 0 (286.26°: centre (15, 20), half chord 15, offset √(25² − 15²) = 20) both
/// ways; R > 0 (73.74°, centre on the other side); a half turn (R 15: centre (15, 0)), where the
/// correction decides which side of a half turn the written arc is; and the same long arc by
/// I J (written with centre words, which the sign does not touch).
fn arcs() -> Vec<(&'static str, [f64; 2], f64)> {
    // 2·asin(15/25) = 73.74°: the short arc; the long one is the rest of the turn.
    let short = 2.0 * (15f64 / 25.0).asin();
    let long = TAU - short;
    vec![
        ("G2 X30 Y0 R-25", [15.0, 20.0], -long),
        ("G3 X30 Y0 R-25", [15.0, -20.0], long),
        ("G2 X30 Y0 R25", [15.0, -20.0], -short),
        ("G3 X30 Y0 R25", [15.0, 20.0], short),
        ("G2 X30 Y0 R15", [15.0, 0.0], -PI),
        ("G3 X30 Y0 R-15", [15.0, 0.0], PI),
        ("G2 X30 Y0 I15 J20", [15.0, 20.0], -long),
    ]
}

/// One written arc: its start and end (mm, plane), centre and sweep as a control computes them.
struct Written {
    centre: [f64; 2],
    sweep: f64,
    from: [f64; 2],
    radius_word: Option<f64>,
}

/// The written arcs of the lines of `out` that come from input line `line`, read by hand: the
/// axis words modal from the line before, the centre from I J (relative to the start) or R (the
/// centre on the perpendicular bisector of the chord at √(R² − c²/4), left of the chord for G3
/// R > 0, right for G2 R > 0, the other side for R < 0).
fn written_arcs(out: &nc::Compensated, line: usize) -> Vec<Written> {
    let mut at = [0.0f64; 2];
    let mut motion = 0;
    let mut arcs = Vec::new();
    assert_eq!(out.text.lines().count(), out.origins.len());
    for (text, &origin) in out.text.lines().zip(&out.origins) {
        let mut to = at;
        let (mut r, mut ij) = (None, [None, None]);
        for word in text.split_whitespace() {
            let (letter, value) = word.split_at(1);
            let Ok(value) = value.parse::<f64>() else {
                continue;
            };
            match letter {
                "G" if value < 4.0 => motion = value as u32,
                "X" => to[0] = value,
                "Y" => to[1] = value,
                "R" => r = Some(value),
                "I" => ij[0] = Some(value),
                "J" => ij[1] = Some(value),
                _ => {}
            }
        }
        if origin == line && (motion == 2 || motion == 3) {
            let centre = if let Some(r) = r {
                let (du, dv) = (to[0] - at[0], to[1] - at[1]);
                let chord = du.hypot(dv);
                let h = (r * r - chord * chord / 4.0).max(0.0).sqrt();
                let side = if motion == 3 { 1.0 } else { -1.0 } * r.signum();
                let left = [-dv / chord, du / chord];
                [
                    at[0] + du / 2.0 + side * h * left[0],
                    at[1] + dv / 2.0 + side * h * left[1],
                ]
            } else {
                [at[0] + ij[0].unwrap_or(0.0), at[1] + ij[1].unwrap_or(0.0)]
            };
            let angle = |p: [f64; 2]| (p[1] - centre[1]).atan2(p[0] - centre[0]);
            let turn = (angle(to) - angle(at)).rem_euclid(TAU);
            let sweep = if motion == 3 { turn } else { turn - TAU };
            arcs.push(Written {
                centre,
                sweep,
                from: at,
                radius_word: r,
            });
        }
        at = to;
    }
    arcs
}

#[test]
fn each_arc_written_by_r_carries_the_sign_of_its_own_sweep() {
    let mut options = Options::default();
    options
        .work_offsets
        .insert(54, [400.0, 300.0, 250.0, 0.0, 0.0, 0.0]);
    let mut half_turns_seen = [false; 2];
    for name in ["vmc-li2015", "gantry-2m"] {
        let machine = embedded::load(name).unwrap();
        for (arc, centre, sweep) in arcs() {
            let out = nc::compensate(&machine, program(arc).as_bytes(), "r.nc", &options)
                .unwrap_or_else(|e| panic!("{name}: {arc}: {e}"));
            let written = written_arcs(&out, 4);
            assert!(!written.is_empty(), "{name}: {arc}: no arc:\n{}", out.text);
            // The written path is the intended one moved by the correction (at most the largest
            // correction at the compensated points; it varies by less than half of it along
            // these arcs on both machines, hence 1.5×), within the chord tolerance, plus the
            // written words' rounding (4 decimals: 0.5e-4 mm in each of the start, end and R,
            // a few 1e-4 mm on a centre over this chord). The fault this guards against puts a
            // piece the long way round, tens of mm off.
            let bound = 1.5 * out.report.largest_correction_mm + options.chord_tolerance_mm + 5e-4;
            assert!(
                bound < 0.5,
                "{name}: corrections too large to test: {bound}"
            );
            let mut total = 0.0;
            for w in &written {
                // Every written R arc turns the way its sign says.
                if let Some(r) = w.radius_word {
                    assert_eq!(
                        r < 0.0,
                        w.sweep.abs() > PI,
                        "{name}: {arc}: R{r} on a piece of {:.2}°:\n{}",
                        w.sweep.to_degrees(),
                        out.text
                    );
                    if (sweep.abs() - PI).abs() < 1e-9 {
                        half_turns_seen[usize::from(r < 0.0)] = true;
                    }
                }
                // Sampled every ~0.5°, the written arc stays on the programmed circle.
                let radius = (w.from[0] - w.centre[0]).hypot(w.from[1] - w.centre[1]);
                let a0 = (w.from[1] - w.centre[1]).atan2(w.from[0] - w.centre[0]);
                let n = (w.sweep.abs().to_degrees() * 2.0).ceil() as usize;
                for k in 0..=n {
                    let a = a0 + w.sweep * k as f64 / n as f64;
                    let p = [
                        w.centre[0] + radius * a.cos(),
                        w.centre[1] + radius * a.sin(),
                    ];
                    let off = ((p[0] - centre[0]).hypot(p[1] - centre[1])
                        - (centre[0] - 0.0).hypot(centre[1]))
                    .abs();
                    assert!(
                        off <= bound,
                        "{name}: {arc}: {off} mm off the programmed circle (bound {bound}):\n{}",
                        out.text
                    );
                }
                total += w.sweep;
            }
            // The pieces together turn as the programmed arc: each end moved by at most the
            // bound, an angle of at most bound / 15 mm (the shortest distance from the centre
            // to an end's chord neighbourhood) at each end.
            assert!(
                (total - sweep).abs() <= 2.0 * bound / 15.0,
                "{name}: {arc}: the pieces turn {:.3}°, the program {:.3}°:\n{}",
                total.to_degrees(),
                sweep.to_degrees(),
                out.text
            );
        }
    }
    // Either sign may be right for a half turn once corrected; the test only needs one seen.
    assert!(
        half_turns_seen.iter().any(|&s| s),
        "no half turn written by R"
    );
}
