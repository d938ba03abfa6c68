//! What the fuzzing campaigns found in field files (docs/testing.md, "Fuzzing"), each kept as the file
//! that showed it (`tests/fuzz-regressions/`), with the error volmap now gives.

use super::common::fuzz_regression as regression;

/// The error opening the saved field `name` gives (it must be refused).
fn field_error(name: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.exr");
    std::fs::write(&path, regression(name)).unwrap();
    volmap::io::field::FieldFile::open(&path)
        .err()
        .expect("refused")
        .to_string()
}

/// A multi-part field whose part, not a scanline image, was named with a machine file's text
/// quoted the whole name: the name is quoted cut to 80 characters.
#[test]
fn a_long_part_name_is_quoted_cut() {
    let error = field_error("field-part-name.exr");
    assert!(error.len() < 400, "{error}");
    assert!(
        error.ends_with("…`) is not a scanline image; volmap reads the fields it writes"),
        "{error}"
    );
}

/// A field whose `volmap.temperatures` attribute held a kilobyte of other attributes' text (with
/// a backquote in it) was quoted whole: the inputs' messages quote what they were given cut.
#[test]
fn a_bad_inputs_attribute_is_quoted_cut() {
    let error = field_error("field-temperatures-attribute.exr");
    assert!(error.len() < 400, "{error}");
    assert!(
        error.contains("not a volmap field: attribute volmap.temperatures: `")
            && error.ends_with("…`: expected NAME=VALUE pairs separated by commas"),
        "{error}"
    );
}

/// A field of 150 channels was refused listing every one: the message names the first eight and
/// how many there are.
#[test]
fn a_field_of_many_channels_names_the_first_few() {
    let error = field_error("field-many-channels.exr");
    assert!(error.len() < 600, "{error}");
    assert!(
        error.contains("channels must be OE.X OE.Y OE.Z VE.X VE.Y VE.Z all FLOAT (or all HALF), found OE.X FLOAT, OE.Y FLOAT,"),
        "{error}"
    );
    assert!(error.contains(", … ("), "{error}");
    assert!(error.ends_with(" channels in all)"), "{error}");
}
