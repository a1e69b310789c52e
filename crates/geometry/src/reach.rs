//! Where the crane's tip is: its pose for a trunk state and a bend, and each state's workspace.
//!
//! The trunk is two modules stacked on the base (bottom β = 35°, top β = 31.72°), each a
//! straight prism of its state's height (`TrunkHeights`) until the tendons bend it. A bend
//! (θ toward φ, [`Bend`]) is constant curvature over the state's *flexible length*: the folded
//! modules bend, a deployed or self-packed module stays straight and is carried by the bend
//! below it. A state with no folded module (`D&P`) bends over its whole height. Each bending
//! module of height h takes the share θ·h/L of the angle (L: the flexible length, so the
//! curvature θ/L is the same in all of them), and its top lies, in its own frame, at
//!
//! ρ = h·(1 − cos θ_i)/θ_i (toward φ), z = h·sin θ_i/θ_i (along its axis),
//!
//! which tends to (0, h) as θ_i → 0 (the series is used there, no division by zero). The
//! frames are chained bottom to top by rotations of θ_i about the axis normal to φ, so the tip
//! axis is tilted by θ toward φ whatever the split. `docs/geometry.md` ("Tip pose and
//! workspace") derives it and compares it with the simulator.
//!
//! The workspace of a state is the set of tips for every bend the controller allows there
//! (`|θ| ≤ max_bend`, any φ): a surface of revolution about the base axis, whose side view is
//! one curve for θ ∈ [−max, max]. [`nearest`] finds the closest point of that surface to a
//! goal.

use crate::tendon::Bend;
use crate::trunk::{BottomState, TopState, TrunkState};
use crate::ModuleDesign;
use crate::ShapeState;

/// Why a trunk's dimensions or a query were refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReachError {
    /// A height is not finite or negative, or a module design is invalid.
    BadDimensions,
    /// An input (point, angle) is NaN or infinite, or a bend limit is negative.
    NotFinite,
}

impl core::fmt::Display for ReachError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ReachError::BadDimensions => {
                f.write_str("module heights must be finite and non-negative (mm)")
            }
            ReachError::NotFinite => {
                f.write_str("tip queries need finite inputs and a non-negative bend limit")
            }
        }
    }
}

impl core::error::Error for ReachError {}

/// Straight heights of the crane's two modules in each of their states, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TrunkHeights {
    /// Top module folded, deployed.
    pub top_mm: [f64; 2],
    /// Bottom module self-packed, folded, deployed.
    pub bottom_mm: [f64; 3],
}

/// One module of the crane as built: its design (n, β), the edge length and the layers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuiltModule {
    /// Polygon sides.
    pub n: u32,
    /// Fold angle β, degrees.
    pub beta_deg: f64,
    /// Valley fold (edge) length l, mm.
    pub edge_mm: f64,
    /// Layers (Yoshimura units) stacked in the module.
    pub layers: u32,
}

impl TrunkHeights {
    /// Heights from explicit values; every one finite and ≥ 0.
    pub fn new(top_mm: [f64; 2], bottom_mm: [f64; 3]) -> Result<Self, ReachError> {
        if top_mm
            .iter()
            .chain(bottom_mm.iter())
            .all(|h| h.is_finite() && *h >= 0.0)
        {
            Ok(Self { top_mm, bottom_mm })
        } else {
            Err(ReachError::BadDimensions)
        }
    }

    /// Heights of the built trunk: per module layers × the layer's slant height d (folded or
    /// deployed, the catalogue's pose) × the edge; a self-packed bottom is layers ×
    /// `packed_layer_mm` (d → 0, the panels' thickness stacked).
    pub fn of_modules(
        top: BuiltModule,
        bottom: BuiltModule,
        packed_layer_mm: f64,
    ) -> Result<Self, ReachError> {
        let d = |m: &BuiltModule, s: ShapeState| -> Result<f64, ReachError> {
            let design =
                ModuleDesign::new(m.n, m.beta_deg).map_err(|_| ReachError::BadDimensions)?;
            Ok(f64::from(m.layers) * design.pose(s).d * m.edge_mm)
        };
        Self::new(
            [d(&top, ShapeState::Folded)?, d(&top, ShapeState::Deployed)?],
            [
                f64::from(bottom.layers) * packed_layer_mm,
                d(&bottom, ShapeState::Folded)?,
                d(&bottom, ShapeState::Deployed)?,
            ],
        )
    }

