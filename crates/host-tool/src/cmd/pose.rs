//! `host-tool pose` (where the tip is for a state and a bend) and `host-tool workspace` (each
//! state's reachable tips: JSON, a table, a side-view figure).
//!
//! Both are geometry queries (`geometry::reach`) on the crane as built
//! (`protocol::CraneGeometry::default()`, what the firmware is configured with: its trunk, its
//! bend limits per state and its tendon take-up margin); nothing is sent to a device.

use std::path::PathBuf;

use geometry::reach::{chain_in_plane, side_tip, TrunkHeights};
use geometry::TrunkState;
use planner::task::Workspace;
use protocol::CraneGeometry;
use serde_json::{json, Value};

use crate::failure::Failure;
use crate::figure::{self, colour, Anchor, Area, Figure, Format, Rect, Stroke, Ticks};

/// Arguments of `host-tool pose`.
#[derive(Debug, clap::Args)]
pub struct PoseArgs {
    /// The trunk state: F&P, F&F, F&D, D&P, D&F or D&D (quote the '&').
    #[arg(long, value_name = "STATE", value_parser = crate::arg::trunk_state)]
    pub state: TrunkState,
    /// The bend: ANGLE,DIRECTION in degrees (the tip axis tilted by ANGLE ≥ 0 toward DIRECTION,
    /// 0° = toward tendon 0, counter-clockwise seen from above). Default: straight.
    #[arg(long, value_name = "ANGLE,DIR", allow_hyphen_values = true,
          value_parser = crate::arg::usage(parse_bend))]
    pub bend: Option<(f64, f64)>,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// Arguments of `host-tool workspace`.
#[derive(Debug, clap::Args)]
pub struct WorkspaceArgs {
    /// Only this state (default: all six).
    #[arg(long, value_name = "STATE", value_parser = crate::arg::trunk_state)]
    pub state: Option<TrunkState>,
    /// Side-view points per state, from −limit to +limit (2 to 10 000).
    #[arg(long, default_value_t = 61, value_parser = crate::num::int_in(2, 10_000))]
    pub samples: u32,
    /// Write the side view of the workspaces: FIG.svg, FIG.png (600 dpi) or FIG.pdf.
    #[arg(long, value_name = "FIG")]
    pub figure: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(skip)]
    pub json: bool,
}

/// The crane's workspace as the firmware is configured: its trunk, the controller's bend
/// limits per state less what the tendons' take-up margin costs
/// ([`Workspace::held_limits`]).
pub fn crane_workspace(cfg: &CraneGeometry) -> Result<Workspace, Failure> {
    let limits = Workspace::held_limits(
        TrunkState::ALL.map(|s| cfg.bend_limit_deg(s).map(f64::from)),
        f64::from(cfg.take_up_margin_mm),
        f64::from(cfg.tendon_radius_mm),
    );
    Workspace::of_crane(cfg, limits)
        .map_err(|e| Failure::Runtime(anyhow::anyhow!("the crane's configuration: {e}")))
}

/// Parses `ANGLE,DIR` (degrees).
pub fn parse_bend(text: &str) -> Result<(f64, f64), Failure> {
    let bad = || {
        Failure::usage(format!(
            "invalid --bend '{text}': expected ANGLE,DIRECTION in degrees, e.g. 20,90"
        ))
    };
    let (a, d) = text.split_once(',').ok_or_else(bad)?;
    let a: f64 = a.trim().parse().map_err(|_| bad())?;
    let d: f64 = d.trim().parse().map_err(|_| bad())?;
    if !(a.is_finite() && d.is_finite()) {
        return Err(bad());
    }
    Ok((a, d))
}

fn r3(v: f64) -> f64 {
    (v * 1e3).round() / 1e3 + 0.0
}

/// Runs `host-tool pose`.
pub fn run_pose(args: PoseArgs) -> Result<(), Failure> {
    let state = args.state;
    let (angle, dir) = args.bend.unwrap_or((0.0, 0.0));
    let ws = crane_workspace(&CraneGeometry::default())?;
    let tip = ws
        .tip(state, angle, dir)
        .map_err(|e| Failure::usage(format!("--bend {angle},{dir}: {e}")))?;
    let [x, y, z] = tip.position_mm.map(r3);
    let axis = tip.axis.map(|v| (v * 1e6).round() / 1e6 + 0.0);
    if args.json {
        crate::cli::print_json(json!({
            "state": state.name(),
            "bend_deg": angle,
            "toward_deg": if angle == 0.0 { 0.0 } else { dir },
            "bend_limit_deg": ws.limit_deg(state).map(r3),
            "tip_mm": [x, y, z],
            "axis": axis,
            "height_mm": r3(ws.heights().height_mm(state)),
            "flexible_mm": r3(ws.heights().flexible_mm(state)),
        }));
    } else {
        crate::out!(
            "{state}, bend {angle}° toward {dir}°: tip at ({x:.1}, {y:.1}, {z:.1}) mm, axis ({:.3}, {:.3}, {:.3})",
            axis[0],
            axis[1],
            axis[2]
        );
        crate::out!(
            "  straight height {:.1} mm, bending over {:.1} mm; bend limit {}",
            ws.heights().height_mm(state),
            ws.heights().flexible_mm(state),
            ws.limit_deg(state)
                .map_or("none (not bent in this state)".to_string(), |l| format!(
                    "{l:.1}°"
                ))
        );
    }
    Ok(())
}

