//! Running a transition plan on a device: upload, start, follow, prompt, replan.
//!
//! The device's status is the source of truth: its `plan` field (step index and phase) is polled
//! every [`Timing::poll_period`](crate::session::Timing), which also keeps the device's link
//! watchdog fed. Events (step done, manual step required, faults) are hints that refine the
//! report (exact step durations) but are never waited for: on a noisy line any frame can be lost.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::Arc;
use std::time::Instant;

use geometry::TrunkState;
use planner::graph::{kind_name, Graph, Plan};
use protocol::{Event, FaultCode, ManualTask, Mode, PlanPhase, Primitive, RequestBody, StepKind};

use crate::session::{Session, SessionError};

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

/// The account of a whole `plan` run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Outcome {
    /// The state the device reported before planning (None if it never answered).
    pub from: Option<TrunkState>,
    /// The state asked for.
    pub target: Option<TrunkState>,
    /// The state the device reported last.
    pub final_state: Option<TrunkState>,
    /// Every step started, across replans, in order.
    pub steps: Vec<StepReport>,
    /// Why the run failed (None on success).
    pub error: Option<String>,
    /// Times the plan was remade after a surprise.
    pub replans: u32,
}

impl Outcome {
    /// Success: no error and the device reports the target state.
    pub fn ok(&self) -> bool {
        self.error.is_none() && self.final_state.is_some() && self.final_state == self.target
    }
}

/// Options of a run.
#[derive(Debug, Clone)]
pub struct ExecOptions {
    /// Surprises tolerated before giving up.
    pub max_replans: u32,
    /// Set from outside (Ctrl-C) to abort the run.
    pub cancel: Arc<AtomicBool>,
    /// Device time allowed past a step's own time limit before the host aborts it (the device
    /// should fault first; this is the host's backstop).
    pub step_grace_ms: u32,
}

impl Default for ExecOptions {
    fn default() -> Self {
        Self {
            max_replans: 3,
            cancel: Arc::new(AtomicBool::new(false)),
            step_grace_ms: 5_000,
        }
    }
}

/// Where a run shows its progress (a terminal, plain lines, nothing).
pub trait Progress {
    /// A plan was made (`replan`: after a surprise).
    fn plan(&mut self, plan: &Plan, replan: bool);
    /// Step `index` of `total` started.
    fn step_started(&mut self, index: usize, total: usize, plan: &Plan);
    /// Step `index` is running: `elapsed_ms` of device time, latest pressure.
    fn step_progress(&mut self, index: usize, elapsed_ms: u32, pressure_kpa: f32);
    /// A manual step waits for a person; `enter_confirms`: Enter on stdin works too.
    fn manual_prompt(&mut self, index: usize, task: ManualTask, enter_confirms: bool);
    /// Step `index` ended.
    fn step_finished(&mut self, index: usize, report: &StepReport);
    /// Anything else worth a line.
    fn note(&mut self, message: &str);
}

/// A [`Progress`] that shows nothing.
#[cfg(test)]
pub struct Silent;

#[cfg(test)]
impl Progress for Silent {
    fn plan(&mut self, _: &Plan, _: bool) {}
    fn step_started(&mut self, _: usize, _: usize, _: &Plan) {}
    fn step_progress(&mut self, _: usize, _: u32, _: f32) {}
    fn manual_prompt(&mut self, _: usize, _: ManualTask, _: bool) {}
    fn step_finished(&mut self, _: usize, _: &StepReport) {}
    fn note(&mut self, _: &str) {}
}

/// How following one uploaded plan ended.
enum Followed {
    /// The device reports the plan done in `state`.
    Done(TrunkState),
    /// Step `index` ended in `reached`, not where it should: replan from there.
    Surprise {
        index: usize,
        reached: TrunkState,
        error: String,
    },
    /// A failure that replanning cannot fix.
    Failed(String),
}

/// Runs plans on one device until it reports `target`, or fails cleanly.
pub struct Executor<'a, T: std::io::Read + std::io::Write> {
    session: &'a mut Session<T>,
    graph: &'a Graph,
    options: ExecOptions,
    ui: &'a mut dyn Progress,
    /// Lines typed by the operator (Enter confirms a manual step), when stdin is a terminal.
    confirm: Option<Receiver<()>>,
}

impl<'a, T: std::io::Read + std::io::Write> Executor<'a, T> {
    /// An executor over a session whose handshake is done.
    pub fn new(
        session: &'a mut Session<T>,
        graph: &'a Graph,
        options: ExecOptions,
        ui: &'a mut dyn Progress,
        confirm: Option<Receiver<()>>,
    ) -> Self {
        Self {
            session,
            graph,
            options,
            ui,
            confirm,
        }
    }

