//! What volmap does not follow in a program written for tool-centre-point control (G43.4,
//! G43.5) is refused, naming the line.

use volmap::io::embedded;
use volmap::nc::{self, Options};

fn tcpm_options() -> Options {
    Options {
        decimals: Some(4),
        orientation_tolerance_rad: Some(1e-5),
        work_offsets: [(54, [100.0, 400.0, 200.0, 0.0, 0.0, 0.0])]
            .into_iter()
            .collect(),
        ..Options::default()
    }
}

/// What volmap does not follow under tool-centre-point control is refused naming the line
/// (README: cancel with G49 first); the same block after G49 is read.
#[test]
fn what_tcpm_does_not_follow_is_refused_naming_the_line() {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let options = tcpm_options();
    let start = "G90 G54\nG0 B30. C45.\nG43.4\nG0 X0. Y0. Z50.\n";
    for (block, says) in [
        ("G53 G0 Z0.", "G53, a move to a machine position, under"),
        ("G28 Z0.", "G28, a move to a machine position, under"),
        ("G81 Z-5. R2. F100.", "G81, a canned cycle, under"),
        ("G68 X0 Y0 R30.", "G68, a coordinate rotation, under"),
        ("T2 M6", "a tool change (M6) under"),
        ("G55", "G55, a change of work offset, under"),
    ] {
        let program = format!("{start}{block}\n");
        let error = nc::compensate(&machine, program.as_bytes(), "r.nc", &options)
            .unwrap_err()
            .to_string();
        assert!(
            error.starts_with("r.nc: line 5: ") && error.contains(says),
            "{block}: {error}"
        );
    }
    // G43.5 gives the orientation by the vector: a rotary word, an incomplete vector, one no pose
    // reaches within the travels (B ±110°: the tool cannot point down), refused.
    let start = "G90 G54\nG0 B30. C45.\nG43.5\nG0 X0. Y0. Z50. I0.5 J0 K0.8660254038\n";
    for (block, says) in [
        ("G1 X5. B20. F100.", "B20., a rotary word"),
        ("G1 X5. I0.5 J0 F100.", "needs all of I J K"),
        ("G1 X5. I0 J0 K-1 F100.", "outside their travels"),
    ] {
        let program = format!("{start}{block}\n");
        let error = nc::compensate(&machine, program.as_bytes(), "v.nc", &options)
            .unwrap_err()
            .to_string();
        assert!(
            error.starts_with("v.nc: line 5: ") && error.contains(says),
            "{block}: {error}"
        );
    }
    // A G49 before the tip was given: where the axes stand is not known.
    let error = nc::compensate(
        &machine,
        b"G90 G54\nG0 B30. C45.\nG43.4\nG49\nG0 X0. Y0. Z50.\n",
        "c.nc",
        &options,
    )
    .unwrap_err()
    .to_string();
    assert!(error.starts_with("c.nc: line 4: "), "{error}");
    // A G43.5 program that never says where the rotary axes stand: the control solves the vector
    // nearest where they are, which volmap cannot know.
    let plain = Options {
        orientation_tolerance_rad: None,
        ..options.clone()
    };
    let error = nc::compensate(
        &machine,
        b"G90 G54\nG43.5\nG0 X0. Y0. Z50. I0.5 J0 K0.8660254038\n",
        "n.nc",
        &plain,
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.starts_with("n.nc: line 3: ") && error.contains("is not known here"),
        "{error}"
    );
    // After G49 a tool change is an ordinary block again.
    let program = "G90 G54\nG0 B30. C45.\nG43.4\nG0 X0. Y0. Z50.\nG49\nT2 M6\nG0 X10.\n";
    nc::compensate(&machine, program.as_bytes(), "ok.nc", &options).unwrap();
}
