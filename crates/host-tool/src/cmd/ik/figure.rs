//! The picture a user looks at first, sized for one journal column: the target curve and the
//! fitted boom (module rings and side edges) in three orthographic views laid out in
//! third-angle projection — top view above the front view, side view right of it — at one
//! common scale with equal aspect, axes in units of l; tips marked and labelled with their
//! states; a legend for every mark.

use geometry::ModuleDesign;
use planner::ik::{Frame, Point3, Problem, Solution};

use crate::figure::{
    colour, paragraph, text_box, text_width, wrap, Anchor, Area, Figure, Legend, Rect, Stroke,
    Swatch, Ticks, ASCENT, CAP, COLUMN_PT, DESCENT, LEADING, SIZE_LABEL, SIZE_TICK, SIZE_TITLE,
};

/// What the header says about the fit.
pub struct Header {
    /// Solver name.
    pub algorithm: String,
    /// The target as given (generator spec or file path).
    pub target: String,
    /// Metric name.
    pub metric: String,
    /// The fit's RMS in l.
    pub rms: f64,
    /// "proven optimal", "≤ 3.2 % above the optimum", or empty.
    pub status: String,
    /// One short line per warning of the fit (`ik::diagnose`), drawn under the header.
    pub warnings: Vec<String>,
}

/// Module geometry in world coordinates.
struct Boom {
    /// Top ring of every module (and the base ring first).
    rings: Vec<Vec<Point3<f64>>>,
    /// Side edges, with whether the module's state is infeasible.
    edges: Vec<([Point3<f64>; 2], bool)>,
}

fn boom(problem: &Problem, designs: &[ModuleDesign], s: &Solution) -> Boom {
    let frames = problem.catalogue.frames(&s.states);
    let mut rings = Vec::new();
    let mut edges = Vec::new();
    for (i, d) in designs.iter().enumerate() {
        let bottom = if i == 0 {
            Frame::identity()
        } else {
            frames[i - 1]
        };
        let top = frames[i];
        let infeasible = !problem.catalogue.candidates(i)[s.states[i]].feasible;
        let ring: Vec<Point3<f64>> = (0..d.n()).map(|k| d.bottom_vertex(k)).collect();
        let b: Vec<Point3<f64>> = ring.iter().map(|p| bottom.apply(p)).collect();
        let t: Vec<Point3<f64>> = ring.iter().map(|p| top.apply(p)).collect();
        for k in 0..ring.len() {
            edges.push(([b[k], t[k]], infeasible));
        }
        if i == 0 {
            rings.push(b);
        }
        rings.push(t);
    }
    Boom { rings, edges }
}

/// A short name of a state for a tip label: D, F, FF, SP, E0…, V0….
pub fn abbreviation(name: &str) -> String {
    match name {
        "deployed" => "D".into(),
        "folded" => "F".into(),
        "flat-folded" => "FF".into(),
        "self-packed" => "SP".into(),
        _ => {
            if let Some(k) = name.strip_prefix("edge-") {
                format!("E{k}")
            } else if let Some(k) = name.strip_prefix("vertex-") {
                format!("V{k}")
            } else {
                name.to_string()
            }
        }
    }
}

/// What the abbreviations used stand for, for the legend.
fn abbreviation_key(names: &[String]) -> String {
    let mut parts: Vec<&str> = Vec::new();
    let has = |p: &dyn Fn(&str) -> bool| names.iter().any(|n| p(n));
    if has(&|n| n == "deployed") {
        parts.push("D\u{a0}deployed");
    }
    if has(&|n| n == "folded") {
        parts.push("F\u{a0}folded");
    }
    if has(&|n| n == "flat-folded") {
        parts.push("FF\u{a0}flat-folded");
    }
    if has(&|n| n == "self-packed") {
        parts.push("SP\u{a0}self-packed");
    }
    if has(&|n| n.starts_with("edge-")) {
        parts.push("Ek\u{a0}edge\u{a0}pop-out\u{a0}k");
    }
    if has(&|n| n.starts_with("vertex-")) {
        parts.push("Vk\u{a0}vertex\u{a0}pop-out\u{a0}k");
    }
    format!("tip state: {}", parts.join(", "))
}

