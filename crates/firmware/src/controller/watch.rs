//! The watches over a trunk that should be still: the leak watch (a sealed, still trunk losing
//! pressure), the stuck-open inlet watch (gas coming in with the inlet closed) and the rest
//! watch (a confirmed state at rest that a snap or incoming gas may have changed)
//! (`docs/firmware.md`, "Safety").

use protocol::FaultCode;

use super::belief::Belief;
use super::exec::Exec;
use super::{snap, Controller, REST_RISE_KPA};

/// The watches' state.
#[derive(Debug, Clone, Copy)]
pub(super) struct Watches {
    /// The leak watch is quiet until then ([`super::LEAK_SETTLE_MS`]).
    pub(super) leak_quiet_until_ms: u64,
    /// At rest with the state confirmed: the lowest pressure since (the rest watch's floor).
    pub(super) rest_floor_kpa: Option<f32>,
    /// A person may be folding the trunk until then ([`super::HANDS_MS`] after a manual
    /// step's wait).
    pub(super) hands_until_ms: u64,
    pub(super) leak: LeakWatch,
    pub(super) inlet: InletWatch,
}

/// Leak watch: a sealed, still trunk losing pressure faster than the allowance.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct LeakWatch {
    start: Option<(u64, f32)>,
    suspect_since_ms: Option<u64>,
}

/// Stuck-open inlet watch: gas coming in with the inlet commanded closed.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct InletWatch {
    /// Since when the inlet is commanded closed with the servos still.
    closed_since_ms: Option<u64>,
    /// Lowest pressure since then, creeping up at the drift allowance.
    floor_kpa: Option<f32>,
    last_ms: u64,
    /// A rise seen: when, and the pressure half-way through the confirmation (it must go on
    /// rising in the second half to count).
    suspect: Option<(u64, Option<f32>)>,
    /// Venting window: start time and pressure.
    vent_start: Option<(u64, f32)>,
}

impl Controller {
    /// A stuck-open inlet: the pressure rises although the inlet is commanded closed (the
    /// servos still, so no tendon compresses the trunk), or a vent stops making progress.
    /// Raises InletStuck; its fault keeps the exhaust open (`update_outputs`), which holds the
    /// pressure at or below where it was.
    pub(super) fn check_inlet(&mut self, p: f32) {
        let now = self.now_ms;
        let w = self.cfg.inlet_watch;
        let still = self.act.servo_deg == self.act.servo_target_deg;
        // A person doing a manual step moves the trunk (packing it raises the pressure), and
        // finishes a fold begun after the step stopped waiting.
        if self.exec.as_ref().is_some_and(Exec::waiting_manual) {
            self.watch.hands_until_ms = now + super::HANDS_MS;
        }
        let by_hand = now < self.watch.hands_until_ms;
        if self.act.outputs.inlet_open
            || !still
            || by_hand
            || self.fault_active(FaultCode::InletStuck)
        {
            self.watch.inlet = InletWatch::default();
            return;
        }
        let since = *self.watch.inlet.closed_since_ms.get_or_insert(now);
        if now.saturating_sub(since) < w.closed_settle_ms as u64 {
            self.watch.inlet.last_ms = now;
            return;
        }
        let dt_s = now.saturating_sub(self.watch.inlet.last_ms) as f32 / 1_000.0;
        self.watch.inlet.last_ms = now;
        let floor = match self.watch.inlet.floor_kpa {
            Some(f) => (f + w.drift_kpa_per_s * dt_s).min(p),
            None => p,
        };
        self.watch.inlet.floor_kpa = Some(floor);
        // A rise must go on: a load pressing on the sealed trunk raises it once, then stops
        // (accepted as the new level); gas coming in keeps raising it.
        // The second half of the window, so a step still settling through the filter (8 ms)
        // or the trunk's damping (≈ 50 ms) is not taken for a continuing rise.
        let mut stuck = false;
        let half = w.confirm_ms as u64 / 2;
        match self.watch.inlet.suspect {
            None if p - floor > w.rise_kpa => self.watch.inlet.suspect = Some((now, None)),
            Some((t0, None)) if now.saturating_sub(t0) >= half => {
                self.watch.inlet.suspect = Some((t0, Some(p)));
            }
            Some((t0, Some(p_half))) if now.saturating_sub(t0) >= 2 * half => {
                if p - p_half > w.confirm_rise_kpa {
                    stuck = true;
                } else {
                    self.watch.inlet.suspect = None;
                    self.watch.inlet.floor_kpa = Some(p);
                }
            }
            _ => {}
        }
        if self.act.outputs.exhaust_open && p > w.vent_min_pressure_kpa {
            let (t0, p0) = *self.watch.inlet.vent_start.get_or_insert((now, p));
            if now.saturating_sub(t0) >= w.vent_window_ms as u64 {
                stuck |= p0 - p < w.vent_min_drop_kpa;
                self.watch.inlet.vent_start = Some((now, p));
            }
        } else {
            self.watch.inlet.vent_start = None;
        }
        if stuck {
            self.watch.inlet = InletWatch::default();
            self.raise(FaultCode::InletStuck);
        }
    }

