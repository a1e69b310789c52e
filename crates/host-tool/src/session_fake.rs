//! An in-memory device double for the session and executor tests: it speaks the real protocol
//! (the protocol crate's framing and messages) and runs plans in a scripted way, one step per
//! few status polls, with lossy responses, faults, surprises and silence on demand.

use std::collections::{HashMap, VecDeque};
use std::io::{self, Read, Write};

use geometry::TrunkState;
use protocol::{
    Board, DeviceInfo, DeviceMessage, Event, FaultCode, FrameDecoder, Mode, ModuleConfig,
    PlanPhase, PlanStatus, RejectReason, Request, RequestBody, ResponseBody, ResultCode, Status,
    TrunkConfig, MAX_FRAME_LEN, PROTOCOL_VERSION, SCHEMA_ID,
};

/// How a scripted step ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepScript {
    /// Reaches its `to`.
    Ok,
    /// Faults and stays in `from`.
    Fault(FaultCode),
    /// Ends confirmed in another state (`TransitionNotConfirmed`).
    EndIn(TrunkState),
}

/// The fake device.
pub struct FakeDevice {
    decoder: FrameDecoder,
    outbox: VecDeque<u8>,
    pub state: TrunkState,
    pub mode: Mode,
    pub uptime_ms: u32,
    pub faults: u16,
    pub version: (u16, u32),
    pub script: HashMap<(TrunkState, TrunkState), StepScript>,
    pub polls_per_step: u32,
    /// Polls a manual step waits before the simulated operator presses the button (None: never).
    pub button_after_polls: Option<u32>,
    /// Drop every k-th response (1-based count of responses produced).
    pub drop_every: Option<u32>,
    /// Stop answering after this many requests.
    pub silent_after: Option<u32>,
    /// Requests executed per sequence number (a retry must not execute again).
    pub executed: HashMap<u16, u32>,
    pub requests_seen: u32,
    pub confirms: u32,
    responses_made: u32,
    cache: Option<(u16, DeviceMessage)>,
    handshake: bool,
    plan: Option<protocol::Plan>,
    plan_status: Option<PlanStatus>,
    step_polls: u32,
}

impl FakeDevice {
    pub fn new(state: TrunkState) -> Self {
        Self {
            decoder: FrameDecoder::new(),
            outbox: VecDeque::new(),
            state,
            mode: Mode::Standalone,
            uptime_ms: 1_000,
            faults: 0,
            version: (PROTOCOL_VERSION, SCHEMA_ID),
            script: HashMap::new(),
            polls_per_step: 3,
            button_after_polls: Some(5),
            drop_every: None,
            silent_after: None,
            executed: HashMap::new(),
            requests_seen: 0,
            confirms: 0,
            responses_made: 0,
            cache: None,
            handshake: false,
            plan: None,
            plan_status: None,
            step_polls: 0,
        }
    }

    /// Bytes the host will read before anything the device sends.
    pub fn inject_to_host(&mut self, bytes: &[u8]) {
        self.outbox.extend(bytes);
    }

    fn status(&self) -> Status {
        Status {
            state: self.state,
            state_confirmed: true,
            candidates: protocol::StateSet::single(self.state),
            interrupted: None,
            mode: self.mode,
            pressure_kpa: 0.0,
            servo_deg: [90.0; 3],
            inlet_open: false,
            exhaust_open: false,
            gripper_closed: false,
            estop: false,
            plan: self.plan_status,
            faults: self.faults,
            frames_rx: 0,
            frames_dropped: 0,
            uptime_ms: self.uptime_ms,
        }
    }

