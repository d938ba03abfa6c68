//! The arguments several commands share, defined once and flattened into each: the machine, the
//! grid, the pose, the device, the JSON output. Each resolves itself and names its own flag in
//! any error.

use std::path::PathBuf;

use clap::ValueEnum;
use volmap::engine::{DeviceChoice, Engine, EngineError};
use volmap::gpu::GpuSampler;
use volmap::io::embedded;
use volmap::io::field::FieldFile;
use volmap::io::source::Reach;
use volmap::model::grid::{self, Grid};
use volmap::model::inputs::Inputs;
use volmap::model::poses;
use volmap::model::{Command, Machine};
use volmap::query::{self, QueryError};

use super::failure::{Failure, FlagContext};

/// `--machine` where a command changes or judges something real (compensates a program, fits
/// measurements, predicts tests, budgets a design): the machine must be named, since a program
/// compensated for an example machine is wrong on every real one.
#[derive(clap::Args)]
pub struct MachineArg {
    /// The machine (required): an embedded machine's name (see `volmap machines`) or a machine
    /// file (TOML).
    #[arg(long)]
    pub machine: Option<String>,
    #[command(flatten)]
    pub reach: ReachArg,
}

impl MachineArg {
    pub fn load(&self) -> Result<Machine, Failure> {
        match &self.machine {
            Some(name) => load_machine(name, &self.reach),
            None => Err(missing_machine()),
        }
    }
}

/// `--allow-outside-paths`: where the CSV files a machine file or a fit file names may lie.
#[derive(clap::Args, Clone, Copy)]
pub struct ReachArg {
    /// Read CSV files named in machine files and fit files wherever they lie; without it they
    /// must lie in the folder of the file that names them, or below it.
    #[arg(long)]
    pub allow_outside_paths: bool,
}

impl ReachArg {
    pub fn reach(&self) -> Reach {
        if self.allow_outside_paths {
            Reach::Anywhere
        } else {
            Reach::Folder
        }
    }

    /// A failure about a file named outside its folder, with the way round it.
    pub fn hint(failure: Failure, outside: bool) -> Failure {
        if outside {
            failure.hint("--allow-outside-paths reads CSV files wherever they lie")
        } else {
            failure
        }
    }
}

/// The failure of a command that needs a machine and was given none.
pub fn missing_machine() -> Failure {
    Failure::input(
        "no machine named: give --machine NAME (an embedded machine) or --machine FILE.toml (a machine file); `volmap machines` lists the embedded ones",
    )
}

/// `--machine` where a command only shows a machine's error (`map`, `plot grid`): a first look
/// at an embedded example needs no machine file.
#[derive(clap::Args)]
pub struct DefaultMachineArg {
    /// An embedded machine's name (see `volmap machines`) or a machine file (TOML).
    #[arg(long, default_value = embedded::DEFAULT_MACHINE)]
    pub machine: String,
    #[command(flatten)]
    pub reach: ReachArg,
}

impl DefaultMachineArg {
    pub fn load(&self) -> Result<Machine, Failure> {
        load_machine(&self.machine, &self.reach)
    }
}

/// `--machine` where a command may take its machine from elsewhere (a field).
#[derive(clap::Args)]
pub struct OptionalMachineArg {
    /// An embedded machine's name (see `volmap machines`) or a machine file (TOML).
    #[arg(long)]
    pub machine: Option<String>,
    #[command(flatten)]
    pub reach: ReachArg,
}

/// The machine `--machine` names.
pub fn load_machine(name_or_path: &str, reach: &ReachArg) -> Result<Machine, Failure> {
    load_machine_flag(name_or_path, reach, "--machine")
}

/// The machine a flag (`--machine`, `--base`) names.
pub fn load_machine_flag(
    name_or_path: &str,
    reach: &ReachArg,
    flag: &str,
) -> Result<Machine, Failure> {
    embedded::load_reaching(name_or_path, reach.reach()).map_err(|e| {
        let outside = e.is_outside_folder();
        ReachArg::hint(Failure::from(e).context(flag.to_string()), outside)
    })
}

/// `--grid`.
#[derive(clap::Args)]
pub struct GridArg {
    /// Grid points along X, Y and Z, spanning each linear axis's full travel, `NXxNYxNZ` (at
    /// most 262144 along each, and NY·NZ below 2^31).
    #[arg(long, default_value = "64x64x64", value_parser = grid::parse_dims)]
    pub grid: [usize; 3],
}

/// `--pose`.
#[derive(clap::Args)]
pub struct PoseArg {
    /// Positions of the rotary axes in degrees, e.g. `B=30,C=-45`; axes not named are at 0.
    #[arg(long, default_value = "", allow_hyphen_values = true)]
    pub pose: String,
}

impl PoseArg {
    /// The pose on `machine`.
    pub fn on(&self, machine: &Machine) -> Result<Command, Failure> {
        poses::parse_pose(&self.pose, machine).flag("--pose")
    }
}

/// The grid of `--grid` over the machine's travels, with the rotary axes at `--pose`.
pub fn full_travel(machine: &Machine, grid: &GridArg, pose: &PoseArg) -> Result<Grid, Failure> {
    let pose = pose.on(machine)?;
    Grid::full_travel(machine, grid.grid, pose).flag("--grid")
}

