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

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use geometry::TrunkState;
use host::{Io as _, RunEvent, RunOptions, RunShell, ShellAction};
use planner::graph::{kind_name, CostModel, Graph};
use protocol::transitions::{self, Transition};
use protocol::{Event, ParamId, RequestBody, ResponseBody, StepKind, Telemetry};
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::cmd::plan::CliShell;
use crate::device::{DeviceArgs, DeviceConfig};
use crate::failure::Failure;
use crate::record::Recorder;
use crate::transport::AnyIo;

/// The profile file's format version: a file of another is refused, naming both.
pub const FORMAT_VERSION: u32 = 1;
/// The margin a calibrated plan adds to each measured threshold: an inflation toward
/// snap × (1 + 0.15), a pull to stroke × (1 + 0.15) (at least stroke + 3 mm).
pub const MARGIN: f64 = 0.15;
/// The least a pull's length exceeds its measured stroke, mm (a top that buckles after 10 mm
/// of pull would get 1.5 mm otherwise: under two telemetry samples of the servos' slew).
pub const MIN_TENDON_MARGIN_MM: f64 = 3.0;
/// The tendons' reach, mm: the longest pull the catalogue makes (within the winches' 185 mm).
pub const REACH_MM: f64 = transitions::PACK_BOTTOM_MM as f64;
/// The telemetry rate of a calibration, Hz (the device's highest).
pub const TELEMETRY_HZ: u32 = 50;
/// A fall of the pressure this far under its peak ends a ramp's peak: the snap, kPa. The
/// ramp rises 0.1–0.4 kPa per 20 ms sample and its noise is ≈ 0.05 kPa, so a fall of 0.6 kPa
/// is no noise; it is under the firmware's own detector (1.5 kPa over the ramp), so a snap too
/// small for the device (the top's pop-out over a deployed bottom drops ≈ 1 kPa on a × 1.1
/// trunk) is still measured here, and the profile says the device did not confirm it.
pub const SNAP_FALL_KPA: f64 = 0.6;
/// A rise between two telemetry samples this large during a pull is the top's buckling spike,
/// kPa (the sealed trunk's compression by the pull itself rises ≤ 0.5 kPa per 20 ms).
pub const SPIKE_KPA: f64 = 0.6;
/// The physical range of a snap pressure, kPa: above the sensor's noise at rest, and at most
/// the protocol's hard pressure ceiling.
pub const SNAP_RANGE_KPA: (f64, f64) = (1.0, protocol::HARD_MAX_PRESSURE_KPA as f64);
/// A pressure sensor reading more than this at rest (vented) is refused, kPa: the device's vent
/// tolerance (`CraneConfig::vent_tolerance_kpa`, 0.5 kPa). Every pneumatic step starts from the
/// air, a vent that ends when the sensor reads under the tolerance, so a sensor reading
/// +1 kPa at ambient never starts one (measured: a simulated offset of +1 kPa times every
/// inflation out, E-03, with or without a profile).
pub const MAX_ZERO_KPA: f64 = 0.5;

/// What a calibration measures on each step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Measure {
    /// The snap pressure of an inflation.
    Snap,
    /// The stroke of the top's buckling.
    Stroke,
    /// Nothing the sensors can read: the step moves the trunk on.
    Pass,
}

fn state(name: &str) -> TrunkState {
    // The six names are the catalogue's: parsing them cannot fail.
    name.parse().unwrap_or(TrunkState::ALL[0])
}

/// The walk, in order; with `manual`, the fold by hand to D&P and the unpacking under a
/// deployed top from there.
fn walk(manual: bool) -> Vec<(TrunkState, TrunkState, Measure)> {
    let by_hand: &[(&str, &str, Measure)] = if manual {
        &[("D&F", "D&P", Measure::Pass), ("D&P", "D&F", Measure::Snap)]
    } else {
        &[]
    };
    [("F&P", "F&F", Measure::Snap), ("F&F", "D&F", Measure::Snap)]
        .iter()
        .chain(by_hand)
        .chain(&[
            ("D&F", "F&F", Measure::Stroke),
            ("F&F", "D&F", Measure::Pass),
            ("D&F", "D&D", Measure::Snap),
            ("D&D", "F&D", Measure::Stroke),
            ("F&D", "F&F", Measure::Pass),
            ("F&F", "F&P", Measure::Pass),
        ])
        .map(|&(a, b, m)| (state(a), state(b), m))
        .collect()
}

