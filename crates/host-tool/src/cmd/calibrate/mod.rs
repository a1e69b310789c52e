//! `host-tool calibrate`: measure the trunk's own thresholds; `host-tool calibration show`:
//! print a profile. `Profile` is the versioned file both write and read, and the measured
//! targets `plan --calibration` builds its graph from (docs/host.md, "Calibration").
//!
//! The walk: F&P → F&F → D&F by pressure, D&F → F&F by the tendons (the top's fold over a
//! folded bottom), F&F → D&F → D&D by pressure, D&D → F&D → F&F → F&P by the tendons; with
//! `--manual`, D&F → D&P by hand and D&P → D&F by pressure after the second step.
//! Each inflation is a slow ramp toward the pressure limit with `snaps = 1`; the snap is the
//! peak of the 50 Hz telemetry before its fall, the hold the pressure the trunk settles to
//! before the vent. Each pull goes toward the tendons' reach with the step's snaps; the top's
//! buckling is the pressure spike of the sealed trunk, its stroke the commanded tendon length
//! then. The bottom's fold and packing make no spike under the tendons (the winches hold the
//! length: the trunk cannot jump), so their strokes cannot be read from the crane's sensors:
//! they run at the catalogue's lengths and the profile says so.

mod probe;

use std::path::{Path, PathBuf};

use geometry::TrunkState;
use host::calibration::{Calibration, Hooks, Measured, Targets, WalkError};
use planner::graph::Graph;
use protocol::transitions;
use protocol::{RequestBody, ResponseBody, StepKind};
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::device::{DeviceArgs, DeviceConfig};
use crate::failure::Failure;
use crate::record::Recorder;
use crate::shell::CliShell;
use crate::transport::AnyIo;

/// The profile file's format version: a file of another is refused, naming both.
pub const FORMAT_VERSION: u32 = 1;
/// A calibration profile (TOML).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    /// [`FORMAT_VERSION`].
    pub format: u32,
    /// The trunk's name.
    pub name: String,
    /// The firmware's schema id (`protocol::SCHEMA_ID`), `0x` and eight hex digits.
    pub schema_id: String,
    /// When it was measured (RFC 3339, UTC).
    pub date: String,
    /// The margin plans add to each threshold ([`MARGIN`]).
    pub margin: f64,
    /// The device's pressure limit during the calibration, kPa.
    pub pressure_limit_kpa: f64,
    /// The tendons' reach the pulls went toward, mm.
    pub tendon_reach_mm: f64,
    /// The pressure sensor's reading at rest, vented, kPa.
    pub sensor_zero_kpa: f64,
    /// The calibration's duration on the link's clock, s: the simulator's with `--sim`, the
    /// host's over a port (the device's within its clock's drift).
    pub duration_s: f64,
    /// The identification probe's signatures of this trunk, which `calibrate` and
    /// `calibration load` store on the device (absent: none measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probe: Option<ProbeSignatures>,
    /// Each measured transition, in the walk's order.
    #[serde(rename = "transition")]
    pub transitions: Vec<Measured>,
}

/// The identification probe's fill rates of one trunk (kPa/s; docs/firmware.md,
/// "Identification"): what the device decides a state from, once stored on it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSignatures {
    /// Each state's fill rate: F&P, F&F, F&D, D&P, D&F, D&D.
    pub states: Vec<f64>,
    /// A trunk resting half-packed under the folded top (F&P½) and under the deployed top
    /// (D&P½).
    pub between: Vec<f64>,
}

impl ProbeSignatures {
    /// The wire form, or why the device would refuse it (six and two rates, each within
    /// `protocol::PROBE_RATE_RANGE`).
    pub fn to_wire(&self) -> Result<protocol::ProbeProfile, String> {
        let (Ok(states), Ok(between)) = (
            <[f64; 6]>::try_from(self.states.as_slice()),
            <[f64; 2]>::try_from(self.between.as_slice()),
        ) else {
            return Err(format!(
                "probe: {} state rates and {} between rates; a profile has 6 (F&P, F&F, F&D, \
                 D&P, D&F, D&D) and 2 (F&P½, D&P½)",
                self.states.len(),
                self.between.len()
            ));
        };
        let p = protocol::ProbeProfile {
            states: states.map(|r| r as f32),
            between: between.map(|r| r as f32),
        };
        if let Some((i, r)) = p.out_of_range() {
            let (lo, hi) = protocol::PROBE_RATE_RANGE;
            return Err(format!(
                "probe: the {} fill rate {r} kPa/s is outside {lo} to {hi} kPa/s",
                host::text::probe_rate_name(i)
            ));
        }
        Ok(p)
    }