    /// Plans from the device's state to `target` and runs the plan, replanning on surprises.
    /// Never returns an error: every failure is written into the [`Outcome`].
    pub fn run(&mut self, target: TrunkState) -> Outcome {
        let mut out = Outcome {
            target: Some(target),
            ..Outcome::default()
        };
        if let Err(e) = self.run_inner(target, &mut out) {
            out.error = Some(e);
        }
        if out.error.is_none() && out.final_state != Some(target) {
            out.error = Some(format!(
                "the device reports {} instead of the target {target}",
                out.final_state
                    .map_or("no state".to_string(), |s| s.to_string())
            ));
        }
        out
    }

    fn run_inner(&mut self, target: TrunkState, out: &mut Outcome) -> Result<(), String> {
        let mut status = self
            .session
            .status()
            .map_err(|e| format!("before planning: {e}"))?;
        if status.estop {
            return Err("the e-stop is latched: release it and reset faults first".into());
        }
        if matches!(status.mode, Mode::Running | Mode::WaitingManual) {
            return Err("the device is already running a plan (`host-tool stop` aborts it)".into());
        }
        if status.faults != 0 {
            // A fault left from an earlier run whose cause is gone: clear it once.
            self.ui.note(&format!(
                "clearing old faults: {}",
                fault_list(status.faults)
            ));
            let _ = self.session.command(RequestBody::ResetFaults);
            status = self
                .session
                .status()
                .map_err(|e| format!("before planning: {e}"))?;
            if status.faults != 0 {
                return Err(format!(
                    "the device has active faults: {}",
                    fault_list(status.faults)
                ));
            }
        }
        out.from = Some(status.state);
        out.final_state = Some(status.state);
        if !status.state_confirmed {
            self.ui.note(&format!(
                "warning: the device has not confirmed its state {} (it assumes it)",
                status.state
            ));
        }
        let mut at = status.state;
        let mut failed_edges = Vec::new();
        let mut plan_id = status.plan.map_or(0, |p| p.plan_id).wrapping_add(1).max(1);
        let mut last_surprise: Option<String> = None;
        while at != target {
            let plan = match self.graph.replan(at, target, &failed_edges) {
                Ok(plan) => plan,
                Err(e) => {
                    return Err(match last_surprise {
                        Some(s) => format!("{s}; no other way on: {e}"),
                        None => e.to_string(),
                    })
                }
            };
            self.ui.plan(&plan, out.replans > 0);
            let wire = plan.to_protocol(plan_id).map_err(|e| e.to_string())?;
            self.session
                .command(RequestBody::UploadPlan(wire))
                .map_err(|e| format!("uploading the plan: {e}"))?;
            self.session
                .command(RequestBody::StartPlan { plan_id })
                .map_err(|e| format!("starting the plan: {e}"))?;
            match self.follow(plan_id, &plan, out) {
                Followed::Done(state) => at = state,
                Followed::Surprise {
                    index,
                    reached,
                    error,
                } => {
                    let step = &plan.steps()[index];
                    failed_edges.push((step.edge.from(), step.edge.to()));
                    out.replans += 1;
                    if out.replans > self.options.max_replans {
                        return Err(format!(
                            "{error}; gave up after {} replans",
                            out.replans - 1
                        ));
                    }
                    self.ui.note(&format!("{error}; replanning from {reached}"));
                    self.session
                        .command(RequestBody::ResetFaults)
                        .map_err(|e| format!("{error}; clearing the fault to replan: {e}"))?;
                    at = reached;
                    last_surprise = Some(error);
                }
                Followed::Failed(error) => return Err(error),
            }
            plan_id = plan_id.wrapping_add(1).max(1);
        }
        out.final_state = Some(at);
        Ok(())
    }

