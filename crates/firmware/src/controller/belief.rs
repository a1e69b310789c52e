//! What the controller knows about the trunk's state, and how sure it is.
//!
//! A [`Belief`] is either *confirmed* (the sensors, a completed and confirmed step, the operator
//! or the host said so) or *unconfirmed*: the best guess, the [`StateSet`] of states the trunk
//! may be in, and the step that was under way when confidence was lost. Every interruption of a
//! step after its actuation began (fault, abort, e-stop, link loss, power cut) makes it
//! unconfirmed with the step's [`reach`] as candidates, unless the sensors decide (nothing
//! reached the first threshold: [`untouched`]).
//!
//! The thresholds here are the simulator's calibrated physics (`hil-sim discover`,
//! `docs/simulator.md`), the same numbers `protocol::transitions` documents; a hil-sim test holds
//! them to the calibrated trunk. Each is the *lowest* actuation at which the edge's snap was seen;
//! [`reach`] adds a margin above the step's largest actuation, [`untouched`] one below.

use geometry::TrunkState;
use protocol::{Primitive, StateSet, Step, StepKind, Transition};

/// Pressure at which each pneumatic edge snaps, kPa (gauge).
pub const PNEUMATIC_SNAP_KPA: [(usize, usize, f32); 5] = [
    (FP, FF, 13.1),
    (DP, DF, 13.1),
    (FF, DF, 19.6),
    (FD, DD, 19.6),
    (DF, DD, 30.1),
];

/// Tendon shortening (from the slack position of the deployed trunk) at which each tendon
/// edge's first snap comes, mm.
pub const TENDON_SNAP_MM: [(usize, usize, f32); 5] = [
    (DD, FD, 9.0),
    (DF, FF, 56.0),
    (DP, FP, 102.0),
    (FD, FF, 92.0),
    (FF, FP, 138.0),
];

/// What one hand task (fold the top, fold the bottom, pack the bottom) makes of each state, by
/// [`TrunkState::index`] (bit per index: F&P, F&F, F&D, D&P, D&F, D&D), the state itself
/// included: F&P {F&P, F&F}, F&F {F&F, F&P}, F&D {F&D, F&F, F&P}, D&P {D&P, F&P, D&F},
/// D&F {D&F, F&F, D&P}, D&D {D&D, F&D, D&F, D&P} (a unit test derives it).
pub const HAND_REACH: [u8; 6] = [0b000011, 0b000011, 0b000111, 0b011001, 0b011010, 0b111100];

/// Margin above a step's largest inflation within which a further snap counts as possible
/// (the regulator's hysteresis, sensor noise and the spread of the thresholds with load).
pub const REACH_MARGIN_KPA: f32 = 3.0;
/// Margin above a step's longest pull within which a further snap counts as possible.
pub const REACH_MARGIN_MM: f32 = 10.0;
/// Margin below an edge's threshold under which the trunk certainly did not snap.
pub const UNTOUCHED_MARGIN_KPA: f32 = 3.0;
/// Margin below an edge's first tendon snap under which the trunk certainly did not snap.
pub const UNTOUCHED_MARGIN_MM: f32 = 5.0;

const FP: usize = 0;
const FF: usize = 1;
const FD: usize = 2;
const DP: usize = 3;
const DF: usize = 4;
const DD: usize = 5;

fn next_edge(table: &[(usize, usize, f32)], from: TrunkState) -> Option<(TrunkState, f32)> {
    table
        .iter()
        .find(|e| e.0 == from.index())
        .and_then(|e| TrunkState::from_index(e.1).map(|to| (to, e.2)))
}

/// The states reached walking `table` from `from` while each edge's threshold is at most
/// `actuation` (the states past every snap the actuation could have caused).
fn walk(table: &[(usize, usize, f32)], from: TrunkState, actuation: f32) -> StateSet {
    let mut set = StateSet::single(from);
    let mut at = from;
    // At most one pass per state: the tables are chains.
    for _ in 0..TrunkState::ALL.len() {
        match next_edge(table, at) {
            Some((to, threshold)) if threshold <= actuation => {
                set = set.with(to);
                at = to;
            }
            _ => break,
        }
    }
    set
}

