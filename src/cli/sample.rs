//! `volmap sample`: VE and OE at arbitrary commanded positions, CSV in and CSV out, interpolated
//! in a field or computed exactly from the machine model.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use volmap::io::atomic::AtomicFile;
use volmap::io::field::FieldFile;
use volmap::io::points::{
    PointBatch, PointReader, PointsError, Precision, QueryPoint, SampleWriter,
};
use volmap::io::FileError;
use volmap::model::channels::Sample;
use volmap::model::{Command, Machine};
use volmap::query::{self, FieldSampler, Outside, SampledField};

use super::args::{load_machine, DeviceArg, InputsArg, JsonArg, OptionalMachineArg, PoseArg};
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
    /// pick the part of each point's pose.
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

/// Where the values come from: a field (f32 values) or the model at a pose.
enum Source<'a> {
    Field(FieldSampler<'a>),
    Exact {
        machine: Machine,
        pose: Command,
        path: String,
        outside: Outside,
    },
}

impl Source<'_> {
    fn sample(&mut self, points: &[QueryPoint]) -> Result<Vec<Option<Sample>>, Failure> {
        match self {
            Source::Field(sampler) => Ok(sampler.sample(points)?),
            Source::Exact {
                machine,
                pose,
                path,
                outside,
            } => {
                // `--pose` sets the rotary axes the CSV has no column for.
                let points: Vec<QueryPoint> = points
                    .iter()
                    .map(|p| {
                        let mut p = p.clone();
                        for ((value, given), posed) in
                            p.command.iter_mut().zip(p.given).zip(*pose).skip(3)
                        {
                            if !given {
                                *value = posed;
                            }
                        }
                        p
                    })
                    .collect();
                query::sample_exact_within(machine, &points, path, *outside).flag("--points")
            }
        }
    }
}

pub fn run(args: SampleArgs) -> Result<ExitCode, Failure> {
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
    let (first, loaded) = rayon::join(
        || {
            let mut reader = PointReader::open(&args.points)?;
            let batch = reader.next_batch(BATCH_POINTS)?;
            Ok::<_, PointsError>((reader, batch))
        },
        || file.map(SampledField::of).transpose(),
    );
    let (mut reader, mut batch) = first.flag("--points")?;
    let loaded = loaded.flag("--field")?;
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
            let sampler = FieldSampler::new(loaded, gpu.as_ref(), &path, outside);
            (Source::Field(sampler), Precision::F32)
        }
        (None, Some(machine)) if args.exact => {
            let (machine, inputs) = args
                .inputs
                .machine_at(&load_machine(machine, &args.machine.reach)?)?;
            record = Some(format!(
                "exactly for {} at {}",
                machine.name,
                inputs.describe(&machine)
            ));
            let pose = args.pose.on(&machine)?;
            envelope = args.json.json.is_some().then(|| {
                Envelope::new("sample")
                    .machine(&machine)
                    .at_inputs(&machine, &inputs)
                    .at_pose(&machine, &pose)
            });
            query::check_exact_columns(&machine, reader.columns(), &path).flag("--points")?;
            let source = Source::Exact {
                machine,
                pose,
                path: path.clone(),
                outside,
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
    let writer = SampleWriter::start(out, reader.columns(), precision).map_err(write_error)?;
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
                writer.write(out, &prefix, &samples).map_err(write_error)?;
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
        writer.write(out, &batch, &samples).map_err(write_error)?;
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
