//! Profiles judged nominally, in datum reference frames, and after a best fit, on machines whose
//! effect is known by hand.

use std::path::Path;

use volmap::model::{AxisLetter, ErrorFunction, Machine};
use volmap::part::{evaluate, ErrorSource, Evaluation, FeatureResult, PartFile};
use AxisLetter::*;

/// Travels with room around the parts, whose cutter positions reach a radius beyond them.
fn gantry() -> Machine {
    Machine::nominal(
        "gantry",
        "FFXYZ",
        &[
            (X, [-100.0, 500.0]),
            (Y, [-100.0, 400.0]),
            (Z, [-100.0, 100.0]),
        ],
    )
    .unwrap()
}

/// An ASCII STL of the rectangle from `corner` spanning the edges `u` and `v` (two triangles),
/// its normal along `u × v`.
fn rectangle_stl(corner: [f64; 3], u: [f64; 3], v: [f64; 3]) -> String {
    let at = |a: f64, b: f64| {
        let p: Vec<String> = (0..3)
            .map(|i| (corner[i] + a * u[i] + b * v[i]).to_string())
            .collect();
        format!("vertex {}\n", p.join(" "))
    };
    let facet = |corners: [(f64, f64); 3]| {
        let mut f = String::from("facet normal 0 0 0\nouter loop\n");
        for (a, b) in corners {
            f.push_str(&at(a, b));
        }
        f + "endloop\nendfacet\n"
    };
    format!(
        "solid rectangle\n{}{}endsolid rectangle\n",
        facet([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]),
        facet([(0.0, 0.0), (1.0, 1.0), (0.0, 1.0)])
    )
}

/// The datum features: floor A (z = -20, normal +z), wall B (y = 0, normal -y) and wall C
/// (x = 0, normal -x), both 10 mm deep from the floor, hole H (axis along z at x = 200, y = 100)
/// and a second floor A2 parallel to A.
const PART: &str = r#"
name = "datum frames"
[placement]
zero_mm = [0.0, 0.0, 0.0]
[cutter]
radius_mm = 5.0
length_mm = 40.0
[sampling]
spacing_mm = 5.0

[[features]]
kind = "end_milled_plane"
name = "A"
corner_mm = [0.0, 0.0, -20.0]
size_mm = [300.0, 200.0]
tolerance_mm = 0.1

[[features]]
kind = "flank_milled_plane"
name = "B"
start_mm = [0.0, 0.0, -20.0]
direction_deg = 0.0
length_mm = 300.0
depth_mm = 10.0
tolerance_mm = 0.1

[[features]]
kind = "flank_milled_plane"
name = "C"
start_mm = [0.0, 0.0, -20.0]
direction_deg = 90.0
length_mm = 200.0
depth_mm = 10.0
normal_left = true
tolerance_mm = 0.1

[[features]]
kind = "hole"
name = "H"
centre_mm = [200.0, 100.0, -20.0]
diameter_mm = 10.0
depth_mm = 20.0
tolerance_mm = 0.1

[[features]]
kind = "end_milled_plane"
name = "A2"
corner_mm = [0.0, 0.0, -30.0]
size_mm = [100.0, 100.0]
tolerance_mm = 0.1
"#;

/// A profile feature of `mesh` with the extra keys `keys`.
fn profile(name: &str, mesh: &str, keys: &str) -> String {
    format!(
        "\n[[features]]\nkind = \"profile\"\nname = \"{name}\"\nmesh = \"{mesh}\"\ntolerance_mm = 0.05\n{keys}\n"
    )
}

/// Writes the meshes (the skin: the square z = 0 over x, y in [0, 100], normal +z; the side:
/// the rectangle x = 300 over y in [0, 100], z in [-50, 0], normal +x) and the part with
/// `profiles`, and reads it.
fn part_with(dir: &Path, profiles: &str) -> PartFile {
    let skin = rectangle_stl([0.0; 3], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0]);
    std::fs::write(dir.join("skin.stl"), skin).unwrap();
    let side = rectangle_stl([300.0, 0.0, -50.0], [0.0, 100.0, 0.0], [0.0, 0.0, 50.0]);
    std::fs::write(dir.join("side.stl"), side).unwrap();
    let path = dir.join("part.toml");
    std::fs::write(&path, format!("{PART}{profiles}")).unwrap();
    PartFile::read(&path).unwrap()
}