    fn send(&mut self, msg: &DeviceMessage) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        if let Ok(n) = protocol::encode(msg, &mut buf) {
            self.outbox.extend(&buf[..n]);
        }
    }

    /// Advances a running plan by one poll.
    fn tick(&mut self) {
        self.uptime_ms += 100;
        let (Some(plan), Some(mut ps)) = (self.plan.clone(), self.plan_status) else {
            return;
        };
        let Some(step) = plan.steps.get(ps.step as usize) else {
            return;
        };
        match ps.phase {
            PlanPhase::Running | PlanPhase::WaitingManual => {}
            _ => return,
        }
        self.step_polls += 1;
        if step.kind == protocol::StepKind::Manual {
            if ps.phase == PlanPhase::Running {
                ps.phase = PlanPhase::WaitingManual;
                self.mode = Mode::WaitingManual;
                self.step_polls = 0;
                self.plan_status = Some(ps);
                let task = protocol::ManualTask::PackBottomModule;
                self.send(&DeviceMessage::Event(Event::ManualRequired {
                    plan_id: ps.plan_id,
                    step: ps.step,
                    task,
                }));
                return;
            }
            if self
                .button_after_polls
                .is_some_and(|n| self.step_polls >= n)
            {
                self.confirms += 1;
            } else {
                return;
            }
        } else if self.step_polls < self.polls_per_step {
            return;
        }
        self.step_polls = 0;
        let outcome = self
            .script
            .get(&(step.from, step.to))
            .copied()
            .unwrap_or(StepScript::Ok);
        match outcome {
            StepScript::Ok => {
                self.state = step.to;
                self.send(&DeviceMessage::Event(Event::StepDone {
                    plan_id: ps.plan_id,
                    step: ps.step,
                    ok: true,
                    state: step.to,
                    duration_ms: 250,
                }));
                if ps.step as usize + 1 == plan.steps.len() {
                    ps.phase = PlanPhase::Done;
                    self.mode = Mode::Standalone;
                } else {
                    ps.step += 1;
                    ps.phase = PlanPhase::Running;
                    self.mode = Mode::Running;
                }
            }
            StepScript::Fault(code) => {
                ps.phase = PlanPhase::Failed(code);
                self.faults |= code.bit();
                self.mode = Mode::Safe;
                self.send(&DeviceMessage::Event(Event::FaultRaised(code)));
            }
            StepScript::EndIn(state) => {
                self.state = state;
                let code = FaultCode::TransitionNotConfirmed;
                ps.phase = PlanPhase::Failed(code);
                self.faults |= code.bit();
                self.mode = Mode::Safe;
            }
        }
        self.plan_status = Some(ps);
    }

    fn handle(&mut self, req: Request) {
        self.requests_seen += 1;
        if self.silent_after.is_some_and(|n| self.requests_seen > n) {
            return;
        }
        if let Some((seq, cached)) = &self.cache {
            if *seq == req.seq {
                let msg = cached.clone();
                self.respond(msg);
                return;
            }
        }
        *self.executed.entry(req.seq).or_default() += 1;
        let ok = |body| (ResultCode::Ok, body);
        let rej = |r| (ResultCode::Rejected(r), ResponseBody::None);
        let (result, body) = match req.body {
            RequestBody::Hello {
                protocol_version,
                schema_id,
                ..
            } => {
                let info = DeviceInfo {
                    protocol_version: self.version.0,
                    schema_id: self.version.1,
                    firmware_version: [0, 1, 0],
                    board: Board::Simulator,
                    trunk: TrunkConfig {
                        bottom: ModuleConfig {
                            n: 6,
                            beta_deg: 35.0,
                            edge_mm: 40.0,
                            layers: 3,
                        },
                        top: ModuleConfig {
                            n: 6,
                            beta_deg: 31.72,
                            edge_mm: 40.0,
                            layers: 3,
                        },
                        pressure_limit_kpa: 45.0,
                    },
                    session: 7,
                    reset_cause: protocol::ResetCause::PowerOn,
                };
                if (protocol_version, schema_id) == self.version {
                    self.handshake = true;
                    ok(ResponseBody::Hello(info))
                } else {
                    (
                        ResultCode::Rejected(RejectReason::VersionMismatch),
                        ResponseBody::Hello(info),
                    )
                }
            }
            _ if !self.handshake => rej(RejectReason::NoHandshake),
            RequestBody::GetStatus => {
                self.tick();
                ok(ResponseBody::Status(self.status()))
            }
            RequestBody::Heartbeat => {
                self.tick();
                ok(ResponseBody::None)
            }
            RequestBody::UploadPlan(plan) => {
                if self.mode == Mode::Running {
                    (ResultCode::Busy, ResponseBody::None)
                } else if plan.steps.first().map(|s| s.from) != Some(self.state) {
                    rej(RejectReason::WrongState)
                } else {
                    self.plan_status = Some(PlanStatus {
                        plan_id: plan.plan_id,
                        step: 0,
                        steps: plan.steps.len() as u8,
                        phase: PlanPhase::Ready,
                    });
                    self.plan = Some(plan);
                    ok(ResponseBody::None)
                }
            }
            RequestBody::StartPlan { plan_id } => match self.plan_status.as_mut() {
                Some(ps) if ps.plan_id == plan_id && self.faults != 0 => {
                    let _ = ps;
                    rej(RejectReason::Faulted)
                }
                Some(ps) if ps.plan_id == plan_id => {
                    ps.phase = PlanPhase::Running;
                    self.mode = Mode::Running;
                    self.step_polls = 0;
                    (ResultCode::InProgress, ResponseBody::None)
                }
                _ => rej(RejectReason::UnknownPlan),
            },
            RequestBody::Abort => {
                if let Some(ps) = self.plan_status.as_mut() {
                    ps.phase = PlanPhase::Aborted;
                }
                self.mode = Mode::Safe;
                ok(ResponseBody::None)
            }
            RequestBody::ConfirmManual => match self.plan_status.as_mut() {
                Some(ps) if ps.phase == PlanPhase::WaitingManual => {
                    ps.phase = PlanPhase::Running;
                    self.confirms += 1;
                    // Completes at the next poll.
                    self.button_after_polls = Some(0);
                    ok(ResponseBody::None)
                }
                _ => rej(RejectReason::NoManualPending),
            },
            RequestBody::ResetFaults => {
                self.faults = 0;
                self.mode = Mode::Standalone;
                ok(ResponseBody::None)
            }
            _ => rej(RejectReason::NotAllowed),
        };
        let msg = DeviceMessage::Response {
            seq: req.seq,
            result,
            body,
        };
        self.cache = Some((req.seq, msg.clone()));
        self.respond(msg);
    }

    fn respond(&mut self, msg: DeviceMessage) {
        self.responses_made += 1;
        if self
            .drop_every
            .is_some_and(|k| self.responses_made % k == 0)
        {
            return;
        }
        self.send(&msg);
    }
}

impl Write for FakeDevice {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        for &b in buf {
            if let Some(Ok(req)) = self.decoder.push::<Request>(b) {
                self.handle(req);
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Read for FakeDevice {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.outbox.is_empty() {
            return Err(io::ErrorKind::WouldBlock.into());
        }
        let n = buf.len().min(self.outbox.len());
        for (slot, b) in buf.iter_mut().zip(self.outbox.drain(..n)) {
            *slot = b;
        }
        Ok(n)
    }
}
