//! The PDF trunk's nominal transitions: which state changes each actuation makes, and the
//! primitives (with their parameters) that make them.
//!
//! This is the shared catalogue: the planner builds its graph from it, the firmware's standalone
//! buttons step along it, and the simulator's transition discovery must agree with it (a test in
//! `hil-sim`). The thresholds behind these numbers are the simulator's calibrated physics
//! (`docs/simulator.md`); the paper gives the ordering, not the values (DESIGN.md, §5–6):
//!
//! - Pressure from `F&P`: the 35° bottom module leaves self-packing first (`F&F`), then the
//!   31.72° top module pops out (`D&F`), then the bottom deploys (`D&D`).
//! - Tendons from `D&D`: the smaller-β top module buckles first (`F&D`); the bottom then goes
//!   deployed → folded, and folded → self-packed layer by layer (two snaps).
//! - `D&P` cannot be reached by pressure (the bottom unpacks first) nor by tendons (the top
//!   buckles first), so the bottom is packed by hand from `D&F`.
//!
//! Every step stops at the first `snaps` snap-throughs and then releases its actuator (vents or
//! slackens): the origami holds its state without power.
//!
//! Tendon lengths are shortening from the slack position of the fully deployed trunk, in mm.

use geometry::{BottomState, TopState, TrunkState};

use crate::messages::{ManualTask, Primitive, StateSet, Step, StepKind, MAX_STEP_PRIMITIVES};

/// One directed edge of the trunk's state graph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    /// Start state.
    pub from: TrunkState,
    /// End state.
    pub to: TrunkState,
    /// How it is actuated.
    pub kind: StepKind,
    /// What the device does, in order.
    pub primitives: &'static [Primitive],
    /// Time limit of the step.
    pub timeout_ms: u32,
}

const fn st(top: TopState, bottom: BottomState) -> TrunkState {
    TrunkState::new(top, bottom)
}

const FP: TrunkState = st(TopState::Folded, BottomState::Packed);
const FF: TrunkState = st(TopState::Folded, BottomState::Folded);
const FD: TrunkState = st(TopState::Folded, BottomState::Deployed);
const DP: TrunkState = st(TopState::Deployed, BottomState::Packed);
const DF: TrunkState = st(TopState::Deployed, BottomState::Folded);
const DD: TrunkState = st(TopState::Deployed, BottomState::Deployed);

/// Inflate until the first snap, then vent: the lowest-threshold module moves one state up.
const fn inflate(pressure_kpa: f32) -> [Primitive; 2] {
    [
        Primitive::Inflate {
            pressure_kpa,
            snaps: 1,
        },
        Primitive::Vent { pressure_kpa: 0.0 },
    ]
}

/// Pull the tendons until `snaps` snap-throughs (at most `length_mm`), then slacken them.
const fn pull(length_mm: f32, snaps: u8) -> [Primitive; 2] {
    [
        Primitive::TendonPull { length_mm, snaps },
        Primitive::TendonRelease { length_mm: 0.0 },
    ]
}

const PNEUMATIC_TIMEOUT_MS: u32 = 30_000;
const TENDON_TIMEOUT_MS: u32 = 30_000;
const MANUAL_TIMEOUT_MS: u32 = 600_000;