fn row<'a>(rows: &'a [FeatureResult], name: &str) -> &'a FeatureResult {
    rows.iter().find(|r| r.name == name).unwrap()
}

#[test]
fn a_uniform_offset_is_all_error_nominally_and_none_in_a_datum_frame_or_after_a_best_fit() {
    let dir = tempfile::tempdir().unwrap();
    let p = part_with(
        dir.path(),
        &[
            profile("skin nominal", "skin.stl", ""),
            profile("skin ABC", "skin.stl", "datums = [\"A\", \"B\", \"C\"]"),
            profile("skin HAC", "skin.stl", "datums = [\"H\", \"A\", \"C\"]"),
            profile("skin fit", "skin.stl", "evaluation = \"best_fit\""),
            profile("side nominal", "side.stl", "evaluation = \"nominal\""),
            profile("side ABC", "side.stl", "datums = [\"A\", \"B\", \"C\"]"),
            profile("side fit", "side.stl", "evaluation = \"best_fit\""),
        ]
        .concat(),
    );
    // The whole machine off by (0.02, -0.01, 0.03) mm: every surface, the datums' too, moves
    // by it.
    let mut m = gantry();
    m.axis_mut(X).unwrap().components[0] = Some(ErrorFunction::Constant(0.02));
    m.axis_mut(Y).unwrap().components[1] = Some(ErrorFunction::Constant(-0.01));
    m.axis_mut(Z).unwrap().components[2] = Some(ErrorFunction::Constant(0.03));
    let rows = evaluate(&p, ErrorSource::Exact(&m), "part.toml").unwrap();
    // Nominally the skin stands 0.03 mm off: twice that, and all of it outside ±0.025.
    let nominal = row(&rows, "skin nominal");
    assert!(
        (nominal.error_mm - 0.06).abs() < 1e-12,
        "{}",
        nominal.error_mm
    );
    assert_eq!(nominal.area_outside, Some(1.0));
    assert_eq!(nominal.evaluation, Evaluation::Nominal);
    assert!(nominal.datums.is_empty());
    let side = row(&rows, "side nominal");
    assert!((side.error_mm - 0.04).abs() < 1e-12, "{}", side.error_mm);
    // In the datum frames and after the best fit, nothing is left.
    for name in ["skin ABC", "skin HAC", "skin fit", "side ABC", "side fit"] {
        let r = row(&rows, name);
        assert!(r.error_mm < 1e-9, "{name}: {}", r.error_mm);
        assert_eq!(r.area_outside, Some(0.0), "{name}");
    }
    assert_eq!(row(&rows, "skin HAC").evaluation, Evaluation::Datums);
    assert_eq!(row(&rows, "skin HAC").datums, ["H", "A", "C"]);
    assert_eq!(row(&rows, "skin fit").evaluation, Evaluation::BestFit);
}

