//! The sans-IO crane controller.
//!
//! [`Controller`] is fed with `handle_rx` (host bytes), `handle_inputs` (one sample of every
//! sensor and button) and `handle_time` (the control-loop tick), each with `now_ms`; it is read
//! with `poll_tx`, `poll_outputs`, `poll_display`, `poll_store` and `poll_deadline`.
//!
//! Inside:
//! - `requests`: every protocol request (handshake, plans, parameters, faults, declared state),
//!   each answered by exactly one response; a retried request (same `seq`, same bytes) gets
//!   the cached response and is not executed twice.
//! - `exec`: plan execution, one step at a time, primitive by primitive, with the step's
//!   time limit; state confirmation from snaps (or the person, for manual steps). A step's
//!   phase is data (`Phase`: journaling its record ahead of the first actuation, the
//!   pre-release of the tendons, the primitives, a manual step's check by the probe); the
//!   primitive under way (`exec/primitive.rs`, `Run`) carries only its kind's state (an
//!   inflation's snap and hold stages, a pull's relief and sealed-release check, a manual
//!   step's confirm), with one progress check per kind.
//! - [`snap`]: the snap-through detector on the filtered pressure.
//! - [`belief`]: what is known about the trunk's state (confirmed, or unconfirmed with the
//!   candidates and the interrupted step), and the reach of a step.
//! - `trunk`: the belief in force, what a report says of it while a step moves the trunk, and
//!   the journal (each record's handover to the shell that persists it).
//! - [`identify`]: the sealed-pressure probe that identifies an unconfirmed state, and the
//!   operator's answer where it cannot decide.
//! - `safety`: faults, the safe state and the reset.
//! - `watch`: the leak, stuck-open inlet and rest watches.
//! - `panel`: the standalone buttons and joystick.
//! - `actuators`: servo slewing, the gripper, the valve overlay of the safe state.
//! - this module: the pressure filter, dropout and over-pressure, the tendon kinematics,
//!   periodic events, the display.
//!
//! The full behaviour, with every number, is in `docs/firmware.md`.
// The controller is plain logic over its inputs and outputs: no unsafe code anywhere in it (the
// board shell, `board/`, holds the register access).
#![forbid(unsafe_code)]

mod actuators;
pub mod belief;
mod exec;
pub mod identify;
pub mod link;
mod panel;
mod requests;
mod safety;
pub mod snap;
mod trunk;
mod watch;

#[cfg(test)]
mod tests;

use geometry::TrunkState;
use heapless::Vec;
use protocol::{
    DeviceMessage, Event, FaultCode, FrameDecoder, Mode, PlanStatus, Request, ResetCause, Status,
    Telemetry,
};

use crate::config::CraneConfig;
use crate::store::{BootRecord, StoredState};
use actuators::Actuators;
use belief::Belief;
use exec::Exec;
use identify::Identification;
use link::{Fingerprint, ResponseCache, TxQueue, RESPONSE_RESERVE};
use panel::{Debounce, Joystick, Panel};
use safety::Safety;
use snap::{SnapDetector, SnapSign};
use trunk::{Journal, Trunk};
use watch::{InletWatch, LeakWatch, Watches};

/// A button press must be stable this long to count (the e-stop acts at once).
pub const DEBOUNCE_MS: u64 = 20;
/// Consecutive unfiltered samples above the cap that trip the over-pressure at once.
pub const OVERPRESSURE_SAMPLES: u8 = 3;
/// Scratch buffer for encoding one event frame.
const EVENT_SCRATCH_LEN: usize = 128;
/// Step progress events are sent at most this often.
pub const PROGRESS_PERIOD_MS: u64 = 100;
/// The leak watch waits this long after a boot into an unconfirmed state, after the servos went
/// limp and after a step was interrupted: limp servos pulled back by the tendons let a compressed trunk lengthen, and
/// a snap may complete after the valves closed; both drop a sealed trunk's pressure without
/// any leak.
pub const LEAK_SETTLE_MS: u64 = 5_000;
/// A person's hands may still be on the trunk this long after a manual step stopped waiting
/// (aborted, timed out, or a boot into an unconfirmed state): a fold they began is finished,
/// and it compresses the trunk as gas coming in would; the stuck-open inlet watch allows it.
pub const HANDS_MS: u64 = 5_000;
/// At rest, a confirmed state stops being vouched for when the air in the trunk rises this much
/// above the lowest it held since, with [`protocol::transitions::SEALED_ACTS_KPA`] or more in it:
/// gas is coming in (a valve stuck open), and it may snap a module up. A load pressing on the
/// sealed trunk raises it less (the 5.7 kg of §6.5 on D&D: under 1 kPa in the simulator).
pub const REST_RISE_KPA: f32 = 4.0;
/// A step waits at most this long for its journal record to be persisted before its first
/// actuation; then the StateStorage fault is raised (the crane does not move the trunk without a
/// record a reset could boot from).
pub const JOURNAL_TIMEOUT_MS: u64 = 200;

