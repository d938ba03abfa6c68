//! volmap's fuzzing harness: a seeded, structure-aware mutational fuzzer run in process over
//! every parser and reader (`targets`), shared by the campaign runner (`cargo run --release
//! --example fuzz`) and the short campaigns of the test suite (`tests/all/fuzz.rs`).
//!
//! An execution makes an input from the target's seed corpus (`tests/fuzz-corpus/<target>/`)
//! with mutations chosen by a generator seeded from the campaign's seed and the execution's
//! number (`rng`, `mutate`, `grammar`), runs the library's reader on it and checks that it did
//! not panic, broke none of the target's checks, took at most a second of CPU time and held at
//! most 1 GiB of heap (`campaign`, `watch`).

// The test suite uses part of what the campaign runner does.
#![allow(dead_code)]

pub mod campaign;
pub mod corpus;
pub mod grammar;
pub mod mutate;
pub mod rng;
pub mod targets;
pub mod watch;
