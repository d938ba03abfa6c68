//! The machine as the compensation asks it: per tool, at the program's temperatures, in every
//! combination of approach directions the program meets, with its ideal twin.

use std::cell::{OnceCell, RefCell};
use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};

use super::error::{NcError, NcOption};
use super::options::Options;
use super::program::approach::{key, reversing_axes};
use super::program::modal::{Directions, State};
use crate::model::inputs::Inputs;
use crate::model::{Axis, Command, Machine};
use crate::reference::Twin;

/// The machine as one tool sees it: the machine file's machine with that tool, at the program's
/// temperatures, resolved for each combination of directions of its reversing axes when first
/// asked.
pub(super) struct Kinematics {
    /// With its input-dependent errors unresolved.
    machine: Machine,
    /// The program's temperatures, every axis `+` (twin 0).
    inputs: Inputs,
    reversing: [bool; 6],
    /// By [`key`]: one twin per combination of directions of the reversing axes.
    twins: Vec<OnceCell<Twin>>,
    /// The inverse of the ideal tip's Jacobian in X, Y, Z at the last rotary positions it was
    /// asked for: the same for every point until the rotary axes move.
    inverse: RefCell<Option<([f64; 3], Matrix3<f64>)>>,
}

impl Kinematics {
    fn new(machine: Machine, inputs: &Inputs) -> Kinematics {
        Kinematics {
            reversing: reversing_axes(&machine.dependent),
            machine,
            // Every axis `+`: the directions come with each question.
            inputs: Inputs {
                approach: Default::default(),
                ..inputs.clone()
            },
            twins: (0..64).map(|_| OnceCell::new()).collect(),
            inverse: RefCell::new(None),
        }
    }

    /// The axes with a reversal error.
    pub(super) fn reversing(&self) -> &[bool; 6] {
        &self.reversing
    }

    /// The machine with its travels (its errors unresolved).
    pub(super) fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The machine and its ideal twin with the axes approaching in `directions`.
    pub(super) fn twin(&self, directions: &Directions) -> &Twin {
        let index = if self.reversing == [false; 6] {
            0
        } else {
            key(directions, &self.reversing)
        };
        self.twins[index].get_or_init(|| {
            let inputs = Inputs {
                approach: *directions,
                ..self.inputs.clone()
            };
            Twin::new(self.machine.at(&inputs))
        })
    }

    /// Where the ideal machine puts the tool tip (it has no direction or temperature).
    pub(super) fn ideal_tip(&self, q: &Command) -> Vector3<f64> {
        self.twins[0]
            .get_or_init(|| Twin::new(self.machine.at(&self.inputs)))
            .ideal_tip(q)
    }

    /// The inverse of the ideal tip's derivative in X, Y, Z at `q` (constant at fixed rotary
    /// positions, so kept until they change); `None` where the linear axes do not span X, Y, Z.
    pub(super) fn inverse_jacobian(&self, q: &Command) -> Option<Matrix3<f64>> {
        let rotary = [q[3], q[4], q[5]];
        let mut cache = self.inverse.borrow_mut();
        match *cache {
            Some((at, inverse)) if at == rotary => Some(inverse),
            _ => {
                let twin = self.twin(&Directions::default());
                let inverse = twin.ideal_jacobian(q).try_inverse()?;
                *cache = Some((rotary, inverse));
                Some(inverse)
            }
        }
    }

    /// The command whose real tip, approaching in `directions`, lands on the ideal tip of `q`.
    pub(super) fn compensate(&self, q: &Command, directions: &Directions) -> Option<Command> {
        let inverse = self.inverse_jacobian(q)?;
        self.twin(directions)
            .real_command_for(self.ideal_tip(q), q, &inverse)
    }

    /// Distance of the real tip at command `c`, approaching in `directions`, from the ideal tip
    /// at command `q`.
    pub(super) fn miss(&self, c: &Command, q: &Command, directions: &Directions) -> f64 {
        (self.twin(directions).real_tip(c) - self.ideal_tip(q)).norm()
    }
}

/// The compensation of one program: its name, its options, the machine, the machine per tool.
pub(super) struct Compensator<'a> {
    pub(super) path: &'a str,
    pub(super) options: &'a Options,
    base: &'a Machine,
    tools: HashMap<Option<u32>, Kinematics>,
}

impl<'a> Compensator<'a> {
    pub(super) fn new(path: &'a str, options: &'a Options, base: &'a Machine) -> Compensator<'a> {
        Compensator {
            path,
            options,
            base,
            tools: HashMap::new(),
        }
    }

    /// The length of `tool` from the options (`None`: the machine file's tool stands).
    fn length(&self, tool: Option<u32>, line: usize) -> Result<Option<f64>, NcError> {
        let lengths = &self.options.tool_lengths;
        match tool.and_then(|t| lengths.per_tool.get(&t)) {
            Some(&l) => Ok(Some(l)),
            None if lengths.per_tool.is_empty() || lengths.all.is_some() => Ok(lengths.all),
            None => Err(NcError::Missing {
                path: self.path.to_string(),
                line,
                option: NcOption::ToolLengths,
                message: match tool {
                    Some(t) => format!("no length for tool T{t} among the tool lengths"),
                    None => "no tool is active yet and the tool lengths name tools only".into(),
                },
            }),
        }
    }

    /// Where the machine's axes stand relative to the program (mm, degrees): the active work
    /// offset (with the program's G10, G52 and G92), plus with G43 the active tool's length along the spindle axis (Z), as a Fanuc or
    /// Haas control applies it, so that the tool tip follows the program.
    pub(super) fn offset(&self, state: &State, line: usize) -> Result<[f64; 6], NcError> {
        // The work offset as the program has it (G10 may have set it), shifted by G52 and G92.
        let work = state.work_offsets.get(&state.offset).unwrap_or(&[0.0; 6]);
        let mut offset: [f64; 6] =
            std::array::from_fn(|d| work[d] + state.local_shift[d] + state.g92_shift[d]);
        if state.tool_length_on {
            offset[2] += self.length(state.tool, line)?.unwrap_or(0.0);
        }
        Ok(offset)
    }

    /// The machine with `tool` (its length from the options, else the machine file's tool).
    pub(super) fn kinematics(
        &mut self,
        tool: Option<u32>,
        line: usize,
    ) -> Result<&Kinematics, NcError> {
        if !self.tools.contains_key(&tool) {
            let length = self.length(tool, line)?;
            let mut real = self.base.clone();
            if let Some(l) = length {
                real.tool_offset_mm = [0.0, 0.0, -l];
            }
            self.tools
                .insert(tool, Kinematics::new(real, &self.options.inputs));
        }
        Ok(&self.tools[&tool])
    }
}

/// The first axis of `machine` whose position in `command` lies outside its travel (by more
/// than a micrometre's rounding: 1e-6 mm or degrees), with that position; a position that is
/// not a number lies outside.
pub(super) fn beyond_travel<'m>(
    machine: &'m Machine,
    command: &Command,
) -> Option<(&'m Axis, f64)> {
    machine.axes.iter().find_map(|axis| {
        let value = command[axis.letter.index()];
        let [lo, hi] = axis.range;
        (!(lo - 1e-6..=hi + 1e-6).contains(&value)).then_some((axis, value))
    })
}
