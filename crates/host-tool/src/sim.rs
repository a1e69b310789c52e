//! The built-in simulator: `hil-sim` run in-process on a pseudo-terminal.
//!
//! The host talks to it through [`crate::transport`] exactly as to a board; only the start, the
//! stop and the simulator's ground truth (for reports and tests) are specific to it.

use geometry::TrunkState;
use serde_json::{json, Value};

/// The fault names the simulator knows.
pub const FAULT_NAMES: [&str; 8] = [
    "valve-stuck-closed",
    "valve-stuck-open",
    "leak",
    "servo-stall",
    "tendon-break",
    "sensor-dropout",
    "link-drop",
    "line-noise",
];

/// A simulated fault, by name.
pub type SimFault = String;

/// Checks a fault name; the error lists the valid ones.
pub fn parse_fault(name: &str) -> Result<SimFault, String> {
    let name = name.trim();
    if FAULT_NAMES.contains(&name) {
        Ok(name.to_string())
    } else {
        Err(format!(
            "unknown simulator fault '{name}'; valid faults are {}",
            FAULT_NAMES.join(", ")
        ))
    }
}

/// How to run the simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Initial trunk state.
    pub initial: TrunkState,
    /// Virtual time / wall time.
    pub speed: f64,
    /// Injected faults.
    pub faults: Vec<SimFault>,
    /// Random seed.
    pub seed: u64,
}

impl SimConfig {
    /// The fault names, for messages.
    pub fn fault_names(&self) -> Vec<String> {
        self.faults.clone()
    }
}

/// What the simulator knows that the device can only estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct SimTruth {
    /// The trunk's physical state (None between states).
    pub true_state: Option<TrunkState>,
    /// Highest pressure during the run.
    pub max_pressure_kpa: f64,
    /// The pressure cap.
    pub pressure_limit_kpa: f64,
    /// Valves closed and servos not driving.
    pub actuators_safe: bool,
}

impl SimTruth {
    /// The `sim` object of `plan --json` and `status --json`.
    pub fn to_json(&self) -> Value {
        json!({
            "true_state": self.true_state.map(|s| s.name()),
            "max_pressure_kpa": self.max_pressure_kpa,
            "pressure_limit_kpa": self.pressure_limit_kpa,
            "actuators_safe": self.actuators_safe,
        })
    }
}

/// A running simulator.
#[derive(Debug)]
pub struct SimRun {
    path: String,
}

impl SimRun {
    /// Starts the simulator on a new pseudo-terminal.
    pub fn start(_cfg: &SimConfig) -> anyhow::Result<Self> {
        anyhow::bail!("the built-in simulator is not available in this build yet")
    }

    /// The pty's device path.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The simulator's ground truth now.
    pub fn truth(&self) -> SimTruth {
        SimTruth {
            true_state: None,
            max_pressure_kpa: 0.0,
            pressure_limit_kpa: 0.0,
            actuators_safe: true,
        }
    }

    /// Stops the simulator and returns its ground truth.
    pub fn finish(self) -> SimTruth {
        SimTruth {
            true_state: None,
            max_pressure_kpa: 0.0,
            pressure_limit_kpa: 0.0,
            actuators_safe: true,
        }
    }
}
