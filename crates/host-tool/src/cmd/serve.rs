//! `host-tool serve`: one process owns the link to a crane (or the simulator), keeps its
//! session and heartbeat, records it to MCAP, and serves local clients over a Unix socket —
//! `status`, `stop`, `declare`, `param`, `monitor`, `identify`, `plan` (and `run` and the primitives,
//! through `call`) from other terminals go through it.
//!
//! One thread: the engine ([`host::Host`], through the connection's driver) is turned in slices
//! of at most [`SLICE_MS`] of engine time; between slices the server accepts clients and reads
//! their requests (one JSON line each). A `stop` is sent with `request_first`, ahead of anything
//! queued, and cancels a running plan. The client protocol (JSON lines) is
//! [`crate::serve_protocol`]'s [`Request`] and [`Reply`].

use std::collections::HashMap;
use std::io::{Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::PathBuf;
use std::sync::atomic::Ordering;

use crate::device::{Connection, DeviceArgs, DeviceConfig};
use crate::failure::Failure;
use crate::serve_protocol::{DeviceRequest, Reply, Request};
use crate::transport::AnyIo;
use geometry::TrunkState;
use host::{HostEvent, Io as _, RequestId, RunEvent, RunOptions, SessionEvent};
use planner::graph::Graph;
use protocol::{Event, ParamId, RequestBody};

/// Longest slice of engine time between looks at the clients.
pub const SLICE_MS: u64 = 10;

/// Arguments of `host-tool serve`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Record the session to this MCAP file [default: host-tool-serve-UNIXTIME.mcap here].
    #[arg(long, value_name = "FILE.mcap", conflicts_with = "no_record")]
    pub record: Option<PathBuf>,
    /// Do not record.
    #[arg(long)]
    pub no_record: bool,
    /// Telemetry rate while serving, 1–50 Hz.
    #[arg(long, value_name = "HZ", default_value_t = 50, value_parser = crate::num::int_in(1, 50))]
    pub rate: u32,
    /// Serve the live view to Foxglove (WebSocket, foxglove.websocket.v1) on HOST:PORT, e.g.
    /// 127.0.0.1:8765 (PORT 0: any free port; the address is printed).
    #[arg(long, value_name = "HOST:PORT", value_parser = crate::record::live::parse_addr)]
    pub foxglove: Option<crate::record::live::LiveAddr>,
}

struct Conn {
    stream: UnixStream,
    buf: Vec<u8>,
    monitor: bool,
    alive: bool,
}

impl Conn {
    fn send(&mut self, v: &Reply) {
        let Ok(mut line) = serde_json::to_string(v) else {
            // Only a map with non-string keys fails; no reply holds one.
            return;
        };
        line.push('\n');
        // A client that does not read is dropped rather than allowed to stall the link.
        if self.stream.write_all(line.as_bytes()).is_err() {
            self.alive = false;
        }
    }
}

#[derive(Debug, Clone, Copy)]
enum Stage {
    /// The client's own request; its status follows.
    Request { abort_at: Option<u64> },
    /// The status after it.
    Status { abort_latency_ms: Option<u64> },
    /// One request whose answer goes back as it is (`param`).
    Call,
}

struct Server {
    conn: Connection,
    sim: bool,
    clients: HashMap<u64, Conn>,
    next_client: u64,
    pending: HashMap<RequestId, (u64, Stage)>,
    plan_client: Option<u64>,
    /// Whether this server cancelled the running plan (a stop, a signal): its cut step is
    /// "aborted", not "FAILED".
    cancelled: bool,
}

