//! Paper tiles: the windows cover the sheet with the stated overlap, every registration mark
//! stands in an overlap and is printed on exactly the two pages it joins, at the same point of
//! the pattern. (`tools/fabrication/check_outputs.py tiles` reassembles the pages from their
//! marks and compares them with the full pattern.) The legend, on the `--svg` page and on the
//! tiles, lies inside its page and clear of every crease line and registration mark, and every
//! legend text stays inside the legend's box.

use fabrication::pattern::Pattern;
use fabrication::svg::{layout, render, Legend, CHAR_MM, FONT_MM};
use fabrication::tiles::{marks, pages, tiling, Paper, FOOTER_MM, OVERLAP_MM, PRINT_MARGIN_MM};
use fabrication::{Module, Trunk};
use geometry::ModuleDesign;

fn pattern(betas: &[(f64, usize)], edge_mm: f64) -> Pattern {
    let t = Trunk::new(
        betas
            .iter()
            .map(|&(b, layers)| Module {
                design: ModuleDesign::new(3, b).unwrap(),
                layers,
            })
            .collect(),
        edge_mm,
    )
    .unwrap();
    Pattern::new(&t, 5.0).unwrap()
}

/// The point of `text` (an SVG page) where mark `id`'s lines cross, page mm.
fn mark_on_page(text: &str, id: &str) -> Option<[f64; 2]> {
    let start = text.find(&format!(r#"id="reg-{id}""#))?;
    let g = &text[start..start + text[start..].find("</g>")?];
    let num = |key: &str, from: usize| -> f64 {
        let i = g[from..].find(key).unwrap() + from + key.len() + 2;
        g[i..i + g[i..].find('"').unwrap()].parse().unwrap()
    };
    let second =
        g.find("<line").unwrap() + 5 + g[g.find("<line").unwrap() + 5..].find("<line").unwrap();
    // First line horizontal (its y), second vertical (its x).
    Some([num("x1", second), num("y1", 0)])
}

#[test]
fn windows_cover_the_sheet_and_marks_join_exactly_two_pages_at_one_pattern_point() {
    for (p, paper) in [
        (pattern(&[(35.0, 2), (31.72, 2)], 75.0), Paper::A4),
        (pattern(&[(35.0, 2), (31.72, 2)], 75.0), Paper::Letter),
        (pattern(&[(31.72, 4)], 200.0), Paper::Letter),
        (pattern(&[(31.72, 4)], 200.0), Paper::A4),
    ] {
        let t = tiling(&p, paper, Legend::None, "test");
        let [_, _, w, h] = t.region_mm;
        for k in 0..2 {
            let covered = (t.grid[k] - 1) as f64 * t.pitch_mm[k] + t.window_mm[k];
            assert!(covered >= [w, h][k] - 1e-9, "{t:?}");
            assert!((t.window_mm[k] - t.pitch_mm[k] - OVERLAP_MM).abs() < 1e-12);
        }
        // The 1:1 pattern of the crane does not fit one A4 or Letter page.
        assert!(t.pages() >= 2, "{t:?}");
        let svgs = pages(&p, &t, "test");
        assert_eq!(svgs.len(), t.pages());
        let ms = marks(&t);
        assert!(!ms.is_empty());
        for m in &ms {
            let on: Vec<usize> = (0..svgs.len())
                .filter(|&i| svgs[i].contains(&format!(r#"id="reg-{}""#, m.id)))
                .collect();
            assert_eq!(on.len(), 2, "mark {} on pages {on:?}", m.id);
            // Each page shows its window from the printable corner: the mark's page position
            // plus that page's window origin is the mark's place in the pattern, the same for
            // both pages.
            for &i in &on {
                let (c, r) = (i % t.grid[0], i / t.grid[0]);
                let origin = [
                    t.region_mm[0] + c as f64 * t.pitch_mm[0],
                    t.region_mm[1] + r as f64 * t.pitch_mm[1],
                ];
                let at = mark_on_page(&svgs[i], &m.id).unwrap();
                let back = [
                    at[0] - PRINT_MARGIN_MM + origin[0],
                    at[1] - PRINT_MARGIN_MM + origin[1],
                ];
                assert!((back[0] - m.at_mm[0]).abs() < 1e-3 && (back[1] - m.at_mm[1]).abs() < 1e-3);
            }
        }
        for s in &svgs {
            let [pw, ph] = t.page_mm;
            assert!(s.contains(&format!(
                r#"width="{pw}mm" height="{ph}mm" viewBox="0 0 {pw} {ph}""#
            )));
            assert!(s.contains("50 mm: measure it"));
        }
    }
    assert!(Paper::parse("A4").is_ok() && Paper::parse("letter").is_ok());
    assert!(Paper::parse("a3").unwrap_err().0.contains("a4 or letter"));
}

/// Every `<line>` of the crease groups of an SVG: endpoints, page mm.
fn crease_lines(svg: &str) -> Vec<([f64; 2], [f64; 2])> {
    let attr = |tag: &str, key: &str| -> f64 {
        let i = tag.find(&format!(" {key}=\"")).unwrap() + key.len() + 3;
        tag[i..i + tag[i..].find('"').unwrap()].parse().unwrap()
    };
    let mut out = Vec::new();
    for kind in ["mountain", "valley", "boundary", "cut", "virtual"] {
        let Some(start) = svg.find(&format!(r#"<g id="{kind}""#)) else {
            continue;
        };
        let g = &svg[start..start + svg[start..].find("</g>").unwrap()];
        for tag in g.split("<line").skip(1) {
            out.push((
                [attr(tag, "x1"), attr(tag, "y1")],
                [attr(tag, "x2"), attr(tag, "y2")],
            ));
        }
    }
    out
}

/// Whether segment a–b meets the rectangle [x, x + w] × [y, y + h] (Liang–Barsky).
fn meets(a: [f64; 2], b: [f64; 2], r: [f64; 4]) -> bool {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a[0] - r[0]),
        (dx, r[0] + r[2] - a[0]),
        (-dy, a[1] - r[1]),
        (dy, r[1] + r[3] - a[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else if p < 0.0 {
            t0 = t0.max(q / p);
        } else {
            t1 = t1.min(q / p);
        }
    }
    t0 <= t1
}

fn disjoint(a: [f64; 4], b: [f64; 4]) -> bool {
    a[0] + a[2] < b[0] || b[0] + b[2] < a[0] || a[1] + a[3] < b[1] || b[1] + b[3] < a[1]
}

/// The legend group's box (`data-box`) and its texts' boxes: from x, the baseline y (ascent
/// 0.8 em above, descent 0.3 em below) and CHAR_MM per character.
fn legend_boxes(svg: &str) -> Option<([f64; 4], Vec<[f64; 4]>)> {
    let start = svg.find(r#"<g id="legend""#)?;
    let g = &svg[start..start + svg[start..].find("</g>").unwrap()];
    let i = g.find(r#"data-box=""#).unwrap() + 10;
    let b: Vec<f64> = g[i..i + g[i..].find('"').unwrap()]
        .split(' ')
        .map(|x| x.parse().unwrap())
        .collect();
    let attr = |tag: &str, key: &str| -> f64 {
        let i = tag.find(&format!(" {key}=\"")).unwrap() + key.len() + 3;
        tag[i..i + tag[i..].find('"').unwrap()].parse().unwrap()
    };
    let texts = g
        .split("<text")
        .skip(1)
        .map(|tag| {
            let body = &tag[tag.find('>').unwrap() + 1..tag.find("</text>").unwrap()];
            // Characters outside markup, entities as one.
            let mut plain = String::new();
            let mut in_tag = false;
            for c in body.chars() {
                match c {
                    '<' => in_tag = true,
                    '>' => in_tag = false,
                    _ if !in_tag => plain.push(c),
                    _ => {}
                }
            }
            let chars = plain
                .replace("&amp;", "&")
                .replace("&lt;", "<")
                .replace("&gt;", ">")
                .chars()
                .count();
            let (x, y) = (attr(tag, "x"), attr(tag, "y"));
            [x, y - 0.8 * FONT_MM, chars as f64 * CHAR_MM, 1.1 * FONT_MM]
        })
        .collect();
    Some(([b[0], b[1], b[2], b[3]], texts))
}

fn inside(inner: [f64; 4], outer: [f64; 4]) -> bool {
    inner[0] >= outer[0] - 1e-3
        && inner[1] >= outer[1] - 1e-3
        && inner[0] + inner[2] <= outer[0] + outer[2] + 1e-3
        && inner[1] + inner[3] <= outer[1] + outer[3] + 1e-3
}

fn patterns() -> Vec<Pattern> {
    let mut v = vec![
        pattern(&[(35.0, 2), (31.72, 2)], 75.0),
        pattern(&[(31.72, 4)], 200.0),
        pattern(&[(31.72, 1)], 20.0),
        pattern(&[(31.72, 6)], 40.0),
    ];
    // Sheets from a few millimetres to metres, so the legend lands on every kind of page.
    for edge in [10.0, 12.0, 33.0, 58.0, 90.0, 130.0, 260.0, 609.6] {
        for layers in [1, 3, 7] {
            v.push(pattern(&[(31.72, layers)], edge));
        }
    }
    v
}

#[test]
fn the_svg_legend_is_inside_its_page_and_clear_of_every_line() {
    let title = "host-tool pattern: a command line long enough to wrap in a narrow legend column, and then some more words";
    for p in patterns() {
        for legend in [Legend::Below, Legend::Right, Legend::None] {
            let lay = layout(&p, title, legend);
            let svg = render(&p, title, legend);
            let [pw, ph] = lay.page_mm;
            assert!(svg.contains(&format!(r#"viewBox="0 0 {pw:.3} {ph:.3}""#)));
            let lines = crease_lines(&svg);
            assert!(!lines.is_empty());
            let page = [0.0, 0.0, pw, ph];
            for &(a, b) in &lines {
                assert!(
                    inside([a[0], a[1], 0.0, 0.0], page) && inside([b[0], b[1], 0.0, 0.0], page)
                );
            }
            // The sheet box holds every line, 10 mm from the page's edges.
            let sheet = lay.sheet_box_mm;
            assert_eq!([sheet[0], sheet[1]], [10.0, 10.0]);
            for &(a, b) in &lines {
                assert!(
                    inside([a[0], a[1], 0.0, 0.0], sheet) && inside([b[0], b[1], 0.0, 0.0], sheet)
                );
            }
            match legend {
                Legend::None => {
                    assert!(lay.legend.is_none());
                    assert!(!svg.contains(r#"id="legend""#) && !svg.contains(r#"id="annotation""#));
                    assert!(
                        (pw - sheet[2] - 20.0).abs() < 1e-9 && (ph - sheet[3] - 20.0).abs() < 1e-9
                    );
                }
                _ => {
                    let (bx, texts) = legend_boxes(&svg).unwrap();
                    let want = lay.legend.as_ref().unwrap().1;
                    for k in 0..4 {
                        assert!((bx[k] - want[k]).abs() < 1e-3, "{bx:?} vs {want:?}");
                    }
                    // Inside the page with its 10 mm margin, clear of the sheet and its lines.
                    assert!(
                        inside(bx, [10.0, 10.0, pw - 20.0, ph - 20.0]),
                        "{bx:?} on {pw} × {ph}"
                    );
                    assert!(disjoint(bx, sheet), "{bx:?} over the sheet {sheet:?}");
                    for &(a, b) in &lines {
                        assert!(
                            !meets(a, b, bx),
                            "line {a:?}-{b:?} crosses the legend {bx:?}"
                        );
                    }
                    // The scale bar's label, the trunk, the scale, five line kinds, the title.
                    assert!(texts.len() >= 9, "{} legend texts", texts.len());
                    for t in &texts {
                        assert!(inside(*t, bx), "text {t:?} outside the legend {bx:?}");
                    }
                    if legend == Legend::Right {
                        assert!(bx[0] >= sheet[0] + sheet[2] + 8.0 - 1e-3 && bx[2] <= 100.0 + 1e-3);
                    } else {
                        assert!(bx[1] >= sheet[1] + sheet[3] + 4.0 - 1e-3);
                    }
                }
            }
        }
    }
}

#[test]
fn the_tiles_print_the_legend_once_inside_a_window_clear_of_lines_and_marks() {
    let title = "host-tool pattern: n = 3, β = 35°×2 + 31.72°×2 layers (bottom first), l = 75 mm";
    for p in patterns() {
        for paper in [Paper::A4, Paper::Letter] {
            for legend in [Legend::Below, Legend::Right, Legend::None] {
                let t = tiling(&p, paper, legend, title);
                let svgs = pages(&p, &t, title);
                let with: Vec<usize> = (0..svgs.len())
                    .filter(|&i| svgs[i].contains(r#"id="legend""#))
                    .collect();
                let Some((block, bx, page)) = &t.legend else {
                    assert_eq!(legend, Legend::None);
                    assert!(with.is_empty());
                    continue;
                };
                assert_eq!(with, [*page], "{legend:?} {paper:?}");
                let svg = &svgs[*page];
                let (c, r) = (page % t.grid[0], page / t.grid[0]);
                let origin = [
                    t.region_mm[0] + c as f64 * t.pitch_mm[0],
                    t.region_mm[1] + r as f64 * t.pitch_mm[1],
                ];
                let on_page = [
                    bx[0] - origin[0] + PRINT_MARGIN_MM,
                    bx[1] - origin[1] + PRINT_MARGIN_MM,
                    bx[2],
                    bx[3],
                ];
                let (drawn, texts) = legend_boxes(svg).unwrap();
                for k in 0..4 {
                    assert!(
                        (drawn[k] - on_page[k]).abs() < 1e-3,
                        "{drawn:?} vs {on_page:?}"
                    );
                }
                assert_eq!(block.size_mm, [bx[2], bx[3]]);
                // Inside the printable window (not the margin, not the footer), and clear of
                // the overlaps, so of every registration mark.
                let [pw, ph] = t.page_mm;
                let window = [
                    PRINT_MARGIN_MM,
                    PRINT_MARGIN_MM,
                    t.window_mm[0],
                    t.window_mm[1],
                ];
                assert!(
                    inside(drawn, window),
                    "{drawn:?} outside the window {window:?}"
                );
                assert!(
                    drawn[1] + drawn[3] <= ph - PRINT_MARGIN_MM - FOOTER_MM + 1e-9
                        && drawn[0] + drawn[2] <= pw - PRINT_MARGIN_MM
                );
                for &(a, b) in &crease_lines(svg) {
                    assert!(
                        !meets(a, b, drawn),
                        "line {a:?}-{b:?} crosses the legend {drawn:?}"
                    );
                }
                assert!(disjoint(*bx, t.sheet_mm));
                for m in marks(&t) {
                    // The mark's cross (±5 mm) and its id (2.5 mm text from 4 mm right of the
                    // centre, baseline 4 mm up), at CHAR_MM / FONT_MM em per character.
                    let id_mm = m.id.chars().count() as f64 * CHAR_MM / FONT_MM * 2.5;
                    let mark = [m.at_mm[0] - 5.0, m.at_mm[1] - 7.0, 9.0 + id_mm, 12.0];
                    assert!(
                        disjoint(*bx, mark),
                        "mark {} at {:?} under the legend {bx:?}",
                        m.id,
                        m.at_mm
                    );
                }
                for tb in &texts {
                    assert!(
                        inside(*tb, drawn),
                        "text {tb:?} outside the legend {drawn:?}"
                    );
                }
                // No other page's window reaches the legend.
                for (i, _) in svgs.iter().enumerate().filter(|(i, _)| i != page) {
                    let (c, r) = (i % t.grid[0], i / t.grid[0]);
                    let w = [
                        t.region_mm[0] + c as f64 * t.pitch_mm[0],
                        t.region_mm[1] + r as f64 * t.pitch_mm[1],
                        t.window_mm[0],
                        t.window_mm[1],
                    ];
                    let ox = (bx[0] + bx[2]).min(w[0] + w[2]) - bx[0].max(w[0]);
                    let oy = (bx[1] + bx[3]).min(w[1] + w[3]) - bx[1].max(w[1]);
                    assert!(
                        ox <= 1e-9 || oy <= 1e-9,
                        "page {i}'s window also holds part of the legend"
                    );
                }
                // The legend stays outside the sheet, where the pattern's lines are: below it or
                // right of it.
                match legend {
                    Legend::Below => assert!(bx[1] >= t.sheet_mm[1] + t.sheet_mm[3] + 4.0 - 1e-9),
                    _ => assert!(bx[0] >= t.sheet_mm[0] + t.sheet_mm[2] + 8.0 - 1e-9),
                }
            }
        }
    }
}
