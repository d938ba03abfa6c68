//! The `volmap` command line.
//!
//! Exit codes: 0 success; 1 a failure while working (GPU, file system); 2 bad input (machine
//! file, grid, pose, field file, part file, CSV, command-line values); 3 `features` found a
//! feature the machine is unfit for; 4 `--check` found the field further from the f64 reference
//! than the tolerance.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod cli;

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use volmap::engine::map::{self, FieldStats, MapOptions};
use volmap::engine::{DeviceChoice, Engine};
use volmap::io::embedded;
use volmap::io::field::{FieldInfo, FieldReader};
use volmap::model::grid::{self, Grid};

/// Maps the volumetric error of multi-axis machine tools: the full chain of homogeneous
/// transforms with every measured axis error, at every point of a grid over the workspace.
#[derive(Parser)]
#[command(name = "volmap", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Map a machine's volumetric and orientation error over its linear travels into an
    /// OpenEXR field.
    Map(MapArgs),
    /// List the embedded machines.
    Machines,
    /// Print the summary of a field file written by `volmap map`.
    Info {
        /// The field file (.exr).
        file: PathBuf,
    },
    /// VE and OE at arbitrary commanded positions (CSV in, CSV out): interpolated from a field
    /// file, or exactly from the machine model.
    Sample(SampleArgs),
    /// The GD&T error each feature of a part gets from the machine, against its tolerance: the
    /// machine's capability (exit code 3 when any feature is unfit).
    Features(FeaturesArgs),
    /// Measure every path on this machine (CPU reference, CPU engine, GPU kernel, readback, EXR
    /// writing, whole maps) and print one table.
    Bench(BenchArgs),
    /// Standard accuracy tests predicted from the machine model (ISO 230-2 positioning, ISO
    /// 230-6 diagonals, ISO 230-4 circular tests, the R-test), against measured results where
    /// given.
    Test(cli::standards::TestArgs),
    /// Estimate location errors (squareness, rotary axis lines) from diagonal, circular, R-test
    /// or positioning measurements by least squares, with residual and uncertainty.
    Fit(cli::standards::FitArgs),
    /// Build a machine file from component errors measured at sparse positions (CSV per axis),
    /// with linear, quadratic or cubic elements chosen per component.
    Build(cli::standards::BuildArgs),
    /// Plots: a field slice as a colour map, the deformed workspace grid.
    Plot(cli::plots::PlotArgs),
    /// Rewrite an NC program (ISO 6983 / Fanuc) so the real tool tip lands on the programmed
    /// path: the machine's error compensated offline.
    Compensate(cli::compensate::CompensateArgs),
}

#[derive(clap::Args)]
struct SampleArgs {
    /// Positions: CSV with a header row naming X, Y, Z (mm) and optionally A, B, C (degrees).
    #[arg(long)]
    points: PathBuf,
    /// Interpolate (trilinear) in this field file; positions outside its grid are an error.
    #[arg(long, conflicts_with = "exact")]
    field: Option<PathBuf>,
    /// Compute exactly from the machine model (the f64 reference) instead of a field.
    #[arg(long, requires = "machine")]
    exact: bool,
    /// The machine for --exact: an embedded name or a machine file.
    #[arg(long)]
    machine: Option<String>,
    /// With --exact: positions of rotary axes the CSV has no column for, e.g. `B=30,C=-45`
    /// (not named: 0).
    #[arg(long, default_value = "", requires = "exact")]
    pose: String,
    /// Where to write the result (CSV); standard output when left out.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Where to interpolate in a field: `auto` uses a hardware GPU when there is one and the CPU
    /// otherwise (a CPU adapter such as lavapipe is slower at this than the CPU path).
    #[arg(long, value_enum, default_value_t = Device::Auto)]
    device: Device,
}

