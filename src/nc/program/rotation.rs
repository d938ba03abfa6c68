//! Coordinate rotation (G68 X Y R … G69, Fanuc; the XY plane): every move programmed while the
//! rotation is in force is rewritten with the coordinates the control moves to, so the
//! compensation and the written program need no rotation of their own. A point `(x, y)` of the
//! rotated system is `c + Rot(R)·((x, y) − c)` in the program's own, `c` the centre (X Y of the
//! G68 block, the current position where omitted) and `R` degrees counter-clockwise. Absolute
//! words missing from a block keep their value in the rotated system (the current point turned
//! back); incremental ones (G91) and arc centres I J turn as vectors; R arcs and Z do not change.
//! The G68 and G69 blocks become comments that say what was applied.

use super::parse::{parse_line, Line, Word};
use super::settings::is_setting;
use super::subprograms::{Room, MAX_EXPANDED_WORDS};
use crate::nc::error::NcError;

/// What is known of the program while reading it.
struct Scan {
    absolute: bool,
    xy_plane: bool,
    /// The current point in the program's (unrotated) coordinates, where known.
    at: [Option<f64>; 2],
    /// Centre and angle (rad) of the rotation in force.
    rotation: Option<([f64; 2], f64)>,
}

fn g_codes(line: &Line) -> impl Iterator<Item = f64> + '_ {
    line.words
        .iter()
        .filter(|w| w.letter == 'G')
        .map(|w| w.value)
}

