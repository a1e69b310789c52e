//! Mission files (`host-tool run MISSION.toml`): a TOML sequence of steps, each one thing to
//! do — go to a state, bend, grip, reach, vent, wait, aim, identify, a prompt to a person —
//! with an optional time limit and what to do when it fails. [`parse`] reads a file into
//! [`Mission`] and [`check`] validates it whole against the crane before anything moves:
//! every refusal carries the line of the file it is about (toml's spans) and the reason, in
//! the words and ranges the commands of the same names use. The format: docs/host.md,
//! "Missions".

use std::collections::BTreeMap;
use std::str::FromStr;

use chrono::{DateTime, Utc};
use geometry::orient::Heading;
use geometry::TrunkState;
use planner::graph::Graph;
use planner::sun;
use serde::Deserialize;
use toml::Spanned;

use crate::cmd::prim::bend_step;
use crate::cmd::reach::plan_reach;

/// The kinds of step, in the order the docs list them.
pub const KINDS: [&str; 9] = [
    "state", "bend", "grip", "reach", "vent", "wait", "aim", "identify", "prompt",
];
/// The keys every step may carry beside its kind.
pub const COMMON: [&str; 3] = ["time_limit", "on_failure", "name"];

/// What a step does.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// Go to a trunk state (the planner's cheapest plan).
    State(TrunkState),
    /// Bend the tip `angle` degrees toward `toward` (0 straightens).
    Bend {
        /// The tip angle, degrees (≥ 0).
        angle: f64,
        /// The direction, degrees from tendon 0, counter-clockwise seen from above.
        toward: f64,
    },
    /// Close (`true`) or open the gripper.
    Grip(bool),
    /// Put the tip at a point (mm, base frame) within `tolerance` mm.
    Reach {
        /// X, Y, Z, mm.
        point: [f64; 3],
        /// mm, > 0.
        tolerance: f64,
    },
    /// Let the air out, the trunk keeping its state.
    Vent,
    /// Let time pass, ms.
    Wait(u64),
    /// Point the tip axis (a panel) at a direction or the sun.
    Aim(Aim),
    /// Have the device identify an unconfirmed state.
    Identify,
    /// Ask the person at the crane to do something and wait for Enter.
    Prompt {
        /// What to do.
        text: String,
        /// What the simulator's person hangs on the tip, kg (`--sim` only; a person at a
        /// crane is asked by `text`).
        tip_load_kg: Option<f64>,
    },
}

/// Where an aim step points.
#[derive(Debug, Clone, PartialEq)]
pub struct Aim {
    /// A compass direction, or the sun.
    pub target: AimTarget,
    /// The compass heading of the base's x axis.
    pub heading: Heading,
    /// Go first to the state that aims closest.
    pub change_state: bool,
}

/// The direction of an aim step.
#[derive(Debug, Clone, PartialEq)]
pub enum AimTarget {
    /// Compass azimuth and elevation, degrees.
    Toward(f64, f64),
    /// The sun from a site, at an instant (`None`: when the step runs).
    Sun {
        /// Latitude, longitude, degrees.
        lat_lon: (f64, f64),
        /// The instant.
        time: Option<DateTime<Utc>>,
    },
}

/// What a failed step does to the mission.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnFailure {
    /// Stop the mission and make the crane safe (the default).
    Stop,
    /// Go on with the next step.
    Skip,
}

/// One step of a mission.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// Its place in the mission, from 1.
    pub number: usize,
    /// The line of the file its kind's key is on (`bend = …`).
    pub line: usize,
    /// What it does.
    pub action: Action,
    /// The most it may take on the link's clock, ms.
    pub time_limit_ms: Option<u64>,
    /// What a failure does.
    pub on_failure: OnFailure,
    /// A label for the progress lines.
    pub name: Option<String>,
}

