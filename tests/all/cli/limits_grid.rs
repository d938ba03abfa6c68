//! The limits of a map's grid and of a sweep's parts (docs/inputs-and-limits.md): every grid
//! inside the `--grid` limit maps on the CPU and on the GPU in bounded memory, a grid beyond it
//! is refused with exit 2 naming `--grid` before anything is written, and a sweep's headers take
//! memory independent of its number of poses.
//!
//! The memory bounds are checked by running volmap in a bounded address space (`ulimit -v`): an
//! allocation proportional to an axis's points or to the poses fails there (and aborts), where
//! the bounded one fits.

use std::path::Path;

use predicates::prelude::*;

use super::{s, temporaries, volmap, volmap_under};

/// The most points along one axis (`MAX_AXIS_POINTS`, 2^18).
const AXIS_LIMIT: usize = 1 << 18;

/// The devices to map on: the CPU, and the GPU where an adapter exists (lavapipe in CI).
fn devices() -> Vec<&'static str> {
    match super::super::common::gpu() {
        Some(_) => vec!["cpu", "gpu"],
        None => vec!["cpu"],
    }
}

/// The grid with `n` points along dimension `d` and 1 along the others.
fn thin(d: usize, n: usize) -> String {
    let mut dims = [1usize; 3];
    dims[d] = n;
    format!("{}x{}x{}", dims[0], dims[1], dims[2])
}

#[test]
fn a_grid_beyond_the_axis_limit_is_refused_with_exit_2_naming_grid_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.exr");
    // One more than the limit along each axis, and far beyond it (2^31 - 1 along Y is inside
    // the old lines limit, 16 GiB of offset table), on both engines, in map and in budget.
    for d in 0..3 {
        for n in [AXIS_LIMIT + 1, i32::MAX as usize] {
            let grid = thin(d, n);
            let letter = ["X", "Y", "Z"][d];
            for device in devices() {
                volmap()
                    .args(["map", "--device", device, "--grid", &grid, "--out", s(&out)])
                    .assert()
                    .code(2)
                    .stderr(
                        predicate::str::contains("--grid")
                            .and(predicate::str::contains(format!("points along {letter}")))
                            .and(predicate::str::contains("262144")),
                    );
                volmap()
                    .args(["budget", "--device", device, "--grid", &grid])
                    .args(["--samples", "2", "--machine", "vmc-li2015", "--tolerances"])
                    .arg(tolerances())
                    .current_dir(dir.path())
                    .assert()
                    .code(2)
                    .stderr(
                        predicate::str::contains("--grid").and(predicate::str::contains("262144")),
                    );
            }
        }
    }
    // Lines beyond 2^31 - 1 with each axis inside its limit: 2^16 · 2^16 = 2^32 lines.
    volmap()
        .args(["map", "--grid", "1x65536x65536", "--out", s(&out)])
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("--grid").and(predicate::str::contains("4294967296 lines")),
        );
    assert!(!out.exists());
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn long_thin_grids_at_the_axis_limit_map_on_every_engine_in_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    // 2^18 points along one axis of the grid, 1 along the others: each engine's tables of that
    // axis (at most 96 bytes an entry on the GPU, 256 on the CPU: 24 MiB and 64 MiB) and one
    // chunk. The old CPU engine's allocation per value of an axis at 2^31 - 1 (512 GiB) would not
    // fit in 3 GB; the GPU adapter's own mappings (lavapipe) take some of it.
    for device in devices() {
        for d in 0..3 {
            let grid = thin(d, AXIS_LIMIT);
            let out = dir.path().join(format!("{device}-{d}.exr"));
            let json = dir.path().join(format!("{device}-{d}.json"));
            volmap_under("-v 3000000")
                .args(["map", "--device", device, "--grid", &grid])
                .args(["--compression", "zip", "--check", "3", "--json"])
                .arg(&json)
                .arg("--out")
                .arg(&out)
                .assert()
                .success();
            let result = super::json_result(&json);
            // Every point mapped: 2^18 of them.
            assert_eq!(
                result["stats"]["points"], AXIS_LIMIT as u64,
                "{device} {grid}"
            );
            assert_eq!(result["check"]["passed"], true, "{device} {grid}");
            std::fs::remove_file(&out).unwrap();
            // A budget over the same grid (the was refused by a raw validation error
            // of the GPU's): two machines drawn and the budget reported. Along X only, which
            // each budget reads per point; Y and Z take the same tables as the map's above.
            if d != 0 {
                continue;
            }
            volmap_under("-v 3000000")
                .args(["budget", "--device", device, "--grid", &grid])
                .args(["--samples", "2", "--machine", "vmc-li2015", "--tolerances"])
                .arg(tolerances())
                .current_dir(dir.path())
                .assert()
                .success()
                .stdout(predicate::str::contains("Error budget of"));
        }
    }
}

