//! Which device a command talks to: arguments → validated config → open, handshake.
//!
//! A command that acts on a crane needs `--port` (a real crane, or an outside simulator's
//! pty) or an explicit `--sim` (the built-in simulator, in-process): without either it is a
//! usage error, so hardware is never actuated by accident and no throw-away simulator reports
//! a success that nothing earned.

use geometry::TrunkState;
use host::{Driver, Host, SessionError, Timing};
use protocol::DeviceInfo;

use crate::failure::Failure;
use crate::record::{Recorder, Recording};
use crate::sim::{SimConfig, SimTruth};
use crate::transport::{self, AnyIo, SerialIo};

/// The environment variable naming the crane's port when `--port` is not given.
pub const PORT_ENV: &str = "CRANE_PORT";

/// Device selection, shared by `plan`, `status`, `monitor` and `stop`.
#[derive(Debug, Clone, clap::Args)]
pub struct DeviceArgs {
    /// Serial device of a real crane, e.g. /dev/ttyACM0 (or a `hil-sim --pty` device).
    /// Default: $CRANE_PORT, else the one UNO R4 plugged in (asked on a terminal when several).
    #[arg(short, long, value_name = "PATH")]
    pub port: Option<String>,
    /// Use the built-in simulator, in-process (instead of a crane).
    #[arg(long, conflicts_with = "port")]
    pub sim: bool,
    /// Simulator: the trunk's initial state, quoted: 'F&P', 'F&F', 'F&D', 'D&P', 'D&F' or
    /// 'D&D' [default: F&P].
    #[arg(long, value_name = "STATE", value_parser = crate::arg::trunk_state)]
    pub sim_initial: Option<TrunkState>,
    /// Simulator: pace virtual time at X times wall time [range: 0.1–1000] [default: as fast
    /// as the CPU allows; `monitor`: 1].
    #[arg(long, value_name = "X", allow_hyphen_values = true,
          value_parser = crate::num::number_in(0.1, 1000.0))]
    pub sim_speed: Option<f64>,
    /// Simulator: inject a fault (repeatable): valve-stuck-closed, valve-stuck-open, leak,
    /// servo-stall, tendon-break, sensor-dropout, link-drop, line-noise.
    #[arg(long = "sim-fault", value_name = "NAME", value_parser = crate::arg::fault)]
    pub sim_faults: Vec<hil_sim::Fault>,
    /// Simulator: random seed, any integer (negative ones count modulo 2^64; same seed, same
    /// run) [default: 1].
    #[arg(long, value_name = "N", allow_negative_numbers = true,
          value_parser = hil_sim::cli::parse_seed)]
    pub seed: Option<u64>,
    /// Simulator: the trunk's description (TOML, as trunks/pdf.toml, the calibrated default):
    /// its design, snap forces, wells, pneumatics, tendons and sensor error; one the physics
    /// cannot represent, or whose design is outside the crane's topology or disagrees with its
    /// heights, is refused with the reason. `--trunk FILE` is the same flag (the file
    /// `pattern --trunk` and `model --trunk` make the trunk's files from).
    #[arg(long, visible_alias = "trunk", value_name = "FILE")]
    pub sim_trunk: Option<std::path::PathBuf>,
    /// Simulator: every snap force of the trunk times K [range: 0.1 to 10] (e.g. 1.35 is
    /// refused: the top's barriers overlap).
    #[arg(long, value_name = "K", allow_negative_numbers = true,
          value_parser = hil_sim::cli::parse_trunk_scale)]
    pub sim_trunk_scale: Option<f64>,
    /// Take the crane's session over from the host that holds it (one whose `Close` was lost,
    /// or one still running): the device allows it, and that host's next command is refused.
    /// Said on stderr when used; refused when a `serve` server holds the device.
    #[arg(long)]
    pub take_over: bool,
    /// The crane's link-signing key (a file of 32 hex digits, as `signing pair` writes it):
    /// requests are signed when the device says signing is on. Default: $CRANE_LINK_KEY.
    #[arg(long, value_name = "FILE")]
    pub link_key: Option<std::path::PathBuf>,
}

/// The environment variable naming the link-signing key file when `--link-key` is not given.
pub const LINK_KEY_ENV: &str = "CRANE_LINK_KEY";

/// The link key of this process's one device selection, read by [`DeviceArgs::validate`].
static LINK_KEY: std::sync::Mutex<Option<protocol::sign::LinkKey>> = std::sync::Mutex::new(None);

/// Reads a link key file: 32 hexadecimal digits (whitespace around them ignored).
pub fn read_link_key(path: &std::path::Path) -> Result<protocol::sign::LinkKey, Failure> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Failure::usage(format!("cannot read the link key {}: {e}", path.display())))?;
    parse_link_key(text.trim()).ok_or_else(|| {
        Failure::usage(format!(
            "{} is not a link key: expected 32 hexadecimal digits (as `host-tool signing pair` \
             writes)",
            path.display()
        ))
    })
}

