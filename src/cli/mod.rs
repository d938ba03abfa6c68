//! Subcommands with modules of their own.

pub mod plots;
pub mod standards;
