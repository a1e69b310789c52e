//! Identification of an unconfirmed state: the operator, and the sealed-pressure probe where a
//! calibration profile of this crane's own trunk says what it measures (`docs/firmware.md`,
//! "Identification").
//!
//! Without a profile ([`crate::CraneConfig::probe_profile`] `None`, the default) the probe is no
//! evidence: a fill rate depends on the trunk's volume *and* its compliance, the reservoir and
//! the supply, which differ from trunk to trunk, so identification asks the operator at once and
//! a manual step ends unconfirmed with its candidates (the operator is then asked).
//!
//! With a profile the probe is a plan step the controller runs on itself (plan id
//! [`IDENTIFY_PLAN_ID`], so it goes through the same interlocks as any step): let the tendons
//! out, vent, settle sealed, fill to [`PROBE_KPA`] through the inlet, vent. The gas goes into the
//! trunk's volume plus the reservoir, so a shorter trunk fills faster: the fill rate (kPa/s from
//! the settled baseline to the target) tells the trunk's state where the rates differ enough.
//! [`SIM_PROFILE`] is the simulator's calibrated trunk measured through this very probe
//! (`crates/hil-sim/tests/truth.rs` measures it on three seeds and checks it); it is what a
//! calibration of that trunk would write, and the tests load it. [`RATE_TOLERANCE`] covers the
//! seeds' spread (±2 %) and a supply ±3 % off its nominal 80 kPa.
//!
//! What the simulator's profile tells apart (the windows of ±5 % around each signature): F&P,
//! D&P, and F&F from F&D only at the edges of their windows, which touch; D&F and D&D differ by
//! 1 % and are never told apart: where a step may have ended in either (`D&F → D&D`), the
//! operator is asked. The probe stays under a third of the lowest snap pressure: it cannot
//! change the state it measures.

use geometry::TrunkState;
use protocol::{Plan, Primitive, StateSet, Step, StepKind};

/// Plan id of the probe (refused for uploads).
pub const IDENTIFY_PLAN_ID: u16 = u16::MAX;

/// The probe's definition, which the host's calibration runs too (`protocol::probe`).
pub use protocol::probe::{HOLD_MS, LEAK_DROP_KPA, PROBE, PROBE_KPA, RATE_TOLERANCE, SETTLE_MS};

/// What a calibration measured through this probe on one trunk (the wire type: stored on the
/// device with [`protocol::RequestBody::SetProbeProfile`]).
pub use protocol::ProbeProfile;

/// Measured fill rate (kPa/s) of each state, by [`TrunkState::index`] (F&P, F&F, F&D, D&P, D&F,
/// D&D): the mean over seeds 1–3 through this probe on the simulator's calibrated trunk.
pub const PROBE_SIGNATURES: [f32; 6] = [11.71, 10.81, 10.24, 14.08, 12.94, 12.82];

/// The simulator's calibrated trunk's profile ([`PROBE_SIGNATURES`], [`BETWEEN_SIGNATURES`]):
/// evidence about that trunk only.
pub const SIM_PROFILE: ProbeProfile = ProbeProfile {
    states: PROBE_SIGNATURES,
    between: BETWEEN_SIGNATURES,
};

/// Measured fill rate (kPa/s) of a trunk resting between named states, through this probe on
/// the same trunk: the bottom half-packed (one layer of two, a stable well of its own) under the
/// folded top (`F&P½`, seeds 1–3: 10.95, 11.09, 11.10) and under the deployed top (`D&P½`:
/// 13.23, 13.18, 13.20). Where the candidates hold both neighbours of one (`F&P` and `F&F`,
/// `D&P` and `D&F`: a step between them may have stopped half-way) and the rate is within
/// [`RATE_TOLERANCE`] of it, the trunk may be between states, so the probe confirms nothing
/// (F&F and F&P½ are 2 % apart, D&F and D&P½ 2 %, F&P and F&P½ 6 %).
pub const BETWEEN_SIGNATURES: [f32; 2] = [11.05, 13.20];

