//! Unit tests of the controller, driven with explicit time and inputs against a small plant
//! model (pressure, tendons, snap-throughs at fixed thresholds). The real physics is the
//! simulator's; this plant only produces the signatures `docs/firmware.md` assumes.

extern crate std;

use std::vec::Vec as StdVec;

use geometry::{BottomState, TopState, TrunkState};
use host::{RequestId, Session, SessionError, SessionEvent, Timing};
use protocol::{
    transitions, DeviceInfo, DeviceMessage, Event, FaultCode, FrameDecoder, ManualTask, Mode,
    ParamId, Plan, PlanPhase, Primitive, RejectReason, Request, RequestBody, ResponseBody,
    ResultCode, Step, StepKind, MAX_FRAME_LEN, PROTOCOL_VERSION, SCHEMA_ID,
};

use super::*;
use crate::display;

const FP: TrunkState = TrunkState::new(TopState::Folded, BottomState::Packed);
const FF: TrunkState = TrunkState::new(TopState::Folded, BottomState::Folded);
const FD: TrunkState = TrunkState::new(TopState::Folded, BottomState::Deployed);
const DP: TrunkState = TrunkState::new(TopState::Deployed, BottomState::Packed);
const DF: TrunkState = TrunkState::new(TopState::Deployed, BottomState::Folded);
const DD: TrunkState = TrunkState::new(TopState::Deployed, BottomState::Deployed);

/// Unloaded D&D height of the default trunk (tendon lengths count from its slack position).
const H_DD_MM: f32 = 197.7;
/// Sealed pressure change per mm of trunk height (linearised Boyle, ≈ the simulator's).
const KPA_PER_MM: f32 = 0.12;
/// A tendon snap's visible spike (the tendons stretch and the trunk jumps shorter).
const TENDON_SPIKE_KPA: f32 = 2.0;

/// A crude trunk: a pressure node filled by the inlet at 10 kPa/s (or, with `volume_fill`, below
/// 5 kPa at the state's probe signature: a smaller gas volume fills faster, as in the
/// simulator), emptied by the exhaust
/// (time constant 200 ms); the sealed gas changes with the trunk's height (0.12 kPa/mm); the
/// tendons pin the height once taut; snaps at fixed thresholds between the nominal
/// catalogue's pressures and lengths.
struct Plant {
    p_kpa: f32,
    state: TrunkState,
    pulled_mm: f32,
    pack_snaps: u8,
    leak_kpa_per_s: f32,
    /// A hole: the pressure falls at this fraction of itself per second (an orifice), so an
    /// open inlet plateaus at `inlet_kpa_per_s / hole_per_s`.
    hole_per_s: f32,
    /// What the open inlet adds per second.
    inlet_kpa_per_s: f32,
    /// Below 5 kPa the inlet fills at the state's probe signature.
    volume_fill: bool,
    /// The inlet never opens (stuck closed, or the supply is off).
    inlet_blocked: bool,
    /// Snaps disabled (a trunk that does not move).
    stuck: bool,
    /// Tendon snaps show as a pressure spike; `false`: the tendons pin the height and the
    /// buckling does not change the volume until they are let out (a blind snap).
    tendon_spike: bool,
    /// The inlet sticks open the first time it opens.
    inlet_sticks: bool,
    inlet_stuck_open: bool,
    /// How much shorter than the tendons allow the trunk jumped at a spiking snap.
    jump_mm: f32,
    height_mm: f32,
    noise: u32,
}

impl Plant {
    fn new(state: TrunkState) -> Self {
        let mut p = Self {
            p_kpa: 0.0,
            state,
            pulled_mm: 0.0,
            pack_snaps: 0,
            leak_kpa_per_s: 0.0,
            hole_per_s: 0.0,
            inlet_kpa_per_s: 10.0,
            volume_fill: false,
            inlet_blocked: false,
            stuck: false,
            tendon_spike: true,
            inlet_sticks: false,
            inlet_stuck_open: false,
            jump_mm: 0.0,
            height_mm: 0.0,
            noise: 12345,
        };
        p.height_mm = p.rest_mm();
        p
    }

    /// Rest height of the current state (one packed layer less while half-packed).
    fn rest_mm(&self) -> f32 {
        let h = CraneConfig::default().trunk_height_mm(self.state).unwrap();
        if self.pack_snaps == 1 {
            h - 24.7
        } else {
            h
        }
    }

    /// The trunk's height: at rest, or pinned by taut tendons.
    fn height(&mut self) -> f32 {
        let free = H_DD_MM - self.pulled_mm - self.jump_mm;
        let rest = self.rest_mm();
        if free < rest {
            free.max(0.0)
        } else {
            self.jump_mm = 0.0;
            rest
        }
    }

    /// Moves the height to where it now is, changing the sealed pressure accordingly.
    fn settle_volume(&mut self) {
        let h = self.height();
        self.p_kpa += KPA_PER_MM * (self.height_mm - h);
        self.height_mm = h;
    }

    /// A person folds the trunk into `state` by hand.
    fn by_hand(&mut self, state: TrunkState) {
        self.state = state;
        self.pack_snaps = 0;
        self.settle_volume();
    }

    fn pressure_threshold(state: TrunkState) -> Option<f32> {
        // Between the catalogue's inflate targets: unpack 14, pop top 22, deploy bottom 34.
        match (state.top, state.bottom) {
            (_, BottomState::Packed) => Some(10.0),
            (TopState::Folded, _) => Some(18.0),
            (TopState::Deployed, BottomState::Folded) => Some(30.0),
            _ => None,
        }
    }

    fn update(&mut self, out: &Outputs, dt_ms: u64, cfg: &CraneConfig) {
        let dt = dt_ms as f32 / 1000.0;
        if out.inlet_open && self.inlet_sticks {
            self.inlet_stuck_open = true;
        }
        if (out.inlet_open && !self.inlet_blocked) || self.inlet_stuck_open {
            let rate = if self.volume_fill && self.p_kpa < 5.0 {
                // 4 % over: the 8 ms filter's lag slows the fill the probe measures by ≈ 3 %.
                identify::PROBE_SIGNATURES[self.state.index()] * 1.04
            } else {
                self.inlet_kpa_per_s
            };
            self.p_kpa += rate * dt;
        }
        self.p_kpa -= self.p_kpa * self.hole_per_s * dt;
        if out.exhaust_open {
            self.p_kpa -= self.p_kpa * dt / 0.2;
        }
        if self.p_kpa > 0.0 {
            self.p_kpa = (self.p_kpa - self.leak_kpa_per_s * dt).max(0.0);
        }
        // Limp servos are back-driven to slack by the trunk.
        self.pulled_mm = if out.servos_enabled {
            (0..3)
                .map(|i| cfg.geometry.winch.length_for_angle(i, out.servo_deg[i]))
                .sum::<f32>()
                / 3.0
        } else {
            0.0
        };
        // Pressure pops modules out only while the tendons are slack (held tendons resist).
        if let (false, true, Some(thr), Some(t)) = (
            self.stuck,
            self.pulled_mm < 1.0,
            Self::pressure_threshold(self.state),
            transitions::step_up(self.state),
        ) {
            if self.p_kpa >= thr {
                self.state = t.to;
                self.p_kpa -= 3.0; // the trunk lengthens: a pressure drop
                self.height_mm = self.height();
            }
        }
        self.settle_volume();
        if self.stuck {
            return;
        }
        let pulled = self.pulled_mm;
        let thr = match (self.state.top, self.state.bottom) {
            // The top folds 14 mm into the taut tendons from D&F, 10 mm from D&P.
            (TopState::Deployed, BottomState::Deployed) => Some(60.0),
            (TopState::Deployed, BottomState::Folded) => Some(60.0),
            (TopState::Deployed, BottomState::Packed) => Some(105.0),
            (TopState::Folded, BottomState::Deployed) => Some(100.0),
            (TopState::Folded, BottomState::Folded) => {
                Some(if self.pack_snaps == 0 { 140.0 } else { 165.0 })
            }
            _ => None,
        };
        if let (Some(thr), Some(t)) = (thr, transitions::step_down(self.state)) {
            if pulled >= thr {
                if self.state == FF && self.pack_snaps == 0 {
                    self.pack_snaps = 1;
                } else {
                    self.state = t.to;
                    self.pack_snaps = 0;
                }
                let pinned = H_DD_MM - pulled - self.jump_mm < self.rest_mm();
                if self.tendon_spike && pinned {
                    // The tendons stretch: the trunk jumps shorter, a pressure spike.
                    self.jump_mm += TENDON_SPIKE_KPA / KPA_PER_MM;
                }
                self.settle_volume();
            }
        }
    }

    fn raw(&mut self, cfg: &CraneConfig) -> u16 {
        // ±15 counts (±0.1 kPa) of deterministic noise.
        self.noise = self.noise.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        let n = ((self.noise >> 16) % 31) as i32 - 15;
        (cfg.pressure_sensor.raw(self.p_kpa) as i32 + n).clamp(0, crate::ADC_MAX as i32) as u16
    }
}

/// What the line does to the next frame that crosses it (once): a device test of the host
/// engine's retry, not a host of its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LineFault {
    /// Flips a bit of the next frame toward the device.
    CorruptToDevice,
    /// Loses what the device sends next; the bytes are kept in [`Rig::lost`].
    LoseToHost,
}

/// The real controller and the plant at 1 kHz, and on the line the real host engine
/// (`host::Session`: handshake, sequence numbers, retries, heartbeat).
struct Rig {
    cfg: CraneConfig,
    ctl: Controller,
    plant: Plant,
    now: u64,
    buttons: Buttons,
    joystick: [u16; 2],
    /// Forces the raw pressure sample (sensor fault injection).
    raw_override: Option<u16>,
    /// Every host that was on the line (none leaves it): each sees every byte the device sends
    /// and ignores answers to the others' requests.
    hosts: StdVec<Session>,
    /// The host [`Rig::request`] speaks for.
    primary: usize,
    /// What the hosts were told, with the time and the host's index: handshakes and replies;
    /// device events as the primary host got them.
    log: StdVec<(u64, usize, SessionEvent)>,
    stores: StdVec<StoredState>,
    line_fault: Option<LineFault>,
    /// What [`LineFault::LoseToHost`] lost.
    lost: StdVec<u8>,
    /// The next host's first sequence number (the device caches its answers by `seq`).
    next_first_seq: u16,
    /// The next forged frame's sequence number.
    forged_seq: u16,
}

impl Rig {
    fn new(state: TrunkState) -> Self {
        Self::with(
            CraneConfig::default(),
            BootRecord::Stored(StoredState::confirmed(state)),
            state,
        )
    }

    fn with(cfg: CraneConfig, boot: BootRecord, plant_state: TrunkState) -> Self {
        let mut r = Self {
            cfg,
            ctl: Controller::new(cfg, boot, 0),
            plant: Plant::new(plant_state),
            now: 0,
            buttons: Buttons::default(),
            joystick: cfg.joystick.center_raw,
            raw_override: None,
            hosts: StdVec::new(),
            primary: 0,
            log: StdVec::new(),
            stores: StdVec::new(),
            line_fault: None,
            lost: StdVec::new(),
            next_first_seq: 1,
            forged_seq: 40_000,
        };
        let host = r.new_host();
        r.hosts.push(host);
        r
    }

    /// A rig with a completed handshake.
    fn connected(state: TrunkState) -> Self {
        let mut r = Self::new(state);
        r.connect();
        r
    }

    /// A rig with a completed handshake whose controller carries the simulator's probe profile
    /// (`identify::SIM_PROFILE`, what a calibration of that trunk writes): the probe is then
    /// evidence, for the manual step's check and for identification.
    fn connected_profiled(state: TrunkState) -> Self {
        let cfg = CraneConfig {
            probe_profile: Some(identify::SIM_PROFILE),
            ..CraneConfig::default()
        };
        let mut r = Self::with(
            cfg,
            BootRecord::Stored(StoredState::confirmed(state)),
            state,
        );
        r.connect();
        r
    }

    /// A host engine that has sent nothing. It sends only what a test asks for until
    /// [`Rig::keepalive`]: the link watch is under test.
    fn new_host(&mut self) -> Session {
        let mut host = Session::new(Timing::standard(), self.next_first_seq);
        self.next_first_seq = self.next_first_seq.wrapping_add(1_000);
        host.set_keepalive(false);
        host
    }

    /// A new host process in place of the primary one, its handshake done.
    fn connect(&mut self) {
        let (i, hello) = self.join(false);
        assert_ne!(hello.expect("the handshake succeeds").session, 0);
        self.primary = i;
    }

    /// The primary host.
    fn host(&mut self) -> &mut Session {
        &mut self.hosts[self.primary]
    }

    /// Another host on the line, and how its handshake ended.
    fn join(&mut self, takeover: bool) -> (usize, Result<DeviceInfo, SessionError>) {
        let host = self.new_host();
        self.hosts.push(host);
        let i = self.hosts.len() - 1;
        (i, self.handshake(i, takeover))
    }

    fn handshake(&mut self, host: usize, takeover: bool) -> Result<DeviceInfo, SessionError> {
        let mark = self.log.len();
        if takeover {
            self.hosts[host].connect_takeover(self.now);
        } else {
            self.hosts[host].connect(self.now);
        }
        self.exchange();
        self.log[mark..]
            .iter()
            .find_map(|(_, h, ev)| match ev {
                SessionEvent::Opened(info) if *h == host => Some(Ok(info.clone())),
                SessionEvent::HandshakeFailed(e) if *h == host => Some(Err(e.clone())),
                _ => None,
            })
            .expect("the device answers the handshake")
    }

    /// The session the primary host holds (0: none).
    fn session(&self) -> u32 {
        self.hosts[self.primary].device().map_or(0, |d| d.session)
    }

    /// The primary host sends a heartbeat whenever it has been quiet for the protocol's period.
    fn keepalive(&mut self) {
        self.host().set_keepalive(true);
    }

    /// Carries bytes both ways until the line is quiet: the hosts' frames to the controller,
    /// the controller's bytes to every host.
    fn exchange(&mut self) {
        loop {
            for host in &mut self.hosts {
                while let Some(mut frame) = host.poll_transmit() {
                    if self.line_fault == Some(LineFault::CorruptToDevice) {
                        self.line_fault = None;
                        frame[4] ^= if frame[4] == 0x10 { 0x20 } else { 0x10 };
                    }
                    self.ctl.handle_rx(&frame, self.now);
                }
            }
            let rx = self.device_bytes();
            if rx.is_empty() {
                break;
            }
            if self.line_fault == Some(LineFault::LoseToHost) {
                self.line_fault = None;
                self.lost = rx;
            } else {
                for host in &mut self.hosts {
                    host.handle_bytes(&rx, self.now);
                }
            }
            self.collect();
        }
        self.collect();
    }

    fn device_bytes(&mut self) -> StdVec<u8> {
        let mut rx = StdVec::new();
        let mut buf = [0u8; 256];
        loop {
            let n = self.ctl.poll_tx(&mut buf);
            if n == 0 {
                return rx;
            }
            rx.extend_from_slice(&buf[..n]);
        }
    }

    fn collect(&mut self) {
        for (i, host) in self.hosts.iter_mut().enumerate() {
            while let Some(ev) = host.poll_event() {
                if i == self.primary || !matches!(ev, SessionEvent::Device(_)) {
                    self.log.push((self.now, i, ev));
                }
            }
        }
    }

    /// Runs `ms` milliseconds of 1 kHz loop.
    fn run(&mut self, ms: u64) {
        for _ in 0..ms {
            self.now += 1;
            let out = self.ctl.poll_outputs();
            self.plant.update(&out, 1, &self.cfg);
            for host in &mut self.hosts {
                if host.poll_timeout().is_some_and(|t| t <= self.now) {
                    host.handle_timeout(self.now);
                }
            }
            self.exchange();
            let inputs = Inputs {
                pressure_raw: self
                    .raw_override
                    .unwrap_or_else(|| self.plant.raw(&self.cfg)),
                joystick_raw: self.joystick,
                buttons: self.buttons,
            };
            self.ctl.handle_inputs(&inputs, self.now);
            self.ctl.handle_time(self.now);
            if let Some(s) = self.ctl.poll_store() {
                self.stores.push(s);
                self.ctl.handle_stored();
            }
            self.exchange();
        }
    }

    /// Runs until `cond` holds or `max_ms` passed; returns the time it took.
    fn run_until(&mut self, max_ms: u64, mut cond: impl FnMut(&Rig) -> bool) -> Option<u64> {
        let t0 = self.now;
        while self.now - t0 < max_ms {
            if cond(self) {
                return Some(self.now - t0);
            }
            self.run(1);
        }
        cond(self).then(|| self.now - t0)
    }