/// A parsed mission.
#[derive(Debug, Clone, PartialEq)]
pub struct Mission {
    /// Its `name`, if it has one.
    pub name: Option<String>,
    /// Its `description`, if it has one.
    pub description: Option<String>,
    /// The steps that parsed, in order (all of them when `refusals` is empty).
    pub steps: Vec<Step>,
    /// The problems of the steps that did not parse, by line.
    pub refusals: Vec<Refusal>,
    /// A hash of the file's text (FNV-1a, 64 bits): a progress file belongs to this text.
    pub hash: u64,
}

/// A refusal: the line it is about and why.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Refusal {
    /// 1-based line of the file.
    pub line: usize,
    /// Why.
    pub reason: String,
}

type RawStep = BTreeMap<Spanned<String>, Spanned<toml::Value>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    name: Option<String>,
    description: Option<String>,
    #[serde(default)]
    step: Vec<Spanned<RawStep>>,
}

/// The 1-based line of byte `offset` in `text`.
pub fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// FNV-1a, 64 bits.
pub fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

impl Step {
    /// The kind's name (`bend`, `wait`, …).
    pub fn kind(&self) -> &'static str {
        match self.action {
            Action::State(_) => "state",
            Action::Bend { .. } => "bend",
            Action::Grip(_) => "grip",
            Action::Reach { .. } => "reach",
            Action::Vent => "vent",
            Action::Wait(_) => "wait",
            Action::Aim(_) => "aim",
            Action::Identify => "identify",
            Action::Prompt { .. } => "prompt",
        }
    }

    /// What it does, in words.
    pub fn describe(&self) -> String {
        let what = match &self.action {
            Action::State(s) => format!("go to {s}"),
            Action::Bend { angle, .. } if *angle == 0.0 => "straighten".into(),
            Action::Bend { angle, toward } => format!("bend {angle}° toward {toward}°"),
            Action::Grip(true) => "close the gripper".into(),
            Action::Grip(false) => "open the gripper".into(),
            Action::Reach { point, .. } => {
                format!("reach ({}, {}, {}) mm", point[0], point[1], point[2])
            }
            Action::Vent => "vent".into(),
            Action::Wait(ms) => format!("wait {}", crate::num::seconds(*ms)),
            Action::Aim(a) => match &a.target {
                AimTarget::Toward(az, el) => format!("aim at azimuth {az}°, elevation {el}°"),
                AimTarget::Sun { time: Some(t), .. } => {
                    format!("aim at the sun of {}", t.to_rfc3339())
                }
                AimTarget::Sun { time: None, .. } => "aim at the sun".into(),
            },
            Action::Identify => "identify the state".into(),
            Action::Prompt { text, .. } => format!("ask: {text}"),
        };
        match &self.name {
            Some(n) => format!("{n}: {what}"),
            None => what,
        }
    }
}

/// Reads a mission's text: its structure and each step's parameters (the ranges of the
/// commands of the same names). A text that is no TOML, or not a mission's shape, is refused
/// whole; a step's problems are kept in [`Mission::refusals`] (that step left out of
/// [`Mission::steps`]), so that [`check`] can add those of the others.
pub fn parse(text: &str) -> Result<Mission, Vec<Refusal>> {
    let raw: RawFile = toml::from_str(text).map_err(|e| {
        vec![Refusal {
            line: e.span().map_or(1, |s| line_of(text, s.start)),
            reason: e.message().trim().to_string(),
        }]
    })?;
    let mut refusals = Vec::new();
    let mut steps = Vec::new();
    if raw.step.is_empty() {
        refusals.push(Refusal {
            line: 1,
            reason: "the mission has no steps: add [[step]] tables (docs/host.md, \"Missions\")"
                .into(),
        });
    }
    for (i, s) in raw.step.iter().enumerate() {
        match parse_step(text, i + 1, s) {
            Ok(step) => steps.push(step),
            Err(mut r) => refusals.append(&mut r),
        }
    }
    refusals.sort();
    Ok(Mission {
        name: raw.name,
        description: raw.description,
        steps,
        refusals,
        hash: fnv1a(text),
    })
}

