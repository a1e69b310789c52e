//! The client protocol of `host-tool serve`, one type each way: a [`Request`] line from a
//! client, [`Reply`] lines back (JSON, one object per line, over the server's Unix socket).
//! The server (`cmd/serve`) and every client (`client`, and through it `status`, `stop`,
//! `declare`, `param`, `monitor`, `identify`, `plan`, `reach`, `run` and the primitives) read
//! and write these types only; nothing else spells an `"op"`.
//!
//! - `{"op":"snapshot","request":R}` (R: a [`protocol::RequestBody`] or null/absent) →
//!   [`Reply::Snapshot`] `{"status", "info", "truth", "abort_latency_ms"}`
//! - `{"op":"call","request":R}` → [`Reply::Call`] `{"result", "body"}`
//! - `{"op":"monitor"}` → [`Reply::Event`] `{"event"}` lines until the client hangs up
//! - `{"op":"plan","target":"D&D"}` → [`Reply::Note`] `{"note"}` lines, then
//!   [`Reply::Outcome`] `{"outcome", "ok"}` (the outcome is `plan --json`'s document)
//! - `{"op":"identify"}` → as `plan`, the run identifying the state
//!
//! Any request may instead be answered by [`Reply::Error`] `{"error"}`: a line that is not a
//! request (bad JSON, an unknown `op`, a missing or malformed field) is answered so, with
//! serde's reason, and the server goes on serving.

use geometry::TrunkState;
use protocol::{DeviceInfo, Event, Plan, RequestBody, ResponseBody, ResultCode, Status, Step};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::sim::SimTruth;

/// A client's request line.
///
/// Read through a JSON value, not by serde's derive for a tagged enum: the derive buffers the
/// line in serde's own content type, which cannot hold serde_json's `arbitrary_precision`
/// numbers (a feature `defmt-decoder` turns on wherever the workspace is built together: every
/// number inside a request then fails to parse); a value keeps them.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum Request {
    /// The request, if any (`stop`: an abort, sent ahead of anything queued; `declare`), then
    /// the device's status.
    Snapshot {
        /// What to send first; `None`: only the status.
        #[serde(default)]
        request: Option<DeviceRequest>,
    },
    /// One request, its answer returned as the device gave it (`param`, the primitives).
    Call {
        /// The request.
        request: DeviceRequest,
    },
    /// Every device event but heartbeats, as it comes.
    Monitor,
    /// Runs a plan to `target` (one at a time per server).
    Plan {
        /// The state to reach, by name (`D&F`).
        #[serde(with = "crate::state_name")]
        target: TrunkState,
    },
    /// Runs the identification of an unconfirmed state.
    Identify,
}

/// A line from the server.
///
/// Untagged: each variant is told by its keys (`error`, `status`, `result`, `event`, `note`,
/// `outcome`), which no two share. Read through a JSON value, as [`Request`] is.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Reply {
    /// The request failed, or was not a request.
    Error {
        /// Why.
        error: String,
    },
    /// The answer to [`Request::Snapshot`].
    Snapshot {
        /// The device's status after the request.
        status: Status,
        /// Who the device is (from the server's handshake).
        info: DeviceInfo,
        /// The simulator's ground truth, when the server runs the simulator.
        truth: Option<SimTruth>,
        /// After an abort: engine ms from the request's arrival to the device's answer.
        abort_latency_ms: Option<u64>,
    },
    /// The answer to [`Request::Call`].
    Call {
        /// The device's result code.
        result: ResultCode,
        /// Its answer.
        body: ResponseBody,
    },
    /// A device event ([`Request::Monitor`]).
    Event {
        /// The event.
        event: Event,
    },
    /// A line of a run's progress ([`Request::Plan`], [`Request::Identify`]).
    Note {
        /// The text.
        note: String,
    },
    /// How a run ended.
    Outcome {
        /// `plan --json`'s outcome document.
        outcome: Box<crate::outcome::PlanOutcome>,
        /// Whether the run reached its target.
        ok: bool,
    },
}

