//! What the fuzzing campaigns found (README "Fuzzing"), each kept as the input that showed it
//! (`tests/fuzz-regressions/`) or a hand-made one like it, with the error volmap now gives.

use std::path::PathBuf;

use volmap::model::Machine;
use volmap::nc::{self, NcError, Options};

fn regression(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz-regressions")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

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

fn machine() -> Machine {
    volmap::io::embedded::embedded("vmc-li2015")
        .unwrap()
        .unwrap()
}

fn options() -> Options {
    Options {
        work_offsets: [(54, [200.0, 200.0, 300.0, 0.0, 0.0, 0.0])].into(),
        ..Options::default()
    }
}

fn line_error(result: Result<impl std::fmt::Debug, NcError>) -> (usize, String) {
    match result {
        Err(NcError::Line { line, message, .. }) => (line, message),
        other => panic!("expected an error naming a line, got {other:?}"),
    }
}

/// A G83 hole 6 km deep in pecks of 2 mm made three million pecks (a 4 GB allocation, then an
/// abort): a hole takes at most 10,000 pecks.
#[test]
fn pecks_past_the_limit_are_refused_naming_the_block() {
    let program = regression("gcode-pecks.nc");
    let (line, message) = line_error(nc::compensate(&machine(), &program, "p.nc", &options()));
    assert_eq!(line, 24);
    assert_eq!(
        message,
        "G83: a peck depth Q2 from R3 to Z-6000000 makes 3000002 pecks, more than the 10000 a hole may take"
    );
    // A peck depth of a ten-thousandth of a micrometre in a 7 mm hole.
    let tiny = b"G0 X10 Y10 Z10\nG83 X10 Y10 Z-5 R2 Q0.0000001\nG80\nM30\n";
    let (line, message) = line_error(nc::blocks_as_run(tiny, "q.nc", false));
    assert_eq!(line, 2);
    assert!(
        message.contains("makes 70000000 pecks, more than the 10000"),
        "{message}"
    );
}

/// A peck smaller than the last digit of the levels it pecks between went on for ever: each
/// peck left the level where it was. Such a peck now goes to the depth.
#[test]
fn pecks_below_the_resolution_of_their_levels_end() {
    let program = b"G0 X10 Y10 Z1e17\nG83 X10 Y10 Z99999999999999990 R1e17 Q2\nG80\nM30\n";
    let blocks = nc::blocks_as_run(program, "deep.nc", false).unwrap();
    let feeds: Vec<&str> = blocks
        .iter()
        .map(|b| b.text.trim())
        .filter(|t| t.starts_with("G1 Z"))
        .collect();
    // The depth as an f64 holds it (its last digit is 16).
    assert_eq!(feeds, ["G1 Z99999999999999984"], "{blocks:#?}");
}

/// Subprograms calling subprograms a thousand times each expanded three million blocks from
/// 30 lines (1.25 GB and 7 s to compensate); calls and cycles add at most four million words
/// and blocks (a block counting eight), which a million blocks of eight words (700 MB, 1 s to
/// read) also passed. A million calls of a body of two comments, when a block counted one, took
/// 600 MB and over a second on a busy machine.
#[test]
fn calls_and_cycles_add_at_most_four_million_words_and_blocks() {
    let program = regression("gcode-calls.nc");
    let (line, message) = line_error(nc::blocks_as_run(&program, "c.nc", false));
    assert_eq!(line, 8, "the outermost call");
    assert_eq!(
        message,
        "M98: the calls add more than 4000000 words and blocks to the program"
    );
    let words = regression("gcode-words.nc");
    let (line, message) = line_error(nc::blocks_as_run(&words, "w.nc", false));
    assert_eq!(line, 18);
    assert_eq!(
        message,
        "M98: the calls add more than 4000000 words and blocks to the program"
    );
    // Canned cycles count against the same bound: 1000 repeats of 1000 pecks.
    let cycles = b"G0 X10 Y10 Z10\nG83 X10 Y10 Z-999 R1 Q1 L1000\nG80\nM30\n";
    let (line, message) = line_error(nc::blocks_as_run(cycles, "h.nc", false));
    assert_eq!(line, 2);
    assert_eq!(
        message,
        "the subprogram calls and canned cycles add more than 4000000 words and blocks to the program"
    );
    // Blocks of nothing but comments count as blocks: the outermost call is refused.
    let empty = regression("gcode-empty-calls.nc");
    let (line, message) = line_error(nc::blocks_as_run(&empty, "e.nc", false));
    assert_eq!(line, 7);
    assert_eq!(
        message,
        "M98: the calls add more than 4000000 words and blocks to the program"
    );
    // Long blocks count for their length: a 6 kB block repeated a million times.
    let long = format!(
        "G0 X10 Y10 Z10\nM98 P1 L1000\nM30\nO1\nM98 P2 L1000\nM99\nO2\nG1 X11 ({})\nM99\n",
        "x".repeat(6000)
    );
    let (line, _) = line_error(nc::blocks_as_run(long.as_bytes(), "l.nc", false));
    assert_eq!(line, 2);
    // A program's own blocks do not count: two million and more of them are read as they are.
    let mut own = String::from("G0 X10 Y10 Z10\nM98 P1\nM30\nO1\nG1 X11 F100\nM99\n");
    own.push_str(&"G1 X12\n".repeat(1_100_000));
    let blocks = nc::blocks_as_run(own.as_bytes(), "own.nc", false).unwrap();
    assert!(blocks.len() > 1_100_000);
}

/// Writes an input of several files (`harness::corpus::split`) into `dir`; the main file's path.
fn write_files(dir: &std::path::Path, main: &str, input: &[u8]) -> PathBuf {
    let (first, others) = crate::fuzz::harness::corpus::split(input);
    std::fs::write(dir.join(main), first).unwrap();
    for (name, bytes) in others {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    dir.join(main)
}

/// A circle with one deviation of 387 mm (micrometres written as mm) fitted a squareness of
/// 0.29 rad, reported as an estimate and written by `fit --out` into a file no reader takes:
/// such an estimate is refused, naming the fit file.
#[test]
fn estimates_no_machine_can_have_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_files(dir.path(), "fit.toml", &regression("fit-implausible.toml"));
    let file = volmap::calibrate::fit::FitFile::read(&path).unwrap();
    let error = volmap::calibrate::fit::fit(&machine(), &file)
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "{}: estimate: the estimate of EC0Y is -0.29",
            path.display()
        )) && error.contains("more than any machine tool has (at most 1e-2 rad)"),
        "{error}"
    );
}