/// One value's line and the refusal builder for it.
struct At<'a> {
    text: &'a str,
    n: usize,
}

impl At<'_> {
    fn refuse<T>(
        &self,
        span: std::ops::Range<usize>,
        why: impl Into<String>,
    ) -> Result<T, Refusal> {
        Err(Refusal {
            line: line_of(self.text, span.start),
            reason: format!("step {}: {}", self.n, why.into()),
        })
    }
}

fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
    .filter(|x| x.is_finite())
}

fn type_name(v: &toml::Value) -> &'static str {
    v.type_str()
}

fn parse_step(text: &str, n: usize, raw: &Spanned<RawStep>) -> Result<Step, Vec<Refusal>> {
    let at = At { text, n };
    let map = raw.get_ref();
    let mut refusals = Vec::new();
    let mut kinds: Vec<&Spanned<String>> = map
        .keys()
        .filter(|k| KINDS.contains(&k.get_ref().as_str()))
        .collect();
    // In the file's order: a second kind is refused where it stands.
    kinds.sort_by_key(|k| k.span().start);
    for k in map.keys() {
        let key = k.get_ref().as_str();
        if KINDS.contains(&key) || COMMON.contains(&key) {
            continue;
        }
        let why = if kinds.is_empty() {
            format!(
                "unknown step kind '{key}': a step is one of {}",
                KINDS.join(", ")
            )
        } else {
            format!(
                "unknown key '{key}' in a {} step: beside its kind a step takes only {}",
                kinds[0].get_ref(),
                COMMON.join(", ")
            )
        };
        refusals.extend(at.refuse::<()>(k.span(), why).err());
    }
    let kind = match kinds[..] {
        [k] => Some(k),
        [] => {
            if refusals.is_empty() {
                refusals.extend(
                    at.refuse::<()>(
                        raw.span(),
                        format!("a step needs one kind: one of {}", KINDS.join(", ")),
                    )
                    .err(),
                );
            }
            None
        }
        [a, b, ..] => {
            refusals.extend(
                at.refuse::<()>(
                    b.span(),
                    format!(
                        "a step does one thing: it has both {} and {} (make two steps)",
                        a.get_ref(),
                        b.get_ref()
                    ),
                )
                .err(),
            );
            None
        }
    };
    let time_limit_ms = match map.get("time_limit") {
        None => None,
        Some(v) => match duration_ms(&at, v, "time_limit") {
            Ok(ms) => Some(ms),
            Err(r) => {
                refusals.push(r);
                None
            }
        },
    };
    let on_failure = match map.get("on_failure") {
        None => OnFailure::Stop,
        Some(v) => match v.get_ref().as_str() {
            Some("stop") => OnFailure::Stop,
            Some("skip") => OnFailure::Skip,
            _ => {
                refusals.extend(
                    at.refuse::<()>(
                        v.span(),
                        format!(
                            "on_failure must be \"stop\" (stop the mission, crane safe) or \"skip\" (go on), got {}",
                            v.get_ref()
                        ),
                    )
                    .err(),
                );
                OnFailure::Stop
            }
        },
    };
    let name = match map.get("name") {
        None => None,
        Some(v) => match v.get_ref().as_str() {
            Some(s) => Some(s.to_string()),
            None => {
                refusals.extend(at.refuse::<()>(v.span(), "name must be a string").err());
                None
            }
        },
    };
    let action = kind.and_then(|k| {
        let v = &map[k.get_ref().as_str()];
        match parse_action(&at, k.get_ref(), v) {
            Ok(a) => Some((a, line_of(text, k.span().start))),
            Err(r) => {
                refusals.push(r);
                None
            }
        }
    });
    if let (Some((Action::Wait(ms), _)), Some(limit), Some(v)) =
        (&action, time_limit_ms, map.get("time_limit"))
    {
        if *ms >= limit {
            refusals.extend(
                at.refuse::<()>(
                    v.span(),
                    format!(
                        "a wait of {} can never end within its time limit of {}",
                        crate::num::seconds(*ms),
                        crate::num::seconds(limit)
                    ),
                )
                .err(),
            );
        }
    }
    match action {
        Some((action, line)) if refusals.is_empty() => Ok(Step {
            number: n,
            line,
            action,
            time_limit_ms,
            on_failure,
            name,
        }),
        _ => Err(refusals),
    }
}

