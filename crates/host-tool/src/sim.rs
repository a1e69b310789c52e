//! The built-in simulator, in-process: the host engine, the real firmware controller and the
//! physics on the simulator's one virtual clock (`hil_sim::pair`). Same seed, same run; as
//! fast as the CPU allows unless `--sim-speed` asks for wall pacing.

use geometry::TrunkState;
use hil_sim::pair::SimIo;
use hil_sim::{Fault, GroundTruth, Sim, SimOptions};
use serde_json::Value;

/// How to run the simulator.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Initial trunk state.
    pub initial: TrunkState,
    /// Virtual time / wall time (`None`: as fast as possible).
    pub speed: Option<f64>,
    /// Injected faults.
    pub faults: Vec<Fault>,
    /// Random seed.
    pub seed: u64,
    /// The simulated trunk (`--sim-trunk`, `--sim-trunk-scale`; checked).
    pub trunk: Box<hil_sim::physics::TrunkSpec>,
}

/// What the simulator knows that the device can only estimate. Its serde form is the `sim`
/// object of `plan --json` and `status --json` (a state by its name).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub struct SimTruth {
    /// The trunk's physical state (None between states).
    #[serde(with = "crate::state_name::option")]
    #[schemars(with = "Option<String>")]
    pub true_state: Option<TrunkState>,
    /// Highest pressure during the run (null: not a number).
    #[serde(with = "crate::f32_or_nan")]
    #[schemars(with = "Option<f32>")]
    pub max_pressure_kpa: f32,
    /// The pressure cap (null: not a number).
    #[serde(with = "crate::f32_or_nan")]
    #[schemars(with = "Option<f32>")]
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
        serde_json::to_value(self).unwrap_or(Value::Null)
    }
}

/// Starts the simulator (with its simulated operator, who does manual steps and presses the
/// confirm button) as the engine's I/O.
pub fn start(cfg: &SimConfig) -> SimIo {
    let mut io = SimIo::new(Sim::new(SimOptions {
        initial: cfg.initial,
        seed: cfg.seed,
        faults: cfg.faults.clone(),
        speed: cfg.speed.unwrap_or(f64::INFINITY),
        operator: true,
        firmware_elf: None,
        trunk: (*cfg.trunk).clone(),
    }));
    io.pace(cfg.speed);
    io
}
