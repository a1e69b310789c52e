//! The recorded messages of every JSON channel, typed: each derives `Serialize` (the bytes
//! written to the file and to the live view) and `JsonSchema` (the channel's schema is
//! `schemars::schema_for!` of it), and names its [`Topic`] — so a channel's messages and its
//! schema cannot drift apart. A device event is typed here in the protocol's serde form
//! ([`DeviceEvent`], built by an exhaustive match, so a new event or field does not compile
//! until it is recorded); a request's and a response's bodies are the protocol's serde form
//! as JSON values (any), as the protocol's types have no JSON schema of their own.

use std::borrow::Cow;

use geometry::TrunkState;
use protocol::{FaultCode, ManualTask, Mode};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;
use serde_json::Value;

use super::Topic;
use crate::outcome::PlanOutcome;

/// A message of one recorded channel.
pub trait Message: Serialize + JsonSchema {
    /// Its channel.
    const TOPIC: Topic;
}

/// A telemetry sample (pressure kPa, servo commands deg, valves).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.Telemetry")]
pub struct Telemetry {
    /// The device's uptime at the sample, ms.
    pub device_ms: u32,
    /// The host's time, ms.
    pub host_ms: u64,
    /// Gauge pressure, kPa.
    pub pressure_kpa: f32,
    /// The three servos' commanded angles, degrees.
    pub servo_deg: [f32; 3],
    /// The inlet valve is open.
    pub inlet_open: bool,
    /// The exhaust valve is open.
    pub exhaust_open: bool,
    /// The device's state (`D&F`).
    pub state: &'static str,
    /// Whether the device has confirmed it.
    pub state_confirmed: bool,
}

impl Message for Telemetry {
    const TOPIC: Topic = Topic::Telemetry;
}

/// A device event (decoded).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.Event")]
pub struct Event {
    /// The host's time, ms.
    pub host_ms: u64,
    /// The event's kind (`host::text::event`'s word).
    pub kind: &'static str,
    /// Its line for people, where it has one.
    pub text: Option<String>,
    /// The event as the wire carries it (`protocol::Event`'s serde form).
    pub event: DeviceEvent,
}

/// A wire value recorded in its own serde form; its schema lists the serde form of each of
/// its values (so the words are the protocol's, never retyped).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Wire<T>(pub T);

/// A wire type whose values can all be listed.
pub trait Enumerated: Serialize + Sized + 'static {
    /// The schema's name.
    const NAME: &'static str;
    /// Every value.
    fn all() -> Vec<Self>;
}

impl<T: Enumerated> JsonSchema for Wire<T> {
    fn schema_name() -> Cow<'static, str> {
        T::NAME.into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        let values: Vec<Value> = T::all()
            .iter()
            .filter_map(|v| serde_json::to_value(v).ok())
            .collect();
        schemars::json_schema!({ "enum": values })
    }
}

impl Enumerated for TrunkState {
    const NAME: &'static str = "TrunkState";
    fn all() -> Vec<Self> {
        TrunkState::ALL.to_vec()
    }
}

impl Enumerated for FaultCode {
    const NAME: &'static str = "FaultCode";
    fn all() -> Vec<Self> {
        FaultCode::ALL.to_vec()
    }
}

impl Enumerated for Mode {
    const NAME: &'static str = "Mode";
    fn all() -> Vec<Self> {
        // A new mode fails to compile here until it is listed.
        let listed = |m: Mode| match m {
            Mode::Standalone | Mode::Running | Mode::WaitingManual | Mode::Safe | Mode::EStop => m,
        };
        [
            Mode::Standalone,
            Mode::Running,
            Mode::WaitingManual,
            Mode::Safe,
            Mode::EStop,
        ]
        .map(listed)
        .to_vec()
    }
}

impl Enumerated for ManualTask {
    const NAME: &'static str = "ManualTask";
    fn all() -> Vec<Self> {
        let listed = |t: ManualTask| match t {
            ManualTask::PackBottomModule
            | ManualTask::FoldTopModule
            | ManualTask::FoldBottomModule => t,
        };
        [
            ManualTask::PackBottomModule,
            ManualTask::FoldTopModule,
            ManualTask::FoldBottomModule,
        ]
        .map(listed)
        .to_vec()
    }
}