/// 32 hex digits → a key.
pub fn parse_link_key(hex: &str) -> Option<protocol::sign::LinkKey> {
    if hex.len() != 32 || !hex.is_ascii() {
        return None;
    }
    let mut key = [0u8; 16];
    for (i, k) in key.iter_mut().enumerate() {
        *k = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(key)
}

/// A counter base that rises across host processes: the wall clock's µs since 1970.
fn signing_counter_base() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.as_micros() as u64)
}

/// `--take-over` of this process's one device selection, set by [`DeviceArgs::validate`].
static TAKE_OVER: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Sends of `Close` at most when a connection ends (its answer lost on a noisy line), one
/// response timeout apart: 4 × 250 ms, so a dead line holds an ending command ≤ 1 s, and a
/// line that loses one round trip in four still frees the session for the next command with
/// 99.6 % odds (without it the next command is refused for the device's 3 s link timeout).
pub const CLOSE_ATTEMPTS: u32 = 1 + protocol::MAX_RETRIES as u32;

/// A validated device selection.
#[derive(Debug, Clone, PartialEq)]
pub enum DeviceConfig {
    /// A real serial device.
    Port(String),
    /// The built-in simulator.
    Sim(SimConfig),
}

impl DeviceArgs {
    /// Validates the selection. `default_speed`: the simulator's pacing when none is given
    /// (`None`: as fast as possible).
    pub fn validate(&self, default_speed: Option<f64>) -> Result<DeviceConfig, Failure> {
        TAKE_OVER.store(self.take_over, std::sync::atomic::Ordering::Relaxed);
        let key_file = self.link_key.clone().or_else(|| {
            std::env::var_os(LINK_KEY_ENV)
                .filter(|v| !v.is_empty())
                .map(std::path::PathBuf::from)
        });
        let key = key_file.as_deref().map(read_link_key).transpose()?;
        *LINK_KEY.lock().unwrap_or_else(|e| e.into_inner()) = key;
        let from_env = if self.sim {
            None
        } else {
            std::env::var(PORT_ENV)
                .ok()
                .filter(|p| !p.trim().is_empty())
        };
        if let Some(path) = self.port.as_ref().or(from_env.as_ref()) {
            let sim_only = [
                (self.sim_initial.is_some(), "--sim-initial"),
                (self.sim_speed.is_some(), "--sim-speed"),
                (!self.sim_faults.is_empty(), "--sim-fault"),
                (self.seed.is_some(), "--seed"),
                (self.sim_trunk.is_some(), "--sim-trunk (--trunk)"),
                (self.sim_trunk_scale.is_some(), "--sim-trunk-scale"),
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
        let initial = self.sim_initial.unwrap_or(TrunkState::AS_MANUFACTURED);
        let speed = self.sim_speed.or(default_speed);
        if let Some(speed) = speed {
            if !(speed.is_finite() && (0.1..=1000.0).contains(&speed)) {
                return Err(Failure::usage(format!(
                    "invalid --sim-speed {speed}: expected a number from 0.1 to 1000"
                )));
            }
        }
        let faults = self.sim_faults.clone();
        let trunk = hil_sim::cli::sim_trunk(self.sim_trunk.as_deref(), self.sim_trunk_scale)
            .map_err(|e| Failure::usage(format!("invalid simulated trunk: {e}")))?;
        if !self.sim {
            return crate::cmd::ports::detect().map(DeviceConfig::Port);
        }
        Ok(DeviceConfig::Sim(SimConfig {
            initial,
            speed,
            faults,
            seed: self.seed.unwrap_or(1),
            trunk: Box::new(trunk),
        }))
    }
}

/// An open, handshaken connection: the host engine driven over the device's I/O.
pub struct Connection {
    /// The engine and its I/O (recorded when a recording is attached).
    pub session: Driver<Recorder<AnyIo>>,
    /// Who the device is.
    pub info: DeviceInfo,
}

impl Drop for Connection {
    /// A port's session ends confirmed ([`CLOSE_ATTEMPTS`]): the next command on this crane
    /// finds it free. The in-process simulator ends with the process, as before.
    fn drop(&mut self) {
        if !matches!(self.session.io.inner, AnyIo::Serial(_))
            || !self.session.host.session().is_open()
        {
            return;
        }
        match self.session.close_confirmed(CLOSE_ATTEMPTS) {
            Ok(()) => crate::debug!("session closed on the device"),
            Err(e) => {
                if crate::cli::notes() {
                    eprintln!(
                        "note: the device did not confirm the end of the session ({e}); it \
                         frees it after its link timeout ({} s), or the next command takes it \
                         over with --take-over",
                        protocol::DEFAULT_LINK_TIMEOUT_MS / 1000
                    );
                }
            }
        }
    }
}

impl Connection {
    /// The simulator's ground truth now, if the device is the built-in simulator.
    pub fn truth(&self) -> Option<SimTruth> {
        match &self.session.io.inner {
            AnyIo::Sim(io) => Some(io.sim.ground_truth().into()),
            AnyIo::Serial(_) => None,
        }
    }

    /// Ends the session and returns the simulator's final ground truth, if it is one. After a
    /// lost link the simulator first runs on for the device's link timeout (and a margin), so
    /// the truth shows what the crane did about the silent host, as a real one would.
    pub fn close(mut self) -> Option<SimTruth> {
        let st = self.session.host.session().stats();
        crate::debug!(
            "link: {}, {} retried, {} dropped",
            crate::num::plural(st.requests as usize, "request", "requests"),
            st.retries,
            crate::num::plural(
                st.frames_dropped as usize,
                "corrupt frame",
                "corrupt frames"
            )
        );
        if let AnyIo::Sim(io) = &mut self.session.io.inner {
            if self.session.host.session().is_closed() {
                io.sim
                    .run_for(u64::from(protocol::DEFAULT_LINK_TIMEOUT_MS) + 1_000);
            }
        }
        self.truth()
    }
}

/// Why a connection could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// The port could not be opened.
    #[error("{0:#}")]
    Open(anyhow::Error),
    /// The handshake failed (version mismatch, no answer).
    #[error("handshake with {device} failed: {source}")]
    Handshake {
        /// Which device.
        device: String,
        /// Why.
        source: SessionError,
        /// The simulator's ground truth, if it is one.
        truth: Option<SimTruth>,
    },
}

impl From<ConnectError> for Failure {
    fn from(err: ConnectError) -> Self {
        // Its message already carries the source's (`{0:#}`, `…: {source}`): not chained again.
        Failure::Runtime(anyhow::anyhow!("{err}"))
    }
}

/// A first sequence number that differs between host processes (a device answers a repeated
/// sequence number from its cache).
fn first_seq() -> u16 {
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    ((t ^ std::process::id()) & 0x7fff) as u16 + 1
}

impl DeviceConfig {
    /// Opens the device (starting the simulator if it is one) and does the handshake.
    pub fn connect(&self) -> Result<Connection, ConnectError> {
        self.connect_recorded(None)
    }

