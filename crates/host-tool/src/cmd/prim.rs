//! `host-tool grip open|close`, `host-tool bend ANGLE --toward DIR`, `host-tool vent`: one
//! primitive on the crane (or the simulator), as a step within the state the trunk is in
//! (`RunStep` with from = to, so the device checks the state and leaves it as it was), through
//! a `host-tool serve` server when one holds the device. Each is refused, with the reason,
//! before anything is sent where it is unsafe or meaningless: no confirmed state, a plan
//! running, faults or the e-stop latched, a bend in a state that is not bent or over its limit,
//! a gripper already where asked, a vent with nothing to let out.
//!
//! The objects of the simulator's world (`--object`, `--tip-load-kg`) and the truth: see
//! `crate::cmd::task`.

use std::sync::atomic::Ordering;

use geometry::tendon::TendonGeometry;
use geometry::TrunkState;
use host::text;
use planner::task::{bend_primitive, step_within, Workspace};
use protocol::{Mode, PlanPhase, Primitive, RequestBody, Status, StepKind};
use serde_json::{json, Value};

use crate::cmd::task::{World, WorldArgs};
use crate::device::{Connection, DeviceArgs};
use crate::failure::Failure;
use crate::shell::{deadline_passed, TIME_LIMIT_ABORT};
use crate::transport::AnyIo;

/// `open` or `close`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Jaw {
    /// Open the gripper (let go).
    Open,
    /// Close the gripper (grasp).
    Close,
}

/// Arguments of `host-tool grip`.
#[derive(Debug, clap::Args)]
pub struct GripArgs {
    /// open or close.
    #[arg(value_enum)]
    pub action: Jaw,
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub world: WorldArgs,
    /// Record the session to this MCAP file (`host-tool log` reads it).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<std::path::PathBuf>,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// Arguments of `host-tool bend`.
#[derive(Debug, clap::Args)]
pub struct BendArgs {
    /// The bend angle of the tip axis, degrees (≥ 0; 0 straightens).
    #[arg(allow_hyphen_values = true, value_parser = crate::arg::usage(bend_angle))]
    pub angle: f64,
    /// The direction the tip bends toward, degrees (0° = toward tendon 0, counter-clockwise
    /// seen from above); not needed for 0.
    #[arg(long, value_name = "DIR", allow_hyphen_values = true,
          value_parser = crate::arg::usage(|s: &str| degrees("--toward", s)))]
    pub toward: Option<f64>,
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub world: WorldArgs,
    /// Record the session to this MCAP file (`host-tool log` reads it).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<std::path::PathBuf>,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// Arguments of `host-tool vent`.
#[derive(Debug, clap::Args)]
pub struct VentArgs {
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub world: WorldArgs,
    /// Record the session to this MCAP file (`host-tool log` reads it).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<std::path::PathBuf>,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// The crane configuration the host assumes: the simulator's for `--sim`, else the firmware's
/// defaults (the crane as built).
pub fn crane_config(device: &DeviceArgs) -> protocol::CraneGeometry {
    if device.sim {
        hil_sim::sim::sim_crane_geometry()
    } else {
        protocol::CraneGeometry::default()
    }
}

/// One device, directly or through a server: a status, one request, waiting.
pub enum Link {
    /// This process holds the device.
    Direct(Box<Connection>),
    /// A `host-tool serve` server holds it.
    Server(std::path::PathBuf),
}

fn session_error(e: &host::SessionError) -> Failure {
    Failure::Runtime(anyhow::Error::new(crate::cli::DeviceError::session("", e)))
}

impl Link {
    /// Opens the device the arguments name (a server's when one holds it), with `world` placed
    /// in the simulator, recording the session to `record` (MCAP, `host-tool log` reads it)
    /// under the command name `command`.
    pub fn open_recorded(
        device: &DeviceArgs,
        world: &World,
        record: Option<&std::path::Path>,
        command: &str,
    ) -> Result<Link, Failure> {
        if let Some(server) = crate::client::server_for(device)? {
            if record.is_some() {
                return Err(Failure::usage(
                    "a server holds this device and records its session itself: --record is not needed",
                ));
            }
            if !world.is_empty() {
                return Err(Failure::usage(
                    "--object and --tip-load-kg place things in the built-in simulator: a server holds this device, so give them to a command with --sim instead",
                ));
            }
            return Ok(Link::Server(server));
        }
        let cfg = device.validate(None)?;
        if !world.is_empty() && !device.sim {
            return Err(Failure::usage(
                "--object and --tip-load-kg need --sim: a real crane's objects are placed by a person",
            ));
        }
        let recording = record
            .map(|p| crate::device::start_recording(p, command, &cfg))
            .transpose()?;
        let mut conn = cfg.connect_recorded(recording)?;
        if let AnyIo::Sim(io) = &mut conn.session.io.inner {
            // Placed at a closed gripper, an object is not held: only closing catches.
            let closed = io.sim.ground_truth().gripper_closed;
            *io.sim.world_mut() = world.to_sim();
            io.sim.world_mut().set_gripper(closed);
        }
        Ok(Link::Direct(Box::new(conn)))
    }