    /// From the wire form.
    pub fn from_wire(p: &protocol::ProbeProfile) -> Self {
        let r = |x: f32| (f64::from(x) * 1000.0).round() / 1000.0;
        Self {
            states: p.states.iter().map(|&x| r(x)).collect(),
            between: p.between.iter().map(|&x| r(x)).collect(),
        }
    }
}

fn schema_text() -> String {
    format!("{:#010x}", protocol::SCHEMA_ID)
}

impl Profile {
    /// Reads and checks a profile file: its format version and schema first (naming what
    /// differs), then its fields, then its values ([`Profile::check`]).
    pub fn load(path: &Path) -> Result<Self, Failure> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("cannot read the profile {}: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| Failure::usage(format!("{}: {e}", path.display())))
    }

    /// Parses and checks a profile's text.
    pub fn parse(text: &str) -> Result<Self, String> {
        let table: toml::Table = text
            .parse()
            .map_err(|e| format!("not a calibration profile (TOML): {e}"))?;
        match table.get("format").and_then(toml::Value::as_integer) {
            Some(v) if v == i64::from(FORMAT_VERSION) => {}
            Some(v) => {
                return Err(format!(
                    "a calibration profile of format version {v}; this host-tool reads version \
                     {FORMAT_VERSION}: calibrate again"
                ))
            }
            None => return Err("not a calibration profile: no `format` version".into()),
        }
        match table.get("schema_id").and_then(toml::Value::as_str) {
            Some(s) if s.eq_ignore_ascii_case(&schema_text()) => {}
            Some(s) => {
                return Err(format!(
                    "a profile measured with firmware schema {s}; this host-tool speaks schema \
                     {}: calibrate again with this firmware",
                    schema_text()
                ))
            }
            None => return Err("not a calibration profile: no `schema_id`".into()),
        }
        let p: Profile =
            toml::from_str(text).map_err(|e| format!("invalid calibration profile: {e}"))?;
        p.check()?;
        Ok(p)
    }

    /// The profile as TOML.
    pub fn to_toml(&self) -> String {
        let head = "# A calibration profile of a crane trunk (host-tool calibrate; docs/host.md, \
                    \"Calibration\").\n# Pressures in kPa as the crane's sensor reads them, \
                    lengths in mm of tendon shortening.\n";
        format!(
            "{head}{}",
            toml::to_string(self).unwrap_or_else(|e| format!("# not written: {e}\n"))
        )
    }

    /// What the walk measured, as the thresholds plans take.
    pub fn calibration(&self) -> Calibration {
        Calibration {
            margin: self.margin,
            pressure_limit_kpa: self.pressure_limit_kpa,
            tendon_reach_mm: self.tendon_reach_mm,
            transitions: self.transitions.clone(),
        }
    }

    /// Refuses a profile whose probe signatures the device would refuse, or whose snaps are
    /// missing, out of order or outside the physical range ([`Calibration::check`]).
    pub fn check(&self) -> Result<(), String> {
        if let Some(p) = &self.probe {
            p.to_wire()?;
        }
        self.calibration().check()
    }

    /// The measured targets under `limit_kpa` ([`Calibration::targets`]).
    pub fn targets(&self, limit_kpa: f64) -> Result<Targets, String> {
        self.calibration().targets(limit_kpa)
    }

    /// The calibrated graph under `limit_kpa` (the device's pressure limit, or the profile's).
    pub fn graph(&self, limit_kpa: f64) -> Result<Graph, String> {
        self.calibration().graph(limit_kpa)
    }

    /// The profile as JSON.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }
}

/// Arguments of `host-tool calibrate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Write the profile here (TOML).
    #[arg(long, value_name = "PROFILE.toml")]
    pub out: PathBuf,
    /// The trunk's name in the profile [default: the trunk's name: the simulated one's with
    /// --sim, the description's given with --trunk FILE on a port, else `crane`].
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
    /// Print the profile as one JSON object on stdout.
    #[arg(skip)]
    pub json: bool,
    /// Also walk the fold by hand: D&F → D&P (the person packs the bottom when prompted; the
    /// simulated person on --sim), then D&P → D&F by pressure, measuring the bottom's
    /// unpacking under a deployed top (otherwise D&P → D&F takes F&P → F&F's snap). The walk
    /// then passes through every state, and the identification probe's signatures are
    /// measured in each and in the two half-packed rests (the person makes and undoes each
    /// when asked); they are written to the profile and stored on the device.
    #[arg(long)]
    pub manual: bool,
}

