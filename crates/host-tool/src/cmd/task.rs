//! The simulator's world on the command line (`--object NAME:X,Y,Z[,MASS_KG]`,
//! `--tip-load-kg M`), the gripper's grasp events and what the physics says a vent would do.

use geometry::TrunkState;
use hil_sim::world::{Grasp, Object};
use serde_json::{json, Value};

use crate::failure::Failure;

/// Objects and a load for the built-in simulator (`--sim` only).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct WorldArgs {
    /// Simulator: an object whose grasp point is at X,Y,Z mm (base frame; z ≥ 0, the table is
    /// z = 0) weighing MASS_KG (default 0.05), e.g. cup:40,0,60,0.1 (repeatable). Closing the
    /// gripper within 15 mm of it holds it; opening drops it to the table below the tip.
    #[arg(long = "object", value_name = "NAME:X,Y,Z[,MASS_KG]", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_object))]
    pub objects: Vec<Object>,
    /// Simulator: a load hung on the tip, kg (0 to 50), whatever the gripper does.
    #[arg(long, value_name = "M", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_tip_load))]
    pub tip_load_kg: Option<f64>,
}

/// Parses `--tip-load-kg`: a mass in kg in [0, `hil_sim::world::MAX_MASS_KG`].
fn parse_tip_load(text: &str) -> Result<f64, Failure> {
    match text.trim().parse::<f64>() {
        Ok(kg) if kg.is_finite() && (0.0..=hil_sim::world::MAX_MASS_KG).contains(&kg) => Ok(kg),
        _ => Err(Failure::usage(format!(
            "invalid --tip-load-kg '{text}': expected a mass in kg in [0, {}]",
            hil_sim::world::MAX_MASS_KG
        ))),
    }
}

/// Parses one `--object`.
pub fn parse_object(text: &str) -> Result<Object, Failure> {
    Object::parse(text).map_err(|e| Failure::usage(format!("invalid --object: {e}")))
}

/// A parsed world.
#[derive(Debug, Clone, Default)]
pub struct World {
    objects: Vec<Object>,
    tip_load_kg: f64,
}

impl WorldArgs {
    /// Checks every object and the load.
    pub fn parse(&self) -> Result<World, Failure> {
        let objects = self.objects.clone();
        let tip_load_kg = self.tip_load_kg.unwrap_or(0.0);
        hil_sim::world::World::with(objects.clone(), tip_load_kg)
            .map_err(|e| Failure::usage(format!("invalid world: {e}")))?;
        Ok(World {
            objects,
            tip_load_kg,
        })
    }
}

impl World {
    /// Whether nothing is placed.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty() && self.tip_load_kg == 0.0
    }

    /// The simulator's world.
    pub fn to_sim(&self) -> hil_sim::world::World {
        // Checked in `WorldArgs::parse`.
        hil_sim::world::World::with(self.objects.clone(), self.tip_load_kg).unwrap_or_default()
    }
}

/// A grasp event as JSON (with a `text` for people).
pub fn grasp_json(g: &Grasp) -> Value {
    match g {
        Grasp::Captured(name) => json!({"event": "captured", "object": name,
            "text": format!("the gripper holds {name}")}),
        Grasp::Released(name) => json!({"event": "released", "object": name,
            "text": format!("{name} was let go and fell to the table below the tip")}),
        Grasp::Missed(None) => json!({"event": "missed", "object": null,
            "text": "the gripper closed on nothing (no object in the world)"}),
        Grasp::Missed(Some((name, d))) => json!({"event": "missed", "object": name,
            "distance_mm": (d * 10.0).round() / 10.0,
            "text": format!("the gripper closed on nothing: the nearest object, {name}, is {d:.1} mm from the tip (capture radius {} mm)", hil_sim::world::CAPTURE_RADIUS_MM)}),
    }
}

/// Hangs `kg` on the simulator's tip (the objects stay where they are, the gripper as it is).
pub fn hang_load(sim: &mut hil_sim::Sim, kg: f64) -> Result<(), Failure> {
    let objects = sim.world().objects().to_vec();
    let closed = sim.ground_truth().gripper_closed;
    *sim.world_mut() = hil_sim::world::World::with(objects, kg)
        .map_err(|e| Failure::usage(format!("tip load {kg} kg: {e}")))?;
    sim.world_mut().set_gripper(closed);
    Ok(())
}

/// The largest axial load (N) each module of `state` holds without air before it buckles into
/// the well below (the physics' compression barriers), `[top, bottom]`; `None` where a module
/// has no well below.
pub fn holding_n(sim: &hil_sim::Sim, state: TrunkState) -> [Option<f64>; 2] {
    let p = sim.trunk().params();
    let top_well = match state.top {
        geometry::TopState::Folded => 0,
        geometry::TopState::Deployed => 1,
    };
    let bottom_well = match state.bottom {
        geometry::BottomState::Packed => 0,
        geometry::BottomState::Folded => 2,
        geometry::BottomState::Deployed => 3,
    };
    let hold = |barriers: &[hil_sim::physics::multistable::Barrier], well: usize| {
        (well > 0).then(|| barriers[well - 1].compression_n)
    };
    [
        hold(p.top.barriers(), top_well),
        hold(p.bottom.barriers(), bottom_well),
    ]
}

/// Why venting `state` in the simulator would let the trunk collapse (its tip load heavier
/// than the state holds without air), if it would.
pub fn vent_would_collapse(sim: &hil_sim::Sim, state: TrunkState) -> Option<String> {
    let load = sim.world().load_n() + sim.trunk().params().tip_load_n;
    let [top, bottom] = holding_n(sim, state);
    let weakest = [top, bottom]
        .into_iter()
        .flatten()
        .fold(f64::INFINITY, f64::min);
    (load > weakest).then(|| {
        format!(
            "venting would change the state: the {load:.1} N on the tip is more than {state} holds without air ({weakest:.1} N before a module buckles)"
        )
    })
}

/// The workspace `reach`, `pick` and `demo` plan with: calibrated against the simulator for
/// `--sim` (set by [`calibrate_for_sim`]), else the geometry's.
static TASK_WORKSPACE: std::sync::OnceLock<planner::task::Workspace> = std::sync::OnceLock::new();

/// The workspace tasks plan with (see [`TASK_WORKSPACE`]).
pub fn task_workspace(cfg: &protocol::CraneGeometry) -> Result<planner::task::Workspace, Failure> {
    match TASK_WORKSPACE.get() {
        Some(ws) => Ok(*ws),
        None => crate::cmd::pose::crane_workspace(cfg),
    }
}

/// Calibrates the workspace tasks plan with against the simulator
/// ([`hil_sim::world::calibrate`]).
pub fn calibrate_for_sim(cfg: &protocol::CraneGeometry) -> Result<(), Failure> {
    let ws = crate::cmd::pose::crane_workspace(cfg)?;
    let ws = hil_sim::world::calibrate(ws, cfg)
        .map_err(|e| Failure::Runtime(anyhow::anyhow!("calibrating against the simulator: {e}")))?;
    for s in TrunkState::ALL {
        if let Some(c) = ws.calibration(s) {
            crate::debug!(
                "calibrated {s}: gain {:.3}, bottom share {:.3}",
                c.gain,
                c.bottom_share
            );
        }
    }
    let _ = TASK_WORKSPACE.set(ws);
    Ok(())
}