/// "m = 10, n = 3, β = 31.72°", the β list given per module when they differ, shortened to a
/// range when the list would take more than two lines of `width`.
fn boom_line(algorithm: &str, designs: &[ModuleDesign], width: f64) -> Vec<String> {
    let m = designs.len();
    let n = designs[0].n();
    let first = designs[0].beta_deg();
    let head = format!("{algorithm} fit: m = {m} modules, n = {n},");
    if designs.iter().all(|d| d.beta_deg() == first) {
        return wrap(&format!("{head} β = {first}°"), SIZE_TITLE, width);
    }
    let list: Vec<String> = designs
        .iter()
        .map(|d| format!("{}°", d.beta_deg()))
        .collect();
    let lines = wrap(
        &format!("{head} β = {} (bottom\u{a0}first)", list.join(", ")),
        SIZE_TITLE,
        width,
    );
    if lines.len() <= 2 {
        return lines;
    }
    let lo = designs
        .iter()
        .map(|d| d.beta_deg())
        .fold(f64::INFINITY, f64::min);
    let hi = designs
        .iter()
        .map(|d| d.beta_deg())
        .fold(f64::NEG_INFINITY, f64::max);
    wrap(
        &format!("{head} β from {lo}° to {hi}° per module (see --json)"),
        SIZE_TITLE,
        width,
    )
}

/// (horizontal axis, vertical axis, view name).
const TOP_VIEW: (usize, usize, &str) = (0, 1, "top view (x–y)");
const FRONT_VIEW: (usize, usize, &str) = (0, 2, "front view (x–z)");
const SIDE_VIEW: (usize, usize, &str) = (1, 2, "side view (y–z)");
const AXIS: [&str; 3] = ["x (l)", "y (l)", "z (l)"];

/// Height of a view's name above it (its baseline 2 pt plus its descent above the frame),
/// with 1 pt to spare.
fn view_title_h() -> f64 {
    (ASCENT + DESCENT) * SIZE_LABEL + 3.0
}

/// Space between two tick labels, in pt, at least.
const TICK_SPACING: f64 = 20.0;
/// Margin kept clear around the canvas.
const MARGIN: f64 = 3.0;

/// Renders the figure.
pub fn render(
    problem: &Problem,
    designs: &[ModuleDesign],
    s: &Solution,
    header: &Header,
) -> Figure {
    render_views(problem, designs, s, header).0
}

