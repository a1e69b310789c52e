//! Aborting: the runner's own abort (a step past its time limit, a device that makes no sense)
//! and the operator's stop, accounted for from the device's status after it.

use protocol::{Mode, PlanPhase, RequestBody, Status};

use super::wait::{AbortBy, Aborting, Stopped, Wait};
use super::{step_of, FailureKind, PlanRunner, RunEvent, RunFailure};
use crate::session::{Reply, Session};
use crate::text;

impl PlanRunner {
    /// The runner aborts the plan: `failure` is reported once the abort is done.
    pub(super) fn abort(&mut self, session: &mut Session, failure: RunFailure, now_ms: u64) {
        self.abort_by(session, failure, AbortBy::Runner, now_ms);
    }

    pub(super) fn abort_by(
        &mut self,
        session: &mut Session,
        reason: RunFailure,
        by: AbortBy,
        now_ms: u64,
    ) {
        self.ask(
            session,
            Wait::Abort(Aborting { reason, by }),
            RequestBody::Abort,
            now_ms,
        );
    }

    pub(super) fn on_abort(
        &mut self,
        session: &mut Session,
        reply: Reply,
        aborting: Aborting,
        now_ms: u64,
    ) {
        match reply.accepted("Abort") {
            Ok(_) => self.ask(
                session,
                Wait::StatusAfterAbort(aborting),
                RequestBody::GetStatus,
                now_ms,
            ),
            Err(e) => {
                if let Some(stopped) = aborting.stopped() {
                    self.report_failed(&stopped.run, None);
                }
                let mut f = aborting.reason;
                f.message = format!("{}; the abort was not acknowledged ({e})", f.message);
                self.finish(Some(f))
            }
        }
    }

    pub(super) fn on_status_after_abort(&mut self, reply: Reply, aborting: Aborting) {
        let stale = self.stale_candidates(aborting.stopped().map(|s| &s.run));
        let Aborting { reason: mut f, by } = aborting;
        let stopped = match by {
            AbortBy::Operator(stopped) => stopped,
            AbortBy::Runner => None,
        };
        match reply.status() {
            Ok(st) => {
                self.record_status(&st);
                if let Some(stopped) = stopped {
                    match self.account_for_stop(stopped, &st) {
                        Some(failure) => f = failure,
                        None => return self.finish(None),
                    }
                }
                f.message = format!("{}; {}", f.message, after_abort_text(&st));
            }
            Err(e) => {
                if let Some(stopped) = stopped {
                    self.report_failed(&stopped.run, None);
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

    /// The account of a plan the operator stopped, from the device's status after the abort:
    /// steps it finished are reported done, the one it was in (if any) failed. `None` when every
    /// step was done and the device reports the target: nothing was cut short, the run reached
    /// it.
    fn account_for_stop(&mut self, stopped: Stopped, st: &Status) -> Option<RunFailure> {
        let Stopped {
            mut run,
            why,
            started,
        } = stopped;
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
            None if started => (run.current, Some(run.current)),
            None => (run.current, None),
        };
        for (i, d) in run
            .event_durations
            .iter()
            .enumerate()
            .take(finished_to)
            .skip(run.current)
        {
            self.finish_step(&run, i, true, *d);
        }
        let step = cut.and_then(|i| {
            self.finish_step(
                &run,
                i,
                false,
                run.event_durations.get(i).copied().flatten(),
            );
            run.current = i;
            step_of(&run)
        });
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