/// A device event in `protocol::Event`'s serde form (every event but telemetry, which has
/// its own channel): the variants and fields are the protocol's, by name.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub enum DeviceEvent {
    /// The device's heartbeat.
    Heartbeat {
        /// Its uptime, ms.
        uptime_ms: u32,
        /// What it is doing.
        mode: Wire<Mode>,
    },
    /// A step is running.
    StepProgress {
        /// Plan id.
        plan_id: u16,
        /// Step index.
        step: u8,
        /// Index of the primitive running within the step.
        primitive: u8,
        /// Time since the step started, ms.
        elapsed_ms: u32,
    },
    /// A step finished.
    StepDone {
        /// Plan id.
        plan_id: u16,
        /// Step index.
        step: u8,
        /// Its target state was confirmed.
        ok: bool,
        /// The state the device now believes.
        state: Wire<TrunkState>,
        /// How long the step took, ms.
        duration_ms: u32,
    },
    /// The whole plan finished.
    PlanDone {
        /// Plan id.
        plan_id: u16,
        /// Every step succeeded.
        ok: bool,
        /// Final state.
        state: Wire<TrunkState>,
    },
    /// The trunk's state changed.
    StateReached {
        /// The new state.
        state: Wire<TrunkState>,
        /// Whether it was confirmed.
        confirmed: bool,
    },
    /// A manual step needs a person.
    ManualRequired {
        /// Plan id.
        plan_id: u16,
        /// Step index.
        step: u8,
        /// What to do.
        task: Wire<ManualTask>,
    },
    /// A fault became active.
    FaultRaised(Wire<FaultCode>),
    /// A fault was cleared.
    FaultCleared(Wire<FaultCode>),
    /// A person must say which of these states the trunk is in.
    IdentifyNeedsOperator {
        /// The states still possible, one bit per state (bit 0 = `F&P` … bit 5 = `D&D`).
        #[schemars(range(max = 63))]
        candidates: u8,
    },
}

impl DeviceEvent {
    /// The recorded form of `ev`; `None` for telemetry (recorded on `/telemetry`).
    pub fn of(ev: &protocol::Event) -> Option<DeviceEvent> {
        use protocol::Event as E;
        Some(match *ev {
            E::Heartbeat { uptime_ms, mode } => DeviceEvent::Heartbeat {
                uptime_ms,
                mode: Wire(mode),
            },
            E::Telemetry(_) => return None,
            E::StepProgress {
                plan_id,
                step,
                primitive,
                elapsed_ms,
            } => DeviceEvent::StepProgress {
                plan_id,
                step,
                primitive,
                elapsed_ms,
            },
            E::StepDone {
                plan_id,
                step,
                ok,
                state,
                duration_ms,
            } => DeviceEvent::StepDone {
                plan_id,
                step,
                ok,
                state: Wire(state),
                duration_ms,
            },
            E::PlanDone { plan_id, ok, state } => DeviceEvent::PlanDone {
                plan_id,
                ok,
                state: Wire(state),
            },
            E::StateReached { state, confirmed } => DeviceEvent::StateReached {
                state: Wire(state),
                confirmed,
            },
            E::ManualRequired {
                plan_id,
                step,
                task,
            } => DeviceEvent::ManualRequired {
                plan_id,
                step,
                task: Wire(task),
            },
            E::FaultRaised(c) => DeviceEvent::FaultRaised(Wire(c)),
            E::FaultCleared(c) => DeviceEvent::FaultCleared(Wire(c)),
            E::IdentifyNeedsOperator {
                candidates: protocol::StateSet(bits),
            } => DeviceEvent::IdentifyNeedsOperator { candidates: bits },
        })
    }
}

impl Message for Event {
    const TOPIC: Topic = Topic::Events;
}

