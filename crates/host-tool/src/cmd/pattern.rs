//! `host-tool pattern`: the files to make a trunk — crease pattern (SVG, DXF, FOLD), the
//! printable dual-material panel (3MF, STL) and the meter-scale kit. The work is in the
//! `fabrication` crate; this parses, validates and writes.

use std::path::PathBuf;

use fabrication::folded::{fold, LayerState};
use fabrication::kit::Kit;
use fabrication::nest::{Nest, NestParams};
use fabrication::panel::{Panel, PanelParams};
use fabrication::parts::{Part, PartParams};
use fabrication::pattern::Pattern;
use fabrication::{Defaults, Module, Trunk};

use super::output;
use super::states::{designs_from, parse_betas, parse_n, Betas};
use crate::failure::Failure;

/// The trunk description shared by `pattern` and `model` (defaults: the paper's crane trunk).
#[derive(Debug, Clone, clap::Args)]
pub struct TrunkArgs {
    /// Number of polygon sides n of every module (an integer in [3, 64]).
    #[arg(long, default_value_t = Defaults::N, allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_n))]
    pub n: u32,
    /// Fold angle(s) β in degrees, one per module, bottom first (one value: one module). The
    /// default is the crane trunk: a 35° self-packing module under a 31.72° golden one.
    #[arg(long, default_value = Defaults::BETA, allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_betas))]
    pub beta: Betas,
    /// Layers per module: one count for every module or one per module (each in [1, 1000],
    /// at most 1000 in total).
    #[arg(long, default_value = Defaults::LAYERS, allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_layers))]
    pub layers: Layers,
    /// Edge length l in mm: the valley fold, the polygon side (0 < l ≤ 10000). Default 75 mm,
    /// the trunk's base length (§5.4, Table 2's L3).
    #[arg(long, default_value_t = Defaults::EDGE_MM, allow_hyphen_values = true,
          value_parser = crate::arg::usage(super::states::parse_edge_mm))]
    pub edge_mm: f64,
    /// The trunk's description (TOML, as trunks/pdf.toml): its `[design]` table gives n, the
    /// edge length and β and layers per module, in place of --n, --beta, --layers and
    /// --edge-mm (refused together with them). A design outside the crane's topology, one
    /// whose heights disagree with it, or a file without `[design]` is refused with the reason.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["n", "beta", "layers", "edge_mm"])]
    pub trunk: Option<PathBuf>,
}

/// `--layers`: one count for every module or one per module (the list as given).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layers(pub Vec<usize>);

fn parse_layers(text: &str) -> Result<Layers, Failure> {
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
    Ok(Layers(counts))
}

/// The layers of each of `m` modules.
fn layers_per_module(layers: &Layers, m: usize) -> Result<Vec<usize>, Failure> {
    match layers.0.as_slice() {
        [one] => Ok(vec![*one; m]),
        counts if counts.len() == m => Ok(counts.to_vec()),
        counts => Err(Failure::usage(format!(
            "--layers has {} values but --beta has {m} modules; give one count for all modules or one per module",
            counts.len()
        ))),
    }
}

impl TrunkArgs {
    /// Number of modules: the longer of the --beta and --layers lists.
    pub fn module_count(&self) -> usize {
        self.beta.0.len().max(self.layers.0.len())
    }

    /// Validates into a trunk.
    pub fn trunk(&self) -> Result<Trunk, Failure> {
        if let Some(path) = &self.trunk {
            return trunk_of_file(path);
        }
        let n = self.n;
        let m = self.module_count();
        let designs = designs_from(n, &self.beta, m, &format!("the stack has {m} modules"))?;
        let layers = layers_per_module(&self.layers, m)?;
        let modules = designs
            .into_iter()
            .zip(layers)
            .map(|(design, layers)| Module { design, layers })
            .collect();
        Trunk::new(modules, self.edge_mm).map_err(|e| Failure::usage(e.to_string()))
    }
}

