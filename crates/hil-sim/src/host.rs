//! Short request/response exchanges with a [`Sim`] the caller steps itself, for the library's
//! own tests and benchmarks. The protocol (handshake, sequence numbers, retries, heartbeats,
//! session) is the real host engine's, [`host::Host`], driven sans-IO here: this module only
//! moves its bytes to and from the simulated line and steps the simulator. Whole plans with
//! reports go through [`crate::pair`] instead.

use geometry::TrunkState;
use host::{Host, HostEvent, RequestId, SessionEvent, Timing};
use protocol::messages::{DeviceMessage, Event, Plan, PlanPhase, RequestBody, ResponseBody, Step};
use protocol::ResultCode;

use crate::Sim;

/// While a plan runs, the host asks for the status this often, virtual ms.
pub const STATUS_POLL_MS: u64 = 1_000;

/// Why an exchange failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HostError {
    /// No response within the time limit (or the engine lost the link).
    #[error("no response to request {request} within {waited_ms} ms")]
    NoResponse {
        /// The request.
        request: &'static str,
        /// How long it waited.
        waited_ms: u64,
    },
    /// The device refused.
    #[error("{request} refused: {result:?}")]
    Refused {
        /// The request.
        request: &'static str,
        /// Its result.
        result: ResultCode,
    },
    /// The plan has more steps than a plan may hold.
    #[error("the plan does not fit in one upload")]
    Encode,
    /// The plan did not finish within the time limit.
    #[error("plan {plan_id} did not finish within {waited_ms} ms")]
    PlanTimeout {
        /// Plan id.
        plan_id: u16,
        /// How long it waited.
        waited_ms: u64,
    },
}

/// The host engine, stepped together with a simulator the caller owns.
#[derive(Debug)]
pub struct SimHost {
    host: Host,
    /// Every device event received, in order.
    pub received: Vec<DeviceMessage>,
}

impl Default for SimHost {
    fn default() -> Self {
        Self::new()
    }
}

impl SimHost {
    /// A host that has sent nothing.
    pub fn new() -> Self {
        Self {
            host: Host::new(Timing::standard(), 1),
            received: Vec::new(),
        }
    }

    /// Signs requests under `key` from the next one on, counters from `first_counter`, once
    /// the handshake says the device signs (`None`: plain; see `host::Session::set_signing`).
    pub fn set_signing(&mut self, key: Option<protocol::sign::LinkKey>, first_counter: u64) {
        self.host.set_signing(key, first_counter);
    }

    /// The session the handshake opened (0: none yet).
    pub fn session(&self) -> u32 {
        self.host.session().device().map_or(0, |d| d.session)
    }

    /// One millisecond: the engine's frames onto the line, one simulator step, the device's
    /// bytes into the engine, its timers.
    fn pump(&mut self, sim: &mut Sim) -> Vec<SessionEvent> {
        while let Some(frame) = self.host.poll_transmit() {
            sim.write_host_bytes(&frame);
        }
        sim.step();
        let now = sim.now_ms();
        if sim.has_device_bytes() {
            self.host.handle_bytes(&sim.read_device_bytes(), now);
        }
        if self.host.poll_timeout().is_some_and(|t| t <= now) {
            self.host.handle_timeout(now);
        }
        let mut out = Vec::new();
        while let Some(ev) = self.host.poll_event() {
            if let HostEvent::Session(ev) = ev {
                if let SessionEvent::Device(e) = &ev {
                    self.received.push(DeviceMessage::Event(e.clone()));
                }
                out.push(ev);
            }
        }
        out
    }

    /// Sends a request without waiting for its answer (a heartbeat, say).
    pub fn send(&mut self, sim: &mut Sim, body: RequestBody) -> Result<RequestId, HostError> {
        Ok(self.host.request(body, sim.now_ms()))
    }

    /// Steps once and returns the device events that arrived.
    pub fn poll(&mut self, sim: &mut Sim) -> Vec<DeviceMessage> {
        self.pump(sim)
            .into_iter()
            .filter_map(|e| match e {
                SessionEvent::Device(ev) => Some(DeviceMessage::Event(ev)),
                _ => None,
            })
            .collect()
    }

