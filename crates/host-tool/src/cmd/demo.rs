//! `host-tool pick --at P --place Q` (§6.3's cycle: reach P, close, carry, open at Q,
//! straighten) and `host-tool demo manipulation|panel|load` (the paper's demonstrations, each ending
//! with a verdict checked against the truth on the simulator, against the device's word and a
//! person's on a crane).

use geometry::TrunkState;
use serde_json::{json, Value};

use crate::cmd::prim::{bend_step, blocked, crane_config, run_step, Link};
use crate::cmd::reach::{execute, parse_point, parse_tolerance, plan_reach};
use crate::cmd::task::{grasp_json, WorldArgs};
use crate::device::DeviceArgs;
use crate::failure::Failure;
use protocol::{Primitive, Status};

/// Arguments of `host-tool pick`.
#[derive(Debug, clap::Args)]
pub struct PickArgs {
    /// Where the object's grasp point is: X,Y,Z mm.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true,
          value_parser = crate::arg::usage(|s: &str| parse_point("--at", s)))]
    pub at: [f64; 3],
    /// Where to let it go: X,Y,Z mm (it falls to the table below).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true,
          value_parser = crate::arg::usage(|s: &str| parse_point("--place", s)))]
    pub place: [f64; 3],
    /// How near the geometry's tip must come to each point, mm.
    #[arg(long, value_name = "MM", default_value = "5", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_tolerance))]
    pub tolerance: f64,
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub world: WorldArgs,
    /// Record the session to this MCAP file.
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<std::path::PathBuf>,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// Which demonstration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Which {
    /// §6.3: three objects at three heights, picked in F&P, F&F and D&F and placed again,
    /// straightening after each.
    Manipulation,
    /// §6.4: a panel on the tip turned toward eight directions in F&D (after F&P → D&D → F&D)
    /// without changing its height.
    Panel,
    /// §6.5: 5.7 kg on the tip of D&D for 60 s with no air.
    Load,
}

/// Arguments of `host-tool demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// manipulation, panel or load.
    #[arg(value_enum)]
    pub which: Which,
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Record the session to this MCAP file.
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<std::path::PathBuf>,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// What the object did in a pick, as far as it is known.
#[derive(Debug, Clone, PartialEq)]
pub struct Picked {
    /// The object (the simulator's name), if one was caught.
    pub object: Option<String>,
    /// The grasp events in order (the simulator only).
    pub events: Vec<Value>,
}

fn note(json: bool, text: &str) {
    if !json {
        crate::say!("{text}");
    }
}

/// Opens or closes the gripper (nothing to do when it is there already) and returns the
/// simulator's grasp events.
pub fn grip(link: &mut Link, close: bool) -> Result<Vec<Value>, Failure> {
    let st = link.status()?;
    if let Some(why) = blocked(&st) {
        return Err(Failure::Runtime(anyhow::anyhow!("{why}")));
    }
    let mut events = Vec::new();
    if st.gripper_closed != close {
        let step = crate::cmd::prim::step_for(st.state, Primitive::Gripper { close });
        let end = run_step(link, step)?;
        if let Some(e) = end.error {
            return Err(Failure::Runtime(anyhow::anyhow!("the gripper: {e}")));
        }
    }
    if let Some(sim) = link.sim() {
        events = sim
            .world_mut()
            .take_events()
            .iter()
            .map(grasp_json)
            .collect();
    }
    Ok(events)
}

fn straighten(link: &mut Link, cfg: &protocol::CraneGeometry) -> Result<(), Failure> {
    let st = link.status()?;
    if !st.state.is_flexible() {
        return Ok(());
    }
    let ws = crate::cmd::pose::crane_workspace(cfg)?;
    let (step, _) = bend_step(&ws, cfg, st.state, 0.0, 0.0)?;
    let end = run_step(link, step)?;
    end.error.map_or(Ok(()), |e| {
        Err(Failure::Runtime(anyhow::anyhow!("straightening: {e}")))
    })
}

/// How a pick whose close caught nothing (the simulator's world says so) fails.
const NOTHING_CAUGHT: &str = "nothing was caught";