/// Runs `host-tool serve`.
pub fn run(args: Args) -> Result<(), Failure> {
    let device = args.device.validate(Some(1.0))?;
    let foxglove = args.foxglove;
    let dir = crate::sockets::socket_dir_create().map_err(Failure::Runtime)?;
    let port = match &device {
        DeviceConfig::Port(p) => Some(p.as_str()),
        DeviceConfig::Sim(_) => None,
    };
    let sock = dir.join(crate::sockets::socket_name(port));
    if UnixStream::connect(&sock).is_ok() {
        return Err(Failure::Runtime(anyhow::anyhow!(
            "a server already serves this device ({})",
            sock.display()
        )));
    }
    let _ = std::fs::remove_file(&sock);
    let record = if args.no_record {
        None
    } else {
        Some(args.record.clone().unwrap_or_else(|| {
            let t = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            PathBuf::from(format!("host-tool-serve-{t}.mcap"))
        }))
    };
    // The live view first: a port in use stops here, before a file is created.
    let live = foxglove
        .map(|addr| crate::record::live::Live::start(addr, "host-tool serve"))
        .transpose()
        .map_err(Failure::Runtime)?;
    let live_addr = live.as_ref().map(|l| l.addr());
    let mut recording = record
        .as_deref()
        .map(|p| crate::device::start_recording(p, "serve", &device))
        .transpose()?;
    if let Some(live) = live {
        match recording.as_mut() {
            Some(r) => r.attach_live(live),
            None => recording = Some(crate::record::Recording::live_only(live)),
        }
    }
    let interrupted = crate::shell::interrupt_flag();
    let mut conn = device.connect_recorded(recording)?;
    let _ = conn.session.command(RequestBody::SetParam {
        id: ParamId::TelemetryHz,
        value: args.rate as f32,
    });
    let listener = {
        use std::os::unix::fs::PermissionsExt;
        let l = UnixListener::bind(&sock)
            .map_err(|e| anyhow::anyhow!("cannot listen on {}: {e}", sock.display()))?;
        std::fs::set_permissions(&sock, std::fs::Permissions::from_mode(0o600))
            .map_err(anyhow::Error::from)?;
        l.set_nonblocking(true).map_err(anyhow::Error::from)?;
        l
    };
    crate::say!(
        "serving {} on {}{}{}",
        port.unwrap_or("the simulator"),
        sock.display(),
        record
            .as_ref()
            .map_or(String::new(), |r| format!(", recording to {}", r.display())),
        live_addr.map_or(String::new(), |a| format!(
            ", live view for Foxglove on ws://{a}"
        ))
    );
    let mut server = Server {
        sim: matches!(conn.session.io.inner, AnyIo::Sim(_)),
        conn,
        clients: HashMap::new(),
        next_client: 0,
        pending: HashMap::new(),
        plan_client: None,
        cancelled: false,
    };
    let result = server.serve(&listener, &interrupted);
    let _ = std::fs::remove_file(&sock);
    for c in server.clients.values_mut() {
        let _ = c.stream.shutdown(std::net::Shutdown::Both);
    }
    server.conn.close();
    result
}

impl Server {
    fn now(&mut self) -> u64 {
        self.conn.session.io.now_ms()
    }

    fn serve(
        &mut self,
        listener: &UnixListener,
        interrupted: &std::sync::atomic::AtomicBool,
    ) -> Result<(), Failure> {
        let mut stopping_since: Option<u64> = None;
        let mut aborting: Option<String> = None;
        loop {
            if interrupted.load(Ordering::SeqCst) && stopping_since.is_none() {
                let now = self.now();
                stopping_since = Some(now);
                if self.plan_running() {
                    aborting = Some(
                        self.plan_client
                            .map_or("a plan".into(), |c| format!("client {c}'s plan")),
                    );
                    self.conn
                        .session
                        .host
                        .cancel("the server was interrupted", now);
                    self.cancelled = true;
                }
            }
            if let Some(since) = stopping_since {
                // Wait for a cancelled plan's safe end, at most 10 s.
                let running = self.plan_running();
                if !running || self.now() > since + 10_000 {
                    return Err(Failure::Interrupted(if let Some(aborted) = aborting {
                        if running {
                            format!(
                                "the server stopped; the plan it ran ({aborted}) was \
                                 aborted but did not end within 10 s: the crane's link watchdog \
                                 stops it"
                            )
                        } else {
                            format!(
                                "the server stopped; the plan it ran ({aborted}) was \
                                 aborted and the device is in its safe state"
                            )
                        }
                    } else {
                        "the server stopped (nothing was running)".into()
                    }));
                }
            }
            while let Ok((stream, _)) = listener.accept() {
                if stream.set_nonblocking(true).is_ok() {
                    self.next_client += 1;
                    self.clients.insert(
                        self.next_client,
                        Conn {
                            stream,
                            buf: Vec::new(),
                            monitor: false,
                            alive: true,
                        },
                    );
                }
            }
            self.read_clients();
            self.turn()
                .map_err(|e| anyhow::anyhow!("serial I/O failed: {e}"))?;
            while let Some(ev) = self.conn.session.host.poll_event() {
                self.dispatch(ev)?;
            }
            self.clients.retain(|_, c| c.alive);
        }
    }