/// Renders the figure; also returns the top, front and side views' plot areas.
fn render_views(
    problem: &Problem,
    designs: &[ModuleDesign],
    s: &Solution,
    header: &Header,
) -> (Figure, [Area; 3]) {
    let b = boom(problem, designs, s);
    let target = problem.objective.target().points();
    let origin = Point3::origin();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in target
        .iter()
        .chain(b.rings.iter().flatten())
        .chain(s.tips.iter())
        .chain(std::iter::once(&origin))
    {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    // Pad every axis so that marks clear the frame, and give a flat axis some depth.
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(1e-6, f64::max);
    let mut range = [(0.0, 0.0); 3];
    for k in 0..3 {
        let min = 0.25 * extent;
        let span = (hi[k] - lo[k]).max(min);
        let mid = 0.5 * (lo[k] + hi[k]);
        let pad = 0.06 * extent;
        range[k] = (mid - span / 2.0 - pad, mid + span / 2.0 + pad);
    }
    let len = |k: usize| range[k].1 - range[k].0;

    let width = COLUMN_PT;
    let inner = width - 2.0 * MARGIN;
    let mut title = boom_line(&header.algorithm, designs, inner);
    let status = if header.status.is_empty() {
        String::new()
    } else {
        format!(" ({})", header.status)
    };
    let status = status.replace("proven optimal", "proven\u{a0}optimal");
    title.extend(wrap(
        &format!(
            "target\u{a0}{}; {}\u{a0}RMS\u{a0}=\u{a0}{:.4}\u{a0}l{status}",
            header.target, header.metric, header.rms
        ),
        SIZE_TITLE,
        inner,
    ));
    for w in &header.warnings {
        title.extend(wrap(&format!("warning: {w}"), SIZE_TITLE, inner));
    }
    let title_h = title.len() as f64 * LEADING * SIZE_TITLE + 2.0;

    let mut legend = Legend::new();
    legend.add(Swatch::Line(target_stroke()), "target curve");
    legend.add(Swatch::Line(ring_stroke()), "module rings");
    legend.add(Swatch::Line(edge_stroke(false)), "module side edges");
    let infeasible: Vec<(usize, &str, f64)> = problem
        .catalogue
        .infeasible(&s.states)
        .map(|(i, c)| (i, c.name.as_str(), c.strain))
        .collect();
    if !infeasible.is_empty() {
        let (a, z) = infeasible
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, z), (_, _, st)| {
                (a.min(*st), z.max(*st))
            });
        let strain = if (z - a).abs() < 5e-4 {
            format!("{a:.3}")
        } else {
            format!("{a:.3}–{z:.3}")
        };
        legend.add(
            Swatch::Line(edge_stroke(true)),
            format!(
                "infeasible state ({} of {} modules, strain {strain})",
                infeasible.len(),
                s.states.len()
            ),
        );
    }
    legend.add(Swatch::Dot(colour::VERMILLION), "tip (top centroid)");
    legend.add(Swatch::Ring(colour::GREEN), "origin (base centre)");
    let key = abbreviation_key(&s.names);

    // Scale: the widest that fits the column, then the height cap. The tick labels' widths
    // depend on the step, which depends on the scale: iterate until the margins settle.
    let max_height = 1.5 * width;
    let below = Area::below();
    let mut left = [Area::left_of(&["−0.0".into()]); 2];
    let mut scale = 1.0;
    let mut step = 1.0;
    for _ in 0..4 {
        let sw = (inner - left[0] - left[1]) / (len(0) + len(1));
        let fixed = title_h + 2.0 * (view_title_h() + below) + 2.0 * MARGIN;
        let legend_h = legend.height(inner) + LEADING * SIZE_LABEL * 3.0;
        let sh = (max_height - fixed - legend_h) / (len(1) + len(2));
        scale = sw.min(sh).max(1e-6);
        step = Ticks::step_at_least(TICK_SPACING / scale);
        let labels = |k: usize| Ticks::within(range[k].0, range[k].1, step).labels();
        let l0 = Area::left_of(&[labels(1), labels(2)].concat());
        let l1 = Area::left_of(&labels(2));
        if (l0 - left[0]).abs() < 1e-9 && (l1 - left[1]).abs() < 1e-9 {
            break;
        }
        left = [l0, l1];
    }
    let ticks = |k: usize| Ticks::within(range[k].0, range[k].1, step);

    let x0 = MARGIN + left[0];
    let col1 = x0 + scale * len(0) + left[1];
    let top_y = MARGIN + title_h + view_title_h();
    // A view of axes (h, v) with its frame's top-left corner at (x, y).
    let view = |x: f64, y: f64, h: usize, v: usize| Area {
        rect: Rect {
            x,
            y,
            w: scale * len(h),
            h: scale * len(v),
        },
        u: range[h],
        v: range[v],
    };
    let top_area = view(x0, top_y, 0, 1);
    let front_y = top_y + scale * len(1) + below + view_title_h();
    let front_area = view(x0, front_y, 0, 2);
    let side_area = view(col1, front_y, 1, 2);
    let views_bottom = front_y + scale * len(2) + below;

    // The legend goes into the empty quadrant right of the top view if it fits there.
    let quadrant = Rect {
        x: col1 - left[1] + 6.0,
        y: MARGIN + title_h,
        w: width - MARGIN - (col1 - left[1] + 6.0),
        h: front_y - view_title_h() - (MARGIN + title_h),
    };
    let in_quadrant = legend.height(quadrant.w) <= quadrant.h
        && legend
            .labels()
            .all(|l| text_width(l, SIZE_LABEL) + 15.0 <= quadrant.w);
    let legend_h = if in_quadrant {
        0.0
    } else {
        legend.height(inner) + 2.0
    };

    // Tip labels in the view where most of them fit, crossing the fewest lines (front, then
    // side, then top on a tie).
    let views = [front_area, side_area, top_area];
    let axes = [(0, 2), (1, 2), (0, 1)];
    let placements: Vec<(Vec<Option<Spot>>, usize)> = views
        .iter()
        .zip(axes)
        .map(|(area, hv)| place_labels(area, hv, s, &segments(area, hv, target, &b)))
        .collect();
    let best = (0..3)
        .min_by_key(|&i| {
            let (spots, crossed) = &placements[i];
            (spots.iter().filter(|p| p.is_none()).count(), *crossed, i)
        })
        .unwrap_or(0);
    let (tip_labels, _) = &placements[best];
    let omitted = tip_labels.iter().filter(|p| p.is_none()).count();
    let key = if omitted > 0 {
        format!(
            "{key} ({omitted} crowded label{} left out; the table lists every state)",
            if omitted == 1 { "" } else { "s" }
        )
    } else {
        key
    };
    let mut key_lines = wrap(&key, SIZE_LABEL, inner - KEY_INDENT);
    key_lines.extend(wrap(
        "lengths in l (the valley-fold length), one scale in all views",
        SIZE_LABEL,
        inner - KEY_INDENT,
    ));
    let key_h = key_lines.len() as f64 * LEADING * SIZE_LABEL;
    let height = views_bottom + legend_h + key_h + MARGIN;
    let mut fig = Figure::new(width, height);

    paragraph(&mut fig, MARGIN, MARGIN, SIZE_TITLE, colour::BLACK, &title);
    for (area, (h, v, name)) in [
        (top_area, TOP_VIEW),
        (front_area, FRONT_VIEW),
        (side_area, SIDE_VIEW),
    ] {
        fig.text(
            area.rect.x,
            area.rect.y - 2.0 - DESCENT * SIZE_LABEL,
            SIZE_LABEL,
            Anchor::Start,
            colour::BLACK,
            name,
        );
        area.axes(
            &mut fig,
            &ticks(h),
            &ticks(v),
            Some(AXIS[h]),
            Some(AXIS[v]),
            false,
        );
        draw_view(&mut fig, &area, (h, v), target, &b, s);
    }
    let feasible = |i: usize| problem.catalogue.candidates(i)[s.states[i]].feasible;
    fig.begin("tip-labels");
    let tip_area = views[best];
    let (th, tv) = axes[best];
    for (i, p) in tip_labels.iter().enumerate() {
        if let Some((x, y, anchor)) = p {
            let tip = tip_area.map(s.tips[i][th], s.tips[i][tv]);
            let r = text_box(*x, *y, SIZE_TICK, *anchor, &abbreviation(&s.names[i]));
            // The nearest point of the label's box; a leader when it is not right beside it.
            let near = (tip.0.clamp(r.x, r.x + r.w), tip.1.clamp(r.y, r.y + r.h));
            if (near.0 - tip.0).hypot(near.1 - tip.1) > 3.5 {
                let d = (near.0 - tip.0).hypot(near.1 - tip.1);
                let from = (
                    tip.0 + (near.0 - tip.0) * 1.5 / d,
                    tip.1 + (near.1 - tip.1) * 1.5 / d,
                );
                fig.line(from, near, Stroke::solid(colour::VERMILLION, 0.4));
            }
            let c = if feasible(i) {
                colour::GREY
            } else {
                colour::PURPLE
            };
            fig.label(*x, *y, SIZE_TICK, *anchor, c, &abbreviation(&s.names[i]));
        }
    }
    fig.end();

    let mut y = views_bottom;
    if in_quadrant {
        legend.draw(&mut fig, quadrant.x, quadrant.y + 2.0, quadrant.w);
    } else {
        legend.draw(&mut fig, MARGIN, y, inner);
        y += legend_h;
    }
    // The key reads like a legend entry: a sample label, then what the labels mean.
    fig.text(
        MARGIN + 6.0,
        y + ASCENT * SIZE_LABEL + 0.5 * (LEADING - ASCENT - DESCENT) * SIZE_LABEL,
        SIZE_TICK,
        Anchor::Middle,
        colour::GREY,
        "E0",
    );
    paragraph(
        &mut fig,
        MARGIN + KEY_INDENT,
        y,
        SIZE_LABEL,
        colour::BLACK,
        &key_lines,
    );
    (fig, [top_area, front_area, side_area])
}

