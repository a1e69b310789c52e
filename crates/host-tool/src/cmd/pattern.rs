//! `host-tool pattern`: the files to make a trunk — crease pattern (SVG, DXF, FOLD), the
//! printable dual-material panel (3MF, STL) and the meter-scale kit. The work is in the
//! `fabrication` crate; this parses, validates and writes.

use std::path::PathBuf;

use fabrication::folded::{fold, LayerState};
use fabrication::pattern::Pattern;
use fabrication::{Defaults, Module, Trunk};

use super::output;
use super::states::{designs_from, parse_n};
use crate::failure::Failure;

/// The trunk description shared by `pattern` and `model` (defaults: the paper's crane trunk).
#[derive(Debug, Clone, clap::Args)]
pub struct TrunkArgs {
    /// Number of polygon sides n of every module (an integer in [3, 64]).
    #[arg(long, default_value_t = Defaults::N.to_string(), allow_hyphen_values = true)]
    pub n: String,
    /// Fold angle(s) β in degrees, one per module, bottom first (one value: one module). The
    /// default is the crane trunk: a 35° self-packing module under a 31.72° golden one.
    #[arg(long, default_value = Defaults::BETA, allow_hyphen_values = true)]
    pub beta: String,
    /// Layers per module: one count for every module or one per module (each in [1, 1000],
    /// at most 1000 in total).
    #[arg(long, default_value = Defaults::LAYERS, allow_hyphen_values = true)]
    pub layers: String,
    /// Edge length l in mm: the valley fold, the polygon side (0 < l ≤ 10000). Default 75 mm,
    /// the trunk's base length (§5.4, Table 2's L3).
    #[arg(long, default_value_t = Defaults::EDGE_MM, allow_hyphen_values = true)]
    pub edge_mm: f64,
}

fn list_len(text: &str) -> usize {
    text.split(',').count()
}