    /// Straight heights `[bottom, top]` in `state`, mm.
    pub fn modules_mm(&self, state: TrunkState) -> [f64; 2] {
        let top = match state.top {
            TopState::Folded => self.top_mm[0],
            TopState::Deployed => self.top_mm[1],
        };
        let bottom = match state.bottom {
            BottomState::Packed => self.bottom_mm[0],
            BottomState::Folded => self.bottom_mm[1],
            BottomState::Deployed => self.bottom_mm[2],
        };
        [bottom, top]
    }

    /// Straight height of the trunk in `state`, mm.
    pub fn height_mm(&self, state: TrunkState) -> f64 {
        let [b, t] = self.modules_mm(state);
        b + t
    }

    /// The length over which `state` bends, mm (the folded modules, or the whole trunk when
    /// none is folded).
    pub fn flexible_mm(&self, state: TrunkState) -> f64 {
        let [b, t] = self.modules_mm(state);
        let [bb, tb] = bending_modules(state);
        match (bb, tb) {
            (true, true) => b + t,
            (true, false) => b,
            (false, true) => t,
            (false, false) => 0.0,
        }
    }
}

/// Which modules `[bottom, top]` take the bend in `state`: the folded ones, or both when none
/// is folded.
pub fn bending_modules(state: TrunkState) -> [bool; 2] {
    let top = state.top == TopState::Folded;
    let bottom = state.bottom == BottomState::Folded;
    if top || bottom {
        [bottom, top]
    } else {
        [true, true]
    }
}

/// The tip's pose in the base frame (z up along the straight trunk, x toward tendon 0).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TipPose {
    /// Tip position, mm.
    pub position_mm: [f64; 3],
    /// Unit vector of the tip's axis (where the gripper points is its opposite for a crane
    /// hanging down; here the axis points away from the base).
    pub axis: [f64; 3],
}

/// Top of one constant-curvature segment of length `h` bent by `angle` (signed), in its own
/// frame: (ρ toward the bend, z along the axis). The series near 0 keeps it exact and finite.
pub fn arc_tip(h: f64, angle: f64) -> (f64, f64) {
    let a = angle;
    if libm::fabs(a) < 1e-4 {
        let a2 = a * a;
        // (1 − cos a)/a = a/2 − a³/24 + …, sin a / a = 1 − a²/6 + a⁴/120 …
        (
            h * (a / 2.0 - a * a2 / 24.0),
            h * (1.0 - a2 / 6.0 + a2 * a2 / 120.0),
        )
    } else {
        (h * (1.0 - libm::cos(a)) / a, h * libm::sin(a) / a)
    }
}

/// Tip of a chain of segments `(height, signed angle)` from the base, each bending in the
/// plane of `direction` (radians from +x): the side-view position (ρ, z) and the tilt.
pub fn chain_in_plane(segments: &[(f64, f64)]) -> (f64, f64, f64) {
    let (mut rho, mut z, mut tilt) = (0.0, 0.0, 0.0);
    for &(h, a) in segments {
        let (dr, dz) = arc_tip(h, a);
        let (s, c) = (libm::sin(tilt), libm::cos(tilt));
        rho += c * dr + s * dz;
        z += -s * dr + c * dz;
        tilt += a;
    }
    (rho, z, tilt)
}

/// The 3D pose of a side-view tip (ρ, z, tilt) in the plane of `direction`.
pub fn pose_from_plane(rho: f64, z: f64, tilt: f64, direction: f64) -> TipPose {
    let (sd, cd) = (libm::sin(direction), libm::cos(direction));
    let (st, ct) = (libm::sin(tilt), libm::cos(tilt));
    TipPose {
        position_mm: [rho * cd, rho * sd, z],
        axis: [st * cd, st * sd, ct],
    }
}

/// Side view of the tip of `state` bent by a signed angle (radians): (ρ, z, tilt).
pub fn side_tip(heights: &TrunkHeights, state: TrunkState, angle: f64) -> (f64, f64, f64) {
    let [b, t] = heights.modules_mm(state);
    let [bb, tb] = bending_modules(state);
    let flex = heights.flexible_mm(state);
    let share = |h: f64, bends: bool| {
        if bends && flex > 0.0 {
            angle * h / flex
        } else {
            0.0
        }
    };
    chain_in_plane(&[(b, share(b, bb)), (t, share(t, tb))])
}

