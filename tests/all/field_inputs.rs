//! Field files record the evaluation inputs they were computed for (docs/model.md, "Evaluation
//! inputs"): every header, every part, read back the same; a field written before fields
//! recorded them means the default inputs; OpenEXR's own readers see the attributes.

use exr::meta::attribute::AttributeValue;
use volmap::engine::map::{self, MapOptions};
use volmap::engine::Engine;
use volmap::io::field::{FieldFile, FieldInfo, FieldReader, FieldWriter, PartsWriter};
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;
use volmap::model::inputs::{Approach, Inputs, InputsRecord};
use volmap::model::{AxisLetter, Machine};

use super::field::tool_available;

/// A machine with thermal and reversal terms: X's scale expands (α = 11.5e-6 /K), Y has a 4 µm
/// backlash, the spindle grows by -1.5 µm/K.
pub const THERMAL_MACHINE: &str = r#"
name = "thermal gantry"
chain = "FFXYZ"
[thermal]
reference_C = 20.0
inputs = ["x_scale", "spindle"]
[axes.X]
range = [0.0, 2000.0]
EXX = { value = { poly = [0.0, 5.0e-6] }, per_kelvin = { x_scale = { poly = [0.0, 11.5e-6] } } }
EBX = 1.0e-5
[axes.Y]
range = [0.0, 1000.0]
EYY = { poly = [0.0, 2.0e-6], reverse = { poly = [0.004, 2.0e-6] } }
EC0Y = 1.5e-5
[axes.Z]
range = [0.0, 500.0]
[spindle]
EZS = { value = 0.0, per_kelvin = { spindle = -0.0015 } }
"#;

fn thermal_machine() -> Machine {
    Machine::from_toml(THERMAL_MACHINE, "thermal.toml", None).unwrap()
}

fn record(approach: &[(AxisLetter, Approach)], temperatures: &[(&str, f64)]) -> InputsRecord {
    InputsRecord {
        approach: approach.to_vec(),
        temperatures_c: temperatures
            .iter()
            .map(|(n, t)| (n.to_string(), *t))
            .collect(),
        reference_c: (!temperatures.is_empty()).then_some(20.0),
    }
}

fn small_info(inputs: InputsRecord) -> FieldInfo {
    FieldInfo {
        dims: [2, 1, 1],
        spacing_mm: [1.0; 3],
        machine_name: "m".into(),
        chain: "FFXYZ".into(),
        machine_toml: "[thermal]\ninputs = [\"a\", \"b\"]\nreference_C = 21.5\n".into(),
        device: "test".into(),
        inputs,
        ..FieldInfo::default()
    }
}

fn write_small(path: &std::path::Path, info: &FieldInfo) {
    let mut writer = FieldWriter::create(path, info).unwrap();
    writer
        .write_lines(0, 1, &[0.0; 2 * CHANNELS.len()])
        .unwrap();
    writer.finish().unwrap();
}

#[test]
fn a_fields_header_round_trips_its_inputs() {
    use AxisLetter::*;
    let dir = tempfile::tempdir().unwrap();
    let held = record(
        &[
            (X, Approach::Positive),
            (Y, Approach::Negative),
            (Z, Approach::Positive),
        ],
        &[("a", 24.5), ("b", 1.0 / 3.0)],
    );
    let path = dir.path().join("one.exr");
    write_small(&path, &small_info(held.clone()));
    let reader = FieldReader::open(&path).unwrap();
    assert_eq!(reader.info().inputs, held);
    assert_eq!(
        held.describe(),
        "approach X+ Y- Z+; temperatures a=24.5 °C, b=0.3333333333333333 °C (reference 20 °C)"
    );

    // A recorded direction that is not one is refused, naming the attribute.
    let mut bytes = std::fs::read(&path).unwrap();
    let at = bytes.windows(11).position(|w| w == b"X=+,Y=-,Z=+").unwrap();
    bytes[at + 6] = b'?';
    let bad = dir.path().join("bad.exr");
    std::fs::write(&bad, &bytes).unwrap();
    let message = FieldReader::open(&bad).err().expect("refused").to_string();
    assert!(
        message.contains("attribute volmap.approach") && message.contains("`Y=?`"),
        "{message}"
    );

    // Every part of a multi-part file carries them.
    let sweep = dir.path().join("parts.exr");
    let mut writer = PartsWriter::create(&sweep, 2, |p| {
        (format!("part {p}"), small_info(held.clone()))
    })
    .unwrap();
    for p in 0..2 {
        writer
            .write_lines(p, 0, 1, &[0.0; 2 * CHANNELS.len()])
            .unwrap();
    }
    writer.finish().unwrap();
    let file = FieldFile::open(&sweep).unwrap();
    for p in 0..2 {
        assert_eq!(file.inputs(p), &held);
        assert_eq!(file.info(p).inputs, held);
    }

    // A machine without [thermal] records its directions only.
    let plain = record(&[(X, Approach::Negative), (Z, Approach::Positive)], &[]);
    let path = dir.path().join("plain.exr");
    let mut info = small_info(plain.clone());
    info.chain = "FXFZ".into();
    write_small(&path, &info);
    assert_eq!(FieldReader::open(&path).unwrap().info().inputs, plain);
}