/// The example tolerance file of `vmc-li2015`.
fn tolerances() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/tolerances/vmc-li2015.toml")
}

/// `4axis-hwang2014` (a C axis) with its `EYY` read from a CSV table of `rows` rows over Y's
/// travel (0 to 240 mm), written into `dir`.
fn machine_with_a_large_table(dir: &Path, rows: usize) -> std::path::PathBuf {
    let output = volmap()
        .args(["machines", "--show", "4axis-hwang2014"])
        .output()
        .unwrap();
    let text = String::from_utf8(output.stdout).unwrap();
    let line = text.lines().find(|l| l.starts_with("EYY = ")).unwrap();
    let text = text.replace(line, "EYY = { csv = \"eyy.csv\", interp = \"linear\" }");
    let mut csv = String::from("position_mm,EYY\n");
    for r in 0..rows {
        let y = 240.0 * r as f64 / (rows - 1) as f64;
        csv.push_str(&format!("{y:.6},{:.7}\n", 1e-5 * (y / 10.0).sin()));
    }
    std::fs::write(dir.join("eyy.csv"), csv).unwrap();
    let path = dir.join("m.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_sweep_of_many_poses_writes_its_headers_in_memory_independent_of_the_poses() {
    let dir = tempfile::tempdir().unwrap();
    // A table of 40,000 rows: about 0.9 MB of CSV text in every part's header.
    let machine = machine_with_a_large_table(dir.path(), 40_000);
    let csv_bytes = std::fs::metadata(dir.path().join("eyy.csv")).unwrap().len();
    assert!(csv_bytes > 800_000, "{csv_bytes}");
    // 1,200 poses of a 2x2x2 grid: the headers hold 1,200 copies of the table, about 1.1 GB,
    // which the old writer built in memory twice (the parts' headers and their bytes) before
    // writing the first; in 700 MB of address space only a bounded writer runs. Written to
    // /dev/null: the test measures memory, not the disk.
    volmap_under("-v 700000")
        .args(["map", "--device", "cpu", "--grid", "2x2x2"])
        .args(["--poses", "C=0:359.7:0.3", "--machine"])
        .arg(&machine)
        .args(["--out", "/dev/null"])
        .assert()
        .success()
        .stdout(predicate::str::contains("1200 parts"));
}

#[test]
fn a_sweep_whose_headers_exceed_the_free_space_is_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let machine = machine_with_a_large_table(dir.path(), 2_000_000);
    // 65,536 poses (the limit) of a 1x1x1 grid: the values take 1.6 MB, but each part's header
    // holds the table's CSV text, about 46 MB, 3 TB in all: more than any test machine's free
    // space, said before anything is computed or written (the check counts the headers).
    let csv_bytes = std::fs::metadata(dir.path().join("eyy.csv")).unwrap().len();
    let headers = 65_536 * csv_bytes;
    let free = volmap::io::disk::free_bytes(dir.path()).expect("the temporary folder's free space");
    assert!(
        free < headers,
        "this test needs a temporary folder with less than {headers} bytes free, not {free}"
    );
    let out = dir.path().join("f.exr");
    volmap()
        .args(["map", "--device", "cpu", "--grid", "1x1x1"])
        .args(["--poses", "C=0:359.99:0.0054932", "--machine"])
        .arg(&machine)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--out").and(predicate::str::contains("free")));
    assert!(!out.exists());
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn a_gpu_refuses_tables_larger_than_its_buffers_with_exit_2_naming_grid() {
    if super::super::common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.exr");
    // gantry-2m's cross-rail sag is a table2d of Y and Z: over a 1x4096x4096 grid its table has
    // 4096² = 16.8 million entries of 32 bytes, 537 MB, beyond the 128 MiB buffers of lavapipe
    // (and of the adapters that offer the least). Refused before the field file is begun (its
    // offset table alone, 4096² lines of 8 bytes, is 134 MB: under a 20 MB file-size limit a
    // run that began it would fail writing, exit 1), nothing left behind.
    volmap_under("-f 20000")
        .args(["map", "--machine", "gantry-2m", "--device", "gpu"])
        .args([
            "--grid",
            "1x4096x4096",
            "--compression",
            "zip",
            "--out",
            s(&out),
        ])
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("--grid")
                .and(predicate::str::contains("bytes, more than one buffer"))
                .and(predicate::str::contains("--device cpu")),
        );
    assert!(!out.exists());
    assert!(temporaries(dir.path()).is_empty());
}
