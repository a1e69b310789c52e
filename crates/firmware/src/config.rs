//! The crane's configuration: calibrations, limits and detector tuning.
//!
//! [`CraneConfig::default`] is the paper's crane (two-module PDF trunk, three tendon servos on
//! winch spools, one pressure sensor, inlet and exhaust valves). Every field is plain data so a
//! board or the simulator can override any of it before building a
//! [`Controller`](crate::Controller). [`CraneConfig::validated`] clamps the values that have a
//! safety meaning (the pressure cap never exceeds [`protocol::HARD_MAX_PRESSURE_KPA`]).

use protocol::{Board, ModuleConfig, TrunkConfig};

/// Linear calibration of the pressure sensor: raw 14-bit ADC counts → gauge kPa.
///
/// Default: an MPX5100DP-class sensor (0–100 kPa, `Vout = Vs·(0.009·P + 0.04)`) read
/// ratiometrically by the 14-bit ADC (reference = sensor supply), so
/// `kPa = (raw − 655.3) · 0.006 782`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PressureSensorConfig {
    /// Raw count at 0 kPa gauge.
    pub offset_raw: f32,
    /// kPa per raw count.
    pub kpa_per_count: f32,
    /// A raw value at or below this is a sensor dropout (open wire / short to ground).
    pub rail_low_raw: u16,
    /// A raw value at or above this is a sensor dropout (short to supply).
    pub rail_high_raw: u16,
    /// How long the raw value must sit at a rail before the PressureSensor fault is raised.
    pub dropout_ms: u32,
    /// Time constant of the first-order low-pass filter applied to every sample.
    pub filter_tau_ms: f32,
}

impl PressureSensorConfig {
    /// Gauge pressure of a raw count.
    pub fn kpa(&self, raw: u16) -> f32 {
        (raw as f32 - self.offset_raw) * self.kpa_per_count
    }

    /// The raw count that reads `kpa` (rounded, clamped to 14 bits): what a simulated sensor emits.
    pub fn raw(&self, kpa: f32) -> u16 {
        let raw = kpa / self.kpa_per_count + self.offset_raw;
        let raw = if raw.is_finite() { raw } else { 0.0 };
        crate::clampf(libm::roundf(raw), 0.0, crate::ADC_MAX as f32) as u16
    }
}

/// Servo limits and the tendon winch geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoConfig {
    /// Lowest allowed angle (any command is clamped to it).
    pub min_deg: f32,
    /// Highest allowed angle.
    pub max_deg: f32,
    /// Slew-rate limit of every servo command.
    pub slew_deg_per_s: f32,
    /// Angle of each servo at which its tendon is slack (zero shortening).
    pub slack_deg: [f32; 3],
    /// `+1.0` when pulling the tendon increases the servo angle, `-1.0` when it decreases it.
    pub pull_sign: [f32; 3],
    /// Radius of the winch spool (or horn) the tendon winds on: mm of tendon per radian.
    pub spool_radius_mm: f32,
}

impl ServoConfig {
    /// Millimetres of tendon wound per degree of servo rotation.
    pub fn mm_per_deg(&self) -> f32 {
        self.spool_radius_mm * core::f32::consts::PI / 180.0
    }

    /// Servo angle for a tendon shortening of `length_mm` on servo `i` (not clamped).
    pub fn angle_for_length(&self, i: usize, length_mm: f32) -> f32 {
        self.slack_deg[i % 3] + self.pull_sign[i % 3] * length_mm / self.mm_per_deg()
    }

    /// Tendon shortening of servo `i` at `angle_deg`.
    pub fn length_for_angle(&self, i: usize, angle_deg: f32) -> f32 {
        (angle_deg - self.slack_deg[i % 3]) * self.pull_sign[i % 3] * self.mm_per_deg()
    }

    /// Whether `angle_deg` is within the configured limits.
    pub fn allows(&self, angle_deg: f32) -> bool {
        angle_deg.is_finite() && angle_deg >= self.min_deg && angle_deg <= self.max_deg
    }
}

/// Snap-through detector tuning (see `docs/firmware.md`, "Snap detection").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnapConfig {
    /// Smallest step in filtered pressure, beyond the recent linear trend, that counts as a snap.
    pub threshold_kpa: f32,
    /// The step is measured across this window (a snap must complete within it).
    pub window_ms: u32,
    /// The linear trend is estimated over this span just before the window.
    pub trend_ms: u32,
    /// After a snap, further snaps are ignored for this long (one snap, one count); at least
    /// `window_ms + trend_ms + 10`. Two real snaps must be further apart than this.
    pub refractory_ms: u32,
    /// After a primitive reached its pressure or length, how long it waits for missing snaps
    /// before raising TransitionNotConfirmed.
    pub settle_ms: u32,
}

