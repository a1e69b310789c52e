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
//!
//! The state is data: each wait (`wait.rs`) carries what only it needs, and each reply is
//! handled by the wait it answers — before planning (`prepare.rs`: status, vent, faults,
//! take-over, identification), following a plan (`follow.rs`: upload, start, polls, replans),
//! aborting (`abort.rs`). This file holds the public calls and what every wait shares: the one
//! request out, the finish, the stale account after a lost link.

mod abort;
mod follow;
mod prepare;
mod report;
mod wait;

use std::collections::VecDeque;

use geometry::TrunkState;
use protocol::{Event, ManualTask, RequestBody, StateSet, Status};
use transition_graph::{Graph, Plan};

pub use abort::after_abort_text;
pub use report::{FailureKind, Outcome, RunFailure, StepRef, StepReport};

use crate::session::{Reply, RequestId, Session, SessionError, SessionEvent};
use crate::text;
use wait::{AbortBy, Before, Exchange, Following, Stopped, Wait};

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

/// What a run remembers across its plans.
#[derive(Debug, Default)]
struct Memory {
    /// Edges that ended in a surprise: replans go around them.
    failed_edges: Vec<(TrunkState, TrunkState)>,
    /// The last surprise, in words (for the failure that may follow it).
    last_surprise: Option<String>,
    /// The id of the next plan uploaded.
    next_plan_id: u16,
    /// Identifications in a row that left the state unconfirmed.
    identify_requests: u32,
    /// The air left sealed in the trunk was let out before anything else (at most once a run).
    vented_first: bool,
    /// The steps that ended without evidence (`TransitionNotConfirmed`, their target a
    /// candidate) and were identified to go on: each edge at most twice in a run (a step that
    /// keeps leaving the trunk where it was is not tried forever).
    unvouched: Vec<(TrunkState, TrunkState)>,
}

/// Runs plans on one device until it reports `target`, or fails cleanly, as a state machine
/// over a [`Session`] whose handshake is done.
#[derive(Debug)]
pub struct PlanRunner {
    graph: Graph,
    target: TrunkState,
    options: RunOptions,
    wait: Wait,
    exchange: Exchange,
    memory: Memory,
    out: Outcome,
    events: VecDeque<RunEvent>,
}

impl PlanRunner {
    /// A run toward `target` on `graph`.
    pub fn new(graph: Graph, target: TrunkState, options: RunOptions) -> Self {
        Self {
            graph,
            target,
            options,
            wait: Wait::Done,
            exchange: Exchange::Stale,
            memory: Memory {
                next_plan_id: 1,
                ..Memory::default()
            },
            out: Outcome {
                target: Some(target),
                candidates: StateSet::ALL,
                ..Outcome::default()
            },
            events: VecDeque::new(),
        }
    }

    /// Starts the run: asks for the device's status.
    pub fn start(&mut self, session: &mut Session, now_ms: u64) {
        self.ask(
            session,
            Wait::Status(Before::Start),
            RequestBody::GetStatus,
            now_ms,
        );
    }

    /// Whether the run is over.
    pub fn is_finished(&self) -> bool {
        matches!(self.wait, Wait::Done)
    }

    /// The account so far (final once [`PlanRunner::is_finished`]).
    pub fn outcome(&self) -> &Outcome {
        &self.out
    }

    /// The request whose answer the runner waits for.
    pub fn waiting_on(&self) -> Option<RequestId> {
        match self.exchange {
            Exchange::Out(id) => Some(id),
            Exchange::Stale | Exchange::Fresh => None,
        }
    }

    /// The next event for the shell.
    pub fn poll_event(&mut self) -> Option<RunEvent> {
        self.events.pop_front()
    }

    /// When [`PlanRunner::handle_timeout`] should be called next.
    pub fn poll_timeout(&self) -> Option<u64> {
        if self.waiting_on().is_some() {
            return None;
        }
        match self.wait {
            Wait::Poll { next_poll_ms, .. } | Wait::Operator { next_poll_ms, .. } => {
                Some(next_poll_ms)
            }
            _ => None,
        }
    }

    /// Stops the run: aborts whatever runs on the device (ahead of any queued request) and
    /// ends with the device's state after the abort.
    pub fn cancel(&mut self, session: &mut Session, now_ms: u64, why: &str) {
        match &self.wait {
            Wait::Done => return,
            Wait::Abort(a) | Wait::StatusAfterAbort(a) if matches!(a.by, AbortBy::Operator(_)) => {
                return
            }
            _ => {}
        }
        let step = self.wait.following().and_then(step_of);
        let message = match step {
            Some(s) => format!("{s} aborted by the operator ({why})"),
            None => format!("aborted by the operator ({why})"),
        };
        let mut failure = RunFailure::new(FailureKind::Aborted, message);
        failure.step = step;
        // Which steps the device got through is known only from its status after the abort:
        // the last poll may predate a step it finished (or the whole plan), and a step that was
        // done is not reported failed. Kept until then.
        let (run, started) = match std::mem::replace(&mut self.wait, Wait::Done) {
            Wait::Upload(run) | Wait::Start(run) => (Some(run), false),
            Wait::Poll { run, .. } | Wait::Confirm { run, .. } => (Some(run), true),
            _ => (None, false),
        };
        let stopped = run.map(|run| Stopped {
            run,
            why: why.to_string(),
            started,
        });
        self.abort_by(session, failure, AbortBy::Operator(stopped), now_ms);
    }