/// Which measured edge each calibrated edge of the catalogue takes its threshold from: the
/// same barrier under the same force (the modules are in series, so D&P → D&F unpacks the
/// bottom at F&P → F&F's pressure, and F&D → D&D pops the top out at F&F → D&F's: measured
/// 19.55 against 19.53 kPa on the calibrated trunk, 21.45 against 21.49 at × 1.1). F&D → D&D
/// is not measured itself: over a deployed bottom the pop-out drops the pressure by ≈ 1 kPa at
/// × 1.1 and under 0.6 kPa at × 1.2 (the stiff deployed bottom barely lengthens), under what a
/// ramp can tell from its noise.
/// D&P → D&F takes its own snap when the walk measured it (`calibrate --manual`).
fn source_of(
    from: TrunkState,
    to: TrunkState,
    self_measured: bool,
) -> Option<(TrunkState, TrunkState)> {
    let pair = (from.name(), to.name());
    if pair == ("D&P", "D&F") && self_measured {
        return Some((from, to));
    }
    let src = match pair {
        ("F&P", "F&F") | ("D&P", "D&F") => ("F&P", "F&F"),
        ("F&F", "D&F") | ("F&D", "D&D") => ("F&F", "D&F"),
        ("D&F", "D&D") => ("D&F", "D&D"),
        ("D&D", "F&D") => ("D&D", "F&D"),
        ("D&F", "F&F") => ("D&F", "F&F"),
        _ => return None,
    };
    Some((state(src.0), state(src.1)))
}

/// Measured targets: `((from, to), value)`, kPa for a pneumatic edge, mm for a tendon edge.
pub type Targets = Vec<((TrunkState, TrunkState), f32)>;