/// Arguments of `host-tool calibration`.
#[derive(Debug, clap::Args)]
pub struct ShowArgs {
    #[command(subcommand)]
    pub command: ShowCommand,
}

/// `calibration` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum ShowCommand {
    /// Print a calibration profile and the targets plans take from it; without a file, the
    /// probe profile stored on the device (--port P, or --sim).
    Show {
        /// The profile (TOML, from `host-tool calibrate`).
        #[arg(value_name = "PROFILE.toml")]
        profile: Option<PathBuf>,
        #[command(flatten)]
        device: DeviceArgs,
        /// One JSON object on stdout.
        #[arg(skip)]
        json: bool,
    },
    /// Store a profile's probe signatures on the device (its data flash): identification then
    /// decides from them. The device refuses a profile of another firmware schema or with a
    /// rate out of range.
    Load {
        /// The profile (TOML, from `host-tool calibrate`), with a `[probe]` table.
        #[arg(value_name = "PROFILE.toml")]
        profile: PathBuf,
        #[command(flatten)]
        device: DeviceArgs,
        /// One JSON object on stdout.
        #[arg(skip)]
        json: bool,
    },
    /// Erase the probe profile stored on the device: identification asks the operator again.
    Erase {
        #[command(flatten)]
        device: DeviceArgs,
        /// One JSON object on stdout.
        #[arg(skip)]
        json: bool,
    },
}

impl ShowArgs {
    /// Whether JSON was asked for.
    pub fn json(&self) -> bool {
        match &self.command {
            ShowCommand::Show { json, .. }
            | ShowCommand::Load { json, .. }
            | ShowCommand::Erase { json, .. } => *json,
        }
    }

    /// Sets whether JSON was asked for (the global `-j/--json`).
    pub fn set_json(&mut self, on: bool) {
        match &mut self.command {
            ShowCommand::Show { json, .. }
            | ShowCommand::Load { json, .. }
            | ShowCommand::Erase { json, .. } => *json = on,
        }
    }
}

/// Runs `host-tool calibration`.
pub fn run_show(args: ShowArgs) -> Result<(), Failure> {
    match args.command {
        ShowCommand::Show {
            profile: Some(profile),
            device,
            json,
        } => {
            if device.port.is_some() || device.sim {
                return Err(Failure::usage(
                    "calibration show: give a profile file or a device (--port P, --sim), not \
                     both",
                ));
            }
            show_file(&profile, json)
        }
        ShowCommand::Show {
            profile: None,
            device,
            json,
        } => {
            let named = device.port.is_some() || device.sim;
            let device = device.validate(None).map_err(|e| match e {
                Failure::Usage(m) if !named => Failure::usage(format!(
                    "calibration show: give a PROFILE.toml, or the device whose stored probe \
                     profile to read: {m}"
                )),
                other => other,
            })?;
            let p = read_device_profile(&device)?;
            if json {
                crate::cli::print_json(json!({
                    "device_profile": p.as_ref().map(ProbeSignatures::from_wire),
                }));
            } else {
                match p {
                    Some(p) => crate::out_raw!(
                        "the device's probe profile: {}\n",
                        host::text::probe_profile_text(&p)
                    ),
                    None => crate::out_raw!(
                        "the device holds no probe profile: identification asks the operator\n"
                    ),
                }
            }
            Ok(())
        }
        ShowCommand::Load {
            profile,
            device,
            json,
        } => {
            let p = Profile::load(&profile)?;
            let Some(probe) = &p.probe else {
                return Err(Failure::usage(format!(
                    "{}: no [probe] signatures in this profile: nothing to store on the device",
                    profile.display()
                )));
            };
            let wire = probe
                .to_wire()
                .map_err(|e| Failure::usage(format!("{}: {e}", profile.display())))?;
            let device = device.validate(None)?;
            store_device_profile(&device, &p.schema_id, Some(wire))?;
            if json {
                crate::cli::print_json(json!({
                    "stored": true,
                    "device_profile": ProbeSignatures::from_wire(&wire),
                }));
            } else {
                crate::say!(
                    "stored the probe profile of trunk '{}' on the device: {}",
                    p.name,
                    host::text::probe_profile_text(&wire)
                );
            }
            Ok(())
        }
        ShowCommand::Erase { device, json } => {
            let device = device.validate(None)?;
            store_device_profile(&device, &schema_text(), None)?;
            if json {
                crate::cli::print_json(json!({"erased": true}));
            } else {
                crate::say!("erased the device's probe profile: identification asks the operator");
            }
            Ok(())
        }
    }
}