fn parse_layers(text: &str, m: usize) -> Result<Vec<usize>, Failure> {
    let bad = || {
        Failure::usage(format!(
            "--layers must be one integer in [1, {}] for every module or one per module, got '{text}'",
            fabrication::MAX_LAYERS
        ))
    };
    let counts = text
        .split(',')
        .map(|t| {
            let t = t.trim();
            if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) {
                return Err(bad());
            }
            let v: usize = t.parse().map_err(|_| bad())?;
            if (1..=fabrication::MAX_LAYERS).contains(&v) {
                Ok(v)
            } else {
                Err(bad())
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    match counts.len() {
        1 => Ok(vec![counts[0]; m]),
        k if k == m => Ok(counts),
        k => Err(Failure::usage(format!(
            "--layers has {k} values but --beta has {m} modules; give one count for all modules or one per module"
        ))),
    }
}

impl TrunkArgs {
    /// Number of modules: the longer of the --beta and --layers lists.
    pub fn module_count(&self) -> usize {
        list_len(&self.beta).max(list_len(&self.layers))
    }

    /// Validates into a trunk.
    pub fn trunk(&self) -> Result<Trunk, Failure> {
        let n = parse_n(&self.n)?;
        let m = self.module_count();
        let designs = designs_from(n, &self.beta, m, &format!("the stack has {m} modules"))?;
        let layers = parse_layers(&self.layers, m)?;
        if !(self.edge_mm.is_finite() && self.edge_mm > 0.0 && self.edge_mm <= 10_000.0) {
            return Err(Failure::usage(format!(
                "--edge-mm must be a length in mm in (0, 10000], got {}",
                self.edge_mm
            )));
        }
        let modules = designs
            .into_iter()
            .zip(layers)
            .map(|(design, layers)| Module { design, layers })
            .collect();
        Trunk::new(modules, self.edge_mm).map_err(|e| Failure::usage(e.to_string()))
    }
}

/// Arguments of `host-tool pattern`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub trunk: TrunkArgs,
    /// Seam allowance in mm: a glue tab beyond the last column that closes the cylinder
    /// (0 for none, at most half an edge).
    #[arg(long, default_value_t = Defaults::SEAM_MM, allow_hyphen_values = true)]
    pub seam_mm: f64,
    /// Write the crease pattern as SVG (1:1 mm; Origami Simulator colours, scale bar, legend).
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Write the crease pattern as DXF (mm; layers MOUNTAIN, VALLEY, CUT, BOUNDARY, VIRTUAL).
    #[arg(long, value_name = "FILE")]
    pub dxf: Option<PathBuf>,
    /// Write FOLD v1.2: the crease pattern plus one folded frame per --states entry.
    #[arg(long, value_name = "FILE")]
    pub fold: Option<PathBuf>,
    /// Frames of --fold, comma-separated: a state for every layer (deployed, folded, edge-<i>,
    /// vertex-<i>, self-packed, flat-folded), or one per module joined by '/', bottom first
    /// (e.g. self-packed/folded). Default: every catalogue state feasible for every module.
    #[arg(long, allow_hyphen_values = true)]
    pub states: Option<String>,
}

/// Parses one frame: a state for every module, or one per module joined by '/'.
pub fn parse_frame(trunk: &Trunk, spec: &str) -> Result<Vec<LayerState>, Failure> {
    let names: Vec<&str> = spec.split('/').collect();
    let m = trunk.modules().len();
    if names.len() != 1 && names.len() != m {
        return Err(Failure::usage(format!(
            "state '{spec}' names {} modules but the trunk has {m}; give one state for all or one per module joined by '/', bottom first",
            names.len()
        )));
    }
    let mut out = Vec::new();
    for (k, module) in trunk.modules().iter().enumerate() {
        let name = names[if names.len() == 1 { 0 } else { k }];
        let s = LayerState::parse(&module.design, name).map_err(|e| {
            Failure::usage(format!(
                "--states '{spec}', module {} (β = {}°): {e}",
                k + 1,
                module.design.beta_deg()
            ))
        })?;
        out.extend(std::iter::repeat_n(s, module.layers));
    }
    Ok(out)
}

/// The default frames: every catalogue state feasible for every module.
pub fn default_frames(trunk: &Trunk) -> Vec<(String, Vec<LayerState>)> {
    let first = trunk.modules()[0].design;
    first
        .shape_states()
        .filter(|s| {
            trunk
                .modules()
                .iter()
                .all(|m| m.design.state_info(*s).feasible)
        })
        .map(|s| {
            (
                s.to_string(),
                vec![LayerState::Shape(s); trunk.layer_count()],
            )
        })
        .collect()
}

/// Runs `host-tool pattern`.
pub fn run(args: Args) -> Result<(), Failure> {
    let trunk = args.trunk.trunk()?;
    let pattern = Pattern::new(&trunk, args.seam_mm)
        .map_err(|e| Failure::usage(format!("--seam-mm: {e}")))?;
    if args.svg.is_none() && args.dxf.is_none() && args.fold.is_none() {
        return Err(Failure::usage(
            "nothing to write: give at least one of --svg FILE, --dxf FILE, --fold FILE",
        ));
    }
    if args.states.is_some() && args.fold.is_none() {
        return Err(Failure::usage(
            "--states selects the frames of --fold; give --fold FILE too",
        ));
    }
    let frames: Vec<(String, Vec<LayerState>)> = match &args.states {
        None => default_frames(&trunk),
        Some(list) => list
            .split(',')
            .map(|spec| {
                if spec.trim().is_empty() {
                    return Err(Failure::usage(
                        "--states must be a comma-separated list of states (e.g. deployed,folded)",
                    ));
                }
                Ok((spec.trim().to_string(), parse_frame(&trunk, spec)?))
            })
            .collect::<Result<_, _>>()?,
    };
    let mut paths: Vec<(&'static str, &std::path::Path)> = Vec::new();
    if let Some(p) = &args.svg {
        paths.push(("--svg", p));
    }
    if let Some(p) = &args.dxf {
        paths.push(("--dxf", p));
    }
    if let Some(p) = &args.fold {
        paths.push(("--fold", p));
    }
    let outputs = output::open_all(&paths)?;
    let title = format!("host-tool pattern: {}", trunk.describe());
    let mut folded = Vec::new();
    for (name, states) in &frames {
        let f = fold(&pattern, states).map_err(|e| Failure::usage(e.to_string()))?;
        if !f.feasible || f.max_strain > geometry::STRAIN_TOLERANCE {
            eprintln!(
                "warning: frame '{name}' is not isometric to the flat pattern (largest face strain {:.2} %); the FOLD frame records it",
                100.0 * f.max_strain
            );
        }
        folded.push((name.clone(), f));
    }
    for out in outputs {
        match out.flag() {
            "--svg" => {
                let text = fabrication::svg::render(&pattern, &title);
                out.write(|w| w.write_all(text.as_bytes()))?
            }
            "--dxf" => out.write(|w| fabrication::dxf_out::write(&pattern, w))?,
            _ => {
                let doc = fabrication::fold::document(
                    &pattern,
                    &folded,
                    &format!("host-tool {}", env!("CARGO_PKG_VERSION")),
                );
                out.write(|w| {
                    serde_json::to_writer(&mut *w, &doc).map_err(std::io::Error::other)?;
                    w.write_all(b"\n")
                })?
            }
        }
    }
    Ok(())
}