fn duration_ms(at: &At<'_>, v: &Spanned<toml::Value>, what: &str) -> Result<u64, Refusal> {
    let Some(s) = v.get_ref().as_str() else {
        return at.refuse(
            v.span(),
            format!(
                "{what} must be a duration string such as \"30s\", \"10m\" or \"1h30m\", got {}",
                type_name(v.get_ref())
            ),
        );
    };
    match sun::parse_duration(s) {
        Ok(d) => Ok(d.num_milliseconds().max(0) as u64),
        Err(e) => at.refuse(v.span(), format!("{what}: {e}")),
    }
}

/// A table's field as a number in `range`.
fn field_number(
    at: &At<'_>,
    span: &std::ops::Range<usize>,
    table: &toml::Table,
    key: &str,
    what: &str,
) -> Result<Option<f64>, Refusal> {
    match table.get(key) {
        None => Ok(None),
        Some(v) => match number(v) {
            Some(x) => Ok(Some(x)),
            None => at.refuse(
                span.clone(),
                format!("{what}: {key} must be a number, got {v}"),
            ),
        },
    }
}

fn unknown_fields(
    at: &At<'_>,
    span: &std::ops::Range<usize>,
    table: &toml::Table,
    kind: &str,
    known: &[&str],
) -> Result<(), Refusal> {
    match table.keys().find(|k| !known.contains(&k.as_str())) {
        Some(k) => at.refuse(
            span.clone(),
            format!(
                "unknown field '{k}' of {kind}: it takes {}",
                known.join(", ")
            ),
        ),
        None => Ok(()),
    }
}

