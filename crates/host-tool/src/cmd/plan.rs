//! `host-tool plan --target STATE`: take the crane (or the simulator) to a trunk state.
//!
//! Open → handshake → status → cheapest plan from the device's state → upload, start → follow
//! (progress, manual prompts, replanning) → exit 0 only when the device reports the target.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;

use geometry::TrunkState;
use planner::graph::{kind_name, Graph, PrimitiveText};
use serde_json::{json, Value};

use crate::device::{parse_state, ConnectError, DeviceArgs, DeviceConfig};
use crate::executor::{ExecOptions, Executor, Outcome, Progress};
use crate::failure::Failure;
use crate::progress::{Bars, Lines};
use crate::sim::SimTruth;

/// The simulator's default speed for `plan` (virtual seconds per wall second).
pub const DEFAULT_SIM_SPEED: f64 = 20.0;

/// Arguments of `host-tool plan`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The trunk state to reach: F&P, F&F, F&D, D&P, D&F or D&D.
    #[arg(long, value_name = "STATE")]
    pub target: String,
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Print the plan and touch nothing (plans from --from, or the simulator's initial state;
    /// with --port it reads the device's state but sends no command).
    #[arg(long)]
    pub dry_run: bool,
    /// With --dry-run: plan from this state instead of asking the device.
    #[arg(long, value_name = "STATE", requires = "dry_run")]
    pub from: Option<String>,
    /// Print one JSON object on stdout instead of a summary.
    #[arg(long)]
    pub json: bool,
}

/// Validated arguments.
struct Config {
    target: TrunkState,
    device: DeviceConfig,
    dry_run: bool,
    from: Option<TrunkState>,
    json: bool,
}

impl Args {
    fn validate(&self) -> Result<Config, Failure> {
        Ok(Config {
            target: parse_state("target", &self.target)?,
            device: self.device.validate(DEFAULT_SIM_SPEED)?,
            dry_run: self.dry_run,
            from: self
                .from
                .as_deref()
                .map(|s| parse_state("--from", s))
                .transpose()?,
            json: self.json,
        })
    }
}

/// Runs `host-tool plan`.
pub fn run(args: Args) -> Result<(), Failure> {
    let cfg = args.validate()?;
    if cfg.dry_run {
        return dry_run(&cfg);
    }
    let cancel = Arc::new(AtomicBool::new(false));
    {
        let cancel = cancel.clone();
        // A second handler cannot be installed (e.g. in tests calling run twice): then Ctrl-C
        // simply kills the process, and the device's link watchdog makes it safe.
        let _ = ctrlc::set_handler(move || cancel.store(true, Ordering::SeqCst));
    }
    let mut conn = match cfg.device.connect() {
        Ok(c) => c,
        Err(e) => {
            let truth = match e {
                ConnectError::Handshake {
                    sim: Some(ref sim), ..
                } => Some(sim.truth()),
                _ => None,
            };
            let out = Outcome {
                target: Some(cfg.target),
                error: Some(e.to_string()),
                ..Outcome::default()
            };
            return finish(&cfg, &out, truth);
        }
    };
    let graph = Graph::nominal();
    let mut ui: Box<dyn Progress> = if std::io::stderr().is_terminal() {
        Box::new(Bars::default())
    } else {
        Box::new(Lines)
    };
    let confirm = stdin_confirmations();
    let options = ExecOptions {
        cancel,
        ..ExecOptions::default()
    };
    let outcome =
        Executor::new(&mut conn.session, &graph, options, ui.as_mut(), confirm).run(cfg.target);
    let stats = conn.session.stats();
    let link = conn.session.link_stats();
    if stats.retries > 0 || link.frames_dropped > 0 {
        eprintln!(
            "link: {} requests, {} retried, {} corrupt frames dropped",
            stats.requests, stats.retries, link.frames_dropped
        );
    }
    let truth = conn.close();
    finish(&cfg, &outcome, truth)
}

/// Prints the outcome (JSON or a summary) and turns it into the exit status.
fn finish(cfg: &Config, out: &Outcome, truth: Option<SimTruth>) -> Result<(), Failure> {
    if cfg.json {
        println!("{}", outcome_json(out, truth.as_ref()));
    } else if out.ok() {
        let steps = out.steps.len();
        eprintln!(
            "reached {} ({} step{}{})",
            cfg.target,
            steps,
            if steps == 1 { "" } else { "s" },
            if out.replans > 0 {
                format!(
                    ", {} replan{}",
                    out.replans,
                    if out.replans == 1 { "" } else { "s" }
                )
            } else {
                String::new()
            }
        );
    }
    if let Some(t) = &truth {
        if !cfg.json {
            eprintln!(
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
            out.error.as_deref().unwrap_or("the target was not reached")
        )))
    }
}

/// The `plan --json` object: exactly `ok, from, target, final_state, steps, error, sim`.
pub fn outcome_json(out: &Outcome, truth: Option<&SimTruth>) -> Value {
    let name = |s: Option<TrunkState>| s.map(|s| s.name());
    json!({
        "ok": out.ok(),
        "from": name(out.from),
        "target": name(out.target),
        "final_state": name(out.final_state),
        "steps": out.steps.iter().map(|s| json!({
            "kind": kind_name(s.kind),
            "from": s.from.name(),
            "to": s.to.name(),
            "ok": s.ok,
            "duration_ms": s.duration_ms,
        })).collect::<Vec<_>>(),
        "error": out.error,
        "sim": truth.map(SimTruth::to_json),
    })
}

/// A thread that turns each line typed on a terminal into a confirmation; none when stdin is
/// not a terminal (never block on a pipe or /dev/null).
fn stdin_confirmations() -> Option<mpsc::Receiver<()>> {
    if !std::io::stdin().is_terminal() {
        return None;
    }
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        while std::io::stdin().read_line(&mut line).is_ok_and(|n| n > 0) {
            line.clear();
            if tx.send(()).is_err() {
                break;
            }
        }
    });
    Some(rx)
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
    let plan = Graph::nominal()
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
        println!(
            "{}",
            json!({
                "dry_run": true,
                "from": from.name(),
                "target": cfg.target.name(),
                "expected_s": plan.cost_s(),
                "steps": steps,
            })
        );
    } else {
        print!("{plan}");
        println!("(dry run: nothing was sent to the device)");
    }
    Ok(())
}
