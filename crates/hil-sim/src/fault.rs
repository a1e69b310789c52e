//! Injectable faults, and [`FaultInjector`]: the layer that applies them.

use std::fmt;
use std::str::FromStr;

/// A fault the simulator can inject (`--fault NAME`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Fault {
    /// The inlet valve never opens (a burnt coil): inflation makes no progress.
    ValveStuckClosed,
    /// The inlet valve sticks open the first time it opens (debris on the seat): only the
    /// exhaust can hold the pressure down.
    ValveStuckOpen,
    /// A torn seam: a 2.5 mm equivalent hole (4× the 1.2 mm inlet's area), so inflation cannot
    /// reach a snap: the plan fails cleanly.
    Leak,
    /// The servos' supply sags (a failing regulator): every servo stalls at 20 % of its torque,
    /// below what buckling any module needs.
    ServoStall,
    /// Tendon 0 snaps the first time its tension exceeds 15 N.
    TendonBreak,
    /// The pressure sensor's signal is lost 1 s after the first plan starts running.
    SensorDropout,
    /// The host link goes silent (both ways) 1 s after the first plan starts running.
    LinkDrop,
    /// 1 % of the bytes on the link are corrupted, both ways.
    LineNoise,
}

impl Fault {
    /// Every fault.
    pub const ALL: [Fault; 8] = [
        Fault::ValveStuckClosed,
        Fault::ValveStuckOpen,
        Fault::Leak,
        Fault::ServoStall,
        Fault::TendonBreak,
        Fault::SensorDropout,
        Fault::LinkDrop,
        Fault::LineNoise,
    ];

    /// The command-line name, e.g. `"valve-stuck-closed"`.
    pub const fn name(self) -> &'static str {
        match self {
            Fault::ValveStuckClosed => "valve-stuck-closed",
            Fault::ValveStuckOpen => "valve-stuck-open",
            Fault::Leak => "leak",
            Fault::ServoStall => "servo-stall",
            Fault::TendonBreak => "tendon-break",
            Fault::SensorDropout => "sensor-dropout",
            Fault::LinkDrop => "link-drop",
            Fault::LineNoise => "line-noise",
        }
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.name())
    }
}

/// An unknown fault name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown fault `{0}`; valid faults are {list}", list = valid_faults())]
pub struct ParseFaultError(pub String);

fn valid_faults() -> String {
    Fault::ALL.map(Fault::name).join(", ")
}

impl FromStr for Fault {
    type Err = ParseFaultError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        Fault::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(t))
            .ok_or_else(|| ParseFaultError(s.to_string()))
    }
}

/// Fraction of the stall torque left under `servo-stall`.
pub const SERVO_STALL_FAULT_TORQUE: f64 = 0.2;
/// Tension at which tendon 0 snaps under `tendon-break`, N.
pub const TENDON_BREAK_N: f64 = 15.0;
/// Probability that a byte on the link is corrupted under `line-noise`.
pub const LINE_NOISE_RATE: f64 = 0.01;
/// Delay from the first running plan to a `link-drop` or `sensor-dropout`, ms.
pub const MID_PLAN_FAULT_DELAY_MS: u64 = 1_000;

/// The faults, as one layer between the controller's shell and the simulated parts (smoltcp's
/// `FaultInjector` is the model): every signal that crosses it — a link byte, the pressure
/// reading, the inlet's command, a tendon's tension — is passed, lost, corrupted or held here,
/// and nowhere else. The simulator asks it at each crossing; it keeps the faults' own state
/// (a valve that stuck, a tendon that broke, when a mid-plan fault strikes).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FaultInjector {
    given: Vec<Fault>,
    /// Byte corruption probability set at run time (`None`: [`LINE_NOISE_RATE`] under
    /// `line-noise`, else none).
    line_noise_rate: Option<f64>,
    first_running_ms: Option<u64>,
    link_dropped: bool,
    sensor_lost: bool,
    inlet_stuck_open: bool,
    tendon_broken: bool,
}

