//! Names of a module's metastable shape states (paper Table 1, §3.2, §4).

use core::fmt;

/// One of the 2(n+1) shape states of the catalogue (§4: deployed, folded, n one-pop-out and
/// n two-pop-out states).
///
/// Names (`Display`/[`ShapeState::parse`]): `deployed`, `folded`, `edge-i` = the one-pop-out
/// state whose coinciding edge is the bottom edge from vertex i to vertex i+1, `vertex-i` =
/// the two-pop-out state whose coinciding vertex is bottom vertex i (numbered as in eq 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum ShapeState {
    /// Fully deployed: d = w, γ = 0, θ = 180°.
    Deployed,
    /// Symmetric folded state: γ = 0, d = w sin(θ/2) (Table 1, eqs 10–11).
    Folded,
    /// One pop-out (θ_in = 0): bottom edge (i, i+1) coincides with the top edge (i, i+1).
    Edge(u8),
    /// Two pop-out (θ_out = 0): bottom vertex i coincides with top vertex i.
    Vertex(u8),
}

impl ShapeState {
    /// Parses a state name for an n-sided module: `deployed`, `folded`, `edge-i`, `vertex-i`
    /// with 0 ≤ i < n (case-insensitive, surrounding whitespace ignored).
    pub fn parse(name: &str, n: u32) -> Result<Self, ParseShapeStateError> {
        let s = name.trim();
        let unknown = ParseShapeStateError {
            n,
            kind: ParseShapeStateErrorKind::Unknown,
        };
        if s.eq_ignore_ascii_case("deployed") {
            return Ok(ShapeState::Deployed);
        }
        if s.eq_ignore_ascii_case("folded") {
            return Ok(ShapeState::Folded);
        }
        let (is_edge, rest) = if let Some(rest) = strip_prefix_ci(s, "edge-") {
            (true, rest)
        } else if let Some(rest) = strip_prefix_ci(s, "vertex-") {
            (false, rest)
        } else {
            return Err(unknown);
        };
        if rest.is_empty() || !rest.bytes().all(|b| b.is_ascii_digit()) {
            return Err(unknown);
        }
        let index: u32 = rest.parse().map_err(|_| ParseShapeStateError {
            n,
            kind: ParseShapeStateErrorKind::IndexOutOfRange,
        })?;
        if index >= n || index > u8::MAX as u32 {
            return Err(ParseShapeStateError {
                n,
                kind: ParseShapeStateErrorKind::IndexOutOfRange,
            });
        }
        let i = index as u8;
        Ok(if is_edge {
            ShapeState::Edge(i)
        } else {
            ShapeState::Vertex(i)
        })
    }

    /// Position of this state in [`crate::ModuleDesign::shape_states`]'s order
    /// (deployed, folded, edge-0…, vertex-0…) for an n-sided module.
    pub fn index(self, n: u32) -> usize {
        match self {
            ShapeState::Deployed => 0,
            ShapeState::Folded => 1,
            ShapeState::Edge(i) => 2 + i as usize,
            ShapeState::Vertex(i) => 2 + n as usize + i as usize,
        }
    }

    /// Whether this is a pop-out (asymmetric) state.
    pub fn is_pop_out(self) -> bool {
        matches!(self, ShapeState::Edge(_) | ShapeState::Vertex(_))
    }
}

fn strip_prefix_ci<'a>(s: &'a str, prefix: &str) -> Option<&'a str> {
    let head = s.get(..prefix.len())?;
    if head.eq_ignore_ascii_case(prefix) {
        s.get(prefix.len()..)
    } else {
        None
    }
}

impl fmt::Display for ShapeState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShapeState::Deployed => f.write_str("deployed"),
            ShapeState::Folded => f.write_str("folded"),
            ShapeState::Edge(i) => write!(f, "edge-{i}"),
            ShapeState::Vertex(i) => write!(f, "vertex-{i}"),
        }
    }
}

/// What was wrong with a state name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParseShapeStateErrorKind {
    /// Not `deployed`, `folded`, `edge-<i>` or `vertex-<i>`.
    Unknown,
    /// `edge-<i>`/`vertex-<i>` with i ≥ n.
    IndexOutOfRange,
}

/// A name that is not a shape state of an n-sided module. `Display` lists the valid names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParseShapeStateError {
    /// The module's n the name was checked against.
    pub n: u32,
    /// What was wrong.
    pub kind: ParseShapeStateErrorKind,
}

impl fmt::Display for ParseShapeStateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let last = self.n.saturating_sub(1);
        match self.kind {
            ParseShapeStateErrorKind::Unknown => f.write_str("unknown shape state")?,
            ParseShapeStateErrorKind::IndexOutOfRange => {
                f.write_str("shape state index out of range")?
            }
        }
        write!(
            f,
            "; valid states for n = {} are deployed, folded, edge-0 … edge-{last}, vertex-0 … vertex-{last}",
            self.n
        )
    }
}

impl core::error::Error for ParseShapeStateError {}

/// Iterator over the 2(n+1) catalogue states: deployed, folded, edge-0 … edge-(n−1),
/// vertex-0 … vertex-(n−1).
#[derive(Debug, Clone)]
pub struct ShapeStates {
    n: u32,
    next: u32,
}

impl ShapeStates {
    pub(crate) fn new(n: u32) -> Self {
        Self { n, next: 0 }
    }
}

impl Iterator for ShapeStates {
    type Item = ShapeState;

    fn next(&mut self) -> Option<ShapeState> {
        let k = self.next;
        let n = self.n;
        let s = match k {
            0 => ShapeState::Deployed,
            1 => ShapeState::Folded,
            k if k < 2 + n => ShapeState::Edge((k - 2) as u8),
            k if k < 2 + 2 * n => ShapeState::Vertex((k - 2 - n) as u8),
            _ => return None,
        };
        self.next += 1;
        Some(s)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = (2 * self.n + 2).saturating_sub(self.next) as usize;
        (left, Some(left))
    }
}

impl ExactSizeIterator for ShapeStates {}

/// The symmetric states of Table 1 (γ = 0, ψ = 0). `FlatFolded` and `SelfPacked` are not
/// in the 2(n+1) catalogue (they do not change the boom's shape, §4) but a simulator needs
/// their heights.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum SymmetricState {
    /// d = w, θ = 180°, any β.
    Deployed,
    /// d = w sin(θ/2), β ≥ 90°/n.
    Folded,
    /// d = 0, θ = 0, only at β = 90°/n.
    FlatFolded,
    /// d = 0 with hyperfold angle ζ, β ∈ (90°/n, 45°].
    SelfPacked,
}

impl SymmetricState {
    /// All four, in Table 1's order.
    pub const ALL: [SymmetricState; 4] = [
        SymmetricState::Deployed,
        SymmetricState::Folded,
        SymmetricState::FlatFolded,
        SymmetricState::SelfPacked,
    ];

    /// The name: `deployed`, `folded`, `flat-folded`, `self-packed`.
    pub const fn name(self) -> &'static str {
        match self {
            SymmetricState::Deployed => "deployed",
            SymmetricState::Folded => "folded",
            SymmetricState::FlatFolded => "flat-folded",
            SymmetricState::SelfPacked => "self-packed",
        }
    }
}

impl fmt::Display for SymmetricState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.name())
    }
}
