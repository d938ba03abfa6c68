//! What the fuzzing campaigns found in the heap a reader takes, each kept as the input that
//! showed it (`tests/fuzz-regressions/`) or a hand-made one like it: measured with the harness's
//! counting allocator, which this test installs (volmap's own tests do not).

use volmap::model::Machine;

fn regression(name: &str) -> Vec<u8> {
    let path = volmap_fuzz::checkout()
        .join("tests/fuzz-regressions")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn machine() -> Machine {
    volmap::io::embedded::embedded("vmc-li2015")
        .unwrap()
        .unwrap()
}

/// A field header whose attribute claims 2³⁰ bytes in a file of 6 kB: 1 GiB was allocated
/// before the read found the file's end.
#[test]
fn a_header_attribute_claiming_a_gigabyte_allocates_what_the_file_holds() {
    use volmap_fuzz::watch;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.exr");
    std::fs::write(&path, regression("field-attribute-size.exr")).unwrap();
    watch::begin();
    let result = volmap::io::field::FieldFile::open(&path);
    let usage = watch::end();
    let error = result.err().expect("refused").to_string();
    assert!(
        error.ends_with("the file ends inside its header"),
        "{error}"
    );
    assert!(usage.largest_request_bytes < 4 << 20, "{usage:?}");
}

/// A part file naming `/dev/zero` as its mesh held 1 GiB: reading up to a 512 MiB limit doubled
/// the buffer to 1 GiB at the last byte. Reads now stop before the limit is passed.
#[test]
fn a_file_that_never_ends_is_read_within_its_limit() {
    use volmap::io::source::{read_bytes, SourceKind};
    use volmap_fuzz::watch;
    watch::begin();
    let result = read_bytes(std::path::Path::new("/dev/zero"), SourceKind::Text);
    let usage = watch::end();
    let error = result.unwrap_err().to_string();
    assert!(
        error.starts_with("/dev/zero: larger than 64 MiB"),
        "{error}"
    );
    let limit = SourceKind::Text.limit_bytes();
    assert!(usage.largest_request_bytes <= limit, "{usage:?}");
}

/// A floor sampled every 0.5 mm (241,001 points) took 2.3 s and 600 MB: its minimum zone was
/// one linear programme of two rows a point. It is now solved on subsets (the same optimum).
#[test]
fn a_finely_sampled_floor_is_evaluated_in_little_memory() {
    use volmap::part::{self, ErrorSource, PartFile};
    use volmap_fuzz::watch;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("part.toml");
    std::fs::write(&path, regression("part-fine-floor.toml")).unwrap();
    let part = PartFile::read(&path).unwrap();
    let machine = machine();
    // On this thread alone, where the heap is counted.
    let (result, usage) = volmap_fuzz::campaign::single_threaded(|| {
        watch::begin();
        let result = part::evaluate(&part, ErrorSource::Exact(&machine), "part.toml").unwrap();
        (result, watch::end())
    });
    assert!(usage.peak_bytes < 200 << 20, "{usage:?}");
    assert_eq!(result.len(), 1);
    let floor = format!("{:?}", result[0]);
    assert!(floor.contains("pocket floor"), "{floor}");
}
