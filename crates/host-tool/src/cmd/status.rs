//! `host-tool status`: one snapshot of the device.

use host::text;
use protocol::{DeviceInfo, Mode, RequestBody, Status};
use serde_json::{json, Value};

use crate::device::DeviceArgs;
use crate::failure::Failure;
use crate::num::fixed;
pub use crate::outcome::Snapshot;
use crate::sim::SimTruth;
use host::text::fault_list;

/// Arguments of `host-tool status` (and of `host-tool stop`).
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Print one JSON object on stdout.
    #[arg(skip)]
    pub json: bool,
}

/// Connects to the device, sends `request` (if any), reads its status and closes the connection.
pub fn snapshot(device: &DeviceArgs, request: Option<RequestBody>) -> Result<Snapshot, Failure> {
    if let Some(server) = crate::client::server_for(device)? {
        return crate::client::snapshot(&server, request);
    }
    let device = device.validate(None)?;
    let mut conn = device.connect()?;
    if let Some(request) = request {
        conn.session
            .command(request)
            .map_err(|e| anyhow::Error::new(crate::cli::DeviceError::session("", &e)))?;
    }
    let status = conn
        .session
        .status()
        .map_err(|e| anyhow::Error::new(crate::cli::DeviceError::session("", &e)))?;
    let info = conn.info.clone();
    Ok(Snapshot {
        status,
        info,
        truth: conn.close(),
        abort_latency_ms: None,
        server: None,
    })
}

/// Runs `host-tool status`.
pub fn run(args: Args) -> Result<(), Failure> {
    let Snapshot {
        status,
        info,
        truth,
        server,
        ..
    } = snapshot(&args.device, None)?;
    if args.json {
        let mut v = status_json(&status, &info, truth.as_ref());
        v["server"] = json!(server.as_ref().map(|p| p.display().to_string()));
        crate::cli::print_json(v);
    } else {
        if let Some(p) = &server {
            crate::out!(
                "answered by:  the `host-tool serve` server at {} (it holds the device)",
                p.display()
            );
        }
        crate::out_raw!("{}", status_text(&status, &info));
        if let Some(t) = truth {
            crate::out!("simulator:    {}", truth_text(&status, &t));
        }
    }
    Ok(())
}

/// Whether the simulator's truth agrees with what the device reports: its confirmed state is
/// the true one, or (unconfirmed) the truth is among its candidates. `None` between states.
pub fn device_right(s: &Status, t: &SimTruth) -> Option<bool> {
    let truth = t.true_state?;
    Some(if s.state_confirmed {
        s.state == truth
    } else {
        s.candidates.contains(truth)
    })
}

/// The simulator's line of `status`: the truth, and a warning when the device's belief is wrong.
fn truth_text(s: &Status, t: &SimTruth) -> String {
    let mut line = format!(
        "true state {}, max pressure {} kPa",
        t.true_state.map_or("between states", |s| s.name()),
        fixed(f64::from(t.max_pressure_kpa), 1)
    );
    if device_right(s, t) == Some(false) {
        line += &if s.state_confirmed {
            format!(
                " — THE DEVICE IS WRONG: it holds {} as confirmed (a wrong declaration, or a change \
                 it did not notice); `host-tool declare` the true state",
                s.state
            )
        } else {
            " — THE TRUTH IS NOT AMONG THE DEVICE'S CANDIDATES".to_string()
        };
    }
    line
}

/// The device's belief in words: the state, and when it is not confirmed, what it may be and
/// which step was under way.
pub fn belief_text(s: &Status) -> String {
    if s.state_confirmed {
        return format!("{} (confirmed)", s.state);
    }
    if let (true, Some(t)) = (moving(s), s.interrupted) {
        let may: Vec<&str> = s.candidates.iter().map(|c| c.name()).collect();
        return format!(
            "moving from {} toward {} (not confirmed while the step runs; may be any of {})",
            t.from,
            t.to,
            may.join(", ")
        );
    }
    let may: Vec<&str> = s.candidates.iter().map(|c| c.name()).collect();
    format!(
        "{} NOT CONFIRMED: the trunk may be {}{}; `host-tool identify` or a plan identifies it \
         first",
        s.state,
        if may.is_empty() {
            "in any state".to_string()
        } else {
            format!("any of {}", may.join(", "))
        },
        s.interrupted.map_or(String::new(), |t| format!(
            " (was going {} → {})",
            t.from, t.to
        ))
    )
}

/// Whether the device speaks this host's protocol version and schema.
fn versions_match(info: &DeviceInfo) -> bool {
    info.protocol_version == protocol::PROTOCOL_VERSION && info.schema_id == protocol::SCHEMA_ID
}