    /// The device's status.
    pub fn status(&mut self) -> Result<Status, Failure> {
        match self {
            Link::Direct(c) => c.session.status().map_err(|e| session_error(&e)),
            Link::Server(p) => Ok(crate::client::snapshot(p, None)?.status),
        }
    }

    /// Sends one request and requires it accepted.
    pub fn command(&mut self, body: RequestBody) -> Result<(), Failure> {
        match self {
            Link::Direct(c) => c
                .session
                .command(body)
                .map(|_| ())
                .map_err(|e| session_error(&e)),
            Link::Server(p) => crate::client::call(p, body)?
                .map(|_| ())
                .map_err(|e| session_error(&e)),
        }
    }

    /// Lets `ms` pass (the engine heartbeats; a server's device runs on by itself).
    pub fn wait(&mut self, ms: u64) -> Result<(), Failure> {
        match self {
            Link::Direct(c) => c.session.idle(ms).map_err(|e| session_error(&e)),
            Link::Server(_) => {
                std::thread::sleep(std::time::Duration::from_millis(ms));
                Ok(())
            }
        }
    }

    /// The link's clock, ms: the simulator's virtual time when this process runs it, else the
    /// host's monotonic clock.
    pub fn now_ms(&mut self) -> u64 {
        match self {
            Link::Direct(c) => host::Io::now_ms(&mut c.session.io),
            Link::Server(_) => {
                static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
                START
                    .get_or_init(std::time::Instant::now)
                    .elapsed()
                    .as_millis() as u64
            }
        }
    }

    /// The simulator, when this process runs it.
    pub fn sim(&mut self) -> Option<&mut hil_sim::Sim> {
        match self {
            Link::Direct(c) => match &mut c.session.io.inner {
                AnyIo::Sim(io) => Some(&mut io.sim),
                AnyIo::Serial(_) => None,
            },
            Link::Server(_) => None,
        }
    }

    /// A line in the recording, when this process records the session.
    pub fn log(&mut self, level: crate::record::Level, message: &str) {
        if let Link::Direct(c) = self {
            let now = host::Io::now_ms(&mut c.session.io);
            if let Some(rec) = c.session.io.recording() {
                rec.log(now, level, "host-tool", message);
            }
        }
    }

