//! Tasks for the crane: a goal (a point for the tip, a grip, a bend, a vent) turned into a plan
//! of the primitives the device already runs — state transitions from the graph, `Bend`,
//! `Gripper`, `Vent` — or refused before anything moves, with the limit and the nearest
//! feasible value.
//!
//! Where the tip can be is the geometry's ([`geometry::reach`]): constant curvature over each
//! state's flexible length, with the bend each state allows (the controller's limits, given by
//! the caller: this crate does not depend on the firmware).
//!
//! ```
//! use geometry::reach::{BuiltModule, TrunkHeights};
//! use planner::graph::Graph;
//! use planner::task::Workspace;
//!
//! let m = |beta_deg| BuiltModule { n: 3, beta_deg, edge_mm: 75.0, layers: 2 };
//! let heights = TrunkHeights::of_modules(m(31.72), m(35.0), 5.0).unwrap();
//! let mut limits = [None; 6];
//! for s in ["F&F", "D&F", "F&D"] {
//!     limits[s.parse::<geometry::TrunkState>().unwrap().index()] = Some(30.0);
//! }
//! let ws = Workspace::new(heights, limits).unwrap();
//! let goal = ws.tip("D&F".parse().unwrap(), 20.0, 90.0).unwrap().position_mm;
//! let plan = ws.reach("F&P".parse().unwrap(), goal, 5.0, &Graph::nominal()).unwrap();
//! assert_eq!(plan.state.name(), "D&F");
//! assert!(plan.distance_mm < 1e-3);
//! ```

use core::fmt;

use geometry::reach::{nearest, tip_pose, BuiltModule, TipPose, TrunkHeights};
use geometry::tendon::Bend;
use geometry::TrunkState;
use protocol::{Primitive, Step, StepKind};

use crate::graph::{Graph, Plan};

/// The time limit of a bend, grip or vent step the device is given, ms.
pub const PRIMITIVE_TIMEOUT_MS: u32 = 20_000;

/// Why a task was refused (nothing was sent).
#[derive(Debug, Clone, PartialEq)]
pub enum TaskError {
    /// The state is not bent at all (not among the flexible states).
    NotBendable {
        /// The state.
        state: TrunkState,
    },
    /// A bend over the state's limit.
    BendTooLarge {
        /// The state.
        state: TrunkState,
        /// The angle asked for, degrees.
        angle_deg: f64,
        /// The state's limit, degrees.
        limit_deg: f64,
    },
    /// A non-finite or negative angle, or a non-finite direction or point.
    BadInput(&'static str),
    /// No state's tip comes within the tolerance of the point.
    OutOfReach {
        /// The goal, mm.
        goal: [f64; 3],
        /// The tolerance, mm.
        tolerance_mm: f64,
        /// The nearest reachable point, its state and bend.
        state: TrunkState,
        /// Its bend.
        bend: Bend,
        /// The point, mm.
        nearest_mm: [f64; 3],
        /// Its distance from the goal, mm.
        distance_mm: f64,
    },
    /// The graph has no way to the state.
    NoPath(String),
}

impl fmt::Display for TaskError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TaskError::NotBendable { state } => write!(
                f,
                "{state} is not bent: only the flexible states F&F, D&F, D&P and F&D are (their tendons are taken up); straighten or change state first"
            ),
            TaskError::BendTooLarge {
                state,
                angle_deg,
                limit_deg,
            } => {
                let feasible = (limit_deg * 100.0).floor() / 100.0;
                write!(
                    f,
                    "a bend of {angle_deg}° is over {state}'s limit of {feasible:.2}° (the controller's limit there less what its tendons' take-up margin costs); the nearest feasible bend is {feasible:.2}°"
                )
            }
            TaskError::BadInput(what) => f.write_str(what),
            TaskError::OutOfReach {
                goal,
                tolerance_mm,
                state,
                bend,
                nearest_mm,
                distance_mm,
            } => write!(
                f,
                "no state reaches ({:.1}, {:.1}, {:.1}) mm within {tolerance_mm} mm: the nearest reachable point is ({:.1}, {:.1}, {:.1}) mm in {state} (bend {:.1}° toward {:.1}°), {distance_mm:.1} mm away",
                goal[0],
                goal[1],
                goal[2],
                nearest_mm[0],
                nearest_mm[1],
                nearest_mm[2],
                bend.angle.to_degrees(),
                bend.direction.to_degrees()
            ),
            TaskError::NoPath(e) => f.write_str(e),
        }
    }
}

