//! `host-tool plan --target STATE`: take the crane (or the simulator) to a trunk state.
//!
//! Open → handshake → status → cheapest plan from the device's state → upload, start → follow
//! (progress, manual prompts, replanning) → exit 0 only when the device reports the target.

use std::sync::atomic::Ordering;

use geometry::TrunkState;
use host::{Io as _, Outcome, RunOptions};
use planner::graph::{kind_name, Graph, PrimitiveText};
use serde_json::{json, Value};

use crate::device::{ConnectError, DeviceArgs, DeviceConfig};
use crate::failure::Failure;
use crate::shell::{interrupt_flag, CliShell};
use crate::sim::SimTruth;

/// Arguments of `host-tool plan`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The trunk state to reach: F&P, F&F, F&D, D&P, D&F or D&D.
    #[arg(long, value_name = "STATE", value_parser = crate::arg::trunk_state)]
    pub target: TrunkState,
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Print the plan and touch nothing (plans from --from, or the simulator's initial state;
    /// with --port it reads the device's state but sends no command).
    #[arg(long)]
    pub dry_run: bool,
    /// With --dry-run: plan from this state instead of asking the device.
    #[arg(long, value_name = "STATE", requires = "dry_run", value_parser = crate::arg::trunk_state)]
    pub from: Option<TrunkState>,
    /// Print one JSON object on stdout instead of a summary.
    #[arg(skip)]
    pub json: bool,
    /// Record the session to this MCAP file (telemetry at 50 Hz during the run, events,
    /// requests and responses, the plan; the ground truth with --sim). `host-tool log` reads it.
    #[arg(long, value_name = "FILE.mcap", conflicts_with = "dry_run")]
    pub record: Option<std::path::PathBuf>,
    /// Plan with a calibration profile's measured thresholds (`host-tool calibrate`):
    /// inflations toward each measured snap + 15 %, pulls to each measured stroke + 15 %.
    #[arg(long, value_name = "PROFILE.toml")]
    pub calibration: Option<std::path::PathBuf>,
}

/// Validated arguments.
struct Config {
    target: TrunkState,
    device: DeviceConfig,
    dry_run: bool,
    from: Option<TrunkState>,
    json: bool,
    record: Option<std::path::PathBuf>,
    calibration: Option<std::path::PathBuf>,
    graph: Graph,
}

impl Args {
    fn validate(&self) -> Result<Config, Failure> {
        let mut cfg = self.validate_args()?;
        if let Some(path) = &cfg.calibration {
            cfg.graph = crate::cmd::calibrate::plan_graph(path, &cfg.device, None)?;
        }
        Ok(cfg)
    }

    fn validate_args(&self) -> Result<Config, Failure> {
        Ok(Config {
            target: self.target,
            // A dry run with no device plans from the simulator's initial state (or --from).
            device: if self.dry_run && self.device.port.is_none() {
                DeviceArgs {
                    sim: true,
                    ..self.device.clone()
                }
                .validate(None)?
            } else {
                self.device.validate(None)?
            },
            dry_run: self.dry_run,
            from: self.from,
            json: self.json,
            record: self.record.clone(),
            calibration: self.calibration.clone(),
            graph: Graph::nominal(),
        })
    }
}

/// Runs `host-tool plan`.
pub fn run(args: Args) -> Result<(), Failure> {
    if !args.dry_run {
        if let Some(server) = crate::client::server_for(&args.device)? {
            return through_server(&server, &args);
        }
    }
    let cfg = args.validate()?;
    if cfg.dry_run {
        return dry_run(&cfg);
    }
    let recording = cfg
        .record
        .as_deref()
        .map(|p| crate::device::start_recording(p, "plan", &cfg.device))
        .transpose()?;
    let interrupted = interrupt_flag();
    let mut conn = match cfg.device.connect_recorded(recording) {
        Ok(c) => c,
        Err(e) => {
            let truth = match &e {
                ConnectError::Handshake { truth, .. } => truth.clone(),
                ConnectError::Open(_) => None,
            };
            let out = Outcome {
                target: Some(cfg.target),
                failure: Some(host::RunFailure {
                    kind: host::FailureKind::LinkLost,
                    step: None,
                    fault: None,
                    reject: None,
                    refusal: None,
                    message: e.to_string(),
                }),
                candidates: protocol::StateSet::ALL,
                ..Outcome::default()
            };
            return finish(&cfg, &out, truth);
        }
    };
    let mut shell = CliShell::new(interrupted.clone());
    // A recording gets the snap's pressure curve: telemetry at 50 Hz while the plan runs.
    let previous_rate = if conn.session.io.recording().is_some() {
        crate::cmd::monitor::set_telemetry_rate(&mut conn.session, 50)
    } else {
        None
    };
    // A profile's targets under the device's own pressure limit.
    let graph = match &cfg.calibration {
        Some(path) => {
            let limit = match conn.session.command(protocol::RequestBody::GetParam(
                protocol::ParamId::PressureLimitKpa,
            )) {
                Ok(protocol::ResponseBody::Param { value, .. }) => Some(f64::from(value)),
                _ => None,
            };
            crate::cmd::calibrate::plan_graph(path, &cfg.device, limit)?
        }
        None => cfg.graph.clone(),
    };
    let outcome = conn
        .session
        .run_plan(graph, cfg.target, RunOptions::default(), &mut shell);
    if let Some(value) = previous_rate {
        let _ = conn.session.command(protocol::RequestBody::SetParam {
            id: protocol::ParamId::TelemetryHz,
            value,
        });
    }
    let now = conn.session.io.now_ms();
    if let Some(rec) = conn.session.io.recording() {
        rec.outcome(now, &crate::outcome::PlanOutcome::of(&outcome, None));
    }
    let stats = conn.session.host.session().stats();
    if stats.retries > 0 || stats.frames_dropped > 0 {
        crate::say!(
            "link: {} requests, {} retried, {} corrupt frame{} dropped",
            stats.requests,
            stats.retries,
            stats.frames_dropped,
            if stats.frames_dropped == 1 { "" } else { "s" }
        );
    }
    let truth = conn.close();
    let result = finish(&cfg, &outcome, truth);
    if interrupted.load(Ordering::SeqCst) {
        return Err(Failure::Interrupted(
            outcome
                .error()
                .unwrap_or("interrupted after the target was reached")
                .to_string(),
        ));
    }
    result
}