/// A fault raised or cleared.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.Fault")]
pub struct Fault {
    /// The host's time, ms.
    pub host_ms: u64,
    /// Raised (`true`) or cleared.
    pub raised: bool,
    /// The fault's code (`host::text::fault_code`).
    pub code: String,
    /// What it means.
    pub text: String,
}

impl Message for Fault {
    const TOPIC: Topic = Topic::Faults;
}

/// The device's state and its confidence.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.State")]
pub struct State {
    /// The host's time, ms.
    pub host_ms: u64,
    /// The state (the believed one while unconfirmed; empty when none is named).
    pub state: &'static str,
    /// Whether it is confirmed.
    pub state_confirmed: bool,
    /// The states the trunk may be in.
    pub candidates: Vec<&'static str>,
    /// What said so: `status`, `state-reached`, `identify-needs-operator`, `identify-prompt`.
    pub source: &'static str,
}

impl Message for State {
    const TOPIC: Topic = Topic::State;
}

/// A log time: seconds and nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, JsonSchema)]
pub struct Timestamp {
    /// Whole seconds.
    pub sec: u64,
    /// Nanoseconds within the second.
    #[schemars(range(max = 999_999_999))]
    pub nsec: u32,
}

/// Foxglove's well-known `foxglove.Log` (levels 1 DEBUG … 5 FATAL).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "foxglove.Log")]
pub struct Log {
    /// When (the device's time).
    pub timestamp: Timestamp,
    /// The level, 0 (unknown) to 5 (fatal).
    #[schemars(range(max = 5))]
    pub level: u8,
    /// The line.
    pub message: String,
    /// Who said it (`device`, `run`).
    pub name: String,
    /// Source file (none: empty).
    pub file: &'static str,
    /// Source line (none: 0).
    pub line: u32,
}

impl Message for Log {
    const TOPIC: Topic = Topic::Log;
}

/// A request sent to the device (decoded).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.Request")]
pub struct Request {
    /// The host's time, ms.
    pub host_ms: u64,
    /// Its sequence number.
    pub seq: u16,
    /// Its session.
    pub session: u32,
    /// The request's name (`host::text::request_name`).
    pub name: &'static str,
    /// The request's body (`protocol::RequestBody`'s serde form).
    pub body: Value,
}

impl Message for Request {
    const TOPIC: Topic = Topic::Requests;
}

/// A response from the device (decoded).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.Response")]
pub struct Response {
    /// The host's time, ms.
    pub host_ms: u64,
    /// The sequence number it answers.
    pub seq: u16,
    /// The result code (`protocol::ResultCode`'s serde form).
    pub result: Value,
    /// The answer (`protocol::ResponseBody`'s serde form).
    pub body: Value,
}

impl Message for Response {
    const TOPIC: Topic = Topic::Responses;
}

/// Which way a frame went.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Dir {
    /// Host to device.
    Tx,
    /// Device to host.
    Rx,
}

/// A raw frame on the wire (COBS, delimiter included), hex.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.RawFrame")]
pub struct RawFrame {
    /// The host's time, ms.
    pub host_ms: u64,
    /// Which way.
    pub dir: Dir,
    /// Its length in bytes.
    pub len: usize,
    /// The bytes, two hex digits each.
    pub hex: String,
    /// Whether it decoded as a message.
    pub decoded: bool,
}

impl Message for RawFrame {
    const TOPIC: Topic = Topic::Frames;
}

/// One step of a recorded plan.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct PlanStep {
    /// How it is actuated (`planner::graph::kind_name`).
    pub kind: &'static str,
    /// The state it starts from.
    pub from: &'static str,
    /// The state it reaches.
    pub to: &'static str,
    /// Its expected time, s.
    pub expected_s: f64,
    /// Its time limit on the device, ms.
    pub timeout_ms: u32,
    /// Why the planner took it.
    pub why: String,
}

