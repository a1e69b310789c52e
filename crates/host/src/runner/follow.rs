//! Following a plan: upload, start, the status polls (the device's `plan` field is the truth),
//! manual prompts, and the surprises that replan.

use protocol::{FaultCode, PlanPhase, PlanStatus, RequestBody, Status};
use transition_graph::Plan;

use super::wait::{Following, Wait};
use super::{step_of, FailureKind, PlanRunner, RunEvent, RunFailure, StepRef};
use crate::session::{Reply, Session, SessionError};
use crate::text;

/// Polls in a row that do not show the plan moving before the host gives up on it.
const POLLS_WITHOUT_PLAN: u32 = 50;

impl PlanRunner {
    /// Plans from the last state the device reported and uploads the plan.
    pub(super) fn make_plan(&mut self, session: &mut Session, now_ms: u64) {
        let at = self
            .out
            .final_state
            .unwrap_or(geometry::TrunkState::AS_MANUFACTURED);
        let plan = match self
            .graph
            .replan(at, self.target, &self.memory.failed_edges)
        {
            Ok(plan) => plan,
            Err(e) => {
                let message = match &self.memory.last_surprise {
                    Some(s) => format!("{s}; no other way on: {e}"),
                    None => e.to_string(),
                };
                return self.finish(Some(RunFailure::new(FailureKind::NoPath, message)));
            }
        };
        let plan_id = self.memory.next_plan_id;
        self.memory.next_plan_id = plan_id.wrapping_add(1).max(1);
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
        let run = Following {
            plan_id,
            plan,
            current: 0,
            step_start_uptime: None,
            event_durations: vec![None; total],
            prompted: vec![false; total],
            polls_without_plan: 0,
        };
        self.ask(
            session,
            Wait::Upload(run),
            RequestBody::UploadPlan(wire),
            now_ms,
        );
    }

    pub(super) fn on_uploaded(
        &mut self,
        session: &mut Session,
        reply: Reply,
        run: Following,
        now_ms: u64,
    ) {
        match reply.accepted("UploadPlan") {
            Ok(_) => {
                let plan_id = run.plan_id;
                self.ask(
                    session,
                    Wait::Start(run),
                    RequestBody::StartPlan { plan_id },
                    now_ms,
                );
            }
            Err(e) => self.finish(Some(upload_failure(run, &e))),
        }
    }

    pub(super) fn on_started(&mut self, reply: Reply, run: Following, now_ms: u64) {
        match reply.accepted("StartPlan") {
            Ok(_) => {
                self.events.push_back(RunEvent::StepStarted {
                    index: 0,
                    total: run.plan.steps().len(),
                });
                self.wait = Wait::Poll {
                    run,
                    next_poll_ms: now_ms + self.options.poll_ms,
                };
            }
            Err(e) => {
                // The refusal may answer a retransmission: a first StartPlan heard before a
                // reboot (its reply lost) started the plan, and the trunk may then be anywhere
                // the plan reaches. Nothing fresh says otherwise: the state is unconfirmed.
                self.out.state_confirmed = false;
                self.out.candidates = self.stale_candidates(Some(&run));
                self.finish(Some(RunFailure::from_session("starting the plan", &e)))
            }
        }
    }

    pub(super) fn on_confirmed_manual(&mut self, reply: Reply, run: Following, next_poll_ms: u64) {
        self.wait = Wait::Poll { run, next_poll_ms };
        if let Err(e) = reply.accepted("ConfirmManual") {
            // The button may have confirmed it meanwhile: not an error.
            self.events
                .push_back(RunEvent::Note(format!("confirm not taken: {e}")));
        }
    }

    pub(super) fn on_reset_for_replan(&mut self, session: &mut Session, reply: Reply, now_ms: u64) {
        match reply.accepted("ResetFaults") {
            Ok(_) => self.make_plan(session, now_ms),
            Err(e) => {
                let error = self.memory.last_surprise.clone().unwrap_or_default();
                self.finish(Some(RunFailure::from_session(
                    &format!("{error}; clearing the fault to replan"),
                    &e,
                )))
            }
        }
    }

