//! Feature errors on machines whose effect on a feature is known by hand.

use volmap::model::{AxisLetter, ErrorFunction, Interp, Machine, Table};
use volmap::part::{evaluate, ErrorSource, FeatureError, PartFile, Verdict};
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

const PART: &str = r#"
name = "test part"
[placement]
zero_mm = [0.0, 0.0, 0.0]
[cutter]
radius_mm = 5.0
length_mm = 40.0
[sampling]
spacing_mm = 5.0
"#;

fn part(features: &str) -> PartFile {
    PartFile::parse(&format!("{PART}\n{features}"), "part.toml").unwrap()
}

#[test]
fn a_z_straightness_alone_gives_its_height_as_flatness() {
    let mut m = gantry();
    let arc = Table::new(
        vec![(0.0, 0.0), (200.0, 0.01), (400.0, 0.0)],
        Interp::Quadratic,
        false,
    )
    .unwrap();
    m.axis_mut(X).unwrap().components[2] = Some(ErrorFunction::Table(arc));
    let p = part(
        r#"[[features]]
kind = "end_milled_plane"
name = "floor"
corner_mm = [0.0, 0.0, -10.0]
size_mm = [400.0, 100.0]
tolerance_mm = 0.05
"#,
    );
    let rows = evaluate(&p, ErrorSource::Exact(&m), "part.toml").unwrap();
    assert!(
        (rows[0].error_mm - 0.01).abs() < 1e-9,
        "{}",
        rows[0].error_mm
    );
    assert!((rows[0].safety.unwrap() - 5.0).abs() < 1e-6);
    assert_eq!(rows[0].verdict, Verdict::Fit);
    assert!(
        (rows[0].worst_point[0] - 200.0).abs() < 1e-9
            || rows[0].worst_point[0].abs() < 1e-9
            || (rows[0].worst_point[0] - 400.0).abs() < 1e-9
    );
}

#[test]
fn a_pure_spindle_tilt_lowers_a_rib_by_radius_times_tilt() {
    let mut m = gantry();
    m.spindle[3] = 2e-4;
    let p = part(
        r#"[[features]]
kind = "rib_height"
name = "rib"
corner_mm = [100.0, 100.0, 0.0]
size_mm = [50.0, 4.0]
tolerance_mm = 0.002

[[features]]
kind = "end_milled_plane"
name = "floor"
corner_mm = [100.0, 100.0, -20.0]
size_mm = [50.0, 50.0]
tolerance_mm = 0.01
"#,
    );
    let rows = evaluate(&p, ErrorSource::Exact(&m), "part.toml").unwrap();
    assert!(
        (rows[0].error_mm - 5.0 * 2e-4).abs() < 1e-12,
        "{}",
        rows[0].error_mm
    );
    assert_eq!(rows[0].verdict, Verdict::Inspect);
    // The tilt lowers the whole floor alike: no flatness error.
    assert!(rows[1].error_mm < 1e-12, "{}", rows[1].error_mm);
    assert_eq!(rows[1].safety, None);
}

#[test]
fn a_pitch_error_tilts_two_holes_apart_by_depth_times_pitch() {
    let b1 = 1e-7;
    let mut m = gantry();
    m.axis_mut(X).unwrap().components[4] = Some(ErrorFunction::Poly(vec![3e-5, b1]));
    let p = part(
        r#"[[features]]
kind = "hole"
name = "A"
centre_mm = [50.0, 150.0, 0.0]
diameter_mm = 10.0
depth_mm = 20.0
tolerance_mm = 0.01

[[features]]
kind = "parallel_hole"
name = "B"
centre_mm = [250.0, 150.0, 0.0]
diameter_mm = 10.0
depth_mm = 20.0
datum = "A"
tolerance_mm = 0.0003
"#,
    );
    let rows = evaluate(&p, ErrorSource::Exact(&m), "part.toml").unwrap();
    // Bored (cutter as wide as the hole): each hole's sections across the tool axis are circles
    // shifted along the tilted cutter, so across its own axis the hole is an ellipse: the
    // R·(1 − cos β) of Li et al.'s Eq. (12) is its whole cylindricity.
    let beta: f64 = 3e-5 + b1 * 50.0;
    let ellipse = 5.0 * (1.0 - beta.cos());
    assert!(
        (rows[0].error_mm - ellipse).abs() < 1e-12,
        "{} vs {ellipse}",
        rows[0].error_mm
    );
    let expected = 20.0 * b1 * 200.0;
    assert!(
        (rows[1].error_mm - expected).abs() < 1e-8,
        "{} vs {expected}",
        rows[1].error_mm
    );
    assert_eq!(rows[1].verdict, Verdict::Unfit);
}

