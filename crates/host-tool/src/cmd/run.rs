//! `host-tool run MISSION.toml`: a mission's steps in order on the crane (or the simulator),
//! directly or through a `host-tool serve` server. The file is read and validated whole first
//! ([`crate::mission`]): a refusal names its line and reason, exit 2, nothing sent. Each step
//! is one of the commands' own functions (`plan`'s run through [`go_to_state`], `bend`'s step,
//! `grip`, `reach`, `vent`, `aim`, `identify`), under its time limit (a step still running at
//! its limit is aborted, the device safe) and its failure policy (`stop`: the mission stops,
//! the crane is made safe; `skip`: the next step). A mission that stops, fails or is
//! interrupted leaves `MISSION.toml.progress`, and `--resume` starts again at its first
//! unfinished step; a mission that completes removes it.

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

use serde_json::{json, Value};

use crate::cmd::prim::{bend_step, crane_config, ready, run_step, Link};
use crate::cmd::reach::{failure_text, go_to_state, plan_reach};
use crate::cmd::task::WorldArgs;
use crate::device::DeviceArgs;
use crate::failure::Failure;
use crate::mission::{self, Action, Mission, OnFailure, Step};
use crate::record::Level;

/// Arguments of `host-tool run`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "A mission is a TOML file of [[step]] tables, each one of: state = \"D&F\", \
bend = { angle = 20, toward = 90 }, grip = \"open\"|\"close\", reach = [X, Y, Z] (mm), vent = true, \
wait = \"60s\", aim = { toward = [AZ, EL] } or { sun = true, lat, lon, time }, identify = true, \
prompt = \"text\"; with time_limit = \"2m\" and on_failure = \"stop\" (default) or \"skip\". \
Examples: missions/*.toml; the format: docs/host.md, \"Missions\".

Examples:
  host-tool run missions/panel.toml --sim
  host-tool run missions/load.toml -p /dev/ttyACM0 --record load.mcap
  host-tool run my.toml --sim --resume          # again from the first unfinished step"
)]
pub struct Args {
    /// The mission file (TOML).
    #[arg(value_name = "MISSION.toml")]
    pub mission: PathBuf,
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub world: WorldArgs,
    /// Validate the mission and list its steps; move nothing (no device needed).
    #[arg(long)]
    pub dry_run: bool,
    /// Start at step N (1-based), the steps before it taken as done.
    #[arg(long, value_name = "N", conflicts_with = "resume",
          value_parser = crate::num::int_in(1, 100_000))]
    pub resume_from: Option<u32>,
    /// Start at the first unfinished step of the progress file a stopped run left
    /// (MISSION.toml.progress).
    #[arg(long)]
    pub resume: bool,
    /// Record the session to this MCAP file (`host-tool log` reads it).
    #[arg(long, value_name = "FILE.mcap", conflicts_with = "dry_run")]
    pub record: Option<PathBuf>,
    /// Print JSON Lines: one object per step as it ends, then a summary (`"summary": true`).
    #[arg(skip)]
    pub json: bool,
}

/// The progress file of a mission file: beside it, `.progress` appended.
pub fn progress_path(mission: &Path) -> PathBuf {
    let mut p = mission.as_os_str().to_owned();
    p.push(".progress");
    PathBuf::from(p)
}

/// How one step ended.
struct Ended {
    ok: bool,
    error: Option<String>,
    detail: Value,
    duration_ms: u64,
}

/// The step whose failure stopped the mission.
struct Stopped {
    index: usize,
    error: String,
    interrupted: bool,
}

fn runtime(text: String) -> Failure {
    Failure::Runtime(anyhow::anyhow!("{text}"))
}

