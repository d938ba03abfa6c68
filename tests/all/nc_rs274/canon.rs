//! LinuxCNC's canonical machining commands as `rs274` prints them, read into moves in machine
//! coordinates (mm): the motion a LinuxCNC control would make of a program, computed by an
//! interpreter that shares no code with volmap.

use nalgebra::Vector3;

/// What kind of motion a canonical move is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// `STRAIGHT_TRAVERSE`: a rapid.
    Rapid,
    /// `STRAIGHT_FEED`.
    Line,
    /// `ARC_FEED`: a circle or helix about `centre` (machine mm), turning about `normal` (a
    /// unit axis) by `sweep_rad` (signed, right-handed about `normal`).
    Arc {
        centre: Vector3<f64>,
        normal: usize,
        sweep_rad: f64,
    },
}

/// One canonical move: from `start` to `end`, machine mm.
#[derive(Debug, Clone, PartialEq)]
pub struct Move {
    pub kind: Kind,
    pub start: Vector3<f64>,
    pub end: Vector3<f64>,
    /// The N word of the block it comes from, or of the last block with one before it.
    pub label: Option<u32>,
    /// The line of the canonical output, for messages.
    pub canon_line: String,
}

impl Move {
    pub fn is_rapid(&self) -> bool {
        self.kind == Kind::Rapid
    }

    /// The point at fraction `t` of the move.
    pub fn at(&self, t: f64) -> Vector3<f64> {
        match self.kind {
            Kind::Rapid | Kind::Line => self.start + (self.end - self.start) * t,
            Kind::Arc {
                centre,
                normal,
                sweep_rad,
            } => {
                let (a, b) = plane_axes(normal);
                let r0 = self.start - centre;
                let r1 = self.end - centre;
                let radius0 = (r0[a] * r0[a] + r0[b] * r0[b]).sqrt();
                let radius1 = (r1[a] * r1[a] + r1[b] * r1[b]).sqrt();
                // The radius runs from the start's to the end's: the two differ by the printed
                // numbers' rounding only (rs274 refuses arcs whose radii differ more).
                let radius = radius0 + (radius1 - radius0) * t;
                let angle = r0[b].atan2(r0[a]) + sweep_rad * t;
                let mut p = centre;
                p[a] += radius * angle.cos();
                p[b] += radius * angle.sin();
                p[normal] = self.start[normal] + (self.end[normal] - self.start[normal]) * t;
                p
            }
        }
    }

    /// The length of the path, mm.
    pub fn length_mm(&self) -> f64 {
        match self.kind {
            Kind::Rapid | Kind::Line => (self.end - self.start).norm(),
            Kind::Arc {
                centre,
                normal,
                sweep_rad,
            } => {
                let (a, b) = plane_axes(normal);
                let r0 = self.start - centre;
                let radius = (r0[a] * r0[a] + r0[b] * r0[b]).sqrt();
                let axial = self.end[normal] - self.start[normal];
                ((radius * sweep_rad).powi(2) + axial * axial).sqrt()
            }
        }
    }

    /// The direction each axis moves in at fraction `t` (`t` > 0: the motion arriving there),
    /// 0 where it stands still.
    pub fn direction_at(&self, t: f64) -> [f64; 3] {
        let d = match self.kind {
            Kind::Rapid | Kind::Line => self.end - self.start,
            // The motion arriving over the last 10 µm of the path (or from the piece's start):
            // at a turning point the axis arrives the old way, where the printed ends' rounding
            // (a radius that changes by 0.1 µm along the piece) would turn it by nanometres.
            Kind::Arc { .. } => {
                let dt = t.min((0.01 / self.length_mm().max(1e-9)).max(1e-6));
                self.at(t) - self.at(t - dt)
            }
        };
        let tiny = 1e-12 * (1.0 + self.length_mm());
        [0, 1, 2].map(|i| {
            if d[i].abs() <= tiny {
                0.0
            } else {
                d[i].signum()
            }
        })
    }
}

/// The in-plane axes of the plane about `normal`, in the order that makes a positive turn
/// right-handed about it (rs274's `ARC_FEED` order: XY, YZ, ZX).
pub fn plane_axes(normal: usize) -> (usize, usize) {
    match normal {
        2 => (0, 1),
        0 => (1, 2),
        _ => (2, 0),
    }
}