/// The state of every button (`true` = pressed). The controller debounces (a change must be
/// stable for [`DEBOUNCE_MS`]) and acts on presses; the e-stop acts at once, on the level.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Buttons {
    /// Step up (deploy: the pneumatic transition from the current state).
    pub up: bool,
    /// Step down (retract: the tendon transition from the current state).
    pub down: bool,
    /// Toggle the gripper.
    pub gripper: bool,
    /// Emergency stop (latches until reset with the button released).
    pub estop: bool,
    /// Confirm a manual step; in the safe state, reset faults (like the host's ResetFaults).
    pub confirm: bool,
    /// Show the pressure on the display while held.
    pub show_pressure: bool,
}

/// One sample of every sensor and button.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Inputs {
    /// Pressure sensor, raw 14-bit ADC counts.
    pub pressure_raw: u16,
    /// Joystick x and y, raw 14-bit ADC counts.
    pub joystick_raw: [u16; 2],
    /// Buttons.
    pub buttons: Buttons,
}

impl Inputs {
    /// A sample of a crane at rest: 0 kPa, joystick centred, no button pressed.
    pub fn at_rest(config: &CraneConfig) -> Self {
        Self {
            pressure_raw: config.pressure_sensor.raw(0.0),
            joystick_raw: config.joystick.center_raw,
            buttons: Buttons::default(),
        }
    }
}

/// Actuator commands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outputs {
    /// Servo angles of tendons 0, 1, 2 (within the limits and slew-limited).
    pub servo_deg: [f32; 3],
    /// Inlet valve open.
    pub inlet_open: bool,
    /// Exhaust valve open.
    pub exhaust_open: bool,
    /// Gripper closed (the boot state: fail-closed, `docs/hardware.md`).
    pub gripper_closed: bool,
    /// Servo pulses on. Off in the safe state: the servos go limp (duty 0, no pulse), so a
    /// servo that stalled short of its command stops pushing, and the origami holds its state
    /// by itself (`docs/firmware.md`, "Safety").
    pub servos_enabled: bool,
}

/// Pressure measurement state.
#[derive(Debug, Clone, Copy)]
struct Pressure {
    /// Filtered gauge pressure (the value every decision uses).
    filt_kpa: f32,
    /// Last unfiltered sample.
    raw_kpa: f32,
    /// A valid sample has been seen.
    init: bool,
    last_ms: u64,
    /// Since when the raw value sits at a rail.
    rail_since_ms: Option<u64>,
    /// The latest raw sample is at a rail.
    at_rail: bool,
    /// Consecutive unfiltered samples above the cap.
    above_cap: u8,
}

/// When the periodic events are due.
#[derive(Debug, Clone, Copy)]
struct Periodic {
    next_heartbeat_ms: u64,
    next_telemetry_ms: u64,
    last_progress_ms: u64,
}

/// Who the device talks to (`docs/protocol.md`, "Sessions").
#[derive(Debug, Clone, Copy)]
struct LinkSession {
    /// A host has shaken hands since boot (events are sent from then on).
    handshake: bool,
    /// The current session (0: none).
    session: u32,
    opened: u32,
    /// Mixed from sensor noise, frame arrival times and the shell's seed: session ids.
    entropy: u32,
    reset_cause: ResetCause,
    /// When the session's owner was last heard.
    last_rx_ms: u64,
}

/// Link signing (feature `link-signing`): the key in force and the replay guard.
#[cfg(feature = "link-signing")]
#[derive(Debug, Clone)]
struct Signing {
    /// The paired key; signing is on while there is one.
    key: Option<protocol::sign::LinkKey>,
    /// The highest counter of a signed request accepted since boot (signed requests must
    /// rise above it; across a boot the session rule refuses old frames).
    last_counter: u64,
    /// A key change to persist ([`Controller::poll_link_key`]).
    to_store: Option<Option<protocol::sign::LinkKey>>,
    /// Whether the store keeps a key ([`Controller::set_link_key`]): pairing is refused
    /// otherwise, so a reset never turns signing off behind the operator's back.
    store_keeps_key: bool,
}

/// The crane controller. See the [crate docs](crate) for the API and the loop.
#[derive(Debug, Clone)]
#[repr(C)]
pub struct Controller {
    // Declared (and laid out, `repr(C)`) from the most used to the largest: the fields read on
    // every pass sit within the short load offsets of the M4 (the default layout puts every
    // `bool` after the kilobytes of plans and buffers, each access then an address
    // computation more).
    now_ms: u64,
    boot_ms: u64,
    last_tick_ms: u64,

    // Modes and faults.
    safety: Safety,

    // Actuators and sensors.
    act: Actuators,
    pressure: Pressure,
    watch: Watches,
    /// The standalone panel: buttons and joystick.
    panel: Panel,

    // Trunk state.
    trunk: Trunk,
    ident: Identification,

    // Link.
    periodic: Periodic,
    link: LinkSession,
    fingerprint: Fingerprint,
    defer_events: bool,
    plan_status: Option<PlanStatus>,

    /// Tendon shortening that takes up each state's slack (joystick and `Bend`), by
    /// [`TrunkState::index`]: computed once here (a plan's upload check needs the take-up of
    /// every step's `from`).
    take_up_mm: [f32; 6],
    /// The shortenings every servo reaches alike ([`equal_pull_range`]), when the limits change.
    pull_range_mm: (f32, f32),
    /// Largest bend in the current state (joystick full deflection, `Bend`), once per state
    /// change.
    max_bend_deg: f32,
    snap: SnapDetector,
    #[cfg(feature = "link-signing")]
    signing: Signing,
    cfg: CraneConfig,