    /// The answer the primary host got to its request `id`, if it came.
    fn reply(&self, id: RequestId) -> Option<(ResultCode, ResponseBody)> {
        self.answer(self.primary, id)
    }

    fn answer(&self, host: usize, id: RequestId) -> Option<(ResultCode, ResponseBody)> {
        self.log.iter().find_map(|(_, h, ev)| match ev {
            SessionEvent::Reply { id: got, reply } if *h == host && *got == id => {
                Some((reply.result, reply.body.clone()))
            }
            SessionEvent::Failed { id: got, error } if *h == host && *got == id => {
                panic!("{id:?} failed: {error}")
            }
            _ => None,
        })
    }

    /// Queues `body` at the primary host; it goes out at the next [`Rig::exchange`].
    fn send(&mut self, body: RequestBody) -> RequestId {
        let now = self.now;
        self.host().request(body, now)
    }

    /// `body` from `host`, answered at once (the controller answers within its pass); exactly
    /// one answer reaches the host (a second one would count as stale).
    fn request_from(&mut self, host: usize, body: RequestBody) -> (ResultCode, ResponseBody) {
        let stale = self.hosts[host].stats().stale_responses;
        let id = self.hosts[host].request(body, self.now);
        self.exchange();
        let answer = self.answer(host, id).expect("answered at once");
        assert_eq!(self.hosts[host].stats().stale_responses, stale);
        answer
    }

    fn request(&mut self, body: RequestBody) -> (ResultCode, ResponseBody) {
        self.request_from(self.primary, body)
    }

    /// `body` framed as no host engine frames it (before any handshake, from a session it does
    /// not hold, an old `seq`): deliberately forged bytes, for the device's side of the rules.
    fn forge(&mut self, seq: Option<u16>, session: u32, body: RequestBody) -> StdVec<u8> {
        let seq = seq.unwrap_or_else(|| {
            self.forged_seq = self.forged_seq.wrapping_add(1);
            self.forged_seq
        });
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = protocol::encode(&Request { seq, session, body }, &mut buf).unwrap();
        buf[..n].to_vec()
    }

    /// Raw bytes to the device (forged frames, garbage); returns what it answered, read off the
    /// line (the hosts see it too).
    fn inject(&mut self, bytes: &[u8]) -> StdVec<DeviceMessage> {
        self.ctl.handle_rx(bytes, self.now);
        let rx = self.device_bytes();
        for host in &mut self.hosts {
            host.handle_bytes(&rx, self.now);
        }
        self.collect();
        off_the_line(&rx)
    }

    /// A forged request (see [`Rig::forge`]) from `session`; returns its one answer.
    fn forged(&mut self, session: u32, body: RequestBody) -> (ResultCode, ResponseBody) {
        let frame = self.forge(None, session, body);
        let answers: StdVec<_> = self
            .inject(&frame)
            .into_iter()
            .filter_map(|m| match m {
                DeviceMessage::Response { result, body, .. } => Some((result, body)),
                DeviceMessage::Event(_) => None,
            })
            .collect();
        assert_eq!(answers.len(), 1, "exactly one answer: {answers:?}");
        answers[0].clone()
    }

    /// The device events received.
    fn events(&self) -> impl Iterator<Item = &Event> {
        self.log.iter().filter_map(|(_, _, ev)| match ev {
            SessionEvent::Device(e) => Some(e),
            _ => None,
        })
    }

    fn plan_done(&self) -> Option<(bool, TrunkState)> {
        self.events().find_map(|e| match e {
            Event::PlanDone { ok, state, .. } => Some((*ok, *state)),
            _ => None,
        })
    }

    fn faults_raised(&self) -> StdVec<FaultCode> {
        self.events()
            .filter_map(|e| match e {
                Event::FaultRaised(f) => Some(*f),
                _ => None,
            })
            .collect()
    }

    fn nominal(from: TrunkState, to: TrunkState) -> Step {
        transitions::transition(from, to).unwrap().step()
    }

    fn plan(id: u16, path: &[TrunkState]) -> Plan {
        let mut steps = heapless::Vec::new();
        for w in path.windows(2) {
            steps.push(Self::nominal(w[0], w[1])).unwrap();
        }
        Plan { plan_id: id, steps }
    }

    /// Runs `step` on its own (the device accepts it: `InProgress`).
    fn run_step(&mut self, step: Step) {
        assert_eq!(
            self.request(RequestBody::RunStep(step)).0,
            ResultCode::InProgress
        );
    }

    fn upload_and_start(&mut self, plan: Plan) {
        let id = plan.plan_id;
        assert_eq!(
            self.request(RequestBody::UploadPlan(plan)).0,
            ResultCode::Ok
        );
        assert_eq!(
            self.request(RequestBody::StartPlan { plan_id: id }).0,
            ResultCode::InProgress
        );
    }

    fn press(&mut self, set: impl Fn(&mut Buttons, bool)) {
        set(&mut self.buttons, true);
        self.run(30);
        set(&mut self.buttons, false);
        self.run(30);
    }
}

/// The device's messages in `bytes`, as a protocol analyser on the line reads them.
fn off_the_line(bytes: &[u8]) -> StdVec<DeviceMessage> {
    let mut dec = FrameDecoder::new();
    bytes
        .iter()
        .filter_map(|&b| dec.push::<DeviceMessage>(b).and_then(Result::ok))
        .collect()
}

fn step(
    kind: StepKind,
    from: TrunkState,
    to: TrunkState,
    prims: &[Primitive],
    timeout_ms: u32,
) -> Step {
    Step {
        kind,
        from,
        to,
        primitives: heapless::Vec::from_slice(prims).unwrap(),
        timeout_ms,
    }
}

// ---------------------------------------------------------------------------------------------
// Boot and storage
// ---------------------------------------------------------------------------------------------

#[test]
fn boot_empty_store_is_f_and_p_confirmed() {
    let cfg = CraneConfig::default();
    let mut c = Controller::new(cfg, BootRecord::Empty, 1_000);
    let s = c.status();
    assert_eq!(
        (s.state, s.state_confirmed, s.mode, s.faults),
        (FP, true, Mode::Standalone, 0)
    );
    assert_eq!(c.poll_display(), display::text("F-P "));
    assert_eq!(c.poll_store(), None);
    let o = c.poll_outputs();
    // Fail-closed: the gripper boots holding.
    assert!(!o.inlet_open && !o.exhaust_open && o.gripper_closed);
    assert_eq!(o.servo_deg, [0.0; 3]);
}

#[test]
fn boot_corrupt_store_is_unconfirmed_with_storage_fault() {
    let mut r = Rig::with(CraneConfig::default(), BootRecord::Corrupt, FP);
    let s = r.ctl.status();
    assert_eq!(
        (s.state, s.state_confirmed, s.mode),
        (FP, false, Mode::Safe)
    );
    assert_eq!(s.faults, FaultCode::StateStorage.bit());
    assert_eq!(r.ctl.poll_display(), display::fault(10));
    r.connect();
    // Plans need a confirmed state.
    let (res, _) = r.request(RequestBody::RunStep(Rig::nominal(FP, FF)));
    assert_eq!(res, ResultCode::Rejected(RejectReason::Faulted));
    // Declaring the state clears the fault and is persisted.
    assert_eq!(r.request(RequestBody::DeclareState(DF)).0, ResultCode::Ok);
    r.run(1);
    assert_eq!(r.stores, [StoredState::confirmed(DF)]);
    let s = r.ctl.status();
    assert_eq!(
        (s.state, s.state_confirmed, s.mode, s.faults),
        (DF, true, Mode::Standalone, 0)
    );
    assert!(r
        .events()
        .any(|e| *e == Event::FaultCleared(FaultCode::StateStorage)));
    assert_eq!(r.ctl.poll_display(), display::text("d-F "));
}

#[test]
fn boot_from_stored_state_and_watchdog_report() {
    let mut c = Controller::new(
        CraneConfig::default(),
        BootRecord::Stored(StoredState::confirmed(FD)),
        0,
    );
    assert_eq!(c.status().state, FD);
    c.report_watchdog_reset();
    assert_eq!(c.status().faults, FaultCode::Watchdog.bit());
    assert_eq!(c.mode(), Mode::Safe);
    assert_eq!(c.poll_display(), display::fault(9));
}

// ---------------------------------------------------------------------------------------------
// Link: handshake, responses, retries, garbage
// ---------------------------------------------------------------------------------------------

#[test]
fn handshake_is_required_and_checked() {
    let mut r = Rig::new(FP);
    // A host that breaks the rules (the engine shakes hands first, with this build's
    // versions): forged frames.
    assert_eq!(
        r.forged(0, RequestBody::GetStatus),
        (
            ResultCode::Rejected(RejectReason::NoHandshake),
            ResponseBody::None
        )
    );
    for (v, id) in [
        (PROTOCOL_VERSION + 1, SCHEMA_ID),
        (PROTOCOL_VERSION, SCHEMA_ID ^ 1),
    ] {
        let (res, body) = r.forged(
            0,
            RequestBody::Hello {
                protocol_version: v,
                schema_id: id,
                takeover: false,
            },
        );
        assert_eq!(res, ResultCode::Rejected(RejectReason::VersionMismatch));
        let ResponseBody::Hello(info) = body else {
            panic!("no device info")
        };
        assert_eq!(
            (info.protocol_version, info.schema_id),
            (PROTOCOL_VERSION, SCHEMA_ID)
        );
        assert_eq!(info.trunk.pressure_limit_kpa, 40.0);
    }
    assert_eq!(
        r.forged(0, RequestBody::Heartbeat).0,
        ResultCode::Rejected(RejectReason::NoHandshake)
    );
    r.connect();
    let (res, body) = r.request(RequestBody::GetStatus);
    assert_eq!(res, ResultCode::Ok);
    let ResponseBody::Status(s) = body else {
        panic!()
    };
    // Frames: 2 Hello and a Heartbeat refused, 1 GetStatus refused, 1 Hello, this GetStatus.
    assert_eq!((s.state, s.mode, s.frames_rx), (FP, Mode::Standalone, 6));
}

#[test]
fn every_request_gets_one_response_and_retries_are_not_reexecuted() {
    let mut r = Rig::connected(FP);
    // The line loses the answer: the engine sends the request again, with the same seq, after
    // its response timeout.
    r.line_fault = Some(LineFault::LoseToHost);
    let id = r.send(RequestBody::RunStep(Rig::nominal(FP, FF)));
    r.exchange();
    let lost = off_the_line(&r.lost);
    let Some(DeviceMessage::Response { seq, result, body }) = lost.first() else {
        panic!("lost {lost:?}")
    };
    let seq = *seq;
    assert_eq!(
        (*result, body),
        (ResultCode::InProgress, &ResponseBody::None)
    );
    assert_eq!(r.reply(id), None);
    r.run(u64::from(protocol::RESPONSE_TIMEOUT_MS));
    // The same answer: the step is not restarted (a second execution would answer Busy).
    assert_eq!(
        r.reply(id),
        Some((ResultCode::InProgress, ResponseBody::None))
    );
    assert_eq!(r.host().stats().retries, 1);
    // A different request with the same seq is a new request (forged: the engine never
    // reuses a seq).
    let heartbeat = r.forge(Some(seq), r.session(), RequestBody::Heartbeat);
    let answers = r.inject(&heartbeat);
    assert!(
        matches!(
            answers.last(),
            Some(DeviceMessage::Response { seq: s, result: ResultCode::Ok, .. }) if *s == seq
        ),
        "{answers:?}"
    );
    assert_eq!(r.ctl.mode(), Mode::Running);
    assert!(r.plan_done().is_none());
}

#[test]
fn any_chunking_and_garbage_never_panic() {
    let mut r = Rig::connected(FP);
    // Garbage and empty frames (deliberate raw bytes), then the engine's request byte by byte.
    r.inject(&[0, 0, 1, 2, 3, 0xFF, 0]);
    let id = r.send(RequestBody::GetParam(ParamId::PressureLimitKpa));
    let frame = r.host().poll_transmit().expect("sent at once");
    for b in &frame {
        r.inject(core::slice::from_ref(b));
    }
    assert_eq!(
        r.reply(id),
        Some((
            ResultCode::Ok,
            ResponseBody::Param {
                id: ParamId::PressureLimitKpa,
                value: 40.0
            }
        ))
    );
    // 200 kB of pseudo-random bytes (with delimiters) interleaved with the loop.
    let mut x: u32 = 7;
    let mut chunk = [0u8; 997];
    for _ in 0..200 {
        for b in chunk.iter_mut() {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            *b = if x >> 28 == 0 { 0 } else { (x >> 20) as u8 };
        }
        r.ctl.handle_rx(&chunk, r.now);
        r.run(1);
    }
    // The noise ends inside a frame: the delimiter the engine sends ahead of a request closes it.
    r.inject(&[0]);
    let s = r.ctl.status();
    assert!(s.frames_dropped > 1_000, "{}", s.frames_dropped);
    // Still alive and answering.
    assert_eq!(r.request(RequestBody::Heartbeat).0, ResultCode::Ok);
}

#[test]
fn corrupted_frames_are_counted_and_the_retry_answers() {
    let mut r = Rig::connected(FP);
    let before = r.ctl.status().frames_dropped;
    r.line_fault = Some(LineFault::CorruptToDevice);
    let id = r.send(RequestBody::GetStatus);
    r.exchange();
    assert_eq!(r.reply(id), None);
    assert_eq!(r.ctl.status().frames_dropped, before + 1);
    // The engine's retry after its response timeout is answered, once.
    r.run(u64::from(protocol::RESPONSE_TIMEOUT_MS));
    assert!(matches!(
        r.reply(id),
        Some((ResultCode::Ok, ResponseBody::Status(_)))
    ));
    let stats = r.host().stats();
    assert_eq!((stats.retries, stats.stale_responses), (1, 0));
}

// ---------------------------------------------------------------------------------------------
// Plans
// ---------------------------------------------------------------------------------------------

#[test]
fn pneumatic_plan_f_and_p_to_d_and_f_is_confirmed_by_snaps() {
    let mut r = Rig::connected(FP);
    r.keepalive();
    r.upload_and_start(Rig::plan(7, &[FP, FF, DF]));
    assert_eq!(r.ctl.mode(), Mode::Running);
    let took = r
        .run_until(20_000, |r| r.plan_done().is_some())
        .expect("plan finishes");
    assert_eq!(r.plan_done(), Some((true, DF)));
    assert_eq!(r.plant.state, DF);
    let s = r.ctl.status();
    assert_eq!(
        (s.state, s.state_confirmed, s.mode, s.faults),
        (DF, true, Mode::Standalone, 0)
    );
    assert_eq!(s.plan.unwrap().phase, PlanPhase::Done);
    // Each inflate ended at its snap and vented below 0.5 kPa.
    assert!(r.plant.p_kpa < 0.6, "{}", r.plant.p_kpa);
    // 10 kPa at 10 kPa/s, snap, vent; then 18 kPa: a few seconds.
    assert!(took > 2_000 && took < 8_000, "{took}");
    // Each step is journaled ahead of its first actuation; its confirmation is the next
    // step's journal (written in the same pass, so the shell keeps only the newer) or, at the
    // end, the confirmed state.
    // The candidates are the step's reach: its inflation's whole chain (belief::reach).
    let pending = |from: TrunkState, to: TrunkState| StoredState {
        state: from,
        confirmed: false,
        candidates: belief::reach(&transitions::transition(from, to).unwrap().step()),
        pending: Some(protocol::Transition { from, to }),
    };
    assert_eq!(
        r.stores,
        [pending(FP, FF), pending(FF, DF), StoredState::confirmed(DF)]
    );
    let reached: StdVec<_> = r
        .events()
        .filter_map(|e| match e {
            Event::StateReached { state, confirmed } => Some((*state, *confirmed)),
            _ => None,
        })
        .collect();
    assert_eq!(reached, [(FF, true), (DF, true)]);
    let done: StdVec<_> = r
        .events()
        .filter_map(|e| match e {
            Event::StepDone {
                step, ok, state, ..
            } => Some((*step, *ok, *state)),
            _ => None,
        })
        .collect();
    assert_eq!(done, [(0, true, FF), (1, true, DF)]);
    // The pressure never went near the cap.
    assert!(r.faults_raised().is_empty());
}