impl std::error::Error for TaskError {}

/// The crane's reachable tips: the trunk's heights and each state's bend limit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    heights: TrunkHeights,
    /// Bend limit per state (index [`TrunkState::index`]), degrees; `None`: not bent there.
    limits_deg: [Option<f64>; 6],
    /// A calibration per state, where one was measured.
    calibration: [Option<Calibration>; 6],
}

/// How a state really bends, measured (on the crane with a tip sensor, or on the simulator):
/// the bend the tip axis takes per degree commanded, and the share of it the bottom module
/// takes. Without one the geometry's model holds (gain 1, the split by length over the flexible
/// modules).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// True bend / commanded bend toward a tendon.
    pub gain: f64,
    /// True bend / commanded bend midway between two tendons (the gain in between follows
    /// cos 3φ).
    pub gain_between: f64,
    /// The bottom module's share of the bend (0–1).
    pub bottom_share: f64,
    /// How much lower the tip is than the bent model per radian of commanded bend, mm/rad (the
    /// tendons' pull also shortens the trunk).
    pub sag_mm_per_rad: f64,
    /// How far a bend between two tendons leans toward the nearer one, rad: the tip faces
    /// φ − lean·sin 3φ when commanded toward φ (no lean toward a tendon or midway between two).
    pub lean_rad: f64,
}

impl Calibration {
    /// True bend / commanded bend toward `direction` (rad).
    pub fn gain_toward(&self, direction: f64) -> f64 {
        let mean = 0.5 * (self.gain + self.gain_between);
        let half = 0.5 * (self.gain - self.gain_between);
        mean + half * (3.0 * direction).cos()
    }

    /// Where the tip faces when commanded toward `direction` (rad).
    pub fn facing(&self, direction: f64) -> f64 {
        direction - self.lean_rad * (3.0 * direction).sin()
    }