    /// Sends `body` and runs the sim until its answer arrives (up to `max_ms`); the engine
    /// retries with the same sequence number on a lossy line.
    pub fn request(
        &mut self,
        sim: &mut Sim,
        body: RequestBody,
        max_ms: u64,
    ) -> Result<(ResultCode, ResponseBody), HostError> {
        let request = host::text::request_name(&body);
        let start = sim.now_ms();
        let id = self.host.request(body, start);
        while sim.now_ms() - start < max_ms {
            for ev in self.pump(sim) {
                match ev {
                    SessionEvent::Reply { id: got, reply } if got == id => {
                        return Ok((reply.result, reply.body))
                    }
                    SessionEvent::Failed { id: got, .. } if got == id => {
                        return Err(HostError::NoResponse {
                            request,
                            waited_ms: sim.now_ms() - start,
                        })
                    }
                    _ => {}
                }
            }
        }
        Err(HostError::NoResponse {
            request,
            waited_ms: max_ms,
        })
    }

    /// Like [`SimHost::request`], but a result other than `Ok`/`InProgress` is an error.
    pub fn request_ok(
        &mut self,
        sim: &mut Sim,
        body: RequestBody,
        max_ms: u64,
    ) -> Result<ResponseBody, HostError> {
        let request = host::text::request_name(&body);
        match self.request(sim, body, max_ms)? {
            (ResultCode::Ok | ResultCode::InProgress, b) => Ok(b),
            (result, _) => Err(HostError::Refused { request, result }),
        }
    }

    /// The handshake.
    pub fn hello(&mut self, sim: &mut Sim) -> Result<ResponseBody, HostError> {
        let start = sim.now_ms();
        self.host.connect(start);
        while sim.now_ms() - start < 2_000 {
            for ev in self.pump(sim) {
                match ev {
                    SessionEvent::Opened(info) => return Ok(ResponseBody::Hello(info)),
                    SessionEvent::HandshakeFailed(_) => {
                        return Err(HostError::Refused {
                            request: "Hello",
                            result: ResultCode::Rejected(protocol::RejectReason::VersionMismatch),
                        })
                    }
                    _ => {}
                }
            }
        }
        Err(HostError::NoResponse {
            request: "Hello",
            waited_ms: 2_000,
        })
    }

    /// Uploads and starts a plan of `steps`, then runs the sim (the engine heartbeats) until
    /// `PlanDone` or `max_ms`. Returns the plan's `ok` and final state.
    pub fn run_plan(
        &mut self,
        sim: &mut Sim,
        plan_id: u16,
        steps: &[Step],
        max_ms: u64,
    ) -> Result<(bool, TrunkState), HostError> {
        let mut plan = Plan {
            plan_id,
            steps: heapless::Vec::new(),
        };
        for s in steps {
            plan.steps.push(s.clone()).map_err(|_| HostError::Encode)?;
        }
        self.request_ok(sim, RequestBody::UploadPlan(plan), 1_000)?;
        self.request_ok(sim, RequestBody::StartPlan { plan_id }, 1_000)?;
        let start = sim.now_ms();
        let mut next_status = start + STATUS_POLL_MS;
        while sim.now_ms() - start < max_ms {
            for ev in self.pump(sim) {
                if let SessionEvent::Device(Event::PlanDone {
                    plan_id: p,
                    ok,
                    state,
                }) = ev
                {
                    if p == plan_id {
                        return Ok((ok, state));
                    }
                }
            }
            if sim.now_ms() >= next_status {
                // Events can be lost on a noisy line: the status tells the plan's phase too.
                next_status = sim.now_ms() + STATUS_POLL_MS;
                if let Ok((_, ResponseBody::Status(st))) =
                    self.request(sim, RequestBody::GetStatus, 2_000)
                {
                    if let Some(ps) = st.plan.filter(|p| p.plan_id == plan_id) {
                        match ps.phase {
                            PlanPhase::Done => return Ok((true, st.state)),
                            PlanPhase::Failed(_) | PlanPhase::Aborted => {
                                return Ok((false, st.state))
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        Err(HostError::PlanTimeout {
            plan_id,
            waited_ms: max_ms,
        })
    }
}
