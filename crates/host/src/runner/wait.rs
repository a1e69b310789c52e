//! What the runner waits for, each wait with the data only it needs: the plan being followed
//! lives in the waits that follow one, the poll time in the waits that poll, what an
//! identification has told the operator in the identification's waits, and the reason and the
//! stopped plan in the abort's. A plan followed while nothing is loaded, an operator's stop
//! outside an abort, or a manual confirmation out while polling cannot be written down.

use transition_graph::Plan;

use super::RunFailure;
use crate::session::RequestId;

/// The runner's state.
#[derive(Debug, Clone)]
pub(super) enum Wait {
    /// A `GetStatus` before planning is out; what led to it.
    Status(Before),
    /// Old faults are being reset.
    ResetFaults,
    /// A stray plan is being aborted.
    TakeoverAbort,
    /// `Identify` is out.
    Identify(Identification),
    /// The operator's answer to an identify prompt, or the end of the crane's probes: nothing is
    /// out, and the status is polled at `next_poll_ms` (the crane's own confirm button may
    /// settle it).
    Operator {
        /// What this identification has told the operator so far.
        identification: Identification,
        /// When the status is polled next (shell clock).
        next_poll_ms: u64,
    },
    /// A declared state; then the status.
    Declared,
    /// A vent of the air left sealed in the trunk is out (`RunStep` within the state).
    Vent,
    /// The vent runs: nothing is out, the status is polled at `next_poll_ms` until it ends.
    Venting {
        /// When the status is polled next (shell clock).
        next_poll_ms: u64,
    },
    /// A status poll while the vent runs.
    VentPoll,
    /// `UploadPlan` is out.
    Upload(Following),
    /// `StartPlan` is out (the device may have started the plan already).
    Start(Following),
    /// Following the started plan: a status poll is out, or due at `next_poll_ms`.
    Poll {
        /// The plan.
        run: Following,
        /// When the status is polled next (shell clock).
        next_poll_ms: u64,
    },
    /// A manual confirmation from the host is out (it took the place of any poll that was
    /// out); then the polls go on at `next_poll_ms`.
    Confirm {
        /// The plan.
        run: Following,
        /// When the status is polled next (shell clock).
        next_poll_ms: u64,
    },
    /// Resetting a fault before a replan.
    ResetForReplan,
    /// An abort is out; then the final status.
    Abort(Aborting),
    /// The status after the abort.
    StatusAfterAbort(Aborting),
    /// Over.
    Done,
}

impl Wait {
    /// Whether the request out in this wait is a `GetStatus`.
    pub(super) fn asks_status(&self) -> bool {
        matches!(
            self,
            Wait::Status(_) | Wait::Poll { .. } | Wait::VentPoll | Wait::StatusAfterAbort(_)
        )
    }

    /// The plan loaded on the device, or being loaded (not a stopped one).
    pub(super) fn following(&self) -> Option<&Following> {
        match self {
            Wait::Upload(run)
            | Wait::Start(run)
            | Wait::Poll { run, .. }
            | Wait::Confirm { run, .. } => Some(run),
            _ => None,
        }
    }

    /// [`Wait::following`], to change.
    pub(super) fn following_mut(&mut self) -> Option<&mut Following> {
        match self {
            Wait::Upload(run)
            | Wait::Start(run)
            | Wait::Poll { run, .. }
            | Wait::Confirm { run, .. } => Some(run),
            _ => None,
        }
    }

    /// The plans the device may be running when nothing fresh will say: one whose `StartPlan`
    /// is out or was accepted, and one the operator stopped.
    pub(super) fn may_run(&self) -> Option<&Following> {
        match self {
            Wait::Start(run) | Wait::Poll { run, .. } | Wait::Confirm { run, .. } => Some(run),
            Wait::Abort(a) | Wait::StatusAfterAbort(a) => a.stopped().map(|s| &s.run),
            _ => None,
        }
    }
}

/// What came before a status asked for before planning.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Before {
    /// Nothing: the run's first status.
    Start,
    /// Faults were reset, a state declared, or a vent ended (or was refused).
    Reset,
    /// A stray plan was aborted.
    Takeover,
    /// `Identify` was answered.
    Identify(Identification),
    /// A poll while the operator is asked (or the crane probes).
    OperatorPoll(Identification),
}

impl Before {
    /// The identification under way, if this status is one of its.
    pub(super) fn identification(self) -> Option<Identification> {
        match self {
            Before::Identify(i) | Before::OperatorPoll(i) => Some(i),
            Before::Start | Before::Reset | Before::Takeover => None,
        }
    }
}

/// What one identification (from its `Identify` on) has told the operator: each at most once.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct Identification {
    /// That the crane probes its state.
    pub(super) probing_noted: bool,
    /// The identify prompt.
    pub(super) prompted: bool,
}

/// The plan being followed.
#[derive(Debug, Clone)]
pub(super) struct Following {
    pub(super) plan_id: u16,
    pub(super) plan: Plan,
    pub(super) current: usize,
    pub(super) step_start_uptime: Option<u32>,
    pub(super) event_durations: Vec<Option<u32>>,
    pub(super) prompted: Vec<bool>,
    pub(super) polls_without_plan: u32,
}

/// An abort under way.
#[derive(Debug, Clone)]
pub(super) struct Aborting {
    /// The failure to report once the abort is done.
    pub(super) reason: RunFailure,
    /// Who asked for it.
    pub(super) by: AbortBy,
}

impl Aborting {
    /// The plan the operator stopped, if any.
    pub(super) fn stopped(&self) -> Option<&Stopped> {
        match &self.by {
            AbortBy::Operator(stopped) => stopped.as_ref(),
            AbortBy::Runner => None,
        }
    }
}

/// Who asked for an abort.
#[derive(Debug, Clone)]
pub(super) enum AbortBy {
    /// The runner (a step past its time limit, a device that makes no sense); the operator's
    /// stop still goes out on top of it.
    Runner,
    /// The operator (a second stop changes nothing), with the plan they stopped if one was
    /// loaded.
    Operator(Option<Stopped>),
}

/// A plan the operator stopped, until the status after the abort tells how far it got.
#[derive(Debug, Clone)]
pub(super) struct Stopped {
    /// The plan.
    pub(super) run: Following,
    /// What stopped it.
    pub(super) why: String,
    /// `StartPlan` was accepted.
    pub(super) started: bool,
}

/// The one request the runner has out, and whether the last status it heard is fresh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Exchange {
    /// This request is out; whatever status was heard before it is stale.
    Out(RequestId),
    /// Nothing is out, and no status has been heard since the last request went out.
    Stale,
    /// Nothing is out, and the last reply was a status: what it says is fresh.
    Fresh,
}
