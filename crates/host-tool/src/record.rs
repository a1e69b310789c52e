//! Recording a session to MCAP: [`Recorder`] wraps the engine's I/O ([`host::Io`]), forwards
//! every byte and records it — raw frames on `/frames`, decoded requests and responses, the
//! device's telemetry, events, faults and state — so the engine itself stays untouched. The
//! shell adds what only it sees (the plan, run events) through [`Recorder::recording`].
//!
//! Every message is JSON with a JSON schema (`crane.*`), or Foxglove's well-known `foxglove.Log`
//! for the human-readable lines; each channel's messages are one typed struct of [`messages`]
//! and its schema is derived from it (`schemars`). Log time is the device's time (its uptime, ns): messages that
//! carry the uptime are stamped with it, the others with the host's receive time plus the latest
//! device − host offset, never going back. The host's time (the I/O's clock: ms since the port
//! was opened, or the simulator's virtual clock) is the publish time and a `host_ms` field.
//!
//! Chunks (LZ4) are closed at least every [`FLUSH_PERIOD_MS`] of host time and written out, so
//! a writer that dies leaves a file readable up to its last chunk (`host-tool log recover`, or
//! any reader that reads linearly without the summary).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use host::{text, RunEvent};
use protocol::{DeviceMessage, Event, Request, ResponseBody, Telemetry};
use serde_json::{json, Value};

pub mod live;
pub mod messages;

use messages as msg;
use messages::{RunDetail, RunKind};

use crate::outcome::PlanOutcome;
pub use messages::Message;

/// Longest stretch of host time between closed chunks.
pub const FLUSH_PERIOD_MS: u64 = 1000;
/// Chunks are closed at this size too.
const CHUNK_SIZE: u64 = 256 * 1024;
/// Ground-truth samples per second (simulator only).
pub const TRUTH_HZ: u64 = 50;
/// Shortest host time between two scenes while the bend or the pressure moves: 20 Hz.
pub const SCENE_PERIOD_MS: u64 = 50;
/// Longest host time between two scenes (a viewer that joins sees the trunk within it).
pub const SCENE_KEEPALIVE_MS: u64 = 1000;

/// The recording's channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Topic {
    /// Device telemetry samples.
    Telemetry,
    /// Device events (all but telemetry).
    Events,
    /// Faults raised and cleared.
    Faults,
    /// The device's state and its confidence.
    State,
    /// Human-readable lines (foxglove.Log).
    Log,
    /// Requests sent, decoded.
    Requests,
    /// Responses received, decoded.
    Responses,
    /// Raw frames, both directions.
    Frames,
    /// The plan (and every replan).
    Plan,
    /// The plan runner's events.
    Run,
    /// The simulator's ground truth.
    Truth,
    /// The trunk's 3D shape (`foxglove.SceneUpdate`, protobuf).
    Scene,
    /// The tip's frame (`foxglove.FrameTransforms`, protobuf).
    Transforms,
}

/// Every topic, in channel-id order.
pub const TOPICS: [Topic; 13] = [
    Topic::Telemetry,
    Topic::Events,
    Topic::Faults,
    Topic::State,
    Topic::Log,
    Topic::Requests,
    Topic::Responses,
    Topic::Frames,
    Topic::Plan,
    Topic::Run,
    Topic::Truth,
    Topic::Scene,
    Topic::Transforms,
];