impl FaultInjector {
    /// A layer with `faults` given from the start.
    pub fn new(faults: &[Fault]) -> Self {
        Self {
            given: faults.to_vec(),
            ..Self::default()
        }
    }

    /// Whether `fault` is given (from the start or injected since).
    pub fn has(&self, fault: Fault) -> bool {
        self.given.contains(&fault)
    }

    /// Every fault given so far, in the order given.
    pub fn given(&self) -> &[Fault] {
        &self.given
    }

    /// Adds `fault` now; `link-drop` and `sensor-dropout` strike at once. Returns `false` if it
    /// was already given.
    pub fn inject(&mut self, fault: Fault) -> bool {
        if self.has(fault) {
            return false;
        }
        self.given.push(fault);
        match fault {
            Fault::LinkDrop => self.link_dropped = true,
            Fault::SensorDropout => self.sensor_lost = true,
            _ => {}
        }
        true
    }

    /// Corrupts each link byte with probability `rate` (clamped to 0–1) from now on.
    pub fn set_line_noise_rate(&mut self, rate: f64) {
        self.line_noise_rate = Some(rate.clamp(0.0, 1.0));
    }

    /// The factor on every servo's stall torque.
    pub fn stall_torque_factor(&self) -> f64 {
        if self.has(Fault::ServoStall) {
            SERVO_STALL_FAULT_TORQUE
        } else {
            1.0
        }
    }

    /// One step at `now_ms`, `running` while a plan runs: the mid-plan faults strike
    /// [`MID_PLAN_FAULT_DELAY_MS`] after the first plan began to run.
    pub fn tick(&mut self, now_ms: u64, running: bool) {
        if self.first_running_ms.is_none() && running {
            self.first_running_ms = Some(now_ms);
        }
        if self
            .first_running_ms
            .is_some_and(|t0| now_ms >= t0 + MID_PLAN_FAULT_DELAY_MS)
        {
            self.link_dropped |= self.has(Fault::LinkDrop);
            self.sensor_lost |= self.has(Fault::SensorDropout);
        }
    }

    /// The pressure sensor's raw reading as the controller gets it.
    pub fn pressure_raw(&self, raw: u16) -> u16 {
        if self.sensor_lost {
            0
        } else {
            raw
        }
    }

    /// Whether the link is down (both ways).
    pub fn link_down(&self) -> bool {
        self.link_dropped
    }

    /// One byte crossing the link (either way): lost (`None`) or passed, maybe corrupted, drawing
    /// from `rng` only while the line is noisy.
    pub fn link_byte(&self, b: u8, rng: &mut impl rand::Rng) -> Option<u8> {
        if self.link_dropped {
            return None;
        }
        let noisy = self.line_noise_rate.is_some_and(|r| r > 0.0) || self.has(Fault::LineNoise);
        if noisy && rng.gen_bool(self.line_noise_rate.unwrap_or(LINE_NOISE_RATE)) {
            return Some(b ^ rng.gen_range(1..=255u8));
        }
        Some(b)
    }

    /// Whether the inlet passes gas with the inlet `commanded` open now (a valve stuck open
    /// stays open from the first time it opens; one stuck closed never opens).
    pub fn inlet(&mut self, commanded: bool) -> bool {
        if commanded && self.has(Fault::ValveStuckOpen) {
            self.inlet_stuck_open = true;
        }
        self.inlet_passes(commanded)
    }

    /// As [`FaultInjector::inlet`], without changing anything (for reports).
    pub fn inlet_passes(&self, commanded: bool) -> bool {
        (commanded || self.inlet_stuck_open) && !self.has(Fault::ValveStuckClosed)
    }

    /// Whether the trunk leaks through the torn seam.
    pub fn leak(&self) -> bool {
        self.has(Fault::Leak)
    }

    /// Which tendons are broken, given tendon 0's tension now (N).
    pub fn tendons_broken(&mut self, tension0_n: f64) -> [bool; 3] {
        if self.has(Fault::TendonBreak) && tension0_n > TENDON_BREAK_N {
            self.tendon_broken = true;
        }
        [self.tendon_broken, false, false]
    }