    /// The operator did the manual step the device waits for (Enter on the terminal).
    pub fn confirm_manual(&mut self, session: &mut Session, now_ms: u64) {
        match std::mem::replace(&mut self.wait, Wait::Done) {
            Wait::Poll { run, next_poll_ms }
                if run.prompted.get(run.current).copied().unwrap_or(false) =>
            {
                self.ask(
                    session,
                    Wait::Confirm { run, next_poll_ms },
                    RequestBody::ConfirmManual,
                    now_ms,
                );
            }
            wait => self.wait = wait,
        }
    }

    /// The operator's answer to [`RunEvent::IdentifyPrompt`]: the trunk is in `state`
    /// (`None`: the operator cannot tell, and the run fails unidentified).
    pub fn declare(&mut self, session: &mut Session, state: Option<TrunkState>, now_ms: u64) {
        if !matches!(
            self.wait,
            Wait::Operator { .. } | Wait::Status(Before::OperatorPoll(_))
        ) {
            return;
        }
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
        if self.waiting_on().is_some() {
            return;
        }
        let poll_ms = self.options.poll_ms;
        // Waiting on the operator or on a vent: a status poll when due (a wait of its own).
        let poll = match &mut self.wait {
            Wait::Operator {
                identification,
                next_poll_ms,
            } if now_ms >= *next_poll_ms => {
                Some(Wait::Status(Before::OperatorPoll(*identification)))
            }
            Wait::Venting { next_poll_ms } if now_ms >= *next_poll_ms => Some(Wait::VentPoll),
            // Following a plan: the poll goes out within the wait.
            Wait::Poll { next_poll_ms, .. } if now_ms >= *next_poll_ms => {
                *next_poll_ms = (*next_poll_ms).max(now_ms) + poll_ms;
                self.exchange = Exchange::Out(session.request(RequestBody::GetStatus, now_ms));
                None
            }
            _ => None,
        };
        if let Some(poll) = poll {
            self.ask(session, poll, RequestBody::GetStatus, now_ms);
        }
    }

    /// A session event (the runner takes the replies to its own requests, device events and
    /// link loss; it ignores the rest).
    pub fn handle_session_event(&mut self, ev: &SessionEvent, session: &mut Session, now_ms: u64) {
        if self.is_finished() {
            return;
        }
        let out = self.waiting_on();
        match ev {
            SessionEvent::Device(event) => self.on_device_event(event),
            SessionEvent::Reply { id, reply } if Some(*id) == out => {
                self.exchange = Exchange::Stale;
                self.on_reply(session, reply.clone(), now_ms);
            }
            SessionEvent::Failed {
                id,
                error: SessionError::Preempted { .. },
            } if Some(*id) == out && self.wait.asks_status() => {
                // An urgent request (an abort from another terminal through `serve`, or the
                // crane's own) went out ahead of this status request: a status changes nothing,
                // so it is asked again, and the one after tells what the abort did.
                self.exchange = Exchange::Out(session.request(RequestBody::GetStatus, now_ms));
            }
            SessionEvent::Failed { id, error } if Some(*id) == out => {
                self.exchange = Exchange::Stale;
                self.on_failed(error);
            }
            SessionEvent::LinkLost(error) => {
                if out.is_some() {
                    self.exchange = Exchange::Stale;
                }
                self.on_failed(error);
            }
            _ => {}
        }
    }

