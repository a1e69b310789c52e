//! Where in β each family of states is feasible: the design space of one n.
//!
//! A pop-out is feasible only near the fold angle at which it closes exactly (β_in for the edge
//! pop-outs, β_out for the vertex pop-outs, [`geometry::popout`]); away from it the crease
//! strain of its 3D construction grows past [`geometry::STRAIN_TOLERANCE`]. [`bands`] sweeps β
//! over (0°, 90°) and returns every interval where a family is feasible, its ends refined by
//! bisection. The edge (vertex) pop-outs of one module are rotations of each other, so `edge-0`
//! (`vertex-0`) stands for the family.

use geometry::{popout, ModuleDesign, ShapeState};

/// A family of states whose feasibility depends on β alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// `folded` (straight, short).
    Folded,
    /// The n edge pop-outs `edge-i` (bent, one pop-out).
    Edge,
    /// The n vertex pop-outs `vertex-i` (bent, two pop-outs).
    Vertex,
    /// `self-packed` (straight, d = 0; the hyperfold of §3.1.2).
    SelfPacked,
}

impl Family {
    /// Every family, in report order.
    pub const ALL: [Family; 4] = [
        Family::Folded,
        Family::Edge,
        Family::Vertex,
        Family::SelfPacked,
    ];

    /// The family's name in reports (`folded`, `edge`, `vertex`, `self-packed`).
    pub fn name(self) -> &'static str {
        match self {
            Family::Folded => "folded",
            Family::Edge => "edge",
            Family::Vertex => "vertex",
            Family::SelfPacked => "self-packed",
        }
    }

    /// Whether the family's states bend the boom (tilt γ > 0).
    pub fn bends(self) -> bool {
        matches!(self, Family::Edge | Family::Vertex)
    }

    /// The state that stands for the family in a catalogue (`None` for self-packed, which is a
    /// symmetric extra, not a catalogue state).
    pub fn representative(self) -> Option<ShapeState> {
        match self {
            Family::Folded => Some(ShapeState::Folded),
            Family::Edge => Some(ShapeState::Edge(0)),
            Family::Vertex => Some(ShapeState::Vertex(0)),
            Family::SelfPacked => None,
        }
    }

    /// Whether the family is feasible for `n` sides at fold angle `beta_deg` (false for an
    /// invalid design).
    pub fn feasible(self, n: u32, beta_deg: f64) -> bool {
        let Ok(d) = ModuleDesign::new(n, beta_deg) else {
            return false;
        };
        match self.representative() {
            Some(s) => d.state_info(s).feasible,
            None => d.can_self_pack(),
        }
    }

    /// The limiting angle the family closes at exactly, if it has one: β_in (edge), β_out
    /// (vertex), from [`geometry::popout`].
    pub fn closing_angle_deg(self, n: u32) -> Option<f64> {
        match self {
            Family::Edge => popout::beta_in_deg(n),
            Family::Vertex => popout::beta_out_deg(n),
            _ => None,
        }
    }
}

/// A β interval `[lo_deg, hi_deg]` in which a family is feasible.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    /// Which family.
    pub family: Family,
    /// Smallest feasible β found (degrees), to [`BAND_TOLERANCE_DEG`].
    pub lo_deg: f64,
    /// Largest feasible β found (degrees), to [`BAND_TOLERANCE_DEG`].
    pub hi_deg: f64,
}

impl Band {
    /// Whether `beta_deg` lies in the band.
    pub fn contains(&self, beta_deg: f64) -> bool {
        (self.lo_deg..=self.hi_deg).contains(&beta_deg)
    }

    /// The band's middle.
    pub fn mid_deg(&self) -> f64 {
        0.5 * (self.lo_deg + self.hi_deg)
    }
}

/// Scan step of [`bands`] (degrees). Bands narrower than this can be missed unless they contain
/// a family's closing angle, which is always probed.
pub const SCAN_STEP_DEG: f64 = 0.05;

/// How precisely [`bands`] locates a band's ends (degrees).
pub const BAND_TOLERANCE_DEG: f64 = 1e-6;

/// Feasible runs narrower than this (degrees) are isolated points, not bands, and are left
/// out: e.g. n = 3 at β = 60° exactly, where w = 2λ′ and the edge pop-outs fold over to
/// γ = 180° with zero strain — a degenerate closed form no fabrication tolerance could hold.
pub const MIN_BAND_WIDTH_DEG: f64 = 1e-3;