/// Side view of the tip of `state` bent by a signed angle (radians) with the bend split
/// between the modules as given: the bottom takes `bottom_share` of it, the top the rest (a
/// calibrated split, where the geometry's own is by length over the flexible modules).
pub fn side_tip_split(
    heights: &TrunkHeights,
    state: TrunkState,
    angle: f64,
    bottom_share: f64,
) -> (f64, f64, f64) {
    let [b, t] = heights.modules_mm(state);
    let s = bottom_share.clamp(0.0, 1.0);
    chain_in_plane(&[(b, angle * s), (t, angle * (1.0 - s))])
}

/// The tip of `state` under `bend` (the geometry's constant-curvature model, see the module
/// text).
pub fn tip_pose(heights: &TrunkHeights, state: TrunkState, bend: Bend) -> TipPose {
    let (rho, z, tilt) = side_tip(heights, state, bend.angle);
    pose_from_plane(rho, z, tilt, bend.direction)
}

/// The point of a state's workspace nearest a goal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// The bend that reaches it.
    pub bend: Bend,
    /// The tip there.
    pub tip: TipPose,
    /// Distance from the goal, mm.
    pub distance_mm: f64,
}

/// The bend within `|θ| ≤ max_bend` (radians) whose tip in `state` is nearest `goal` (mm,
/// base frame), found in the goal's vertical plane (the workspace is a surface of revolution:
/// the nearest point of it lies in that plane) by a dense scan then golden-section refinement
/// (the distance along the side-view curve has one minimum per scan cell at the resolution
/// used; the result is within 1e-6 mm of the scan's best cell's minimum).
pub fn nearest(
    heights: &TrunkHeights,
    state: TrunkState,
    max_bend: f64,
    goal: [f64; 3],
) -> Result<Nearest, ReachError> {
    nearest_by(|a| side_tip(heights, state, a), max_bend, goal)
}

