//! Which device a command talks to: arguments → validated config → open, handshake.
//!
//! Without `--port` every device command uses the built-in simulator and says so on stderr,
//! so hardware is never actuated by accident.

use std::str::FromStr;

use geometry::TrunkState;
use protocol::DeviceInfo;

use crate::failure::Failure;
use crate::session::{Session, SessionError, Timing};
use crate::sim::{SimConfig, SimRun, SimTruth};
use crate::transport::{self, Port};

/// Device selection, shared by `plan`, `status`, `monitor` and `stop`.
#[derive(Debug, Clone, clap::Args)]
pub struct DeviceArgs {
    /// Serial device of a real crane, e.g. /dev/ttyACM0 (without it: the built-in simulator).
    #[arg(long, value_name = "PATH")]
    pub port: Option<String>,
    /// Use the built-in simulator on a pseudo-terminal (the default without --port).
    #[arg(long, conflicts_with = "port")]
    pub sim: bool,
    /// Simulator: the trunk's initial state [default: F&P].
    #[arg(long, value_name = "STATE")]
    pub sim_initial: Option<String>,
    /// Simulator: virtual time runs this many times faster than wall time.
    #[arg(long, value_name = "X")]
    pub sim_speed: Option<f64>,
    /// Simulator: inject a fault (repeatable): valve-stuck-closed, valve-stuck-open, leak,
    /// servo-stall, tendon-break, sensor-dropout, link-drop, line-noise.
    #[arg(long = "sim-fault", value_name = "NAME")]
    pub sim_faults: Vec<String>,
    /// Simulator: random seed (same seed, same run).
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
}

/// A validated device selection.
#[derive(Debug, Clone, PartialEq)]
pub enum DeviceConfig {
    /// A real serial device.
    Port(String),
    /// The built-in simulator.
    Sim(SimConfig),
}

/// Parses a trunk state argument; the error lists the six valid states.
pub fn parse_state(what: &str, value: &str) -> Result<TrunkState, Failure> {
    TrunkState::from_str(value)
        .map_err(|e| Failure::usage(format!("invalid {what} '{value}': {e}")))
}

impl DeviceArgs {
    /// Validates the selection. `default_speed`: the simulator speed when none is given.
    pub fn validate(&self, default_speed: f64) -> Result<DeviceConfig, Failure> {
        if let Some(path) = &self.port {
            let sim_only = [
                (self.sim_initial.is_some(), "--sim-initial"),
                (self.sim_speed.is_some(), "--sim-speed"),
                (!self.sim_faults.is_empty(), "--sim-fault"),
                (self.seed.is_some(), "--seed"),
            ];
            if let Some((_, flag)) = sim_only.iter().find(|(set, _)| *set) {
                return Err(Failure::usage(format!(
                    "{flag} only applies to the simulator; it cannot be used with --port"
                )));
            }
            if path.trim().is_empty() {
                return Err(Failure::usage(
                    "--port needs a device path, e.g. /dev/ttyACM0",
                ));
            }
            return Ok(DeviceConfig::Port(path.clone()));
        }
        let initial = match &self.sim_initial {
            Some(s) => parse_state("--sim-initial", s)?,
            None => TrunkState::AS_MANUFACTURED,
        };
        let speed = self.sim_speed.unwrap_or(default_speed);
        if !(speed.is_finite() && (0.1..=1000.0).contains(&speed)) {
            return Err(Failure::usage(format!(
                "invalid --sim-speed {speed}: it must be between 0.1 and 1000"
            )));
        }
        let mut faults = Vec::new();
        for name in &self.sim_faults {
            faults.push(crate::sim::parse_fault(name).map_err(Failure::usage)?);
        }
        Ok(DeviceConfig::Sim(SimConfig {
            initial,
            speed,
            faults,
            seed: self.seed.unwrap_or(1),
        }))
    }
}

/// An open, handshaken connection.
pub struct Connection {
    /// The protocol session.
    pub session: Session<Port>,
    /// Who the device is.
    pub info: DeviceInfo,
    /// The simulator behind the port, if it is one.
    pub sim: Option<SimRun>,
}

