//! `map --check` failing: a correct engine never fails the spot check, so the tests corrupt one
//! grid point between the engine and the check (`VOLMAP_TEST_CORRUPT_OUTPUT=N`, point N moved by
//! 2 µm in VE's x, 2,000 times the tolerance) and expect exit code 4 with the point and its difference named; the library's
//! check is given values doctored by hand.

use std::path::Path;

use volmap::engine::map::{self, check_against_reference, CORRUPTION_MM};
use volmap::engine::Engine;
use volmap::io::embedded;
use volmap::io::field::FieldFile;
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;
use volmap::report::numbers;

use super::volmap;

/// Point 37 of a 5x4x3 grid: i = 37 mod 5, j = (37 div 5) mod 4, k = 37 div 20.
const POINT: u64 = 37;
const INDICES: [usize; 3] = [2, 3, 1];

/// `map` with the corrupted point and `extra`: exit code 4, its stdout and stderr.
fn corrupted_map(out: &Path, extra: &[&str]) -> (String, String) {
    let output = volmap()
        .args(["map", "--grid", "5x4x3", "--device", "cpu", "--check", "60"])
        .args(extra)
        .arg("--out")
        .arg(out)
        .env("VOLMAP_TEST_CORRUPT_OUTPUT", POINT.to_string())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(4), "{stdout}\n{stderr}");
    (stdout, stderr)
}

/// ` X=… Y=… Z=… mm` of `INDICES` in part `part` of the field at `path`, as the commands print it.
fn position(path: &Path, part: usize) -> String {
    let command = FieldFile::open(path)
        .unwrap()
        .info(part)
        .grid()
        .command(INDICES);
    format!(
        "X={} Y={} Z={} mm",
        numbers::length(command[0]),
        numbers::length(command[1]),
        numbers::length(command[2])
    )
}

#[test]
fn a_corrupted_point_fails_the_check_with_exit_code_4_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.exr");
    let (stdout, stderr) = corrupted_map(&out, &["--machine", "vmc-li2015"]);
    assert!(
        stdout.contains("check       60 points") && stdout.contains("FAILED"),
        "{stdout}"
    );
    // 2 µm (2,000 times the tolerance) added to an f32 of under 1 mm: the difference is 2 µm to
    // 1e-4 µm, within the 4 digits printed.
    assert_eq!(CORRUPTION_MM, 2e-3);
    let named = format!(
        "the spot check failed at point (2, 3, 1), {}: ΔVE 2.000 µm,",
        position(&out, 0)
    );
    assert!(stderr.contains(&named), "`{named}` not in: {stderr}");
}

#[test]
fn a_corrupted_point_of_a_sweep_names_its_pose() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep.exr");
    let (stdout, stderr) = corrupted_map(
        &out,
        &[
            "--machine",
            "5axis-hwang2014",
            "--poses",
            "B=-45:45:90,C=30",
        ],
    );
    // Both poses checked whole, each with its corrupted point.
    assert!(
        stdout.contains("check       120 points") && stdout.contains("FAILED"),
        "{stdout}"
    );
    // Both poses fail by the same 2 µm; the check names the first it met of the largest excess.
    let named: Vec<String> = (0..2)
        .map(|part| {
            let pose = ["B=-45,C=30", "B=45,C=30"][part];
            format!(
                "the spot check failed at point (2, 3, 1) of pose {pose}, {}: ΔVE 2.000 µm,",
                position(&out, part)
            )
        })
        .collect();
    assert!(
        named.iter().any(|n| stderr.contains(n)),
        "none of {named:?} in: {stderr}"
    );
}

#[test]
fn the_check_fails_on_doctored_values_naming_the_worst_point() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let grid = Grid::full_travel(&machine, [5, 4, 3], [0.0; 6]).unwrap();
    let points: Vec<u64> = (0..grid.points()).collect();
    let nx = grid.dims[0];
    let mut values: Vec<[f32; 6]> = Vec::new();
    Engine::Cpu
        .run(
            &machine,
            &grid,
            None,
            |first, lines, data| -> Result<(), volmap::engine::EngineError> {
                for local in 0..lines as usize * nx {
                    let (line, i) = (local / nx, local % nx);
                    let base = line * CHANNELS.len() * nx + i;
                    values.push(std::array::from_fn(|c| data[base + c * nx]));
                }
                assert_eq!(values.len() as u64, (first + lines) * nx as u64);
                Ok(())
            },
        )
        .unwrap();
    assert_eq!(values.len(), points.len());
    let clean = check_against_reference(&machine, &grid, &points, &values);
    assert!(clean.passed(), "{clean:?}");
    assert_eq!(clean.points, 60);

    // An orientation error off by twice its tolerance at one point, VE off by half its
    // tolerance at another: the check fails on the first and names it.
    let mut doctored = values.clone();
    doctored[POINT as usize][2] += 2.0 * map::OE_TOLERANCE_RAD as f32;
    doctored[5][4] += 0.5 * map::VE_TOLERANCE_MM as f32;
    let result = check_against_reference(&machine, &grid, &points, &doctored);
    assert!(!result.passed(), "{result:?}");
    let worst = result.worst.as_ref().expect("a worst point");
    assert_eq!((worst.point, worst.indices), (POINT, INDICES));
    let command = grid.command(INDICES);
    assert_eq!(worst.at_mm, [command[0], command[1], command[2]]);
    // f32 steps near OE's values (under 1e-4 rad) are below 1e-11 rad.
    assert!(
        (worst.oe_diff_rad - 2.0 * map::OE_TOLERANCE_RAD).abs() < 0.05 * map::OE_TOLERANCE_RAD,
        "{worst:?}"
    );
    assert!(result.max_ve_diff_mm < map::VE_TOLERANCE_MM, "{result:?}");
    assert!(worst.excess() > 1.0, "{worst:?}");
}

#[test]
#[should_panic(expected = "a value per checked point")]
fn the_check_refuses_fewer_values_than_points() {
    let machine = embedded::load("vmc-li2015").unwrap();
    let grid = Grid::full_travel(&machine, [2, 2, 2], [0.0; 6]).unwrap();
    check_against_reference(&machine, &grid, &[0, 1], &[[0.0; 6]]);
}
