//! What a sweep of the command line with bad values found (README "Inputs, outputs and their
//! limits"), each now refused with exit code 2 naming the flag or key, or done right.

use super::{refused, volmap};

/// Counts and values that made an abort, an endless loop or output that is not a number.
#[test]
fn unbounded_values_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 5000³ points of residual grid: an allocation of 3 TB and an abort.
    refused(
        &[
            "export",
            "--machine",
            "vmc-li2015",
            "--format",
            "grid-csv",
            "--out",
            "e.csv",
            "--points",
            "3",
            "--residual-grid",
            "5000",
        ],
        d,
        &["--residual-grid", "at most 201"],
    );
    assert!(!d.join("e.csv").exists());
    // A pitch whose phase overflows: an endless cyclic-error fit.
    refused(
        &[
            "test",
            "circular",
            "--plane",
            "XY",
            "--machine",
            "vmc-li2015",
            "--points",
            "16",
            "--pitch",
            "1e-308",
        ],
        d,
        &["pitch", "between 0.001 and 1e6 mm"],
    );
    // No reference points: NaN and inf in the benchmark's table.
    refused(
        &["bench", "--reference-points", "0"],
        d,
        &["--reference-points"],
    );
    // An infinite chord tolerance, printed as `inf mm`.
    std::fs::write(d.join("p.nc"), "G90 G0 X0 Y0 Z10\nG1 X50 F500\nM30\n").unwrap();
    for value in ["inf", "1e400", "1e7"] {
        refused(
            &[
                "compensate",
                "--machine",
                "vmc-li2015",
                "--program",
                "p.nc",
                "--out",
                "c.nc",
                "--work-offset",
                "G54=100,100,100",
                "--chord-tolerance",
                value,
            ],
            d,
            &["--chord-tolerance", "at most 1000000 mm"],
        );
    }
    // A thousand trillion degrees: VE of 1e13 mm with exit 0.
    std::fs::write(d.join("q.csv"), "X,Y,Z\n100,100,100\n").unwrap();
    refused(
        &[
            "sample",
            "--exact",
            "--machine",
            "gantry-2m",
            "--points",
            "q.csv",
            "--temperatures",
            "hall=1e15",
        ],
        d,
        &[
            "--temperatures",
            "more than 200 K from the machine's reference_C (20 °C)",
        ],
    );
    volmap()
        .args([
            "sample",
            "--exact",
            "--machine",
            "gantry-2m",
            "--points",
            "q.csv",
            "--temperatures",
            "hall=210",
        ])
        .current_dir(d)
        .assert()
        .success();
    // A reference temperature below absolute zero, or of 309 digits.
    let machine = String::from_utf8(
        volmap()
            .args(["machines", "--show", "gantry-2m"])
            .output()
            .unwrap()
            .stdout,
    )
    .unwrap();
    assert!(
        machine.contains("reference_C = 20.0"),
        "the embedded gantry's thermal section"
    );
    for value in ["-300", "1e308"] {
        std::fs::write(
            d.join("g.toml"),
            machine.replace("reference_C = 20.0", &format!("reference_C = {value}")),
        )
        .unwrap();
        refused(
            &[
                "sample",
                "--exact",
                "--machine",
                "g.toml",
                "--points",
                "q.csv",
            ],
            d,
            &["g.toml", "thermal.reference_C", "between absolute zero"],
        );
    }
}

/// A field holding a NaN (a damaged file: volmap never writes one) was summarised and sampled
/// as NaN with exit 0.
#[test]
fn a_field_holding_a_value_that_is_not_a_number_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    volmap()
        .args([
            "map",
            "--machine",
            "vmc-li2015",
            "--device",
            "cpu",
            "--grid",
            "3x3x3",
            "--compression",
            "none",
            "--out",
            "f.exr",
        ])
        .current_dir(d)
        .assert()
        .success();
    let mut bytes = std::fs::read(d.join("f.exr")).unwrap();
    let n = bytes.len();
    bytes[n - 4..].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(d.join("c.exr"), bytes).unwrap();
    std::fs::write(d.join("q.csv"), "X,Y,Z\n1000,600,500\n").unwrap();
    let says = ["c.exr", "VE.Z of grid point (2, 2, 2) is NaN"];
    refused(&["info", "c.exr"], d, &says);
    refused(
        &[
            "sample", "--field", "c.exr", "--points", "q.csv", "--device", "cpu",
        ],
        d,
        &says,
    );
}

/// A machine without a Y axis: the points file holds X, Y and Z, and Y is 0 on it.
#[test]
fn a_machine_without_a_linear_axis_is_sampled_at_its_zero() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("xz.toml"),
        "name = \"two axes\"\nchain = \"FXFZ\"\n[axes.X]\nrange = [0.0, 100.0]\nEXX = { poly = [0.0, 2.4e-4] }\n[axes.Z]\nrange = [0.0, 100.0]\nEZZ = 1e-7\n",
    )
    .unwrap();
    std::fs::write(d.join("q.csv"), "X,Y,Z\n50,0,20\n").unwrap();
    let output = volmap()
        .args([
            "sample",
            "--exact",
            "--machine",
            "xz.toml",
            "--points",
            "q.csv",
        ])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).unwrap();
    let row: Vec<f64> = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // EXX = 2.4e-4·x at x = 50 and EZZ = 1e-7: VE = (0.012, 0, 1e-7).
    assert!(
        (row[3] - 0.012).abs() < 1e-12 && row[4] == 0.0 && (row[5] - 1e-7).abs() < 1e-12,
        "{text}"
    );
    std::fs::write(d.join("q.csv"), "X,Y,Z\n50,5,20\n").unwrap();
    refused(
        &[
            "sample",
            "--exact",
            "--machine",
            "xz.toml",
            "--points",
            "q.csv",
        ],
        d,
        &["q.csv: line 2: Y=5 lies outside the machine's travel (0 to 0)"],
    );
}