#[test]
fn tendon_plan_d_and_d_to_f_and_p_counts_two_snaps_to_pack() {
    // D&D → F&D: the top's buckling spikes (the tendons are taut); F&F → F&P: two spikes,
    // one per layer. (F&D → F&F is blind in this plant, as in the simulator: below.)
    for (from, to) in [(DD, FD), (FF, FP)] {
        let mut r = Rig::connected(from);
        r.keepalive();
        r.upload_and_start(Rig::plan(3, &[from, to]));
        r.run_until(30_000, |r| r.plan_done().is_some())
            .expect("plan finishes");
        assert_eq!(r.plan_done(), Some((true, to)));
        assert_eq!(r.plant.state, to);
        assert_eq!(r.ctl.status().state, to);
        assert!(r.ctl.status().state_confirmed);
        // Released after the pull.
        assert!(r
            .ctl
            .poll_outputs()
            .servo_deg
            .iter()
            .all(|d| d.abs() < 1e-3));
        assert!(r.faults_raised().is_empty(), "{:?}", r.faults_raised());
    }
}

/// The blind edges (docs/simulator.md, "Findings" 1): the tendons pin the trunk's height, the
/// buckling makes no pressure spike. The sealed release shows the volume shrank, but how much
/// a fold shrinks it depends on the trunk (two folds shrink it more than one): without the
/// spikes the step expects the fold is not confirmed, and the candidates hold it.
#[test]
fn blind_tendon_snaps_are_not_confirmed_by_the_volume_alone() {
    let mut r = Rig::connected(FD);
    r.plant.tendon_spike = false;
    r.keepalive();
    r.upload_and_start(Rig::plan(3, &[FD, FF, FP]));
    let mut sealed_releases = 0;
    let mut was_pulled = false;
    r.run_until(40_000, |r| {
        let o = r.ctl.poll_outputs();
        // Letting the tendons out with both valves closed.
        let pulled = r.plant.pulled_mm > 50.0;
        if was_pulled && !pulled && !o.exhaust_open {
            sealed_releases += 1;
        }
        was_pulled = pulled;
        r.plan_done().is_some()
    })
    .expect("plan finishes");
    assert_eq!(r.faults_raised(), [FaultCode::TransitionNotConfirmed]);
    assert_eq!(r.plan_done().map(|d| d.0), Some(false));
    assert_eq!(r.plant.state, FF);
    let s = r.ctl.status();
    assert!(!s.state_confirmed, "{s:?}");
    assert!(
        s.candidates.contains(FF) && s.candidates.contains(FD),
        "{s:?}"
    );
    assert_eq!(
        s.interrupted,
        Some(protocol::Transition { from: FD, to: FF })
    );
    assert_eq!(sealed_releases, 1);
}

#[test]
fn a_pull_without_a_snap_is_refused_after_the_sealed_release() {
    for (from, to) in [(DD, FD), (FF, FP)] {
        let mut r = Rig::connected(from);
        r.plant.stuck = true;
        r.keepalive();
        r.upload_and_start(Rig::plan(1, &[from, to]));
        r.run_until(20_000, |r| r.plan_done().is_some())
            .expect("fails in time");
        assert_eq!(r.plan_done(), Some((false, from)));
        assert_eq!(r.faults_raised(), [FaultCode::TransitionNotConfirmed]);
        // The pull went past the first snap's length: the sealed check says "no rise", but a
        // leak would say the same, so the state is not vouched for.
        let s = r.ctl.status();
        assert_eq!((s.state, s.state_confirmed), (from, false));
        assert!(s.candidates.contains(from) && s.candidates.contains(to));
        assert_eq!(s.interrupted, Some(protocol::Transition { from, to }));
        // The release went back to slack before the comparison.
        assert!(r.plant.pulled_mm < 1e-3, "{}", r.plant.pulled_mm);
    }
    // Packing one bottom layer of two (+3 kPa where both make +6): one snap is not two.
    let mut r = Rig::connected(FF);
    r.plant.tendon_spike = false;
    r.keepalive();
    r.upload_and_start(Rig::plan(1, &[FF, FP]));
    let stop_at_half = |r: &mut Rig| {
        // The second layer never packs: a stiff one.
        if r.plant.pack_snaps == 1 && r.plant.pulled_mm > 160.0 {
            r.plant.stuck = true;
        }
    };
    for _ in 0..20_000 {
        stop_at_half(&mut r);
        r.run(1);
        if r.plan_done().is_some() {
            break;
        }
    }
    assert_eq!(r.plan_done(), Some((false, FF)));
    assert_eq!(r.faults_raised(), [FaultCode::TransitionNotConfirmed]);
}

#[test]
fn a_load_pressing_on_the_sealed_trunk_is_not_a_stuck_inlet() {
    let mut r = Rig::connected(FF);
    r.run(200);
    // A one-off rise of 2.5 kPa (a payload compressing the sealed trunk), then flat.
    r.plant.p_kpa += 2.5;
    r.run(2_000);
    assert!(r.faults_raised().is_empty(), "{:?}", r.faults_raised());
    assert!(!r.ctl.poll_outputs().exhaust_open);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
}

#[test]
fn a_fold_finished_after_its_manual_step_was_aborted_is_not_a_stuck_inlet() {
    // A person packing the bottom when the step is aborted finishes the fold: the trunk is
    // squeezed (4 kPa/s for 1.5 s, as the simulator's sealed trunk packed over 3 s) with the
    // inlet shut. For HANDS_MS
    // that is their hands, not gas coming in; after it, gas coming in is a stuck inlet again.
    let mut r = Rig::connected_profiled(DF);
    r.keepalive();
    r.upload_and_start(Rig::plan(4, &[DF, DP]));
    r.run(100);
    assert_eq!(r.ctl.mode(), Mode::WaitingManual);
    r.run(2_000);
    assert_eq!(r.request(RequestBody::Abort).0, ResultCode::Ok);
    r.run(50);
    assert_ne!(r.ctl.mode(), Mode::WaitingManual);
    for _ in 0..1_500 {
        r.plant.p_kpa += 0.004;
        r.run(1);
    }
    assert!(
        !r.faults_raised().contains(&FaultCode::InletStuck),
        "{:?}",
        r.faults_raised()
    );
    r.run(super::HANDS_MS.saturating_sub(1_500));
    r.plant.inlet_stuck_open = true;
    r.run_until(1_000, |r| {
        r.faults_raised().contains(&FaultCode::InletStuck)
    })
    .expect("a stuck inlet after the person's hands are off the trunk");
}

#[test]
fn a_stuck_open_inlet_is_vented_and_never_pushes_the_trunk_on() {
    // Idle and sealed: gas coming in is a stuck inlet; the exhaust opens and stays open.
    let mut r = Rig::connected(FF);
    r.run(200);
    r.plant.inlet_stuck_open = true;
    let t = r
        .run_until(1_000, |r| r.ctl.poll_outputs().exhaust_open)
        .expect("vents");
    // 1 kPa of rise (100 ms at 10 kPa/s) and 200 ms of confirmation.
    assert!(t < 400, "{t} ms");
    assert_eq!(r.faults_raised(), [FaultCode::InletStuck]);
    assert_eq!(r.ctl.poll_display(), display::fault(11));
    let at_fault = r.plant.p_kpa;
    assert!(at_fault < 3.5, "{at_fault} kPa");
    let mut max = 0.0f32;
    for _ in 0..5_000 {
        r.run(1);
        max = max.max(r.plant.p_kpa);
    }
    // Never above where the fault found it; then down to the open exhaust's balance against
    // the stuck inlet (the plant's 10 kPa/s · 0.2 s).
    assert!(max <= at_fault + 0.05, "{max} vs {at_fault} kPa");
    assert!(r.plant.p_kpa < 2.1, "{} kPa", r.plant.p_kpa);
    assert!(r.ctl.poll_outputs().exhaust_open);
    assert_eq!(r.plant.state, FF);
    // Below 3 kPa a reset is allowed (the exhaust wins); a still-stuck inlet trips it again.
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    r.run(600);
    assert!(r.ctl.poll_outputs().exhaust_open);
    assert_eq!(r.ctl.mode(), Mode::Safe);
    // A plan whose inflate sticks the inlet: the pop it asked for happens, but the check that
    // its drop was a snap (the sealed trunk holding its pressure) cannot finish with gas still
    // coming in, so the state is unconfirmed with D&F among the candidates; after the vent
    // gives up, the safe state holds the pressure down (no second pop).
    let mut r = Rig::connected(FF);
    r.plant.inlet_sticks = true;
    r.keepalive();
    r.upload_and_start(Rig::plan(1, &[FF, DF]));
    r.run_until(40_000, |r| r.plan_done().is_some())
        .expect("fails in time");
    let s = r.ctl.status();
    assert!(!s.state_confirmed, "{s:?}");
    assert!(s.candidates.contains(DF), "{s:?}");
    assert_eq!(r.plan_done().map(|d| d.0), Some(false));
    assert!(r.faults_raised().contains(&FaultCode::InletStuck));
    let at_fault = r.plant.p_kpa;
    let mut max = 0.0f32;
    for _ in 0..10_000 {
        r.run(1);
        max = max.max(r.plant.p_kpa);
    }
    // Never above where the fault found it (far below D&D's 30 kPa snap), then down to the
    // open exhaust's balance against the stuck inlet.
    assert!(max <= at_fault + 0.05, "{max} vs {at_fault} kPa");
    assert!(r.plant.p_kpa < 2.1, "{} kPa", r.plant.p_kpa);
    assert_eq!(r.plant.state, DF);
    assert!(r.ctl.poll_outputs().exhaust_open);
}

#[test]
fn a_step_without_its_snap_is_not_confirmed() {
    let mut r = Rig::connected(FP);
    r.plant.stuck = true;
    r.keepalive();
    r.upload_and_start(Rig::plan(1, &[FP, FF]));
    r.run_until(10_000, |r| r.plan_done().is_some())
        .expect("fails in time");
    assert_eq!(r.plan_done(), Some((false, FP)));
    assert_eq!(r.faults_raised(), [FaultCode::TransitionNotConfirmed]);
    // Inflated to the cap (39 kPa) without a snap: the snaps may still come, any of the
    // inflation's chain. Unconfirmed, with the step's reach.
    let s = r.ctl.status();
    assert_eq!(
        (s.state, s.state_confirmed, s.mode),
        (FP, false, Mode::Safe)
    );
    assert_eq!(
        s.candidates,
        belief::reach(&transitions::transition(FP, FF).unwrap().step())
    );
    assert_eq!(
        s.plan.unwrap().phase,
        PlanPhase::Failed(FaultCode::TransitionNotConfirmed)
    );
    // Held at the cap's regulator target (cap − 1 kPa: an inflation waiting for its snap goes
    // up to it) without venting: safe state = valves closed.
    let o = r.ctl.poll_outputs();
    assert!(!o.inlet_open && !o.exhaust_open);
    let cfg = CraneConfig::default();
    assert!(
        (r.plant.p_kpa - (cfg.pressure_limit_kpa - cfg.hysteresis_kpa)).abs() < 1.5,
        "{}",
        r.plant.p_kpa
    );
    assert_eq!(r.ctl.poll_display(), display::fault(4));
    // Journaled, then persisted as unconfirmed (a reset boots into the same belief).
    assert_eq!(r.stores.len(), 2);
    assert_eq!(
        r.stores[1],
        StoredState {
            state: FP,
            confirmed: false,
            candidates: s.candidates,
            pending: Some(protocol::Transition { from: FP, to: FF }),
        }
    );
    // Reset: the last confirmed state is shown, marked unconfirmed (first decimal point).
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
    let mut shown = display::text("F-P ");
    shown[0] |= display::DP;
    assert_eq!(r.ctl.poll_display(), shown);
}

#[test]
fn step_time_limit_faults() {
    let mut r = Rig::connected(FP);
    r.keepalive();
    let s = step(
        StepKind::Pneumatic,
        FP,
        FF,
        &[Primitive::WaitSnap { timeout_ms: 60_000 }],
        1_000,
    );
    r.run_step(s);
    let t = r.run_until(5_000, |r| r.ctl.mode() == Mode::Safe).unwrap();
    assert!((999..=1_001).contains(&t), "{t}");
    assert_eq!(r.faults_raised(), [FaultCode::StepTimeout]);
    assert_eq!(r.ctl.status().state, FP);
}

#[test]
fn plan_validation_rejects_bad_plans() {
    let mut r = Rig::connected(FP);
    let reject = |x| (ResultCode::Rejected(x), ResponseBody::None);
    // Steps that do not chain.
    let mut p = Rig::plan(2, &[FP, FF]);
    p.steps.push(Rig::nominal(DF, DD)).unwrap();
    let refused = |step, field, value, limit| {
        ResponseBody::Refused(protocol::Refusal {
            step,
            field,
            value,
            limit,
        })
    };
    // The refusal names the step that does not chain on.
    assert_eq!(
        r.request(RequestBody::UploadPlan(p)),
        (
            ResultCode::Rejected(RejectReason::InvalidPlan),
            refused(Some(1), protocol::RefusedField::Steps, 2.0, 8.0)
        )
    );
    // Id 0, empty.
    assert_eq!(
        r.request(RequestBody::UploadPlan(Rig::plan(0, &[FP, FF]))),
        reject(RejectReason::InvalidPlan)
    );
    let empty = Plan {
        plan_id: 4,
        steps: heapless::Vec::new(),
    };
    assert_eq!(
        r.request(RequestBody::UploadPlan(empty)).0,
        ResultCode::Rejected(RejectReason::InvalidPlan)
    );
    // Not from the current state.
    assert_eq!(
        r.request(RequestBody::UploadPlan(Rig::plan(5, &[DD, FD]))),
        reject(RejectReason::WrongState)
    );
    // Values out of range: above the cap, too long a pull, NaN, zero timeout. Each refusal
    // names the field, the value asked for and the limit.
    use protocol::RefusedField as F;
    let cap = r.cfg.pressure_limit_kpa;
    for (prim, field, value, limit) in [
        (
            Primitive::Inflate {
                pressure_kpa: 45.0,
                snaps: 1,
            },
            F::Pressure,
            45.0,
            cap,
        ),
        (
            Primitive::TendonPull {
                length_mm: 500.0,
                snaps: 1,
            },
            F::TendonLength,
            500.0,
            r.cfg.max_tendon_mm,
        ),
        (
            Primitive::Bend {
                direction_deg: 0.0,
                angle_deg: 200.0,
            },
            F::BendAngle,
            200.0,
            180.0,
        ),
    ] {
        let s = step(StepKind::Pneumatic, FP, FF, &[prim], 1_000);
        assert_eq!(
            r.request(RequestBody::RunStep(s)),
            (
                ResultCode::Rejected(RejectReason::OutOfRange),
                refused(Some(0), field, value, limit)
            ),
            "{prim:?}"
        );
    }
    for prim in [
        Primitive::Inflate {
            pressure_kpa: f32::NAN,
            snaps: 1,
        },
        Primitive::Bend {
            direction_deg: 0.0,
            angle_deg: f32::INFINITY,
        },
    ] {
        let s = step(StepKind::Pneumatic, FP, FF, &[prim], 1_000);
        assert_eq!(
            r.request(RequestBody::RunStep(s)).0,
            ResultCode::Rejected(RejectReason::OutOfRange),
            "{prim:?}"
        );
    }
    let s = step(
        StepKind::Pneumatic,
        FP,
        FF,
        &[Primitive::Hold { duration_ms: 1 }],
        0,
    );
    assert_eq!(
        r.request(RequestBody::RunStep(s)),
        (
            ResultCode::Rejected(RejectReason::OutOfRange),
            refused(Some(0), F::Duration, 0.0, 3_600_000.0)
        )
    );
    // Unknown plan id.
    assert_eq!(
        r.request(RequestBody::StartPlan { plan_id: 9 }),
        reject(RejectReason::UnknownPlan)
    );
    // A valid upload, then busy while running.
    r.keepalive();
    r.upload_and_start(Rig::plan(6, &[FP, FF]));
    assert_eq!(
        r.request(RequestBody::UploadPlan(Rig::plan(8, &[FP, FF])))
            .0,
        ResultCode::Busy
    );
    assert_eq!(
        r.request(RequestBody::StartPlan { plan_id: 6 }).0,
        ResultCode::Busy
    );
    assert_eq!(r.request(RequestBody::DeclareState(DD)).0, ResultCode::Busy);
    // Nothing was changed by the rejected requests.
    assert_eq!(r.ctl.status().plan.unwrap().plan_id, 6);
}

