//! Injectable faults.

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

#[cfg(test)]
mod tests {
    use super::*;

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