/// `--out /dev/null` as root renamed a file over the device; it is written directly now.
#[cfg(unix)]
#[test]
fn an_output_that_is_a_device_stays_a_device() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("q.csv"), "X,Y,Z\n100,100,100\n").unwrap();
    volmap()
        .args([
            "sample",
            "--exact",
            "--machine",
            "vmc-li2015",
            "--points",
            "q.csv",
            "--out",
            "/dev/null",
        ])
        .current_dir(dir.path())
        .assert()
        .success();
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());
}

/// Tool lengths of 1e12 mm gave deviations of 2e7 mm; two bare lengths, a bare one beside
/// per-tool ones, an empty item or a tool twice were taken silently.
#[test]
fn tool_lengths_are_bounded_and_unambiguous() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G90 G0 X0 Y0 Z10\nG1 X50 F500\nM30\n").unwrap();
    let trace = |lengths: &str| -> Vec<String> {
        [
            "trace",
            "--machine",
            "vmc-li2015",
            "--program",
            "p.nc",
            "--work-offset",
            "G54=100,100,100",
            "--tool-length",
            lengths,
        ]
        .map(String::from)
        .to_vec()
    };
    for (lengths, says) in [
        ("1e12", "is not a length of at most 1000000 mm"),
        ("1,500", "one length for every tool stands alone"),
        ("500,T1=1", "one length for every tool stands alone"),
        (",500", "an empty item"),
        ("T1=5,T1=6", "T1 is given twice"),
    ] {
        let args = trace(lengths);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&args, d, &["--tool-length", says]);
    }
    let args = trace("120");
    volmap().args(&args).current_dir(d).assert().success();
}

/// One work offset given twice, or two outputs of one run on one file, were taken silently (the
/// last won).
#[test]
fn a_work_offset_twice_and_two_outputs_on_one_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G90 G0 X0 Y0 Z10\nG1 X50 F500\nM30\n").unwrap();
    let base = [
        "compensate",
        "--machine",
        "vmc-li2015",
        "--program",
        "p.nc",
        "--out",
        "c.nc",
    ];
    let with =
        |more: &[&'static str]| -> Vec<&'static str> { base.iter().chain(more).copied().collect() };
    refused(
        &with(&[
            "--work-offset",
            "G54=100,100,100",
            "--work-offset",
            "G54=0,0,0",
        ]),
        d,
        &["--work-offset: G54 is given twice"],
    );
    std::fs::write(d.join("o.toml"), "G54 = [100.0, 100.0, 100.0]\n").unwrap();
    refused(
        &with(&["--work-offset-file", "o.toml", "--work-offset", "G54=0,0,0"]),
        d,
        &["G54 is given twice (here or in --work-offset-file)"],
    );
    refused(
        &with(&["--work-offset", "G54=100,100,100", "--json", "c.nc"]),
        d,
        &["--json", "is also the output of --out"],
    );
    assert!(!d.join("c.nc").exists());
    volmap()
        .args(with(&[
            "--work-offset",
            "G54=100,100,100",
            "--json",
            "c.json",
        ]))
        .current_dir(d)
        .assert()
        .success();
}

/// A machine's name with terminal escapes or a NUL was printed whole in every summary.
#[test]
fn a_machine_name_with_control_characters_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("q.csv"), "X,Y,Z\n1,1,1\n").unwrap();
    let machine = "chain = \"FFXYZ\"\n[axes.X]\nrange = [0.0, 10.0]\n[axes.Y]\nrange = [0.0, 10.0]\n[axes.Z]\nrange = [0.0, 10.0]\n";
    for name in ["\\u001b[31mred", "a\\u0000b", &"n".repeat(201)] {
        std::fs::write(d.join("m.toml"), format!("name = \"{name}\"\n{machine}")).unwrap();
        refused(
            &[
                "sample",
                "--exact",
                "--machine",
                "m.toml",
                "--points",
                "q.csv",
            ],
            d,
            &["m.toml", "name", "without control characters"],
        );
    }
    std::fs::write(d.join("m.toml"), format!("name = \"plain\"\n{machine}")).unwrap();
    volmap()
        .args([
            "sample",
            "--exact",
            "--machine",
            "m.toml",
            "--points",
            "q.csv",
        ])
        .current_dir(d)
        .assert()
        .success();
}

/// `trace` evaluated moves beyond the travels with exit 0, where `compensate` and `sample`
/// refuse them.
#[test]
fn trace_refuses_a_move_beyond_the_travel() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.nc"), "G90 G0 X0 Y0 Z10\nG1 X5000 F500\nM30\n").unwrap();
    refused(
        &[
            "trace",
            "--machine",
            "vmc-li2015",
            "--program",
            "p.nc",
            "--work-offset",
            "G54=100,100,100",
        ],
        d,
        &[
            "p.nc: line 2: the move reaches X=",
            "outside the travel of X",
        ],
    );
}