    /// As [`DeviceConfig::connect`], recording the session (handshake included) to `recording`.
    pub fn connect_recorded(
        &self,
        recording: Option<Recording>,
    ) -> Result<Connection, ConnectError> {
        let (name, io, seq) = match self {
            DeviceConfig::Port(path) => {
                let port = transport::open(path).map_err(ConnectError::Open)?;
                (
                    path.clone(),
                    AnyIo::Serial(SerialIo::new(port)),
                    first_seq(),
                )
            }
            // Deterministic: the same run for the same seed, down to the sequence numbers.
            DeviceConfig::Sim(cfg) => (
                "the simulator".to_string(),
                AnyIo::Sim(Box::new(crate::sim::start(cfg))),
                1,
            ),
        };
        let mut session = Driver::new(
            Host::new(Timing::standard(), seq),
            Recorder::new(io, recording),
        );
        let key = *LINK_KEY.lock().unwrap_or_else(|e| e.into_inner());
        // The simulator in-process keeps its own clock: counters from 1, same seed same run.
        let base = match self {
            DeviceConfig::Port(_) => signing_counter_base(),
            DeviceConfig::Sim(_) => 1,
        };
        session.host.set_signing(key, base);
        let started = std::time::Instant::now();
        let take_over = TAKE_OVER.load(std::sync::atomic::Ordering::Relaxed);
        if take_over && crate::cli::notes() {
            eprintln!(
                "--take-over: taking {name}'s session over from any host that holds it (that \
                 host's next command will be refused)"
            );
        }
        match session.connect_with(take_over) {
            Ok(info) => {
                crate::debug!(
                    "handshake with {name}: {} ms wall time; protocol {}, schema {:#010x}, \
                     session {}, signing {}",
                    started.elapsed().as_millis(),
                    info.protocol_version,
                    info.schema_id,
                    info.session,
                    if info.signing { "on" } else { "off" }
                );
                if info.signing && key.is_none() && crate::cli::notes() {
                    eprintln!(
                        "note: {name} signs its link: without its key (--link-key FILE or \
                         ${LINK_KEY_ENV}) every request that changes anything is refused"
                    );
                }
                Ok(Connection { session, info })
            }
            Err(source) => {
                let conn_truth = match &session.io.inner {
                    AnyIo::Sim(io) => Some(io.sim.ground_truth().into()),
                    AnyIo::Serial(_) => None,
                };
                Err(ConnectError::Handshake {
                    device: name,
                    source,
                    truth: conn_truth,
                })
            }
        }
    }
}

/// Opens the recording `path` for `command` on `device`, before anything is sent: a path that
/// cannot be written is refused up front.
pub fn start_recording(
    path: &std::path::Path,
    command: &str,
    device: &DeviceConfig,
) -> Result<Recording, Failure> {
    let mut meta = std::collections::BTreeMap::new();
    meta.insert("command".to_string(), command.to_string());
    meta.insert(
        "argv".to_string(),
        std::env::args().collect::<Vec<_>>().join(" "),
    );
    let (device_text, clock) = match device {
        DeviceConfig::Port(p) => (
            format!("port {p}"),
            "host_ms: ms since the port was opened (wall clock)",
        ),
        DeviceConfig::Sim(s) => (
            format!(
                "simulator seed {} initial {} faults [{}]",
                s.seed,
                s.initial,
                s.faults
                    .iter()
                    .map(|f| f.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            "host_ms: the simulator's virtual clock, ms",
        ),
    };
    meta.insert("device".to_string(), device_text);
    meta.insert("host_clock".to_string(), clock.to_string());
    meta.insert(
        "log_time".to_string(),
        "device uptime (ns); messages without one: host time + latest device-host offset"
            .to_string(),
    );
    let unix_ms = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis());
    meta.insert("started_unix_ms".to_string(), unix_ms.to_string());
    Recording::create(path, meta).map_err(Failure::Runtime)
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
            sim_trunk: None,
            sim_trunk_scale: None,
            take_over: false,
            link_key: None,
        }
    }

