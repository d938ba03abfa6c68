//! Canned drilling cycles expanded into the moves the control makes of them, before the
//! compensation reads the program: each hole becomes a rapid to its X Y at the current level, a
//! rapid to the R plane, its feed moves into the hole (pecks, dwells) and the retract, so every
//! point of the plunge is compensated like any other move (the error varies along the plunge:
//! an R plane and a depth compensated at the hole's X Y alone would not put the tip on the hole's
//! axis all the way down).
//!
//! Semantics as Fanuc and LinuxCNC run them, in absolute distance (G90) in the XY plane (G17):
//! the initial level is Z before the cycle's first block; G98 retracts to it (or to R where R is
//! higher), G99 to R; where Z is below R the tool first rises to R. A later block with axis words
//! and no motion code drills another hole with the cycle's Z, R, Q, P unless it gives new ones;
//! L or K repeats a hole; G80 or a motion code (G0–G3) ends the cycle. G81 drills, G82 dwells P
//! at the bottom, G83 pecks Q deep retracting to R between pecks, G73 pecks Q breaking the chip
//! with a small retract, G85 feeds out, G89 dwells then feeds out. Cycles that need the spindle
//! synchronised, stopped or oriented (G74 G76 G84 G86 G87 G88), incremental cycles (G91) and
//! cycles in another plane are refused.

use super::modal::MM_PER_INCH;
use super::offsets::{offset_of, selected, shift, WorkOffsets};
use super::parse::{parse_line, Line};
use super::settings::{definite_g10, is_setting};
use super::subprograms::{Room, BLOCK_WORDS, MAX_EXPANDED_WORDS};
use super::unknown::unread_names_axis;
use crate::error::shown;
use crate::nc::error::NcError;

/// The most pecks a G73 or G83 hole may take from its R plane to its depth: a peck depth Q far
/// smaller than the hole (or a hole far deeper than any travel) would otherwise make moves
/// past any memory.
pub const MAX_PECKS: u32 = 10_000;

/// The retract of G73 and the clearance G83 stops above the last peck, mm (0.010 in on the
/// controls' defaults).
const PECK_CLEARANCE_MM: f64 = 0.254;
const PECK_CLEARANCE_INCH: f64 = 0.010;

/// A drilling cycle in force.
#[derive(Debug, Clone)]
struct Cycle {
    code: u32,
    depth: f64,
    r: f64,
    q: Option<f64>,
    dwell: Option<String>,
    initial: f64,
}

/// What the scan ahead of the compensation knows of the program.
struct Scan {
    absolute: bool,
    inch: bool,
    xy_plane: bool,
    retract_to_r: bool,
    z: Option<f64>,
    /// The work offset in force: a change of it moves nothing, so Z where it stands (and a
    /// cycle's initial level) is carried over in machine coordinates (`offsets`).
    offset: u32,
    /// The work offsets as the program has set them so far (G10), mm; NaN where not known.
    offsets: WorkOffsets,
    /// The G92 and G52 shifts of Z in force, mm.
    g92_z: f64,
    local_z: f64,
    cycle: Option<Cycle>,
    /// A cycle volmap does not expand, passed with `pass_unknown`: its holes pass too.
    passed_cycle: Option<String>,
}

fn g_codes(line: &Line) -> impl Iterator<Item = f64> + '_ {
    line.words
        .iter()
        .filter(|w| w.letter == 'G')
        .map(|w| w.value)
}

fn is_cycle_code(g: f64) -> bool {
    g.fract() == 0.0 && matches!(g as u32, 73 | 74 | 76 | 81..=89)
}

/// Why a cycle is not expanded, where it is not.
fn refusal(code: u32) -> Option<&'static str> {
    match code {
        74 | 84 => Some("tapping needs the spindle synchronised with the feed"),
        76 | 87 | 88 => Some("it orients or stops the spindle and shifts the tool in the hole"),
        86 => Some("it stops the spindle at the bottom"),
        _ => None,
    }
}