/// §6.3's cycle on an open link: open the gripper, reach `at`, close, reach `place`, open,
/// straighten. With a crane (no simulator) a person is asked to place the object first.
pub fn pick(
    link: &mut Link,
    cfg: &protocol::CraneGeometry,
    at: [f64; 3],
    place: [f64; 3],
    tolerance: f64,
    json: bool,
) -> Result<Picked, Failure> {
    let mut events = Vec::new();
    if link.sim().is_none() {
        ask_person(&format!(
            "place the object with its grasp point at ({:.0}, {:.0}, {:.0}) mm",
            at[0], at[1], at[2]
        ))?;
    }
    note(json, "open the gripper");
    events.extend(grip(link, false)?);
    let st = link.status()?;
    let to_at = plan_reach(cfg, st.state, at, tolerance)?;
    note(
        json,
        &format!(
            "reach ({:.1}, {:.1}, {:.1}) mm in {}",
            at[0], at[1], at[2], to_at.state
        ),
    );
    execute(link, cfg, &to_at)?;
    note(json, "close the gripper");
    let caught = grip(link, true)?;
    let object = caught
        .iter()
        .find(|e| e["event"] == "captured")
        .and_then(|e| e["object"].as_str())
        .map(str::to_string);
    events.extend(caught);
    if link.sim().is_some() && object.is_none() {
        return Err(Failure::Runtime(anyhow::anyhow!(
            "{NOTHING_CAUGHT} at ({:.1}, {:.1}, {:.1}) mm: {}",
            at[0],
            at[1],
            at[2],
            events
                .last()
                .and_then(|e| e["text"].as_str())
                .unwrap_or("no object there")
        )));
    }
    let st = link.status()?;
    let to_place = plan_reach(cfg, st.state, place, tolerance)?;
    note(
        json,
        &format!(
            "carry to ({:.1}, {:.1}, {:.1}) mm in {}",
            place[0], place[1], place[2], to_place.state
        ),
    );
    execute(link, cfg, &to_place)?;
    note(json, "open the gripper");
    events.extend(grip(link, false)?);
    note(json, "straighten");
    straighten(link, cfg)?;
    Ok(Picked { object, events })
}

/// Asks the person at the crane to do something, and waits for Enter (a terminal is needed).
pub fn ask_person(what: &str) -> Result<(), Failure> {
    if !crate::keyboard::available() {
        return Err(Failure::Runtime(anyhow::anyhow!(
            "refused: a person must {what} first, and confirm with Enter: run this on a terminal"
        )));
    }
    crate::keyboard::discard_typed();
    crate::say!("please {what}, then press Enter");
    crate::keyboard::next_line()
        .map(|_| ())
        .ok_or_else(|| anyhow::anyhow!("the terminal closed before the confirmation").into())
}

/// Runs `host-tool pick`.
pub fn run_pick(args: PickArgs) -> Result<(), Failure> {
    let at = args.at;
    let place = args.place;
    let tolerance = args.tolerance;
    let world = args.world.parse()?;
    let cfg = crane_config(&args.device);
    if args.device.sim {
        crate::cmd::task::calibrate_for_sim(&cfg)?;
    }
    plan_reach(&cfg, TrunkState::AS_MANUFACTURED, at, tolerance)?;
    plan_reach(&cfg, TrunkState::AS_MANUFACTURED, place, tolerance)?;
    let mut link = Link::open_recorded(&args.device, &world, args.record.as_deref(), "pick")?;
    let st = link.status()?;
    if let Some(why) = blocked(&st) {
        link.close();
        return Err(Failure::Runtime(anyhow::anyhow!("refused: {why}")));
    }
    let result = pick(&mut link, &cfg, at, place, tolerance, args.json);
    let world_json = link.sim().map(|s| s.world().to_json());
    let st = link.status().ok();
    link.close();
    let fate = fate(&result, st.as_ref());
    if args.json {
        crate::cli::print_json(json!({
            "ok": result.is_ok(),
            "object": result.as_ref().ok().and_then(|p| p.object.clone()),
            "events": result.as_ref().map(|p| p.events.clone()).unwrap_or_default(),
            "object_fate": fate,
            "state": st.as_ref().map(|s| s.state.name()),
            "state_confirmed": st.as_ref().map(|s| s.state_confirmed),
            "error": result.as_ref().err().map(crate::cmd::reach::failure_text),
            "sim": world_json,
        }));
    } else if let Ok(p) = &result {
        crate::out!(
            "picked {} and let it go at ({:.1}, {:.1}, {:.1}) mm",
            p.object.as_deref().unwrap_or("the object"),
            place[0],
            place[1],
            place[2]
        );
    } else {
        crate::say!("the object: {fate}");
    }
    result.map(|_| ())
}

