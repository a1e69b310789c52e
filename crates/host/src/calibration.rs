//! The calibration walk (docs/host.md, "Calibration"): the trunk measured through the
//! device, over any [`Io`] — a serial port (`host-tool calibrate --port`), the simulator
//! (`calibrate --sim`, and the swarm tester's calibration before each scenario).
//!
//! The walk is a cycle through the states ([`walk`]), started where the trunk is
//! ([`walk_at`]; from F&P when it is not on it). It takes each transition once, as a plan of
//! one step: an inflation ramps toward the device's pressure limit and its snap pressure is
//! the ramp's peak before its fall ([`ramp_snap`]); a pull goes toward the tendons' reach and
//! its stroke is the tendon length at the first buckling spike ([`pull_spikes`]); the bottom's
//! fold, which makes no spike, is searched by pulls of growing length let out sealed
//! ([`sealed_release`]). The sensor's zero is read at rest first. [`targets`] turns what was
//! measured into the thresholds plans use: the snap or stroke with a margin, capped by the
//! device's limits.
//!
//! What the caller adds is its own: the words it shows ([`Hooks::say`]), what it measures in
//! each state the walk reaches ([`Hooks::at_state`]: host-tool's probe signatures), how an
//! interruption is seen ([`Hooks::interrupted`]), and the profile file.

use std::collections::VecDeque;

use geometry::TrunkState;
use protocol::transitions::{self, Transition};
use protocol::{
    Event, Mode, ParamId, PlanPhase, Primitive, RequestBody, ResponseBody, Step, StepKind,
    Telemetry,
};
use transition_graph::{kind_name, CostModel, Graph};

use crate::driver::{Driver, Io, RunShell, ShellAction};
use crate::runner::{RunEvent, RunOptions};

/// The margin a calibrated plan adds to each measured threshold: an inflation toward
/// snap × (1 + 0.15), a pull to stroke × (1 + 0.15) (at least stroke + 3 mm).
pub const MARGIN: f64 = 0.15;
/// The least a pull's length exceeds its measured stroke, mm (a top that buckles after 10 mm
/// of pull would get 1.5 mm otherwise: under two telemetry samples of the servos' slew).
pub const MIN_TENDON_MARGIN_MM: f64 = 3.0;
/// The tendons' reach, mm: the longest pull the catalogue makes (the winches' travel).
pub const REACH_MM: f64 = transitions::PACK_BOTTOM_MM as f64;
/// The bottom's fold (F&D → F&F) is searched: pulls of growing length from F&D, each let out
/// sealed, until the trunk's volume stays smaller ([`sealed_release`]). The first pull, mm:
/// under the shortest fold of any trunk drawn within ±25 % of the calibrated one (75 mm, with
/// the tendons taut from ≈ 62 mm on the calibrated trunk).
pub const SEARCH_FROM_MM: f64 = 64.0;
/// Each pull of the search is this much longer than the one before, mm.
pub const SEARCH_STEP_MM: f64 = 5.0;
/// A searched fold's plans pull this much past the shortest pull that folded, mm: the search's
/// step and 3 mm more. Not the 15 % of a spike's stroke: a longer pull half-packs the bottom
/// on some trunks (23 mm past the fold on the closest of 300 trunks drawn within ±25 %, where
/// 15 % of a 140 mm fold is 21 mm).
pub const SEARCH_MARGIN_MM: f64 = SEARCH_STEP_MM + MIN_TENDON_MARGIN_MM;
/// A sealed release this close to the pressure before its pull left the trunk's volume as it
/// was, kPa: the sealed trunk's pressure is its volume (a fold of the bottom leaves ≥ 1.6 kPa
/// more on trunks drawn within ±25 %; a pull that moved nothing leaves 0.04 kPa).
pub const UNCHANGED_KPA: f64 = 0.5;
/// A sealed release is settled when its last five samples lie within this, kPa (the sensor's
/// noise is ≈ 0.05 kPa, the filtered reading’s less).
pub const STILL_KPA: f64 = 0.2;
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
/// The longest the vent before the sensor's zero may take, ms (a trunk at the 40 kPa limit
/// vents in under 3 s).
pub const ZERO_VENT_MS: u32 = 10_000;

/// What a calibration measures on each step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// The snap pressure of an inflation.
    Snap,
    /// The stroke of the top's buckling.
    Stroke,
    /// The shortest pull that folds the bottom, searched by sealed releases (its snap makes
    /// no spike under the pinning tendons).
    Search,
    /// Nothing the sensors can read: the step moves the trunk on.
    Pass,
}

fn state(name: &str) -> TrunkState {
    // The six names are the catalogue's: parsing them cannot fail.
    name.parse().unwrap_or(TrunkState::ALL[0])
}

/// The walk, in order; with `manual`, the fold by hand to D&P and the unpacking under a
/// deployed top from there.
pub fn walk(manual: bool) -> Vec<(TrunkState, TrunkState, Measure)> {
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
            ("F&D", "F&F", Measure::Search),
            ("F&F", "F&P", Measure::Pass),
        ])
        .map(|&(a, b, m)| (state(a), state(b), m))
        .collect()
}

/// [`walk`]'s cycle turned to start (and end) at `at`; `None` when `at` is not on it (D&P
/// without `manual`).
pub fn walk_at(manual: bool, at: TrunkState) -> Option<Vec<(TrunkState, TrunkState, Measure)>> {
    let w = walk(manual);
    let i = w.iter().position(|s| s.0 == at)?;
    Some(w[i..].iter().chain(&w[..i]).copied().collect())
}

