//! Random programs from a small grammar, written twice: as volmap reads them (Fanuc
//! subprograms, `M98 P..` and `O..`/`M99` after the program end) and as LinuxCNC's `rs274` reads
//! them (`o.. sub`/`o.. call`, the bodies first). Every code line carries `N` and its line number
//! in volmap's text, which rs274 prints with each canonical command.

use nalgebra::Vector3;

use crate::common::Rng;

/// The machine positions (mm) every program stays in: inside the travels of `vmc-li2015` and
/// `gantry-2m`.
const BOX_MM: [[f64; 2]; 3] = [[250.0, 550.0], [150.0, 450.0], [180.0, 320.0]];

/// G54's work zero (machine mm); G55–G59 are each 10, −10, 5 mm further.
pub fn work_offsets() -> Vec<(u32, [f64; 3])> {
    (0..6)
        .map(|k| {
            let k_f = k as f64;
            (
                54 + k,
                [400.0 + 10.0 * k_f, 300.0 - 10.0 * k_f, 250.0 + 5.0 * k_f],
            )
        })
        .collect()
}

/// Where G28 sends the axes (machine mm): set in rs274's parameters 5161–5163; volmap does not
/// need it (the axes a home names are unknown to it until named again).
pub const HOME_MM: [f64; 3] = [420.0, 280.0, 400.0];

/// A generated program.
pub struct Program {
    /// As volmap reads it.
    pub volmap: String,
    /// As rs274 reads it (without the work offsets, which the harness sets).
    pub rs274: String,
    /// The features it uses.
    pub used: Vec<&'static str>,
}

struct Line {
    volmap: String,
    rs274: Vec<String>,
}

/// The generator's state: where the axes stand (program coordinates as written, 4 decimals).
struct Gen<'a> {
    rng: Rng,
    features: &'a [&'static str],
    used: Vec<&'static str>,
    offsets: Vec<(u32, [f64; 3])>,
    offset: usize,
    /// Program coordinates of the current point.
    at: Vector3<f64>,
    incremental: bool,
    plane: usize,
    main: Vec<Line>,
    /// Subprogram bodies: number and lines (code without N).
    bodies: Vec<(u32, Vec<String>)>,
}

fn round4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

fn num(v: f64) -> String {
    let s = format!("{:.4}", round4(v));
    let s = s.trim_end_matches('0').to_string();
    if s == "-0." {
        "0.".to_string()
    } else {
        s
    }
}

const LETTERS: [char; 3] = ['X', 'Y', 'Z'];