/// Prints a profile file.
fn show_file(profile: &Path, json: bool) -> Result<(), Failure> {
    let p = Profile::load(profile)?;
    let targets = p
        .targets(p.pressure_limit_kpa)
        .map_err(|e| Failure::usage(format!("{}: {e}", profile.display())))?;
    if json {
        let mut v = p.to_json();
        v["targets"] = targets_json(&targets);
        crate::cli::print_json(v);
    } else {
        crate::out_raw!("{}", show_text(&p, &targets));
    }
    Ok(())
}

/// The probe profile the device holds.
fn read_device_profile(device: &DeviceConfig) -> Result<Option<protocol::ProbeProfile>, Failure> {
    let mut conn = device.connect()?;
    let res = conn.session.command(RequestBody::GetProbeProfile);
    conn.close();
    match res {
        Ok(ResponseBody::ProbeProfile(p)) => Ok(p),
        Ok(other) => Err(anyhow::anyhow!("reading the device's probe profile: {other:?}").into()),
        Err(e) => Err(anyhow::anyhow!("reading the device's probe profile: {e}").into()),
    }
}

/// Stores `profile` on the device (`None`: erases it), measured with firmware schema
/// `schema_id` (the profile file's, `0x` and eight hex digits); a refusal says the device's
/// reason.
fn store_device_profile(
    device: &DeviceConfig,
    schema_id: &str,
    profile: Option<protocol::ProbeProfile>,
) -> Result<(), Failure> {
    let schema_id = u32::from_str_radix(schema_id.trim_start_matches("0x"), 16)
        .map_err(|_| Failure::usage(format!("schema id '{schema_id}' is not 0x and hex digits")))?;
    let mut conn = device.connect()?;
    let res = conn
        .session
        .command(RequestBody::SetProbeProfile { schema_id, profile });
    conn.close();
    res.map(|_| ()).map_err(|e| {
        anyhow::anyhow!(
            "the device refused the probe profile ({}): {e}",
            if profile.is_some() {
                "storing"
            } else {
                "erasing"
            }
        )
        .into()
    })
}

fn targets_json(targets: &[((TrunkState, TrunkState), f32)]) -> serde_json::Value {
    targets
        .iter()
        .map(|((a, b), v)| json!({"from": a.name(), "to": b.name(), "value": v}))
        .collect()
}

fn show_text(p: &Profile, targets: &[((TrunkState, TrunkState), f32)]) -> String {
    let mut s = format!(
        "calibration of trunk '{}' ({}), format {}, firmware schema {}\n\
         sensor zero {:+.2} kPa, pressure limit {} kPa, tendon reach {} mm, {:.1} s\n",
        p.name,
        p.date,
        p.format,
        p.schema_id,
        p.sensor_zero_kpa,
        p.pressure_limit_kpa,
        p.tendon_reach_mm,
        p.duration_s
    );
    for m in &p.transitions {
        s += &format!("  {} → {} ({}): {}\n", m.from, m.to, m.kind, m.text());
    }
    s += &format!("plans use (margin {:.0} %):\n", p.margin * 100.0);
    for ((a, b), v) in targets {
        let unit = transitions::transition(*a, *b)
            .map(|t| {
                if t.kind == StepKind::Pneumatic {
                    "kPa"
                } else {
                    "mm"
                }
            })
            .unwrap_or("");
        s += &format!("  {a} → {b}: {v} {unit}\n");
    }
    s += "  other edges: the catalogue's (not measurable from the crane's sensors, or by hand)\n";
    s
}

