//! Subcommands with modules of their own.

pub mod compensate;
pub mod plots;
pub mod standards;
