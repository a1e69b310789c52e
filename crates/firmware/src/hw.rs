//! Narrow hardware traits, adapters from embedded-hal 1.0 parts, and [`Shell`]: the one loop
//! body shared by the board binary and the simulator.
//!
//! Two layers, so both the board and the simulator can plug in at the level that suits them:
//!
//! - **Parts** (one device each): servos are [`embedded_hal::pwm::SetDutyCycle`] channels at
//!   [`SERVO_PWM_HZ`] wrapped in a [`ServoOutput`] (degrees → pulse width, clamped); valves and the
//!   gripper are [`embedded_hal::digital::OutputPin`]s; buttons are
//!   [`embedded_hal::digital::InputPin`]s; the pressure sensor and the joystick axes are
//!   [`AnalogInput`]s (14-bit raw counts); the display is a [`SegmentDisplay`]; the data flash is
//!   a [`StateStore`]; the host link is `embedded_io::{Read, ReadReady, Write, WriteReady}`.
//! - **Groups** the shell drives: an [`InputSource`] (every sensor and button in one
//!   [`Inputs`] sample) and an [`OutputSink`] (every actuator from one [`Outputs`]).
//!   [`PinInputs`] and [`PinOutputs`] build them from parts; a simulator may implement the two
//!   group traits directly.
//!
//! Electrical conventions (the board's wiring in `docs/hardware.md` follows them):
//! - Buttons (up, down, gripper, confirm, show-pressure): a switch to ground with a pull-up, so
//!   **low = pressed**.
//! - E-stop: a normally-closed contact to ground with a pull-up, so **high = pressed**; a broken
//!   wire reads as pressed (fail-safe). A button that cannot be read also counts as e-stop.
//! - Inlet and exhaust valves: normally-closed solenoid valves, **high = energised = open**; a
//!   board without power seals the trunk, which holds its shape.
//! - Gripper: **high = closed**.
//! - A pressure sample that cannot be read is reported as raw 0, a rail value, so the controller
//!   raises the PressureSensor fault.

use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};

use crate::controller::{Buttons, Controller, Inputs, Outputs};
use crate::store::StoredState;

/// Servo PWM frequency.
pub const SERVO_PWM_HZ: u32 = 50;

/// Which hardware group failed (no_std: small and `Copy`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HwError {
    /// A servo PWM channel.
    Servo,
    /// A valve or gripper pin.
    Valve,
    /// A button pin.
    Button,
    /// An analog input.
    Analog,
    /// The display.
    Display,
    /// The state store.
    Store,
    /// The serial link.
    Link,
}

/// A 14-bit analog input (pressure sensor, joystick axis): raw counts 0..=[`crate::ADC_MAX`].
pub trait AnalogInput {
    /// Read error.
    type Error;
    /// One conversion.
    fn read_raw(&mut self) -> Result<u16, Self::Error>;
}

/// A four-digit seven-segment display (TM1637-style); see [`crate::display`] for the encoding.
pub trait SegmentDisplay {
    /// Write error.
    type Error;
    /// Shows four digits, left to right.
    fn show(&mut self, segments: [u8; 4]) -> Result<(), Self::Error>;
}

/// Non-volatile storage of the last confirmed trunk state (the board's data flash).
///
/// Implementations store [`StoredState::to_bytes`] and decode with
/// [`StoredState::from_bytes`]: erased storage loads as `Ok(None)`, a checksum failure as `Err`.
pub trait StateStore {
    /// Storage error (also: corrupt content).
    type Error;
    /// The stored state; `Ok(None)` when nothing was ever stored.
    fn load(&mut self) -> Result<Option<StoredState>, Self::Error>;
    /// Stores `state`, replacing the previous one.
    fn save(&mut self, state: &StoredState) -> Result<(), Self::Error>;

    /// Whether this store keeps a link-signing key ([`StateStore::save_link_key`]); one that
    /// does not (the default) makes the controller refuse pairing, so signing never silently
    /// ends at a reset.
    fn keeps_link_key(&self) -> bool {
        false
    }
    /// The link-signing key kept (`Ok(None)`: none, signing off).
    fn load_link_key(&mut self) -> Result<Option<[u8; 16]>, Self::Error> {
        Ok(None)
    }
    /// Keeps `key` (`None`: forgets it), replacing the previous one.
    fn save_link_key(&mut self, _key: Option<&[u8; 16]>) -> Result<(), Self::Error> {
        Ok(())
    }