/// Runs `host-tool calibrate`.
pub fn run(mut args: Args) -> Result<(), Failure> {
    // On a port, `--trunk FILE` describes the real trunk being calibrated (its name for the
    // profile, its description checked), not a simulated one.
    let real_trunk = match args.device.sim_trunk.take() {
        Some(path) if !args.device.sim => Some(
            hil_sim::cli::sim_trunk(Some(&path), None)
                .map_err(|e| Failure::usage(format!("invalid trunk {}: {e}", path.display())))?,
        ),
        other => {
            args.device.sim_trunk = other;
            None
        }
    };
    let device = args.device.validate(None)?;
    let name = match (&args.name, &device) {
        (Some(n), _) if n.trim().is_empty() => {
            return Err(Failure::usage("--name must not be empty"))
        }
        (Some(n), _) => n.clone(),
        (None, DeviceConfig::Sim(sim)) => sim.trunk.name.clone(),
        (None, DeviceConfig::Port(_)) => real_trunk.map_or_else(|| "crane".to_string(), |t| t.name),
    };
    // The output file is opened before the work (a path that cannot be written is said now).
    std::fs::write(&args.out, "")
        .map_err(|e| Failure::usage(format!("cannot write {}: {e}", args.out.display())))?;
    let result = calibrate(&device, &name, args.manual, &args.out);
    match result {
        Ok((profile, store)) => {
            // A store that failed keeps the file: the profile was measured.
            let stored = store.transpose().map_err(|e| match e {
                Failure::Runtime(e) => Failure::Runtime(anyhow::anyhow!(
                    "profile written to {}, not stored on the device: {e}",
                    args.out.display()
                )),
                other => other,
            })?;
            let stored = stored.is_some();
            if args.json {
                let mut v = profile.to_json();
                if let Ok(t) = profile.targets(profile.pressure_limit_kpa) {
                    v["targets"] = targets_json(&t);
                }
                v["stored_on_device"] = json!(stored);
                crate::cli::print_json(v);
            } else {
                crate::say!(
                    "calibrated trunk '{}' in {:.1} s: profile written to {}{}",
                    profile.name,
                    profile.duration_s,
                    args.out.display(),
                    if stored {
                        "; its probe signatures stored on the device"
                    } else {
                        "; no probe signatures measured (calibrate --manual measures them): nothing stored \
                         on the device"
                    }
                );
            }
            Ok(())
        }
        Err(e) => {
            let _ = std::fs::remove_file(&args.out);
            Err(e)
        }
    }
}

pub(crate) fn refuse(msg: String) -> Failure {
    Failure::Runtime(anyhow::anyhow!("calibration refused: {msg}"))
}

/// Stores `wire` on the device of session `s` and reads it back: `Ok` only when the device
/// holds exactly it.
fn store_in_session(
    s: &mut host::Driver<Recorder<AnyIo>>,
    wire: protocol::ProbeProfile,
) -> Result<(), Failure> {
    s.command(RequestBody::SetProbeProfile {
        schema_id: protocol::SCHEMA_ID,
        profile: Some(wire),
    })
    .map_err(|e| anyhow::anyhow!("the device refused the probe profile (storing): {e}"))?;
    match s.command(RequestBody::GetProbeProfile) {
        Ok(ResponseBody::ProbeProfile(Some(p))) if p == wire => Ok(()),
        Ok(ResponseBody::ProbeProfile(p)) => Err(anyhow::anyhow!(
            "the device accepted the probe profile but reads back {}",
            p.map_or("none".into(), |p| host::text::probe_profile_text(&p))
        )
        .into()),
        Ok(other) => Err(anyhow::anyhow!("reading the probe profile back: {other:?}").into()),
        Err(e) => Err(anyhow::anyhow!("reading the probe profile back: {e}").into()),
    }
}

/// host-tool's side of the walk: its progress lines, Ctrl-C, and (with `--manual`) the probe's
/// signatures in each state the walk reaches and in the two rests between states.
struct CliHooks {
    manual: bool,
    interrupted: std::sync::Arc<std::sync::atomic::AtomicBool>,
    rates: [Option<probe::Reading>; 6],
    between: [Option<probe::Reading>; 2],
}

impl Hooks<Recorder<AnyIo>> for CliHooks {
    type Error = Failure;

    fn say(&mut self, line: &str) {
        crate::say!("{line}");
    }

    fn interrupted(&self) -> bool {
        self.interrupted.load(std::sync::atomic::Ordering::SeqCst)
    }

