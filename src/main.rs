//! The `volmap` command line.
//!
//! Exit codes: 0 success; 1 a failure while working (GPU, file system); 2 bad input (machine
//! file, grid, pose, field file, part file, CSV, command-line values); 3 `features` found a
//! feature that does not conform; 4 `--check` found the field further from the f64 reference
//! than the tolerance; 5 `features` found none that fails but some it cannot decide within the
//! errors' uncertainty; 130, 143 and 129 interrupted by SIGINT, SIGTERM or SIGHUP, 141 its standard
//! output closed under it (its temporary files removed).

mod cli;

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

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
    Map(cli::map::MapArgs),
    /// List the embedded machines, or print one's machine file (`--show NAME`).
    Machines(cli::machines::MachinesArgs),
    /// Print the summary of a field file written by `volmap map`.
    Info(cli::info::InfoArgs),
    /// VE and OE at arbitrary commanded positions (CSV in, CSV out): interpolated from a field
    /// file, or exactly from the machine model.
    Sample(cli::sample::SampleArgs),
    /// The GD&T error each feature of a part gets from the machine, against its tolerance: the
    /// machine's capability and the ISO 14253-1 decision with the error's expanded uncertainty
    /// (exit code 3 when any feature does not conform, 5 when none fails but some are undecided).
    Features(cli::features::FeaturesArgs),
    /// Measure every path on this machine (CPU reference, CPU engine, GPU kernel, readback, EXR
    /// writing, whole maps) and print one table.
    Bench(cli::bench::BenchArgs),
    /// Standard accuracy tests predicted from the machine model (ISO 230-2 positioning, ISO
    /// 230-6 diagonals, ISO 230-4 circular tests, the R-test), against measured results where
    /// given.
    Test(cli::test::TestArgs),
    /// Estimate location errors (squareness, rotary axis lines) from diagonal, circular, R-test
    /// or positioning measurements by least squares, with residual and uncertainty.
    Fit(cli::fit::FitArgs),
    /// Build a machine file from component errors measured at sparse positions (CSV per axis),
    /// with linear, quadratic or cubic elements chosen per component.
    Build(cli::build::BuildArgs),
    /// Machine design from tolerances: the error budget (each toleranced term alone at its
    /// limit), Monte Carlo over machines built to the tolerances, tolerance allocation.
    Budget(cli::budget::BudgetArgs),
    /// Put the shards of a Monte Carlo study (`budget --shard K/M --per-sample FILE.json`)
    /// together: the statistics one run of all the samples gives.
    MergeSamples(cli::merge_samples::MergeSamplesArgs),
    /// Put the shards of a five-axis map (`map --poses … --shard K/M`) into one multi-part
    /// field: the file one run over every pose writes.
    MergeMaps(cli::merge_maps::MergeMapsArgs),
    /// Plots: a field slice as a colour map, the deformed workspace grid.
    Plot(cli::plot::PlotArgs),
    /// Rewrite an NC program (ISO 6983 / Fanuc) so the real tool tip lands on the programmed
    /// path: the machine's error compensated offline.
    Compensate(cli::compensate::CompensateArgs),
    /// The real tool-tip deviation along an NC program, sampled along every move, without
    /// rewriting it (and, with --compensate, along its compensated program).
    Trace(cli::trace::TraceArgs),
    /// Write the machine's correction as a controller's compensation table (LinuxCNC, Klipper,
    /// Marlin, RepRapFirmware, SINUMERIK, HEIDENHAIN, FANUC, ISG/TwinCAT, a generic 3-D grid),
    /// with the residual the control leaves applying it.
    Export(cli::export::ExportArgs),
    /// Write one self-contained HTML page of a field (or of a machine mapped here): section
    /// planes, the deformed grid in 3-D, the machine, and with --part its features' verdicts.
    View(cli::view::ViewArgs),
    /// Print the shell's completion script for volmap (bash, zsh, fish, powershell, elvish).
    Completions(cli::completions::CompletionsArgs),
    /// Write a man page per command into a folder.
    Man(cli::man::ManArgs),
    /// Print this command line's reference as Markdown (the page `docs/cli.md`).
    #[command(hide = true)]
    CliReference,
}

/// The command line, every value allowed to be a negative number (`--from -5,0,0`, `--spec -1`):
/// a value that is one reaches its own check and message, not clap's "unexpected argument".
fn command() -> clap::Command {
    fn negative_numbers(command: clap::Command) -> clap::Command {
        command
            .mut_args(|arg| {
                if arg.get_action().takes_values() {
                    arg.allow_negative_numbers(true)
                } else {
                    arg
                }
            })
            .mut_subcommands(negative_numbers)
    }
    negative_numbers(Cli::command())
}

fn main() -> ExitCode {
    volmap::gpu::device::quiet_window_system();
    cli::interrupt::install();
    volmap::gpu::slow::on_slow_compile(cli::output::say_slow_compile);
    // A run's outputs are put in place together when it succeeds, none when it fails.
    volmap::io::outputs::hold_commits();
    let cli = Cli::from_arg_matches(&command().get_matches()).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        Command::Map(args) => cli::map::run(args),
        Command::Machines(args) => cli::machines::run(args),
        Command::Info(args) => cli::info::run(args),
        Command::Sample(args) => cli::sample::run(args),
        Command::Features(args) => cli::features::run(args),
        Command::Bench(args) => cli::bench::run(args),
        Command::Test(args) => cli::test::run(args),
        Command::Fit(args) => cli::fit::run(args),
        Command::Build(args) => cli::build::run(args),
        Command::Budget(args) => cli::budget::run(args),
        Command::MergeSamples(args) => cli::merge_samples::run(args),
        Command::MergeMaps(args) => cli::merge_maps::run(args),
        Command::Plot(args) => cli::plot::run(args),
        Command::Compensate(args) => cli::compensate::run(args),
        Command::Trace(args) => cli::trace::run(args),
        Command::Export(args) => cli::export::run(args),
        Command::View(args) => cli::view::run(args),
        Command::Completions(args) => cli::completions::run(args, command()),
        Command::Man(args) => cli::man::run(args, command()),
        Command::CliReference => cli::reference::run(command()),
    };
    let result = result.and_then(|code| {
        volmap::io::outputs::commit_held().map_err(cli::failure::Failure::from)?;
        Ok(code)
    });
    result.unwrap_or_else(|failure| {
        volmap::io::outputs::discard_held();
        failure.report();
        failure.exit_code()
    })
}
