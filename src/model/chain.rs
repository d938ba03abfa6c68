//! Axis letters and the kinematic chain, in the notation of Hwang et al. (`FYXCFZB`) or the
//! ISO 10791 structural code (`w C' X' Y' b Z B t`). See docs/model.md, "The kinematic chain".

use std::fmt;

/// One of the six axis letters. `X Y Z` are linear along +x, +y, +z; `A B C` rotate about
/// +x, +y, +z (right-hand rule).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum AxisLetter {
    X,
    Y,
    Z,
    A,
    B,
    C,
}

impl AxisLetter {
    pub const ALL: [AxisLetter; 6] = [
        AxisLetter::X,
        AxisLetter::Y,
        AxisLetter::Z,
        AxisLetter::A,
        AxisLetter::B,
        AxisLetter::C,
    ];

    pub fn from_char(c: char) -> Option<AxisLetter> {
        Some(match c {
            'X' => AxisLetter::X,
            'Y' => AxisLetter::Y,
            'Z' => AxisLetter::Z,
            'A' => AxisLetter::A,
            'B' => AxisLetter::B,
            'C' => AxisLetter::C,
            _ => return None,
        })
    }

    pub fn as_char(self) -> char {
        ['X', 'Y', 'Z', 'A', 'B', 'C'][self.index()]
    }

    /// 0..6 in the order X Y Z A B C.
    pub fn index(self) -> usize {
        self as usize
    }

    pub fn is_linear(self) -> bool {
        self.index() < 3
    }

    /// The coordinate direction (0 = x, 1 = y, 2 = z) the axis moves along or turns about.
    pub fn direction_index(self) -> usize {
        self.index() % 3
    }
}

impl fmt::Display for AxisLetter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.as_char())
    }
}

/// The two branches of a machine, each listed from the bed outward.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chain {
    /// Bed → workpiece.
    pub work: Vec<AxisLetter>,
    /// Bed → tool.
    pub tool: Vec<AxisLetter>,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ChainError {
    #[error("chain is empty")]
    Empty,
    #[error("chain `{0}` must start with `F` (Hwang et al.: F + work axes + F + tool axes) or `w` (ISO 10791: w ... b ... t)")]
    UnknownNotation(String),
    #[error("chain `{chain}`: unknown letter `{letter}` (axes are X Y Z A B C)")]
    UnknownLetter { chain: String, letter: char },
    #[error("chain `{chain}`: needs exactly two `F` (one per branch), found {found}")]
    FrameCount { chain: String, found: usize },
    #[error("chain `{chain}`: axis {axis} appears twice")]
    Duplicate { chain: String, axis: AxisLetter },
    #[error("chain `{chain}`: has no axes")]
    NoAxes { chain: String },
    #[error("chain `{chain}`: {what}")]
    Structure { chain: String, what: String },
}

crate::error::input_errors!(ChainError);

impl Chain {
    /// Parses either notation. Whitespace is ignored in both.
    pub fn parse(text: &str) -> Result<Chain, ChainError> {
        let compact: String = text.chars().filter(|c| !c.is_whitespace()).collect();
        match compact.chars().next() {
            None => Err(ChainError::Empty),
            Some('F') => Self::parse_hwang(text, &compact),
            Some('w') => Self::parse_iso10791(text, &compact),
            Some(_) => Err(ChainError::UnknownNotation(text.to_string())),
        }
    }

    fn parse_hwang(original: &str, compact: &str) -> Result<Chain, ChainError> {
        let frames = compact.chars().filter(|&c| c == 'F').count();
        if frames != 2 {
            return Err(ChainError::FrameCount {
                chain: original.to_string(),
                found: frames,
            });
        }
        let mut branches: [Vec<AxisLetter>; 2] = [Vec::new(), Vec::new()];
        let mut branch = 0usize;
        for (n, c) in compact.chars().enumerate() {
            if c == 'F' {
                if n > 0 {
                    branch = 1;
                }
                continue;
            }
            let letter = AxisLetter::from_char(c).ok_or_else(|| ChainError::UnknownLetter {
                chain: original.to_string(),
                letter: c,
            })?;
            branches[branch].push(letter);
        }
        let [work, tool] = branches;
        Self::checked(original, Chain { work, tool })
    }