/// Which measured edge each calibrated edge of the catalogue takes its threshold from: the
/// same barrier under the same force (the modules are in series, so D&P → D&F unpacks the
/// bottom at F&P → F&F's pressure, and F&D → D&D pops the top out at F&F → D&F's: measured
/// 19.55 against 19.53 kPa on the calibrated trunk, 21.45 against 21.49 at × 1.1). F&D → D&D
/// is not measured itself: over a deployed bottom the pop-out drops the pressure by ≈ 1 kPa at
/// × 1.1 and under 0.6 kPa at × 1.2 (the stiff deployed bottom barely lengthens), under what a
/// ramp can tell from its noise.
/// D&P → D&F takes its own snap when the walk measured it (`calibrate --manual`).
pub fn source_of(
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
        ("F&D", "F&F") => ("F&D", "F&F"),
        _ => return None,
    };
    Some((state(src.0), state(src.1)))
}

/// Whether `from` → `to` is measured by a search of sealed releases ([`Measure::Search`]).
pub fn searched(from: TrunkState, to: TrunkState) -> bool {
    walk(false)
        .iter()
        .any(|&(a, b, m)| (a, b) == (from, to) && m == Measure::Search)
}

/// Measured targets: `((from, to), value)`, kPa for a pneumatic edge, mm for a tendon edge.
pub type Targets = Vec<((TrunkState, TrunkState), f32)>;

/// One measured transition.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields)
)]
pub struct Measured {
    /// Start state.
    pub from: String,
    /// End state.
    pub to: String,
    /// `pneumatic` or `tendon`.
    pub kind: String,
    /// The pressure of each snap on the ramp, kPa (pneumatic steps).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Vec::is_empty")
    )]
    pub snap_kpa: Vec<f64>,
    /// The pressure the trunk settled to after its snap, before the vent, kPa.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub hold_kpa: Option<f64>,
    /// The commanded tendon length at each snap, mm (tendon steps).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Vec::is_empty")
    )]
    pub stroke_mm: Vec<f64>,
    /// Whether the device confirmed the step's target state from its sensors (it held when
    /// released); `false` when the person (or the simulated one) had to say the state.
    pub held: bool,
}

impl Measured {
    /// What was measured, in words.
    pub fn text(&self) -> String {
        let mut parts = Vec::new();
        if !self.snap_kpa.is_empty() {
            parts.push(format!("snap at {}", list(&self.snap_kpa, "kPa")));
        }
        if let Some(h) = self.hold_kpa {
            parts.push(format!("holds at {h:.2} kPa"));
        }
        if !self.stroke_mm.is_empty() {
            let v: Vec<String> = self
                .stroke_mm
                .iter()
                .map(|x| format!("{x:.1} mm"))
                .collect();
            parts.push(format!("buckles at {}", v.join(", ")));
        }
        if parts.is_empty() {
            parts.push("moved on (no snap the sensors can read)".into());
        }
        parts.push(if self.held { "held" } else { "not confirmed" }.into());
        parts.join(", ")
    }
}

fn list(v: &[f64], unit: &str) -> String {
    let v: Vec<String> = v.iter().map(|x| format!("{x:.2} {unit}")).collect();
    v.join(", ")
}

/// What a walk measured, and the limits it measured under.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// The margin plans add to each threshold ([`MARGIN`]).
    pub margin: f64,
    /// The device's pressure limit during the walk, kPa.
    pub pressure_limit_kpa: f64,
    /// The tendons' reach the pulls went toward, mm.
    pub tendon_reach_mm: f64,
    /// Each measured transition, in the walk's order.
    pub transitions: Vec<Measured>,
}

impl Calibration {
    /// Every measured transition `from` → `to` (the walk passes some twice, measuring once).
    fn each(&self, from: TrunkState, to: TrunkState) -> impl Iterator<Item = &Measured> {
        self.transitions
            .iter()
            .filter(move |m| m.from == from.name() && m.to == to.name())
    }

    /// The last snap of `from` → `to`, kPa.
    pub fn snap(&self, from: TrunkState, to: TrunkState) -> Option<f64> {
        self.each(from, to).find_map(|m| m.snap_kpa.last().copied())
    }

    /// The last stroke of `from` → `to`, mm.
    pub fn stroke(&self, from: TrunkState, to: TrunkState) -> Option<f64> {
        self.each(from, to)
            .find_map(|m| m.stroke_mm.last().copied())
    }

    /// Refuses a calibration whose snaps are missing, out of order or outside the physical
    /// range, naming what it holds.
    pub fn check(&self) -> Result<(), String> {
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
                Measure::Stroke | Measure::Search => self.stroke(from, to).is_some(),
                Measure::Pass => true,
            };
            if !found {
                return Err(format!(
                    "{from} → {to}: no {} measured",
                    match what {
                        Measure::Snap => "snap pressure",
                        Measure::Search => "fold stroke",
                        _ => "buckling stroke",
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
    /// snap × (1 + margin), capped by `limit_kpa`; each tendon step measured by its spike pulls
    /// to max(stroke × (1 + margin), stroke + 3 mm), the searched fold to stroke +
    /// [`SEARCH_MARGIN_MM`], within the reach. Refused when the cap is under a measured snap or
    /// the reach under a stroke.
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
                    let past = if searched(a, b) {
                        stroke + SEARCH_MARGIN_MM
                    } else {
                        (stroke * (1.0 + self.margin)).max(stroke + MIN_TENDON_MARGIN_MM)
                    };
                    past.min(self.tendon_reach_mm)
                }
                StepKind::Manual => continue,
            };
            // Rounded to 0.1 (the listing's precision).
            out.push(((t.from, t.to), ((value * 10.0).round() / 10.0) as f32));
        }
        Ok(out)
    }

