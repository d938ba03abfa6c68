//! The model: what a machine is, with no file or device in sight. The kinematic chain, the axes
//! with their nominal geometry and ISO 230-1 errors as functions of position, the spindle errors
//! and the tool offset (docs/model.md); the grid of commanded positions a map covers; the channels
//! of a field. Machine files are read into it by [`crate::io::machine_file`].

pub mod chain;
pub mod channels;
pub mod errorfn;
pub mod grid;
pub mod inputs;
pub mod perturbation;
pub mod poses;
pub mod random;
mod spline;
pub mod statistics;
pub mod table2d;
pub mod uncertainty;

pub use chain::{AxisLetter, Chain, ChainError};
pub use errorfn::{ErrorFunction, Interp, Pieces, Table};

/// Index of an error component within an axis: translations along x, y, z, then rotations about
/// x, y, z. The ISO 230-1 names for axis X are `EXX EYX EZX EAX EBX ECX`; the location errors of
/// X are `EX0X EY0X EZ0X EA0X EB0X EC0X`.
pub const COMPONENT_NAMES: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

/// One axis of the chain.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    pub letter: AxisLetter,
    /// Travel: mm for linear axes, degrees for rotary axes.
    pub range: [f64; 2],
    /// `o_k`, the nominal offset of the axis frame in its parent frame, mm.
    pub offset_mm: [f64; 3],
    /// +1 or −1: the sense of motion along (or rotation about) the axis direction.
    pub direction: f64,
    /// Location errors `EX0k EY0k EZ0k` (mm) and `EA0k EB0k EC0k` (rad).
    pub location: [f64; 6],
    /// Component errors `EXk EYk EZk` (mm) and `EAk EBk ECk` (rad) as functions of the axis
    /// position; `None` is zero.
    pub components: [Option<ErrorFunction>; 6],
}

impl Axis {
    /// An error-free axis with the given travel.
    pub fn nominal(letter: AxisLetter, range: [f64; 2]) -> Axis {
        Axis {
            letter,
            range,
            offset_mm: [0.0; 3],
            direction: 1.0,
            location: [0.0; 6],
            components: Default::default(),
        }
    }

    /// The unit vector `u_k`: the axis direction times its sense.
    pub fn unit_vector(&self) -> [f64; 3] {
        let mut u = [0.0; 3];
        u[self.letter.direction_index()] = self.direction;
        u
    }

    /// The six component errors at position `q` (mm or degrees), every other axis at 0: for an
    /// axis whose errors depend on its own position only.
    pub fn component_values(&self, q: f64) -> [f64; 6] {
        self.component_values_at(q, &[0.0; 6])
    }

    /// The six component errors at position `q` with every axis at `command`.
    pub fn component_values_at(&self, q: f64, command: &Command) -> [f64; 6] {
        std::array::from_fn(|n| {
            self.components[n]
                .as_ref()
                .map_or(0.0, |f| f.eval_at(q, command))
        })
    }

    /// The grid dimensions (0 X, 1 Y, 2 Z) the axis's transform depends on on a grid, in
    /// increasing order: its own (a linear axis) and those of the linear axes its errors read
    /// (`of`, `table2d`, `sum`). A rotary axis stands at its pose, so reading it adds none.
    pub fn grid_dims(&self) -> Vec<usize> {
        let mut dims: Vec<usize> = std::iter::once(self.letter)
            .filter(|l| l.is_linear())
            .chain(
                self.components
                    .iter()
                    .flatten()
                    .flat_map(|f| f.other_axes()),
            )
            .filter(|l| l.is_linear())
            .map(|l| l.direction_index())
            .collect();
        dims.sort_unstable();
        dims.dedup();
        dims
    }

    pub fn component_key(&self, n: usize) -> String {
        format!("E{}{}", COMPONENT_NAMES[n], self.letter)
    }

    pub fn location_key(&self, n: usize) -> String {
        format!("E{}0{}", COMPONENT_NAMES[n], self.letter)
    }
}