fn parse_action(at: &At<'_>, kind: &str, v: &Spanned<toml::Value>) -> Result<Action, Refusal> {
    let span = v.span();
    let value = v.get_ref();
    match kind {
        "state" => {
            let Some(s) = value.as_str() else {
                return at.refuse(
                    span,
                    format!("state must be a state name such as \"D&F\", got {value}"),
                );
            };
            TrunkState::from_str(s)
                .map(Action::State)
                .or_else(|e| at.refuse(span, format!("unknown state '{s}': {e}")))
        }
        "bend" => {
            let Some(t) = value.as_table() else {
                return at.refuse(
                    span,
                    format!("bend must be a table {{ angle = DEG, toward = DIR }} (angle 0 straightens), got {value}"),
                );
            };
            unknown_fields(at, &span, t, "bend", &["angle", "toward"])?;
            let Some(angle) = field_number(at, &span, t, "angle", "bend")? else {
                return at.refuse(span, "bend needs angle = DEG (≥ 0; 0 straightens)");
            };
            if angle < 0.0 {
                return at.refuse(
                    span,
                    format!("bend angle {angle}: a bend angle is ≥ 0° (bend the other way with toward + 180)"),
                );
            }
            let toward = match field_number(at, &span, t, "toward", "bend")? {
                Some(d) => d,
                None if angle == 0.0 => 0.0,
                None => {
                    return at.refuse(
                        span,
                        "a bend needs toward = DIR (degrees, 0° = toward tendon 0); only angle = 0 (straighten) goes without",
                    )
                }
            };
            Ok(Action::Bend { angle, toward })
        }
        "grip" => match value.as_str() {
            Some("open") => Ok(Action::Grip(false)),
            Some("close") => Ok(Action::Grip(true)),
            _ => at.refuse(
                span,
                format!("grip must be \"open\" or \"close\", got {value}"),
            ),
        },
        "reach" => {
            let (point, tolerance) = match value {
                toml::Value::Array(_) => (value, None),
                toml::Value::Table(t) => {
                    unknown_fields(at, &span, t, "reach", &["point", "tolerance"])?;
                    let Some(p) = t.get("point") else {
                        return at.refuse(span, "reach needs point = [X, Y, Z] (mm)");
                    };
                    (p, field_number(at, &span, t, "tolerance", "reach")?)
                }
                _ => {
                    return at.refuse(
                        span,
                        format!("reach must be [X, Y, Z] (mm) or {{ point = [X, Y, Z], tolerance = MM }}, got {value}"),
                    )
                }
            };
            let xyz: Vec<f64> = point
                .as_array()
                .map(|a| a.iter().filter_map(number).collect())
                .unwrap_or_default();
            let point = match (&xyz[..], point.as_array().map(Vec::len)) {
                (&[x, y, z], Some(3)) => [x, y, z],
                _ => {
                    return at.refuse(
                        span,
                        format!("reach: the point must be [X, Y, Z] in mm, got {point}"),
                    )
                }
            };
            let tolerance = tolerance.unwrap_or(5.0);
            if tolerance <= 0.0 {
                return at.refuse(
                    span,
                    format!("reach: tolerance {tolerance}: expected a distance in mm > 0"),
                );
            }
            Ok(Action::Reach { point, tolerance })
        }
        "vent" | "identify" => match value.as_bool() {
            Some(true) => Ok(if kind == "vent" {
                Action::Vent
            } else {
                Action::Identify
            }),
            _ => at.refuse(
                span,
                format!("write {kind} = true (it takes no parameters), got {value}"),
            ),
        },
        "wait" => duration_ms(at, v, "wait").map(Action::Wait),
        "aim" => parse_aim(at, &span, value).map(Action::Aim),
        "prompt" => {
            let (text, load) = match value {
                toml::Value::String(s) => (s.clone(), None),
                toml::Value::Table(t) => {
                    unknown_fields(at, &span, t, "prompt", &["text", "tip_load_kg"])?;
                    let Some(s) = t.get("text").and_then(toml::Value::as_str) else {
                        return at.refuse(span, "prompt needs text = \"what the person is to do\"");
                    };
                    (s.to_string(), field_number(at, &span, t, "tip_load_kg", "prompt")?)
                }
                _ => {
                    return at.refuse(
                        span,
                        format!("prompt must be the text to show, or {{ text = \"…\", tip_load_kg = KG }}, got {value}"),
                    )
                }
            };
            if text.trim().is_empty() {
                return at.refuse(
                    span,
                    "prompt: the text is empty: say what the person is to do",
                );
            }
            if let Some(kg) = load {
                if !(0.0..=hil_sim::world::MAX_MASS_KG).contains(&kg) {
                    return at.refuse(
                        span,
                        format!(
                            "prompt: tip_load_kg {kg}: expected a mass in kg from 0 to {}",
                            hil_sim::world::MAX_MASS_KG
                        ),
                    );
                }
            }
            Ok(Action::Prompt {
                text,
                tip_load_kg: load,
            })
        }
        _ => at.refuse(span, format!("unknown step kind '{kind}'")),
    }
}

