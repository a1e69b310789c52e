//! `host-tool reach --point X,Y,Z`: put the tip at a point — the state and bend whose tip (the
//! geometry's) is nearest, the cheapest way there from where the trunk is, shown, then done;
//! a point no state reaches within the tolerance is refused before anything moves, naming the
//! nearest reachable point.

use std::sync::atomic::Ordering;

use geometry::TrunkState;
use host::RunOptions;
use planner::graph::{kind_name, Graph};
use planner::task::ReachPlan;
use serde_json::{json, Value};

use crate::cmd::prim::{bend_step, crane_config, run_step, Link};
use crate::cmd::task::WorldArgs;
use crate::device::DeviceArgs;
use crate::failure::Failure;

/// Arguments of `host-tool reach`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The point for the tip: X,Y,Z in mm (base frame: z up along the straight trunk, x toward
    /// tendon 0).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true,
          value_parser = crate::arg::usage(|s: &str| parse_point("--point", s)))]
    pub point: [f64; 3],
    /// How near the geometry's tip must come to the point, mm (> 0; with --sim the true tip
    /// is judged by it too).
    #[arg(long, value_name = "MM", default_value = "5", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_tolerance))]
    pub tolerance: f64,
    /// Show the plan and move nothing.
    #[arg(long)]
    pub dry_run: bool,
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub world: WorldArgs,
    /// Record the session to this MCAP file (`host-tool log` reads it).
    #[arg(long, value_name = "FILE.mcap", conflicts_with = "dry_run")]
    pub record: Option<std::path::PathBuf>,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// Parses `X,Y,Z` (mm).
pub fn parse_point(what: &str, text: &str) -> Result<[f64; 3], Failure> {
    let bad = || {
        Failure::usage(format!(
            "invalid {what} '{text}': expected X,Y,Z in mm, e.g. 30,0,140"
        ))
    };
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(bad()),
    }
}

/// Parses a tolerance in mm (finite, > 0).
pub fn parse_tolerance(text: &str) -> Result<f64, Failure> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|t| t.is_finite() && *t > 0.0)
        .ok_or_else(|| {
            Failure::usage(format!(
                "invalid --tolerance '{text}': expected a distance in mm > 0"
            ))
        })
}

/// The plan to put the tip at `goal` from `from`, or the refusal (a usage error: no state
/// reaches it, whatever the trunk's state).
pub fn plan_reach(
    cfg: &protocol::CraneGeometry,
    from: TrunkState,
    goal: [f64; 3],
    tolerance: f64,
) -> Result<ReachPlan, Failure> {
    let ws = crate::cmd::task::task_workspace(cfg)?;
    ws.reach(from, goal, tolerance, &Graph::nominal())
        .map_err(|e| match e {
            planner::task::TaskError::OutOfReach { .. } => Failure::usage(format!("refused: {e}")),
            e => Failure::Runtime(anyhow::anyhow!("{e}")),
        })
}

/// The plan in words and as JSON.
fn describe(p: &ReachPlan) -> (Vec<String>, Value) {
    let mut lines = Vec::new();
    let mut steps = Vec::new();
    for s in p.transitions.steps() {
        lines.push(format!(
            "  {} → {} ({}, ≈{:.0} s): {}",
            s.edge.from(),
            s.edge.to(),
            kind_name(s.edge.kind()),
            s.edge.cost_s,
            s.why
        ));
        steps.push(json!({"kind": kind_name(s.edge.kind()), "from": s.edge.from().name(), "to": s.edge.to().name()}));
    }
    let (angle, toward) = bend_degrees(p);
    if angle > 0.0 || p.state.is_flexible() {
        lines.push(format!(
            "  bend {angle:.2}° toward {toward:.1}° in {}",
            p.state
        ));
    }
    let tip = p.tip.position_mm;
    lines.push(format!(
        "  the tip then at ({:.1}, {:.1}, {:.1}) mm, {:.2} mm from the point; expected ≈{:.0} s",
        tip[0], tip[1], tip[2], p.distance_mm, p.expected_s
    ));
    (
        lines,
        json!({
            "state": p.state.name(),
            "bend_deg": angle,
            "toward_deg": toward,
            "transitions": steps,
            "tip_mm": tip.map(|v| (v * 100.0).round() / 100.0),
            "distance_mm": (p.distance_mm * 1000.0).round() / 1000.0,
            "expected_s": (p.expected_s * 10.0).round() / 10.0,
        }),
    )
}

/// The bend of a plan in degrees (angle ≥ 0, direction in [0, 360)), straight below 1e-6°.
pub fn bend_degrees(p: &ReachPlan) -> (f64, f64) {
    let a = p.bend.angle.to_degrees();
    if a < 1e-6 {
        (0.0, 0.0)
    } else {
        (
            (a * 1e4).round() / 1e4,
            (p.bend.direction.to_degrees() * 1e3).round() / 1e3,
        )
    }
}