/// One measured transition of a profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Measured {
    /// Start state.
    pub from: String,
    /// End state.
    pub to: String,
    /// `pneumatic` or `tendon`.
    pub kind: String,
    /// The pressure of each snap on the ramp, kPa (pneumatic steps).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub snap_kpa: Vec<f64>,
    /// The pressure the trunk settled to after its snap, before the vent, kPa.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hold_kpa: Option<f64>,
    /// The commanded tendon length at each snap, mm (tendon steps).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stroke_mm: Vec<f64>,
    /// Whether the device confirmed the step's target state from its sensors (it held when
    /// released); `false` when the person (or the simulated one) had to say the state.
    pub held: bool,
}

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

    /// The measured transition `from` → `to`.
    pub fn measured(&self, from: TrunkState, to: TrunkState) -> Option<&Measured> {
        self.transitions
            .iter()
            .find(|m| m.from == from.name() && m.to == to.name())
    }

    fn snap(&self, from: TrunkState, to: TrunkState) -> Option<f64> {
        self.measured(from, to)
            .and_then(|m| m.snap_kpa.last().copied())
    }

    fn stroke(&self, from: TrunkState, to: TrunkState) -> Option<f64> {
        self.measured(from, to)
            .and_then(|m| m.stroke_mm.last().copied())
    }

    /// Refuses a profile whose snaps are missing, out of order or outside the physical range,
    /// naming what it holds.
    pub fn check(&self) -> Result<(), String> {
        if let Some(p) = &self.probe {
            p.to_wire()?;
        }
        if !(self.margin.is_finite() && (0.0..=1.0).contains(&self.margin)) {
            return Err(format!(
                "margin {} is not a fraction from 0 to 1",
                self.margin
            ));
        }
        if !(self.pressure_limit_kpa.is_finite()
            && self.pressure_limit_kpa > 0.0
            && self.pressure_limit_kpa <= SNAP_RANGE_KPA.1)
        {
            return Err(format!(
                "pressure_limit_kpa {} is outside 0 to {} kPa",
                self.pressure_limit_kpa, SNAP_RANGE_KPA.1
            ));
        }
        for m in &self.transitions {
            let (from, to) = (
                m.from
                    .parse::<TrunkState>()
                    .map_err(|_| format!("'{}' is not a trunk state", m.from))?,
                m.to.parse::<TrunkState>()
                    .map_err(|_| format!("'{}' is not a trunk state", m.to))?,
            );
            if m.snap_kpa.len() > 1 {
                return Err(format!(
                    "{from} → {to}: {} snaps seen ({}); an inflation toward one snap makes one",
                    m.snap_kpa.len(),
                    list(&m.snap_kpa, "kPa")
                ));
            }
            for &p in &m.snap_kpa {
                if !(p.is_finite() && p >= SNAP_RANGE_KPA.0 && p <= self.pressure_limit_kpa) {
                    return Err(format!(
                        "{from} → {to}: a snap at {p:.2} kPa, outside the physical range {} to \
                         {} kPa (the pressure limit)",
                        SNAP_RANGE_KPA.0, self.pressure_limit_kpa
                    ));
                }
            }
            for &s in &m.stroke_mm {
                if !(s.is_finite() && s > 0.0 && s <= self.tendon_reach_mm) {
                    return Err(format!(
                        "{from} → {to}: a stroke of {s:.1} mm, outside the tendons' reach 0 to \
                         {} mm",
                        self.tendon_reach_mm
                    ));
                }
            }
        }
        for (from, to, what) in walk(false) {
            let found = match what {
                Measure::Snap => self.snap(from, to).is_some(),
                Measure::Stroke => self.stroke(from, to).is_some(),
                Measure::Pass => true,
            };
            if !found {
                return Err(format!(
                    "{from} → {to}: no {} measured",
                    if what == Measure::Snap {
                        "snap pressure"
                    } else {
                        "buckling stroke"
                    }
                ));
            }
        }
        // Under pressure: the bottom unpacks, then the top pops out, then the bottom deploys.
        let order = [
            (state("F&P"), state("F&F"), "the bottom's unpacking"),
            (state("F&F"), state("D&F"), "the top's pop-out"),
            (state("D&F"), state("D&D"), "the bottom's deployment"),
        ];
        if let Some(p) = self.snap(state("D&P"), state("D&F")) {
            let deploy = self.snap(state("D&F"), state("D&D")).unwrap_or(0.0);
            if p >= deploy {
                return Err(format!(
                    "snaps out of order: the bottom's unpacking under a deployed top at {p:.2} \
                     kPa is not below the bottom's deployment at {deploy:.2} kPa"
                ));
            }
        }
        for w in order.windows(2) {
            let (a, b) = (
                self.snap(w[0].0, w[0].1).unwrap_or(0.0),
                self.snap(w[1].0, w[1].1).unwrap_or(0.0),
            );
            if a >= b {
                return Err(format!(
                    "snaps out of order: {} at {a:.2} kPa is not below {} at {b:.2} kPa (under \
                     pressure the bottom unpacks, then the top pops out, then the bottom deploys)",
                    w[0].2, w[1].2
                ));
            }
        }
        Ok(())
    }

    /// The measured targets of the catalogue's edges: each pneumatic step inflates toward
    /// snap × (1 + margin), capped by `limit_kpa`; each measured tendon step pulls to
    /// max(stroke × (1 + margin), stroke + 3 mm) within the reach. Refused when the cap is
    /// under a measured snap or the reach under a stroke.
    pub fn targets(&self, limit_kpa: f64) -> Result<Targets, String> {
        let mut out = Vec::new();
        for t in &transitions::TRANSITIONS {
            let own = self.snap(t.from, t.to).is_some();
            let Some((a, b)) = source_of(t.from, t.to, own) else {
                continue;
            };
            let value = match t.kind {
                StepKind::Pneumatic => {
                    let Some(snap) = self.snap(a, b) else {
                        continue;
                    };
                    if limit_kpa < snap {
                        return Err(format!(
                            "{} → {}: the pressure limit {limit_kpa} kPa is under the measured \
                             snap at {snap:.2} kPa: raise it (param set pressure-limit-kpa) or \
                             calibrate again",
                            t.from, t.to
                        ));
                    }
                    (snap * (1.0 + self.margin)).min(limit_kpa)
                }
                StepKind::Tendon => {
                    let Some(stroke) = self.stroke(a, b) else {
                        continue;
                    };
                    if self.tendon_reach_mm < stroke {
                        return Err(format!(
                            "{} → {}: the tendons' reach {} mm is under the measured stroke \
                             {stroke:.1} mm",
                            t.from, t.to, self.tendon_reach_mm
                        ));
                    }
                    (stroke * (1.0 + self.margin))
                        .max(stroke + MIN_TENDON_MARGIN_MM)
                        .min(self.tendon_reach_mm)
                }
                StepKind::Manual => continue,
            };
            // Rounded to 0.1 (the listing's precision).
            out.push(((t.from, t.to), ((value * 10.0).round() / 10.0) as f32));
        }
        Ok(out)
    }

    /// The calibrated graph under `limit_kpa` (the device's pressure limit, or the profile's).
    pub fn graph(&self, limit_kpa: f64) -> Result<Graph, String> {
        Ok(Graph::calibrated(&self.targets(limit_kpa)?))
    }

    /// The profile as JSON.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }
}