/// `plan` through a server: the server runs it; its notes on stderr, the outcome as usual.
fn through_server(server: &std::path::Path, args: &Args) -> Result<(), Failure> {
    let target = args.target;
    if args.record.is_some() {
        return Err(Failure::usage(
            "a server holds this device and records its session itself: --record is not needed",
        ));
    }
    if args.calibration.is_some() {
        return Err(Failure::usage(
            "a server holds this device and plans with its own graph: --calibration needs the \
             device directly (stop the server, or plan without the profile)",
        ));
    }
    let (outcome, ok) =
        crate::client::run(server, &crate::serve_protocol::Request::Plan { target })?;
    if args.json {
        crate::cli::print_json(outcome.to_json());
    }
    if ok {
        if !args.json {
            crate::say!("{}", reached(target, outcome.steps.len(), 0));
        }
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "{}",
            outcome
                .error
                .as_deref()
                .unwrap_or("the target was not reached")
        )))
    }
}

/// Prints the outcome (JSON or a summary) and turns it into the exit status.
fn finish(cfg: &Config, out: &Outcome, truth: Option<SimTruth>) -> Result<(), Failure> {
    if cfg.json {
        crate::cli::print_json(outcome_json(out, truth.as_ref()));
    } else if out.ok() {
        crate::say!("{}", reached(cfg.target, out.steps.len(), out.replans));
    }
    if let Some(t) = &truth {
        if !cfg.json {
            crate::say!(
                "simulator: true state {}, max pressure {:.1} kPa (limit {:.1}), actuators {}",
                t.true_state.map_or("between states", |s| s.name()),
                t.max_pressure_kpa,
                t.pressure_limit_kpa,
                if t.actuators_safe { "safe" } else { "NOT SAFE" }
            );
        }
    }
    if out.ok() {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "{}",
            out.error().unwrap_or("the target was not reached")
        )))
    }
}

/// The summary of a successful run: `already at D&F` when nothing had to move, else
/// `reached D&F (2 steps, 1 replan)`.
fn reached(target: TrunkState, steps: usize, replans: u32) -> String {
    if steps == 0 {
        return format!("already at {target}");
    }
    let replans = if replans > 0 {
        format!(
            ", {}",
            crate::num::plural(replans as usize, "replan", "replans")
        )
    } else {
        String::new()
    };
    format!(
        "reached {target} ({}{replans})",
        crate::num::plural(steps, "step", "steps")
    )
}

/// The `plan --json` object ([`crate::outcome::PlanOutcome`]).
pub fn outcome_json(out: &Outcome, truth: Option<&SimTruth>) -> Value {
    crate::outcome::PlanOutcome::of(out, truth).to_json()
}

fn dry_run(cfg: &Config) -> Result<(), Failure> {
    let from = match (&cfg.from, &cfg.device) {
        (Some(from), _) => *from,
        (None, DeviceConfig::Sim(sim)) => sim.initial,
        (None, DeviceConfig::Port(_)) => {
            // Read-only: handshake and status, no command.
            let mut conn = cfg.device.connect()?;
            conn.session
                .status()
                .map_err(|e| anyhow::anyhow!("reading the device's state: {e}"))?
                .state
        }
    };
    let plan = cfg
        .graph
        .plan(from, cfg.target)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    if cfg.json {
        let steps: Vec<Value> = plan
            .steps()
            .iter()
            .map(|s| {
                json!({
                    "kind": kind_name(s.edge.kind()),
                    "from": s.edge.from().name(),
                    "to": s.edge.to().name(),
                    "expected_s": s.edge.cost_s,
                    "timeout_ms": s.edge.transition.timeout_ms,
                    "primitives": s.edge.transition.primitives.iter()
                        .map(|p| PrimitiveText(p).to_string()).collect::<Vec<_>>(),
                    "why": s.why,
                })
            })
            .collect();
        crate::cli::print_json(json!({
            "dry_run": true,
            "from": from.name(),
            "target": cfg.target.name(),
            "expected_s": plan.cost_s(),
            "steps": steps,
        }));
    } else {
        crate::out_raw!("{}", crate::cli::wrap(&plan.to_string()));
        crate::out!("(dry run: nothing was sent to the device)");
    }
    Ok(())
}