    /// The direction to command for the tip to face `facing` (rad): the inverse of
    /// [`Calibration::facing`] by bisection (it is increasing for |lean| < 1/3 rad, and within
    /// |lean| of `facing`).
    pub fn command_toward(&self, facing: f64) -> f64 {
        let w = self.lean_rad.abs() + 1e-9;
        let (mut lo, mut hi) = (facing - w, facing + w);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if self.facing(mid) < facing {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

impl Workspace {
    /// A workspace from the heights and the limits (finite, ≥ 0).
    pub fn new(heights: TrunkHeights, limits_deg: [Option<f64>; 6]) -> Result<Self, TaskError> {
        if limits_deg
            .iter()
            .flatten()
            .any(|l| !(l.is_finite() && *l >= 0.0))
        {
            return Err(TaskError::BadInput("bend limits must be finite and ≥ 0°"));
        }
        Ok(Self {
            heights,
            limits_deg,
            calibration: [None; 6],
        })
    }

    /// The workspace of a crane's trunk (its two modules and self-packed layer height) with
    /// the bend limits of its configuration.
    pub fn of_crane(
        crane: &protocol::CraneGeometry,
        limits_deg: [Option<f64>; 6],
    ) -> Result<Self, TaskError> {
        let m = |c: &protocol::ModuleConfig| BuiltModule {
            n: u32::from(c.n),
            beta_deg: f64::from(c.beta_deg),
            edge_mm: f64::from(c.edge_mm),
            layers: u32::from(c.layers),
        };
        let packed_layer_mm = f64::from(crane.packed_layer_mm);
        let heights = TrunkHeights::of_modules(m(&crane.top), m(&crane.bottom), packed_layer_mm)
            .map_err(|_| TaskError::BadInput("the device's trunk has an invalid module"))?;
        Self::new(heights, limits_deg)
    }

    /// The bend limits a host plans with for a crane whose controller allows `controller_deg`
    /// per state and keeps its tendons `margin_mm` short of taut at radius `radius_mm`: the
    /// command for a held bend θ is at most θ + 2·margin/r ([`TendonGeometry::command_for`]),
    /// so θ may be the controller's limit less that.
    ///
    /// [`TendonGeometry::command_for`]: geometry::tendon::TendonGeometry::command_for
    pub fn held_limits(
        controller_deg: [Option<f64>; 6],
        margin_mm: f64,
        radius_mm: f64,
    ) -> [Option<f64>; 6] {
        let extra = (2.0 * margin_mm.max(0.0) / radius_mm).to_degrees();
        controller_deg.map(|l| l.map(|l| (l - extra).max(0.0)))
    }

    /// The same workspace with `state` calibrated (a finite gain in (0, 2], a share in [0, 1]).
    pub fn with_calibration(
        mut self,
        state: TrunkState,
        c: Calibration,
    ) -> Result<Self, TaskError> {
        if !(c.gain.is_finite()
            && c.gain > 0.0
            && c.gain <= 2.0
            && c.gain_between.is_finite()
            && c.gain_between > 0.0
            && c.gain_between <= 2.0
            && (0.0..=1.0).contains(&c.bottom_share)
            && c.sag_mm_per_rad.is_finite()
            && c.lean_rad.is_finite()
            && c.lean_rad.abs() < 0.3)
        {
            return Err(TaskError::BadInput(
                "a calibration needs gains in (0, 2], a share in [0, 1], a finite sag and a lean under 0.3 rad",
            ));
        }
        self.calibration[state.index()] = Some(c);
        Ok(self)
    }

    /// The calibration of `state`, if one was measured.
    pub fn calibration(&self, state: TrunkState) -> Option<Calibration> {
        self.calibration[state.index()]
    }

    /// The side view (ρ, z, tilt) of `state` under a commanded signed bend (radians) in the
    /// plane of the commanded direction `direction` (a negative bend: toward `direction` + π):
    /// the calibrated model where there is one, else the geometry's.
    pub fn side(&self, state: TrunkState, commanded: f64, direction: f64) -> (f64, f64, f64) {
        match self.calibration(state) {
            Some(c) => {
                let toward = if commanded >= 0.0 {
                    direction
                } else {
                    direction + core::f64::consts::PI
                };
                let (r, z, tilt) = geometry::reach::side_tip_split(
                    &self.heights,
                    state,
                    commanded * c.gain_toward(toward),
                    c.bottom_share,
                );
                (r, z - c.sag_mm_per_rad * commanded.abs(), tilt)
            }
            None => geometry::reach::side_tip(&self.heights, state, commanded),
        }
    }

    /// The heights.
    pub fn heights(&self) -> &TrunkHeights {
        &self.heights
    }

    /// The bend limit of `state`, degrees (`None`: not bent there).
    pub fn limit_deg(&self, state: TrunkState) -> Option<f64> {
        self.limits_deg[state.index()]
    }

    /// Checks a bend of `angle_deg` (≥ 0) toward `direction_deg` in `state`.
    pub fn check_bend(
        &self,
        state: TrunkState,
        angle_deg: f64,
        direction_deg: f64,
    ) -> Result<Bend, TaskError> {
        if !(angle_deg.is_finite() && direction_deg.is_finite()) {
            return Err(TaskError::BadInput(
                "a bend's angle and direction must be finite",
            ));
        }
        if angle_deg < 0.0 {
            return Err(TaskError::BadInput(
                "a bend angle is ≥ 0°: bend the other way with --toward DIR+180",
            ));
        }
        if angle_deg == 0.0 {
            // Straightening is meaningful wherever the tendons may have been moved.
            return Ok(Bend::STRAIGHT);
        }
        let limit = self
            .limit_deg(state)
            .ok_or(TaskError::NotBendable { state })?;
        if angle_deg > limit {
            return Err(TaskError::BendTooLarge {
                state,
                angle_deg,
                limit_deg: limit,
            });
        }
        Ok(Bend::new(
            direction_deg.to_radians(),
            angle_deg.to_radians(),
        ))
    }

    /// The tip of `state` bent by `angle_deg` toward `direction_deg` (checked against the
    /// state's limit).
    pub fn tip(
        &self,
        state: TrunkState,
        angle_deg: f64,
        direction_deg: f64,
    ) -> Result<TipPose, TaskError> {
        let bend = self.check_bend(state, angle_deg, direction_deg)?;
        if let Some(c) = self.calibration(state) {
            let (r, z, tilt) = self.side(state, bend.angle, bend.direction);
            return Ok(geometry::reach::pose_from_plane(
                r,
                z,
                tilt,
                c.facing(bend.direction),
            ));
        }
        Ok(tip_pose(&self.heights, state, bend))
    }

    /// The point of `state`'s workspace nearest `goal`: its bend, tip and distance.
    pub fn nearest_in(
        &self,
        state: TrunkState,
        goal: [f64; 3],
    ) -> Result<geometry::reach::Nearest, TaskError> {
        let max = self.limit_deg(state).unwrap_or(0.0).to_radians();
        if let Some(c) = self.calibration(state) {
            // In the goal's plane: the command toward the goal's azimuth (or away from it, for
            // a negative bend) makes the tip face it.
            let az = goal[1].atan2(goal[0]);
            let toward = c.command_toward(az);
            let away = c.command_toward(az + core::f64::consts::PI) - core::f64::consts::PI;
            let side = |a: f64| self.side(state, a, if a >= 0.0 { toward } else { away });
            let mut n = geometry::reach::nearest_by(side, max, goal)
                .map_err(|_| TaskError::BadInput("a point must have finite coordinates (mm)"))?;
            // The bend faces the goal; command the direction that makes it face there.
            n.bend = Bend::new(c.command_toward(n.bend.direction), n.bend.angle);
            return Ok(n);
        }
        nearest(&self.heights, state, max, goal)
            .map_err(|_| TaskError::BadInput("a point must have finite coordinates (mm)"))
    }

    /// The tips of `state`'s side view (the plane of direction 0°): `samples` bends from −limit
    /// to +limit, as (x, z, θ in degrees); one point for a state that is not bent.
    pub fn side_view(&self, state: TrunkState, samples: usize) -> Vec<(f64, f64, f64)> {
        let limit = self.limit_deg(state).unwrap_or(0.0);
        if limit == 0.0 || samples < 2 {
            let (r, z, _) = geometry::reach::side_tip(&self.heights, state, 0.0);
            return vec![(r, z, 0.0)];
        }
        (0..samples)
            .map(|i| {
                let deg = -limit + 2.0 * limit * i as f64 / (samples - 1) as f64;
                let (r, z, _) = self.side(state, deg.to_radians(), 0.0);
                (r, z, deg)
            })
            .collect()
    }

    /// The cheapest way from `from` to a tip within `tolerance_mm` of `goal`: among the states
    /// whose workspace comes that near, the one the graph reaches at the least expected time
    /// (ties: the nearer tip). Refused with the nearest reachable point when none does.
    pub fn reach(
        &self,
        from: TrunkState,
        goal: [f64; 3],
        tolerance_mm: f64,
        graph: &Graph,
    ) -> Result<ReachPlan, TaskError> {
        if !(tolerance_mm.is_finite() && tolerance_mm > 0.0) {
            return Err(TaskError::BadInput(
                "the tolerance must be a finite number of mm > 0",
            ));
        }
        let mut best: Option<(f64, ReachPlan)> = None;
        let mut closest: Option<(TrunkState, geometry::reach::Nearest)> = None;
        for state in TrunkState::ALL {
            let n = self.nearest_in(state, goal)?;
            if closest.is_none_or(|(_, c)| n.distance_mm < c.distance_mm) {
                closest = Some((state, n));
            }
            if n.distance_mm > tolerance_mm {
                continue;
            }
            let transitions = graph
                .plan(from, state)
                .map_err(|e| TaskError::NoPath(e.to_string()))?;
            let bend_s = graph.costs().primitive_s(&bend_primitive(n.bend));
            let cost = transitions.cost_s() + bend_s;
            let better = match &best {
                None => true,
                Some((c, b)) => {
                    cost < *c - 1e-9 || (cost <= *c + 1e-9 && n.distance_mm < b.distance_mm)
                }
            };
            if better {
                best = Some((
                    cost,
                    ReachPlan {
                        state,
                        bend: n.bend,
                        tip: n.tip,
                        distance_mm: n.distance_mm,
                        transitions,
                        expected_s: cost,
                    },
                ));
            }
        }
        if let Some((_, plan)) = best {
            return Ok(plan);
        }
        let Some((state, n)) = closest else {
            return Err(TaskError::NoPath("no trunk state".into()));
        };
        Err(TaskError::OutOfReach {
            goal,
            tolerance_mm,
            state,
            bend: n.bend,
            nearest_mm: n.tip.position_mm,
            distance_mm: n.distance_mm,
        })
    }
}

/// A plan to put the tip at a point.
#[derive(Debug, Clone, PartialEq)]
pub struct ReachPlan {
    /// The state it reaches the point in.
    pub state: TrunkState,
    /// The bend there.
    pub bend: Bend,
    /// The geometry's tip there.
    pub tip: TipPose,
    /// The tip's distance from the goal, mm.
    pub distance_mm: f64,
    /// The state transitions first (empty when already there).
    pub transitions: Plan,
    /// Expected duration: the transitions and the bend, s.
    pub expected_s: f64,
}

/// The `Bend` primitive of a bend (degrees on the wire).
pub fn bend_primitive(bend: Bend) -> Primitive {
    Primitive::Bend {
        direction_deg: bend.direction.to_degrees() as f32,
        angle_deg: bend.angle.to_degrees() as f32,
    }
}

/// A step within `state` that runs `primitives` (a bend, a grip, a vent): from = to, so the
/// device checks it starts in `state` and leaves the state as it was.
pub fn step_within(state: TrunkState, kind: StepKind, primitives: &[Primitive]) -> Step {
    let mut step = Step {
        kind,
        from: state,
        to: state,
        primitives: Default::default(),
        timeout_ms: PRIMITIVE_TIMEOUT_MS,
    };
    for prim in primitives.iter().take(protocol::MAX_STEP_PRIMITIVES) {
        // Cannot fail: `take` bounds the count by the capacity.
        let _ = step.primitives.push(*prim);
    }
    step
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ws() -> Workspace {
        let m = |beta_deg| BuiltModule {
            n: 3,
            beta_deg,
            edge_mm: 75.0,
            layers: 2,
        };
        let heights = TrunkHeights::of_modules(m(31.72), m(35.0), 5.0).unwrap();
        let mut limits = [None; 6];
        for (s, l) in [("F&F", 30.0), ("D&F", 30.0), ("F&D", 30.0), ("D&P", 8.0)] {
            limits[s.parse::<TrunkState>().unwrap().index()] = Some(l);
        }
        Workspace::new(heights, limits).unwrap()
    }

    fn st(s: &str) -> TrunkState {
        s.parse().unwrap()
    }

    #[test]
    fn bends_are_checked_against_the_state_limit() {
        let w = ws();
        assert!(w.check_bend(st("F&F"), 30.0, 10.0).is_ok());
        assert_eq!(
            w.check_bend(st("D&P"), 9.0, 0.0),
            Err(TaskError::BendTooLarge {
                state: st("D&P"),
                angle_deg: 9.0,
                limit_deg: 8.0
            })
        );
        assert_eq!(
            w.check_bend(st("D&D"), 1.0, 0.0),
            Err(TaskError::NotBendable { state: st("D&D") })
        );
        assert_eq!(w.check_bend(st("D&D"), 0.0, 0.0), Ok(Bend::STRAIGHT));
        assert!(w.check_bend(st("F&F"), -1.0, 0.0).is_err());
        assert!(w.check_bend(st("F&F"), f64::NAN, 0.0).is_err());
        let e = w.check_bend(st("D&P"), 9.0, 0.0).unwrap_err().to_string();
        assert!(e.contains("8.00°") && e.contains("D&P"), "{e}");
    }

    #[test]
    fn reach_takes_the_cheapest_state_and_refuses_with_the_nearest_point() {
        let w = ws();
        let g = Graph::nominal();
        // The straight D&D tip is reached only in D&D.
        let top = w.heights().height_mm(st("D&D"));
        let p = w.reach(st("F&P"), [0.0, 0.0, top], 5.0, &g).unwrap();
        assert_eq!(p.state, st("D&D"));
        // A point on F&F's workspace, from F&F: no transition.
        let goal = w.tip(st("F&F"), 20.0, 45.0).unwrap().position_mm;
        let p = w.reach(st("F&F"), goal, 5.0, &g).unwrap();
        assert_eq!(p.state, st("F&F"));
        assert!(p.transitions.steps().is_empty() && p.distance_mm < 1e-3);
        // Far above everything: refused, naming D&D's straight tip.
        match w.reach(st("F&P"), [0.0, 0.0, top + 50.0], 5.0, &g) {
            Err(TaskError::OutOfReach {
                state, distance_mm, ..
            }) => {
                assert_eq!(state, st("D&D"));
                assert!((distance_mm - 50.0).abs() < 1e-6);
            }
            other => panic!("{other:?}"),
        }
        assert!(w.reach(st("F&P"), [0.0; 3], 0.0, &g).is_err());
        assert!(w.reach(st("F&P"), [f64::NAN, 0.0, 0.0], 5.0, &g).is_err());
    }

    #[test]
    fn a_calibration_changes_where_the_tip_is_and_reach_follows_it() {
        let w = ws();
        let ff = st("F&F");
        let c = Calibration {
            gain: 0.9,
            gain_between: 0.9,
            bottom_share: 0.375,
            sag_mm_per_rad: 0.0,
            lean_rad: 0.0,
        };
        let cw = w.with_calibration(ff, c).unwrap();
        // The calibrated tip: the bottom bends 0.9·0.375 of the command, the top the rest.
        let th = 20f64.to_radians();
        let [b, t] = w.heights().modules_mm(ff);
        let (r, z, _) =
            geometry::reach::chain_in_plane(&[(b, 0.9 * th * 0.375), (t, 0.9 * th * 0.625)]);
        let tip = cw.tip(ff, 20.0, 0.0).unwrap().position_mm;
        assert!((tip[0] - r).abs() < 1e-9 && (tip[2] - z).abs() < 1e-9);
        // Reaching that tip plans the same command, and it differs from the geometry's tip.
        let n = cw.nearest_in(ff, tip).unwrap();
        assert!(
            n.distance_mm < 1e-6 && (n.bend.angle - th).abs() < 1e-6,
            "{n:?}"
        );
        assert!((w.tip(ff, 20.0, 0.0).unwrap().position_mm[0] - r).abs() > 1.0);
        let bad = |f: &dyn Fn(&mut Calibration)| {
            let mut b = c;
            f(&mut b);
            w.with_calibration(ff, b).is_err()
        };
        assert!(bad(&|b| b.gain = 0.0));
        assert!(bad(&|b| b.gain_between = f64::NAN));
        assert!(bad(&|b| b.bottom_share = 1.5));
        assert!(bad(&|b| b.sag_mm_per_rad = f64::INFINITY));
        assert!(bad(&|b| b.lean_rad = 0.4));
        // The lean's inverse: commanding `command_toward(φ)` faces φ.
        let lean = Calibration { lean_rad: 0.2, ..c };
        for k in 0..36 {
            let phi = f64::from(k) * 10f64.to_radians();
            assert!((lean.facing(lean.command_toward(phi)) - phi).abs() < 1e-9);
        }
    }

    #[test]
    fn a_step_within_a_state_starts_and_ends_there() {
        let s = step_within(
            st("D&F"),
            StepKind::Tendon,
            &[bend_primitive(Bend::new(0.5, 0.2))],
        );
        assert_eq!((s.from, s.to), (st("D&F"), st("D&F")));
        match s.primitives[0] {
            Primitive::Bend {
                direction_deg,
                angle_deg,
            } => {
                assert!((f64::from(direction_deg) - 0.5f64.to_degrees()).abs() < 1e-4);
                assert!((f64::from(angle_deg) - 0.2f64.to_degrees()).abs() < 1e-4);
            }
            p => panic!("{p:?}"),
        }
    }
}