    #[test]
    fn neither_port_nor_sim_is_a_usage_error() {
        let Err(Failure::Usage(msg)) = args().validate(None) else {
            panic!()
        };
        assert!(msg.contains("--port") && msg.contains("--sim"), "{msg}");
    }

    #[test]
    fn sim_runs_unpaced_with_defaults() {
        let mut a = args();
        a.sim = true;
        let cfg = a.validate(None).unwrap();
        let DeviceConfig::Sim(sim) = cfg else {
            panic!("{cfg:?}")
        };
        assert_eq!(sim.initial, TrunkState::AS_MANUFACTURED);
        assert_eq!(sim.speed, None);
    }

    #[test]
    fn simulator_options_with_a_port_are_usage_errors() {
        let mut a = args();
        a.port = Some("/dev/ttyACM0".into());
        a.sim_speed = Some(5.0);
        let Err(Failure::Usage(msg)) = a.validate(None) else {
            panic!()
        };
        assert!(msg.contains("--sim-speed"), "{msg}");
    }

    #[derive(Debug, clap::Parser)]
    struct Cli {
        #[command(flatten)]
        device: DeviceArgs,
    }

    #[test]
    fn a_bad_initial_state_or_fault_is_clap_usage_error_naming_what_is_valid() {
        use clap::Parser as _;
        let e = Cli::try_parse_from(["t", "--sim", "--sim-initial", "X&Y"]).unwrap_err();
        assert_eq!(e.kind(), clap::error::ErrorKind::ValueValidation);
        assert_eq!(e.exit_code(), 2);
        let msg = e.to_string();
        assert!(msg.contains("'X&Y' for '--sim-initial <STATE>'"), "{msg}");
        for s in ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"] {
            assert!(msg.contains(s), "{msg}");
        }
        let e = Cli::try_parse_from(["t", "--sim", "--sim-fault", "gremlins"]).unwrap_err();
        assert!(e.to_string().contains("line-noise"), "{e}");
        let ok = Cli::try_parse_from(["t", "--sim", "--sim-initial", "d-f", "--sim-fault", "leak"])
            .expect("valid");
        assert_eq!(ok.device.sim_initial.map(|s| s.name()), Some("D&F"));
        assert_eq!(ok.device.sim_faults.len(), 1);
    }

    #[test]
    fn a_trunk_the_physics_cannot_represent_is_a_usage_error() {
        let mut a = args();
        a.sim = true;
        a.sim_trunk_scale = Some(1.35);
        let Err(Failure::Usage(msg)) = a.validate(None) else {
            panic!()
        };
        assert!(
            msg.contains("top module") && msg.contains("barrier"),
            "{msg}"
        );
        a.sim_trunk_scale = Some(1.2);
        let Ok(DeviceConfig::Sim(sim)) = a.validate(None) else {
            panic!()
        };
        assert_eq!(
            *sim.trunk,
            hil_sim::physics::TrunkSpec::pdf().scaled(1.2).unwrap()
        );
    }

    #[test]
    fn a_bad_speed_is_a_usage_error() {
        let mut a = args();
        a.sim = true;
        a.sim_speed = Some(f64::NAN);
        assert!(matches!(a.validate(None), Err(Failure::Usage(_))));
    }
}