fn parse_aim(
    at: &At<'_>,
    span: &std::ops::Range<usize>,
    value: &toml::Value,
) -> Result<Aim, Refusal> {
    let Some(t) = value.as_table() else {
        return at.refuse(
            span.clone(),
            format!("aim must be a table {{ toward = [AZ, EL] }} or {{ sun = true, lat = DEG, lon = DEG, time = \"RFC 3339\" }}, got {value}"),
        );
    };
    unknown_fields(
        at,
        span,
        t,
        "aim",
        &[
            "toward",
            "sun",
            "lat",
            "lon",
            "time",
            "heading",
            "change_state",
        ],
    )?;
    let heading = field_number(at, span, t, "heading", "aim")?.unwrap_or(90.0);
    let heading = Heading::from_deg(heading)
        .or_else(|e| at.refuse(span.clone(), format!("aim: heading: {e}")))?;
    let change_state = match t.get("change_state") {
        None => false,
        Some(v) => v.as_bool().map_or_else(
            || at.refuse(span.clone(), "aim: change_state must be true or false"),
            Ok,
        )?,
    };
    let sun = t.get("sun").and_then(toml::Value::as_bool).unwrap_or(false);
    let target = match (t.get("toward"), sun) {
        (Some(d), false) => {
            let v: Vec<f64> = d
                .as_array()
                .map(|a| a.iter().filter_map(number).collect())
                .unwrap_or_default();
            let [az, el] = v[..] else {
                return at.refuse(
                    span.clone(),
                    format!("aim: toward must be [AZ, EL] in degrees, got {d}"),
                );
            };
            let (az, el) = crate::cmd::aim::direction(az, el)
                .or_else(|e| at.refuse(span.clone(), format!("aim: {e}")))?;
            AimTarget::Toward(az, el)
        }
        (None, true) => {
            let (Some(lat), Some(lon)) = (
                field_number(at, span, t, "lat", "aim")?,
                field_number(at, span, t, "lon", "aim")?,
            ) else {
                return at.refuse(span.clone(), "aim at the sun needs lat = DEG and lon = DEG");
            };
            crate::cmd::aim::site_of(lat, lon).or_else(|e| {
                at.refuse(
                    span.clone(),
                    format!("aim: {}", crate::cmd::reach::failure_text(&e)),
                )
            })?;
            let time = match t.get("time") {
                None => None,
                Some(v) => {
                    let Some(s) = v.as_str() else {
                        return at.refuse(
                            span.clone(),
                            "aim: time must be an RFC 3339 string with its offset",
                        );
                    };
                    Some(
                        sun::parse_instant(s)
                            .or_else(|e| at.refuse(span.clone(), format!("aim: time: {e}")))?
                            .with_timezone(&Utc),
                    )
                }
            };
            AimTarget::Sun {
                lat_lon: (lat, lon),
                time,
            }
        }
        _ => {
            return at.refuse(
                span.clone(),
                "aim needs either toward = [AZ, EL] or sun = true (with lat, lon and time)",
            )
        }
    };
    Ok(Aim {
        target,
        heading,
        change_state,
    })
}

/// What the checks know of the crane the mission runs on.
pub struct Crane<'a> {
    /// The crane's configuration (the simulator's for `--sim`).
    pub cfg: &'a protocol::CraneGeometry,
    /// Whether the built-in simulator runs it (a prompt's person is simulated then).
    pub sim: bool,
    /// Whether a `host-tool serve` server holds the device.
    pub server: bool,
    /// Whether a person can answer at a terminal.
    pub terminal: bool,
}

/// The compass direction an aim step points at, if it is known before it runs (a sun below
/// the horizon: the refusal).
pub fn aim_direction(a: &Aim) -> Result<Option<(f64, f64)>, String> {
    match &a.target {
        AimTarget::Toward(az, el) => Ok(Some((*az, *el))),
        AimTarget::Sun { time: None, .. } => Ok(None),
        AimTarget::Sun {
            lat_lon: (lat, lon),
            time: Some(t),
        } => {
            let fail = |e: crate::failure::Failure| crate::cmd::reach::failure_text(&e);
            let (site, air) = crate::cmd::aim::site_of(*lat, *lon).map_err(fail)?;
            match crate::cmd::aim::sun_at(&site, &air, t).map_err(fail)? {
                Ok(dir) => Ok(Some(dir)),
                Err(el) => Err(format!(
                    "the sun is below the horizon at {} (elevation {el:.2}°): nothing to aim at",
                    t.to_rfc3339()
                )),
            }
        }
    }
}

