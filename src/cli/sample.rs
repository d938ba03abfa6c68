//! `volmap sample`: VE and OE at arbitrary commanded positions, CSV in and CSV out, interpolated
//! in a field or computed exactly from the machine model.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use volmap::io::field::FieldFile;
use volmap::io::points::{self, QueryPoint};
use volmap::query::{self, SampledField};

use super::args::{load_machine, DeviceArg, InputsArg, OptionalMachineArg, PoseArg};
use super::failure::{Failure, FlagContext};
use super::output::write_file;

#[derive(clap::Args)]
#[command(mut_arg("pose", |a| a.requires("exact")))]
pub struct SampleArgs {
    /// Positions: CSV with a header row naming X, Y, Z (mm) and optionally A, B, C (degrees).
    #[arg(long)]
    points: PathBuf,
    /// Interpolate (trilinear) in this field file; positions outside its grid are an error. In a
    /// five-axis map (`map --poses`) the rotary columns pick the part of each point's pose.
    #[arg(long, conflicts_with = "exact")]
    field: Option<PathBuf>,
    /// Compute exactly from the machine model (the f64 reference) instead of a field.
    #[arg(long, requires = "machine")]
    exact: bool,
    #[command(flatten)]
    machine: OptionalMachineArg,
    #[command(flatten)]
    pose: PoseArg,
    /// The evaluation inputs: of the machine with --exact; with --field, those the field must
    /// have been computed for (default: every axis `+`, every input at its reference).
    #[command(flatten)]
    inputs: InputsArg,
    /// Where to write the result (CSV); standard output when left out.
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    device: DeviceArg,
}

pub fn run(args: SampleArgs) -> Result<ExitCode, Failure> {
    // The field's headers first: it must hold the inputs asked for.
    let file = args
        .field
        .as_deref()
        .map(FieldFile::open)
        .transpose()
        .flag("--field")?;
    if let Some(file) = &file {
        args.inputs.check_field(file)?;
    }
    // The points and the field are read side by side: both are mostly parsing.
    // A five-axis map's parts are read later, one by one, as the points ask for them.
    let (points, loaded) = rayon::join(
        || points::read_points(&args.points),
        || file.map(SampledField::of).transpose(),
    );
    let points = points.flag("--points")?;
    let loaded = loaded.flag("--field")?;
    let samples = match (&loaded, &args.machine.machine) {
        (Some(loaded), _) => {
            let path = args.points.display().to_string();
            let (sampler, note) = args.device.sampler()?;
            if let Some(note) = note {
                eprintln!("note: {note}");
            }
            query::sample_fields(loaded, &points, &path, sampler.as_ref())?
        }
        (None, Some(machine)) if args.exact => {
            let (machine, _) = args.inputs.machine_at(&load_machine(machine)?)?;
            let pose = args.pose.on(&machine)?;
            let points: Vec<QueryPoint> = points
                .iter()
                .map(|p| {
                    let mut p = p.clone();
                    for ((value, given), posed) in
                        p.command.iter_mut().zip(p.given).zip(pose).skip(3)
                    {
                        if !given {
                            *value = posed;
                        }
                    }
                    p
                })
                .collect();
            query::sample_exact(&machine, &points)
        }
        _ => {
            return Err(Failure::input(
                "say where the values come from: --field FILE.exr, or --exact --machine M",
            ))
        }
    };
    match &args.out {
        None => {
            let stdout = std::io::stdout();
            let mut out = std::io::BufWriter::new(stdout.lock());
            points::write_samples(&mut out, &points, &samples)
                .and_then(|()| out.flush())
                .map_err(|e| Failure::work(e).context("writing to standard output"))?;
        }
        Some(path) => {
            write_file(path, |out| points::write_samples(out, &points, &samples)).flag("--out")?
        }
    }
    Ok(ExitCode::SUCCESS)
}
