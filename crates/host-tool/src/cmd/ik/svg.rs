//! The picture a user looks at first: the target curve and the fitted boom, module outlines
//! included, in three orthographic views (front x–z, side y–z, top x–y) at one common scale,
//! with the RMS in the caption.

use std::fmt::Write as _;

use geometry::ModuleDesign;
use planner::ik::{Frame, Point3, Problem, Solution};

const VIEW: f64 = 360.0;
const PAD: f64 = 24.0;
const TOP: f64 = 56.0;

/// (horizontal axis, vertical axis, title); vertical axes grow upward.
const VIEWS: [(usize, usize, &str); 3] = [
    (0, 2, "front (x–z)"),
    (1, 2, "side (y–z)"),
    (0, 1, "top (x–y)"),
];

struct Drawing {
    /// Closed polygons (module boundaries) and open polylines (module side edges).
    polygons: Vec<Vec<Point3<f64>>>,
    /// Side edges, each with whether its module's state is infeasible.
    edges: Vec<([Point3<f64>; 2], bool)>,
}

fn boom_drawing(problem: &Problem, designs: &[ModuleDesign], s: &Solution) -> Drawing {
    let frames = problem.catalogue.frames(&s.states);
    let mut polygons = Vec::new();
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
            polygons.push(b);
        }
        polygons.push(t);
    }
    Drawing { polygons, edges }
}

/// Splits `text` at spaces into lines of at most about `width` characters.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split(' ') {
        let last = lines.last_mut().expect("non-empty");
        if !last.is_empty() && last.chars().count() + 1 + word.chars().count() > width {
            lines.push(word.to_string());
        } else {
            if !last.is_empty() {
                last.push(' ');
            }
            last.push_str(word);
        }
    }
    lines
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Renders the SVG document. A non-empty `infeasible_note` (which infeasible states the boom
/// uses) is printed under the views, and those modules' side edges are drawn in orange.
pub fn render(
    problem: &Problem,
    designs: &[ModuleDesign],
    s: &Solution,
    caption: &str,
    infeasible_note: &str,
) -> String {
    let drawing = boom_drawing(problem, designs, s);
    let target = problem.objective.target().points();
    let origin = Point3::origin();
    let all: Vec<&Point3<f64>> = target
        .iter()
        .chain(drawing.polygons.iter().flatten())
        .chain(std::iter::once(&origin))
        .collect();
    // One scale for all views: the largest extent over the projected axes.
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &all {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(1e-9, f64::max);
    let scale = (VIEW - 2.0 * PAD) / extent;
    let width = 3.0 * VIEW;
    let note_lines = wrap(&format!("orange: {infeasible_note}"), 150);
    let note_lines = if infeasible_note.is_empty() {
        Vec::new()
    } else {
        note_lines
    };
    let height = TOP + VIEW + 40.0 + 18.0 * note_lines.len() as f64;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{PAD}" y="22" font-size="15">{}</text>"#,
        esc(caption)
    );
    let _ = writeln!(
        out,
        r##"<text x="{PAD}" y="42" fill="#555">blue: target curve · black: module outlines · red: tips (top centroids) · units of l, one scale for all views</text>"##
    );
    for (v, (h, u, title)) in VIEWS.iter().enumerate() {
        let ox = v as f64 * VIEW;
        // Centre the view's content.
        let cx = 0.5 * (lo[*h] + hi[*h]);
        let cy = 0.5 * (lo[*u] + hi[*u]);
        let map = |p: &Point3<f64>| -> (f64, f64) {
            (
                ox + VIEW / 2.0 + (p[*h] - cx) * scale,
                TOP + VIEW / 2.0 - (p[*u] - cy) * scale,
            )
        };
        let _ = writeln!(
            out,
            r##"<g><rect x="{:.1}" y="{TOP}" width="{:.1}" height="{VIEW}" fill="none" stroke="#ccc"/><text x="{:.1}" y="{:.1}" fill="#333">{title}</text>"##,
            ox + 4.0,
            VIEW - 8.0,
            ox + 12.0,
            TOP + VIEW + 22.0
        );
        let pts = |ps: &[Point3<f64>]| -> String {
            ps.iter()
                .map(|p| {
                    let (x, y) = map(p);
                    format!("{x:.2},{y:.2}")
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        let _ = writeln!(
            out,
            r##"<polyline points="{}" fill="none" stroke="#1f6fd0" stroke-width="2"/>"##,
            pts(target)
        );
        for (e, infeasible) in &drawing.edges {
            let _ = if *infeasible {
                writeln!(
                    out,
                    r##"<polyline class="infeasible" points="{}" fill="none" stroke="#e07000" stroke-width="1.4"/>"##,
                    pts(e)
                )
            } else {
                writeln!(
                    out,
                    r##"<polyline points="{}" fill="none" stroke="#444" stroke-width="0.8"/>"##,
                    pts(e)
                )
            };
        }
        for poly in &drawing.polygons {
            let _ = writeln!(
                out,
                r##"<polygon points="{}" fill="none" stroke="#000" stroke-width="1"/>"##,
                pts(poly)
            );
        }
        for p in &s.tips {
            let (x, y) = map(p);
            let _ = writeln!(
                out,
                r##"<circle cx="{x:.2}" cy="{y:.2}" r="2.5" fill="#d02020"/>"##
            );
        }
        let (x0, y0) = map(&Point3::origin());
        let _ = writeln!(
            out,
            r##"<circle cx="{x0:.2}" cy="{y0:.2}" r="3" fill="none" stroke="#090"/></g>"##
        );
    }
    for (i, line) in note_lines.iter().enumerate() {
        let _ = writeln!(
            out,
            r##"<text x="{PAD}" y="{:.1}" fill="#e07000">{}</text>"##,
            TOP + VIEW + 50.0 + 18.0 * i as f64,
            esc(line)
        );
    }
    out.push_str("</svg>\n");
    out
}
