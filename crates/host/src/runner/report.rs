//! What a run tells its shell when it is over: the steps, the failure (typed and in words), the
//! state the device was left in and how sure it is.

use geometry::TrunkState;
use protocol::{FaultCode, RejectReason, StateSet, Status, StepKind};
use transition_graph::kind_name;

use crate::session::SessionError;

/// What happened to one step that was started on the device.
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport {
    /// How it was actuated.
    pub kind: StepKind,
    /// Start state.
    pub from: TrunkState,
    /// Planned end state.
    pub to: TrunkState,
    /// Whether the device confirmed `to`.
    pub ok: bool,
    /// Device time the step took (from the device's `StepDone` event, or from its uptime in the
    /// status polls around the step when that event was lost).
    pub duration_ms: Option<u32>,
}

/// Which step a failure happened in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepRef {
    /// Index in its plan (0-based).
    pub index: usize,
    /// Steps in its plan.
    pub total: usize,
    /// How it was actuated.
    pub kind: StepKind,
    /// Start state.
    pub from: TrunkState,
    /// Planned end state.
    pub to: TrunkState,
}

impl std::fmt::Display for StepRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "step {}/{} ({} {} → {})",
            self.index + 1,
            self.total,
            kind_name(self.kind),
            self.from,
            self.to
        )
    }
}

/// What kind of failure ended a run (machine-readable; the message says it for people).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FailureKind {
    /// The device raised a fault during a step.
    Fault,
    /// The link was lost (or never came up).
    LinkLost,
    /// Stopped by the operator (Ctrl-C, a signal, the crane's stop button, another host).
    Aborted,
    /// The device refused a request.
    Refused,
    /// No sequence of transitions leads to the target (after the failures seen).
    NoPath,
    /// The e-stop is latched.
    EStop,
    /// The device is busy (a plan runs already).
    Busy,
    /// The device's state is unconfirmed and could not be identified.
    Unidentified,
    /// A step ran past its time limit and the host aborted it.
    Timeout,
    /// Anything else the device did that makes no sense for the request.
    Protocol,
}

impl FailureKind {
    /// A stable name for JSON.
    pub const fn name(self) -> &'static str {
        match self {
            FailureKind::Fault => "fault",
            FailureKind::LinkLost => "link-lost",
            FailureKind::Aborted => "aborted",
            FailureKind::Refused => "refused",
            FailureKind::NoPath => "no-path",
            FailureKind::EStop => "e-stop",
            FailureKind::Busy => "busy",
            FailureKind::Unidentified => "unidentified",
            FailureKind::Timeout => "timeout",
            FailureKind::Protocol => "protocol",
        }
    }
}

/// Why a run failed: typed (kind, step, fault code) and in words.
#[derive(Debug, Clone, PartialEq)]
pub struct RunFailure {
    /// What kind of failure.
    pub kind: FailureKind,
    /// The step it happened in, if one ran.
    pub step: Option<StepRef>,
    /// The device's fault code, where it gave one.
    pub fault: Option<FaultCode>,
    /// The device's refusal, where it gave one.
    pub reject: Option<RejectReason>,
    /// The field the device refused, with the value asked for and the limit, where it named
    /// one.
    pub refusal: Option<protocol::Refusal>,
    /// For people.
    pub message: String,
}

impl RunFailure {
    pub(super) fn new(kind: FailureKind, message: impl Into<String>) -> Self {
        Self {
            kind,
            step: None,
            fault: None,
            reject: None,
            refusal: None,
            message: message.into(),
        }
    }

    pub(super) fn at(mut self, step: StepRef) -> Self {
        self.step = Some(step);
        self
    }

    pub(super) fn from_session(context: &str, e: &SessionError) -> Self {
        let refusal = match e {
            SessionError::Rejected { refusal, .. } => *refusal,
            _ => None,
        };
        let (kind, reject) = match e {
            SessionError::Timeout { .. } | SessionError::Closed => (FailureKind::LinkLost, None),
            SessionError::Rejected { reason, .. } => (
                if *reason == RejectReason::EStopLatched {
                    FailureKind::EStop
                } else {
                    FailureKind::Refused
                },
                Some(*reason),
            ),
            SessionError::Busy { .. } => (FailureKind::Busy, None),
            SessionError::VersionMismatch(_)
            | SessionError::Unexpected { .. }
            | SessionError::Preempted { .. } => (FailureKind::Protocol, None),
        };
        let message = match kind {
            FailureKind::LinkLost => format!(
                "link lost {context}: {e}; the device aborts to its safe state by itself when \
                 the host falls silent"
            ),
            _ => format!("{context}: {e}"),
        };
        Self {
            reject,
            refusal,
            ..Self::new(kind, message)
        }
    }
}

/// The account of a whole run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Outcome {
    /// The state the device reported before planning (None if it never answered).
    pub from: Option<TrunkState>,
    /// The state asked for.
    pub target: Option<TrunkState>,
    /// The state the device reported last (None if it never answered).
    pub final_state: Option<TrunkState>,
    /// Whether the device had confirmed `final_state` when it reported it last. A run that
    /// ended without a fresh status (lost link) reports `false`: the last report is stale.
    pub state_confirmed: bool,
    /// The states the trunk may be in: `{final_state}` when confirmed; unconfirmed, the
    /// device's own candidates from a fresh status, or — when the run ended without one (a lost
    /// link) — the last report's candidates widened by the reach
    /// ([`protocol::transitions::reach`]) of every plan step the device may have run since.
    /// All six states: unknown (the device never answered).
    pub candidates: StateSet,
    /// The last status the device sent.
    pub last_status: Option<Status>,
    /// Every step started, across replans, in order.
    pub steps: Vec<StepReport>,
    /// Why the run failed (None on success).
    pub failure: Option<RunFailure>,
    /// Times the plan was remade after a surprise.
    pub replans: u32,
    /// Whether the state had to be identified before planning (by the crane's probes, or by the
    /// operator when the probes could not decide).
    pub identified: bool,
}

impl Outcome {
    /// Success: no failure and the device reports the target state, confirmed.
    pub fn ok(&self) -> bool {
        self.failure.is_none()
            && self.state_confirmed
            && self.final_state.is_some()
            && self.final_state == self.target
    }

    /// The failure's message, if any.
    pub fn error(&self) -> Option<&str> {
        self.failure.as_ref().map(|f| f.message.as_str())
    }
}