/// Pressure that unpacks the bottom module (P → F). The simulator's calibrated trunk unpacks at
/// 13.1 kPa and pops the top at 19.6 kPa (`hil-sim discover`), so 16 kPa has ≈ 3 kPa margin on
/// both sides.
pub const UNPACK_KPA: f32 = 16.0;
/// Pressure that pops the top module out (F → D): between the top's 19.6 kPa and the bottom's
/// F → D at 30.1 kPa, ≈ 5 kPa from each.
pub const POP_TOP_KPA: f32 = 24.5;
/// Pressure that deploys the bottom module (F → D, 30.1 kPa in the simulator), below the
/// firmware's default 40 kPa cap.
pub const DEPLOY_BOTTOM_KPA: f32 = 35.0;
/// Longest pull that folds the top module (D → F). The calibrated trunk buckles the top after
/// 9 mm of pull from D&D, 56 mm from D&F and 102 mm from D&P; the next snap the tendons could
/// cause from any of these (bottom F → packed from F&F) needs 138 mm.
pub const FOLD_TOP_MM: f32 = 120.0;
/// Longest pull that folds the top module over a packed bottom (D&P → F&P). The calibrated
/// trunk buckles the top there after 102 mm of pull, and nothing else can snap under the pull
/// (the bottom is packed: no well below it), so the limit is set by the trunk's stack instead:
/// D&D (197.7 mm) less F&P (43.1 mm) is 154.6 mm of pull before the tendons would squeeze a
/// folded-over-packed trunk, and 140 mm leaves 14 mm of that. 120 mm (the other top folds'
/// limit) failed the fold on 2 in 100 trunks drawn within ±25 % (their bottom taller when
/// deployed, so their tendons slacker at D&P; `hil-sim swarm --trunk-spread 0.25`).
pub const FOLD_TOP_OVER_PACKED_MM: f32 = 140.0;
/// Longest pull that folds the bottom module (D → F): it buckles after 92 mm from F&D.
pub const FOLD_BOTTOM_MM: f32 = 120.0;
/// Longest pull that packs the bottom module (F → P, two snaps at 138 mm and 167 mm from F&F):
/// the winches' whole travel (`CraneConfig::max_tendon_mm`, 185 mm). 182 mm left the bottom
/// half-packed on trunks whose second layer packs late: 10 of 150 trunks drawn within ±25 %
/// that pack within the travel (`hil-sim swarm --trunk-spread 0.25 --calibrate`, seed 1000).
pub const PACK_BOTTOM_MM: f32 = 185.0;

static UNPACK: [Primitive; 2] = inflate(UNPACK_KPA);
static POP_TOP: [Primitive; 2] = inflate(POP_TOP_KPA);
static DEPLOY_BOTTOM: [Primitive; 2] = inflate(DEPLOY_BOTTOM_KPA);
static FOLD_TOP: [Primitive; 2] = pull(FOLD_TOP_MM, 1);
static FOLD_TOP_OVER_PACKED: [Primitive; 2] = pull(FOLD_TOP_OVER_PACKED_MM, 1);
static FOLD_BOTTOM: [Primitive; 2] = pull(FOLD_BOTTOM_MM, 1);
static PACK_BOTTOM: [Primitive; 2] = pull(PACK_BOTTOM_MM, 2);
static PACK_BY_HAND: [Primitive; 1] = [Primitive::Manual(ManualTask::PackBottomModule)];

const fn edge(
    from: TrunkState,
    to: TrunkState,
    kind: StepKind,
    primitives: &'static [Primitive],
) -> Transition {
    let timeout_ms = match kind {
        StepKind::Pneumatic => PNEUMATIC_TIMEOUT_MS,
        StepKind::Tendon => TENDON_TIMEOUT_MS,
        StepKind::Manual => MANUAL_TIMEOUT_MS,
    };
    Transition {
        from,
        to,
        kind,
        primitives,
        timeout_ms,
    }
}

/// Every nominal transition of the PDF trunk.
pub static TRANSITIONS: [Transition; 11] = [
    // Pressure: one module one state up, lowest threshold first.
    edge(FP, FF, StepKind::Pneumatic, &UNPACK),
    edge(DP, DF, StepKind::Pneumatic, &UNPACK),
    edge(FF, DF, StepKind::Pneumatic, &POP_TOP),
    edge(FD, DD, StepKind::Pneumatic, &POP_TOP),
    edge(DF, DD, StepKind::Pneumatic, &DEPLOY_BOTTOM),
    // Tendons: the smaller-β top module buckles first.
    edge(DD, FD, StepKind::Tendon, &FOLD_TOP),
    edge(DF, FF, StepKind::Tendon, &FOLD_TOP),
    edge(DP, FP, StepKind::Tendon, &FOLD_TOP_OVER_PACKED),
    edge(FD, FF, StepKind::Tendon, &FOLD_BOTTOM),
    edge(FF, FP, StepKind::Tendon, &PACK_BOTTOM),
    // By hand: pack the bottom under a deployed top.
    edge(DF, DP, StepKind::Manual, &PACK_BY_HAND),
];

/// The nominal transition `from` → `to`, if one exists.
pub fn transition(from: TrunkState, to: TrunkState) -> Option<&'static Transition> {
    TRANSITIONS.iter().find(|t| t.from == from && t.to == to)
}

