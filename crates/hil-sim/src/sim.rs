//! The simulator: physics, simulated parts and the real controller on one virtual clock.

use std::collections::VecDeque;
use std::fmt::Write as _;

use firmware::hw::{PinInputs, PinOutputs, ServoOutput, ServoPulse, Shell};
/// The buttons a test or a person holds ([`Sim::set_buttons`]): the controller's own input.
pub use firmware::Buttons;
use firmware::{Controller, CraneConfig, StoredState};
use geometry::TrunkState;
use protocol::messages::{Board, DeviceMessage, Event, ManualTask, Mode, ModuleConfig};
use protocol::{CraneGeometry, FrameDecoder};
use rand::{Rng, SeedableRng};

use crate::devices::{
    segments_text, SimAnalog, SimDisplay, SimFlash, SimInputPin, SimOutputPin, SimPwm, SimSerial,
};
#[cfg(feature = "pil")]
use crate::elf_board::{ElfBoard, ElfBoardError};
use crate::fault::{Fault, FaultInjector};
use crate::operator::{Operator, OperatorAction};
use crate::physics::params::{
    BOTTOM_BETA_DEG, BOTTOM_LAYERS, EDGE_MM, N_SIDES, PACKED_LAYER_MM, TOP_BETA_DEG, TOP_LAYERS,
};
use crate::physics::trunk::{well_name, Module};
use crate::physics::{Actuation, Trunk, TrunkError, TrunkSpec};
use crate::rng::SimRng;
use crate::servo::{Servo, ServoSpec};

/// Virtual time of one simulation step (the board's loop runs at 1 kHz).
pub const STEP_MS: u64 = 1;
/// Pressure sensor noise, kPa (1σ, before quantisation): ≈ 7 mV on an MPX5100-class output,
/// what an unshielded sensor shows on an Arduino ADC.
pub const SENSOR_NOISE_KPA: f64 = 0.15;
/// Joystick ADC noise, counts (1σ).
pub const JOYSTICK_NOISE_RAW: f64 = 3.0;
pub use crate::fault::{
    LINE_NOISE_RATE, MID_PLAN_FAULT_DELAY_MS, SERVO_STALL_FAULT_TORQUE, TENDON_BREAK_N,
};

/// How to run the simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    /// The trunk's true state at start (also what the controller's flash holds, confirmed).
    pub initial: TrunkState,
    /// Seed of every random choice (sensor noise, line noise).
    pub seed: u64,
    /// Faults to inject.
    pub faults: Vec<Fault>,
    /// Virtual seconds per wall second in pty mode (`f64::INFINITY`: as fast as possible).
    pub speed: f64,
    /// A simulated person does manual steps.
    pub operator: bool,
    /// Run this `uno-r4` ELF in the RA4M1 emulator instead of the host-built controller
    /// (processor in the loop, [`crate::elf_board`]).
    pub firmware_elf: Option<std::path::PathBuf>,
    /// The trunk's physics (`trunks/pdf.toml` by default; `--sim-trunk FILE`); checked by
    /// [`Sim::try_new`].
    pub trunk: TrunkSpec,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            initial: TrunkState::AS_MANUFACTURED,
            seed: 0,
            faults: Vec::new(),
            speed: 20.0,
            operator: true,
            firmware_elf: None,
            trunk: TrunkSpec::pdf(),
        }
    }
}

/// Why [`Sim::try_new`] could not start the simulator.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// The firmware ELF could not be loaded or the emulator refused it.
    #[cfg(feature = "pil")]
    #[error(transparent)]
    Board(#[from] ElfBoardError),
    /// A firmware ELF was asked for, but this build has no emulator.
    #[error(
        "{0}: this build of hil-sim has no processor in the loop (the RA4M1 emulator is its \
         feature `pil`); build it with `--features pil` to run a firmware ELF"
    )]
    NoPil(String),
    /// The trunk's description is one the physics cannot represent.
    #[error(transparent)]
    Trunk(#[from] TrunkError),
}

/// The truth that judges safety ([`Sim::safety`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Safety {
    /// The trunk's true state (`None` between states).
    pub true_state: Option<TrunkState>,
    /// True gauge pressure, kPa.
    pub pressure_kpa: f32,
    /// The running controller's pressure cap, kPa ([`Sim::pressure_limit_kpa`]).
    pub pressure_limit_kpa: f32,
    /// The inlet passes air (a stuck valve included).
    pub inlet_open: bool,
    /// The controller commands the inlet open.
    pub inlet_commanded_open: bool,
    /// The exhaust passes air.
    pub exhaust_open: bool,
    /// Every servo limp or at its command.
    pub servos_still: bool,
    /// As [`GroundTruth::actuators_safe`].
    pub actuators_safe: bool,
}

/// What really happened, for judging the controller.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundTruth {
    /// The trunk's true state (`None` while snapping or with the bottom half-packed).
    pub true_state: Option<TrunkState>,
    /// Highest true gauge pressure so far, kPa.
    pub max_pressure_kpa: f32,
    /// The running controller's pressure cap, kPa ([`Sim::pressure_limit_kpa`]).
    pub pressure_limit_kpa: f32,
    /// Inlet closed, every servo limp or at its command (none pushing toward a position it
    /// has not reached), and the pressure within the cap.
    pub actuators_safe: bool,
    /// True gauge pressure now, kPa.
    pub pressure_kpa: f32,
    /// Virtual time, ms.
    pub time_ms: u64,
    /// Module heights `[top, bottom]`, mm.
    pub module_heights_mm: [f32; 2],
    /// Tip bend angle, degrees.
    pub bend_deg: f32,
    /// Tendon tensions, N.
    pub tendon_tension_n: [f32; 3],
    /// Servo shaft angles, degrees.
    pub servo_deg: [f32; 3],
    /// Servos powered (receiving pulses).
    pub servos_energised: [bool; 3],
    /// Inlet passes air (including a stuck valve).
    pub inlet_open: bool,
    /// Exhaust passes air.
    pub exhaust_open: bool,
    /// Gripper closed.
    pub gripper_closed: bool,
    /// The display's content as text (`.` after a digit with its decimal point lit).
    pub display: String,
    /// What the controller believes.
    pub believed_state: TrunkState,
    /// The controller's mode.
    pub mode: Mode,
    /// Snap-throughs so far.
    pub snaps: u32,
    /// Manual tasks the simulated operator did.
    pub manual_tasks: u32,
    /// Faults injected.
    pub faults: Vec<Fault>,
}