impl Reply {
    /// The reply's kind, for "expected X, got Y" messages.
    pub fn kind(&self) -> &'static str {
        match self {
            Reply::Error { .. } => "error",
            Reply::Snapshot { .. } => "snapshot",
            Reply::Call { .. } => "call",
            Reply::Event { .. } => "event",
            Reply::Note { .. } => "note",
            Reply::Outcome { .. } => "outcome",
        }
    }

    /// An error line.
    pub fn error(e: impl std::fmt::Display) -> Self {
        Reply::Error {
            error: e.to_string(),
        }
    }
}

/// A device request in the server's protocol: [`RequestBody`]'s serde form, except that a
/// step (and a plan) is written as the sequence its `Deserialize` reads (the wire's in-place
/// form takes a struct's fields in order and refuses a map).
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceRequest(pub RequestBody);

impl From<RequestBody> for DeviceRequest {
    fn from(r: RequestBody) -> Self {
        Self(r)
    }
}

impl Serialize for DeviceRequest {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        // The variant indices are `RequestBody`'s declaration order (unused by JSON).
        match &self.0 {
            RequestBody::UploadPlan(plan) => {
                s.serialize_newtype_variant("RequestBody", 3, "UploadPlan", &PlanSeq(plan))
            }
            RequestBody::RunStep(step) => {
                s.serialize_newtype_variant("RequestBody", 5, "RunStep", &StepSeq(step))
            }
            other => other.serialize(s),
        }
    }
}

/// [`Request`] as serde's derive reads it, variant by variant.
mod wire {
    use super::*;

    #[derive(Deserialize)]
    pub struct Snapshot {
        #[serde(default)]
        pub request: Option<DeviceRequest>,
    }
    #[derive(Deserialize)]
    pub struct Call {
        pub request: DeviceRequest,
    }
    #[derive(Deserialize)]
    pub struct Plan {
        #[serde(with = "crate::state_name")]
        pub target: TrunkState,
    }
    #[derive(Deserialize)]
    pub struct Error {
        pub error: String,
    }
    #[derive(Deserialize)]
    pub struct Snap {
        pub status: Status,
        pub info: DeviceInfo,
        #[serde(default)]
        pub truth: Option<SimTruth>,
        #[serde(default)]
        pub abort_latency_ms: Option<u64>,
    }
    #[derive(Deserialize)]
    pub struct CallReply {
        pub result: ResultCode,
        pub body: ResponseBody,
    }
    #[derive(Deserialize)]
    pub struct EventReply {
        pub event: Event,
    }
    #[derive(Deserialize)]
    pub struct Note {
        pub note: String,
    }
    #[derive(Deserialize)]
    pub struct Outcome {
        pub outcome: Box<crate::outcome::PlanOutcome>,
        pub ok: bool,
    }
}

/// `T` from a JSON value, the error in `D`'s terms.
fn from_value<'de, D: Deserializer<'de>, T: serde::de::DeserializeOwned>(
    v: serde_json::Value,
) -> Result<T, D::Error> {
    serde_json::from_value(v).map_err(serde::de::Error::custom)
}

impl<'de> Deserialize<'de> for Request {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        const OPS: &[&str] = &["snapshot", "call", "monitor", "plan", "identify"];
        let v = serde_json::Value::deserialize(d)?;
        if !v.is_object() {
            return Err(D::Error::invalid_type(
                serde::de::Unexpected::Other("a JSON value that is not an object"),
                &"a request object with an `op`",
            ));
        }
        let op = match v.get("op") {
            Some(serde_json::Value::String(op)) => op.clone(),
            Some(_) => return Err(D::Error::custom("`op` must be a string")),
            None => return Err(D::Error::missing_field("op")),
        };
        Ok(match op.as_str() {
            "snapshot" => Request::Snapshot {
                request: from_value::<D, wire::Snapshot>(v)?.request,
            },
            "call" => Request::Call {
                request: from_value::<D, wire::Call>(v)?.request,
            },
            "monitor" => Request::Monitor,
            "plan" => Request::Plan {
                target: from_value::<D, wire::Plan>(v)?.target,
            },
            "identify" => Request::Identify,
            other => return Err(D::Error::unknown_variant(other, OPS)),
        })
    }
}