/// Where a machine came from: kept so a field file can carry everything needed to rebuild it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MachineSource {
    /// The machine file's text, verbatim.
    pub toml: String,
    /// Each CSV file the machine reads, as `(path as written in the file, text)`.
    pub csv_files: Vec<(String, String)>,
    /// The folder its CSV paths are relative to (`None`: a machine read from text, like the
    /// embedded ones, whose tables are inline).
    pub folder: Option<std::path::PathBuf>,
}

/// A complete machine: what docs/model.md's chain needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Machine {
    pub name: String,
    pub description: String,
    pub chain: Chain,
    /// One per axis of the chain, in no particular order; look up with [`Machine::axis`].
    pub axes: Vec<Axis>,
    /// The tool tip in the spindle frame, mm.
    pub tool_offset_mm: [f64; 3],
    /// Spindle errors `EXS EYS EZS` (mm), `EAS EBS` (rad).
    pub spindle: [f64; 5],
    /// `[thermal]`, where the machine declares temperature inputs.
    pub thermal: Option<inputs::Thermal>,
    /// The error values that depend on the evaluation inputs (see [`Machine::at`]); the values
    /// above are those at the default inputs.
    pub dependent: Vec<inputs::Dependent>,
    /// The evaluation inputs the error values above are at: the default ones (every axis `+`,
    /// every input at `reference_C`) as loaded, those given to [`Machine::at`] after it.
    pub inputs: inputs::Inputs,
    /// The standard uncertainties of the error values, where the machine file gives them.
    pub uncertainty: uncertainty::Uncertainty,
    pub source: MachineSource,
}

impl Machine {
    pub fn axis(&self, letter: AxisLetter) -> Option<&Axis> {
        self.axes.iter().find(|a| a.letter == letter)
    }

    pub fn axis_mut(&mut self, letter: AxisLetter) -> Option<&mut Axis> {
        self.axes.iter_mut().find(|a| a.letter == letter)
    }

    /// The axes in the order their transforms multiply (see [`Chain::product_order`]).
    pub fn axes_in_product_order(&self) -> Vec<&Axis> {
        self.chain
            .product_order()
            .into_iter()
            .filter_map(|l| self.axis(l))
            .collect()
    }

    /// The rotary axes of the machine, in the order A B C.
    pub fn rotary_axes(&self) -> Vec<AxisLetter> {
        AxisLetter::ALL[3..]
            .iter()
            .copied()
            .filter(|&l| self.chain.contains(l))
            .collect()
    }

    /// An error-free machine with the given chain and travels (tests and examples).
    pub fn nominal(
        name: &str,
        chain: &str,
        ranges: &[(AxisLetter, [f64; 2])],
    ) -> Result<Machine, ChainError> {
        let chain = Chain::parse(chain)?;
        Ok(Machine {
            name: name.to_string(),
            description: String::new(),
            axes: ranges.iter().map(|&(l, r)| Axis::nominal(l, r)).collect(),
            chain,
            tool_offset_mm: [0.0; 3],
            spindle: [0.0; 5],
            thermal: None,
            dependent: Vec::new(),
            inputs: inputs::Inputs::default(),
            uncertainty: uncertainty::Uncertainty::default(),
            source: MachineSource::default(),
        })
    }

    /// The same machine with every error value zero (nominal offsets, directions, tool kept):
    /// the ideal machine of docs/model.md.
    pub fn without_errors(&self) -> Machine {
        let mut ideal = self.clone();
        for axis in &mut ideal.axes {
            axis.location = [0.0; 6];
            axis.components = Default::default();
        }
        ideal.spindle = [0.0; 5];
        ideal.dependent.clear();
        ideal.uncertainty = uncertainty::Uncertainty::default();
        ideal
    }
}

/// Commanded positions of all six possible axes, indexed by [`AxisLetter::index`]: mm for X Y Z,
/// degrees for A B C. Letters the machine lacks are ignored.
pub type Command = [f64; 6];