/// `v` with 9 decimals (far below any control's resolution; the compensation rewrites the
/// numbers at the output's decimals), no trailing zeros.
fn number(v: f64) -> String {
    let text = format!("{v:.9}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

fn turn(v: [f64; 2], angle: f64) -> [f64; 2] {
    let (s, c) = angle.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

/// The program with every G68 rotation applied to its coordinates (see the module's
/// documentation). Rewriting a block costs several times what adding it did: beyond the
/// program's `own_blocks` (as many rewrites as the file has blocks), each rewritten block takes
/// its words from the `room` calls and cycles left, so that calls repeated under a rotation
/// stay within [`MAX_EXPANDED_WORDS`] together.
pub(super) fn apply_rotations(
    lines: Vec<Line>,
    path: &str,
    own_blocks: usize,
    room: &mut Room,
) -> Result<Vec<Line>, NcError> {
    let mut scan = Scan {
        absolute: true,
        xy_plane: true,
        at: [None, None],
        rotation: None,
    };
    // The line of the G68 in force, and how many blocks have been rewritten.
    let (mut rotated_at, mut rewritten) = (0, 0usize);
    let mut out = Vec::with_capacity(lines.len());
    for line in lines {
        let error = |message: String| NcError::line(path, line.number, message);
        let codes: Vec<f64> = g_codes(&line).collect();
        for &g in &codes {
            match g {
                90.0 => scan.absolute = true,
                91.0 => scan.absolute = false,
                17.0 => scan.xy_plane = true,
                18.0 | 19.0 => scan.xy_plane = false,
                _ => {}
            }
        }
        let value = |letter: char| line.word(letter).map(|w| w.value);
        if codes.contains(&68.0) {
            if !scan.xy_plane {
                return Err(error(
                    "G68: volmap rotates coordinates in the XY plane (G17) only".into(),
                ));
            }
            if !scan.absolute {
                return Err(error(
                    "G68 in incremental distance (G91): program the rotation in G90".into(),
                ));
            }
            let axis = [value('I'), value('J'), value('K')];
            if axis.iter().any(Option::is_some)
                && !(axis[0].unwrap_or(0.0) == 0.0
                    && axis[1].unwrap_or(0.0) == 0.0
                    && axis[2].is_some_and(|k| k > 0.0))
            {
                return Err(error(
                    "G68 with I J K turns about that axis: volmap rotates about the XY plane's axis only (I0 J0 K1)".into(),
                ));
            }
            let angle = value('R').ok_or_else(|| error("G68 needs its angle R".into()))?;
            let centre = [value('X').or(scan.at[0]), value('Y').or(scan.at[1])];
            let [Some(cx), Some(cy)] = centre else {
                return Err(error(
                    "G68 without X and Y turns about the current point, which is not known here: give the centre".into(),
                ));
            };
            scan.rotation = Some(([cx, cy], angle.to_radians()));
            rotated_at = line.number;
            out.push(comment(
                &line,
                path,
                "rotation applied to the coordinates below",
            )?);
            out.extend(kept_words(&line, 68.0, path)?);
            continue;
        }
        if codes.contains(&69.0) {
            scan.rotation = None;
            out.push(comment(&line, path, "rotation ends")?);
            out.extend(kept_words(&line, 69.0, path)?);
            continue;
        }
        let setting = is_setting(&line);
        if (setting || line.unknown.is_some()) && scan.rotation.is_some() {
            return Err(error(
                "a block that sets coordinates (G10, G52, G92) or that volmap cannot follow while G68 is in force: cancel the rotation (G69) first".into(),
            ));
        }
        let machine_coordinates = setting || codes.iter().any(|&g| matches!(g, 28.0 | 30.0 | 53.0));
        if machine_coordinates {
            // A move in machine coordinates or to a home: the program's point is not known
            // after it.
            for (d, letter) in ['X', 'Y'].into_iter().enumerate() {
                if line.has(letter) {
                    scan.at[d] = None;
                }
            }
            out.push(line);
            continue;
        }
        let Some((centre, angle)) = scan.rotation else {
            for (d, letter) in ['X', 'Y'].into_iter().enumerate() {
                if let Some(v) = value(letter) {
                    scan.at[d] = if scan.absolute {
                        Some(v)
                    } else {
                        scan.at[d].map(|a| a + v)
                    };
                }
            }
            out.push(line);
            continue;
        };
        if codes.iter().any(|&g| (54.0..=59.0).contains(&g)) {
            return Err(error(
                "a work offset changes while G68 is in force: cancel the rotation (G69) first"
                    .into(),
            ));
        }
        let moves = line.has('X') || line.has('Y');
        let arc_centre = line.has('I') || line.has('J');
        if !moves && !arc_centre {
            out.push(line);
            continue;
        }
        let mut words: Vec<String> = Vec::new();
        if moves {
            if scan.absolute {
                let current = match scan.at {
                    [Some(x), Some(y)] => {
                        let back = turn([x - centre[0], y - centre[1]], -angle);
                        Some([centre[0] + back[0], centre[1] + back[1]])
                    }
                    _ => None,
                };
                let rotated = [
                    value('X').or(current.map(|c| c[0])),
                    value('Y').or(current.map(|c| c[1])),
                ];
                let [Some(x), Some(y)] = rotated else {
                    return Err(error(
                        "under G68 a block giving only X or only Y needs the current point, which is not known here: give both".into(),
                    ));
                };
                let turned = turn([x - centre[0], y - centre[1]], angle);
                let point = [centre[0] + turned[0], centre[1] + turned[1]];
                scan.at = [Some(point[0]), Some(point[1])];
                words.push(format!("X{} Y{}", number(point[0]), number(point[1])));
            } else {
                let step = turn(
                    [value('X').unwrap_or(0.0), value('Y').unwrap_or(0.0)],
                    angle,
                );
                scan.at = [
                    scan.at[0].map(|a| a + step[0]),
                    scan.at[1].map(|a| a + step[1]),
                ];
                words.push(format!("X{} Y{}", number(step[0]), number(step[1])));
            }
        }
        if arc_centre {
            let ij = turn(
                [value('I').unwrap_or(0.0), value('J').unwrap_or(0.0)],
                angle,
            );
            words.push(format!("I{} J{}", number(ij[0]), number(ij[1])));
        }
        let kept: Vec<&str> = line
            .words
            .iter()
            .filter(|w| !matches!(w.letter, 'X' | 'Y' | 'I' | 'J'))
            .map(|w| line.text[w.letter_at..w.number.end].trim())
            .collect();
        let text = format!(
            "{} {} (G68: {})",
            kept.join(" "),
            words.join(" "),
            line.text.trim().replace('(', "[").replace(')', "]")
        );
        let rotated = parse_line(text.trim(), line.ending, line.number, path)?;
        rewritten += 1;
        if rewritten > own_blocks && !room.take(&rotated) {
            return Err(NcError::line(
                path,
                rotated_at,
                format!("G68: the blocks it rotates, with what subprogram calls and canned cycles add, come to more than {MAX_EXPANDED_WORDS} words and blocks"),
            ));
        }
        out.push(rotated);
    }
    Ok(out)
}

/// The words of a G68 (`code` 68) or G69 block that are not the rotation's (spindle, coolant,
/// tool, feed, other modes), on a block of their own after its comment: the rotation moves
/// nothing, so they act as they did. A motion (G0–G3) there is refused: its axis words are the
/// centre's.
fn kept_words(line: &Line, code: f64, path: &str) -> Result<Option<Line>, NcError> {
    let own = |w: &&Word| match w.letter {
        'G' => w.value == code,
        'X' | 'Y' | 'Z' | 'I' | 'J' | 'K' | 'R' => code == 68.0,
        'N' => true,
        _ => false,
    };
    if let Some(w) = line
        .words
        .iter()
        .find(|w| w.letter == 'G' && w.value < 4.0 && w.value.fract() == 0.0)
    {
        return Err(NcError::line(
            path,
            line.number,
            format!(
                "G{} in a G{} block: give the motion on a block of its own",
                line.text_of(w),
                code as u32
            ),
        ));
    }
    let kept: Vec<&str> = line
        .words
        .iter()
        .filter(|w| !own(w))
        .map(|w| line.text[w.letter_at..w.number.end].trim())
        .collect();
    if kept.is_empty() {
        return Ok(None);
    }
    let mut kept = parse_line(&kept.join(" "), line.ending, line.number, path)?;
    kept.spaced = line.spaced;
    Ok(Some(kept))
}

/// `line` as a comment saying what was done with it.
fn comment(line: &Line, path: &str, what: &str) -> Result<Line, NcError> {
    let text = format!(
        "({}: {what})",
        line.text.trim().replace('(', "[").replace(')', "]")
    );
    parse_line(&text, line.ending, line.number, path)
}