/// The transition the standalone "step up" (deploy) button makes from `state`: the pneumatic one.
pub fn step_up(state: TrunkState) -> Option<&'static Transition> {
    TRANSITIONS
        .iter()
        .find(|t| t.from == state && t.kind == StepKind::Pneumatic)
}

/// The transition the standalone "step down" (retract) button makes from `state`: the tendon one.
pub fn step_down(state: TrunkState) -> Option<&'static Transition> {
    TRANSITIONS
        .iter()
        .find(|t| t.from == state && t.kind == StepKind::Tendon)
}

/// What one hand task (fold the top, fold the bottom, pack the bottom) makes of each state, by
/// [`TrunkState::index`] (bit per index: F&P, F&F, F&D, D&P, D&F, D&D), the state itself
/// included: F&P {F&P, F&F}, F&F {F&F, F&P}, F&D {F&D, F&F, F&P}, D&P {D&P, F&P, D&F},
/// D&F {D&F, F&F, D&P}, D&D {D&D, F&D, D&F, D&P} (a unit test derives it).
pub const HAND_REACH: [u8; 6] = [0b000011, 0b000011, 0b000111, 0b011001, 0b011010, 0b111100];

/// The states each state's pneumatic chain reaches (inflating on, snap after snap), itself
/// included, by [`TrunkState::index`] (bit per index as [`HAND_REACH`]): F&P {F&P, F&F, D&F, D&D},
/// F&F {F&F, D&F, D&D}, F&D {F&D, D&D}, D&P {D&P, D&F, D&D}, D&F {D&F, D&D}, D&D {D&D} (a unit
/// test derives it from [`TRANSITIONS`]; a table, so the board's step start stays short).
pub const UP_REACH: [u8; 6] = [0b110011, 0b110010, 0b100100, 0b111000, 0b110000, 0b100000];
/// The states each state's tendon chain reaches (pulling on, fold after fold), itself included:
/// F&P {F&P}, F&F {F&F, F&P}, F&D {F&D, F&F, F&P}, D&P {D&P, F&P}, D&F {D&F, F&F, F&P},
/// D&D {D&D, F&D, F&F, F&P} (derived in a unit test).
pub const DOWN_REACH: [u8; 6] = [0b000001, 0b000011, 0b000111, 0b001001, 0b010011, 0b100111];

/// The union of `table`'s entries for every state of `set`.
fn along(set: StateSet, table: &[u8; 6]) -> StateSet {
    let mut out = set.0;
    for (i, t) in table.iter().enumerate() {
        if set.0 & (1 << i) != 0 {
            out |= t;
        }
    }
    StateSet(out & StateSet::ALL.0)
}

/// Sealed pressure (kPa) at or above which the air in the trunk may snap a module up once a step
/// lets it go (a pull releasing a folded top that the limp tendons held): the identification
/// probe's own fill, a third of the calibrated trunk's lowest snap (13.1 kPa).
pub const SEALED_ACTS_KPA: f32 = 4.0;

/// [`reach`] of a step that starts with `sealed_kpa` in the trunk: at or above
/// [`SEALED_ACTS_KPA`], also every state that air may push each of its states up to (the swarm
/// found a fold F&D → F&F started with 28.6 kPa left sealed by an interrupted pull: the top
/// popped at once, D&D, outside the fold's reach).
pub fn reach_sealed(step: &Step, sealed_kpa: f32) -> StateSet {
    let set = reach(step);
    if sealed_kpa < SEALED_ACTS_KPA {
        return set;
    }
    along(set, &UP_REACH)
}

/// Every state a trunk resting in `state` may be in after a change nobody commanded (a snap at
/// rest, or air coming in through a valve stuck open): what air makes of it (up its pneumatic
/// chain) and what a load does (down its tendon chain: a collapse).
pub fn rest_reach(state: TrunkState) -> StateSet {
    let one = StateSet::single(state);
    along(one, &UP_REACH).union(along(one, &DOWN_REACH))
}