    /// Polls the device while plan `plan_id` runs, until it ends.
    fn follow(&mut self, plan_id: u16, plan: &Plan, out: &mut Outcome) -> Followed {
        let steps = plan.steps();
        let total = steps.len();
        let step_name = |i: usize| {
            let s = &steps[i.min(total - 1)];
            format!(
                "step {}/{} ({} {} → {})",
                i.min(total - 1) + 1,
                total,
                kind_name(s.edge.kind()),
                s.edge.from(),
                s.edge.to()
            )
        };
        let mut current = 0usize;
        let mut step_start_uptime: Option<u32> = None;
        let mut event_durations: Vec<Option<u32>> = vec![None; total];
        let mut prompted = vec![false; total];
        let mut polls_without_plan = 0u32;
        self.ui.step_started(0, total, plan);
        let period = self.session.timing().poll_period;
        let mut next_poll = Instant::now();
        loop {
            next_poll += period;
            let now = Instant::now();
            if next_poll > now {
                std::thread::sleep(next_poll - now);
            } else {
                next_poll = now;
            }
            if self.options.cancel.load(Ordering::SeqCst) {
                let after = self.abort(out);
                self.report_failed(out, steps, current, None);
                return Followed::Failed(format!(
                    "{} aborted by the operator (Ctrl-C); {after}",
                    step_name(current)
                ));
            }
            let status = match self.session.status() {
                Ok(s) => s,
                Err(e) => {
                    self.report_failed(out, steps, current, None);
                    return Followed::Failed(link_error(&step_name(current), &e));
                }
            };
            out.final_state = Some(status.state);
            for ev in self.session.take_events() {
                match ev {
                    Event::StepDone {
                        plan_id: p,
                        step,
                        duration_ms,
                        ..
                    } if p == plan_id => {
                        if let Some(slot) = event_durations.get_mut(step as usize) {
                            *slot = Some(duration_ms);
                        }
                    }
                    Event::FaultRaised(code) => self.ui.note(&format!(
                        "device fault E-{:02}: {}",
                        code.code(),
                        code.description()
                    )),
                    _ => {}
                }
            }
            let Some(ps) = status.plan.filter(|p| p.plan_id == plan_id) else {
                polls_without_plan += 1;
                if polls_without_plan > 50 {
                    return Followed::Failed(format!(
                        "the device does not report plan {plan_id} after it was started"
                    ));
                }
                continue;
            };
            let index = (ps.step as usize).min(total - 1);
            let start = *step_start_uptime.get_or_insert(status.uptime_ms);
            // Steps the device finished between two polls.
            while current < index {
                let duration =
                    event_durations[current].or(Some(status.uptime_ms.saturating_sub(start)));
                self.finish_step(out, steps, current, true, duration);
                current += 1;
                step_start_uptime = Some(status.uptime_ms);
                self.ui.step_started(current, total, plan);
            }
            let elapsed = status
                .uptime_ms
                .saturating_sub(step_start_uptime.unwrap_or(status.uptime_ms));
            match ps.phase {
                PlanPhase::Ready => {
                    polls_without_plan += 1;
                    if polls_without_plan > 50 {
                        return Followed::Failed(format!(
                            "plan {plan_id} was started but the device still reports it ready"
                        ));
                    }
                }
                PlanPhase::Running => {
                    self.ui.step_progress(current, elapsed, status.pressure_kpa);
                    let limit = steps[current].edge.transition.timeout_ms;
                    if elapsed > limit.saturating_add(self.options.step_grace_ms) {
                        let after = self.abort(out);
                        self.report_failed(out, steps, current, Some(elapsed));
                        return Followed::Failed(format!(
                            "{} did not finish within its time limit of {} ms (device time); \
                             the host aborted it; {after}",
                            step_name(current),
                            limit
                        ));
                    }
                }
                PlanPhase::WaitingManual => {
                    self.ui.step_progress(current, elapsed, status.pressure_kpa);
                    if !prompted[current] {
                        prompted[current] = true;
                        let task = manual_task(steps[current].edge.transition.primitives);
                        self.ui.manual_prompt(current, task, self.confirm.is_some());
                    }
                    let entered = self
                        .confirm
                        .as_ref()
                        .is_some_and(|rx| rx.try_iter().count() > 0);
                    if entered {
                        if let Err(e) = self.session.command(RequestBody::ConfirmManual) {
                            // The button may have confirmed it meanwhile: not an error.
                            self.ui.note(&format!("confirm not taken: {e}"));
                        }
                    }
                }
                PlanPhase::Done => {
                    let duration = event_durations[current].or(Some(elapsed));
                    self.finish_step(out, steps, current, true, duration);
                    for (i, duration) in event_durations.iter().enumerate().skip(current + 1) {
                        self.finish_step(out, steps, i, true, *duration);
                    }
                    return Followed::Done(status.state);
                }
                PlanPhase::Failed(fault) => {
                    let duration = event_durations[current].or(Some(elapsed));
                    self.finish_step(out, steps, current, false, duration);
                    let expected = steps[current].edge.to();
                    let error = format!(
                        "{} failed: {} (E-{:02}); the device reports {}",
                        step_name(current),
                        fault.description(),
                        fault.code(),
                        status.state
                    );
                    // A surprise is a confirmed state that is neither end of the step: the
                    // trunk went somewhere else, and the way on starts there. A step that left
                    // the trunk where it was (or unconfirmed) failed: replanning a detour
                    // around it would act on a state nobody has confirmed.
                    if fault == FaultCode::TransitionNotConfirmed
                        && status.state_confirmed
                        && status.state != expected
                        && status.state != steps[current].edge.from()
                    {
                        return Followed::Surprise {
                            index: current,
                            reached: status.state,
                            error,
                        };
                    }
                    return Followed::Failed(error);
                }
                PlanPhase::Aborted => {
                    let duration = event_durations[current].or(Some(elapsed));
                    self.finish_step(out, steps, current, false, duration);
                    return Followed::Failed(format!(
                        "{} was aborted on the device (its stop button, or another host); \
                         the device reports {}",
                        step_name(current),
                        status.state
                    ));
                }
            }
        }
    }