/// The step's largest inflation target (kPa) and longest pull (mm), `-1` where it has none.
fn actuation(step: &Step) -> (f32, f32) {
    let mut kpa = -1.0f32;
    let mut mm = -1.0f32;
    for p in &step.primitives {
        match *p {
            Primitive::Inflate { pressure_kpa, .. } => kpa = kpa.max(pressure_kpa),
            Primitive::TendonPull { length_mm, .. } | Primitive::TendonRelease { length_mm } => {
                mm = mm.max(length_mm)
            }
            _ => {}
        }
    }
    (kpa, mm)
}

/// Every state an interrupted `step` may have left the trunk in: `from`, `to`, and every state
/// further along the same actuation that its largest inflation or longest pull could reach
/// (overshoots: a pull from `D&D` to `F&D` whose snap went unseen goes on to buckle the bottom,
/// `F&F`). A manual step: `from`, `to`, or what any one hand task makes of `from` (a person
/// may fold the wrong module: fold the top, fold or pack the bottom).
pub fn reach(step: &Step) -> StateSet {
    let mut set = StateSet::single(step.from).with(step.to);
    let by_hand = step.kind == StepKind::Manual
        || step
            .primitives
            .iter()
            .any(|p| matches!(p, Primitive::Manual(_)));
    if by_hand {
        set = set.union(StateSet(HAND_REACH[step.from.index()]));
    }
    if step.kind == StepKind::Manual {
        return set;
    }
    let (kpa, mm) = actuation(step);
    if kpa >= 0.0 {
        set = set.union(walk(&PNEUMATIC_SNAP_KPA, step.from, kpa + REACH_MARGIN_KPA));
    }
    if mm >= 0.0 {
        set = set.union(walk(&TENDON_SNAP_MM, step.from, mm + REACH_MARGIN_MM));
    }
    set
}

/// Whether a step from `from` that reached at most `peak_kpa` (filtered, valid readings
/// throughout) and `peak_pull_mm` (commanded, which the servos never exceed) certainly left the
/// trunk in `from`: both stayed under the first threshold by the margins.
pub fn untouched(from: TrunkState, peak_kpa: f32, peak_pull_mm: f32) -> bool {
    let p_ok = next_edge(&PNEUMATIC_SNAP_KPA, from)
        .is_none_or(|(_, t)| peak_kpa < t - UNTOUCHED_MARGIN_KPA);
    let l_ok = next_edge(&TENDON_SNAP_MM, from)
        .is_none_or(|(_, t)| peak_pull_mm < t - UNTOUCHED_MARGIN_MM);
    p_ok && l_ok
}

/// What the controller knows about the trunk's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Belief {
    /// Best guess: the confirmed state; unconfirmed, the last confirmed one (or, after a step
    /// that completed without evidence, its target).
    state: TrunkState,
    confirmed: bool,
    /// The states the trunk may be in (`{state}` when confirmed).
    candidates: StateSet,
    /// The step under way when confidence was lost.
    interrupted: Option<Transition>,
}

impl Belief {
    /// Confirmed in `state`.
    pub const fn confirmed(state: TrunkState) -> Self {
        Self {
            state,
            confirmed: true,
            candidates: StateSet::single(state),
            interrupted: None,
        }
    }

    /// Unconfirmed: best guess `state`, one of `candidates` (`state` is added), after
    /// `interrupted`. A single candidate is still unconfirmed (nobody checked).
    pub const fn unconfirmed(
        state: TrunkState,
        candidates: StateSet,
        interrupted: Option<Transition>,
    ) -> Self {
        Self {
            state,
            confirmed: false,
            candidates: candidates.with(state),
            interrupted,
        }
    }

    /// Nothing known (a corrupt store): any state, `state` as the guess.
    pub const fn unknown(state: TrunkState) -> Self {
        Self::unconfirmed(state, StateSet::ALL, None)
    }

