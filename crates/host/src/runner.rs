//! The plan runner: status → (identify) → plan → upload → start → follow → replan, without I/O.
//!
//! The device's status is the truth: while a plan runs its `plan` field (step index and phase)
//! is polled every [`RunOptions::poll_ms`], which also feeds the device's link watchdog. Events
//! (step done, faults) are hints that refine the report (exact step durations) but are never
//! waited for: on a noisy line any frame can be lost.
//!
//! A state the device has not confirmed is never planned from: the runner first has the state
//! identified (the operator names it; the device refuses a step from a state it cannot vouch
//! for anyway), then plans.

use std::collections::VecDeque;

use geometry::TrunkState;
use protocol::{
    Event, FaultCode, ManualTask, Mode, PlanPhase, RejectReason, RequestBody, ResponseBody,
    StateSet, Status, StepKind,
};
use transition_graph::{kind_name, Graph, Plan};

use crate::session::{RequestId, Session, SessionError, SessionEvent};
use crate::text;

/// While the operator is asked to identify the state, the status is read this often (the
/// crane's confirm button may settle it first).
const OPERATOR_POLL_MS: u64 = 500;
/// Time limit of the vent of air left sealed in the resting trunk (from the cap it takes a few
/// seconds).
const VENT_TIMEOUT_MS: u32 = 20_000;

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
    fn new(kind: FailureKind, message: impl Into<String>) -> Self {
        Self {
            kind,
            step: None,
            fault: None,
            reject: None,
            refusal: None,
            message: message.into(),
        }
    }

    fn at(mut self, step: StepRef) -> Self {
        self.step = Some(step);
        self
    }

    fn from_session(context: &str, e: &SessionError) -> Self {
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

/// Options of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunOptions {
    /// Surprises tolerated before giving up.
    pub max_replans: u32,
    /// Device time allowed past a step's own time limit before the host aborts it (the device
    /// should fault first; this is the host's backstop).
    pub step_grace_ms: u32,
    /// Status polls this often while a plan runs (shell clock, ms).
    pub poll_ms: u64,
    /// A plan found running on the device (left by a host that died) is aborted and the run
    /// goes on from the device's state afterwards, instead of refusing.
    pub take_over_running: bool,
    /// Only identify: end as soon as the device's state is confirmed (whatever it is), without
    /// planning (`host-tool identify`).
    pub identify_only: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            max_replans: 3,
            step_grace_ms: 5_000,
            poll_ms: 100,
            take_over_running: false,
            identify_only: false,
        }
    }
}

/// What the runner tells its shell (progress for people, prompts to answer).
#[derive(Debug, Clone, PartialEq)]
pub enum RunEvent {
    /// A plan was made (`replan`: after a surprise).
    Plan {
        /// The plan.
        plan: Plan,
        /// Made after a surprise.
        replan: bool,
    },
    /// Step `index` of `total` started.
    StepStarted {
        /// Index.
        index: usize,
        /// Steps in the plan.
        total: usize,
    },
    /// Step `index` is running: `elapsed_ms` of device time, latest pressure.
    StepProgress {
        /// Index.
        index: usize,
        /// Device time since the step started.
        elapsed_ms: u32,
        /// Latest pressure.
        pressure_kpa: f32,
    },
    /// A manual step waits for a person: answer with [`PlanRunner::confirm_manual`] (or the
    /// crane's confirm button).
    ManualPrompt {
        /// Index.
        index: usize,
        /// What to do.
        task: ManualTask,
    },
    /// The device's state is unconfirmed: the operator must say which state the trunk is in
    /// (answer with [`PlanRunner::declare`]); `candidates` are the states it can be in.
    IdentifyPrompt {
        /// What the device last had confirmed.
        believed: TrunkState,
        /// States the trunk may be in.
        candidates: Vec<TrunkState>,
    },
    /// Step `index` ended.
    StepFinished {
        /// Index.
        index: usize,
        /// What happened.
        report: StepReport,
    },
    /// Anything else worth a line.
    Note(String),
    /// The run is over; [`PlanRunner::outcome`] has the account.
    Finished,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Wait {
    /// The first status.
    Status,
    /// Old faults are being reset.
    ResetFaults,
    /// Faults were reset (or a state declared); the status after it.
    StatusAfterReset,
    /// A stray plan is being aborted.
    TakeoverAbort,
    /// A stray plan was aborted; the status after it.
    StatusAfterTakeover,
    /// `Identify` is out.
    Identify,
    /// The status after `Identify` answered.
    StatusAfterIdentify,
    /// The operator's answer to an identify prompt (the status is polled meanwhile: the crane's
    /// own confirm button may settle it).
    Operator,
    /// A status poll while the operator is asked.
    OperatorPoll,
    /// A declared state; then the status.
    Declared,
    Upload,
    Start,
    /// Following the plan: a status poll is out.
    Poll,
    /// A manual confirmation from the host is out.
    Confirm,
    /// Resetting a fault before a replan.
    ResetForReplan,
    /// A vent of the air left sealed in the trunk is out (`RunStep` within the state).
    Vent,
    /// The vent runs: the status is polled until it ends.
    Venting,
    /// A status poll while the vent runs.
    VentPoll,
    /// An abort is out; then the final status.
    Abort,
    /// The status after the abort.
    StatusAfterAbort,
    /// Over.
    Done,
}

impl Wait {
    /// Whether the request out in this wait is a `GetStatus`.
    fn asks_status(self) -> bool {
        matches!(
            self,
            Wait::Status
                | Wait::StatusAfterReset
                | Wait::StatusAfterTakeover
                | Wait::StatusAfterIdentify
                | Wait::OperatorPoll
                | Wait::Poll
                | Wait::VentPoll
                | Wait::StatusAfterAbort
        )
    }
}

/// The plan being followed.
#[derive(Debug, Clone)]
struct Following {
    plan_id: u16,
    plan: Plan,
    current: usize,
    step_start_uptime: Option<u32>,
    event_durations: Vec<Option<u32>>,
    prompted: Vec<bool>,
    polls_without_plan: u32,
    /// `StartPlan` was accepted.
    started: bool,
}

/// Runs plans on one device until it reports `target`, or fails cleanly, as a state machine
/// over a [`Session`] whose handshake is done.
#[derive(Debug)]
pub struct PlanRunner {
    graph: Graph,
    target: TrunkState,
    options: RunOptions,
    wait: Wait,
    waiting_on: Option<RequestId>,
    next_poll_ms: Option<u64>,
    following: Option<Following>,
    failed_edges: Vec<(TrunkState, TrunkState)>,
    last_surprise: Option<String>,
    next_plan_id: u16,
    /// Failure to report once the abort that follows it is done.
    abort_reason: Option<RunFailure>,
    out: Outcome,
    events: VecDeque<RunEvent>,
    cancelled: bool,
    /// The plan the operator stopped, and why, until the status after the abort tells how far
    /// it got.
    stopped: Option<(Following, String)>,
    manual_confirm_pending: bool,
    status_fresh: bool,
    probing_noted: bool,
    prompted_identify: bool,
    /// Identifications in a row that left the state unconfirmed.
    identify_requests: u32,
    /// The air left sealed in the trunk was let out before anything else (at most once a run).
    vented_first: bool,
    /// The steps that ended without evidence (`TransitionNotConfirmed`, their target a
    /// candidate) and were identified to go on: each edge at most twice in a run (a step that
    /// keeps leaving the trunk where it was is not tried forever).
    unvouched: Vec<(TrunkState, TrunkState)>,
}

impl PlanRunner {
    /// A run toward `target` on `graph`.
    pub fn new(graph: Graph, target: TrunkState, options: RunOptions) -> Self {
        Self {
            graph,
            target,
            options,
            wait: Wait::Done,
            waiting_on: None,
            next_poll_ms: None,
            following: None,
            failed_edges: Vec::new(),
            last_surprise: None,
            next_plan_id: 1,
            abort_reason: None,
            out: Outcome {
                target: Some(target),
                candidates: StateSet::ALL,
                ..Outcome::default()
            },
            events: VecDeque::new(),
            cancelled: false,
            stopped: None,
            manual_confirm_pending: false,
            status_fresh: false,
            probing_noted: false,
            prompted_identify: false,
            identify_requests: 0,
            vented_first: false,
            unvouched: Vec::new(),
        }
    }

