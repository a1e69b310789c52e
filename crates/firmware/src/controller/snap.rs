//! Snap-through detection from the pressure signature.
//!
//! A snap-through changes the trunk's volume within a few milliseconds. With the trunk sealed, or
//! fed through a restricted inlet, that shows as a *step* in pressure: a drop when a module pops
//! out under inflation (the trunk lengthens), a spike when a module buckles under a tendon pull
//! (the trunk shortens). Slow changes (filling, venting, compression by a slewing servo) are
//! ramps, not steps.
//!
//! The detector works on the low-pass-filtered pressure, resampled every [`SLOT_MS`] into a
//! short history. At each slot it compares the change across the last `window_ms` with the
//! change the linear trend of the `trend_ms` before it predicts:
//!
//! ```text
//! residual = (p[now] − p[now − W]) − (p[now − W] − p[now − W − T]) · W / T
//! ```
//!
//! A residual at or beyond `threshold_kpa` is a snap, signed. After a snap, further snaps are
//! ignored for `refractory_ms` (one snap, one count): a step first shows in the window, then
//! in the trend (with the opposite sign), so the refractory time must exceed `window_ms +
//! trend_ms`. A gap in samples longer than [`MAX_GAP_MS`] restarts the history.

use crate::config::SnapConfig;

/// Resampling period of the history.
pub const SLOT_MS: u64 = 10;
/// Slots kept: enough for a 100 ms window plus a 200 ms trend.
pub const HISTORY: usize = 32;
/// A gap between samples longer than this restarts the history.
pub const MAX_GAP_MS: u64 = 100;

/// Which way a snap moved the pressure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SnapSign {
    /// Pressure jumped down (a module popped out: the trunk lengthened).
    Drop,
    /// Pressure jumped up (a module buckled: the trunk shortened).
    Rise,
}

/// A detected snap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Snap {
    /// Direction.
    pub sign: SnapSign,
    /// The residual step, kPa (signed).
    pub step_kpa: f32,
    /// When it was detected.
    pub at_ms: u64,
}

/// The detector's state.
#[derive(Debug, Clone)]
pub struct SnapDetector {
    hist: [f32; HISTORY],
    /// Valid slots in `hist` (saturates at HISTORY); `hist[head]` is the newest.
    len: usize,
    head: usize,
    next_slot_ms: u64,
    last_sample_ms: Option<u64>,
    quiet_until_ms: u64,
    /// The last residual computed (for telemetry and tuning).
    pub last_residual_kpa: f32,
}

impl Default for SnapDetector {
    fn default() -> Self {
        Self::new()
    }
}

impl SnapDetector {
    /// An empty detector.
    pub const fn new() -> Self {
        Self {
            hist: [0.0; HISTORY],
            len: 0,
            head: 0,
            next_slot_ms: 0,
            last_sample_ms: None,
            quiet_until_ms: 0,
            last_residual_kpa: 0.0,
        }
    }

    /// Forgets the history (e.g. after a sensor dropout).
    pub fn reset(&mut self) {
        self.len = 0;
        self.last_sample_ms = None;
    }

    fn slot(&self, back: usize) -> f32 {
        self.hist[(self.head + HISTORY - back % HISTORY) % HISTORY]
    }

    fn push(&mut self, p: f32) {
        self.head = (self.head + 1) % HISTORY;
        self.hist[self.head] = p;
        self.len = (self.len + 1).min(HISTORY);
    }