    /// Ends the session.
    pub fn close(self) {
        if let Link::Direct(c) = self {
            let _ = c.close();
        }
    }
}

/// A step within `state` of one primitive (a tendon-kind step: the device lets no tendon out
/// before it, as it would before a pneumatic one).
pub fn step_for(state: TrunkState, prim: Primitive) -> protocol::Step {
    step_within(state, StepKind::Tendon, &[prim])
}

/// Why the device cannot take a step now, if it cannot.
pub fn blocked(st: &Status) -> Option<String> {
    if st.estop {
        return Some("the e-stop is latched: release it and `host-tool stop`/reset first".into());
    }
    if matches!(st.mode, Mode::Running | Mode::WaitingManual) {
        return Some("the device is running a plan: wait for it, or `host-tool stop`".into());
    }
    if st.faults != 0 {
        return Some(format!(
            "the device has active faults ({}): see `host-tool status`",
            text::fault_list(st.faults)
        ));
    }
    if !st.state_confirmed {
        return Some(format!(
            "the trunk's state is not confirmed ({}): `host-tool identify` or `host-tool declare` first",
            crate::cmd::status::belief_text(st).trim()
        ));
    }
    None
}

/// How one primitive step ended.
pub struct StepEnd {
    /// The device's status after it.
    pub status: Status,
    /// `true` when the step completed.
    pub ok: bool,
    /// Why not.
    pub error: Option<String>,
}

/// Runs `step` on the device and waits for its end (Ctrl-C aborts it, and so does the time
/// set by [`set_deadline`]: then the step ends not ok, [`TIME_LIMIT_ABORT`]).
pub fn run_step(link: &mut Link, step: protocol::Step) -> Result<StepEnd, Failure> {
    let interrupted = crate::shell::interrupt_flag();
    link.command(RequestBody::RunStep(step))?;
    let mut aborted = false;
    let mut timed_out = false;
    loop {
        link.wait(50)?;
        if interrupted.load(Ordering::SeqCst) && !aborted {
            aborted = true;
            link.command(RequestBody::Abort)?;
        }
        if !aborted && !timed_out && deadline_passed(link.now_ms()) {
            timed_out = true;
            link.command(RequestBody::Abort)?;
        }
        let st = link.status()?;
        if matches!(st.mode, Mode::Running | Mode::WaitingManual) {
            continue;
        }
        let phase = st.plan.filter(|p| p.plan_id == 0).map(|p| p.phase);
        let (ok, error) = match phase {
            Some(PlanPhase::Done) => (true, None),
            Some(PlanPhase::Failed(code)) => (
                false,
                Some(format!(
                    "the device stopped the step: {}",
                    text::fault(code)
                )),
            ),
            Some(PlanPhase::Aborted) => (false, Some("the step was aborted".into())),
            other => (
                false,
                Some(format!("the step ended in an unexpected phase ({other:?})")),
            ),
        };
        if aborted {
            return Err(Failure::Interrupted(
                "interrupted: the step was aborted, the device is in its safe state".into(),
            ));
        }
        if timed_out && !ok {
            return Ok(StepEnd {
                status: st,
                ok,
                error: Some(TIME_LIMIT_ABORT.into()),
            });
        }
        return Ok(StepEnd {
            status: st,
            ok,
            error,
        });
    }
}

/// The report of a primitive: the device's view, and the simulator's truth when it runs here.
fn report(
    link: &mut Link,
    what: &str,
    end: &StepEnd,
    json_out: bool,
    extra: Value,
) -> Result<(), Failure> {
    let st = &end.status;
    let truth = link.sim().map(|sim| {
        let t = sim.true_tip();
        let true_state = sim.trunk().state();
        json!({
            "true_state": sim.trunk().state().map(|s| s.name()),
            "true_tip_mm": t.position_mm.map(|v| (v * 10.0).round() / 10.0),
            "true_bend_deg": (sim.trunk().bend_deg().0 * 100.0).round() / 100.0,
            "pressure_kpa": (sim.trunk().pressure_kpa() * 100.0).round() / 100.0,
            "world": sim.world().to_json(),
            "matches_device": true_state == Some(st.state),
        })
    });
    let mismatch = truth.as_ref().is_some_and(|t| t["matches_device"] == false);
    let end = &StepEnd {
        status: end.status.clone(),
        ok: end.ok && !mismatch,
        error: end.error.clone().or_else(|| {
            mismatch.then(|| {
                format!(
                    "the device reports {} but the simulator's trunk is {}: the device did not notice the change",
                    st.state,
                    truth.as_ref().and_then(|t| t["true_state"].as_str()).unwrap_or("between states")
                )
            })
        }),
    };
    if json_out {
        let mut v = json!({
            "ok": end.ok,
            "done": what,
            "state": st.state.name(),
            "state_confirmed": st.state_confirmed,
            "gripper_closed": st.gripper_closed,
            "pressure_kpa": st.pressure_kpa,
            "servo_deg": st.servo_deg,
            "error": end.error,
            "sim": truth,
        });
        if let (Some(o), Some(e)) = (v.as_object_mut(), extra.as_object()) {
            for (k, x) in e {
                o.insert(k.clone(), x.clone());
            }
        }
        crate::cli::print_json(v);
    } else {
        crate::out!(
            "{}: {what}; state {}{}, gripper {}, {} kPa",
            if end.ok { "done" } else { "FAILED" },
            st.state,
            if st.state_confirmed {
                " (confirmed)"
            } else {
                " (NOT confirmed)"
            },
            if st.gripper_closed { "closed" } else { "open" },
            crate::num::fixed(f64::from(st.pressure_kpa), 1)
        );
        if let Some(t) = &truth {
            crate::out!(
                "simulator: true state {}, true tip ({}, {}, {}) mm, {} kPa",
                t["true_state"].as_str().unwrap_or("between states"),
                t["true_tip_mm"][0],
                t["true_tip_mm"][1],
                t["true_tip_mm"][2],
                t["pressure_kpa"]
            );
        }
    }
    match &end.error {
        None => Ok(()),
        Some(e) => Err(Failure::Runtime(anyhow::anyhow!("{what}: {e}"))),
    }
}

/// The state the device is in, or why nothing may be sent.
/// The device's status, refused with the reason when it cannot take a step now ([`blocked`]).
pub fn ready(link: &mut Link) -> Result<Status, Failure> {
    let st = link.status()?;
    match blocked(&st) {
        Some(why) => Err(Failure::Runtime(anyhow::anyhow!("refused: {why}"))),
        None => Ok(st),
    }
}

/// Runs `host-tool grip`.
pub fn run_grip(args: GripArgs) -> Result<(), Failure> {
    let world = args.world.parse()?;
    let close = args.action == Jaw::Close;
    let mut link = Link::open_recorded(&args.device, &world, args.record.as_deref(), "grip")?;
    let st = ready(&mut link)?;
    if st.gripper_closed == close {
        return Err(Failure::Runtime(anyhow::anyhow!(
            "refused: the gripper is already {}: nothing to do",
            if close { "closed" } else { "open" }
        )));
    }
    let step = step_for(st.state, Primitive::Gripper { close });
    let end = run_step(&mut link, step)?;
    let mut grasp = Value::Null;
    if let Some(sim) = link.sim() {
        grasp = json!(sim
            .world_mut()
            .take_events()
            .iter()
            .map(crate::cmd::task::grasp_json)
            .collect::<Vec<_>>());
        if !args.json {
            for g in grasp.as_array().into_iter().flatten() {
                crate::out!("simulator: {}", g["text"].as_str().unwrap_or(""));
            }
        }
    }
    let r = report(
        &mut link,
        if close {
            "gripper closed"
        } else {
            "gripper opened"
        },
        &end,
        args.json,
        json!({"grasp": grasp}),
    );
    link.close();
    r
}

/// Parses a number argument in degrees.
fn degrees(what: &str, text: &str) -> Result<f64, Failure> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            Failure::usage(format!(
                "invalid {what} '{text}': expected a number of degrees"
            ))
        })
}

