//! `host-tool fk`: forward kinematics of a stack of modules, the tip of each module.

use geometry::{fk, ModuleDesign, Pose, ShapeState, SymmetricState};
use serde_json::Value;

use super::states::{designs_from, ordered_object, parse_betas, parse_edge_mm, parse_n, Betas};
use crate::failure::Failure;

/// Arguments of `host-tool fk`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of polygon sides n of every module (an integer in [3, 64]).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::usage(parse_n))]
    pub n: u32,
    /// Fold angle(s) β in degrees: one for all modules or one per module, comma-separated,
    /// bottom module first.
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::usage(parse_betas))]
    pub beta: Betas,
    /// State of each module, comma-separated, bottom module first: deployed, folded,
    /// edge-<i>, vertex-<i> (0 ≤ i < n), or self-packed / flat-folded where β allows.
    #[arg(long, allow_hyphen_values = true)]
    pub states: String,
    /// Accept states the geometry marks infeasible (crease strain above 1 %: the paper's full
    /// catalogue); each one used is marked with its strain. Default: only feasible states.
    #[arg(long)]
    pub all_states: bool,
    /// Print the tips in millimetres too, for a valley fold (polygon edge) of this length.
    #[arg(long, value_name = "MM", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_edge_mm))]
    pub edge_mm: Option<f64>,
    /// Print JSON (`{"tips": [[x, y, z], …], "infeasible": [{"module", "state", "strain"}, …],
    /// "heading_deg", "frames": [{"module", "origin", "rotation", "normal",
    /// "normal_azimuth_deg", "normal_elevation_deg"}, …], "edge_mm", "tips_mm"}`; the last two
    /// `null` without --edge-mm) instead of a table.
    #[arg(skip)]
    pub json: bool,
    /// Compass heading of the base frame's x axis (towards bottom vertex 0), degrees
    /// clockwise from north; 90 puts x east and y north. Gives each top-face normal's compass
    /// azimuth and elevation.
    #[arg(long, default_value = "90", allow_hyphen_values = true,
          value_parser = crate::arg::heading)]
    pub heading: geometry::orient::Heading,
}

/// Each module's top-face frame (origin, rotation matrix rows, outward normal in the base
/// frame, and the normal on the compass) as JSON.
fn frames_json(poses: &[Pose], heading: &geometry::orient::Heading) -> String {
    let n = |v: f64| crate::num::json(v).to_string();
    let v3 = |x: f64, y: f64, z: f64| format!("[{},{},{}]", n(x), n(y), n(z));
    let list: Vec<String> = geometry::orient::top_faces(poses.iter().copied())
        .enumerate()
        .map(|(i, f)| {
            let r = f.rotation.to_rotation_matrix();
            let m = r.matrix();
            let rows: Vec<String> = (0..3)
                .map(|k| v3(m[(k, 0)], m[(k, 1)], m[(k, 2)]))
                .collect();
            let (az, el) = heading.compass_of(&f.normal);
            ordered_object(&[
                ("module", (i + 1).to_string()),
                ("origin", v3(f.origin.x, f.origin.y, f.origin.z)),
                ("rotation", format!("[{}]", rows.join(","))),
                ("normal", v3(f.normal.x, f.normal.y, f.normal.z)),
                ("normal_azimuth_deg", n(az)),
                ("normal_elevation_deg", n(el)),
            ])
        })
        .collect();
    format!("[{}]", list.join(","))
}

/// One module of the stack, validated.
struct Module {
    design: ModuleDesign,
    name: String,
    pose: Pose,
    /// `Some(strain)` when the geometry marks the state infeasible.
    infeasible: Option<f64>,
}

/// The state's pose and, if the geometry marks it infeasible, its strain. The symmetric extras
/// (self-packed, flat-folded) are exact where they exist, so they are feasible.
fn parse_state(design: &ModuleDesign, name: &str) -> Result<(Pose, Option<f64>), Failure> {
    let trimmed = name.trim();
    for sym in [SymmetricState::SelfPacked, SymmetricState::FlatFolded] {
        if trimmed.eq_ignore_ascii_case(sym.name()) {
            return design.symmetric_pose(sym).map(|p| (p, None)).ok_or_else(|| {
                Failure::usage(format!(
                    "state '{trimmed}' does not exist for β = {}° (self-packed needs β in ({:.4}°, 45°], flat-folded needs β = {:.4}°)",
                    design.beta_deg(),
                    design.flat_foldable_beta_deg(),
                    design.flat_foldable_beta_deg()
                ))
            });
        }
    }
    let state = ShapeState::parse(trimmed, design.n()).map_err(|e| {
        Failure::usage(format!(
            "'{name}': {e} (and self-packed, flat-folded where β allows)"
        ))
    })?;
    let info = design.state_info(state);
    Ok((info.pose, (!info.feasible).then_some(info.max_strain)))
}