impl Topic {
    /// The MCAP topic.
    pub const fn name(self) -> &'static str {
        match self {
            Topic::Telemetry => "/telemetry",
            Topic::Events => "/events",
            Topic::Faults => "/faults",
            Topic::State => "/state",
            Topic::Log => "/log",
            Topic::Requests => "/link/requests",
            Topic::Responses => "/link/responses",
            Topic::Frames => "/link/frames",
            Topic::Plan => "/plan",
            Topic::Run => "/run",
            Topic::Truth => "/sim/truth",
            Topic::Scene => "/scene",
            Topic::Transforms => "/tf",
        }
    }

    /// The schema's name.
    pub const fn schema_name(self) -> &'static str {
        match self {
            Topic::Telemetry => "crane.Telemetry",
            Topic::Events => "crane.Event",
            Topic::Faults => "crane.Fault",
            Topic::State => "crane.State",
            Topic::Log => "foxglove.Log",
            Topic::Requests => "crane.Request",
            Topic::Responses => "crane.Response",
            Topic::Frames => "crane.RawFrame",
            Topic::Plan => "crane.Plan",
            Topic::Run => "crane.RunEvent",
            Topic::Truth => "crane.GroundTruth",
            Topic::Scene => "foxglove.SceneUpdate",
            Topic::Transforms => "foxglove.FrameTransforms",
        }
    }

    /// How its messages are encoded: `json`, or `protobuf` for Foxglove's scene types.
    pub const fn message_encoding(self) -> &'static str {
        match self {
            Topic::Scene | Topic::Transforms => "protobuf",
            _ => "json",
        }
    }

    /// The schema as written to the file and advertised live: (encoding, data).
    pub fn schema_record(self) -> (&'static str, Vec<u8>) {
        use foxglove::Encode as _;
        let sdk = match self {
            Topic::Scene => foxglove::messages::SceneUpdate::get_schema(),
            Topic::Transforms => foxglove::messages::FrameTransforms::get_schema(),
            _ => None,
        };
        match sdk {
            Some(s) => ("protobuf", s.data.into_owned()),
            None => (
                "jsonschema",
                serde_json::to_vec(&self.schema()).expect("a JSON value serialises"),
            ),
        }
    }

    /// The JSON schema of its messages: derived from the channel's message type
    /// ([`messages`]); `{}` for the protobuf channels (their schema is the SDK's descriptor,
    /// [`Topic::schema_record`]).
    pub fn schema(self) -> Value {
        match self {
            Topic::Telemetry => msg::schema::<msg::Telemetry>(),
            Topic::Events => msg::schema::<msg::Event>(),
            Topic::Faults => msg::schema::<msg::Fault>(),
            Topic::State => msg::schema::<msg::State>(),
            Topic::Log => msg::schema::<msg::Log>(),
            Topic::Requests => msg::schema::<msg::Request>(),
            Topic::Responses => msg::schema::<msg::Response>(),
            Topic::Frames => msg::schema::<msg::RawFrame>(),
            Topic::Plan => msg::schema::<msg::Plan>(),
            Topic::Run => msg::schema::<msg::Run>(),
            Topic::Truth => msg::schema::<msg::Truth>(),
            Topic::Scene | Topic::Transforms => json!({}),
        }
    }
}

/// `foxglove.Log` levels.
#[derive(Debug, Clone, Copy)]
pub enum Level {
    /// Information.
    Info = 2,
    /// Something went wrong but the run goes on.
    Warning = 3,
    /// A fault or failure.
    Error = 4,
}

/// An open MCAP recording.
pub struct Recording {
    path: PathBuf,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    channels: [u16; TOPICS.len()],
    sequence: u32,
    counts: [u64; TOPICS.len()],
    /// Device − host clock offset, ms, from the latest message that carried the uptime.
    offset_ms: Option<i64>,
    last_log_ns: u64,
    last_flush_ms: u64,
    failed: Option<String>,
    /// The live view, if one is served: every message goes there too.
    live: Option<crate::record::live::Live>,
    /// The trunk's scene builder (from the device's handshake).
    scene: Option<crate::scene::Scene>,
    /// The last sample drawn, and when (host ms).
    last_scene: Option<(crate::scene::Sample, u64)>,
}

impl std::fmt::Debug for Recording {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recording")
            .field("path", &self.path)
            .field("counts", &self.counts)
            .finish_non_exhaustive()
    }
}

