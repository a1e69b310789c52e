//! `host-tool pattern`: the files to make a trunk — crease pattern (SVG, DXF, FOLD), the
//! printable dual-material panel (3MF, STL) and the meter-scale kit. The work is in the
//! `fabrication` crate; this parses, validates and writes.

use std::path::PathBuf;

use fabrication::folded::{fold, LayerState};
use fabrication::kit::Kit;
use fabrication::panel::{Panel, PanelParams};
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
    /// Write the printable dual-material panel as 3MF: a TPU 95A base object and a nylon
    /// facets object, print parameters in the metadata (§5.3).
    #[arg(long = "3mf", value_name = "FILE")]
    pub three_mf: Option<PathBuf>,
    /// Write the panel as one binary STL per material into DIR (base-tpu.stl,
    /// facets-nylon.stl); DIR is created if missing.
    #[arg(long, value_name = "DIR")]
    pub stl_dir: Option<PathBuf>,
    /// Gap between neighbouring facets in mm, one for all modules or one per module
    /// (positive, below twice the smallest facet's inradius). Default: 3,1.5 for the default
    /// crane trunk (Table 2's d4 = 2·d1 under the 35° module, d1 under the golden one), else
    /// 1.5 (d1) for every module.
    #[arg(long, allow_hyphen_values = true)]
    pub gap_mm: Option<String>,
    /// Nylon facet thickness in mm, (0, 20] (Table 2's t1).
    #[arg(long, default_value_t = Defaults::FACET_MM, allow_hyphen_values = true)]
    pub facet_mm: f64,
    /// TPU 95A base sheet thickness in mm, (0, 20] (Table 2's t2).
    #[arg(long, default_value_t = Defaults::BASE_MM, allow_hyphen_values = true)]
    pub base_mm: f64,
    /// Write the meter-scale kit (§7) as JSON: facet cut list, hinge positions, hinge and
    /// screw counts; the table is printed. The paper's build: --beta 31.72 --layers 4
    /// --edge-mm 609.6 (four 2 ft modules: 180 hinges, 720 screws).
    #[arg(long, value_name = "FILE")]
    pub kit: Option<PathBuf>,
}

fn parse_gaps(args: &Args, m: usize) -> Result<Vec<f64>, Failure> {
    let text = match &args.gap_mm {
        Some(t) => t.clone(),
        None if args.trunk.beta.trim() == Defaults::BETA && m == 2 => {
            Defaults::GAP_MM_TRUNK.to_string()
        }
        None => Defaults::GAP_MM.to_string(),
    };
    let gaps = text
        .split(',')
        .map(|t| {
            t.trim().parse::<f64>().map_err(|_| {
                Failure::usage(format!(
                    "--gap-mm must be gap widths in mm, one for all modules or one per module, got '{text}'"
                ))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    match gaps.len() {
        1 => Ok(vec![gaps[0]; m]),
        k if k == m => Ok(gaps),
        k => Err(Failure::usage(format!(
            "--gap-mm has {k} values but the trunk has {m} modules; give one gap for all or one per module"
        ))),
    }
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
    if args.svg.is_none()
        && args.dxf.is_none()
        && args.fold.is_none()
        && args.three_mf.is_none()
        && args.stl_dir.is_none()
        && args.kit.is_none()
    {
        return Err(Failure::usage(
            "nothing to write: give at least one of --svg FILE, --dxf FILE, --fold FILE, --3mf FILE, --stl-dir DIR, --kit FILE",
        ));
    }
    let wants_panel = args.three_mf.is_some() || args.stl_dir.is_some();
    let panel_given = args.gap_mm.is_some()
        || args.facet_mm != Defaults::FACET_MM
        || args.base_mm != Defaults::BASE_MM;
    if panel_given && !wants_panel {
        return Err(Failure::usage(
            "--gap-mm, --facet-mm and --base-mm shape the printed panel; give --3mf FILE or --stl-dir DIR too",
        ));
    }
    let panel = if wants_panel {
        let params = PanelParams {
            gap_mm: parse_gaps(&args, trunk.modules().len())?,
            facet_mm: args.facet_mm,
            base_mm: args.base_mm,
        };
        Some(Panel::new(&pattern, params).map_err(|e| Failure::usage(e.to_string()))?)
    } else {
        None
    };
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
    if let Some(p) = &args.three_mf {
        paths.push(("--3mf", p));
    }
    if let Some(p) = &args.kit {
        paths.push(("--kit", p));
    }
    let stl_paths = args
        .stl_dir
        .as_ref()
        .map(|d| (d.join("base-tpu.stl"), d.join("facets-nylon.stl")));
    if let (Some(dir), Some((base, facets))) = (&args.stl_dir, &stl_paths) {
        output::ensure_dir("--stl-dir", dir)?;
        paths.push(("--stl-dir", base));
        paths.push(("--stl-dir", facets));
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
    let kit = args.kit.as_ref().map(|_| Kit::new(&trunk));
    let mut stl_meshes = panel.iter().flat_map(|p| [&p.base, &p.facets]);
    for out in outputs {
        match out.flag() {
            "--3mf" => {
                if let Some(panel) = &panel {
                    let app = format!("host-tool {}", env!("CARGO_PKG_VERSION"));
                    let mut buf = std::io::Cursor::new(Vec::new());
                    panel
                        .write_3mf(&pattern, &app, &mut buf)
                        .map_err(|e| Failure::Runtime(anyhow::anyhow!("3MF: {e}")))?;
                    out.write(|w| w.write_all(buf.get_ref()))?
                }
            }
            "--stl-dir" => {
                if let Some(mesh) = stl_meshes.next() {
                    out.write(|w| mesh.write_stl(w))?
                }
            }
            "--kit" => {
                if let Some(kit) = &kit {
                    let text = serde_json::to_string_pretty(&kit.to_json())
                        .map_err(|e| Failure::Runtime(anyhow::anyhow!("kit JSON: {e}")))?;
                    out.write(|w| w.write_all(text.as_bytes()))?;
                    print!("{}", kit.table());
                }
            }
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
