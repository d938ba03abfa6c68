//! Shared helpers: machines for tests (and the shared ones of `tests/fixtures/`), the GPU (or the reason it is skipped), the inputs of past
//! fuzzing findings.

use std::sync::OnceLock;

use volmap::gpu::{GpuMapper, GpuSampler};
use volmap::model::random::SplitMix64;
use volmap::model::{AxisLetter, ErrorFunction, Interp, Machine, Table};

/// The GPU engine, opened once. `None` (the test, or its GPU part, skipped and recorded by
/// [`crate::skips`]) only where no adapter exists; a panic instead when `VOLMAP_REQUIRE_GPU` is
/// set.
pub fn gpu() -> Option<&'static GpuMapper> {
    static GPU: OnceLock<Option<GpuMapper>> = OnceLock::new();
    let gpu = GPU
        .get_or_init(|| GpuMapper::open().expect("an adapter exists but the device failed to open"))
        .as_ref();
    if gpu.is_none() {
        no_adapter();
    }
    gpu
}

/// A failure under `VOLMAP_REQUIRE_GPU`, else a skip recorded ([`crate::skips`]).
fn no_adapter() {
    if crate::skips::gpu_required() {
        panic!("VOLMAP_REQUIRE_GPU is set but no GPU adapter exists (install mesa-vulkan-drivers for lavapipe)");
    }
    crate::skips::skipped("no GPU adapter (the test or its GPU part)");
}

/// The GPU sampler, opened once; skipped and required like [`gpu`].
pub fn sampler() -> Option<&'static GpuSampler> {
    static SAMPLER: OnceLock<Option<GpuSampler>> = OnceLock::new();
    let sampler = SAMPLER
        .get_or_init(|| {
            GpuSampler::open().expect("an adapter exists but the device failed to open")
        })
        .as_ref();
    if sampler.is_none() {
        no_adapter();
    }
    sampler
}

/// Test data from the library's SplitMix64 (`Rng::new(seed)`), with uniform draws in a range.
pub struct Rng(SplitMix64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(SplitMix64::new(seed))
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.0.next_f64()
    }
}

/// Gives every axis of `machine` random errors of realistic size, of every kind the file
/// format has: constants, polynomials, linear / quadratic / cubic tables, periodic rotary tables;
/// location errors, nominal offsets, a spindle error and a tool offset.
pub fn with_random_errors(mut machine: Machine, rng: &mut Rng) -> Machine {
    for axis in &mut machine.axes {
        let [lo, hi] = axis.range;
        axis.offset_mm = [
            rng.uniform(-200.0, 200.0),
            rng.uniform(-200.0, 200.0),
            rng.uniform(-200.0, 200.0),
        ];
        axis.location = [
            rng.uniform(-0.01, 0.01),
            rng.uniform(-0.01, 0.01),
            rng.uniform(-0.01, 0.01),
            rng.uniform(-5e-5, 5e-5),
            rng.uniform(-5e-5, 5e-5),
            rng.uniform(-5e-5, 5e-5),
        ];
        for n in 0..6 {
            let scale = if n < 3 { 0.01 } else { 3e-5 };
            let kind = rng.next_u64() % 5;
            let periodic = !axis.letter.is_linear() && rng.next_u64().is_multiple_of(2);
            let function = match kind {
                0 => ErrorFunction::Constant(rng.uniform(-scale, scale)),
                1 => {
                    let span = hi - lo;
                    ErrorFunction::Poly(vec![
                        rng.uniform(-scale, scale),
                        rng.uniform(-scale, scale) / span,
                        rng.uniform(-scale, scale) / (span * span),
                    ])
                }
                _ => {
                    let interp =
                        [Interp::Linear, Interp::Quadratic, Interp::Cubic][(kind - 2) as usize];
                    let (start, end) = if periodic { (lo, lo + 300.0) } else { (lo, hi) };
                    let nodes = if periodic { 6 } else { 7 };
                    let table: Vec<(f64, f64)> = (0..nodes)
                        .map(|k| {
                            let q = start + (end - start) * k as f64 / (nodes - 1) as f64;
                            (q, rng.uniform(-scale, scale))
                        })
                        .collect();
                    ErrorFunction::Table(Table::new(table, interp, periodic).expect("valid table"))
                }
            };
            axis.components[n] = Some(function);
        }
    }
    machine.spindle = [
        rng.uniform(-0.005, 0.005),
        rng.uniform(-0.005, 0.005),
        rng.uniform(-0.005, 0.005),
        rng.uniform(-2e-5, 2e-5),
        rng.uniform(-2e-5, 2e-5),
    ];
    machine.tool_offset_mm = [
        rng.uniform(-20.0, 20.0),
        rng.uniform(-20.0, 20.0),
        rng.uniform(-300.0, -50.0),
    ];
    machine
}

