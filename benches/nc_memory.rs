//! Peak heap memory of `trace` and `compensate` against program size: programs of short feed
//! moves on the 3-axis embedded machine, each run as the command runs it (the trace with its
//! summary; the compensation with the check of what it wrote and the model run along it), the
//! heap counted by a global allocator. `cargo bench --bench nc_memory`; the sizes are the
//! programs' moves, `VOLMAP_BENCH_MOVES=10000,200000` to choose others. The figures are in
//! docs/nc.md ("Program size and memory").

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use volmap::io::embedded;
use volmap::nc::{self, Options};

/// The system allocator, counting the bytes held now and the most held since the last reset.
struct Counting;

static HELD: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = HELD.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        unsafe { System.dealloc(p, layout) };
        HELD.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The most bytes `work` held at once beyond what was held before it.
fn peak_of(work: impl FnOnce()) -> usize {
    let before = HELD.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    work();
    PEAK.load(Ordering::Relaxed) - before
}

/// `moves` feed moves a few tenths of a millimetre long, wandering over the table.
fn program(moves: usize) -> Vec<u8> {
    let mut text = String::from("G21 G90 G17 G54\nG0 X100 Y100 Z150\nG1 F1000\n");
    let (mut x, mut y) = (100.0f64, 100.0f64);
    for k in 0..moves {
        // A fixed walk (no random source): the same program on every run.
        x = (x + 0.37 * ((k as f64) * 0.61).sin()).clamp(10.0, 500.0);
        y = (y + 0.37 * ((k as f64) * 0.43).cos()).clamp(10.0, 300.0);
        text.push_str(&format!("X{x:.3} Y{y:.3}\n"));
    }
    text.into_bytes()
}

fn main() {
    let sizes: Vec<usize> = std::env::var("VOLMAP_BENCH_MOVES")
        .ok()
        .map(|v| {
            v.split(',')
                .map(|n| {
                    n.trim()
                        .parse()
                        .expect("VOLMAP_BENCH_MOVES: moves, comma separated")
                })
                .collect()
        })
        .unwrap_or_else(|| vec![10_000, 50_000, 200_000]);
    let machine = embedded::load("vmc-li2015").expect("the embedded machine");
    let options = Options::default();
    println!("| moves | program | `trace` | a move | `compensate` | a move |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for moves in sizes {
        let text = program(moves);
        let trace = peak_of(|| {
            // As `volmap trace` runs: the summary's largest deviation and one entry a block.
            let mut largest = 0.0f64;
            let mut blocks = nc::PerBlock::default();
            nc::trace_each(&machine, &text, "bench.nc", &options, 0.5, |s| {
                largest = largest.max(s.deviation_mm);
                blocks.add(s.line, s.deviation_mm);
            })
            .expect("the trace");
            nc::moves_left_alone(&machine, &text, "bench.nc", &options).expect("the reader");
            std::hint::black_box((largest, blocks.by_line()));
        });
        let compensate = peak_of(|| {
            // As `volmap compensate` runs: the compensation, the check of what it wrote and
            // the model run along it.
            let compensated =
                nc::compensate(&machine, &text, "bench.nc", &options).expect("the compensation");
            let bounds = nc::CheckBounds::of(compensated.report.largest_correction_mm, &options);
            nc::check_written(
                &machine,
                &text,
                compensated.text.as_bytes(),
                "bench.nc",
                &options,
                bounds,
            )
            .expect("the check");
            let residual = nc::residual(&machine, &text, &compensated, "bench.nc", &options)
                .expect("the residual");
            std::hint::black_box(residual);
        });
        let mb = |b: usize| format!("{:.1} MB", b as f64 / 1e6);
        println!(
            "| {moves} | {} | {} | {} B | {} | {} B |",
            mb(text.len()),
            mb(trace),
            trace / moves,
            mb(compensate),
            compensate / moves
        );
    }
}