/// `--device`.
#[derive(clap::Args)]
pub struct DeviceArg {
    /// Where to compute: `auto` uses the GPU when an adapter exists and the CPU otherwise (to
    /// sample a field, a hardware GPU only: a CPU adapter such as lavapipe is slower at it than
    /// the CPU).
    #[arg(long, value_enum, default_value_t = Device::Auto)]
    pub device: Device,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Device {
    Auto,
    Gpu,
    Cpu,
}

impl DeviceArg {
    pub fn choice(&self) -> DeviceChoice {
        match self.device {
            Device::Auto => DeviceChoice::Auto,
            Device::Gpu => DeviceChoice::Gpu,
            Device::Cpu => DeviceChoice::Cpu,
        }
    }

    /// The engine `--device` asks for, with a note when `auto` falls back to the CPU.
    pub fn engine(&self) -> Result<(Engine, Option<String>), Failure> {
        Engine::select(self.choice()).map_err(|e| {
            let no_adapter = matches!(e, EngineError::NoAdapter);
            no_gpu(Failure::from(e), no_adapter)
        })
    }

    /// The GPU sampler `--device` asks for (`None`: sample on the CPU), with a note when
    /// `auto` finds no adapter.
    pub fn sampler(&self) -> Result<(Option<GpuSampler>, Option<String>), Failure> {
        query::open_sampler(self.choice()).map_err(|e| {
            let no_adapter = matches!(e, QueryError::NoAdapter);
            no_gpu(Failure::from(e), no_adapter)
        })
    }
}

/// A failure to open the GPU, said to come from `--device gpu`, with the way round it where
/// there is no adapter.
fn no_gpu(failure: Failure, no_adapter: bool) -> Failure {
    let failure = failure.context("--device gpu");
    if no_adapter {
        failure.hint("--device auto or --device cpu computes on the CPU")
    } else {
        failure
    }
}

/// `--json`.
#[derive(clap::Args)]
pub struct JsonArg {
    /// Also write the result as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// `--poses`.
#[derive(clap::Args)]
pub struct PosesArg {
    /// Every pose of a sweep of the rotary axes: `B=-90:90:15,C=0:345:15` (each axis one value
    /// or START:STOP:STEP degrees, the last axis varying fastest; axes not named at 0). `map`
    /// writes one part per pose into one multi-part field; `budget` takes the grid at every pose
    /// and its statistics over all of them.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "pose")]
    pub poses: Option<String>,
}

/// The grids of `--grid` over the machine's travels: one per pose of `--poses`, or the one of
/// `--pose`.
pub fn sweep_grids(
    machine: &Machine,
    grid: &GridArg,
    pose: &PoseArg,
    poses: &PosesArg,
) -> Result<Vec<Grid>, Failure> {
    match &poses.poses {
        Some(text) => volmap::model::poses::parse_sweep(text, machine)
            .flag("--poses")?
            .into_iter()
            .map(|pose| Grid::full_travel(machine, grid.grid, pose).flag("--grid"))
            .collect(),
        None => Ok(vec![full_travel(machine, grid, pose)?]),
    }
}

/// `--temperatures` and `--approach`: the evaluation inputs (docs/model.md, "Evaluation inputs").
#[derive(clap::Args)]
pub struct InputsArg {
    /// Temperatures of the machine's thermal inputs in °C, e.g. `x_scale=24.5,spindle=31`;
    /// inputs not named are at the machine's reference_C.
    #[arg(long, default_value = "", allow_hyphen_values = true)]
    pub temperatures: String,
    /// Approach directions of the axes, e.g. `X=-,Y=+`; axes not named approach `+`.
    #[arg(long, default_value = "", allow_hyphen_values = true)]
    pub approach: String,
}

impl InputsArg {
    /// The inputs on `machine`, each error naming its flag.
    pub fn on(&self, machine: &Machine) -> Result<Inputs, Failure> {
        let temperatures = Inputs::parse(&self.temperatures, "", machine).flag("--temperatures")?;
        let approach = Inputs::parse("", &self.approach, machine).flag("--approach")?;
        let inputs = Inputs {
            approach: approach.approach,
            temperatures_c: temperatures.temperatures_c,
        };
        // The file's thermal terms were checked at ±50 K; the run's temperatures may lie further.
        volmap::io::machine_file::check_at_inputs(machine, &inputs).flag("--temperatures")?;
        Ok(inputs)
    }

    /// The machine at these inputs, and the inputs.
    pub fn machine_at(&self, machine: &Machine) -> Result<(Machine, Inputs), Failure> {
        let inputs = self.on(machine)?;
        Ok((machine.at(&inputs), inputs))
    }

    /// Checks that the field file `--field` names was computed at these inputs: the flags read
    /// against the axes and thermal inputs the field records (each error naming its flag), then
    /// every part compared, a field of other inputs refused naming `--field` with the flags that
    /// ask for what it holds.
    pub fn check_field(&self, file: &FieldFile) -> Result<(), Failure> {
        let record = file.inputs(0);
        let chain = file.info(0).chain;
        let temperatures =
            Inputs::parse_for(&self.temperatures, "", record, &chain).flag("--temperatures")?;
        let approach = Inputs::parse_for("", &self.approach, record, &chain).flag("--approach")?;
        let inputs = Inputs {
            approach: approach.approach,
            temperatures_c: temperatures.temperatures_c,
        };
        file.check_inputs(&inputs).flag("--field").map_err(|f| {
            let mut flags = format!("--approach {}", record.approach_text());
            if !record.temperatures_c.is_empty() {
                flags += &format!(" --temperatures {}", record.temperatures_text());
            }
            f.hint(format!("{flags} asks for the field's inputs"))
        })
    }
}
