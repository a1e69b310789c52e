//! The crane's configuration: calibrations, limits and detector tuning.
//!
//! [`CraneConfig::default`] is the paper's crane (two-module PDF trunk, three tendon servos on
//! winch spools, one pressure sensor, inlet and exhaust valves). Every field is plain data so a
//! board or the simulator can override any of it before building a
//! [`Controller`](crate::Controller). [`CraneConfig::validated`] clamps the values that have a
//! safety meaning (the pressure cap never exceeds [`protocol::HARD_MAX_PRESSURE_KPA`]).

use geometry::{BottomState, ShapeState, TopState, TrunkState};
use protocol::{Board, CraneGeometry, ModuleConfig};

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

/// Servo limits (the winch each servo turns is [`CraneGeometry::winch`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoConfig {
    /// Lowest allowed angle (any command is clamped to it).
    pub min_deg: f32,
    /// Highest allowed angle.
    pub max_deg: f32,
    /// Slew-rate limit of every servo command.
    pub slew_deg_per_s: f32,
}

impl ServoConfig {
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

/// Confirmation of a tendon step by a sealed release (`docs/firmware.md`, "Tendon steps").
///
/// Under a tendon pull the tendons pin the trunk's height, so a module that buckles may barely
/// change the gas volume while the servos hold it (no pressure spike). Its volume tells after
/// the tendons are let out again with both valves closed: a trunk that snapped shorter holds
/// the same gas in a smaller volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TendonCheckConfig {
    /// Smallest rise of the sealed pressure, from before the pull to after the sealed release,
    /// that shows the trunk's volume shrank (a module folded; the step's expected spikes must
    /// have come as well): well above the sensor's noise, well under any fold.
    pub min_rise_kpa: f32,
    /// Time the trunk is given to settle, sealed and still, at the end of the pull and after
    /// the release, before the pressure is read.
    pub settle_ms: u32,
}

/// Stuck-open inlet watch (`docs/firmware.md`, "Safety").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InletWatchConfig {
    /// With the inlet commanded closed and the servos still, a rise of the pressure by this much
    /// above its lowest value since then is gas coming in through the inlet.
    pub rise_kpa: f32,
    /// The lowest value creeps up at this rate, so a slow drift (a sealed trunk warming in the
    /// sun) is not taken for a stuck inlet; an open inlet fills at ≈ 10 kPa/s.
    pub drift_kpa_per_s: f32,
    /// The watch starts this long after the inlet was commanded closed (valve and filter lag).
    pub closed_settle_ms: u32,
    /// After a rise, the pressure must rise by `confirm_rise_kpa` more in the second half of
    /// this time (an open inlet fills at ≈ 10 kPa/s); a rise that stops (a load pressing on
    /// the sealed trunk) becomes the new floor.
    pub confirm_ms: u32,
    /// See `confirm_ms`.
    pub confirm_rise_kpa: f32,
    /// While venting (exhaust open, inlet closed, servos still) above `vent_min_pressure_kpa`,
    /// the pressure must fall by `vent_min_drop_kpa` in every window of this length.
    pub vent_window_ms: u32,
    /// See `vent_window_ms`.
    pub vent_min_drop_kpa: f32,
    /// See `vent_window_ms`: below this a vent is slow by nature.
    pub vent_min_pressure_kpa: f32,
}

/// Stalled-inflation watch (`docs/firmware.md`, "Safety"): the inflate regulator has the inlet
/// open but the pressure does not rise.
///
/// In the simulator a nominal inflation rises 7.6–15 kPa/s with the inlet open (slowest just
/// before the bottom module's snap at ≈ 19 kPa) and never goes 0.1 s without gaining 0.5 kPa,
/// except across the snap itself (≤ 71 ms); a 2.5 mm hole plateaus at ≈ 4 kPa, a stuck-closed
/// inlet stays at 0 ± 0.1 kPa.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RiseWatchConfig {
    /// With the inlet open throughout this window, the pressure must gain at least
    /// `min_gain_kpa` across it (now against a window ago).
    pub window_ms: u32,
    /// See `window_ms`.
    pub min_gain_kpa: f32,
    /// A stall at or above this pressure is a Leak (gas comes in, but goes out as fast); below
    /// it the pressure never left ambient: NoPressureRise (supply off, inlet stuck closed).
    pub ambient_band_kpa: f32,
}

/// Joystick calibration (its full-deflection bend per state is
/// [`CraneGeometry::max_bend_deg_in`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoystickConfig {
    /// Raw count of a centred axis (both axes).
    pub center_raw: [u16; 2],
    /// Raw counts from centre to full deflection.
    pub half_range_raw: f32,
    /// Deflection (fraction of full, 0–1) ignored around the centre.
    pub dead_zone: f32,
}