    // Plans.
    exec: Option<Exec>,
    uploaded: Option<protocol::Plan>,

    // Link buffers.
    deferred: Vec<Event, 8>,
    decoder: FrameDecoder,
    cache: ResponseCache,
    tx: TxQueue,
}

impl Controller {
    /// A controller booting at `now_ms` with what the state store held: `Empty` boots in the
    /// manufactured state `F&P`, confirmed; `Stored` in the stored belief (a step that was
    /// pending boots unconfirmed, "was going from → to", with its candidates); `Corrupt`
    /// unconfirmed with every state a candidate and the StateStorage fault (cleared by
    /// DeclareState or ResetFaults).
    ///
    /// The configuration is [validated](CraneConfig::validated) first.
    pub fn new(config: CraneConfig, boot: BootRecord, now_ms: u64) -> Self {
        let cfg = config.validated();
        let (belief, faults, last_fault) = match boot {
            BootRecord::Empty => (Belief::confirmed(TrunkState::AS_MANUFACTURED), 0, None),
            BootRecord::Stored(s) if s.confirmed => (Belief::confirmed(s.state), 0, None),
            BootRecord::Stored(s) => (
                Belief::unconfirmed(s.state, s.candidates, s.pending),
                0,
                None,
            ),
            BootRecord::Corrupt => (
                Belief::unknown(TrunkState::AS_MANUFACTURED),
                FaultCode::StateStorage.bit(),
                Some(FaultCode::StateStorage),
            ),
        };
        let state = belief.state();
        let servo_deg = slack_angles(&cfg);
        let take_up_mm = TrunkState::ALL.map(|s| take_up_mm(&cfg, s));
        let max_bend_deg = max_bend_deg(&cfg, state);
        let mut ctl = Self {
            cfg,
            now_ms,
            boot_ms: now_ms,
            last_tick_ms: now_ms,
            trunk: Trunk {
                belief,
                journal: Journal::default(),
            },
            ident: Identification::default(),
            safety: Safety {
                faults,
                last_fault,
                estop_latched: false,
                safe: faults != 0,
                venting_for_safety: false,
            },
            pressure: Pressure {
                filt_kpa: 0.0,
                raw_kpa: 0.0,
                init: false,
                last_ms: now_ms,
                rail_since_ms: None,
                at_rail: false,
                above_cap: 0,
            },
            snap: SnapDetector::new(),
            watch: Watches {
                // After a reset mid-step the servos, now slack, may let a compressed trunk
                // lengthen, and a snap may still complete: not a leak.
                leak_quiet_until_ms: if belief.is_confirmed() {
                    now_ms
                } else {
                    now_ms + LEAK_SETTLE_MS
                },
                rest_floor_kpa: None,
                hands_until_ms: if belief.is_confirmed() {
                    now_ms
                } else {
                    now_ms + HANDS_MS
                },
                leak: LeakWatch::default(),
                inlet: InletWatch::default(),
            },
            panel: Panel {
                buttons: Buttons::default(),
                debounce: Debounce::default(),
                joystick: Joystick {
                    raw: cfg.joystick.center_raw,
                    used_raw: None,
                    armed: false,
                },
            },
            act: Actuators {
                servo_deg,
                servo_target_deg: servo_deg,
                servos_enabled: faults == 0,
                // Fail-closed: the controller boots holding (a reset while it carries a load
                // must not drop it; the GPIO set-up already drives the pin closed): it opens
                // only when told to (the gripper button, a `Gripper` primitive).
                gripper_closed: true,
                want_inlet: false,
                want_exhaust: false,
                outputs: Outputs {
                    servo_deg,
                    inlet_open: false,
                    exhaust_open: false,
                    gripper_closed: true,
                    servos_enabled: faults == 0,
                },
            },
            take_up_mm,
            pull_range_mm: equal_pull_range(&cfg),
            max_bend_deg,
            uploaded: None,
            exec: None,
            plan_status: None,
            decoder: FrameDecoder::new(),
            fingerprint: Fingerprint::START,
            link: LinkSession {
                handshake: false,
                session: 0,
                opened: 0,
                entropy: Fingerprint::START.0,
                reset_cause: ResetCause::Unknown,
                last_rx_ms: now_ms,
            },
            cache: ResponseCache::new(),
            #[cfg(feature = "link-signing")]
            signing: Signing {
                key: None,
                last_counter: 0,
                to_store: None,
                store_keeps_key: false,
            },
            tx: TxQueue::new(),
            defer_events: false,
            deferred: Vec::new(),
            periodic: Periodic {
                next_heartbeat_ms: now_ms,
                next_telemetry_ms: now_ms,
                last_progress_ms: now_ms,
            },
        };
        ctl.update_outputs();
        ctl
    }

    /// The board restarted through its watchdog: raises the Watchdog fault (safe state until
    /// reset). Call once after [`Controller::new`].
    pub fn report_watchdog_reset(&mut self) {
        self.link.reset_cause = ResetCause::Watchdog;
        self.raise(FaultCode::Watchdog);
    }

    /// Why the board started, as its reset-status register tells (reported in the handshake's
    /// [`protocol::DeviceInfo::reset_cause`]; `Unknown` until set). A watchdog reset is
    /// reported with [`Controller::report_watchdog_reset`] instead, which also raises the fault.
    pub fn set_reset_cause(&mut self, cause: ResetCause) {
        if self.link.reset_cause != ResetCause::Watchdog {
            self.link.reset_cause = cause;
        }
    }

