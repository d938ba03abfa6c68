//! What volmap prints for people, shared by the command line and the library's report text.

pub mod numbers;