/// Everything the controller needs to know about its crane.
///
/// Aligned to 8 bytes for the board binary's size: the controller that holds it (its `u64`
/// clocks) is laid out around it as when the configuration was 288 B, and LLVM's code for the
/// loop is that much smaller (measured on the board binary: 46 276 B of flash with it, 46 756 B
/// without; BENCHMARKS.md, "Issue 28"). It costs no RAM: the controller's size is unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(align(8))]
pub struct CraneConfig {
    /// The board reported in the handshake.
    pub board: Board,
    /// Firmware version reported in the handshake, `[major, minor, patch]`.
    pub firmware_version: [u8; 3],
    /// Pressure sensor calibration.
    pub pressure_sensor: PressureSensorConfig,
    /// Pressure cap; above it the controller vents at once (OverPressure). Never above
    /// [`protocol::HARD_MAX_PRESSURE_KPA`]. The one copy on the device: `SetParam` changes it,
    /// `GetParam` and the handshake report it.
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
    /// Servo limits.
    pub servo: ServoConfig,
    /// Longest tendon shortening any primitive may ask for.
    pub max_tendon_mm: f32,
    /// Sealed-release confirmation of tendon steps.
    pub tendon_check: TendonCheckConfig,
    /// Stuck-open inlet watch.
    pub inlet_watch: InletWatchConfig,
    /// Stalled-inflation watch (a leak the supply cannot beat, or no rise at all).
    pub rise_watch: RiseWatchConfig,
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
    /// The identification probe's signatures measured on this crane's own trunk (a calibration
    /// profile). `None` (the default): the probe is no evidence, identification asks the
    /// operator and a manual step is not checked by it (`docs/firmware.md`, "Identification").
    pub probe_profile: Option<crate::controller::identify::ProbeProfile>,
    /// The crane's shape: the trunk's modules, tendons, winches, bend limits (what a host
    /// models of it too). The handshake reports its modules with
    /// [`CraneConfig::pressure_limit_kpa`] ([`CraneGeometry::trunk`]).
    pub geometry: CraneGeometry,
}

impl Default for CraneConfig {
    fn default() -> Self {
        Self {
            board: Board::UnoR4Wifi,
            firmware_version: [0, 1, 0],
            // The paper's trunk (§5.4), as a host assumes it.
            geometry: CraneGeometry::PAPER,
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
            vent_tolerance_kpa: protocol::DEFAULT_VENT_TOLERANCE_KPA,
            pull_relief_kpa: 15.0,
            overpressure_vent_to_kpa: 5.0,
            servo: ServoConfig {
                min_deg: 0.0,
                max_deg: 180.0,
                slew_deg_per_s: 90.0,
            },
            max_tendon_mm: 185.0,
            tendon_check: TendonCheckConfig {
                // A module fold (46–60 mm shorter) reads +5.6 to +7.9 kPa after the sealed
                // release in the simulator, packing one layer +3.2, no snap +0.04 (the sensor's
                // noise is 0.15 kPa): 2.1 kPa is a volume change, not noise nor a leak's fall
                // over the check, on any trunk whose modules fold by a third of that. The count
                // of folds is the spikes', not this.
                min_rise_kpa: 2.1,
                settle_ms: 300,
            },
            inlet_watch: InletWatchConfig {
                rise_kpa: 1.0,
                drift_kpa_per_s: 0.2,
                closed_settle_ms: 50,
                confirm_ms: 200,
                confirm_rise_kpa: 0.3,
                vent_window_ms: 1_000,
                vent_min_drop_kpa: 0.5,
                vent_min_pressure_kpa: 3.0,
            },
            rise_watch: RiseWatchConfig {
                // 3 s and 0.5 kPa: a supply 45× slower than the simulator's slowest nominal
                // rise still passes; a leak or a dead supply is named within ≈ 4.5 s instead of
                // the step's 30 s time limit.
                window_ms: 3_000,
                min_gain_kpa: 0.5,
                // 10× the filtered noise (±0.1 kPa), a quarter of the simulated leak's plateau.
                ambient_band_kpa: 1.0,
            },
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
            },
            link_timeout_ms: protocol::DEFAULT_LINK_TIMEOUT_MS,
            telemetry_hz: 10.0,
            gripper_settle_ms: 400,
            control_period_ms: 10,
            probe_profile: None,
        }
    }
}