    /// Starts the run: asks for the device's status.
    pub fn start(&mut self, session: &mut Session, now_ms: u64) {
        self.ask(session, Wait::Status, RequestBody::GetStatus, now_ms);
    }

    /// Whether the run is over.
    pub fn is_finished(&self) -> bool {
        self.wait == Wait::Done
    }

    /// The account so far (final once [`PlanRunner::is_finished`]).
    pub fn outcome(&self) -> &Outcome {
        &self.out
    }

    /// The request whose answer the runner waits for.
    pub fn waiting_on(&self) -> Option<RequestId> {
        self.waiting_on
    }

    /// The next event for the shell.
    pub fn poll_event(&mut self) -> Option<RunEvent> {
        self.events.pop_front()
    }

    /// When [`PlanRunner::handle_timeout`] should be called next.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.waiting_on.is_none() && matches!(self.wait, Wait::Poll | Wait::Operator) {
            self.next_poll_ms
        } else {
            None
        }
    }

    /// Stops the run: aborts whatever runs on the device (ahead of any queued request) and
    /// ends with the device's state after the abort.
    pub fn cancel(&mut self, session: &mut Session, now_ms: u64, why: &str) {
        if self.wait == Wait::Done || self.cancelled {
            return;
        }
        self.cancelled = true;
        let step = self.current_step();
        let message = match step {
            Some(s) => format!("{s} aborted by the operator ({why})"),
            None => format!("aborted by the operator ({why})"),
        };
        let mut failure = RunFailure::new(FailureKind::Aborted, message);
        failure.step = step;
        // Which steps the device got through is known only from its status after the abort:
        // the last poll may predate a step it finished (or the whole plan), and a step that was
        // done is not reported failed. Kept until then.
        self.stopped = self.following.take().map(|f| (f, why.to_string()));
        self.abort(session, failure, now_ms);
    }

    /// The account of a plan the operator stopped, from the device's status after the abort:
    /// steps it finished are reported done, the one it was in (if any) failed. `None` when every
    /// step was done and the device reports the target: nothing was cut short, the run reached
    /// it.
    fn account_for_stop(&mut self, run: Following, why: &str, st: &Status) -> Option<RunFailure> {
        let total = run.plan.steps().len();
        let ps = st.plan.filter(|p| p.plan_id == run.plan_id);
        // Steps finished (up to this index), and the one cut short.
        let (finished_to, cut) = match ps {
            Some(p) if p.phase == PlanPhase::Done => (total, None),
            Some(p) if p.phase == PlanPhase::Ready => (run.current, None),
            Some(p) => {
                let i = usize::from(p.step)
                    .max(run.current)
                    .min(total.saturating_sub(1));
                (i, Some(i))
            }
            None if run.started => (run.current, Some(run.current)),
            None => (run.current, None),
        };
        let durations = run.event_durations.clone();
        let from = run.current;
        self.following = Some(run);
        for (i, d) in durations.iter().enumerate().take(finished_to).skip(from) {
            self.finish_step(i, true, *d);
        }
        let step = cut.and_then(|i| {
            self.finish_step(i, false, durations.get(i).copied().flatten());
            let f = self.following.as_mut()?;
            f.current = i;
            Self::step_of(f)
        });
        self.following = None;
        if let Some(s) = step {
            return Some(
                RunFailure::new(
                    FailureKind::Aborted,
                    format!("{s} aborted by the operator ({why})"),
                )
                .at(s),
            );
        }
        let message = if finished_to == total {
            format!(
                "stopped by the operator after the last step was done ({why}); no step was cut \
                 short"
            )
        } else {
            format!("aborted by the operator ({why}) before the plan started")
        };
        if finished_to == total && st.state == self.target && st.state_confirmed {
            self.events.push_back(RunEvent::Note(message));
            return None;
        }
        Some(RunFailure::new(FailureKind::Aborted, message))
    }

    /// The operator did the manual step the device waits for (Enter on the terminal).
    pub fn confirm_manual(&mut self, session: &mut Session, now_ms: u64) {
        if self.wait == Wait::Poll && !self.manual_confirm_pending {
            if let Some(f) = &self.following {
                if f.prompted.get(f.current).copied().unwrap_or(false) {
                    self.manual_confirm_pending = true;
                    self.ask(session, Wait::Confirm, RequestBody::ConfirmManual, now_ms);
                }
            }
        }
    }

    /// The operator's answer to [`RunEvent::IdentifyPrompt`]: the trunk is in `state`
    /// (`None`: the operator cannot tell, and the run fails unidentified).
    pub fn declare(&mut self, session: &mut Session, state: Option<TrunkState>, now_ms: u64) {
        if !matches!(self.wait, Wait::Operator | Wait::OperatorPoll) {
            return;
        }
        self.next_poll_ms = None;
        match state {
            Some(state) => {
                self.out.identified = true;
                self.events.push_back(RunEvent::Note(format!(
                    "the operator identified the trunk as {state}"
                )));
                self.ask(
                    session,
                    Wait::Declared,
                    RequestBody::DeclareState(state),
                    now_ms,
                );
            }
            None => self.finish(Some(RunFailure::new(
                FailureKind::Unidentified,
                "the device's state is unconfirmed and the operator could not identify it; \
                 look at the trunk and run `host-tool declare STATE`",
            ))),
        }
    }

    /// Time has passed: poll the status when due.
    pub fn handle_timeout(&mut self, session: &mut Session, now_ms: u64) {
        // Waiting on the operator or on a vent: a status poll when due.
        let poll = match self.wait {
            Wait::Operator => Some(Wait::OperatorPoll),
            Wait::Venting => Some(Wait::VentPoll),
            _ => None,
        };
        if let Some(poll) = poll.filter(|_| self.waiting_on.is_none()) {
            if self.next_poll_ms.is_some_and(|at| now_ms >= at) {
                self.next_poll_ms = None;
                self.ask(session, poll, RequestBody::GetStatus, now_ms);
            }
            return;
        }
        if self.wait == Wait::Poll && self.waiting_on.is_none() {
            if let Some(at) = self.next_poll_ms {
                if now_ms >= at {
                    self.next_poll_ms = Some(at.max(now_ms) + self.options.poll_ms);
                    self.status_fresh = false;
                    self.waiting_on = Some(session.request(RequestBody::GetStatus, now_ms));
                }
            }
        }
    }

    /// A session event (the runner takes the replies to its own requests, device events and
    /// link loss; it ignores the rest).
    pub fn handle_session_event(&mut self, ev: &SessionEvent, session: &mut Session, now_ms: u64) {
        if self.wait == Wait::Done {
            return;
        }
        match ev {
            SessionEvent::Device(event) => self.on_device_event(event),
            SessionEvent::Reply { id, reply } if Some(*id) == self.waiting_on => {
                self.waiting_on = None;
                let reply = reply.clone();
                self.on_reply(session, reply.result, reply.body, now_ms);
            }
            SessionEvent::Failed {
                id,
                error: SessionError::Preempted { .. },
            } if Some(*id) == self.waiting_on && self.wait.asks_status() => {
                // An urgent request (an abort from another terminal through `serve`, or the
                // crane's own) went out ahead of this status request: a status changes nothing,
                // so it is asked again, and the one after tells what the abort did.
                self.waiting_on = Some(session.request(RequestBody::GetStatus, now_ms));
            }
            SessionEvent::Failed { id, error } if Some(*id) == self.waiting_on => {
                self.waiting_on = None;
                self.on_failed(error);
            }
            SessionEvent::LinkLost(error) => {
                self.waiting_on = None;
                self.on_failed(error);
            }
            _ => {}
        }
    }

    fn ask(&mut self, session: &mut Session, wait: Wait, body: RequestBody, now_ms: u64) {
        self.wait = wait;
        // Whatever comes next, the last status predates it.
        self.status_fresh = false;
        let id = if matches!(body, RequestBody::Abort) {
            session.request_first(body, now_ms)
        } else {
            session.request(body, now_ms)
        };
        self.waiting_on = Some(id);
    }

    fn current_step(&self) -> Option<StepRef> {
        Self::step_of(self.following.as_ref()?)
    }

    fn step_of(f: &Following) -> Option<StepRef> {
        let steps = f.plan.steps();
        let i = f.current.min(steps.len().checked_sub(1)?);
        let e = &steps[i].edge;
        Some(StepRef {
            index: i,
            total: steps.len(),
            kind: e.kind(),
            from: e.from(),
            to: e.to(),
        })
    }

    fn finish(&mut self, failure: Option<RunFailure>) {
        self.wait = Wait::Done;
        self.waiting_on = None;
        self.next_poll_ms = None;
        let mut failure = failure;
        if failure.is_none() && !self.out.ok() {
            let state = self
                .out
                .final_state
                .map_or("no state".to_string(), |s| s.to_string());
            failure = Some(RunFailure::new(
                FailureKind::Protocol,
                format!(
                    "the device reports {state}{} instead of the target {}",
                    if self.out.state_confirmed {
                        ""
                    } else {
                        " (unconfirmed)"
                    },
                    self.target
                ),
            ));
        }
        // A run that ended on a failed request has no fresh status: what it last heard is
        // stale, and is not reported as confirmed.
        if failure.as_ref().is_some_and(|f| {
            matches!(
                f.kind,
                FailureKind::LinkLost | FailureKind::Refused | FailureKind::Protocol
            )
        }) && !self.status_fresh
        {
            self.out.state_confirmed = false;
            self.out.candidates = self.out.candidates.union(self.stale_candidates());
        }
        if let Some(f) = failure.as_mut().filter(|_| !self.out.state_confirmed) {
            if f.kind == FailureKind::LinkLost {
                f.message = format!(
                    "{}; {} (identify it before planning on: host-tool identify)",
                    f.message,
                    text::may_be(self.out.candidates)
                );
            }
        }
        self.out.failure = failure;
        self.events.push_back(RunEvent::Finished);
    }

    /// What the trunk may be when no fresh status will say: the last report's candidates (all
    /// six states if the device never answered) and the reach of every step of a plan the device
    /// may be running (widened by the air the last report saw sealed in the trunk), from the first step not reported done to the end (a step's end may have
    /// gone unheard, and a device that lost its host aborts the step it is in).
    fn stale_candidates(&self) -> StateSet {
        let mut set = match &self.out.last_status {
            Some(_) => self.out.candidates,
            None => StateSet::ALL,
        };
        let running = self
            .following
            .as_ref()
            .filter(|f| f.started || self.wait == Wait::Start)
            .into_iter()
            .chain(self.stopped.as_ref().map(|(run, _)| run));
        // The air last reported in the trunk may act when a step lets a module go.
        let sealed_kpa = self
            .out
            .last_status
            .as_ref()
            .map_or(f32::NAN, |s| s.pressure_kpa);
        for run in running {
            for step in run.plan.steps().iter().skip(run.current) {
                let reach = protocol::transitions::reach_sealed(&step.to_protocol(), sealed_kpa);
                set = set.union(reach);
            }
        }
        set
    }

    fn on_failed(&mut self, error: &SessionError) {
        // Nothing fresh will come: the last report is stale.
        self.out.state_confirmed = false;
        self.out.candidates = self.stale_candidates();
        let context = match self.current_step() {
            Some(s) if self.following.is_some() => format!("during {s}"),
            _ => match self.wait {
                Wait::Upload => "uploading the plan".to_string(),
                Wait::Start => "starting the plan".to_string(),
                Wait::Status | Wait::StatusAfterReset => "before planning".to_string(),
                _ => "".to_string(),
            },
        };
        if self.wait == Wait::Abort || self.wait == Wait::StatusAfterAbort {
            if let Some((run, _)) = self.stopped.take() {
                self.following = Some(run);
                self.report_current_failed(None);
                self.following = None;
            }
            let mut f = self.abort_reason.take().unwrap_or_else(|| {
                RunFailure::new(FailureKind::LinkLost, "link lost during the abort")
            });
            f.message = format!("{}; the abort was not acknowledged ({error})", f.message);
            return self.finish(Some(f));
        }
        if self.following.is_some() {
            self.report_current_failed(None);
        }
        let mut failure = RunFailure::from_session(&context, error);
        failure.step = self.following.as_ref().and(self.current_step());
        self.finish(Some(failure));
    }

    fn on_device_event(&mut self, event: &Event) {
        match event {
            Event::StepDone {
                plan_id,
                step,
                duration_ms,
                ..
            } => {
                if let Some(f) = self.following.as_mut().filter(|f| f.plan_id == *plan_id) {
                    if let Some(slot) = f.event_durations.get_mut(usize::from(*step)) {
                        *slot = Some(*duration_ms);
                    }
                }
            }
            Event::FaultRaised(code) => self.events.push_back(RunEvent::Note(format!(
                "device fault {}",
                text::fault(*code)
            ))),
            _ => {}
        }
    }

    fn record_status(&mut self, status: &Status) {
        self.out.final_state = Some(status.state);
        self.out.state_confirmed = status.state_confirmed;
        self.out.candidates = if status.state_confirmed {
            StateSet::single(status.state)
        } else {
            status.candidates.with(status.state)
        };
        self.out.last_status = Some(status.clone());
        self.status_fresh = true;
    }

    fn on_reply(
        &mut self,
        session: &mut Session,
        result: protocol::ResultCode,
        body: ResponseBody,
        now_ms: u64,
    ) {
        let reply = crate::session::Reply { result, body };
        match self.wait {
            Wait::Status
            | Wait::StatusAfterReset
            | Wait::StatusAfterTakeover
            | Wait::StatusAfterIdentify
            | Wait::OperatorPoll => {
                let after = self.wait;
                match reply.status() {
                    Ok(st) => self.on_first_status(session, st, after, now_ms),
                    Err(e) => self.finish(Some(RunFailure::from_session("before planning", &e))),
                }
            }
            Wait::Vent => match reply.accepted("RunStep") {
                Ok(_) => {
                    self.wait = Wait::Venting;
                    self.next_poll_ms = Some(now_ms + self.options.poll_ms);
                }
                // Refused (the device cannot vent now): go on as before; the air stays.
                Err(_) => self.ask(
                    session,
                    Wait::StatusAfterReset,
                    RequestBody::GetStatus,
                    now_ms,
                ),
            },
            Wait::VentPoll => match reply.status() {
                Ok(st) if matches!(st.mode, Mode::Running | Mode::WaitingManual) => {
                    self.record_status(&st);
                    self.wait = Wait::Venting;
                    self.next_poll_ms = Some(now_ms + self.options.poll_ms);
                }
                Ok(st) => self.on_first_status(session, st, Wait::StatusAfterReset, now_ms),
                Err(e) => self.finish(Some(RunFailure::from_session("venting the trunk", &e))),
            },
            Wait::Identify => match reply.accepted("Identify") {
                Ok(_) => self.ask(
                    session,
                    Wait::StatusAfterIdentify,
                    RequestBody::GetStatus,
                    now_ms,
                ),
                Err(e) => self.finish(Some(RunFailure {
                    kind: FailureKind::Unidentified,
                    ..RunFailure::from_session("identifying the unconfirmed state", &e)
                })),
            },
            Wait::ResetFaults | Wait::TakeoverAbort => {
                let (name, next) = if self.wait == Wait::ResetFaults {
                    ("ResetFaults", Wait::StatusAfterReset)
                } else {
                    ("Abort", Wait::StatusAfterTakeover)
                };
                match reply.accepted(name) {
                    Ok(_) => self.ask(session, next, RequestBody::GetStatus, now_ms),
                    Err(e) => self.finish(Some(RunFailure::from_session("before planning", &e))),
                }
            }
            Wait::Declared => match reply.accepted("DeclareState") {
                Ok(_) => self.ask(
                    session,
                    Wait::StatusAfterReset,
                    RequestBody::GetStatus,
                    now_ms,
                ),
                Err(e) => self.finish(Some(RunFailure::from_session(
                    "declaring the identified state",
                    &e,
                ))),
            },
            Wait::Upload => match reply.accepted("UploadPlan") {
                Ok(_) => {
                    let plan_id = self.following.as_ref().map_or(0, |f| f.plan_id);
                    self.ask(
                        session,
                        Wait::Start,
                        RequestBody::StartPlan { plan_id },
                        now_ms,
                    )
                }
                Err(e) => {
                    // A pressure refusal names the first step over the limit; the plan may
                    // need more later: the hint names the plan's most.
                    let most = self.following.as_ref().and_then(|f| {
                        let (i, kpa) = most_pressure(&f.plan)?;
                        match &e {
                            SessionError::Rejected {
                                refusal:
                                    Some(protocol::Refusal {
                                        field: protocol::RefusedField::Pressure,
                                        value,
                                        ..
                                    }),
                                ..
                            } if kpa > *value => Some((i, kpa)),
                            _ => None,
                        }
                    });
                    // A refusal that names a step: the failure is that step's.
                    let step = match &e {
                        SessionError::Rejected {
                            refusal: Some(protocol::Refusal { step: Some(i), .. }),
                            ..
                        } => self.following.as_mut().and_then(|f| {
                            f.current = usize::from(*i);
                            Self::step_of(f)
                        }),
                        _ => None,
                    };
                    self.following = None;
                    let context = match step {
                        Some(s) => format!("uploading the plan: {s}"),
                        None => "uploading the plan".to_string(),
                    };
                    let mut failure = RunFailure::from_session(&context, &e);
                    failure.step = step;
                    if let Some((i, kpa)) = most {
                        // The hint's number is the plan's most, so one change lets it all run.
                        let asked = failure.refusal.map_or(0.0, |r| r.value);
                        failure.message = failure.message.replace(
                            &format!("`host-tool param set pressure-limit-kpa {asked}`"),
                            &format!(
                                "`host-tool param set pressure-limit-kpa {kpa}` (the whole plan \
                                 needs up to {kpa} kPa, in step {})",
                                i + 1
                            ),
                        );
                    }
                    self.finish(Some(failure))
                }
            },
            Wait::Start => match reply.accepted("StartPlan") {
                Ok(_) => {
                    self.wait = Wait::Poll;
                    self.next_poll_ms = Some(now_ms + self.options.poll_ms);
                    if let Some(f) = self.following.as_mut() {
                        f.started = true;
                        self.events.push_back(RunEvent::StepStarted {
                            index: 0,
                            total: f.plan.steps().len(),
                        });
                    }
                }
                Err(e) => {
                    self.following = None;
                    self.finish(Some(RunFailure::from_session("starting the plan", &e)))
                }
            },
            Wait::Poll => match reply.status() {
                Ok(st) => self.on_poll(session, st, now_ms),
                Err(e) => {
                    self.report_current_failed(None);
                    let step = self.current_step();
                    let mut f = RunFailure::from_session("polling the status", &e);
                    f.step = step;
                    self.finish(Some(f));
                }
            },
            Wait::Confirm => {
                self.manual_confirm_pending = false;
                self.wait = Wait::Poll;
                if let Err(e) = reply.accepted("ConfirmManual") {
                    // The button may have confirmed it meanwhile: not an error.
                    self.events
                        .push_back(RunEvent::Note(format!("confirm not taken: {e}")));
                }
            }
            Wait::ResetForReplan => match reply.accepted("ResetFaults") {
                Ok(_) => self.make_plan(session, now_ms),
                Err(e) => {
                    let error = self.last_surprise.clone().unwrap_or_default();
                    self.finish(Some(RunFailure::from_session(
                        &format!("{error}; clearing the fault to replan"),
                        &e,
                    )))
                }
            },
            Wait::Abort => {
                if let Err(e) = reply.accepted("Abort") {
                    if let Some((run, _)) = self.stopped.take() {
                        self.following = Some(run);
                        self.report_current_failed(None);
                        self.following = None;
                    }
                    let mut f = self.abort_reason.take().unwrap_or_else(|| {
                        RunFailure::new(FailureKind::Aborted, "aborted".to_string())
                    });
                    f.message = format!("{}; the abort was not acknowledged ({e})", f.message);
                    return self.finish(Some(f));
                }
                self.ask(
                    session,
                    Wait::StatusAfterAbort,
                    RequestBody::GetStatus,
                    now_ms,
                );
            }
            Wait::StatusAfterAbort => {
                let mut f = self
                    .abort_reason
                    .take()
                    .unwrap_or_else(|| RunFailure::new(FailureKind::Aborted, "aborted"));
                let stale = self.stale_candidates();
                let stopped = self.stopped.take();
                match reply.status() {
                    Ok(st) => {
                        self.record_status(&st);
                        if let Some((run, why)) = stopped {
                            match self.account_for_stop(run, &why, &st) {
                                Some(failure) => f = failure,
                                None => return self.finish(None),
                            }
                        }
                        f.message = format!("{}; {}", f.message, after_abort_text(&st));
                    }
                    Err(e) => {
                        if let Some((run, _)) = stopped {
                            self.following = Some(run);
                            self.report_current_failed(None);
                            self.following = None;
                        }
                        self.out.state_confirmed = false;
                        self.out.candidates = stale;
                        f.message = format!(
                            "{}; abort acknowledged, no status after it ({e})",
                            f.message
                        );
                    }
                }
                self.finish(Some(f));
            }
            Wait::Operator | Wait::Venting | Wait::Done => {}
        }
    }

    fn on_first_status(&mut self, session: &mut Session, st: Status, after: Wait, now_ms: u64) {
        self.record_status(&st);
        if self.out.from.is_none() {
            self.out.from = Some(st.state);
        }
        if st.estop {
            return self.finish(Some(RunFailure::new(
                FailureKind::EStop,
                "the e-stop is latched: release it and reset faults first",
            )));
        }
        // Identification under way: the crane runs its probes (a short plan of its own) or asks
        // its operator; that is what this run asked for, not another host's plan.
        let identifying =
            matches!(after, Wait::StatusAfterIdentify | Wait::OperatorPoll) && !st.state_confirmed;
        // Air left sealed in the resting trunk (an interrupted pull compresses it: 37 kPa in the
        // swarm) may still change its state once the tendons let go — popping a folded top
        // after the state was identified. It is let out first (venting changes no state), once.
        if !self.vented_first
            && !identifying
            && st.mode == Mode::Standalone
            && st.faults == 0
            && st.pressure_kpa >= protocol::transitions::SEALED_ACTS_KPA
        {
            self.vented_first = true;
            self.events.push_back(RunEvent::Note(format!(
                "the trunk holds {:.1} kPa sealed, air that may still change its state: venting \
                 it first",
                st.pressure_kpa
            )));
            let mut primitives = heapless::Vec::new();
            let _ = primitives.push(protocol::Primitive::Vent { pressure_kpa: 0.0 });
            let step = protocol::Step {
                kind: StepKind::Pneumatic,
                from: st.state,
                to: st.state,
                primitives,
                timeout_ms: VENT_TIMEOUT_MS,
            };
            return self.ask(session, Wait::Vent, RequestBody::RunStep(step), now_ms);
        }
        if identifying && !st.estop {
            if st.mode == Mode::Running {
                if !self.probing_noted {
                    self.probing_noted = true;
                    self.events.push_back(RunEvent::Note(
                        "the crane probes its state (identification)".into(),
                    ));
                }
                self.wait = Wait::Operator;
                self.next_poll_ms = Some(now_ms + self.options.poll_ms);
                return;
            }
            if st.faults == 0 || self.prompted_identify {
                if !self.prompted_identify {
                    self.prompted_identify = true;
                    let mut candidates: Vec<TrunkState> = st.candidates.iter().collect();
                    if candidates.is_empty() {
                        candidates = TrunkState::ALL.to_vec();
                    }
                    self.events.push_back(RunEvent::IdentifyPrompt {
                        believed: st.state,
                        candidates,
                    });
                }
                self.wait = Wait::Operator;
                self.next_poll_ms = Some(now_ms + OPERATOR_POLL_MS);
                return;
            }
        }
        if matches!(st.mode, Mode::Running | Mode::WaitingManual) && !identifying {
            if self.options.take_over_running && after != Wait::StatusAfterTakeover {
                self.events.push_back(RunEvent::Note(
                    "a plan left by another host is running: aborting it first".into(),
                ));
                return self.ask(session, Wait::TakeoverAbort, RequestBody::Abort, now_ms);
            }
            return self.finish(Some(RunFailure::new(
                FailureKind::Busy,
                "the device is already running a plan (`host-tool stop` aborts it)",
            )));
        }
        if st.faults != 0 {
            if after == Wait::StatusAfterReset {
                return self.finish(Some(RunFailure::new(
                    FailureKind::Fault,
                    format!(
                        "the device has active faults: {}",
                        text::fault_list(st.faults)
                    ),
                )));
            }
            // A fault left from an earlier run whose cause is gone: clear it once.
            self.events.push_back(RunEvent::Note(format!(
                "clearing old faults: {}",
                text::fault_list(st.faults)
            )));
            return self.ask(session, Wait::ResetFaults, RequestBody::ResetFaults, now_ms);
        }
        if !st.state_confirmed {
            if self.identify_requests >= 2 {
                return self.finish(Some(RunFailure::new(
                    FailureKind::Unidentified,
                    format!(
                        "the device's state is still unconfirmed after identification (it may \
                         be {}); look at the trunk and run `host-tool declare STATE`",
                        st.candidates
                            .iter()
                            .map(|s| s.name())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )));
            }
            self.identify_requests += 1;
            // A new identification: the operator is asked again if the probes cannot decide.
            self.prompted_identify = false;
            self.probing_noted = false;
            self.events.push_back(RunEvent::Note(format!(
                "the device has not confirmed its state ({}{}): identifying it first",
                st.state,
                st.interrupted.map_or(String::new(), |t| format!(
                    ", was going {} → {}",
                    t.from, t.to
                ))
            )));
            return self.ask(session, Wait::Identify, RequestBody::Identify, now_ms);
        }
        // Confirmed: whatever identification led here worked (a later blind step may need
        // its own).
        self.identify_requests = 0;
        if matches!(after, Wait::StatusAfterIdentify | Wait::OperatorPoll) && !self.out.identified {
            self.out.identified = true;
            self.events.push_back(RunEvent::Note(format!(
                "identified: the crane's probes confirm {}",
                st.state
            )));
        }
        self.next_plan_id = st.plan.map_or(0, |p| p.plan_id).wrapping_add(1).max(1);
        if self.options.identify_only {
            // The "target" of an identification is whatever the device now confirms.
            self.target = st.state;
            self.out.target = Some(st.state);
            return self.finish(None);
        }
        if st.state == self.target {
            return self.finish(None);
        }
        self.make_plan(session, now_ms);
    }

    fn make_plan(&mut self, session: &mut Session, now_ms: u64) {
        let at = self.out.final_state.unwrap_or(TrunkState::AS_MANUFACTURED);
        let plan = match self.graph.replan(at, self.target, &self.failed_edges) {
            Ok(plan) => plan,
            Err(e) => {
                let message = match &self.last_surprise {
                    Some(s) => format!("{s}; no other way on: {e}"),
                    None => e.to_string(),
                };
                return self.finish(Some(RunFailure::new(FailureKind::NoPath, message)));
            }
        };
        let plan_id = self.next_plan_id;
        self.next_plan_id = plan_id.wrapping_add(1).max(1);
        let wire = match plan.to_protocol(plan_id) {
            Ok(w) => w,
            Err(e) => {
                return self.finish(Some(RunFailure::new(FailureKind::NoPath, e.to_string())))
            }
        };
        self.events.push_back(RunEvent::Plan {
            plan: plan.clone(),
            replan: self.out.replans > 0,
        });
        let total = plan.steps().len();
        self.following = Some(Following {
            plan_id,
            plan,
            current: 0,
            step_start_uptime: None,
            event_durations: vec![None; total],
            prompted: vec![false; total],
            polls_without_plan: 0,
            started: false,
        });
        self.ask(session, Wait::Upload, RequestBody::UploadPlan(wire), now_ms);
    }

    fn abort(&mut self, session: &mut Session, failure: RunFailure, now_ms: u64) {
        self.abort_reason = Some(failure);
        self.following = None;
        self.ask(session, Wait::Abort, RequestBody::Abort, now_ms);
    }

    fn finish_step(&mut self, index: usize, ok: bool, duration_ms: Option<u32>) {
        let Some(f) = &self.following else { return };
        let Some(step) = f.plan.steps().get(index) else {
            return;
        };
        let report = StepReport {
            kind: step.edge.kind(),
            from: step.edge.from(),
            to: step.edge.to(),
            ok,
            duration_ms,
        };
        self.events.push_back(RunEvent::StepFinished {
            index,
            report: report.clone(),
        });
        self.out.steps.push(report);
    }

    fn report_current_failed(&mut self, duration_ms: Option<u32>) {
        if let Some(f) = &self.following {
            let i = f.current;
            let d = duration_ms.or(f.event_durations.get(i).copied().flatten());
            self.finish_step(i, false, d);
        }
    }

    fn on_poll(&mut self, session: &mut Session, st: Status, now_ms: u64) {
        self.record_status(&st);
        let Some(f) = self.following.as_mut() else {
            return;
        };
        let total = f.plan.steps().len();
        let plan_id = f.plan_id;
        let Some(ps) = st.plan.filter(|p| p.plan_id == plan_id) else {
            f.polls_without_plan += 1;
            if f.polls_without_plan > 50 {
                self.report_current_failed(None);
                let step = self.current_step();
                let mut fail = RunFailure::new(
                    FailureKind::Protocol,
                    format!("the device does not report plan {plan_id} after it was started"),
                );
                fail.step = step;
                self.abort(session, fail, now_ms);
            }
            return;
        };
        let index = usize::from(ps.step).min(total - 1);
        let start = *f.step_start_uptime.get_or_insert(st.uptime_ms);
        // Steps the device finished between two polls.
        while self.following.as_ref().is_some_and(|f| f.current < index) {
            let f = self.following.as_mut().expect("checked");
            let cur = f.current;
            let duration = f.event_durations[cur].or(Some(st.uptime_ms.saturating_sub(start)));
            self.finish_step(cur, true, duration);
            let f = self.following.as_mut().expect("checked");
            f.current += 1;
            f.step_start_uptime = Some(st.uptime_ms);
            self.events.push_back(RunEvent::StepStarted {
                index: f.current,
                total,
            });
        }
        let f = self.following.as_mut().expect("checked");
        let current = f.current;
        let elapsed = st
            .uptime_ms
            .saturating_sub(f.step_start_uptime.unwrap_or(st.uptime_ms));
        let edge = f.plan.steps()[current].edge;
        match ps.phase {
            PlanPhase::Ready => {
                f.polls_without_plan += 1;
                if f.polls_without_plan > 50 {
                    let step = self.current_step();
                    let mut fail = RunFailure::new(
                        FailureKind::Protocol,
                        format!("plan {plan_id} was started but the device still reports it ready"),
                    );
                    fail.step = step;
                    self.abort(session, fail, now_ms);
                }
            }
            PlanPhase::Running | PlanPhase::WaitingManual => {
                self.events.push_back(RunEvent::StepProgress {
                    index: current,
                    elapsed_ms: elapsed,
                    pressure_kpa: st.pressure_kpa,
                });
                // The host's backstop: a step running, or a manual step waiting, past its own
                // time limit and a grace is aborted.
                let limit = edge.transition.timeout_ms;
                if elapsed > limit.saturating_add(self.options.step_grace_ms) {
                    self.report_current_failed(Some(elapsed));
                    let step = self.current_step();
                    let what = if ps.phase == PlanPhase::WaitingManual {
                        "nobody did the manual step within its time limit"
                    } else {
                        "did not finish within its time limit"
                    };
                    let mut fail = RunFailure::new(
                        FailureKind::Timeout,
                        format!(
                            "{} {what} of {limit} ms (device time); the host aborted it",
                            step.map_or(String::new(), |s| s.to_string())
                        ),
                    );
                    fail.step = step;
                    return self.abort(session, fail, now_ms);
                }
                if ps.phase == PlanPhase::Running {
                    return;
                }
                // The task the device says it waits for (its status names it).
                let f = self.following.as_mut().expect("checked");
                if let (false, Some(task)) = (f.prompted[current], st.manual_task) {
                    f.prompted[current] = true;
                    self.events.push_back(RunEvent::ManualPrompt {
                        index: current,
                        task,
                    });
                }
            }
            PlanPhase::Done => {
                let d = f.event_durations.clone();
                let duration = d[current].or(Some(elapsed));
                self.finish_step(current, true, duration);
                for (i, duration) in d.iter().enumerate().skip(current + 1) {
                    self.finish_step(i, true, *duration);
                }
                self.following = None;
                if st.state == self.target && st.state_confirmed {
                    return self.finish(None);
                }
                // Done but elsewhere (should not happen): plan on from what it reports.
                if st.state_confirmed {
                    self.make_plan(session, now_ms);
                } else {
                    self.finish(None);
                }
            }
            PlanPhase::Failed(fault) => {
                let duration = f.event_durations[current].or(Some(elapsed));
                let step = self.current_step();
                self.finish_step(current, false, duration);
                let step = step.expect("following a plan");
                let message = format!(
                    "{step} failed: {} ({}); the device reports {}{}",
                    fault.description(),
                    text::fault_code(fault),
                    st.state,
                    if st.state_confirmed {
                        String::new()
                    } else {
                        " (unconfirmed)".to_string()
                    }
                );
                // A surprise is a confirmed state that is neither end of the step: the trunk
                // went somewhere else, and the way on starts there. A step that left the trunk
                // where it was (or unconfirmed) failed: replanning a detour around it would act
                // on a state nobody has confirmed.
                if fault == FaultCode::TransitionNotConfirmed
                    && st.state_confirmed
                    && st.state != step.to
                    && st.state != step.from
                {
                    self.following = None;
                    self.failed_edges.push((step.from, step.to));
                    self.out.replans += 1;
                    if self.out.replans > self.options.max_replans {
                        let mut fail = RunFailure::new(
                            FailureKind::Fault,
                            format!("{message}; gave up after {} replans", self.out.replans - 1),
                        )
                        .at(step);
                        fail.fault = Some(fault);
                        return self.finish(Some(fail));
                    }
                    self.events.push_back(RunEvent::Note(format!(
                        "{message}; replanning from {}",
                        st.state
                    )));
                    self.last_surprise = Some(message);
                    self.ask(
                        session,
                        Wait::ResetForReplan,
                        RequestBody::ResetFaults,
                        now_ms,
                    );
                    return;
                }
                // A step the device cannot vouch for (no evidence that holds without a
                // calibration: a fold by hand, a fold under the tendons) that may have done its
                // work: the state is identified (the operator is asked), and the way on starts
                // from what is identified.
                if fault == FaultCode::TransitionNotConfirmed
                    && !st.state_confirmed
                    && st.candidates.contains(step.to)
                    && self
                        .unvouched
                        .iter()
                        .filter(|e| **e == (step.from, step.to))
                        .count()
                        < 2
                {
                    self.unvouched.push((step.from, step.to));
                    self.following = None;
                    self.out.replans += 1;
                    self.events.push_back(RunEvent::Note(format!(
                        "{message}; identifying the trunk's state to go on"
                    )));
                    self.last_surprise = Some(message);
                    // A new identification: the operator is asked again.
                    self.prompted_identify = false;
                    self.probing_noted = false;
                    // Reset, then the status: unconfirmed, it is identified before planning on.
                    self.ask(session, Wait::ResetFaults, RequestBody::ResetFaults, now_ms);
                    return;
                }
                self.following = None;
                let mut fail = RunFailure::new(FailureKind::Fault, message).at(step);
                fail.fault = Some(fault);
                self.finish(Some(fail));
            }
            PlanPhase::Aborted => {
                let duration = f.event_durations[current].or(Some(elapsed));
                let step = self.current_step();
                self.finish_step(current, false, duration);
                self.following = None;
                let step = step.expect("following a plan");
                let fail = RunFailure::new(
                    FailureKind::Aborted,
                    format!(
                        "{step} was aborted on the device (its stop button, or another host); {}",
                        after_abort_text(&st)
                    ),
                )
                .at(step);
                self.finish(Some(fail));
            }
        }
    }
}