/// A bend angle: a number of degrees ≥ 0.
fn bend_angle(text: &str) -> Result<f64, Failure> {
    let angle = degrees("ANGLE", text)?;
    if angle < 0.0 {
        return Err(Failure::usage(format!(
            "invalid ANGLE {angle}: a bend angle is ≥ 0° (bend the other way with --toward DIR+180)"
        )));
    }
    Ok(angle)
}

/// Runs `host-tool bend`.
pub fn run_bend(args: BendArgs) -> Result<(), Failure> {
    let angle = args.angle;
    let toward = match args.toward {
        Some(t) => t,
        None if angle == 0.0 => 0.0,
        None => {
            return Err(Failure::usage(
                "a bend needs --toward DIR (degrees, 0° = toward tendon 0); only `bend 0` (straighten) goes without",
            ))
        }
    };
    let cfg = crane_config(&args.device);
    let ws = crate::cmd::pose::crane_workspace(&cfg)?;
    let widest = TrunkState::ALL
        .iter()
        .filter_map(|s| ws.limit_deg(*s))
        .fold(0.0, f64::max);
    if angle > widest {
        return Err(Failure::usage(format!(
            "invalid ANGLE {angle}°: no state bends more than {:.2}° (the nearest feasible bend)",
            (widest * 100.0).floor() / 100.0
        )));
    }
    let world = args.world.parse()?;
    let mut link = Link::open_recorded(&args.device, &world, args.record.as_deref(), "bend")?;
    let st = ready(&mut link)?;
    let (step, cmd) = bend_step(&ws, &cfg, st.state, angle, toward)?;
    let end = run_step(&mut link, step)?;
    let tip = ws.tip(st.state, angle, toward).ok();
    let what = if angle == 0.0 {
        "straightened".to_string()
    } else {
        format!("bent {angle}° toward {toward}°")
    };
    if !args.json {
        if let Some(t) = tip {
            crate::out!(
                "geometry: tip at ({:.1}, {:.1}, {:.1}) mm",
                t.position_mm[0],
                t.position_mm[1],
                t.position_mm[2]
            );
        }
    }
    let r = report(
        &mut link,
        &what,
        &end,
        args.json,
        json!({
            "bend_deg": angle,
            "toward_deg": toward,
            "command": {"angle_deg": cmd.0, "toward_deg": cmd.1},
            "tip_mm": tip.map(|t| t.position_mm.map(|v| (v * 10.0).round() / 10.0)),
        }),
    );
    link.close();
    r
}

