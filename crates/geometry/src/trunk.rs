//! Trunk states of the two-module "PDF" crane trunk (paper §6.2).
//!
//! A state is written `TOP&BOTTOM`: the top module (β = 31.72°) is `F` (folded, flexible) or
//! `D` (deployed); the bottom module (β = 35°) is `P` (self-packed), `F` or `D`.

use core::fmt;
use core::str::FromStr;

/// State of the top (β = 31.72°) module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "schema", derive(postcard_schema::Schema))]
pub enum TopState {
    /// Folded: short and flexible.
    Folded,
    /// Deployed: long and stiff.
    Deployed,
}

/// State of the bottom (β = 35°) module.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "schema", derive(postcard_schema::Schema))]
pub enum BottomState {
    /// Self-packed (hyperfolded, §3.1.2): the most compact state.
    Packed,
    /// Folded: short and flexible.
    Folded,
    /// Deployed: long and stiff.
    Deployed,
}

/// A state of the two-module trunk, `TOP&BOTTOM`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "schema", derive(postcard_schema::Schema))]
pub struct TrunkState {
    /// The top module.
    pub top: TopState,
    /// The bottom module.
    pub bottom: BottomState,
}

/// The text every parse error shows: the six valid states.
pub const VALID_STATES_TEXT: &str = "F&P, F&F, F&D, D&P, D&F, D&D";

/// A string that is not one of the six trunk states.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParseTrunkStateError;

impl fmt::Display for ParseTrunkStateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown trunk state; valid states are {VALID_STATES_TEXT}"
        )
    }
}

impl core::error::Error for ParseTrunkStateError {}

impl TrunkState {
    /// All six states, in the order `F&P, F&F, F&D, D&P, D&F, D&D`.
    pub const ALL: [TrunkState; 6] = [
        TrunkState::new(TopState::Folded, BottomState::Packed),
        TrunkState::new(TopState::Folded, BottomState::Folded),
        TrunkState::new(TopState::Folded, BottomState::Deployed),
        TrunkState::new(TopState::Deployed, BottomState::Packed),
        TrunkState::new(TopState::Deployed, BottomState::Folded),
        TrunkState::new(TopState::Deployed, BottomState::Deployed),
    ];

    /// The state as manufactured: `F&P`.
    pub const AS_MANUFACTURED: TrunkState = TrunkState::new(TopState::Folded, BottomState::Packed);

    /// A state from its two module states.
    pub const fn new(top: TopState, bottom: BottomState) -> Self {
        Self { top, bottom }
    }

    /// Index into [`TrunkState::ALL`] (0..6).
    pub const fn index(self) -> usize {
        let t = match self.top {
            TopState::Folded => 0,
            TopState::Deployed => 3,
        };
        let b = match self.bottom {
            BottomState::Packed => 0,
            BottomState::Folded => 1,
            BottomState::Deployed => 2,
        };
        t + b
    }

    /// The state at `index` in [`TrunkState::ALL`], if in range.
    pub fn from_index(index: usize) -> Option<Self> {
        Self::ALL.get(index).copied()
    }

    /// The canonical name, e.g. `"D&F"`.
    pub const fn name(self) -> &'static str {
        match (self.top, self.bottom) {
            (TopState::Folded, BottomState::Packed) => "F&P",
            (TopState::Folded, BottomState::Folded) => "F&F",
            (TopState::Folded, BottomState::Deployed) => "F&D",
            (TopState::Deployed, BottomState::Packed) => "D&P",
            (TopState::Deployed, BottomState::Folded) => "D&F",
            (TopState::Deployed, BottomState::Deployed) => "D&D",
        }
    }

    /// The four-character text for a 7-segment display, e.g. `"d-F "` (a lower-case `d`
    /// because an upper-case D cannot be drawn on seven segments).
    pub const fn display_text(self) -> &'static str {
        match (self.top, self.bottom) {
            (TopState::Folded, BottomState::Packed) => "F-P ",
            (TopState::Folded, BottomState::Folded) => "F-F ",
            (TopState::Folded, BottomState::Deployed) => "F-d ",
            (TopState::Deployed, BottomState::Packed) => "d-P ",
            (TopState::Deployed, BottomState::Folded) => "d-F ",
            (TopState::Deployed, BottomState::Deployed) => "d-d ",
        }
    }

    /// The flexible states in which the joystick may bend the trunk (paper §6.2):
    /// `F&F`, `D&F`, `D&P`, `F&D`.
    pub const fn is_flexible(self) -> bool {
        matches!(
            (self.top, self.bottom),
            (TopState::Folded, BottomState::Folded)
                | (TopState::Deployed, BottomState::Folded)
                | (TopState::Deployed, BottomState::Packed)
                | (TopState::Folded, BottomState::Deployed)
        )
    }
}

