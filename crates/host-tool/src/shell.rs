//! The terminal side of every command that runs steps on the crane: the interrupt flag
//! (SIGINT, SIGTERM, SIGHUP), the run shell (progress, the operator's Enter and answers), and
//! the deadline a command of several steps sets for them. Commands share these; none of them
//! imports another command for them.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

use geometry::TrunkState;
use host::{Io as _, RunEvent, RunShell, ShellAction};
use planner::graph::Plan;

use crate::progress::{Bars, Lines, Progress};
use crate::record::Recorder;
use crate::transport::AnyIo;

/// Sets `flag` on SIGINT, SIGTERM and SIGHUP (a closed terminal): the run aborts on the
/// device and waits for its safe state instead of dying with the crane mid-step.
pub fn interrupt_flag() -> Arc<AtomicBool> {
    // One flag for the process, set by one handler: a command of several steps (a demo, a
    // day's tracking) asks for it at each, and a Ctrl-C during any of them must be seen.
    static FLAG: std::sync::OnceLock<Arc<AtomicBool>> = std::sync::OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        // Fails only when another handler is installed already; the device's link watchdog
        // still makes the crane safe then.
        let _ = ctrlc::set_handler(move || f.store(true, Ordering::SeqCst));
        flag
    })
    .clone()
}

/// The terminal side of a run: progress, the operator's Enter for manual steps, the
/// operator's answer when the state must be identified, and the interrupt.
pub(crate) struct CliShell {
    ui: Box<dyn Progress>,
    pending: Option<ShellAction>,
    plan: Option<Plan>,
    interrupted: Arc<AtomicBool>,
    cancel_sent: bool,
    /// A person can type at a terminal (Enter confirms a manual step; a state name answers
    /// an identify prompt).
    confirm: bool,
    identify: Option<Vec<TrunkState>>,
    /// The simulated person was asked the trunk's state and answers once their hands are off
    /// it.
    sim_asked: bool,
}

impl CliShell {
    /// The terminal shell of a run: bars on a terminal, plain lines otherwise; stdin lines
    /// when stdin is a terminal; the interrupt flag.
    pub(crate) fn new(interrupted: Arc<AtomicBool>) -> Self {
        let ui: Box<dyn Progress> = if std::io::stderr().is_terminal() {
            Box::new(Bars::default())
        } else {
            Box::new(Lines)
        };
        Self {
            ui,
            pending: None,
            sim_asked: false,
            plan: None,
            interrupted,
            cancel_sent: false,
            confirm: crate::keyboard::available(),
            identify: None,
        }
    }
}

impl RunShell<Recorder<AnyIo>> for CliShell {
    fn event(&mut self, event: &RunEvent, io: &mut Recorder<AnyIo>) {
        let now = io.now_ms();
        if let Some(rec) = io.recording() {
            rec.run_event(now, event);
        }
        let io = &mut io.inner;
        match event {
            RunEvent::Plan { plan, replan } => {
                self.ui.plan(plan, *replan);
                self.plan = Some(plan.clone());
            }
            RunEvent::StepStarted { index, total } => {
                if let Some(plan) = &self.plan {
                    self.ui.step_started(*index, *total, plan);
                }
            }
            RunEvent::StepProgress {
                index,
                elapsed_ms,
                pressure_kpa,
            } => self.ui.step_progress(*index, *elapsed_ms, *pressure_kpa),
            RunEvent::ManualPrompt { index, task } => {
                self.ui.manual_prompt(*index, *task, self.confirm)
            }
            RunEvent::StepFinished { index, report } => {
                self.ui
                    .step_finished(*index, report, self.cancel_sent && !report.ok)
            }
            RunEvent::Note(m) => self.ui.note(m),
            RunEvent::IdentifyPrompt {
                believed,
                candidates,
            } => {
                let names: Vec<&str> = candidates.iter().map(|s| s.name()).collect();
                self.ui.note(&format!(
                    "the device has not confirmed its state (it reports {believed}, \
                     unconfirmed); it may be any of {}",
                    names.join(", ")
                ));
                if let AnyIo::Sim(_) = io {
                    self.identify = None;
                    self.sim_asked = true;
                } else if self.confirm {
                    self.ui.note(
                        "look at the trunk and type its state (e.g. D&F) and Enter, or an empty \
                         line if you cannot tell",
                    );
                    self.identify = Some(candidates.clone());
                } else {
                    self.pending = Some(ShellAction::Declare(None));
                }
            }
            RunEvent::Finished => {}
        }
    }

    fn poll(&mut self, io: &mut Recorder<AnyIo>) -> Option<ShellAction> {
        if self.interrupted.load(Ordering::SeqCst) && !self.cancel_sent {
            self.cancel_sent = true;
            return Some(ShellAction::Cancel(
                "interrupted: Ctrl-C, SIGTERM or SIGHUP".into(),
            ));
        }
        if !self.cancel_sent && deadline_passed(io.now_ms()) {
            self.cancel_sent = true;
            return Some(ShellAction::Cancel(TIME_LIMIT_ABORT.into()));
        }
        if let Some(a) = self.pending.take() {
            return Some(a);
        }
        if let (true, AnyIo::Sim(sim)) = (self.sim_asked, &io.inner) {
            // The simulated person at the crane looks at the simulated trunk, once their
            // hands are off it.
            let truth = sim.sim.person_names()?;
            self.sim_asked = false;
            self.ui.note(&format!(
                "simulated operator: the trunk is {}",
                truth.map_or("between states", |s| s.name())
            ));
            return Some(ShellAction::Declare(truth));
        }
        let line = crate::keyboard::try_line()?;
        match self.identify.take() {
            Some(candidates) => {
                let answer = line.trim();
                if answer.is_empty() {
                    return Some(ShellAction::Declare(None));
                }
                match answer.parse::<TrunkState>() {
                    Ok(s) if candidates.contains(&s) => Some(ShellAction::Declare(Some(s))),
                    _ => {
                        self.ui.note(&format!(
                            "'{answer}' is not one of the candidates; type one of them, or an \
                             empty line"
                        ));
                        self.identify = Some(candidates);
                        None
                    }
                }
            }
            None => Some(ShellAction::ConfirmManual),
        }
    }
}

/// The link-clock time (ms) by which what runs now must have ended (a mission step's time
/// limit), `u64::MAX` for none. Process-wide like the interrupt flag: a step that runs past
/// it is aborted, the device left in its safe state (`cmd::prim::run_step`, and [`CliShell`]).
static DEADLINE_MS: AtomicU64 = AtomicU64::new(u64::MAX);

/// Sets (or with `None` clears) the time by which what runs now must end, on the link's clock.
pub fn set_deadline(at_ms: Option<u64>) {
    DEADLINE_MS.store(at_ms.unwrap_or(u64::MAX), Ordering::SeqCst);
}

/// Whether the time set by [`set_deadline`] has come at `now_ms`.
pub fn deadline_passed(now_ms: u64) -> bool {
    now_ms >= DEADLINE_MS.load(Ordering::SeqCst)
}

/// What a step aborted at its time limit reports.
pub const TIME_LIMIT_ABORT: &str =
    "its time limit ran out: the step was aborted, the device is in its safe state";