/// Every interval of β ∈ (0°, 90°) where `family` is feasible for `n` sides, in increasing β:
/// a scan at [`SCAN_STEP_DEG`] (plus the family's closing angle β_in/β_out) whose feasible
/// runs are widened by bisection against their infeasible neighbours to
/// [`BAND_TOLERANCE_DEG`]; runs narrower than [`MIN_BAND_WIDTH_DEG`] are dropped.
pub fn family_bands(n: u32, family: Family) -> Vec<Band> {
    let feasible = |b: f64| family.feasible(n, b);
    let steps = (90.0 / SCAN_STEP_DEG).round() as usize;
    let mut grid: Vec<f64> = (1..steps).map(|k| k as f64 * SCAN_STEP_DEG).collect();
    if let Some(c) = family.closing_angle_deg(n) {
        if c > 0.0 && c < 90.0 {
            grid.push(c);
        }
    }
    grid.sort_by(f64::total_cmp);
    grid.dedup();
    let ok: Vec<bool> = grid.iter().map(|&b| feasible(b)).collect();
    // Refines the boundary between a feasible `inside` and an infeasible `outside`.
    let refine = |mut inside: f64, mut outside: f64| {
        while (outside - inside).abs() > BAND_TOLERANCE_DEG {
            let mid = 0.5 * (inside + outside);
            if feasible(mid) {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        inside
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < grid.len() {
        if !ok[i] {
            i += 1;
            continue;
        }
        let start = i;
        while i + 1 < grid.len() && ok[i + 1] {
            i += 1;
        }
        let lo = if start == 0 {
            refine(grid[0], BAND_TOLERANCE_DEG)
        } else {
            refine(grid[start], grid[start - 1])
        };
        let hi = if i + 1 == grid.len() {
            refine(grid[i], 90.0 - BAND_TOLERANCE_DEG)
        } else {
            refine(grid[i], grid[i + 1])
        };
        if hi - lo >= MIN_BAND_WIDTH_DEG {
            out.push(Band {
                family,
                lo_deg: lo,
                hi_deg: hi,
            });
        }
        i += 1;
    }
    out
}

/// The bands of every family of [`Family::ALL`] for `n` sides.
pub fn bands(n: u32) -> Vec<Band> {
    Family::ALL
        .iter()
        .flat_map(|&f| family_bands(n, f))
        .collect()
}

/// The bands where a bending family (edge or vertex pop-outs) is feasible for `n` sides.
pub fn bending_bands(n: u32) -> Vec<Band> {
    [Family::Edge, Family::Vertex]
        .iter()
        .flat_map(|&f| family_bands(n, f))
        .collect()
}

/// `22.81–24.02° (edge), 30.1–30.4° (vertex)`, or `none` — for messages.
pub fn describe(bands: &[Band]) -> String {
    if bands.is_empty() {
        return "none in (0°, 90°)".to_string();
    }
    bands
        .iter()
        .map(|b| format!("{:.2}–{:.2}° ({})", b.lo_deg, b.hi_deg, b.family.name()))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edge_and_vertex_bands_contain_the_closing_angles_and_end_where_feasibility_ends() {
        for n in 3..=8 {
            for family in [Family::Edge, Family::Vertex] {
                let bands = family_bands(n, family);
                for b in &bands {
                    assert!(b.lo_deg <= b.hi_deg, "{n} {family:?} {b:?}");
                    assert!(family.feasible(n, b.lo_deg) && family.feasible(n, b.hi_deg));
                    // Just outside each end the family is infeasible (unless the end is the
                    // edge of (0°, 90°)).
                    assert!(b.hi_deg - b.lo_deg >= MIN_BAND_WIDTH_DEG);
                    for out in [b.lo_deg - 1e-5, b.hi_deg + 1e-5] {
                        if out > 0.0 && out < 90.0 {
                            assert!(!family.feasible(n, out), "{n} {family:?} {out}");
                        }
                    }
                }
                if let Some(c) = family.closing_angle_deg(n) {
                    if family.feasible(n, c) {
                        assert!(
                            bands.iter().any(|b| b.contains(c)),
                            "n = {n} {family:?}: closing angle {c} in no band {bands:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn n4_edge_popouts_are_feasible_near_23_degrees_only() {
        // The figures: n = 4 edge pop-outs at 22.8–24°, none at 25° or 35°.
        let bands = family_bands(4, Family::Edge);
        assert!(bands.iter().any(|b| b.contains(23.5)), "{bands:?}");
        assert!(!bands.iter().any(|b| b.contains(25.0) || b.contains(35.0)));
    }
}
