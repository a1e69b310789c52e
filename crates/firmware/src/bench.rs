//! The controller's worst-case loop pass, as a reproducible workload.
//!
//! Used by the host bench (`examples/worst_step.rs`, also run under
//! `valgrind --tool=callgrind`) and by the Cortex-M4 harness (`qemu-m4/`), so both count the
//! very same work. Not part of the control API.
//!
//! One [`WorstCase::step`] is one pass of [`crate::hw::Shell::step`]'s controller calls with
//! everything due at once:
//!
//! - a full-size request frame arrives in one chunk: an `UploadPlan` of
//!   [`protocol::MAX_PLAN_STEPS`] steps × [`protocol::MAX_STEP_PRIMITIVES`] `Bend` primitives
//!   (the most expensive plan to validate: each bend is checked through the tendon kinematics);
//! - a new pressure sample (filter, over-pressure, a snap-detector slot, leak check) and a new
//!   joystick position in a flexible state (constant-curvature kinematics in `f32`);
//! - a heartbeat, a telemetry frame and a status response are due, and the transmit queue is
//!   drained;
//!
//! [`Scenario::Running`] instead has a host plan running (progress events, step logic) and
//! the frame rejected as `Busy` after decoding.
//!
//! [`Arrival`] says how much of the frames arrives in the measured pass: everything at once
//! (the upper bound), only the last [`crate::hw::SHELL_IO_CHUNK`] bytes of the plan frame
//! (what [`crate::hw::Shell`] actually delivers: it reads at most that much per pass, so the
//! rest arrived in earlier passes), or nothing (a quiet pass with every periodic event due).

use geometry::{BottomState, TopState, TrunkState};
use protocol::{
    ParamId, Plan, Primitive, Request, RequestBody, Step, StepKind, MAX_FRAME_LEN, MAX_PLAN_STEPS,
    MAX_STEP_PRIMITIVES, PROTOCOL_VERSION, SCHEMA_ID,
};

use crate::{BootRecord, Buttons, Controller, CraneConfig, Inputs, StoredState};

/// Which worst case.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scenario {
    /// Standalone in a flexible state: the frame is a plan that is fully validated and stored,
    /// the joystick moves.
    Idle,
    /// A host plan runs: the frame is decoded and refused (`Busy`), the plan advances.
    Running,
}

/// How the request bytes arrive in the measured pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arrival {
    /// The full-size plan frame and a status request, whole.
    Whole,
    /// The plan frame's last `SHELL_IO_CHUNK` bytes (its start was fed before the pass).
    ShellChunk,
    /// No bytes.
    Quiet,
}

/// The workload's state.
#[derive(Debug)]
pub struct WorstCase {
    /// The controller under test.
    pub ctl: Controller,
    frame: [u8; MAX_FRAME_LEN],
    frame_len: usize,
    status_frame: [u8; 64],
    status_len: usize,
    seq: u16,
    now_ms: u64,
    scenario: Scenario,
    arrival: Arrival,
    cfg: CraneConfig,
    flip: bool,
}

const FF: TrunkState = TrunkState::new(TopState::Folded, BottomState::Folded);

fn encode(seq: u16, session: u32, body: RequestBody, out: &mut [u8]) -> usize {
    protocol::encode(&Request { seq, session, body }, out).unwrap_or(0)
}

/// The largest plan: every step a chain of bends in `F&F`.
pub fn largest_plan(plan_id: u16) -> Plan {
    let mut steps = heapless::Vec::new();
    for s in 0..MAX_PLAN_STEPS {
        let mut primitives = heapless::Vec::new();
        for p in 0..MAX_STEP_PRIMITIVES {
            let _ = primitives.push(Primitive::Bend {
                direction_deg: 37.0 * (s * MAX_STEP_PRIMITIVES + p) as f32,
                angle_deg: 17.5,
            });
        }
        let _ = steps.push(Step {
            kind: StepKind::Tendon,
            from: FF,
            to: FF,
            primitives,
            timeout_ms: 3_599_999,
        });
    }
    Plan { plan_id, steps }
}