    /// Mixes `seed` into the entropy that session ids are drawn from (a board's unique id or
    /// a free-running timer, the simulator's seed). Optional: sensor noise and frame arrival
    /// times are mixed in anyway.
    pub fn add_entropy(&mut self, seed: u32) {
        for b in seed.to_le_bytes() {
            self.link.entropy = Fingerprint(self.link.entropy).with(b).0;
        }
    }

    fn advance_clock(&mut self, now_ms: u64) {
        // Time never runs backwards inside the controller, whatever the caller passes.
        self.now_ms = self.now_ms.max(now_ms);
    }

    /// Bytes received from the host link, in any chunking. Bad frames are counted and dropped.
    pub fn handle_rx(&mut self, bytes: &[u8], now_ms: u64) {
        self.advance_clock(now_ms);
        // Read where it lies and borrowed from there: a `Request` is ~530 bytes, a move is a
        // memcpy on the M4.
        let mut req = Request::blank();
        for &b in bytes {
            if b != 0 {
                self.fingerprint = self.fingerprint.with(b);
            }
            let decoded = self.decoder.push_request(b, &mut req);
            if b == 0 {
                let fp = core::mem::replace(&mut self.fingerprint, Fingerprint::START);
                match decoded {
                    Some(Ok(())) => self.on_request(&mut req, fp.0),
                    Some(Err(protocol::FrameError::Legacy)) => self.on_v1_frame(),
                    _ => {}
                }
            }
        }
    }

    /// One sample of every sensor and button.
    pub fn handle_inputs(&mut self, inputs: &Inputs, now_ms: u64) {
        self.advance_clock(now_ms);
        // The ADC's lowest bits are noise: cheap entropy for session ids.
        self.link.entropy = self.link.entropy.rotate_left(3) ^ u32::from(inputs.pressure_raw);
        self.on_pressure(inputs.pressure_raw);
        self.on_buttons(inputs.buttons);
        self.panel.joystick.raw = inputs.joystick_raw;
        self.update_outputs();
    }

    /// The passage of time: runs the control loop (plan steps, time limits, link watch, servo
    /// slewing, periodic events).
    pub fn handle_time(&mut self, now_ms: u64) {
        self.advance_clock(now_ms);
        let dt_ms = self.now_ms.saturating_sub(self.last_tick_ms);
        self.last_tick_ms = self.now_ms;
        self.check_link();
        if self.exec.is_some() {
            self.advance_exec();
        } else {
            self.standalone_joystick();
        }
        self.slew(dt_ms);
        self.update_outputs();
        self.periodic_events();
    }

    /// Moves bytes to send to the host into `out`; returns how many (0: nothing to send).
    pub fn poll_tx(&mut self, out: &mut [u8]) -> usize {
        self.tx.pop_into(out)
    }

    /// The actuator commands now.
    pub fn poll_outputs(&self) -> Outputs {
        self.act.outputs
    }

    /// The display content now, in priority order: the pressure while show-pressure is held;
    /// `E-xx` for the most recent active fault; `SAFE` after an abort; the task while a manual
    /// step waits (`H-Pb`, [`display::task`](crate::display::task)); otherwise the trunk state (`F-P ` …), with the last decimal point lit while a
    /// plan runs and the first one lit while the state is unconfirmed.
    pub fn poll_display(&self) -> [u8; 4] {
        use crate::display;
        if self.panel.buttons.show_pressure {
            if self.pressure_valid() {
                return display::pressure(self.pressure.filt_kpa);
            }
            return display::text("----");
        }
        if self.safety.faults != 0 {
            let code = self
                .safety
                .last_fault
                .filter(|f| self.fault_active(*f))
                .or_else(|| FaultCode::ALL.into_iter().find(|f| self.fault_active(*f)));
            if let Some(f) = code {
                return display::fault(f.code());
            }
        }
        if self.safety.safe || self.safety.estop_latched {
            return display::text("SAFE");
        }
        if let Some(t) = self.exec.as_ref().and_then(|e| e.waiting_task()) {
            return display::task(t);
        }
        if let Some(s) = self.ident.asking {
            // "Is it this one?": the candidate with every decimal point lit.
            let mut seg = display::text(s.display_text());
            for d in &mut seg {
                *d |= display::DP;
            }
            return seg;
        }
        let mut seg = display::text(self.trunk.belief.state().display_text());
        if self.exec.is_some() {
            seg[3] |= display::DP;
        }
        if !self.trunk.belief.is_confirmed() {
            seg[0] |= display::DP;
        }
        seg
    }

    /// The record to persist, once per change (the shell saves it, then calls
    /// [`Controller::handle_stored`]).
    pub fn poll_store(&mut self) -> Option<StoredState> {
        let s = self.trunk.journal.pending.take();
        if s.is_some() {
            self.trunk.journal.polled = self.trunk.journal.made;
        }
        s
    }

    /// Link signing at boot: the key the store holds (`None`: signing off), and whether the
    /// store can keep one at all (pairing is refused when it cannot). The shell calls it once
    /// after [`Controller::new`] ([`crate::hw::Shell::boot`]).
    #[cfg(feature = "link-signing")]
    pub fn set_link_key(&mut self, key: Option<protocol::sign::LinkKey>, store_keeps_key: bool) {
        self.signing.key = key;
        self.signing.store_keeps_key = store_keeps_key;
        self.decoder.set_key(key.as_ref());
    }