    /// A reply to the request out, handled by the wait it answers.
    fn on_reply(&mut self, session: &mut Session, reply: Reply, now_ms: u64) {
        match std::mem::replace(&mut self.wait, Wait::Done) {
            Wait::Status(before) => match reply.status() {
                Ok(st) => self.on_status_before_plan(session, st, before, now_ms),
                Err(e) => self.finish(Some(RunFailure::from_session("before planning", &e))),
            },
            Wait::ResetFaults => self.on_reset(session, reply, now_ms),
            Wait::TakeoverAbort => self.on_takeover_abort(session, reply, now_ms),
            Wait::Identify(identification) => {
                self.on_identify(session, reply, identification, now_ms)
            }
            Wait::Declared => self.on_declared(session, reply, now_ms),
            Wait::Vent => self.on_vent(session, reply, now_ms),
            Wait::VentPoll => self.on_vent_poll(session, reply, now_ms),
            Wait::Upload(run) => self.on_uploaded(session, reply, run, now_ms),
            Wait::Start(run) => self.on_started(reply, run, now_ms),
            Wait::Poll { run, next_poll_ms } => {
                self.on_poll(session, reply, run, next_poll_ms, now_ms)
            }
            Wait::Confirm { run, next_poll_ms } => {
                self.on_confirmed_manual(reply, run, next_poll_ms)
            }
            Wait::ResetForReplan => self.on_reset_for_replan(session, reply, now_ms),
            Wait::Abort(aborting) => self.on_abort(session, reply, aborting, now_ms),
            Wait::StatusAfterAbort(aborting) => self.on_status_after_abort(reply, aborting),
            // Nothing is out in these: no reply is theirs.
            wait @ (Wait::Operator { .. } | Wait::Venting { .. } | Wait::Done) => self.wait = wait,
        }
    }

    fn ask(&mut self, session: &mut Session, wait: Wait, body: RequestBody, now_ms: u64) {
        self.wait = wait;
        let id = if matches!(body, RequestBody::Abort) {
            session.request_first(body, now_ms)
        } else {
            session.request(body, now_ms)
        };
        // Whatever comes next, the last status predates it.
        self.exchange = Exchange::Out(id);
    }

    /// Ends the run (no plan left that the device may be running).
    fn finish(&mut self, failure: Option<RunFailure>) {
        self.finish_while(failure, None);
    }

    /// Ends the run; `running`: a started plan the device may still be running.
    fn finish_while(&mut self, failure: Option<RunFailure>, running: Option<&Following>) {
        let fresh = self.exchange == Exchange::Fresh;
        self.wait = Wait::Done;
        if let Exchange::Out(_) = self.exchange {
            self.exchange = Exchange::Stale;
        }
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
        }) && !fresh
        {
            self.out.state_confirmed = false;
            self.out.candidates = self.out.candidates.union(self.stale_candidates(running));
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
    /// six states if the device never answered) and the reach of every step of `running` (a
    /// plan the device may be running), widened by the air the last report saw sealed in the
    /// trunk, from the first step not reported done to the end (a step's end may have gone
    /// unheard, and a device that lost its host aborts the step it is in).
    fn stale_candidates(&self, running: Option<&Following>) -> StateSet {
        let mut set = match &self.out.last_status {
            Some(_) => self.out.candidates,
            None => StateSet::ALL,
        };
        // The air last reported in the trunk may act when a step lets a module go.
        let sealed_kpa = self
            .out
            .last_status
            .as_ref()
            .map_or(f32::NAN, |s| s.pressure_kpa);
        if let Some(run) = running {
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
        self.out.candidates = self.stale_candidates(self.wait.may_run());
        let step = self.wait.following().and_then(step_of);
        let context = match step {
            Some(s) => format!("during {s}"),
            None => match self.wait {
                Wait::Upload(_) => "uploading the plan".to_string(),
                Wait::Start(_) => "starting the plan".to_string(),
                Wait::Status(Before::Start | Before::Reset) => "before planning".to_string(),
                _ => "".to_string(),
            },
        };
        match std::mem::replace(&mut self.wait, Wait::Done) {
            Wait::Abort(aborting) | Wait::StatusAfterAbort(aborting) => {
                if let Some(stopped) = aborting.stopped() {
                    self.report_failed(&stopped.run, None);
                }
                let mut f = aborting.reason;
                f.message = format!("{}; the abort was not acknowledged ({error})", f.message);
                self.finish(Some(f))
            }
            wait => {
                if let Some(run) = wait.following() {
                    self.report_failed(run, None);
                }
                let mut failure = RunFailure::from_session(&context, error);
                failure.step = step;
                let started = match &wait {
                    Wait::Poll { run, .. } | Wait::Confirm { run, .. } => Some(run),
                    _ => None,
                };
                self.finish_while(Some(failure), started)
            }
        }
    }

    fn on_device_event(&mut self, event: &Event) {
        match event {
            Event::StepDone {
                plan_id,
                step,
                duration_ms,
                ..
            } => {
                if let Some(f) = self.wait.following_mut().filter(|f| f.plan_id == *plan_id) {
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
        self.exchange = Exchange::Fresh;
    }

    /// Reports step `index` of `run` ended.
    fn finish_step(&mut self, run: &Following, index: usize, ok: bool, duration_ms: Option<u32>) {
        let Some(step) = run.plan.steps().get(index) else {
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

    /// Reports the step `run` is in failed (its duration from the device's event if heard).
    fn report_failed(&mut self, run: &Following, duration_ms: Option<u32>) {
        let i = run.current;
        let d = duration_ms.or(run.event_durations.get(i).copied().flatten());
        self.finish_step(run, i, false, d);
    }
}

/// The step `f` is in.
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