    /// `w` + work-side axes read from the workpiece towards the bed (primed) + `b` + tool-side
    /// axes from the bed towards the tool + `t`.
    fn parse_iso10791(original: &str, compact: &str) -> Result<Chain, ChainError> {
        let structure = |what: &str| ChainError::Structure {
            chain: original.to_string(),
            what: what.to_string(),
        };
        let chars: Vec<char> = compact.chars().collect();
        if chars.last() != Some(&'t') {
            return Err(structure("the ISO 10791 code must end with `t` (the tool)"));
        }
        let bed = chars.iter().position(|&c| c == 'b').ok_or_else(|| {
            structure("the ISO 10791 code needs `b` (the bed) between the work and the tool axes")
        })?;
        let mut work_from_workpiece = Vec::new();
        let mut n = 1;
        while n < bed {
            let c = chars[n];
            let letter = AxisLetter::from_char(c).ok_or_else(|| ChainError::UnknownLetter {
                chain: original.to_string(),
                letter: c,
            })?;
            if chars.get(n + 1) != Some(&'\'') {
                return Err(structure(&format!(
                    "work-side axis {letter} (between `w` and `b`) must be primed: {letter}'"
                )));
            }
            work_from_workpiece.push(letter);
            n += 2;
        }
        let mut tool = Vec::new();
        for &c in &chars[bed + 1..chars.len() - 1] {
            if c == '\'' {
                return Err(structure(
                    "a primed axis stands after `b`: primes mark work-side axes only",
                ));
            }
            tool.push(
                AxisLetter::from_char(c).ok_or_else(|| ChainError::UnknownLetter {
                    chain: original.to_string(),
                    letter: c,
                })?,
            );
        }
        work_from_workpiece.reverse();
        Self::checked(
            original,
            Chain {
                work: work_from_workpiece,
                tool,
            },
        )
    }

    fn checked(original: &str, chain: Chain) -> Result<Chain, ChainError> {
        let mut seen = [false; 6];
        for &axis in chain.work.iter().chain(&chain.tool) {
            if std::mem::replace(&mut seen[axis.index()], true) {
                return Err(ChainError::Duplicate {
                    chain: original.to_string(),
                    axis,
                });
            }
        }
        if chain.work.is_empty() && chain.tool.is_empty() {
            return Err(ChainError::NoAxes {
                chain: original.to_string(),
            });
        }
        Ok(chain)
    }

    /// The axes in the order their relative transforms multiply in
    /// `E_rel = A_wm ⋯ A_w1 · A_t1 ⋯ A_tn` (docs/model.md): the work branch from the workpiece
    /// down to the bed, then the tool branch from the bed up to the tool.
    pub fn product_order(&self) -> Vec<AxisLetter> {
        self.work.iter().rev().chain(&self.tool).copied().collect()
    }

    pub fn contains(&self, axis: AxisLetter) -> bool {
        self.work.contains(&axis) || self.tool.contains(&axis)
    }

    pub fn axes(&self) -> impl Iterator<Item = AxisLetter> + '_ {
        self.work.iter().chain(&self.tool).copied()
    }

    /// The chain in Hwang's notation, e.g. `FYXCFZB`.
    pub fn hwang_notation(&self) -> String {
        let mut s = String::from("F");
        s.extend(self.work.iter().map(|a| a.as_char()));
        s.push('F');
        s.extend(self.tool.iter().map(|a| a.as_char()));
        s
    }

    /// The chain as an ISO 10791 structural code, e.g. `w C' X' Y' b Z B t`.
    pub fn iso10791_code(&self) -> String {
        let mut parts = vec!["w".to_string()];
        parts.extend(self.work.iter().rev().map(|a| format!("{a}'")));
        parts.push("b".into());
        parts.extend(self.tool.iter().map(|a| a.to_string()));
        parts.push("t".into());
        parts.join(" ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use AxisLetter::*;

    #[test]
    fn both_notations_agree() {
        let hwang = Chain::parse("FYXCFZB").unwrap();
        let iso = Chain::parse("w C' X' Y' b Z B t").unwrap();
        assert_eq!(hwang, iso);
        assert_eq!(hwang.work, vec![Y, X, C]);
        assert_eq!(hwang.tool, vec![Z, B]);
        assert_eq!(hwang.product_order(), vec![C, X, Y, Z, B]);
        assert_eq!(Chain::parse(&hwang.iso10791_code()).unwrap(), hwang);
        assert_eq!(hwang.hwang_notation(), "FYXCFZB");
    }

    #[test]
    fn bad_chains() {
        assert!(matches!(
            Chain::parse("FYXQFZ"),
            Err(ChainError::UnknownLetter { letter: 'Q', .. })
        ));
        assert!(matches!(
            Chain::parse("FYXFZX"),
            Err(ChainError::Duplicate { axis: X, .. })
        ));
        assert!(matches!(
            Chain::parse("FYXZ"),
            Err(ChainError::FrameCount { .. })
        ));
        assert!(matches!(
            Chain::parse("YXFZ"),
            Err(ChainError::UnknownNotation(_))
        ));
        assert!(matches!(
            Chain::parse("w X Y b Z t"),
            Err(ChainError::Structure { .. })
        ));
        assert!(matches!(Chain::parse("FF"), Err(ChainError::NoAxes { .. })));
    }
}