#[test]
fn a_wall_follows_the_tilt_of_the_cutter() {
    // A roll of the X carriage (EAX = k·x) tilts the cutter about x by an amount that grows
    // along a wall running along x.
    let mut m = gantry();
    m.axis_mut(X).unwrap().components[3] = Some(ErrorFunction::Poly(vec![0.0, 1e-7]));
    let p = part(
        r#"[[features]]
kind = "flank_milled_plane"
name = "wall"
start_mm = [0.0, 50.0, -10.0]
direction_deg = 0.0
length_mm = 300.0
depth_mm = 10.0
tolerance_mm = 0.01
"#,
    );
    let rows = evaluate(&p, ErrorSource::Exact(&m), "part.toml").unwrap();
    assert!(rows[0].error_mm > 0.0);
    // The wall's deviation is k·x·(s − 10) (the roll tilts the cutter, and moves its tip by the
    // 10 mm it stands below the Y-Z carriage): a twisted surface, whose best plane leaves
    // k·(x − X/2)·(s − S/2), between ±k·X·S/4: a zone k·X·S/2 wide.
    assert!(
        (rows[0].error_mm - 1e-7 * 300.0 * 10.0 / 2.0).abs() < 1e-9,
        "{}",
        rows[0].error_mm
    );
}

#[test]
fn bad_part_files_are_clear_errors() {
    let bad = |features: &str| match PartFile::parse(&format!("{PART}\n{features}"), "part.toml") {
        Ok(_) => panic!("accepted: {features}"),
        Err(e) => e.to_string(),
    };
    let hole = "[[features]]\nkind = \"hole\"\nname = \"A\"\ncentre_mm = [0.0, 0.0, 0.0]\ndiameter_mm = 10.0\ndepth_mm = 5.0\ntolerance_mm = 0.01\n";
    let message = bad(&hole.replace("tolerance_mm = 0.01", "tolerance_mm = 0.0"));
    assert!(
        message.contains("part.toml: feature `A`: tolerance_mm must be a positive"),
        "{message}"
    );
    let message = bad(&format!("{hole}[[features]]\nkind = \"parallel_hole\"\nname = \"B\"\ncentre_mm = [0.0, 0.0, 0.0]\ndiameter_mm = 10.0\ndepth_mm = 5.0\ndatum = \"C\"\ntolerance_mm = 0.01\n"));
    assert!(
        message.contains("feature `B`: datum `C` names no feature"),
        "{message}"
    );
    let message = bad(&hole.replace("depth_mm = 5.0", "depth_mm = 5.0\ncolour = 1"));
    assert!(
        message.contains("part.toml") && message.contains("colour"),
        "{message}"
    );
    let message = bad(&hole.replace("kind = \"hole\"", "kind = \"thread\""));
    assert!(message.contains("thread"), "{message}");
    // A feature the cutter cannot reach, and one outside the map.
    let deep = part(&hole.replace("depth_mm = 5.0", "depth_mm = 50.0"));
    let error = evaluate(&deep, ErrorSource::Exact(&gantry()), "part.toml").unwrap_err();
    assert!(
        matches!(&error, FeatureError::Feature { feature, .. } if feature == "A"),
        "{error}"
    );
    assert!(
        error.to_string().contains("exceeds the cutter length"),
        "{error}"
    );
}

fn square_stl(size: f64) -> String {
    let c = [[0.0, 0.0], [size, 0.0], [size, size], [0.0, size]];
    let facet = |t: [usize; 3]| {
        let mut f = String::from("facet normal 0 0 1\nouter loop\n");
        for i in t {
            f.push_str(&format!("vertex {} {} 0\n", c[i][0], c[i][1]));
        }
        f + "endloop\nendfacet\n"
    };
    format!(
        "solid square\n{}{}endsolid square\n",
        facet([0, 1, 2]),
        facet([0, 2, 3])
    )
}

