//! Compressed and HALF fields (`--compression none|zip|pxr24`, `--half`): written by the
//! pipeline in many chunks, read back by volmap, by the `exr` crate, by OpenEXR's exrheader,
//! Python's OpenEXR and OpenImageIO's oiiotool, each value within the precision docs/field-file.md
//! states: exact for none and zip, within 2^-16 of itself for PXR24, within 2^-11 of itself (or
//! 2^-25 below HALF's normal range) for HALF.

use exr::prelude::{read_first_flat_layer_from_file, FlatSamples};
use volmap::engine::map::{self, MapOptions};
use volmap::engine::Engine;
use volmap::io::embedded;
use volmap::io::field::{Compression, FieldReader, Storage};
use volmap::model::channels::CHANNELS;
use volmap::model::grid::Grid;
use volmap::model::poses::parse_pose;

use super::field::{engine_values, tool_available};

/// Every storage a map writes.
fn storages() -> Vec<Storage> {
    let mut all = Vec::new();
    for half in [false, true] {
        for compression in Compression::ALL {
            all.push(Storage { compression, half });
        }
    }
    all
}

/// How far a value `want` may move when it is stored as `storage` (docs/field-file.md's bounds).
fn bound(storage: Storage, want: f64) -> f64 {
    if storage.half {
        (want.abs() * 2f64.powi(-11)).max(2f64.powi(-25))
    } else if storage.compression == Compression::Pxr24 {
        want.abs() * 2f64.powi(-16)
    } else {
        0.0
    }
}

/// Whether `got` is `want` stored as `storage` keeps it.
fn within(storage: Storage, got: f32, want: f32) -> bool {
    (got as f64 - want as f64).abs() <= bound(storage, want as f64)
}

/// 35 lines (two blocks of 16 and one of 3 where blocks hold 16), mapped in chunks of 3 lines.
const DIMS: [usize; 3] = [9, 7, 5];

fn mapped(
    dir: &std::path::Path,
    storage: Storage,
) -> (volmap::model::Machine, Grid, std::path::PathBuf) {
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let pose = parse_pose("B=12.5,C=200", &machine).unwrap();
    let grid = Grid::full_travel(&machine, DIMS, pose).unwrap();
    let path = dir.join(format!(
        "field-{}{}.exr",
        storage.compression.name(),
        if storage.half { "-half" } else { "" }
    ));
    let options = MapOptions {
        chunk_points: Some(DIMS[0] as u64 * 3),
        storage,
        ..Default::default()
    };
    let summary = map::map_to_file(&machine, &grid, &Engine::Cpu, &path, &options, |_| {}).unwrap();
    assert_eq!(
        summary.times.write.bytes,
        std::fs::metadata(&path).unwrap().len()
    );
    (machine, grid, path)
}

#[test]
fn every_storage_reads_back_within_its_precision_in_volmap_and_the_exr_crate() {
    let dir = tempfile::tempdir().unwrap();
    let mut sizes = Vec::new();
    for storage in storages() {
        let (machine, grid, path) = mapped(dir.path(), storage);
        sizes.push((storage, std::fs::metadata(&path).unwrap().len()));
        let expected = engine_values(&machine, &grid);
        let mut reader = FieldReader::open(&path).unwrap();
        let mut line = vec![0.0f32; CHANNELS.len() * DIMS[0]];
        for k in 0..DIMS[2] {
            for j in 0..DIMS[1] {
                reader
                    .read_line((j + k * DIMS[1]) as u64, &mut line)
                    .unwrap();
                for i in 0..DIMS[0] {
                    for c in 0..6 {
                        let (got, want) = (line[c * DIMS[0] + i], expected([i, j, k], c));
                        assert!(
                            within(storage, got, want),
                            "{storage:?} {} at ({i}, {j}, {k}): {got} for {want}",
                            CHANNELS[c]
                        );
                    }
                }
            }
        }
        // An independent decoder: the exr crate's own reader of the whole image.
        let image = read_first_flat_layer_from_file(&path).expect("the exr crate reads it");
        for (c, channel) in image.layer_data.channel_data.list.iter().enumerate() {
            let value = |n: usize| match &channel.sample_data {
                FlatSamples::F32(v) => {
                    assert!(!storage.half, "{storage:?}: FLOAT channels");
                    v[n]
                }
                FlatSamples::F16(v) => {
                    assert!(storage.half, "{storage:?}: HALF channels");
                    v[n].to_f32()
                }
                FlatSamples::U32(_) => panic!("UINT channel"),
            };
            for k in 0..DIMS[2] {
                for j in 0..DIMS[1] {
                    for i in 0..DIMS[0] {
                        let got = value((j + k * DIMS[1]) * DIMS[0] + i);
                        assert!(within(storage, got, expected([i, j, k], c)));
                    }
                }
            }
        }
    }
    // Compression makes the file smaller, HALF halves it.
    let size = |compression, half| {
        sizes
            .iter()
            .find(|(s, _)| s.compression == compression && s.half == half)
            .unwrap()
            .1
    };
    assert!(size(Compression::Pxr24, false) < size(Compression::None, false));
    assert!(size(Compression::None, true) < size(Compression::None, false));
}