/// Takes the trunk to `target` through the planner's cheapest plan (direct: the run engine;
/// through a server: its `plan` op).
pub fn go_to_state(link: &mut Link, target: TrunkState) -> Result<(), Failure> {
    match link {
        Link::Direct(conn) => {
            let interrupted = crate::shell::interrupt_flag();
            let mut shell = crate::shell::CliShell::new(interrupted.clone());
            let out =
                conn.session
                    .run_plan(Graph::nominal(), target, RunOptions::default(), &mut shell);
            if interrupted.load(Ordering::SeqCst) {
                return Err(Failure::Interrupted(
                    "interrupted: the plan was aborted, the crane made safe".into(),
                ));
            }
            if out.ok() {
                Ok(())
            } else {
                Err(Failure::Runtime(anyhow::anyhow!(
                    "going to {target}: {}",
                    out.error().unwrap_or("the state was not reached")
                )))
            }
        }
        Link::Server(path) => {
            let (outcome, ok) =
                crate::client::run(path, &crate::serve_protocol::Request::Plan { target })?;
            if ok {
                Ok(())
            } else {
                Err(Failure::Runtime(anyhow::anyhow!(
                    "going to {target}: {}",
                    outcome
                        .error
                        .as_deref()
                        .unwrap_or("the state was not reached")
                )))
            }
        }
    }
}

/// Carries out a reach plan: the transitions, then the bend (or straightening) in the state.
pub fn execute(
    link: &mut Link,
    cfg: &protocol::CraneGeometry,
    plan: &ReachPlan,
) -> Result<protocol::Status, Failure> {
    let st = link.status()?;
    if st.state != plan.state {
        go_to_state(link, plan.state)?;
    }
    let st = link.status()?;
    if let Some(why) = crate::cmd::prim::blocked(&st) {
        return Err(Failure::Runtime(anyhow::anyhow!(
            "after the transitions: {why}"
        )));
    }
    if !plan.state.is_flexible() {
        return Ok(st);
    }
    let ws = crate::cmd::task::task_workspace(cfg)?;
    let (angle, toward) = bend_degrees(plan);
    let (step, _) = bend_step(
        &ws,
        cfg,
        plan.state,
        angle.min(ws.limit_deg(plan.state).unwrap_or(0.0)),
        toward,
    )?;
    let end = run_step(link, step)?;
    match end.error {
        None => Ok(end.status),
        Some(e) => Err(Failure::Runtime(anyhow::anyhow!("the bend: {e}"))),
    }
}

/// Runs `host-tool reach`.
pub fn run(args: Args) -> Result<(), Failure> {
    let goal = args.point;
    let tolerance = args.tolerance;
    let world = args.world.parse()?;
    let cfg = crane_config(&args.device);
    if args.device.sim {
        crate::cmd::task::calibrate_for_sim(&cfg)?;
    }
    // Refused before anything is opened when no state reaches the point at all.
    plan_reach(&cfg, TrunkState::AS_MANUFACTURED, goal, tolerance)?;
    let mut link = Link::open_recorded(&args.device, &world, args.record.as_deref(), "reach")?;
    let st = link.status()?;
    if let Some(why) = crate::cmd::prim::blocked(&st) {
        link.close();
        return Err(Failure::Runtime(anyhow::anyhow!("refused: {why}")));
    }
    let plan = plan_reach(&cfg, st.state, goal, tolerance)?;
    let (lines, plan_json) = describe(&plan);
    if !args.json {
        crate::out!(
            "reach ({:.1}, {:.1}, {:.1}) mm from {}:",
            goal[0],
            goal[1],
            goal[2],
            st.state
        );
        for l in &lines {
            crate::out!("{l}");
        }
    }
    if args.dry_run {
        if args.json {
            crate::cli::print_json(
                json!({"ok": true, "dry_run": true, "from": st.state.name(), "point_mm": goal, "plan": plan_json}),
            );
        } else {
            crate::out!("(dry run: nothing was sent to the device)");
        }
        link.close();
        return Ok(());
    }
    let started = link.sim().map(|s| s.now_ms());
    let result = execute(&mut link, &cfg, &plan);
    let (truth, miss) = match link.sim() {
        Some(sim) => {
            let t = sim.true_tip().position_mm;
            let e =
                ((t[0] - goal[0]).powi(2) + (t[1] - goal[1]).powi(2) + (t[2] - goal[2]).powi(2))
                    .sqrt();
            let virtual_s = started.map(|s| (sim.now_ms() - s) as f64 / 1000.0);
            (
                Some(json!({
                    "true_state": sim.trunk().state().map(|s| s.name()),
                    "true_tip_mm": t.map(|v| (v * 100.0).round() / 100.0),
                    "error_mm": (e * 1000.0).round() / 1000.0,
                    "virtual_s": virtual_s,
                })),
                Some(e),
            )
        }
        None => (None, None),
    };
    let st = link.status().ok();
    link.close();
    let within = miss.is_none_or(|e| e <= tolerance);
    let ok = result.is_ok() && within;
    if args.json {
        crate::cli::print_json(json!({
            "ok": ok,
            "point_mm": goal,
            "tolerance_mm": tolerance,
            "plan": plan_json,
            "state": st.as_ref().map(|s| s.state.name()),
            "state_confirmed": st.as_ref().map(|s| s.state_confirmed),
            "error": result.as_ref().err().map(failure_text),
            "sim": truth,
        }));
    } else if let Some(t) = &truth {
        crate::out!(
            "simulator: true tip ({}, {}, {}) mm, {} mm from the point (tolerance {tolerance} mm){}",
            t["true_tip_mm"][0],
            t["true_tip_mm"][1],
            t["true_tip_mm"][2],
            t["error_mm"],
            if within { "" } else { ": MISSED" }
        );
    }
    result?;
    if within {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "the true tip ended {:.1} mm from the point, more than the {tolerance} mm tolerance",
            miss.unwrap_or(f64::NAN)
        )))
    }
}

/// A failure's message.
pub fn failure_text(f: &Failure) -> String {
    match f {
        Failure::Usage(m) | Failure::Interrupted(m) => m.clone(),
        Failure::Runtime(e) => format!("{e:#}"),
    }
}