/// `v` written with at most 6 decimals, no trailing zeros.
fn number(v: f64) -> String {
    let text = format!("{v:.6}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

/// The program with every canned cycle expanded (see the module's documentation), and the
/// number of cycle blocks (holes) expanded.
pub(super) fn expand_cycles(
    lines: Vec<Line>,
    path: &str,
    pass_unknown: bool,
    work_offsets: &WorkOffsets,
    room: &mut Room,
) -> Result<(Vec<Line>, usize), NcError> {
    let mut holes = 0;
    let mut scan = Scan {
        absolute: true,
        inch: false,
        xy_plane: true,
        retract_to_r: false,
        z: None,
        offset: 54,
        offsets: work_offsets.clone(),
        g92_z: 0.0,
        local_z: 0.0,
        cycle: None,
        passed_cycle: None,
    };
    let mut out = Vec::with_capacity(lines.len());
    for mut line in lines {
        for g in g_codes(&line).collect::<Vec<_>>() {
            match g {
                _ if g.fract() != 0.0 => {}
                _ => match g as u32 {
                    20 => scan.inch = true,
                    21 => scan.inch = false,
                    90 => scan.absolute = true,
                    91 => scan.absolute = false,
                    17 => scan.xy_plane = true,
                    18 | 19 => scan.xy_plane = false,
                    98 => scan.retract_to_r = false,
                    99 => scan.retract_to_r = true,
                    0..=3 | 80 => {
                        scan.cycle = None;
                        scan.passed_cycle = None;
                    }
                    _ => {}
                },
            }
        }
        if let Some(to) = selected(&line) {
            let unit = if scan.inch { 25.4 } else { 1.0 };
            let dz = shift(&scan.offsets, scan.offset, to)[2] / unit;
            scan.z = scan.z.map(|z| z + dz).filter(|z| z.is_finite());
            if let Some(cycle) = scan.cycle.as_mut() {
                cycle.initial += dz;
            }
            scan.offset = to;
        }
        let code = g_codes(&line).find(|&g| is_cycle_code(g)).map(|g| g as u32);
        let axis_words = line
            .words
            .iter()
            .any(|w| matches!(w.letter, 'X' | 'Y' | 'Z'));
        if let Some(code) = code {
            let why = refusal(code)
                .or((!scan.absolute).then_some(
                    "canned cycles in incremental distance (G91) are not supported: program them in G90",
                ))
                .or((!scan.xy_plane)
                    .then_some("canned cycles are expanded in the XY plane (G17) only"));
            if let Some(why) = why {
                if !pass_unknown {
                    return Err(NcError::line(path, line.number, format!("G{code}: {why}")));
                }
                scan.cycle = None;
                scan.passed_cycle = Some(format!("G{code}"));
                line.unknown = Some(format!("G{code}"));
                out.push(line);
                continue;
            }
            scan.passed_cycle = None;
            let previous = scan.cycle.take();
            let value = |letter: char| line.word(letter).map(|w| w.value);
            let retained = |f: fn(&Cycle) -> f64| previous.as_ref().map(f);
            let missing = |what: &str| {
                NcError::line(
                    path,
                    line.number,
                    format!("G{code}: the cycle needs {what}"),
                )
            };
            let initial = match (&previous, scan.z) {
                (Some(p), _) => p.initial,
                (None, Some(z)) => z,
                (None, None) => {
                    return Err(missing("Z set before it (its initial level is not known)"))
                }
            };
            let cycle = Cycle {
                code,
                depth: value('Z')
                    .or(retained(|c| c.depth))
                    .ok_or_else(|| missing("its depth Z"))?,
                r: value('R')
                    .or(retained(|c| c.r))
                    .ok_or_else(|| missing("its R plane"))?,
                q: value('Q').or(previous.as_ref().and_then(|c| c.q)),
                dwell: line
                    .word('P')
                    .map(|w| line.text_of(w).to_string())
                    .or(previous.and_then(|c| c.dwell)),
                initial,
            };
            if matches!(code, 73 | 83) && !cycle.q.is_some_and(|q| q > 0.0) {
                return Err(missing("a positive peck depth Q"));
            }
            scan.cycle = Some(cycle);
            expand_hole(&line, &mut scan, path, room, &mut out)?;
            holes += 1;
        } else if scan.cycle.is_some() && line.unknown.is_some() && unread_names_axis(&line) {
            // A line volmap cannot read (macro words) may drill a hole of the cycle.
            return Err(NcError::line(
                path,
                line.number,
                "a block volmap cannot read while a canned cycle is in force: it may drill a hole whose depth is not known".into(),
            ));
        } else if scan.cycle.is_some() && axis_words && !is_setting(&line) {
            let cycle = scan.cycle.as_mut().expect("a cycle is in force");
            for (letter, slot) in [('Z', &mut cycle.depth), ('R', &mut cycle.r)] {
                if let Some(w) = line.word(letter) {
                    *slot = w.value;
                }
            }
            if let Some(w) = line.word('Q') {
                cycle.q = Some(w.value);
            }
            if let Some(w) = line.word('P') {
                cycle.dwell = Some(line.text_of(w).to_string());
            }
            expand_hole(&line, &mut scan, path, room, &mut out)?;
            holes += 1;
        } else {
            if scan.passed_cycle.is_some() && axis_words {
                line.unknown = scan.passed_cycle.clone();
            }
            if is_setting(&line) {
                scan.setting(&line);
            } else if g_codes(&line).any(|g| g == 28.0 || g == 30.0 || g == 53.0) {
                if line.has('Z') {
                    scan.z = None;
                }
            } else if let Some(w) = line.word('Z') {
                let z = if scan.absolute {
                    Some(w.value)
                } else {
                    scan.z.map(|z| z + w.value)
                };
                scan.z = z;
            }
            out.push(line);
        }
    }
    Ok((out, holes))
}

impl Scan {
    /// Z after a setting block (G10 L2/L20, G52, G92, G92.1/.2), in the coordinates it leaves
    /// in force, as `settings` takes it; not known where the block is one volmap refuses.
    fn setting(&mut self, line: &Line) {
        let unit = if self.inch { MM_PER_INCH } else { 1.0 };
        let code = |c: f64| g_codes(line).any(|g| g == c);
        let value = line.word('Z').map(|w| w.value);
        if code(92.1) || code(92.2) {
            self.z = self.z.map(|z| z + self.g92_z / unit);
            self.g92_z = 0.0;
        } else if code(92.0) {
            if let Some(v) = value {
                // The point where the tool stands reads as `v`.
                self.g92_z += self.z.map_or(f64::NAN, |z| (z - v) * unit);
                self.z = Some(v);
            }
        } else if code(52.0) {
            if let Some(v) = value {
                self.z = self.z.map(|z| z + self.local_z / unit - v);
                self.local_z = v * unit;
            }
        } else if let (Some(n), Some(v)) = (definite_g10(line), value) {
            let old = offset_of(&self.offsets, n)[2];
            let active = n == self.offset;
            let new = if line.word('L').is_some_and(|w| w.value == 20.0) {
                // The point where the tool stands reads as `v` in offset `n` (the shifts in
                // force alike in both).
                self.z.map_or(f64::NAN, |z| z * unit) + offset_of(&self.offsets, self.offset)[2]
                    - v * unit
            } else {
                v * unit
            };
            self.offsets.entry(n).or_insert([0.0; 6])[2] = new;
            if active {
                self.z = self.z.map(|z| z + (old - new) / unit);
            }
        } else if line.has('Z') {
            self.z = None;
        }
        self.z = self.z.filter(|z| z.is_finite());
    }
}

/// The moves of one hole of the cycle in force at `line` (its L or K repeats included).
fn expand_hole(
    line: &Line,
    scan: &mut Scan,
    path: &str,
    room: &mut Room,
    out: &mut Vec<Line>,
) -> Result<(), NcError> {
    let cycle = scan.cycle.clone().expect("a cycle is in force");
    let repeats = line.word('L').or(line.word('K')).map_or(1.0, |w| w.value);
    if repeats.fract() != 0.0 || !(0.0..=1000.0).contains(&repeats) {
        return Err(NcError::line(
            path,
            line.number,
            "the repeats (L or K) must be a whole number up to 1000".into(),
        ));
    }
    let clearance = if scan.inch {
        PECK_CLEARANCE_INCH
    } else {
        PECK_CLEARANCE_MM
    };
    let clear = if scan.retract_to_r {
        cycle.r
    } else {
        cycle.initial.max(cycle.r)
    };
    let feed = line.word('F').map(|w| format!(" F{}", line.text_of(w)));
    let mut texts = vec![format!(
        "(G{} block expanded into its moves: {})",
        cycle.code,
        line.text.trim().replace('(', "[").replace(')', "]")
    )];
    // The block's other words (sequence number, work offset, spindle, coolant) stay in force.
    let kept: Vec<&str> = line
        .words
        .iter()
        .filter(|w| {
            !matches!(
                w.letter,
                'X' | 'Y' | 'Z' | 'R' | 'Q' | 'P' | 'L' | 'K' | 'F'
            ) && !(w.letter == 'G'
                && (is_cycle_code(w.value) || w.value == 98.0 || w.value == 99.0))
        })
        .map(|w| line.text[w.letter_at..w.number.end].trim())
        .collect();
    if !kept.is_empty() {
        texts.push(kept.join(" "));
    }
    let xy: Vec<String> = ['X', 'Y']
        .iter()
        .filter_map(|&l| line.word(l).map(|w| format!("{l}{}", line.text_of(w))))
        .collect();
    let mut feed_word = feed;
    let mut feed_to = |texts: &mut Vec<String>, z: f64| {
        texts.push(format!(
            "G1 Z{}{}",
            number(z),
            feed_word.take().unwrap_or_default()
        ))
    };
    if matches!(cycle.code, 73 | 83) {
        let q = cycle.q.expect("a peck depth");
        let pecks = ((cycle.r - cycle.depth) / q).ceil();
        if pecks.is_nan() || pecks > MAX_PECKS as f64 {
            return Err(NcError::line(
                path,
                line.number,
                format!(
                    "G{}: a peck depth Q{} from R{} to Z{} makes {} pecks, more than the {MAX_PECKS} a hole may take",
                    cycle.code,
                    shown(q),
                    shown(cycle.r),
                    shown(cycle.depth),
                    shown(pecks)
                ),
            ));
        }
    }
    // The hole's blocks may not pass what calls and cycles may add (each block counts
    // BLOCK_WORDS, and one more for each of its words once read).
    let too_many = || {
        NcError::line(
            path,
            line.number,
            format!(
                "the subprogram calls and canned cycles add more than {MAX_EXPANDED_WORDS} words and blocks to the program"
            ),
        )
    };
    let room_for_blocks = room.left();
    let mut z = scan.z.unwrap_or(cycle.initial);
    for _ in 0..repeats as usize {
        if z < cycle.r {
            texts.push(format!("G0 Z{}", number(cycle.r)));
        }
        if !xy.is_empty() {
            texts.push(format!("G0 {}", xy.join(" ")));
        }
        texts.push(format!("G0 Z{}", number(cycle.r)));
        match cycle.code {
            73 | 83 => {
                let q = cycle.q.expect("a peck depth");
                let mut reached = cycle.r;
                loop {
                    let next = (reached - q).max(cycle.depth);
                    // A peck too small to change a number this large goes to the depth.
                    let next = if next < reached { next } else { cycle.depth };
                    feed_to(&mut texts, next);
                    if texts.len() * BLOCK_WORDS > room_for_blocks {
                        return Err(too_many());
                    }
                    reached = next;
                    if reached <= cycle.depth {
                        break;
                    }
                    if cycle.code == 83 {
                        texts.push(format!("G0 Z{}", number(cycle.r)));
                        texts.push(format!("G0 Z{}", number(reached + clearance)));
                    } else {
                        texts.push(format!("G0 Z{}", number(reached + clearance)));
                    }
                }
            }
            _ => feed_to(&mut texts, cycle.depth),
        }
        if matches!(cycle.code, 82 | 89) {
            if let Some(p) = &cycle.dwell {
                texts.push(format!("G4 P{p}"));
            }
        }
        if matches!(cycle.code, 85 | 89) {
            texts.push(format!("G1 Z{}", number(cycle.r)));
        }
        if !(matches!(cycle.code, 85 | 89) && clear == cycle.r) {
            texts.push(format!("G0 Z{}", number(clear)));
        }
        z = clear;
        if texts.len() * BLOCK_WORDS > room_for_blocks {
            return Err(too_many());
        }
    }
    scan.z = Some(z);
    let between = if line.ending.is_empty() {
        "\n"
    } else {
        line.ending
    };
    let count = texts.len();
    for (k, text) in texts.into_iter().enumerate() {
        let ending = if k + 1 == count { line.ending } else { between };
        let block = parse_line(&text, ending, line.number, path)?;
        if !room.take(&block) {
            return Err(too_many());
        }
        out.push(block);
    }
    Ok(())
}
