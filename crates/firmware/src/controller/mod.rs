//! The sans-IO crane controller (skeleton: API stable, behaviour landing).

use geometry::TrunkState;
use protocol::{FaultCode, Mode, Status};

use crate::config::CraneConfig;
use crate::store::{BootRecord, StoredState};

/// The state of every button (`true` = pressed), already debounced or not: the controller acts
/// on rising edges and debounces by ignoring edges closer than 20 ms apart.
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
    /// Servo angles of tendons 0, 1, 2 (already within the limits and slew-limited).
    pub servo_deg: [f32; 3],
    /// Inlet valve open.
    pub inlet_open: bool,
    /// Exhaust valve open.
    pub exhaust_open: bool,
    /// Gripper closed.
    pub gripper_closed: bool,
}

/// The crane controller. See the [crate docs](crate) for the API and the loop.
#[derive(Debug)]
pub struct Controller {
    config: CraneConfig,
    state: TrunkState,
    confirmed: bool,
    faults: u16,
    now_ms: u64,
    boot_ms: u64,
    outputs: Outputs,
    pending_store: Option<StoredState>,
}

impl Controller {
    /// A controller booting at `now_ms` with what the state store held.
    pub fn new(config: CraneConfig, boot: BootRecord, now_ms: u64) -> Self {
        let config = config.validated();
        let (state, confirmed, faults) = match boot {
            BootRecord::Empty => (TrunkState::AS_MANUFACTURED, true, 0),
            BootRecord::Stored(s) => (s.state, s.confirmed, 0),
            BootRecord::Corrupt => (
                TrunkState::AS_MANUFACTURED,
                false,
                FaultCode::StateStorage.bit(),
            ),
        };
        let mut servo_deg = [0.0; 3];
        for (i, d) in servo_deg.iter_mut().enumerate() {
            *d = config
                .servo
                .angle_for_length(i, 0.0)
                .clamp(config.servo.min_deg, config.servo.max_deg);
        }
        Self {
            config,
            state,
            confirmed,
            faults,
            now_ms,
            boot_ms: now_ms,
            outputs: Outputs {
                servo_deg,
                inlet_open: false,
                exhaust_open: false,
                gripper_closed: false,
            },
            pending_store: None,
        }
    }

    /// The board restarted through its watchdog: raises the Watchdog fault.
    pub fn report_watchdog_reset(&mut self) {
        self.faults |= FaultCode::Watchdog.bit();
    }

    /// Bytes received from the host link, in any chunking.
    pub fn handle_rx(&mut self, _bytes: &[u8], now_ms: u64) {
        self.now_ms = self.now_ms.max(now_ms);
    }

    /// One sample of every sensor and button.
    pub fn handle_inputs(&mut self, _inputs: &Inputs, now_ms: u64) {
        self.now_ms = self.now_ms.max(now_ms);
    }

    /// The passage of time: runs the control loop.
    pub fn handle_time(&mut self, now_ms: u64) {
        self.now_ms = self.now_ms.max(now_ms);
    }

    /// Moves bytes to send to the host into `out`; returns how many (0: nothing to send).
    pub fn poll_tx(&mut self, _out: &mut [u8]) -> usize {
        0
    }

    /// The actuator commands now.
    pub fn poll_outputs(&self) -> Outputs {
        self.outputs
    }

    /// The display content now.
    pub fn poll_display(&self) -> [u8; 4] {
        crate::display::text(self.state.display_text())
    }

    /// The state to persist, once per change.
    pub fn poll_store(&mut self) -> Option<StoredState> {
        self.pending_store.take()
    }

    /// The next `now_ms` at which [`Controller::handle_time`] must run.
    pub fn poll_deadline(&self) -> u64 {
        self.now_ms + self.config.control_period_ms as u64
    }

    /// The status snapshot (the one `GetStatus` returns).
    pub fn status(&self) -> Status {
        Status {
            state: self.state,
            state_confirmed: self.confirmed,
            mode: Mode::Standalone,
            pressure_kpa: 0.0,
            servo_deg: self.outputs.servo_deg,
            inlet_open: self.outputs.inlet_open,
            exhaust_open: self.outputs.exhaust_open,
            gripper_closed: self.outputs.gripper_closed,
            estop: false,
            plan: None,
            faults: self.faults,
            frames_rx: 0,
            frames_dropped: 0,
            uptime_ms: (self.now_ms - self.boot_ms) as u32,
        }
    }

    /// The configuration in force (after validation and parameter changes).
    pub fn config(&self) -> &CraneConfig {
        &self.config
    }
}