    /// A status poll while following `run`.
    pub(super) fn on_poll(
        &mut self,
        session: &mut Session,
        reply: Reply,
        mut run: Following,
        next_poll_ms: u64,
        now_ms: u64,
    ) {
        let st = match reply.status() {
            Ok(st) => st,
            Err(e) => {
                self.report_failed(&run, None);
                let mut f = RunFailure::from_session("polling the status", &e);
                f.step = step_of(&run);
                return self.finish_while(Some(f), Some(&run));
            }
        };
        self.record_status(&st);
        let plan_id = run.plan_id;
        let Some(ps) = st.plan.filter(|p| p.plan_id == plan_id) else {
            run.polls_without_plan += 1;
            if run.polls_without_plan > POLLS_WITHOUT_PLAN {
                self.report_failed(&run, None);
                let mut fail = RunFailure::new(
                    FailureKind::Protocol,
                    format!("the device does not report plan {plan_id} after it was started"),
                );
                fail.step = step_of(&run);
                return self.abort(session, fail, now_ms);
            }
            self.wait = Wait::Poll { run, next_poll_ms };
            return;
        };
        self.catch_up(&mut run, &ps, &st);
        match ps.phase {
            PlanPhase::Ready => {
                run.polls_without_plan += 1;
                if run.polls_without_plan > POLLS_WITHOUT_PLAN {
                    let mut fail = RunFailure::new(
                        FailureKind::Protocol,
                        format!("plan {plan_id} was started but the device still reports it ready"),
                    );
                    fail.step = step_of(&run);
                    return self.abort(session, fail, now_ms);
                }
                self.wait = Wait::Poll { run, next_poll_ms };
            }
            PlanPhase::Running | PlanPhase::WaitingManual => {
                self.on_step_running(session, &st, ps.phase, run, next_poll_ms, now_ms)
            }
            PlanPhase::Done => self.on_plan_done(session, &st, &run, now_ms),
            PlanPhase::Failed(fault) => self.on_step_failed(session, &st, &run, fault, now_ms),
            PlanPhase::Aborted => {
                let step = self.end_current_step(&run, &st);
                let fail = RunFailure::new(
                    FailureKind::Aborted,
                    format!(
                        "{step} was aborted on the device (its stop button, or another host); {}",
                        super::after_abort_text(&st)
                    ),
                )
                .at(step);
                self.finish(Some(fail));
            }
        }
    }

    /// Reports the steps the device finished between two polls, and starts the next.
    fn catch_up(&mut self, run: &mut Following, ps: &PlanStatus, st: &Status) {
        let total = run.plan.steps().len();
        let index = usize::from(ps.step).min(total - 1);
        let start = *run.step_start_uptime.get_or_insert(st.uptime_ms);
        while run.current < index {
            let cur = run.current;
            let duration = run.event_durations[cur].or(Some(st.uptime_ms.saturating_sub(start)));
            self.finish_step(run, cur, true, duration);
            run.current += 1;
            run.step_start_uptime = Some(st.uptime_ms);
            self.events.push_back(RunEvent::StepStarted {
                index: run.current,
                total,
            });
        }
    }