/// The trunk of a description's `[design]` (`--trunk FILE`): the bottom module, then the top.
fn trunk_of_file(path: &std::path::Path) -> Result<Trunk, Failure> {
    use hil_sim::physics::{TrunkError, TrunkSpec};
    let shown = path.display();
    let text = std::fs::read_to_string(path)
        .map_err(|e| Failure::usage(format!("--trunk: cannot read the trunk file {shown}: {e}")))?;
    let refused = |e: TrunkError| Failure::usage(format!("--trunk {shown}: {e}"));
    let spec = TrunkSpec::from_toml(&text).map_err(refused)?;
    spec.check_design().map_err(refused)?;
    let Some(design) = spec.design else {
        return Err(Failure::usage(format!(
            "--trunk {shown} has no [design] table (n, edge_mm, [design.top] and \
             [design.bottom] with beta_deg and layers, as in trunks/pdf.toml): it describes the \
             simulated physics only, not the pattern"
        )));
    };
    let (top, bottom) = design.check().map_err(|e| refused(TrunkError::Design(e)))?;
    let modules = vec![
        Module {
            design: bottom,
            layers: design.bottom.layers as usize,
        },
        Module {
            design: top,
            layers: design.top.layers as usize,
        },
    ];
    Trunk::new(modules, design.edge_mm).map_err(|e| Failure::usage(format!("--trunk {shown}: {e}")))
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
    #[arg(long, allow_hyphen_values = true, value_parser = crate::arg::usage(parse_gap_list))]
    pub gap_mm: Option<Gaps>,
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
    /// Lay the kit's facets on cut sheets of WIDTHxHEIGHT mm (e.g. 1220x2440): one DXF and one
    /// SVG per sheet plus nest.json in --nest-dir, each facet with its hinges' insert holes, its
    /// id and its neighbours' ids.
    #[arg(long, value_name = "SHEET", value_parser = crate::arg::usage(parse_sheet))]
    pub nest: Option<[f64; 2]>,
    /// Directory for the cut sheets of --nest (sheet-1.dxf, sheet-1.svg, …, nest.json); created
    /// if missing.
    #[arg(long, value_name = "DIR")]
    pub nest_dir: Option<PathBuf>,
    /// Width of the laser's cut in mm, [0, 5]: cut paths are offset by half of it so the parts
    /// come out true to size.
    #[arg(long, default_value_t = 0.2, allow_hyphen_values = true)]
    pub kerf_mm: f64,
    /// Clear border of each sheet in mm: no cut within it.
    #[arg(long, default_value_t = 10.0, allow_hyphen_values = true)]
    pub margin_mm: f64,
    /// Least material between two parts' cut paths in mm, [0, 1000].
    #[arg(long, default_value_t = 3.0, allow_hyphen_values = true)]
    pub spacing_mm: f64,
    /// Finished diameter of the heat-set insert holes in mm (check your M4 insert's datasheet).
    #[arg(long, default_value_t = fabrication::nest::INSERT_HOLE_MM, allow_hyphen_values = true)]
    pub insert_hole_mm: f64,
    /// Write a bill of materials as CSV (section, part, quantity, unit, specification): the
    /// crane's printed panel and electronics, or with --kit/--nest the meter-scale kit (with
    /// --nest its sheet count).
    #[arg(long, value_name = "FILE")]
    pub bom: Option<PathBuf>,
    /// Where the legend (scale bar, trunk, line kinds, command) goes on the --svg page and the
    /// --page tiles: below the sheet, right of it, or none (crease lines only, e.g. for a
    /// laser cutter's import). On tiles it is printed once, on a page where it clears every
    /// crease line and registration mark.
    #[arg(long, value_name = "PLACE", default_value = "below",
          value_parser = crate::arg::usage(parse_legend))]
    pub legend: fabrication::svg::Legend,
    /// Tile the 1:1 crease pattern over paper pages (a4 or letter) with registration marks and
    /// a 50 mm scale bar: page-1.svg, page-2.svg, … in --page-dir. Print at 100 %.
    #[arg(long, value_name = "PAPER", value_parser = crate::arg::usage(parse_paper))]
    pub page: Option<fabrication::tiles::Paper>,
    /// Directory for the pages of --page; created if missing.
    #[arg(long, value_name = "DIR")]
    pub page_dir: Option<PathBuf>,
    /// Write the printable parts into DIR (created if missing), each as binary STL and as a
    /// slicer-ready 3MF (mm, its material, quantity and dimensions in the metadata): the
    /// meter-scale kit's hinge leaf (hinge-leaf, two and a 3 mm pin per hinge), the crane's
    /// upper-cap, lower-cap, tendon-locator and gripper-mount.
    #[arg(long, value_name = "DIR")]
    pub parts: Option<PathBuf>,
    /// File format of --parts: stl, 3mf or both (PART.stl and PART.3mf side by side).
    #[arg(long, value_name = "FORMAT", default_value = "both",
          value_parser = crate::arg::usage(PartsFormat::parse))]
    pub parts_format: PartsFormat,
    /// Thickness of the kit's panels in mm, [5.7, 50]: the M4 heat-set inserts (5.7 mm) sit
    /// fully in it; sets the hinge's screw length.
    #[arg(long, default_value_t = fabrication::parts::DEFAULT_PANEL_MM, allow_hyphen_values = true)]
    pub panel_mm: f64,
    /// Largest fold angle (degrees, (0, 180], 0 = flat) the hinge must allow; sets the pin's
    /// height above the facet so the screw heads clear.
    #[arg(long, default_value_t = 180.0, allow_hyphen_values = true)]
    pub fold_max_deg: f64,
    /// Radius in mm at which the three tendons run (the firmware's default); the caps, the
    /// tendon locator and the gripper mount have their tendon holes there.
    #[arg(long, default_value_t = fabrication::parts::DEFAULT_TENDON_RADIUS_MM, allow_hyphen_values = true)]
    pub tendon_radius_mm: f64,
    /// Print what was written as one JSON object on stdout (instead of the kit's table).
    #[arg(skip)]
    pub json: bool,
}