#[test]
fn abort_goes_to_the_safe_state_and_is_not_latched() {
    let mut r = Rig::connected(DD);
    r.keepalive();
    r.upload_and_start(Rig::plan(2, &[DD, FD]));
    r.run(300);
    let mid = r.ctl.poll_outputs().servo_deg;
    assert!(mid[0] > 10.0, "{mid:?}");
    assert_eq!(r.request(RequestBody::Abort).0, ResultCode::Ok);
    r.run(500);
    // Frozen where they were when aborted.
    let after = r.ctl.poll_outputs();
    assert!(
        (after.servo_deg[0] - mid[0]).abs() < 1.0,
        "{:?} vs {mid:?}",
        after.servo_deg
    );
    assert!(!after.inlet_open && !after.exhaust_open);
    // Limp: no pulses, so a servo that stalled short of its command pushes nothing.
    assert!(!after.servos_enabled);
    assert_eq!(r.ctl.mode(), Mode::Safe);
    assert_eq!(r.ctl.status().plan.unwrap().phase, PlanPhase::Aborted);
    assert_eq!(r.plan_done(), Some((false, DD)));
    assert_eq!(r.ctl.poll_display(), display::text("SAFE"));
    // Aborted past the first snap's length: unconfirmed, the truth among the candidates; no
    // step starts from a state nobody vouches for.
    let s = r.ctl.status();
    assert!(!s.state_confirmed);
    assert!(s.candidates.contains(r.plant.state), "{s:?}");
    assert_eq!(
        r.request(RequestBody::RunStep(Rig::nominal(DD, FD))).0,
        ResultCode::Rejected(RejectReason::Unconfirmed)
    );
    // Not latched: once the state is declared, a new step may start at once, the servos on
    // again from slack (where a limp servo really is is unknown; paying out pushes nothing).
    let truth = r.plant.state;
    assert_eq!(
        r.request(RequestBody::DeclareState(truth)).0,
        ResultCode::Ok
    );
    let next = transitions::step_down(truth).unwrap().to;
    assert_eq!(
        r.request(RequestBody::RunStep(Rig::nominal(truth, next))).0,
        ResultCode::InProgress
    );
    r.run(1);
    let o = r.ctl.poll_outputs();
    assert!(o.servos_enabled);
    assert!(o.servo_deg.iter().all(|d| *d < 1.0), "{o:?}");
}

#[test]
fn a_fault_leaves_the_servos_limp_until_reset() {
    let mut r = Rig::connected(DD);
    r.keepalive();
    r.upload_and_start(Rig::plan(2, &[DD, FD]));
    r.run(300);
    r.buttons.estop = true;
    r.run(10);
    assert!(!r.ctl.poll_outputs().servos_enabled);
    r.buttons.estop = false;
    r.run(10);
    assert!(!r.ctl.poll_outputs().servos_enabled);
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    let o = r.ctl.poll_outputs();
    assert!(o.servos_enabled && o.servo_deg == [0.0; 3], "{o:?}");
}

#[test]
fn manual_step_waits_for_the_button_or_the_host() {
    for by_button in [true, false] {
        let mut r = Rig::connected_profiled(DF);
        r.keepalive();
        assert_eq!(
            r.request(RequestBody::ConfirmManual).0,
            ResultCode::Rejected(RejectReason::NoManualPending)
        );
        r.upload_and_start(Rig::plan(4, &[DF, DP]));
        r.run(100);
        assert_eq!(r.ctl.mode(), Mode::WaitingManual);
        assert_eq!(r.ctl.status().plan.unwrap().phase, PlanPhase::WaitingManual);
        assert_eq!(
            r.ctl.poll_display(),
            display::task(ManualTask::PackBottomModule)
        );
        assert_eq!(
            r.ctl.status().manual_task,
            Some(ManualTask::PackBottomModule)
        );
        assert!(r.events().any(|e| *e
            == Event::ManualRequired {
                plan_id: 4,
                step: 0,
                task: ManualTask::PackBottomModule
            }));
        r.run(5_000);
        assert_eq!(r.ctl.mode(), Mode::WaitingManual);
        r.plant.volume_fill = true;
        r.plant.by_hand(DP);
        r.run(100);
        if by_button {
            r.press(|b, v| b.confirm = v);
        } else {
            assert_eq!(r.request(RequestBody::ConfirmManual).0, ResultCode::Ok);
        }
        // The person's word is checked: the probe finds the trunk packed.
        r.run(20);
        assert_eq!(r.ctl.mode(), Mode::Running);
        assert_eq!(r.ctl.status().manual_task, None);
        r.run_until(5_000, |r| r.plan_done().is_some());
        assert_eq!(r.plan_done(), Some((true, DP)));
        assert_eq!(r.ctl.status().state, DP);
        assert!(r.ctl.status().state_confirmed);
    }
}

#[test]
fn a_persons_confirm_is_checked_and_never_taken_for_the_truth() {
    // Asked to pack the bottom (D&F → D&P), the person does nothing, or folds the top by
    // mistake, and confirms: the probe finds the trunk where it is, the step fails (E-04). It
    // confirms F&F; not D&F, which fills as a half-packed bottom under the top would (2 %
    // apart), and a person packing by hand may have stopped half-way: that reading narrows
    // nothing.
    let hand = protocol::StateSet::EMPTY.with(DF).with(DP).with(FF);
    for (done, found, left) in [(DF, DF, hand), (FF, FF, protocol::StateSet::single(FF))] {
        let mut r = Rig::connected_profiled(DF);
        r.keepalive();
        r.upload_and_start(Rig::plan(4, &[DF, DP]));
        r.run(1_000);
        r.plant.volume_fill = true;
        r.plant.by_hand(done);
        r.run(100);
        assert_eq!(r.request(RequestBody::ConfirmManual).0, ResultCode::Ok);
        r.run_until(5_000, |r| r.plan_done().is_some());
        assert_eq!(r.plan_done(), Some((false, found)), "{done}");
        assert_eq!(r.faults_raised(), [FaultCode::TransitionNotConfirmed]);
        let st = r.ctl.status();
        assert_eq!((st.state, st.candidates), (found, left), "{done}");
        assert_eq!(st.state_confirmed, left.only().is_some(), "{done}");
        // The probe vented what it put in.
        assert!(r.plant.p_kpa < 1.0, "{}", r.plant.p_kpa);
    }
    // A leaking trunk voids the probe: unconfirmed among what a hand can make of D&F.
    let mut r = Rig::connected(DF);
    r.keepalive();
    r.upload_and_start(Rig::plan(4, &[DF, DP]));
    r.run(1_000);
    r.plant.volume_fill = true;
    r.plant.by_hand(DP);
    r.plant.hole_per_s = 2.0;
    r.run(100);
    assert_eq!(r.request(RequestBody::ConfirmManual).0, ResultCode::Ok);
    r.run_until(20_000, |r| r.plan_done().is_some());
    assert_eq!(r.plan_done().map(|d| d.0), Some(false));
    let st = r.ctl.status();
    assert!(!st.state_confirmed);
    assert_eq!(st.candidates, hand, "{st:?}");
}

#[test]
fn a_step_without_evidence_is_assumed_unconfirmed() {
    let mut r = Rig::connected(FP);
    r.keepalive();
    let s = step(
        StepKind::Pneumatic,
        FP,
        FF,
        &[Primitive::Hold { duration_ms: 100 }],
        1_000,
    );
    r.run_step(s);
    r.run(200);
    let st = r.ctl.status();
    assert_eq!((st.state, st.state_confirmed), (FF, false));
    assert_eq!(r.ctl.poll_display()[0], display::glyph(b'F') | display::DP);
    // The next step needs a confirmed state.
    assert_eq!(
        r.request(RequestBody::RunStep(Rig::nominal(FF, DF))).0,
        ResultCode::Rejected(RejectReason::Unconfirmed)
    );
}

#[test]
fn gripper_and_bend_primitives() {
    let mut r = Rig::connected(FF);
    r.keepalive();
    let s = step(
        StepKind::Tendon,
        FF,
        FF,
        &[
            Primitive::Gripper { close: true },
            Primitive::Bend {
                direction_deg: 0.0,
                angle_deg: 20.0,
            },
        ],
        10_000,
    );
    r.run_step(s);
    r.run(100);
    assert!(r.ctl.poll_outputs().gripper_closed);
    // The bend waits for the gripper to settle (400 ms) before moving.
    assert_eq!(r.ctl.poll_outputs().servo_deg, [0.0; 3]);
    r.run_until(5_000, |r| r.plan_done().is_some()).unwrap();
    assert_eq!(r.plan_done(), Some((true, FF)));
    // Around F&F's taken-up slack (105.2 mm − the 2 mm margin): tendon 0 on the inside of
    // the bend shortens by r_t·θ = 60 mm · 0.349 = 20.94 mm more, tendons 1 and 2 pay out half
    // of that (cos 120° = −0.5).
    let o = r.ctl.poll_outputs();
    let take = r.cfg.tendon_slack_mm(FF) - r.cfg.geometry.take_up_margin_mm;
    assert!((take - 103.2).abs() < 0.1, "{take}");
    let pull = 60.0 * 20f32.to_radians();
    let want = [take + pull, take - pull / 2.0, take - pull / 2.0];
    for (i, w) in want.iter().enumerate() {
        let got = r.cfg.geometry.winch.length_for_angle(i, o.servo_deg[i]);
        assert!((got - w).abs() < 0.01, "{i}: {got} vs {w}: {o:?}");
    }
    assert!(r.ctl.status().state_confirmed);
}

/// A `Bend` runs around its state's taken-up slack, so the upload check adds the take-up of the
/// step's `from`: a bend that cannot fit there is refused at upload (`OutOfRange`), not left to
/// fail as a `ServoLimit` mid-plan. F&F takes up 103.2 mm; the 185 mm tendon limit leaves
/// r_t·θ ≤ 81.8 mm, θ ≤ 78.1° (at r_t = 60 mm).
#[test]
fn a_bend_is_checked_at_upload_around_its_steps_taken_up_slack() {
    let bend = |from: TrunkState, angle_deg: f32| {
        step(
            StepKind::Tendon,
            from,
            from,
            &[Primitive::Bend {
                direction_deg: 0.0,
                angle_deg,
            }],
            10_000,
        )
    };
    let upload = |r: &mut Rig, id: u16, steps: &[Step]| {
        r.request(RequestBody::UploadPlan(Plan {
            plan_id: id,
            steps: heapless::Vec::from_slice(steps).unwrap(),
        }))
    };
    let reject = |_| ResultCode::Rejected(RejectReason::OutOfRange);
    let mut r = Rig::connected(FF);
    let limit_deg = (r.cfg.max_tendon_mm - r.ctl.take_up_for(FF)) / r.cfg.geometry.tendon_radius_mm;
    assert!((limit_deg.to_degrees() - 78.1).abs() < 0.1, "{limit_deg}");
    // 90° (94 mm of pull alone: the old check, without the take-up, let it through).
    let (code, body) = upload(&mut r, 1, &[bend(FF, 90.0)]);
    assert_eq!(code, reject(()));
    // The tendon the bend would need passes the travel: named with its length and the limit.
    let ResponseBody::Refused(why) = body else {
        panic!("{body:?}")
    };
    assert_eq!(
        (why.step, why.field, why.limit),
        (
            Some(0),
            protocol::RefusedField::TendonLength,
            r.cfg.max_tendon_mm
        )
    );
    assert!(why.value > r.cfg.max_tendon_mm, "{why:?}");
    assert_eq!(
        r.request(RequestBody::RunStep(bend(FF, 90.0))).0,
        reject(())
    );
    // The same bend in D&D (no slack to take up) passes.
    let mut dd = Rig::connected(DD);
    assert_eq!(upload(&mut dd, 1, &[bend(DD, 90.0)]).0, ResultCode::Ok);
    // The check uses each step's own `from`, not the current state: a plan that reaches F&F
    // first is refused for its later bend.
    let mut fp = Rig::connected(FP);
    let to_ff = Rig::nominal(FP, FF);
    assert_eq!(
        upload(&mut fp, 2, &[to_ff.clone(), bend(FF, 90.0)]).0,
        reject(())
    );
    assert_eq!(
        upload(&mut fp, 3, &[to_ff, bend(FF, 20.0)]).0,
        ResultCode::Ok
    );
    // Stiff D&P bends at most 8°: refused above it at upload too.
    let mut dp = Rig::connected(DP);
    let (code, body) = upload(&mut dp, 4, &[bend(DP, 10.0)]);
    assert_eq!(code, reject(()));
    let ResponseBody::Refused(why) = body else {
        panic!("{body:?}")
    };
    assert_eq!(
        (why.field, why.value),
        (protocol::RefusedField::BendAngle, 10.0)
    );
    assert!((8.0..10.0).contains(&why.limit), "{why:?}");
    assert_eq!(upload(&mut dp, 5, &[bend(DP, 8.0)]).0, ResultCode::Ok);
    // Just inside the limit, the accepted bend runs to its end: no ServoLimit.
    r.keepalive();
    assert_eq!(
        r.request(RequestBody::RunStep(bend(FF, 77.0))).0,
        ResultCode::InProgress
    );
    r.run_until(20_000, |r| r.plan_done().is_some()).unwrap();
    assert_eq!(r.plan_done(), Some((true, FF)), "{:?}", r.faults_raised());
    let o = r.ctl.poll_outputs();
    let pulled = r.cfg.geometry.winch.length_for_angle(0, o.servo_deg[0]);
    let want = r.ctl.take_up_for(FF) + r.cfg.geometry.tendon_radius_mm * 77f32.to_radians();
    assert!((pulled - want).abs() < 0.01, "{pulled} vs {want}");
}

// ---------------------------------------------------------------------------------------------
// Safety
// ---------------------------------------------------------------------------------------------

#[test]
fn over_pressure_vents_at_once() {
    let mut r = Rig::connected(FP);
    r.plant.stuck = true;
    r.keepalive();
    // The inlet is open (an inflate) when the pressure jumps: with it closed, the same jump
    // would be a stuck inlet (tested below).
    assert_eq!(
        r.request(RequestBody::RunStep(Rig::nominal(FP, FF))).0,
        ResultCode::InProgress
    );
    r.run(100);
    assert!(r.ctl.poll_outputs().inlet_open);
    r.plant.p_kpa = 45.0;
    // On the third sample above the cap.
    let t = r
        .run_until(50, |r| r.ctl.poll_outputs().exhaust_open)
        .unwrap();
    assert_eq!(t, 3);
    assert_eq!(r.faults_raised(), [FaultCode::OverPressure]);
    assert!(!r.ctl.poll_outputs().inlet_open);
    assert_eq!(r.ctl.poll_display(), display::fault(1));
    // Still above the cap: the fault stays.
    assert_eq!(
        r.request(RequestBody::ResetFaults).0,
        ResultCode::Rejected(RejectReason::NotAllowed)
    );
    // Vents down to 5 kPa, then closes.
    r.run_until(5_000, |r| !r.ctl.poll_outputs().exhaust_open)
        .unwrap();
    assert!(
        r.plant.p_kpa <= 5.2 && r.plant.p_kpa > 3.0,
        "{}",
        r.plant.p_kpa
    );
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
    assert!(r
        .events()
        .any(|e| *e == Event::FaultCleared(FaultCode::OverPressure)));
}

#[test]
fn a_lowered_cap_caps_the_inflate_target() {
    let mut r = Rig::connected(FP);
    r.keepalive();
    r.plant.stuck = true;
    assert_eq!(
        r.request(RequestBody::UploadPlan(Rig::plan(1, &[FP, FF])))
            .0,
        ResultCode::Ok
    );
    // Lowering the cap below the uploaded target: the start re-validates.
    r.request(RequestBody::SetParam {
        id: ParamId::PressureLimitKpa,
        value: 12.0,
    });
    assert_eq!(
        r.request(RequestBody::StartPlan { plan_id: 1 }).0,
        ResultCode::Rejected(RejectReason::OutOfRange)
    );
    // A step within the cap, and the cap lowered while it runs: never above the cap.
    r.request(RequestBody::SetParam {
        id: ParamId::PressureLimitKpa,
        value: 40.0,
    });
    let s = step(
        StepKind::Pneumatic,
        FP,
        FF,
        &[Primitive::Inflate {
            pressure_kpa: 30.0,
            snaps: 1,
        }],
        20_000,
    );
    r.run_step(s);
    r.run(500);
    r.request(RequestBody::SetParam {
        id: ParamId::PressureLimitKpa,
        value: 12.0,
    });
    let mut max_p: f32 = 0.0;
    for _ in 0..3_000 {
        r.run(1);
        max_p = max_p.max(r.plant.p_kpa);
    }
    assert!(max_p < 12.0, "{max_p}");
}

