//! SVG crease pattern, 1:1 in millimetres, for laser cutters, cutting plotters and Origami
//! Simulator.
//!
//! Stroke colours are Origami Simulator's import colours: mountain red `#ff0000`, valley blue
//! `#0000ff`, boundary black `#000000`, cut green `#00ff00`, and the virtual creases magenta
//! `#ff00ff` (Origami Simulator's undriven hinge: it may bend, nothing drives it). The scale
//! bar and the legend are grey `#808080` and text, below or right of the sheet ([`Legend`]),
//! outside every cut line, or left out; Origami Simulator ignores other colours and text.

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

/// Legend text size, mm.
pub const FONT_MM: f64 = 3.5;
/// Baseline to baseline, mm.
const LINE_MM: f64 = FONT_MM * 1.6;
/// Advance of one character, mm: 0.62 em, a deliberately wide estimate of a sans-serif font's
/// mean advance for mixed text, so the estimated width of a line bounds the drawn one
/// (`tools/fabrication/check_outputs.py legend` checks it on rsvg-convert's rendering).
pub const CHAR_MM: f64 = 0.62 * FONT_MM;
/// Clear space between the sheet and a legend below it, mm.
pub const GAP_BELOW_MM: f64 = 4.0;
/// Clear space between the sheet and a legend right of it, mm.
pub const GAP_RIGHT_MM: f64 = 8.0;
/// Width a legend right of the sheet is wrapped to, mm.
pub const RIGHT_COLUMN_MM: f64 = 100.0;
/// Least width a legend below the sheet is wrapped to, mm.
pub const BELOW_MIN_MM: f64 = 180.0;

/// Where the legend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Legend {
    /// Below the sheet (the default).
    Below,
    /// Right of the sheet.
    Right,
    /// No legend and no scale bar: the crease lines only.
    None,
}

impl Legend {
    /// Parses `below`, `right` or `none` (any case).
    pub fn parse(text: &str) -> Result<Self, crate::FabError> {
        match text.trim().to_ascii_lowercase().as_str() {
            "below" => Ok(Legend::Below),
            "right" => Ok(Legend::Right),
            "none" => Ok(Legend::None),
            _ => Err(crate::FabError::new(format!(
                "the legend goes below, right or none, got '{text}'"
            ))),
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Legend::Below => "below",
            Legend::Right => "right",
            Legend::None => "none",
        }
    }
}

/// The legend laid out: the scale bar, then lines of text wrapped to a width; its size from
/// [`CHAR_MM`] per character, so the drawn text stays inside it.
#[derive(Debug, Clone, PartialEq)]
pub struct LegendBlock {
    bar_mm: f64,
    /// Text lines, each with the line kind whose swatch starts it.
    lines: Vec<(Option<LineKind>, String)>,
    /// Width and height, mm.
    pub size_mm: [f64; 2],
}

/// Splits `text` at spaces into lines of at most `chars` characters (a longer word stands alone).
fn wrap(text: &str, chars: usize) -> Vec<String> {
    let mut out = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        let len = line.chars().count();
        if len > 0 && len + 1 + word.chars().count() > chars {
            out.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line += word;
    }
    if !line.is_empty() {
        out.push(line);
    }
    out
}

const SWATCH: &str = "━━ ";

fn text_mm(s: &str) -> f64 {
    s.chars().count() as f64 * CHAR_MM
}

