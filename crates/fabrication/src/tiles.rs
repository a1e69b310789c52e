//! The 1:1 crease pattern tiled over paper pages (A4 or Letter), for a maker without a large
//! printer.
//!
//! The sheet (the pattern and its seam tab, in the frame of [`crate::svg::render`]) is cut into
//! windows of the page's printable area (10 mm from every edge, a footer for the page's name and
//! a scale bar), neighbouring windows overlapping by [`OVERLAP_MM`]. In the middle of every
//! overlap strip stand registration marks (a cross in a circle, grey, with an id): each appears
//! on both pages at the same place of the pattern, so laying one page over the other with the
//! marks on top of each other puts the pattern together 1:1. The footer's bar is 50 mm: measure
//! it to check the printer did not scale the page. The page is portrait or landscape, whichever
//! needs fewer pages. The legend of the `--svg` page (unless [`Legend::None`]) is printed once,
//! below or right of the sheet, on a page whose window holds it whole outside the overlaps.

use std::fmt::Write as _;

use crate::pattern::Pattern;
use crate::svg::{
    line_groups, to_page, Legend, LegendBlock, GAP_BELOW_MM, GAP_RIGHT_MM, RIGHT_COLUMN_MM,
};
use crate::trunk::FabError;

/// Unprinted border of every page, mm (most printers cannot print closer to the edge).
pub const PRINT_MARGIN_MM: f64 = 10.0;
/// Overlap of neighbouring windows, mm.
pub const OVERLAP_MM: f64 = 20.0;
/// Height of the footer (page name, scale bar), mm.
pub const FOOTER_MM: f64 = 14.0;
/// The scale bar's length, mm.
pub const SCALE_BAR_MM: f64 = 50.0;

/// A paper size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Paper {
    /// ISO A4, 210 × 297 mm.
    A4,
    /// US Letter, 8.5 × 11 in.
    Letter,
}

impl Paper {
    /// Parses `a4` or `letter` (any case).
    pub fn parse(text: &str) -> Result<Self, FabError> {
        match text.trim().to_ascii_lowercase().as_str() {
            "a4" => Ok(Paper::A4),
            "letter" => Ok(Paper::Letter),
            _ => Err(FabError::new(format!(
                "the paper must be a4 or letter, got '{text}'"
            ))),
        }
    }

    /// Portrait width and height, mm.
    pub fn size_mm(self) -> [f64; 2] {
        match self {
            Paper::A4 => [210.0, 297.0],
            Paper::Letter => [215.9, 279.4],
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Paper::A4 => "A4",
            Paper::Letter => "Letter",
        }
    }
}

/// How the sheet is tiled.
#[derive(Debug, Clone, PartialEq)]
pub struct Tiling {
    /// The paper.
    pub paper: Paper,
    /// Page width and height as laid (portrait or landscape), mm.
    pub page_mm: [f64; 2],
    /// Columns and rows of pages.
    pub grid: [usize; 2],
    /// The window of the pattern each page shows, mm.
    pub window_mm: [f64; 2],
    /// Step from one window to the next (window − overlap), mm.
    pub pitch_mm: [f64; 2],
    /// The tiled region (the sheet, and the legend's box beside it) in the full SVG's frame:
    /// origin and size, mm.
    pub region_mm: [f64; 4],
    /// The sheet in the full SVG's frame: origin and size, mm.
    pub sheet_mm: [f64; 4],
    /// The legend, its box in the full SVG's frame (x, y, width, height, mm) and the index of
    /// the one page that prints it (row by row from the top left).
    pub legend: Option<(LegendBlock, [f64; 4], usize)>,
}

impl Tiling {
    /// Number of pages.
    pub fn pages(&self) -> usize {
        self.grid[0] * self.grid[1]
    }
}

fn count(length: f64, window: f64, pitch: f64) -> usize {
    if length <= window {
        1
    } else {
        1 + ((length - window) / pitch - 1e-9).ceil() as usize
    }
}