impl CraneConfig {
    /// Unloaded height of the straight trunk in `state`, mm: per module, layers × the layer's
    /// slant height d (folded or deployed, the geometry crate's Table 1) × the edge, or layers ×
    /// [`CraneGeometry::packed_layer_mm`] when self-packed. `None` for a module the geometry
    /// rejects (n outside 3..=64, β outside (0°, 90°)).
    ///
    /// In `f32`, from the geometry crate's closed forms (eq 2: deployed d = w = tan β; Table 1:
    /// folded d = √(w² − tan²(90°/n)), 0 where that is imaginary), with [`crate::mathf`]'s
    /// `tan` and `sqrt`: the crate's `f64` versions (and `libm`'s `tanf`, `f64` inside) cost the
    /// board binary ~10 KiB of software double precision and trigonometry. A host test checks
    /// them against the crate to 1e-4 relative over n = 3..12 and β = 10°..80°.
    pub fn trunk_height_mm(&self, state: TrunkState) -> Option<f32> {
        let module = |m: &ModuleConfig, s: Option<ShapeState>| -> Option<f32> {
            let layers = m.layers as f32;
            match s {
                None => Some(layers * self.geometry.packed_layer_mm),
                Some(s) => {
                    let valid_n = (geometry::design::MIN_N..=geometry::design::MAX_N)
                        .contains(&u32::from(m.n));
                    if !(valid_n && m.beta_deg > 0.0 && m.beta_deg < 90.0) {
                        return None;
                    }
                    let w = crate::mathf::tan(m.beta_deg.to_radians());
                    let slant = match s {
                        ShapeState::Folded => {
                            let t = crate::mathf::tan(core::f32::consts::PI / (2.0 * m.n as f32));
                            if w < t {
                                0.0
                            } else {
                                crate::mathf::sqrt((w - t) * (w + t))
                            }
                        }
                        _ => w,
                    };
                    Some(layers * slant * m.edge_mm)
                }
            }
        };
        let top = match state.top {
            TopState::Folded => Some(ShapeState::Folded),
            TopState::Deployed => Some(ShapeState::Deployed),
        };
        let bottom = match state.bottom {
            BottomState::Packed => None,
            BottomState::Folded => Some(ShapeState::Folded),
            BottomState::Deployed => Some(ShapeState::Deployed),
        };
        let g = &self.geometry;
        let h = module(&g.top, top)? + module(&g.bottom, bottom)?;
        h.is_finite().then_some(h)
    }

    /// How far every tendon hangs slack in `state` at zero shortening: tendon lengths are
    /// measured from the slack position of the fully deployed trunk, so this is
    /// H(D&D) − H(state) (0 when a height is unknown).
    pub fn tendon_slack_mm(&self, state: TrunkState) -> f32 {
        let dd = TrunkState::new(TopState::Deployed, BottomState::Deployed);
        match (self.trunk_height_mm(dd), self.trunk_height_mm(state)) {
            (Some(dd), Some(h)) => (dd - h).max(0.0),
            _ => 0.0,
        }
    }