type SimInputs = PinInputs<
    SimAnalog,
    SimAnalog,
    SimAnalog,
    SimInputPin,
    SimInputPin,
    SimInputPin,
    SimInputPin,
    SimInputPin,
    SimInputPin,
>;
type SimOutputs = PinOutputs<SimPwm, SimPwm, SimPwm, SimOutputPin, SimOutputPin, SimOutputPin>;
/// The shell over the simulated parts (in ELF mode: only the parts, the emulator is the loop).
pub type SimShell = Shell<SimInputs, SimOutputs, SimDisplay, SimFlash, SimSerial>;

/// The crane's configuration as the simulator builds it: the firmware's defaults (the same
/// trunk: a test checks it), with the board of this simulator; the trunk is still set from
/// the physics' constants, so a change there reaches the controller.
pub fn sim_crane_config() -> CraneConfig {
    CraneConfig {
        board: Board::Simulator,
        geometry: sim_crane_geometry(),
        ..CraneConfig::default()
    }
    .validated()
}

/// The simulated crane's shape (what a host plans the simulator with): the firmware's default
/// geometry with the simulated trunk's modules and packed layer.
pub fn sim_crane_geometry() -> CraneGeometry {
    CraneGeometry {
        top: ModuleConfig {
            n: N_SIDES as u8,
            beta_deg: TOP_BETA_DEG as f32,
            edge_mm: EDGE_MM as f32,
            layers: TOP_LAYERS as u8,
        },
        bottom: ModuleConfig {
            n: N_SIDES as u8,
            beta_deg: BOTTOM_BETA_DEG as f32,
            edge_mm: EDGE_MM as f32,
            layers: BOTTOM_LAYERS as u8,
        },
        packed_layer_mm: PACKED_LAYER_MM as f32,
        ..CraneConfig::default().geometry
    }
}

/// The simulated crane running the real controller.
pub struct Sim {
    opts: SimOptions,
    rng: SimRng,
    now_ms: u64,
    cfg: CraneConfig,
    trunk: Trunk,
    servos: [Servo; 3],
    shell: SimShell,
    ctl: Controller,
    operator: Operator,
    /// Buttons a test or a person holds: the controller's own [`Buttons`] (`true` = pressed);
    /// the shell's pins carry them (active-low, the e-stop normally closed).
    held: Buttons,
    joystick: [f64; 2],
    /// Device → host bytes after the link (noise, drop).
    to_host: VecDeque<u8>,
    sniffer: FrameDecoder,
    max_pressure_kpa: f64,
    snaps: u32,
    /// Every fault, applied where a signal crosses between the shell and the parts.
    faults: FaultInjector,
    trace: Option<Trace>,
    payload_n: f64,
    spare_gauss: Option<f64>,
    /// The display's segments the operator last read, and the task they name.
    shown: ([u8; 4], Option<ManualTask>),
    /// Each servo's last duty count taken (`None`: none yet) and the tendon pay-in of its shaft
    /// angle (the angle's bits, mm): a still servo recomputes neither.
    duty_seen: [Option<u16>; 3],
    pay_in: [(u64, f64); 3],
    /// The board ELF in the emulator (processor in the loop), when it runs instead of `ctl`.
    #[cfg(feature = "pil")]
    board: Option<Box<ElfBoard>>,
    board_error: Option<String>,
    /// Objects, the tip load and the true tip ([`crate::world`]).
    world: crate::world::World,
}

impl std::fmt::Debug for Sim {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sim")
            .field("now_ms", &self.now_ms)
            .field("true_state", &self.trunk.state())
            .field("pressure_kpa", &self.trunk.pressure_kpa())
            .finish_non_exhaustive()
    }
}

#[derive(Debug, Clone)]
struct Trace {
    period_ms: u64,
    text: String,
}

impl Sim {
    /// A simulator at virtual time 0 with the trunk at rest in `opts.initial`.
    ///
    /// With [`SimOptions::firmware_elf`] or a trunk of one's own use [`Sim::try_new`] (loading
    /// the ELF can fail, and a description can be one the physics cannot represent); here a
    /// failure is reported on stderr and the host-built controller runs (on the calibrated
    /// trunk, when it was the trunk that was refused).
    pub fn new(opts: SimOptions) -> Self {
        match Self::try_new(opts.clone()) {
            Ok(s) => s,
            Err(e) => {
                let trunk_refused = matches!(e, StartError::Trunk(_));
                eprintln!(
                    "hil-sim: {e}; running the host-built controller{} instead",
                    if trunk_refused {
                        " on the calibrated trunk (trunks/pdf.toml)"
                    } else {
                        ""
                    }
                );
                let trunk = if trunk_refused {
                    TrunkSpec::pdf()
                } else {
                    opts.trunk.clone()
                };
                Self::try_new(SimOptions {
                    firmware_elf: None,
                    trunk,
                    ..opts.clone()
                })
                .or_else(|_| {
                    Self::try_new(SimOptions {
                        firmware_elf: None,
                        trunk: TrunkSpec::pdf(),
                        ..opts
                    })
                })
                .unwrap_or_else(|_| {
                    unreachable!("without an ELF, on the calibrated trunk, nothing can fail")
                })
            }
        }
    }