impl LegendBlock {
    /// The legend of `pattern` (its trunk, scale, line kinds and `title`), wrapped to
    /// `width_mm` (at least 40 mm).
    pub fn new(pattern: &Pattern, title: &str, width_mm: f64) -> Self {
        let l = pattern.trunk().edge_mm();
        let sheet_w = (pattern.width() + pattern.seam()) * l;
        let sheet_h = pattern.height() * l;
        let chars = ((width_mm.max(40.0) / CHAR_MM).floor() as usize).max(1);
        let mut lines: Vec<(Option<LineKind>, String)> = Vec::new();
        let text = |t: &str, lines: &mut Vec<(Option<LineKind>, String)>| {
            lines.extend(wrap(t, chars).into_iter().map(|t| (None, t)))
        };
        text(&pattern.trunk().describe(), &mut lines);
        text(
            &format!(
                "1:1, millimetres; sheet {sheet_w:.1} × {sheet_h:.1} mm; seam allowance {:.1} mm (glue under the left edge)",
                pattern.seam() * l
            ),
            &mut lines,
        );
        let kind_chars = chars.saturating_sub(SWATCH.chars().count()).max(1);
        for kind in LineKind::ALL {
            for (i, t) in wrap(describe(kind), kind_chars).into_iter().enumerate() {
                if i == 0 {
                    lines.push((Some(kind), format!("{SWATCH}{t}")));
                } else {
                    lines.push((None, format!("   {t}")));
                }
            }
        }
        text(title, &mut lines);
        // A round bar of about a quarter of the sheet, its label beside it within the width.
        let width = width_mm.max(40.0);
        let label = text_mm("1000 mm") + 2.0;
        let bar_mm = scale_bar_mm(sheet_w.min(4.0 * (width - label)));
        let bar_line = bar_mm + 2.0 + text_mm(&format!("{bar_mm} mm"));
        let widest = lines
            .iter()
            .map(|(_, t)| text_mm(t))
            .fold(bar_line, f64::max);
        // Down to the last line's descenders (0.3 em below its baseline).
        let height = Self::first_baseline() + (lines.len() as f64 - 1.0) * LINE_MM + 0.3 * FONT_MM;
        LegendBlock {
            bar_mm,
            lines,
            size_mm: [widest, height],
        }
    }

    /// The baseline of the first text line below the block's top (the scale bar's line is
    /// above it), mm.
    fn first_baseline() -> f64 {
        4.0 + FONT_MM * 1.8
    }

    /// The legend's SVG (a `<g id="annotation">` scale bar and a `<g id="legend">` of text)
    /// with its top-left corner at (x, y), in user units (mm).
    pub fn svg(&self, x: f64, y: f64) -> String {
        let font = FONT_MM;
        let bar = self.bar_mm;
        let by = y + 4.0;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<g id="annotation" fill="none" stroke="{ANNOTATION}" stroke-width="0.5">"#
        );
        let _ = writeln!(
            s,
            r#"<path d="M {x:.3} {:.3} V {by:.3} H {:.3} V {:.3}"/>"#,
            by - 2.0,
            x + bar,
            by - 2.0
        );
        s += "</g>\n";
        let _ = writeln!(
            s,
            r#"<g id="legend" font-family="sans-serif" font-size="{font}" fill="{ANNOTATION}" data-box="{x:.3} {y:.3} {:.3} {:.3}">"#,
            self.size_mm[0], self.size_mm[1]
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.3}" y="{by:.3}">{bar} mm</text>"#,
            x + bar + 2.0
        );
        let mut ty = y + Self::first_baseline();
        for (kind, t) in &self.lines {
            match kind {
                Some(k) => {
                    let rest = t.strip_prefix(SWATCH).unwrap_or(t);
                    let _ = writeln!(
                        s,
                        r#"<text x="{x:.3}" y="{ty:.3}"><tspan fill="{}" font-weight="bold">━━</tspan> {}</text>"#,
                        colour(*k),
                        esc(rest)
                    );
                }
                None => {
                    let _ = writeln!(
                        s,
                        r#"<text x="{x:.3}" y="{ty:.3}" xml:space="preserve">{}</text>"#,
                        esc(t)
                    );
                }
            }
            ty += LINE_MM;
        }
        s += "</g>\n";
        s
    }
}

/// The page of [`render`]: its size and the legend's box (x, y, width, height), mm.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Page width and height, mm.
    pub page_mm: [f64; 2],
    /// The sheet (pattern and seam tab) on the page: x, y, width, height, mm.
    pub sheet_box_mm: [f64; 4],
    /// The legend and its box, if there is one.
    pub legend: Option<(LegendBlock, [f64; 4])>,
}

