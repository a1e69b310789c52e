//! The crane as built, as the host plans for it and the controller moves it: the trunk's two
//! modules, the height of a self-packed layer, where the tendons run, how a servo angle winds
//! a tendon, and how far the crane may be bent in each state.
//!
//! Plain data, no wire type: the handshake reports the modules ([`DeviceInfo::trunk`]) and
//! nothing more, so a host assumes [`CraneGeometry::default`] (the paper's crane) for the rest.
//! The firmware's configuration embeds one (`firmware::CraneConfig::geometry`), the simulator
//! builds its crane's from its trunk description.
//!
//! [`DeviceInfo::trunk`]: crate::DeviceInfo::trunk

use geometry::{BottomState, TopState, TrunkState};

use crate::{ModuleConfig, TrunkConfig};

/// A vent is done at its target plus this much, kPa (the sensor is noisy around 0): the
/// controller's default, which a host checks a vented trunk against.
pub const DEFAULT_VENT_TOLERANCE_KPA: f32 = 0.5;

/// How each servo winds its tendon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WinchConfig {
    /// Angle of each servo at which its tendon is slack (zero shortening).
    pub slack_deg: [f32; 3],
    /// `+1.0` when pulling the tendon increases the servo angle, `-1.0` when it decreases it.
    pub pull_sign: [f32; 3],
    /// Radius of the winch spool (or horn) the tendon winds on: mm of tendon per radian.
    pub spool_radius_mm: f32,
}

impl WinchConfig {
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
}

/// The crane's shape: trunk, tendons, winches and bend limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CraneGeometry {
    /// The bottom module.
    pub bottom: ModuleConfig,
    /// The top module.
    pub top: ModuleConfig,
    /// Height of one self-packed layer (its panels stacked; the geometry's d → 0).
    pub packed_layer_mm: f32,
    /// Radial distance of the tendons from the trunk axis (differential bending; the tendons
    /// sit at 0°, 120°, 240°, [`geometry::tendon::TENDON_ANGLES`]).
    pub tendon_radius_mm: f32,
    /// The joystick and `Bend` take up a flexible state's tendon slack up to this much short of
    /// taut, so an error in the modelled heights never compresses the trunk.
    pub take_up_margin_mm: f32,
    /// The servos' tendon winches.
    pub winch: WinchConfig,
    /// Bend angle of the trunk tip at full joystick deflection, and the largest `Bend`, in a
    /// flexible state with a folded module.
    pub max_bend_deg: f32,
    /// Bend at full deflection in a flexible state without a folded module (`D&P`: a
    /// deployed top over a packed bottom). Neither module bends easily there, so a one-sided
    /// pull mostly compresses the trunk, and the deployed top buckles under ≈ 75 N (7 mm of
    /// compression past taut in the simulator); 8° keeps the pull ≈ 6 mm past taut (≈ 31 N,
    /// 2.6° of real bend in the simulator). Also the largest `Bend` allowed there (a larger
    /// one faults with ServoLimit).
    pub stiff_max_bend_deg: f32,
}

impl Default for CraneGeometry {
    /// [`CraneGeometry::PAPER`].
    fn default() -> Self {
        Self::PAPER
    }
}

impl CraneGeometry {
    /// The paper's crane (§5.4): n = 3 (the largest folded/deployed height contrast), 75 mm
    /// edges, two layers per module (the bottom packs layer by layer in two snaps);
    /// docs/simulator.md gives the reasoning. Three tendons at 60 mm on 60 mm spools.
    pub const PAPER: Self = Self {
        bottom: ModuleConfig {
            n: 3,
            beta_deg: 35.0,
            edge_mm: 75.0,
            layers: 2,
        },
        top: ModuleConfig {
            n: 3,
            beta_deg: 31.72,
            edge_mm: 75.0,
            layers: 2,
        },
        packed_layer_mm: 5.0,
        tendon_radius_mm: 60.0,
        take_up_margin_mm: 2.0,
        winch: WinchConfig {
            slack_deg: [0.0; 3],
            pull_sign: [1.0; 3],
            spool_radius_mm: 60.0,
        },
        max_bend_deg: 30.0,
        stiff_max_bend_deg: 8.0,
    };

    /// The trunk as the handshake reports it, with the device's pressure cap.
    pub fn trunk(&self, pressure_limit_kpa: f32) -> TrunkConfig {
        TrunkConfig {
            bottom: self.bottom,
            top: self.top,
            pressure_limit_kpa,
        }
    }

    /// This geometry with the modules a device reports (its handshake's [`TrunkConfig`]).
    pub fn with_trunk(self, trunk: &TrunkConfig) -> Self {
        Self {
            bottom: trunk.bottom,
            top: trunk.top,
            ..self
        }
    }

    /// The full-deflection bend in `state`, degrees: [`CraneGeometry::max_bend_deg`] with a
    /// folded module, [`CraneGeometry::stiff_max_bend_deg`] without one.
    pub fn max_bend_deg_in(&self, state: TrunkState) -> f32 {
        let folded = state.top == TopState::Folded || state.bottom == BottomState::Folded;
        if folded {
            self.max_bend_deg
        } else {
            self.stiff_max_bend_deg
        }
    }

    /// The largest bend the crane is bent by in `state` (the joystick at full deflection, a
    /// `Bend`), degrees; `None` where it is not bent at all (`F&P`, `D&D`: not among the
    /// flexible states, their tendons are not taken up).
    pub fn bend_limit_deg(&self, state: TrunkState) -> Option<f32> {
        state.is_flexible().then(|| self.max_bend_deg_in(state))
    }
}
