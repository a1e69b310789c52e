//! The built-in simulator: `hil-sim` run in-process on a pseudo-terminal.
//!
//! The host talks to it through [`crate::transport`] exactly as to a board (the simulator
//! serves the real firmware controller behind the pty); only the start, the stop and the
//! simulator's ground truth (for reports and tests) are specific to it.

use std::str::FromStr;

use geometry::TrunkState;
use hil_sim::pty::PtySim;
use hil_sim::{Fault, GroundTruth, SimOptions};
use serde_json::{json, Value};

/// Checks a fault name; the error lists the valid ones.
pub fn parse_fault(name: &str) -> Result<Fault, String> {
    Fault::from_str(name).map_err(|e| format!("invalid --sim-fault: {e}"))
}

/// How to run the simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Initial trunk state.
    pub initial: TrunkState,
    /// Virtual time / wall time.
    pub speed: f64,
    /// Injected faults.
    pub faults: Vec<Fault>,
    /// Random seed.
    pub seed: u64,
}

impl SimConfig {
    /// The fault names, for messages.
    pub fn fault_names(&self) -> Vec<&'static str> {
        self.faults.iter().map(|f| f.name()).collect()
    }
}

/// What the simulator knows that the device can only estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct SimTruth {
    /// The trunk's physical state (None between states).
    pub true_state: Option<TrunkState>,
    /// Highest pressure during the run.
    pub max_pressure_kpa: f32,
    /// The pressure cap.
    pub pressure_limit_kpa: f32,
    /// Valves closed and servos not driving.
    pub actuators_safe: bool,
}

impl From<GroundTruth> for SimTruth {
    fn from(t: GroundTruth) -> Self {
        Self {
            true_state: t.true_state,
            max_pressure_kpa: t.max_pressure_kpa,
            pressure_limit_kpa: t.pressure_limit_kpa,
            actuators_safe: t.actuators_safe,
        }
    }
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
    pty: PtySim,
    path: String,
}

impl SimRun {
    /// Starts the simulator on a new pseudo-terminal (with its simulated operator, who does
    /// manual steps and presses the confirm button).
    pub fn start(cfg: &SimConfig) -> anyhow::Result<Self> {
        let pty = PtySim::spawn(SimOptions {
            initial: cfg.initial,
            seed: cfg.seed,
            faults: cfg.faults.clone(),
            speed: cfg.speed,
            operator: true,
        })?;
        let path = pty.path().to_string_lossy().into_owned();
        Ok(Self { pty, path })
    }

    /// The pty's device path.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The simulator's ground truth now.
    pub fn truth(&self) -> SimTruth {
        self.pty.ground_truth().into()
    }

    /// Stops the simulator and returns its final ground truth.
    pub fn finish(self) -> SimTruth {
        self.pty.stop().into()
    }
}