    /// Whether this store keeps a probe profile ([`StateStore::save_probe_profile`]); one
    /// that does not (the default) makes the controller refuse storing one.
    fn keeps_probe_profile(&self) -> bool {
        false
    }
    /// The probe profile kept, as [`crate::store::profile_to_bytes`] wrote it (`Ok(None)`:
    /// none).
    fn load_probe_profile(
        &mut self,
    ) -> Result<Option<[u8; crate::store::PROFILE_LEN]>, Self::Error> {
        Ok(None)
    }
    /// Keeps `profile` (`None`: erases it), replacing the previous one.
    fn save_probe_profile(
        &mut self,
        _profile: Option<&[u8; crate::store::PROFILE_LEN]>,
    ) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Servo pulse timing: angle 0 → `min_us`, angle `range_deg` → `max_us`, linear in between.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoPulse {
    /// Pulse width at 0°.
    pub min_us: u16,
    /// Pulse width at `range_deg`.
    pub max_us: u16,
    /// Mechanical range.
    pub range_deg: f32,
    /// PWM period (20 000 µs at 50 Hz).
    pub period_us: u32,
}

impl Default for ServoPulse {
    fn default() -> Self {
        Self {
            min_us: 500,
            max_us: 2_500,
            range_deg: 180.0,
            period_us: 1_000_000 / SERVO_PWM_HZ,
        }
    }
}

impl ServoPulse {
    /// Pulse width for `deg`, clamped to the servo's range (NaN → 0°).
    pub fn pulse_us(&self, deg: f32) -> f32 {
        let deg = if deg.is_finite() { deg } else { 0.0 };
        let frac = crate::clampf(deg / self.range_deg, 0.0, 1.0);
        self.min_us as f32 + frac * (self.max_us as f32 - self.min_us as f32)
    }

    /// Duty cycle for `deg` on a channel whose full scale is `max_duty`.
    pub fn duty(&self, deg: f32, max_duty: u16) -> u16 {
        let duty = self.pulse_us(deg) / self.period_us as f32 * max_duty as f32;
        crate::clampf(libm::roundf(duty), 0.0, max_duty as f32) as u16
    }
}

/// One servo on a 50 Hz PWM channel: degrees in, duty cycle out.
#[derive(Debug, Clone)]
pub struct ServoOutput<P> {
    pwm: P,
    pulse: ServoPulse,
    /// The last duty computed and what it was computed from (the angle's bits, the channel's
    /// full scale): the shell writes every step, the command changes far less often. Hosts
    /// only (the simulator runs this shell for hours of virtual time); on the board the field
    /// would cost ≈ 0.5 KiB of flash in the main loop's code, more than the budget leaves.
    #[cfg(not(target_os = "none"))]
    cached: (u32, u16, u16),
}

impl<P: SetDutyCycle> ServoOutput<P> {
    /// Wraps a PWM channel already running at [`SERVO_PWM_HZ`].
    pub fn new(pwm: P, pulse: ServoPulse) -> Self {
        // Full scale 0 gives duty 0 for every angle: true of no channel until one is computed.
        Self {
            pwm,
            pulse,
            #[cfg(not(target_os = "none"))]
            cached: (0, 0, 0),
        }
    }

    /// Commands `deg` (clamped to the servo's range). The duty is written every call (a
    /// glitched channel is corrected at once); on hosts it is recomputed only when `deg` or the
    /// full scale changed.
    pub fn set_deg(&mut self, deg: f32) -> Result<(), P::Error> {
        let max = self.pwm.max_duty_cycle();
        #[cfg(not(target_os = "none"))]
        let duty = {
            if self.cached.0 != deg.to_bits() || self.cached.1 != max {
                self.cached = (deg.to_bits(), max, self.pulse.duty(deg, max));
            }
            self.cached.2
        };
        #[cfg(target_os = "none")]
        let duty = self.pulse.duty(deg, max);
        self.pwm.set_duty_cycle(duty)
    }

    /// Stops the pulses (duty 0): the servo goes limp, driving nothing (the controller's safe
    /// state; see [`Outputs::servos_enabled`]).
    pub fn disable(&mut self) -> Result<(), P::Error> {
        self.pwm.set_duty_cycle(0)
    }