impl<'de> Deserialize<'de> for Reply {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let v = serde_json::Value::deserialize(d)?;
        let has = |k: &str| v.get(k).is_some();
        if has("error") {
            let r: wire::Error = from_value::<D, _>(v)?;
            Ok(Reply::Error { error: r.error })
        } else if has("status") {
            let r: wire::Snap = from_value::<D, _>(v)?;
            Ok(Reply::Snapshot {
                status: r.status,
                info: r.info,
                truth: r.truth,
                abort_latency_ms: r.abort_latency_ms,
            })
        } else if has("result") {
            let r: wire::CallReply = from_value::<D, _>(v)?;
            Ok(Reply::Call {
                result: r.result,
                body: r.body,
            })
        } else if has("event") {
            let r: wire::EventReply = from_value::<D, _>(v)?;
            Ok(Reply::Event { event: r.event })
        } else if has("note") {
            let r: wire::Note = from_value::<D, _>(v)?;
            Ok(Reply::Note { note: r.note })
        } else if has("outcome") {
            let r: wire::Outcome = from_value::<D, _>(v)?;
            Ok(Reply::Outcome {
                outcome: r.outcome,
                ok: r.ok,
            })
        } else {
            Err(D::Error::custom(
                "data did not match any variant of untagged enum Reply",
            ))
        }
    }
}

impl<'de> Deserialize<'de> for DeviceRequest {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        RequestBody::deserialize(d).map(Self)
    }
}

/// A step as its fields in order.
struct StepSeq<'a>(&'a Step);

impl Serialize for StepSeq<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let st = self.0;
        (st.kind, st.from, st.to, &st.primitives, st.timeout_ms).serialize(s)
    }
}

/// A plan as its fields in order, its steps as [`StepSeq`].
struct PlanSeq<'a>(&'a Plan);

impl Serialize for PlanSeq<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let steps: Vec<StepSeq<'_>> = self.0.steps.iter().map(StepSeq).collect();
        (self.0.plan_id, steps).serialize(s)
    }
}

#[cfg(test)]
mod tests {

    /// A line the CI's workspace-built host-tool failed to read (`arbitrary_precision`, turned
    /// on by defmt-decoder, breaks serde's derive for untagged and tagged enums): a snapshot
    /// after an abort, floats and all, and a call whose request carries numbers.
    #[test]
    fn lines_with_numbers_read_whatever_serde_json_features_are_on() {
        let snap = r#"{"status":{"state":{"top":"Folded","bottom":"Packed"},"state_confirmed":true,"candidates":1,"interrupted":null,"mode":"Safe","pressure_kpa":0.19604324,"servo_deg":[0.0,0.0,0.0],"inlet_open":false,"exhaust_open":false,"gripper_closed":true,"estop":false,"plan":{"plan_id":1,"step":0,"steps":3,"phase":"Aborted"},"manual_task":null,"faults":0,"frames_rx":8,"frames_dropped":0,"uptime_ms":55},"info":{"protocol_version":2,"schema_id":1926739351,"firmware_version":[0,1,0],"board":"Simulator","trunk":{"bottom":{"n":3,"beta_deg":35.0,"edge_mm":75.0,"layers":2},"top":{"n":3,"beta_deg":31.72,"edge_mm":75.0,"layers":2},"pressure_limit_kpa":40.0},"session":1973720947,"reset_cause":"Unknown","signing":false},"truth":null,"abort_latency_ms":1}"#;
        match serde_json::from_str::<Reply>(snap).expect("a snapshot") {
            Reply::Snapshot {
                status,
                abort_latency_ms,
                truth,
                ..
            } => {
                assert!((status.pressure_kpa - 0.196_043_24).abs() < 1e-6);
                assert_eq!((abort_latency_ms, truth), (Some(1), None));
            }
            other => panic!("{other:?}"),
        }
        let call = Request::Call {
            request: DeviceRequest(RequestBody::SetParam {
                id: protocol::messages::ParamId::PressureLimitKpa,
                value: 32.5,
            }),
        };
        let line = serde_json::to_string(&call).unwrap();
        assert_eq!(
            serde_json::from_str::<Request>(&line).unwrap(),
            call,
            "{line}"
        );
    }
    use super::*;
    use protocol::{Primitive, StepKind};