#[test]
fn a_compressed_multi_chunk_map_equals_the_uncompressed_one_within_its_precision() {
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("vmc-li2015").unwrap();
    // 400 lines: 25 blocks of 16 where blocks hold 16.
    let grid = Grid::full_travel(&machine, [33, 20, 20], [0.0; 6]).unwrap();
    let read_all = |path: &std::path::Path| {
        let mut values = Vec::new();
        FieldReader::open(path)
            .unwrap()
            .for_each_chunk(7, |_, _, data| values.extend_from_slice(data))
            .unwrap();
        values
    };
    let whole = dir.path().join("one-chunk.exr");
    let options = MapOptions::default();
    map::map_to_file(&machine, &grid, &Engine::Cpu, &whole, &options, |_| {}).unwrap();
    let uncompressed = read_all(&whole);
    let largest = uncompressed
        .iter()
        .fold(0.0f64, |m, v| m.max((*v as f64).abs()));
    for compression in [Compression::Zip, Compression::Pxr24] {
        let path = dir.path().join(format!("{}.exr", compression.name()));
        let options = MapOptions {
            chunk_points: Some(33 * 5),
            storage: Storage {
                compression,
                half: false,
            },
            ..Default::default()
        };
        map::map_to_file(&machine, &grid, &Engine::Cpu, &path, &options, |_| {}).unwrap();
        let values = read_all(&path);
        assert_eq!(values.len(), uncompressed.len());
        let mut worst = 0.0f64;
        for (got, want) in values.iter().zip(&uncompressed) {
            let storage = Storage {
                compression,
                half: false,
            };
            assert!(
                within(storage, *got, *want),
                "{compression:?}: {got} for {want}"
            );
            worst = worst.max((*got as f64 - *want as f64).abs());
        }
        match compression {
            Compression::Zip => assert_eq!(worst, 0.0),
            // docs/field-file.md's bound relative to the field's largest value, and not lossless.
            _ => assert!(worst > 0.0 && worst <= largest * 2f64.powi(-16), "{worst}"),
        }
    }
}