    fn plan_running(&self) -> bool {
        self.conn
            .session
            .host
            .runner()
            .is_some_and(|r| !r.is_finished())
    }

    /// One slice: the driver's turn, never waiting past [`SLICE_MS`].
    fn turn(&mut self) -> std::io::Result<()> {
        let d = &mut self.conn.session;
        let now = d.io.now_ms();
        d.turn_until(Some(now + SLICE_MS))
    }

    fn read_clients(&mut self) {
        let mut lines = Vec::new();
        for (id, c) in self.clients.iter_mut() {
            let mut chunk = [0u8; 4096];
            loop {
                match c.stream.read(&mut chunk) {
                    Ok(0) => {
                        c.alive = false;
                        break;
                    }
                    Ok(n) => c.buf.extend_from_slice(&chunk[..n]),
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                    Err(_) => {
                        c.alive = false;
                        break;
                    }
                }
            }
            while let Some(pos) = c.buf.iter().position(|b| *b == b'\n') {
                let line: Vec<u8> = c.buf.drain(..=pos).collect();
                lines.push((*id, line));
            }
            if c.buf.len() > 1 << 20 {
                c.alive = false;
            }
        }
        for (id, line) in lines {
            match serde_json::from_slice::<Request>(&line) {
                Ok(r) => self.handle(id, r),
                Err(e) => self.reply(id, Reply::error(format!("bad request line: {e}"))),
            }
        }
    }

    fn reply(&mut self, id: u64, v: Reply) {
        if let Some(c) = self.clients.get_mut(&id) {
            c.send(&v);
        }
    }

    /// Runs a plan (or an identification) for `client`, unless one is running already.
    fn start_run(&mut self, client: u64, target: TrunkState, options: RunOptions, now: u64) {
        if self.plan_running() {
            return self.reply(
                client,
                Reply::error("a plan is already running on this server"),
            );
        }
        self.plan_client = Some(client);
        self.cancelled = false;
        self.conn
            .session
            .host
            .run_plan(Graph::nominal(), target, options, now);
    }

    fn handle(&mut self, client: u64, request: Request) {
        let now = self.now();
        match request {
            Request::Snapshot { request } => {
                let host = &mut self.conn.session.host;
                match request {
                    Some(DeviceRequest(RequestBody::Abort)) => {
                        // Ahead of everything queued; a running plan is cancelled once the
                        // device has answered (its runner's own abort would supersede this one).
                        let id = host.request_first(RequestBody::Abort, now);
                        self.pending.insert(
                            id,
                            (
                                client,
                                Stage::Request {
                                    abort_at: Some(now),
                                },
                            ),
                        );
                    }
                    Some(DeviceRequest(body)) => {
                        let id = host.request(body, now);
                        self.pending
                            .insert(id, (client, Stage::Request { abort_at: None }));
                    }
                    None => {
                        let id = host.request(RequestBody::GetStatus, now);
                        self.pending.insert(
                            id,
                            (
                                client,
                                Stage::Status {
                                    abort_latency_ms: None,
                                },
                            ),
                        );
                    }
                }
            }
            Request::Call {
                request: DeviceRequest(body),
            } => {
                let host = &mut self.conn.session.host;
                let id = if matches!(body, RequestBody::Abort) {
                    host.request_first(body, now)
                } else {
                    host.request(body, now)
                };
                self.pending.insert(id, (client, Stage::Call));
            }
            Request::Monitor => {
                if let Some(c) = self.clients.get_mut(&client) {
                    c.monitor = true;
                }
            }
            Request::Plan { target } => {
                self.start_run(client, target, RunOptions::default(), now);
            }
            Request::Identify => {
                // The target is replaced by whatever the device confirms.
                let options = RunOptions {
                    identify_only: true,
                    ..RunOptions::default()
                };
                self.start_run(client, TrunkState::AS_MANUFACTURED, options, now);
            }
        }
    }