/// Validates the mission against the crane, following the state each step leaves where it is
/// known (from the first `state` step on): a state no plan reaches, a bend over its state's
/// limit or in a state that does not bend, a point no state reaches, a sun below the horizon,
/// a prompt nobody can answer, an identify a server cannot do. Every refusal, by line.
pub fn check(mission: &Mission, crane: &Crane<'_>) -> Vec<Refusal> {
    let mut refusals = Vec::new();
    let ws = match crate::cmd::pose::crane_workspace(crane.cfg) {
        Ok(ws) => ws,
        Err(e) => {
            return vec![Refusal {
                line: 1,
                reason: crate::cmd::reach::failure_text(&e),
            }]
        }
    };
    let widest = TrunkState::ALL
        .iter()
        .filter_map(|s| ws.limit_deg(*s))
        .fold(0.0, f64::max);
    // The state the trunk is in before each step, where known, and the step that left it so.
    let mut state: Option<TrunkState> = None;
    let mut by = 0usize;
    let mut previous = 0usize;
    for step in &mission.steps {
        let i = step.number - 1;
        if step.number != previous + 1 {
            // A step before it did not parse: where the trunk is is not known.
            state = None;
        }
        previous = step.number;
        let refuse = |why: String| Refusal {
            line: step.line,
            reason: format!("step {} ({}): {why}", i + 1, step.kind()),
        };
        let strip = |e: crate::failure::Failure| {
            let t = crate::cmd::reach::failure_text(&e);
            t.strip_prefix("refused: ").unwrap_or(&t).to_string()
        };
        match &step.action {
            Action::State(target) => {
                let from = state.map_or(TrunkState::ALL.to_vec(), |s| vec![s]);
                if let Some(e) = from
                    .iter()
                    .find_map(|f| Graph::nominal().plan(*f, *target).err())
                {
                    refusals.push(refuse(format!("{target} cannot be reached: {e}")));
                }
                state = Some(*target);
                by = i + 1;
            }
            Action::Bend { angle, toward } => {
                if *angle > widest {
                    refusals.push(refuse(format!(
                        "bend {angle}°: no state bends more than {:.2}° (the nearest feasible bend)",
                        (widest * 100.0).floor() / 100.0
                    )));
                } else if let Some(s) = state {
                    if let Err(e) = bend_step(&ws, crane.cfg, s, *angle, *toward) {
                        refusals.push(refuse(format!(
                            "in {s}, where step {by} leaves the trunk: {}",
                            strip(e)
                        )));
                    }
                }
            }
            Action::Reach { point, tolerance } => {
                match plan_reach(
                    crane.cfg,
                    state.unwrap_or(TrunkState::AS_MANUFACTURED),
                    *point,
                    *tolerance,
                ) {
                    Ok(p) => {
                        state = state.map(|_| p.state);
                        by = i + 1;
                    }
                    Err(e) => refusals.push(refuse(strip(e))),
                }
            }
            Action::Aim(a) => match aim_direction(a) {
                Err(e) => refusals.push(refuse(e)),
                Ok(dir) => {
                    if a.change_state {
                        state = match (state, dir) {
                            (Some(s), Some((az, el))) => {
                                let ws = crate::cmd::task::task_workspace(crane.cfg).unwrap_or(ws);
                                let target = a.heading.base_of(az, el).into_inner();
                                by = i + 1;
                                Some(
                                    crate::cmd::aim::better_state(&ws, s, &target)
                                        .map_or(s, |b| b.0),
                                )
                            }
                            _ => None,
                        };
                    }
                }
            },
            Action::Identify => {
                if crane.server {
                    refusals.push(refuse(
                        "a mission's identify step does not go through a `host-tool serve` server: run `host-tool identify` (it does) from another terminal first, or stop the server".into(),
                    ));
                }
                state = None;
            }
            Action::Prompt { tip_load_kg, .. } => {
                if !crane.sim && !crane.terminal {
                    refusals.push(refuse(
                        "a person must answer this prompt with Enter: run the mission on a terminal (stdin is not one)".into(),
                    ));
                }
                if tip_load_kg.is_some() && crane.server {
                    refusals.push(refuse(
                        "tip_load_kg is hung by the built-in simulator's person: a server holds this device; run with --sim, or leave it to the prompt's text".into(),
                    ));
                }
            }
            Action::Grip(_) | Action::Vent | Action::Wait(_) => {}
        }
    }
    refusals.sort();
    refusals
}