    /// A link key change to persist (`Some(None)`: forget the key), taken once; the shell
    /// writes it to its store ([`crate::hw::StateStore::save_link_key`]).
    #[cfg(feature = "link-signing")]
    pub fn poll_link_key(&mut self) -> Option<Option<protocol::sign::LinkKey>> {
        self.signing.to_store.take()
    }

    /// The probe profile at boot: the one the store holds (`None`: the configuration's
    /// [`CraneConfig::probe_profile`] stays), and whether the store can keep one at all
    /// (storing one is refused when it cannot). The shell calls it once after
    /// [`Controller::new`] ([`crate::hw::Shell::boot`]).
    pub fn set_probe_profile(
        &mut self,
        profile: Option<identify::ProbeProfile>,
        store_keeps_profile: bool,
    ) {
        if profile.is_some() {
            self.cfg.probe_profile = profile;
        }
        self.ident.store_keeps_profile = store_keeps_profile;
    }

    /// A probe profile change to persist (`Some(None)`: erase it), taken once; the shell
    /// writes it to its store ([`crate::hw::StateStore::save_probe_profile`]).
    pub fn poll_probe_profile(&mut self) -> Option<Option<identify::ProbeProfile>> {
        self.ident.profile_to_store.take()
    }

    /// The probe profile identification decides with (`None`: it asks the operator).
    pub fn probe_profile(&self) -> Option<identify::ProbeProfile> {
        self.cfg.probe_profile
    }

    /// Whether link signing is on (every session-bound request must be signed).
    pub fn signing(&self) -> bool {
        #[cfg(feature = "link-signing")]
        return self.signing.key.is_some();
        #[cfg(not(feature = "link-signing"))]
        false
    }

    /// The record last taken with [`Controller::poll_store`] is persisted. A step's first
    /// actuation waits for this (the journal is written ahead of the motion).
    pub fn handle_stored(&mut self) {
        self.trunk.journal.persisted = self.trunk.journal.polled;
    }

    /// What the last identification probe measured (for reports and calibration).
    pub fn last_probe(&self) -> Option<identify::ProbeLog> {
        self.ident.last
    }

    /// What the controller believes about the trunk.
    pub fn belief(&self) -> &Belief {
        &self.trunk.belief
    }

    /// The next `now_ms` at which [`Controller::handle_time`] must run: one control period
    /// ahead while anything moves or a plan runs, else the next heartbeat, telemetry or link
    /// deadline (at most one second ahead).
    pub fn poll_deadline(&self) -> u64 {
        let now = self.now_ms;
        let moving = self.act.servo_deg != self.act.servo_target_deg;
        let active = self.exec.is_some()
            || moving
            || self.act.outputs.inlet_open
            || self.act.outputs.exhaust_open
            || self.panel.joystick.armed;
        let mut d = if active {
            now + self.cfg.control_period_ms as u64
        } else {
            now + 1_000
        };
        if self.link.handshake {
            d = d.min(self.periodic.next_heartbeat_ms.max(now));
            if self.cfg.telemetry_hz > 0.0 {
                d = d.min(self.periodic.next_telemetry_ms.max(now));
            }
        }
        d
    }

    /// The status snapshot (the one `GetStatus` returns).
    pub fn status(&self) -> Status {
        let stats = self.decoder.stats();
        let (state_confirmed, candidates, interrupted) = self.reported_belief();
        Status {
            state: self.trunk.belief.state(),
            state_confirmed,
            candidates,
            interrupted,
            mode: self.mode(),
            pressure_kpa: self.pressure.filt_kpa,
            servo_deg: self.act.outputs.servo_deg,
            inlet_open: self.act.outputs.inlet_open,
            exhaust_open: self.act.outputs.exhaust_open,
            gripper_closed: self.act.outputs.gripper_closed,
            estop: self.safety.estop_latched,
            plan: self.plan_status,
            manual_task: self.exec.as_ref().and_then(|e| e.waiting_task()),
            faults: self.safety.faults,
            frames_rx: stats.frames_ok,
            frames_dropped: stats.frames_dropped,
            uptime_ms: self.uptime_ms(),
        }
    }

    /// What the controller is doing.
    pub fn mode(&self) -> Mode {
        if self.safety.estop_latched {
            Mode::EStop
        } else if self.safety.safe {
            Mode::Safe
        } else if let Some(e) = &self.exec {
            if e.waiting_manual() {
                Mode::WaitingManual
            } else {
                Mode::Running
            }
        } else {
            Mode::Standalone
        }
    }

    /// The current session id (0: none), as the last successful handshake opened it.
    pub fn session(&self) -> u32 {
        self.link.session
    }

    /// The configuration in force (after validation and parameter changes).
    pub fn config(&self) -> &CraneConfig {
        &self.cfg
    }

    /// The filtered gauge pressure the controller acts on.
    pub fn pressure_kpa(&self) -> f32 {
        self.pressure.filt_kpa
    }

    /// Frames dropped from the transmit queue for lack of space (events only; a response that
    /// does not fit is re-sent from the cache when the host retries).
    pub fn tx_dropped(&self) -> u32 {
        self.tx.dropped
    }