    /// A simulator at virtual time 0 with the trunk at rest in `opts.initial`; fails when the
    /// firmware ELF cannot be loaded.
    pub fn try_new(opts: SimOptions) -> Result<Self, StartError> {
        let cfg = sim_crane_config();
        let mut params = opts.trunk.params()?;
        // The tendons run where the rig puts them: the controller's configured radius.
        params.tendon_radius_mm = cfg.geometry.tendon_radius_mm as f64;
        let trunk = Trunk::new(params, opts.initial);
        let spec = ServoSpec::default();
        let faults = FaultInjector::new(&opts.faults);
        let mut servos: [Servo; 3] =
            core::array::from_fn(|i| Servo::new(spec, cfg.geometry.winch.slack_deg[i] as f64));
        for s in &mut servos {
            s.spec.stall_torque_n_m *= faults.stall_torque_factor();
        }
        let center = cfg.joystick.center_raw;
        let inputs = PinInputs {
            pressure: SimAnalog::new(cfg.pressure_sensor.raw(0.0)),
            joystick_x: SimAnalog::new(center[0]),
            joystick_y: SimAnalog::new(center[1]),
            up: SimInputPin::new(true),
            down: SimInputPin::new(true),
            gripper: SimInputPin::new(true),
            estop: SimInputPin::new(false),
            confirm: SimInputPin::new(true),
            show_pressure: SimInputPin::new(true),
        };
        let pulse = ServoPulse::default();
        let outputs = PinOutputs {
            servos: (
                ServoOutput::new(SimPwm::default(), pulse),
                ServoOutput::new(SimPwm::default(), pulse),
                ServoOutput::new(SimPwm::default(), pulse),
            ),
            inlet: SimOutputPin::default(),
            exhaust: SimOutputPin::default(),
            gripper: SimOutputPin::default(),
        };
        let flash = SimFlash::holding(StoredState::confirmed(opts.initial));
        let mut shell = Shell::new(
            inputs,
            outputs,
            SimDisplay::default(),
            flash,
            SimSerial::default(),
        );
        let ctl = shell.boot(cfg, 0);
        let operator = Operator::new(opts.operator);
        #[cfg(feature = "pil")]
        let board = match &opts.firmware_elf {
            Some(path) => Some(Box::new(ElfBoard::new(
                path,
                StoredState::confirmed(opts.initial),
            )?)),
            None => None,
        };
        #[cfg(not(feature = "pil"))]
        if let Some(path) = &opts.firmware_elf {
            return Err(StartError::NoPil(path.display().to_string()));
        }
        Ok(Self {
            rng: SimRng::seed_from_u64(opts.seed),
            opts,
            now_ms: 0,
            cfg,
            trunk,
            servos,
            shell,
            ctl,
            operator,
            held: Buttons::default(),
            joystick: [0.0; 2],
            to_host: VecDeque::new(),
            sniffer: FrameDecoder::default(),
            max_pressure_kpa: 0.0,
            snaps: 0,
            faults,
            trace: None,
            payload_n: 0.0,
            spare_gauss: None,
            shown: ([0; 4], crate::operator::task_shown([0; 4])),
            duty_seen: [None; 3],
            pay_in: [(f64::NAN.to_bits(), f64::NAN); 3],
            #[cfg(feature = "pil")]
            board,
            board_error: None,
            world: crate::world::World::new(),
        })
    }

    /// A copy of this run from now on (same state, same random stream), for the power-cut
    /// campaign to cut every 10 ms of one step without re-running its start. `None` with the
    /// firmware ELF (an emulated chip is not copied).
    pub fn fork(&self) -> Option<Sim> {
        if self.runs_elf() {
            return None;
        }
        Some(Sim {
            opts: self.opts.clone(),
            rng: self.rng.clone(),
            now_ms: self.now_ms,
            cfg: self.cfg,
            trunk: self.trunk.clone(),
            servos: self.servos,
            shell: self.shell.clone(),
            ctl: self.ctl.clone(),
            operator: self.operator.clone(),
            held: self.held,
            joystick: self.joystick,
            to_host: self.to_host.clone(),
            sniffer: self.sniffer.clone(),
            max_pressure_kpa: self.max_pressure_kpa,
            snaps: self.snaps,
            faults: self.faults.clone(),
            trace: self.trace.clone(),
            payload_n: self.payload_n,
            spare_gauss: self.spare_gauss,
            shown: self.shown,
            duty_seen: self.duty_seen,
            pay_in: self.pay_in,
            #[cfg(feature = "pil")]
            board: None,
            board_error: self.board_error.clone(),
            world: self.world.clone(),
        })
    }

    /// The emulated board, when the simulator runs the firmware ELF.
    #[cfg(feature = "pil")]
    pub fn elf_board(&self) -> Option<&ElfBoard> {
        self.board.as_deref()
    }

    /// The emulated board, mutably (to inject chip-level faults).
    #[cfg(feature = "pil")]
    pub fn elf_board_mut(&mut self) -> Option<&mut ElfBoard> {
        self.board.as_deref_mut()
    }

    /// The controller's mode: the host-built controller's, or the one the ELF last reported.
    pub fn mode(&self) -> Mode {
        #[cfg(feature = "pil")]
        if let Some(b) = &self.board {
            return b.mode;
        }
        self.ctl.mode()
    }

    /// The same simulator with the controller's link timeout set to `ms` (clamped to the
    /// parameter's range), booted again; for a wall-clock client of a sped-up simulator, whose
    /// heartbeats arrive `speed` times further apart in virtual time. Call before running (with
    /// the firmware ELF the board keeps its own default).
    pub fn with_link_timeout_ms(mut self, ms: u32) -> Self {
        self.cfg.link_timeout_ms = ms;
        self.cfg = self.cfg.validated();
        self.ctl = self.shell.boot(self.cfg, self.now_ms);
        self
    }