    /// The best guess (the confirmed state when confirmed).
    pub const fn state(&self) -> TrunkState {
        self.state
    }

    /// Whether [`Belief::state`] is confirmed.
    pub const fn is_confirmed(&self) -> bool {
        self.confirmed
    }

    /// The states the trunk may be in.
    pub const fn candidates(&self) -> StateSet {
        self.candidates
    }

    /// The step under way when confidence was lost.
    pub const fn interrupted(&self) -> Option<Transition> {
        self.interrupted
    }

    /// The state, when it is confirmed.
    pub fn known(&self) -> Option<TrunkState> {
        self.confirmed.then_some(self.state)
    }

    /// Narrows the candidates to those also in `set` (a probe's verdict); confirms when one is
    /// left. A verdict that excludes every candidate contradicts what is known: nothing changes
    /// and `false` is returned.
    pub fn narrow(&mut self, set: StateSet) -> bool {
        let left = self.candidates.intersect(set);
        if left.is_empty() {
            return false;
        }
        match left.only() {
            Some(s) => *self = Self::confirmed(s),
            None => {
                self.candidates = left;
                if !left.contains(self.state) {
                    if let Some(first) = left.iter().next() {
                        self.state = first;
                    }
                }
            }
        }
        true
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
        protocol::transitions::transition(s(from), s(to))
            .unwrap()
            .step()
    }

    #[test]
    fn the_reach_of_every_nominal_edge_holds_its_overshoots() {
        let cases = [
            // Pneumatic: the regulator's target plus the margin stays under the next snap.
            ("F&P", "F&F", &["F&P", "F&F"][..]),
            ("D&P", "D&F", &["D&P", "D&F"]),
            ("F&F", "D&F", &["F&F", "D&F"]),
            ("F&D", "D&D", &["F&D", "D&D"]),
            ("D&F", "D&D", &["D&F", "D&D"]),
            // Tendon: a 120 mm pull from D&D buckles the top at 9 mm and, if it goes on, the
            // bottom at 92 mm (F&F); packing (138 mm) is out of reach.
            ("D&D", "F&D", &["D&D", "F&D", "F&F"]),
            ("D&F", "F&F", &["D&F", "F&F"]),
            ("D&P", "F&P", &["D&P", "F&P"]),
            ("F&D", "F&F", &["F&D", "F&F"]),
            ("F&F", "F&P", &["F&F", "F&P"]),
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
    fn untouched_needs_both_actuations_under_their_first_threshold() {
        // F&P unpacks at 13.1 kPa: 9.9 kPa is 3.2 under it, 10.2 only 2.9.
        assert!(untouched(s("F&P"), 9.9, 0.0));
        assert!(!untouched(s("F&P"), 10.2, 0.0));
        // D&D buckles at 9 mm of pull: under 4 mm is untouched.
        assert!(untouched(s("D&D"), 0.0, 3.9));
        assert!(!untouched(s("D&D"), 0.0, 4.1));
        // A state without a pneumatic edge (D&D) is not moved by any pressure.
        assert!(untouched(s("D&D"), 39.0, 0.0));
    }

    #[test]
    fn narrowing_confirms_at_one_candidate_and_refuses_a_contradiction() {
        let step = nominal("D&D", "F&D");
        let mut b = Belief::unconfirmed(
            s("D&D"),
            reach(&step),
            Some(Transition {
                from: s("D&D"),
                to: s("F&D"),
            }),
        );
        assert!(!b.is_confirmed());
        assert!(!b.narrow(set(&["D&P"])));
        assert_eq!(b.candidates(), set(&["D&D", "F&D", "F&F"]));
        assert!(b.narrow(set(&["F&D", "F&F", "D&P"])));
        assert_eq!(b.candidates(), set(&["F&D", "F&F"]));
        assert!(!b.is_confirmed());
        assert!(b.candidates().contains(b.state()));
        assert!(b.narrow(set(&["F&F"])));
        assert_eq!(b, Belief::confirmed(s("F&F")));
        assert_eq!(b.candidates(), set(&["F&F"]));
    }
}
