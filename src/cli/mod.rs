//! The command line: one file per subcommand, the arguments they share ([`args`]), the one place
//! errors become exit codes ([`failure`]) and the one place for output ([`output`]).

pub mod args;
pub mod bench;
pub mod budget;
pub mod budget_report;
pub mod build;
pub mod compensate;
pub mod export;
pub mod failure;
pub mod features;
pub mod fit;
pub mod info;
pub mod interrupt;
pub mod machines;
pub mod map;
pub mod output;
pub mod plot;
pub mod sample;
pub mod sweep;
pub mod test;
pub mod trace;