#[derive(clap::Args)]
struct FeaturesArgs {
    /// The part file (TOML): placement, cutter and features with their tolerances.
    #[arg(long)]
    part: PathBuf,
    /// Take the machine's error from this field file (trilinear interpolation).
    #[arg(long, conflicts_with = "machine")]
    field: Option<PathBuf>,
    /// Take the machine's error exactly from this machine (embedded name or file).
    #[arg(long)]
    machine: Option<String>,
    /// Also write the rows as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(clap::Args)]
struct BenchArgs {
    /// The machines to measure, comma-separated (embedded names or files).
    #[arg(long, default_value = "vmc-li2015,5axis-hwang2014")]
    machines: String,
    /// The grid, spanning each machine's travels.
    #[arg(long, default_value = "128x128x128")]
    grid: String,
    /// Rotary axes' positions in degrees for machines that have them.
    #[arg(long, default_value = "B=30,C=60")]
    pose: String,
    /// Points the single-thread f64 reference computes (its rate does not depend on how many).
    #[arg(long, default_value_t = 100_000)]
    reference_points: u64,
    /// Where to compute the GPU paths: `auto` measures them when an adapter exists.
    #[arg(long, value_enum, default_value_t = Device::Auto)]
    device: Device,
    /// Also write the figures as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(clap::Args)]
struct MapArgs {
    /// An embedded machine's name (see `volmap machines`) or a machine file (TOML).
    #[arg(long, default_value = embedded::DEFAULT_MACHINE)]
    machine: String,
    /// Grid points along X, Y and Z, spanning each axis's full travel.
    #[arg(long, default_value = "64x64x64")]
    grid: String,
    /// Positions of the rotary axes in degrees, e.g. `B=30,C=-45`; axes not named are at 0.
    #[arg(long, default_value = "")]
    pose: String,
    /// The field file to write.
    #[arg(long, default_value = "volmap-field.exr")]
    out: PathBuf,
    /// Where to compute: `auto` uses the GPU when an adapter exists and the CPU otherwise.
    #[arg(long, value_enum, default_value_t = Device::Auto)]
    device: Device,
    /// Recompute N random grid points with the f64 reference and report the largest difference
    /// (exit code 4 when it exceeds 1e-6 mm or 1e-9 rad).
    #[arg(long, default_value_t = 0)]
    check: usize,
    /// At most this many points per chunk (the device's limits apply anyway).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    chunk_points: Option<u64>,
}

#[derive(Clone, Copy, ValueEnum)]
enum Device {
    Auto,
    Gpu,
    Cpu,
}

impl From<Device> for DeviceChoice {
    fn from(device: Device) -> DeviceChoice {
        match device {
            Device::Auto => DeviceChoice::Auto,
            Device::Gpu => DeviceChoice::Gpu,
            Device::Cpu => DeviceChoice::Cpu,
        }
    }
}

/// A failure with the exit code it maps to.
struct Failure {
    code: u8,
    error: anyhow::Error,
}

/// Exit code 1 when the device failed, 2 when the input is at fault.
fn query_failure(error: volmap::query::QueryError) -> Failure {
    match error {
        volmap::query::QueryError::Gpu(_) | volmap::query::QueryError::NoAdapter => Failure {
            code: 1,
            error: error.into(),
        },
        _ => bad_input(error),
    }
}

fn bad_input(error: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 2,
        error: error.into(),
    }
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(error: E) -> Failure {
        Failure {
            code: 1,
            error: error.into(),
        }
    }
}

/// Writes a file through a temporary file in its folder, renamed into place once complete, so a
/// failed run never leaves half a file.
fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> anyhow::Result<()> {
    let temp = path.with_file_name(format!(
        ".{}.part",
        path.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    ));
    let result = (|| -> std::io::Result<()> {
        let mut out = std::io::BufWriter::new(std::fs::File::create(&temp)?);
        write(&mut out)?;
        out.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&temp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result.with_context(|| format!("writing {}", path.display()))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Map(args) => run_map(args),
        Command::Machines => list_machines(),
        Command::Info { file } => run_info(&file),
        Command::Sample(args) => run_sample(args),
        Command::Features(args) => run_features(args),
        Command::Bench(args) => run_bench(args),
        Command::Test(args) => cli::standards::run_test(args),
        Command::Fit(args) => cli::standards::run_fit(args),
        Command::Build(args) => cli::standards::run_build(args),
        Command::Plot(args) => cli::plots::run_plot(args),
        Command::Compensate(args) => cli::compensate::run_compensate(args),
    };
    match result {
        Ok(code) => code,
        Err(failure) => {
            eprintln!("error: {:#}", failure.error);
            ExitCode::from(failure.code)
        }
    }
}

fn list_machines() -> Result<ExitCode, Failure> {
    println!("{:<18} {:<9} {:<6} description", "name", "chain", "axes");
    for (name, _) in embedded::EMBEDDED {
        let machine = embedded::embedded(name)
            .expect("listed")
            .with_context(|| format!("embedded machine {name}"))?;
        let axes = machine.chain.axes().count();
        println!(
            "{name:<18} {:<9} {axes:<6} {}",
            machine.chain.hwang_notation(),
            machine.description
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn run_map(args: MapArgs) -> Result<ExitCode, Failure> {
    let machine = embedded::load(&args.machine).map_err(bad_input)?;
    let dims = grid::parse_dims(&args.grid).map_err(bad_input)?;
    let pose = grid::parse_pose(&args.pose, &machine).map_err(bad_input)?;
    let grid = Grid::full_travel(&machine, dims, pose).map_err(bad_input)?;
    if args
        .out
        .extension()
        .is_none_or(|e| !e.eq_ignore_ascii_case("exr"))
    {
        return Err(bad_input(anyhow::anyhow!(
            "--out {}: a field file ends in .exr",
            args.out.display()
        )));
    }
    let (engine, note) = Engine::select(args.device.into())?;
    if let Some(note) = note {
        eprintln!("volmap: {note}");
    }

    let bar = ProgressBar::with_draw_target(Some(grid.points()), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} mapping [{bar:40}] {percent:>3}% {human_pos}/{human_len} points, {eta} left",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    let options = MapOptions {
        chunk_points: args.chunk_points,
        check_points: args.check,
    };
    let summary = map::map_to_file(&machine, &grid, &engine, &args.out, &options, |done| {
        bar.set_position(done)
    })
    .with_context(|| format!("mapping {} into {}", machine.name, args.out.display()))?;
    bar.finish_and_clear();

    let info = map::field_info(&machine, &grid, &summary.device);
    print_summary(&info, &summary.stats);
    println!(
        "  time        {:.3} s, {:.2} Mpts/s",
        summary.seconds,
        summary.stats.points as f64 / summary.seconds.max(1e-9) / 1e6
    );
    println!("  field       {}", args.out.display());
    if let Some(check) = &summary.check {
        println!(
            "  check       {} points against the f64 reference: max ΔVE {:.3e} mm, max ΔOE {:.3e} rad (tolerance {:e} mm, {:e} rad): {}",
            check.points,
            check.max_ve_diff_mm,
            check.max_oe_diff_rad,
            map::VE_TOLERANCE_MM,
            map::OE_TOLERANCE_RAD,
            if check.passed() { "ok" } else { "FAILED" }
        );
        if !check.passed() {
            return Ok(ExitCode::from(4));
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn print_summary(info: &FieldInfo, stats: &FieldStats) {
    let grid = info.grid();
    let ijk = grid.indices(stats.max_ve_point);
    let command = grid.command(ijk);
    let at: Vec<String> = (0..3)
        .map(|d| format!("{}={:.3}", ["X", "Y", "Z"][d], command[d]))
        .collect();
    let pose: Vec<String> = info
        .pose_axes
        .chars()
        .map(|a| {
            let index = "ABC".find(a).unwrap_or(0);
            format!("{a}={}°", info.pose_deg[index])
        })
        .collect();
    println!(
        "volmap: {} ({}), grid {}x{}x{} = {} points{}",
        info.machine_name,
        info.chain,
        info.dims[0],
        info.dims[1],
        info.dims[2],
        stats.points,
        if pose.is_empty() {
            String::new()
        } else {
            format!(", pose {}", pose.join(" "))
        }
    );
    println!("  device      {}", info.device);
    println!(
        "  max |VE|    {:.6} mm at point ({}, {}, {}): {} mm",
        stats.max_ve_mm,
        ijk[0],
        ijk[1],
        ijk[2],
        at.join(" ")
    );
    println!("  RMS |VE|    {:.6} mm", stats.rms_ve_mm());
    println!("  max |OE|    {:.3e} rad", stats.max_oe_rad);
}

fn run_info(path: &Path) -> Result<ExitCode, Failure> {
    let mut reader = FieldReader::open(path).map_err(bad_input)?;
    let info = reader.info().clone();
    let mut stats = FieldStats::default();
    let nx = info.dims[0];
    let lines_per_chunk = (1u64 << 20) / nx as u64;
    reader
        .for_each_chunk(lines_per_chunk, |first, lines, data| {
            stats.add_chunk(first, lines, nx, data)
        })
        .map_err(bad_input)?;
    print_summary(&info, &stats);
    println!("  field       {}", path.display());
    Ok(ExitCode::SUCCESS)
}

fn run_bench(args: BenchArgs) -> Result<ExitCode, Failure> {
    let dims = grid::parse_dims(&args.grid).map_err(bad_input)?;
    let mut machines = Vec::new();
    for name in args
        .machines
        .split(',')
        .map(str::trim)
        .filter(|n| !n.is_empty())
    {
        let machine = embedded::load(name).map_err(bad_input)?;
        // Each machine takes the rotary positions of --pose that it has axes for.
        let pose_text: Vec<&str> = args
            .pose
            .split(',')
            .filter(|p| {
                p.trim()
                    .chars()
                    .next()
                    .and_then(volmap::model::AxisLetter::from_char)
                    .is_some_and(|l| machine.chain.contains(l))
            })
            .collect();
        let pose = grid::parse_pose(&pose_text.join(","), &machine).map_err(bad_input)?;
        let grid = Grid::full_travel(&machine, dims, pose).map_err(bad_input)?;
        machines.push((machine, grid));
    }
    let (engine, note) = Engine::select(args.device.into())?;
    if note.is_some() {
        eprintln!("volmap: no GPU adapter found: GPU paths left out");
    }
    let scratch = std::env::temp_dir().join(format!("volmap-bench-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).with_context(|| format!("creating {}", scratch.display()))?;
    let mut results = Vec::new();
    for (machine, grid) in &machines {
        let result = volmap::bench::bench_machine(
            machine,
            grid,
            &engine,
            &scratch,
            args.reference_points,
            |step| eprintln!("bench: {}: {step}", machine.name),
        );
        results.push(result.with_context(|| format!("benchmarking {}", machine.name))?);
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let report = volmap::bench::BenchReport {
        date: volmap::bench::today(),
        adapter: match &engine {
            Engine::Gpu(g) => Some(g.adapter_name().to_string()),
            Engine::Cpu => None,
        },
        cpu: volmap::bench::cpu_name(),
        threads: rayon::current_num_threads(),
        machines: results,
    };
    print!("{}", volmap::bench::table(&report));
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report).context("encoding the report")?;
        write_atomically(path, |out| writeln!(out, "{text}"))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn run_sample(args: SampleArgs) -> Result<ExitCode, Failure> {
    use volmap::query;
    // The points and the field are read side by side: both are mostly parsing.
    let (points, loaded) = rayon::join(
        || volmap::io::points::read_points(&args.points),
        || {
            args.field
                .as_deref()
                .map(volmap::io::field::LoadedField::open)
                .transpose()
        },
    );
    let points = points.map_err(bad_input)?;
    let loaded = loaded.map_err(bad_input)?;
    let samples = match (&loaded, &args.machine) {
        (Some(loaded), _) => {
            let path = args.points.display().to_string();
            let (sampler, note) = query::open_sampler(args.device.into())?;
            if let Some(note) = note {
                eprintln!("note: {note}");
            }
            match &sampler {
                Some(sampler) => query::sample_field_gpu(loaded, &points, &path, sampler),
                None => query::sample_field(loaded, &points, &path),
            }
            .map_err(query_failure)?
        }
        (None, Some(machine)) if args.exact => {
            let machine = embedded::load(machine).map_err(bad_input)?;
            let pose = grid::parse_pose(&args.pose, &machine).map_err(bad_input)?;
            let points: Vec<volmap::io::points::QueryPoint> = points
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
            return Err(bad_input(anyhow::anyhow!(
                "say where the values come from: --field FILE.exr, or --exact --machine M"
            )))
        }
    };
    match &args.out {
        None => {
            let stdout = std::io::stdout();
            let mut out = std::io::BufWriter::new(stdout.lock());
            volmap::io::points::write_samples(&mut out, &points, &samples)
                .context("writing to standard output")?;
            out.flush().context("writing to standard output")?;
        }
        Some(path) => write_atomically(path, |out| {
            volmap::io::points::write_samples(out, &points, &samples)
        })?,
    }
    Ok(ExitCode::SUCCESS)
}

fn run_features(args: FeaturesArgs) -> Result<ExitCode, Failure> {
    use volmap::part::{ErrorSource, PartFile, Verdict};
    let part_name = args.part.display().to_string();
    let part = PartFile::read(&args.part).map_err(bad_input)?;
    let field;
    let machine;
    let source = match (&args.field, &args.machine) {
        (Some(path), _) => {
            field = volmap::io::field::LoadedField::open(path).map_err(bad_input)?;
            ErrorSource::Field(&field)
        }
        (None, Some(name)) => {
            machine = embedded::load(name).map_err(bad_input)?;
            ErrorSource::Exact(&machine)
        }
        (None, None) => {
            return Err(bad_input(anyhow::anyhow!(
                "say where the machine's error comes from: --field FILE.exr or --machine M"
            )))
        }
    };
    let rows = volmap::part::evaluate(&part, source, &part_name).map_err(bad_input)?;
    println!("{} ({} features)", part.name, rows.len());
    println!(
        "  {:<24} {:<18} {:>12} {:>12} {:>8}  {:<8} worst point (commanded X Y Z, mm)",
        "feature", "kind", "error mm", "tolerance mm", "safety", "verdict"
    );
    for r in &rows {
        let safety = r.safety.map_or("-".to_string(), |s| format!("{s:.2}"));
        let verdict = match r.verdict {
            Verdict::Unfit => "unfit",
            Verdict::Inspect => "inspect",
            Verdict::Fit => "fit",
        };
        let area = r.area_outside.map_or(String::new(), |a| {
            format!("  ({:.1}% of the area outside the zone)", 100.0 * a)
        });
        println!(
            "  {:<24} {:<18} {:>12.6} {:>12.6} {:>8}  {:<8} {:.3} {:.3} {:.3}{area}",
            r.name,
            r.kind,
            r.error_mm,
            r.tolerance_mm,
            safety,
            verdict,
            r.worst_point[0],
            r.worst_point[1],
            r.worst_point[2]
        );
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&rows).context("encoding the rows")?;
        write_atomically(path, |out| writeln!(out, "{text}"))?;
    }
    if rows.iter().any(|r| r.verdict == Verdict::Unfit) {
        return Ok(ExitCode::from(3));
    }
    Ok(ExitCode::SUCCESS)
}