    fn uptime_ms(&self) -> u32 {
        self.now_ms.saturating_sub(self.boot_ms) as u32
    }

    fn pressure_valid(&self) -> bool {
        self.pressure.init
            && !self.pressure.at_rail
            && !self.fault_active(FaultCode::PressureSensor)
    }

    // -----------------------------------------------------------------------------------------
    // Sensors
    // -----------------------------------------------------------------------------------------

    fn on_pressure(&mut self, raw: u16) {
        let now = self.now_ms;
        let cal = self.cfg.pressure_sensor;
        let at_rail = raw <= cal.rail_low_raw || raw >= cal.rail_high_raw;
        self.pressure.at_rail = at_rail;
        if at_rail {
            let since = *self.pressure.rail_since_ms.get_or_insert(now);
            if now.saturating_sub(since) >= cal.dropout_ms as u64
                && !self.fault_active(FaultCode::PressureSensor)
            {
                self.raise(FaultCode::PressureSensor);
            }
            self.snap.reset();
            self.watch.leak = LeakWatch::default();
            return;
        }
        self.pressure.rail_since_ms = None;
        let kpa = cal.kpa(raw);
        let dt = now.saturating_sub(self.pressure.last_ms) as f32;
        self.pressure.last_ms = now;
        self.pressure.raw_kpa = kpa;
        if !self.pressure.init {
            self.pressure.filt_kpa = kpa;
            self.pressure.init = true;
        } else {
            let alpha = if cal.filter_tau_ms <= 0.0 {
                1.0
            } else {
                dt / (cal.filter_tau_ms + dt)
            };
            self.pressure.filt_kpa += alpha * (kpa - self.pressure.filt_kpa);
        }
        if self.fault_active(FaultCode::PressureSensor) {
            // Readings resumed, but the fault stays until reset: keep venting, detect nothing.
            return;
        }
        let p = self.pressure.filt_kpa;

        // Over-pressure: vent at once, whatever runs. The filtered value lags a fast rise by
        // the filter's time constant, so a run of unfiltered samples above the cap also
        // counts (a single glitched sample does not).
        if kpa > self.cfg.pressure_limit_kpa {
            self.pressure.above_cap = self.pressure.above_cap.saturating_add(1);
        } else {
            self.pressure.above_cap = 0;
        }
        if p > self.cfg.pressure_limit_kpa || self.pressure.above_cap >= OVERPRESSURE_SAMPLES {
            self.safety.venting_for_safety = true;
            if !self.fault_active(FaultCode::OverPressure) {
                self.raise(FaultCode::OverPressure);
            }
        } else if self.safety.venting_for_safety {
            let vent_to = self
                .cfg
                .overpressure_vent_to_kpa
                .min(self.cfg.pressure_limit_kpa * 0.5);
            if p <= vent_to {
                self.safety.venting_for_safety = false;
            }
        }

        // Snap-throughs.
        let snapped = self.snap.feed(p, now, &self.cfg.snap);
        if let Some(s) = snapped {
            self.watch.leak = LeakWatch::default();
            self.on_snap(s.sign);
        }
        self.check_rest(p, snapped.is_some());

        self.check_leak(p);
        self.check_inlet(p);
    }

    fn on_snap(&mut self, sign: SnapSign) {
        let counted = self.exec.as_mut().is_some_and(|e| e.on_snap(sign));
        if counted {
            self.advance_exec();
        }
    }

    // -----------------------------------------------------------------------------------------
    // Actuators
    // -----------------------------------------------------------------------------------------

    /// The servo angles of a set of tendon shortenings, or `None` if one is outside the limits.
    fn angles_for(&self, length_mm: [f32; 3]) -> Option<[f32; 3]> {
        angles_for(&self.cfg, length_mm)
    }

    /// Whether all three tendons can be at `length_mm` (the same on each) within the servo
    /// limits: exactly `angles_for([length_mm; 3]).is_some()`, in two comparisons (a plan's
    /// upload checks every tendon primitive and `Bend` this way, all in one loop pass).
    fn equal_pull_allowed(&self, length_mm: f32) -> bool {
        let (lo, hi) = self.pull_range_mm;
        lo <= length_mm && length_mm <= hi
    }

    /// Tendon shortenings for a constant-curvature bend around the state's taken-up slack: the
    /// tendon on the inside of the bend is reeled in by r_t·θ·cos(φ − φ_i) more, the others pay
    /// out (a tendon cannot push: never below 0). `geometry::tendon`'s law, in `f32` (as the
    /// joystick's): its `f64` costs the board binary software double precision. The direction
    /// is reduced in degrees (exactly) before any trigonometry, so every finite one works.
    fn bend_lengths(&self, direction_deg: f32, angle_rad: f32) -> Option<[f32; 3]> {
        let take_up_mm = self.take_up_for(self.state());
        if stiff_bend_limit_rad(&self.cfg, take_up_mm, self.max_bend_deg)
            .is_some_and(|limit_rad| libm::fabsf(angle_rad) > limit_rad)
        {
            return None;
        }
        let k = self.cfg.geometry.tendon_radius_mm * angle_rad;
        let (sin_d, cos_d) = crate::mathf::sin_cos_deg(direction_deg);
        if !(sin_d.is_finite() && k.is_finite()) {
            return None;
        }
        let mut out = [0.0; 3];
        for (o, (sin_i, cos_i)) in out.iter_mut().zip(TENDON_DIRECTIONS) {
            // cos(φ − φ_i) = cos φ cos φ_i + sin φ sin φ_i
            *o = (take_up_mm + k * (cos_d * cos_i + sin_d * sin_i)).max(0.0);
        }
        Some(out)
    }

