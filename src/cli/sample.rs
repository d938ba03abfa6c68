//! `volmap sample`: VE and OE at arbitrary commanded positions, CSV in and CSV out, interpolated
//! in a field or computed exactly from the machine model.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use rayon::prelude::*;
use volmap::io::atomic::AtomicFile;
use volmap::io::field::FieldFile;
use volmap::io::points::{
    PointBatch, PointReader, PointsError, Precision, QueryPoint, SampleWriter, VeUncertainty,
};
use volmap::io::FileError;
use volmap::model::channels::Sample;
use volmap::model::{Command, Machine};
use volmap::query::{self, FieldSampler, Outside, SampledField};
use volmap::reference::Propagation;

use super::args::{
    load_machine, Device, DeviceArg, InputsArg, JsonArg, OptionalMachineArg, PoseArg,
};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};

#[derive(clap::Args)]
#[command(mut_arg("pose", |a| a.requires("exact")))]
pub struct SampleArgs {
    /// Positions: CSV with a header row naming X, Y, Z (mm) and optionally A, B, C (degrees), in
    /// either case; other columns (an id) are carried through to the answer.
    #[arg(long)]
    points: PathBuf,
    /// Interpolate (trilinear) in this field file; positions outside its grid are an error
    /// unless --outside says otherwise. In a five-axis map (`map --poses`) the rotary columns
    /// pick the part of each point's pose. A field mapped with its uncertainties (`map
    /// --uncertainty`) adds the columns u(VE.X), u(VE.Y), u(VE.Z) (mm), interpolated in them.
    #[arg(long, conflicts_with = "exact")]
    field: Option<PathBuf>,
    /// A position outside the field's grid (with --exact: outside the machine's travels):
    /// `error` stops naming its line, `skip` leaves its row out, `nan` answers NaN (a field is
    /// never extrapolated). Default: error.
    #[arg(long, value_enum)]
    outside: Option<OutsideArg>,
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
    /// With --exact: add the first-order standard uncertainty (GUM) of VE, columns u(VE.X),
    /// u(VE.Y), u(VE.Z) (mm), from the u the machine file gives its error values and its
    /// [covariance] (on the CPU).
    #[arg(long, requires = "exact", conflicts_with = "uncertainty_samples")]
    uncertainty: bool,
    /// With --exact: the same columns by Monte Carlo: the standard deviation of VE over N
    /// machines drawn from the u and [covariance] of the machine file (on the CPU).
    #[arg(long, value_name = "N", requires = "exact", value_parser = clap::value_parser!(u32).range(2..=MAX_UNCERTAINTY_SAMPLES))]
    uncertainty_samples: Option<u32>,
    /// The seed of the Monte Carlo draws of --uncertainty-samples: the same seed gives the same
    /// machines.
    #[arg(long, default_value_t = 1, requires = "uncertainty_samples")]
    seed: u64,
    /// Where to write the result (CSV); standard output when left out.
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    device: DeviceArg,
    #[command(flatten)]
    json: JsonArg,
}

/// `--outside`: what to do with a position outside the field's grid.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum OutsideArg {
    Error,
    Skip,
    Nan,
}

/// Positions read, sampled and written at a time: memory holds one batch however many points
/// the file has.
const BATCH_POINTS: usize = 65_536;

/// The most machines `--uncertainty-samples` draws: each is a pass over every point.
const MAX_UNCERTAINTY_SAMPLES: i64 = 1_000_000;

/// How the standard uncertainty of VE is found, where it is asked for.
enum Uncertainty {
    FirstOrder,
    MonteCarlo { draws: usize, seed: u64 },
}

/// Where the values come from: a field (f32 values, with the standard uncertainties of VE
/// where the field holds them) or the model at a pose.
enum Source<'a> {
    Field {
        values: FieldSampler<'a>,
        /// Boxed: a sampler is large beside the exact source.
        uncertainty: Option<Box<FieldSampler<'a>>>,
    },
    Exact {
        machine: Machine,
        pose: Command,
        path: String,
        outside: Outside,
        /// Boxed: the prepared machines are large beside a field's sampler.
        uncertainty: Option<Box<(Propagation, Uncertainty)>>,
    },
}