    /// The same simulator with the controller carrying `profile` (the identification probe's
    /// signatures of a calibration: `identify::SIM_PROFILE` is the calibrated trunk's), booted
    /// again. Without one (the default) the probe is no evidence and identification asks the
    /// operator. Call before running (the firmware ELF keeps its own).
    pub fn with_probe_profile(
        mut self,
        profile: Option<firmware::controller::identify::ProbeProfile>,
    ) -> Self {
        self.cfg.probe_profile = profile;
        self.ctl = self.shell.boot(self.cfg, self.now_ms);
        self
    }

    /// The options it runs with.
    pub fn options(&self) -> &SimOptions {
        &self.opts
    }

    /// Virtual time, ms.
    pub fn now_ms(&self) -> u64 {
        self.now_ms
    }

    /// The crane configuration the host-built controller booted with (a board ELF boots with
    /// its own; the pressure cap in effect is [`Sim::pressure_limit_kpa`]).
    pub fn crane_config(&self) -> &CraneConfig {
        &self.cfg
    }

    /// The controller (read-only: everything reaches it through the shell).
    pub fn controller(&self) -> &Controller {
        &self.ctl
    }

    /// The trunk physics.
    pub fn trunk(&self) -> &Trunk {
        &self.trunk
    }

    /// Holds buttons (as a person at the crane would), until changed.
    pub fn set_buttons(&mut self, held: Buttons) {
        self.held = held;
    }

    /// Deflects the joystick: each axis in −1…1.
    pub fn set_joystick(&mut self, x: f64, y: f64) {
        self.joystick = [x.clamp(-1.0, 1.0), y.clamp(-1.0, 1.0)];
    }

    /// Hangs an object on the tip (N; the gripper holds it).
    pub fn set_payload_n(&mut self, payload_n: f64) {
        self.payload_n = payload_n.max(0.0);
    }

    /// The world around the crane: objects, the tip load, the true tip.
    pub fn world(&self) -> &crate::world::World {
        &self.world
    }

    /// The tip's true pose now ([`crate::world::true_tip`]).
    pub fn true_tip(&self) -> geometry::reach::TipPose {
        crate::world::true_tip(&self.trunk)
    }

    /// Places `object` in the world while the crane runs, as a person does: the world first
    /// learns whether the gripper is closed now (an empty world does not follow it), so only a
    /// later closing catches the object.
    pub fn place_object(
        &mut self,
        object: crate::world::Object,
    ) -> Result<(), crate::world::WorldError> {
        let closed = self.shell.outputs.gripper.high;
        self.world.set_gripper(closed);
        self.world.place(object)
    }

    /// The world, to place objects or hang a load (and to take its grasp events).
    pub fn world_mut(&mut self) -> &mut crate::world::World {
        &mut self.world
    }

    /// Starts recording a compact trace: one line every `period_ms`, plus one per event.
    pub fn enable_trace(&mut self, period_ms: u64) {
        // The device's events are decoded only while tracing: from the next frame on.
        if self.trace.is_none() {
            self.sniffer = FrameDecoder::default();
        }
        self.trace = Some(Trace {
            period_ms: period_ms.max(1),
            text: String::new(),
        });
    }

    /// The trace recorded so far.
    pub fn trace(&self) -> &str {
        self.trace.as_ref().map_or("", |t| t.text.as_str())
    }