impl Gen<'_> {
    /// True once in `n` draws.
    fn one_in(&mut self, n: u64) -> bool {
        self.rng.next_u64().is_multiple_of(n)
    }

    fn on(&mut self, feature: &'static str) -> bool {
        if self.features.contains(&feature) {
            if !self.used.contains(&feature) {
                self.used.push(feature);
            }
            true
        } else {
            false
        }
    }

    fn zero(&self) -> Vector3<f64> {
        Vector3::from(self.offsets[self.offset].1)
    }

    fn push(&mut self, code: String) {
        self.main.push(Line {
            volmap: code.clone(),
            rs274: vec![code],
        });
    }

    /// A random point of the box in program coordinates, with a margin, rounded.
    fn point(&mut self, margin: f64) -> Vector3<f64> {
        let zero = self.zero();
        Vector3::from_fn(|d, _| {
            round4(
                self.rng
                    .uniform(BOX_MM[d][0] + margin, BOX_MM[d][1] - margin)
                    - zero[d],
            )
        })
    }

    fn inside(&self, p: Vector3<f64>, margin: f64) -> bool {
        let m = p + self.zero();
        (0..3).all(|d| m[d] >= BOX_MM[d][0] + margin && m[d] <= BOX_MM[d][1] - margin)
    }

    /// The axis words of a move to `to` from the current point, the axes in `axes`.
    fn words(&self, to: Vector3<f64>, axes: &[usize]) -> String {
        axes.iter()
            .map(|&d| {
                let v = if self.incremental {
                    to[d] - self.at[d]
                } else {
                    to[d]
                };
                format!("{}{}", LETTERS[d], num(v))
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    fn mode_word(&mut self) -> &'static str {
        if self.on("incremental") && self.one_in(4) {
            self.incremental = !self.incremental;
            if self.incremental {
                "G91 "
            } else {
                "G90 "
            }
        } else {
            ""
        }
    }

    fn straight(&mut self) {
        self.on("lines");
        let rapid = self.one_in(3);
        let mut to = self.point(5.0);
        let axes: Vec<usize> = match self.rng.next_u64() % 5 {
            0 => vec![0],
            1 => vec![1],
            2 => vec![2],
            3 => vec![0, 1],
            _ => vec![0, 1, 2],
        };
        for d in 0..3 {
            if !axes.contains(&d) {
                to[d] = self.at[d];
            }
        }
        let mode = self.mode_word();
        let words = self.words(to, &axes);
        let code = if rapid {
            format!("{mode}G0 {words}")
        } else {
            format!("{mode}G1 {words} F800")
        };
        self.push(code);
        self.at = to;
    }

    fn arc(&mut self) {
        if !self.on("arcs") {
            return self.straight();
        }
        if self.on("planes") {
            let plane = (self.rng.next_u64() % 3) as usize;
            if plane != self.plane {
                self.plane = plane;
                self.push(["G19", "G18", "G17"][plane].to_string());
            }
        }
        // The plane's normal: G17 Z, G18 Y, G19 X; its axes right-handed about it.
        let normal = [0, 1, 2][self.plane];
        let (a, b) = crate::nc_rs274::canon::plane_axes(normal);
        let radius = round4(self.rng.uniform(3.0, 40.0));
        // The whole circle stays inside the box.
        for d in [a, b] {
            let mut p = self.at;
            p[d] += 2.0 * radius;
            let mut q = self.at;
            q[d] -= 2.0 * radius;
            if !self.inside(p, 1.0) || !self.inside(q, 1.0) {
                return self.straight();
            }
        }
        let phi = self.rng.uniform(0.0, std::f64::consts::TAU);
        let mut centre = self.at;
        centre[a] += radius * phi.cos();
        centre[b] += radius * phi.sin();
        for d in [a, b] {
            centre[d] = round4(centre[d]);
        }
        let ccw = self.one_in(2);
        let with_r = self.one_in(3);
        let full = !with_r && self.one_in(8);
        let sweep_deg = if full {
            360.0
        } else if with_r {
            if self.one_in(2) && self.on("arcs-r-over-180") {
                self.rng.uniform(200.0, 340.0)
            } else {
                self.rng.uniform(20.0, 160.0)
            }
        } else {
            self.rng.uniform(10.0, 350.0)
        };
        let turn = sweep_deg.to_radians() * if ccw { 1.0 } else { -1.0 };
        let r0 = self.at - centre;
        let start_angle = r0[b].atan2(r0[a]);
        let real_radius = (r0[a] * r0[a] + r0[b] * r0[b]).sqrt();
        let mut to = self.at;
        if !full {
            to[a] = round4(centre[a] + real_radius * (start_angle + turn).cos());
            to[b] = round4(centre[b] + real_radius * (start_angle + turn).sin());
        }
        if self.on("helices") && self.one_in(2) {
            let axial = round4(self.rng.uniform(-5.0, 5.0));
            let mut next = to;
            next[normal] += axial;
            if self.inside(next, 1.0) {
                to = next;
            }
        }
        let mode = self.mode_word();
        let g = if ccw { "G3" } else { "G2" };
        let mut axes = vec![a, b];
        if to[normal] != self.at[normal] {
            axes.push(normal);
        }
        axes.sort_unstable();
        if full {
            axes.retain(|&d| d == normal);
        }
        let words = if axes.is_empty() {
            String::new()
        } else {
            format!("{} ", self.words(to, &axes))
        };
        let centre_words = if with_r {
            let r = if sweep_deg > 180.0 {
                -real_radius
            } else {
                real_radius
            };
            format!("R{}", num(r))
        } else {
            let mut w = Vec::new();
            for d in [0, 1, 2] {
                if d == a || d == b {
                    w.push(format!(
                        "{}{}",
                        ['I', 'J', 'K'][d],
                        num(centre[d] - self.at[d])
                    ));
                }
            }
            w.join(" ")
        };
        self.push(format!("{mode}{g} {words}{centre_words} F600"));
        self.at = to;
    }

    fn cycle(&mut self) {
        if !self.on("cycles") {
            return self.straight();
        }
        // The R plane below the current point, the bottom below R; holes inside the box.
        let r_plane = round4(self.at[2] - self.rng.uniform(1.0, 10.0));
        let bottom = round4(r_plane - self.rng.uniform(2.0, 15.0));
        if !self.inside(Vector3::new(self.at[0], self.at[1], bottom), 1.0) {
            return self.straight();
        }
        let initial = self.at[2];
        if self.incremental || self.plane != 2 {
            self.incremental = false;
            self.plane = 2;
            self.push("G90 G17".to_string());
        }
        let g98 = self.one_in(2);
        let peck = self.one_in(2);
        let holes = 1 + self.rng.next_u64() % 3;
        for h in 0..holes {
            let p = self.point(5.0);
            let code = if h == 0 {
                let kind = if peck {
                    format!("G83 Q{}", num(self.rng.uniform(1.0, 4.0)))
                } else {
                    "G81".to_string()
                };
                format!(
                    "{} {kind} X{} Y{} Z{} R{} F300",
                    if g98 { "G98" } else { "G99" },
                    num(p[0]),
                    num(p[1]),
                    num(bottom),
                    num(r_plane)
                )
            } else {
                format!("X{} Y{}", num(p[0]), num(p[1]))
            };
            self.push(code);
            self.at = Vector3::new(p[0], p[1], if g98 { initial } else { r_plane });
        }
        self.push("G80".to_string());
    }

    fn subprogram(&mut self) {
        if !self.on("subprograms") {
            return self.straight();
        }
        let number = 1000 + self.bodies.len() as u32 + 1;
        let mut body = Vec::new();
        self.incremental = false;
        for _ in 0..1 + self.rng.next_u64() % 3 {
            let p = self.point(5.0);
            body.push(format!(
                "G90 G1 X{} Y{} Z{} F700",
                num(p[0]),
                num(p[1]),
                num(p[2])
            ));
            self.at = p;
        }
        let repeats = 1 + self.rng.next_u64() % 3;
        self.bodies.push((number, body));
        self.main.push(Line {
            volmap: if repeats == 1 {
                format!("M98 P{number}")
            } else {
                format!("M98 P{number} L{repeats}")
            },
            rs274: (0..repeats).map(|_| format!("o{number} call")).collect(),
        });
    }

    fn work_offset(&mut self) {
        let alone = self.one_in(2);
        if !self.on(if alone {
            "offset-change"
        } else {
            "work-offsets"
        }) {
            return self.straight();
        }
        let machine = self.at + self.zero();
        let before = self.offset;
        self.offset = (self.rng.next_u64() % 6) as usize;
        let g = format!("G{}", self.offsets[self.offset].0);
        if alone {
            // The axes stay where they stand: their program coordinates change.
            self.at = (machine - self.zero()).map(round4);
            self.push(g);
        } else {
            // Each axis moves the same way in program and machine coordinates ("work-offsets"),
            // or either way ("offset-direction").
            let mut p = self.point(5.0);
            let agree = |p: &Vector3<f64>, g: &Self| {
                (0..3).all(|d| (p[d] - g.at[d]) * (p[d] + g.zero()[d] - machine[d]) > 0.0)
            };
            if !agree(&p, self) && !self.on("offset-direction") {
                for _ in 0..1000 {
                    p = self.point(5.0);
                    if agree(&p, self) {
                        break;
                    }
                }
                if !agree(&p, self) {
                    self.offset = before;
                    return self.straight();
                }
            }
            self.incremental = false;
            self.push(format!(
                "{g} G90 G0 X{} Y{} Z{}",
                num(p[0]),
                num(p[1]),
                num(p[2])
            ));
            self.at = p;
        }
    }

    fn machine_move(&mut self) {
        if self.one_in(2) {
            if !self.on("g53") {
                return self.straight();
            }
            self.incremental = false;
            let z = round4(self.rng.uniform(BOX_MM[2][1] + 5.0, 450.0));
            self.push(format!("G90 G53 G0 Z{}", num(z)));
            self.at[2] = z - self.zero()[2];
        } else {
            if !self.on("g28") {
                return self.straight();
            }
            let (words, axes): (&str, &[usize]) = if self.one_in(2) {
                ("Z0.", &[2])
            } else {
                ("X0. Y0.", &[0, 1])
            };
            self.push(format!("G91 G28 {words}"));
            self.push("G90".to_string());
            self.incremental = false;
            for &d in axes {
                self.at[d] = HOME_MM[d] - self.zero()[d];
            }
        }
        // Back into the box in two moves: first some axes (the others stand where the machine
        // position left them: their height is the machine's, not the program's), then the rest.
        let p = self.point(5.0);
        let first: Vec<usize> = match self.rng.next_u64() % 3 {
            0 => vec![0, 1],
            1 => vec![2],
            _ => vec![0, 1, 2],
        };
        let rest: Vec<usize> = (0..3).filter(|d| !first.contains(d)).collect();
        for axes in [first, rest] {
            if axes.is_empty() {
                continue;
            }
            let mut to = self.at;
            for &d in &axes {
                to[d] = p[d];
            }
            let words = self.words(to, &axes);
            self.push(format!("G0 {words}"));
            self.at = to;
        }
    }

    fn passed(&mut self) {
        match self.rng.next_u64() % 6 {
            0 if self.on("dwell-g64") => self.push("G4 P0.5".to_string()),
            1 if self.on("dwell-g64") => self.push("G64 P0.01".to_string()),
            2 if self.on("g10") => {
                let (number, zero) = self.offsets[self.offset];
                self.push(format!(
                    "G90 G10 L2 P{} X{} Y{} Z{}",
                    number - 53,
                    num(zero[0]),
                    num(zero[1]),
                    num(zero[2])
                ));
                self.incremental = false;
            }
            3 if self.on("macros") => {
                let p = self.point(5.0);
                self.push(format!("#100={}", num(p[0])));
                self.push("G90 G1 X#100 F800".to_string());
                self.incremental = false;
                self.at[0] = p[0];
            }
            4 if self.on("expressions") => {
                let p = self.point(5.0);
                let half = round4(p[1] / 2.0);
                self.push(format!("G90 G1 Y[{}+{}] F800", num(half), num(p[1] - half)));
                self.incremental = false;
                self.at[1] = p[1];
            }
            5 if self.on("g92") => {
                // The current point becomes (0, 0, 0) of the shifted coordinates, and is
                // left at once; G92.1 ends the shift. A move naming every axis first: G92
                // needs where they stand, which a block volmap does not follow may have hidden.
                let p = self.point(5.0);
                self.push(format!(
                    "G90 G1 X{} Y{} Z{} F800",
                    num(p[0]),
                    num(p[1]),
                    num(p[2])
                ));
                self.at = p;
                self.push("G92 X0 Y0 Z0".to_string());
                let p = self.point(5.0);
                let q = p - self.at;
                self.incremental = false;
                self.push(format!(
                    "G90 G1 X{} Y{} Z{} F800",
                    num(q[0]),
                    num(q[1]),
                    num(q[2])
                ));
                self.push("G92.1".to_string());
                self.at = p;
            }
            _ => self.straight(),
        }
    }
}

/// A program of `blocks` random blocks from `features` (names from [`FEATURES`]).
pub fn program(seed: u64, blocks: usize, features: &[&'static str]) -> Program {
    let offsets = work_offsets();
    let mut g = Gen {
        rng: Rng::new(seed),
        features,
        used: Vec::new(),
        offsets,
        offset: 0,
        at: Vector3::zeros(),
        incremental: false,
        plane: 2,
        main: Vec::new(),
        bodies: Vec::new(),
    };
    g.push("G21 G90 G17 G54".to_string());
    let p = g.point(5.0);
    g.push(format!("G0 X{} Y{} Z{}", num(p[0]), num(p[1]), num(p[2])));
    g.at = p;
    for _ in 0..blocks {
        match g.rng.next_u64() % 16 {
            0..=5 => g.straight(),
            6..=9 => g.arc(),
            10 | 11 => g.cycle(),
            12 => g.subprogram(),
            13 => g.work_offset(),
            14 => g.machine_move(),
            _ => g.passed(),
        }
    }
    let z = num(g.at[2]);
    g.push(format!("G90 G0 Z{z}"));
    g.push("M30".to_string());
    render(g)
}

fn render(g: Gen) -> Program {
    let mut volmap = Vec::new();
    let mut rs274_main = Vec::new();
    let numbered = |n: usize, code: &str| {
        if code.starts_with('#') || code.starts_with('o') {
            code.to_string()
        } else {
            format!("N{n} {code}")
        }
    };
    for line in &g.main {
        let n = volmap.len() + 1;
        volmap.push(numbered(n, &line.volmap));
        rs274_main.extend(line.rs274.iter().map(|c| numbered(n, c)));
    }
    let mut subs = Vec::new();
    for (number, body) in &g.bodies {
        volmap.push(format!("O{number}"));
        subs.push(format!("o{number} sub"));
        for code in body {
            let n = volmap.len() + 1;
            volmap.push(numbered(n, code));
            subs.push(numbered(n, code));
        }
        volmap.push("M99".to_string());
        subs.push(format!("o{number} endsub"));
    }
    subs.extend(rs274_main);
    Program {
        volmap: volmap.join("\n") + "\n",
        rs274: subs.join("\n") + "\n",
        used: g.used,
    }
}