    /// The calibrated graph under `limit_kpa` (the device's pressure limit, or the walk's).
    pub fn graph(&self, limit_kpa: f64) -> Result<Graph, String> {
        Ok(Graph::calibrated(&self.targets(limit_kpa)?))
    }
}

/// The peak of an inflation's ramp before its first fall of [`SNAP_FALL_KPA`], and the
/// pressure the trunk settled to after it before the exhaust opened; then the ramp's highest
/// pressure. `samples`: (pressure kPa, inlet open, exhaust open).
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
/// `samples`: (pressure kPa, tendon length mm).
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

/// What a pull's sealed release says about the trunk's volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Release {
    /// Let out sealed to where it started, the trunk came back to within [`UNCHANGED_KPA`]
    /// of the pressure before the pull and stayed there ([`STILL_KPA`]), no gas having left
    /// (no relief, and its pressure held while the pull held its length: no leak): it is
    /// where it was.
    Unchanged,
    /// Back to this much over the pressure before the pull, kPa: its volume changed (a fold
    /// leaves it smaller), or gas left through the relief valve, or the release was not seen.
    Changed(f64),
}

/// The sealed release of one pull, from its samples (pressure kPa, tendon length mm, exhaust
/// open): the pressure before the tendons moved against the last one after they came back,
/// before the exhaust opened again to vent. A relief while pulled (gas out: the pressure no
/// longer tells the volume), a pressure falling while the pull held its length or after the
/// release (a leak), or no sample back at the start is never [`Release::Unchanged`].
pub fn sealed_release(samples: &[(f64, f64, bool)]) -> Release {
    let moved = |s: &(f64, f64, bool)| s.1 > 0.5;
    let Some(first_pulled) = samples.iter().position(moved) else {
        return Release::Changed(f64::NAN);
    };
    // The first sample may be the pull's first: its tendons still slack (5 mm in 0.1 s).
    let Some(before) = samples[..first_pulled]
        .last()
        .or(samples.first().filter(|s| s.1 < 5.0))
        .map(|s| s.0)
    else {
        return Release::Changed(f64::NAN);
    };
    let last_pulled = samples.iter().rposition(moved).unwrap_or(first_pulled);
    let pulled = &samples[first_pulled..=last_pulled];
    let relieved = pulled.iter().any(|s| s.2);
    // Held at its length, the pinned, sealed trunk keeps its pressure; one that loses it leaks
    // (the simulated leak: 3.05 → 0.47 kPa in 0.3 s at 104 mm, where a sound trunk holds 7.0
    // within 0.1), and a leak lets a fold's rise out before the release could show it.
    let longest = pulled.iter().fold(0.0f64, |a, s| a.max(s.1));
    let at_length: Vec<f64> = pulled
        .iter()
        .filter(|s| s.1 >= longest - 0.5)
        .map(|s| s.0)
        .collect();
    let held = at_length
        .first()
        .is_some_and(|&p0| p0 - lowest(&at_length) <= STILL_KPA);
    let back: Vec<f64> = samples[last_pulled + 1..]
        .iter()
        .take_while(|s| !s.2)
        .map(|s| s.0)
        .collect();
    // Settled: its last samples (100 ms) within the sensor's noise; a trunk still losing
    // air (a leak that could hide a fold's rise) is no evidence.
    let tail = &back[back.len().saturating_sub(5)..];
    let highest = tail.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    let still = tail.len() >= 3 && highest - lowest(tail) <= STILL_KPA;
    match back.last() {
        Some(&a) if !relieved && held && still && (a - before).abs() <= UNCHANGED_KPA => {
            Release::Unchanged
        }
        Some(&a) => Release::Changed(a - before),
        None => Release::Changed(f64::NAN),
    }
}

fn lowest(v: &[f64]) -> f64 {
    v.iter().fold(f64::INFINITY, |a, &b| a.min(b))
}

/// The walk's one-step transition for `t`: toward the pressure limit with one snap, or toward
/// the reach with the step's snaps.
pub fn probe_transition(t: &Transition, limit_kpa: f32, what: Measure) -> Transition {
    match what {
        Measure::Snap => transition_graph::retarget(t, limit_kpa),
        Measure::Stroke => transition_graph::retarget(t, REACH_MM as f32),
        Measure::Pass | Measure::Search => *t,
    }
}

/// The mean commanded tendon length of the three servos at `deg`, mm.
pub fn tendon_mm(cfg: &protocol::WinchConfig, deg: &[f32; 3]) -> f64 {
    (0..3)
        .map(|i| f64::from(cfg.length_for_angle(i, deg[i])))
        .sum::<f64>()
        / 3.0
}

fn round(x: f64, per: f64) -> f64 {
    (x * per).round() / per
}

/// Why a walk ended without a calibration.
#[derive(Debug, Clone, PartialEq)]
pub enum WalkError<E> {
    /// What the trunk did is not a calibration; the text says what was seen.
    Refused(String),
    /// [`Hooks::interrupted`] said so.
    Interrupted,
    /// The device did not answer as a device does.
    Device(String),
    /// The caller's [`Hooks::at_state`] failed.
    Hook(E),
}

impl<E: std::fmt::Display> std::fmt::Display for WalkError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Refused(m) => write!(f, "calibration refused: {m}"),
            Self::Interrupted => f.write_str("calibration interrupted"),
            Self::Device(m) => f.write_str(m),
            Self::Hook(e) => e.fmt(f),
        }
    }
}

