//! The identity of a machine's sources: a SHA-256 over its machine file's text and each CSV
//! table it reads, so that two reports computed from the same files name the same hash, and a
//! change to any of them (a value, a table, a path) changes it.

use sha2::{Digest, Sha256};

use crate::model::Machine;

/// [`machine_sha256`] of the files `machine` was read from.
pub fn of_machine(machine: &Machine) -> String {
    machine_sha256(&machine.source.toml, &machine.source.csv_files)
}

/// `sha256:` and the hex SHA-256 of the machine file's `toml` text followed by each table's
/// path (as the machine file writes it) and text, in the order the file reads them; each part is
/// preceded by its length in bytes (8 bytes, little-endian), so that no two different sets of
/// parts hash the same bytes.
pub fn machine_sha256(toml: &str, csv_files: &[(String, String)]) -> String {
    let mut hasher = Sha256::new();
    let mut part = |bytes: &[u8]| {
        hasher.update((bytes.len() as u64).to_le_bytes());
        hasher.update(bytes);
    };
    part(toml.as_bytes());
    for (path, text) in csv_files {
        part(path.as_bytes());
        part(text.as_bytes());
    }
    let digest = hasher.finalize();
    let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
    format!("sha256:{hex}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_empty_machine_hashes_its_length_prefix() {
        // SHA-256 of eight zero bytes.
        assert_eq!(
            machine_sha256("", &[]),
            "sha256:af5570f5a1810b7af78caf4bc70a660f0df51e42baf91d4de5b2328de0e83dfc"
        );
    }

    #[test]
    fn moving_bytes_between_parts_changes_the_hash() {
        let a = machine_sha256("ab", &[("c".into(), "d".into())]);
        let b = machine_sha256("a", &[("bc".into(), "d".into())]);
        let c = machine_sha256("ab", &[("c".into(), "d ".into())]);
        assert_ne!(a, b);
        assert_ne!(a, c);
        assert_eq!(a, machine_sha256("ab", &[("c".into(), "d".into())]));
    }
}
