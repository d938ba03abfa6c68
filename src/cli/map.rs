//! `volmap map`: a machine's volumetric and orientation error over its linear travels, into an
//! OpenEXR field.

use std::path::PathBuf;
use std::process::ExitCode;

use volmap::design::shards::Shard;
use volmap::engine::map::{self, FieldStats, MapOptions};
use volmap::engine::uncertainty::UncertaintyMethod;
use volmap::engine::EngineError;
use volmap::gpu::GpuError;
use volmap::io::disk;
use volmap::io::field::{Compression, FieldError, FieldInfo, Storage};
use volmap::model::Machine;

use super::args::{
    sweep_grids, DefaultMachineArg, DeviceArg, GridArg, InputsArg, JsonArg, PoseArg, PosesArg,
};
use super::envelope::{pose_of, Envelope};
use super::failure::{Failure, FlagContext};
use super::field_report::{check_json, file_json, stats_json, sweep_json};
use super::map_report::{
    print_check, print_stored, print_summary, print_time, print_uncertainty, uncertainty_json,
    worse,
};
use super::numbers;
use super::output::progress;
use super::sweep;

#[derive(clap::Args)]
pub struct MapArgs {
    #[command(flatten)]
    machine: DefaultMachineArg,
    #[command(flatten)]
    grid: GridArg,
    #[command(flatten)]
    pose: PoseArg,
    #[command(flatten)]
    poses: PosesArg,
    /// With --poses: map only the K-th (from 0) of M equal ranges of the poses (a job of a
    /// batch scheduler's array); `merge-maps` puts the files together.
    #[arg(long, value_name = "K/M", requires = "poses")]
    shard: Option<Shard>,
    #[command(flatten)]
    inputs: InputsArg,
    /// The field file to write.
    #[arg(long, default_value = "volmap-field.exr")]
    out: PathBuf,
    #[command(flatten)]
    device: DeviceArg,
    /// Recompute N random grid points with the f64 reference and report the largest difference
    /// (exit code 4 when it exceeds 1e-6 mm or 1e-9 rad).
    #[arg(long, default_value_t = 0)]
    check: usize,
    /// Also write the field as VTK XML ImageData (.vti) for ParaView: point arrays VE (mm) and
    /// OE (rad) on the grid, written chunk by chunk as the field is.
    #[arg(long)]
    vti: Option<PathBuf>,
    /// At most this many points per chunk, and at least one grid line along X (the device's
    /// limits apply anyway).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    chunk_points: Option<u64>,
    #[command(flatten)]
    storage: StorageArg,
    #[command(flatten)]
    uncertainty: MapUncertaintyArg,
    #[command(flatten)]
    json: JsonArg,
}