/// What the caller adds to a walk.
pub trait Hooks<I: Io> {
    /// The error of [`Hooks::at_state`].
    type Error;
    /// A line of progress.
    fn say(&mut self, _line: &str) {}
    /// Whether the person asked to stop (checked before each step).
    fn interrupted(&self) -> bool {
        false
    }
    /// The walk reached `at` (confirmed): the caller's own measurements there.
    fn at_state(&mut self, _d: &mut Driver<I>, _at: TrunkState) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Hooks that add nothing.
#[derive(Debug, Default, Clone, Copy)]
pub struct Quiet;

impl<I: Io> Hooks<I> for Quiet {
    type Error = std::convert::Infallible;
}

/// What [`run`] measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Walked {
    /// The thresholds.
    pub calibration: Calibration,
    /// The sensor's reading at rest, vented, kPa (to 0.001).
    pub sensor_zero_kpa: f64,
    /// The walk's duration on the I/O's clock, ms.
    pub duration_ms: u64,
}

/// The caller's shell, and the telemetry samples of the step.
struct Sampling<'a, I> {
    inner: &'a mut dyn RunShell<I>,
    samples: Vec<Telemetry>,
}

impl<I> RunShell<I> for Sampling<'_, I> {
    fn event(&mut self, event: &RunEvent, io: &mut I) {
        self.inner.event(event, io);
    }
    fn poll(&mut self, io: &mut I) -> Option<ShellAction> {
        self.inner.poll(io)
    }
    fn device_event(&mut self, event: &Event, io: &mut I) {
        if let Event::Telemetry(t) = event {
            self.samples.push(*t);
        }
        self.inner.device_event(event, io);
    }
}

/// Sets the device's telemetry rate to `hz`; the rate before, when it could be read and set.
pub fn set_telemetry_rate<I: Io>(d: &mut Driver<I>, hz: u32) -> Option<f32> {
    let previous = match d.command(RequestBody::GetParam(ParamId::TelemetryHz)) {
        Ok(ResponseBody::Param { value, .. }) => value,
        _ => return None,
    };
    d.command(RequestBody::SetParam {
        id: ParamId::TelemetryHz,
        value: hz as f32,
    })
    .ok()?;
    Some(previous)
}

/// Walks the calibration on the open session `d` (the trunk taken to F&P first), with
/// `shell` answering the runs' prompts; the device's telemetry rate is [`TELEMETRY_HZ`]
/// during the walk and as it was after.
pub fn run<I: Io, H: Hooks<I>>(
    d: &mut Driver<I>,
    shell: &mut dyn RunShell<I>,
    manual: bool,
    hooks: &mut H,
) -> Result<Walked, WalkError<H::Error>> {
    let limit_kpa = match d.command(RequestBody::GetParam(ParamId::PressureLimitKpa)) {
        Ok(ResponseBody::Param { value, .. }) => value,
        other => {
            return Err(WalkError::Device(format!(
                "reading the device's pressure limit: {other:?}"
            )))
        }
    };
    let previous_rate = set_telemetry_rate(d, TELEMETRY_HZ);
    let result = walk_from(d, shell, manual, limit_kpa, hooks);
    if let Some(value) = previous_rate {
        let _ = d.command(RequestBody::SetParam {
            id: ParamId::TelemetryHz,
            value,
        });
    }
    result
}