/// One file written: what the command reports.
struct Wrote {
    flag: &'static str,
    path: String,
    bytes: u64,
    format: &'static str,
    what: String,
    extra: serde_json::Value,
}

fn human_bytes(n: u64) -> String {
    if n < 1000 {
        format!("{n} B")
    } else if n < 1_000_000 {
        format!("{:.1} kB", n as f64 / 1e3)
    } else {
        format!("{:.1} MB", n as f64 / 1e6)
    }
}

fn report(
    trunk: &Trunk,
    wrote: &[Wrote],
    extra: serde_json::Map<String, serde_json::Value>,
    json: bool,
) {
    if json {
        let mut v = serde_json::json!({
            "trunk": trunk.describe(),
            "files": wrote.iter().map(|w| {
                let mut o = serde_json::json!({
                    "flag": w.flag,
                    "path": w.path,
                    "bytes": w.bytes,
                    "format": w.format,
                    "description": w.what,
                });
                if let (Some(o), Some(e)) = (o.as_object_mut(), w.extra.as_object()) {
                    o.extend(e.clone());
                }
                o
            }).collect::<Vec<_>>(),
        });
        if let Some(o) = v.as_object_mut() {
            o.extend(extra);
        }
        crate::cli::print_json(crate::num::clean(v));
    } else {
        for w in wrote {
            crate::say!("wrote {} ({}): {}", w.path, human_bytes(w.bytes), w.what);
        }
    }
}

/// `--gap-mm`: gap widths in mm, one for all modules or one per module (the list as given;
/// the panel checks each against its facets).
#[derive(Debug, Clone, PartialEq)]
pub struct Gaps(pub Vec<f64>);