impl fmt::Display for TrunkState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.name())
    }
}

impl FromStr for TrunkState {
    type Err = ParseTrunkStateError;

    /// Parses `TOP&BOTTOM`, case-insensitive, surrounding whitespace ignored; `-` is accepted
    /// in place of `&` (shells make `&` awkward to type).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        let bytes = s.as_bytes();
        if bytes.len() != 3 || !(bytes[1] == b'&' || bytes[1] == b'-') {
            return Err(ParseTrunkStateError);
        }
        let top = match bytes[0].to_ascii_uppercase() {
            b'F' => TopState::Folded,
            b'D' => TopState::Deployed,
            _ => return Err(ParseTrunkStateError),
        };
        let bottom = match bytes[2].to_ascii_uppercase() {
            b'P' => BottomState::Packed,
            b'F' => BottomState::Folded,
            b'D' => BottomState::Deployed,
            _ => return Err(ParseTrunkStateError),
        };
        Ok(Self { top, bottom })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_for_all_six_states() {
        for (i, s) in TrunkState::ALL.iter().enumerate() {
            assert_eq!(s.index(), i);
            assert_eq!(TrunkState::from_index(i), Some(*s));
            assert_eq!(s.name().parse::<TrunkState>(), Ok(*s));
        }
        assert_eq!(TrunkState::from_index(6), None);
    }

    #[test]
    fn parse_accepts_lower_case_and_dash() {
        let df = TrunkState::new(TopState::Deployed, BottomState::Folded);
        assert_eq!("d&f".parse::<TrunkState>(), Ok(df));
        assert_eq!(" D-F ".parse::<TrunkState>(), Ok(df));
    }

    #[test]
    fn parse_rejects_invalid_states() {
        for bad in ["", "D&", "P&D", "F&X", "DD", "D&DD", "F&Pé", "é&P"] {
            assert_eq!(
                bad.parse::<TrunkState>(),
                Err(ParseTrunkStateError),
                "{bad}"
            );
        }
        let mut buf = [0u8; 128];
        let msg = {
            use core::fmt::Write;
            struct W<'a>(&'a mut [u8], usize);
            impl Write for W<'_> {
                fn write_str(&mut self, s: &str) -> fmt::Result {
                    let end = self.1 + s.len();
                    self.0
                        .get_mut(self.1..end)
                        .ok_or(fmt::Error)?
                        .copy_from_slice(s.as_bytes());
                    self.1 = end;
                    Ok(())
                }
            }
            let mut w = W(&mut buf, 0);
            write!(w, "{ParseTrunkStateError}").unwrap();
            let n = w.1;
            core::str::from_utf8(&buf[..n]).unwrap()
        };
        for name in ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"] {
            assert!(msg.contains(name), "{msg}");
        }
    }

    #[test]
    fn exactly_four_states_are_flexible() {
        let flexible: usize = TrunkState::ALL.iter().filter(|s| s.is_flexible()).count();
        assert_eq!(flexible, 4);
        assert!(!TrunkState::AS_MANUFACTURED.is_flexible());
        assert!(!"D&D".parse::<TrunkState>().unwrap().is_flexible());
    }
}