/// Lays out the page of [`render`] with the legend at `legend`.
pub fn layout(pattern: &Pattern, title: &str, legend: Legend) -> Layout {
    let l = pattern.trunk().edge_mm();
    let sheet_w = (pattern.width() + pattern.seam()) * l;
    let sheet_h = pattern.height() * l;
    let sheet_box_mm = [MARGIN_MM, MARGIN_MM, sheet_w, sheet_h];
    match legend {
        Legend::None => Layout {
            page_mm: [sheet_w + 2.0 * MARGIN_MM, sheet_h + 2.0 * MARGIN_MM],
            sheet_box_mm,
            legend: None,
        },
        Legend::Below => {
            let block = LegendBlock::new(pattern, title, sheet_w.max(BELOW_MIN_MM));
            let [w, h] = block.size_mm;
            let at = [MARGIN_MM, MARGIN_MM + sheet_h + GAP_BELOW_MM];
            Layout {
                page_mm: [sheet_w.max(w) + 2.0 * MARGIN_MM, at[1] + h + MARGIN_MM],
                sheet_box_mm,
                legend: Some((block, [at[0], at[1], w, h])),
            }
        }
        Legend::Right => {
            let block = LegendBlock::new(pattern, title, RIGHT_COLUMN_MM);
            let [w, h] = block.size_mm;
            let at = [MARGIN_MM + sheet_w + GAP_RIGHT_MM, MARGIN_MM];
            Layout {
                page_mm: [at[0] + w + MARGIN_MM, sheet_h.max(h) + 2.0 * MARGIN_MM],
                sheet_box_mm,
                legend: Some((block, [at[0], at[1], w, h])),
            }
        }
    }
}

/// Where [`render`] draws a pattern point (units of l, y up): SVG user units (mm, y down).
/// The sheet's place does not depend on the legend's.
pub fn to_page(pattern: &Pattern, p: [f64; 2]) -> [f64; 2] {
    let l = pattern.trunk().edge_mm();
    let sheet_h = pattern.height() * l;
    [MARGIN_MM + p[0] * l, MARGIN_MM + sheet_h - p[1] * l]
}

/// A segment clipper: the part of a–b to draw, if any.
pub(crate) type Clip<'a> = &'a dyn Fn([f64; 2], [f64; 2]) -> Option<([f64; 2], [f64; 2])>;

/// The crease lines, one `<g>` per kind, mapped by `at` (a pattern point in page mm → the
/// SVG's frame) and clipped by `clip`.
pub(crate) fn line_groups(
    pattern: &Pattern,
    at: &dyn Fn([f64; 2]) -> [f64; 2],
    clip: Clip<'_>,
) -> String {
    let mut s = String::new();
    let lines = pattern.lines();
    for kind in LineKind::ALL {
        let mut g = String::new();
        for (a, b, k) in &lines {
            if *k != kind {
                continue;
            }
            if let Some((p, q)) = clip(to_page(pattern, *a), to_page(pattern, *b)) {
                let ([ax, ay], [bx, by]) = (at(p), at(q));
                let _ = writeln!(
                    g,
                    r#"<line x1="{ax:.4}" y1="{ay:.4}" x2="{bx:.4}" y2="{by:.4}"/>"#
                );
            }
        }
        if !g.is_empty() {
            let dash = if kind == LineKind::Virtual {
                r#" stroke-dasharray="1.5,1.5""#
            } else {
                ""
            };
            let _ = writeln!(
                s,
                r#"<g id="{}" fill="none" stroke="{}" stroke-width="0.25"{dash}>"#,
                kind.layer_name().to_ascii_lowercase(),
                colour(kind)
            );
            s += &g;
            s += "</g>\n";
        }
    }
    s
}

/// Renders the pattern with the legend at `legend`. `title` goes into the legend (e.g. the
/// command line) and the SVG's `<title>`.
pub fn render(pattern: &Pattern, title: &str, legend: Legend) -> String {
    let lay = layout(pattern, title, legend);
    let [page_w, page_h] = lay.page_mm;
    let mut s = String::new();
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{page_w:.3}mm" height="{page_h:.3}mm" viewBox="0 0 {page_w:.3} {page_h:.3}">"#
    );
    let _ = writeln!(s, "<title>{}</title>", esc(title));
    s += &line_groups(pattern, &|p| p, &|a, b| Some((a, b)));
    if let Some((block, [x, y, _, _])) = &lay.legend {
        s += &block.svg(*x, *y);
    }
    s += "</svg>\n";
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