/// The plan the host made (replan: after a surprise).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.Plan")]
pub struct Plan {
    /// The host's time, ms.
    pub host_ms: u64,
    /// The state it starts from.
    pub from: &'static str,
    /// The state it reaches.
    pub target: &'static str,
    /// A replan after a surprise.
    pub replan: bool,
    /// Its expected time, s.
    pub expected_s: f64,
    /// Its steps, in order.
    pub steps: Vec<PlanStep>,
}

impl Message for Plan {
    const TOPIC: Topic = Topic::Plan;
}

/// An event of the host's plan runner.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.RunEvent")]
pub struct Run {
    /// The host's time, ms.
    pub host_ms: u64,
    /// What happened.
    pub kind: RunKind,
    /// Its line for people.
    pub text: String,
    /// The kind's details (`outcome`: the `plan --json` object), or null.
    pub detail: RunDetail,
}

/// What a plan-runner event is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum RunKind {
    /// A plan was made (on `/plan`).
    Plan,
    /// A step started.
    StepStarted,
    /// A manual step asks a person.
    ManualPrompt,
    /// The state is unconfirmed: a person is asked which it is.
    IdentifyPrompt,
    /// A step finished.
    StepFinished,
    /// A note of the runner.
    Note,
    /// The run finished.
    Finished,
    /// The run's outcome.
    Outcome,
}

/// The details of a plan-runner event (null for `plan`, `note` and `finished`).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum RunDetail {
    /// `step-started`.
    StepStarted {
        /// The step's index (0-based).
        index: usize,
        /// Steps in the plan.
        total: usize,
    },
    /// `manual-prompt`.
    ManualPrompt {
        /// The step's index (0-based).
        index: usize,
    },
    /// `identify-prompt`.
    IdentifyPrompt {
        /// The state the device believes.
        believed: &'static str,
        /// The states it may be in.
        candidates: Vec<&'static str>,
    },
    /// `step-finished`.
    StepFinished {
        /// The step's index (0-based).
        index: usize,
        /// Its start state.
        from: &'static str,
        /// The state it reached.
        to: &'static str,
        /// It completed.
        ok: bool,
        /// How long it took, ms, where known.
        duration_ms: Option<u32>,
        /// How it is actuated (`planner::graph::kind_name`).
        kind: &'static str,
    },
    /// `outcome`: the `plan --json` object.
    Outcome(Box<PlanOutcome>),
    /// No details.
    None,
}

impl Message for Run {
    const TOPIC: Topic = Topic::Run;
}

/// The simulator's ground truth.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(title = "crane.GroundTruth")]
pub struct Truth {
    /// The host's time, ms (set when it is recorded).
    pub host_ms: u64,
    /// The true tip's position, mm (0.1 mm).
    pub tip_mm: [f64; 3],
    /// The true tip's axis (unit vector, 1e-4).
    pub tip_axis: [f64; 3],
    /// The world's objects, while it holds any.
    pub objects: Option<Vec<TruthObject>>,
    /// The simulator's time, ms.
    pub time_ms: u64,
    /// The trunk's physical state (null between states).
    pub true_state: Option<&'static str>,
    /// Gauge pressure, kPa.
    pub pressure_kpa: f32,
    /// Highest pressure so far, kPa.
    pub max_pressure_kpa: f32,
    /// Each module's height, mm (bottom first).
    pub module_heights_mm: [f32; 2],
    /// The trunk's bend, degrees.
    pub bend_deg: f32,
    /// Each tendon's tension, N.
    pub tendon_tension_n: [f32; 3],
    /// Each servo's angle, degrees.
    pub servo_deg: [f32; 3],
    /// Whether each servo is driven.
    pub servos_energised: [bool; 3],
    /// The inlet valve is open.
    pub inlet_open: bool,
    /// The exhaust valve is open.
    pub exhaust_open: bool,
    /// The gripper is closed.
    pub gripper_closed: bool,
    /// The device's belief (`D&F`).
    pub believed_state: &'static str,
    /// The device's mode (`host::text::mode`).
    pub mode: &'static str,
    /// Snap-throughs so far.
    pub snaps: u32,
    /// Valves closed and servos not driving.
    pub actuators_safe: bool,
}

