//! The campaign runner of volmap's fuzzing harness (the library of this crate):
//!
//! ```text
//! cargo run --release -p volmap-fuzz -- --target machine --executions 10000000 --seed 1
//! cargo run --release -p volmap-fuzz -- --target all --executions 100000
//! cargo run --release -p volmap-fuzz -- --target gcode --replay target/fuzz-findings/gcode-panic-seed1-execution42.bin
//! cargo run --release -p volmap-fuzz -- --target gcode --seed 1 --at 42 --save input.nc
//! ```
//!
//! Exit code 0 when no campaign found anything, 1 when one did (each finding's input is saved
//! under `--findings`), 2 when the campaign could not run.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;

use volmap_fuzz::campaign::{self, Plan};
use volmap_fuzz::targets::{self, Outcome, TARGETS};
use volmap_fuzz::watch::{CountingAllocator, ThreadClock};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Runs fuzzing campaigns of volmap's parsers and readers in process.
#[derive(Parser)]
struct Args {
    /// The target, or `all` (in the order of `--list`); repeat for several.
    #[arg(long, default_value = "all")]
    target: Vec<String>,
    /// Executions per target (`10000000`, `1e7`, `10_000_000`).
    #[arg(long, default_value = "100000", value_parser = count)]
    executions: u64,
    /// The campaign's seed: execution N of a seed is always the same input.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The first execution's number (to go on with a campaign, or run one execution again).
    #[arg(long, default_value_t = 0)]
    first: u64,
    /// Where the inputs of findings are saved.
    #[arg(long, default_value_os_t = volmap_fuzz::findings_folder())]
    findings: PathBuf,
    /// Collect up to 16 distinct findings instead of stopping at the first.
    #[arg(long)]
    keep_going: bool,
    /// Run this saved input once and say what the target made of it.
    #[arg(long)]
    replay: Option<PathBuf>,
    /// Make the input of execution N of `--seed` (with --save, or to standard output).
    #[arg(long)]
    at: Option<u64>,
    /// Where `--at` writes the input.
    #[arg(long, requires = "at")]
    save: Option<PathBuf>,
    /// List the targets and what each reads.
    #[arg(long)]
    list: bool,
    /// Append each campaign's figures as a line of JSON to this file.
    #[arg(long)]
    record: Option<PathBuf>,
}

/// A count written as an integer, with `_`, or as `1e7`.
fn count(text: &str) -> Result<u64, String> {
    let text = text.replace('_', "");
    text.parse::<u64>().or_else(|_| {
        text.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0 && v.fract() == 0.0 && *v < 1.8e19)
            .map(|v| v as u64)
            .ok_or_else(|| format!("`{text}` is not a count"))
    })
}