    /// The PWM channel.
    pub fn inner(&self) -> &P {
        &self.pwm
    }

    /// The PWM channel, mutably.
    pub fn inner_mut(&mut self) -> &mut P {
        &mut self.pwm
    }
}

/// Every sensor and button, sampled at once.
pub trait InputSource {
    /// One sample. Infallible by design: a part that cannot be read is reported fail-safe
    /// (pressure raw 0, e-stop pressed).
    fn read_inputs(&mut self) -> Inputs;
}

/// Every actuator, commanded at once.
pub trait OutputSink {
    /// Applies `outputs` (servo angles are already limited by the controller).
    fn apply(&mut self, outputs: &Outputs) -> Result<(), HwError>;
}

/// An [`InputSource`] built from embedded-hal pins and [`AnalogInput`]s, with the electrical
/// conventions of the [module docs](self).
#[derive(Debug, Clone)]
pub struct PinInputs<P, X, Y, BUp, BDown, BGrip, BStop, BConfirm, BShow> {
    /// Pressure sensor.
    pub pressure: P,
    /// Joystick x axis.
    pub joystick_x: X,
    /// Joystick y axis.
    pub joystick_y: Y,
    /// Step-up button (low = pressed).
    pub up: BUp,
    /// Step-down button (low = pressed).
    pub down: BDown,
    /// Gripper toggle button (low = pressed).
    pub gripper: BGrip,
    /// E-stop (normally closed: high = pressed).
    pub estop: BStop,
    /// Confirm button (low = pressed).
    pub confirm: BConfirm,
    /// Show-pressure button (low = pressed).
    pub show_pressure: BShow,
}

fn pressed_low<B: InputPin>(b: &mut B) -> Option<bool> {
    b.is_low().ok()
}

impl<P, X, Y, BUp, BDown, BGrip, BStop, BConfirm, BShow> InputSource
    for PinInputs<P, X, Y, BUp, BDown, BGrip, BStop, BConfirm, BShow>
where
    P: AnalogInput,
    X: AnalogInput,
    Y: AnalogInput,
    BUp: InputPin,
    BDown: InputPin,
    BGrip: InputPin,
    BStop: InputPin,
    BConfirm: InputPin,
    BShow: InputPin,
{
    fn read_inputs(&mut self) -> Inputs {
        let center = crate::ADC_MAX / 2 + 1;
        let up = pressed_low(&mut self.up);
        let down = pressed_low(&mut self.down);
        let gripper = pressed_low(&mut self.gripper);
        let estop = self.estop.is_high().ok();
        let confirm = pressed_low(&mut self.confirm);
        let show = pressed_low(&mut self.show_pressure);
        let any_err = [up, down, gripper, estop, confirm, show]
            .iter()
            .any(Option::is_none);
        Inputs {
            pressure_raw: self.pressure.read_raw().unwrap_or(0),
            joystick_raw: [
                self.joystick_x.read_raw().unwrap_or(center),
                self.joystick_y.read_raw().unwrap_or(center),
            ],
            buttons: Buttons {
                up: up.unwrap_or(false),
                down: down.unwrap_or(false),
                gripper: gripper.unwrap_or(false),
                estop: any_err || estop.unwrap_or(true),
                confirm: confirm.unwrap_or(false),
                show_pressure: show.unwrap_or(false),
            },
        }
    }
}

/// An [`OutputSink`] built from three [`ServoOutput`]s and three embedded-hal output pins.
#[derive(Debug, Clone)]
pub struct PinOutputs<S0, S1, S2, Inlet, Exhaust, Grip> {
    /// The three tendon servos, tendon 0, 1, 2 (120° apart).
    pub servos: (ServoOutput<S0>, ServoOutput<S1>, ServoOutput<S2>),
    /// Inlet valve (high = open).
    pub inlet: Inlet,
    /// Exhaust valve (high = open).
    pub exhaust: Exhaust,
    /// Gripper (high = closed).
    pub gripper: Grip,
}

fn set_pin<O: OutputPin>(pin: &mut O, high: bool) -> Result<(), HwError> {
    if high { pin.set_high() } else { pin.set_low() }.map_err(|_| HwError::Valve)
}

impl<S0, S1, S2, Inlet, Exhaust, Grip> OutputSink for PinOutputs<S0, S1, S2, Inlet, Exhaust, Grip>
where
    S0: SetDutyCycle,
    S1: SetDutyCycle,
    S2: SetDutyCycle,
    Inlet: OutputPin,
    Exhaust: OutputPin,
    Grip: OutputPin,
{
    fn apply(&mut self, o: &Outputs) -> Result<(), HwError> {
        // Valves first: closing the inlet is the most important safety action.
        let valves = [
            set_pin(&mut self.inlet, o.inlet_open),
            set_pin(&mut self.exhaust, o.exhaust_open),
            set_pin(&mut self.gripper, o.gripper_closed),
        ];
        let servos = if o.servos_enabled {
            [
                self.servos.0.set_deg(o.servo_deg[0]).is_ok(),
                self.servos.1.set_deg(o.servo_deg[1]).is_ok(),
                self.servos.2.set_deg(o.servo_deg[2]).is_ok(),
            ]
        } else {
            [
                self.servos.0.disable().is_ok(),
                self.servos.1.disable().is_ok(),
                self.servos.2.disable().is_ok(),
            ]
        };
        if let Some(e) = valves.into_iter().find_map(Result::err) {
            return Err(e);
        }
        if servos.contains(&false) {
            return Err(HwError::Servo);
        }
        Ok(())
    }
}

/// Counters of hardware errors seen by the [`Shell`] (the controller itself never sees them).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShellStats {
    /// Failed actuator writes.
    pub output_errors: u32,
    /// Failed display writes.
    pub display_errors: u32,
    /// Failed state saves (retried at the next step).
    pub store_errors: u32,
    /// Failed link reads or writes.
    pub link_errors: u32,
}