/// The part of window `i` of `count` along one axis that no neighbouring window overlaps:
/// (start, end) from the region's origin.
fn exclusive(i: usize, count: usize, window: f64, pitch: f64) -> (f64, f64) {
    let start = i as f64 * pitch;
    let lo = if i > 0 {
        start + OVERLAP_MM + MARK_CLEARANCE_MM
    } else {
        start
    };
    let hi = if i + 1 < count {
        start + window - OVERLAP_MM - MARK_CLEARANCE_MM
    } else {
        start + window
    };
    (lo, hi)
}

/// Clear space kept between the legend and an overlap strip, mm: a registration mark's id is
/// written right of its cross and may reach past the strip (up to 4 mm + 10 characters of
/// 2.5 mm text beyond the mark's centre, 10 mm inside the strip).
pub const MARK_CLEARANCE_MM: f64 = 10.0;

/// The tiling of `pattern` on `paper`, with the legend (of `title`) at `legend`: below or
/// right of the sheet as on the `--svg` page, moved further down (right) if needed so that it
/// lies whole in one page's window, clear of the overlaps (and so of every registration mark
/// and of every other page).
pub fn tiling(pattern: &Pattern, paper: Paper, legend: Legend, title: &str) -> Tiling {
    let l = pattern.trunk().edge_mm();
    let sheet = [(pattern.width() + pattern.seam()) * l, pattern.height() * l];
    // The sheet's top-left corner in the full SVG's frame (pattern x = 0, y = height).
    let origin = to_page(pattern, [0.0, pattern.height()]);
    let [pw, ph] = paper.size_mm();
    let layout = |page: [f64; 2]| {
        let window = [
            page[0] - 2.0 * PRINT_MARGIN_MM,
            page[1] - 2.0 * PRINT_MARGIN_MM - FOOTER_MM,
        ];
        let pitch = [window[0] - OVERLAP_MM, window[1] - OVERLAP_MM];
        // The widest legend that fits between a window's two overlaps.
        let room = window[0] - 2.0 * (OVERLAP_MM + MARK_CLEARANCE_MM) - 1.0;
        let block = match legend {
            Legend::None => None,
            Legend::Below => Some(LegendBlock::new(pattern, title, room)),
            Legend::Right => Some(LegendBlock::new(pattern, title, room.min(RIGHT_COLUMN_MM))),
        };
        // The legend's corner from the region's origin; the axis it may move along.
        let (mut at, axis) = match legend {
            Legend::Right => ([sheet[0] + GAP_RIGHT_MM, 0.0], 0),
            _ => ([0.0, sheet[1] + GAP_BELOW_MM], 1),
        };
        let mut grid = [1, 1];
        let mut page_index = 0;
        for _ in 0..8 {
            let size = block.as_ref().map(|b| b.size_mm).unwrap_or([0.0, 0.0]);
            let extent = if block.is_some() {
                [sheet[0].max(at[0] + size[0]), sheet[1].max(at[1] + size[1])]
            } else {
                sheet
            };
            grid = [
                count(extent[0], window[0], pitch[0]),
                count(extent[1], window[1], pitch[1]),
            ];
            if block.is_none() {
                break;
            }
            // The page whose exclusive part holds the legend, or the next one along the axis.
            let mut cell = [0usize; 2];
            let mut fits = true;
            for k in 0..2 {
                let found = (0..grid[k]).find(|&i| {
                    let (lo, hi) = exclusive(i, grid[k], window[k], pitch[k]);
                    at[k] >= lo - 1e-9 && at[k] + size[k] <= hi + 1e-9
                });
                match found {
                    Some(i) => cell[k] = i,
                    None => {
                        fits = false;
                        if k == axis {
                            // Move to the start of the next window's exclusive part.
                            let next = (0..grid[k] + 1)
                                .map(|i| exclusive(i, grid[k] + 1, window[k], pitch[k]).0)
                                .find(|&lo| lo > at[k] + 1e-9);
                            if let Some(lo) = next {
                                at[k] = lo;
                            }
                        }
                    }
                }
            }
            if fits {
                page_index = cell[1] * grid[0] + cell[0];
                break;
            }
        }
        let size = block.as_ref().map(|b| b.size_mm).unwrap_or([0.0, 0.0]);
        let region = if block.is_some() {
            [sheet[0].max(at[0] + size[0]), sheet[1].max(at[1] + size[1])]
        } else {
            sheet
        };
        Tiling {
            paper,
            page_mm: page,
            grid,
            window_mm: window,
            pitch_mm: pitch,
            region_mm: [origin[0], origin[1], region[0], region[1]],
            sheet_mm: [origin[0], origin[1], sheet[0], sheet[1]],
            legend: block.map(|b| {
                let bx = [origin[0] + at[0], origin[1] + at[1], size[0], size[1]];
                (b, bx, page_index)
            }),
        }
    };
    let portrait = layout([pw, ph]);
    let landscape = layout([ph, pw]);
    if landscape.pages() < portrait.pages() {
        landscape
    } else {
        portrait
    }
}