/// The refusals as the error of `run`: `FILE:LINE: reason`, one a line.
pub fn refusal_text(file: &str, refusals: &[Refusal]) -> String {
    let mut out = format!(
        "the mission {file} is refused ({}; nothing was sent to the crane):",
        crate::num::plural(refusals.len(), "problem", "problems")
    );
    for r in refusals {
        out.push_str(&format!("\n  {file}:{}: {}", r.line, r.reason));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refusals(text: &str) -> Vec<Refusal> {
        match parse(text) {
            Ok(m) => m.refusals,
            Err(r) => r,
        }
    }

    #[test]
    fn every_kind_parses_with_its_line() {
        let m = parse(
            "name = \"all\"\n\
             [[step]]\nstate = \"D&F\"\ntime_limit = \"2m\"\n\
             [[step]]\nbend = { angle = 10, toward = 90 }\non_failure = \"skip\"\n\
             [[step]]\ngrip = \"close\"\n\
             [[step]]\nreach = [0, 20, 150]\n\
             [[step]]\nvent = true\n\
             [[step]]\nwait = \"1m30s\"\n\
             [[step]]\naim = { toward = [135, 40] }\n\
             [[step]]\nidentify = true\n\
             [[step]]\nprompt = { text = \"hang it\", tip_load_kg = 1.5 }\n",
        )
        .unwrap();
        assert!(m.refusals.is_empty(), "{:?}", m.refusals);
        let kinds: Vec<&str> = m.steps.iter().map(Step::kind).collect();
        assert_eq!(kinds, KINDS);
        assert_eq!(m.steps[0].line, 3);
        assert_eq!(m.steps[0].time_limit_ms, Some(120_000));
        assert_eq!(m.steps[1].on_failure, OnFailure::Skip);
        assert_eq!(m.steps[5].action, Action::Wait(90_000));
    }

    #[test]
    fn refusals_name_the_line_and_the_reason() {
        let r = refusals("[[step]]\nstate = \"D&F\"\n\n[[step]]\njump = 3\n");
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].line, 5);
        assert!(r[0].reason.contains("unknown step kind 'jump'"), "{r:?}");
        let r =
            refusals("[[step]]\nbend = { angle = -3, toward = 0 }\n[[step]]\nstate = \"X&Y\"\n");
        assert_eq!((r[0].line, r[1].line), (2, 4), "{r:?}");
        assert!(r[0].reason.contains("≥ 0°") && r[1].reason.contains("unknown state 'X&Y'"));
        let r = refusals("[[step]]\nwait = \"60s\"\ntime_limit = \"30s\"\n");
        assert_eq!(r[0].line, 3);
        assert!(r[0].reason.contains("can never end"), "{r:?}");
        let r = refusals("[[step]]\nstate = \"D&F\"\nbend = { angle = 0 }\n");
        assert!(r[0].reason.contains("does one thing"), "{r:?}");
        let r = refusals("title = 3\n");
        assert!(r[0].reason.contains("unknown field"), "{r:?}");
        let r = refusals("name = \"empty\"\n");
        assert!(r[0].reason.contains("no steps"), "{r:?}");
        let r = refusals("[[step]]\nstate = \"D&F\"\non_failure = \"retry\"\n");
        assert!(r[0].reason.contains("\"skip\""), "{r:?}");
    }
}
