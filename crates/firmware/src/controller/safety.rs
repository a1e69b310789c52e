//! Faults and the safe state: raising a fault (its event once per activation), the safe state
//! it leads to (plan ended, servos frozen and limp, valves closed but for a safety vent) and
//! the reset that clears every fault whose cause is gone (`docs/firmware.md`, "Safety").

use protocol::{Event, FaultCode, PlanPhase};

use super::watch::LeakWatch;
use super::{Controller, LEAK_SETTLE_MS};

/// The faults and the modes they force.
#[derive(Debug, Clone, Copy)]
pub(super) struct Safety {
    /// Active faults ([`FaultCode::bit`]).
    pub(super) faults: u16,
    /// The most recent fault raised (the display shows it while active).
    pub(super) last_fault: Option<FaultCode>,
    pub(super) estop_latched: bool,
    /// Safe state (after a fault or an abort) until reset.
    pub(super) safe: bool,
    /// Exhaust held open for safety (over-pressure until below the vent-to pressure).
    pub(super) venting_for_safety: bool,
}

impl Controller {
    /// Whether `f` is active.
    pub(super) fn fault_active(&self, f: FaultCode) -> bool {
        self.safety.faults & f.bit() != 0
    }

    /// Raises `code` (event once per activation) and goes to the safe state.
    pub(super) fn raise(&mut self, code: FaultCode) {
        if !self.fault_active(code) {
            self.safety.faults |= code.bit();
            self.emit(Event::FaultRaised(code));
        }
        self.safety.last_fault = Some(code);
        self.enter_safe(PlanPhase::Failed(code));
    }

    /// Stops whatever runs (ending its plan with `phase`), freezes the servos where they are and
    /// closes the valves (the exhaust stays open while venting for safety).
    pub(super) fn enter_safe(&mut self, phase: PlanPhase) {
        self.end_plan(phase);
        self.safety.safe = true;
        self.freeze_servos();
        // No position feedback: a servo may have stalled short of its command, still pushing.
        // Limp servos push nothing; the origami holds its state without them.
        if self.act.servos_enabled {
            // The tendons may pull them back and let a compressed trunk lengthen: not a leak.
            self.watch.leak_quiet_until_ms = self.now_ms + LEAK_SETTLE_MS;
        }
        self.act.servos_enabled = false;
        self.panel.joystick.armed = false;
        self.act.want_inlet = false;
        self.act.want_exhaust = false;
        self.update_outputs();
    }

    /// Clears every fault whose cause is gone; leaves the safe state when none is left.
    /// Returns whether everything cleared.
    pub(super) fn reset_faults(&mut self) -> bool {
        if self.panel.buttons.estop {
            return false;
        }
        for f in FaultCode::ALL {
            if !self.fault_active(f) {
                continue;
            }
            let cause_present = match f {
                FaultCode::EStop => self.panel.buttons.estop,
                // Until the safety vent is done.
                FaultCode::OverPressure => {
                    self.safety.venting_for_safety
                        || self.pressure.filt_kpa > self.cfg.pressure_limit_kpa
                }
                FaultCode::PressureSensor => self.pressure.at_rail,
                // Until the exhaust has brought the pressure down: a still-stuck inlet holds
                // it up against the open exhaust.
                FaultCode::InletStuck => {
                    !self.pressure_valid()
                        || self.pressure.filt_kpa > self.cfg.inlet_watch.vent_min_pressure_kpa
                }
                _ => false,
            };
            if !cause_present {
                self.safety.faults &= !f.bit();
                self.emit(Event::FaultCleared(f));
            }
        }
        if self.fault_active(FaultCode::EStop) {
            return false;
        }
        self.safety.estop_latched = false;
        if self.safety.faults == 0 {
            self.safety.safe = false;
            self.watch.leak = LeakWatch::default();
            self.enable_servos();
            true
        } else {
            false
        }
    }
}
