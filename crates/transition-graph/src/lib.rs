#![forbid(unsafe_code)]
//! PDF trunk transition planning: the six-state graph, the cheapest plan, replanning.
//!
//! The graph is built from the shared catalogue [`protocol::transitions::TRANSITIONS`] (the same
//! edges the firmware's buttons step along and the simulator's discovery must agree with); this
//! module adds what the catalogue does not say: what each edge *costs* (its expected duration,
//! from a [`CostModel`]), which sequence of edges is cheapest (Dijkstra), why each step is there
//! (text a person can check), and how to go on when a step ends somewhere unexpected
//! ([`Graph::replan`]).
//!
//! ```
//! use geometry::TrunkState;
//! use transition_graph::Graph;
//!
//! let graph = Graph::nominal();
//! let from: TrunkState = "F&P".parse().unwrap();
//! let plan = graph.plan(from, "D&F".parse().unwrap()).unwrap();
//! assert_eq!(plan.steps().len(), 2); // F&P → F&F → D&F, by pressure
//! let wire = plan.to_protocol(1).unwrap();
//! assert_eq!(wire.steps.len(), 2);
//! ```

use core::fmt;

use geometry::{BottomState, TopState, TrunkState};
use protocol::transitions::{Transition, TRANSITIONS};
use protocol::{ManualTask, Primitive, StepKind, MAX_PLAN_STEPS};

/// How long actuation primitives are expected to take, in seconds; the edge cost is the sum over
/// its primitives.
///
/// The defaults are conservative figures for the crane's pneumatics and tendon servos (the
/// simulator's calibrated physics finishes well inside them): what matters to the planner is
/// their order of magnitude, and above all that a manual step costs far more than any
/// actuated one, so a person is asked only when no actuator can do the job.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostModel {
    /// Fixed overhead of every step (upload, interlock checks, sensor confirmation).
    pub step_overhead_s: f64,
    /// Inflation rate toward the target pressure.
    pub inflate_kpa_per_s: f64,
    /// Venting time from any working pressure to the target.
    pub vent_s: f64,
    /// Tendon pull speed (slew-limited servos).
    pub tendon_mm_per_s: f64,
    /// Time to let the tendons out to slack.
    pub tendon_release_s: f64,
    /// A person folding panels by hand, including reading the prompt and confirming.
    pub manual_s: f64,
    /// Opening or closing the gripper.
    pub gripper_s: f64,
    /// Bending speed of the trunk's tip axis.
    pub bend_deg_per_s: f64,
}

impl Default for CostModel {
    fn default() -> Self {
        Self {
            step_overhead_s: 0.5,
            inflate_kpa_per_s: 5.0,
            vent_s: 1.5,
            tendon_mm_per_s: 40.0,
            tendon_release_s: 1.5,
            manual_s: 120.0,
            gripper_s: 0.5,
            bend_deg_per_s: 30.0,
        }
    }
}

impl CostModel {
    /// Expected duration of one primitive, seconds.
    pub fn primitive_s(&self, primitive: &Primitive) -> f64 {
        match *primitive {
            Primitive::Inflate { pressure_kpa, .. } => {
                f64::from(pressure_kpa.max(0.0)) / self.inflate_kpa_per_s
            }
            Primitive::Vent { .. } => self.vent_s,
            Primitive::TendonPull { length_mm, .. } => {
                f64::from(length_mm.max(0.0)) / self.tendon_mm_per_s
            }
            Primitive::TendonRelease { .. } => self.tendon_release_s,
            Primitive::Hold { duration_ms } => f64::from(duration_ms) / 1000.0,
            // A snap is waited for, not caused: count half its time limit.
            Primitive::WaitSnap { timeout_ms } => f64::from(timeout_ms) / 2000.0,
            Primitive::Manual(_) => self.manual_s,
            Primitive::Gripper { .. } => self.gripper_s,
            Primitive::Bend { angle_deg, .. } => f64::from(angle_deg.abs()) / self.bend_deg_per_s,
        }
    }

    /// Expected duration of a whole transition, seconds.
    pub fn transition_s(&self, t: &Transition) -> f64 {
        self.step_overhead_s
            + t.primitives
                .iter()
                .map(|p| self.primitive_s(p))
                .sum::<f64>()
    }
}

/// One edge of the graph: a catalogue transition with its cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// The catalogue transition (kind, primitives, time limit).
    pub transition: Transition,
    /// Expected duration, seconds.
    pub cost_s: f64,
}