#[test]
fn a_meshed_profile_gives_its_largest_deviation_and_the_area_outside_the_zone() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("square.stl"), square_stl(100.0)).unwrap();
    // VE_z = a·x over a 100 mm square: the deviation runs from 0 to 0.01 mm; a 0.01 mm zone
    // (±0.005) leaves out the half where x > 50.
    let a = 1e-4;
    let mut m = gantry();
    m.axis_mut(X).unwrap().components[2] = Some(ErrorFunction::Poly(vec![0.0, a]));
    let part_path = dir.path().join("part.toml");
    std::fs::write(
        &part_path,
        format!("{PART}\n[[features]]\nkind = \"profile\"\nname = \"skin\"\nmesh = \"square.stl\"\ntolerance_mm = 0.01\nply = \"skin.ply\"\n"),
    )
    .unwrap();
    let p = PartFile::read(&part_path).unwrap();
    let rows = evaluate(&p, ErrorSource::Exact(&m), "part.toml").unwrap();
    let row = &rows[0];
    // Sampled at sub-triangle centroids no farther apart than 5 mm: the largest lies within a
    // few mm of the far edge.
    assert!(
        row.error_mm <= 2.0 * a * 100.0 && row.error_mm > 2.0 * a * 96.0,
        "{}",
        row.error_mm
    );
    let outside = row.area_outside.unwrap();
    assert!((outside - 0.5).abs() < 0.02, "{outside}");
    assert_eq!(row.verdict, Verdict::Unfit);
    // The PLY holds the deviation at the four corners: 0 at x = 0, a·100 at x = 100.
    let bytes = std::fs::read(dir.path().join("skin.ply")).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let float =
        |k: usize| f32::from_le_bytes(bytes[end + 4 * k..end + 4 * k + 4].try_into().unwrap());
    for v in 0..4 {
        let (x, deviation) = (float(5 * v), float(5 * v + 3));
        assert!(
            (deviation as f64 - a * x as f64).abs() < 1e-9,
            "vertex at x={x}: {deviation}"
        );
    }
    // Last (it rewrites the PLY for its own machine): the command line says where it wrote the deviations.
    super::cli::volmap()
        .args(["features", "--machine", "gantry-2m", "--part"])
        .arg(&part_path)
        .assert()
        .success()
        .stdout(predicates::str::contains(format!(
            "  wrote {} (deviations of `skin`)",
            dir.path().join("skin.ply").display()
        )));
}

#[test]
fn a_profile_written_as_vtp_holds_the_deviation_for_paraview() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("square.stl"), square_stl(100.0)).unwrap();
    // VE_z = a·x: the normal deviation at a vertex is a·x.
    let a = 1e-4;
    let mut m = gantry();
    m.axis_mut(X).unwrap().components[2] = Some(ErrorFunction::Poly(vec![0.0, a]));
    let part_path = dir.path().join("part.toml");
    std::fs::write(
        &part_path,
        format!("{PART}\n[[features]]\nkind = \"profile\"\nname = \"skin\"\nmesh = \"square.stl\"\ntolerance_mm = 0.01\nply = \"skin.vtp\"\n"),
    )
    .unwrap();
    let p = PartFile::read(&part_path).unwrap();
    evaluate(&p, ErrorSource::Exact(&m), "part.toml").unwrap();
    let path = dir.path().join("skin.vtp");
    assert!(std::fs::read(&path).unwrap().starts_with(b"<?xml"));
    let Some(json) = crate::vtk::python_read("vtk", "read_vtk.py", &path) else {
        return;
    };
    assert_eq!(json["points"], 4);
    assert_eq!(json["active"], "deviation_mm");
    for v in 0..4 {
        let x = json["coordinates"][v][0].as_f64().unwrap();
        let deviation = json["arrays"]["deviation_mm"][v].as_f64().unwrap();
        assert!(
            (deviation - a * x).abs() < 1e-9,
            "vertex at x={x}: {deviation}"
        );
    }
}

