//! The command line: one file per subcommand, the arguments they share ([`args`]), the one place
//! errors become exit codes ([`failure`]), the one place for output ([`output`]) and the one
//! shape of every `--json` report ([`envelope`]; a field's summary in it: [`field_report`]), and
//! the one rule for the numbers it prints ([`numbers`]).
//!
//! Each command's work is done in the library; the file of a command here reads its arguments,
//! calls that module and prints what it returns:
//!
//! | command | file | the library's module |
//! |---|---|---|
//! | `map` | [`map`] | `volmap::engine` (the GPU, the CPU engine), `volmap::io::field` |
//! | `machines` | [`machines`] | `volmap::io::embedded` |
//! | `info` | [`info`] | `volmap::io::field` |
//! | `sample` | [`sample`] | `volmap::query` |
//! | `features` | [`features`] | `volmap::part` (with `volmap::design` for `--tolerances`) |
//! | `bench` | [`bench`] | `volmap::bench` |
//! | `test` | [`test`] | `volmap::standards` |
//! | `fit`, `build` | [`fit`], [`build`] | `volmap::calibrate` |
//! | `budget` | [`budget`], [`budget_report`] | `volmap::design` |
//! | `plot` | [`plot`] | `volmap::plot`, `volmap::query` |
//! | `compensate`, `trace` | [`compensate`], [`trace`] | `volmap::nc` |
//! | `export` | [`export`] | `volmap::export` |
//! | `cli-reference` (hidden) | [`reference`] | none: the clap definitions as Markdown |

// Defined before the commands' modules, so every one of them has them in scope.

/// `print!` to standard output through [`output::print_out`]: a closed standard output ends the
/// command quietly, never with a panic.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::output::print_out(format_args!($($arg)*))
    };
}

/// `println!` to standard output through [`output::print_out`].
macro_rules! outln {
    () => {
        $crate::cli::output::print_out(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::output::print_out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `eprintln!` to standard error through [`output::print_err`].
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::cli::output::print_err(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub mod args;
pub mod bench;
pub mod budget;
pub mod budget_allocate;
pub mod budget_report;
pub mod build;
pub mod compensate;
pub mod completions;
pub mod envelope;
pub mod estimate;
pub mod export;
pub mod failure;
pub mod features;
pub mod field_report;
pub mod fit;
pub mod info;
pub mod interrupt;
pub mod machines;
pub mod man;
pub mod map;
pub mod map_report;
pub mod merge_maps;
pub mod merge_samples;
pub mod numbers;
pub mod output;
pub mod plot;
pub mod reference;
pub mod sample;
pub mod sweep;
pub mod test;
pub mod trace;
pub mod view;