/// Clips the segment a–b to the rectangle [x0, x1] × [y0, y1] (Liang–Barsky).
fn clip(a: [f64; 2], b: [f64; 2], r: [f64; 4]) -> Option<([f64; 2], [f64; 2])> {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a[0] - r[0]),
        (dx, r[1] - a[0]),
        (-dy, a[1] - r[2]),
        (dy, r[3] - a[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t1 - t0 > 1e-12).then(|| {
        (
            [a[0] + t0 * dx, a[1] + t0 * dy],
            [a[0] + t1 * dx, a[1] + t1 * dy],
        )
    })
}

/// One registration mark: id and centre in the full SVG's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    /// `v{column}-{row}-{k}` on the overlap right of column `column`, `h…` below row `row`.
    pub id: String,
    /// Centre, mm, in the full SVG's frame.
    pub at_mm: [f64; 2],
}

/// Every registration mark of the tiling.
pub fn marks(t: &Tiling) -> Vec<Mark> {
    let [x0, y0, _, _] = t.region_mm;
    let mut out = Vec::new();
    for r in 0..t.grid[1] {
        for c in 0..t.grid[0] {
            let (wx, wy) = (x0 + c as f64 * t.pitch_mm[0], y0 + r as f64 * t.pitch_mm[1]);
            if c + 1 < t.grid[0] {
                let x = x0 + (c + 1) as f64 * t.pitch_mm[0] + 0.5 * OVERLAP_MM;
                for (k, f) in [0.25, 0.75].into_iter().enumerate() {
                    out.push(Mark {
                        id: format!("v{}-{}-{k}", c + 1, r + 1),
                        at_mm: [x, wy + f * t.window_mm[1]],
                    });
                }
            }
            if r + 1 < t.grid[1] {
                let y = y0 + (r + 1) as f64 * t.pitch_mm[1] + 0.5 * OVERLAP_MM;
                for (k, f) in [0.25, 0.75].into_iter().enumerate() {
                    out.push(Mark {
                        id: format!("h{}-{}-{k}", c + 1, r + 1),
                        at_mm: [wx + f * t.window_mm[0], y],
                    });
                }
            }
        }
    }
    out
}

