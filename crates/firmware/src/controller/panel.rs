//! The standalone panel: the buttons (debounced; up and down step the trunk, the gripper
//! button toggles it, confirm confirms a manual step, answers the operator's question or resets
//! faults) and the joystick, which bends a flexible state by hand (`docs/firmware.md`,
//! "Standalone (no host needed)").

use geometry::TrunkState;
use heapless::Vec;
use protocol::{FaultCode, Mode};

use super::exec::Exec;
use super::{joystick_lengths_f32, Buttons, Controller, DEBOUNCE_MS};

/// The panel's state.
#[derive(Debug, Clone, Copy)]
pub(super) struct Panel {
    /// The buttons as last sampled (the e-stop and show-pressure act on the level).
    pub(super) buttons: Buttons,
    pub(super) debounce: Debounce,
    pub(super) joystick: Joystick,
}

/// Debounced buttons (up, down, gripper, confirm).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Debounce {
    raw: [bool; 4],
    stable: [bool; 4],
    since_ms: [u64; 4],
}

/// The joystick: the last sample, the one last acted on, and whether it has taken the servos.
#[derive(Debug, Clone, Copy)]
pub(super) struct Joystick {
    pub(super) raw: [u16; 2],
    pub(super) used_raw: Option<[u16; 2]>,
    /// It takes the servos only once moved past the dead zone (entering standalone never
    /// moves the tendons by itself).
    pub(super) armed: bool,
}

impl Controller {
    pub(super) fn on_buttons(&mut self, b: Buttons) {
        let now = self.now_ms;
        self.panel.buttons = b;
        if b.estop && !self.safety.estop_latched {
            self.safety.estop_latched = true;
            self.raise(FaultCode::EStop);
        }
        let raw = [b.up, b.down, b.gripper, b.confirm];
        let mut pressed = [false; 4];
        for (i, r) in raw.into_iter().enumerate() {
            if r != self.panel.debounce.raw[i] {
                self.panel.debounce.raw[i] = r;
                self.panel.debounce.since_ms[i] = now;
            }
            if self.panel.debounce.stable[i] != r
                && now.saturating_sub(self.panel.debounce.since_ms[i]) >= DEBOUNCE_MS
            {
                self.panel.debounce.stable[i] = r;
                pressed[i] = r;
            }
        }
        let [up, down, grip, confirm] = pressed;
        if confirm {
            if self.exec.as_mut().is_some_and(Exec::confirm_manual) {
                self.advance_exec();
            } else if let (Some(shown), None) = (self.ident.asking, &self.exec) {
                // The operator says the trunk is in the state shown.
                self.declare(shown);
            } else if self.safety.safe || self.safety.estop_latched {
                self.reset_faults();
            }
        }
        let idle = self.mode() == Mode::Standalone;
        if idle && grip {
            self.act.gripper_closed = !self.act.gripper_closed;
        }
        if let (Some(shown), true) = (self.ident.asking, idle || self.safety.safe) {
            // Identification by the operator: up/down pick a candidate, confirm takes it.
            if up || down {
                let c: Vec<TrunkState, 6> = self.trunk.belief.candidates().iter().collect();
                if let Some(i) = c.iter().position(|s| *s == shown) {
                    let n = c.len();
                    let j = if up { (i + 1) % n } else { (i + n - 1) % n };
                    self.ident.asking = Some(c[j]);
                }
            }
            return;
        }
        if idle && (up || down) && self.confirmed() {
            let t = if up {
                protocol::transitions::step_up(self.state())
            } else {
                protocol::transitions::step_down(self.state())
            };
            if let Some(t) = t {
                self.start_local_step(t);
            }
        }
    }

    pub(super) fn standalone_joystick(&mut self) {
        if self.mode() != Mode::Standalone || !self.state().is_flexible() || !self.confirmed() {
            self.panel.joystick.armed = false;
            self.panel.joystick.used_raw = None;
            return;
        }
        let raw = self.panel.joystick.raw;
        if self.panel.joystick.used_raw == Some(raw) {
            return;
        }
        let jc = self.cfg.joystick;
        let x = (raw[0] as f32 - jc.center_raw[0] as f32) / jc.half_range_raw;
        let y = (raw[1] as f32 - jc.center_raw[1] as f32) / jc.half_range_raw;
        let m = crate::mathf::hypot(x, y);
        if m > jc.dead_zone {
            // The joystick takes the servos only once it has been moved: entering standalone
            // (after a plan or an abort) never moves the tendons by itself.
            self.panel.joystick.armed = true;
        }
        if !self.panel.joystick.armed {
            return;
        }
        self.panel.joystick.used_raw = Some(raw);
        let dl = joystick_lengths_f32(
            x,
            y,
            jc.dead_zone,
            self.max_bend_deg,
            self.cfg.geometry.tendon_radius_mm,
        );
        let take_up_mm = self.take_up_for(self.state());
        for (i, d) in dl.iter().enumerate() {
            // Around the state's taken-up slack: the inside tendon shortens, the others pay
            // out. Human input is clamped silently to the limits (a plan's would fault).
            let l = crate::clampf(take_up_mm + d, 0.0, self.cfg.max_tendon_mm);
            self.act.servo_target_deg[i] = self
                .cfg
                .geometry
                .winch
                .angle_for_length(i, l)
                .max(self.cfg.servo.min_deg)
                .min(self.cfg.servo.max_deg);
        }
    }
}