/// Every state an interrupted `step` may have left the trunk in: `from`, `to`, and every state
/// further along the same actuation (an inflation may go on snapping up to the cap, a pull
/// whose snap went unseen goes on to buckle the next module). A manual step: `from`, `to`, or
/// what any one hand task makes of `from` (a person may fold the wrong module: fold the top,
/// fold or pack the bottom).
pub fn reach(step: &Step) -> StateSet {
    let from = StateSet::single(step.from);
    let mut set = from.with(step.to);
    let (mut by_hand, mut kpa, mut mm) = (step.kind == StepKind::Manual, false, false);
    for p in &step.primitives {
        match p {
            Primitive::Manual(_) => by_hand = true,
            Primitive::Inflate { .. } => kpa = true,
            Primitive::TendonPull { .. } => mm = true,
            _ => {}
        }
    }
    if by_hand {
        set = set.union(StateSet(HAND_REACH[step.from.index()]));
    }
    if step.kind == StepKind::Manual {
        return set;
    }
    if kpa {
        set = set.union(along(from, &UP_REACH));
    }
    if mm {
        // A pull folds on down its chain, and the air it compresses in the sealed trunk may
        // push a folded module back up: the sealed spike of a fold over a packed bottom may
        // unpack it, and a top folded by the pull springs back out once a collapsing bottom
        // slackens the tendons (the swarm at ±40 %: D&D → F&D ended at D&F, through F&D and
        // F&F, with 16.6 kPa in the trunk; seed 4053).
        let folds = along(from, &DOWN_REACH);
        set = set.union(folds).union(along(folds, &UP_REACH));
    }
    set
}