impl Recording {
    /// Creates `path` (replacing it) and writes the header, schemas, channels and `metadata`
    /// (a `session` record: the command, the device, the host clock's start).
    pub fn create(path: &Path, metadata: BTreeMap<String, String>) -> anyhow::Result<Self> {
        use anyhow::Context as _;
        let file = File::create(path)
            .with_context(|| format!("cannot create the recording {}", path.display()))?;
        let mut w = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Lz4))
            .chunk_size(Some(CHUNK_SIZE))
            .profile("")
            .library(concat!("host-tool ", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::new(file))
            .with_context(|| format!("cannot write the recording {}", path.display()))?;
        let mut channels = [0u16; TOPICS.len()];
        for (i, t) in TOPICS.iter().enumerate() {
            let (encoding, schema) = t.schema_record();
            let sid = w.add_schema(t.schema_name(), encoding, &schema)?;
            channels[i] = w.add_channel(sid, t.name(), t.message_encoding(), &BTreeMap::new())?;
        }
        w.write_metadata(&mcap::records::Metadata {
            name: "session".into(),
            metadata,
        })?;
        w.flush()?;
        Ok(Self::new(path.to_path_buf(), Some(w), channels, None))
    }

    /// No file: the messages go to the live view only.
    pub fn live_only(live: crate::record::live::Live) -> Self {
        Self::new(PathBuf::new(), None, [0; TOPICS.len()], Some(live))
    }

    fn new(
        path: PathBuf,
        writer: Option<mcap::Writer<BufWriter<File>>>,
        channels: [u16; TOPICS.len()],
        live: Option<crate::record::live::Live>,
    ) -> Self {
        Self {
            path,
            writer,
            channels,
            sequence: 0,
            counts: [0; TOPICS.len()],
            offset_ms: None,
            last_log_ns: 0,
            last_flush_ms: 0,
            failed: None,
            live,
            scene: None,
            last_scene: None,
        }
    }

    /// Serves every message live too.
    pub fn attach_live(&mut self, live: crate::record::live::Live) {
        self.live = Some(live);
    }

    /// Whether a message on `topic` goes anywhere (a file, or a live subscriber).
    fn wanted(&self, topic: Topic) -> bool {
        self.writer.is_some() || self.live.as_ref().is_some_and(|l| l.wanted(topic))
    }

    /// Writes one message on its channel. `device_ms`: the device's time if the message
    /// carries it.
    pub fn write<M: Message>(&mut self, host_ms: u64, device_ms: Option<u64>, msg: &M) {
        let data = if self.wanted(M::TOPIC) {
            // Only a map with non-string keys fails; no message holds one.
            serde_json::to_vec(msg).unwrap_or_default()
        } else {
            Vec::new()
        };
        self.write_bytes(M::TOPIC, host_ms, device_ms, &data);
    }

    /// Writes one encoded message (the log time as [`Recording::write`]); the file's copy and
    /// the live one are the same bytes.
    pub fn write_bytes(&mut self, topic: Topic, host_ms: u64, device_ms: Option<u64>, data: &[u8]) {
        if let Some(d) = device_ms {
            self.offset_ms = Some(d as i64 - host_ms as i64);
        }
        let log_ms = device_ms
            .unwrap_or_else(|| (host_ms as i64 + self.offset_ms.unwrap_or(0)).max(0) as u64);
        let log_ns = (log_ms * 1_000_000).max(self.last_log_ns);
        self.last_log_ns = log_ns;
        if let (Some(live), false) = (&self.live, data.is_empty()) {
            live.log(topic, data, log_ns);
        }
        let Some(w) = self.writer.as_mut() else {
            return;
        };
        self.sequence = self.sequence.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id: self.channels[topic as usize],
            sequence: self.sequence,
            log_time: log_ns,
            publish_time: host_ms * 1_000_000,
        };
        let mut result = w.write_to_known_channel(&header, data);
        if result.is_ok() && host_ms >= self.last_flush_ms + FLUSH_PERIOD_MS {
            self.last_flush_ms = host_ms;
            result = w.flush();
        }
        match result {
            Ok(()) => self.counts[topic as usize] += 1,
            Err(e) => self.fail(e),
        }
    }

    fn fail(&mut self, e: mcap::McapError) {
        let msg = format!("recording to {} stopped: {e}", self.path.display());
        crate::say!("{msg}");
        self.failed = Some(msg);
        // The chunks written so far stay readable; nothing more is written.
        if let Some(w) = self.writer.take() {
            std::mem::forget(w);
        }
    }

    /// A `foxglove.Log` line.
    pub fn log(&mut self, host_ms: u64, level: Level, name: &str, message: &str) {
        let ns = self.estimated_device_ns(host_ms);
        let v = msg::Log {
            timestamp: msg::Timestamp {
                sec: ns / 1_000_000_000,
                nsec: (ns % 1_000_000_000) as u32,
            },
            level: level as u8,
            message: message.to_string(),
            name: name.to_string(),
            file: "",
            line: 0,
        };
        self.write(host_ms, None, &v);
    }

    fn estimated_device_ns(&self, host_ms: u64) -> u64 {
        let ms = (host_ms as i64 + self.offset_ms.unwrap_or(0)).max(0) as u64;
        (ms * 1_000_000).max(self.last_log_ns)
    }

    /// A frame the host sent.
    pub fn tx_frame(&mut self, host_ms: u64, frame: &[u8]) {
        let mut copy = frame.to_vec();
        let decoded = protocol::decode::<Request>(&mut copy);
        self.raw(host_ms, msg::Dir::Tx, frame, decoded.is_ok(), None);
        if let Ok(req) = decoded {
            let v = msg::Request {
                host_ms,
                seq: req.seq,
                session: req.session,
                name: text::request_name(&req.body),
                body: serde_json::to_value(&req.body).unwrap_or(Value::Null),
            };
            self.write(host_ms, None, &v);
        }
    }

    /// A frame the device sent.
    pub fn rx_frame(&mut self, host_ms: u64, frame: &[u8]) {
        let mut copy = frame.to_vec();
        let decoded = protocol::decode::<DeviceMessage>(&mut copy);
        // The device's time, where the message carries it: the raw frame gets it too.
        let device_ms = match &decoded {
            Ok(DeviceMessage::Response {
                body: ResponseBody::Status(s),
                ..
            }) => Some(u64::from(s.uptime_ms)),
            Ok(DeviceMessage::Event(Event::Telemetry(t))) => Some(u64::from(t.uptime_ms)),
            Ok(DeviceMessage::Event(Event::Heartbeat { uptime_ms, .. })) => {
                Some(u64::from(*uptime_ms))
            }
            _ => None,
        };
        self.raw(host_ms, msg::Dir::Rx, frame, decoded.is_ok(), device_ms);
        match decoded {
            Ok(DeviceMessage::Response { seq, result, body }) => {
                if let ResponseBody::Hello(info) = &body {
                    self.set_trunk(&info.trunk);
                }
                let v = msg::Response {
                    host_ms,
                    seq,
                    result: serde_json::to_value(result).unwrap_or(Value::Null),
                    body: serde_json::to_value(&body).unwrap_or(Value::Null),
                };
                self.write(host_ms, device_ms, &v);
                if let ResponseBody::Status(s) = body {
                    let v = msg::State {
                        host_ms,
                        state: s.state.name(),
                        state_confirmed: s.state_confirmed,
                        candidates: s.candidates.iter().map(|c| c.name()).collect(),
                        source: "status",
                    };
                    self.write(host_ms, device_ms, &v);
                }
            }
            Ok(DeviceMessage::Event(ev)) => self.event(host_ms, &ev),
            Err(_) => {}
        }
    }

    fn raw(
        &mut self,
        host_ms: u64,
        dir: msg::Dir,
        frame: &[u8],
        decoded: bool,
        device_ms: Option<u64>,
    ) {
        let mut hex = String::with_capacity(frame.len() * 2);
        for b in frame {
            use std::fmt::Write as _;
            let _ = write!(hex, "{b:02x}");
        }
        let v = msg::RawFrame {
            host_ms,
            dir,
            len: frame.len(),
            hex,
            decoded,
        };
        self.write(host_ms, device_ms, &v);
    }

    /// The trunk the device reported: the scene is built for it.
    fn set_trunk(&mut self, trunk: &protocol::TrunkConfig) {
        match crate::scene::Scene::new(trunk) {
            Ok(s) => self.scene = Some(s),
            Err(e) => {
                self.scene = None;
                crate::say!("no 3D scene for the device's trunk: {e}");
            }
        }
        self.last_scene = None;
    }

    /// The scene and the tip's frame for a telemetry sample: at once when the state (or its
    /// confidence) changed; when the bend or the pressure moved, at most every
    /// [`SCENE_PERIOD_MS`]; and at least every [`SCENE_KEEPALIVE_MS`].
    fn draw(&mut self, host_ms: u64, t: &Telemetry) {
        let sample = crate::scene::Sample {
            state: t.state,
            confirmed: t.state_confirmed,
            servo_deg: t.servo_deg,
            pressure_kpa: t.pressure_kpa,
        };
        let due = match self.last_scene {
            None => true,
            Some((last, at)) => {
                let new_state = last.state != sample.state || last.confirmed != sample.confirmed;
                let moved = (0..3).any(|i| (last.servo_deg[i] - sample.servo_deg[i]).abs() >= 0.25)
                    || (last.pressure_kpa - sample.pressure_kpa).abs() >= 0.25;
                new_state
                    || (moved && host_ms >= at + SCENE_PERIOD_MS)
                    || host_ms >= at + SCENE_KEEPALIVE_MS
            }
        };
        if !due || !(self.wanted(Topic::Scene) || self.wanted(Topic::Transforms)) {
            return;
        }
        let Some(scene) = self.scene.as_mut() else {
            return;
        };
        let device_ms = u64::from(t.uptime_ms);
        match scene.build(&sample, device_ms * 1_000_000) {
            Ok((update, tf)) => {
                use foxglove::Encode as _;
                let mut buf = Vec::new();
                let _ = update.encode(&mut buf);
                self.write_bytes(Topic::Scene, host_ms, Some(device_ms), &buf);
                buf.clear();
                let _ = tf.encode(&mut buf);
                self.write_bytes(Topic::Transforms, host_ms, Some(device_ms), &buf);
            }
            Err(e) => {
                crate::say!("no 3D scene for {}: {e}", sample.state);
                self.scene = None;
            }
        }
        self.last_scene = Some((sample, host_ms));
    }

    fn event(&mut self, host_ms: u64, ev: &Event) {
        if let Event::Telemetry(t) = ev {
            self.write(
                host_ms,
                Some(u64::from(t.uptime_ms)),
                &telemetry(t, host_ms),
            );
            self.draw(host_ms, t);
            return;
        }
        let device_ms = match ev {
            Event::Heartbeat { uptime_ms, .. } => Some(u64::from(*uptime_ms)),
            _ => None,
        };
        let (kind, line) = text::event(ev);
        let v = msg::Event {
            host_ms,
            kind,
            text: line.clone(),
            event: match msg::DeviceEvent::of(ev) {
                Some(e) => e,
                None => return,
            },
        };
        self.write(host_ms, device_ms, &v);
        match ev {
            Event::FaultRaised(f) | Event::FaultCleared(f) => {
                let raised = matches!(ev, Event::FaultRaised(_));
                let v = msg::Fault {
                    host_ms,
                    raised,
                    code: text::fault_code(*f),
                    text: text::fault(*f),
                };
                self.write(host_ms, None, &v);
            }
            Event::StateReached { state, confirmed } => {
                let v = msg::State {
                    host_ms,
                    state: state.name(),
                    state_confirmed: *confirmed,
                    candidates: if *confirmed {
                        vec![state.name()]
                    } else {
                        vec![]
                    },
                    source: "state-reached",
                };
                self.write(host_ms, None, &v);
            }
            Event::IdentifyNeedsOperator { candidates } => {
                let names: Vec<&str> = candidates.iter().map(|c| c.name()).collect();
                let v = msg::State {
                    host_ms,
                    state: names.first().copied().unwrap_or(""),
                    state_confirmed: false,
                    candidates: names,
                    source: "identify-needs-operator",
                };
                self.write(host_ms, None, &v);
            }
            _ => {}
        }
        if let Some(line) = line {
            let level = match ev {
                Event::FaultRaised(_) => Level::Error,
                Event::StepDone { ok: false, .. } | Event::PlanDone { ok: false, .. } => {
                    Level::Warning
                }
                _ => Level::Info,
            };
            self.log(host_ms, level, "device", &line);
        }
    }

    /// A plan-runner event (from the shell).
    pub fn run_event(&mut self, host_ms: u64, ev: &RunEvent) {
        let (kind, line, detail) = match ev {
            RunEvent::Plan { plan, replan } => {
                let steps = plan
                    .steps()
                    .iter()
                    .map(|s| msg::PlanStep {
                        kind: planner::graph::kind_name(s.edge.kind()),
                        from: s.edge.from().name(),
                        to: s.edge.to().name(),
                        expected_s: s.edge.cost_s,
                        timeout_ms: s.edge.transition.timeout_ms,
                        why: s.why.clone(),
                    })
                    .collect();
                let v = msg::Plan {
                    host_ms,
                    from: plan.from().name(),
                    target: plan.target().name(),
                    replan: *replan,
                    expected_s: plan.cost_s(),
                    steps,
                };
                self.write(host_ms, None, &v);
                let text = format!(
                    "{}plan {} → {}: {} steps",
                    if *replan { "re" } else { "" },
                    plan.from(),
                    plan.target(),
                    plan.steps().len()
                );
                (RunKind::Plan, text, RunDetail::None)
            }
            RunEvent::StepStarted { index, total } => (
                RunKind::StepStarted,
                format!("step {}/{} started", index + 1, total),
                RunDetail::StepStarted {
                    index: *index,
                    total: *total,
                },
            ),
            // At the telemetry rate: the samples carry it.
            RunEvent::StepProgress { .. } => return,
            RunEvent::ManualPrompt { index, task } => (
                RunKind::ManualPrompt,
                format!(
                    "step {}: manual task: {}",
                    index + 1,
                    planner::graph::manual_task_text(*task)
                ),
                RunDetail::ManualPrompt { index: *index },
            ),
            RunEvent::IdentifyPrompt {
                believed,
                candidates,
            } => {
                let names: Vec<&str> = candidates.iter().map(|c| c.name()).collect();
                let v = msg::State {
                    host_ms,
                    state: believed.name(),
                    state_confirmed: false,
                    candidates: names.clone(),
                    source: "identify-prompt",
                };
                self.write(host_ms, None, &v);
                (
                    RunKind::IdentifyPrompt,
                    format!("state unconfirmed; candidates {}", names.join(", ")),
                    RunDetail::IdentifyPrompt {
                        believed: believed.name(),
                        candidates: names,
                    },
                )
            }
            RunEvent::StepFinished { index, report } => (
                RunKind::StepFinished,
                format!(
                    "step {} {} → {} {}",
                    index + 1,
                    report.from,
                    report.to,
                    if report.ok { "done" } else { "FAILED" }
                ),
                RunDetail::StepFinished {
                    index: *index,
                    from: report.from.name(),
                    to: report.to.name(),
                    ok: report.ok,
                    duration_ms: report.duration_ms,
                    kind: planner::graph::kind_name(report.kind),
                },
            ),
            RunEvent::Note(m) => (RunKind::Note, m.clone(), RunDetail::None),
            RunEvent::Finished => (
                RunKind::Finished,
                "run finished".to_string(),
                RunDetail::None,
            ),
        };
        let v = msg::Run {
            host_ms,
            kind,
            text: line.clone(),
            detail,
        };
        self.write(host_ms, None, &v);
        self.log(host_ms, Level::Info, "run", &line);
    }

    /// The plan run's outcome (the `plan --json` object), on `/run` and `/log`.
    pub fn outcome(&mut self, host_ms: u64, outcome: &PlanOutcome) {
        let ok = outcome.ok;
        let line = if ok {
            "outcome: target reached".to_string()
        } else {
            format!(
                "outcome: FAILED: {}",
                outcome
                    .error
                    .as_deref()
                    .unwrap_or("the target was not reached")
            )
        };
        let v = msg::Run {
            host_ms,
            kind: RunKind::Outcome,
            text: line.clone(),
            detail: RunDetail::Outcome(Box::new(outcome.clone())),
        };
        self.write(host_ms, None, &v);
        let level = if ok { Level::Info } else { Level::Error };
        self.log(host_ms, level, "run", &line);
    }

    /// Writes the summary and closes the file; the error, if any write failed.
    pub fn finish(&mut self) -> Result<(), String> {
        if let Some(mut w) = self.writer.take() {
            if let Err(e) = w.finish() {
                return Err(format!("recording to {}: {e}", self.path.display()));
            }
        }
        self.failed.clone().map_or(Ok(()), Err)
    }
}