/// A test's value written as a string of 4 kB over several lines (`to_deg = """a…"""`) was
/// quoted whole in the message saying it is not a number.
#[test]
fn a_long_string_where_a_number_belongs_is_quoted_in_part() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_files(dir.path(), "fit.toml", &regression("fit-long-string.toml"));
    let error = match volmap::calibrate::fit::FitFile::read(&path) {
        Ok(_) => panic!("a string where degrees belong was read"),
        Err(e) => e.to_string(),
    };
    assert!(
        error.starts_with(&format!(
            "{}: [[rtest]] number 1: invalid type: string",
            path.display()
        )),
        "{error}"
    );
    assert!(
        error.contains('…') && error.len() < 400,
        "{} bytes: {error}",
        error.len()
    );
}

/// What the tests cannot tell apart was said without the file it is about.
#[test]
fn errors_of_the_estimation_name_the_fit_file() {
    let dir = tempfile::tempdir().unwrap();
    let seed = std::fs::read(
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fuzz-corpus/fit/diagonal-positioning.toml"),
    )
    .unwrap();
    let two = String::from_utf8(seed)
        .unwrap()
        .replace("estimate = [\"EC0Y\"]", "estimate = [\"EC0Y\", \"EB0Z\"]");
    let path = write_files(dir.path(), "fit.toml", two.as_bytes());
    let file = volmap::calibrate::fit::FitFile::read(&path).unwrap();
    let error = volmap::calibrate::fit::fit(&machine(), &file)
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "{}: estimate: EC0Y and EB0Z cannot be told apart",
            path.display()
        )),
        "{error}"
    );
}