fn round(x: f64, per: f64) -> f64 {
    (x * per).round() / per
}

fn list(v: &[f64], unit: &str) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x:.2} {unit}")).collect();
    parts.join(", ")
}

/// Arguments of `host-tool calibrate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Write the profile here (TOML).
    #[arg(long, value_name = "PROFILE.toml")]
    pub out: PathBuf,
    /// The trunk's name in the profile [default: the simulated trunk's name with --sim, else
    /// `crane`].
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
        s += &format!(
            "  {} → {} ({}): {}\n",
            m.from,
            m.to,
            m.kind,
            measured_text(m)
        );
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

fn measured_text(m: &Measured) -> String {
    let mut parts = Vec::new();
    if !m.snap_kpa.is_empty() {
        parts.push(format!("snap at {}", list(&m.snap_kpa, "kPa")));
    }
    if let Some(h) = m.hold_kpa {
        parts.push(format!("holds at {h:.2} kPa"));
    }
    if !m.stroke_mm.is_empty() {
        let v: Vec<String> = m.stroke_mm.iter().map(|x| format!("{x:.1} mm")).collect();
        parts.push(format!("buckles at {}", v.join(", ")));
    }
    if parts.is_empty() {
        parts.push("moved on (no snap the sensors can read)".into());
    }
    parts.push(if m.held { "held" } else { "not confirmed" }.into());
    parts.join(", ")
}

/// The shell of a calibration's steps: the plan command's (progress, prompts, the simulated
/// person) plus the telemetry samples of the step.
struct CalShell {
    inner: CliShell,
    samples: Vec<Telemetry>,
}

impl RunShell<Recorder<AnyIo>> for CalShell {
    fn event(&mut self, event: &RunEvent, io: &mut Recorder<AnyIo>) {
        self.inner.event(event, io);
    }
    fn poll(&mut self, io: &mut Recorder<AnyIo>) -> Option<ShellAction> {
        self.inner.poll(io)
    }
    fn device_event(&mut self, event: &Event, _io: &mut Recorder<AnyIo>) {
        if let Event::Telemetry(t) = event {
            self.samples.push(*t);
        }
    }
}

/// The peak of an inflation's ramp before its first fall of [`SNAP_FALL_KPA`], and the
/// pressure the trunk settled to after it before the exhaust opened.
pub fn ramp_snap(samples: &[(f64, bool, bool)]) -> (Option<f64>, Option<f64>, f64) {
    let start = samples.iter().position(|s| s.1).unwrap_or(samples.len());
    let mut peak = f64::NEG_INFINITY;
    let mut snap = None;
    let mut after = samples.len();
    for (i, &(p, _, _)) in samples.iter().enumerate().skip(start) {
        if p > peak {
            peak = p;
        } else if p < peak - SNAP_FALL_KPA {
            // A snap falls while the inlet is open (the device closes it at the drop); a fall
            // after the inlet closed is the regulator at its target, or the leak: the ramp
            // goes on from there.
            if samples[i - 1].1 {
                snap = Some(peak);
                after = i;
                break;
            }
            peak = p;
        }
    }
    let max = samples
        .iter()
        .map(|s| s.0)
        .fold(f64::NEG_INFINITY, f64::max);
    // The hold: only when the inlet closed at the fall (the device saw the snap); an
    // inflation that went on to the cap holds nothing of the snap's.
    let closed = samples[after.min(samples.len())..]
        .iter()
        .take(3)
        .any(|s| !s.1);
    let hold = snap.filter(|_| closed).and_then(|_| {
        samples[after..]
            .iter()
            .take_while(|s| !s.2)
            .last()
            .map(|s| s.0)
    });
    (snap, hold, max)
}