#[test]
fn pressure_sensor_dropout_faults_and_vents() {
    let mut r = Rig::connected(FP);
    r.keepalive();
    r.request(RequestBody::RunStep(Rig::nominal(FP, FF)));
    r.run(300);
    assert!(r.ctl.poll_outputs().inlet_open);
    r.raw_override = Some(0);
    let t = r.run_until(100, |r| r.ctl.mode() == Mode::Safe).unwrap();
    assert!((19..=21).contains(&t), "{t}");
    assert_eq!(r.faults_raised(), [FaultCode::PressureSensor]);
    let o = r.ctl.poll_outputs();
    assert!(!o.inlet_open && o.exhaust_open);
    assert_eq!(
        r.request(RequestBody::ResetFaults).0,
        ResultCode::Rejected(RejectReason::NotAllowed)
    );
    // Short glitches at the rail (under 20 ms) are not a fault.
    r.raw_override = None;
    r.run(100);
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    r.raw_override = Some(crate::ADC_MAX);
    r.run(15);
    r.raw_override = None;
    r.run(100);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
}

#[test]
fn estop_latches_until_released_and_reset() {
    let mut r = Rig::connected(DD);
    r.keepalive();
    r.upload_and_start(Rig::plan(1, &[DD, FD]));
    r.run(400);
    let mid = r.ctl.poll_outputs().servo_deg;
    r.buttons.estop = true;
    r.run(1);
    assert_eq!(r.ctl.mode(), Mode::EStop);
    assert_eq!(r.ctl.poll_display(), display::fault(6));
    r.run(1_000);
    let o = r.ctl.poll_outputs();
    assert!(
        (o.servo_deg[0] - mid[0]).abs() < 0.2,
        "frozen: {:?} {mid:?}",
        o.servo_deg
    );
    assert!(!o.inlet_open && !o.exhaust_open);
    assert!(r.ctl.status().estop);
    // Reset refused while pressed; plans refused while latched.
    assert_eq!(
        r.request(RequestBody::ResetFaults).0,
        ResultCode::Rejected(RejectReason::NotAllowed)
    );
    r.press(|b, v| b.confirm = v);
    assert_eq!(r.ctl.mode(), Mode::EStop);
    r.buttons.estop = false;
    r.run(10);
    assert_eq!(
        r.request(RequestBody::RunStep(Rig::nominal(DD, FD))).0,
        ResultCode::Rejected(RejectReason::EStopLatched)
    );
    // Released: the confirm button resets it (standalone, no host needed).
    r.press(|b, v| b.confirm = v);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
    assert!(!r.ctl.status().estop);
}

#[test]
fn link_loss_aborts_a_host_plan_only() {
    let mut r = Rig::connected(DD);
    let s = step(
        StepKind::Tendon,
        DD,
        DD,
        &[Primitive::Hold {
            duration_ms: 10_000,
        }],
        20_000,
    );
    r.run_step(s);
    let t0 = r.now;
    r.run_until(5_000, |r| r.ctl.mode() == Mode::Safe).unwrap();
    assert_eq!(r.now - t0, protocol::DEFAULT_LINK_TIMEOUT_MS as u64);
    assert_eq!(r.faults_raised(), [FaultCode::LinkLoss]);
    assert_eq!(
        r.ctl.status().plan.unwrap().phase,
        PlanPhase::Failed(FaultCode::LinkLoss)
    );
    // With heartbeats the same plan runs to its end.
    let mut r = Rig::connected(DD);
    r.keepalive();
    r.upload_and_start(Rig::plan(1, &[DD, FD]));
    r.run_until(10_000, |r| r.plan_done().is_some()).unwrap();
    assert_eq!(r.plan_done(), Some((true, FD)));
    // A standalone step needs no host.
    let mut r = Rig::connected(DD);
    r.press(|b, v| b.down = v);
    r.run_until(10_000, |r| r.ctl.mode() == Mode::Standalone)
        .unwrap();
    assert_eq!(r.ctl.status().state, FD);
    assert!(r.faults_raised().is_empty());
}

/// From F&F: inflate to 8 kPa (no snap), then `then` sealed.
fn sealed_at_8_kpa(to: TrunkState, then: Primitive) -> Step {
    let inflate = Primitive::Inflate {
        pressure_kpa: 8.0,
        snaps: 0,
    };
    step(StepKind::Pneumatic, FF, to, &[inflate, then], 20_000)
}

#[test]
fn leak_is_detected_while_holding_sealed() {
    let five_s = Primitive::Hold { duration_ms: 5_000 };
    let hold = |r: &mut Rig| {
        r.run_step(sealed_at_8_kpa(FF, five_s));
        r.run_until(8_000, |r| r.plan_done().is_some()).unwrap();
    };
    // The trunk's own small leak (0.5 kPa/s) is within the allowance; the regulator tops it up.
    let mut r = Rig::connected(FF);
    r.keepalive();
    r.plant.stuck = true;
    r.plant.leak_kpa_per_s = 0.5;
    hold(&mut r);
    assert_eq!(r.plan_done(), Some((true, FF)));
    assert!(r.faults_raised().is_empty());
    // A torn trunk (4 kPa/s) is a Leak.
    let mut r = Rig::connected(FF);
    r.keepalive();
    r.plant.stuck = true;
    hold(&mut r);
    r.plant.leak_kpa_per_s = 0.0;
    let mut r2 = Rig::connected(FF);
    r2.keepalive();
    r2.plant.stuck = true;
    r2.run_step(sealed_at_8_kpa(FF, five_s));
    r2.run(1_500);
    r2.plant.leak_kpa_per_s = 4.0;
    r2.run_until(3_000, |r| r.ctl.mode() == Mode::Safe).unwrap();
    assert_eq!(r2.faults_raised(), [FaultCode::Leak]);
    assert_eq!(r2.ctl.poll_display(), display::fault(8));
    assert_eq!(r.plan_done(), Some((true, FF)));
}

#[test]
fn snap_while_holding_sealed_is_not_a_leak() {
    // A pressure step of −3 kPa while sealed and still: the snap detector claims it.
    let mut r = Rig::connected(FF);
    r.keepalive();
    r.plant.stuck = true;
    r.run_step(sealed_at_8_kpa(
        DF,
        Primitive::WaitSnap { timeout_ms: 5_000 },
    ));
    r.run(2_000);
    r.plant.p_kpa -= 3.0;
    r.run_until(3_000, |r| r.plan_done().is_some()).unwrap();
    assert_eq!(r.plan_done(), Some((true, DF)));
    assert!(r.faults_raised().is_empty(), "{:?}", r.faults_raised());
}

#[test]
fn servo_slew_and_limits() {
    let mut r = Rig::connected(DD);
    r.keepalive();
    // Slew limit: 90 °/s → at most 0.09° per 1 ms tick.
    r.request(RequestBody::RunStep(Rig::nominal(DD, FD)));
    let mut last = r.ctl.poll_outputs().servo_deg[0];
    let mut max_step: f32 = 0.0;
    for _ in 0..500 {
        r.run(1);
        let d = r.ctl.poll_outputs().servo_deg[0];
        max_step = max_step.max((d - last).abs());
        last = d;
    }
    assert!(max_step <= 0.0901, "{max_step}");
    assert!(max_step >= 0.089, "{max_step}");
    r.run_until(10_000, |r| r.plan_done().is_some()).unwrap();
    // Limits lowered while a plan runs: the next pull beyond them is a ServoLimit fault.
    let mut r = Rig::connected(FD);
    r.keepalive();
    r.upload_and_start(Rig::plan(2, &[FD, DD, FD]));
    r.run(200);
    let (res, body) = r.request(RequestBody::SetParam {
        id: ParamId::ServoMaxDeg,
        value: 50.0,
    });
    assert_eq!(
        (res, body),
        (
            ResultCode::Ok,
            ResponseBody::Param {
                id: ParamId::ServoMaxDeg,
                value: 50.0
            }
        )
    );
    r.run_until(20_000, |r| r.plan_done().is_some()).unwrap();
    assert_eq!(r.faults_raised(), [FaultCode::ServoLimit]);
    assert_eq!(r.ctl.status().state, DD);
    assert!(r.ctl.poll_outputs().servo_deg.iter().all(|d| *d <= 50.0));
}

#[test]
fn parameters_have_ranges() {
    let mut r = Rig::connected(FP);
    for id in ParamId::ALL {
        let (res, body) = r.request(RequestBody::GetParam(id));
        assert_eq!(res, ResultCode::Ok);
        let ResponseBody::Param { value, .. } = body else {
            panic!()
        };
        assert!(id.accepts(value), "{id:?} = {value}");
    }
    let rejected = ResultCode::Rejected(RejectReason::OutOfRange);
    for (id, v) in [
        (ParamId::PressureLimitKpa, 61.0),
        (ParamId::PressureLimitKpa, f32::NAN),
        (ParamId::TelemetryHz, -1.0),
        (ParamId::LinkTimeoutMs, 10.0),
        (ParamId::ServoMinDeg, 181.0),
    ] {
        assert_eq!(
            r.request(RequestBody::SetParam { id, value: v }).0,
            rejected,
            "{id:?}"
        );
    }
    r.request(RequestBody::SetParam {
        id: ParamId::ServoMaxDeg,
        value: 90.0,
    });
    assert_eq!(
        r.request(RequestBody::SetParam {
            id: ParamId::ServoMinDeg,
            value: 100.0
        })
        .0,
        rejected
    );
    r.request(RequestBody::SetParam {
        id: ParamId::PressureLimitKpa,
        value: 30.0,
    });
    let (_, body) = r.request(RequestBody::hello());
    let ResponseBody::Hello(info) = body else {
        panic!()
    };
    assert_eq!(info.trunk.pressure_limit_kpa, 30.0);
}

// ---------------------------------------------------------------------------------------------
// Periodic events
// ---------------------------------------------------------------------------------------------

#[test]
fn telemetry_and_heartbeat_rates() {
    let mut r = Rig::connected(FP);
    r.request(RequestBody::SetParam {
        id: ParamId::TelemetryHz,
        value: 20.0,
    });
    r.log.clear();
    r.run(2_000);
    let telemetry = r
        .events()
        .filter(|e| matches!(e, Event::Telemetry(_)))
        .count();
    let heartbeats = r
        .events()
        .filter(|e| matches!(e, Event::Heartbeat { .. }))
        .count();
    assert!((40..=41).contains(&telemetry), "{telemetry}");
    assert!((4..=5).contains(&heartbeats), "{heartbeats}");
    r.request(RequestBody::SetParam {
        id: ParamId::TelemetryHz,
        value: 0.0,
    });
    r.log.clear();
    r.run(1_000);
    assert_eq!(
        r.events()
            .filter(|e| matches!(e, Event::Telemetry(_)))
            .count(),
        0
    );
    // Progress while a step runs: at most every 100 ms.
    r.request(RequestBody::SetParam {
        id: ParamId::TelemetryHz,
        value: 50.0,
    });
    r.keepalive();
    r.request(RequestBody::RunStep(Rig::nominal(FP, FF)));
    r.log.clear();
    r.run(1_000);
    let progress: StdVec<u64> = r
        .log
        .iter()
        .filter(|(_, _, ev)| matches!(ev, SessionEvent::Device(Event::StepProgress { .. })))
        .map(|(t, _, _)| *t)
        .collect();
    assert!((9..=11).contains(&progress.len()), "{progress:?}");
    assert!(progress
        .windows(2)
        .all(|w| w[1] - w[0] >= PROGRESS_PERIOD_MS));
}

#[test]
fn no_events_before_the_handshake() {
    let mut r = Rig::new(FP);
    r.run(2_000);
    assert!(r.log.is_empty());
    assert_eq!(r.host().stats().frames_rx, 0);
}

#[test]
fn deadline_follows_activity() {
    let mut r = Rig::new(FP);
    r.run(10);
    assert_eq!(r.ctl.poll_deadline(), r.now + 1_000);
    r.connect();
    r.run(1);
    // Next telemetry (10 Hz) or heartbeat.
    assert!(r.ctl.poll_deadline() <= r.now + 100);
    r.request(RequestBody::RunStep(Rig::nominal(FP, FF)));
    r.run(1);
    assert_eq!(r.ctl.poll_deadline(), r.now + 10);
}

// ---------------------------------------------------------------------------------------------
// Standalone
// ---------------------------------------------------------------------------------------------

#[test]
fn step_buttons_follow_the_nominal_transitions() {
    let mut r = Rig::new(FP);
    r.press(|b, v| b.up = v);
    assert_eq!(r.ctl.mode(), Mode::Running);
    r.run_until(10_000, |r| r.ctl.mode() == Mode::Standalone)
        .unwrap();
    assert_eq!(r.ctl.status().state, FF);
    r.press(|b, v| b.up = v);
    r.run_until(10_000, |r| r.ctl.mode() == Mode::Standalone)
        .unwrap();
    assert_eq!(r.ctl.status().state, DF);
    r.press(|b, v| b.down = v);
    r.run_until(10_000, |r| r.ctl.mode() == Mode::Standalone)
        .unwrap();
    assert_eq!((r.ctl.status().state, r.plant.state), (FF, FF));
    assert_eq!(
        r.stores
            .iter()
            .filter(|s| s.confirmed)
            .map(|s| s.state)
            .collect::<StdVec<_>>(),
        [FF, DF, FF]
    );
    // Each step was journaled ahead of its motion.
    assert_eq!(r.stores.iter().filter(|s| s.pending.is_some()).count(), 3);
    // No step down from F&P's neighbour's end: F&P has no tendon transition.
    let mut r = Rig::new(FP);
    r.press(|b, v| b.down = v);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
    // A glitch shorter than the debounce is not a press.
    r.buttons.up = true;
    r.run(5);
    r.buttons.up = false;
    r.run(50);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
}

#[test]
fn joystick_bends_only_flexible_states() {
    let cfg = CraneConfig::default();
    // D&D is not flexible: the joystick does nothing.
    let mut r = Rig::new(DD);
    r.joystick = [
        cfg.joystick.center_raw[0] + 8_000,
        cfg.joystick.center_raw[1],
    ];
    r.run(1_000);
    assert_eq!(r.ctl.poll_outputs().servo_deg, [0.0; 3]);
    // F&F: full +x deflection bends toward tendon 0 by the maximum bend (30°), around the
    // state's taken-up slack (F&F hangs 105.2 mm slack; taken up to 2 mm short of taut).
    let mut r = Rig::new(FF);
    r.joystick = [
        cfg.joystick.center_raw[0] + 8_000,
        cfg.joystick.center_raw[1],
    ];
    r.run(3_000);
    let lengths = |r: &Rig| {
        let o = r.ctl.poll_outputs();
        [0, 1, 2].map(|i| cfg.geometry.winch.length_for_angle(i, o.servo_deg[i]))
    };
    let near = |got: [f32; 3], want: [f32; 3]| {
        assert!(
            got.iter().zip(want).all(|(g, w)| (g - w).abs() < 0.05),
            "{got:?} vs {want:?}"
        );
    };
    let take = cfg.tendon_slack_mm(FF) - cfg.geometry.take_up_margin_mm;
    let pull0 = cfg.geometry.tendon_radius_mm * 30f32.to_radians();
    near(
        lengths(&r),
        [take + pull0, take - pull0 / 2.0, take - pull0 / 2.0],
    );
    // Inside the dead zone: straight again, the slack still taken up.
    r.joystick = [cfg.joystick.center_raw[0] + 400, cfg.joystick.center_raw[1]];
    r.run(2_000);
    near(lengths(&r), [take; 3]);
    // +y: between tendons 1 (120°) and 0; tendon 1 pulls r·θ·cos(30°), tendon 2 pays out as
    // much, tendon 0 (90° off) stays.
    r.joystick = [
        cfg.joystick.center_raw[0],
        cfg.joystick.center_raw[1] + 8_000,
    ];
    r.run(2_000);
    let c30 = 30f32.to_radians().cos();
    near(lengths(&r), [take, take + pull0 * c30, take - pull0 * c30]);
    // The take-up follows the state (computed at the state change): D&F hangs 45.6 mm slack.
    let mut r = Rig::new(DF);
    r.joystick = [
        cfg.joystick.center_raw[0] + 8_000,
        cfg.joystick.center_raw[1],
    ];
    r.run(2_000);
    let take_df = cfg.tendon_slack_mm(DF) - cfg.geometry.take_up_margin_mm;
    assert!((take_df - 43.6).abs() < 0.1, "{take_df}");
    near(
        lengths(&r),
        [
            take_df + pull0,
            take_df - pull0 / 2.0,
            take_df - pull0 / 2.0,
        ],
    );
    // Step up from a bent trunk releases the tendons first (a held tendon would stop the
    // pop-out), then inflates.
    let mut r = Rig::new(FF);
    r.joystick = [
        cfg.joystick.center_raw[0],
        cfg.joystick.center_raw[1] + 8_000,
    ];
    r.run(2_000);
    assert!(r.plant.pulled_mm > 90.0, "{}", r.plant.pulled_mm);
    r.press(|b, v| b.up = v);
    r.run_until(20_000, |r| r.ctl.mode() == Mode::Standalone)
        .unwrap();
    assert_eq!(r.ctl.status().state, DF);
    assert!(r.faults_raised().is_empty());
}