/// 2³² µrad of pitch at one position (a count where the angle belonged) was built into a
/// machine file that no command then read: `build` refuses it, naming the measurements and
/// the component.
#[test]
fn measured_tables_no_machine_can_have_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.csv");
    std::fs::write(&path, regression("interferometer-implausible.csv")).unwrap();
    let axes = [(volmap::model::AxisLetter::X, path.as_path())];
    let error = volmap::calibrate::build::build(&machine(), &axes, &[])
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "{}: axes.X.EBX: an angular error of 4294.9673 rad at X=200.000 mm is more than any machine tool has",
            path.display()
        )),
        "{error}"
    );
}

fn five_axis_setup() -> volmap::standards::Setup {
    let machine = volmap::io::embedded::embedded("5axis-hwang2014")
        .unwrap()
        .unwrap();
    volmap::standards::Setup::new(&machine, "").unwrap()
}

/// Measured results of a circle at one angle: the error said the angles do not determine a
/// circle without saying whose angles; it names the file now.
#[test]
fn a_circle_of_measured_angles_that_determine_none_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.csv");
    std::fs::write(&path, regression("measured-one-angle.csv")).unwrap();
    let spec = volmap::standards::CircularSpec {
        plane: "XY".into(),
        centre_mm: None,
        radius_mm: None,
        points: 36,
        direction: "ccw".into(),
        start_deg: 0.0,
        pose: String::new(),
        csv: Some(path.clone()),
        pitch_mm: None,
    };
    let error = volmap::standards::circular(&five_axis_setup(), &spec)
        .unwrap_err()
        .to_string();
    assert_eq!(
        error,
        format!(
            "{}: the angles do not determine a circle (at least 3 distinct angles spread around it)",
            path.display()
        )
    );
}

/// An R-test measured at C = 30,000,000°: the sphere there lies outside the travel, said
/// without the file or line that asked for it; both are named now.
#[test]
fn an_r_test_angle_beyond_the_travel_names_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.csv");
    std::fs::write(&path, regression("measured-rtest-angle.csv")).unwrap();
    let spec = volmap::standards::RTestSpec {
        axis: "C".into(),
        sphere_mm: Some([300.0, 200.0, 250.0]),
        from_deg: Some(0.0),
        to_deg: Some(30.0),
        step_deg: 10.0,
        pose: String::new(),
        csv: Some(path.clone()),
    };
    let error = volmap::standards::rtest(&five_axis_setup(), &spec)
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with(&format!(
            "{}: line 5: R-test of C at C=30000000°: Y=",
            path.display()
        )) && error.contains("lies outside the travel of Y (0 to 600)"),
        "{error}"
    );
}

fn compensated_reads_back(machine: &Machine, program: &[u8]) -> String {
    let options = Options {
        tool_lengths: nc::ToolLengths::parse("T1=80").unwrap(),
        ..options()
    };
    let out = nc::compensate(machine, program, "in.nc", &options).unwrap();
    if let Err(e) = nc::trace(machine, out.text.as_bytes(), "out.nc", &options) {
        panic!(
            "the compensated program does not read back: {e}\n{}",
            out.text
        );
    }
    out.text
}

/// A last line without a line end whose arc was split: the added pieces were written onto it,
/// one block of two arcs (`X59.9299 Y19.7988 I-9.8263 X49.9317 …`) that no reader takes.
#[test]
fn pieces_after_a_last_line_without_a_line_end_start_lines_of_their_own() {
    let program = regression("gcode-last-line.nc");
    assert!(!program.ends_with(b"\n"));
    let text = compensated_reads_back(&machine(), &program);
    for line in text.lines() {
        assert!(line.matches('X').count() <= 1, "{line}\n{text}");
    }
}

/// A half circle by R (`G3 X40 Y0 R10` from X20): compensated, its written R (9.9999) fell
/// short of half its written chord (10.0000), which the reader refuses; the planner now holds
/// a written R to the reader's rule and splits such an arc.
#[test]
fn compensated_half_circles_by_radius_read_back() {
    let five = volmap::io::embedded::embedded("5axis-hwang2014")
        .unwrap()
        .unwrap();
    compensated_reads_back(&five, &regression("gcode-half-circle-r.nc"));
}