impl Source<'_> {
    fn sample(&mut self, points: &[QueryPoint]) -> Result<Vec<Option<Sample>>, Failure> {
        match self {
            Source::Field { values, .. } => Ok(values.sample(points)?),
            Source::Exact {
                machine,
                pose,
                path,
                outside,
                ..
            } => {
                let points = posed(points, pose);
                query::sample_exact_within(machine, &points, path, *outside).flag("--points")
            }
        }
    }

    /// The standard uncertainty of VE at each sampled point (NaN where the sample is NaN, at
    /// a position outside the travels or the grid); none where it is not asked for or the
    /// field holds none.
    fn uncertainty(
        &mut self,
        points: &[QueryPoint],
        samples: &[Option<Sample>],
    ) -> Result<Vec<VeUncertainty>, Failure> {
        if let Source::Field {
            uncertainty: Some(sampler),
            ..
        } = self
        {
            // Interpolated in the part of uncertainties as the values are in theirs: the same
            // cells, so the same positions are outside.
            let u = sampler.sample(points)?;
            return Ok(u
                .iter()
                .map(|u| u.map_or([f64::NAN; 3], |u| [u[0], u[1], u[2]]))
                .collect());
        }
        let Source::Exact {
            pose,
            uncertainty: Some(prepared),
            ..
        } = self
        else {
            return Ok(Vec::new());
        };
        let (propagation, how) = &**prepared;
        let points = posed(points, pose);
        let inside: Vec<Command> = points
            .iter()
            .zip(samples)
            .filter(|(_, s)| s.is_some_and(|s| !s[0].is_nan()))
            .map(|(p, _)| p.command)
            .collect();
        let values: Vec<VeUncertainty> = match how {
            Uncertainty::FirstOrder => inside
                .par_iter()
                .map(|c| {
                    let u = propagation.first_order(c);
                    [u[0], u[1], u[2]]
                })
                .collect(),
            Uncertainty::MonteCarlo { draws, seed } => {
                let mc = propagation
                    .monte_carlo(&inside, *draws, *seed)
                    .map_err(|_| {
                        Failure::input("the covariance matrix is not positive semi-definite")
                    })?;
                mc.std.iter().map(|s| [s[0], s[1], s[2]]).collect()
            }
        };
        let mut values = values.into_iter();
        Ok(samples
            .iter()
            .map(|s| match s {
                Some(s) if !s[0].is_nan() => values.next().expect("one per point inside"),
                _ => [f64::NAN; 3],
            })
            .collect())
    }
}

/// The points with `--pose` setting the rotary axes the CSV has no column for.
fn posed(points: &[QueryPoint], pose: &Command) -> Vec<QueryPoint> {
    points
        .iter()
        .map(|p| {
            let mut p = p.clone();
            for ((value, given), posed) in p.command.iter_mut().zip(p.given).zip(*pose).skip(3) {
                if !given {
                    *value = posed;
                }
            }
            p
        })
        .collect()
}