impl Connection {
    /// Ends the session, then stops the simulator (if it is one) and returns its ground truth.
    pub fn close(self) -> Option<SimTruth> {
        // The session goes first: the simulator stops serving once its port is closed.
        drop(self.session);
        self.sim.map(SimRun::finish)
    }
}

/// Why a connection could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// The port or the simulator could not be opened.
    #[error("{0:#}")]
    Open(anyhow::Error),
    /// The handshake failed (version mismatch, no answer).
    #[error("handshake with {device} failed: {source}")]
    Handshake {
        /// Which device.
        device: String,
        /// Why.
        source: SessionError,
        /// The simulator, so its ground truth can still be reported.
        sim: Option<Box<SimRun>>,
    },
}

impl From<ConnectError> for Failure {
    fn from(err: ConnectError) -> Self {
        // Its message already carries the source's (`{0:#}`, `…: {source}`): not chained again.
        Failure::Runtime(anyhow::anyhow!("{err}"))
    }
}

impl DeviceConfig {
    /// Timing suited to the device.
    pub fn timing(&self) -> Timing {
        match self {
            DeviceConfig::Port(_) => Timing::hardware(),
            DeviceConfig::Sim(cfg) => Timing::simulator(cfg.speed),
        }
    }

    /// Opens the device (starting the simulator if it is one) and does the handshake.
    /// Announces the simulator on stderr.
    pub fn connect(&self) -> Result<Connection, ConnectError> {
        let (path, sim) = match self {
            DeviceConfig::Port(path) => (path.clone(), None),
            DeviceConfig::Sim(cfg) => {
                let run = SimRun::start(cfg).map_err(ConnectError::Open)?;
                eprintln!(
                    "note: no --port given: using the built-in simulator on {} \
                     (initial state {}, speed ×{}, seed {}{}); no hardware is touched",
                    run.path(),
                    cfg.initial,
                    cfg.speed,
                    cfg.seed,
                    if cfg.faults.is_empty() {
                        String::new()
                    } else {
                        format!(", faults: {}", cfg.fault_names().join(", "))
                    }
                );
                (run.path().to_string(), Some(run))
            }
        };
        let port = match transport::open(&path) {
            Ok(p) => p,
            Err(e) => return Err(ConnectError::Open(e)),
        };
        let mut session = Session::new(port, self.timing());
        match session.handshake() {
            Ok(info) => Ok(Connection { session, info, sim }),
            Err(source) => Err(ConnectError::Handshake {
                device: path,
                source,
                sim: sim.map(Box::new),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args() -> DeviceArgs {
        DeviceArgs {
            port: None,
            sim: false,
            sim_initial: None,
            sim_speed: None,
            sim_faults: Vec::new(),
            seed: None,
        }
    }

    #[test]
    fn no_port_means_the_simulator_with_defaults() {
        let cfg = args().validate(20.0).unwrap();
        let DeviceConfig::Sim(sim) = cfg else {
            panic!("{cfg:?}")
        };
        assert_eq!(sim.initial, TrunkState::AS_MANUFACTURED);
        assert_eq!(sim.speed, 20.0);
    }

    #[test]
    fn simulator_options_with_a_port_are_usage_errors() {
        let mut a = args();
        a.port = Some("/dev/ttyACM0".into());
        a.sim_speed = Some(5.0);
        let Err(Failure::Usage(msg)) = a.validate(20.0) else {
            panic!()
        };
        assert!(msg.contains("--sim-speed"), "{msg}");
    }

    #[test]
    fn a_bad_initial_state_lists_the_six_states() {
        let mut a = args();
        a.sim_initial = Some("X&Y".into());
        let Err(Failure::Usage(msg)) = a.validate(20.0) else {
            panic!()
        };
        for s in ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"] {
            assert!(msg.contains(s), "{msg}");
        }
    }

    #[test]
    fn a_bad_speed_is_a_usage_error() {
        let mut a = args();
        a.sim_speed = Some(f64::NAN);
        assert!(matches!(a.validate(20.0), Err(Failure::Usage(_))));
    }
}
