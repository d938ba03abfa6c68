//! What a controller format is to the export: its facts as data ([`Spec`]: name, limits, what
//! its tables can hold), and the code it brings ([`Format`]: how it fits and writes its tables,
//! how it reads them back) to hand the core a [`Control`], the control's own use of the tables
//! as written.

use super::error::ExportError;
use super::fitting::{Fitting, Structure};
use crate::model::inputs::Approach;
use crate::model::Command;

/// One file an export writes: its name (relative to `--out`'s folder for a multi-file format)
/// and its whole text.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct WrittenFile {
    pub name: String,
    pub text: String,
}

/// Where a format's files go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// One file: the output path is that file.
    File,
    /// Several files: the output path is a folder (created), the files named by the format.
    Folder,
}

/// How a format places the nodes of its tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Nodes {
    /// Anywhere along the travel, in increasing order: volmap chooses them.
    Free,
    /// At a constant spacing from a start position.
    Equidistant,
    /// No nodes at all: a fixed set of numbers (a skew), so no table size to choose.
    Fixed,
}

/// The table sizes a format accepts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    pub nodes: Nodes,
    /// The fewest and the most points one table (per axis, for a 3-D grid) holds.
    pub min_points: usize,
    pub max_points: usize,
    /// The smallest spacing between nodes the format accepts, mm (0: any).
    pub min_spacing_mm: f64,
    /// The points per table when neither a spacing nor a number of points is asked for.
    pub default_points: usize,
    /// Where the limits come from, for messages: "LinuxCNC's motion module (EMCMOT_COMP_SIZE)".
    pub source: &'static str,
}

/// The table size asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TableSize {
    /// The format's default.
    Default,
    /// Points per table (per axis for a 3-D grid).
    Points(usize),
    /// Spacing between nodes, mm.
    Spacing(f64),
}

/// A table of one file as written, for the report.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TableInfo {
    /// What the table is: "grid", "joint 0 (X)", "skew".
    pub name: String,
    /// Its size in words: "21 x 21 x 21 points, spacing 50 x 30 x 25 mm", "3 factors".
    pub size: String,
    /// The most points along one axis (for the evaluation grid's density).
    pub points: usize,
    /// The components of the correction (X, Y, Z) its values hold, for the uncertainty of its
    /// nodes ([`uncertainty`](crate::export::uncertainty)).
    #[serde(skip)]
    pub corrects: [bool; 3],
}

/// A table that holds every component of the correction.
pub const EVERY_COMPONENT: [bool; 3] = [true; 3];

/// A table that holds the correction of axis `k` (0, 1, 2: X, Y, Z) alone.
pub fn component(k: usize) -> [bool; 3] {
    std::array::from_fn(|d| d == k)
}

/// A skew's factors: X's and Y's corrections (`xy`, `xz`, `yz`).
pub const SKEW_COMPONENTS: [bool; 3] = [true, true, false];

/// What a format is, as data: one `const SPEC: Spec` beside each format's code, read by the
/// core (the table size's checks, the report) and the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spec {
    /// The name `--format` takes: `grid-csv`.
    pub name: &'static str,
    /// The controller in words: "LinuxCNC (joint compensation files, matrixkins)".
    pub title: &'static str,
    pub layout: Layout,
    pub limits: Limits,
    pub structure: Structure,
    /// What its tables hold and cannot hold, one sentence for the report.
    pub holds: &'static str,
    /// Whether the control picks a table by the direction each axis approaches (LinuxCNC's
    /// forward and reverse columns): the report then says so.
    pub uses_direction: bool,
}

/// A controller format: its code. A trait object (the registry holds every format as one), so
/// its facts come by [`Format::spec`], not as associated consts.
pub trait Format: Sync {
    /// The format's facts: its `SPEC`.
    fn spec(&self) -> &'static Spec;
    /// The versions or generations of the control the format is written for, the default
    /// first (none: one layout for every control).
    fn controls(&self) -> &'static [&'static str] {
        &[]
    }
    /// Whether the tables take numbers from a pool of compensation points the request may give
    /// ([`Request::point_numbers`](crate::export::Request::point_numbers)).
    fn numbers_points(&self) -> bool {
        false
    }
    /// Whether the tables correct a probe's readings, so the request must give the probe's
    /// offset from the nozzle ([`Request::probe_offset_mm`](crate::export::Request::probe_offset_mm)).
    fn takes_probe_offset(&self) -> bool {
        false
    }
    /// What starts a comment line where the format's one file may end in comments (`# `, `; `):
    /// the report is written there. `None`: no comments (or a folder format).
    fn comment_prefix(&self) -> Option<&'static str> {
        None
    }
    /// Adds each `(table, line)` of `notes` as a comment to the file that holds that table
    /// (after what the control reads), where a folder format's files take comments; a one-file
    /// format's file has them with the report ([`Format::comment_prefix`]).
    fn note_tables(&self, _files: &mut [WrittenFile], _notes: &[(String, String)]) {}
    /// The facts of the format written for `control` (one of [`Format::controls`]).
    fn spec_for(&self, _control: Option<&str>) -> &'static Spec {
        self.spec()
    }
    /// Fits the tables to the correction and writes them as the control reads them; `points`
    /// is the size the core checked against [`Spec::limits`] (per axis; `None` for
    /// [`Nodes::Fixed`]), `spacing_mm` set where a spacing was asked for.
    fn write(
        &self,
        fitting: &Fitting,
        points: Option<[usize; 3]>,
        spacing_mm: Option<f64>,
    ) -> Result<Vec<WrittenFile>, ExportError>;
    /// Reads the files as the control reads them, on a machine whose X, Y, Z travels (the
    /// control's own limits) are `travel_mm`; what does not read is an error naming the file
    /// and line.
    fn read(
        &self,
        files: &[WrittenFile],
        travel_mm: &[[f64; 2]; 3],
    ) -> Result<Box<dyn Control>, ExportError>;
    /// [`Format::read`] for the machine the files were written for. A control that runs its own
    /// kinematic model (the ISG kernel's volumetric compensation) takes the error parameters
    /// from the files and the nominal kinematics from its own configuration, which the files do
    /// not carry: such a format reads them here, with `fitting`'s machine as that
    /// configuration. Every other format reads the files alone, on the travels of `fitting`.
    fn read_for(
        &self,
        files: &[WrittenFile],
        fitting: &Fitting,
    ) -> Result<Box<dyn Control>, ExportError> {
        self.read(files, &fitting.ranges)
    }
}

/// What a control does with the tables it loaded.
pub trait Control: Sync {
    /// The command the control moves the axes to when the program asks for `target` (X, Y, Z
    /// mm; rotary axes in degrees, passed through), each axis approaching in `approach`:
    /// `target + Σ contributions`, every table evaluated with the control's own interpolation at
    /// the positions the control looks it up by.
    fn command(&self, target: &Command, approach: &[Approach; 6]) -> Command;
    /// The tables, for the report.
    fn tables(&self) -> Vec<TableInfo>;
    /// The commands (X, Y, Z, mm) of the nodes where each node holds every component of the
    /// correction at its own command (a 3-D grid), for the uncertainty of the nodes; `None`:
    /// a node applies over a line or a plane of commands.
    fn nodes(&self) -> Option<Vec<[f64; 3]>> {
        None
    }
}