/// What became of the object, as far as the crane can tell — no sensor sees the object, so
/// after a failure it is the gripper's state the device last reported, or unknown when the
/// device no longer answers. (On `--sim`, the simulator's truth is beside it, under `sim`.)
fn fate(result: &Result<Picked, Failure>, st: Option<&Status>) -> &'static str {
    match (result, st) {
        (Ok(_), _) => "placed",
        (Err(e), _) if crate::cmd::reach::failure_text(e).starts_with(NOTHING_CAUGHT) => {
            "not caught (the simulator's world: nothing at the grasp point)"
        }
        (Err(_), Some(s)) if s.gripper_closed => "held (the gripper is closed)",
        (Err(_), Some(_)) => "released (the gripper is open)",
        (Err(_), None) => "unknown (the device does not answer: look at the crane)",
    }
}

/// One part of the manipulation demo: the object's name, where it is, where it goes (mm).
type Part = (String, [f64; 3], [f64; 3]);

/// The three objects of §6.3: one at each height, each picked in its state and placed on the
/// other side.
fn manipulation_set(cfg: &protocol::CraneGeometry) -> Result<Vec<Part>, Failure> {
    let ws = crate::cmd::task::task_workspace(cfg)?;
    let tip = |s: &str, angle: f64, dir: f64| -> Result<[f64; 3], Failure> {
        let state: TrunkState = s.parse().map_err(|_| anyhow::anyhow!("state {s}"))?;
        ws.tip(state, angle, dir)
            .map(|t| t.position_mm.map(|v| (v * 10.0).round() / 10.0))
            .map_err(|e| Failure::Runtime(anyhow::anyhow!("{e}")))
    };
    Ok(vec![
        // Part 1: the straight F&P tip; placed from F&F, bent the other way.
        (
            "low".into(),
            tip("F&P", 0.0, 0.0)?,
            tip("F&F", 15.0, 180.0)?,
        ),
        // Part 2: higher, in F&F's workspace.
        (
            "middle".into(),
            tip("F&F", 15.0, 0.0)?,
            tip("F&F", 15.0, 240.0)?,
        ),
        // Part 3: higher again, in D&F's.
        (
            "high".into(),
            tip("D&F", 12.0, 0.0)?,
            tip("D&F", 12.0, 180.0)?,
        ),
    ])
}

/// How far an object may land from below its place point, mm: the reach tolerance (the host
/// plans with the workspace calibrated against the simulator: its tip within 2 mm).
pub const PLACE_TOLERANCE_MM: f64 = 5.0;

/// Runs `host-tool demo`.
pub fn run_demo(args: DemoArgs) -> Result<(), Failure> {
    match args.which {
        Which::Manipulation => manipulation(&args),
        Which::Load => load(&args),
        Which::Panel => panel(&args),
    }
}

/// The panel's tilt in the panel demo, degrees.
pub const PANEL_TILT_DEG: f64 = 20.0;
/// How far the panel's true facing may be from each direction asked, degrees (the simulator's
/// bend leans up to ≈ 11° toward the tendon that carries it: docs/geometry.md).
pub const PANEL_AZIMUTH_TOLERANCE_DEG: f64 = 15.0;
/// How much the tip's true height may change while the panel turns, mm.
pub const PANEL_HEIGHT_TOLERANCE_MM: f64 = 4.0;