impl Drop for Recording {
    fn drop(&mut self) {
        if let Err(e) = self.finish() {
            crate::say!("{e}");
        }
    }
}

/// A telemetry sample as recorded (and as `monitor --json` prints its fields).
pub fn telemetry(t: &Telemetry, host_ms: u64) -> msg::Telemetry {
    msg::Telemetry {
        device_ms: t.uptime_ms,
        host_ms,
        pressure_kpa: t.pressure_kpa,
        servo_deg: t.servo_deg,
        inlet_open: t.inlet_open,
        exhaust_open: t.exhaust_open,
        state: t.state.name(),
        state_confirmed: t.state_confirmed,
    }
}

/// What an I/O can say about the world beyond the wire (the simulator's ground truth).
pub trait Truth {
    /// The ground truth now, as recorded on `/sim/truth` (`None`: a real device); its
    /// `host_ms` is set when it is recorded.
    fn truth(&self) -> Option<msg::Truth> {
        None
    }
}

impl Truth for crate::transport::AnyIo {
    fn truth(&self) -> Option<msg::Truth> {
        match self {
            crate::transport::AnyIo::Sim(io) => {
                let t = io.sim.ground_truth();
                let tip = io.sim.true_tip();
                let world = io.sim.world();
                Some(msg::Truth {
                    host_ms: 0,
                    tip_mm: tip.position_mm.map(|v| (v * 10.0).round() / 10.0),
                    tip_axis: tip.axis.map(|v| (v * 1e4).round() / 1e4),
                    objects: (!world.objects().is_empty())
                        .then(|| world.objects().iter().map(msg::TruthObject::of).collect()),
                    time_ms: t.time_ms,
                    true_state: t.true_state.map(|s| s.name()),
                    pressure_kpa: t.pressure_kpa,
                    max_pressure_kpa: t.max_pressure_kpa,
                    module_heights_mm: t.module_heights_mm,
                    bend_deg: t.bend_deg,
                    tendon_tension_n: t.tendon_tension_n,
                    servo_deg: t.servo_deg,
                    servos_energised: t.servos_energised,
                    inlet_open: t.inlet_open,
                    exhaust_open: t.exhaust_open,
                    gripper_closed: t.gripper_closed,
                    believed_state: t.believed_state.name(),
                    mode: text::mode(t.mode),
                    snaps: t.snaps,
                    actuators_safe: t.actuators_safe,
                })
            }
            crate::transport::AnyIo::Serial(_) => None,
        }
    }
}

