//! Paper tiles: the windows cover the sheet with the stated overlap, every registration mark
//! stands in an overlap and is printed on exactly the two pages it joins, at the same point of
//! the pattern. (`tools/fabrication/check_outputs.py tiles` reassembles the pages from their
//! marks and compares them with the full pattern.)

use fabrication::pattern::Pattern;
use fabrication::tiles::{marks, pages, tiling, Paper, OVERLAP_MM, PRINT_MARGIN_MM};
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
        let t = tiling(&p, paper);
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