fn walk_from<I: Io, H: Hooks<I>>(
    d: &mut Driver<I>,
    shell: &mut dyn RunShell<I>,
    manual: bool,
    limit_kpa: f32,
    hooks: &mut H,
) -> Result<Walked, WalkError<H::Error>> {
    let start_ms = d.io.now_ms();
    let mut shell = Sampling {
        inner: shell,
        samples: Vec::new(),
    };
    let st = d
        .status()
        .map_err(|e| WalkError::Device(format!("reading the device's state: {e}")))?;
    // The walk is a cycle: it starts where the trunk is, when that is on it, so the bottom's
    // fold is searched before the pack needs it (a plan to F&P first folds it at the
    // catalogue's length, which half-packs or misses the fold on trunks unlike the
    // simulator's).
    let on_cycle = Some(st.state)
        .filter(|_| st.state_confirmed)
        .and_then(|s| walk_at(manual, s).map(|w| (s, w)));
    let (first, steps) = match on_cycle {
        Some(start) => start,
        None => {
            let first = state("F&P");
            hooks.say(&format!(
                "calibrate: the trunk is at {}{}: taking it to F&P first",
                st.state,
                if st.state_confirmed {
                    ""
                } else {
                    " (unconfirmed)"
                }
            ));
            let out = d.run_plan(Graph::nominal(), first, RunOptions::default(), &mut shell);
            if !out.ok() {
                return Err(WalkError::Refused(format!(
                    "could not start from F&P: {}",
                    out.error().unwrap_or("not reached")
                )));
            }
            (first, walk(manual))
        }
    };
    // The sensor's zero: the trunk vented within its state to the device's tolerance (the air
    // a plan leaves sealed in it is let out), then one second of telemetry at rest. A
    // vent that cannot end is a sensor reading over the tolerance at ambient: its exhaust
    // stays open on the air, and the reading then is the zero.
    let interrupted = || hooks.interrupted();
    let vent = [Primitive::Vent { pressure_kpa: 0.0 }];
    let vented = match run_within(d, first, &vent, ZERO_VENT_MS, &interrupted) {
        Ok(_) => None,
        Err(WithinError::Interrupted) => return Err(WalkError::Interrupted),
        Err(WithinError::Link(e)) => {
            return Err(WalkError::Device(format!("venting the trunk at rest: {e}")))
        }
        Err(WithinError::Failed { why, samples }) => Some((why, samples)),
    };
    let rest: Vec<f64> = match &vented {
        None => {
            d.device_events.clear();
            d.idle(1000)
                .map_err(|e| WalkError::Device(format!("reading the sensor at rest: {e}")))?;
            drain_telemetry(&mut d.device_events)
                .iter()
                .map(|t| f64::from(t.pressure_kpa))
                .collect()
        }
        // The vent's last second, its exhaust open.
        Some((_, samples)) => {
            let end = samples.last().map_or(0, |t| t.uptime_ms);
            samples
                .iter()
                .filter(|t| t.exhaust_open && end.saturating_sub(t.uptime_ms) < 1000)
                .map(|t| f64::from(t.pressure_kpa))
                .collect()
        }
    };
    if rest.is_empty() {
        return Err(WalkError::Refused(format!(
            "no telemetry at rest: the device sends none at {TELEMETRY_HZ} Hz{}",
            vented
                .as_ref()
                .map(|(why, _)| format!("; the vent: {why}"))
                .unwrap_or_default()
        )));
    }
    let zero = rest.iter().sum::<f64>() / rest.len() as f64;
    hooks.say(&format!(
        "calibrate: sensor zero {zero:+.2} kPa at rest ({} samples)",
        rest.len()
    ));
    if let Some((why, _)) = vented {
        if zero > MAX_ZERO_KPA {
            return Err(WalkError::Refused(format!(
                "the pressure sensor reads {zero:+.2} kPa at rest, vented: over the device's \
                 {MAX_ZERO_KPA} kPa vent tolerance, no inflation can start from the air; \
                 correct the sensor's offset (its calibration in the firmware's configuration)"
            )));
        }
        return Err(WalkError::Refused(format!(
            "the trunk could not be vented at {first}: {why}"
        )));
    }
    let servo = protocol::CraneGeometry::default().winch;
    let mut measured: Vec<Measured> = Vec::new();
    hooks.at_state(d, first).map_err(WalkError::Hook)?;
    for (k, (from, to, what)) in steps.iter().copied().enumerate() {
        if hooks.interrupted() {
            return Err(WalkError::Interrupted);
        }
        let Some(t) = transitions::transition(from, to) else {
            return Err(WalkError::Refused(format!(
                "{from} → {to} is not in the catalogue"
            )));
        };
        let t = probe_transition(t, limit_kpa, what);
        let (n, total) = (k + 1, steps.len());
        hooks.say(&format!(
            "calibrate {n}/{total}: {from} → {to} by {}{}",
            match t.kind {
                StepKind::Tendon => "the tendons",
                StepKind::Pneumatic => "pressure",
                StepKind::Manual => "hand (the person folds it when prompted)",
            },
            match what {
                Measure::Snap => format!(", a ramp toward {limit_kpa} kPa"),
                Measure::Stroke => format!(", a pull toward {REACH_MM} mm"),
                Measure::Search => format!(
                    ", pulls from {SEARCH_FROM_MM} mm, {SEARCH_STEP_MM} mm longer each, each \
                     let out sealed until the bottom stays folded"
                ),
                Measure::Pass => String::new(),
            }
        ));
        let record = |held: bool| Measured {
            from: from.name().into(),
            to: to.name().into(),
            kind: kind_name(t.kind).into(),
            snap_kpa: Vec::new(),
            hold_kpa: None,
            stroke_mm: Vec::new(),
            held,
        };
        if what == Measure::Search {
            let found = search(d, &mut shell, &t, hooks, (n, total))?;
            let m = Measured {
                stroke_mm: vec![round(found.length, 10.0)],
                ..record(found.held)
            };
            if found.at != Some(to) {
                let why = match found.at {
                    Some(at) if at == from => format!(
                        "the bottom did not stay folded after any pull up to {:.1} mm",
                        found.length
                    ),
                    Some(at) => {
                        format!("the pull to {:.1} mm left the trunk at {at}", found.length)
                    }
                    None => format!(
                        "after the pull to {:.1} mm the trunk's state is not known",
                        found.length
                    ),
                };
                return Err(WalkError::Refused(format!(
                    "{from} → {to}: {why} (measured so far: {})",
                    so_far(&measured)
                )));
            }
            measured.push(m);
            hooks.at_state(d, to).map_err(WalkError::Hook)?;
            continue;
        }
        let graph = Graph::from_transitions(vec![t], CostModel::default());
        shell.samples.clear();
        let out = d.run_plan(graph, to, RunOptions::default(), &mut shell);
        let samples = std::mem::take(&mut shell.samples);
        let mut m = record(out.steps.first().is_some_and(|r| r.ok));
        let step_error = || {
            out.error()
                .map(|e| format!("; the step: {e}"))
                .unwrap_or_default()
        };
        match what {
            Measure::Snap => {
                let ramp: Vec<(f64, bool, bool)> = samples
                    .iter()
                    .map(|t| (f64::from(t.pressure_kpa), t.inlet_open, t.exhaust_open))
                    .collect();
                let (snap, hold, max) = ramp_snap(&ramp);
                let Some(snap) = snap else {
                    return Err(WalkError::Refused(format!(
                        "{from} → {to}: no snap seen on the ramp (the pressure rose to \
                         {max:.2} kPa; the limit is {limit_kpa} kPa){}",
                        step_error()
                    )));
                };
                m.snap_kpa.push(round(snap, 100.0));
                m.hold_kpa = hold.map(|h| round(h, 100.0));
                hooks.say(&format!(
                    "calibrate {}/{}: snap at {snap:.2} kPa{}",
                    k + 1,
                    steps.len(),
                    hold.map(|h| format!(", holds at {h:.2} kPa"))
                        .unwrap_or_default()
                ));
            }
            Measure::Stroke => {
                let pull: Vec<(f64, f64)> = samples
                    .iter()
                    .map(|t| (f64::from(t.pressure_kpa), tendon_mm(&servo, &t.servo_deg)))
                    .collect();
                let spikes = pull_spikes(&pull);
                let longest = pull.iter().map(|p| p.1).fold(0.0, f64::max);
                let Some(&stroke) = spikes.first() else {
                    return Err(WalkError::Refused(format!(
                        "{from} → {to}: no buckling seen (the tendons pulled {longest:.1} \
                         mm){}",
                        step_error()
                    )));
                };
                m.stroke_mm = spikes.iter().map(|&x| round(x, 10.0)).collect();
                hooks.say(&format!(
                    "calibrate {}/{}: buckles at {stroke:.1} mm of pull",
                    k + 1,
                    steps.len()
                ));
            }
            Measure::Pass | Measure::Search => {}
        }
        if !out.ok() {
            measured.push(m);
            return Err(WalkError::Refused(format!(
                "{from} → {to}: {} (measured so far: {})",
                out.error().unwrap_or("the step did not reach its target"),
                so_far(&measured)
            )));
        }
        measured.push(m);
        hooks.at_state(d, to).map_err(WalkError::Hook)?;
    }
    let calibration = Calibration {
        margin: MARGIN,
        pressure_limit_kpa: f64::from(limit_kpa),
        tendon_reach_mm: REACH_MM,
        transitions: measured,
    };
    calibration.check().map_err(WalkError::Refused)?;
    calibration
        .targets(calibration.pressure_limit_kpa)
        .map_err(WalkError::Refused)?;
    Ok(Walked {
        calibration,
        sensor_zero_kpa: (zero * 1000.0).round() / 1000.0,
        duration_ms: d.io.now_ms() - start_ms,
    })
}