    /// The tendon shortening that takes up `state`'s slack (0 outside the flexible states).
    fn take_up_for(&self, state: TrunkState) -> f32 {
        self.take_up_mm[state.index()]
    }

    // -----------------------------------------------------------------------------------------
    // Link
    // -----------------------------------------------------------------------------------------

    fn check_link(&mut self) {
        let host_plan = self
            .exec
            .as_ref()
            .is_some_and(|e| matches!(e.origin, exec::Origin::Host | exec::Origin::Identify));
        if host_plan
            && self.now_ms.saturating_sub(self.link.last_rx_ms) >= self.cfg.link_timeout_ms as u64
        {
            self.raise(FaultCode::LinkLoss);
        }
    }

    /// Queues an event (only once a host has shaken hands: nobody listens before).
    fn emit(&mut self, ev: Event) {
        if !self.link.handshake {
            return;
        }
        if self.defer_events {
            if let Err(ev) = self.deferred.push(ev) {
                self.send_event(ev);
            }
            return;
        }
        self.send_event(ev);
    }

    fn send_event(&mut self, ev: Event) {
        // Events encode to under 64 bytes; a small scratch saves clearing 512 bytes per event.
        let mut scratch = [0u8; EVENT_SCRATCH_LEN];
        match protocol::encode_device_message(&DeviceMessage::Event(ev), &mut scratch) {
            Ok(n) => {
                self.tx.push_frame(&scratch[..n], RESPONSE_RESERVE);
            }
            Err(_) => self.tx.dropped = self.tx.dropped.wrapping_add(1),
        }
    }

    fn periodic_events(&mut self) {
        if !self.link.handshake {
            return;
        }
        let now = self.now_ms;
        let mut progress_due = false;
        if now >= self.periodic.next_heartbeat_ms {
            self.periodic.next_heartbeat_ms = now + protocol::HEARTBEAT_PERIOD_MS as u64;
            let (uptime_ms, mode) = (self.uptime_ms(), self.mode());
            self.emit(Event::Heartbeat { uptime_ms, mode });
            progress_due = true;
        }
        if self.cfg.telemetry_hz > 0.0 && now >= self.periodic.next_telemetry_ms {
            let period = (1_000.0 / self.cfg.telemetry_hz) as u64;
            self.periodic.next_telemetry_ms = now + period.max(1);
            let t = Telemetry {
                uptime_ms: self.uptime_ms(),
                pressure_kpa: self.pressure.filt_kpa,
                servo_deg: self.act.outputs.servo_deg,
                inlet_open: self.act.outputs.inlet_open,
                exhaust_open: self.act.outputs.exhaust_open,
                state: self.state(),
                state_confirmed: self.confirmed() && self.moving_step().is_none(),
            };
            self.emit(Event::Telemetry(t));
            progress_due = true;
        }
        if progress_due && now.saturating_sub(self.periodic.last_progress_ms) >= PROGRESS_PERIOD_MS
        {
            if let Some(e) = &self.exec {
                let ev = Event::StepProgress {
                    plan_id: e.plan.plan_id,
                    step: e.step,
                    primitive: e.prim,
                    elapsed_ms: now.saturating_sub(e.step_start_ms) as u32,
                };
                self.periodic.last_progress_ms = now;
                self.emit(ev);
            }
        }
    }
}

/// Tendon shortenings for a joystick deflection `(x, y)` (full scale ±1): the single-precision
/// twin of `geometry::tendon::JoystickMap::bend` followed by `TendonGeometry::length_changes`
/// (Δl_i = −r_t·θ·cos(φ − φ_i); the shortening is −Δl_i, negative for a tendon that pays
/// out). The caller adds them to the state's taken-up slack.
///
/// Why a twin: the M4F has a single-precision FPU only; the `f64` path is emulated in software
/// and costs ~14 000 instructions per update (`docs/firmware.md`, "Timing"), this one a few
/// hundred. A unit test pins it to the geometry crate within 0.01 mm.
pub fn joystick_lengths_f32(
    x: f32,
    y: f32,
    dead_zone: f32,
    max_bend_deg: f32,
    tendon_radius_mm: f32,
) -> [f32; 3] {
    if !(x.is_finite() && y.is_finite()) {
        return [0.0; 3];
    }
    let (x, y) = (crate::clampf(x, -1.0, 1.0), crate::clampf(y, -1.0, 1.0));
    let r = crate::mathf::hypot(x, y);
    let m = r.min(1.0);
    let dz = crate::clampf(dead_zone, 0.0, 0.99);
    if m <= dz {
        return [0.0; 3];
    }
    let angle_rad = max_bend_deg.to_radians() * (m - dz) / (1.0 - dz);
    let k = tendon_radius_mm * angle_rad;
    // The bend's direction φ is the deflection's: cos(φ − φ_i) = (x cos φ_i + y sin φ_i) / r,
    // no angle needed (r > the dead zone ≥ 0 here).
    let (cx, cy) = (x / r, y / r);
    let mut out = [0.0; 3];
    for (o, (sin_i, cos_i)) in out.iter_mut().zip(TENDON_DIRECTIONS) {
        *o = k * (cx * cos_i + cy * sin_i);
    }
    out
}