    /// Feeds one filtered pressure sample at `now_ms`; returns a snap when one is detected.
    pub fn feed(&mut self, p_kpa: f32, now_ms: u64, cfg: &SnapConfig) -> Option<Snap> {
        if !p_kpa.is_finite() {
            self.reset();
            return None;
        }
        match self.last_sample_ms {
            Some(last) if now_ms.saturating_sub(last) <= MAX_GAP_MS => {}
            _ => {
                self.len = 0;
                self.next_slot_ms = now_ms;
            }
        }
        self.last_sample_ms = Some(now_ms);
        if now_ms < self.next_slot_ms {
            return None;
        }
        // Fill every slot that elapsed with the current value (sampling slower than SLOT_MS).
        while self.next_slot_ms <= now_ms {
            self.push(p_kpa);
            self.next_slot_ms += SLOT_MS;
        }
        let w = ((cfg.window_ms as u64).div_ceil(SLOT_MS) as usize).clamp(1, HISTORY / 3);
        let t = ((cfg.trend_ms as u64).div_ceil(SLOT_MS) as usize).clamp(1, HISTORY - 1 - w);
        if self.len < w + t + 1 {
            return None;
        }
        let now = self.slot(0);
        let mid = self.slot(w);
        let old = self.slot(w + t);
        let residual = (now - mid) - (mid - old) * (w as f32 / t as f32);
        self.last_residual_kpa = residual;
        let sign = if residual >= cfg.threshold_kpa {
            SnapSign::Rise
        } else if residual <= -cfg.threshold_kpa {
            SnapSign::Drop
        } else {
            return None;
        };
        if now_ms < self.quiet_until_ms {
            return None;
        }
        let quiet = (cfg.refractory_ms as u64).max((cfg.window_ms + cfg.trend_ms) as u64 + SLOT_MS);
        self.quiet_until_ms = now_ms + quiet;
        Some(Snap {
            sign,
            step_kpa: residual,
            at_ms: now_ms,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> SnapConfig {
        crate::CraneConfig::default().snap
    }

    /// Feeds `f(t)` every `dt` ms over `[t0, t1)` and returns the snaps seen.
    fn run(
        d: &mut SnapDetector,
        t0: u64,
        t1: u64,
        dt: u64,
        f: impl Fn(u64) -> f32,
    ) -> heapless::Vec<Snap, 16> {
        let mut out = heapless::Vec::new();
        let mut t = t0;
        while t < t1 {
            if let Some(s) = d.feed(f(t), t, &cfg()) {
                let _ = out.push(s);
            }
            t += dt;
        }
        out
    }

    #[test]
    fn a_ramp_is_not_a_snap() {
        let mut d = SnapDetector::new();
        // 20 kPa/s filling, the fastest the inlet is assumed to fill.
        let s = run(&mut d, 0, 3_000, 1, |t| t as f32 * 0.02);
        assert!(s.is_empty(), "{s:?}");
        // A ramp that stops (inlet closes at the target) is not a snap either.
        let mut d = SnapDetector::new();
        let s = run(&mut d, 0, 3_000, 1, |t| (t as f32 * 0.02).min(20.0));
        assert!(s.is_empty(), "{s:?}");
    }

    #[test]
    fn a_drop_on_a_ramp_is_one_snap_at_the_step() {
        let mut d = SnapDetector::new();
        // Filling at 10 kPa/s; a module pops out at t = 1500 ms: −3 kPa in 5 ms.
        let p = |t: u64| {
            let ramp = t as f32 * 0.01;
            let snap = if t >= 1_500 {
                -3.0 * ((t - 1_500) as f32 / 5.0).min(1.0)
            } else {
                0.0
            };
            ramp + snap
        };
        let s = run(&mut d, 0, 3_000, 1, p);
        assert_eq!(s.len(), 1, "{s:?}");
        assert_eq!(s[0].sign, SnapSign::Drop);
        // Seen within one window of the step.
        assert!(s[0].at_ms >= 1_500 && s[0].at_ms <= 1_560, "{}", s[0].at_ms);
        assert!(s[0].step_kpa < -1.5);
    }

    #[test]
    fn two_spikes_under_a_pull_are_two_snaps() {
        let mut d = SnapDetector::new();
        // Sealed trunk compressed by a slewing servo (5 kPa/s), two buckling snaps +2 kPa.
        let p = |t: u64| {
            let mut v = t as f32 * 0.005;
            for at in [1_000, 2_000] {
                if t >= at {
                    v += 2.0;
                }
            }
            v
        };
        let s = run(&mut d, 0, 3_000, 1, p);
        assert_eq!(s.len(), 2, "{s:?}");
        assert!(s.iter().all(|s| s.sign == SnapSign::Rise));
    }

    #[test]
    fn small_steps_and_slow_sampling() {
        // A 1 kPa step is below the 1.5 kPa threshold.
        let mut d = SnapDetector::new();
        let s = run(
            &mut d,
            0,
            2_000,
            1,
            |t| if t >= 1_000 { 11.0 } else { 10.0 },
        );
        assert!(s.is_empty());
        // Sampling at 100 Hz still sees a 3 kPa step.
        let mut d = SnapDetector::new();
        let s = run(
            &mut d,
            0,
            2_000,
            10,
            |t| if t >= 1_000 { 7.0 } else { 10.0 },
        );
        assert_eq!(s.len(), 1);
        // A gap longer than MAX_GAP_MS restarts the history: the step across the gap is unseen.
        let mut d = SnapDetector::new();
        let mut s = run(&mut d, 0, 1_000, 1, |_| 10.0);
        s.extend(run(&mut d, 1_500, 2_500, 1, |_| 6.0));
        assert!(s.is_empty());
        // Non-finite input is ignored.
        assert!(d.feed(f32::NAN, 2_600, &cfg()).is_none());
    }
}