    /// Sends `Abort` and says what the device reports afterwards.
    fn abort(&mut self, out: &mut Outcome) -> String {
        if let Err(e) = self.session.command(RequestBody::Abort) {
            return format!("the abort was not acknowledged ({e})");
        }
        match self.session.status() {
            Ok(st) => {
                out.final_state = Some(st.state);
                format!(
                    "the device reports {} at {} with the inlet {}",
                    if st.mode == Mode::Safe {
                        "its safe state"
                    } else {
                        "mode other than safe"
                    },
                    st.state,
                    if st.inlet_open { "OPEN" } else { "closed" }
                )
            }
            Err(e) => format!("abort acknowledged; no status after it ({e})"),
        }
    }

    fn finish_step(
        &mut self,
        out: &mut Outcome,
        steps: &[planner::graph::PlannedStep],
        index: usize,
        ok: bool,
        duration_ms: Option<u32>,
    ) {
        let edge = &steps[index].edge;
        let report = StepReport {
            kind: edge.kind(),
            from: edge.from(),
            to: edge.to(),
            ok,
            duration_ms,
        };
        self.ui.step_finished(index, &report);
        out.steps.push(report);
    }

    fn report_failed(
        &mut self,
        out: &mut Outcome,
        steps: &[planner::graph::PlannedStep],
        index: usize,
        duration_ms: Option<u32>,
    ) {
        self.finish_step(out, steps, index, false, duration_ms);
    }
}

/// The manual task of a step's primitives (the catalogue has exactly one per manual step).
fn manual_task(primitives: &[Primitive]) -> ManualTask {
    primitives
        .iter()
        .find_map(|p| match p {
            Primitive::Manual(task) => Some(*task),
            _ => None,
        })
        .unwrap_or(ManualTask::PackBottomModule)
}

fn link_error(step: &str, e: &SessionError) -> String {
    match e {
        SessionError::Timeout { .. } => format!(
            "link lost during {step}: {e}; the device aborts to its safe state by itself \
             when the host falls silent"
        ),
        _ => format!("during {step}: {e}"),
    }
}