/// Bytes moved between the link and the controller per [`Shell::step`], each way.
pub const SHELL_IO_CHUNK: usize = 64;

/// The whole loop body shared by the board and the simulator: read every input, feed the
/// controller (received bytes, the input sample, the time), then write the actuators, the
/// display, the store and the bytes to send. Board and simulator construct it once and call
/// [`Shell::step`] in their loop (the board at 1 kHz).
///
/// It never blocks: it reads only while the link is `read_ready`, and writes only while it is
/// `write_ready`, at most [`SHELL_IO_CHUNK`] bytes each way per step.
#[derive(Debug, Clone)]
pub struct Shell<I, O, D, S, L> {
    /// Sensors and buttons.
    pub inputs: I,
    /// Servos, valves, gripper.
    pub outputs: O,
    /// The display.
    pub display: D,
    /// The state store.
    pub store: S,
    /// The host link.
    pub link: L,
    /// Error counters.
    pub stats: ShellStats,
    last_display: Option<[u8; 4]>,
    pending_store: Option<StoredState>,
    #[cfg(feature = "link-signing")]
    pending_key: Option<Option<[u8; 16]>>,
    pending_profile: Option<Option<[u8; crate::store::PROFILE_LEN]>>,
    tx: [u8; SHELL_IO_CHUNK],
    tx_len: usize,
    tx_pos: usize,
}