/// Indent of the tip-label key (past its sample label).
const KEY_INDENT: f64 = 15.0;

fn target_stroke() -> Stroke {
    Stroke::solid(colour::BLUE, 1.0)
}

fn ring_stroke() -> Stroke {
    Stroke::solid(colour::BLACK, 0.5)
}

fn edge_stroke(infeasible: bool) -> Stroke {
    if infeasible {
        Stroke::solid(colour::PURPLE, 0.9)
    } else {
        Stroke::solid(colour::GREY, 0.35)
    }
}

fn draw_view(
    fig: &mut Figure,
    area: &Area,
    (h, v): (usize, usize),
    target: &[Point3<f64>],
    b: &Boom,
    s: &Solution,
) {
    let map = |p: &Point3<f64>| area.map(p[h], p[v]);
    let proj = |ps: &[Point3<f64>]| -> Vec<(f64, f64)> { ps.iter().map(map).collect() };
    fig.begin("target");
    fig.polyline(&proj(target), target_stroke());
    fig.end();
    fig.begin("side-edges");
    for (e, _) in b.edges.iter().filter(|(_, inf)| !inf) {
        fig.polyline(&proj(e), edge_stroke(false));
    }
    fig.end();
    if b.edges.iter().any(|(_, inf)| *inf) {
        fig.begin("infeasible");
        for (e, _) in b.edges.iter().filter(|(_, inf)| *inf) {
            fig.polyline(&proj(e), edge_stroke(true));
        }
        fig.end();
    }
    fig.begin("rings");
    for r in &b.rings {
        fig.polygon(&proj(r), ring_stroke());
    }
    fig.end();
    fig.begin("tips");
    for p in &s.tips {
        fig.dot(map(p), 1.3, colour::VERMILLION);
    }
    fig.end();
    fig.begin("origin");
    fig.ring(
        map(&Point3::origin()),
        2.2,
        Stroke::solid(colour::GREEN, 0.8),
    );
    fig.end();
}

