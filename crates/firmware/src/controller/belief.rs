//! What the controller knows about the trunk's state, and how sure it is.
//!
//! A [`Belief`] is either *confirmed* (the sensors, a completed and confirmed step, the operator
//! or the host said so) or *unconfirmed*: the best guess, the [`StateSet`] of states the trunk
//! may be in, and the step that was under way when confidence was lost. Every interruption of a
//! step after its actuation began (fault, abort, e-stop, link loss, power cut) makes it
//! unconfirmed with the step's [`reach`] as candidates, unless the sensors decide (nothing
//! came near any snap: [`untouched`]).
//!
//! Nothing here depends on where a trunk snaps (`docs/firmware.md`, "Truth without the
//! simulator's constants"): a trunk printed from other TPU snaps at other pressures and pulls.
//! The reach of a step is every state along its actuation's chain of the transition table
//! (`protocol::transitions`: what more of the same actuation makes of the trunk), and a step is
//! untouched only below [`UNTOUCHED_KPA`] and [`UNTOUCHED_MM`], far under any snap of a trunk
//! of this design.

use geometry::TrunkState;
pub use protocol::transitions::{reach, HAND_REACH};
use protocol::transitions::{step_down, step_up};
use protocol::StateSet;

/// Highest pressure (kPa) under which a step certainly left the trunk where it was: the
/// identification probe's own fill pressure, under a third of the calibrated trunk's lowest
/// snap (13.1 kPa); a trunk of this design that unpacks this low (its barrier under a third
/// of the calibrated one) does not hold its states.
pub const UNTOUCHED_KPA: f32 = super::identify::PROBE_KPA;
/// Longest pull (mm) under which a step certainly left the trunk where it was: at D&D the
/// tendons are taut from the first millimetre, and 1 mm compresses the deployed trunk by a
/// few newtons (its modules' 16–20 N/mm in series), far from the top's buckling (75 N).
pub const UNTOUCHED_MM: f32 = 1.0;

/// Whether a step from `from` that reached at most `peak_kpa` (filtered, valid readings
/// throughout) and `peak_pull_mm` (commanded, which the servos never exceed) certainly left the
/// trunk in `from`: each actuation that can move `from` stayed under its bound.
pub fn untouched(from: TrunkState, peak_kpa: f32, peak_pull_mm: f32) -> bool {
    let p_ok = step_up(from).is_none() || peak_kpa < UNTOUCHED_KPA;
    let l_ok = step_down(from).is_none() || peak_pull_mm < UNTOUCHED_MM;
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
    interrupted: Option<protocol::Transition>,
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
        interrupted: Option<protocol::Transition>,
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
    pub const fn interrupted(&self) -> Option<protocol::Transition> {
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
    use protocol::Step;

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
    fn untouched_needs_both_actuations_under_their_bounds() {
        // Under the probe's 4 kPa nothing snaps; above it, whatever the trunk, it may have.
        assert!(untouched(s("F&P"), 3.9, 0.0));
        assert!(!untouched(s("F&P"), 4.1, 0.0));
        // D&D's tendons are taut: under 1 mm of pull is untouched.
        assert!(untouched(s("D&D"), 0.0, 0.9));
        assert!(!untouched(s("D&D"), 0.0, 1.1));
        // A state without a pneumatic edge (D&D) is not moved by any pressure, one without a
        // tendon edge (F&P) by any pull.
        assert!(untouched(s("D&D"), 39.0, 0.0));
        assert!(untouched(s("F&P"), 0.0, 150.0));
    }

    #[test]
    fn narrowing_confirms_at_one_candidate_and_refuses_a_contradiction() {
        let step = nominal("D&D", "F&D");
        let mut b = Belief::unconfirmed(
            s("D&D"),
            reach(&step),
            Some(protocol::Transition {
                from: s("D&D"),
                to: s("F&D"),
            }),
        );
        assert!(!b.is_confirmed());
        assert!(!b.narrow(set(&["D&P"])));
        assert_eq!(b.candidates(), set(&["D&D", "F&D", "F&F", "F&P", "D&F"]));
        assert!(b.narrow(set(&["F&D", "F&F", "D&P"])));
        assert_eq!(b.candidates(), set(&["F&D", "F&F"]));
        assert!(!b.is_confirmed());
        assert!(b.candidates().contains(b.state()));
        assert!(b.narrow(set(&["F&F"])));
        assert_eq!(b, Belief::confirmed(s("F&F")));
        assert_eq!(b.candidates(), set(&["F&F"]));
    }
}
