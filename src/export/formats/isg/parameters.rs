//! The error parameters and the files of an `isg` export as both its writer and its reader know
//! them: the files' names, a parameter as written, and the axes of the configuration list.

use crate::model::{AxisLetter, Machine};

pub const CONFIG: &str = "vol_comp_0.lis";
pub const ERRORS: &str = "volcomp_errors.csv";

/// One error parameter as written: its ISG name (`EXX`, `C0Y`, `N0Z`), the axes it is
/// tabulated against (none: a constant), the nodes along each, and its values on the full grid
/// of the nodes, the first argument outermost.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    pub name: String,
    pub arguments: Vec<AxisLetter>,
    pub nodes: Vec<Vec<f64>>,
    pub values: Vec<f64>,
}

impl Parameter {
    /// Whether its values are angles (rad).
    pub fn is_angular(&self) -> bool {
        is_angular(&self.name)
    }
}

/// Whether the parameter `name` is an angle: a rotation component (`EA?`, `EB?`, `EC?`) or
/// orientation position error (`A0?`, `B0?`, `C0?`).
pub fn is_angular(name: &str) -> bool {
    let b = name.as_bytes();
    match b {
        [b'E', c, _] => matches!(c, b'A' | b'B' | b'C'),
        [c, b'0', _] => matches!(c, b'A' | b'B' | b'C'),
        _ => false,
    }
}

/// The ISG chain: the axes from the workpiece to the tool (the work branch from the workpiece
/// inward, then the tool branch from the bed), and how many of them carry the workpiece.
pub fn isg_chain(machine: &Machine) -> (String, usize) {
    let order: String = machine
        .chain
        .product_order()
        .iter()
        .map(|a| a.as_char())
        .collect();
    (order, machine.chain.work.len())
}

/// The logical axis numbers the configuration list assigns: X 1, Y 2, Z 3, then the rotary
/// axes in the order A B C from 4.
pub fn axis_numbers(machine: &Machine) -> Vec<(AxisLetter, usize)> {
    let mut out = Vec::new();
    let mut next = 4;
    for letter in AxisLetter::ALL {
        if machine.chain.contains(letter) {
            let n = if letter.is_linear() {
                letter.index() + 1
            } else {
                next += 1;
                next - 1
            };
            out.push((letter, n));
        }
    }
    out
}