/// A line segment on the canvas, in pt.
type Segment = ((f64, f64), (f64, f64));
/// Where a tip's label goes: its baseline point and anchor.
type Spot = (f64, f64, Anchor);

/// Whether the segment a–b meets the rectangle (Liang–Barsky clipping).
fn segment_meets(a: (f64, f64), b: (f64, f64), r: &Rect) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - r.x),
        (dx, r.x + r.w - a.0),
        (-dy, a.1 - r.y),
        (dy, r.y + r.h - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

/// The line segments drawn in a view (target, side edges, rings), in canvas pt.
fn segments(area: &Area, (h, v): (usize, usize), target: &[Point3<f64>], b: &Boom) -> Vec<Segment> {
    let map = |p: &Point3<f64>| area.map(p[h], p[v]);
    let mut out: Vec<Segment> = target
        .windows(2)
        .map(|w| (map(&w[0]), map(&w[1])))
        .collect();
    out.extend(b.edges.iter().map(|(e, _)| (map(&e[0]), map(&e[1]))));
    for r in &b.rings {
        for k in 0..r.len() {
            out.push((map(&r[k]), map(&r[(k + 1) % r.len()])));
        }
    }
    out
}

/// Where each tip's label goes in a view (baseline point and anchor), or `None` where no
/// spot near the tip is free: inside the frame, clear of the other labels, the tips and the
/// origin; among the free spots the one crossing the fewest drawn lines. Also returns the
/// lines crossed in all.
fn place_labels(
    area: &Area,
    (h, v): (usize, usize),
    s: &Solution,
    lines: &[Segment],
) -> (Vec<Option<Spot>>, usize) {
    let tips: Vec<(f64, f64)> = s.tips.iter().map(|p| area.map(p[h], p[v])).collect();
    let origin = area.map(0.0, 0.0);
    let dots: Vec<Rect> = tips
        .iter()
        .map(|(x, y)| (x, y, 1.5))
        .chain(std::iter::once((&origin.0, &origin.1, 2.8)))
        .map(|(x, y, r)| Rect {
            x: x - r,
            y: y - r,
            w: 2.0 * r,
            h: 2.0 * r,
        })
        .collect();
    let frame = Rect {
        x: area.rect.x + 0.5,
        y: area.rect.y + 0.5,
        w: area.rect.w - 1.0,
        h: area.rect.h - 1.0,
    };
    let mut placed: Vec<Rect> = Vec::new();
    let mut out = Vec::new();
    let mut crossed = 0;
    let half_cap = 0.5 * CAP * SIZE_TICK;
    for (i, (x, y)) in tips.iter().enumerate() {
        let text = abbreviation(&s.names[i]);
        let mut best: Option<(Spot, usize)> = None;
        for d in [2.5, 5.0, 9.0] {
            let candidates = [
                (x + d, y + half_cap, Anchor::Start),
                (x - d, y + half_cap, Anchor::End),
                (*x, y - d - DESCENT * SIZE_TICK, Anchor::Middle),
                (*x, y + d + ASCENT * SIZE_TICK, Anchor::Middle),
                (x + d, y - d, Anchor::Start),
                (x - d, y - d, Anchor::End),
                (x + d, y + d + CAP * SIZE_TICK, Anchor::Start),
                (x - d, y + d + CAP * SIZE_TICK, Anchor::End),
            ];
            for (cx, cy, a) in candidates {
                let r = text_box(cx, cy, SIZE_TICK, a, &text);
                if !frame.contains(&r)
                    || placed.iter().any(|p| p.overlaps(&r))
                    || dots.iter().any(|dd| dd.overlaps(&r))
                {
                    continue;
                }
                // A farther spot costs as much as a crossing per step out (it gets a leader).
                let n = lines
                    .iter()
                    .filter(|(p, q)| segment_meets(*p, *q, &r))
                    .count()
                    + if d > 3.0 { 1 } else { 0 }
                    + if d > 6.0 { 1 } else { 0 };
                if best.as_ref().is_none_or(|(_, m)| n < *m) {
                    best = Some(((cx, cy, a), n));
                }
            }
        }
        if let Some(((cx, cy, a), n)) = best {
            placed.push(text_box(cx, cy, SIZE_TICK, a, &text));
            crossed += n;
        }
        out.push(best.map(|(spot, _)| spot));
    }
    (out, crossed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn abbreviations_name_every_state_kind() {
        assert_eq!(abbreviation("deployed"), "D");
        assert_eq!(abbreviation("edge-2"), "E2");
        assert_eq!(abbreviation("vertex-10"), "V10");
        assert_eq!(abbreviation("self-packed"), "SP");
        let key = abbreviation_key(&["edge-0".into(), "folded".into()]);
        assert_eq!(
            key.replace('\u{a0}', " "),
            "tip state: F folded, Ek edge pop-out k"
        );
    }

    /// Equal aspect and third-angle alignment: one scale (pt per l) on all six axes; the top
    /// view over the front view on the same x range, the side view beside it on the same z.
    #[test]
    fn the_three_views_share_one_scale_and_align() {
        use planner::ik::{Algorithm, Catalogue, Control, Metric};
        let designs: Vec<ModuleDesign> = (0..6)
            .map(|_| ModuleDesign::new(3, 31.72).unwrap())
            .collect();
        let catalogue = Catalogue::from_designs(&designs, true).unwrap();
        let target = planner::ik::target::generate("helix:radius=1,pitch=2,turns=1").unwrap();
        let problem = Problem::new(catalogue, target, Metric::Eq36);
        let s = planner::ik::solve(&problem, Algorithm::Greedy, &Control::new()).unwrap();
        let header = Header {
            algorithm: "greedy".into(),
            target: "helix".into(),
            metric: "eq36".into(),
            rms: s.rms,
            status: String::new(),
            warnings: Vec::new(),
        };
        let (fig, [top, front, side]) = render_views(&problem, &designs, &s, &header);
        let scale = |a: &Area| (a.rect.w / (a.u.1 - a.u.0), a.rect.h / (a.v.1 - a.v.0));
        let k = scale(&front).0;
        for a in [&top, &front, &side] {
            let (su, sv) = scale(a);
            assert!(
                (su - k).abs() < 1e-9 && (sv - k).abs() < 1e-9,
                "{su} {sv} vs {k}"
            );
        }
        assert_eq!(top.u, front.u);
        assert_eq!((top.rect.x, top.rect.w), (front.rect.x, front.rect.w));
        assert_eq!(side.v, front.v);
        assert_eq!((side.rect.y, side.rect.h), (front.rect.y, front.rect.h));
        assert_eq!(top.v, side.u);
        // One column wide, every view inside the canvas.
        assert!((fig.width() - 8.5 / 2.54 * 72.0).abs() < 1e-9);
        for a in [&top, &front, &side] {
            assert!(a.rect.x > 0.0 && a.rect.x + a.rect.w < fig.width());
            assert!(a.rect.y > 0.0 && a.rect.y + a.rect.h < fig.height());
        }
        // Every text box the layout knows is inside the canvas.
        let canvas = Rect {
            x: 0.0,
            y: 0.0,
            w: fig.width(),
            h: fig.height(),
        };
        for (b, t) in fig.text_boxes() {
            assert!(canvas.contains(b), "{t}: {b:?}");
        }
    }

    #[test]
    fn a_long_beta_list_becomes_a_range() {
        let designs: Vec<ModuleDesign> = (0..40)
            .map(|i| ModuleDesign::new(3, if i % 2 == 0 { 35.0 } else { 31.72 }).unwrap())
            .collect();
        let lines = boom_line("exact", &designs, 200.0);
        assert!(lines.len() <= 2, "{lines:?}");
        assert!(
            lines.join(" ").contains("β from 31.72° to 35°"),
            "{lines:?}"
        );
        let two = &designs[..2];
        let lines = boom_line("exact", two, 235.0);
        assert!(
            lines
                .join(" ")
                .replace('\u{a0}', " ")
                .contains("β = 35°, 31.72° (bottom first)"),
            "{lines:?}"
        );
    }
}