fn panel(args: &DemoArgs) -> Result<(), Failure> {
    let cfg = crane_config(&args.device);
    let world = WorldArgs::default().parse()?;
    let mut link = Link::open_recorded(&args.device, &world, args.record.as_deref(), "demo panel")?;
    let st = link.status()?;
    if let Some(why) = blocked(&st) {
        link.close();
        return Err(Failure::Runtime(anyhow::anyhow!("refused: {why}")));
    }
    let fd: TrunkState = "F&D".parse().map_err(|_| anyhow::anyhow!("F&D"))?;
    let ws = crate::cmd::pose::crane_workspace(&cfg)?;
    note(
        args.json,
        "§6.4 turns the panel in F&P first: this controller does not bend F&P (not a flexible state), so the panel is turned in F&D only",
    );
    let mut turns = Vec::new();
    let r = (|| -> Result<(), Failure> {
        note(args.json, &format!("{} → F&D (by D&D)", st.state));
        if st.state != fd {
            crate::cmd::reach::go_to_state(
                &mut link,
                "D&D".parse().map_err(|_| anyhow::anyhow!("D&D"))?,
            )?;
            crate::cmd::reach::go_to_state(&mut link, fd)?;
        }
        for k in 0..8 {
            let dir = f64::from(k) * 45.0;
            note(
                args.json,
                &format!("turn the panel toward {dir:.0}° (tilt {PANEL_TILT_DEG}°)"),
            );
            let (step, _) = bend_step(&ws, &cfg, fd, PANEL_TILT_DEG, dir)?;
            let end = run_step(&mut link, step)?;
            if let Some(e) = end.error {
                return Err(Failure::Runtime(anyhow::anyhow!(
                    "turning toward {dir}°: {e}"
                )));
            }
            let truth = link.sim().map(|sim| {
                let t = sim.true_tip();
                let az = t.axis[1].atan2(t.axis[0]).to_degrees().rem_euclid(360.0);
                let tilt = t.axis[2].clamp(-1.0, 1.0).acos().to_degrees();
                let off = ((az - dir + 540.0).rem_euclid(360.0) - 180.0).abs();
                json!({"toward_deg": dir, "true_facing_deg": (az * 10.0).round() / 10.0,
                       "true_tilt_deg": (tilt * 10.0).round() / 10.0,
                       "facing_error_deg": (off * 10.0).round() / 10.0,
                       "true_tip_z_mm": (t.position_mm[2] * 10.0).round() / 10.0,
                       "true_state": sim.trunk().state().map(|s| s.name())})
            });
            turns.push(truth.unwrap_or_else(|| json!({"toward_deg": dir})));
        }
        straighten(&mut link, &cfg)
    })();
    let st = link.status().ok();
    let sim = link.sim().is_some();
    link.close();
    let z: Vec<f64> = turns
        .iter()
        .filter_map(|t| t["true_tip_z_mm"].as_f64())
        .collect();
    let z_span = z.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - z.iter().copied().fold(f64::INFINITY, f64::min);
    let truth_ok = !sim
        || (turns.iter().all(|t| {
            t["facing_error_deg"]
                .as_f64()
                .is_some_and(|e| e <= PANEL_AZIMUTH_TOLERANCE_DEG)
                && t["true_tilt_deg"]
                    .as_f64()
                    .is_some_and(|a| a >= 0.6 * PANEL_TILT_DEG)
                && t["true_state"] == "F&D"
        }) && z_span <= PANEL_HEIGHT_TOLERANCE_MM);
    let device_ok = st
        .as_ref()
        .is_some_and(|s| s.state == fd && s.state_confirmed);
    let ok = r.is_ok() && truth_ok && device_ok;
    if args.json {
        crate::cli::print_json(json!({
            "ok": ok,
            "demo": "panel",
            "tilt_deg": PANEL_TILT_DEG,
            "turns": turns,
            "height_span_mm": sim.then_some((z_span * 100.0).round() / 100.0),
            "state": st.as_ref().map(|s| s.state.name()),
            "error": r.as_ref().err().map(crate::cmd::reach::failure_text),
        }));
    } else if sim {
        for t in &turns {
            crate::out!(
                "toward {:>3}°: the panel faces {}° (off by {}°), tilted {}°, tip at z = {} mm",
                t["toward_deg"],
                t["true_facing_deg"],
                t["facing_error_deg"],
                t["true_tilt_deg"],
                t["true_tip_z_mm"]
            );
        }
        crate::out!("the tip's height changed by {z_span:.2} mm while the panel turned (tolerance {PANEL_HEIGHT_TOLERANCE_MM} mm)");
    }
    r?;
    if ok {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "the panel did not face every direction within {PANEL_AZIMUTH_TOLERANCE_DEG}° at a steady height in F&D"
        )))
    }
}