#[test]
fn gripper_button_toggles_when_idle() {
    let mut r = Rig::new(FF);
    assert!(r.ctl.poll_outputs().gripper_closed, "boots closed");
    r.press(|b, v| b.gripper = v);
    assert!(!r.ctl.poll_outputs().gripper_closed);
    r.press(|b, v| b.gripper = v);
    assert!(r.ctl.poll_outputs().gripper_closed);
}

/// A reset of a crane that holds a load (watchdog, brown-out: any boot, whatever the record)
/// boots with the gripper closed, and it stays closed through the first passes.
#[test]
fn the_gripper_boots_closed_from_any_record() {
    let cfg = CraneConfig::default();
    for boot in [
        BootRecord::Empty,
        BootRecord::Corrupt,
        BootRecord::Stored(StoredState::confirmed(DF)),
    ] {
        let mut c = Controller::new(cfg, boot, 0);
        c.report_watchdog_reset();
        let rest = Inputs::at_rest(&cfg);
        for now in 0..200 {
            c.handle_inputs(&rest, now);
            c.handle_time(now);
            assert!(c.poll_outputs().gripper_closed, "{boot:?} at {now} ms");
        }
    }
}

#[test]
fn display_shows_pressure_on_request() {
    let mut r = Rig::new(FP);
    r.plant.p_kpa = 8.3;
    r.buttons.show_pressure = true;
    r.run(100);
    let seg = r.ctl.poll_display();
    // 8.3 ± the noise: " 8.2"–" 8.4".
    assert_eq!(&seg[..3], &[0, 0, display::glyph(b'8') | display::DP]);
    assert!(
        [b'2', b'3', b'4']
            .iter()
            .any(|&d| seg[3] == display::glyph(d)),
        "{seg:?}"
    );
    r.buttons.show_pressure = false;
    r.run(1);
    assert_eq!(r.ctl.poll_display(), display::text("F-P "));
}

/// The upload check's two comparisons (`equal_pull_range`) accept exactly the shortenings
/// `angles_for` accepts on all three servos, at and around both ends (every float within 4 ulp)
/// and across the range, for servos mounted either way, narrow, single-angle and unreachable
/// limits.
#[test]
fn the_equal_pull_range_is_exactly_where_angles_for_succeeds() {
    let mut cfgs = StdVec::<CraneConfig>::new();
    let base = CraneConfig::default();
    cfgs.push(base);
    let mut c = base;
    c.geometry.winch.pull_sign = [-1.0, 1.0, -1.0];
    c.geometry.winch.slack_deg = [180.0, 0.0, 175.0];
    cfgs.push(c);
    let mut c = base;
    c.servo.min_deg = 10.0;
    c.servo.max_deg = 20.0;
    c.geometry.winch.slack_deg = [12.0, 11.0, 15.0];
    cfgs.push(c);
    // Tendon 1 needs ≥ 10.5 mm to reach 10°, tendon 0 allows ≤ 8.4 mm: nothing.
    c.geometry.winch.slack_deg = [12.0, 0.0, 15.0];
    cfgs.push(c);
    let mut c = base;
    c.servo.min_deg = 90.0;
    c.servo.max_deg = 90.0;
    cfgs.push(c);
    let mut c = base;
    c.servo.min_deg = 170.0;
    c.servo.max_deg = 180.0;
    c.max_tendon_mm = 20.0;
    cfgs.push(c);
    let mut c = base;
    c.geometry.winch.spool_radius_mm = 7.3;
    c.geometry.winch.slack_deg = [3.3, 41.0, 0.7];
    cfgs.push(c);
    for (k, cfg) in cfgs.iter().enumerate() {
        let cfg = cfg.validated();
        let (lo, hi) = equal_pull_range(&cfg);
        let check = |l: f32| {
            let want = angles_for(&cfg, [l; 3]).is_some();
            assert_eq!(
                lo <= l && l <= hi,
                want,
                "config {k}: {l} (range {lo}..={hi})"
            );
        };
        let near = |x: f32| {
            let mut v = x;
            for _ in 0..4 {
                v = v.next_down();
            }
            for _ in 0..9 {
                check(v);
                v = v.next_up();
            }
        };
        for x in [lo, hi, 0.0, -0.0, cfg.max_tendon_mm] {
            if x.is_finite() {
                near(x);
            }
        }
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0, 1e30] {
            check(x);
        }
        for i in 0..=20_000 {
            check(-5.0 + (cfg.max_tendon_mm + 10.0) * i as f32 / 20_000.0);
        }
        if k == 5 {
            assert!(lo > hi, "config {k}: nothing reachable, {lo}..={hi}");
        } else if k != 3 {
            // (3: a single angle, 90°, may be hit by no float at all.)
            assert!(lo <= hi, "config {k}: {lo}..={hi}");
        }
    }
}

#[test]
fn tendon_direction_table_is_the_geometry_crates() {
    for ((sin_i, cos_i), phi) in TENDON_DIRECTIONS
        .iter()
        .zip(geometry::tendon::TENDON_ANGLES)
    {
        assert!((f64::from(*sin_i) - phi.sin()).abs() < 1e-7, "{phi}");
        assert!((f64::from(*cos_i) - phi.cos()).abs() < 1e-7, "{phi}");
    }
}

/// A `Bend`'s tendon shortenings in `f32` (`bend_lengths`: the direction reduced in degrees,
/// then the Cephes kernels of `mathf`) against `geometry::tendon`'s `f64` law, around D&D (no
/// take-up), over every whole degree of direction, several turns either way and far out.
#[test]
fn bend_lengths_match_the_geometry_crate_for_any_direction() {
    let r = Rig::connected(DD);
    let tg = geometry::tendon::TendonGeometry::new(r.cfg.geometry.tendon_radius_mm as f64).unwrap();
    let mut worst: f64 = 0.0;
    let far = [1.0e6f32, -3.6e7 + 45.0, 3.0e38];
    for dir in (-1080..=1080).map(|d| d as f32).chain(far) {
        for angle_deg in [1.0f32, 10.0, 30.0] {
            let got = r.ctl.bend_lengths(dir, angle_deg.to_radians()).unwrap();
            let reduced = f64::from(dir % 360.0).to_radians();
            let bend = geometry::tendon::Bend {
                direction: reduced.rem_euclid(std::f64::consts::TAU),
                angle: f64::from(angle_deg).to_radians(),
            };
            let dl = tg.length_changes(bend);
            for k in 0..3 {
                // Shortening = −Δl, never below 0 (a tendon cannot push).
                let want = (-dl[k]).max(0.0);
                worst = worst.max((f64::from(got[k]) - want).abs());
            }
        }
    }
    assert!(worst < 1e-4, "{worst} mm");
    assert_eq!(r.ctl.bend_lengths(f32::NAN, 0.1), None);
}

#[test]
fn joystick_twin_matches_the_geometry_crate() {
    let cfg = CraneConfig::default();
    let jc = cfg.joystick;
    let max_deg = cfg.geometry.max_bend_deg;
    let map =
        geometry::tendon::JoystickMap::new((max_deg as f64).to_radians(), jc.dead_zone as f64)
            .unwrap();
    let tg = geometry::tendon::TendonGeometry::new(cfg.geometry.tendon_radius_mm as f64).unwrap();
    let mut worst: f64 = 0.0;
    for i in -20..=20 {
        for j in -20..=20 {
            let (x, y) = (i as f32 / 16.0, j as f32 / 16.0); // beyond ±1 too (clamped)
            let ours =
                joystick_lengths_f32(x, y, jc.dead_zone, max_deg, cfg.geometry.tendon_radius_mm);
            let dl = tg.length_changes(map.bend(x as f64, y as f64));
            for k in 0..3 {
                worst = worst.max((ours[k] as f64 + dl[k]).abs());
            }
        }
    }
    assert!(worst < 0.01, "{worst} mm");
    assert_eq!(
        joystick_lengths_f32(f32::NAN, 0.0, jc.dead_zone, max_deg, 60.0),
        [0.0; 3]
    );
}

#[test]
fn an_assumed_state_stops_the_next_step_of_a_plan() {
    let mut r = Rig::connected(FF);
    r.keepalive();
    // Step 0 reaches D&F without evidence (assumed); step 1 needs a confirmed D&F.
    let mut steps = heapless::Vec::new();
    steps
        .push(step(
            StepKind::Pneumatic,
            FF,
            DF,
            &[Primitive::Hold { duration_ms: 50 }],
            1_000,
        ))
        .unwrap();
    steps.push(Rig::nominal(DF, DD)).unwrap();
    r.upload_and_start(Plan { plan_id: 9, steps });
    r.run(200);
    assert_eq!(r.plan_done(), Some((false, DF)));
    assert_eq!(r.faults_raised(), [FaultCode::TransitionNotConfirmed]);
    let done: StdVec<_> = r
        .events()
        .filter_map(|e| match e {
            Event::StepDone { step, ok, .. } => Some((*step, *ok)),
            _ => None,
        })
        .collect();
    assert_eq!(done, [(0, true), (1, false)]);
    assert_eq!(r.plant.p_kpa, 0.0, "step 1 never inflated");
}

// ---------------------------------------------------------------------------------------------
// Stalled inflation (the rise watch, docs/firmware.md "Safety")
// ---------------------------------------------------------------------------------------------

/// Runs the nominal F&P → F&F step (inflate to 16 kPa for one snap) on `r`; returns the time
/// from its start to the first fault, with the fault, the filtered pressure then and the
/// outputs then.
fn inflate_until_fault(r: &mut Rig) -> (u64, FaultCode, f32, Outputs) {
    r.keepalive();
    r.upload_and_start(Rig::plan(5, &[FP, FF]));
    let t0 = r.now;
    r.run_until(30_000, |r| !r.faults_raised().is_empty())
        .expect("a fault before the step's time limit");
    (
        r.now - t0,
        r.faults_raised()[0],
        r.ctl.pressure_kpa(),
        r.ctl.poll_outputs(),
    )
}

#[test]
fn a_leak_the_supply_cannot_beat_is_named_leak_at_the_documented_time() {
    // The hole takes 2.5 p per second: the 10 kPa/s inlet plateaus at 4 kPa (time constant
    // 0.4 s), far below the 10 kPa snap. p(t) − p(t − 3 s) = 4·e^(−t/0.4)·(e^(3/0.4) − 1)
    // falls below 0.5 kPa at t = 3 s + 0.4 s·ln 8 = 3.83 s; the watch samples every 100 ms.
    let mut r = Rig::connected(FP);
    r.plant.hole_per_s = 2.5;
    let (t, code, p, out) = inflate_until_fault(&mut r);
    assert_eq!(code, FaultCode::Leak);
    assert!((3_830..=4_000).contains(&t), "{t} ms");
    assert!((p - 4.0).abs() < 0.3, "{p} kPa");
    assert_eq!(r.faults_raised(), [FaultCode::Leak]);
    // The existing safe state: inlet and exhaust closed, servos limp, state unchanged.
    assert!(!out.inlet_open && !out.exhaust_open && !out.servos_enabled);
    // 4 kPa is at the bound under which nothing snaps whatever the trunk (belief::UNTOUCHED_KPA):
    // unconfirmed, F&P the guess.
    let s = r.ctl.status();
    assert_eq!(
        (s.state, s.state_confirmed, s.mode),
        (FP, false, Mode::Safe)
    );
    assert!(s.candidates.contains(FP), "{s:?}");
    assert_eq!(s.plan.unwrap().phase, PlanPhase::Failed(FaultCode::Leak));
    assert_eq!(r.plan_done(), Some((false, FP)));
    assert_eq!(r.ctl.poll_display(), display::fault(8));
    // Cleared by a reset (the cause is a trunk that needs mending, not a live hazard).
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
}

#[test]
fn an_inlet_that_never_opens_is_no_pressure_rise_after_one_window() {
    // Stuck closed or no supply: the pressure stays at 0 ± 0.1 kPa. The window is full 3 s
    // after the inlet was commanded open (one control pass after the step started).
    let mut r = Rig::connected(FP);
    r.plant.inlet_blocked = true;
    let (t, code, p, out) = inflate_until_fault(&mut r);
    assert_eq!(code, FaultCode::NoPressureRise);
    assert!((3_000..=3_010).contains(&t), "{t} ms");
    assert!(p.abs() < 0.2, "{p} kPa");
    assert!(!out.inlet_open && !out.exhaust_open && !out.servos_enabled);
    assert_eq!(r.ctl.status().state, FP);
    assert_eq!(r.plan_done(), Some((false, FP)));
    assert_eq!(r.ctl.poll_display(), display::fault(12));
    // A supply that comes back after a reset: the same step now succeeds.
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    r.plant.inlet_blocked = false;
    r.log.clear();
    r.upload_and_start(Rig::plan(6, &[FP, FF]));
    r.run_until(10_000, |r| r.plan_done().is_some()).unwrap();
    assert_eq!(r.plan_done(), Some((true, FF)));
    assert!(r.faults_raised().is_empty());
}

#[test]
fn a_slow_but_steady_rise_is_not_a_stall() {
    // A supply 10× slower than the nominal 10 kPa/s gains 3 kPa per 3 s window, six times the
    // 0.5 kPa the watch asks for: both inflates reach their snaps, in ≈ 30 s.
    let mut r = Rig::connected(FP);
    r.keepalive();
    r.plant.inlet_kpa_per_s = 1.0;
    r.upload_and_start(Rig::plan(5, &[FP, FF, DF]));
    let took = r
        .run_until(60_000, |r| r.plan_done().is_some())
        .expect("plan finishes");
    assert_eq!(r.plan_done(), Some((true, DF)));
    assert!(r.faults_raised().is_empty());
    // 10 kPa then 18 kPa at 1 kPa/s, plus the vents.
    assert!((28_000..40_000).contains(&took), "{took}");
    // Around the threshold: 0.2 kPa/s (0.6 kPa per window) keeps going; 0.15 kPa/s (0.45 kPa
    // per window) is a stall at the first full window, still within the 1 kPa ambient band:
    // NoPressureRise.
    let mut r = Rig::connected(FP);
    r.keepalive();
    r.plant.inlet_kpa_per_s = 0.2;
    r.upload_and_start(Rig::plan(5, &[FP, FF]));
    r.run(10_000);
    assert!(r.faults_raised().is_empty());
    assert_eq!(r.ctl.mode(), Mode::Running);
    let mut r = Rig::connected(FP);
    r.plant.inlet_kpa_per_s = 0.15;
    let (t, code, p, _) = inflate_until_fault(&mut r);
    assert_eq!(code, FaultCode::NoPressureRise);
    assert!((3_000..=3_010).contains(&t), "{t} ms");
    assert!((p - 0.45).abs() < 0.15, "{p} kPa");
}

#[test]
fn a_leak_while_the_regulator_holds_is_named_leak() {
    // The regulator holds 2.5 kPa (below the sealed leak check's 3 kPa floor); then a hole
    // opens that the inlet can only hold at 2 kPa (10 kPa/s against 5 p per second): the
    // inlet stays open, the pressure stalls at 2 kPa, above the ambient band.
    let mut r = Rig::connected(FP);
    r.keepalive();
    let s = step(
        StepKind::Pneumatic,
        FP,
        FP,
        &[
            Primitive::Inflate {
                pressure_kpa: 2.5,
                snaps: 0,
            },
            Primitive::Hold {
                duration_ms: 20_000,
            },
        ],
        30_000,
    );
    r.run_step(s);
    r.run(2_000);
    assert!(r.faults_raised().is_empty());
    r.plant.hole_per_s = 5.0;
    let t0 = r.now;
    r.run_until(10_000, |r| !r.faults_raised().is_empty())
        .unwrap();
    assert_eq!(r.faults_raised(), [FaultCode::Leak]);
    // The inlet reopens once the pressure is 1 kPa under the target (a few ms), then the
    // pressure settles at 2 kPa within ≈ 0.5 s: the window closes 3 s after that.
    assert!((3_000..=4_000).contains(&(r.now - t0)), "{}", r.now - t0);
    assert!((r.ctl.pressure_kpa() - 2.0).abs() < 0.2);
}

// ---------------------------------------------------------------------------------------------
// Sessions: binding, takeover, replay
// ---------------------------------------------------------------------------------------------