/// The uncertainty of a map: a part of the field beside the values, holding the standard
/// uncertainty of every channel from the `u` and `[covariance]` of the machine file.
#[derive(clap::Args)]
pub struct MapUncertaintyArg {
    /// Add the standard uncertainty of VE and OE at every point by the GUM's first-order
    /// propagation (one pair of maps per uncertain quantity, summed on the device).
    #[arg(long, conflicts_with = "uncertainty_samples")]
    uncertainty: bool,
    /// The same by Monte Carlo (JCGM 101): the standard deviation over N machines drawn from
    /// the machine file's u and [covariance], summed on the device; with
    /// --uncertainty-adaptive, the draws of each batch.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(2..=MAX_MAP_DRAWS))]
    uncertainty_samples: Option<u32>,
    /// Monte Carlo with the adaptive stopping rule of JCGM 101 section 7.9: batches of
    /// --uncertainty-samples draws (default 10000) until every point's uncertainty and mean are
    /// stable to two significant digits (at most 100 batches).
    #[arg(long, conflicts_with = "uncertainty")]
    uncertainty_adaptive: bool,
    /// The seed of the Monte Carlo draws: the same seed gives the same machines.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// The most machines a map's Monte Carlo draws (per batch, adaptive).
const MAX_MAP_DRAWS: i64 = 1_000_000;

impl MapUncertaintyArg {
    /// The method asked for, if any; a machine without `u` refused for it.
    fn method(&self, machine: &Machine) -> Result<Option<UncertaintyMethod>, Failure> {
        let method = match (
            self.uncertainty,
            self.uncertainty_samples,
            self.uncertainty_adaptive,
        ) {
            (true, _, _) => UncertaintyMethod::FirstOrder,
            (false, draws, true) => UncertaintyMethod::Adaptive {
                batch: draws.unwrap_or(10_000) as usize,
                seed: self.seed,
            },
            (false, Some(draws), false) => UncertaintyMethod::MonteCarlo {
                draws: draws as usize,
                seed: self.seed,
            },
            (false, None, false) => return Ok(None),
        };
        if machine.uncertainty.is_empty() {
            let flag = match method {
                UncertaintyMethod::FirstOrder => "--uncertainty",
                UncertaintyMethod::MonteCarlo { .. } => "--uncertainty-samples",
                UncertaintyMethod::Adaptive { .. } => "--uncertainty-adaptive",
            };
            return Err(Failure::input(format!(
                "{flag}: {} gives no error value a standard uncertainty (`u`): there is nothing to propagate",
                machine.name
            )));
        }
        Ok(Some(method))
    }
}

/// `--compression` and `--half`: how the field file stores its values.
#[derive(clap::Args)]
pub struct StorageArg {
    /// How the field file is compressed: `none` (the f32 values as computed), `zip` (OpenEXR's
    /// ZIP, lossless) or `pxr24` (OpenEXR's PXR24: each value rounded to 24 bits, within 2^-16 of
    /// itself, about 0.76 nm on a field whose largest |VE| is 0.05 mm). Compressed on all cores
    /// while the next chunk is computed.
    #[arg(long, value_enum, default_value_t = CompressionArg::None)]
    compression: CompressionArg,
    /// 16-bit (HALF) channels, for a picture rather than a measurement: each value within
    /// 2^-11 of itself (3e-8 absolute below 6.1e-5); values beyond ±65504 are refused.
    #[arg(long)]
    half: bool,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum CompressionArg {
    None,
    Zip,
    Pxr24,
}

impl StorageArg {
    pub fn storage(&self) -> Storage {
        Storage {
            compression: match self.compression {
                CompressionArg::None => Compression::None,
                CompressionArg::Zip => Compression::Zip,
                CompressionArg::Pxr24 => Compression::Pxr24,
            },
            half: self.half,
        }
    }
}

pub fn run(args: MapArgs) -> Result<ExitCode, Failure> {
    super::output::check_distinct_outputs(&[
        ("--out", Some(args.out.as_path())),
        ("--vti", args.vti.as_deref()),
        ("--json", args.json.json.as_deref()),
    ])?;
    let loaded = args.machine.load()?;
    // The machine at the evaluation inputs: the field records them.
    let (machine, _) = args.inputs.machine_at(&loaded)?;
    let sweep = sweep_grids(&machine, &args.grid, &args.pose, &args.poses)?;
    let sweep = match args.shard {
        Some(shard) => {
            let range = shard.range(sweep.len()).flag("--shard")?;
            outln!(
                "Shard {}/{}: poses {}..{} of {}",
                shard.index,
                shard.count,
                range.start,
                range.end,
                sweep.len()
            );
            sweep[range].to_vec()
        }
        None => sweep,
    };
    let grid = sweep[0].clone();
    let grids = args.poses.poses.is_some().then_some(sweep);
    // A device or a pipe (`/dev/null`) is written directly, whatever its name.
    let device_out = disk::is_device(&args.out);
    if !device_out
        && args
            .out
            .extension()
            .is_none_or(|e| !e.eq_ignore_ascii_case("exr"))
    {
        return Err(Failure::input(format!(
            "--out {}: a field file ends in .exr",
            args.out.display()
        )));
    }
    if let Some(vti) = &args.vti {
        if vti
            .extension()
            .is_none_or(|e| !e.eq_ignore_ascii_case("vti"))
        {
            return Err(Failure::input(format!(
                "--vti {}: a VTK ImageData file ends in .vti",
                vti.display()
            )));
        }
        if grids.is_some() {
            return Err(Failure::input(
                "--vti writes the field of one pose; with --poses, `volmap plot slice --pose … --out FILE.vti` writes a slice of one",
            ));
        }
    }
    let method = args.uncertainty.method(&machine)?;
    if !device_out {
        let per_pose = if method.is_some() { 2 } else { 1 };
        let parts = per_pose * grids.as_ref().map_or(1, |g| g.len() as u64);
        let text_bytes = machine.source.toml.len()
            + machine
                .source
                .csv_files
                .iter()
                .map(|(path, text)| path.len() + text.len())
                .sum::<usize>();
        let container = volmap::io::field::container_bytes(
            grid.dims,
            args.storage.storage(),
            parts,
            text_bytes as u64,
        );
        check_space(&args, grid.points().saturating_mul(parts), container)?;
    }
    let (engine, note) = args.device.engine()?;
    if let Some(note) = note {
        errln!("volmap: {note}");
    }
    if let volmap::engine::Engine::Gpu(mapper) = &engine {
        // Tables beyond one buffer are refused before the field file is begun.
        let first = grids.as_ref().and_then(|g| g.first()).unwrap_or(&grid);
        mapper
            .check_grid_tables(&machine, first)
            .map_err(|e| map_failure(e.into(), &machine, &args.out))?;
    }
    let options = MapOptions {
        chunk_points: args.chunk_points,
        check_points: args.check,
        vtk_image: args.vti.clone(),
        storage: args.storage.storage(),
        corrupt_point_for_tests: corrupt_point_for_tests(),
        uncertainty: method,
    };
    if let Some(grids) = &grids {
        let summary = sweep::map_sweep(&machine, grids, &engine, &args.out, &options)
            .map_err(|e| map_failure(e, &machine, &args.out))?;
        sweep::print_map_summary(&machine, grids, &summary);
        print_time(summary.seconds, summary.stats.points);
        print_stored(&options.storage, summary.times.write.bytes);
        outln!(
            "  field       {} ({} parts, one per pose)",
            args.out.display(),
            grids.len()
        );
        if let Some(path) = &args.json.json {
            // Each pose's grid and pose, the machine's text left out: the JSON reads neither,
            // and a copy per pose would grow with the sweep.
            let bare = map::field_info(&machine, &grid, &summary.device).without_machine();
            let infos: Vec<FieldInfo> = grids
                .iter()
                .map(|g| FieldInfo {
                    pose_deg: [g.pose[3], g.pose[4], g.pose[5]],
                    ..bare.clone()
                })
                .collect();
            let names: Vec<String> = summary.poses.iter().map(|p| p.name.clone()).collect();
            let stats: Vec<FieldStats> = summary.poses.iter().map(|p| p.stats.clone()).collect();
            let mut result = sweep_json(
                &args.out,
                &infos,
                &names,
                &stats,
                &summary.stats,
                options.storage.describe(),
            );
            result["bytes"] = summary.times.write.bytes.into();
            result["seconds"] = summary.seconds.into();
            result["check"] = check_json(summary.check.as_ref());
            result["uncertainty"] = uncertainty_json(&bare, summary.uncertainty.as_ref());
            let poses = grids.iter().map(|g| pose_of(&machine, &g.pose)).collect();
            Envelope::new("map")
                .machine(&machine)
                .pose(serde_json::Value::Array(poses))
                .write(path, "--json", &result)?;
        }
        let names: Vec<String> = summary.poses.iter().map(|p| p.name.clone()).collect();
        let code = print_check(summary.check.as_ref(), &names);
        return Ok(match &summary.uncertainty {
            Some(u) => worse(
                code,
                print_uncertainty(
                    &map::field_info(&machine, &grid, &summary.device),
                    u,
                    &names,
                ),
            ),
            None => code,
        });
    }
    let bar = progress(Some(grid.points()), "mapping", "points");
    let summary = map::map_to_file(&machine, &grid, &engine, &args.out, &options, |done| {
        bar.set_position(done)
    });
    bar.finish_and_clear();
    let summary = summary.map_err(|e| map_failure(e, &machine, &args.out))?;

    let info = map::field_info(&machine, &grid, &summary.device);
    print_summary(&info, &summary.stats);
    print_time(summary.seconds, summary.stats.points);
    print_stored(&options.storage, summary.times.write.bytes);
    outln!("  field       {}", args.out.display());
    if let Some(vti) = &args.vti {
        outln!("  VTK image   {}", vti.display());
    }
    if let Some(path) = &args.json.json {
        let mut result = file_json(&args.out, &info, options.storage.describe());
        result["bytes"] = summary.times.write.bytes.into();
        result["seconds"] = summary.seconds.into();
        result["stats"] = stats_json(&info, &summary.stats);
        result["vti"] = args.vti.as_ref().map(|p| p.display().to_string()).into();
        result["check"] = check_json(summary.check.as_ref());
        result["uncertainty"] = uncertainty_json(&info, summary.uncertainty.as_ref());
        Envelope::new("map")
            .machine(&machine)
            .at_pose(&machine, &grid.pose)
            .write(path, "--json", &result)?;
    }
    let code = print_check(summary.check.as_ref(), &[]);
    Ok(match &summary.uncertainty {
        Some(u) => worse(code, print_uncertainty(&info, u, &[])),
        None => code,
    })
}

/// Tests corrupt the field on purpose (`VOLMAP_TEST_CORRUPT_OUTPUT=N`: grid point N of every pose
/// moved by 2 µm) to see the spot check fail; a correct engine never fails it.
fn corrupt_point_for_tests() -> Option<u64> {
    std::env::var("VOLMAP_TEST_CORRUPT_OUTPUT")
        .ok()
        .and_then(|v| v.parse().ok())
}

/// Fields larger than this say their size when they start, bytes.
const SAID_BYTES: u64 = 2_000_000_000;
/// The most a compression stores a field in, against its FLOAT values (pxr24 stores about a
/// tenth): a compressed field surely larger than the free space is refused.
const BEST_COMPRESSION: u64 = 16;

/// Refuses a field that cannot fit in the free space of its folder (uncompressed: its size;
/// compressed: a sixteenth of its values), and says the size of a large one. `container_bytes`
/// (headers, offset tables: never compressed) counts whole.
fn check_space(args: &MapArgs, points: u64, container_bytes: u64) -> Result<(), Failure> {
    let storage = args.storage.storage();
    let value_bytes = if storage.half { 2 } else { 4 };
    let bytes = points
        .saturating_mul(6 * value_bytes)
        .saturating_add(container_bytes);
    let folder = args.out.parent().unwrap_or(std::path::Path::new(""));
    let gb = |b: u64| format!("{} GB", numbers::quantity(b as f64 / 1e9));
    let compressed = !matches!(storage.compression, Compression::None);
    if let Some(free) = disk::free_bytes(folder) {
        let least = if compressed {
            (bytes - container_bytes) / BEST_COMPRESSION + container_bytes
        } else {
            bytes
        };
        if least > free {
            let least_words = if compressed {
                format!(
                    " at the least (its values take {} before compression)",
                    gb(bytes)
                )
            } else {
                String::new()
            };
            return Err(Failure::input(format!(
                "--out {}: the field needs {}{least_words}, and its folder has {} free",
                args.out.display(),
                gb(least),
                gb(free)
            )));
        }
    }
    if bytes > SAID_BYTES {
        outln!(
            "writing a field of {}{} into {}",
            gb(bytes),
            if compressed {
                " before compression"
            } else {
                ""
            },
            args.out.display()
        );
    }
    Ok(())
}

/// A failure of the map, said to have happened while mapping the machine into the file, with
/// the way round a machine the GPU refuses.
pub fn map_failure(error: EngineError, machine: &Machine, out: &std::path::Path) -> Failure {
    let angles = matches!(
        error,
        EngineError::Gpu(GpuError::ErrorAngles { .. } | GpuError::CrossAxis { .. })
    );
    let half = matches!(error, EngineError::Field(FieldError::HalfRange { .. }));
    let tables = matches!(error, EngineError::Gpu(GpuError::GridTables { .. }));
    let failure =
        Failure::from(error).context(format!("mapping {} into {}", machine.name, out.display()));
    if tables {
        failure
            .context("--grid".to_string())
            .hint("--device cpu maps it")
    } else if angles {
        failure.hint("--device cpu maps it")
    } else if half {
        failure.hint("leave out --half: FLOAT channels hold it")
    } else {
        failure
    }
}
