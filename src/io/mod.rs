//! Files: every format volmap reads and writes that more than one part of it uses. The machine
//! file (TOML, with CSV tables) and the embedded machines, field files (OpenEXR), meshes (STL in,
//! PLY out).

pub mod embedded;
pub mod field;
pub mod machine_file;
pub mod mesh;
pub mod points;