/// What the device reports after an abort, in words: mode, state and its confidence, and the
/// pressure the trunk still holds (and how to vent it).
pub fn after_abort_text(st: &Status) -> String {
    let mut t = format!(
        "the device reports {} at {}{}",
        if st.mode == Mode::Safe {
            "its safe state".to_string()
        } else {
            format!("mode {}", text::mode(st.mode))
        },
        st.state,
        if st.state_confirmed {
            String::new()
        } else {
            " (unconfirmed: the shape is not known)".to_string()
        }
    );
    t += &format!(
        " with the inlet {}",
        if st.inlet_open { "OPEN" } else { "closed" }
    );
    if st.pressure_kpa >= 1.0 {
        t += &format!(
            "; the trunk holds {:.1} kPa (vent it with the crane's exhaust, or run a plan that \
             ends in a vent)",
            st.pressure_kpa
        );
    }
    t
}

/// The highest pressure any step of `plan` inflates toward, and the first step that does.
fn most_pressure(plan: &Plan) -> Option<(usize, f32)> {
    plan.steps()
        .iter()
        .enumerate()
        .flat_map(|(i, s)| {
            s.edge
                .transition
                .primitives
                .iter()
                .filter_map(move |p| match p {
                    protocol::Primitive::Inflate { pressure_kpa, .. } => Some((i, *pressure_kpa)),
                    _ => None,
                })
        })
        .fold(None, |best: Option<(usize, f32)>, (i, p)| match best {
            Some((_, b)) if b >= p => best,
            _ => Some((i, p)),
        })
}