/// The reason a handshake was refused for (`None`: it succeeded, or failed otherwise).
fn refusal(hello: &Result<DeviceInfo, SessionError>) -> Option<RejectReason> {
    match hello {
        Err(SessionError::Rejected { reason, .. }) => Some(*reason),
        _ => None,
    }
}

#[test]
fn a_live_session_refuses_a_second_hello_and_a_takeover_is_explicit() {
    let mut r = Rig::connected(FF);
    let first = r.session();
    r.keepalive();
    r.run(500);
    // A second host while the first is live: refused, and not told the session in force.
    let (b, hello) = r.join(false);
    assert_eq!(
        refusal(&hello),
        Some(RejectReason::SessionBusy),
        "{hello:?}"
    );
    assert_eq!(r.hosts[b].device().map(|info| info.session), Some(0));
    // The first host goes on working.
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    // An explicit takeover opens a new session ...
    let (c, hello) = r.join(true);
    let second = hello.expect("taken over").session;
    assert!(second != 0 && second != first);
    // ... and the first host's next state-changing request is refused.
    assert_eq!(
        r.request(RequestBody::DeclareState(FD)).0,
        ResultCode::Rejected(RejectReason::NotSessionOwner)
    );
    assert_eq!(
        r.request(RequestBody::Heartbeat).0,
        ResultCode::Rejected(RejectReason::NotSessionOwner)
    );
    assert_eq!(r.ctl.status().state, FF, "nothing changed");
    // Status and parameters are answered for anyone.
    assert_eq!(r.request(RequestBody::GetStatus).0, ResultCode::Ok);
    assert_eq!(
        r.request(RequestBody::GetParam(ParamId::LinkTimeoutMs)).0,
        ResultCode::Ok
    );
    // The new owner is obeyed.
    assert_eq!(
        r.request_from(c, RequestBody::DeclareState(FD)).0,
        ResultCode::Ok
    );
    assert_eq!(r.ctl.status().state, FD);
}

#[test]
fn a_silent_owner_frees_the_crane_after_the_link_timeout_and_close_frees_it_at_once() {
    let mut r = Rig::connected(FF);
    r.run(r.cfg.link_timeout_ms as u64 - 10);
    let (_, hello) = r.join(false);
    assert_eq!(
        refusal(&hello),
        Some(RejectReason::SessionBusy),
        "{hello:?}"
    );
    r.run(20);
    let (_, hello) = r.join(false);
    assert!(
        hello.is_ok(),
        "the owner was silent for the link timeout: {hello:?}"
    );
    // A host that closes its session frees the crane at once.
    let mut r = Rig::connected(FF);
    assert_eq!(r.request(RequestBody::Close).0, ResultCode::Ok);
    let (_, hello) = r.join(false);
    assert!(hello.is_ok(), "{hello:?}");
}

#[test]
fn a_close_whose_answer_is_lost_is_resent_and_frees_the_crane_for_the_next_host_at_once() {
    // Fire and forget: a Close lost on the way keeps the session live, and the next host is
    // refused until the link timeout, unless it takes over explicitly.
    let mut r = Rig::connected(FF);
    r.line_fault = Some(LineFault::CorruptToDevice);
    r.host().close();
    r.exchange();
    let (_, hello) = r.join(false);
    assert_eq!(
        refusal(&hello),
        Some(RejectReason::SessionBusy),
        "{hello:?}"
    );
    let (_, hello) = r.join(true);
    assert!(hello.is_ok(), "an explicit takeover is allowed: {hello:?}");
    // Confirmed: the device closes the session, its answer is lost, and the resend (same
    // seq) is answered from the cache: one close, one answer reaching the host.
    let mut r = Rig::connected(FF);
    let frames_before = r.ctl.status().frames_rx;
    r.line_fault = Some(LineFault::LoseToHost);
    let now = r.now;
    let id = r
        .host()
        .close_confirmed(4, now)
        .expect("the session is open");
    r.exchange();
    assert!(!r.lost.is_empty(), "the answer was lost");
    assert_eq!(r.reply(id), None);
    assert!(!r.host().is_closed(), "still waiting for the answer");
    let waited = r
        .run_until(1_000, |r| r.reply(id).is_some())
        .expect("the resend is answered");
    assert_eq!(waited, Timing::standard().request_timeout_ms);
    assert_eq!(r.reply(id).map(|(res, _)| res), Some(ResultCode::Ok));
    assert!(r.host().is_closed());
    assert_eq!(
        r.ctl.status().frames_rx,
        frames_before + 2,
        "Close and its resend"
    );
    let (_, hello) = r.join(false);
    assert!(hello.is_ok(), "freed at once: {hello:?}");
    // A Close that never gets through (the line dead toward the device) is given up after
    // its attempts, one timeout apart.
    let mut r = Rig::connected(FF);
    let h = r.primary;
    let t0 = r.now;
    let id = r.hosts[h].close_confirmed(3, t0).expect("open");
    let (mut sent, mut t) = (0, t0);
    while !r.hosts[h].is_closed() && t < t0 + 5_000 {
        while r.hosts[h].poll_transmit().is_some() {
            sent += 1;
        }
        t += 1;
        if r.hosts[h].poll_timeout().is_some_and(|d| d <= t) {
            r.hosts[h].handle_timeout(t);
        }
    }
    r.now = t;
    r.collect();
    assert_eq!(sent, 3);
    let failed = r.log.iter().find_map(|(t, _, ev)| match ev {
        SessionEvent::Failed { id: got, error } if *got == id => Some((*t - t0, error.clone())),
        _ => None,
    });
    assert!(
        matches!(
            failed,
            Some((750, SessionError::Timeout { attempts: 3, .. }))
        ),
        "{failed:?}"
    );
    assert!(r.host().is_closed());
}

#[test]
fn a_replayed_upload_and_start_from_a_stranger_is_refused_and_abort_from_anyone_is_honoured() {
    // Host A runs a plan; its frames are recorded off the wire.
    let mut r = Rig::connected(FP);
    let recorded = |r: &mut Rig, body| {
        let id = r.send(body);
        let frame = r.host().poll_transmit().expect("sent at once");
        r.inject(&frame);
        assert!(r.reply(id).is_some());
        frame
    };
    let upload = recorded(&mut r, RequestBody::UploadPlan(Rig::plan(5, &[FP, FF])));
    let start = recorded(&mut r, RequestBody::StartPlan { plan_id: 5 });
    assert_eq!(r.ctl.mode(), Mode::Running);
    // Abort from a host without any session is honoured at once (forged: the engine shakes
    // hands first).
    assert_eq!(r.forged(0, RequestBody::Abort).0, ResultCode::Ok);
    assert_eq!(r.ctl.mode(), Mode::Safe);
    r.run(100);
    // Host A closes; host B handshakes and replays A's recorded frames byte for byte
    // (deliberately raw: a replay is a forged frame).
    assert_eq!(r.request(RequestBody::Close).0, ResultCode::Ok);
    r.connect();
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    r.request(RequestBody::DeclareState(FP));
    let mut answers = r.inject(&upload);
    answers.extend(r.inject(&start));
    let answers: StdVec<ResultCode> = answers
        .iter()
        .filter_map(|m| match m {
            DeviceMessage::Response { result, .. } => Some(*result),
            DeviceMessage::Event(_) => None,
        })
        .collect();
    assert_eq!(
        answers,
        [
            ResultCode::Rejected(RejectReason::NotSessionOwner),
            ResultCode::Rejected(RejectReason::NotSessionOwner)
        ]
    );
    assert_eq!(r.ctl.mode(), Mode::Standalone, "the replay did not run");
    r.run(2_000);
    assert_eq!(r.ctl.status().state, FP);
}

#[test]
fn before_any_handshake_only_hello_and_abort_are_served() {
    let mut r = Rig::new(FF);
    // A host that skips the handshake (the engine never does): forged frames.
    for body in [
        RequestBody::GetStatus,
        RequestBody::Heartbeat,
        RequestBody::Close,
        RequestBody::Identify,
        RequestBody::DeclareState(FD),
    ] {
        assert_eq!(
            r.forged(0, body.clone()).0,
            ResultCode::Rejected(RejectReason::NoHandshake),
            "{body:?}"
        );
    }
    assert_eq!(r.forged(0, RequestBody::Abort).0, ResultCode::Ok);
    assert_eq!(r.ctl.mode(), Mode::Safe);
}

#[test]
fn session_ids_differ_per_handshake_and_per_boot() {
    let mut ids = StdVec::new();
    for boot in 0..4u32 {
        let mut r = Rig::new(FF);
        r.ctl.add_entropy(boot);
        for _ in 0..4 {
            r.run(7);
            // The engine's close (nothing before the first handshake), then a new host.
            r.host().close();
            r.exchange();
            r.connect();
            ids.push(r.session());
        }
    }
    let mut unique = ids.clone();
    unique.sort_unstable();
    unique.dedup();
    assert_eq!(unique.len(), ids.len(), "{ids:x?}");
    assert!(!ids.contains(&0));
}

// ---------------------------------------------------------------------------------------------
// Belief: boot from the journal, identification by the operator
// ---------------------------------------------------------------------------------------------

impl Rig {
    /// Booted from the journal of a D&D → F&D fold interrupted mid-pull (the trunk is F&D),
    /// connected; with the record.
    fn interrupted_fold() -> (Self, StoredState) {
        let record = StoredState {
            state: DD,
            confirmed: false,
            candidates: protocol::StateSet::single(DD).with(FD).with(FF),
            pending: Some(protocol::Transition { from: DD, to: FD }),
        };
        let mut r = Rig::with(CraneConfig::default(), BootRecord::Stored(record), FD);
        r.connect();
        (r, record)
    }
}

#[test]
fn a_pending_record_boots_unconfirmed_and_refuses_steps() {
    let (mut r, record) = Rig::interrupted_fold();
    let s = r.ctl.status();
    assert_eq!((s.state, s.state_confirmed), (DD, false));
    assert_eq!(s.candidates, record.candidates);
    assert_eq!(s.interrupted, record.pending);
    // Not the safe state: nothing is faulty, the state is only unknown.
    assert_eq!(s.mode, Mode::Standalone);
    let mut shown = display::text("d-d ");
    shown[0] |= display::DP;
    assert_eq!(r.ctl.poll_display(), shown);
    for step in [
        Rig::nominal(DD, FD),
        Rig::nominal(FD, FF),
        Rig::nominal(FD, DD),
    ] {
        assert_eq!(
            r.request(RequestBody::RunStep(step)).0,
            ResultCode::Rejected(RejectReason::Unconfirmed)
        );
    }
    // The step buttons do nothing either.
    r.press(|b, v| b.down = v);
    assert_eq!(r.ctl.mode(), Mode::Standalone);
}

#[test]
fn the_operator_picks_a_candidate_with_up_down_and_confirms_it() {
    let (mut r, record) = Rig::interrupted_fold();
    // A sensor fault: no probing, the operator is asked at once.
    r.raw_override = Some(0);
    r.run(r.cfg.pressure_sensor.dropout_ms as u64 + 20);
    assert!(r.faults_raised().contains(&FaultCode::PressureSensor));
    assert_eq!(r.request(RequestBody::Identify).0, ResultCode::InProgress);
    assert!(r.events().any(|e| *e
        == Event::IdentifyNeedsOperator {
            candidates: record.candidates
        }));
    let all_dp = |text: &str| {
        let mut seg = display::text(text);
        for d in &mut seg {
            *d |= display::DP;
        }
        seg
    };
    // The fault's code has priority on the display; once the sensor is back and the fault
    // reset, the question shows: the best guess first, up/down walk the candidates.
    r.raw_override = None;
    r.run(50);
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    assert_eq!(r.ctl.poll_display(), all_dp("d-d "));
    r.press(|b, v| b.up = v);
    assert_eq!(r.ctl.poll_display(), all_dp("F-F "));
    r.press(|b, v| b.up = v);
    assert_eq!(r.ctl.poll_display(), all_dp("F-d "));
    assert_eq!(r.ctl.mode(), Mode::Standalone, "choosing moves nothing");
    r.press(|b, v| b.confirm = v);
    let s = r.ctl.status();
    assert_eq!((s.state, s.state_confirmed), (FD, true));
    assert_eq!(r.stores.last(), Some(&StoredState::confirmed(FD)));
    assert_eq!(r.ctl.poll_display(), display::text("F-d "));
}

#[test]
fn a_v1_host_is_refused_in_v1_words() {
    let mut r = Rig::new(FF);
    // A v1 Hello (seq 9, version 1, schema 0x221ee9a8) framed with v1's CRC-16, by hand:
    // deliberately raw bytes (no host engine speaks v1).
    let payload = [0x09u8, 0x00, 0x01, 0xa8, 0xd3, 0xfb, 0x90, 0x02];
    let crc = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC).checksum(&payload);
    let mut raw = payload.to_vec();
    raw.extend(crc.to_le_bytes());
    let mut frame = [0u8; 32];
    let n = cobs::try_encode(&raw, &mut frame).unwrap();
    r.ctl.handle_rx(&frame[..n], r.now);
    r.ctl.handle_rx(&[0], r.now);
    let mut out = [0u8; 128];
    let len = r.ctl.poll_tx(&mut out);
    assert!(len > 0, "answered");
    assert_eq!(out[len - 1], 0);
    // v1 framing: COBS, then payload ‖ CRC-16; the payload is v1's
    // Response { seq 9, Rejected(VersionMismatch), Hello(DeviceInfo { version 2, .. }) }.
    let m = cobs::decode_in_place(&mut out[..len - 1]).unwrap();
    let (p, check) = out[..m].split_last_chunk::<2>().unwrap();
    assert_eq!(
        crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC)
            .checksum(p)
            .to_le_bytes(),
        *check
    );
    assert_eq!(
        &p[..6],
        &[0x00, 0x09, 0x01, 0x00, 0x01, PROTOCOL_VERSION as u8]
    );
    // Nothing else changed: no handshake, no session.
    assert_eq!(r.ctl.session(), 0);
    assert_eq!(
        r.forged(0, RequestBody::GetStatus).0,
        ResultCode::Rejected(RejectReason::NoHandshake)
    );
}

#[test]
fn a_leak_opening_mid_inflation_is_not_taken_for_the_snap() {
    // Swarm seed 10754 (xoshiro stream): D&F → D&D inflating toward 35 kPa, a 2.5 mm hole
    // opens at ≈ 20 kPa, far below the bottom's 30 kPa snap. The sudden fall is a step in the
    // pressure's trend, as a snap's drop is; the trunk has not moved and must not be
    // confirmed at D&D.
    let mut r = Rig::connected(DF);
    r.upload_and_start(Rig::plan(7, &[DF, DD]));
    r.run_until(10_000, |r| r.ctl.pressure_kpa() >= 20.0)
        .expect("the inflation reaches 20 kPa");
    r.plant.hole_per_s = 2.5;
    let mut wrong = false;
    r.run_until(30_000, |r| {
        let s = r.ctl.status();
        wrong |= s.state_confirmed && s.state != r.plant.state;
        r.plan_done().is_some()
    })
    .expect("the plan ends");
    assert_eq!(r.plant.state, DF);
    assert!(!wrong, "a state other than the trunk's was confirmed");
    let s = r.ctl.status();
    assert!(!s.state_confirmed || s.state == DF, "{s:?}");
    // 20 kPa may have snapped a trunk other than this plant's: unconfirmed, D&F a candidate.
    assert!(!s.state_confirmed && s.candidates.contains(DF), "{s:?}");
    assert_eq!(r.plan_done().map(|d| d.0), Some(false));
    assert_eq!(r.faults_raised(), [FaultCode::Leak]);
}