    fn step() -> Step {
        let d_f: TrunkState = "D&F".parse().expect("a state");
        let mut step = planner::task::step_within(
            d_f,
            StepKind::Tendon,
            &[Primitive::Hold { duration_ms: 250 }],
        );
        step.timeout_ms = 5_000;
        step
    }

    fn round_trip_request(r: &Request) -> String {
        let line = serde_json::to_string(r).expect("a request serialises");
        let back: Request = serde_json::from_str(&line).expect("and reads back");
        assert_eq!(&back, r, "{line}");
        line
    }

    #[test]
    fn every_request_round_trips_with_the_wire_bytes_it_always_had() {
        let d_f: TrunkState = "D&F".parse().expect("a state");
        let cases = [
            (
                Request::Snapshot { request: None },
                r#"{"op":"snapshot","request":null}"#.to_string(),
            ),
            (
                Request::Snapshot {
                    request: Some(RequestBody::Abort.into()),
                },
                r#"{"op":"snapshot","request":"Abort"}"#.into(),
            ),
            (
                Request::Snapshot {
                    request: Some(RequestBody::DeclareState(d_f).into()),
                },
                r#"{"op":"snapshot","request":{"DeclareState":{"top":"Deployed","bottom":"Folded"}}}"#
                    .into(),
            ),
            (
                Request::Call {
                    request: RequestBody::GetParam(protocol::ParamId::TelemetryHz).into(),
                },
                r#"{"op":"call","request":{"GetParam":"TelemetryHz"}}"#.into(),
            ),
            (Request::Monitor, r#"{"op":"monitor"}"#.into()),
            (
                Request::Plan { target: d_f },
                r#"{"op":"plan","target":"D&F"}"#.into(),
            ),
            (Request::Identify, r#"{"op":"identify"}"#.into()),
        ];
        for (r, wire) in cases {
            assert_eq!(round_trip_request(&r), wire);
        }
    }

    #[test]
    fn a_step_and_a_plan_travel_in_the_sequence_form_the_wire_types_read() {
        let r = Request::Call {
            request: RequestBody::RunStep(step()).into(),
        };
        let line = round_trip_request(&r);
        assert_eq!(
            line,
            r#"{"op":"call","request":{"RunStep":["Tendon",{"top":"Deployed","bottom":"Folded"},{"top":"Deployed","bottom":"Folded"},[{"Hold":{"duration_ms":250}}],5000]}}"#
        );
        let mut with_steps = Plan {
            plan_id: 7,
            steps: Default::default(),
        };
        for _ in 0..2 {
            with_steps.steps.push(step()).expect("room for two steps");
        }
        let plan = Request::Call {
            request: RequestBody::UploadPlan(with_steps).into(),
        };
        assert!(round_trip_request(&plan).contains(r#"{"UploadPlan":[7,[["Tendon""#));
        // The derive's map form of a step is what the wire type refuses.
        let map = serde_json::json!({"op": "call", "request": {"RunStep": step()}});
        assert!(serde_json::from_value::<Request>(map).is_err());
    }

    #[test]
    fn a_state_is_read_by_the_parser_and_a_bad_one_is_named() {
        let r: Request = serde_json::from_str(r#"{"op":"plan","target":"d-f"}"#).expect("read");
        assert_eq!(
            r,
            Request::Plan {
                target: "D&F".parse().expect("a state")
            }
        );
        let e = serde_json::from_str::<Request>(r#"{"op":"plan","target":"X&Y"}"#)
            .expect_err("no such state")
            .to_string();
        assert!(e.contains("invalid trunk state 'X&Y'"), "{e}");
        assert!(e.contains(geometry::trunk::VALID_STATES_TEXT), "{e}");
        // A missing request of a snapshot is none.
        let r: Request = serde_json::from_str(r#"{"op":"snapshot"}"#).expect("read");
        assert_eq!(r, Request::Snapshot { request: None });
    }

    #[test]
    fn an_unknown_or_malformed_request_is_an_error_that_says_why() {
        for (line, why) in [
            (r#"{"op":"dance"}"#, "unknown variant `dance`"),
            (r#"{"target":"D&F"}"#, "missing field `op`"),
            (r#"{"op":"plan"}"#, "missing field `target`"),
            (r#"{"op":"call"}"#, "missing field `request`"),
            (
                r#"{"op":"call","request":{"Fly":1}}"#,
                "unknown variant `Fly`",
            ),
            (r#"{"op":"plan","target":7}"#, "invalid type"),
            ("[1,2]", "invalid type"),
            ("not json", "expected"),
        ] {
            let e = serde_json::from_str::<Request>(line)
                .expect_err(line)
                .to_string();
            assert!(e.contains(why), "{line}: {e}");
        }
    }

    #[test]
    fn every_reply_round_trips_as_its_own_variant() {
        let truth = SimTruth {
            true_state: Some("F&P".parse().expect("a state")),
            max_pressure_kpa: 12.5,
            pressure_limit_kpa: 60.0,
            actuators_safe: true,
        };
        let replies = [
            Reply::error("a plan is already running on this server"),
            Reply::Call {
                result: ResultCode::Ok,
                body: ResponseBody::Param {
                    id: protocol::ParamId::TelemetryHz,
                    value: 10.0,
                },
            },
            Reply::Event {
                event: Event::Heartbeat {
                    uptime_ms: 1234,
                    mode: protocol::Mode::Standalone,
                },
            },
            Reply::Note {
                note: "step 1/2 started".into(),
            },
            Reply::Outcome {
                outcome: Box::new(crate::outcome::PlanOutcome {
                    ok: true,
                    from: Some("F&P".into()),
                    target: Some("D&D".into()),
                    final_state: Some("D&D".into()),
                    state_confirmed: true,
                    candidates: None,
                    identified: false,
                    steps: Vec::new(),
                    error: None,
                    fault_code: None,
                    failure: None,
                    sim: None,
                }),
                ok: true,
            },
        ];
        for r in replies {
            let line = serde_json::to_string(&r).expect("serialises");
            let back: Reply = serde_json::from_str(&line).expect("reads back");
            assert_eq!(back, r, "{line}");
        }
        // The snapshot, with its truth (NaN travels as null and comes back NaN).
        let line = serde_json::to_string(&truth).expect("serialises");
        assert_eq!(
            line,
            r#"{"true_state":"F&P","max_pressure_kpa":12.5,"pressure_limit_kpa":60.0,"actuators_safe":true}"#
        );
        let nan = SimTruth {
            true_state: None,
            max_pressure_kpa: f32::NAN,
            ..truth
        };
        let back: SimTruth =
            serde_json::from_str(&serde_json::to_string(&nan).expect("serialises")).expect("reads");
        assert!(back.true_state.is_none() && back.max_pressure_kpa.is_nan());
        assert_eq!(back.pressure_limit_kpa, 60.0);
    }

    #[test]
    fn a_snapshot_of_the_simulated_device_round_trips() {
        let mut sim = hil_sim::Sim::new(hil_sim::SimOptions::default());
        let mut host = hil_sim::host::SimHost::new();
        let ResponseBody::Hello(info) = host.hello(&mut sim).expect("handshake") else {
            panic!("the handshake answers Hello");
        };
        let ResponseBody::Status(status) = host
            .request_ok(&mut sim, RequestBody::GetStatus, 1_000)
            .expect("a status")
        else {
            panic!("GetStatus answers Status");
        };
        let r = Reply::Snapshot {
            status,
            info,
            truth: Some(sim.ground_truth().into()),
            abort_latency_ms: Some(3),
        };
        let line = serde_json::to_string(&r).expect("serialises");
        let back: Reply = serde_json::from_str(&line).expect("reads back");
        assert_eq!(back, r, "{line}");
        assert_eq!(back.kind(), "snapshot");
    }
}