    /// The faults in effect now (the mid-plan ones once they struck; a stuck-open valve once it
    /// stuck; a tendon once it broke).
    pub fn in_effect(&self) -> Vec<Fault> {
        self.given
            .iter()
            .copied()
            .filter(|f| match f {
                Fault::LinkDrop => self.link_dropped,
                Fault::SensorDropout => self.sensor_lost,
                Fault::ValveStuckOpen => self.inlet_stuck_open,
                Fault::TendonBreak => self.tendon_broken,
                _ => true,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layer_drops_corrupts_and_holds_what_its_faults_say() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        // Nothing given: everything passes, no random draw.
        let mut none = FaultInjector::new(&[]);
        let before = rng.clone();
        assert_eq!(none.link_byte(0x55, &mut rng), Some(0x55));
        assert_eq!(rng, before);
        assert!(none.inlet(true) && !none.inlet(false));
        assert_eq!(none.tendons_broken(100.0), [false; 3]);
        // Line noise at 100 %: every byte changes; at 0 %: none.
        let mut noisy = FaultInjector::new(&[]);
        noisy.set_line_noise_rate(1.0);
        assert!((0..100).all(|_| noisy.link_byte(0x55, &mut rng) != Some(0x55)));
        noisy.set_line_noise_rate(0.0);
        assert_eq!(noisy.link_byte(0x55, &mut rng), Some(0x55));
        // A valve stuck open holds from the first time it opens; one stuck closed never opens.
        let mut open = FaultInjector::new(&[Fault::ValveStuckOpen]);
        assert!(!open.inlet(false) && open.in_effect().is_empty());
        assert!(open.inlet(true) && open.inlet(false));
        assert_eq!(open.in_effect(), [Fault::ValveStuckOpen]);
        assert!(!FaultInjector::new(&[Fault::ValveStuckClosed]).inlet(true));
        // A tendon breaks above its tension and stays broken.
        let mut t = FaultInjector::new(&[Fault::TendonBreak]);
        assert_eq!(t.tendons_broken(TENDON_BREAK_N - 1.0), [false; 3]);
        assert_eq!(t.tendons_broken(TENDON_BREAK_N + 1.0), [true, false, false]);
        assert_eq!(t.tendons_broken(0.0), [true, false, false]);
        // Mid-plan faults strike a second after the first plan ran; injected, at once.
        let mut link = FaultInjector::new(&[Fault::LinkDrop, Fault::SensorDropout]);
        link.tick(10, true);
        link.tick(10 + MID_PLAN_FAULT_DELAY_MS - 1, false);
        assert!(!link.link_down() && link.pressure_raw(8_000) == 8_000);
        link.tick(10 + MID_PLAN_FAULT_DELAY_MS, false);
        assert!(link.link_down() && link.pressure_raw(8_000) == 0);
        assert_eq!(link.link_byte(1, &mut rng), None);
        let mut later = FaultInjector::new(&[]);
        assert!(later.inject(Fault::LinkDrop) && !later.inject(Fault::LinkDrop));
        assert!(later.link_down());
        assert_eq!(later.stall_torque_factor(), 1.0);
        assert!(later.inject(Fault::ServoStall));
        assert_eq!(later.stall_torque_factor(), SERVO_STALL_FAULT_TORQUE);
    }

    #[test]
    fn names_round_trip() {
        for f in Fault::ALL {
            assert_eq!(f.to_string().parse::<Fault>(), Ok(f));
        }
        assert_eq!("LEAK".parse::<Fault>(), Ok(Fault::Leak));
    }

    #[test]
    fn unknown_names_list_the_valid_ones() {
        let e = "valve-stuck".parse::<Fault>().unwrap_err().to_string();
        assert!(e.contains("`valve-stuck`"), "{e}");
        for f in Fault::ALL {
            assert!(e.contains(f.name()), "{e}");
        }
    }
}