#[test]
fn a_squareness_shows_against_the_datums_and_a_best_fit_removes_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = part_with(
        dir.path(),
        &[
            profile("nominal", "side.stl", ""),
            profile(
                "ABC",
                "side.stl",
                "datums = [\"A\", \"B\", \"C\"]\nply = \"abc.ply\"",
            ),
            profile("A only", "side.stl", "datums = [\"A\"]"),
            profile("fit", "side.stl", "evaluation = \"best_fit\""),
        ]
        .concat(),
    );
    // Z out of square to X: VE_x = k·z. The floor A and the wall B keep their places; the wall
    // C, cut with the cutter's tip at z = -20, stands -20k off along x, and the side (at
    // z from -50 to 0) leans: its deviation along +x is k·z.
    let k = 1e-4;
    let mut m = gantry();
    m.axis_mut(Z).unwrap().components[0] = Some(ErrorFunction::Poly(vec![0.0, k]));
    let rows = evaluate(&p, ErrorSource::Exact(&m), "part.toml").unwrap();
    // The samples are sub-triangle centroids: the one nearest the edge z = -50 lies a third
    // of a sub-triangle's height (50/23/3 mm) inside it.
    let inside = 50.0 / 23.0 / 3.0;
    let within = |name: &str, largest: f64| {
        let e = row(&rows, name).error_mm;
        let expected = 2.0 * k * (largest - inside);
        assert!((e - expected).abs() < 1e-9, "{name}: {e} vs {expected}");
    };
    // Nominally: the largest |k·z|, at z = -50.
    within("nominal", 50.0);
    // In the frame of A, B, C: the frame moves by +20k along x with C, leaving k·(z + 20),
    // from -30k to 20k.
    within("ABC", 30.0);
    // Against A alone, the side floats along x (A leaves x free) to the least-squares
    // position, the middle z = -25, but cannot turn about y (A holds that): k·(z + 25).
    // (The float is a least-squares fit over the samples, whose centroids weigh y·z not quite
    // as the area does: it turns the side by a few parts in 10⁴ of k about z.)
    let a_only = row(&rows, "A only").error_mm;
    let expected = 2.0 * k * (25.0 - inside);
    assert!(
        (a_only - expected).abs() < 1e-3 * expected,
        "{a_only} vs {expected}"
    );
    // The lean is a rotation about y: the best fit leaves nothing.
    let fit = row(&rows, "fit").error_mm;
    assert!(fit < 1e-9, "{fit}");
    // The PLY holds the deviation in the datum frame: k·(z + 20) at every vertex.
    let bytes = std::fs::read(dir.path().join("abc.ply")).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let float =
        |i: usize| f32::from_le_bytes(bytes[end + 4 * i..end + 4 * i + 4].try_into().unwrap());
    // Each vertex: x, y, z, quality (MeshLab's scalar), deviation_mm; the same value twice.
    for v in 0..4 {
        let z = float(5 * v + 2) as f64;
        for deviation in [float(5 * v + 3) as f64, float(5 * v + 4) as f64] {
            assert!(
                (deviation - k * (z + 20.0)).abs() < 1e-8,
                "vertex at z={z}: {deviation}"
            );
        }
    }
}

#[test]
fn bad_datums_name_the_file_the_feature_and_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let bad = |keys: &str| {
        let path = dir.path().join("bad.toml");
        std::fs::write(
            &path,
            format!("{PART}{}", profile("skin", "skin.stl", keys)),
        )
        .unwrap();
        match PartFile::read(&path) {
            Ok(_) => panic!("accepted: {keys}"),
            Err(e) => e.to_string(),
        }
    };
    let expect = |keys: &str, words: &[&str]| {
        let message = bad(keys);
        assert!(
            message.contains("bad.toml") && message.contains("feature `skin`"),
            "{message}"
        );
        for w in words {
            assert!(message.contains(w), "{keys}: {message}");
        }
    };
    expect("datums = [\"Z\"]", &["datums", "`Z` names no feature"]);
    expect("datums = [\"skin\"]", &["datums", "`skin` is a profile"]);
    expect("datums = [\"A\", \"A\"]", &["datums", "`A` is named twice"]);
    expect(
        "datums = [\"A\", \"B\", \"C\", \"H\"]",
        &["datums", "names 4 datums"],
    );
    expect("evaluation = \"datums\"", &["evaluation", "needs `datums`"]);
    expect(
        "evaluation = \"best_fit\"\ndatums = [\"A\"]",
        &["evaluation = \"best_fit\" ignores `datums`"],
    );
    // An unknown evaluation is refused as the file is parsed.
    let message = bad("evaluation = \"least_squares\"");
    assert!(
        message.contains("bad.toml") && message.contains("unknown variant `least_squares`"),
        "{message}"
    );
}

#[test]
fn a_datum_parallel_to_the_one_before_it_constrains_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = part_with(
        dir.path(),
        &profile("skin", "skin.stl", "datums = [\"A\", \"A2\", \"C\"]"),
    );
    let error = evaluate(&p, ErrorSource::Exact(&gantry()), "part.toml")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("part.toml: feature `skin`")
            && error.contains("`A2` constrains no degree of freedom that `A` leave(s) free"),
        "{error}"
    );
}