    /// Bytes from the host to the device (through the line's faults).
    pub fn write_host_bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if let Some(b) = self.faults.link_byte(b, &mut self.rng) {
                self.shell.link.rx.push_back(b);
            }
        }
    }

    /// Takes every byte the device has sent to the host so far.
    pub fn read_device_bytes(&mut self) -> Vec<u8> {
        self.to_host.drain(..).collect()
    }

    /// Appends every byte the device has sent to the host so far to `buf`.
    pub fn read_device_bytes_into(&mut self, buf: &mut Vec<u8>) {
        buf.extend(self.to_host.drain(..));
    }

    /// Whether the device has bytes waiting for the host.
    pub fn has_device_bytes(&self) -> bool {
        !self.to_host.is_empty()
    }

    /// Corrupts each byte on the link (both ways) with probability `rate` (0–1) from now on.
    pub fn set_line_noise_rate(&mut self, rate: f64) {
        self.faults.set_line_noise_rate(rate);
    }

    /// Injects `fault` now (a fault with an onset, for the swarm tester): from this step on the
    /// simulator behaves as if it had been given from the start; `link-drop` and
    /// `sensor-dropout` act at once.
    pub fn inject_fault(&mut self, fault: Fault) {
        if !self.faults.inject(fault) {
            return;
        }
        self.opts.faults.push(fault);
        if fault == Fault::ServoStall {
            for s in &mut self.servos {
                s.spec.stall_torque_n_m *= SERVO_STALL_FAULT_TORQUE;
            }
        }
    }

    /// The fault layer (what is given, what struck).
    pub fn fault_injector(&self) -> &FaultInjector {
        &self.faults
    }

    /// The simulated operator (to script mistakes).
    pub fn operator_mut(&mut self) -> &mut Operator {
        &mut self.operator
    }

    fn gauss(&mut self) -> f64 {
        // Marsaglia's polar method (rand 0.8 without rand_distr), both values of each pair
        // used: exactly normal, like Box–Muller, without its sine and cosine.
        if let Some(g) = self.spare_gauss.take() {
            return g;
        }
        loop {
            let u = 2.0 * self.rng.gen::<f64>() - 1.0;
            let v = 2.0 * self.rng.gen::<f64>() - 1.0;
            let s = u * u + v * v;
            if s > 0.0 && s < 1.0 {
                let f = (-2.0 * s.ln() / s).sqrt();
                self.spare_gauss = Some(v * f);
                return u * f;
            }
        }
    }

    /// Advances the virtual clock by one step ([`STEP_MS`]).
    pub fn step(&mut self) {
        self.now_ms += STEP_MS;
        let now = self.now_ms;

        // Mid-plan faults start a while after the first plan runs.
        let running = self.mode() == Mode::Running;
        self.faults.tick(now, running);

        // Sensors.
        let (gain, offset) = {
            let p = self.trunk.params();
            (p.sensor_gain, p.sensor_offset_kpa)
        };
        let p_kpa = gain * self.trunk.pressure_kpa() + offset + SENSOR_NOISE_KPA * self.gauss();
        let raw = self.cfg.pressure_sensor.raw(p_kpa as f32);
        let sensor = &mut self.shell.inputs.pressure;
        sensor.raw = self.faults.pressure_raw(raw);
        sensor.failed = false;
        let half = self.cfg.joystick.half_range_raw as f64;
        for axis in 0..2 {
            // Triangular noise (σ = JOYSTICK_NOISE_RAW): cheaper than a Gaussian, and the
            // controller only applies a dead zone to it.
            let (u1, u2): (f64, f64) = (self.rng.gen(), self.rng.gen());
            let raw = self.cfg.joystick.center_raw[axis] as f64
                + self.joystick[axis] * half
                + JOYSTICK_NOISE_RAW * 6f64.sqrt() * (u1 + u2 - 1.0);
            let raw = round_to_count(raw, firmware::ADC_MAX);
            if axis == 0 {
                self.shell.inputs.joystick_x.raw = raw;
            } else {
                self.shell.inputs.joystick_y.raw = raw;
            }
        }
        // The display changes seldom: read its task only when it did.
        let segments = self.shell.display.segments;
        if self.shown.0 != segments {
            self.shown = (segments, crate::operator::task_shown(segments));
        }
        let shown = self.shown.1;
        let (action, confirm_held) = self.operator.tick(now, shown);
        if let OperatorAction::Fold { task, over_ms } = action {
            self.do_manual(task, over_ms);
        }
        let held = self.held;
        let inputs = &mut self.shell.inputs;
        // Pull-ups: low = pressed; the e-stop's normally-closed contact reads high when pressed.
        inputs.up.high = !held.up;
        inputs.down.high = !held.down;
        inputs.gripper.high = !held.gripper;
        inputs.confirm.high = !(held.confirm || confirm_held);
        inputs.show_pressure.high = !held.show_pressure;
        inputs.estop.high = held.estop;

        // The controller, through the board's own loop body (or the board ELF in the emulator).
        #[cfg(feature = "pil")]
        match self.board.as_mut() {
            None => self.shell.step(&mut self.ctl, now),
            Some(b) => {
                if let Err(e) = b.step(&mut self.shell, now) {
                    // The emulated chip stopped (a model refused an access): the board is dead,
                    // its outputs as they were; say so once.
                    if self.board_error.is_none() {
                        eprintln!("hil-sim: the emulated board stopped at {now} ms: {e}");
                        self.board_error = Some(e.to_string());
                    }
                }
            }
        }
        #[cfg(not(feature = "pil"))]
        self.shell.step(&mut self.ctl, now);

        // Its bytes to the host go through the line.
        // (The sniffer decodes the device's frames for the trace only.)
        while let Some(b) = self.shell.link.tx.pop_front() {
            if self.trace.is_some() {
                if let Some(Ok(DeviceMessage::Event(ev))) = self.sniffer.push::<DeviceMessage>(b) {
                    self.on_device_event(&ev);
                }
            }
            if let Some(b) = self.faults.link_byte(b, &mut self.rng) {
                self.to_host.push_back(b);
            }
        }

        // Actuators.
        let out = &self.shell.outputs;
        let duties = [
            out.servos.0.inner(),
            out.servos.1.inner(),
            out.servos.2.inner(),
        ];
        for (i, pwm) in duties.into_iter().enumerate() {
            // The same pulse again changes nothing in the servo (`Servo::set_pulse_us`).
            if self.duty_seen[i] != Some(pwm.duty) {
                self.duty_seen[i] = Some(pwm.duty);
                self.servos[i].set_pulse_us(pwm.pulse_us());
            }
        }
        let exhaust_cmd = out.exhaust.high;
        let inlet_open = self.faults.inlet(out.inlet.high);
        let dt_s = STEP_MS as f64 * 1e-3;
        let spool_m = self.cfg.geometry.winch.spool_radius_mm as f64 * 1e-3;
        let tensions = self.trunk.tensions_n();
        let mut pay_in_mm = [0.0; 3];
        for (i, servo) in self.servos.iter_mut().enumerate() {
            // The tendon's torque opposes the pulling direction of the shaft.
            let sign = self.cfg.geometry.winch.pull_sign[i] as f64;
            servo.step(dt_s, sign * tensions[i] * spool_m);
            let bits = servo.angle_deg.to_bits();
            if self.pay_in[i].0 != bits {
                let mm = self
                    .cfg
                    .geometry
                    .winch
                    .length_for_angle(i, servo.angle_deg as f32) as f64;
                self.pay_in[i] = (bits, mm);
            }
            pay_in_mm[i] = self.pay_in[i].1;
        }
        let act = Actuation {
            pay_in_mm,
            inlet_open,
            exhaust_open: exhaust_cmd,
            fault_leak: self.faults.leak(),
            tendon_broken: self.faults.tendons_broken(tensions[0]),
            payload_n: if self.shell.outputs.gripper.high {
                self.payload_n
            } else {
                0.0
            } + self.world.load_n(),
        };
        let snaps = self.trunk.step(dt_s, &act);
        if !self.world.is_empty() {
            self.world
                .after_step(&self.trunk, self.shell.outputs.gripper.high);
        }
        let p = self.trunk.pressure_kpa();
        self.max_pressure_kpa = self.max_pressure_kpa.max(p);
        for s in snaps.iter() {
            self.snaps += 1;
            if let Some(tr) = self.trace.as_mut() {
                let _ = writeln!(
                    tr.text,
                    "{:>8} snap {} {}>{} p={:.1}",
                    now,
                    match s.module {
                        Module::Top => "top",
                        Module::Bottom => "bottom",
                    },
                    well_name(s.module, s.from_well),
                    well_name(s.module, s.to_well),
                    p
                );
            }
        }
        if let Some(tr) = self.trace.as_ref() {
            if now.is_multiple_of(tr.period_ms) {
                let line = self.trace_line();
                if let Some(tr) = self.trace.as_mut() {
                    tr.text.push_str(&line);
                }
            }
        }
    }

    fn trace_line(&self) -> String {
        let h = self.trunk.heights_mm();
        let state = self.trunk.state().map_or("--", |s| s.name());
        format!(
            "{:>8} p={:5.1} h={:5.1}+{:5.1} s={:5.1} {} v={}{} {}\n",
            self.now_ms,
            self.trunk.pressure_kpa(),
            h[0],
            h[1],
            self.servos[0].angle_deg,
            state,
            if self.shell.outputs.inlet.high {
                'I'
            } else {
                '-'
            },
            if self.shell.outputs.exhaust.high {
                'E'
            } else {
                '-'
            },
            segments_text(self.shell.display.segments).trim_end(),
        )
    }

    fn on_device_event(&mut self, ev: &Event) {
        if let Some(tr) = self.trace.as_mut() {
            let text = match ev {
                Event::Heartbeat { .. } | Event::Telemetry(_) | Event::StepProgress { .. } => None,
                other => Some(format!("{other:?}")),
            };
            if let Some(t) = text {
                let _ = writeln!(tr.text, "{:>8} event {t}", self.now_ms);
            }
        }
    }

    /// What the person at the crane names when asked the trunk's state: `None` while their
    /// hands are still folding it (they finish the fold, then look), else the true state
    /// (`Some(None)`: between states, which they say they cannot tell).
    pub fn person_names(&self) -> Option<Option<TrunkState>> {
        (!self.trunk.folding_by_hand()).then(|| self.trunk.state())
    }

    /// A person moves one module into a well of its force curve by hand (the operator's tasks;
    /// a test's way to leave the bottom half-packed, well 1).
    pub fn move_module_by_hand(&mut self, module: Module, well: usize) {
        self.trunk.set_module_well(module, well);
    }

    /// The operator's task, folded over `over_ms`.
    fn do_manual(&mut self, task: ManualTask, over_ms: u64) {
        let (module, well) = match task {
            ManualTask::PackBottomModule => (Module::Bottom, 0),
            ManualTask::FoldTopModule => (Module::Top, 0),
            ManualTask::FoldBottomModule => (Module::Bottom, 2),
        };
        self.trunk.fold_by_hand(module, well, over_ms as f64 * 1e-3);
        if let Some(tr) = self.trace.as_mut() {
            let _ = writeln!(tr.text, "{:>8} operator {task:?}", self.now_ms);
        }
    }

    /// Cuts and restores the board's power: the controller boots again from the emulated data
    /// flash (the trunk, the servos' shafts and the gas stay as they are; the link's buffers
    /// are lost).
    pub fn power_cycle(&mut self) {
        self.shell.link.rx.clear();
        self.shell.link.tx.clear();
        #[cfg(feature = "pil")]
        match self.board.as_mut() {
            None => self.ctl = self.shell.boot(self.cfg, self.now_ms),
            Some(b) => {
                if let Err(e) = b.power_cycle() {
                    self.board_error = Some(e.to_string());
                }
            }
        }
        #[cfg(not(feature = "pil"))]
        {
            self.ctl = self.shell.boot(self.cfg, self.now_ms);
        }
        if let Some(tr) = self.trace.as_mut() {
            let _ = writeln!(tr.text, "{:>8} power cycle", self.now_ms);
        }
    }

    /// Writes `record` to the emulated data flash as the controller would (the next
    /// [`Sim::power_cycle`] boots from it): a test's way to boot into any belief.
    pub fn write_flash_record(&mut self, record: &StoredState) {
        use firmware::hw::StateStore as _;
        let _ = self.shell.store.save(record);
    }

    /// Boots the controller again knowing nothing of the trunk (every state a candidate, as
    /// after a record lost with the flash), the trunk left as it is.
    pub fn boot_knowing_nothing(&mut self) {
        self.write_flash_record(&StoredState {
            state: TrunkState::AS_MANUFACTURED,
            confirmed: false,
            candidates: protocol::StateSet::ALL,
            pending: None,
        });
        self.power_cycle();
    }

    /// Successful writes to the emulated data flash so far (with the ELF: records, counted
    /// as programmed bytes per 14-byte slot).
    pub fn flash_writes(&self) -> u32 {
        #[cfg(feature = "pil")]
        if let Some(b) = &self.board {
            return (b.emu.machine().flash.programs / 14) as u32;
        }
        self.shell.store.writes
    }

    /// Why the emulated board stopped, if it did.
    pub fn board_error(&self) -> Option<&str> {
        self.board_error.as_deref()
    }

    /// Runs for `ms` of virtual time.
    pub fn run_for(&mut self, ms: u64) {
        let end = self.now_ms + ms;
        while self.now_ms < end {
            self.step();
        }
    }

    /// Runs until `pred` holds (checked every step) or `max_ms` pass; returns whether it held.
    pub fn run_until(&mut self, max_ms: u64, mut pred: impl FnMut(&Sim) -> bool) -> bool {
        let end = self.now_ms + max_ms;
        while self.now_ms < end {
            if pred(self) {
                return true;
            }
            self.step();
        }
        pred(self)
    }

    /// What really happened.
    pub fn ground_truth(&self) -> GroundTruth {
        let limit = self.pressure_limit_kpa();
        let p = self.trunk.pressure_kpa() as f32;
        let inlet_open = self.inlet_passes();
        let (believed_state, mode) = self.believed();
        let h = self.trunk.heights_mm();
        GroundTruth {
            true_state: self.trunk.state(),
            max_pressure_kpa: self.max_pressure_kpa as f32,
            pressure_limit_kpa: limit,
            actuators_safe: self.actuators_safe(),
            pressure_kpa: p,
            time_ms: self.now_ms,
            module_heights_mm: [h[0] as f32, h[1] as f32],
            bend_deg: self.trunk.bend_deg().0 as f32,
            tendon_tension_n: self.trunk.tensions_n().map(|t| t as f32),
            servo_deg: self.servos.map(|s| s.angle_deg as f32),
            servos_energised: self.servos.map(|s| !s.limp),
            inlet_open,
            exhaust_open: self.shell.outputs.exhaust.high,
            gripper_closed: self.shell.outputs.gripper.high,
            display: segments_text(self.shell.display.segments),
            believed_state,
            mode,
            snaps: self.snaps,
            manual_tasks: self.operator.tasks_done,
            faults: self.faults.given().to_vec(),
        }
    }
}