impl Edge {
    /// Start state.
    pub fn from(&self) -> TrunkState {
        self.transition.from
    }

    /// End state.
    pub fn to(&self) -> TrunkState {
        self.transition.to
    }

    /// How the edge is actuated.
    pub fn kind(&self) -> StepKind {
        self.transition.kind
    }
}

/// Why no plan could be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum PlanError {
    /// No sequence of (allowed) transitions leads from `from` to `to`.
    #[error("no sequence of transitions leads from {from} to {to}")]
    Unreachable {
        /// Start state.
        from: TrunkState,
        /// Wanted state.
        to: TrunkState,
    },
    /// The plan has more steps than one uploaded plan may hold.
    #[error("the plan has {steps} steps; a device plan holds at most {max}")]
    TooLong {
        /// Steps in the plan.
        steps: usize,
        /// [`protocol::MAX_PLAN_STEPS`].
        max: usize,
    },
}

/// The directed graph of trunk states and the transitions between them.
#[derive(Debug, Clone, PartialEq)]
pub struct Graph {
    edges: Vec<Edge>,
    costs: CostModel,
}

impl Default for Graph {
    fn default() -> Self {
        Self::nominal()
    }
}

impl Graph {
    /// The catalogue's transitions with the default [`CostModel`].
    pub fn nominal() -> Self {
        Self::with_costs(CostModel::default())
    }

    /// The catalogue's transitions with `costs`.
    pub fn with_costs(costs: CostModel) -> Self {
        let edges = TRANSITIONS
            .iter()
            .map(|t| Edge {
                transition: *t,
                cost_s: costs.transition_s(t),
            })
            .collect();
        Self { edges, costs }
    }

    /// A graph over `transitions` (any edges: a calibrated catalogue, or the one edge a
    /// calibration step runs) with `costs`.
    pub fn from_transitions(transitions: Vec<Transition>, costs: CostModel) -> Self {
        let edges = transitions
            .into_iter()
            .map(|t| Edge {
                cost_s: costs.transition_s(&t),
                transition: t,
            })
            .collect();
        Self { edges, costs }
    }

    /// The catalogue with measured actuation targets: for each `((from, to), value)` the
    /// edge's inflation target pressure (kPa, pneumatic edges) or pull length (mm, tendon
    /// edges) becomes `value`; every other edge is the catalogue's. The nominal graph
    /// ([`Graph::nominal`]) and the firmware's shared catalogue stay as they are.
    pub fn calibrated(targets: &[((TrunkState, TrunkState), f32)]) -> Self {
        let transitions = TRANSITIONS
            .iter()
            .map(
                |t| match targets.iter().find(|(e, _)| *e == (t.from, t.to)) {
                    Some(&(_, value)) => retarget(t, value),
                    None => *t,
                },
            )
            .collect();
        Self::from_transitions(transitions, CostModel::default())
    }

    /// The cost model the edge costs come from.
    pub fn costs(&self) -> &CostModel {
        &self.costs
    }

    /// Every edge, in catalogue order.
    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// The edge `from` → `to`, if the trunk can make that transition in one step.
    pub fn edge(&self, from: TrunkState, to: TrunkState) -> Option<&Edge> {
        self.edges.iter().find(|e| e.from() == from && e.to() == to)
    }

    /// The `(from, to)` pairs of every edge, sorted: the shape of the graph without costs, to
    /// compare with a graph discovered elsewhere (the simulator's).
    pub fn adjacency(&self) -> Vec<(TrunkState, TrunkState)> {
        let mut pairs: Vec<_> = self.edges.iter().map(|e| (e.from(), e.to())).collect();
        pairs.sort();
        pairs
    }

    /// The cheapest plan from `from` to `to` (empty when they are equal).
    pub fn plan(&self, from: TrunkState, to: TrunkState) -> Result<Plan, PlanError> {
        self.plan_avoiding(from, to, &[])
    }

