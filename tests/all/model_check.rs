//! volmap's f64 reference against an independent implementation of docs/model.md in Python
//! (`tests/python/model.py`, written from the specification alone), through the command line
//! (`sample --exact`): the embedded machines and machine files exercising every form of the
//! model, under approach directions, temperatures and poses, with their errors as given and a
//! hundred times larger (where composition order and small-angle terms show), and the machine
//! file's rules (what must be refused, what must be accepted) probed on both sides.

use super::field::tool_available;

#[test]
fn the_reference_agrees_with_an_independent_model() {
    if !tool_available(
        std::process::Command::new("python3").args(["-c", "import numpy, tomllib"]),
        "Python 3.11 with numpy",
    ) {
        return;
    }
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/compare_model.py");
    let output = std::process::Command::new("python3")
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_volmap"))
        .args(["--points", "40"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    // Rows: machine, inputs, points, largest |ΔVE| mm, largest |ΔOE| rad, |VE|, |OE|, same text.
    let mut rows = 0;
    for line in text.lines() {
        let tokens: Vec<&str> = line.split_whitespace().collect();
        let Some(&[points, ve, oe, _, _, _]) = tokens.len().checked_sub(6).map(|n| &tokens[n..])
        else {
            continue;
        };
        let (Ok(_), Ok(ve), Ok(oe)) = (
            points.parse::<usize>(),
            ve.parse::<f64>(),
            oe.parse::<f64>(),
        ) else {
            continue;
        };
        // Two f64 implementations of one model agree to rounding.
        assert!(ve <= 1e-9 && oe <= 1e-12, "{line}");
        rows += 1;
    }
    for machine in volmap::io::embedded::EMBEDDED.iter().map(|(n, _)| n) {
        assert!(
            text.lines().any(|l| l.starts_with(machine)),
            "{machine}:\n{text}"
        );
    }
    for machine in ["forms3", "trunnion", "head", "trunnion-iso"] {
        assert!(
            text.lines().any(|l| l.starts_with(machine)),
            "{machine}:\n{text}"
        );
    }
    assert!(rows >= 80, "{rows} rows:\n{text}");
    // What the specification says must be refused is refused, and what it allows is read.
    let probes: Vec<&str> = text.lines().filter(|l| l.starts_with('p')).collect();
    assert!(probes.len() >= 30, "{text}");
    for probe in probes {
        if probe.contains("[refuse]") {
            assert!(probe.contains("volmap rc=2"), "{probe}");
        }
        if probe.contains("[accept]") {
            assert!(probe.contains("volmap rc=0"), "{probe}");
        }
    }
}
