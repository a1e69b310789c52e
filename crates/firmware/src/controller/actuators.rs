//! The actuators: the servos (slew-limited toward their targets, limp in the safe state), the
//! gripper and the valves, whose commands are what the running step wants under the safety
//! overlay (`docs/firmware.md`, "Safety").

use protocol::FaultCode;

use super::{slack_angles, Controller, Outputs};

/// The actuators' state.
#[derive(Debug, Clone, Copy)]
pub(super) struct Actuators {
    /// Servo angles now (slewing toward the targets).
    pub(super) servo_deg: [f32; 3],
    pub(super) servo_target_deg: [f32; 3],
    /// Servo pulses on (off in the safe state).
    pub(super) servos_enabled: bool,
    pub(super) gripper_closed: bool,
    /// What the running step wants of the valves (before the safety overlay).
    pub(super) want_inlet: bool,
    pub(super) want_exhaust: bool,
    /// The commands in force ([`Controller::poll_outputs`]).
    pub(super) outputs: Outputs,
}

impl Controller {
    /// Moves each servo toward its target by at most the slew rate over `dt_ms` (frozen in
    /// the safe state and under the e-stop).
    pub(super) fn slew(&mut self, dt_ms: u64) {
        if self.safety.safe || self.safety.estop_latched {
            self.freeze_servos();
            return;
        }
        let max_step = self.cfg.servo.slew_deg_per_s * dt_ms as f32 / 1_000.0;
        let (lo, hi) = (self.cfg.servo.min_deg, self.cfg.servo.max_deg);
        for i in 0..3 {
            let target = crate::clampf(self.act.servo_target_deg[i], lo, hi);
            self.act.servo_target_deg[i] = target;
            let d = target - self.act.servo_deg[i];
            self.act.servo_deg[i] = if d.abs() <= max_step {
                target
            } else {
                self.act.servo_deg[i] + max_step.copysign(d)
            };
        }
    }

    /// Every servo is where it was sent.
    pub(super) fn servos_at_target(&self) -> bool {
        self.act.servo_deg == self.act.servo_target_deg
    }

    /// Computes the outputs from the wanted valve states and the safety overlay.
    pub(super) fn update_outputs(&mut self) {
        let vent = self.safety.venting_for_safety
            || self.fault_active(FaultCode::PressureSensor)
            || self.fault_active(FaultCode::InletStuck);
        let running = self.exec.is_some() && !self.safety.safe && !self.safety.estop_latched;
        // Never open the inlet at or above the cap, whatever asked for it.
        let below_cap = self.pressure.filt_kpa < self.cfg.pressure_limit_kpa;
        self.act.outputs = Outputs {
            servo_deg: self.act.servo_deg,
            inlet_open: running
                && self.act.want_inlet
                && !vent
                && below_cap
                && self.pressure_valid(),
            exhaust_open: vent || (running && self.act.want_exhaust),
            gripper_closed: self.act.gripper_closed,
            servos_enabled: self.act.servos_enabled,
        };
    }

    /// Holds each servo where it is.
    pub(super) fn freeze_servos(&mut self) {
        self.act.servo_target_deg = self.act.servo_deg;
    }

    /// Turns limp servos back on, commanded to the slack position: where a limp servo really
    /// is is unknown (its tendon may have back-driven it toward slack), and paying tendon out
    /// can never push the trunk, so slack is the one safe command. No-op when enabled.
    pub(super) fn enable_servos(&mut self) {
        if self.act.servos_enabled {
            return;
        }
        let slack = slack_angles(&self.cfg);
        self.act.servo_deg = slack;
        self.act.servo_target_deg = slack;
        self.panel.joystick.used_raw = None;
        self.act.servos_enabled = true;
    }
}