/// The active faults of a status bit set, as `E-xx description` text.
pub fn fault_list(bits: u16) -> String {
    let names: Vec<String> = FaultCode::ALL
        .iter()
        .filter(|f| bits & f.bit() != 0)
        .map(|f| format!("E-{:02} {}", f.code(), f.description()))
        .collect();
    if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::session::Timing;
    use crate::session_fake::{FakeDevice, StepScript};

    fn s(name: &str) -> TrunkState {
        name.parse().unwrap()
    }

    fn run(dev: FakeDevice, target: &str) -> (Outcome, FakeDevice) {
        let timing = Timing {
            request_timeout: Duration::from_millis(5),
            attempts: 4,
            poll_period: Duration::from_millis(1),
        };
        let mut session = Session::new(dev, timing);
        session.handshake().unwrap();
        let graph = Graph::nominal();
        let mut ui = Silent;
        let out = Executor::new(&mut session, &graph, ExecOptions::default(), &mut ui, None)
            .run(s(target));
        let dev = std::mem::replace(session.transport_mut(), FakeDevice::new(s("F&P")));
        (out, dev)
    }

    #[test]
    fn every_pair_reaches_its_target_on_a_well_behaved_device() {
        for from in TrunkState::ALL {
            for to in TrunkState::ALL {
                let (out, dev) = run(FakeDevice::new(from), to.name());
                assert!(out.ok(), "{from} → {to}: {:?}", out.error);
                assert_eq!(dev.state, to);
                assert_eq!((out.from, out.final_state), (Some(from), Some(to)));
                let expected = Graph::nominal().plan(from, to).unwrap().steps().len();
                assert_eq!(out.steps.len(), expected, "{from} → {to}");
                assert!(out.steps.iter().all(|st| st.ok && st.duration_ms.is_some()));
            }
        }
    }

    #[test]
    fn manual_steps_wait_for_the_devices_button() {
        let mut dev = FakeDevice::new(s("F&P"));
        dev.button_after_polls = Some(4);
        let (out, dev) = run(dev, "D&P");
        assert!(out.ok(), "{:?}", out.error);
        assert_eq!(dev.confirms, 1);
        assert_eq!(out.steps.last().unwrap().kind, StepKind::Manual);
    }

    #[test]
    fn a_fault_ends_the_run_with_the_step_and_the_fault_named() {
        let mut dev = FakeDevice::new(s("F&P"));
        dev.script.insert(
            (s("F&F"), s("D&F")),
            StepScript::Fault(FaultCode::StepTimeout),
        );
        let (out, dev) = run(dev, "D&D");
        assert!(!out.ok());
        let err = out.error.unwrap();
        assert!(err.contains("step 2/3 (pneumatic F&F → D&F)"), "{err}");
        assert!(err.contains(FaultCode::StepTimeout.description()), "{err}");
        assert_eq!(out.steps.len(), 2);
        assert!(out.steps[0].ok && !out.steps[1].ok);
        assert_eq!(out.final_state, Some(s("F&F")));
        assert_eq!(dev.state, s("F&F"));
    }

    #[test]
    fn a_surprise_is_replanned_from_the_reported_state() {
        let mut dev = FakeDevice::new(s("F&P"));
        // Unpacking overshoots: the top pops out too.
        dev.script
            .insert((s("F&P"), s("F&F")), StepScript::EndIn(s("D&F")));
        let (out, dev) = run(dev, "D&D");
        assert!(out.ok(), "{:?}", out.error);
        assert_eq!(out.replans, 1);
        let path: Vec<_> = out.steps.iter().map(|st| (st.from, st.to, st.ok)).collect();
        assert_eq!(
            path,
            [(s("F&P"), s("F&F"), false), (s("D&F"), s("D&D"), true)]
        );
        assert_eq!(dev.state, s("D&D"));
    }

    #[test]
    fn a_surprise_with_no_way_on_fails_naming_the_step() {
        let mut dev = FakeDevice::new(s("F&F"));
        // F&F → D&F keeps ending in F&F's neighbour F&P: D&F has no other way in.
        dev.script
            .insert((s("F&F"), s("D&F")), StepScript::EndIn(s("F&P")));
        let (out, _) = run(dev, "D&F");
        assert!(!out.ok());
        let err = out.error.unwrap();
        assert!(err.contains("F&F → D&F"), "{err}");
        assert!(err.contains("no other way on"), "{err}");
    }

    #[test]
    fn a_lossy_link_still_reaches_the_target() {
        let mut dev = FakeDevice::new(s("F&P"));
        dev.drop_every = Some(3);
        let (out, dev) = run(dev, "D&D");
        assert!(out.ok(), "{:?}", out.error);
        assert!(dev.executed.values().all(|&n| n == 1));
    }

    #[test]
    fn link_loss_mid_plan_fails_naming_the_step() {
        let mut dev = FakeDevice::new(s("F&P"));
        dev.polls_per_step = 10;
        dev.silent_after = Some(8); // hello, status, upload, start, then a few polls
        let (out, _) = run(dev, "F&F");
        assert!(!out.ok());
        let err = out.error.unwrap();
        assert!(
            err.starts_with("link lost during step 1/1 (pneumatic F&P → F&F)"),
            "{err}"
        );
        assert_eq!(out.steps.len(), 1);
        assert!(!out.steps[0].ok);
    }

    #[test]
    fn a_step_that_leaves_the_trunk_where_it_was_fails_without_a_detour() {
        let mut dev = FakeDevice::new(s("F&F"));
        dev.script
            .insert((s("F&F"), s("F&P")), StepScript::EndIn(s("F&F")));
        let (out, dev) = run(dev, "F&P");
        assert!(!out.ok());
        assert_eq!(out.replans, 0);
        assert_eq!(out.steps.len(), 1);
        let err = out.error.unwrap();
        assert!(
            err.starts_with("step 1/1 (tendon F&F → F&P) failed"),
            "{err}"
        );
        assert!(err.contains("the device reports F&F"), "{err}");
        assert_eq!(dev.state, s("F&F"));
    }

    #[test]
    fn already_at_the_target_does_nothing() {
        let (out, dev) = run(FakeDevice::new(s("D&F")), "D&F");
        assert!(out.ok());
        assert!(out.steps.is_empty());
        assert_eq!(dev.executed.len(), 2); // hello and one status
    }
}