/// `x.round().clamp(0.0, max as f64) as u16`, exactly (NaN gives 0), without the library call
/// `round` is on x86-64: the truncation is one instruction and `x - trunc(x)` is exact.
fn round_to_count(x: f64, max: u16) -> u16 {
    // 2^52: below it every f64 has a fraction part that `x - trunc(x)` gives exactly.
    if x.is_nan() || x.abs() >= 4_503_599_627_370_496.0 {
        return x.round().clamp(0.0, max as f64) as u16;
    }
    let t = x as i64;
    let frac = x - t as f64;
    let r = if frac >= 0.5 {
        t + 1
    } else if frac <= -0.5 {
        t - 1
    } else {
        t
    };
    r.clamp(0, max as i64) as u16
}

/// The ground-truth log for outside clients (`hil-sim --pty --truth-log FILE`): one JSON object
/// per line whenever the trunk's true state, the actuators' safety or the set of faults (the
/// controller's active ones and the injected ones in effect) changes, and once more at the end.
#[derive(Debug, Clone, Default)]
pub struct TruthLog {
    last: Option<(Option<TrunkState>, bool, u16, Vec<Fault>)>,
}

impl TruthLog {
    /// A log that has written nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// The line to append after a simulation step, if anything it watches changed (the first
    /// call always gives one).
    pub fn observe(&mut self, sim: &Sim) -> Option<String> {
        let key = sim.truth_key();
        if self.last.as_ref() == Some(&key) {
            return None;
        }
        self.last = Some(key);
        Some(sim.truth_line())
    }