/// A misspelt key of 3,000 characters was quoted whole in the message, as the command line
/// shows it (`capped` cuts what is quoted between backticks, not the key's path).
#[test]
fn long_keys_are_quoted_within_80_characters() {
    use volmap::error::capped;
    let key = "k".repeat(3000);
    let text = format!("name = \"m\"\nchain = \"FYXFZ\"\n[axes.X]\nrange = [0.0, 100.0]\n\"{key}\" = 1\n[axes.Y]\nrange = [0.0, 100.0]\n[axes.Z]\nrange = [0.0, 100.0]\n");
    let message = capped(
        &Machine::from_toml(&text, "m.toml", None)
            .unwrap_err()
            .to_string(),
    );
    assert!(message.len() < 400, "{message}");
    assert!(message.starts_with("m.toml: axes.X.kkk"), "{message}");
    let tolerances = format!("[\"{key}\"]\nx = 1\n");
    let message = capped(
        &volmap::io::tolerance_file::ToleranceFile::parse(
            &tolerances,
            std::path::Path::new("t.toml"),
            &machine(),
        )
        .unwrap_err()
        .to_string(),
    );
    assert!(message.len() < 400, "{message}");
    assert!(message.starts_with("t.toml: kkk"), "{message}");
}

/// An arc in the XZ plane after `G53 G0 Z0` and no Z word since: its K was written relative to
/// a Z the output had not written, as `KNaN`. Such an arc starts where the control has Z, not at
/// a point of the program: it is refused now, naming its line and the G53 block
/// (`fuzz_findings_nc`); with Z set again before it, its centre words are numbers.
#[test]
fn centre_words_after_a_reference_return_are_numbers() {
    let program = regression("gcode-arc-after-home.nc");
    let (line, message) = line_error(nc::compensate(&machine(), &program, "p.nc", &options()));
    assert_eq!(line, 10);
    assert!(message.contains("on line 7"), "{message}");
    let set = String::from_utf8(program)
        .unwrap()
        .replace("G18 G2 X60 Z-1", "G1 Z-1\nG18 G2 X60 Z-1");
    let text = compensated_reads_back(&machine(), set.as_bytes());
    assert!(!text.contains("NaN") && !text.contains("inf"), "{text}");
}

/// A field header whose attribute claims 2³⁰ bytes in a file of 6 kB: 1 GiB was allocated
/// before the read found the file's end.
#[test]
fn a_header_attribute_claiming_a_gigabyte_allocates_what_the_file_holds() {
    use crate::fuzz::harness::watch;
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

/// Work offsets of ten thousand unclosed inline tables overflowed the TOML parser's stack (an
/// abort, on the command line too): every TOML reader refuses nesting beyond 64 levels first,
/// naming the line.
#[test]
fn toml_nested_beyond_the_limit_is_refused_before_it_is_parsed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("offsets.toml");
    std::fs::write(&path, "G54 = { [200.0, 200.0, 300.0]\n".repeat(10_000)).unwrap();
    let error = nc::read_work_offsets(&path).unwrap_err().to_string();
    assert!(
        error.ends_with(
            "line 64, column 9: arrays and inline tables nested more than 64 levels deep\n  | G54 = { [200.0, 200.0, 300.0]"
        ),
        "{error}"
    );
    let machine_file = dir.path().join("m.toml");
    std::fs::write(&machine_file, format!("name = {}", "[".repeat(100_000))).unwrap();
    let error = volmap::model::Machine::from_path(&machine_file)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("line 1, column 72: arrays and inline tables nested more than 64"),
        "{error}"
    );
}

