//! An in-process host for the simulator: encodes requests into the sim's link and decodes what
//! the device sends back. Tests and benchmarks drive the real controller through it exactly as
//! `host-tool` does over a serial port.

use protocol::messages::{
    DeviceMessage, Event, Plan, PlanPhase, RequestBody, ResponseBody, ResultCode, Step,
};
use protocol::{encode, FrameDecoder, Request, MAX_FRAME_LEN};

use crate::Sim;

/// While a plan runs, the host asks for the status this often, virtual ms.
pub const STATUS_POLL_MS: u64 = 1_000;
/// A request without a response is sent again after this long, virtual ms.
pub const RETRY_MS: u64 = 300;
/// How often the host sends a heartbeat while waiting, virtual ms.
pub const HOST_HEARTBEAT_MS: u64 = protocol::HOST_HEARTBEAT_PERIOD_MS as u64;

/// Why a host exchange failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HostError {
    /// No response within the time limit.
    #[error("no response to request {seq} within {waited_ms} ms")]
    NoResponse {
        /// The request.
        seq: u16,
        /// How long it waited.
        waited_ms: u64,
    },
    /// The device refused.
    #[error("request {seq} refused: {result:?}")]
    Refused {
        /// The request.
        seq: u16,
        /// Its result.
        result: ResultCode,
    },
    /// A message could not be encoded.
    #[error("could not encode a request")]
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

/// The host side of the link.
#[derive(Debug, Default)]
pub struct SimHost {
    seq: u16,
    /// The session the last successful handshake opened (0: none yet).
    pub session: u32,
    decoder: FrameDecoder,
    /// Every message received, in order.
    pub received: Vec<DeviceMessage>,
    last_sent_ms: u64,
}

impl SimHost {
    /// A host that has sent nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sends a request; returns its sequence number.
    pub fn send(&mut self, sim: &mut Sim, body: RequestBody) -> Result<u16, HostError> {
        self.seq = self.seq.wrapping_add(1);
        let req = Request {
            seq: self.seq,
            session: self.session,
            body,
        };
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(&req, &mut buf).map_err(|_| HostError::Encode)?;
        sim.write_host_bytes(&buf[..n]);
        self.last_sent_ms = sim.now_ms();
        Ok(self.seq)
    }

    /// Decodes whatever the device has sent; returns the new messages.
    pub fn poll(&mut self, sim: &mut Sim) -> Vec<DeviceMessage> {
        if !sim.has_device_bytes() {
            return Vec::new();
        }
        let bytes = sim.read_device_bytes();
        let new: Vec<DeviceMessage> = self
            .decoder
            .feed::<DeviceMessage>(&bytes)
            .filter_map(Result::ok)
            .collect();
        self.received.extend(new.iter().cloned());
        new
    }

    /// Sends `body` and runs the sim until its response arrives (up to `max_ms`), resending
    /// the same request (same `seq`: the device does not execute it twice) every
    /// [`RETRY_MS`] while no response came, as a host does on a lossy line.
    pub fn request(
        &mut self,
        sim: &mut Sim,
        body: RequestBody,
        max_ms: u64,
    ) -> Result<(ResultCode, ResponseBody), HostError> {
        self.seq = self.seq.wrapping_add(1);
        let seq = self.seq;
        let req = Request {
            seq,
            session: self.session,
            body,
        };
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(&req, &mut buf).map_err(|_| HostError::Encode)?;
        let start = sim.now_ms();
        let mut next_send = start;
        while sim.now_ms() - start < max_ms {
            if sim.now_ms() >= next_send {
                // A lone delimiter first flushes any partial frame a corrupted byte left behind.
                sim.write_host_bytes(&[0]);
                sim.write_host_bytes(&buf[..n]);
                self.last_sent_ms = sim.now_ms();
                next_send = sim.now_ms() + RETRY_MS;
            }
            sim.step();
            for m in self.poll(sim) {
                if let DeviceMessage::Response {
                    seq: s,
                    result,
                    body,
                } = m
                {
                    if s == seq {
                        return Ok((result, body));
                    }
                }
            }
        }
        Err(HostError::NoResponse {
            seq,
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
        let seq_next = self.seq.wrapping_add(1);
        match self.request(sim, body, max_ms)? {
            (ResultCode::Ok | ResultCode::InProgress, b) => Ok(b),
            (result, _) => Err(HostError::Refused {
                seq: seq_next,
                result,
            }),
        }
    }

    /// The handshake; keeps the session it opened for every later request.
    pub fn hello(&mut self, sim: &mut Sim) -> Result<ResponseBody, HostError> {
        let body = self.request_ok(sim, RequestBody::hello(), 1_000)?;
        if let ResponseBody::Hello(info) = &body {
            self.session = info.session;
        }
        Ok(body)
    }

    /// Uploads and starts a plan, then runs the sim (heartbeating) until `PlanDone` or
    /// `max_ms`. Returns the `PlanDone` event's `ok` and final state.
    pub fn run_plan(
        &mut self,
        sim: &mut Sim,
        plan_id: u16,
        steps: &[Step],
        max_ms: u64,
    ) -> Result<(bool, geometry::TrunkState), HostError> {
        let mut plan = Plan {
            plan_id,
            steps: heapless::Vec::new(),
        };
        for s in steps {
            if plan.steps.push(s.clone()).is_err() {
                return Err(HostError::Encode);
            }
        }
        self.request_ok(sim, RequestBody::UploadPlan(plan), 1_000)?;
        self.request_ok(sim, RequestBody::StartPlan { plan_id }, 1_000)?;
        let start = sim.now_ms();
        let mut next_status = start + STATUS_POLL_MS;
        let mut scanned = self.received.len();
        while sim.now_ms() - start < max_ms {
            sim.step();
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
            } else if sim.now_ms() - self.last_sent_ms >= HOST_HEARTBEAT_MS {
                self.send(sim, RequestBody::Heartbeat)?;
            }
            self.poll(sim);
            while scanned < self.received.len() {
                if let DeviceMessage::Event(Event::PlanDone {
                    plan_id: p,
                    ok,
                    state,
                }) = self.received[scanned]
                {
                    if p == plan_id {
                        return Ok((ok, state));
                    }
                }
                scanned += 1;
            }
        }
        Err(HostError::PlanTimeout {
            plan_id,
            waited_ms: max_ms,
        })
    }
}