#[test]
fn a_missing_mesh_names_the_feature_and_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let part_path = dir.path().join("part.toml");
    std::fs::write(&part_path, format!("{PART}\n[[features]]\nkind = \"profile\"\nname = \"skin\"\nmesh = \"absent.stl\"\ntolerance_mm = 0.1\n")).unwrap();
    let p = PartFile::read(&part_path).unwrap();
    let error = evaluate(&p, ErrorSource::Exact(&gantry()), "part.toml")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("feature `skin`") && error.contains("absent.stl"),
        "{error}"
    );
}

const DATUMS: &str = r#"
[[features]]
kind = "flank_milled_plane"
name = "A"
start_mm = [0.0, 0.0, -10.0]
direction_deg = 90.0
length_mm = 200.0
depth_mm = 10.0
normal_left = true
tolerance_mm = 0.1

[[features]]
kind = "flank_milled_plane"
name = "B"
start_mm = [0.0, 0.0, -10.0]
direction_deg = 0.0
length_mm = 300.0
depth_mm = 10.0
tolerance_mm = 0.1

[[features]]
kind = "hole_position"
name = "H"
centre_mm = [200.0, 100.0, 0.0]
diameter_mm = 10.0
depth_mm = 20.0
datums = ["A", "B"]
tolerance_mm = 0.05

[[features]]
kind = "rib_position"
name = "R"
start_mm = [250.0, 0.0, 0.0]
direction_deg = 90.0
length_mm = 100.0
depth_mm = 10.0
datums = ["A"]
tolerance_mm = 0.05
"#;

#[test]
fn positions_move_with_their_datums() {
    // Wall A at x = 0 faces -x (normal to the left of +y), wall B at y = 0 faces -y.
    let with_x_error = |f: ErrorFunction| {
        let mut m = gantry();
        m.axis_mut(X).unwrap().components[0] = Some(f);
        m
    };
    let p = part(DATUMS);
    // A uniform X offset moves datums and features alike: no position error.
    let rows = evaluate(
        &p,
        ErrorSource::Exact(&with_x_error(ErrorFunction::Constant(0.02))),
        "part.toml",
    )
    .unwrap();
    let by_name = |rows: &[volmap::part::FeatureResult], n: &str| {
        rows.iter().find(|r| r.name == n).unwrap().error_mm
    };
    assert!(by_name(&rows, "H") < 1e-9, "{}", by_name(&rows, "H"));
    assert!(by_name(&rows, "R") < 1e-9, "{}", by_name(&rows, "R"));
    // A scale error k·x: datum A is cut with the cutter's axis at x = -5 (its radius off the
    // wall), so it moves by -5k; the hole (bored at x = 200) by 200k; the rib side, cut from
    // x = 255, by 255k. Twice the distance from the true position is the position error.
    let k = 5e-5;
    let rows = evaluate(
        &p,
        ErrorSource::Exact(&with_x_error(ErrorFunction::Poly(vec![0.0, k]))),
        "part.toml",
    )
    .unwrap();
    assert!(
        (by_name(&rows, "H") - 2.0 * k * 205.0).abs() < 1e-9,
        "{}",
        by_name(&rows, "H")
    );
    assert!(
        (by_name(&rows, "R") - 2.0 * k * 260.0).abs() < 1e-9,
        "{}",
        by_name(&rows, "R")
    );
    assert_eq!(
        rows.iter().find(|r| r.name == "H").unwrap().verdict,
        Verdict::Inspect
    );
}

#[test]
fn positions_need_plane_datums() {
    let bad = |text: String| {
        PartFile::parse(&format!("{PART}\n{text}"), "part.toml")
            .unwrap_err()
            .to_string()
    };
    let message = bad(DATUMS.replace("datums = [\"A\", \"B\"]", "datums = []"));
    assert!(message.contains("feature `H`: names 0 datums"), "{message}");
    let message = bad(format!(
        "{DATUMS}\n[[features]]\nkind = \"hole\"\nname = \"D\"\ncentre_mm = [0.0, 0.0, 0.0]\ndiameter_mm = 5.0\ndepth_mm = 5.0\ntolerance_mm = 0.1\n"
    )
    .replace("datums = [\"A\"]", "datums = [\"D\"]"));
    assert!(
        message.contains("feature `R`: datum `D` is a hole"),
        "{message}"
    );
}

fn machine() -> Machine {
    volmap::io::embedded::embedded("vmc-li2015")
        .unwrap()
        .unwrap()
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