/// A CSV name of 4 kB in a fit file (newlines in it) was quoted whole in the message: a path is
/// shown with its control characters as `?` and cut in the middle beyond 320 characters.
#[test]
fn a_long_csv_name_is_shown_cut_in_the_message() {
    let dir = tempfile::tempdir().unwrap();
    let fit = dir.path().join("fit.toml");
    std::fs::write(
        &fit,
        format!(
            "estimate = [\"EX0C\", \"EY0C\"]\n[[rtest]]\naxis = \"C\"\nsphere_mm = [100.0, 200.0, 250.0]\nfrom_deg = 0.0\nto_deg = 30.0\nstep_deg = 10.0\ncsv = \"\"\"a\n{}\nb\"\"\"\n",
            "0,".repeat(2000)
        ),
    )
    .unwrap();
    let out = crate::cli::volmap()
        .args(["fit", "--machine", "5axis-hwang2014", "--measurements"])
        .arg(&fit)
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    let message = String::from_utf8(out).unwrap();
    assert!(message.len() < 1200, "{} bytes: {message}", message.len());
    assert!(message.contains("[[rtest]] number 1: "), "{message}");
    assert!(message.contains("a?0,0,0,"), "{message}");
    assert!(message.contains(",0,…0,0,"), "{message}");
    assert!(
        message
            .trim_end()
            .ends_with(",?b: cannot read: File name too long (os error 36)"),
        "{message}"
    );
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

/// A part file naming `/dev/zero` as its mesh held 1 GiB: reading up to a 512 MiB limit doubled
/// the buffer to 1 GiB at the last byte. Reads now stop before the limit is passed.
#[test]
fn a_file_that_never_ends_is_read_within_its_limit() {
    use crate::fuzz::harness::watch;
    use volmap::io::source::{read_bytes, SourceKind};
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
    use crate::fuzz::harness::watch;
    use volmap::part::{self, ErrorSource, PartFile};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("part.toml");
    std::fs::write(&path, regression("part-fine-floor.toml")).unwrap();
    let part = PartFile::read(&path).unwrap();
    let machine = machine();
    // On this thread alone, where the heap is counted.
    let (result, usage) = crate::fuzz::harness::campaign::single_threaded(|| {
        watch::begin();
        let result = part::evaluate(&part, ErrorSource::Exact(&machine), "part.toml").unwrap();
        (result, watch::end())
    });
    assert!(usage.peak_bytes < 200 << 20, "{usage:?}");
    assert_eq!(result.len(), 1);
    let floor = format!("{:?}", result[0]);
    assert!(floor.contains("pocket floor"), "{floor}");
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

/// A part whose ply output is named by a NUL byte: the name no file can have was reported as a
/// failure of the work (exit code 1); it is the input's fault (exit code 2), and the message
/// names the feature.
#[test]
fn an_output_name_no_file_can_have_is_bad_input() {
    use volmap::error::{Classify, ErrorKind};
    use volmap::part::{self, ErrorSource, PartFile};
    let dir = tempfile::tempdir().unwrap();
    let skin = "solid plate\nfacet normal 0 0 1\nouter loop\nvertex 0 0 -5\nvertex 100 0 -5\nvertex 100 80 -5\nendloop\nendfacet\nendsolid plate\n";
    std::fs::write(dir.path().join("skin.stl"), skin).unwrap();
    let path = dir.path().join("part.toml");
    std::fs::write(
        &path,
        "name = \"profile\"\n[placement]\nzero_mm = [200.0, 150.0, 300.0]\n[cutter]\nradius_mm = 5.0\nlength_mm = 40.0\n[sampling]\nspacing_mm = 10.0\n\n[[features]]\nkind = \"profile\"\nname = \"top skin\"\nmesh = \"skin.stl\"\ntolerance_mm = 0.05\nply = \"\\u0000\"\n",
    )
    .unwrap();
    let part = PartFile::read(&path).unwrap();
    let machine = machine();
    let Err(error) = part::evaluate(&part, ErrorSource::Exact(&machine), "part.toml") else {
        panic!("refused");
    };
    let message = error.to_string();
    assert_eq!(error.kind(), ErrorKind::Input, "{message}");
    assert!(
        message.contains("top skin") && message.contains("cannot write"),
        "{message}"
    );
}

/// A part whose mesh is /dev/zero read 512 MiB of zeros before the limit refused it (up to a
/// second under load): a device's binary header says how much follows, and no more is read.
#[cfg(unix)]
#[test]
fn an_endless_device_as_a_mesh_is_read_no_further_than_its_header() {
    let error = volmap::io::mesh::Mesh::read_stl(std::path::Path::new("/dev/zero"))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        error.starts_with("/dev/zero")
            && error.ends_with("the header announces 0 triangles (84 bytes) but more follow"),
        "{error}"
    );
}
