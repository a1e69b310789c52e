//! `host-tool model`: a 3D model of a stack in given states (glTF, OBJ, STL), and the model
//! of an IK fit for `host-tool ik --gltf`. The work is in `fabrication::model`.

use std::path::{Path, PathBuf};

use fabrication::folded::{fold, LayerState};
use fabrication::model::Model;
use fabrication::pattern::Pattern;
use fabrication::{Defaults, Module, Trunk};
use geometry::ModuleDesign;

use super::output::{self, Output};
use super::pattern::{parse_frame, TrunkArgs};
use crate::failure::Failure;

/// Arguments of `host-tool model`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub trunk: TrunkArgs,
    /// State of every layer: one name for all (deployed, folded, edge-<i>, vertex-<i>,
    /// self-packed, flat-folded), one per module or one per layer, comma-separated, bottom first;
    /// or, for a two-module trunk, the crane's state name `TOP&BOTTOM` (`F&P`, `D&F`, …; `-` for
    /// `&`). A module is a group of layers of one β (`--layers`).
    #[arg(long, default_value = "deployed", allow_hyphen_values = true)]
    pub states: String,
    /// Write binary glTF 2.0 (metres, +Y up; vertex colours: module, red = strain).
    #[arg(long, value_name = "FILE")]
    pub gltf: Option<PathBuf>,
    /// Write OBJ with vertex colours (mm, +Z up along the trunk).
    #[arg(long, value_name = "FILE")]
    pub obj: Option<PathBuf>,
    /// Write binary STL (mm, +Z up; an open sheet, for viewing, not printing).
    #[arg(long, value_name = "FILE")]
    pub stl: Option<PathBuf>,
}

/// The module states (bottom first) of a crane state name `TOP&BOTTOM`: the top module is
/// folded or deployed, the bottom self-packed, folded or deployed.
fn trunk_state_names(state: geometry::TrunkState) -> [&'static str; 2] {
    use geometry::{BottomState, TopState};
    let bottom = match state.bottom {
        BottomState::Packed => "self-packed",
        BottomState::Folded => "folded",
        BottomState::Deployed => "deployed",
    };
    let top = match state.top {
        TopState::Folded => "folded",
        TopState::Deployed => "deployed",
    };
    [bottom, top]
}

fn parse_states(trunk: &Trunk, text: &str) -> Result<Vec<LayerState>, Failure> {
    let t = text.trim();
    if t.len() == 3 && matches!(t.as_bytes()[1], b'&' | b'-') {
        let state: geometry::TrunkState = t
            .parse()
            .map_err(|e| Failure::usage(format!("--states '{t}': {e} (or layer state names)")))?;
        let m = trunk.modules().len();
        if m != 2 {
            return Err(Failure::usage(format!(
                "--states '{t}' is a crane state (TOP&BOTTOM), which needs a two-module trunk (bottom, top); this one has {m} modules: give layer state names instead"
            )));
        }
        return parse_frame(trunk, &trunk_state_names(state).join("/"));
    }
    let names: Vec<&str> = text.split(',').collect();
    if names.iter().any(|s| s.trim().is_empty()) {
        return Err(Failure::usage(
            "--states must be a comma-separated list of state names (e.g. self-packed,folded)",
        ));
    }
    let m = trunk.modules().len();
    let layers = trunk.layer_count();
    if names.len() == 1 || names.len() == m {
        return parse_frame(trunk, &names.join("/"));
    }
    if names.len() != layers {
        return Err(Failure::usage(format!(
            "--states has {} names; give one for all layers, one per module ({m}) or one per layer ({layers})",
            names.len()
        )));
    }
    trunk
        .layers()
        .iter()
        .zip(&names)
        .enumerate()
        .map(|(k, ((_, d), name))| {
            LayerState::parse(d, name).map_err(|e| {
                Failure::usage(format!(
                    "--states, layer {} (β = {}°): {e}",
                    k + 1,
                    d.beta_deg()
                ))
            })
        })
        .collect()
}

fn generator() -> String {
    format!("host-tool {}", env!("CARGO_PKG_VERSION"))
}