    fn at_state(
        &mut self,
        s: &mut host::Driver<Recorder<AnyIo>>,
        at: TrunkState,
    ) -> Result<(), Failure> {
        if !self.manual || self.rates[at.index()].is_some() {
            return Ok(());
        }
        let r = probe::measure(s, at, &self.interrupted)?;
        crate::say!(
            "calibrate: the probe at {at} fills at {:.2} kPa/s ({:.0} ms from {:+.2} kPa)",
            r.rate,
            r.fill_ms,
            r.p0_kpa
        );
        self.rates[at.index()] = Some(r);
        for b in [probe::Between::FoldedTop, probe::Between::DeployedTop] {
            if b.home() == at && self.between[b.index()].is_none() {
                let rb = probe::measure_between(s, b, r, &self.interrupted)?;
                crate::say!(
                    "calibrate: the probe at the rest {} fills at {:.2} kPa/s",
                    b.name(),
                    rb.rate
                );
                self.between[b.index()] = Some(rb);
            }
        }
        Ok(())
    }
}

impl CliHooks {
    /// The probe's signatures the walk measured (`None` without `--manual`).
    fn signatures(&self) -> Result<Option<ProbeSignatures>, Failure> {
        if !self.manual {
            return Ok(None);
        }
        let all = |v: &[Option<probe::Reading>]| -> Option<Vec<f64>> {
            v.iter()
                .map(|r| r.map(|r| (r.rate * 100.0).round() / 100.0))
                .collect()
        };
        let (Some(states), Some(between)) = (all(&self.rates), all(&self.between)) else {
            return Err(refuse(format!(
                "the walk did not probe every state and rest (states {:?}, rests {:?})",
                self.rates.map(|r| r.is_some()),
                self.between.map(|r| r.is_some())
            )));
        };
        let (s6, b2) = (
            <[f64; 6]>::try_from(states.as_slice()).unwrap_or_default(),
            <[f64; 2]>::try_from(between.as_slice()).unwrap_or_default(),
        );
        for note in probe::check(&s6, &b2).map_err(refuse)? {
            crate::say!("calibrate: {note}");
        }
        Ok(Some(ProbeSignatures { states, between }))
    }
}

/// Walks the calibration ([`host::calibration::run`]), writes the profile to `out` and, when
/// it holds the probe's signatures, stores them on the same device (in the same session: with
/// `--sim` the simulator that was calibrated) and reads them back. The second value is the
/// store's outcome (`None`: nothing to store).
#[allow(clippy::type_complexity)]
fn calibrate(
    device: &DeviceConfig,
    name: &str,
    manual: bool,
    out: &Path,
) -> Result<(Profile, Option<Result<(), Failure>>), Failure> {
    let interrupted = crate::shell::interrupt_flag();
    let mut conn = device.connect()?;
    let s = &mut conn.session;
    let mut shell = CliShell::new(interrupted.clone());
    let mut hooks = CliHooks {
        manual,
        interrupted: interrupted.clone(),
        rates: [None; 6],
        between: [None; 2],
    };
    let result = host::calibration::run(s, &mut shell, manual, &mut hooks)
        .map_err(|e| match e {
            WalkError::Refused(m) => refuse(m),
            WalkError::Interrupted => Failure::Interrupted("calibration interrupted".into()),
            WalkError::Device(m) => Failure::Runtime(anyhow::anyhow!(m)),
            WalkError::Hook(f) => f,
        })
        .and_then(|walked| {
            let probe = hooks.signatures()?;
            let c = walked.calibration;
            let profile = Profile {
                format: FORMAT_VERSION,
                name: name.to_string(),
                schema_id: schema_text(),
                date: chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
                margin: c.margin,
                pressure_limit_kpa: c.pressure_limit_kpa,
                tendon_reach_mm: c.tendon_reach_mm,
                sensor_zero_kpa: walked.sensor_zero_kpa,
                duration_s: walked.duration_ms as f64 / 1000.0,
                probe,
                transitions: c.transitions,
            };
            profile.check().map_err(refuse)?;
            Ok(profile)
        });
    let result = result.and_then(|profile| {
        std::fs::write(out, profile.to_toml())
            .map_err(|e| anyhow::anyhow!("writing {}: {e}", out.display()))?;
        let store = profile.probe.as_ref().map(|probe| {
            probe
                .to_wire()
                .map_err(refuse)
                .and_then(|wire| store_in_session(s, wire))
        });
        Ok((profile, store))
    });
    conn.close();
    if interrupted.load(std::sync::atomic::Ordering::SeqCst) {
        return Err(Failure::Interrupted("calibration interrupted".into()));
    }
    result
}