/// The engine's I/O with a tap: forwards every call to `inner`, records what passes when a
/// [`Recording`] is attached, and traces it on stderr with `-v` ([`crate::trace`]).
pub struct Recorder<I> {
    /// The I/O that does the work.
    pub inner: I,
    recording: Option<Recording>,
    /// Bytes of the device's current, unfinished frame.
    rx_partial: Vec<u8>,
    next_truth_ms: u64,
    /// The debug trace of the frames (`-v`).
    trace: Option<crate::trace::Trace>,
}

impl<I> Recorder<I> {
    /// `inner`, recorded to `recording` (if any).
    pub fn new(inner: I, recording: Option<Recording>) -> Self {
        Self {
            inner,
            recording,
            rx_partial: Vec::new(),
            next_truth_ms: 0,
            trace: crate::trace::Trace::if_asked(),
        }
    }

    /// The recording, if one is attached.
    pub fn recording(&mut self) -> Option<&mut Recording> {
        self.recording.as_mut()
    }
}

impl<I: host::Io + Truth> host::Io for Recorder<I> {
    fn now_ms(&mut self) -> u64 {
        self.inner.now_ms()
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        if let Some(trace) = self.trace.as_mut() {
            let now = self.inner.now_ms();
            for line in trace.tx_lines(now, bytes) {
                crate::debug!("{line}");
            }
        }
        self.inner.write(bytes)?;
        if let Some(rec) = self.recording.as_mut() {
            let now = self.inner.now_ms();
            // A lone delimiter (sent to flush the device's decoder) is no frame.
            for frame in bytes.split_inclusive(|b| *b == 0).filter(|f| f != &[0]) {
                rec.tx_frame(now, frame);
            }
        }
        Ok(())
    }