#[test]
fn a_field_written_before_fields_recorded_inputs_means_the_default_inputs() {
    use AxisLetter::*;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.exr");
    let held = record(
        &[
            (X, Approach::Negative),
            (Y, Approach::Negative),
            (Z, Approach::Negative),
        ],
        &[("a", 30.0), ("b", 40.0)],
    );
    write_small(&path, &small_info(held));
    // The same file without the attributes: renamed in place (same lengths), so readers skip
    // them as attributes of no meaning to volmap, as they skip any other.
    let mut bytes = std::fs::read(&path).unwrap();
    for (name, other) in [
        ("volmap.approach", "volmap.xpproach"),
        ("volmap.temperatures", "volmap.xemperatures"),
        ("volmap.referenceTemperature", "volmap.xeferenceTemperature"),
        ("volmap.inputs", "volmap.xnputs"),
    ] {
        let at = bytes
            .windows(name.len() + 1)
            .position(|w| w == [name.as_bytes(), b"\0"].concat())
            .unwrap_or_else(|| panic!("{name} is written"));
        bytes[at..at + other.len()].copy_from_slice(other.as_bytes());
    }
    std::fs::write(&path, &bytes).unwrap();
    let reader = FieldReader::open(&path).unwrap();
    let expected = InputsRecord {
        approach: vec![
            (X, Approach::Positive),
            (Y, Approach::Positive),
            (Z, Approach::Positive),
        ],
        temperatures_c: vec![("a".into(), 21.5), ("b".into(), 21.5)],
        reference_c: Some(21.5),
    };
    assert_eq!(reader.info().inputs, expected);
    let file = FieldFile::open(&path).unwrap();
    file.check_inputs(&Inputs::default()).unwrap();
}

#[test]
fn a_field_is_refused_for_other_inputs_saying_what_it_holds() {
    let dir = tempfile::tempdir().unwrap();
    let machine = thermal_machine();
    let inputs = Inputs::parse("x_scale=25", "Y=-", &machine).unwrap();
    let at = machine.at(&inputs);
    let grid = Grid::full_travel(&at, [3, 2, 2], [0.0; 6]).unwrap();
    let path = dir.path().join("warm.exr");
    map::map_to_file(
        &at,
        &grid,
        &Engine::Cpu,
        &path,
        &MapOptions::default(),
        |_| {},
    )
    .unwrap();
    let file = FieldFile::open(&path).unwrap();
    assert_eq!(file.inputs(0), &inputs.record(&machine));
    file.check_inputs(&inputs).unwrap();
    // Naming an input at its reference is the same as leaving it out.
    file.check_inputs(&Inputs::parse("x_scale=25,spindle=20", "Y=-,X=+", &machine).unwrap())
        .unwrap();
    for (temperatures, approach) in [("", ""), ("x_scale=25", ""), ("x_scale=25.5", "Y=-")] {
        let asked = Inputs::parse(temperatures, approach, &machine).unwrap();
        let message = file.check_inputs(&asked).unwrap_err().to_string();
        assert!(
            message.contains(
                "holds the field computed at approach X+ Y- Z+; temperatures x_scale=25 °C, spindle=20 °C (reference 20 °C)"
            ) && message.contains("not at the inputs asked"),
            "{message}"
        );
    }
}

#[test]
fn openexr_readers_see_the_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let machine = thermal_machine();
    let at = machine.at(&Inputs::parse("x_scale=24.5", "Y=-", &machine).unwrap());
    let grid = Grid::full_travel(&at, [3, 2, 2], [0.0; 6]).unwrap();
    let path = dir.path().join("warm.exr");
    map::map_to_file(
        &at,
        &grid,
        &Engine::Cpu,
        &path,
        &MapOptions::default(),
        |_| {},
    )
    .unwrap();
    // The exr crate reads the file with its double attribute.
    let image = exr::prelude::read_first_flat_layer_from_file(&path).unwrap();
    let attribute = |name: &str| {
        let key = exr::prelude::Text::from(name);
        image
            .attributes
            .other
            .get(&key)
            .or_else(|| image.layer_data.attributes.other.get(&key))
            .cloned()
    };
    let text = |name: &str| match attribute(name) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{name}: {other:?}"),
    };
    assert_eq!(text("volmap.approach"), "X=+,Y=-,Z=+");
    assert_eq!(text("volmap.temperatures"), "x_scale=24.5,spindle=20");
    assert!(matches!(
        attribute("volmap.referenceTemperature"),
        Some(AttributeValue::F64(t)) if t == 20.0
    ));

    if tool_available(
        std::process::Command::new("sh").args(["-c", "command -v exrheader"]),
        "exrheader (Debian package openexr)",
    ) {
        let output = std::process::Command::new("exrheader")
            .arg(&path)
            .output()
            .unwrap();
        assert!(output.status.success());
        let text = String::from_utf8_lossy(&output.stdout);
        for expected in [
            "volmap.approach (type string): \"X=+,Y=-,Z=+\"",
            "volmap.temperatures (type string): \"x_scale=24.5,spindle=20\"",
            "volmap.referenceTemperature (type double): 20",
            "volmap.inputs (type string): \"approach X+ Y- Z+; temperatures x_scale=24.5",
        ] {
            assert!(
                text.contains(expected),
                "exrheader lacks `{expected}`:\n{text}"
            );
        }
    }
    if tool_available(
        std::process::Command::new("python3").args(["-c", "import OpenEXR, numpy"]),
        "the Python OpenEXR package",
    ) {
        let script = [
            "import sys, numpy, OpenEXR",
            "with OpenEXR.File(sys.argv[1]) as f:",
            "    h = f.header()",
            "    print(h['volmap.approach'], h['volmap.temperatures'],",
            "          float(numpy.ravel(h['volmap.referenceTemperature'])[0]))",
        ]
        .join("\n");
        let output = std::process::Command::new("python3")
            .args(["-c", &script])
            .arg(&path)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        assert_eq!(
            String::from_utf8_lossy(&output.stdout).trim(),
            "X=+,Y=-,Z=+ x_scale=24.5,spindle=20 20.0"
        );
    }
}
