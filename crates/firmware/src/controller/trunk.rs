//! What is known about the trunk and its persistence: the belief (confirmed, or unconfirmed
//! with its candidates and the interrupted step), what a report says of it while a step moves
//! the trunk, and the journal, the handover of each record to the shell that persists it
//! (`docs/firmware.md`, "What a state report means").

use geometry::TrunkState;
use protocol::{Event, FaultCode, StateSet};

use super::belief::Belief;
use super::{max_bend_deg, Controller};
use crate::store::StoredState;

/// The trunk's record.
#[derive(Debug, Clone, Copy)]
pub(super) struct Trunk {
    /// What is known about the trunk.
    pub(super) belief: Belief,
    pub(super) journal: Journal,
}

/// The persisted record's handover to the shell: records made, taken
/// ([`Controller::poll_store`]) and persisted ([`Controller::handle_stored`]), counted; a step
/// actuates only once its journal record is persisted.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Journal {
    pub(super) pending: Option<StoredState>,
    pub(super) made: u32,
    pub(super) polled: u32,
    pub(super) persisted: u32,
}

impl Controller {
    /// The trunk state now (confirmed, or the best guess).
    pub(super) fn state(&self) -> TrunkState {
        self.trunk.belief.state()
    }

    /// Whether the trunk state is confirmed.
    pub(super) fn confirmed(&self) -> bool {
        self.trunk.belief.is_confirmed()
    }

    /// The step of a running plan that moves the trunk to another state, if one is under way,
    /// and its reach.
    pub(super) fn moving_step(&self) -> Option<(&protocol::Step, StateSet)> {
        let e = self.exec.as_ref()?;
        let step = e.plan.steps.get(usize::from(e.step))?;
        (step.from != step.to).then_some((step, e.reach))
    }

    /// What a report says of the state: the belief, except while a step moves the trunk — then
    /// the trunk is between the step's ends or further along its reach, and the last confirmed
    /// state (`state`, the step's `from`) is not claimed: unconfirmed, the step's reach as
    /// candidates, the step as the one under way (`docs/firmware.md`,
    /// "What a state report means").
    pub(super) fn reported_belief(&self) -> (bool, StateSet, Option<protocol::Transition>) {
        match self.moving_step() {
            Some((step, reach)) => (
                false,
                reach.with(self.trunk.belief.state()),
                Some(protocol::Transition {
                    from: step.from,
                    to: step.to,
                }),
            ),
            None => (
                self.trunk.belief.is_confirmed(),
                self.trunk.belief.candidates(),
                self.trunk.belief.interrupted(),
            ),
        }
    }

    /// Takes `belief` as what is known; persists and reports it when it changed.
    pub(super) fn set_belief(&mut self, belief: Belief) {
        if belief == self.trunk.belief {
            return;
        }
        if belief.state() != self.trunk.belief.state() {
            self.max_bend_deg = max_bend_deg(&self.cfg, belief.state());
        }
        self.trunk.belief = belief;
        if belief.is_confirmed() {
            self.ident.asking = None;
        }
        self.store(StoredState {
            state: belief.state(),
            confirmed: belief.is_confirmed(),
            candidates: belief.candidates(),
            pending: if belief.is_confirmed() {
                None
            } else {
                belief.interrupted()
            },
        });
        self.emit(Event::StateReached {
            state: belief.state(),
            confirmed: belief.is_confirmed(),
        });
    }

    /// Hands `record` to the shell to persist; returns its number (see
    /// [`Controller::journal_persisted`]).
    pub(super) fn store(&mut self, record: StoredState) -> u32 {
        self.trunk.journal.made = self.trunk.journal.made.wrapping_add(1);
        self.trunk.journal.pending = Some(record);
        self.trunk.journal.made
    }

    /// Whether record number `n` (or a later one) is persisted.
    pub(super) fn journal_persisted(&self, n: u32) -> bool {
        self.trunk.journal.persisted.wrapping_sub(n) < u32::MAX / 2
    }

    /// A person or the host says the trunk is in `state`: confirmed and persisted; a
    /// StateStorage fault (nothing was known) is cleared with it.
    pub(super) fn declare(&mut self, state: TrunkState) {
        self.confirm_state(state);
        if self.fault_active(FaultCode::StateStorage) {
            self.safety.faults &= !FaultCode::StateStorage.bit();
            self.emit(Event::FaultCleared(FaultCode::StateStorage));
            if self.safety.faults == 0 && !self.safety.estop_latched {
                self.safety.safe = false;
            }
        }
    }

    /// Asks the operator which candidate the trunk is in (display, up/down, confirm; or the
    /// host's DeclareState).
    pub(super) fn ask_operator(&mut self) {
        let c = self.trunk.belief.candidates();
        let shown = if c.contains(self.state()) {
            Some(self.state())
        } else {
            c.iter().next()
        };
        self.ident.asking = shown;
        self.emit(Event::IdentifyNeedsOperator { candidates: c });
    }

    /// Confirms `state` (sensors, a person, the host).
    pub(super) fn confirm_state(&mut self, state: TrunkState) {
        self.set_belief(Belief::confirmed(state));
    }
}
