//! Measured results: the CSV files of the standard tests, fit files with their CSV files, the
//! interferometer CSV files `build` reads per axis.

use std::path::PathBuf;

use volmap::calibrate::build;
use volmap::calibrate::fit::{self, FitFile};
use volmap::model::{AxisLetter, Machine};
use volmap::standards::{
    self, CircularSpec, DiagonalSpec, PositioningSpec, RTestSpec, Setup, TestResult,
};

use super::machine::{as_strs, names};
use super::{directive, read, Context, Outcome, Target, Verdict};
use crate::material::Grammar;

/// The embedded machine an input names with `# machine: NAME`, or `default`.
pub(super) fn machine_of<'a>(cx: &'a Context, input: &[u8], default: &str) -> &'a Machine {
    let name = directive(input, "machine")
        .filter(|n| cx.machines().iter().any(|(m, _)| m == n))
        .unwrap_or(default);
    cx.machine(name)
}

const MEASURED_WORDS: &[&str] = &[
    "target_mm",
    "target_um",
    "target_deg",
    "direction",
    "run",
    "deviation_mm",
    "deviation_um",
    "deviation_arcsec",
    "deviation_urad",
    "position_mm",
    "position_um",
    "angle_deg",
    "dX_mm",
    "dY_mm",
    "dZ_mm",
    "dX_um",
    "up",
    "down",
    "+",
    "-",
];

pub const MEASURED: Target = Target {
    name: "measured",
    about: "measured results of the standard tests (CSV, `test --measured`): the test a seed names with `# test:` (positioning of a linear or a rotary axis, diagonal, circular with the ballbar diagnostics, R-test) run on `5axis-hwang2014` against the file, or all five",
    grammar: Grammar::Csv,
    words: MEASURED_WORDS,
    run: measured,
};

fn measured(cx: &mut Context, input: &[u8]) -> Verdict {
    const FILE: &str = "measured.csv";
    let paths = cx.write(FILE, input)?;
    let machine = machine_of(cx, input, "5axis-hwang2014");
    let setup = read!(Setup::new(machine, ""), &[]);
    let csv = Some(paths[0].clone());
    let test = directive(input, "test").unwrap_or("all");
    let mut outcome = Outcome::Accepted;
    let mut judge = |result: Result<TestResult, standards::StandardsError>| -> Result<(), String> {
        if let Err(error) = result {
            outcome = super::refused(error, &[FILE])?;
        }
        Ok(())
    };
    let all = test == "all";
    for axis in ["X", "C"] {
        let rotary = axis == "C";
        if all || (test == "positioning" && !rotary) || (test == "rotary" && rotary) {
            let spec = PositioningSpec {
                axis: axis.into(),
                targets: None,
                runs: 5,
                at_mm: None,
                pose: String::new(),
                csv: csv.clone(),
            };
            judge(standards::positioning(&setup, &spec))?;
        }
    }
    if all || test == "diagonal" {
        let spec = DiagonalSpec {
            diagonal: Some("PPP".into()),
            from_mm: None,
            to_mm: None,
            points: 21,
            pose: String::new(),
            csv: csv.clone(),
        };
        judge(standards::diagonal(&setup, &spec))?;
    }
    if all || test == "circular" {
        let spec = CircularSpec {
            plane: "XY".into(),
            centre_mm: None,
            radius_mm: None,
            points: 36,
            direction: "ccw".into(),
            start_deg: 0.0,
            pose: String::new(),
            csv: csv.clone(),
            pitch_mm: Some(10.0),
        };
        judge(standards::circular(&setup, &spec))?;
    }
    if all || test == "rtest" {
        // Within the travels: the C table turns about the corner of X and Y.
        let spec = RTestSpec {
            axis: "C".into(),
            sphere_mm: Some([300.0, 200.0, 250.0]),
            from_deg: Some(0.0),
            to_deg: Some(30.0),
            step_deg: 10.0,
            pose: String::new(),
            csv,
        };
        judge(standards::rtest(&setup, &spec))?;
    }
    Ok(outcome)
}

const FIT_WORDS: &[&str] = &[
    "estimate",
    "positioning",
    "diagonal",
    "circular",
    "rtest",
    "ballbar",
    "axis",
    "targets",
    "runs",
    "at_mm",
    "pose",
    "csv",
    "from_mm",
    "to_mm",
    "points",
    "plane",
    "centre_mm",
    "radius_mm",
    "direction",
    "start_deg",
    "sphere_mm",
    "from_deg",
    "to_deg",
    "step_deg",
    "temperatures",
    "squareness_urad",
    "scale_mismatch_ppm",
    "backlash_um",
    "per_kelvin",
    "EC0Y",
    "EB0Z",
    "EA0Z",
    "EX0C",
    "EY0C",
    "EA0C",
    "EB0C",
    "EXS",
    "EYS",
    "EAS",
    "EBS",
    "XY",
    "YZ",
    "ZX",
    "ccw",
    "cw",
    "PPP",
    "NPP",
    "PNP",
    "PPN",
    "hall",
];

pub const FIT: Target = Target {
    name: "fit",
    about: "fit files (TOML) with their measured CSV files: `FitFile::read` and the whole least-squares fit (`fit::fit`) on the embedded machine a seed names (`vmc-li2015` by default)",
    grammar: Grammar::Toml,
    words: FIT_WORDS,
    run: fit_file,
};

fn fit_file(cx: &mut Context, input: &[u8]) -> Verdict {
    let paths = cx.write("fit.toml", input)?;
    let names = names(&paths);
    let files = as_strs(&names);
    let file = read!(FitFile::read(&paths[0]), &files);
    let machine = machine_of(cx, input, "vmc-li2015");
    let report = read!(fit::fit(machine, &file), &files);
    // What `fit --out` writes must read back as a machine.
    let text = read!(fit::fitted_machine_toml(machine, &report), &files);
    if let Err(e) = Machine::from_toml(&text, "fitted.toml", None) {
        return Err(format!("the fitted machine file does not read back: {e}"));
    }
    Ok(Outcome::Accepted)
}

const INTERFEROMETER_WORDS: &[&str] = &[
    "position_mm",
    "position_deg",
    "EXX_um",
    "EXX_mm",
    "EYX_um",
    "EZX_um",
    "EAX_urad",
    "EBX_urad",
    "ECX_urad",
    "EAX_arcsec",
    "EXC_um",
    "ECC_arcsec",
    "ECC_urad",
    "EYY_um",
    "EZZ_um",
];

pub const INTERFEROMETER: Target = Target {
    name: "interferometer",
    about: "interferometer CSV files (`build --axis`): `build::build` of the axis a seed names (`# axis:`, X by default) on its base machine, and the machine file written read back",
    grammar: Grammar::Csv,
    words: INTERFEROMETER_WORDS,
    run: interferometer,
};

fn interferometer(cx: &mut Context, input: &[u8]) -> Verdict {
    const FILE: &str = "axis.csv";
    let paths: Vec<PathBuf> = cx.write(FILE, input)?;
    let base = machine_of(cx, input, "vmc-li2015");
    let axis = directive(input, "axis")
        .and_then(|a| a.chars().next())
        .and_then(AxisLetter::from_char)
        .unwrap_or(AxisLetter::X);
    let (text, built) = read!(build::build(base, &[(axis, &paths[0])], &[]), &[FILE]);
    std::hint::black_box(built);
    // What `build --out` writes must read back as a machine.
    if let Err(e) = Machine::from_toml(&text, "built.toml", None) {
        return Err(format!("the built machine file does not read back: {e}"));
    }
    Ok(Outcome::Accepted)
}