    /// The final line (at exit), whatever changed.
    pub fn finish(&mut self, sim: &Sim) -> String {
        self.last = Some(sim.truth_key());
        sim.truth_line()
    }
}

impl Sim {
    /// The part of the truth that judges safety, cheap enough to ask every step.
    pub fn safety(&self) -> Safety {
        Safety {
            true_state: self.trunk.state(),
            pressure_kpa: self.trunk.pressure_kpa() as f32,
            pressure_limit_kpa: self.pressure_limit_kpa(),
            inlet_open: self.inlet_passes(),
            inlet_commanded_open: self.shell.outputs.inlet.high,
            exhaust_open: self.shell.outputs.exhaust.high,
            servos_still: self.servos_still(),
            actuators_safe: self.actuators_safe(),
        }
    }

    fn inlet_passes(&self) -> bool {
        self.faults.inlet_passes(self.shell.outputs.inlet.high)
    }

    fn servos_still(&self) -> bool {
        self.servos
            .iter()
            .all(|s| s.limp || (s.angle_deg - s.command_deg).abs() < 0.5)
    }

    /// The pressure cap of the controller that runs, kPa: the host-built controller's own
    /// (every `SetParam` it accepted), or with a board ELF what the board last reported
    /// ([`ElfBoard::pressure_limit_kpa`](crate::elf_board::ElfBoard::pressure_limit_kpa)).
    /// The one source of the cap the judge holds the pressure to.
    pub fn pressure_limit_kpa(&self) -> f32 {
        #[cfg(feature = "pil")]
        if let Some(b) = &self.board {
            return b.pressure_limit_kpa;
        }
        self.ctl.config().pressure_limit_kpa
    }

    fn actuators_safe(&self) -> bool {
        let limit = self.pressure_limit_kpa() as f64;
        !self.inlet_passes() && self.servos_still() && self.trunk.pressure_kpa() <= limit
    }

    /// The injected faults in effect now (the mid-plan ones once they struck).
    pub fn faults_in_effect(&self) -> Vec<Fault> {
        self.faults.in_effect()
    }

    /// The controller's active faults (none known from an emulated board).
    fn device_faults(&self) -> u16 {
        if self.runs_elf() {
            return 0;
        }
        self.ctl.status().faults
    }

    /// The board ELF runs in the emulator instead of the host-built controller.
    fn runs_elf(&self) -> bool {
        #[cfg(feature = "pil")]
        return self.board.is_some();
        #[cfg(not(feature = "pil"))]
        false
    }

    /// What the device believes and its mode: the host-built controller's, or (an emulated
    /// board) the last it reported.
    fn believed(&self) -> (TrunkState, Mode) {
        #[cfg(feature = "pil")]
        if let Some(b) = &self.board {
            return (b.state, b.mode);
        }
        let st = self.ctl.status();
        (st.state, st.mode)
    }

    fn truth_key(&self) -> (Option<TrunkState>, bool, u16, Vec<Fault>) {
        (
            self.trunk.state(),
            self.actuators_safe(),
            self.device_faults(),
            self.faults_in_effect(),
        )
    }