    fn read(&mut self, deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
        let start = buf.len();
        self.inner.read(deadline_ms, buf)?;
        if let Some(trace) = self.trace.as_mut().filter(|_| buf.len() > start) {
            let now = self.inner.now_ms();
            for line in trace.rx_lines(now, &buf[start..]) {
                crate::debug!("{line}");
            }
        }
        let Some(rec) = self.recording.as_mut() else {
            return Ok(());
        };
        let now = self.inner.now_ms();
        for &b in &buf[start..] {
            self.rx_partial.push(b);
            if b == 0 {
                if self.rx_partial.len() > 1 {
                    rec.rx_frame(now, &self.rx_partial);
                }
                self.rx_partial.clear();
            } else if self.rx_partial.len() > 4 * protocol::MAX_FRAME_LEN {
                // Noise without delimiters: recorded as one undecodable frame.
                rec.rx_frame(now, &self.rx_partial);
                self.rx_partial.clear();
            }
        }
        if now >= self.next_truth_ms {
            if let Some(mut t) = self.inner.truth() {
                t.host_ms = now;
                rec.write(now, None, &t);
                // The simulator's world in the 3D scene, when it holds objects.
                if t.objects.is_some() && rec.wanted(Topic::Scene) {
                    let ns = t.time_ms * 1_000_000;
                    let sample = serde_json::to_value(&t).unwrap_or(Value::Null);
                    if let Some(update) = crate::scene::world_update(&sample, ns) {
                        use foxglove::Encode as _;
                        let mut buf = Vec::new();
                        let _ = update.encode(&mut buf);
                        rec.write_bytes(Topic::Scene, now, None, &buf);
                    }
                }
            }
            self.next_truth_ms = now + 1000 / TRUTH_HZ;
        }
        Ok(())
    }
}