/// What a walk measured so far, in words.
fn so_far(measured: &[Measured]) -> String {
    if measured.is_empty() {
        return "nothing yet".into();
    }
    measured
        .iter()
        .map(|m| format!("{} → {}: {}", m.from, m.to, m.text()))
        .collect::<Vec<_>>()
        .join("; ")
}

/// Where a [`search`] ended.
struct Searched {
    /// The last pull's length, mm: the fold's stroke when `at` is the step's target.
    length: f64,
    /// The state confirmed after it (`None`: not known).
    at: Option<TrunkState>,
    /// The device confirmed it from its own sensors.
    held: bool,
}

/// The search of [`Measure::Search`]: the step of `t` on its own at growing lengths from
/// [`SEARCH_FROM_MM`], each pull let out sealed by the device's own check, which cannot confirm
/// a fold it sees no spike of. After each, a release that left the volume as it was
/// ([`sealed_release`]) declares the start state, the evidence being the host's; any other is
/// identified by the person (the simulated one under the simulator). The search ends at the
/// first pull that reached `t.to`, with its length; without one at the reach, or at a state
/// that is neither (the outcome says which).
fn search<I: Io, H: Hooks<I>>(
    d: &mut Driver<I>,
    shell: &mut Sampling<'_, I>,
    t: &Transition,
    hooks: &mut H,
    (n, total): (usize, usize),
) -> Result<Searched, WalkError<H::Error>> {
    let servo = protocol::CraneGeometry::default().winch;
    let device = |e: String| WalkError::Device(format!("{} → {}: {e}", t.from, t.to));
    let mut length = SEARCH_FROM_MM;
    loop {
        let pull = transition_graph::retarget(t, length as f32);
        let step = Step {
            kind: t.kind,
            from: t.from,
            to: t.to,
            primitives: pull.primitives.iter().copied().collect(),
            timeout_ms: t.timeout_ms,
        };
        let interrupted = || hooks.interrupted();
        let samples = match run_step(d, step, &interrupted) {
            Ok((samples, _)) => samples,
            Err(WithinError::Interrupted) => return Err(WalkError::Interrupted),
            Err(WithinError::Link(e)) => return Err(device(e)),
            Err(WithinError::Failed { samples, .. }) => samples,
        };
        let st = d.status().map_err(|e| device(e.to_string()))?;
        let held = st.state_confirmed;
        let mut at = Some(st.state).filter(|_| held);
        let mut declared = false;
        if !held {
            let pulled: Vec<(f64, f64, bool)> = samples
                .iter()
                .map(|s| {
                    let mm = tendon_mm(&servo, &s.servo_deg);
                    (f64::from(s.pressure_kpa), mm, s.exhaust_open)
                })
                .collect();
            if sealed_release(&pulled) == Release::Unchanged && st.candidates.contains(t.from) {
                d.command(RequestBody::ResetFaults)
                    .and_then(|_| d.command(RequestBody::DeclareState(t.from)))
                    .map_err(|e| device(format!("declaring {} after the pull: {e}", t.from)))?;
                at = Some(t.from);
                declared = true;
            } else {
                let known = RunOptions {
                    identify_only: true,
                    ..RunOptions::default()
                };
                let who = d.run_plan(Graph::nominal(), t.to, known, shell);
                at = who.final_state.filter(|_| who.state_confirmed);
            }
        }
        let next = length + SEARCH_STEP_MM;
        if at != Some(t.from) || next > REACH_MM {
            if at == Some(t.to) {
                hooks.say(&format!(
                    "calibrate {n}/{total}: folds at {length:.1} mm of pull"
                ));
            }
            return Ok(Searched { length, at, held });
        }
        hooks.say(&format!(
            "calibrate {n}/{total}: {length:.1} mm: {}",
            if declared {
                "the sealed trunk came back as it was, not folded"
            } else {
                "not folded (identified: the sealed release could not tell)"
            }
        ));
        length = next;
    }
}