/// The graph `plan --calibration FILE` runs: the profile's targets under `limit_kpa`; on the
/// simulator, a profile of another trunk than the simulated one is refused.
pub fn plan_graph(
    path: &Path,
    device: &DeviceConfig,
    limit_kpa: Option<f64>,
) -> Result<Graph, Failure> {
    let p = Profile::load(path)?;
    if let DeviceConfig::Sim(sim) = device {
        if sim.trunk.name != p.name {
            return Err(Failure::usage(format!(
                "{}: a profile of trunk '{}', but the simulator runs trunk '{}': calibrate this \
                 trunk (calibrate --sim … --out FILE)",
                path.display(),
                p.name,
                sim.trunk.name
            )));
        }
    }
    p.graph(limit_kpa.unwrap_or(p.pressure_limit_kpa))
        .map_err(|e| Failure::usage(format!("{}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;
    use host::calibration::{MARGIN, REACH_MM};

    fn state(name: &str) -> TrunkState {
        name.parse().unwrap()
    }

    fn profile() -> Profile {
        let m = |a: &str, b: &str, kind: &str, snap: Vec<f64>, stroke: Vec<f64>| Measured {
            from: a.into(),
            to: b.into(),
            kind: kind.into(),
            snap_kpa: snap,
            hold_kpa: None,
            stroke_mm: stroke,
            held: true,
        };
        Profile {
            format: FORMAT_VERSION,
            name: "pdf".into(),
            schema_id: schema_text(),
            date: "2026-12-03T14:00:00Z".into(),
            margin: MARGIN,
            pressure_limit_kpa: 40.0,
            tendon_reach_mm: REACH_MM,
            sensor_zero_kpa: 0.0,
            duration_s: 60.0,
            probe: None,
            transitions: vec![
                m("F&P", "F&F", "pneumatic", vec![13.1], vec![]),
                m("F&F", "D&F", "pneumatic", vec![19.6], vec![]),
                m("D&F", "F&F", "tendon", vec![], vec![60.0]),
                m("D&F", "D&D", "pneumatic", vec![30.1], vec![]),
                m("D&D", "F&D", "tendon", vec![], vec![14.8]),
                m("F&D", "F&F", "tendon", vec![], vec![104.0]),
            ],
        }
    }

    /// The thresholds themselves are `host::calibration`'s (tested there); the profile gives
    /// them its fields and round-trips through TOML.
    #[test]
    fn a_profile_gives_its_targets_and_round_trips_through_toml() {
        let p = profile();
        p.check().unwrap();
        let t = p.targets(40.0).unwrap();
        assert_eq!(t, p.calibration().targets(40.0).unwrap());
        let unpack = t
            .iter()
            .find(|(e, _)| *e == (state("F&P"), state("F&F")))
            .unwrap()
            .1;
        assert!((unpack - 15.1).abs() < 1e-4, "13.1 kPa × 1.15: {unpack}");
        assert!(p
            .targets(30.0)
            .unwrap_err()
            .contains("under the measured snap at 30.10"));
        assert_eq!(Profile::parse(&p.to_toml()).unwrap(), p);
    }

    #[test]
    fn refusals_name_what_they_saw() {
        let mut p = profile();
        p.transitions[1].snap_kpa = vec![12.0];
        assert!(p.check().unwrap_err().contains("out of order"));
        let mut p = profile();
        p.transitions[0].snap_kpa = vec![0.2];
        assert!(p
            .check()
            .unwrap_err()
            .contains("0.20 kPa, outside the physical range"));
        let mut p = profile();
        p.transitions[3].snap_kpa.clear();
        assert!(p
            .check()
            .unwrap_err()
            .contains("D&F → D&D: no snap pressure measured"));
        let text = profile().to_toml().replace("format = 1", "format = 2");
        assert!(Profile::parse(&text)
            .unwrap_err()
            .contains("format version 2"));
        let text = profile().to_toml().replace(&schema_text(), "0x00000001");
        assert!(Profile::parse(&text)
            .unwrap_err()
            .contains("schema 0x00000001"));
    }
}
