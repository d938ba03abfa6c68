//! volmap's fuzzing harness: a seeded, structure-aware mutational fuzzer run in process over
//! every parser and reader (`targets`), shared by the campaign runner (`cargo run --release -p
//! volmap-fuzz`, `src/main.rs`) and the short campaigns of this crate's test
//! (`tests/harness/`).
//!
//! An execution makes an input from the target's seed corpus (`tests/fuzz-corpus/<target>/`)
//! with mutations chosen by a generator seeded from the campaign's seed and the execution's
//! number (`rng`, `mutate`, `grammar`), runs the library's reader on it and checks that it did
//! not panic, broke none of the target's checks, made no more allocations and asked for no more
//! bytes than its counted limits and held at most 1 GiB of heap (`campaign`, `watch`).

use std::path::{Path, PathBuf};

pub mod campaign;
pub mod corpus;
pub mod grammar;
pub mod material;
pub mod mutate;
pub mod rng;
pub mod targets;
pub mod watch;

/// volmap's checkout, which holds the seed corpus (`tests/fuzz-corpus/`), the inputs of past
/// findings (`tests/fuzz-regressions/`) and the build folder the findings are saved in.
pub fn checkout() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the harness's crate lies in volmap's checkout")
}

/// Where the inputs of findings are saved unless told otherwise.
pub fn findings_folder() -> PathBuf {
    checkout().join("target").join("fuzz-findings")
}