/// One state's workspace, summarised.
struct Summary {
    state: TrunkState,
    limit: Option<f64>,
    side: Vec<(f64, f64, f64)>,
    reach_mm: f64,
    z: (f64, f64),
}

fn summarise(ws: &Workspace, state: TrunkState, samples: usize) -> Summary {
    let side = ws.side_view(state, samples);
    let reach_mm = side.iter().map(|p| p.0.abs()).fold(0.0, f64::max);
    let z = side
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
    Summary {
        state,
        limit: ws.limit_deg(state),
        side,
        reach_mm,
        z,
    }
}

/// Runs `host-tool workspace`.
pub fn run_workspace(args: WorkspaceArgs) -> Result<(), Failure> {
    let states: Vec<TrunkState> = match args.state {
        Some(s) => vec![s],
        None => TrunkState::ALL.to_vec(),
    };
    let format = match &args.figure {
        Some(p) => Some(Format::from_path(p).ok_or_else(|| {
            Failure::usage(format!(
                "cannot tell the figure format of --figure {}: name it .svg, .png or .pdf",
                p.display()
            ))
        })?),
        None => None,
    };
    let cfg = CraneGeometry::default();
    let ws = crane_workspace(&cfg)?;
    let all: Vec<Summary> = states
        .iter()
        .map(|&s| summarise(&ws, s, args.samples as usize))
        .collect();
    if let (Some(path), Some(format)) = (&args.figure, format) {
        let fig = render(&ws, &all);
        let bytes = fig
            .encode(format)
            .map_err(|e| anyhow::anyhow!("cannot draw {}: {e}", path.display()))?;
        std::fs::write(path, bytes)
            .map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
        crate::say!(
            "{}: the side view of {} workspaces",
            path.display(),
            all.len()
        );
    }
    if args.json {
        let list: Vec<Value> = all
            .iter()
            .map(|s| {
                json!({
                    "state": s.state.name(),
                    "height_mm": r3(ws.heights().height_mm(s.state)),
                    "flexible_mm": r3(ws.heights().flexible_mm(s.state)),
                    "bend_limit_deg": s.limit.map(r3),
                    "controller_bend_limit_deg": cfg.bend_limit_deg(s.state).map(|l| r3(f64::from(l))),
                    "reach_mm": r3(s.reach_mm),
                    "z_mm": [r3(s.z.0), r3(s.z.1)],
                    "side_view": s.side.iter().map(|p| json!({"bend_deg": r3(p.2), "x_mm": r3(p.0), "z_mm": r3(p.1)})).collect::<Vec<_>>(),
                })
            })
            .collect();
        crate::cli::print_json(json!({
            "frame": "base: z up along the straight trunk, x toward tendon 0; each workspace is the surface of revolution of its side view about z",
            "take_up_margin_mm": f64::from(cfg.take_up_margin_mm),
            "states": list,
        }));
    } else {
        crate::out!(
            "  {:<5} {:>9} {:>10} {:>11} {:>10} {:>15}",
            "state",
            "height",
            "bending",
            "bend limit",
            "reach",
            "tip z"
        );
        for s in &all {
            crate::out!(
                "  {:<5} {:>6.1} mm {:>7.1} mm {:>11} {:>7.1} mm {:>6.1}–{:.1} mm",
                s.state.name(),
                ws.heights().height_mm(s.state),
                ws.heights().flexible_mm(s.state),
                s.limit.map_or("—".to_string(), |l| format!("±{l:.1}°")),
                s.reach_mm,
                s.z.0,
                s.z.1
            );
        }
        crate::out!("(reach: the tip's largest distance from the axis; the workspace of a state is the surface of revolution of its side view about the axis)");
    }
    Ok(())
}

/// Points along the trunk's centreline in `state` bent by `angle` (radians), in the side view.
fn centreline(h: &TrunkHeights, state: TrunkState, angle: f64) -> Vec<(f64, f64)> {
    let [b, t] = h.modules_mm(state);
    let [bb, tb] = geometry::reach::bending_modules(state);
    let flex = h.flexible_mm(state);
    let share = |len: f64, bends: bool| {
        if bends && flex > 0.0 {
            angle * len / flex
        } else {
            0.0
        }
    };
    let (ab, at) = (share(b, bb), share(t, tb));
    let n = 24;
    let mut pts = vec![(0.0, 0.0)];
    for i in 1..=n {
        let f = i as f64 / n as f64;
        let (r, z, _) = chain_in_plane(&[(b * f, ab * f)]);
        pts.push((r, z));
    }
    for i in 1..=n {
        let f = i as f64 / n as f64;
        let (r, z, _) = chain_in_plane(&[(b, ab), (t * f, at * f)]);
        pts.push((r, z));
    }
    pts
}