    /// The step runs, or waits for a person: progress, the host's time limit, the manual
    /// prompt.
    fn on_step_running(
        &mut self,
        session: &mut Session,
        st: &Status,
        phase: PlanPhase,
        mut run: Following,
        next_poll_ms: u64,
        now_ms: u64,
    ) {
        let current = run.current;
        let elapsed = step_elapsed(&run, st);
        self.events.push_back(RunEvent::StepProgress {
            index: current,
            elapsed_ms: elapsed,
            pressure_kpa: st.pressure_kpa,
        });
        // The host's backstop: a step running, or a manual step waiting, past its own time
        // limit and a grace is aborted.
        let limit = run.plan.steps()[current].edge.transition.timeout_ms;
        if elapsed > limit.saturating_add(self.options.step_grace_ms) {
            self.report_failed(&run, Some(elapsed));
            let step = step_of(&run);
            let what = if phase == PlanPhase::WaitingManual {
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
        // The task the device says it waits for (its status names it).
        if phase == PlanPhase::WaitingManual {
            if let (false, Some(task)) = (run.prompted[current], st.manual_task) {
                run.prompted[current] = true;
                self.events.push_back(RunEvent::ManualPrompt {
                    index: current,
                    task,
                });
            }
        }
        self.wait = Wait::Poll { run, next_poll_ms };
    }

    /// The device finished the plan.
    fn on_plan_done(&mut self, session: &mut Session, st: &Status, run: &Following, now_ms: u64) {
        let current = run.current;
        let d = &run.event_durations;
        let duration = d[current].or(Some(step_elapsed(run, st)));
        self.finish_step(run, current, true, duration);
        for (i, duration) in d.iter().enumerate().skip(current + 1) {
            self.finish_step(run, i, true, *duration);
        }
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

    /// The step the plan was in ended (failed or aborted): reported failed, and named.
    fn end_current_step(&mut self, run: &Following, st: &Status) -> StepRef {
        let current = run.current;
        let duration = run.event_durations[current].or(Some(step_elapsed(run, st)));
        self.finish_step(run, current, false, duration);
        let edge = &run.plan.steps()[current].edge;
        StepRef {
            index: current,
            total: run.plan.steps().len(),
            kind: edge.kind(),
            from: edge.from(),
            to: edge.to(),
        }
    }

    /// The step failed on the device: a surprise replans, a step the device cannot vouch for
    /// is identified, anything else ends the run.
    fn on_step_failed(
        &mut self,
        session: &mut Session,
        st: &Status,
        run: &Following,
        fault: FaultCode,
        now_ms: u64,
    ) {
        let step = self.end_current_step(run, st);
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
        // A surprise is a confirmed state that is neither end of the step: the trunk went
        // somewhere else, and the way on starts there. A step that left the trunk where it was
        // (or unconfirmed) failed: replanning a detour around it would act on a state nobody
        // has confirmed.
        if fault == FaultCode::TransitionNotConfirmed
            && st.state_confirmed
            && st.state != step.to
            && st.state != step.from
        {
            return self.replan_after_surprise(session, st, step, fault, message, now_ms);
        }
        // A step the device cannot vouch for (no evidence that holds without a calibration: a
        // fold by hand, a fold under the tendons) that may have done its work: the state is
        // identified (the operator is asked), and the way on starts from what is identified.
        if fault == FaultCode::TransitionNotConfirmed
            && !st.state_confirmed
            && st.candidates.contains(step.to)
            && self
                .memory
                .unvouched
                .iter()
                .filter(|e| **e == (step.from, step.to))
                .count()
                < 2
        {
            self.memory.unvouched.push((step.from, step.to));
            self.out.replans += 1;
            self.events.push_back(RunEvent::Note(format!(
                "{message}; identifying the trunk's state to go on"
            )));
            self.memory.last_surprise = Some(message);
            // Reset, then the status: unconfirmed, it is identified (a new identification, the
            // operator asked again) before planning on.
            return self.ask(session, Wait::ResetFaults, RequestBody::ResetFaults, now_ms);
        }
        let mut fail = RunFailure::new(FailureKind::Fault, message).at(step);
        fail.fault = Some(fault);
        self.finish(Some(fail));
    }

    /// The trunk went somewhere else: the fault is cleared and the plan remade from there,
    /// around the edge that failed (a few times a run).
    fn replan_after_surprise(
        &mut self,
        session: &mut Session,
        st: &Status,
        step: StepRef,
        fault: FaultCode,
        message: String,
        now_ms: u64,
    ) {
        self.memory.failed_edges.push((step.from, step.to));
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
        self.memory.last_surprise = Some(message);
        self.ask(
            session,
            Wait::ResetForReplan,
            RequestBody::ResetFaults,
            now_ms,
        );
    }
}

/// Why the device refused `run`'s upload: the step it names, and a pressure hint that lets the
/// whole plan run.
fn upload_failure(mut run: Following, e: &SessionError) -> RunFailure {
    // A pressure refusal names the first step over the limit; the plan may need more
    // later: the hint names the plan's most.
    let most = most_pressure(&run.plan).and_then(|(i, kpa)| match e {
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
    });
    // A refusal that names a step: the failure is that step's.
    let step = match e {
        SessionError::Rejected {
            refusal: Some(protocol::Refusal { step: Some(i), .. }),
            ..
        } => {
            run.current = usize::from(*i);
            step_of(&run)
        }
        _ => None,
    };
    let context = match step {
        Some(s) => format!("uploading the plan: {s}"),
        None => "uploading the plan".to_string(),
    };
    let mut failure = RunFailure::from_session(&context, e);
    failure.step = step;
    if let Some((i, kpa)) = most {
        // The hint's number is the plan's most, so one change lets it all run.
        let asked = failure.refusal.map_or(0.0, |r| r.value);
        failure.message = failure.message.replace(
            &format!("`host-tool param set pressure-limit-kpa {asked}`"),
            &format!(
                "`host-tool param set pressure-limit-kpa {kpa}` (the whole plan needs up to \
                 {kpa} kPa, in step {})",
                i + 1
            ),
        );
    }
    failure
}

/// Device time since the step `run` is in started (as far as the polls tell).
fn step_elapsed(run: &Following, st: &Status) -> u32 {
    st.uptime_ms
        .saturating_sub(run.step_start_uptime.unwrap_or(st.uptime_ms))
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