/// Leak detection tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeakConfig {
    /// Largest pressure decay accepted with both valves closed and the servos still.
    pub allowance_kpa_per_s: f32,
    /// Shortest sealed time over which a decay is judged.
    pub min_window_ms: u32,
    /// Pressure noise margin added to the allowed decay (filtered sensor noise is ~0.05 kPa).
    pub margin_kpa: f32,
    /// Below this pressure the trunk is not considered to be holding (no leak check).
    pub min_pressure_kpa: f32,
}

/// Joystick calibration and standalone bending.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoystickConfig {
    /// Raw count of a centred axis (both axes).
    pub center_raw: [u16; 2],
    /// Raw counts from centre to full deflection.
    pub half_range_raw: f32,
    /// Deflection (fraction of full, 0–1) ignored around the centre.
    pub dead_zone: f32,
    /// Bend angle of the trunk tip at full deflection.
    pub max_bend_deg: f32,
}

/// Everything the controller needs to know about its crane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CraneConfig {
    /// The board reported in the handshake.
    pub board: Board,
    /// Firmware version reported in the handshake, `[major, minor, patch]`.
    pub firmware_version: [u8; 3],
    /// The trunk (its `pressure_limit_kpa` is kept equal to [`CraneConfig::pressure_limit_kpa`]).
    pub trunk: TrunkConfig,
    /// Pressure sensor calibration.
    pub pressure_sensor: PressureSensorConfig,
    /// Pressure cap; above it the controller vents at once (OverPressure). Never above
    /// [`protocol::HARD_MAX_PRESSURE_KPA`].
    pub pressure_limit_kpa: f32,
    /// Hysteresis band of the inflate-and-hold regulator: the inlet reopens below
    /// `target − hysteresis`.
    pub hysteresis_kpa: f32,
    /// A vent is done at `target + vent_tolerance_kpa` (the sensor is noisy around 0).
    pub vent_tolerance_kpa: f32,
    /// During a tendon pull the exhaust acts as a relief valve above this pressure.
    pub pull_relief_kpa: f32,
    /// After an over-pressure the exhaust stays open until the pressure is below this.
    pub overpressure_vent_to_kpa: f32,
    /// Servos and tendon winches.
    pub servo: ServoConfig,
    /// Radial distance of the tendons from the trunk axis (differential bending; the tendons
    /// sit at 0°, 120°, 240°, [`geometry::tendon::TENDON_ANGLES`]).
    pub tendon_radius_mm: f32,
    /// Longest tendon shortening any primitive may ask for.
    pub max_tendon_mm: f32,
    /// Snap-through detector.
    pub snap: SnapConfig,
    /// Leak detector.
    pub leak: LeakConfig,
    /// Joystick.
    pub joystick: JoystickConfig,
    /// Host silence that aborts a running host plan.
    pub link_timeout_ms: u32,
    /// Telemetry rate at boot (0: off).
    pub telemetry_hz: f32,
    /// Time the gripper needs to open or close.
    pub gripper_settle_ms: u32,
    /// Control-loop period asked for through [`Controller::poll_deadline`](crate::Controller::poll_deadline)
    /// while something moves.
    pub control_period_ms: u32,
}

impl Default for CraneConfig {
    fn default() -> Self {
        Self {
            board: Board::UnoR4Wifi,
            firmware_version: [0, 1, 0],
            trunk: TrunkConfig {
                bottom: ModuleConfig {
                    n: 6,
                    beta_deg: 35.0,
                    edge_mm: 75.0,
                    layers: 3,
                },
                top: ModuleConfig {
                    n: 6,
                    beta_deg: 31.72,
                    edge_mm: 75.0,
                    layers: 3,
                },
                pressure_limit_kpa: 40.0,
            },
            pressure_sensor: PressureSensorConfig {
                offset_raw: 655.3,
                kpa_per_count: 0.006_782,
                rail_low_raw: 64,
                rail_high_raw: crate::ADC_MAX - 64,
                dropout_ms: 20,
                filter_tau_ms: 8.0,
            },
            pressure_limit_kpa: 40.0,
            hysteresis_kpa: 1.0,
            vent_tolerance_kpa: 0.5,
            pull_relief_kpa: 15.0,
            overpressure_vent_to_kpa: 5.0,
            servo: ServoConfig {
                min_deg: 0.0,
                max_deg: 180.0,
                slew_deg_per_s: 90.0,
                slack_deg: [0.0; 3],
                pull_sign: [1.0; 3],
                spool_radius_mm: 60.0,
            },
            tendon_radius_mm: 60.0,
            max_tendon_mm: 185.0,
            snap: SnapConfig {
                threshold_kpa: 1.5,
                window_ms: 50,
                trend_ms: 100,
                refractory_ms: 200,
                settle_ms: 1_500,
            },
            leak: LeakConfig {
                allowance_kpa_per_s: 2.0,
                min_window_ms: 100,
                margin_kpa: 0.3,
                min_pressure_kpa: 3.0,
            },
            joystick: JoystickConfig {
                center_raw: [8192, 8192],
                half_range_raw: 8000.0,
                dead_zone: 0.1,
                max_bend_deg: 30.0,
            },
            link_timeout_ms: protocol::DEFAULT_LINK_TIMEOUT_MS,
            telemetry_hz: 10.0,
            gripper_settle_ms: 400,
            control_period_ms: 10,
        }
    }
}