fn parse_gap_list(text: &str) -> Result<Gaps, Failure> {
    text.split(',')
        .map(|t| {
            t.trim().parse::<f64>().map_err(|_| {
                Failure::usage(format!(
                    "--gap-mm must be gap widths in mm, one for all modules or one per module, got '{text}'"
                ))
            })
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Gaps)
}

fn parse_gaps(args: &Args, trunk: &Trunk) -> Result<Vec<f64>, Failure> {
    let m = trunk.modules().len();
    let betas = Betas(
        trunk
            .modules()
            .iter()
            .map(|m| m.design.beta_deg())
            .collect(),
    );
    let Gaps(gaps) = match &args.gap_mm {
        Some(g) => g.clone(),
        None if parse_betas(Defaults::BETA).is_ok_and(|d| d == betas) => {
            parse_gap_list(Defaults::GAP_MM_TRUNK)?
        }
        None => Gaps(vec![Defaults::GAP_MM]),
    };
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

/// The cut-sheet parameters, validated.
fn nest_params(args: &Args) -> Result<Option<NestParams>, Failure> {
    let Some(sheet) = &args.nest else {
        let given = args.nest_dir.is_some()
            || args.kerf_mm != 0.2
            || args.margin_mm != 10.0
            || args.spacing_mm != 3.0
            || args.insert_hole_mm != fabrication::nest::INSERT_HOLE_MM;
        if given {
            return Err(Failure::usage(
                "--nest-dir, --kerf-mm, --margin-mm, --spacing-mm and --insert-hole-mm shape the cut sheets; give --nest WIDTHxHEIGHT too",
            ));
        }
        return Ok(None);
    };
    if args.nest_dir.is_none() {
        return Err(Failure::usage(
            "--nest writes one DXF and one SVG per sheet: give --nest-dir DIR for them",
        ));
    }
    Ok(Some(NestParams {
        sheet_mm: *sheet,
        kerf_mm: args.kerf_mm,
        margin_mm: args.margin_mm,
        spacing_mm: args.spacing_mm,
        hole_mm: args.insert_hole_mm,
    }))
}

/// `--nest`: a cut sheet's WIDTHxHEIGHT, mm.
fn parse_sheet(text: &str) -> Result<[f64; 2], Failure> {
    NestParams::parse_sheet(text).map_err(|e| Failure::usage(format!("--nest: {e}")))
}

/// `--legend`: where the legend goes.
fn parse_legend(text: &str) -> Result<fabrication::svg::Legend, Failure> {
    fabrication::svg::Legend::parse(text).map_err(|e| Failure::usage(format!("--legend: {e}")))
}

/// `--page`: the paper of the tiles.
fn parse_paper(text: &str) -> Result<fabrication::tiles::Paper, Failure> {
    fabrication::tiles::Paper::parse(text).map_err(|e| Failure::usage(format!("--page: {e}")))
}

/// Which files --parts writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartsFormat {
    /// PART.stl only.
    Stl,
    /// PART.3mf only.
    ThreeMf,
    /// Both side by side.
    Both,
}

impl PartsFormat {
    fn parse(text: &str) -> Result<Self, Failure> {
        match text.trim().to_ascii_lowercase().as_str() {
            "stl" => Ok(PartsFormat::Stl),
            "3mf" => Ok(PartsFormat::ThreeMf),
            "both" => Ok(PartsFormat::Both),
            _ => Err(Failure::usage(format!(
                "--parts-format must be stl, 3mf or both, got '{text}'"
            ))),
        }
    }

    fn extensions(self) -> &'static [&'static str] {
        match self {
            PartsFormat::Stl => &["stl"],
            PartsFormat::ThreeMf => &["3mf"],
            PartsFormat::Both => &["stl", "3mf"],
        }
    }
}

/// The printable parts: every part for --parts; for --bom, the parts of its build (the hinge
/// leaf for the kit, the crane's parts for the crane). Sizing flags that nothing uses are
/// refused.
struct Printable {
    /// Written by --parts.
    files: Vec<Part>,
    /// The crane's parts for its BOM.
    crane: Vec<Part>,
    /// The kit's hinge leaf for its BOM.
    leaf: Option<Part>,
}

fn printable_parts(
    args: &Args,
    trunk: &Trunk,
    kit_bom: bool,
    format: PartsFormat,
) -> Result<Printable, Failure> {
    let params = PartParams {
        panel_mm: args.panel_mm,
        fold_max_deg: args.fold_max_deg,
        tendon_radius_mm: args.tendon_radius_mm,
    };
    let defaults = PartParams::default();
    let bom = args.bom.is_some();
    if args.parts.is_none() {
        if format != PartsFormat::Both {
            return Err(Failure::usage(
                "--parts-format chooses the files of --parts; give --parts DIR too",
            ));
        }
        let hinge_given =
            params.panel_mm != defaults.panel_mm || params.fold_max_deg != defaults.fold_max_deg;
        let crane_bom = bom && !kit_bom;
        if hinge_given && !(bom && kit_bom) {
            return Err(Failure::usage(
                "--panel-mm and --fold-max-deg size the kit's hinge leaf; give --parts DIR too (or --bom FILE with --kit or --nest)",
            ));
        }
        if params.tendon_radius_mm != defaults.tendon_radius_mm && !crane_bom {
            return Err(Failure::usage(
                "--tendon-radius-mm sizes the crane's caps, tendon locator and gripper mount; give --parts DIR too (or --bom FILE, without --kit and --nest)",
            ));
        }
    }
    let usage = |e: fabrication::FabError| Failure::usage(e.to_string());
    let hinges = Kit::new(trunk).hinges.len();
    let files = if args.parts.is_some() {
        fabrication::parts::all_parts(trunk, &params, hinges).map_err(usage)?
    } else {
        Vec::new()
    };
    let crane = if bom && !kit_bom {
        fabrication::parts::crane_parts(trunk, &params).map_err(usage)?
    } else {
        Vec::new()
    };
    let leaf = if bom && kit_bom {
        Some(fabrication::parts::hinge_leaf(&params, hinges).map_err(usage)?)
    } else {
        None
    };
    Ok(Printable { files, crane, leaf })
}