fn manipulation(args: &DemoArgs) -> Result<(), Failure> {
    let cfg = crane_config(&args.device);
    if args.device.sim {
        crate::cmd::task::calibrate_for_sim(&cfg)?;
    }
    let set = manipulation_set(&cfg)?;
    let mut world = WorldArgs::default();
    if args.device.sim {
        world.objects = set
            .iter()
            .map(|(n, at, _)| {
                crate::cmd::task::parse_object(&format!("{n}:{},{},{},0.05", at[0], at[1], at[2]))
            })
            .collect::<Result<_, _>>()?;
    }
    let world = world.parse()?;
    let mut link = Link::open_recorded(
        &args.device,
        &world,
        args.record.as_deref(),
        "demo manipulation",
    )?;
    let st = link.status()?;
    if let Some(why) = blocked(&st) {
        link.close();
        return Err(Failure::Runtime(anyhow::anyhow!("refused: {why}")));
    }
    if st.state != TrunkState::AS_MANUFACTURED {
        note(args.json, &format!("start: {} → F&P first", st.state));
        crate::cmd::reach::go_to_state(&mut link, TrunkState::AS_MANUFACTURED)?;
    }
    let t0 = link.sim().map(|s| s.now_ms());
    let mut parts = Vec::new();
    let mut failure = None;
    for (i, (name, at, place)) in set.iter().enumerate() {
        note(args.json, &format!("part {}: {name} object", i + 1));
        match pick(&mut link, &cfg, *at, *place, 5.0, args.json) {
            Ok(p) => parts.push(json!({"object": name, "caught": p.object, "events": p.events})),
            Err(e) => {
                failure = Some(crate::cmd::reach::failure_text(&e));
                break;
            }
        }
    }
    let virtual_s = match (t0, link.sim()) {
        (Some(t0), Some(sim)) => Some((sim.now_ms() - t0) as f64 / 1000.0),
        _ => None,
    };
    // The verdict against the truth: every object on the table below its place point.
    let mut verdict = Vec::new();
    let mut all_placed = failure.is_none();
    if let Some(sim) = link.sim() {
        for (name, _, place) in &set {
            let o = sim.world().objects().iter().find(|o| &o.name == name);
            let (ok, d) = match o {
                Some(o) => {
                    let d = (o.position_mm[0] - place[0]).hypot(o.position_mm[1] - place[1]);
                    (
                        !o.held && o.position_mm[2] == 0.0 && d <= PLACE_TOLERANCE_MM,
                        d,
                    )
                }
                None => (false, f64::NAN),
            };
            all_placed &= ok;
            verdict.push(
                json!({"object": name, "placed": ok, "from_place_mm": (d * 10.0).round() / 10.0,
                "position_mm": o.map(|o| o.position_mm.map(|v| (v * 10.0).round() / 10.0))}),
            );
        }
    }
    let checked = link.sim().is_some();
    if !checked && failure.is_none() {
        note(
            args.json,
            "the objects' places are not checked: over a port the host cannot see them (look)",
        );
    }
    let st = link.status().ok();
    link.close();
    if args.json {
        crate::cli::print_json(json!({
            "ok": all_placed,
            "checked": checked,
            "demo": "manipulation",
            "parts": parts,
            "verdict": verdict,
            "virtual_s": virtual_s,
            "state": st.as_ref().map(|s| s.state.name()),
            "error": failure,
        }));
    } else {
        for v in &verdict {
            crate::out!(
                "{}: {} ({} mm from below its place point; tolerance {PLACE_TOLERANCE_MM} mm)",
                v["object"].as_str().unwrap_or("?"),
                if v["placed"] == true {
                    "placed"
                } else {
                    "NOT placed"
                },
                v["from_place_mm"]
            );
        }
        if let Some(s) = virtual_s {
            crate::out!("virtual duration {s:.1} s");
        }
    }
    match failure {
        Some(e) => Err(Failure::Runtime(anyhow::anyhow!("{e}"))),
        None if all_placed => Ok(()),
        None => Err(Failure::Runtime(anyhow::anyhow!(
            "not every object is where it should be"
        ))),
    }
}

/// §6.5's load: kg.
pub const PAPER_LOAD_KG: f64 = 5.7;
/// The true pressure that counts as "no air", kPa: the controller's vent tolerance (0.5) and
/// twice the sensor's noise (σ = 0.15), the most a vent can leave without the sensor knowing.
pub const TRUE_AMBIENT_KPA: f64 = 0.8;
/// §6.5's hold, ms.
pub const HOLD_MS: u64 = 60_000;