/// The SVG of every page, row by row from the top left.
pub fn pages(pattern: &Pattern, t: &Tiling, title: &str) -> Vec<String> {
    let [x0, y0, _, _] = t.region_mm;
    let [pw, ph] = t.page_mm;
    let all_marks = marks(t);
    let total = t.pages();
    let mut out = Vec::with_capacity(total);
    for r in 0..t.grid[1] {
        for c in 0..t.grid[0] {
            let (wx, wy) = (x0 + c as f64 * t.pitch_mm[0], y0 + r as f64 * t.pitch_mm[1]);
            let window = [wx, wx + t.window_mm[0], wy, wy + t.window_mm[1]];
            // Full frame → page: shift the window's corner onto the printable area's corner.
            let (dx, dy) = (PRINT_MARGIN_MM - wx, PRINT_MARGIN_MM - wy);
            let at = |p: [f64; 2]| (p[0] + dx, p[1] + dy);
            let index = r * t.grid[0] + c + 1;
            let mut s = String::new();
            let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
            let _ = writeln!(
                s,
                r#"<svg xmlns="http://www.w3.org/2000/svg" width="{pw}mm" height="{ph}mm" viewBox="0 0 {pw} {ph}">"#
            );
            let _ = writeln!(
                s,
                "<title>{} — page {index} of {total}</title>",
                title.replace('&', "&amp;").replace('<', "&lt;")
            );
            let _ = writeln!(
                s,
                r##"<rect id="paper" x="0" y="0" width="{pw}" height="{ph}" fill="#ffffff"/>"##
            );
            s += &line_groups(pattern, &|p| [p[0] + dx, p[1] + dy], &|a, b| {
                clip(a, b, window)
            });
            if let Some((block, [lx, ly, _, _], page)) = &t.legend {
                if *page + 1 == index {
                    s += &block.svg(lx + dx, ly + dy);
                }
            }
            // The window's outline, thin grey: where this page's part of the pattern ends.
            let _ = writeln!(
                s,
                r##"<rect id="window" x="{PRINT_MARGIN_MM}" y="{PRINT_MARGIN_MM}" width="{:.4}" height="{:.4}" fill="none" stroke="#c0c0c0" stroke-width="0.2"/>"##,
                t.window_mm[0], t.window_mm[1]
            );
            for m in &all_marks {
                let inside = m.at_mm[0] > window[0]
                    && m.at_mm[0] < window[1]
                    && m.at_mm[1] > window[2]
                    && m.at_mm[1] < window[3];
                if !inside {
                    continue;
                }
                let (x, y) = at(m.at_mm);
                let _ = writeln!(
                    s,
                    r##"<g class="registration" id="reg-{}" fill="none" stroke="#404040" stroke-width="0.2"><line x1="{:.4}" y1="{y:.4}" x2="{:.4}" y2="{y:.4}"/><line x1="{x:.4}" y1="{:.4}" x2="{x:.4}" y2="{:.4}"/><circle cx="{x:.4}" cy="{y:.4}" r="3"/><text x="{:.4}" y="{:.4}" font-family="sans-serif" font-size="2.5" fill="#404040" stroke="none">{}</text></g>"##,
                    m.id,
                    x - 5.0,
                    x + 5.0,
                    y - 5.0,
                    y + 5.0,
                    x + 4.0,
                    y - 4.0,
                    m.id
                );
            }
            let fy = ph - PRINT_MARGIN_MM - FOOTER_MM + 5.0;
            let _ = writeln!(
                s,
                r##"<g id="footer" font-family="sans-serif" font-size="3" fill="#404040"><path d="M {m} {:.3} V {fy:.3} H {:.3} V {:.3}" fill="none" stroke="#404040" stroke-width="0.4"/><text x="{:.3}" y="{fy:.3}">{SCALE_BAR_MM} mm: measure it — print at 100 % (actual size), never "fit to page"</text><text x="{m}" y="{:.3}">page {index} of {total} (column {}, row {}, {} {}): lay the pages with the grey marks on top of each other</text></g>"##,
                fy - 2.0,
                PRINT_MARGIN_MM + SCALE_BAR_MM,
                fy - 2.0,
                PRINT_MARGIN_MM + SCALE_BAR_MM + 2.0,
                fy + 5.0,
                c + 1,
                r + 1,
                t.paper.name(),
                if pw > ph { "landscape" } else { "portrait" },
                m = PRINT_MARGIN_MM,
            );
            s += "</svg>\n";
            out.push(s);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_keeps_the_part_inside() {
        let r = [0.0, 10.0, 0.0, 10.0];
        assert_eq!(
            clip([-5.0, 5.0], [15.0, 5.0], r),
            Some(([0.0, 5.0], [10.0, 5.0]))
        );
        assert_eq!(clip([-5.0, -5.0], [-1.0, 20.0], r), None);
        assert_eq!(
            clip([2.0, 2.0], [3.0, 3.0], r),
            Some(([2.0, 2.0], [3.0, 3.0]))
        );
    }
}
