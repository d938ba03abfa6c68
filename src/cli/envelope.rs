//! The one shape of every `--json` file (docs/schema/): the `volmap` version, the `schema`
//! version, the `command` with its arguments, the `machine` (its name and a hash of its file
//! and tables), the evaluation `inputs`, and the command's own `result`.

use serde::Serialize;
use serde_json::{json, Map, Value};
use volmap::io::digest;
use volmap::io::field::FieldInfo;
use volmap::model::inputs::{Inputs, InputsRecord};
use volmap::model::{AxisLetter, Command, Machine};

use super::failure::Failure;
use super::output::write_json_for;

/// The version of the shapes docs/schema/ describes: raised when a key is removed or changes
/// its meaning (a key added leaves it).
pub const SCHEMA_VERSION: u32 = 1;

/// What a report says besides its result: the command and what it computed from.
pub struct Envelope {
    command: &'static str,
    machine: Value,
    inputs: Value,
}

impl Envelope {
    /// The envelope of `command` (its name as typed: `map`, `test`), computed from no machine.
    pub fn new(command: &'static str) -> Envelope {
        Envelope {
            command,
            machine: Value::Null,
            inputs: Value::Null,
        }
    }

    /// Computed from `machine`, at its evaluation inputs ([`Machine::inputs`]).
    pub fn machine(self, machine: &Machine) -> Envelope {
        Envelope {
            machine: machine_json(
                &machine.name,
                &machine.chain.hwang_notation(),
                Some(digest::of_machine(machine)),
            ),
            inputs: inputs_json(&machine.inputs.record(machine)),
            ..self
        }
    }

    /// Computed from the machine a field file records, at the inputs it records.
    pub fn field(self, info: &FieldInfo) -> Envelope {
        Envelope {
            machine: machine_json(
                &info.machine_name,
                &info.chain,
                Some(digest::machine_sha256(&info.machine_toml, &info.csv_files)),
            ),
            inputs: inputs_json(&info.inputs),
            ..self
        }
        .pose(field_pose(info))
    }

    /// Computed from a machine known by name and hash only (a study's shards record no more).
    pub fn named_machine(self, name: &str, sha256: Option<&str>) -> Envelope {
        Envelope {
            machine: json!({ "name": name, "chain": Value::Null, "sha256": sha256 }),
            ..self
        }
    }

    /// At these evaluation inputs (the pose kept).
    pub fn at(mut self, record: &InputsRecord) -> Envelope {
        let pose = self.inputs.get("pose_deg").cloned().unwrap_or(Value::Null);
        self.inputs = inputs_json(record);
        self.pose(pose)
    }

    /// At `inputs` of `machine`.
    pub fn at_inputs(self, machine: &Machine, inputs: &Inputs) -> Envelope {
        self.at(&inputs.record(machine))
    }

    /// The inputs, replaced: `approach` and `temperatures_C` as a study records them.
    pub fn with_inputs(self, inputs: Value) -> Envelope {
        Envelope { inputs, ..self }
    }

    /// At the pose `pose` of `machine` (its rotary axes, degrees).
    pub fn at_pose(self, machine: &Machine, pose: &Command) -> Envelope {
        self.pose(pose_of(machine, pose))
    }

    /// The pose (rotary axes, degrees) or poses the result is at: an object of axis letters, or
    /// an array of them (a sweep).
    pub fn pose(mut self, pose: Value) -> Envelope {
        if let Value::Object(inputs) = &mut self.inputs {
            inputs.insert("pose_deg".into(), pose);
        } else {
            self.inputs = json!({ "pose_deg": pose });
        }
        self
    }

    /// The report: this envelope around `result`.
    pub fn wrap(&self, result: &impl Serialize) -> Result<Value, Failure> {
        let arguments: Vec<String> = std::env::args_os()
            .skip(1)
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        Ok(json!({
            "volmap": env!("CARGO_PKG_VERSION"),
            "schema": SCHEMA_VERSION,
            "command": { "name": self.command, "arguments": arguments },
            "machine": self.machine,
            "inputs": self.inputs,
            "result": serde_json::to_value(result).map_err(Failure::work)?,
        }))
    }

    /// Writes the report around `result` to the file `flag` names.
    pub fn write(
        &self,
        path: &std::path::Path,
        flag: &str,
        result: &impl Serialize,
    ) -> Result<(), Failure> {
        write_json_for(path, &self.wrap(result)?, flag)
    }
}

fn machine_json(name: &str, chain: &str, sha256: Option<String>) -> Value {
    json!({ "name": name, "chain": chain, "sha256": sha256 })
}

/// `{"approach": {"X": "+", …}, "temperatures_C": {"spindle": 31.0, …}, "reference_C": 20.0}`
/// (`reference_C` null where the machine declares no thermal input), with no pose.
pub fn inputs_json(record: &InputsRecord) -> Value {
    let approach: Map<String, Value> = record
        .approach
        .iter()
        .map(|(l, a)| (l.to_string(), json!(a.sign().to_string())))
        .collect();
    let temperatures: Map<String, Value> = record
        .temperatures_c
        .iter()
        .map(|(n, t)| (n.clone(), json!(t)))
        .collect();
    json!({
        "approach": approach,
        "temperatures_C": temperatures,
        "reference_C": record.reference_c,
        "pose_deg": Value::Null,
    })
}

/// A pose of `machine` as `pose_deg` holds it: each rotary axis letter and its angle, degrees.
pub fn pose_of(machine: &Machine, pose: &Command) -> Value {
    Value::Object(
        machine
            .rotary_axes()
            .iter()
            .map(|l| (l.to_string(), json!(pose[l.index()])))
            .collect(),
    )
}

/// The pose of a field's part (its rotary axes, degrees).
pub fn field_pose(info: &FieldInfo) -> Value {
    Value::Object(
        info.pose_axes
            .chars()
            .filter_map(AxisLetter::from_char)
            .filter(|l| !l.is_linear())
            .map(|l| (l.to_string(), json!(info.pose_deg[l.index() - 3])))
            .collect(),
    )
}