impl Transition {
    /// The wire form of this transition as one plan step.
    pub fn step(&self) -> Step {
        let mut primitives = heapless::Vec::new();
        for p in self.primitives.iter().take(MAX_STEP_PRIMITIVES) {
            // Cannot fail: `take` bounds the count by the capacity.
            let _ = primitives.push(*p);
        }
        Step {
            kind: self.kind,
            from: self.from,
            to: self.to,
            primitives,
            timeout_ms: self.timeout_ms,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(name: &str) -> TrunkState {
        name.parse().unwrap()
    }

    fn set(names: &[&str]) -> StateSet {
        names.iter().fold(StateSet::EMPTY, |a, n| a.with(s(n)))
    }

    fn nominal(from: &str, to: &str) -> Step {
        transition(s(from), s(to)).unwrap().step()
    }

    #[test]
    fn every_state_reaches_every_other_state() {
        for from in TrunkState::ALL {
            let mut reached = [false; 6];
            reached[from.index()] = true;
            let mut changed = true;
            while changed {
                changed = false;
                for t in &TRANSITIONS {
                    if reached[t.from.index()] && !reached[t.to.index()] {
                        reached[t.to.index()] = true;
                        changed = true;
                    }
                }
            }
            assert_eq!(reached, [true; 6], "from {from}");
        }
    }

    #[test]
    fn d_and_p_is_reached_only_by_hand() {
        let into_dp: usize = TRANSITIONS.iter().filter(|t| t.to == DP).count();
        assert_eq!(into_dp, 1);
        assert_eq!(transition(DF, DP).map(|t| t.kind), Some(StepKind::Manual));
    }

    #[test]
    fn edges_are_unique_and_fit_a_step() {
        for (i, a) in TRANSITIONS.iter().enumerate() {
            assert!(a.primitives.len() <= MAX_STEP_PRIMITIVES);
            assert_ne!(a.from, a.to);
            for b in &TRANSITIONS[i + 1..] {
                assert!(
                    !(a.from == b.from && a.to == b.to),
                    "{} -> {} twice",
                    a.from,
                    a.to
                );
            }
            let step = a.step();
            assert_eq!(step.primitives.len(), a.primitives.len());
            assert_eq!((step.from, step.to, step.kind), (a.from, a.to, a.kind));
        }
    }

    #[test]
    fn pressure_thresholds_follow_the_papers_order() {
        assert!(UNPACK_KPA < POP_TOP_KPA && POP_TOP_KPA < DEPLOY_BOTTOM_KPA);
        assert!(DEPLOY_BOTTOM_KPA < crate::HARD_MAX_PRESSURE_KPA);
        assert_eq!(step_up(FP).map(|t| t.to), Some(FF));
        assert_eq!(step_down(DD).map(|t| t.to), Some(FD));
        assert!(step_up(DD).is_none());
        assert!(step_down(FP).is_none());
    }
    #[test]
    fn the_reach_of_every_nominal_edge_holds_its_overshoots() {
        let cases = [
            // Pneumatic: the inflation may go on snapping up its chain to the cap.
            ("F&P", "F&F", &["F&P", "F&F", "D&F", "D&D"][..]),
            ("D&P", "D&F", &["D&P", "D&F", "D&D"]),
            ("F&F", "D&F", &["F&F", "D&F", "D&D"]),
            ("F&D", "D&D", &["F&D", "D&D"]),
            ("D&F", "D&D", &["D&F", "D&D"]),
            // Tendon: a pull whose snap went unseen goes on down its chain, and the air it
            // compresses may push what it folded back up the pneumatic chain.
            ("D&D", "F&D", &["D&D", "F&D", "F&F", "F&P", "D&F"]),
            ("D&F", "F&F", &["D&F", "F&F", "F&P", "D&D"]),
            // Over a packed bottom: the fold's spike may unpack it, and the pressure go on.
            ("D&P", "F&P", &["D&P", "F&P", "F&F", "D&F", "D&D"]),
            ("F&D", "F&F", &["F&D", "F&F", "F&P", "D&F", "D&D"]),
            ("F&F", "F&P", &["F&F", "F&P", "D&F", "D&D"]),
            // By hand: the task asked, or any other one by mistake (fold the top: F&F).
            ("D&F", "D&P", &["D&F", "D&P", "F&F"]),
        ];
        for (from, to, want) in cases {
            assert_eq!(reach(&nominal(from, to)), set(want), "{from} -> {to}");
        }
    }

    #[test]
    fn the_hand_reach_is_what_one_hand_task_makes_of_each_state() {
        use geometry::{BottomState, TopState};
        for from in TrunkState::ALL {
            let want = [
                from,
                TrunkState::new(TopState::Folded, from.bottom),
                TrunkState::new(from.top, BottomState::Folded),
                TrunkState::new(from.top, BottomState::Packed),
            ]
            .into_iter()
            .fold(StateSet::EMPTY, StateSet::with);
            assert_eq!(StateSet(HAND_REACH[from.index()]), want, "{from}");
        }
    }

    #[test]
    fn air_left_sealed_widens_a_fold_by_what_it_may_pop() {
        let fold = nominal("F&D", "F&F");
        assert_eq!(reach_sealed(&fold, 0.4), reach(&fold));
        assert_eq!(reach_sealed(&fold, 3.9), reach(&fold));
        // Each of F&D, F&F, F&P may be pushed up its chain: D&D, D&F and F&F's chain.
        assert_eq!(
            reach_sealed(&fold, 28.6),
            set(&["F&D", "F&F", "F&P", "D&D", "D&F"])
        );
        // A reading that is no number widens too (nothing is known of the air).
        assert_eq!(reach_sealed(&fold, f32::NAN), reach_sealed(&fold, 28.6));
        let pack = nominal("F&F", "F&P");
        assert!(reach_sealed(&pack, 10.0).contains(s("D&D")));
    }

    #[test]
    fn a_change_at_rest_may_go_either_way_along_the_chains() {
        assert_eq!(rest_reach(s("D&P")), set(&["D&P", "D&F", "D&D", "F&P"]));
        assert_eq!(rest_reach(s("F&P")), set(&["F&P", "F&F", "D&F", "D&D"]));
        assert_eq!(rest_reach(s("D&D")), set(&["D&D", "F&D", "F&F", "F&P"]));
    }

    /// The chain tables are what following the transition table gives.
    #[test]
    fn the_chain_tables_follow_the_transition_table() {
        fn chain(from: TrunkState, next: fn(TrunkState) -> Option<&'static Transition>) -> u8 {
            let mut set = StateSet::single(from);
            let mut at = from;
            while let Some(e) = next(at) {
                assert!(!set.contains(e.to), "a chain of the table loops at {at}");
                set = set.with(e.to);
                at = e.to;
            }
            set.0
        }
        for from in TrunkState::ALL {
            assert_eq!(
                UP_REACH[from.index()],
                chain(from, step_up),
                "up from {from}"
            );
            assert_eq!(
                DOWN_REACH[from.index()],
                chain(from, step_down),
                "down from {from}"
            );
        }
    }
}