/// An object of the simulator's world.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
pub struct TruthObject {
    /// Its name.
    pub name: String,
    /// Its grasp point, mm (base frame, 0.001 mm).
    pub position_mm: [f64; 3],
    /// Its mass, kg.
    pub mass_kg: f64,
    /// The gripper holds it.
    pub held: bool,
}

impl TruthObject {
    /// The recorded form of `o`.
    pub fn of(o: &hil_sim::world::Object) -> Self {
        let hil_sim::world::Object {
            name,
            position_mm,
            mass_kg,
            held,
        } = o;
        TruthObject {
            name: name.clone(),
            position_mm: position_mm.map(|v| (v * 1e3).round() / 1e3),
            mass_kg: *mass_kg,
            held: *held,
        }
    }
}

impl Message for Truth {
    const TOPIC: Topic = Topic::Truth;
}

/// The JSON schema of `M`'s channel (`schemars::schema_for!`'s draft 2020-12, with nested
/// types inlined: no `$ref`s, which not every viewer resolves).
pub fn schema<M: Message>() -> Value {
    schemars::generate::SchemaSettings::draft2020_12()
        .with(|s| s.inline_subschemas = true)
        .into_generator()
        .into_root_schema_for::<M>()
        .to_value()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::TOPICS;

    /// `v` against the top level of `schema`: an object, every required field present, no
    /// field the schema does not name, each field of the JSON type the schema says.
    fn conforms(schema: &Value, v: &Value) -> Result<(), String> {
        let props = schema["properties"].as_object().ok_or("no properties")?;
        let obj = v.as_object().ok_or("not an object")?;
        for r in schema["required"].as_array().ok_or("no required list")? {
            let r = r.as_str().ok_or("a required name is not a string")?;
            if !obj.contains_key(r) {
                return Err(format!("required field {r} missing"));
            }
        }
        for (k, val) in obj {
            let p = props
                .get(k)
                .ok_or_else(|| format!("field {k} not in the schema"))?;
            let types: Vec<&str> = match &p["type"] {
                Value::String(t) => vec![t.as_str()],
                Value::Array(ts) => ts.iter().filter_map(Value::as_str).collect(),
                _ => continue, // any
            };
            let ty = match val {
                Value::Null => "null",
                Value::Bool(_) => "boolean",
                Value::Number(n) if n.is_u64() || n.is_i64() => "integer",
                Value::Number(_) => "number",
                Value::String(_) => "string",
                Value::Array(_) => "array",
                Value::Object(_) => "object",
            };
            let ok = types.contains(&ty) || (ty == "integer" && types.contains(&"number"));
            if !ok {
                return Err(format!("field {k}: {ty}, the schema says {types:?}"));
            }
        }
        Ok(())
    }

    fn check<M: Message>(m: &M) {
        let schema = schema::<M>();
        let v = serde_json::to_value(m).expect("serialises");
        if let Err(e) = conforms(&schema, &v) {
            panic!("{}: {e}\n{v}\n{schema}", M::TOPIC.name());
        }
        // The channel's schema is this type's.
        assert_eq!(M::TOPIC.schema(), schema, "{}", M::TOPIC.name());
    }

    #[test]
    fn a_message_of_every_channel_conforms_to_the_schema_derived_from_its_type() {
        check(&Telemetry {
            device_ms: 1200,
            host_ms: 1210,
            pressure_kpa: 30.1,
            servo_deg: [0.0, 12.5, -3.0],
            inlet_open: true,
            exhaust_open: false,
            state: "D&F",
            state_confirmed: true,
        });
        check(&Event {
            host_ms: 1,
            kind: "step-done",
            text: None,
            event: DeviceEvent::StepDone {
                plan_id: 1,
                step: 0,
                ok: true,
                state: Wire(TrunkState::ALL[1]),
                duration_ms: 4100,
            },
        });
        check(&Fault {
            host_ms: 1,
            raised: true,
            code: "E07".into(),
            text: "overpressure".into(),
        });
        check(&State {
            host_ms: 1,
            state: "F&P",
            state_confirmed: false,
            candidates: vec!["F&P", "F&F"],
            source: "status",
        });
        check(&Log {
            timestamp: Timestamp {
                sec: 3,
                nsec: 999_999_999,
            },
            level: 4,
            message: "step 1 FAILED".into(),
            name: "run".into(),
            file: "",
            line: 0,
        });
        check(&Request {
            host_ms: 1,
            seq: 7,
            session: 9,
            name: "GetStatus",
            body: Value::String("GetStatus".into()),
        });
        check(&Response {
            host_ms: 1,
            seq: 7,
            result: Value::String("Ok".into()),
            body: serde_json::json!({"Param": {"id": "TelemetryHz", "value": 50.0}}),
        });
        check(&RawFrame {
            host_ms: 1,
            dir: Dir::Rx,
            len: 3,
            hex: "010200".into(),
            decoded: false,
        });
        check(&Plan {
            host_ms: 1,
            from: "F&P",
            target: "D&D",
            replan: false,
            expected_s: 21.1,
            steps: vec![PlanStep {
                kind: "pneumatic",
                from: "F&P",
                to: "F&F",
                expected_s: 5.2,
                timeout_ms: 30_000,
                why: "pressure lengthens the trunk".into(),
            }],
        });
        check(&Run {
            host_ms: 1,
            kind: RunKind::Note,
            text: "a note".into(),
            detail: RunDetail::None,
        });
        check(&Run {
            host_ms: 1,
            kind: RunKind::StepFinished,
            text: "step 1 F&P → F&F done".into(),
            detail: RunDetail::StepFinished {
                index: 0,
                from: "F&P",
                to: "F&F",
                ok: true,
                duration_ms: None,
                kind: "pneumatic",
            },
        });
        check(&Truth {
            host_ms: 1,
            tip_mm: [0.0, 0.0, 140.9],
            tip_axis: [0.0, 0.0, 1.0],
            objects: None,
            time_ms: 1,
            true_state: None,
            pressure_kpa: 0.5,
            max_pressure_kpa: 35.2,
            module_heights_mm: [20.0, 13.0],
            bend_deg: 0.0,
            tendon_tension_n: [0.0; 3],
            servo_deg: [0.0; 3],
            servos_energised: [false; 3],
            inlet_open: false,
            exhaust_open: false,
            gripper_closed: false,
            believed_state: "F&P",
            mode: "standalone",
            snaps: 0,
            actuators_safe: true,
        });
    }

    /// One of each device event but telemetry, a fault's by every code.
    fn every_event() -> Vec<protocol::Event> {
        use protocol::Event as E;
        let s = TrunkState::ALL[4];
        let mut all = vec![
            E::Heartbeat {
                uptime_ms: 5,
                mode: Mode::WaitingManual,
            },
            E::StepProgress {
                plan_id: 1,
                step: 2,
                primitive: 1,
                elapsed_ms: 300,
            },
            E::StepDone {
                plan_id: 1,
                step: 2,
                ok: false,
                state: s,
                duration_ms: 4000,
            },
            E::PlanDone {
                plan_id: 1,
                ok: true,
                state: s,
            },
            E::StateReached {
                state: s,
                confirmed: false,
            },
            E::ManualRequired {
                plan_id: 1,
                step: 0,
                task: ManualTask::FoldBottomModule,
            },
            E::IdentifyNeedsOperator {
                candidates: protocol::StateSet::ALL,
            },
        ];
        all.extend(FaultCode::ALL.into_iter().map(E::FaultRaised));
        all.push(E::FaultCleared(FaultCode::ALL[0]));
        all
    }

    #[test]
    fn a_recorded_event_is_the_protocols_serde_form_and_its_words_are_in_the_schema() {
        let schema = schema::<Event>();
        let text = schema.to_string();
        for ev in every_event() {
            let rec = DeviceEvent::of(&ev).expect("not telemetry");
            let wire = serde_json::to_value(&ev).unwrap();
            assert_eq!(serde_json::to_value(&rec).unwrap(), wire);
            // The variant's name and each word it carries are the schema's.
            let (variant, inner) = match &wire {
                Value::Object(o) => o
                    .iter()
                    .next()
                    .map(|(k, v)| (k.clone(), v.clone()))
                    .unwrap(),
                other => panic!("{other}"),
            };
            assert!(
                text.contains(&format!("\"{variant}\"")),
                "{variant}: {text}"
            );
            let words: Vec<String> = match &inner {
                Value::String(w) => vec![w.clone()],
                Value::Object(o) => o
                    .values()
                    .filter_map(|v| v.as_str().map(String::from))
                    .collect(),
                _ => vec![],
            };
            for w in words {
                assert!(text.contains(&format!("\"{w}\"")), "{w}: {text}");
            }
        }
        assert!(
            DeviceEvent::of(&protocol::Event::Telemetry(protocol::Telemetry {
                uptime_ms: 0,
                pressure_kpa: 0.0,
                servo_deg: [0.0; 3],
                inlet_open: false,
                exhaust_open: false,
                state: TrunkState::AS_MANUFACTURED,
                state_confirmed: true,
            }))
            .is_none()
        );
    }

    #[test]
    fn every_json_schema_is_titled_with_its_schema_name_inline_and_keeps_its_required_fields() {
        for t in TOPICS {
            if t.message_encoding() != "json" {
                continue;
            }
            let s = t.schema();
            assert_eq!(s["title"], t.schema_name(), "{}", t.name());
            assert_eq!(s["type"], "object", "{}", t.name());
            assert!(!s.to_string().contains("$ref"), "{}: {s}", t.name());
        }
        // The fields the hand-written schemas required are required still.
        let required = |t: Topic| -> Vec<String> {
            t.schema()["required"]
                .as_array()
                .map(|r| {
                    r.iter()
                        .filter_map(|v| v.as_str().map(String::from))
                        .collect()
                })
                .unwrap_or_default()
        };
        for (t, fields) in [
            (
                Topic::Telemetry,
                &[
                    "device_ms",
                    "host_ms",
                    "pressure_kpa",
                    "servo_deg",
                    "inlet_open",
                    "exhaust_open",
                    "state",
                    "state_confirmed",
                ][..],
            ),
            (Topic::Events, &["host_ms", "kind", "event"]),
            (Topic::Faults, &["host_ms", "raised", "code"]),
            (
                Topic::State,
                &[
                    "host_ms",
                    "state",
                    "state_confirmed",
                    "candidates",
                    "source",
                ],
            ),
            (
                Topic::Requests,
                &["host_ms", "seq", "session", "name", "body"],
            ),
            (Topic::Responses, &["host_ms", "seq", "result", "body"]),
            (Topic::Frames, &["host_ms", "dir", "len", "hex", "decoded"]),
            (
                Topic::Plan,
                &["host_ms", "from", "target", "replan", "steps"],
            ),
            (Topic::Run, &["host_ms", "kind", "text"]),
            (Topic::Truth, &["host_ms", "time_ms", "pressure_kpa"]),
        ] {
            let have = required(t);
            for f in fields {
                assert!(
                    have.iter().any(|h| h == f),
                    "{}: {f} not required: {have:?}",
                    t.name()
                );
            }
        }
        // Frames' direction is one of two words; foxglove.Log's level and nsec keep their bounds.
        let frames = Topic::Frames.schema();
        let dir = &frames["properties"]["dir"];
        let words: Vec<&Value> = match dir["enum"].as_array() {
            Some(e) => e.iter().collect(),
            None => dir["oneOf"]
                .as_array()
                .map(|o| o.iter().map(|v| &v["const"]).collect())
                .unwrap_or_default(),
        };
        assert_eq!(
            words,
            [&serde_json::json!("tx"), &serde_json::json!("rx")],
            "{dir}"
        );
        let log = Topic::Log.schema();
        assert_eq!(log["properties"]["level"]["maximum"], 5);
        assert_eq!(
            log["properties"]["timestamp"]["properties"]["nsec"]["maximum"],
            999_999_999
        );
    }
}