    /// The configuration with its safety-relevant values forced into range: the pressure cap
    /// within `0..=HARD_MAX_PRESSURE_KPA`, servo limits ordered within 0–180°, positive slew and
    /// periods. Non-finite values fall back to the defaults.
    pub fn validated(mut self) -> Self {
        use fix_value as fix;
        let d = CraneConfig::default();
        self.pressure_limit_kpa = fix(
            self.pressure_limit_kpa,
            0.0,
            protocol::HARD_MAX_PRESSURE_KPA,
            d.pressure_limit_kpa,
        );
        self.servo.min_deg = fix(self.servo.min_deg, 0.0, 180.0, d.servo.min_deg);
        self.servo.max_deg = fix(
            self.servo.max_deg,
            self.servo.min_deg,
            180.0,
            d.servo.max_deg,
        );
        self.servo.slew_deg_per_s = fix(self.servo.slew_deg_per_s, 1.0, 600.0, 90.0);
        let (g, dg) = (&mut self.geometry, &d.geometry);
        if !(g.winch.spool_radius_mm.is_finite() && g.winch.spool_radius_mm > 0.1) {
            g.winch.spool_radius_mm = dg.winch.spool_radius_mm;
        }
        for s in &mut g.winch.pull_sign {
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
        let (g, dg) = (&mut self.geometry, &d.geometry);
        g.stiff_max_bend_deg = fix(
            g.stiff_max_bend_deg,
            0.0,
            g.max_bend_deg.max(0.0),
            dg.stiff_max_bend_deg,
        );
        g.packed_layer_mm = fix(g.packed_layer_mm, 0.0, 50.0, dg.packed_layer_mm);
        g.take_up_margin_mm = fix(g.take_up_margin_mm, 0.0, 50.0, dg.take_up_margin_mm);
        // A zero threshold would confirm any tendon step.
        self.tendon_check.min_rise_kpa = fix(
            self.tendon_check.min_rise_kpa,
            0.2,
            20.0,
            d.tendon_check.min_rise_kpa,
        );
        self.tendon_check.settle_ms = self.tendon_check.settle_ms.min(5_000);
        self.inlet_watch.rise_kpa = fix(self.inlet_watch.rise_kpa, 0.2, 20.0, 1.0);
        self.inlet_watch.drift_kpa_per_s = fix(self.inlet_watch.drift_kpa_per_s, 0.0, 5.0, 0.2);
        self.inlet_watch.vent_window_ms = self.inlet_watch.vent_window_ms.clamp(100, 60_000);
        // A window shorter than a snap's dip (≈ 70 ms) or a zero gain would misfire or never fire.
        self.rise_watch.window_ms = self.rise_watch.window_ms.clamp(500, 30_000);
        self.rise_watch.min_gain_kpa = fix(self.rise_watch.min_gain_kpa, 0.05, 10.0, 0.5);
        self.rise_watch.ambient_band_kpa = fix(self.rise_watch.ambient_band_kpa, 0.2, 20.0, 1.0);
        if !(self.joystick.half_range_raw.is_finite() && self.joystick.half_range_raw >= 1.0) {
            self.joystick.half_range_raw = d.joystick.half_range_raw;
        }
        self
    }
}

/// `v` limited to `lo..=hi`, or `dflt` when it is not finite (one of
/// [`CraneConfig::validated`]'s checks; out of line: it runs once, at boot, and is called
/// for every field).
#[inline(never)]
fn fix_value(v: f32, lo: f32, hi: f32, dflt: f32) -> f32 {
    if v.is_finite() {
        crate::clampf(v, lo, hi)
    } else {
        dflt
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
        let cfg = CraneConfig {
            pressure_limit_kpa: f32::NAN,
            ..CraneConfig::default()
        }
        .validated();
        assert_eq!(cfg.pressure_limit_kpa, 40.0);
    }

    #[test]
    fn default_trunk_heights_are_the_two_module_n3_trunk() {
        // docs/simulator.md, "Geometry": F&P 43.1, F&F 92.5, F&D 138.1, D&P 102.7, D&F 152.1,
        // D&D 197.7 mm (the simulator builds its trunk from the same geometry).
        let cfg = CraneConfig::default();
        assert_eq!((cfg.geometry.top.n, cfg.geometry.top.layers), (3, 2));
        assert_eq!((cfg.geometry.bottom.n, cfg.geometry.bottom.layers), (3, 2));
        let want = [
            ("F&P", 43.1),
            ("F&F", 92.5),
            ("F&D", 138.1),
            ("D&P", 102.7),
            ("D&F", 152.1),
            ("D&D", 197.7),
        ];
        for (name, h) in want {
            let s: TrunkState = name.parse().unwrap();
            let got = cfg.trunk_height_mm(s).unwrap();
            assert!((got - h).abs() < 0.1, "{name}: {got} mm");
        }
        let ff: TrunkState = "F&F".parse().unwrap();
        assert!((cfg.tendon_slack_mm(ff) - 105.2).abs() < 0.1);
        let dd: TrunkState = "D&D".parse().unwrap();
        assert_eq!(cfg.tendon_slack_mm(dd), 0.0);
        let bad = CraneConfig {
            geometry: CraneGeometry {
                top: ModuleConfig {
                    n: 1,
                    ..cfg.geometry.top
                },
                ..cfg.geometry
            },
            ..cfg
        };
        assert_eq!(bad.trunk_height_mm(ff), None);
        assert_eq!(bad.tendon_slack_mm(ff), 0.0);
    }

    #[test]
    fn winch_geometry_round_trips() {
        let cfg = CraneConfig::default();
        let (s, w) = (cfg.servo, cfg.geometry.winch);
        // 60 mm spool: 60·π/180 = 1.047 mm per degree; 175 mm (pack the bottom) fits in 180°.
        assert!((w.mm_per_deg() - core::f32::consts::FRAC_PI_3).abs() < 1e-5);
        assert!(s.allows(w.angle_for_length(0, 175.0)));
        assert!((w.length_for_angle(1, w.angle_for_length(1, 42.0)) - 42.0).abs() < 1e-3);
    }
}