fn part_json(p: &Part) -> serde_json::Value {
    let dims: serde_json::Map<String, serde_json::Value> = p
        .dimensions
        .iter()
        .map(|(k, v)| ((*k).to_string(), serde_json::json!(v)))
        .collect();
    serde_json::json!({
        "part": p.name,
        "quantity": p.quantity,
        "material": p.material.name,
        "density_g_per_cm3": p.material.g_per_cm3,
        "mass_g": p.mass_g(),
        "triangles": p.mesh.triangles.len(),
        "volume_mm3": p.mesh.volume(),
        "dimensions": dims,
        "holes": p.holes.iter().map(|h| serde_json::json!({
            "role": h.role.name(),
            "centre_mm": h.centre_mm,
            "axis": h.axis,
            "diameter_mm": h.diameter_mm,
            "depth_mm": h.depth_mm,
        })).collect::<Vec<_>>(),
    })
}

fn runtime(what: &str, e: impl std::fmt::Display) -> Failure {
    Failure::Runtime(anyhow::anyhow!("{what}: {e}"))
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
        && args.nest.is_none()
        && args.bom.is_none()
        && args.page.is_none()
        && args.parts.is_none()
    {
        return Err(Failure::usage(
            "nothing to write: give at least one of --svg FILE, --dxf FILE, --fold FILE, --3mf FILE, --stl-dir DIR, --kit FILE, --nest SHEET, --bom FILE, --page PAPER, --parts DIR",
        ));
    }
    let kit_bom = args.kit.is_some() || args.nest.is_some();
    let parts_format = args.parts_format;
    let legend = args.legend;
    if legend != fabrication::svg::Legend::Below && args.svg.is_none() && args.page.is_none() {
        return Err(Failure::usage(
            "--legend places the legend of --svg and --page; give --svg FILE or --page PAPER too",
        ));
    }
    let printable = printable_parts(&args, &trunk, kit_bom, parts_format)?;
    let parts = &printable.files;
    let wants_panel =
        args.three_mf.is_some() || args.stl_dir.is_some() || (args.bom.is_some() && !kit_bom);
    let panel_given = args.gap_mm.is_some()
        || args.facet_mm != Defaults::FACET_MM
        || args.base_mm != Defaults::BASE_MM;
    if panel_given && !wants_panel {
        return Err(Failure::usage(
            "--gap-mm, --facet-mm and --base-mm shape the printed panel; give --3mf FILE or --stl-dir DIR too (or --bom FILE, without --kit and --nest)",
        ));
    }
    let panel = if wants_panel {
        let params = PanelParams {
            gap_mm: parse_gaps(&args, &trunk)?,
            facet_mm: args.facet_mm,
            base_mm: args.base_mm,
        };
        Some(Panel::new(&pattern, params).map_err(|e| Failure::usage(e.to_string()))?)
    } else {
        None
    };
    let nest = match nest_params(&args)? {
        Some(p) => Some(Nest::new(&trunk, p).map_err(|e| Failure::usage(format!("--nest: {e}")))?),
        None => None,
    };
    let title = format!("host-tool pattern: {}", trunk.describe());
    let tiling = match (args.page, &args.page_dir) {
        (Some(p), Some(_)) => Some(fabrication::tiles::tiling(&pattern, p, legend, &title)),
        (Some(_), None) => {
            return Err(Failure::usage(
                "--page writes one SVG per page: give --page-dir DIR for them",
            ))
        }
        (None, Some(_)) => {
            return Err(Failure::usage(
                "--page-dir holds the pages of --page; give --page a4|letter too",
            ))
        }
        (None, None) => None,
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
    if let Some(p) = &args.bom {
        paths.push(("--bom", p));
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
    let nest_paths: Vec<(PathBuf, PathBuf)> = match (&nest, &args.nest_dir) {
        (Some(nest), Some(dir)) => {
            output::ensure_dir("--nest-dir", dir)?;
            (1..=nest.sheets.len())
                .map(|i| {
                    (
                        dir.join(format!("sheet-{i}.dxf")),
                        dir.join(format!("sheet-{i}.svg")),
                    )
                })
                .collect()
        }
        _ => Vec::new(),
    };
    let nest_json = args.nest_dir.as_ref().map(|d| d.join("nest.json"));
    for (dxf, svg) in &nest_paths {
        paths.push(("--nest", dxf));
        paths.push(("--nest", svg));
    }
    if let (Some(p), Some(_)) = (&nest_json, &nest) {
        paths.push(("--nest", p));
    }
    let page_paths: Vec<PathBuf> = match (&tiling, &args.page_dir) {
        (Some(t), Some(dir)) => {
            output::ensure_dir("--page-dir", dir)?;
            (1..=t.pages())
                .map(|i| dir.join(format!("page-{i}.svg")))
                .collect()
        }
        _ => Vec::new(),
    };
    for p in &page_paths {
        paths.push(("--page", p));
    }
    let part_paths: Vec<(&Part, &'static str, PathBuf)> = match &args.parts {
        Some(dir) => {
            output::ensure_dir("--parts", dir)?;
            parts
                .iter()
                .flat_map(|p| {
                    parts_format
                        .extensions()
                        .iter()
                        .map(move |ext| (p, *ext, dir.join(format!("{}.{ext}", p.name))))
                })
                .collect()
        }
        None => Vec::new(),
    };
    for (_, _, p) in &part_paths {
        paths.push(("--parts", p));
    }
    let mut part_iter = part_paths.iter();
    let outputs = output::open_all(&paths)?;
    let page_svgs = tiling
        .as_ref()
        .map(|t| fabrication::tiles::pages(&pattern, t, &title))
        .unwrap_or_default();
    let mut page_svgs = page_svgs.into_iter().enumerate();
    let mut folded = Vec::new();
    for (name, states) in &frames {
        let f = fold(&pattern, states).map_err(|e| Failure::usage(e.to_string()))?;
        if !f.feasible || f.max_strain > geometry::STRAIN_TOLERANCE {
            crate::say!(
                "warning: frame '{name}' is not isometric to the flat pattern (largest face strain {:.2} %); the FOLD frame records it",
                100.0 * f.max_strain
            );
        }
        folded.push((name.clone(), f));
    }
    let kit = kit_bom.then(|| Kit::new(&trunk));
    let mut stl_meshes = panel
        .iter()
        .flat_map(|p| [(&p.base, "TPU 95A base sheet"), (&p.facets, "nylon facets")]);
    let mut nest_files = nest_paths
        .iter()
        .enumerate()
        .flat_map(|(i, (d, s))| [(i, d, "DXF"), (i, s, "SVG")]);
    let l = trunk.edge_mm();
    let (sheet_w, sheet_h) = ((pattern.width() + pattern.seam()) * l, pattern.height() * l);
    let mut wrote: Vec<Wrote> = Vec::new();
    let mut extra = serde_json::Map::new();
    for out in outputs {
        let flag = out.flag();
        let path = out.path().display().to_string();
        let mut record = |bytes, format, what: String, extra: serde_json::Value| {
            wrote.push(Wrote {
                flag,
                path: path.clone(),
                bytes,
                format,
                what,
                extra,
            })
        };
        match flag {
            "--3mf" => {
                if let Some(panel) = &panel {
                    let app = format!("host-tool {}", env!("CARGO_PKG_VERSION"));
                    let mut buf = std::io::Cursor::new(Vec::new());
                    panel
                        .write_3mf(&pattern, &app, &mut buf)
                        .map_err(|e| runtime("3MF", e))?;
                    let n = out.write_counted(|w| w.write_all(buf.get_ref()))?;
                    let facets = panel.facet_count;
                    record(
                        n,
                        "3mf",
                        format!("printable panel, 2 objects (TPU base, {facets} nylon facets)"),
                        serde_json::json!({ "objects": 2, "facets": facets }),
                    );
                }
            }
            "--stl-dir" => {
                if let Some((mesh, what)) = stl_meshes.next() {
                    let n = out.write_counted(|w| mesh.write_stl(w))?;
                    let tris = mesh.triangles.len();
                    record(
                        n,
                        "stl",
                        format!("{what}, {tris} triangles"),
                        serde_json::json!({ "triangles": tris }),
                    );
                }
            }
            "--parts" => {
                let Some((part, ext, _)) = part_iter.next() else {
                    continue;
                };
                let (n, format) = if *ext == "3mf" {
                    let app = format!("host-tool {}", env!("CARGO_PKG_VERSION"));
                    let bytes = part.model(&app).to_bytes().map_err(|e| runtime("3MF", e))?;
                    (out.write_counted(|w| w.write_all(&bytes))?, "3mf")
                } else {
                    (out.write_counted(|w| part.mesh.write_stl(w))?, "stl")
                };
                record(
                    n,
                    format,
                    format!(
                        "{}, {} triangles, {} cm³ of {} ({} g printed solid), print {}",
                        part.description,
                        part.mesh.triangles.len(),
                        crate::num::fixed(part.mesh.volume() / 1000.0, 2),
                        part.material.name,
                        crate::num::fixed(part.mass_g(), 1),
                        part.quantity
                    ),
                    part_json(part),
                );
            }
            "--page" => {
                let (Some(t), Some((i, text))) = (&tiling, page_svgs.next()) else {
                    continue;
                };
                let n = out.write_counted(|w| w.write_all(text.as_bytes()))?;
                let [pw, ph] = t.page_mm;
                record(
                    n,
                    "svg",
                    format!(
                        "crease pattern 1:1, page {} of {} ({} {}, {} × {} pages)",
                        i + 1,
                        t.pages(),
                        t.paper.name(),
                        if pw > ph { "landscape" } else { "portrait" },
                        t.grid[0],
                        t.grid[1]
                    ),
                    serde_json::json!({
                        "page": i + 1,
                        "pages": t.pages(),
                        "page_mm": t.page_mm,
                        "grid": t.grid,
                        "legend": t.legend.as_ref().is_some_and(|(_, _, p)| *p == i),
                    }),
                );
            }
            "--bom" => {
                let bom = match (&kit, &panel, &printable.leaf) {
                    (Some(kit), _, Some(leaf)) => {
                        fabrication::bom::Bom::kit(kit, nest.as_ref(), leaf)
                    }
                    (None, Some(panel), _) => fabrication::bom::Bom::crane(panel, &printable.crane),
                    _ => continue,
                };
                let text = bom.to_csv();
                let n = out.write_counted(|w| w.write_all(text.as_bytes()))?;
                record(
                    n,
                    "csv",
                    format!(
                        "bill of materials ({}), {} lines",
                        if kit.is_some() {
                            "meter-scale kit: sheets, facets, printed hinge leaves, pins, screws, inserts"
                        } else {
                            "crane: printed panel, printed parts, magnets, electronics"
                        },
                        bom.rows.len()
                    ),
                    serde_json::json!({ "rows": bom.rows.len() }),
                );
            }
            "--kit" => {
                if let Some(kit) = &kit {
                    let text = serde_json::to_string_pretty(&crate::num::clean(kit.to_json()))
                        .map_err(|e| runtime("kit JSON", e))?;
                    let n = out.write_counted(|w| {
                        w.write_all(text.as_bytes())?;
                        w.write_all(b"\n")
                    })?;
                    record(
                        n,
                        "json",
                        format!(
                            "meter-scale kit, {} facets, {} hinges, {} screws",
                            kit.facet_count(),
                            kit.hinges.len(),
                            kit.screws()
                        ),
                        serde_json::json!({ "facets": kit.facet_count(), "hinges": kit.hinges.len(), "screws": kit.screws() }),
                    );
                    if !args.json {
                        crate::out_raw!("{}", kit.table());
                    }
                }
            }
            "--svg" => {
                let text = fabrication::svg::render(&pattern, &title, legend);
                let n = out.write_counted(|w| w.write_all(text.as_bytes()))?;
                let lay = fabrication::svg::layout(&pattern, &title, legend);
                let [pw, ph] = lay.page_mm;
                record(
                    n,
                    "svg",
                    format!(
                        "crease pattern 1:1, one {} × {} mm page (sheet {} × {} mm)",
                        crate::num::fixed(pw, 1),
                        crate::num::fixed(ph, 1),
                        crate::num::fixed(sheet_w, 1),
                        crate::num::fixed(sheet_h, 1)
                    ),
                    serde_json::json!({
                        "pages": 1,
                        "page_mm": [pw, ph],
                        "sheet_mm": [sheet_w, sheet_h],
                        "legend": legend.name(),
                        "legend_box_mm": lay.legend.as_ref().map(|(_, b)| b.to_vec()),
                    }),
                );
            }
            "--dxf" => {
                let n = out.write_counted(|w| fabrication::dxf_out::write(&pattern, w))?;
                let lines = pattern.lines().len();
                record(
                    n,
                    "dxf",
                    format!(
                        "crease pattern, {lines} lines, sheet {} × {} mm",
                        crate::num::fixed(sheet_w, 1),
                        crate::num::fixed(sheet_h, 1)
                    ),
                    serde_json::json!({ "lines": lines, "sheet_mm": [sheet_w, sheet_h] }),
                );
            }
            "--nest" => {
                let Some(nest) = &nest else { continue };
                if let Some((i, _, kind)) = nest_files.next() {
                    let parts = nest.sheets[i].len();
                    let holes: usize = nest.sheets[i].iter().map(|p| p.holes.len()).sum();
                    let n = if kind == "DXF" {
                        out.write_counted(|w| fabrication::nest_out::write_dxf(nest, i, w))?
                    } else {
                        let text = fabrication::nest_out::svg_sheet(
                            nest,
                            i,
                            &format!("{title}: sheet {} of {}", i + 1, nest.sheets.len()),
                        );
                        out.write_counted(|w| w.write_all(text.as_bytes()))?
                    };
                    let [w, h] = nest.params.sheet_mm;
                    record(
                        n,
                        if kind == "DXF" { "dxf" } else { "svg" },
                        format!(
                            "cut sheet {} of {} ({w} × {h} mm), {parts} facets, {holes} insert holes",
                            i + 1,
                            nest.sheets.len()
                        ),
                        serde_json::json!({ "sheet": i + 1, "sheets": nest.sheets.len(), "parts": parts, "holes": holes }),
                    );
                } else {
                    let files: Vec<(String, String)> = nest_paths
                        .iter()
                        .map(|(d, s)| (d.display().to_string(), s.display().to_string()))
                        .collect();
                    let doc = crate::num::clean(fabrication::nest_out::to_json(nest, &files));
                    let text =
                        serde_json::to_string_pretty(&doc).map_err(|e| runtime("nest JSON", e))?;
                    let n = out.write_counted(|w| {
                        w.write_all(text.as_bytes())?;
                        w.write_all(b"\n")
                    })?;
                    record(
                        n,
                        "json",
                        format!("cut-sheet layout: {}", nest.summary()),
                        serde_json::json!({}),
                    );
                    extra.insert(
                        "nest".into(),
                        serde_json::json!({
                            "sheet_mm": nest.params.sheet_mm,
                            "sheets": nest.sheets.len(),
                            "area_bound_sheets": nest.area_bound,
                            "facets": nest.part_count(),
                            "holes": nest.hole_count(),
                            "utilisation": nest.utilisation(),
                        }),
                    );
                }
            }
            _ => {
                let doc = fabrication::fold::document(
                    &pattern,
                    &folded,
                    &format!("host-tool {}", env!("CARGO_PKG_VERSION")),
                );
                let n = out.write_counted(|w| {
                    serde_json::to_writer(&mut *w, &doc).map_err(std::io::Error::other)?;
                    w.write_all(b"\n")
                })?;
                record(
                    n,
                    "fold",
                    format!(
                        "FOLD v1.2, crease pattern + {}",
                        crate::num::plural(folded.len(), "folded frame", "folded frames")
                    ),
                    serde_json::json!({ "frames": folded.len() }),
                );
            }
        }
    }
    if let Some(nest) = &nest {
        crate::say!("{}", nest.summary());
    }
    report(&trunk, &wrote, extra, args.json);
    Ok(())
}