impl WorstCase {
    /// Sets up the controller (handshake done, telemetry at 50 Hz, state `F&F`).
    pub fn new(scenario: Scenario, arrival: Arrival) -> Self {
        let cfg = CraneConfig::default();
        let mut ctl = Controller::new(cfg, BootRecord::Stored(StoredState::confirmed(FF)), 0);
        let mut buf = [0u8; MAX_FRAME_LEN];
        let mut sink = [0u8; 256];
        let n = encode(
            1,
            0,
            RequestBody::Hello {
                protocol_version: PROTOCOL_VERSION,
                schema_id: SCHEMA_ID,
                takeover: false,
            },
            &mut buf,
        );
        ctl.handle_rx(&buf[..n], 0);
        let session = ctl.session();
        let n = encode(
            2,
            session,
            RequestBody::SetParam {
                id: ParamId::TelemetryHz,
                value: 50.0,
            },
            &mut buf,
        );
        ctl.handle_rx(&buf[..n], 0);
        if scenario == Scenario::Running {
            let mut primitives = heapless::Vec::new();
            let _ = primitives.push(Primitive::Hold {
                duration_ms: 3_000_000,
            });
            let step = Step {
                kind: StepKind::Pneumatic,
                from: FF,
                to: FF,
                primitives,
                timeout_ms: 3_500_000,
            };
            let n = encode(3, session, RequestBody::RunStep(step), &mut buf);
            ctl.handle_rx(&buf[..n], 0);
        }
        while ctl.poll_tx(&mut sink) > 0 {}
        let mut frame = [0u8; MAX_FRAME_LEN];
        let frame_len = encode(
            10,
            session,
            RequestBody::UploadPlan(largest_plan(10)),
            &mut frame,
        );
        let mut status_frame = [0u8; 64];
        let status_len = encode(11, session, RequestBody::GetStatus, &mut status_frame);
        Self {
            ctl,
            frame,
            frame_len,
            status_frame,
            status_len,
            seq: 100,
            now_ms: 0,
            scenario,
            arrival,
            cfg,
            flip: false,
        }
    }

    /// Length of the full-size frame.
    pub fn frame_len(&self) -> usize {
        self.frame_len
    }

    /// Prepares the next pass (outside the measured region): a fresh `seq` in the frames so the
    /// controller executes them rather than answering from its cache.
    pub fn prepare(&mut self) {
        self.seq = self.seq.wrapping_add(2);
        let plan = largest_plan(10);
        let session = self.ctl.session();
        self.frame_len = encode(
            self.seq,
            session,
            RequestBody::UploadPlan(plan),
            &mut self.frame,
        );
        self.status_len = encode(
            self.seq.wrapping_add(1),
            session,
            RequestBody::GetStatus,
            &mut self.status_frame,
        );
        match self.arrival {
            Arrival::ShellChunk => {
                let head = self.frame_len.saturating_sub(crate::hw::SHELL_IO_CHUNK);
                self.ctl.handle_rx(&self.frame[..head], self.now_ms);
            }
            Arrival::Quiet => {
                // Keeps a running host plan alive (link watch) outside the measured pass.
                let mut hb = [0u8; 16];
                let n = encode(
                    self.seq,
                    self.ctl.session(),
                    RequestBody::Heartbeat,
                    &mut hb,
                );
                self.ctl.handle_rx(&hb[..n], self.now_ms);
            }
            Arrival::Whole => {}
        }
        let mut sink = [0u8; 64];
        while self.ctl.poll_tx(&mut sink) > 0 {}
    }

    /// One worst-case pass; returns the number of bytes the controller sent.
    pub fn step(&mut self) -> usize {
        // Half a second per pass: heartbeat, telemetry and progress are all due.
        self.now_ms += u64::from(protocol::HEARTBEAT_PERIOD_MS);
        let now = self.now_ms;
        self.flip = !self.flip;
        let c = self.cfg.joystick.center_raw;
        let dx = if self.flip { 6_000 } else { 3_000 };
        let inputs = Inputs {
            pressure_raw: self
                .cfg
                .pressure_sensor
                .raw(if self.flip { 5.0 } else { 5.2 }),
            joystick_raw: [c[0] + dx, c[1] + 2_000],
            buttons: Buttons::default(),
        };
        match self.arrival {
            Arrival::Whole => {
                self.ctl.handle_rx(&self.frame[..self.frame_len], now);
                self.ctl
                    .handle_rx(&self.status_frame[..self.status_len], now);
            }
            Arrival::ShellChunk => {
                let head = self.frame_len.saturating_sub(crate::hw::SHELL_IO_CHUNK);
                self.ctl.handle_rx(&self.frame[head..self.frame_len], now);
            }
            Arrival::Quiet => {}
        }
        self.ctl.handle_inputs(&inputs, now);
        self.ctl.handle_time(now);
        let _ = self.ctl.poll_outputs();
        let _ = self.ctl.poll_display();
        let _ = self.ctl.poll_store();
        let mut sent = 0;
        let mut out = [0u8; 64];
        loop {
            let n = self.ctl.poll_tx(&mut out);
            if n == 0 {
                break;
            }
            sent += n;
        }
        sent
    }

    /// The scenario.
    pub fn scenario(&self) -> Scenario {
        self.scenario
    }

    /// The arrival pattern.
    pub fn arrival(&self) -> Arrival {
        self.arrival
    }
}