/// Each buckling spike of a pull: the commanded tendon length (mm) at each sample whose
/// pressure rose [`SPIKE_KPA`] over the one before while the tendons were not let out.
pub fn pull_spikes(samples: &[(f64, f64)]) -> Vec<f64> {
    let mut out = Vec::new();
    let mut longest = 0.0f64;
    let mut last_spike: Option<usize> = None;
    for i in 1..samples.len() {
        let (p0, l0) = samples[i - 1];
        let (p, l) = samples[i];
        longest = longest.max(l);
        let pulling = l >= l0 - 1e-3 && l > 0.5;
        // One snap's spike lasts a few samples: count it once.
        if pulling && p - p0 >= SPIKE_KPA && last_spike.is_none_or(|k| i > k + 5) {
            out.push(longest);
            last_spike = Some(i);
        } else if p - p0 >= SPIKE_KPA {
            last_spike = Some(i);
        }
    }
    out
}

/// The calibration's one-step transition from `from` to `to`: toward the pressure limit with
/// one snap, or toward the reach with the step's snaps.
fn probe(t: &Transition, limit_kpa: f32, what: Measure) -> Transition {
    match what {
        Measure::Snap => planner::graph::retarget(t, limit_kpa),
        Measure::Stroke => planner::graph::retarget(t, REACH_MM as f32),
        Measure::Pass => *t,
    }
}

fn tendon_mm(cfg: &protocol::WinchConfig, deg: &[f32; 3]) -> f64 {
    (0..3)
        .map(|i| f64::from(cfg.length_for_angle(i, deg[i])))
        .sum::<f64>()
        / 3.0
}

