//! The inputs volmap refuses, as a table: each row a run (the files in its folder and its
//! arguments), the exit code and the fragments its message must hold. Every row also requires
//! no panic, an answer within 30 seconds (a count checked too late would loop or allocate for
//! long) and nothing written: after the run the folder holds the row's files alone.

use std::path::Path;
use std::time::{Duration, Instant};

use super::features::{hole, part_text, SPACING, ZERO};
use super::input_files::CIRCLE;
use super::volmap;

/// Runs volmap with `args` in a folder holding `files`: exit code `code` with every one of
/// `says` on stderr, no panic, within 30 s, and no file written or removed.
fn check(files: &[(&str, String)], args: &[&str], code: i32, says: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let before = listing(dir.path());
    let start = Instant::now();
    let output = volmap()
        .current_dir(dir.path())
        .args(args)
        .timeout(Duration::from_secs(60))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(code), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    for s in says {
        assert!(stderr.contains(s), "{args:?}: `{s}` not in: {stderr}");
    }
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "{args:?} took {:?}",
        start.elapsed()
    );
    assert_eq!(listing(dir.path()), before, "{args:?} left files");
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Rows, each a test: `NAME: [FILE => TEXT, …] ARG, … => CODE [FRAGMENT, …];`.
macro_rules! refusals {
    ($($(#[$doc:meta])* $name:ident: [$($file:expr => $text:expr),* $(,)?]
        $($arg:expr),+ => $code:literal [$($says:expr),+ $(,)?];)*) => {
        $(
            $(#[$doc])*
            #[test]
            fn $name() {
                check(&[$(($file, String::from($text))),*], &[$($arg),+], $code, &[$($says),+]);
            }
        )*
    };
}

/// A fit file holding `body` after its estimate.
fn fit_file(body: &str) -> String {
    format!("estimate = [\"EC0Y\"]\n{body}")
}

const POSITIONING: &str =
    "target_mm,direction,run,deviation_mm\n0,+,1,0\n1000,+,1,0.002\n1000,-,1,0.002\n0,-,1,0\n";
const LINE: &str = "G54 G0 X10 Y10 Z10\nG1 X20 F100\n";
const MOVE: &str = "G0 X10 Y10 Z10\nG1 X500 Y300 Z200 F1000\n";
const TOLERANCES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/tolerances/vmc-li2015.toml"
);
const PART: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/li2015-part.toml");

// Errors inside a fit file's tests name the file and the test.
refusals! {
    a_fit_files_circle_in_no_plane_names_the_test:
        ["c.csv" => CIRCLE, "a.toml" => fit_file("[[circular]]\nplane = \"XQ\"\ncsv = \"c.csv\"\n")]
        "fit", "--machine", "vmc-li2015", "--measurements", "a.toml"
        => 2 ["a.toml: [[circular]] number 1: plane `XQ`: XY, YZ or ZX"];
    a_fit_files_second_circle_beyond_the_travel_names_the_test:
        ["c.csv" => CIRCLE, "b.toml" => fit_file("[[circular]]\nplane = \"XY\"\npoints = 8\ncsv = \"c.csv\"\n[[circular]]\nplane = \"XY\"\nradius_mm = 5000.0\npoints = 8\ncsv = \"c.csv\"\n")]
        "fit", "--machine", "vmc-li2015", "--measurements", "b.toml"
        => 2 ["b.toml: [[circular]] number 2: circle in XY"];
    a_fit_files_diagonal_without_its_csv_names_the_test:
        ["c.toml" => fit_file("[[diagonal]]\ndiagonal = \"PPP\"\ncsv = \"absent.csv\"\n")]
        "fit", "--machine", "vmc-li2015", "--measurements", "c.toml"
        => 2 ["c.toml: [[diagonal]] number 1: "];
    a_fit_files_positioning_at_a_pose_of_no_axis_names_the_test:
        ["pos.csv" => POSITIONING, "d.toml" => fit_file("[[positioning]]\naxis = \"X\"\npose = \"B=30\"\ncsv = \"pos.csv\"\n")]
        "fit", "--machine", "vmc-li2015", "--measurements", "d.toml"
        => 2 ["d.toml: [[positioning]] number 1: B is not an axis of this machine"];
    a_fit_files_circle_of_positioning_results_names_the_test:
        ["pos.csv" => POSITIONING, "e.toml" => fit_file("[[circular]]\nplane = \"XY\"\npoints = 8\ncsv = \"pos.csv\"\n")]
        "fit", "--machine", "vmc-li2015", "--measurements", "e.toml"
        => 2 ["e.toml: [[circular]] number 1: "];
}

// A work offset or a tool length that is not a number names the offset or the flag.
refusals! {
    a_work_offset_flag_that_is_not_a_number_names_the_offset:
        ["p.nc" => LINE]
        "compensate", "--machine", "vmc-li2015", "--program", "p.nc", "--out", "o.nc",
        "--work-offset", "G54=nan,0,0"
        => 2 ["--work-offset: work offset `G54=nan,0,0`: G54: its X value is not a finite number"];
    a_work_offset_file_value_that_is_not_a_number_names_the_offset:
        ["p.nc" => LINE, "w.toml" => "G55 = [0.0, 0.0, 0.0]\nG54 = [0.0, inf, 0.0]\n"]
        "compensate", "--machine", "vmc-li2015", "--program", "p.nc", "--out", "o.nc",
        "--work-offset-file", "w.toml"
        => 2 ["w.toml: work offset `G54=0,inf,0`: G54: its Y value is not a finite number"];
    a_tool_length_that_is_not_a_number_names_the_flag:
        ["p.nc" => LINE]
        "compensate", "--machine", "vmc-li2015", "--program", "p.nc", "--out", "o.nc",
        "--tool-length", "T1=nan"
        => 2 ["--tool-length"];
}

// Nesting limits name the file and the line.
refusals! {
    a_machine_file_nested_too_deep_names_the_line:
        ["deep.toml" => format!("name = \"deep\"\nchain = \"FFXYZ\"\ndescription = {}{}\n", "[".repeat(100_000), "]".repeat(100_000))]
        "map", "--grid", "2x2x2", "--machine", "deep.toml"
        => 2 ["deep.toml: line 3, column"];
    calls_nested_too_deep_name_the_line:
        ["self.nc" => "G0 X10 Y10 Z10\nM98 P1\nM30\nO1\nG1 X20 F100\nM98 P1\nM99\n"]
        "compensate", "--machine", "vmc-li2015", "--program", "self.nc", "--out", "o.nc"
        => 2 ["self.nc: line 6: M98: calls nest deeper than 8 levels"];
    calls_repeated_to_a_billion_blocks_are_refused:
        ["many.nc" => "G0 X10 Y10 Z10\nM98 P1 L1000\nM30\nO1\nM98 P2 L1000\nM99\nO2\nM98 P3 L1000\nM99\nO3\nG1 X20 F100\nM99\n"]
        "compensate", "--machine", "vmc-li2015", "--program", "many.nc", "--out", "o.nc"
        => 2 ["M98: the calls add more than 4000000 words and blocks to the program"];
}

// Inputs that would leave no number (NaN or an infinity in the output), and a move beyond
// the travel in `trace` (which evaluated it with exit 0 where `compensate` and `sample`
// refuse it).
refusals! {
    a_map_at_a_temperature_no_thermal_term_survives_is_refused:
        []
        "map", "--machine", "gantry-2m", "--grid", "4x4x4", "--device", "cpu",
        "--temperatures", "x_scale=1e308", "--out", "f.exr"
        => 2 ["--temperatures", "x_scale=1e308", "more than 200 K"];
    a_test_at_a_temperature_no_thermal_term_survives_is_refused:
        []
        "test", "positioning", "--axis", "X", "--machine", "gantry-2m",
        "--temperatures", "x_scale=1e308"
        => 2 ["--temperatures", "more than 200 K"];
    a_map_below_absolute_zero_is_refused:
        []
        "map", "--machine", "gantry-2m", "--grid", "4x4x4", "--device", "cpu",
        "--temperatures", "x_scale=-300", "--out", "f.exr"
        => 2 ["--temperatures", "absolute zero"];
    points_far_beyond_the_travel_name_their_line:
        ["p.csv" => "X,Y,Z\n100,100,100\n1.7e308,1.7e308,1.7e308\n"]
        "sample", "--machine", "vmc-li2015", "--exact", "--points", "p.csv", "--out", "s.csv"
        => 2 ["--points", "line 3"];
    a_work_offset_far_beyond_the_travel_names_the_line:
        ["p.nc" => MOVE]
        "trace", "--machine", "vmc-li2015", "--program", "p.nc", "--work-offset", "G54=1e308,0,0"
        => 2 ["p.nc", "line 1", "X=1e308 (machine), outside the travel of X"];
    a_part_zero_far_beyond_the_travel_names_the_key:
        ["part.toml" => "name = \"p\"\n[placement]\nzero_mm = [1e300, 0.0, 0.0]\n[cutter]\nradius_mm = 8.0\nlength_mm = 60.0\n[[features]]\nkind = \"hole\"\nname = \"h\"\ncentre_mm = [50.0, 100.0, -20.0]\ndiameter_mm = 20.0\ndepth_mm = 30.0\ntolerance_mm = 0.04\n"]
        "features", "--machine", "vmc-li2015", "--part", "part.toml"
        => 2 ["part.toml", "`h`", "zero_mm"];
    trace_refuses_a_move_beyond_the_travel:
        ["p.nc" => "G90 G0 X0 Y0 Z10\nG1 X5000 F500\nM30\n"]
        "trace", "--machine", "vmc-li2015", "--program", "p.nc", "--work-offset", "G54=100,100,100"
        => 2 ["p.nc: line 2: the move reaches X=", "outside the travel of X"];
}

// An output in a folder that does not exist, refused alike by every writer.
refusals! {
    a_map_into_a_missing_folder_is_refused:
        []
        "map", "--machine", "vmc-li2015", "--grid", "2x2x2", "--device", "cpu", "--out", "nodir/f.exr"
        => 2 ["nodir", "does not exist"];
    samples_into_a_missing_folder_are_refused:
        ["p.csv" => "X,Y,Z\n1,2,3\n"]
        "sample", "--exact", "--machine", "vmc-li2015", "--points", "p.csv", "--out", "nodir/s.csv"
        => 2 ["nodir", "does not exist"];
    a_plot_into_a_missing_folder_is_refused:
        []
        "plot", "grid", "--machine", "vmc-li2015", "--grid", "3x3x3", "--out", "nodir/g.svg"
        => 2 ["nodir", "does not exist"];
    a_budgets_samples_into_a_missing_folder_are_refused:
        ["tol.toml" => "[axes.X]\nEXX = { uniform = 1e-3 }\n"]
        "budget", "--machine", "vmc-li2015", "--tolerances", "tol.toml", "--grid", "2x2x2",
        "--device", "cpu", "--samples", "3", "--per-sample", "nodir/ps.csv"
        => 2 ["nodir", "does not exist"];
    a_tests_json_into_a_missing_folder_is_refused:
        []
        "test", "circular", "--machine", "vmc-li2015", "--plane", "XY", "--json", "nodir/c.json"
        => 2 ["nodir", "does not exist"];
}

// Commands that judge a machine require it named (and `build` its base).
refusals! {
    compensate_requires_a_machine:
        ["p.nc" => "G0 X10 Y10 Z10\n"]
        "compensate", "--program", "p.nc", "--out", "o.nc"
        => 2 ["--machine", "`volmap machines` lists"];
    fit_requires_a_machine:
        ["fit.toml" => "estimate = [\"EC0Y\"]\n"]
        "fit", "--measurements", "fit.toml"
        => 2 ["--machine", "`volmap machines` lists"];
    a_positioning_test_requires_a_machine:
        []
        "test", "positioning", "--axis", "X"
        => 2 ["--machine", "`volmap machines` lists"];
    a_circular_test_requires_a_machine:
        []
        "test", "circular", "--plane", "XY"
        => 2 ["--machine", "`volmap machines` lists"];
    budget_requires_a_machine:
        ["t.toml" => ""]
        "budget", "--tolerances", "t.toml"
        => 2 ["--machine", "`volmap machines` lists"];
    build_requires_a_base:
        []
        "build", "--axis", "X=x.csv", "--out", "b.toml"
        => 2 ["--base"];
    features_require_a_machine_or_a_field:
        ["part.toml" => ""]
        "features", "--part", "part.toml"
        => 2 ["--machine", "--field"];
}

// Part files that imply endless cuts (a capacity overflow, a 50 GB allocation, an endless
// loop, hours and over 6 GiB) name the file and the keys.
refusals! {
    a_hole_1e300_wide_is_refused:
        ["d.toml" => part_text(ZERO, SPACING, &hole("1e300", "30.0"))]
        "features", "--machine", "vmc-li2015", "--part", "d.toml"
        => 2 ["d.toml", "`h`", "diameter_mm"];
    a_hole_1e9_wide_is_refused:
        ["d9.toml" => part_text(ZERO, SPACING, &hole("1e9", "30.0"))]
        "features", "--machine", "vmc-li2015", "--part", "d9.toml"
        => 2 ["d9.toml", "`h`", "diameter_mm"];
    a_hole_1e300_deep_is_refused:
        ["h.toml" => part_text(ZERO, SPACING, &hole("20.0", "1e300"))]
        "features", "--machine", "vmc-li2015", "--part", "h.toml"
        => 2 ["h.toml", "`h`", "depth_mm"];
    a_rib_1e300_long_is_refused:
        ["rib.toml" => part_text(ZERO, SPACING, "kind = \"rib_height\"\nname = \"r\"\ncorner_mm = [0.0, 220.0, 0.0]\nsize_mm = [1e300, 5.0]\ntolerance_mm = 0.1")]
        "features", "--machine", "vmc-li2015", "--part", "rib.toml"
        => 2 ["rib.toml", "`r`", "size_mm"];
    a_spacing_of_1e_minus_300_is_refused:
        ["sp.toml" => part_text(ZERO, "spacing_mm = 1e-300", &hole("20.0", "30.0"))]
        "features", "--machine", "vmc-li2015", "--part", "sp.toml"
        => 2 ["sp.toml", "spacing_mm", "1e-300"];
    a_plane_of_2_to_the_32_mm_is_refused:
        ["big.toml" => part_text(ZERO, SPACING, "kind = \"end_milled_plane\"\nname = \"f\"\ncorner_mm = [0.0, 0.0, -20.0]\nsize_mm = [65536.0, 4294967296.0]\ntolerance_mm = 0.05")]
        "features", "--machine", "vmc-li2015", "--part", "big.toml"
        => 2 ["big.toml", "`f`", "size_mm", "limit of 1000000"];
    // A cutter long enough for a hole 1e300 deep: the count, not the reach, refuses it.
    a_hole_1e300_deep_is_refused_with_a_cutter_that_reaches:
        ["cut.toml" => part_text(ZERO, SPACING, &hole("20.0", "1e300")).replace("length_mm = 60.0", "length_mm = 1e300")]
        "features", "--machine", "vmc-li2015", "--part", "cut.toml"
        => 2 ["`h`", "depth_mm"];
    // The datum features of positions too.
    a_rib_position_1e300_long_is_refused:
        ["pos.toml" => part_text(ZERO, SPACING, "kind = \"end_milled_plane\"\nname = \"floor\"\ncorner_mm = [0.0, 0.0, -20.0]\nsize_mm = [300.0, 200.0]\ntolerance_mm = 0.05\n[[features]]\nkind = \"rib_position\"\nname = \"side\"\nstart_mm = [0.0, 0.0, -20.0]\ndirection_deg = 0.0\nlength_mm = 1e300\ndepth_mm = 20.0\ndatums = [\"floor\"]\ntolerance_mm = 0.06\n[[features]]\nkind = \"hole_position\"\nname = \"hp\"\ncentre_mm = [50.0, 100.0, -20.0]\ndiameter_mm = 20.0\ndepth_mm = 1e300\ndatums = [\"floor\"]\ntolerance_mm = 0.04")]
        "features", "--machine", "vmc-li2015", "--part", "pos.toml"
        => 2 ["`side`", "length_mm"];
}

// Counts of tests, compensations, samples and drawings beyond the documented limits name the
// flag (`flag_values::counts_at_their_limits_are_taken` runs the limits themselves).
refusals! {
    an_r_test_step_of_1e_minus_300_is_refused:
        []
        "test", "rtest", "--axis", "C", "--step", "1e-300", "--machine", "5axis-hwang2014"
        => 2 ["--step", "100000"];
    an_r_test_step_of_1e_minus_9_is_refused:
        []
        "test", "rtest", "--axis", "C", "--step", "1e-9", "--machine", "5axis-hwang2014"
        => 2 ["--step", "100000"];
    an_r_test_from_and_to_1e308_is_refused:
        []
        "test", "rtest", "--axis", "C", "--from", "-1e308", "--to", "1e308", "--machine", "5axis-hwang2014"
        => 2 ["--from", "--to"];
    a_trillion_positioning_targets_are_refused:
        []
        "test", "positioning", "--axis", "X", "--targets", "1000000000000", "--machine", "vmc-li2015"
        => 2 ["--targets", "100000"];
    a_trillion_positioning_runs_are_refused:
        []
        "test", "positioning", "--axis", "X", "--runs", "1000000000000", "--machine", "vmc-li2015"
        => 2 ["--runs", "100"];
    a_trillion_diagonal_points_are_refused:
        []
        "test", "diagonal", "--diagonal", "PPP", "--points", "1000000000000", "--machine", "vmc-li2015"
        => 2 ["--points"];
    a_trillion_circle_points_are_refused:
        []
        "test", "circular", "--plane", "XY", "--points", "1000000000000", "--machine", "vmc-li2015"
        => 2 ["--points"];
    compensating_to_65536_decimals_is_refused:
        ["p.nc" => MOVE]
        "compensate", "--program", "p.nc", "--out", "o.nc", "--decimals", "65536", "--machine", "vmc-li2015"
        => 2 ["--decimals", "at most 15"];
    tracing_to_65536_decimals_is_refused:
        ["p.nc" => MOVE]
        "trace", "--program", "p.nc", "--compensate", "--decimals", "65536", "--machine", "vmc-li2015"
        => 2 ["--decimals"];
    a_trace_step_of_1e_minus_300_is_refused:
        ["p.nc" => MOVE]
        "trace", "--program", "p.nc", "--step", "1e-300", "--machine", "vmc-li2015"
        => 2 ["--step"];
    a_trillion_budget_samples_are_refused:
        []
        "budget", "--tolerances", TOLERANCES, "--grid", "3x3x3", "--samples", "1000000000000", "--machine", "vmc-li2015"
        => 2 ["--samples", "1000000"];
    a_trillion_feature_samples_are_refused:
        []
        "features", "--part", PART, "--tolerances", TOLERANCES, "--samples", "1000000000000", "--machine", "vmc-li2015"
        => 2 ["--samples"];
    a_grid_of_300_cubed_is_not_drawn:
        []
        "plot", "grid", "--grid", "300x300x300", "--out", "g.svg"
        => 2 ["--grid", "300x300x300"];
}
