//! Numbers in what the commands print: the rule is the library's ([`volmap::report::numbers`]),
//! so the command line and the library's report text print them alike.

pub use volmap::report::numbers::*;
