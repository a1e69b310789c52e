//! SVG crease pattern, 1:1 in millimetres, for laser cutters, cutting plotters and Origami
//! Simulator.
//!
//! Stroke colours are Origami Simulator's import colours: mountain red `#ff0000`, valley blue
//! `#0000ff`, boundary black `#000000`, cut green `#00ff00`, and the virtual creases magenta
//! `#ff00ff` (Origami Simulator's undriven hinge: it may bend, nothing drives it). The scale
//! bar and the legend are grey `#808080` and text, below the sheet, outside every cut line;
//! Origami Simulator ignores other colours and text.

use std::fmt::Write as _;

use crate::pattern::{LineKind, Pattern};

/// Stroke colour of a line kind.
pub fn colour(kind: LineKind) -> &'static str {
    match kind {
        LineKind::Mountain => "#ff0000",
        LineKind::Valley => "#0000ff",
        LineKind::Boundary => "#000000",
        LineKind::Cut => "#00ff00",
        LineKind::Virtual => "#ff00ff",
    }
}

/// What the legend says a kind is for.
pub fn describe(kind: LineKind) -> &'static str {
    match kind {
        LineKind::Mountain => "mountain fold (score; folds out of the trunk)",
        LineKind::Valley => "valley fold (score; folds into the trunk)",
        LineKind::Boundary => "boundary (cut)",
        LineKind::Cut => "cut (seam allowance outline)",
        LineKind::Virtual => "virtual crease (do not cut or score; facets bend here)",
    }
}

const MARGIN_MM: f64 = 10.0;
const ANNOTATION: &str = "#808080";

/// A scale bar length that is a round number of millimetres, about a quarter of `width_mm`.
fn scale_bar_mm(width_mm: f64) -> f64 {
    let target = (width_mm / 4.0).max(1.0);
    let p = 10f64.powf(target.log10().floor());
    [5.0, 2.0, 1.0]
        .iter()
        .map(|k| k * p)
        .find(|&v| v <= target)
        .unwrap_or(p)
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

const FONT_MM: f64 = 3.5;

/// The page of [`render`], mm: the sheet, its margins and the legend below it.
pub fn page_mm(pattern: &Pattern) -> [f64; 2] {
    let l = pattern.trunk().edge_mm();
    let sheet_w = (pattern.width() + pattern.seam()) * l;
    let sheet_h = pattern.height() * l;
    let legend_lines = LineKind::ALL.len() + 3;
    let legend_h = 12.0 + legend_lines as f64 * FONT_MM * 1.6;
    [
        (sheet_w + 2.0 * MARGIN_MM).max(150.0),
        sheet_h + 2.0 * MARGIN_MM + legend_h,
    ]
}

/// Where [`render`] draws a pattern point (units of l, y up): SVG user units (mm, y down).
pub fn to_page(pattern: &Pattern, p: [f64; 2]) -> [f64; 2] {
    let l = pattern.trunk().edge_mm();
    let sheet_h = pattern.height() * l;
    [MARGIN_MM + p[0] * l, MARGIN_MM + sheet_h - p[1] * l]
}

/// Renders the pattern. `title` goes into the legend (e.g. the command line).
pub fn render(pattern: &Pattern, title: &str) -> String {
    let l = pattern.trunk().edge_mm();
    let sheet_w = (pattern.width() + pattern.seam()) * l;
    let sheet_h = pattern.height() * l;
    let font = FONT_MM;
    let [page_w, page_h] = page_mm(pattern);
    let x0 = MARGIN_MM;
    let y0 = MARGIN_MM + sheet_h; // pattern y = 0 here; pattern y grows upwards
    let tx = |p: [f64; 2]| (x0 + p[0] * l, y0 - p[1] * l);
    let stroke = 0.25;
    let mut s = String::new();
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{page_w:.3}mm" height="{page_h:.3}mm" viewBox="0 0 {page_w:.3} {page_h:.3}">"#
    );
    let _ = writeln!(s, "<title>{}</title>", esc(title));
    let lines = pattern.lines();
    for kind in LineKind::ALL {
        let mut any = false;
        let mut g = String::new();
        for (a, b, k) in &lines {
            if *k != kind {
                continue;
            }
            any = true;
            let (ax, ay) = tx(*a);
            let (bx, by) = tx(*b);
            let _ = writeln!(
                g,
                r#"<line x1="{ax:.4}" y1="{ay:.4}" x2="{bx:.4}" y2="{by:.4}"/>"#
            );
        }
        if any {
            let dash = if kind == LineKind::Virtual {
                r#" stroke-dasharray="1.5,1.5""#
            } else {
                ""
            };
            let _ = writeln!(
                s,
                r#"<g id="{}" fill="none" stroke="{}" stroke-width="{stroke}"{dash}>"#,
                kind.layer_name().to_ascii_lowercase(),
                colour(kind)
            );
            s += &g;
            s += "</g>\n";
        }
    }
    // Scale bar and legend, below the sheet.
    let bar = scale_bar_mm(sheet_w);
    let by = y0 + 8.0;
    let _ = writeln!(
        s,
        r#"<g id="annotation" fill="none" stroke="{ANNOTATION}" stroke-width="0.5">"#
    );
    let _ = writeln!(
        s,
        r#"<path d="M {x0:.3} {:.3} V {by:.3} H {:.3} V {:.3}"/>"#,
        by - 2.0,
        x0 + bar,
        by - 2.0
    );
    s += "</g>\n";
    let _ = writeln!(
        s,
        r#"<g id="legend" font-family="sans-serif" font-size="{font}" fill="{ANNOTATION}">"#
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.3}" y="{:.3}">{} mm</text>"#,
        x0 + bar + 2.0,
        by,
        bar
    );
    let mut ty = by + font * 1.8;
    let _ = writeln!(
        s,
        r#"<text x="{x0:.3}" y="{ty:.3}">{}</text>"#,
        esc(&pattern.trunk().describe())
    );
    ty += font * 1.6;
    let _ = writeln!(
        s,
        r#"<text x="{x0:.3}" y="{ty:.3}">1:1, millimetres; sheet {sheet_w:.1} × {sheet_h:.1} mm; seam allowance {:.1} mm (glue under the left edge)</text>"#,
        pattern.seam() * l
    );
    ty += font * 1.6;
    for kind in LineKind::ALL {
        let _ = writeln!(
            s,
            r#"<text x="{x0:.3}" y="{ty:.3}"><tspan fill="{}" font-weight="bold">━━</tspan> {}</text>"#,
            colour(kind),
            describe(kind)
        );
        ty += font * 1.6;
    }
    let _ = writeln!(s, r#"<text x="{x0:.3}" y="{ty:.3}">{}</text>"#, esc(title));
    s += "</g>\n</svg>\n";
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_bar_is_round_and_at_most_a_quarter() {
        assert_eq!(scale_bar_mm(230.0), 50.0);
        assert_eq!(scale_bar_mm(1830.0), 200.0);
        assert_eq!(scale_bar_mm(40.0), 10.0);
        assert_eq!(scale_bar_mm(2.0), 1.0);
    }
}