/// [`nearest`] for any side-view model `side(θ) = (ρ, z, tilt)` of a signed bend θ (a
/// calibrated one, say): the bend within `|θ| ≤ max_bend` whose tip is nearest `goal`.
pub fn nearest_by(
    side: impl Fn(f64) -> (f64, f64, f64),
    max_bend: f64,
    goal: [f64; 3],
) -> Result<Nearest, ReachError> {
    if !(goal.iter().all(|v| v.is_finite()) && max_bend.is_finite() && max_bend >= 0.0) {
        return Err(ReachError::NotFinite);
    }
    let rho_goal = libm::hypot(goal[0], goal[1]);
    let direction = if rho_goal > 1e-12 {
        libm::atan2(goal[1], goal[0])
    } else {
        0.0
    };
    let dist2 = |a: f64| {
        let (r, z, _) = side(a);
        (r - rho_goal) * (r - rho_goal) + (z - goal[2]) * (z - goal[2])
    };
    const CELLS: usize = 256;
    let step = 2.0 * max_bend / CELLS as f64;
    let mut best = (0.0, dist2(0.0));
    if max_bend > 0.0 {
        for i in 0..=CELLS {
            let a = -max_bend + step * i as f64;
            let d = dist2(a);
            if d < best.1 {
                best = (a, d);
            }
        }
        // Golden-section search in the cells around the best sample.
        let (mut lo, mut hi) = (
            (best.0 - step).max(-max_bend),
            (best.0 + step).min(max_bend),
        );
        let g = 0.618_033_988_749_894_9;
        let mut x1 = hi - g * (hi - lo);
        let mut x2 = lo + g * (hi - lo);
        let (mut f1, mut f2) = (dist2(x1), dist2(x2));
        for _ in 0..80 {
            if f1 < f2 {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - g * (hi - lo);
                f1 = dist2(x1);
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + g * (hi - lo);
                f2 = dist2(x2);
            }
        }
        let a = 0.5 * (lo + hi);
        let d = dist2(a);
        if d < best.1 {
            best = (a, d);
        }
    }
    let bend = Bend::new(direction, best.0);
    let (rho, z, tilt) = side(best.0);
    // The side view's ρ is signed along the goal's direction: a negative θ bends away from it.
    Ok(Nearest {
        bend,
        tip: pose_from_plane(rho, z, tilt, direction),
        distance_mm: libm::sqrt(best.1.max(0.0)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    fn pdf() -> TrunkHeights {
        let m = |beta_deg| BuiltModule {
            n: 3,
            beta_deg,
            edge_mm: 75.0,
            layers: 2,
        };
        TrunkHeights::of_modules(m(31.72), m(35.0), 5.0).unwrap()
    }

    fn st(s: &str) -> TrunkState {
        s.parse().unwrap()
    }

    #[test]
    fn straight_tips_are_the_state_heights_on_the_axis() {
        let h = pdf();
        // Table 1 at n = 3: deployed d = tan β, folded d = √(tan²β − tan²30°); 2 layers × 75 mm.
        let t = 30f64.to_radians().tan();
        let w_top = 31.72f64.to_radians().tan();
        let w_bot = 35f64.to_radians().tan();
        let ff = 150.0 * ((w_top * w_top - t * t).sqrt() + (w_bot * w_bot - t * t).sqrt());
        assert!((h.height_mm(st("F&F")) - ff).abs() < 1e-9);
        assert!((h.height_mm(st("D&D")) - 150.0 * (w_top + w_bot)).abs() < 1e-9);
        assert!(
            (h.height_mm(st("F&P")) - (10.0 + 150.0 * (w_top * w_top - t * t).sqrt())).abs() < 1e-9
        );
        for s in TrunkState::ALL {
            let p = tip_pose(&h, s, Bend::STRAIGHT);
            assert_eq!(p.position_mm[0], 0.0);
            assert!((p.position_mm[2] - h.height_mm(s)).abs() < 1e-12);
            assert_eq!(p.axis, [0.0, 0.0, 1.0]);
        }
    }

    #[test]
    fn one_arc_matches_the_circle_it_lies_on() {
        // F&F bends over its whole height: the tip lies on the circle of radius L/θ centred at
        // (L/θ, 0) in the bend's plane, and the arc length along it is L.
        let h = pdf();
        let s = st("F&F");
        let l = h.height_mm(s);
        for deg in [1.0f64, 10.0, 30.0, 90.0] {
            let th = deg.to_radians();
            let p = tip_pose(&h, s, Bend::new(PI / 2.0, th));
            let r = l / th;
            let (x, y, z) = (p.position_mm[0], p.position_mm[1], p.position_mm[2]);
            assert!(x.abs() < 1e-9, "{x}");
            assert!(((y - r).powi(2) + z * z).sqrt() - r < 1e-9);
            // The chord subtends θ: its length is 2r·sin(θ/2).
            assert!(((y * y + z * z).sqrt() - 2.0 * r * (th / 2.0).sin()).abs() < 1e-9);
            // The axis is tilted by θ toward +y.
            assert!((p.axis[1] - th.sin()).abs() < 1e-12 && (p.axis[2] - th.cos()).abs() < 1e-12);
        }
    }

    #[test]
    fn a_stiff_module_is_carried_straight_by_the_bend_below() {
        // D&F: the folded bottom bends, the deployed top is a straight segment along the tilted
        // axis.
        let h = pdf();
        let s = st("D&F");
        let [b, t] = h.modules_mm(s);
        let th = 0.4;
        let p = tip_pose(&h, s, Bend::new(0.0, th));
        let (r0, z0) = arc_tip(b, th);
        assert!((p.position_mm[0] - (r0 + t * th.sin())).abs() < 1e-9);
        assert!((p.position_mm[2] - (z0 + t * th.cos())).abs() < 1e-9);
        // F&D: the deployed bottom stands straight, the folded top bends on it.
        let s = st("F&D");
        let [b, t] = h.modules_mm(s);
        let p = tip_pose(&h, s, Bend::new(0.0, th));
        let (r1, z1) = arc_tip(t, th);
        assert!((p.position_mm[0] - r1).abs() < 1e-9);
        assert!((p.position_mm[2] - (b + z1)).abs() < 1e-9);
    }

    #[test]
    fn small_angles_are_continuous_through_the_series() {
        // Either side of the switch to the series, the two forms agree to rounding.
        for h in [1.0, 60.0, 200.0] {
            let (a, b) = (arc_tip(h, 1e-4 - 1e-13), arc_tip(h, 1e-4 + 1e-13));
            assert!(
                (a.0 - b.0).abs() < 1e-9 * h && (a.1 - b.1).abs() < 1e-9 * h,
                "{h}"
            );
            let (a, b) = (arc_tip(h, -1e-4 + 1e-13), arc_tip(h, -1e-4 - 1e-13));
            assert!(
                (a.0 - b.0).abs() < 1e-9 * h && (a.1 - b.1).abs() < 1e-9 * h,
                "{h}"
            );
            assert_eq!(arc_tip(h, 0.0), (0.0, h));
        }
    }

    #[test]
    fn nearest_finds_a_tip_it_was_given_and_names_the_gap_of_one_outside() {
        let h = pdf();
        let max = 30f64.to_radians();
        for s in ["F&F", "D&F", "F&D", "D&P"].map(st) {
            for (dir, deg) in [(0.3, 5.0), (2.0, 17.0), (-2.5, 29.0), (1.0, 0.0)] {
                let bend = Bend::new(dir, f64::to_radians(deg));
                let goal = tip_pose(&h, s, bend).position_mm;
                let n = nearest(&h, s, max, goal).unwrap();
                assert!(n.distance_mm < 1e-6, "{s} {deg}: {}", n.distance_mm);
            }
            // Straight above the top: the nearest is the straight tip, the gap the extra height.
            let top = h.height_mm(s);
            let n = nearest(&h, s, max, [0.0, 0.0, top + 40.0]).unwrap();
            assert!((n.distance_mm - 40.0).abs() < 1e-6, "{s}");
            assert!(n.bend.angle < 1e-6);
        }
        // A state without bends reaches only its straight tip.
        let n = nearest(&h, st("D&D"), 0.0, [10.0, 0.0, 0.0]).unwrap();
        assert!((n.distance_mm - (100.0 + h.height_mm(st("D&D")).powi(2)).sqrt()).abs() < 1e-9);
        assert_eq!(
            nearest(&h, st("D&D"), -1.0, [0.0; 3]),
            Err(ReachError::NotFinite)
        );
        assert_eq!(
            nearest(&h, st("D&D"), 0.1, [f64::NAN, 0.0, 0.0]),
            Err(ReachError::NotFinite)
        );
    }

    #[test]
    fn the_command_for_a_bend_holds_that_bend_past_the_take_up_margin() {
        use crate::tendon::TendonGeometry;
        let tg = TendonGeometry::new(60.0).unwrap();
        let m = 2.0;
        // Without a margin the held bend is the command (all three tendons taut).
        for (dir, ang) in [(0.3, 0.2), (2.5, 0.5), (4.0, 0.05)] {
            let b = tg.held_bend(Bend::new(dir, ang), 0.0);
            assert!((b.angle - ang).abs() < 1e-9 && (b.direction - dir).abs() < 1e-9);
        }
        // With one: a command toward a tendon pulls that tendon only, and the bend is the
        // command less the margin.
        let b = tg.held_bend(Bend::new(120f64.to_radians(), 0.5), m);
        assert!((b.direction - 120f64.to_radians()).abs() < 1e-9, "{b:?}");
        assert!((b.angle - (0.5 - m / 60.0)).abs() < 1e-9, "{b:?}");
        // Under the margin nothing bends.
        assert_eq!(tg.held_bend(Bend::new(1.0, 0.02), m), Bend::STRAIGHT);
        // The command for a bend holds it exactly, in every direction, and asks at most
        // 2·margin/r more.
        for k in 0..72 {
            let dir = f64::from(k) * 5f64.to_radians() + 0.01;
            for ang in [0.01, 0.2, 0.45] {
                let want = Bend::new(dir, ang);
                let cmd = tg.command_for(want, m);
                assert!(cmd.angle <= ang + 2.0 * m / 60.0 + 1e-12);
                let got = tg.held_bend(cmd, m);
                let (a, b) = (got.as_vector(), want.as_vector());
                assert!(
                    (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9,
                    "{dir} {ang}: {got:?}"
                );
            }
        }
        assert_eq!(tg.command_for(Bend::STRAIGHT, m), Bend::STRAIGHT);
    }

    #[test]
    fn bad_dimensions_are_refused() {
        assert_eq!(
            TrunkHeights::new([1.0, f64::NAN], [0.0; 3]),
            Err(ReachError::BadDimensions)
        );
        assert_eq!(
            TrunkHeights::new([1.0, 2.0], [0.0, -1.0, 3.0]),
            Err(ReachError::BadDimensions)
        );
        let bad = BuiltModule {
            n: 2,
            beta_deg: 30.0,
            edge_mm: 75.0,
            layers: 2,
        };
        assert!(TrunkHeights::of_modules(bad, bad, 5.0).is_err());
    }
}