/// Why a step within a state ([`run_within`]) gave no reading.
#[derive(Debug, Clone, PartialEq)]
pub enum WithinError {
    /// The person asked to stop: the step was aborted (the device is in its safe state).
    Interrupted,
    /// The link failed under it; the text says how.
    Link(String),
    /// The device refused or stopped the step, or its end was not heard; the telemetry
    /// during it.
    Failed {
        /// What happened.
        why: String,
        /// The telemetry the step sent.
        samples: Vec<Telemetry>,
    },
}

/// Runs one step of `prims` within `state` ([`run_step`]).
pub fn run_within<I: Io>(
    d: &mut Driver<I>,
    state: TrunkState,
    prims: &[Primitive],
    timeout_ms: u32,
    interrupted: &dyn Fn() -> bool,
) -> Result<(Vec<Telemetry>, u32), WithinError> {
    let step = Step {
        kind: StepKind::Pneumatic,
        from: state,
        to: state,
        primitives: prims.iter().copied().collect(),
        timeout_ms,
    };
    run_step(d, step, interrupted)
}

/// Runs `step` on its own (plan id 0) and waits for its end on the device's clock, up to its
/// time limit and 2 s more: the telemetry during it and the step's duration from its
/// `StepDone`.
pub fn run_step<I: Io>(
    d: &mut Driver<I>,
    step: Step,
    interrupted: &dyn Fn() -> bool,
) -> Result<(Vec<Telemetry>, u32), WithinError> {
    let timeout_ms = step.timeout_ms;
    d.device_events.clear();
    d.command(RequestBody::RunStep(step))
        .map_err(|e| WithinError::Failed {
            why: format!("the device refused its step: {e}"),
            samples: Vec::new(),
        })?;
    let start = d.io.now_ms();
    let mut samples = Vec::new();
    let mut done: Option<(bool, u32)> = None;
    loop {
        if interrupted() {
            let _ = d.command(RequestBody::Abort);
            return Err(WithinError::Interrupted);
        }
        d.idle(20).map_err(|e| WithinError::Link(e.to_string()))?;
        for ev in d.device_events.drain(..) {
            match ev {
                Event::Telemetry(t) => samples.push(t),
                Event::StepDone {
                    plan_id: 0,
                    ok,
                    duration_ms,
                    ..
                } => done = Some((ok, duration_ms)),
                _ => {}
            }
        }
        if done.is_some() || d.io.now_ms() > start + u64::from(timeout_ms) + 2_000 {
            break;
        }
    }
    let st = d
        .status()
        .map_err(|e| WithinError::Link(format!("reading the status: {e}")))?;
    let phase = st.plan.filter(|p| p.plan_id == 0).map(|p| p.phase);
    let why = match (done, phase, st.mode) {
        (_, _, Mode::Running | Mode::WaitingManual) => {
            let _ = d.command(RequestBody::Abort);
            format!("its step did not end within {} s", timeout_ms / 1000)
        }
        (Some((true, ms)), Some(PlanPhase::Done), _) => return Ok((samples, ms)),
        (None, Some(PlanPhase::Done), _) => {
            "the step's end was not heard (its duration is the reading): calibrate again".into()
        }
        (_, Some(PlanPhase::Failed(code)), _) => {
            format!("the device stopped its step: {}", crate::text::fault(code))
        }
        (_, other, _) => format!("its step ended in phase {other:?}"),
    };
    Err(WithinError::Failed { why, samples })
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

    fn measured(from: &str, to: &str, snap: Option<f64>, stroke: Option<f64>) -> Measured {
        Measured {
            from: from.into(),
            to: to.into(),
            kind: if stroke.is_some() {
                "tendon"
            } else {
                "pneumatic"
            }
            .into(),
            snap_kpa: snap.into_iter().collect(),
            hold_kpa: None,
            stroke_mm: stroke.into_iter().collect(),
            held: true,
        }
    }

    fn calibration() -> Calibration {
        Calibration {
            margin: 0.15,
            pressure_limit_kpa: 40.0,
            tendon_reach_mm: REACH_MM,
            transitions: vec![
                measured("F&P", "F&F", Some(10.0), None),
                measured("F&F", "D&F", Some(20.0), None),
                measured("D&F", "F&F", None, Some(12.0)),
                measured("D&F", "D&D", Some(30.0), None),
                measured("D&D", "F&D", None, Some(14.0)),
                measured("F&D", "F&F", None, Some(104.0)),
            ],
        }
    }

    #[test]
    fn targets_add_the_margin_within_the_limits() {
        let c = calibration();
        c.check().unwrap();
        let t = c.targets(40.0).unwrap();
        let get = |a: &str, b: &str| {
            t.iter()
                .find(|((f, to), _)| f.name() == a && to.name() == b)
                .map(|x| x.1)
        };
        assert_eq!(get("F&P", "F&F"), Some(11.5));
        // D&P → D&F takes F&P → F&F's snap; F&D → D&D takes F&F → D&F's.
        assert_eq!(get("D&P", "D&F"), Some(11.5));
        assert_eq!(get("F&D", "D&D"), Some(23.0));
        // 30 × 1.15 = 34.5 under the 40 kPa cap; capped at 33 under a 33 kPa one.
        assert_eq!(get("D&F", "D&D"), Some(34.5));
        let capped = c.targets(33.0).unwrap();
        assert!(capped.contains(&((state("D&F"), state("D&D")), 33.0)));
        // 12 × 1.15 = 13.8 over 12 + 3 = 15: the 3 mm floor wins.
        assert_eq!(get("D&F", "F&F"), Some(15.0));
        // The searched fold: its shortest holding pull and 8 mm (not 15 %: 119.6 mm).
        assert_eq!(get("F&D", "F&F"), Some(112.0));
        // A walk that passed F&F → D&F first without measuring it still finds its snap.
        let mut twice = c.clone();
        twice
            .transitions
            .insert(0, measured("F&F", "D&F", None, None));
        assert_eq!(twice.targets(40.0).unwrap(), t);
        // A cap under a snap is refused, naming it.
        let e = c.targets(25.0).unwrap_err();
        assert!(e.contains("D&F → D&D") && e.contains("30.00"), "{e}");
    }

    #[test]
    fn a_calibration_out_of_order_or_incomplete_is_refused() {
        let mut c = calibration();
        c.transitions[1].snap_kpa = vec![9.0];
        let e = c.check().unwrap_err();
        assert!(e.contains("out of order") && e.contains("9.00"), "{e}");
        let mut c = calibration();
        c.transitions.remove(2);
        assert_eq!(
            c.check().unwrap_err(),
            "D&F → F&F: no buckling stroke measured"
        );
        let mut c = calibration();
        c.transitions.pop();
        assert_eq!(c.check().unwrap_err(), "F&D → F&F: no fold stroke measured");
        let mut c = calibration();
        c.transitions[0].snap_kpa = vec![0.5];
        assert!(c.check().unwrap_err().contains("physical range"));
    }

    #[test]
    fn the_walk_is_a_cycle_turned_to_start_where_the_trunk_is() {
        for manual in [false, true] {
            let w = walk(manual);
            assert_eq!(w[0].0, state("F&P"));
            for s in TrunkState::ALL {
                let Some(turned) = walk_at(manual, s) else {
                    // Only D&P is off the cycle, and only without the fold by hand.
                    assert!(!manual && s == state("D&P"), "{s}");
                    continue;
                };
                assert_eq!(turned.len(), w.len());
                assert_eq!(turned[0].0, s);
                assert_eq!(turned.last().unwrap().1, s, "{s}: ends where it began");
                // Each step starts where the one before ended.
                assert!(turned.windows(2).all(|p| p[0].1 == p[1].0), "{s}");
                // The same steps, in the same cyclic order.
                let mut sorted = turned.clone();
                let mut all = w.clone();
                let key = |x: &(TrunkState, TrunkState, Measure)| {
                    (x.0.index(), x.1.index(), format!("{:?}", x.2))
                };
                sorted.sort_by_key(key);
                all.sort_by_key(key);
                assert_eq!(sorted, all);
            }
        }
        // From D&D the bottom's fold is searched before the pack needs it.
        let d = walk_at(false, state("D&D")).unwrap();
        let fold = d.iter().position(|x| x.2 == Measure::Search).unwrap();
        let pack = d
            .iter()
            .position(|x| (x.0, x.1) == (state("F&F"), state("F&P")))
            .unwrap();
        assert!(fold < pack);
    }

    #[test]
    fn a_sealed_release_back_at_its_pressure_left_the_trunk_as_it_was() {
        // (pressure, tendon mm, exhaust open): at rest, the pull compressing the sealed trunk,
        // the release, at rest again, then the vent.
        let pull = |after: f64, relief: bool| -> Vec<(f64, f64, bool)> {
            let mut v = vec![(1.04, 0.0, false); 3];
            v.extend((1..=10).map(|i| (1.04 + 0.5 * i as f64, 10.0 * i as f64, relief && i > 8)));
            v.extend(
                (0..10)
                    .rev()
                    .map(|i| (after + 0.3 * i as f64, 10.0 * i as f64, false)),
            );
            v.extend([(after, 0.0, false), (after, 0.0, false), (0.2, 0.0, true)]);
            v
        };
        assert_eq!(sealed_release(&pull(1.30, false)), Release::Unchanged);
        assert_eq!(sealed_release(&pull(0.60, false)), Release::Unchanged);
        // A fold leaves the volume smaller: ≥ 1.6 kPa more on trunks within ±25 %.
        let Release::Changed(rise) = sealed_release(&pull(2.70, false)) else {
            panic!("a fold is a change");
        };
        assert!((rise - 1.66).abs() < 1e-9, "{rise}");
        // Still falling at the end (a leak): no evidence, though back near the start.
        let mut leaking = pull(1.30, false);
        let vent = leaking.len() - 1;
        leaking.splice(
            vent..vent,
            (1..=5).map(|k| (1.30 - 0.1 * k as f64, 0.0, false)),
        );
        assert!(matches!(sealed_release(&leaking), Release::Changed(_)));
        // Losing pressure while held at its length (a leak), back at the start all the same.
        let mut held_leaking = pull(1.04, false);
        held_leaking.splice(13..13, [(5.0, 100.0, false), (4.0, 100.0, false)]);
        assert!(matches!(sealed_release(&held_leaking), Release::Changed(_)));
        // Gas let out by the relief: the pressure no longer tells the volume.
        assert!(matches!(
            sealed_release(&pull(1.04, true)),
            Release::Changed(_)
        ));
        // The release not seen (the samples end pulled), or no pull at all.
        let cut = &pull(1.04, false)[..8];
        assert!(matches!(sealed_release(cut), Release::Changed(_)));
        assert!(matches!(
            sealed_release(&[(1.0, 0.0, false); 5]),
            Release::Changed(_)
        ));
        // The samples begin with the pull under way, its tendons still slack: its first is
        // the pressure before.
        let mut late = vec![(1.04, 2.0, false)];
        late.extend_from_slice(&pull(1.04, false)[3..]);
        assert_eq!(sealed_release(&late), Release::Unchanged);
        // Not when its first is already pulled taut.
        assert!(matches!(
            sealed_release(&pull(1.04, false)[3..]),
            Release::Changed(_)
        ));
    }
}