    pub(super) fn check_leak(&mut self, p: f32) {
        let now = self.now_ms;
        let lc = self.cfg.leak;
        let still = self.act.servo_deg == self.act.servo_target_deg;
        let sealed = !self.act.outputs.inlet_open && !self.act.outputs.exhaust_open;
        let settled = now >= self.watch.leak_quiet_until_ms;
        if !(sealed && still && settled && p >= lc.min_pressure_kpa) {
            self.watch.leak = LeakWatch::default();
            return;
        }
        let (t0, p0) = *self.watch.leak.start.get_or_insert((now, p));
        let elapsed_ms = now.saturating_sub(t0);
        if elapsed_ms < lc.min_window_ms as u64 {
            return;
        }
        let allowed = lc.allowance_kpa_per_s * elapsed_ms as f32 / 1_000.0 + lc.margin_kpa;
        if p0 - p > allowed {
            // A snap also drops the pressure at once: wait until the snap detector has had a
            // full window to claim the drop before calling it a leak.
            let since = *self.watch.leak.suspect_since_ms.get_or_insert(now);
            let confirm_ms = self.cfg.snap.window_ms as u64 + 2 * snap::SLOT_MS;
            if now.saturating_sub(since) >= confirm_ms {
                self.watch.leak = LeakWatch::default();
                self.raise(FaultCode::Leak);
            }
        } else {
            self.watch.leak.suspect_since_ms = None;
        }
    }

    /// The rest watch: with no step running, a confirmed state changes only if something moved
    /// the trunk — a snap the detector saw, or gas coming in ([`REST_RISE_KPA`]). Then the state
    /// is unconfirmed, its candidates what a change at rest may make of it
    /// (`transitions::rest_reach`): the swarm found valves stuck open unpacking a resting F&P and
    /// D&P while the device held them confirmed. (Air left sealed in the trunk is let out by the
    /// host before it identifies a state: `host::PlanRunner`.)
    pub(super) fn check_rest(&mut self, p: f32, snapped: bool) {
        if self.exec.is_some() || !self.trunk.belief.is_confirmed() {
            self.watch.rest_floor_kpa = None;
            return;
        }
        let floor = self.watch.rest_floor_kpa.map_or(p, |f| f.min(p));
        self.watch.rest_floor_kpa = Some(floor);
        let filling = p >= protocol::transitions::SEALED_ACTS_KPA && p - floor >= REST_RISE_KPA;
        if snapped || filling {
            let state = self.trunk.belief.state();
            self.watch.rest_floor_kpa = None;
            self.set_belief(Belief::unconfirmed(
                state,
                protocol::transitions::rest_reach(state),
                None,
            ));
        }
    }
}