    /// The cheapest plan from `from` to `to` that uses none of the `avoid` edges
    /// (`(from, to)` pairs), e.g. edges that just failed on this device.
    ///
    /// Dijkstra over six nodes; ties go to fewer steps, then to the catalogue's order, so the
    /// same question always gets the same plan.
    pub fn plan_avoiding(
        &self,
        from: TrunkState,
        to: TrunkState,
        avoid: &[(TrunkState, TrunkState)],
    ) -> Result<Plan, PlanError> {
        const N: usize = TrunkState::ALL.len();
        // (cost, steps) per node, and the edge index that reached it.
        let mut best: [Option<(f64, usize)>; N] = [None; N];
        let mut via: [Option<usize>; N] = [None; N];
        let mut done = [false; N];
        best[from.index()] = Some((0.0, 0));
        loop {
            let next = (0..N)
                .filter(|&i| !done[i])
                .filter_map(|i| best[i].map(|b| (i, b)))
                .min_by(|a, b| {
                    a.1 .0
                        .total_cmp(&b.1 .0)
                        .then(a.1 .1.cmp(&b.1 .1))
                        .then(a.0.cmp(&b.0))
                });
            let Some((u, (cost_u, steps_u))) = next else {
                break;
            };
            done[u] = true;
            if u == to.index() {
                break;
            }
            for (k, e) in self.edges.iter().enumerate() {
                if e.from().index() != u || avoid.contains(&(e.from(), e.to())) {
                    continue;
                }
                let v = e.to().index();
                let cand = (cost_u + e.cost_s, steps_u + 1);
                let better = match best[v] {
                    None => true,
                    Some((c, s)) => cand.0 < c || (cand.0 == c && cand.1 < s),
                };
                if !done[v] && better {
                    best[v] = Some(cand);
                    via[v] = Some(k);
                }
            }
        }
        if best[to.index()].is_none() {
            return Err(PlanError::Unreachable { from, to });
        }
        let mut path = Vec::new();
        let mut at = to.index();
        while at != from.index() {
            // Every reached node other than the start has a `via` edge (set with its `best`).
            let Some(k) = via[at] else {
                return Err(PlanError::Unreachable { from, to });
            };
            path.push(self.edges[k]);
            at = self.edges[k].from().index();
        }
        path.reverse();
        let steps = path
            .iter()
            .map(|e| PlannedStep {
                edge: *e,
                why: why(e, to),
            })
            .collect();
        Ok(Plan {
            from,
            target: to,
            steps,
        })
    }

    /// A new plan after a step ended in `reported` (the state the device reports) instead of
    /// where the plan expected: the cheapest way on to `target` from there, avoiding the edges
    /// that already failed (so a transition that does not work on this device is not retried
    /// forever).
    pub fn replan(
        &self,
        reported: TrunkState,
        target: TrunkState,
        failed: &[(TrunkState, TrunkState)],
    ) -> Result<Plan, PlanError> {
        self.plan_avoiding(reported, target, failed)
    }
}

/// `t` with its actuation's target replaced: the first `Inflate`'s pressure (kPa) or the first
/// `TendonPull`'s length (mm) becomes `value`; other primitives are kept. A transition's
/// primitives are `&'static` (the catalogue is static data), so the new ones are leaked: a
/// process builds a handful of calibrated graphs (a few dozen bytes each), never one per
/// sample.
pub fn retarget(t: &Transition, value: f32) -> Transition {
    let mut done = false;
    let primitives: Vec<Primitive> = t
        .primitives
        .iter()
        .map(|p| match *p {
            Primitive::Inflate { snaps, .. } if !done => {
                done = true;
                Primitive::Inflate {
                    pressure_kpa: value,
                    snaps,
                }
            }
            Primitive::TendonPull { snaps, .. } if !done => {
                done = true;
                Primitive::TendonPull {
                    length_mm: value,
                    snaps,
                }
            }
            other => other,
        })
        .collect();
    Transition {
        primitives: Box::leak(primitives.into_boxed_slice()),
        ..*t
    }
}

/// One step of a [`Plan`]: an edge and the reason it is on the path.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedStep {
    /// The transition and its cost.
    pub edge: Edge,
    /// Why this step, in a sentence.
    pub why: String,
}

impl PlannedStep {
    /// The wire form of this step.
    pub fn to_protocol(&self) -> protocol::Step {
        self.edge.transition.step()
    }
}

/// A sequence of transitions from a state to a target, cheapest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    from: TrunkState,
    target: TrunkState,
    steps: Vec<PlannedStep>,
}

impl Plan {
    /// Start state.
    pub fn from(&self) -> TrunkState {
        self.from
    }

    /// Target state.
    pub fn target(&self) -> TrunkState {
        self.target
    }

    /// The steps, in order (empty when already at the target).
    pub fn steps(&self) -> &[PlannedStep] {
        &self.steps
    }

    /// Expected total duration, seconds.
    pub fn cost_s(&self) -> f64 {
        self.steps.iter().map(|s| s.edge.cost_s).sum()
    }