impl CraneConfig {
    /// The configuration with its safety-relevant values forced into range: the pressure cap
    /// within `0..=HARD_MAX_PRESSURE_KPA`, servo limits ordered within 0–180°, positive slew and
    /// periods. Non-finite values fall back to the defaults.
    pub fn validated(mut self) -> Self {
        let d = CraneConfig::default();
        let fix = |v: f32, lo: f32, hi: f32, dflt: f32| {
            if v.is_finite() {
                crate::clampf(v, lo, hi)
            } else {
                dflt
            }
        };
        self.pressure_limit_kpa = fix(
            self.pressure_limit_kpa,
            0.0,
            protocol::HARD_MAX_PRESSURE_KPA,
            d.pressure_limit_kpa,
        );
        self.trunk.pressure_limit_kpa = self.pressure_limit_kpa;
        self.servo.min_deg = fix(self.servo.min_deg, 0.0, 180.0, d.servo.min_deg);
        self.servo.max_deg = fix(
            self.servo.max_deg,
            self.servo.min_deg,
            180.0,
            d.servo.max_deg,
        );
        self.servo.slew_deg_per_s = fix(self.servo.slew_deg_per_s, 1.0, 600.0, 90.0);
        if !(self.servo.spool_radius_mm.is_finite() && self.servo.spool_radius_mm > 0.1) {
            self.servo.spool_radius_mm = d.servo.spool_radius_mm;
        }
        for s in &mut self.servo.pull_sign {
            *s = if *s < 0.0 { -1.0 } else { 1.0 };
        }
        self.link_timeout_ms = self.link_timeout_ms.clamp(200, 60_000);
        self.telemetry_hz = fix(self.telemetry_hz, 0.0, 50.0, d.telemetry_hz);
        self.control_period_ms = self.control_period_ms.clamp(1, 100);
        self.hysteresis_kpa = fix(self.hysteresis_kpa, 0.05, 10.0, d.hysteresis_kpa);
        if !(self.pressure_sensor.kpa_per_count.is_finite()
            && self.pressure_sensor.kpa_per_count != 0.0)
        {
            self.pressure_sensor.kpa_per_count = d.pressure_sensor.kpa_per_count;
        }
        self.pressure_sensor.filter_tau_ms =
            fix(self.pressure_sensor.filter_tau_ms, 0.0, 1000.0, 8.0);
        self.joystick.dead_zone = fix(self.joystick.dead_zone, 0.0, 0.9, d.joystick.dead_zone);
        if !(self.joystick.half_range_raw.is_finite() && self.joystick.half_range_raw >= 1.0) {
            self.joystick.half_range_raw = d.joystick.half_range_raw;
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_calibration_maps_rails_and_zero() {
        let c = CraneConfig::default().pressure_sensor;
        assert!(c.kpa(655).abs() < 0.01);
        // MPX5100-class full scale: 100 kPa at 0.94 Vs.
        assert!((c.kpa(15_400) - 100.0).abs() < 0.1, "{}", c.kpa(15_400));
        for kpa in [0.0f32, 12.5, 40.0] {
            assert!((c.kpa(c.raw(kpa)) - kpa).abs() <= c.kpa_per_count);
        }
    }

    #[test]
    fn validated_caps_pressure_at_the_hard_maximum() {
        let cfg = CraneConfig {
            pressure_limit_kpa: 500.0,
            ..CraneConfig::default()
        }
        .validated();
        assert_eq!(cfg.pressure_limit_kpa, protocol::HARD_MAX_PRESSURE_KPA);
        assert_eq!(
            cfg.trunk.pressure_limit_kpa,
            protocol::HARD_MAX_PRESSURE_KPA
        );
        let cfg = CraneConfig {
            pressure_limit_kpa: f32::NAN,
            ..CraneConfig::default()
        }
        .validated();
        assert_eq!(cfg.pressure_limit_kpa, 40.0);
    }

    #[test]
    fn winch_geometry_round_trips() {
        let s = CraneConfig::default().servo;
        // 60 mm spool: 60·π/180 = 1.047 mm per degree; 175 mm (pack the bottom) fits in 180°.
        assert!((s.mm_per_deg() - core::f32::consts::FRAC_PI_3).abs() < 1e-5);
        assert!(s.allows(s.angle_for_length(0, 175.0)));
        assert!((s.length_for_angle(1, s.angle_for_length(1, 42.0)) - 42.0).abs() < 1e-3);
    }
}
