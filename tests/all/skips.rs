//! Tests that skip where the GPU or a reader is missing, said where they can be seen: a test that
//! skips writes `volmap-skip: TEST: REASON` straight to the process's stderr (libtest captures a
//! passing test's `eprintln!`) and, when the test binary exits, one `volmap-skip:` line per reason
//! lists every test skipped for it. `VOLMAP_REQUIRE_GPU` makes a missing adapter a failure, and
//! `VOLMAP_REQUIRE_READERS` (or its older name `VOLMAP_REQUIRE_EXR_TOOLS`) a missing reader
//! (exrheader, oiiotool, Python's OpenEXR, VTK, plyfile and jsonschema, LinuxCNC's rs274, the
//! Python model). `cargo test 2>&1 | grep volmap-skip` lists what did not run.

use std::collections::BTreeMap;
use std::io::Write;
use std::sync::{Mutex, Once};

/// The skips so far: the test (its thread's name, which libtest sets) and the reason.
static SKIPPED: Mutex<Vec<(String, String)>> = Mutex::new(Vec::new());
static SUMMARY_AT_EXIT: Once = Once::new();

/// Whether a missing GPU adapter must fail the tests.
pub fn gpu_required() -> bool {
    std::env::var_os("VOLMAP_REQUIRE_GPU").is_some()
}

/// Whether a missing reader must fail the tests: `VOLMAP_REQUIRE_READERS`, or the name CI set
/// before it, `VOLMAP_REQUIRE_EXR_TOOLS`.
pub fn readers_required() -> bool {
    ["VOLMAP_REQUIRE_READERS", "VOLMAP_REQUIRE_EXR_TOOLS"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}

/// Records that the running test skips (all of it or a part) for `reason`, and says so at once
/// and again at the end of the run.
pub fn skipped(reason: &str) {
    let test = std::thread::current()
        .name()
        .unwrap_or("(unnamed thread)")
        .to_string();
    // Straight to the file descriptor: `eprintln!` would be captured and shown only on failure.
    let _ = writeln!(std::io::stderr(), "volmap-skip: {test}: {reason}");
    let mut skipped = SKIPPED.lock().unwrap_or_else(|e| e.into_inner());
    if !skipped.iter().any(|(t, r)| *t == test && r == reason) {
        skipped.push((test, reason.to_string()));
    }
    drop(skipped);
    // libtest has no hook at the end of a run; the C runtime's exit handlers run after it,
    // whether the run passed (main returns) or failed (`process::exit`).
    SUMMARY_AT_EXIT.call_once(|| {
        // SAFETY: registers a function that takes no arguments and does not unwind.
        unsafe {
            libc::atexit(print_summary);
        }
    });
}

extern "C" fn print_summary() {
    let skipped = SKIPPED.lock().unwrap_or_else(|e| e.into_inner());
    let mut err = std::io::stderr();
    for line in summary(&skipped) {
        let _ = writeln!(err, "{line}");
    }
}

/// One line per reason: `volmap-skip: 2 tests skipped: no GPU adapter: a, b`, tests sorted.
pub fn summary(skipped: &[(String, String)]) -> Vec<String> {
    let mut by_reason: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (test, reason) in skipped {
        by_reason.entry(reason).or_default().push(test);
    }
    by_reason
        .into_iter()
        .map(|(reason, mut tests)| {
            tests.sort_unstable();
            let count = match tests.len() {
                1 => "1 test".to_string(),
                n => format!("{n} tests"),
            };
            format!(
                "volmap-skip: {count} skipped: {reason}: {}",
                tests.join(", ")
            )
        })
        .collect()
}

#[test]
fn the_summary_lists_each_reason_once_with_its_tests() {
    let skips = [
        ("gpu::b", "no GPU adapter"),
        ("vtk::ply", "the Python plyfile package is not installed"),
        ("gpu::a", "no GPU adapter"),
    ]
    .map(|(t, r)| (t.to_string(), r.to_string()));
    assert_eq!(
        summary(&skips),
        [
            "volmap-skip: 2 tests skipped: no GPU adapter: gpu::a, gpu::b",
            "volmap-skip: 1 test skipped: the Python plyfile package is not installed: vtk::ply",
        ]
    );
    assert!(summary(&[]).is_empty());
}