/// Runs one step's action on the link; its details (JSON) on success.
fn act(
    link: &mut Link,
    cfg: &protocol::CraneGeometry,
    step: &Step,
    json_out: bool,
) -> Result<Value, Failure> {
    match &step.action {
        Action::State(target) => {
            go_to_state(link, *target)?;
            Ok(json!({"state": target.name()}))
        }
        Action::Bend { angle, toward } => {
            let st = ready(link)?;
            let ws = crate::cmd::pose::crane_workspace(cfg)?;
            let (s, cmd) = bend_step(&ws, cfg, st.state, *angle, *toward)?;
            let end = run_step(link, s)?;
            match end.error {
                Some(e) => Err(runtime(format!("the bend: {e}"))),
                None => Ok(
                    json!({"state": st.state.name(), "bend_deg": angle, "toward_deg": toward,
                                  "command": {"angle_deg": cmd.0, "toward_deg": cmd.1}}),
                ),
            }
        }
        Action::Grip(close) => {
            let events = crate::cmd::demo::grip(link, *close)?;
            for e in &events {
                if !json_out {
                    crate::say!("simulator: {}", e["text"].as_str().unwrap_or(""));
                }
                // A close that misses an object in the world is a miss the simulator sees.
                if e["event"] == "missed" && !e["object"].is_null() {
                    return Err(runtime(e["text"].as_str().unwrap_or("missed").to_string()));
                }
            }
            Ok(json!({"gripper_closed": close, "grasp": events}))
        }
        Action::Reach { point, tolerance } => {
            let st = ready(link)?;
            let plan = plan_reach(cfg, st.state, *point, *tolerance)?;
            crate::cmd::reach::execute(link, cfg, &plan)?;
            let mut detail = json!({"state": plan.state.name(), "distance_mm": plan.distance_mm});
            if let Some(sim) = link.sim() {
                let t = sim.true_tip().position_mm;
                let miss = (0..3)
                    .map(|k| (t[k] - point[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                detail["sim"] = json!({"true_tip_mm": t.map(|v| (v * 100.0).round() / 100.0),
                                       "error_mm": (miss * 1000.0).round() / 1000.0});
                if miss > *tolerance {
                    return Err(runtime(format!(
                        "the true tip ended {miss:.1} mm from the point, more than the {tolerance} mm tolerance"
                    )));
                }
            }
            Ok(detail)
        }
        Action::Vent => {
            let st = ready(link)?;
            match crate::cmd::prim::vent_step(link, &st)? {
                None => Ok(json!({"vented": false, "pressure_kpa": st.pressure_kpa})),
                Some(s) => {
                    let end = run_step(link, s)?;
                    match end.error {
                        Some(e) => Err(runtime(format!("venting: {e}"))),
                        None => {
                            Ok(json!({"vented": true, "pressure_kpa": end.status.pressure_kpa}))
                        }
                    }
                }
            }
        }
        Action::Wait(ms) => {
            let until = link.now_ms() + ms;
            crate::cmd::track::wait_until(link, until, "while a mission waited")?;
            Ok(json!({"waited_ms": ms}))
        }
        Action::Aim(a) => {
            let dir = match mission::aim_direction(a).map_err(runtime)? {
                Some(d) => d,
                None => {
                    // The sun when the step runs.
                    let mut now = a.clone();
                    if let mission::AimTarget::Sun { time, .. } = &mut now.target {
                        *time = Some(chrono::Utc::now());
                    }
                    mission::aim_direction(&now)
                        .map_err(runtime)?
                        .ok_or_else(|| runtime("no direction to aim at".into()))?
                }
            };
            let aimed = crate::cmd::aim::aim_crane(link, cfg, a.heading, dir, a.change_state)?;
            let mut detail = crate::cmd::aim::aim_json(aimed.state, &aimed.aim, None);
            detail["sim"] = crate::cmd::aim::truth_json(a.heading, aimed.truth);
            if aimed.within_tolerance() {
                Ok(detail)
            } else {
                Err(runtime(format!(
                    "the true tip axis ended further from the model's than its {}° tolerance",
                    crate::cmd::aim::SIM_AXIS_TOLERANCE_DEG
                )))
            }
        }
        Action::Identify => {
            let Link::Direct(conn) = link else {
                return Err(runtime(
                    "identify does not go through a `host-tool serve` server".into(),
                ));
            };
            let out = crate::cmd::identify::identify(conn);
            if crate::shell::interrupt_flag().load(Ordering::SeqCst) {
                return Err(Failure::Interrupted(
                    "interrupted while identifying: the device is in its safe state".into(),
                ));
            }
            if out.ok() {
                Ok(
                    json!({"state": out.final_state.map(|s| s.name()), "identified": out.identified}),
                )
            } else {
                Err(runtime(
                    out.error()
                        .unwrap_or("the device's state is still unconfirmed")
                        .to_string(),
                ))
            }
        }
        Action::Prompt { text, tip_load_kg } => {
            if let Some(sim) = link.sim() {
                if let Some(kg) = tip_load_kg {
                    crate::cmd::task::hang_load(sim, *kg)?;
                }
                if !json_out {
                    crate::say!("simulated person: {text}: done");
                }
                Ok(json!({"answered_by": "the simulator's person", "tip_load_kg": tip_load_kg}))
            } else {
                crate::cmd::demo::ask_person(text)?;
                Ok(json!({"answered_by": "a person (Enter)"}))
            }
        }
    }
}

/// Runs a step under its time limit.
fn run_one(
    link: &mut Link,
    cfg: &protocol::CraneGeometry,
    step: &Step,
    json_out: bool,
) -> Result<Ended, Failure> {
    let t0 = link.now_ms();
    crate::shell::set_deadline(step.time_limit_ms.map(|l| t0 + l));
    let r = act(link, cfg, step, json_out);
    crate::shell::set_deadline(None);
    let duration_ms = link.now_ms().saturating_sub(t0);
    let over = step.time_limit_ms.filter(|l| duration_ms >= *l);
    let (ok, error, detail) = match r {
        Err(Failure::Interrupted(m)) => return Err(Failure::Interrupted(m)),
        Ok(detail) if over.is_none() => (true, None, detail),
        Ok(detail) => (false, None, detail),
        Err(e) => (false, Some(failure_text(&e)), Value::Null),
    };
    let error = match over {
        Some(limit) => Some(format!(
            "exceeded its time limit of {} (stopped after {}){}",
            crate::num::seconds(limit),
            crate::num::seconds(duration_ms),
            error.map_or(String::new(), |e| format!(": {e}"))
        )),
        None => error,
    };
    Ok(Ended {
        ok: ok && error.is_none(),
        error,
        detail,
        duration_ms,
    })
}

/// Where a run starts (0-based), from `--resume-from` or the progress file of `--resume`.
fn start_index(args: &Args, m: &Mission) -> Result<usize, Failure> {
    let n = m.steps.len();
    let file = args.mission.display();
    if let Some(k) = args.resume_from {
        let k = k as usize;
        if k > n {
            return Err(Failure::usage(format!(
                "--resume-from {k}: {file} has {}",
                crate::num::plural(n, "step", "steps")
            )));
        }
        return Ok(k - 1);
    }
    if !args.resume {
        return Ok(0);
    }
    let path = progress_path(&args.mission);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        Failure::usage(format!(
            "--resume: no progress file {} ({e}): the mission has not stopped since it last completed; run it without --resume",
            path.display()
        ))
    })?;
    let v: Value = serde_json::from_str(&text).map_err(|e| {
        Failure::usage(format!(
            "--resume: {} is not a progress file: {e}",
            path.display()
        ))
    })?;
    if v["hash"].as_str() != Some(format!("{:016x}", m.hash).as_str()) {
        return Err(Failure::usage(format!(
            "--resume: {file} changed since the run that left {} stopped: give --resume-from N to say where to start",
            path.display()
        )));
    }
    match v["next_step"].as_u64().map(|k| k as usize) {
        Some(k) if (1..=n).contains(&k) => Ok(k - 1),
        _ => Err(Failure::usage(format!(
            "--resume: {} names no step of {file} to start at",
            path.display()
        ))),
    }
}

fn step_json(i: usize, m: &Mission, step: &Step, e: &Ended, skipped: bool) -> Value {
    json!({
        "step": i + 1,
        "of": m.steps.len(),
        "line": step.line,
        "kind": step.kind(),
        "name": step.name,
        "what": step.describe(),
        "ok": e.ok,
        "skipped": skipped,
        "duration_s": e.duration_ms as f64 / 1000.0,
        "time_limit_s": step.time_limit_ms.map(|l| l as f64 / 1000.0),
        "error": e.error,
        "detail": e.detail,
    })
}

/// Runs `host-tool run`.
pub fn run(args: Args) -> Result<(), Failure> {
    let file = args.mission.display().to_string();
    let text = std::fs::read_to_string(&args.mission)
        .map_err(|e| Failure::usage(format!("cannot read the mission {file}: {e}")))?;
    let m = mission::parse(&text).map_err(|r| Failure::usage(mission::refusal_text(&file, &r)))?;
    let cfg = crane_config(&args.device);
    let server = if args.dry_run {
        None
    } else {
        crate::client::server_for(&args.device)?
    };
    let world = args.world.parse()?;
    let needs_calibration = m
        .steps
        .iter()
        .any(|s| matches!(s.action, Action::Reach { .. } | Action::Aim(_)));
    if args.device.sim && needs_calibration {
        crate::cmd::task::calibrate_for_sim(&cfg)?;
    }
    let crane = mission::Crane {
        cfg: &cfg,
        sim: args.device.sim || (args.dry_run && args.device.port.is_none()),
        server: server.is_some(),
        terminal: std::io::stdin().is_terminal(),
    };
    let mut refusals = m.refusals.clone();
    refusals.extend(mission::check(&m, &crane));
    refusals.sort();
    if !refusals.is_empty() {
        return Err(Failure::usage(mission::refusal_text(&file, &refusals)));
    }
    let start = start_index(&args, &m)?;
    let title = m.name.clone().unwrap_or_else(|| file.clone());
    if args.dry_run {
        let steps: Vec<Value> = m
            .steps
            .iter()
            .enumerate()
            .map(|(i, s)| json!({"step": i + 1, "line": s.line, "kind": s.kind(), "what": s.describe(),
                                 "time_limit_s": s.time_limit_ms.map(|l| l as f64 / 1000.0),
                                 "on_failure": if s.on_failure == OnFailure::Skip { "skip" } else { "stop" }}))
            .collect();
        if args.json {
            crate::cli::print_json(json!({"ok": true, "dry_run": true, "mission": title,
                                          "from_step": start + 1, "steps": steps}));
        } else {
            crate::out!(
                "mission {title}: {}",
                crate::num::plural(m.steps.len(), "step", "steps")
            );
            for (i, s) in m.steps.iter().enumerate().skip(start) {
                crate::out!(
                    "  {:>2}. (line {}) {}{}{}",
                    i + 1,
                    s.line,
                    s.describe(),
                    s.time_limit_ms.map_or(String::new(), |l| format!(
                        ", within {}",
                        crate::num::seconds(l)
                    )),
                    if s.on_failure == OnFailure::Skip {
                        ", skipped if it fails"
                    } else {
                        ""
                    }
                );
            }
            crate::out!("(dry run: the mission is valid; nothing was sent to the device)");
        }
        return Ok(());
    }
    let mut link = Link::open_recorded(&args.device, &world, args.record.as_deref(), "run")?;
    let interrupted = crate::shell::interrupt_flag();
    let t0 = link.now_ms();
    if !args.json {
        crate::say!(
            "mission {title}: {}{}",
            crate::num::plural(m.steps.len(), "step", "steps"),
            if start > 0 {
                format!(", from step {}", start + 1)
            } else {
                String::new()
            }
        );
    }
    link.log(
        Level::Info,
        &format!(
            "mission {title}: {} steps, from step {}",
            m.steps.len(),
            start + 1
        ),
    );
    let mut done = 0usize;
    let mut skipped = Vec::new();
    let mut stopped: Option<Stopped> = None;
    for (i, step) in m.steps.iter().enumerate().skip(start) {
        if interrupted.load(Ordering::SeqCst) {
            stopped = Some(Stopped {
                index: i,
                error: "interrupted between steps: nothing was moving".into(),
                interrupted: true,
            });
            break;
        }
        let head = format!("step {}/{} (line {})", i + 1, m.steps.len(), step.line);
        crate::say!("{head}: {}", step.describe());
        link.log(Level::Info, &format!("{head} starts: {}", step.describe()));
        let ended = match run_one(&mut link, &cfg, step, args.json) {
            Ok(e) => e,
            Err(e) => {
                let error = failure_text(&e);
                link.log(Level::Error, &format!("{head}: {error}"));
                stopped = Some(Stopped {
                    index: i,
                    error,
                    interrupted: true,
                });
                break;
            }
        };
        let skip = !ended.ok && step.on_failure == OnFailure::Skip;
        if args.json {
            crate::cli::print_json(step_json(i, &m, step, &ended, skip));
        } else {
            let took = crate::num::seconds(ended.duration_ms);
            match (&ended.error, skip) {
                (None, _) => crate::out!("{head} {}: done in {took}", step.describe()),
                (Some(e), true) => crate::out!(
                    "{head} {}: failed after {took}, skipped (on_failure = \"skip\"): {e}",
                    step.describe()
                ),
                (Some(e), false) => {
                    crate::out!("{head} {}: FAILED after {took}: {e}", step.describe())
                }
            }
        }
        match &ended.error {
            None => {
                done += 1;
                link.log(Level::Info, &format!("{head} done"));
            }
            Some(e) => {
                link.log(Level::Error, &format!("{head} failed: {e}"));
                if skip {
                    skipped.push(i + 1);
                } else {
                    stopped = Some(Stopped {
                        index: i,
                        error: format!(
                            "step {} ({}, line {}): {}",
                            i + 1,
                            step.kind(),
                            step.line,
                            e
                        ),
                        interrupted: false,
                    });
                    break;
                }
            }
        }
    }
    // Stop safe: whatever the failed step left running or pressurised is stopped.
    let mut safe_error = None;
    if stopped.as_ref().is_some_and(|s| !s.interrupted) {
        if let Err(e) = link.command(protocol::RequestBody::Abort) {
            safe_error = Some(failure_text(&e));
        }
    }
    let virtual_s = link
        .sim()
        .is_some()
        .then(|| (link.now_ms() - t0) as f64 / 1000.0);
    let st = link.status().ok();
    let truth = link.sim().map(|sim| {
        json!({
            "true_state": sim.trunk().state().map(|s| s.name()),
            "true_tip_mm": sim.true_tip().position_mm.map(|v| (v * 10.0).round() / 10.0),
            "pressure_kpa": (sim.trunk().pressure_kpa() * 100.0).round() / 100.0,
            "world": sim.world().to_json(),
        })
    });
    link.close();
    let progress = progress_path(&args.mission);
    let mut progress_written = None;
    match &stopped {
        None => {
            let _ = std::fs::remove_file(&progress);
        }
        Some(s) => {
            let v = json!({
                "mission": file,
                "hash": format!("{:016x}", m.hash),
                "steps": m.steps.len(),
                "next_step": s.index + 1,
                "line": m.steps[s.index].line,
                "skipped": skipped,
                "error": s.error,
                "interrupted": s.interrupted,
            });
            match serde_json::to_string_pretty(&v)
                .map_err(|e| e.to_string())
                .and_then(|t| std::fs::write(&progress, t + "\n").map_err(|e| e.to_string()))
            {
                Ok(()) => progress_written = Some(progress.display().to_string()),
                Err(e) => crate::say!(
                    "could not write the progress file {}: {e}",
                    progress.display()
                ),
            }
        }
    }
    let ok = stopped.is_none();
    if args.json {
        crate::cli::print_json(json!({
            "summary": true,
            "ok": ok,
            "mission": title,
            "steps": m.steps.len(),
            "from_step": start + 1,
            "done": done,
            "skipped": skipped,
            "stopped_at": stopped.as_ref().map(|s| s.index + 1),
            "progress_file": progress_written,
            "state": st.as_ref().map(|s| s.state.name()),
            "state_confirmed": st.as_ref().map(|s| s.state_confirmed),
            "virtual_s": virtual_s,
            "error": stopped.as_ref().map(|s| s.error.clone()),
            "safe_error": safe_error,
            "sim": truth,
        }));
    } else {
        match &stopped {
            None => crate::out!(
                "mission {title}: {done} of {} done{}{}",
                crate::num::plural(m.steps.len() - start, "step", "steps"),
                if skipped.is_empty() {
                    String::new()
                } else {
                    format!(", {} skipped", skipped.len())
                },
                virtual_s.map_or(String::new(), |s| format!(" in {s:.1} s (virtual)"))
            ),
            Some(s) => crate::out!(
                "mission {title}: stopped at step {}{}; {}",
                s.index + 1,
                if s.interrupted {
                    ""
                } else {
                    ", the crane made safe"
                },
                progress_written
                    .as_ref()
                    .map_or("no progress file".to_string(), |p| format!(
                        "{p} written: `host-tool run {file} --resume` starts again at step {}",
                        s.index + 1
                    ))
            ),
        }
        if let Some(st) = &st {
            crate::out!(
                "the device: {}{}, gripper {}, {} kPa",
                st.state,
                if st.state_confirmed {
                    " (confirmed)"
                } else {
                    " (NOT confirmed)"
                },
                if st.gripper_closed { "closed" } else { "open" },
                crate::num::fixed(f64::from(st.pressure_kpa), 1)
            );
        }
    }
    match stopped {
        None => Ok(()),
        Some(s) if s.interrupted => Err(Failure::Interrupted(s.error)),
        Some(s) => Err(runtime(s.error)),
    }
}
