//! `volmap machines --show` and the embedded gantry `gantry-2m`, which uses every form of the
//! machine file: mapped on the CPU at its default inputs and at others, checked against the f64
//! reference.

use predicates::prelude::*;
use volmap::io::embedded;
use volmap::model::Machine;

use super::volmap;

#[test]
fn machines_show_prints_an_embedded_machine_file() {
    let output = volmap()
        .args(["machines", "--show", "gantry-2m"])
        .output()
        .unwrap();
    assert!(output.status.success());
    let text = String::from_utf8(output.stdout).unwrap();
    assert!(text.starts_with("# A large gantry"), "{text}");
    for form in [
        "of = \"Y\"",
        "sum = [",
        "table2d",
        "reverse =",
        "per_kelvin",
        "[thermal]",
    ] {
        assert!(text.contains(form), "the gantry shows `{form}`");
    }
    let shown = Machine::from_toml(&text, "shown", None).unwrap();
    assert_eq!(shown, embedded::load("gantry-2m").unwrap());
    volmap()
        .args(["machines", "--show", "gantry-3m"])
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("--show: `gantry-3m` is not an embedded machine")
                .and(predicate::str::contains("vmc-li2015")),
        );
    volmap()
        .arg("machines")
        .assert()
        .success()
        .stdout(predicate::str::contains("gantry-2m          FFXYZ"));
}

#[test]
fn the_gantry_maps_on_the_cpu_and_passes_its_check() {
    let dir = tempfile::tempdir().unwrap();
    for inputs in [
        &[][..],
        &[
            "--temperatures",
            "x_scale=24,y_scale=23,spindle=35,hall=25",
            "--approach",
            "Y=-",
        ][..],
    ] {
        volmap()
            .args([
                "map",
                "--machine",
                "gantry-2m",
                "--device",
                "cpu",
                "--grid",
                "13x9x5",
                "--check",
                "100",
                "--out",
            ])
            .arg(dir.path().join("g.exr"))
            .args(inputs)
            .assert()
            .success()
            .stdout(
                predicate::str::contains("check       100 points")
                    .and(predicate::str::contains(": ok")),
            );
    }
}