fn main() -> ExitCode {
    let args = Args::parse();
    if args.list {
        for t in TARGETS {
            println!("{:<15} {}", t.name, t.about);
        }
        return ExitCode::SUCCESS;
    }
    let chosen: Vec<&'static targets::Target> = if args.target.iter().any(|t| t == "all") {
        TARGETS.iter().collect()
    } else {
        let mut chosen = Vec::new();
        for name in &args.target {
            match targets::find(name) {
                Some(t) => chosen.push(t),
                None => {
                    eprintln!("fuzz: no target `{name}` (see --list)");
                    return ExitCode::from(2);
                }
            }
        }
        chosen
    };
    if let Some(path) = &args.replay {
        return replay(&chosen, path);
    }
    if let Some(at) = args.at {
        return make_input(&chosen, args.seed, at, args.save.as_deref());
    }
    let mut found = false;
    for target in chosen {
        let plan = Plan {
            seed: args.seed,
            first: args.first,
            executions: args.executions,
            findings: args.findings.clone(),
            keep_going: args.keep_going,
            progress: Some(Duration::from_secs(30)),
            hang_after: campaign::HANG_CPU,
            work: campaign::Work::LIMIT,
        };
        eprintln!(
            "fuzz: {}: {} executions from {}, seed {}; the input under way is kept in {}",
            target.name,
            plan.executions,
            plan.first,
            plan.seed,
            plan.findings.display()
        );
        match campaign::run(target, &plan) {
            Ok(report) => {
                println!("{}", report.summary());
                for f in &report.findings {
                    println!(
                        "  {} at execution {}: {}\n    input: {}",
                        f.kind.name(),
                        f.execution,
                        f.message,
                        f.saved.display()
                    );
                }
                if let Some(path) = &args.record {
                    record(path, &report, plan.first);
                }
                if !report.findings.is_empty() {
                    found = true;
                    if report
                        .findings
                        .iter()
                        .any(|f| f.kind == campaign::Kind::Hang)
                    {
                        // The hung execution cannot be stopped but by ending the process.
                        return ExitCode::from(1);
                    }
                }
            }
            Err(e) => {
                eprintln!("fuzz: {e}");
                return ExitCode::from(2);
            }
        }
    }
    if found {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// Appends a campaign's figures to `path` as one line of JSON.
fn record(path: &std::path::Path, report: &campaign::Report, first: u64) {
    let line = serde_json::json!({
        "target": report.target,
        "seed": report.seed,
        "first": first,
        "executions": report.executions,
        "seconds": report.seconds,
        "executions_per_second": report.executions_per_second(),
        "accepted": report.accepted,
        "refused": report.refused,
        "slowest_ms": report.slowest.1.as_secs_f64() * 1e3,
        "peak_heap_bytes": report.peak_bytes,
        "largest_request_bytes": report.largest_request_bytes,
        "most_allocations": report.most_allocations,
        "most_allocated_bytes": report.most_allocated_bytes,
        "findings": report.findings.len(),
        "date": humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
    });
    use std::io::Write;
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .and_then(|mut f| writeln!(f, "{line}"));
    if let Err(e) = written {
        eprintln!("fuzz: cannot record to {}: {e}", path.display());
    }
}

/// Runs a saved input through each chosen target once.
fn replay(chosen: &[&'static targets::Target], path: &std::path::Path) -> ExitCode {
    let input = match std::fs::read(path) {
        Ok(input) => input,
        Err(e) => {
            eprintln!("fuzz: cannot read {}: {e}", path.display());
            return ExitCode::from(2);
        }
    };
    let mut cx = match targets::Context::new() {
        Ok(cx) => cx,
        Err(e) => {
            eprintln!("fuzz: cannot make a scratch folder: {e}");
            return ExitCode::from(2);
        }
    };
    campaign::single_threaded(|| replay_in(chosen, &input, &mut cx))
}

fn replay_in(
    chosen: &[&'static targets::Target],
    input: &[u8],
    cx: &mut targets::Context,
) -> ExitCode {
    let clock = ThreadClock::current();
    let mut found = false;
    for target in chosen {
        let executed = campaign::execute(target, cx, input, &clock);
        let what = match &executed.result {
            Ok(Ok(Outcome::Accepted)) => "accepted".to_string(),
            Ok(Ok(Outcome::Refused(m))) => format!("refused: {m}"),
            Ok(Err(check)) => {
                found = true;
                format!("CHECK BROKEN: {check}")
            }
            Err(panic) => {
                found = true;
                format!("PANIC: {panic}")
            }
        };
        println!(
            "{}: {what}\n  {:.3} ms of CPU time, {} bytes of heap at most, largest request {} bytes, {} allocations asking for {} bytes in all",
            target.name,
            executed.cpu.as_secs_f64() * 1e3,
            executed.usage.peak_bytes,
            executed.usage.largest_request_bytes,
            executed.usage.allocations,
            executed.usage.allocated_bytes
        );
        for (kind, message) in campaign::judge(&executed, campaign::Work::LIMIT) {
            if matches!(kind, campaign::Kind::Work | campaign::Kind::Memory) {
                found = true;
                println!("  {}: {message}", kind.name().to_uppercase());
            }
        }
    }
    if found {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// Writes the input of execution `at` of `seed`.
fn make_input(
    chosen: &[&'static targets::Target],
    seed: u64,
    at: u64,
    save: Option<&std::path::Path>,
) -> ExitCode {
    let [target] = chosen else {
        eprintln!("fuzz: --at makes the input of one target: name it with --target");
        return ExitCode::from(2);
    };
    let prepared = match campaign::Prepared::of(target) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("fuzz: {e}");
            return ExitCode::from(2);
        }
    };
    let input = campaign::input_at(target, &prepared, seed, at);
    let written = match save {
        Some(path) => std::fs::write(path, &input),
        None => {
            use std::io::Write;
            std::io::stdout().write_all(&input)
        }
    };
    match written {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fuzz: cannot write the input: {e}");
            ExitCode::from(2)
        }
    }
}