/// The moves of a canonical output; an error where the interpreter stopped on an error (no
/// `PROGRAM_END`), or printed something this reader does not follow.
pub fn read(canon: &str) -> Result<Vec<Move>, String> {
    let mut moves = Vec::new();
    let mut g5x = Vector3::zeros();
    let mut g92 = Vector3::zeros();
    let mut tool = Vector3::zeros();
    let mut plane_normal = 2;
    let mut position: Option<Vector3<f64>> = None;
    let mut label: Option<u32> = None;
    let mut ended = false;
    for line in canon.lines() {
        let rest = line.trim_start();
        let Some((_, rest)) = rest.split_once(' ') else {
            continue;
        };
        let rest = rest.trim_start();
        let Some((n, call)) = rest.split_once(' ') else {
            continue;
        };
        if let Some(number) = n.strip_prefix('N').and_then(|n| n.parse::<u32>().ok()) {
            label = Some(number);
        }
        let call = call.trim();
        let Some((name, args)) = call.split_once('(') else {
            continue;
        };
        let args = args.trim_end_matches(')');
        let numbers = || crate::common::canon_numbers(call);
        match name {
            "USE_LENGTH_UNITS" if !args.contains("MM") => {
                return Err(format!("inch programs are not read here: {line}"))
            }
            "SET_G5X_OFFSET" => {
                let n = numbers();
                g5x = Vector3::new(n[1], n[2], n[3]);
            }
            "SET_G92_OFFSET" => {
                let n = numbers();
                g92 = Vector3::new(n[0], n[1], n[2]);
            }
            "USE_TOOL_LENGTH_OFFSET" => {
                let n = numbers();
                tool = Vector3::new(n[0], n[1], n[2]);
            }
            "SET_XY_ROTATION" if numbers().first() != Some(&0.0) => {
                return Err(format!(
                    "a rotated coordinate system is not read here: {line}"
                ))
            }
            "SELECT_PLANE" => {
                plane_normal = if args.contains("XY") {
                    2
                } else if args.contains("YZ") {
                    0
                } else {
                    1
                };
            }
            "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" | "ARC_FEED" => {
                let n = numbers();
                let shift = g5x + g92 + tool;
                let (kind, end) = if name == "ARC_FEED" {
                    let (a, b) = plane_axes(plane_normal);
                    let mut end = Vector3::zeros();
                    end[a] = n[0];
                    end[b] = n[1];
                    end[plane_normal] = n[5];
                    let mut centre = Vector3::zeros();
                    centre[a] = n[2] + shift[a];
                    centre[b] = n[3] + shift[b];
                    let end = end + shift;
                    let start = position.ok_or_else(|| format!("an arc from nowhere: {line}"))?;
                    let turns = n[4];
                    let angle = |p: Vector3<f64>| (p[b] - centre[b]).atan2(p[a] - centre[a]);
                    let mut sweep = angle(end) - angle(start);
                    // rotation ±1: less than a turn that way (a whole turn where the ends
                    // meet); ±n: n − 1 more whole turns.
                    if turns > 0.0 {
                        while sweep <= 1e-12 {
                            sweep += std::f64::consts::TAU;
                        }
                        sweep += std::f64::consts::TAU * (turns - 1.0);
                    } else {
                        while sweep >= -1e-12 {
                            sweep -= std::f64::consts::TAU;
                        }
                        sweep += std::f64::consts::TAU * (turns + 1.0);
                    }
                    (
                        Kind::Arc {
                            centre: {
                                let mut c = centre;
                                c[plane_normal] = start[plane_normal];
                                c
                            },
                            normal: plane_normal,
                            sweep_rad: sweep,
                        },
                        end,
                    )
                } else {
                    let kind = if name == "STRAIGHT_TRAVERSE" {
                        Kind::Rapid
                    } else {
                        Kind::Line
                    };
                    (kind, Vector3::new(n[0], n[1], n[2]) + shift)
                };
                // The first move starts where the axes stand: LinuxCNC's start is its zero,
                // unknown to volmap, so the first move is compared from its end only.
                let start = position.unwrap_or(end);
                moves.push(Move {
                    kind,
                    start,
                    end,
                    label,
                    canon_line: line.to_string(),
                });
                position = Some(end);
            }
            "PROGRAM_END" | "PROGRAM_STOP" => ended = true,
            _ => {}
        }
    }
    if !ended {
        return Err("the interpreter stopped before the program's end".to_string());
    }
    Ok(moves)
}