/// The probe, as a plan within `state` (steps within one state change no belief): vent,
/// settle, fill, hold; then vent.
pub fn probe_plan(state: TrunkState) -> Plan {
    let step = |prims: &[Primitive]| Step {
        kind: StepKind::Pneumatic,
        from: state,
        to: state,
        primitives: prims.iter().copied().collect(),
        timeout_ms: 20_000,
    };
    Plan {
        plan_id: IDENTIFY_PLAN_ID,
        steps: [step(&PROBE[..4]), step(&PROBE[4..])].into_iter().collect(),
    }
}

/// A running mean.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Mean {
    sum: f32,
    n: u32,
}

impl Mean {
    fn add(&mut self, x: f32) {
        self.sum += x;
        self.n += 1;
    }

    /// The mean (`None` without samples).
    pub fn get(&self) -> Option<f32> {
        (self.n > 0).then(|| self.sum / self.n as f32)
    }
}

/// What the probe measured.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ProbeLog {
    /// Mean pressure over the settle's second half (the fill's baseline), kPa.
    pub p0: Mean,
    /// When the current primitive began, ms.
    pub prim_start_ms: u64,
    /// How long the fill took, ms (0 until it ended).
    pub fill_ms: u64,
    /// Pressure when the fill ended, kPa.
    pub filled_kpa: f32,
    /// Mean pressure over the hold's first and last 100 ms, kPa.
    pub hold_first: Mean,
    /// See `hold_first`.
    pub hold_last: Mean,
}

impl ProbeLog {
    /// One control pass during primitive `index` of the first step of [`probe_plan`] with pressure `p`.
    pub fn sample(&mut self, index: u8, started_ms: u64, now_ms: u64, p: f32) {
        self.prim_start_ms = started_ms;
        let t = now_ms.saturating_sub(started_ms);
        let hold = HOLD_MS as u64;
        match index {
            1 if t >= SETTLE_MS as u64 / 2 => self.p0.add(p),
            3 if t < 100 && self.fill_ms > 0 => self.hold_first.add(p),
            3 if t >= hold - 100 && t < hold => self.hold_last.add(p),
            _ => {}
        }
    }

    /// Primitive `index` ended at `now_ms` with pressure `p`.
    pub fn primitive_done(&mut self, index: u8, now_ms: u64, p: f32) {
        if index == 2 {
            self.fill_ms = now_ms.saturating_sub(self.prim_start_ms);
            self.filled_kpa = p;
        }
    }

    /// Fill rate, kPa/s (`None` until the fill is recorded).
    pub fn rate_kpa_per_s(&self) -> Option<f32> {
        protocol::probe::fill_rate(self.p0.get()?, self.filled_kpa, self.fill_ms)
    }

    /// Whether the sealed hold lost pressure like a leak (`None` until it is recorded).
    pub fn leaking(&self) -> Option<bool> {
        // The inlet regulator keeps holding the target through the hold: a leak shows as a
        // hold under the target (refilled in cycles), a slow one as a falling hold.
        let (first, last) = (self.hold_first.get()?, self.hold_last.get()?);
        Some(protocol::probe::leaking(self.filled_kpa, first, last))
    }

    /// The states consistent with the measurement under `profile`, for narrowing `candidates`: every state
    /// when it is incomplete, the trunk leaks, or the rate is also that of a trunk half-way
    /// between two of the candidates ([`BETWEEN_SIGNATURES`]: such a reading narrows nothing).
    pub fn verdict(&self, candidates: StateSet, profile: &ProbeProfile) -> StateSet {
        let (Some(rate), Some(false)) = (self.rate_kpa_per_s(), self.leaking()) else {
            return StateSet::ALL;
        };
        let near = |want: f32| libm::fabsf(rate - want) <= RATE_TOLERANCE * want;
        // F&P and F&F (bits 0, 1) around F&P½; D&P and D&F (bits 3, 4) around D&P½.
        let between = [0b00011, 0b11000]
            .into_iter()
            .zip(profile.between)
            .any(|(both, want)| candidates.0 & both == both && near(want));
        if between {
            return StateSet::ALL;
        }
        TrunkState::ALL
            .iter()
            .filter(|s| near(profile.states[s.index()]))
            .fold(StateSet::EMPTY, |set, s| set.with(*s))
    }
}