/// `(sin φ_i, cos φ_i)` of the three tendons' angles (`geometry::tendon::TENDON_ANGLES`: 0°,
/// 120°, 240°; a test holds them to the geometry crate's).
const TENDON_DIRECTIONS: [(f32, f32); 3] = [(0.0, 1.0), (0.866_025_4, -0.5), (-0.866_025_4, -0.5)];

/// The servo angles of a set of tendon shortenings, or `None` if one is outside the limits.
fn angles_for(cfg: &CraneConfig, length_mm: [f32; 3]) -> Option<[f32; 3]> {
    let (sc, w) = (&cfg.servo, &cfg.geometry.winch);
    let deg_per_mm = 1.0 / w.mm_per_deg();
    let mut a = [0.0; 3];
    for (i, l) in length_mm.iter().enumerate() {
        if !(l.is_finite() && *l >= 0.0 && *l <= cfg.max_tendon_mm) {
            return None;
        }
        a[i] = w.slack_deg[i] + w.pull_sign[i] * l * deg_per_mm;
        if !sc.allows(a[i]) {
            return None;
        }
    }
    Some(a)
}

/// The shortenings `l` with `angles_for(cfg, [l; 3]).is_some()`, as `(lo, hi)` (`lo > hi`:
/// none), found exactly: that set is an interval of the floats, because each angle is a
/// monotone function of `l` (a product with the fixed sign, one with the fixed degrees per
/// mm, a sum with the fixed slack angle: every rounding step is monotone) and each test
/// (finite, within the limits, within `0..=max_tendon_mm`) keeps an interval. So: a point of
/// it from the closed form, then each end by bisection over the floats' bit patterns (in
/// order for non-negative floats), ≤ 2 × 32 evaluations when the limits change.
fn equal_pull_range(cfg: &CraneConfig) -> (f32, f32) {
    const EMPTY: (f32, f32) = (1.0, 0.0);
    let ok = |l: f32| angles_for(cfg, [l; 3]).is_some();
    let (sc, w) = (&cfg.servo, &cfg.geometry.winch);
    let top = cfg.max_tendon_mm;
    let mm_per_deg = w.mm_per_deg();
    let (mut lo, mut hi) = (0.0f32, top);
    for i in 0..3 {
        let a = (sc.min_deg - w.slack_deg[i]) * mm_per_deg * w.pull_sign[i];
        let b = (sc.max_deg - w.slack_deg[i]) * mm_per_deg * w.pull_sign[i];
        lo = lo.max(a.min(b));
        hi = hi.min(a.max(b));
    }
    let Some(inside) = [(lo + hi) * 0.5, lo, hi, 0.0, top]
        .into_iter()
        .find(|&l| l >= 0.0 && ok(l))
    else {
        return EMPTY;
    };
    // The last float still `ok` walking from `inside` toward `outside` (bit patterns).
    let edge = |inside: f32, outside: f32| {
        let (mut a, mut b) = (inside.to_bits(), outside.to_bits());
        while a.abs_diff(b) > 1 {
            let m = a / 2 + b / 2 + (a & b & 1);
            if ok(f32::from_bits(m)) {
                a = m;
            } else {
                b = m;
            }
        }
        f32::from_bits(a)
    };
    let low = if ok(0.0) { 0.0 } else { edge(inside, 0.0) };
    let high = if ok(top) { top } else { edge(inside, top) };
    (low, high)
}

/// Every servo at its slack angle (zero shortening), within the limits.
fn slack_angles(cfg: &CraneConfig) -> [f32; 3] {
    core::array::from_fn(|i| {
        crate::clampf(
            cfg.geometry.winch.angle_for_length(i, 0.0),
            cfg.servo.min_deg,
            cfg.servo.max_deg,
        )
    })
}

/// The largest bend in `state`: the joystick's full deflection, less where no module is folded.
fn max_bend_deg(cfg: &CraneConfig, state: TrunkState) -> f32 {
    cfg.geometry.max_bend_deg_in(state)
}

/// The largest bend a stiff state takes before it buckles (D&P: no folded module), with a
/// rounding allowance, or `None` where only the tendons limit a bend. The same rule at a
/// plan's upload (each step's `from`) and when a `Bend` runs.
fn stiff_bend_limit_rad(cfg: &CraneConfig, take_up_mm: f32, max_bend_deg: f32) -> Option<f32> {
    (take_up_mm > 0.0 && max_bend_deg < cfg.geometry.max_bend_deg)
        .then(|| max_bend_deg.to_radians() + 1e-5)
}

/// The tendon shortening that takes up `state`'s slack, short of taut by the margin: in the
/// flexible states (the joystick's and `Bend`'s), 0 elsewhere (D&D has none; F&P is not bent).
fn take_up_mm(cfg: &CraneConfig, state: TrunkState) -> f32 {
    if !state.is_flexible() {
        return 0.0;
    }
    (cfg.tendon_slack_mm(state) - cfg.geometry.take_up_margin_mm).max(0.0)
}