/// The step that bends `state` by `angle` toward `toward` (degrees), refused where the state is
/// not bent or the angle is over its limit; also the command sent (angle, direction), with the
/// take-up margin's compensation ([`TendonGeometry::command_for`]).
pub fn bend_step(
    ws: &Workspace,
    cfg: &protocol::CraneGeometry,
    state: TrunkState,
    angle: f64,
    toward: f64,
) -> Result<(protocol::Step, (f64, f64)), Failure> {
    if ws.limit_deg(state).is_none() {
        return Err(Failure::Runtime(anyhow::anyhow!(
            "refused: {state} is not bent{}: only the flexible states F&F, D&F, D&P and F&D are",
            if angle == 0.0 {
                " (nothing to straighten)"
            } else {
                ""
            }
        )));
    }
    let bend = ws
        .check_bend(state, angle, toward)
        .map_err(|e| Failure::Runtime(anyhow::anyhow!("refused: {e}")))?;
    let tg = TendonGeometry::new(f64::from(cfg.tendon_radius_mm))
        .map_err(|e| anyhow::anyhow!("the crane's tendon radius: {e}"))?;
    let cmd = tg.command_for(bend, f64::from(cfg.take_up_margin_mm));
    let step = step_within(state, StepKind::Tendon, &[bend_primitive(cmd)]);
    Ok((
        step,
        (
            (cmd.angle.to_degrees() * 1e3).round() / 1e3,
            (cmd.direction.to_degrees() * 1e3).round() / 1e3,
        ),
    ))
}

/// The vent step for the device's state `st`: `Ok(None)` when the trunk is within the vent
/// tolerance of ambient already (nothing to let out), refused where the simulator's physics
/// says the trunk would collapse.
pub fn vent_step(link: &mut Link, st: &Status) -> Result<Option<protocol::Step>, Failure> {
    if st.pressure_kpa <= protocol::DEFAULT_VENT_TOLERANCE_KPA {
        return Ok(None);
    }
    if let Some(why) = link
        .sim()
        .and_then(|sim| crate::cmd::task::vent_would_collapse(sim, st.state))
    {
        return Err(Failure::Runtime(anyhow::anyhow!("refused: {why}")));
    }
    Ok(Some(step_for(
        st.state,
        Primitive::Vent { pressure_kpa: 0.0 },
    )))
}

/// Runs `host-tool vent`.
pub fn run_vent(args: VentArgs) -> Result<(), Failure> {
    let world = args.world.parse()?;
    let mut link = Link::open_recorded(&args.device, &world, args.record.as_deref(), "vent")?;
    let st = ready(&mut link)?;
    let step = match vent_step(&mut link, &st) {
        Ok(Some(step)) => step,
        Ok(None) => {
            link.close();
            return Err(Failure::Runtime(anyhow::anyhow!(
                "refused: the trunk is at {} kPa, within {} kPa of ambient: nothing to let out",
                crate::num::fixed(f64::from(st.pressure_kpa), 1),
                protocol::DEFAULT_VENT_TOLERANCE_KPA
            )));
        }
        Err(e) => {
            link.close();
            return Err(e);
        }
    };
    let end = run_step(&mut link, step)?;
    let r = report(&mut link, "vented", &end, args.json, json!({}));
    link.close();
    r
}