/// Letting the air out changes no state: a single vent within the believed state is accepted
/// when the state is not confirmed (the host lets out air an interrupted step left sealed before
/// it identifies the state), leaves the belief as it was, and nothing else is let through.
#[test]
fn a_vent_or_the_probes_fill_alone_is_allowed_while_the_state_is_unconfirmed_and_changes_no_belief()
{
    let mut r = Rig::connected(DD);
    r.keepalive();
    r.upload_and_start(Rig::plan(2, &[DD, FD]));
    r.run(300);
    assert_eq!(r.request(RequestBody::Abort).0, ResultCode::Ok);
    r.run(500);
    let before = r.ctl.status();
    assert!(!before.state_confirmed);
    assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
    let vent = |from: TrunkState, to: TrunkState, extra: Option<Primitive>| {
        let mut primitives = heapless::Vec::new();
        primitives
            .push(Primitive::Vent { pressure_kpa: 0.0 })
            .unwrap();
        if let Some(p) = extra {
            primitives.push(p).unwrap();
        }
        Step {
            kind: StepKind::Pneumatic,
            from,
            to,
            primitives,
            timeout_ms: 20_000,
        }
    };
    // Not a vent, hold or probe's fill alone, or not within the state: refused as before.
    let grip = Some(Primitive::Gripper { close: true });
    let fill = |pressure_kpa: f32, snaps: u8| {
        Some(Primitive::Inflate {
            pressure_kpa,
            snaps,
        })
    };
    let probe_kpa = protocol::probe::PROBE_KPA;
    for step in [
        vent(before.state, before.state, grip),
        vent(before.state, FF, None),
        vent(before.state, before.state, fill(probe_kpa + 0.1, 0)),
        vent(before.state, before.state, fill(probe_kpa, 1)),
    ] {
        assert_eq!(
            r.request(RequestBody::RunStep(step)).0,
            ResultCode::Rejected(RejectReason::Unconfirmed)
        );
    }
    assert_eq!(
        r.request(RequestBody::RunStep(vent(before.state, before.state, None)))
            .0,
        ResultCode::InProgress
    );
    for _ in 0..200 {
        if r.ctl.mode() != Mode::Running {
            break;
        }
        r.run(100);
    }
    assert_ne!(r.ctl.mode(), Mode::Running);
    let after = r.ctl.status();
    assert!(!after.state_confirmed);
    assert_eq!(
        (after.state, after.candidates),
        (before.state, before.candidates)
    );
    assert!(after.pressure_kpa < 0.6, "{after:?}");
    assert_eq!(
        after.plan.map(|p| p.phase),
        Some(PlanPhase::Done),
        "{after:?}"
    );
    assert_eq!(after.faults, 0);
    // The probe's fill (a calibration's probe of a trunk between states): accepted, and the
    // belief stays as it was.
    assert_eq!(
        r.request(RequestBody::RunStep(vent(
            before.state,
            before.state,
            fill(probe_kpa, 0)
        )))
        .0,
        ResultCode::InProgress
    );
    r.run_until(20_000, |r| r.ctl.mode() != Mode::Running);
    let probed = r.ctl.status();
    assert_eq!(
        probed.plan.map(|p| p.phase),
        Some(PlanPhase::Done),
        "{probed:?}"
    );
    assert!(!probed.state_confirmed);
    assert_eq!(
        (probed.state, probed.candidates),
        (before.state, before.candidates)
    );
}

#[test]
fn pairing_is_refused_where_no_key_can_be_kept_and_the_handshake_says_signing_is_off() {
    // Built without the feature `link-signing`, or with a store that keeps no key (the
    // controller alone): refused, nothing changes, plain requests obeyed.
    let mut r = Rig::connected(FF);
    assert_eq!(
        r.request(RequestBody::SetSigning {
            key: *b"crane-test-key-1",
            enabled: true
        })
        .0,
        ResultCode::Rejected(RejectReason::NotAllowed)
    );
    assert!(!r.ctl.signing());
    let (c, hello) = r.join(true);
    assert!(!hello.expect("handshake").signing);
    assert_eq!(
        r.request_from(c, RequestBody::DeclareState(FD)).0,
        ResultCode::Ok
    );
}

/// Link signing: pairing, forged, replayed and correctly signed frames (`protocol::sign`).
#[cfg(feature = "link-signing")]
mod signing {
    use super::*;

    const KEY: [u8; 16] = *b"crane-test-key-1";

    fn limit(r: &mut Rig) -> f32 {
        match r.request(RequestBody::GetParam(ParamId::PressureLimitKpa)) {
            (ResultCode::Ok, ResponseBody::Param { value, .. }) => value,
            other => panic!("{other:?}"),
        }
    }

    fn set_limit(kpa: f32) -> RequestBody {
        RequestBody::SetParam {
            id: ParamId::PressureLimitKpa,
            value: kpa,
        }
    }

    /// A rig whose store keeps a key, paired with [`KEY`] by its primary host.
    fn paired() -> Rig {
        let mut r = Rig::connected(FF);
        r.ctl.set_link_key(None, true);
        assert!(!r.ctl.signing());
        let (res, _) = r.request(RequestBody::SetSigning {
            key: KEY,
            enabled: true,
        });
        assert_eq!(res, ResultCode::Ok);
        assert!(r.ctl.signing());
        assert_eq!(
            r.ctl.poll_link_key(),
            Some(Some(KEY)),
            "the key goes to the store"
        );
        assert!(r.host().signs(), "the host signs from the next request on");
        r
    }

    /// The request the primary host signs, as it went on the wire (and its answer).
    fn signed_frame(r: &mut Rig, body: RequestBody) -> (StdVec<u8>, ResultCode) {
        let id = r.send(body);
        let frame = r.host().poll_transmit().expect("sent at once");
        r.inject(&frame);
        (frame, r.reply(id).expect("answered").0)
    }

    #[test]
    fn a_signed_request_is_obeyed_and_a_forged_one_with_the_session_id_is_refused() {
        let mut r = paired();
        assert_eq!(r.request(set_limit(30.0)).0, ResultCode::Ok);
        assert_eq!(limit(&mut r), 30.0);
        // A stranger who read the session id off the line: its frame, correct in every other
        // way, carries no signature.
        let session = r.session();
        assert_eq!(
            r.forged(session, set_limit(60.0)).0,
            ResultCode::Rejected(RejectReason::Unsigned)
        );
        assert_eq!(
            r.forged(session, RequestBody::UploadPlan(Rig::plan(9, &[FF, FP])))
                .0,
            ResultCode::Rejected(RejectReason::Unsigned)
        );
        assert_eq!(
            r.forged(session, RequestBody::StartPlan { plan_id: 9 }).0,
            ResultCode::Rejected(RejectReason::Unsigned)
        );
        // Signed with another key: the trailer does not check out, so the frame does not
        // decode at all (dropped, counted, unanswered).
        let dropped = r.ctl.status().frames_dropped;
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = protocol::frame::encode_signed(
            &Request {
                seq: 41_000,
                session,
                body: set_limit(60.0),
            },
            b"not-the-crane-ky",
            u64::MAX,
            &mut buf,
        )
        .unwrap();
        assert!(r.inject(&buf[..n]).is_empty(), "no answer");
        assert_eq!(r.ctl.status().frames_dropped, dropped + 1);
        assert_eq!(limit(&mut r), 30.0, "nothing forged took effect");
        // What anyone may do stays unsigned: status, parameters read, abort.
        assert_eq!(r.forged(0, RequestBody::GetStatus).0, ResultCode::Ok);
        assert_eq!(r.forged(0, RequestBody::Abort).0, ResultCode::Ok);
        // A plan from the owner, signed, runs.
        assert_eq!(r.request(RequestBody::ResetFaults).0, ResultCode::Ok);
        r.upload_and_start(Rig::plan(3, &[FF, FP]));
        assert_eq!(r.ctl.mode(), Mode::Running);
    }

    #[test]
    fn a_replayed_signed_frame_is_refused_and_a_retry_is_answered_from_the_cache() {
        let mut r = paired();
        let (first, res) = signed_frame(&mut r, set_limit(25.0));
        assert_eq!(res, ResultCode::Ok);
        // The same bytes at once are a retry: the cached answer, nothing executed again.
        let answers = r.inject(&first);
        assert!(
            matches!(
                answers.as_slice(),
                [DeviceMessage::Response {
                    result: ResultCode::Ok,
                    ..
                }]
            ),
            "{answers:?}"
        );
        assert_eq!(r.request(set_limit(35.0)).0, ResultCode::Ok);
        // Replayed later (another request answered since): its counter is not above the last
        // accepted, refused, and the value it carried is not set again.
        let answers = r.inject(&first);
        assert!(
            matches!(
                answers.as_slice(),
                [DeviceMessage::Response {
                    result: ResultCode::Rejected(RejectReason::Unsigned),
                    ..
                }]
            ),
            "{answers:?}"
        );
        assert_eq!(limit(&mut r), 35.0);
        // A frame signed with the right key but an old counter, under a new seq: refused too.
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = protocol::frame::encode_signed(
            &Request {
                seq: 42_000,
                session: r.session(),
                body: set_limit(20.0),
            },
            &KEY,
            1,
            &mut buf,
        )
        .unwrap();
        assert!(matches!(
            r.inject(&buf[..n]).as_slice(),
            [DeviceMessage::Response {
                result: ResultCode::Rejected(RejectReason::Unsigned),
                ..
            }]
        ));
        assert_eq!(limit(&mut r), 35.0);
    }

    #[test]
    fn the_handshake_says_signing_is_on_and_unpairing_turns_it_off() {
        let mut r = paired();
        // A new host learns it at the handshake; without the key its requests are refused.
        let (b, hello) = r.join(true);
        assert!(hello.expect("taken over").signing);
        assert_eq!(
            r.request_from(b, set_limit(50.0)).0,
            ResultCode::Rejected(RejectReason::Unsigned)
        );
        // With the key it is obeyed (its counters continue above the first host's).
        r.hosts[b].set_signing(Some(KEY), 1_000);
        assert_eq!(r.request_from(b, set_limit(32.0)).0, ResultCode::Ok);
        // Unpairing is itself signed; then plain requests are obeyed again.
        assert_eq!(
            r.request_from(
                b,
                RequestBody::SetSigning {
                    key: [0; 16],
                    enabled: false
                }
            )
            .0,
            ResultCode::Ok
        );
        assert!(!r.ctl.signing());
        assert_eq!(r.ctl.poll_link_key(), Some(None));
        assert!(!r.hosts[b].signs());
        assert_eq!(r.request_from(b, set_limit(33.0)).0, ResultCode::Ok);
        // An all-zero key is refused; a store that keeps no key refuses pairing.
        assert_eq!(
            r.request_from(
                b,
                RequestBody::SetSigning {
                    key: [0; 16],
                    enabled: true
                }
            )
            .0,
            ResultCode::Rejected(RejectReason::OutOfRange)
        );
        let mut bare = Rig::connected(FF);
        assert_eq!(
            bare.request(RequestBody::SetSigning {
                key: KEY,
                enabled: true
            })
            .0,
            ResultCode::Rejected(RejectReason::NotAllowed)
        );
        // A device that boots with the key kept is signing from the start.
        let mut boot = Rig::new(FF);
        boot.ctl.set_link_key(Some(KEY), true);
        let (_, hello) = boot.join(false);
        assert!(hello.expect("handshake").signing);
    }
}

/// The probe profile stored on the device (`RequestBody::SetProbeProfile`).
mod probe_profile {
    use super::*;
    use protocol::{ProbeProfile, Refusal, RefusedField, SCHEMA_ID};

    fn set(profile: Option<ProbeProfile>) -> RequestBody {
        RequestBody::SetProbeProfile {
            schema_id: SCHEMA_ID,
            profile,
        }
    }

    fn stored(r: &mut Rig) -> Option<ProbeProfile> {
        match r.request(RequestBody::GetProbeProfile) {
            (ResultCode::Ok, ResponseBody::ProbeProfile(p)) => p,
            other => panic!("{other:?}"),
        }
    }

    fn asked(r: &Rig) -> bool {
        r.events()
            .any(|e| matches!(e, Event::IdentifyNeedsOperator { .. }))
    }

    #[test]
    fn storing_takes_effect_at_once_and_goes_to_the_store() {
        let (mut r, _) = Rig::interrupted_fold();
        r.ctl.set_probe_profile(None, true);
        assert_eq!(stored(&mut r), None);
        // Pressure samples first (no probing without a valid reading).
        r.run(100);
        // Without a profile identification asks the operator at once, no probe runs.
        assert_eq!(r.request(RequestBody::Identify).0, ResultCode::InProgress);
        assert!(asked(&r), "asked the operator");
        assert_eq!(r.ctl.status().plan.map(|p| p.plan_id), None);
        assert_eq!(r.ctl.poll_probe_profile(), None, "nothing to store");

        let (mut r, _) = Rig::interrupted_fold();
        r.ctl.set_probe_profile(None, true);
        assert_eq!(
            r.request(set(Some(identify::SIM_PROFILE))).0,
            ResultCode::Ok
        );
        assert_eq!(
            r.ctl.poll_probe_profile(),
            Some(Some(identify::SIM_PROFILE))
        );
        assert_eq!(r.ctl.poll_probe_profile(), None, "taken once");
        assert_eq!(stored(&mut r), Some(identify::SIM_PROFILE));
        r.run(100);
        // With it, identification runs the probe instead of asking.
        assert_eq!(r.request(RequestBody::Identify).0, ResultCode::InProgress);
        assert!(!asked(&r), "the probe decides, not the operator");
        assert_eq!(
            r.ctl.status().plan.map(|p| p.plan_id),
            Some(identify::IDENTIFY_PLAN_ID)
        );
        // While it runs, the profile cannot change.
        assert_eq!(r.request(set(None)).0, ResultCode::Busy);
        assert_eq!(r.request(RequestBody::Abort).0, ResultCode::Ok);
        // Erasing takes effect at once too: the operator is asked again.
        assert_eq!(r.request(set(None)).0, ResultCode::Ok);
        assert_eq!(r.ctl.poll_probe_profile(), Some(None));
        assert_eq!(stored(&mut r), None);
        assert_eq!(r.request(RequestBody::Identify).0, ResultCode::InProgress);
        assert!(asked(&r));
    }

    #[test]
    fn a_profile_loaded_at_boot_is_the_one_identification_uses() {
        let (mut r, _) = Rig::interrupted_fold();
        let mine = ProbeProfile {
            states: [20.0, 21.0, 22.0, 23.0, 24.0, 25.0],
            between: [20.5, 23.5],
        };
        r.ctl.set_probe_profile(Some(mine), true);
        assert_eq!(r.ctl.probe_profile(), Some(mine));
        assert_eq!(stored(&mut r), Some(mine));
        r.run(100);
        assert_eq!(r.request(RequestBody::Identify).0, ResultCode::InProgress);
        assert!(!asked(&r));
    }

    #[test]
    fn bad_profiles_are_refused_with_the_field_and_change_nothing() {
        let (mut r, _) = Rig::interrupted_fold();
        // A store that keeps no profile: refused (it would be gone at the next reset).
        assert_eq!(
            r.request(set(Some(identify::SIM_PROFILE))).0,
            ResultCode::Rejected(RejectReason::NotAllowed)
        );
        r.ctl.set_probe_profile(None, true);
        // Another firmware's schema.
        assert_eq!(
            r.request(RequestBody::SetProbeProfile {
                schema_id: SCHEMA_ID ^ 1,
                profile: Some(identify::SIM_PROFILE),
            })
            .0,
            ResultCode::Rejected(RejectReason::VersionMismatch)
        );
        let (lo, hi) = protocol::PROBE_RATE_RANGE;
        for (i, bad, limit) in [
            (0usize, f32::NAN, hi),
            (3, f32::INFINITY, hi),
            (5, -1.0, lo),
            (6, 0.0, lo),
            (7, 1.0e6, hi),
            (2, f32::NEG_INFINITY, lo),
        ] {
            let mut p = identify::SIM_PROFILE;
            if i < 6 {
                p.states[i] = bad;
            } else {
                p.between[i - 6] = bad;
            }
            let (res, body) = r.request(set(Some(p)));
            assert_eq!(
                res,
                ResultCode::Rejected(RejectReason::OutOfRange),
                "{i}: {bad}"
            );
            let ResponseBody::Refused(Refusal {
                step: None,
                field: RefusedField::ProbeRate(at),
                value,
                limit: l,
            }) = body
            else {
                panic!("{i}: {body:?}");
            };
            assert_eq!(usize::from(at), i);
            assert!(value == bad || (value.is_nan() && bad.is_nan()));
            assert_eq!(l, limit, "{i}: {bad}");
        }
        assert_eq!(stored(&mut r), None, "nothing stored");
        assert_eq!(r.ctl.poll_probe_profile(), None);
        // The bounds themselves are accepted.
        let edge = ProbeProfile {
            states: [lo, hi, lo, hi, lo, hi],
            between: [lo, hi],
        };
        assert_eq!(r.request(set(Some(edge))).0, ResultCode::Ok);
    }

    #[test]
    fn the_stored_form_round_trips_and_refuses_other_schemas_and_bad_rates() {
        use crate::store::{profile_from_bytes, profile_to_bytes};
        let b = profile_to_bytes(&identify::SIM_PROFILE);
        assert_eq!(b[..4], SCHEMA_ID.to_le_bytes());
        assert_eq!(profile_from_bytes(&b), Some(identify::SIM_PROFILE));
        let mut other = b;
        other[0] ^= 1;
        assert_eq!(profile_from_bytes(&other), None, "another schema");
        let mut nan = b;
        nan[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(profile_from_bytes(&nan), None, "a rate the device refuses");
    }
}