impl<I, O, D, S, L> Shell<I, O, D, S, L>
where
    I: InputSource,
    O: OutputSink,
    D: SegmentDisplay,
    S: StateStore,
    L: Read + ReadReady + Write + WriteReady,
{
    /// A shell over the given parts.
    pub fn new(inputs: I, outputs: O, display: D, store: S, link: L) -> Self {
        Self {
            inputs,
            outputs,
            display,
            store,
            link,
            stats: ShellStats::default(),
            last_display: None,
            pending_store: None,
            #[cfg(feature = "link-signing")]
            pending_key: None,
            pending_profile: None,
            tx: [0; SHELL_IO_CHUNK],
            tx_len: 0,
            tx_pos: 0,
        }
    }

    /// Loads the stored state and builds the controller from it (a read error or corrupt
    /// content boots with the StateStorage fault; see [`Controller::new`]).
    pub fn boot(&mut self, config: crate::CraneConfig, now_ms: u64) -> Controller {
        let record = match self.store.load() {
            Ok(Some(s)) => crate::BootRecord::Stored(s),
            Ok(None) => crate::BootRecord::Empty,
            Err(_) => crate::BootRecord::Corrupt,
        };
        #[allow(unused_mut)]
        let mut ctl = Controller::new(config, record, now_ms);
        #[cfg(feature = "link-signing")]
        {
            // An unreadable key boots with signing off (the store error counted): the
            // operator pairs again.
            let key = match self.store.load_link_key() {
                Ok(k) => k,
                Err(_) => {
                    self.stats.store_errors = self.stats.store_errors.wrapping_add(1);
                    None
                }
            };
            ctl.set_link_key(key, self.store.keeps_link_key());
        }
        // A profile that cannot be read, or of another firmware schema, boots with none (the
        // operator is asked until it is stored again).
        let profile = match self.store.load_probe_profile() {
            Ok(b) => b.as_ref().and_then(crate::store::profile_from_bytes),
            Err(_) => {
                self.stats.store_errors = self.stats.store_errors.wrapping_add(1);
                None
            }
        };
        ctl.set_probe_profile(profile, self.store.keeps_probe_profile());
        ctl
    }

    /// One pass of the loop at time `now_ms`.
    pub fn step(&mut self, ctl: &mut Controller, now_ms: u64) {
        // 1. Host bytes.
        let mut rx = [0u8; SHELL_IO_CHUNK];
        match self.link.read_ready() {
            Ok(true) => match self.link.read(&mut rx) {
                Ok(n) => ctl.handle_rx(&rx[..n.min(rx.len())], now_ms),
                Err(_) => self.stats.link_errors = self.stats.link_errors.wrapping_add(1),
            },
            Ok(false) => {}
            Err(_) => self.stats.link_errors = self.stats.link_errors.wrapping_add(1),
        }
        // 2. Sensors and buttons, then the control loop.
        let sample = self.inputs.read_inputs();
        ctl.handle_inputs(&sample, now_ms);
        ctl.handle_time(now_ms);
        // 3. Actuators (every step: a PWM or pin glitch is corrected at once).
        if self.outputs.apply(&ctl.poll_outputs()).is_err() {
            self.stats.output_errors = self.stats.output_errors.wrapping_add(1);
        }
        // 4. Display, only when it changes (a TM1637 write is slow).
        let seg = ctl.poll_display();
        if self.last_display != Some(seg) {
            match self.display.show(seg) {
                Ok(()) => self.last_display = Some(seg),
                Err(_) => self.stats.display_errors = self.stats.display_errors.wrapping_add(1),
            }
        }
        // 5. Persisted state (kept and retried until a save succeeds, then acknowledged).
        if let Some(s) = ctl.poll_store() {
            self.pending_store = Some(s);
        }
        if let Some(s) = self.pending_store {
            match self.store.save(&s) {
                Ok(()) => {
                    self.pending_store = None;
                    // A step's journal is on flash: its actuation may begin.
                    ctl.handle_stored();
                }
                Err(_) => self.stats.store_errors = self.stats.store_errors.wrapping_add(1),
            }
        }
        // 5b. A link key paired or forgotten (kept and retried until saved).
        #[cfg(feature = "link-signing")]
        {
            if let Some(k) = ctl.poll_link_key() {
                self.pending_key = Some(k);
            }
            if let Some(k) = self.pending_key {
                match self.store.save_link_key(k.as_ref()) {
                    Ok(()) => self.pending_key = None,
                    Err(_) => self.stats.store_errors = self.stats.store_errors.wrapping_add(1),
                }
            }
        }
        // 5c. A probe profile stored or erased (kept and retried until saved).
        if let Some(p) = ctl.poll_probe_profile() {
            self.pending_profile = Some(p.as_ref().map(crate::store::profile_to_bytes));
        }
        if let Some(p) = self.pending_profile {
            match self.store.save_probe_profile(p.as_ref()) {
                Ok(()) => self.pending_profile = None,
                Err(_) => self.stats.store_errors = self.stats.store_errors.wrapping_add(1),
            }
        }
        // 6. Bytes to the host.
        if self.tx_pos >= self.tx_len {
            self.tx_len = ctl.poll_tx(&mut self.tx);
            self.tx_pos = 0;
        }
        if self.tx_pos < self.tx_len {
            match self.link.write_ready() {
                Ok(true) => match self.link.write(&self.tx[self.tx_pos..self.tx_len]) {
                    Ok(n) => self.tx_pos += n.min(self.tx_len - self.tx_pos),
                    Err(_) => self.stats.link_errors = self.stats.link_errors.wrapping_add(1),
                },
                Ok(false) => {}
                Err(_) => self.stats.link_errors = self.stats.link_errors.wrapping_add(1),
            }
        }
    }
}