fn status_text(s: &Status, info: &DeviceInfo) -> String {
    let v = info.firmware_version;
    let mut t = format!(
        "device:       {} (firmware {}.{}.{}, protocol {}, schema {:#010x})\n",
        text::board(info.board),
        v[0],
        v[1],
        v[2],
        info.protocol_version,
        info.schema_id
    );
    t += &format!(
        "host:         host-tool {}; {}\n",
        crate::cli::version(),
        if versions_match(info) {
            "the same protocol and schema as the device"
        } else {
            "the protocol or schema DIFFERS from the device's"
        }
    );
    t += &format!("state:        {}\n", crate::cmd::status::belief_text(s));
    t += &format!("mode:         {}\n", text::mode(s.mode));
    t += &format!(
        "pressure:     {} kPa (limit {}); inlet {}, exhaust {}\n",
        fixed(f64::from(s.pressure_kpa), 1),
        crate::num::widen(info.trunk.pressure_limit_kpa),
        if s.inlet_open { "open" } else { "closed" },
        if s.exhaust_open { "open" } else { "closed" }
    );
    t += &format!(
        "servos:       {}° {}° {}°; gripper {}\n",
        fixed(f64::from(s.servo_deg[0]), 1),
        fixed(f64::from(s.servo_deg[1]), 1),
        fixed(f64::from(s.servo_deg[2]), 1),
        if s.gripper_closed { "closed" } else { "open" }
    );
    t += &format!(
        "faults:       {}{}\n",
        fault_list(s.faults),
        if s.estop { "; E-STOP latched" } else { "" }
    );
    if let Some(p) = s.plan {
        t += &format!(
            "plan:         #{} step {}/{} {}\n",
            p.plan_id,
            u16::from(p.step) + 1,
            p.steps,
            text::phase(p.phase)
        );
    }
    t += &format!(
        "link:         {} frames received, {} dropped; uptime {:.1} s\n",
        s.frames_rx,
        s.frames_dropped,
        f64::from(s.uptime_ms) / 1000.0
    );
    t
}

/// Whether the status is of a step moving the trunk (the device then names that step in
/// `interrupted` and confirms no state).
fn moving(s: &Status) -> bool {
    !s.state_confirmed && matches!(s.mode, Mode::Running | Mode::WaitingManual)
}

/// The `status --json` object.
pub fn status_json(s: &Status, info: &DeviceInfo, truth: Option<&SimTruth>) -> Value {
    let faults: Vec<Value> = protocol::FaultCode::ALL
        .iter()
        .filter(|f| s.faults & f.bit() != 0)
        .map(|f| json!({"code": f.code(), "description": f.description()}))
        .collect();
    json!({
        "state": s.state.name(),
        "state_confirmed": s.state_confirmed,
        "candidates": s.candidates.iter().map(|c| c.name()).collect::<Vec<_>>(),
        // While a step runs the device names it as the step under way: `moving`, not an
        // interruption.
        "interrupted": s.interrupted.filter(|_| !moving(s)).map(|t| json!({"from": t.from.name(), "to": t.to.name()})),
        "moving": s.interrupted.filter(|_| moving(s)).map(|t| json!({"from": t.from.name(), "to": t.to.name()})),
        "mode": text::mode(s.mode),
        "pressure_kpa": s.pressure_kpa,
        "servo_deg": s.servo_deg,
        "inlet_open": s.inlet_open,
        "exhaust_open": s.exhaust_open,
        "gripper_closed": s.gripper_closed,
        "estop": s.estop,
        "faults": faults,
        "plan": s.plan.map(|p| json!({
            "plan_id": p.plan_id,
            "step": p.step,
            "steps": p.steps,
            "phase": text::phase(p.phase),
        })),
        "frames_rx": s.frames_rx,
        "frames_dropped": s.frames_dropped,
        "uptime_ms": s.uptime_ms,
        "device": {
            "board": text::board(info.board),
            "firmware_version": info.firmware_version,
            "protocol_version": info.protocol_version,
            "schema_id": info.schema_id,
            "pressure_limit_kpa": info.trunk.pressure_limit_kpa,
        },
        "host": {
            "version": env!("CARGO_PKG_VERSION"),
            "protocol_version": protocol::PROTOCOL_VERSION,
            "schema_id": protocol::SCHEMA_ID,
            "commit": crate::cli::GIT_COMMIT,
        },
        "versions_match": versions_match(info),
        "sim": truth.map(|t| {
            let mut v = t.to_json();
            v["matches_device"] = json!(device_right(s, t));
            v
        }),
    })
}