    /// One truth-log line: `{"t_ms", "true_state", "pressure_kpa", "actuators_safe", …}` with
    /// `true_state` a state name or `"between"`, and what the controller believes beside it;
    /// with objects or a tip load in the world, the true tip (`tip_mm`) and the `world`.
    pub fn truth_line(&self) -> String {
        let bits = self.device_faults();
        let faults: Vec<String> = protocol::FaultCode::ALL
            .iter()
            .filter(|f| bits & f.bit() != 0)
            .map(|f| format!("E-{:02}", f.code()))
            .collect();
        let injected: Vec<String> = self
            .faults_in_effect()
            .iter()
            .map(|f| f.to_string())
            .collect();
        let mut v = serde_json::json!({
            "t_ms": self.now_ms,
            "true_state": self.trunk.state().map_or("between", |s| s.name()),
            "pressure_kpa": (self.trunk.pressure_kpa() * 100.0).round() / 100.0,
            "actuators_safe": self.actuators_safe(),
            "faults": faults,
            "injected_faults": injected,
        });
        // What the device believes: the controller's belief, or (an emulated board) the last
        // state it reported.
        v["believed_state"] = self.believed().0.name().into();
        if !self.runs_elf() {
            let status = self.ctl.status();
            v["state_confirmed"] = status.state_confirmed.into();
            v["candidates"] = status
                .candidates
                .iter()
                .map(|s| s.name())
                .collect::<Vec<_>>()
                .into();
        }
        if !self.world.is_empty() {
            v["tip_mm"] = self
                .true_tip()
                .position_mm
                .map(|x| (x * 10.0).round() / 10.0)
                .into();
            v["world"] = self.world.to_json();
        }
        v.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_truth_log_writes_a_line_per_change_and_one_at_the_end() {
        let mut sim = Sim::new(SimOptions {
            initial: "F&P".parse().unwrap(),
            ..SimOptions::default()
        });
        let mut log = TruthLog::new();
        let first = log.observe(&sim).expect("the first observation is logged");
        let v: serde_json::Value = serde_json::from_str(&first).unwrap();
        assert_eq!(v["true_state"], "F&P");
        assert_eq!(v["t_ms"], 0);
        assert_eq!(v["actuators_safe"], true);
        assert!(v["pressure_kpa"].as_f64().unwrap().abs() < 0.01);
        // Nothing changes at rest: no line.
        for _ in 0..100 {
            sim.step();
            assert_eq!(log.observe(&sim), None);
        }
        // The step-up button unpacks the trunk: the state goes F&P → between → F&F.
        sim.set_buttons(Buttons {
            up: true,
            ..Buttons::default()
        });
        sim.run_for(50);
        sim.set_buttons(Buttons::default());
        let mut states = Vec::new();
        for _ in 0..10_000 {
            sim.step();
            if let Some(line) = log.observe(&sim) {
                let v: serde_json::Value = serde_json::from_str(&line).unwrap();
                states.push(v["true_state"].as_str().unwrap().to_string());
            }
        }
        // (F&P lines while the valves change, then the snap.)
        states.dedup();
        assert_eq!(states, ["F&P", "between", "F&F"]);
        let end: serde_json::Value = serde_json::from_str(&log.finish(&sim)).unwrap();
        assert_eq!(end["true_state"], "F&F");
        assert_eq!(end["believed_state"], "F&F");
        assert_eq!(end["state_confirmed"], true);
    }

    #[test]
    fn the_firmware_default_is_this_trunk_and_its_heights_are_the_physics_wells() {
        let fw = CraneConfig::default();
        let sim = sim_crane_config();
        assert_eq!(fw.geometry, sim.geometry);
        // The controller's state heights (its joystick take-up) are where the physics rests.
        for s in TrunkState::ALL {
            let trunk = Trunk::new(crate::physics::TrunkParams::pdf().unwrap(), s);
            let h: f64 = trunk.heights_mm().iter().sum();
            let ours = sim.trunk_height_mm(s).unwrap() as f64;
            assert!(
                (h - ours).abs() < 1.0,
                "{s}: physics {h:.2} vs controller {ours:.2}"
            );
        }
    }

    #[test]
    fn rounding_to_a_count_is_round_then_clamp_exactly() {
        let reference = |x: f64| x.round().clamp(0.0, firmware::ADC_MAX as f64) as u16;
        let mut xs = vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -0.0,
            0.5,
            -0.5,
            0.499_999_999_999_999_94,
            1.5,
            2.5,
            16_383.5,
            16_384.4,
            -1.5,
            1e300,
            -1e300,
            4_503_599_627_370_497.0,
        ];
        let mut rng = SimRng::seed_from_u64(3);
        xs.extend((0..100_000).map(|_| rng.gen_range(-200.0..16_600.0)));
        xs.extend((0..2_000).map(|i| i as f64 * 0.25 - 100.0));
        for x in xs {
            assert_eq!(round_to_count(x, firmware::ADC_MAX), reference(x), "{x}");
        }
    }

    #[test]
    fn sensor_noise_has_the_stated_spread() {
        let mut sim = Sim::new(SimOptions::default());
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| sim.gauss()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var.sqrt() - 1.0).abs() < 0.03, "{var}");
    }

    #[test]
    fn the_controller_sees_the_true_pressure_through_the_sensor() {
        let mut sim = Sim::new(SimOptions {
            initial: "D&D".parse().unwrap(),
            ..SimOptions::default()
        });
        // Pressurise the gas by hand (as if the trunk had been inflated) and let the
        // controller's filter settle: it must read the true pressure within the noise.
        sim.trunk.set_gas_gauge_kpa(10.0);
        sim.run_for(100);
        let seen = sim.controller().pressure_kpa() as f64;
        let truth = sim.trunk().pressure_kpa();
        assert!((seen - truth).abs() < 0.3, "{seen} vs {truth}");
    }
}