    /// Whether a person has to do one of the steps.
    pub fn needs_manual(&self) -> bool {
        self.steps.iter().any(|s| s.edge.kind() == StepKind::Manual)
    }

    /// The plan as the device takes it, with id `plan_id` (non-zero).
    pub fn to_protocol(&self, plan_id: u16) -> Result<protocol::Plan, PlanError> {
        let too_long = PlanError::TooLong {
            steps: self.steps.len(),
            max: MAX_PLAN_STEPS,
        };
        let mut plan = protocol::Plan {
            plan_id,
            steps: Default::default(),
        };
        for s in &self.steps {
            plan.steps.push(s.to_protocol()).map_err(|_| too_long)?;
        }
        Ok(plan)
    }
}

impl fmt::Display for Plan {
    /// Explains the plan step by step: kind, from → to, primitives with their parameters, why.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.steps.is_empty() {
            return writeln!(f, "already at {}: nothing to do", self.target);
        }
        writeln!(
            f,
            "plan {} → {}: {} step{}, expected {:.1} s{}",
            self.from,
            self.target,
            self.steps.len(),
            if self.steps.len() == 1 { "" } else { "s" },
            self.cost_s(),
            if self.needs_manual() {
                " (includes a manual step)"
            } else {
                ""
            }
        )?;
        for (i, s) in self.steps.iter().enumerate() {
            let t = &s.edge.transition;
            writeln!(
                f,
                "  {}. {:<9} {} → {}  ~{:.1} s (limit {} s)",
                i + 1,
                kind_name(t.kind),
                t.from,
                t.to,
                s.edge.cost_s,
                t.timeout_ms / 1000
            )?;
            for p in t.primitives {
                writeln!(f, "       - {}", PrimitiveText(p))?;
            }
            writeln!(f, "       why: {}", s.why)?;
        }
        Ok(())
    }
}

/// The lower-case name of a step kind as used in reports: `pneumatic`, `tendon`, `manual`.
pub fn kind_name(kind: StepKind) -> &'static str {
    match kind {
        StepKind::Pneumatic => "pneumatic",
        StepKind::Tendon => "tendon",
        StepKind::Manual => "manual",
    }
}

/// What a person is asked to do for a manual task.
pub fn manual_task_text(task: ManualTask) -> &'static str {
    match task {
        ManualTask::PackBottomModule => {
            "fold the panels of the bottom module's two lowest units back into self-packing"
        }
        ManualTask::FoldTopModule => "fold the top module from deployed to folded by hand",
        ManualTask::FoldBottomModule => "fold the bottom module from deployed to folded by hand",
    }
}

/// A primitive with its parameters, for people.
pub struct PrimitiveText<'a>(pub &'a Primitive);

impl fmt::Display for PrimitiveText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let snaps = |n: u8| match n {
            0 => String::new(),
            1 => ", stop at the first snap-through".to_string(),
            n => format!(", stop after {n} snap-throughs"),
        };
        match *self.0 {
            Primitive::Inflate {
                pressure_kpa,
                snaps: n,
            } => write!(f, "inflate toward {pressure_kpa:.1} kPa{}", snaps(n)),
            Primitive::Vent { pressure_kpa } => write!(f, "vent to {pressure_kpa:.1} kPa"),
            Primitive::TendonPull {
                length_mm,
                snaps: n,
            } => write!(
                f,
                "pull the tendons in by up to {length_mm:.0} mm{}",
                snaps(n)
            ),
            Primitive::TendonRelease { length_mm } if length_mm <= 0.0 => {
                f.write_str("let the tendons out to slack")
            }
            Primitive::TendonRelease { length_mm } => {
                write!(f, "let the tendons out to {length_mm:.0} mm")
            }
            Primitive::Hold { duration_ms } => write!(f, "hold for {duration_ms} ms"),
            Primitive::WaitSnap { timeout_ms } => {
                write!(f, "wait up to {timeout_ms} ms for a snap-through")
            }
            Primitive::Manual(task) => write!(f, "by hand: {}", manual_task_text(task)),
            Primitive::Gripper { close } => f.write_str(if close {
                "close the gripper"
            } else {
                "open the gripper"
            }),
            Primitive::Bend {
                direction_deg,
                angle_deg,
            } => write!(f, "bend {angle_deg:.1}° toward {direction_deg:.0}°"),
        }
    }
}

