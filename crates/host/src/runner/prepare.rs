//! Before planning: the device's status, the air left sealed in the trunk, old faults, a plan
//! left running by another host, and the identification of an unconfirmed state.

use geometry::TrunkState;
use protocol::{Mode, RequestBody, Status, StepKind};

use super::wait::{Before, Identification, Wait};
use super::{FailureKind, PlanRunner, RunEvent, RunFailure};
use crate::session::{Reply, Session};
use crate::text;

/// While the operator is asked to identify the state, the status is read this often (the
/// crane's confirm button may settle it first).
const OPERATOR_POLL_MS: u64 = 500;
/// Time limit of the vent of air left sealed in the resting trunk (from the cap it takes a few
/// seconds).
const VENT_TIMEOUT_MS: u32 = 20_000;

impl PlanRunner {
    /// A status asked for before planning (`before`: what led to it).
    pub(super) fn on_status_before_plan(
        &mut self,
        session: &mut Session,
        st: Status,
        before: Before,
        now_ms: u64,
    ) {
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
        let identifying = before.identification().filter(|_| !st.state_confirmed);
        // Air left sealed in the resting trunk (an interrupted pull compresses it: 37 kPa in the
        // swarm) may still change its state once the tendons let go — popping a folded top
        // after the state was identified. It is let out first (venting changes no state), once;
        // also from the safe state an aborted pull leaves (the tendons holding the fold).
        if !self.memory.vented_first
            && identifying.is_none()
            && matches!(st.mode, Mode::Standalone | Mode::Safe)
            && st.faults == 0
            && st.pressure_kpa >= protocol::transitions::SEALED_ACTS_KPA
        {
            return self.vent_first(session, &st, now_ms);
        }
        if let Some(identification) = identifying {
            if self.await_identification(identification, &st, now_ms) {
                return;
            }
        } else if matches!(st.mode, Mode::Running | Mode::WaitingManual) {
            return self.on_busy(session, before, now_ms);
        }
        if st.faults != 0 {
            return self.on_old_faults(session, &st, before, now_ms);
        }
        if !st.state_confirmed {
            return self.identify(session, &st, now_ms);
        }
        self.on_confirmed_before_plan(session, &st, before, now_ms);
    }

    /// Lets out the air sealed in the resting trunk by a vent within its state.
    fn vent_first(&mut self, session: &mut Session, st: &Status, now_ms: u64) {
        self.memory.vented_first = true;
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
        self.ask(session, Wait::Vent, RequestBody::RunStep(step), now_ms);
    }

    /// An identification under way and the state still unconfirmed: waits for the crane's
    /// probes, or for the operator (asked once). `false` when neither fits: old faults are
    /// cleared first.
    fn await_identification(
        &mut self,
        mut identification: Identification,
        st: &Status,
        now_ms: u64,
    ) -> bool {
        if st.mode == Mode::Running {
            if !identification.probing_noted {
                identification.probing_noted = true;
                self.events.push_back(RunEvent::Note(
                    "the crane probes its state (identification)".into(),
                ));
            }
            self.wait = Wait::Operator {
                identification,
                next_poll_ms: now_ms + self.options.poll_ms,
            };
            return true;
        }
        if st.faults != 0 && !identification.prompted {
            return false;
        }
        if !identification.prompted {
            identification.prompted = true;
            let mut candidates: Vec<TrunkState> = st.candidates.iter().collect();
            if candidates.is_empty() {
                candidates = TrunkState::ALL.to_vec();
            }
            self.events.push_back(RunEvent::IdentifyPrompt {
                believed: st.state,
                candidates,
            });
        }
        self.wait = Wait::Operator {
            identification,
            next_poll_ms: now_ms + OPERATOR_POLL_MS,
        };
        true
    }

    /// A plan runs on the device that this run did not start.
    fn on_busy(&mut self, session: &mut Session, before: Before, now_ms: u64) {
        if self.options.take_over_running && before != Before::Takeover {
            self.events.push_back(RunEvent::Note(
                "a plan left by another host is running: aborting it first".into(),
            ));
            return self.ask(session, Wait::TakeoverAbort, RequestBody::Abort, now_ms);
        }
        self.finish(Some(RunFailure::new(
            FailureKind::Busy,
            "the device is already running a plan (`host-tool stop` aborts it)",
        )));
    }