fn modules(args: &Args) -> Result<Vec<Module>, Failure> {
    let n = args.n;
    let names: Vec<&str> = args.states.split(',').collect();
    if names.iter().any(|s| s.trim().is_empty()) {
        return Err(Failure::usage(
            "--states must be a comma-separated list of state names, one per module (e.g. deployed,edge-0,folded)",
        ));
    }
    let designs = designs_from(
        n,
        &args.beta,
        names.len(),
        &format!("--states has {} modules", names.len()),
    )?;
    names
        .iter()
        .zip(designs)
        .enumerate()
        .map(|(i, (name, design))| {
            let (pose, infeasible) = parse_state(&design, name)?;
            let name = name.trim().to_ascii_lowercase();
            if let (Some(strain), false) = (infeasible, args.all_states) {
                return Err(Failure::usage(format!(
                    "module {} state '{name}' is infeasible for n = {}, β = {}°: its crease strain {strain:.3} exceeds the {} % tolerance (see `host-tool states --n {} --beta {}`); pass --all-states to use the paper's full catalogue anyway",
                    i + 1,
                    design.n(),
                    design.beta_deg(),
                    geometry::STRAIN_TOLERANCE * 100.0,
                    design.n(),
                    design.beta_deg()
                )));
            }
            Ok(Module {
                design,
                name,
                pose,
                infeasible,
            })
        })
        .collect()
}

/// Runs `host-tool fk`.
pub fn run(args: Args) -> Result<(), Failure> {
    let heading = args.heading;
    let edge_mm = args.edge_mm;
    let stack = modules(&args)?;
    let tips: Vec<_> = fk::tips(stack.iter().map(|m| m.pose)).collect();
    if args.json {
        let list_in = |scale: f64| -> Vec<String> {
            tips.iter()
                .map(|p| {
                    let xyz: Vec<String> = [p.x, p.y, p.z]
                        .iter()
                        .map(|v| crate::num::json(*v * scale).to_string())
                        .collect();
                    format!("[{}]", xyz.join(","))
                })
                .collect()
        };
        let list = list_in(1.0);
        let infeasible: Vec<String> = stack
            .iter()
            .enumerate()
            .filter_map(|(i, m)| {
                m.infeasible.map(|strain| {
                    ordered_object(&[
                        ("module", (i + 1).to_string()),
                        ("state", Value::from(m.name.as_str()).to_string()),
                        ("strain", crate::num::json(strain).to_string()),
                    ])
                })
            })
            .collect();
        crate::cli::print_json_text(&ordered_object(&[
            ("tips", format!("[{}]", list.join(","))),
            ("infeasible", format!("[{}]", infeasible.join(","))),
            ("heading_deg", crate::num::json(heading.deg()).to_string()),
            (
                "frames",
                frames_json(&stack.iter().map(|m| m.pose).collect::<Vec<_>>(), &heading),
            ),
            (
                "edge_mm",
                edge_mm.map_or("null".into(), |e| crate::num::json(e).to_string()),
            ),
            (
                "tips_mm",
                edge_mm.map_or("null".into(), |e| format!("[{}]", list_in(e).join(","))),
            ),
        ]));
        return Ok(());
    }
    let (scale, unit) = match edge_mm {
        Some(e) => (e, format!("mm, edge l = {e} mm")),
        None => (1.0, "units of the edge l".to_string()),
    };
    crate::out!(
        "tips of a {}-module stack ({unit}, bottom module first; a module is one layer)",
        stack.len()
    );
    crate::out!(
        "  {:>3}  {:<12} {:>8} {:>10} {:>10} {:>10}  feasibility",
        "#",
        "state",
        "β (°)",
        "x",
        "y",
        "z"
    );
    for (k, (m, p)) in stack.iter().zip(&tips).enumerate() {
        let mark = m.infeasible.map_or_else(
            || "feasible".to_string(),
            |strain| format!("INFEASIBLE (strain {strain:.3})"),
        );
        let w = |v: f64| crate::num::fixed_w(v, 5, 10);
        crate::out!(
            "  {:>3}  {:<12} {:>8.3} {} {} {}  {mark}",
            k + 1,
            m.name,
            m.design.beta_deg(),
            w(p.x * scale),
            w(p.y * scale),
            w(p.z * scale)
        );
    }
    let used = stack.iter().filter(|m| m.infeasible.is_some()).count();
    if used > 0 {
        crate::out!(
            "warning: {used} of {} modules use states the geometry marks infeasible (--all-states)",
            stack.len()
        );
    }
    Ok(())
}