pub fn run(args: SampleArgs) -> Result<ExitCode, Failure> {
    let mut uncertainty = match (args.uncertainty, args.uncertainty_samples) {
        (true, _) => Some(Uncertainty::FirstOrder),
        (false, Some(draws)) => Some(Uncertainty::MonteCarlo {
            draws: draws as usize,
            seed: args.seed,
        }),
        (false, None) => None,
    };
    if uncertainty.is_some() && args.device.device == Device::Gpu {
        let flag = if args.uncertainty {
            "--uncertainty"
        } else {
            "--uncertainty-samples"
        };
        return Err(Failure::input(format!(
            "{flag} is computed on the CPU only, for now: leave out --device gpu (or say --device cpu)"
        )));
    }
    super::output::check_distinct_outputs(&[
        ("--out", args.out.as_deref()),
        ("--json", args.json.json.as_deref()),
    ])?;
    // The field's headers first: it must hold the inputs asked for.
    let file = args
        .field
        .as_deref()
        .map(|path| {
            volmap::io::source::note_source(path);
            FieldFile::open(path)
        })
        .transpose()
        .flag("--field")?;
    if let Some(file) = &file {
        args.inputs.check_field(file)?;
    }
    // What the answer was computed for (every output records its inputs): said on standard
    // output beside a file written with --out; the CSV itself stays plain for its readers.
    let mut record = file
        .as_ref()
        .map(|f| format!("from {} at {}", f.path().display(), f.inputs(0).describe()));
    // The pose of a five-axis map's points is each point's own.
    // Only a report needs it: hashing the machine's files is work a plain run need not do.
    let mut field_envelope = file.as_ref().filter(|_| args.json.json.is_some()).map(|f| {
        Envelope::new("sample")
            .field(&f.info(0))
            .pose(serde_json::Value::Null)
    });
    // The first points and the field are read side by side: both are mostly parsing.
    // A five-axis map's parts are read later, one by one, as the points ask for them.
    // The part of uncertainties is read through a second opening of the file, as the values
    // are through the first.
    let field_u = file
        .as_ref()
        .filter(|f| f.has_uncertainties())
        .map(|f| FieldFile::open(f.path()))
        .transpose()
        .flag("--field")?;
    let method = file
        .as_ref()
        .filter(|f| f.has_uncertainties())
        .and_then(|f| f.uncertainty(0))
        .map(String::from);
    let (first, (loaded, loaded_u)) = rayon::join(
        || {
            let mut reader = PointReader::open(&args.points)?;
            let batch = reader.next_batch(BATCH_POINTS)?;
            Ok::<_, PointsError>((reader, batch))
        },
        || {
            rayon::join(
                || file.map(SampledField::of).transpose(),
                || field_u.map(SampledField::uncertainty_of).transpose(),
            )
        },
    );
    let (mut reader, mut batch) = first.flag("--points")?;
    let loaded = loaded.flag("--field")?;
    let loaded_u = loaded_u.flag("--field")?.flatten();
    let path = args.points.display().to_string();
    let gpu;
    let outside = match args.outside {
        None | Some(OutsideArg::Error) => Outside::Error,
        Some(OutsideArg::Skip) => Outside::Skip,
        Some(OutsideArg::Nan) => Outside::Nan,
    };
    let envelope;
    let (mut source, precision) = match (&loaded, &args.machine.machine) {
        (Some(loaded), _) => {
            envelope = field_envelope.take();
            let (sampler, note) = args.device.sampler()?;
            if let Some(note) = note {
                errln!("note: {note}");
            }
            gpu = sampler;
            let values = FieldSampler::new(loaded, gpu.as_ref(), &path, outside);
            // The uncertainties on the device the values are sampled on.
            let uncertainty = loaded_u
                .as_ref()
                .map(|u| Box::new(FieldSampler::new(u, gpu.as_ref(), &path, outside)));
            if let (Some(record), Some(_)) = (&mut record, &uncertainty) {
                record.push_str(", with the uncertainty of VE it holds");
            }
            (
                Source::Field {
                    values,
                    uncertainty,
                },
                Precision::F32,
            )
        }
        (None, Some(machine)) if args.exact => {
            let (machine, inputs) = args
                .inputs
                .machine_at(&load_machine(machine, &args.machine.reach)?)?;
            record = Some(format!(
                "exactly for {} at {}{}",
                machine.name,
                inputs.describe(&machine),
                match &uncertainty {
                    Some(Uncertainty::FirstOrder) => ", with the first-order uncertainty of VE",
                    Some(Uncertainty::MonteCarlo { .. }) =>
                        ", with the uncertainty of VE by Monte Carlo",
                    None => "",
                }
            ));
            let pose = args.pose.on(&machine)?;
            envelope = args.json.json.is_some().then(|| {
                Envelope::new("sample")
                    .machine(&machine)
                    .at_inputs(&machine, &inputs)
                    .at_pose(&machine, &pose)
            });
            query::check_exact_columns(&machine, reader.columns(), &path).flag("--points")?;
            if uncertainty.is_some() && machine.uncertainty.is_empty() {
                errln!(
                    "note: {} gives no error value a u: every standard uncertainty is 0",
                    machine.name
                );
            }
            let uncertainty = uncertainty
                .take()
                .map(|how| Box::new((Propagation::new(&machine), how)));
            let source = Source::Exact {
                machine,
                pose,
                path: path.clone(),
                outside,
                uncertainty,
            };
            (source, Precision::F64)
        }
        _ => {
            return Err(Failure::input(
                "say where the values come from: --field FILE.exr, or --exact --machine M",
            ))
        }
    };
    let mut file_out = args
        .out
        .as_deref()
        .map(|path| AtomicFile::create(path, 1 << 20))
        .transpose()
        .flag("--out")?;
    let stdout = std::io::stdout();
    let mut stdout = std::io::BufWriter::with_capacity(1 << 20, stdout.lock());
    let out: &mut dyn Write = match &mut file_out {
        Some(file) => file,
        None => &mut stdout,
    };
    let write_error = |e: std::io::Error| match &args.out {
        Some(path) => Failure::from(FileError::write(path, e)).context("--out"),
        None => super::output::stdout_failed(&e),
    };
    let with_uncertainty = matches!(
        source,
        Source::Exact {
            uncertainty: Some(_),
            ..
        } | Source::Field {
            uncertainty: Some(_),
            ..
        }
    );
    let writer = SampleWriter::start_with(out, reader.columns(), precision, with_uncertainty)
        .map_err(write_error)?;
    let (mut outside_count, mut first_outside, mut sampled) = (0usize, None, 0usize);
    let mut read = 0usize;
    while !batch.points.is_empty() {
        read += batch.points.len();
        // The next batch is read while this one is sampled.
        let (samples, next) = rayon::join(
            || source.sample(&batch.points),
            || reader.next_batch(BATCH_POINTS),
        );
        let samples = match samples {
            Ok(samples) => samples,
            Err(error) => {
                // The rows before the failing position are written, as everywhere else.
                let (prefix, samples) = sampled_prefix(&mut source, &batch);
                let uncertainties = source.uncertainty(&prefix.points, &samples)?;
                writer
                    .write_with(out, &prefix, &samples, &uncertainties)
                    .map_err(write_error)?;
                out.flush().map_err(write_error)?;
                return Err(error);
            }
        };
        for (p, s) in batch.points.iter().zip(&samples) {
            if s.is_none_or(|s| s[0].is_nan()) {
                outside_count += 1;
                first_outside.get_or_insert(p.line);
            }
        }
        let uncertainties = source.uncertainty(&batch.points, &samples)?;
        writer
            .write_with(out, &batch, &samples, &uncertainties)
            .map_err(write_error)?;
        sampled += samples.iter().filter(|s| s.is_some()).count();
        batch = next.flag("--points")?;
    }
    out.flush().map_err(write_error)?;
    if let Some(file) = file_out {
        file.commit().flag("--out")?;
        if let (Some(path), Some(record)) = (&args.out, &record) {
            outln!("{}: {sampled} position(s) sampled {record}", path.display());
        }
    }
    if let Some(draws) = args.uncertainty_samples {
        let relative = 100.0 / (2.0 * (f64::from(draws) - 1.0)).sqrt();
        errln!(
            "note: u(VE) by Monte Carlo over {draws} machines (seed {}): each carries a standard error of {relative:.2} % of itself",
            args.seed
        );
    }
    if let Some(line) = first_outside {
        let done = match outside {
            Outside::Skip => "left out",
            _ => "answered NaN",
        };
        let of = if args.exact {
            "the machine's travels"
        } else {
            "the field's grid"
        };
        errln!(
            "note: {outside_count} position(s) outside {of} {done} (--outside), \
             the first at line {line} of {path}"
        );
    }
    if let (Some(json), Some(envelope)) = (&args.json.json, &envelope) {
        let result = serde_json::json!({
            "points": read,
            "sampled": sampled,
            "outside": outside_count,
            "first_outside_line": first_outside,
            "outside_rule": match outside {
                Outside::Error => "error",
                Outside::Skip => "skip",
                Outside::Nan => "nan",
            },
            "precision": match precision {
                Precision::F32 => "f32",
                Precision::F64 => "f64",
            },
            "out": args.out.as_ref().map(|p| p.display().to_string()),
            "uncertainty": match (args.uncertainty, args.uncertainty_samples, &method) {
                (true, _, _) => serde_json::json!({ "method": "first_order" }),
                (false, Some(draws), _) => serde_json::json!({
                    "method": "monte_carlo", "draws": draws, "seed": args.seed,
                }),
                // The field's own words (its header's volmap.uncertainty), as `info` reports.
                (false, None, Some(method)) => serde_json::json!({
                    "method": method, "from": "field",
                }),
                (false, None, None) => serde_json::Value::Null,
            },
        });
        envelope.write(json, "--json", &result)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The longest start of `batch` that samples without an error (found by halving: the error
/// path alone pays for it), with its samples.
fn sampled_prefix(source: &mut Source, batch: &PointBatch) -> (PointBatch, Vec<Option<Sample>>) {
    // Invariant: the first `good` positions sample, the first `bad` do not.
    let (mut good, mut bad) = (0, batch.points.len());
    let mut kept = Vec::new();
    while bad - good > 1 {
        let mid = (good + bad) / 2;
        match source.sample(&batch.points[..mid]) {
            Ok(samples) => {
                good = mid;
                kept = samples;
            }
            Err(_) => bad = mid,
        }
    }
    let prefix = PointBatch {
        points: batch.points[..good].to_vec(),
        rows: batch.rows[..good].to_vec(),
    };
    (prefix, kept)
}