/// Travels for the axes of a test machine: linear axes over 2 m, rotary axes over ±180°.
pub fn ranges(letters: &[AxisLetter]) -> Vec<(AxisLetter, [f64; 2])> {
    letters
        .iter()
        .map(|&l| {
            (
                l,
                if l.is_linear() {
                    [-1000.0, 1000.0]
                } else {
                    [-180.0, 180.0]
                },
            )
        })
        .collect()
}

/// All orderings of `items`.
pub fn permutations<T: Copy>(items: &[T]) -> Vec<Vec<T>> {
    if items.len() <= 1 {
        return vec![items.to_vec()];
    }
    let mut out = Vec::new();
    for i in 0..items.len() {
        let mut rest = items.to_vec();
        let first = rest.remove(i);
        for mut tail in permutations(&rest) {
            tail.insert(0, first);
            out.push(tail);
        }
    }
    out
}

/// Every chain of the five axes: 120 orders × 6 places of the second `F` = 720 chains.
pub fn all_five_axis_chains(letters: [AxisLetter; 5]) -> Vec<String> {
    let mut chains = Vec::new();
    for order in permutations(&letters) {
        for split in 0..=5 {
            let work: String = order[..split].iter().map(|a| a.as_char()).collect();
            let tool: String = order[split..].iter().map(|a| a.as_char()).collect();
            chains.push(format!("F{work}F{tool}"));
        }
    }
    chains
}

/// Runs LinuxCNC's interpreter, `rs274 -g PROGRAM CANON`. rs274 truncates and maps
/// `$HOME/.tool.mmap` at start, so two runs in one home break each other (a bus error, as the
/// tests run side by side): each run gets the program's folder as its home.
pub fn rs274(program: &std::path::Path, canon: &std::path::Path) -> std::process::Output {
    let home = program.parent().expect("a program in a folder");
    std::process::Command::new("rs274")
        .env("HOME", home)
        .arg("-g")
        .arg(program)
        .arg(canon)
        .output()
        .expect("rs274 starts")
}

/// The numbers of a canonical call `rs274` prints (`STRAIGHT_FEED(1.0000, 2.0000, …)`), in
/// order; words that are not numbers are left out.
pub fn canon_numbers(line: &str) -> Vec<f64> {
    let (Some(open), Some(close)) = (line.find('('), line.rfind(')')) else {
        return Vec::new();
    };
    line[open + 1..close.max(open + 1)]
        .split([',', ' '])
        .filter_map(|n| n.trim().parse().ok())
        .collect()
}

/// The machine file `tests/fixtures/NAME.toml`, a machine several tests share.
pub fn fixture_path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(format!("{name}.toml"))
}

/// The text of the machine file `tests/fixtures/NAME.toml`.
pub fn fixture(name: &str) -> String {
    let path = fixture_path(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The saved input of a fuzzing finding, `tests/fuzz-regressions/NAME`.
pub fn fuzz_regression(name: &str) -> Vec<u8> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz-regressions")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Writes an input of several files as the fuzzing harness writes them (the main file, then each
/// other file after a line `#=== NAME`) into `dir`, the main file as `main`; its path.
pub fn write_input_files(dir: &std::path::Path, main: &str, input: &[u8]) -> std::path::PathBuf {
    let mut files: Vec<(String, Vec<u8>)> = vec![(main.to_string(), Vec::new())];
    for line in input.split_inclusive(|&b| b == b'\n') {
        let mark = line.strip_prefix(b"#=== ").map(|rest| {
            let rest = rest.strip_suffix(b"\n").unwrap_or(rest);
            rest.strip_suffix(b"\r").unwrap_or(rest)
        });
        match mark {
            Some(other) if plain_name(other) => {
                files.push((String::from_utf8_lossy(other).into_owned(), Vec::new()))
            }
            _ => files
                .last_mut()
                .expect("the main file")
                .1
                .extend_from_slice(line),
        }
    }
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    dir.join(main)
}

/// A name the harness takes for a file of an input: no folder, no leading dot.
fn plain_name(name: &[u8]) -> bool {
    (1..=40).contains(&name.len())
        && name[0] != b'.'
        && name
            .iter()
            .all(|&b| b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'-'))
}