fn write_model(out: Output, model: &Model) -> Result<(), Failure> {
    let path = out.path().display().to_string();
    let tris = model.mesh.triangles.len();
    let (n, what) = match out.flag() {
        "--gltf" => {
            let bytes = model
                .glb(&generator())
                .map_err(|e| Failure::Runtime(anyhow::anyhow!("glTF: {e}")))?;
            (
                out.write_counted(|w| w.write_all(&bytes))?,
                "binary glTF 2.0",
            )
        }
        "--obj" => {
            let text = model.obj();
            (out.write_counted(|w| w.write_all(text.as_bytes()))?, "OBJ")
        }
        _ => (
            out.write_counted(|w| model.mesh.write_stl(w))?,
            "binary STL",
        ),
    };
    crate::say!("wrote {path} ({n} bytes): {what}, {tris} triangles");
    Ok(())
}

/// Runs `host-tool model`.
pub fn run(args: Args) -> Result<(), Failure> {
    let trunk = args.trunk.trunk()?;
    let states = parse_states(&trunk, &args.states)?;
    let mut paths: Vec<(&'static str, &Path)> = Vec::new();
    if let Some(p) = &args.gltf {
        paths.push(("--gltf", p));
    }
    if let Some(p) = &args.obj {
        paths.push(("--obj", p));
    }
    if let Some(p) = &args.stl {
        paths.push(("--stl", p));
    }
    if paths.is_empty() {
        return Err(Failure::usage(
            "nothing to write: give at least one of --gltf FILE, --obj FILE, --stl FILE",
        ));
    }
    let pattern = Pattern::new(&trunk, 0.0).map_err(|e| Failure::usage(e.to_string()))?;
    let outputs = output::open_all(&paths)?;
    let folded = fold(&pattern, &states).map_err(|e| Failure::usage(e.to_string()))?;
    let model = Model::new(&pattern, &folded);
    for out in outputs {
        write_model(out, &model)?;
    }
    let names: Vec<String> = states.iter().map(|s| s.to_string()).collect();
    println!(
        "model of {} in states {} (bottom first): {} triangles, largest strain {:.3e}{}",
        trunk.describe(),
        names.join(","),
        model.mesh.triangles.len(),
        model.max_strain,
        strain_note(&states, model.feasible, model.max_strain)
    );
    Ok(())
}

/// What the largest strain means: nothing (isometric), infeasible states, or — when every
/// layer's state is feasible on its own — the expected mismatch where a self-packed layer's
/// boundary (bent at its edge midpoints, a smaller circumradius) meets an unpacked layer's flat
/// n-gon (docs/fabrication.md, "3D models").
fn strain_note(states: &[LayerState], feasible: bool, max_strain: f64) -> String {
    if feasible && max_strain <= geometry::STRAIN_TOLERANCE {
        return String::new();
    }
    let packed = |s: &LayerState| matches!(s, LayerState::SelfPacked);
    let boundary = states.windows(2).any(|w| packed(&w[0]) != packed(&w[1]));
    if feasible && boundary {
        " — every layer's state is feasible; the strain is where a self-packed layer's boundary (bent at its edge midpoints) meets an unpacked layer's flat n-gon, expected at a packed boundary (the real trunk's panels flex there); strained faces drawn red".to_string()
    } else {
        " — not isometric to the flat pattern: strained faces drawn red".to_string()
    }
}

/// Opens `ik --gltf FILE` before the solve.
pub fn open_ik_gltf(path: Option<&Path>) -> Result<Option<Output>, Failure> {
    match path {
        None => Ok(None),
        Some(p) => Ok(output::open_all(&[("--gltf", p)])?.pop()),
    }
}

/// Writes the glTF model of an IK fit: one layer per boom module in the solved states, at the
/// crane's edge length (l = 75 mm).
pub fn write_ik_gltf(
    out: Option<Output>,
    designs: &[ModuleDesign],
    names: &[String],
) -> Result<(), Failure> {
    let Some(out) = out else {
        return Ok(());
    };
    let modules = designs
        .iter()
        .map(|&design| Module { design, layers: 1 })
        .collect();
    let trunk = Trunk::new(modules, Defaults::EDGE_MM)
        .map_err(|e| Failure::Runtime(anyhow::anyhow!("ik --gltf: {e}")))?;
    let states = designs
        .iter()
        .zip(names)
        .map(|(d, n)| LayerState::parse(d, n))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| Failure::Runtime(anyhow::anyhow!("ik --gltf: {e}")))?;
    let pattern =
        Pattern::new(&trunk, 0.0).map_err(|e| Failure::Runtime(anyhow::anyhow!("{e}")))?;
    let folded = fold(&pattern, &states).map_err(|e| Failure::Runtime(anyhow::anyhow!("{e}")))?;
    write_model(out, &Model::new(&pattern, &folded))
}