#[test]
fn python_openexr_reads_every_storage() {
    if !tool_available(
        std::process::Command::new("python3").args(["-c", "import OpenEXR, numpy"]),
        "the Python OpenEXR package",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/read_field.py");
    let points = [[0, 0, 0], [8, 6, 4], [4, 3, 2], [1, 5, 3]];
    for storage in storages() {
        let (machine, grid, path) = mapped(dir.path(), storage);
        let expected = engine_values(&machine, &grid);
        let output = std::process::Command::new("python3")
            .arg(&script)
            .arg(&path)
            .args(points.iter().map(|p| format!("{},{},{}", p[0], p[1], p[2])))
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{storage:?}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        assert_eq!(json["dims"], serde_json::json!(DIMS));
        let dtype = if storage.half { "float16" } else { "float32" };
        assert_eq!(json["dtype"], dtype, "{storage:?}");
        assert_eq!(
            json["compression"].as_str().unwrap(),
            match storage.compression {
                Compression::None => "NO_COMPRESSION",
                Compression::Zip => "ZIP_COMPRESSION",
                Compression::Pxr24 => "PXR24_COMPRESSION",
            }
        );
        for (n, p) in points.iter().enumerate() {
            for (c, name) in CHANNELS.iter().enumerate() {
                let got = json["values"][n][name].as_f64().unwrap() as f32;
                assert!(
                    within(storage, got, expected(*p, c)),
                    "{storage:?} {name} at {p:?}: {got}"
                );
            }
        }
    }
}

#[test]
fn exrheader_reads_every_storage() {
    if !tool_available(
        std::process::Command::new("sh").args(["-c", "command -v exrheader"]),
        "exrheader (Debian package openexr)",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for storage in storages() {
        let (_, _, path) = mapped(dir.path(), storage);
        let output = std::process::Command::new("exrheader")
            .arg(&path)
            .output()
            .unwrap();
        assert!(output.status.success(), "{storage:?}");
        let text = String::from_utf8_lossy(&output.stdout);
        let compression = match storage.compression {
            Compression::None => "compression (type compression): none",
            Compression::Zip => "compression (type compression): zip, multi-scanline blocks",
            Compression::Pxr24 => "compression (type compression): pxr24",
        };
        let channel = if storage.half {
            "VE.X, 16-bit floating-point"
        } else {
            "VE.X, 32-bit floating-point"
        };
        for expected in [compression, channel, "volmap.dims (type v3i): (9 7 5)"] {
            assert!(
                text.contains(expected),
                "{storage:?}: exrheader lacks `{expected}`:\n{text}"
            );
        }
    }
}

#[test]
fn oiiotool_reads_every_storage() {
    if !tool_available(
        std::process::Command::new("sh").args(["-c", "command -v oiiotool"]),
        "oiiotool (Debian package openimageio-tools)",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for storage in storages() {
        let (machine, grid, path) = mapped(dir.path(), storage);
        let expected = engine_values(&machine, &grid);
        let output = std::process::Command::new("oiiotool")
            .arg("--dumpdata")
            .arg(&path)
            .output()
            .unwrap();
        assert!(output.status.success(), "{storage:?}");
        let text = String::from_utf8_lossy(&output.stdout);
        let mut pixels = 0;
        // `Pixel (x, y): v0 v1 … v5`, channels in the file's order, 9 decimals.
        for line in text
            .lines()
            .filter_map(|l| l.trim().strip_prefix("Pixel ("))
        {
            let (at, values) = line.split_once("):").unwrap();
            let (x, y) = at.split_once(',').unwrap();
            let (i, row): (usize, usize) = (x.trim().parse().unwrap(), y.trim().parse().unwrap());
            let (j, k) = (row % DIMS[1], row / DIMS[1]);
            for (c, v) in values.split_whitespace().enumerate() {
                let got: f64 = v.parse().unwrap();
                let want = expected([i, j, k], c) as f64;
                // oiiotool prints 9 decimals.
                assert!(
                    (got - want).abs() <= bound(storage, want) + 5.1e-10,
                    "{storage:?} {} at ({i}, {j}, {k}): {got} for {want}",
                    CHANNELS[c]
                );
            }
            pixels += 1;
        }
        assert_eq!(pixels, DIMS.iter().product::<usize>(), "{storage:?}");
    }
}

#[test]
fn a_compressed_half_sweep_holds_every_pose_within_its_precision() {
    let dir = tempfile::tempdir().unwrap();
    let machine = embedded::load("5axis-hwang2014").unwrap();
    let grids: Vec<Grid> = volmap::model::poses::parse_sweep("B=-45:45:45,C=30", &machine)
        .unwrap()
        .into_iter()
        .map(|pose| Grid::full_travel(&machine, DIMS, pose).unwrap())
        .collect();
    for storage in storages() {
        let path = dir.path().join("sweep.exr");
        let options = MapOptions {
            chunk_points: Some(DIMS[0] as u64 * 4),
            storage,
            ..Default::default()
        };
        volmap::engine::sweep::map_sweep_to_file(
            &machine,
            &grids,
            &Engine::Cpu,
            &path,
            &options,
            |_| {},
        )
        .unwrap();
        let file = volmap::io::field::FieldFile::open(&path).unwrap();
        assert_eq!(file.parts(), 3);
        assert_eq!(file.storage(1), storage.describe());
        for (p, grid) in grids.iter().enumerate() {
            let expected = engine_values(&machine, grid);
            let mut reader = file.reader(p).unwrap();
            let mut line = vec![0.0f32; CHANNELS.len() * DIMS[0]];
            for k in 0..DIMS[2] {
                for j in 0..DIMS[1] {
                    reader
                        .read_line((j + k * DIMS[1]) as u64, &mut line)
                        .unwrap();
                    for i in 0..DIMS[0] {
                        for c in 0..6 {
                            let (got, want) = (line[c * DIMS[0] + i], expected([i, j, k], c));
                            assert!(within(storage, got, want), "{storage:?} part {p}");
                        }
                    }
                }
            }
        }
        // The exr crate reads every part.
        let image = exr::prelude::read_all_flat_layers_from_file(&path).expect("exr reads it");
        assert_eq!(image.layer_data.len(), 3, "{storage:?}");
    }
    // The last one written, PXR24 with HALF channels, as Python's OpenEXR reads its parts.
    if tool_available(
        std::process::Command::new("python3").args(["-c", "import OpenEXR, numpy"]),
        "the Python OpenEXR package",
    ) {
        let script =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/read_parts.py");
        let output = std::process::Command::new("python3")
            .arg(script)
            .arg(dir.path().join("sweep.exr"))
            .args(["B=45,C=30", "8,6,4"])
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        assert_eq!(
            json["parts"],
            serde_json::json!(["B=-45,C=30", "B=0,C=30", "B=45,C=30"])
        );
        assert_eq!(json["dtype"], "float16");
        let expected = engine_values(&machine, &grids[2]);
        let half = Storage {
            compression: Compression::Pxr24,
            half: true,
        };
        for (c, name) in CHANNELS.iter().enumerate() {
            let got = json["values"][0][name].as_f64().unwrap() as f32;
            assert!(within(half, got, expected([8, 6, 4], c)), "{name}: {got}");
        }
    }
}