/// Identification of an unconfirmed state.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Identification {
    /// The operator is asked: the candidate shown (up/down select, confirm accepts).
    pub(super) asking: Option<TrunkState>,
    /// The probe's measurements while it runs, and the last probe's.
    pub(super) probe: Option<ProbeLog>,
    pub(super) last: Option<ProbeLog>,
    /// Whether the store keeps a probe profile ([`super::Controller::set_probe_profile`]):
    /// storing one is refused otherwise (it would be gone at the next reset).
    pub(super) store_keeps_profile: bool,
    /// A probe profile change to persist ([`super::Controller::poll_probe_profile`]).
    pub(super) profile_to_store: Option<Option<ProbeProfile>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log_leaking(rate: f32, leak: f32) -> ProbeLog {
        let mut l = ProbeLog::default();
        for t in 0..300 {
            l.sample(1, 1_000, 1_000 + t, 0.2);
        }
        let fill_ms = (3.8 / rate * 1_000.0) as u64;
        l.sample(2, 1_300, 1_300, 0.2);
        l.primitive_done(2, 1_300 + fill_ms, 4.0);
        let end = 1_300 + fill_ms;
        for t in 0..500 {
            l.sample(3, end, end + t, 4.0 - leak * t as f32 / 1_000.0);
        }
        l
    }

    fn log(rate: f32) -> ProbeLog {
        log_leaking(rate, 0.0)
    }

    fn set(names: &[&str]) -> StateSet {
        names
            .iter()
            .fold(StateSet::EMPTY, |a, n| a.with(n.parse().unwrap()))
    }

    #[test]
    fn the_signatures_tell_what_they_can_and_no_more() {
        // Each state's own signature keeps it.
        for s in TrunkState::ALL {
            let v = log(PROBE_SIGNATURES[s.index()]).verdict(StateSet::EMPTY, &SIM_PROFILE);
            assert!(v.contains(s), "{s}: {v:?}");
        }
        assert_eq!(
            log(11.71).verdict(StateSet::EMPTY, &SIM_PROFILE),
            set(&["F&P"])
        );
        assert_eq!(
            log(14.08).verdict(StateSet::EMPTY, &SIM_PROFILE),
            set(&["D&P"])
        );
        // D&F and D&D differ by 1 %: never told apart.
        assert_eq!(
            log(12.9).verdict(StateSet::EMPTY, &SIM_PROFILE),
            set(&["D&F", "D&D"])
        );
        // F&F and F&D: apart at their signatures, together where the windows touch.
        assert_eq!(
            log(10.81).verdict(StateSet::EMPTY, &SIM_PROFILE),
            set(&["F&F"])
        );
        assert_eq!(
            log(10.5).verdict(StateSet::EMPTY, &SIM_PROFILE),
            set(&["F&F", "F&D"])
        );
        // A leaking trunk (1 kPa/s at 4 kPa) fills slower than its volume says: no verdict.
        assert_eq!(
            log_leaking(11.71, 1.0).verdict(StateSet::EMPTY, &SIM_PROFILE),
            StateSet::ALL
        );
        assert_eq!(
            log_leaking(11.71, 0.1).verdict(StateSet::EMPTY, &SIM_PROFILE),
            set(&["F&P"])
        );
        // A half-packed bottom reads as F&F or D&F would: not decisive where it may be.
        let all = StateSet::ALL;
        assert_eq!(log(10.81).verdict(all, &SIM_PROFILE), all);
        assert_eq!(log(12.94).verdict(all, &SIM_PROFILE), all);
        assert_eq!(log(11.71).verdict(all, &SIM_PROFILE), set(&["F&P"]));
        assert_eq!(log(14.08).verdict(all, &SIM_PROFILE), set(&["D&P"]));
        let hand = set(&["F&F", "D&F", "D&P"]);
        assert_eq!(log(10.81).verdict(hand, &SIM_PROFILE), set(&["F&F"]));
        assert_eq!(log(12.94).verdict(hand, &SIM_PROFILE), all);
        // Nothing fills this slowly.
        assert!(log(8.0).verdict(StateSet::EMPTY, &SIM_PROFILE).is_empty());
        // An incomplete probe says nothing.
        let mut l = ProbeLog::default();
        l.sample(1, 0, 200, 0.0);
        assert_eq!(l.verdict(StateSet::EMPTY, &SIM_PROFILE), StateSet::ALL);
    }
}
