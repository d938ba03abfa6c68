//! `volmap bench`: every path measured on this machine, one table.

use std::process::ExitCode;

use volmap::bench::{self, BenchReport};
use volmap::engine::Engine;
use volmap::io::atomic::ScratchDir;
use volmap::model::grid::Grid;
use volmap::model::poses;
use volmap::model::AxisLetter;

use super::args::{load_machine_flag, DeviceArg, GridArg, JsonArg, PoseArg, ReachArg};
use super::envelope::Envelope;
use super::failure::{Failure, FlagContext};

#[derive(clap::Args)]
#[command(mut_arg("grid", |a| a.default_value("128x128x128")))]
#[command(mut_arg("pose", |a| a.default_value("B=30,C=60").help("Positions of the rotary axes in degrees, for the machines that have them")))]
pub struct BenchArgs {
    /// The machines to measure, comma-separated (embedded names or files).
    #[arg(long, default_value = "vmc-li2015,5axis-hwang2014")]
    machines: String,
    #[command(flatten)]
    reach: ReachArg,
    #[command(flatten)]
    grid: GridArg,
    #[command(flatten)]
    pose: PoseArg,
    /// Points the single-thread f64 reference computes (its rate does not depend on how many).
    #[arg(long, default_value_t = 100_000, value_parser = clap::value_parser!(u64).range(1..=100_000_000))]
    reference_points: u64,
    /// Runs of every path: each figure is their median, printed with the slowest and fastest.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=1000))]
    runs: u64,
    #[command(flatten)]
    device: DeviceArg,
    #[command(flatten)]
    json: JsonArg,
}

pub fn run(args: BenchArgs) -> Result<ExitCode, Failure> {
    super::output::check_distinct_outputs(&[("--json", args.json.json.as_deref())])?;
    let mut machines = Vec::new();
    for name in args
        .machines
        .split(',')
        .map(str::trim)
        .filter(|n| !n.is_empty())
    {
        let machine = load_machine_flag(name, &args.reach, "--machines")?;
        // Each machine takes the rotary positions of --pose that it has axes for.
        let pose_text: Vec<&str> = args
            .pose
            .pose
            .split(',')
            .filter(|p| {
                p.trim()
                    .chars()
                    .next()
                    .and_then(AxisLetter::from_char)
                    .is_some_and(|l| machine.chain.contains(l))
            })
            .collect();
        let pose = poses::parse_pose(&pose_text.join(","), &machine).flag("--pose")?;
        let grid = Grid::full_travel(&machine, args.grid.grid, pose).flag("--grid")?;
        machines.push((machine, grid));
    }
    let scratch = scratch_dir()?;
    let mut results = Vec::new();
    let mut adapter = None;
    for (n, (machine, grid)) in machines.iter().enumerate() {
        // A fresh engine per machine: on a GPU a new device, so nothing the machine before
        // allocated or compiled is held or reused, whatever the order of the machines.
        let (engine, note) = args.device.engine()?;
        if note.is_some() && n == 0 {
            errln!("volmap: no GPU adapter found: GPU paths left out");
        }
        if let Engine::Gpu(g) = &engine {
            adapter = Some(g.adapter_name().to_string());
        }
        let result = bench::bench_machine(
            machine,
            grid,
            &engine,
            scratch.path(),
            args.reference_points,
            args.runs as usize,
            |step| errln!("bench: {}: {step}", machine.name),
        );
        drop(engine);
        results.push(
            result
                .map_err(|e| Failure::from(e).context(format!("benchmarking {}", machine.name)))?,
        );
    }
    drop(scratch);
    let report = BenchReport {
        date: today(),
        adapter,
        cpu: cpu_name(),
        threads: rayon::current_num_threads(),
        runs: args.runs as usize,
        warm_up_s: bench::WARM_UP_SECONDS,
        machines: results,
    };
    out!("{}", bench::table(&report));
    if let Some(path) = &args.json.json {
        // Several machines: the envelope names none; each result names its own.
        Envelope::new("bench").write(path, "--json", &report)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// A scratch folder for the fields the benchmarks write, removed when the run ends, however it
/// ends (Ctrl-C and `kill` included).
fn scratch_dir() -> Result<ScratchDir, Failure> {
    let scratch = std::env::temp_dir().join(format!("volmap-bench-{}", std::process::id()));
    ScratchDir::create(&scratch)
        .map_err(|e| Failure::from(e).context(format!("creating {}", scratch.display())))
}

/// The CPU's model name (Linux), or the architecture.
fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, name)| name.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

/// Today's UTC date from the system clock (civil-from-days, proleptic Gregorian).
fn today() -> String {
    let days = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() / 86_400) as i64;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}