/// Why `e` is on a path to `target`: which module it moves, and why that actuation.
fn why(e: &Edge, target: TrunkState) -> String {
    let (from, to) = (e.from(), e.to());
    let what = match e.kind() {
        StepKind::Pneumatic => {
            if from.bottom == BottomState::Packed && to.bottom == BottomState::Folded {
                "pressure lengthens the trunk; the 35° bottom module leaves self-packing first \
                 (lowest snap threshold)"
            } else if from.top == TopState::Folded && to.top == TopState::Deployed {
                "pressure pops the 31.72° top module out (it snaps before the bottom deploys)"
            } else {
                "higher pressure deploys the bottom module (the highest threshold)"
            }
        }
        StepKind::Tendon => {
            if from.top == TopState::Deployed && to.top == TopState::Folded {
                "tendons shorten the trunk; the smaller-β top module buckles first"
            } else if from.bottom == BottomState::Deployed {
                "tendons fold the bottom module once the top is folded"
            } else {
                "tendons self-pack the bottom module layer by layer (two snaps)"
            }
        }
        StepKind::Manual => {
            "no actuator reaches it: pressure unpacks the bottom first and tendons fold the top \
             first, so a person packs the bottom module by hand"
        }
    };
    if to == target {
        format!("{what}; reaches the target {target}")
    } else {
        format!("{what}; cheapest way on toward {target}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_calibrated_graph_changes_only_the_targets_it_is_given() {
        let fp: TrunkState = "F&P".parse().unwrap();
        let ff: TrunkState = "F&F".parse().unwrap();
        let dd: TrunkState = "D&D".parse().unwrap();
        let fd: TrunkState = "F&D".parse().unwrap();
        let g = Graph::calibrated(&[((fp, ff), 15.1), ((dd, fd), 17.0)]);
        let nominal = Graph::nominal();
        assert_eq!(g.adjacency(), nominal.adjacency());
        let e = g.edge(fp, ff).unwrap();
        assert!(matches!(
            e.transition.primitives[0],
            Primitive::Inflate { pressure_kpa, snaps: 1 } if pressure_kpa == 15.1
        ));
        assert_eq!(
            e.transition.primitives[1],
            Primitive::Vent { pressure_kpa: 0.0 }
        );
        // 15.1 kPa at 5 kPa/s + a 1.5 s vent + 0.5 s overhead.
        assert!(
            (e.cost_s - (15.1f64 / 5.0 + 2.0)).abs() < 1e-5,
            "{}",
            e.cost_s
        );
        let t = g.edge(dd, fd).unwrap();
        assert!(matches!(
            t.transition.primitives[0],
            Primitive::TendonPull { length_mm, snaps: 1 } if length_mm == 17.0
        ));
        for e in g.edges() {
            if (e.from(), e.to()) != (fp, ff) && (e.from(), e.to()) != (dd, fd) {
                assert_eq!(Some(e), nominal.edge(e.from(), e.to()));
            }
        }
        // The plans follow the same edges, with the calibrated numbers in their wire form.
        let plan = g.plan(fp, dd).unwrap();
        let wire = plan.to_protocol(1).unwrap();
        assert!(matches!(
            wire.steps[0].primitives[0],
            Primitive::Inflate { pressure_kpa, .. } if pressure_kpa == 15.1
        ));
        let one = Graph::from_transitions(
            vec![nominal.edge(fp, ff).unwrap().transition],
            CostModel::default(),
        );
        assert_eq!(one.edges().len(), 1);
        assert!(one.plan(fp, dd).is_err());
    }

    fn s(name: &str) -> TrunkState {
        name.parse().unwrap()
    }

    #[test]
    fn manual_edges_cost_more_than_any_actuated_path() {
        let g = Graph::nominal();
        let manual = g
            .edges()
            .iter()
            .find(|e| e.kind() == StepKind::Manual)
            .unwrap();
        let actuated: f64 = g
            .edges()
            .iter()
            .filter(|e| e.kind() != StepKind::Manual)
            .map(|e| e.cost_s)
            .sum();
        assert!(
            manual.cost_s > actuated,
            "{} vs {}",
            manual.cost_s,
            actuated
        );
    }

    #[test]
    fn avoiding_the_only_way_in_is_unreachable() {
        let g = Graph::nominal();
        let err = g
            .plan_avoiding(s("F&P"), s("D&P"), &[(s("D&F"), s("D&P"))])
            .unwrap_err();
        assert_eq!(
            err,
            PlanError::Unreachable {
                from: s("F&P"),
                to: s("D&P")
            }
        );
    }
}