fn load(args: &DemoArgs) -> Result<(), Failure> {
    let world = WorldArgs::default().parse()?;
    let mut link = Link::open_recorded(&args.device, &world, args.record.as_deref(), "demo load")?;
    let st = link.status()?;
    if let Some(why) = blocked(&st) {
        link.close();
        return Err(Failure::Runtime(anyhow::anyhow!("refused: {why}")));
    }
    let dd: TrunkState = "D&D".parse().map_err(|_| anyhow::anyhow!("D&D"))?;
    note(args.json, &format!("{} → D&D", st.state));
    let r = (|| -> Result<(), Failure> {
        crate::cmd::reach::go_to_state(&mut link, dd)?;
        match link.sim() {
            Some(sim) => {
                crate::cmd::task::hang_load(sim, PAPER_LOAD_KG)?;
                note(args.json, &format!("{PAPER_LOAD_KG} kg hung on the tip"));
            }
            None => ask_person(&format!("hang {PAPER_LOAD_KG} kg on the tip"))?,
        }
        // Let the load settle on the sealed trunk, then let out what it squeezed: no air.
        link.wait(1_000)?;
        let st = link.status()?;
        if st.pressure_kpa > protocol::DEFAULT_VENT_TOLERANCE_KPA {
            note(args.json, "vent: no air in the trunk");
            let end = run_step(
                &mut link,
                crate::cmd::prim::step_for(dd, Primitive::Vent { pressure_kpa: 0.0 }),
            )?;
            if let Some(e) = end.error {
                return Err(Failure::Runtime(anyhow::anyhow!("venting: {e}")));
            }
        }
        note(args.json, &format!("hold {} s", HOLD_MS / 1000));
        let mut left = HOLD_MS;
        while left > 0 {
            let d = left.min(5_000);
            link.wait(d)?;
            left -= d;
        }
        Ok(())
    })();
    let st = link.status().ok();
    let truth = link.sim().map(|sim| {
        json!({
            "true_state": sim.trunk().state().map(|s| s.name()),
            "pressure_kpa": (sim.trunk().pressure_kpa() * 100.0).round() / 100.0,
            "tip_load_kg": sim.world().tip_load_kg(),
            "true_tip_mm": sim.true_tip().position_mm.map(|v| (v * 10.0).round() / 10.0),
        })
    });
    link.close();
    let device_ok = st.as_ref().is_some_and(|s| {
        s.state == dd
            && s.state_confirmed
            && s.pressure_kpa <= protocol::DEFAULT_VENT_TOLERANCE_KPA
            && s.faults == 0
    });
    let truth_ok = truth.as_ref().is_none_or(|t| {
        t["true_state"] == "D&D"
            && t["pressure_kpa"]
                .as_f64()
                .is_some_and(|p| p.abs() <= TRUE_AMBIENT_KPA)
    });
    let ok = r.is_ok() && device_ok && truth_ok;
    if args.json {
        crate::cli::print_json(json!({
            "ok": ok,
            "demo": "load",
            "load_kg": PAPER_LOAD_KG,
            "hold_s": HOLD_MS / 1000,
            "state": st.as_ref().map(|s| s.state.name()),
            "state_confirmed": st.as_ref().map(|s| s.state_confirmed),
            "pressure_kpa": st.as_ref().map(|s| s.pressure_kpa),
            "error": r.as_ref().err().map(crate::cmd::reach::failure_text),
            "sim": truth,
        }));
    } else if let Some(s) = &st {
        crate::out!(
            "after {} s with {PAPER_LOAD_KG} kg: the device says {} ({}), {} kPa{}",
            HOLD_MS / 1000,
            s.state,
            if s.state_confirmed {
                "confirmed"
            } else {
                "NOT confirmed"
            },
            crate::num::fixed(f64::from(s.pressure_kpa), 1),
            truth.as_ref().map_or(String::new(), |t| format!(
                "; simulator: true state {}, {} kPa",
                t["true_state"].as_str().unwrap_or("between states"),
                t["pressure_kpa"]
            ))
        );
    }
    r?;
    if ok {
        Ok(())
    } else {
        Err(Failure::Runtime(anyhow::anyhow!(
            "the load was not held in D&D confirmed at 0 kPa"
        )))
    }
}