    /// Faults are active: cleared once (a fault left from an earlier run whose cause is gone),
    /// refused after that.
    fn on_old_faults(&mut self, session: &mut Session, st: &Status, before: Before, now_ms: u64) {
        if before == Before::Reset {
            return self.finish(Some(RunFailure::new(
                FailureKind::Fault,
                format!(
                    "the device has active faults: {}",
                    text::fault_list(st.faults)
                ),
            )));
        }
        self.events.push_back(RunEvent::Note(format!(
            "clearing old faults: {}",
            text::fault_list(st.faults)
        )));
        self.ask(session, Wait::ResetFaults, RequestBody::ResetFaults, now_ms);
    }

    /// The state is unconfirmed: a new identification (at most two in a row).
    fn identify(&mut self, session: &mut Session, st: &Status, now_ms: u64) {
        if self.memory.identify_requests >= 2 {
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
        self.memory.identify_requests += 1;
        self.events.push_back(RunEvent::Note(format!(
            "the device has not confirmed its state ({}{}): identifying it first",
            st.state,
            st.interrupted.map_or(String::new(), |t| format!(
                ", was going {} → {}",
                t.from, t.to
            ))
        )));
        // A new identification: the operator is asked again if the probes cannot decide.
        self.ask(
            session,
            Wait::Identify(Identification::default()),
            RequestBody::Identify,
            now_ms,
        );
    }

    /// The state is confirmed and nothing stands in the way: done, or a plan.
    fn on_confirmed_before_plan(
        &mut self,
        session: &mut Session,
        st: &Status,
        before: Before,
        now_ms: u64,
    ) {
        // Whatever identification led here worked (a later blind step may need its own).
        self.memory.identify_requests = 0;
        if before.identification().is_some() && !self.out.identified {
            self.out.identified = true;
            self.events.push_back(RunEvent::Note(format!(
                "identified: the crane's probes confirm {}",
                st.state
            )));
        }
        self.memory.next_plan_id = st.plan.map_or(0, |p| p.plan_id).wrapping_add(1).max(1);
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

    pub(super) fn on_reset(&mut self, session: &mut Session, reply: Reply, now_ms: u64) {
        match reply.accepted("ResetFaults") {
            Ok(_) => self.ask(
                session,
                Wait::Status(Before::Reset),
                RequestBody::GetStatus,
                now_ms,
            ),
            Err(e) => self.finish(Some(RunFailure::from_session("before planning", &e))),
        }
    }

    pub(super) fn on_takeover_abort(&mut self, session: &mut Session, reply: Reply, now_ms: u64) {
        match reply.accepted("Abort") {
            Ok(_) => self.ask(
                session,
                Wait::Status(Before::Takeover),
                RequestBody::GetStatus,
                now_ms,
            ),
            Err(e) => self.finish(Some(RunFailure::from_session("before planning", &e))),
        }
    }

    pub(super) fn on_identify(
        &mut self,
        session: &mut Session,
        reply: Reply,
        identification: Identification,
        now_ms: u64,
    ) {
        match reply.accepted("Identify") {
            Ok(_) => self.ask(
                session,
                Wait::Status(Before::Identify(identification)),
                RequestBody::GetStatus,
                now_ms,
            ),
            Err(e) => self.finish(Some(RunFailure {
                kind: FailureKind::Unidentified,
                ..RunFailure::from_session("identifying the unconfirmed state", &e)
            })),
        }
    }

    pub(super) fn on_declared(&mut self, session: &mut Session, reply: Reply, now_ms: u64) {
        match reply.accepted("DeclareState") {
            Ok(_) => self.ask(
                session,
                Wait::Status(Before::Reset),
                RequestBody::GetStatus,
                now_ms,
            ),
            Err(e) => self.finish(Some(RunFailure::from_session(
                "declaring the identified state",
                &e,
            ))),
        }
    }

    pub(super) fn on_vent(&mut self, session: &mut Session, reply: Reply, now_ms: u64) {
        match reply.accepted("RunStep") {
            Ok(_) => {
                self.wait = Wait::Venting {
                    next_poll_ms: now_ms + self.options.poll_ms,
                };
            }
            // Refused (the device cannot vent now): go on as before; the air stays.
            Err(_) => self.ask(
                session,
                Wait::Status(Before::Reset),
                RequestBody::GetStatus,
                now_ms,
            ),
        }
    }

    pub(super) fn on_vent_poll(&mut self, session: &mut Session, reply: Reply, now_ms: u64) {
        match reply.status() {
            Ok(st) if matches!(st.mode, Mode::Running | Mode::WaitingManual) => {
                self.record_status(&st);
                self.wait = Wait::Venting {
                    next_poll_ms: now_ms + self.options.poll_ms,
                };
            }
            Ok(st) => self.on_status_before_plan(session, st, Before::Reset, now_ms),
            Err(e) => self.finish(Some(RunFailure::from_session("venting the trunk", &e))),
        }
    }
}