    fn dispatch(&mut self, ev: HostEvent) -> Result<(), Failure> {
        let now = self.now();
        match ev {
            HostEvent::Session(SessionEvent::Reply { id, reply }) => {
                let Some((client, stage)) = self.pending.remove(&id) else {
                    return Ok(());
                };
                match stage {
                    Stage::Call => {
                        self.reply(
                            client,
                            Reply::Call {
                                result: reply.result,
                                body: reply.body,
                            },
                        );
                    }
                    Stage::Request { abort_at } => {
                        if let Err(e) = reply.accepted("request") {
                            self.reply(client, Reply::error(e));
                            return Ok(());
                        }
                        let latency = abort_at.map(|t| now.saturating_sub(t));
                        if abort_at.is_some() && self.plan_running() {
                            self.conn
                                .session
                                .host
                                .cancel("stopped from another terminal (host-tool stop)", now);
                            self.cancelled = true;
                        }
                        let id = self.conn.session.host.request(RequestBody::GetStatus, now);
                        self.pending.insert(
                            id,
                            (
                                client,
                                Stage::Status {
                                    abort_latency_ms: latency,
                                },
                            ),
                        );
                    }
                    Stage::Status { abort_latency_ms } => match reply.status() {
                        Ok(status) => {
                            let v = Reply::Snapshot {
                                status,
                                info: self.conn.info.clone(),
                                truth: self.conn.truth(),
                                abort_latency_ms,
                            };
                            self.reply(client, v);
                        }
                        Err(e) => self.reply(client, Reply::error(e)),
                    },
                }
            }
            HostEvent::Session(SessionEvent::Failed { id, error }) => {
                if let Some((client, _)) = self.pending.remove(&id) {
                    self.reply(client, Reply::error(error));
                }
            }
            HostEvent::Session(SessionEvent::Device(e)) => self.device_event(&e),
            HostEvent::Session(SessionEvent::LinkLost(e)) => {
                return Err(Failure::Runtime(anyhow::anyhow!("link lost: {e}")));
            }
            HostEvent::Session(_) => {}
            HostEvent::Run(ev) => self.run_event(&ev, now),
        }
        Ok(())
    }

    fn device_event(&mut self, e: &Event) {
        if matches!(e, Event::Heartbeat { .. }) {
            return;
        }
        let v = Reply::Event { event: e.clone() };
        for c in self.clients.values_mut().filter(|c| c.monitor) {
            c.send(&v);
        }
    }

    fn run_event(&mut self, ev: &RunEvent, now: u64) {
        if let Some(rec) = self.conn.session.io.recording() {
            rec.run_event(now, ev);
        }
        let note = match ev {
            RunEvent::Plan { plan, .. } => Some(plan.to_string()),
            RunEvent::StepStarted { index, total } => {
                Some(format!("step {}/{} started", index + 1, total))
            }
            RunEvent::StepProgress { .. } => None,
            RunEvent::ManualPrompt { index, task } => Some(format!(
                "step {}: {} — press the confirm button on the crane",
                index + 1,
                planner::graph::manual_task_text(*task)
            )),
            RunEvent::IdentifyPrompt { candidates, .. } => {
                // The simulated person looks at the simulated trunk; nobody answers for a
                // real crane here: declare it from another terminal (`host-tool declare`).
                let truth: Option<TrunkState> = match &self.conn.session.io.inner {
                    AnyIo::Sim(io) if self.sim => io.sim.ground_truth().true_state,
                    _ => None,
                };
                self.conn.session.host.declare(truth, now);
                Some(format!(
                    "state unconfirmed (one of {}); {}",
                    candidates
                        .iter()
                        .map(|s| s.name())
                        .collect::<Vec<_>>()
                        .join(", "),
                    match truth {
                        Some(s) => format!("simulated operator: the trunk is {s}"),
                        None => "nobody can tell here".into(),
                    }
                ))
            }
            RunEvent::StepFinished { index, report } => Some(crate::progress::finished_line(
                *index,
                report,
                self.cancelled && !report.ok,
            )),
            RunEvent::Note(m) => Some(m.clone()),
            RunEvent::Finished => {
                let outcome = self
                    .conn
                    .session
                    .host
                    .runner()
                    .map(|r| r.outcome().clone())
                    .unwrap_or_default();
                let truth = self.conn.truth();
                let doc = crate::outcome::PlanOutcome::of(&outcome, truth.as_ref());
                if let Some(rec) = self.conn.session.io.recording() {
                    rec.outcome(now, &doc);
                }
                if let Some(c) = self.plan_client.take() {
                    self.reply(
                        c,
                        Reply::Outcome {
                            outcome: Box::new(doc),
                            ok: outcome.ok(),
                        },
                    );
                }
                None
            }
        };
        if let (Some(n), Some(c)) = (note, self.plan_client) {
            self.reply(c, Reply::Note { note: n });
        }
    }
}