const STATE_COLOURS: [&str; 6] = [
    colour::GREY,
    colour::BLUE,
    colour::GREEN,
    colour::PURPLE,
    colour::VERMILLION,
    colour::ORANGE,
];

/// The side view of the workspaces at one scale for x and z: the trunk straight (thin) and at
/// its limit toward +x (dashed), the tip's locus from −limit to +limit (thick), each state named
/// at its straight tip.
fn render(ws: &Workspace, all: &[Summary]) -> Figure {
    let h = ws.heights();
    let x_max = all
        .iter()
        .map(|s| s.reach_mm)
        .fold(10.0, f64::max)
        .max(20.0);
    let z_max = all.iter().map(|s| s.z.1).fold(10.0, f64::max);
    let xt = Ticks::covering(-x_max - 5.0, x_max + 5.0, 7);
    let zt = Ticks::covering(0.0, z_max + 8.0, 12);
    let width = figure::COLUMN_PT;
    let left = Area::left_of(&zt.labels());
    let title_h = figure::LEADING * figure::SIZE_TITLE + 4.0;
    let plot_w = width - left - 6.0;
    let (u0, u1) = xt.range();
    let (v0, v1) = zt.range();
    let scale = plot_w / (u1 - u0);
    let plot_h = (v1 - v0) * scale;
    let height = title_h + plot_h + Area::below() + 4.0;
    let mut fig = Figure::new(width, height);
    fig.text(
        width / 2.0,
        figure::ASCENT * figure::SIZE_TITLE + 2.0,
        figure::SIZE_TITLE,
        Anchor::Middle,
        colour::BLACK,
        "Tip workspaces of the trunk states (side view)",
    );
    let area = Area {
        rect: Rect {
            x: left,
            y: title_h,
            w: plot_w,
            h: plot_h,
        },
        u: (u0, u1),
        v: (v0, v1),
    };
    area.axes(&mut fig, &xt, &zt, Some("x (mm)"), Some("z (mm)"), true);
    fig.begin("base");
    fig.line(
        area.map(u0, 0.0),
        area.map(u1, 0.0),
        Stroke::solid(colour::BLACK, 1.2),
    );
    // The straight trunks all lie on the axis.
    let top = all.iter().map(|s| s.z.1).fold(0.0, f64::max);
    fig.line(
        area.map(0.0, 0.0),
        area.map(0.0, top),
        Stroke::solid(colour::GREY, 0.5),
    );
    fig.end();
    for s in all {
        let c = STATE_COLOURS[s.state.index()];
        fig.begin(&format!("state-{}", s.state.name()));
        if let Some(limit) = s.limit.filter(|l| *l > 0.0) {
            let bent = centreline(h, s.state, limit.to_radians());
            let pts: Vec<_> = bent.iter().map(|p| area.map(p.0, p.1)).collect();
            fig.polyline(&pts, Stroke::dashed(c, 0.6, "2 1.2"));
            let locus: Vec<_> = s.side.iter().map(|p| area.map(p.0, p.1)).collect();
            fig.polyline(&locus, Stroke::solid(c, 1.6));
        } else {
            let (r, z, _) = side_tip(h, s.state, 0.0);
            fig.dot(area.map(r, z), 1.8, c);
        }
        fig.end();
    }
    // Labels: left of the axis, at each straight tip's height, pushed apart where they would
    // overlap (they stack downward from the highest).
    let mut order: Vec<&Summary> = all.iter().collect();
    order.sort_by(|a, b| b.z.1.total_cmp(&a.z.1));
    let line = figure::LEADING * figure::SIZE_LABEL;
    let mut last_y = f64::NEG_INFINITY;
    for s in order {
        let (r, z, _) = side_tip(h, s.state, 0.0);
        let (_, y) = area.map(r, z);
        let y = y.max(last_y + line);
        last_y = y;
        let text = match s.limit.filter(|l| *l > 0.0) {
            Some(l) => format!("{} ±{:.1}°", s.state.name(), l),
            None => format!("{} (not bent)", s.state.name()),
        };
        let (x0, _) = area.map(u0, 0.0);
        fig.label(
            x0 + 3.0,
            y + 0.5 * figure::CAP * figure::SIZE_LABEL,
            figure::SIZE_LABEL,
            Anchor::Start,
            STATE_COLOURS[s.state.index()],
            &text,
        );
    }
    fig
}