/// Runs `host-tool calibrate`.
pub fn run(args: Args) -> Result<(), Failure> {
    let device = args.device.validate(None)?;
    let name = match (&args.name, &device) {
        (Some(n), _) if n.trim().is_empty() => {
            return Err(Failure::usage("--name must not be empty"))
        }
        (Some(n), _) => n.clone(),
        (None, DeviceConfig::Sim(sim)) => sim.trunk.name.clone(),
        (None, DeviceConfig::Port(_)) => "crane".to_string(),
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

/// Walks the calibration, writes the profile to `out` and, when it holds the probe's
/// signatures, stores them on the same device (in the same session: with `--sim` the
/// simulator that was calibrated) and reads them back. The second value is the store's
/// outcome (`None`: nothing to store).
#[allow(clippy::type_complexity)]
fn calibrate(
    device: &DeviceConfig,
    name: &str,
    manual: bool,
    out: &Path,
) -> Result<(Profile, Option<Result<(), Failure>>), Failure> {
    let interrupted = crate::cmd::plan::interrupt_flag();
    let mut conn = device.connect()?;
    let s = &mut conn.session;
    let limit_kpa = match s.command(RequestBody::GetParam(ParamId::PressureLimitKpa)) {
        Ok(ResponseBody::Param { value, .. }) => value,
        other => {
            return Err(anyhow::anyhow!("reading the device's pressure limit: {other:?}").into())
        }
    };
    let previous_rate = crate::cmd::monitor::set_telemetry_rate(s, TELEMETRY_HZ);
    let start_ms = s.io.now_ms();
    let mut shell = CalShell {
        inner: CliShell::new(interrupted.clone()),
        samples: Vec::new(),
    };
    let result = (|| -> Result<Profile, Failure> {
        let st = s
            .status()
            .map_err(|e| anyhow::anyhow!("reading the device's state: {e}"))?;
        let first = state("F&P");
        if !(st.state == first && st.state_confirmed) {
            crate::say!(
                "calibrate: the trunk is at {}{}: taking it to F&P first",
                st.state,
                if st.state_confirmed {
                    ""
                } else {
                    " (unconfirmed)"
                }
            );
            let out = s.run_plan(Graph::nominal(), first, RunOptions::default(), &mut shell);
            if !out.ok() {
                return Err(refuse(format!(
                    "could not start from F&P: {}",
                    out.error().unwrap_or("not reached")
                )));
            }
        }
        // The sensor's zero: one second of telemetry at rest, vented.
        s.device_events.clear();
        s.idle(1000)
            .map_err(|e| anyhow::anyhow!("reading the sensor at rest: {e}"))?;
        let rest: Vec<f64> = drain_telemetry(&mut s.device_events)
            .iter()
            .map(|t| f64::from(t.pressure_kpa))
            .collect();
        if rest.is_empty() {
            return Err(refuse(
                "no telemetry at rest: the device sends none at 50 Hz".into(),
            ));
        }
        let zero = rest.iter().sum::<f64>() / rest.len() as f64;
        crate::say!(
            "calibrate: sensor zero {zero:+.2} kPa at rest ({} samples)",
            rest.len()
        );
        if zero > MAX_ZERO_KPA {
            return Err(refuse(format!(
                "the pressure sensor reads {zero:+.2} kPa at rest, vented: over the device's \
                 {MAX_ZERO_KPA} kPa vent tolerance, no inflation can start from the air; \
                 correct the sensor's offset (its calibration in the firmware's configuration)"
            )));
        }
        let servo = protocol::CraneGeometry::default().winch;
        let steps = walk(manual);
        let mut measured = Vec::new();
        // The probe's signatures (with --manual: the walk then passes through every state).
        let mut rates: [Option<probe::Reading>; 6] = [None; 6];
        let mut between: [Option<probe::Reading>; 2] = [None; 2];
        let mut probe_at =
            |s: &mut host::Driver<Recorder<AnyIo>>, at: TrunkState| -> Result<(), Failure> {
                if !manual || rates[at.index()].is_some() {
                    return Ok(());
                }
                let r = probe::measure(s, at, &interrupted)?;
                crate::say!(
                    "calibrate: the probe at {at} fills at {:.2} kPa/s ({:.0} ms from {:+.2} kPa)",
                    r.rate,
                    r.fill_ms,
                    r.p0_kpa
                );
                rates[at.index()] = Some(r);
                for b in [probe::Between::FoldedTop, probe::Between::DeployedTop] {
                    if b.home() == at && between[b.index()].is_none() {
                        let rb = probe::measure_between(s, b, r, &interrupted)?;
                        crate::say!(
                            "calibrate: the probe at the rest {} fills at {:.2} kPa/s",
                            b.name(),
                            rb.rate
                        );
                        between[b.index()] = Some(rb);
                    }
                }
                Ok(())
            };
        probe_at(s, first)?;
        for (k, (from, to, what)) in steps.iter().copied().enumerate() {
            if interrupted.load(std::sync::atomic::Ordering::SeqCst) {
                return Err(Failure::Interrupted("calibration interrupted".into()));
            }
            let Some(t) = transitions::transition(from, to) else {
                return Err(refuse(format!("{from} → {to} is not in the catalogue")));
            };
            let t = probe(t, limit_kpa, what);
            let graph = Graph::from_transitions(vec![t], CostModel::default());
            shell.samples.clear();
            crate::say!(
                "calibrate {}/{}: {from} → {to} by {}{}",
                k + 1,
                steps.len(),
                match t.kind {
                    StepKind::Tendon => "the tendons",
                    StepKind::Pneumatic => "pressure",
                    StepKind::Manual => "hand (the person folds it when prompted)",
                },
                match what {
                    Measure::Snap => format!(", a ramp toward {limit_kpa} kPa"),
                    Measure::Stroke => format!(", a pull toward {REACH_MM} mm"),
                    Measure::Pass => String::new(),
                }
            );
            let out = s.run_plan(graph, to, RunOptions::default(), &mut shell);
            let samples = std::mem::take(&mut shell.samples);
            let mut m = Measured {
                from: from.name().into(),
                to: to.name().into(),
                kind: kind_name(t.kind).into(),
                snap_kpa: Vec::new(),
                hold_kpa: None,
                stroke_mm: Vec::new(),
                held: out.steps.first().is_some_and(|r| r.ok),
            };
            match what {
                Measure::Snap => {
                    let ramp: Vec<(f64, bool, bool)> = samples
                        .iter()
                        .map(|t| (f64::from(t.pressure_kpa), t.inlet_open, t.exhaust_open))
                        .collect();
                    let (snap, hold, max) = ramp_snap(&ramp);
                    let Some(snap) = snap else {
                        return Err(refuse(format!(
                            "{from} → {to}: no snap seen on the ramp (the pressure rose to \
                             {max:.2} kPa; the limit is {limit_kpa} kPa){}",
                            out.error()
                                .map(|e| format!("; the step: {e}"))
                                .unwrap_or_default()
                        )));
                    };
                    m.snap_kpa.push(round(snap, 100.0));
                    m.hold_kpa = hold.map(|h| round(h, 100.0));
                    crate::say!(
                        "calibrate {}/{}: snap at {snap:.2} kPa{}",
                        k + 1,
                        steps.len(),
                        hold.map(|h| format!(", holds at {h:.2} kPa"))
                            .unwrap_or_default()
                    );
                }
                Measure::Stroke => {
                    let pull: Vec<(f64, f64)> = samples
                        .iter()
                        .map(|t| (f64::from(t.pressure_kpa), tendon_mm(&servo, &t.servo_deg)))
                        .collect();
                    let spikes = pull_spikes(&pull);
                    let longest = pull.iter().map(|p| p.1).fold(0.0, f64::max);
                    let Some(&stroke) = spikes.first() else {
                        return Err(refuse(format!(
                            "{from} → {to}: no buckling seen (the tendons pulled {longest:.1} \
                             mm){}",
                            out.error()
                                .map(|e| format!("; the step: {e}"))
                                .unwrap_or_default()
                        )));
                    };
                    m.stroke_mm = spikes.iter().map(|&x| round(x, 10.0)).collect();
                    crate::say!(
                        "calibrate {}/{}: buckles at {stroke:.1} mm of pull",
                        k + 1,
                        steps.len()
                    );
                }
                Measure::Pass => {}
            }
            if !out.ok() {
                return Err(refuse(format!(
                    "{from} → {to}: {} (measured so far: {})",
                    out.error().unwrap_or("the step did not reach its target"),
                    measured
                        .iter()
                        .chain(std::iter::once(&m))
                        .map(|m: &Measured| format!("{} → {}: {}", m.from, m.to, measured_text(m)))
                        .collect::<Vec<_>>()
                        .join("; ")
                )));
            }
            measured.push(m);
            probe_at(s, to)?;
        }
        let probe = if manual {
            let all = |v: &[Option<probe::Reading>]| -> Option<Vec<f64>> {
                v.iter().map(|r| r.map(|r| round(r.rate, 100.0))).collect()
            };
            let (Some(states), Some(between)) = (all(&rates), all(&between)) else {
                return Err(refuse(format!(
                    "the walk did not probe every state and rest (states {:?}, rests {:?})",
                    rates.map(|r| r.is_some()),
                    between.map(|r| r.is_some())
                )));
            };
            let (s6, b2) = (
                <[f64; 6]>::try_from(states.as_slice()).unwrap_or_default(),
                <[f64; 2]>::try_from(between.as_slice()).unwrap_or_default(),
            );
            for note in probe::check(&s6, &b2).map_err(refuse)? {
                crate::say!("calibrate: {note}");
            }
            Some(ProbeSignatures { states, between })
        } else {
            None
        };
        let profile = Profile {
            format: FORMAT_VERSION,
            name: name.to_string(),
            schema_id: schema_text(),
            date: chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
            margin: MARGIN,
            pressure_limit_kpa: f64::from(limit_kpa),
            tendon_reach_mm: REACH_MM,
            sensor_zero_kpa: (zero * 1000.0).round() / 1000.0,
            duration_s: (s.io.now_ms() - start_ms) as f64 / 1000.0,
            probe,
            transitions: measured,
        };
        profile.check().map_err(refuse)?;
        profile
            .targets(profile.pressure_limit_kpa)
            .map_err(refuse)?;
        Ok(profile)
    })();
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
    if let Some(value) = previous_rate {
        let _ = s.command(RequestBody::SetParam {
            id: ParamId::TelemetryHz,
            value,
        });
    }
    conn.close();
    if interrupted.load(std::sync::atomic::Ordering::SeqCst) {
        return Err(Failure::Interrupted("calibration interrupted".into()));
    }
    result
}

fn drain_telemetry(events: &mut VecDeque<Event>) -> Vec<Telemetry> {
    events
        .drain(..)
        .filter_map(|e| match e {
            Event::Telemetry(t) => Some(t),
            _ => None,
        })
        .collect()
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

    #[test]
    fn the_ramps_peak_before_its_fall_is_the_snap() {
        // 0.22 kPa per sample up to 13.09, the snap's fall, the hold, then the vent.
        let mut s: Vec<(f64, bool, bool)> =
            (0..60).map(|i| (i as f64 * 0.22, true, false)).collect();
        s.push((12.79, true, false));
        s.push((9.64, false, false));
        s.push((12.2, false, false));
        s.push((12.1, false, false));
        s.push((8.0, false, true));
        let (snap, hold, _) = ramp_snap(&s);
        assert!((snap.unwrap() - 59.0 * 0.22).abs() < 1e-9);
        assert_eq!(hold, Some(12.1));
        let flat: Vec<_> = (0..60).map(|i| (i as f64 * 0.2, true, false)).collect();
        assert_eq!(ramp_snap(&flat).0, None);
        // At the cap: the inlet closes, the pressure settles and leaks: no snap.
        let mut cap = flat.clone();
        cap.extend((0..20).map(|i| (11.8 - 0.1 * i as f64, false, false)));
        cap.extend((0..3).map(|i| (10.0 + 0.5 * i as f64, true, false)));
        cap.extend((0..20).map(|i| (11.0 - 0.1 * i as f64, false, false)));
        assert_eq!(ramp_snap(&cap).0, None);
    }

    #[test]
    fn a_pulls_spike_gives_its_stroke() {
        let s = [
            (0.1, 0.0),
            (0.2, 2.0),
            (0.3, 4.0),
            (1.9, 6.0),
            (3.6, 6.0),
            (3.0, 4.0),
        ];
        assert_eq!(pull_spikes(&s), vec![6.0]);
        let flat = [(0.1, 0.0), (0.4, 2.0), (0.8, 4.0)];
        assert!(pull_spikes(&flat).is_empty());
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
            ],
        }
    }

    #[test]
    fn targets_add_the_margin_within_the_limits() {
        let p = profile();
        p.check().unwrap();
        let t = p.targets(40.0).unwrap();
        let get = |a: &str, b: &str| {
            t.iter()
                .find(|(e, _)| *e == (state(a), state(b)))
                .unwrap()
                .1
        };
        assert!((get("F&P", "F&F") - 15.1).abs() < 1e-4);
        assert!((get("D&P", "D&F") - 15.1).abs() < 1e-4);
        assert!((get("D&F", "D&D") - 34.6).abs() < 1e-4);
        assert!((get("D&D", "F&D") - 17.8).abs() < 1e-4);
        assert!((get("D&F", "F&F") - 69.0).abs() < 1e-4);
        // Capped by the limit; refused under the snap.
        assert!(
            (p.targets(32.0)
                .unwrap()
                .iter()
                .find(|(e, _)| *e == (state("D&F"), state("D&D")))
                .unwrap()
                .1
                - 32.0)
                .abs()
                < 1e-4
        );
        assert!(p
            .targets(30.0)
            .unwrap_err()
            .contains("under the measured snap at 30.10"));
        // The round trip through TOML.
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
