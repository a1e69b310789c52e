//! An operator's stop (Ctrl-C, SIGTERM, SIGHUP) is reported for what it cut short. A stop that
//! comes after the device finished the last step, before the host's next status poll saw it,
//! labels no step FAILED and reports the target reached (exit 130: the operator did stop); a
//! stop during a step names that step and reports it failed.
//!
//! First on the host engine and the simulator in-process, stopped at an exact device event
//! (deterministic), then through the real binary, interrupted by SIGINT when its `-v` trace
//! shows the device's last `StepDone`.

use std::io::{BufRead, BufReader, Read};
use std::process::{Command, Stdio};

use geometry::TrunkState;
use hil_sim::pair::{pair, SimIo};
use hil_sim::SimOptions;
use host::{FailureKind, Outcome, RunEvent, RunOptions, RunShell, ShellAction};
use planner::graph::Graph;
use protocol::Event;

fn st(s: &str) -> TrunkState {
    s.parse().expect("a state name")
}

/// When the operator stops the run.
#[derive(Debug, Clone, Copy, PartialEq)]
enum StopAt {
    /// As soon as the device's `StepDone` of the plan's last step arrives.
    LastStepDone,
    /// As soon as the host sees the last step start.
    LastStepStarted,
}

/// A shell that stops the run once, at `at`, and keeps every run event.
struct Operator {
    at: StopAt,
    steps: usize,
    stop: bool,
    stopped: bool,
    events: Vec<RunEvent>,
}

impl RunShell<SimIo> for Operator {
    fn event(&mut self, event: &RunEvent, _io: &mut SimIo) {
        match event {
            RunEvent::Plan { plan, .. } => self.steps = plan.steps().len(),
            RunEvent::StepStarted { index, total }
                if self.at == StopAt::LastStepStarted && index + 1 == *total =>
            {
                self.stop = true
            }
            _ => {}
        }
        self.events.push(event.clone());
    }

    fn device_event(&mut self, event: &Event, _io: &mut SimIo) {
        if let Event::StepDone { step, ok: true, .. } = event {
            if self.at == StopAt::LastStepDone && usize::from(*step) + 1 == self.steps {
                self.stop = true;
            }
        }
    }

    fn poll(&mut self, _io: &mut SimIo) -> Option<ShellAction> {
        if self.stop && !self.stopped {
            self.stopped = true;
            return Some(ShellAction::Cancel("Ctrl-C".into()));
        }
        None
    }
}

fn run_stopped(at: StopAt, seed: u64) -> (Outcome, Operator) {
    let mut p = pair(SimOptions {
        initial: st("F&P"),
        seed,
        ..SimOptions::default()
    });
    p.connect().expect("handshake");
    let mut op = Operator {
        at,
        steps: 0,
        stop: false,
        stopped: false,
        events: Vec::new(),
    };
    let out = p.run_plan(Graph::nominal(), st("D&F"), RunOptions::default(), &mut op);
    assert!(
        op.stopped,
        "{at:?}: the stop was never given: {:#?}",
        op.events
    );
    (out, op)
}

#[test]
fn a_stop_after_the_device_finished_the_last_step_reports_every_step_done_and_the_target_reached() {
    let (out, op) = run_stopped(StopAt::LastStepDone, 1);
    // The stop was taken while the run still followed the plan (not after it had ended).
    assert!(
        op.events.iter().any(|e| matches!(e, RunEvent::Note(n)
            if n.contains("stopped by the operator after the last step was done")
                && n.contains("no step was cut short"))),
        "{:#?}",
        op.events
    );
    assert!(out.failure.is_none(), "{:?}", out.failure);
    assert!(out.ok(), "{out:?}");
    assert_eq!(out.final_state, Some(st("D&F")));
    assert_eq!(out.steps.len(), 2, "{:?}", out.steps);
    assert!(out.steps.iter().all(|s| s.ok), "{:?}", out.steps);
    assert!(!op.events.iter().any(|e| matches!(
        e,
        RunEvent::StepFinished { report, .. } if !report.ok
    )));
}

#[test]
fn a_stop_during_the_last_step_names_it_and_reports_it_failed() {
    let (out, _) = run_stopped(StopAt::LastStepStarted, 1);
    let f = out.failure.as_ref().expect("a failure");
    assert_eq!(f.kind, FailureKind::Aborted, "{f:?}");
    assert!(
        f.message.contains("aborted by the operator (Ctrl-C)"),
        "{f:?}"
    );
    let step = f.step.expect("the step cut short");
    assert_eq!((step.index, step.total), (1, 2), "{f:?}");
    assert_eq!(
        out.steps.iter().map(|s| s.ok).collect::<Vec<_>>(),
        [true, false]
    );
}

#[test]
fn through_the_binary_ctrl_c_after_the_last_step_is_done_exits_130_with_no_step_failed() {
    // Seed 2: the host's next status poll comes 96 ms of device time after the device's last
    // StepDone (its `-v` trace shows both); paced at ×0.5 that is ~190 ms of wall time for the
    // SIGINT to land first. On a machine too loaded for that, the signal lands after the run
    // ended: that run must still label no step FAILED, and it is tried again (3 runs at most).
    for attempt in 1..=3 {
        if stop_after_the_last_step_done() {
            return;
        }
        eprintln!("run {attempt}: the SIGINT landed after the run had ended; again");
    }
    panic!("in 3 runs the SIGINT never landed between the last StepDone and the host's poll");
}

/// One run of the binary interrupted at its last `StepDone`: `true` when the stop landed in
/// the window (and was reported right), `false` when the run had already ended on its own.
fn stop_after_the_last_step_done() -> bool {
    let mut child = Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args([
            "plan",
            "--target",
            "D&F",
            "--sim",
            "--seed",
            "2",
            "--sim-speed",
            "0.5",
            "-v",
            "--json",
        ])
        .env_remove("CRANE_PORT")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("host-tool runs");
    let mut err = BufReader::new(child.stderr.take().expect("stderr"));
    let mut shown = String::new();
    let mut line = String::new();
    loop {
        line.clear();
        assert!(
            err.read_line(&mut line).expect("stderr") > 0,
            "host-tool ended before the last StepDone:\n{shown}"
        );
        shown += &line;
        if line.contains("← event StepDone{plan 1 step 2, ok,") {
            break;
        }
    }
    let pid = nix::unistd::Pid::from_raw(child.id() as i32);
    // The child may have ended already (ESRCH): that is the missed window, checked below.
    let _ = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGINT);
    err.read_to_string(&mut shown).expect("stderr");
    let out = child.wait_with_output().expect("host-tool ends");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("one JSON object ({e}):\n{shown}"));
    assert_eq!(v["ok"], true, "{v}");
    assert!(v["failure"].is_null(), "{v}");
    assert_eq!(v["final_state"], "D&F", "{v}");
    let steps = v["steps"].as_array().expect("steps");
    assert_eq!(steps.len(), 2, "{v}");
    assert!(steps.iter().all(|s| s["ok"] == true), "{v}");
    assert!(!shown.contains("FAILED"), "{shown}");
    if out.status.code() == Some(0) && !shown.contains("no step was cut short") {
        return false;
    }
    assert_eq!(out.status.code(), Some(130), "{v}\n{shown}");
    assert!(
        shown.contains("no step was cut short"),
        "the stop came after the run ended, not between the StepDone and the poll:\n{shown}"
    );
    assert!(
        shown.contains("interrupted: interrupted after the target was reached"),
        "{shown}"
    );
    true
}
