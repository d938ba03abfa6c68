//! `volmap compensate`.

use predicates::prelude::*;

use super::volmap;

#[test]
fn compensate_writes_a_new_program_and_never_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dobariya2015");
    let out = dir.path().join("compensated.nc");
    let json = dir.path().join("report.json");
    volmap()
        .args(["compensate", "--machine"])
        .arg(example.join("machine.toml"))
        .arg("--program")
        .arg(example.join("test-piece.nc"))
        .args(["--work-offset", "G54=0,0,10", "--out"])
        .arg(&out)
        .arg("--json")
        .arg(&json)
        .assert()
        .success()
        .stdout(
            predicate::str::contains("largest correction")
                .and(predicate::str::contains("blocks changed"))
                .and(predicate::str::contains("mm before")),
        );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("N60 X39.8168 F200 (SLOT ALONG X: 30 MM BETWEEN ITS CENTRES)"),
        "{text}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(report["largest_error_after_mm"].as_f64().unwrap() <= 1e-3);
    // The input is never the output.
    let program = dir.path().join("p.nc");
    std::fs::write(&program, "G0 X10 Y10 Z10\nG1 X20\n").unwrap();
    volmap()
        .args(["compensate", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&program)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("never writes over it"));
    assert_eq!(
        std::fs::read_to_string(&program).unwrap(),
        "G0 X10 Y10 Z10\nG1 X20\n"
    );
    // A bad program: the line and the reason, exit 2, nothing written.
    std::fs::write(&program, "G0 X10 Y10 Z10\nG2 X20 Y20\n").unwrap();
    let never = dir.path().join("never.nc");
    volmap()
        .args(["compensate", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&never)
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "p.nc: line 2: an arc (G2) needs its centre",
        ));
    std::fs::write(&program, [0u8, 159, 146, 150]).unwrap();
    volmap()
        .args(["compensate", "--program"])
        .arg(&program)
        .arg("--out")
        .arg(&never)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("not a text file"));
    assert!(!never.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        3,
        "no temporary files left"
    );
}
