//! Cut sheets: every facet present once, inside the margins, a spacing apart, its holes at the
//! kit's hinges, its neighbours' ids right; the area bound; refusals.

use fabrication::kit::Kit;
use fabrication::nest::{kit_facets, min_edge_mm, FacetKind, Nest, NestParams, INSERT_HOLE_MM};
use fabrication::nest_out;
use fabrication::{Module, Trunk};
use geometry::ModuleDesign;

fn trunk(n: u32, betas: &[(f64, usize)], edge_mm: f64) -> Trunk {
    Trunk::new(
        betas
            .iter()
            .map(|&(b, layers)| Module {
                design: ModuleDesign::new(n, b).unwrap(),
                layers,
            })
            .collect(),
        edge_mm,
    )
    .unwrap()
}

/// The paper's meter-scale build: four 2 ft golden modules.
fn paper() -> Trunk {
    trunk(3, &[(31.72, 4)], 609.6)
}

fn params(sheet: [f64; 2]) -> NestParams {
    NestParams {
        sheet_mm: sheet,
        kerf_mm: 0.2,
        margin_mm: 10.0,
        spacing_mm: 3.0,
        hole_mm: INSERT_HOLE_MM,
    }
}

fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    fabrication::nest::point_segment_distance(p, a, b)
}

fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Strictly inside (by more than 1e-6 mm of cross product per mm of edge).
fn inside(p: [f64; 2], t: &[[f64; 2]; 3]) -> bool {
    let s: Vec<f64> = (0..3)
        .map(|i| {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            cross(a, b, p) / (b[0] - a[0]).hypot(b[1] - a[1])
        })
        .collect();
    s.iter().all(|&v| v > 1e-6) || s.iter().all(|&v| v < -1e-6)
}

fn segments_cross(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let eps = 1e-6;
    let d1 = cross(a, b, c);
    let d2 = cross(a, b, d);
    let d3 = cross(c, d, a);
    let d4 = cross(c, d, b);
    ((d1 > eps && d2 < -eps) || (d1 < -eps && d2 > eps))
        && ((d3 > eps && d4 < -eps) || (d3 < -eps && d4 > eps))
}

fn centroid(t: &[[f64; 2]; 3]) -> [f64; 2] {
    [
        (t[0][0] + t[1][0] + t[2][0]) / 3.0,
        (t[0][1] + t[1][1] + t[2][1]) / 3.0,
    ]
}

/// Whether two triangles' interiors overlap.
fn overlap(s: &[[f64; 2]; 3], t: &[[f64; 2]; 3]) -> bool {
    s.iter().any(|&p| inside(p, t))
        || t.iter().any(|&p| inside(p, s))
        || inside(centroid(s), t)
        || inside(centroid(t), s)
        || (0..3)
            .any(|i| (0..3).any(|j| segments_cross(s[i], s[(i + 1) % 3], t[j], t[(j + 1) % 3])))
}

/// Distance between the boundaries of two triangles that do not overlap.
fn tri_dist(s: &[[f64; 2]; 3], t: &[[f64; 2]; 3]) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..3 {
        for j in 0..3 {
            let (a, b) = (s[i], s[(i + 1) % 3]);
            let (c, d) = (t[j], t[(j + 1) % 3]);
            best = best
                .min(seg_dist(a, c, d))
                .min(seg_dist(b, c, d))
                .min(seg_dist(c, a, b))
                .min(seg_dist(d, a, b));
        }
    }
    best
}

fn check_layout(nest: &Nest) {
    let p = nest.params;
    let [w, h] = p.sheet_mm;
    // Every facet exactly once.
    let mut seen = vec![0; nest.facets.len()];
    for part in nest.sheets.iter().flatten() {
        seen[part.facet] += 1;
    }
    assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
    for parts in &nest.sheets {
        for (i, a) in parts.iter().enumerate() {
            for q in a.cut_mm {
                assert!(
                    q[0] >= p.margin_mm - 1e-9
                        && q[0] <= w - p.margin_mm + 1e-9
                        && q[1] >= p.margin_mm - 1e-9
                        && q[1] <= h - p.margin_mm + 1e-9,
                    "cut path corner {q:?} outside the margins"
                );
            }
            // The cut path is the outline offset by half the kerf.
            for e in 0..3 {
                for q in a.outline_mm {
                    let d = seg_dist(q, a.cut_mm[e], a.cut_mm[(e + 1) % 3]);
                    assert!(d >= 0.5 * p.kerf_mm - 1e-9, "{d}");
                }
                let (s, t) = (a.outline_mm[e], a.outline_mm[(e + 1) % 3]);
                let mid = [0.5 * (s[0] + t[0]), 0.5 * (s[1] + t[1])];
                let d = seg_dist(mid, a.cut_mm[e], a.cut_mm[(e + 1) % 3]);
                assert!((d - 0.5 * p.kerf_mm).abs() < 1e-9, "offset {d}");
            }
            for hole in &a.holes {
                assert!(inside(hole.at_mm, &a.outline_mm));
            }
            for b in &parts[i + 1..] {
                assert!(!overlap(&a.cut_mm, &b.cut_mm));
                let d = tri_dist(&a.cut_mm, &b.cut_mm);
                assert!(
                    d >= p.spacing_mm - 1e-9,
                    "parts {} and {} are {d} mm apart",
                    nest.facets[a.facet].id,
                    nest.facets[b.facet].id
                );
            }
        }
    }
    assert!(nest.sheets.len() >= nest.area_bound);
}

#[test]
fn the_paper_kit_on_4x8_ft_sheets_takes_two_with_every_facet_and_hole() {
    let t = paper();
    let nest = Nest::new(&t, params([1220.0, 2440.0])).unwrap();
    check_layout(&nest);
    assert_eq!(nest.part_count(), 48);
    // Rows of six along the 2440 mm side, six rows: 36 a sheet, so 2 sheets; the area bound is
    // 1 (Σ cut area 2.76 m² < 2.90 m² inside the margins), which triangles in rows cannot reach.
    assert_eq!(nest.sheets.len(), 2);
    assert_eq!(nest.sheets[0].len(), 36);
    assert_eq!(nest.area_bound, 1);
    assert!(nest.turned, "rows run along the sheet's 2440 mm height");
    let kit = Kit::new(&t);
    // Two insert holes per hinge in each of its two facets: one hole per screw.
    assert_eq!(nest.hole_count(), kit.screws());
    assert_eq!(nest.hole_count(), 720);
    assert!((nest.utilisation() - 2.757e6 / (2.0 * 1220.0 * 2440.0)).abs() < 1e-3);
}

#[test]
fn every_hole_pair_sits_on_a_hinge_the_kit_lists_and_every_hinge_gets_four_holes() {
    let t = paper();
    let kit = Kit::new(&t);
    let nest = Nest::new(&t, params([1220.0, 2440.0])).unwrap();
    let width = 3.0 * 609.6;
    let mut per_hinge = vec![0usize; kit.hinges.len()];
    for part in nest.sheets.iter().flatten() {
        let f = &nest.facets[part.facet];
        for (hole, local) in part
            .holes
            .iter()
            .zip(fabrication::nest::local_holes(f, INSERT_HOLE_MM))
        {
            // The hole on the sheet is the local hole placed.
            let placed = part.placement.apply(local.at_mm);
            assert!((placed[0] - hole.at_mm[0]).abs() < 1e-9);
            assert!((placed[1] - hole.at_mm[1]).abs() < 1e-9);
            // Its hinge centre, in the flat pattern, is one of the kit's.
            let q = f.to_pattern(local.hinge_mm);
            let x = q[0].rem_euclid(width);
            let k = kit
                .hinges
                .iter()
                .position(|h| {
                    let dx = (h.at_mm[0] - x).abs();
                    dx.min(width - dx) < 1e-6 && (h.at_mm[1] - q[1]).abs() < 1e-6
                })
                .unwrap_or_else(|| panic!("facet {}: no kit hinge at {q:?}", f.id));
            per_hinge[k] += 1;
            // 12 mm from its crease and 12 mm along it from the hinge centre.
            let d = (local.at_mm[0] - local.hinge_mm[0]).hypot(local.at_mm[1] - local.hinge_mm[1]);
            assert!((d - 12.0 * 2f64.sqrt()).abs() < 1e-9, "{d}");
        }
    }
    assert!(per_hinge.iter().all(|&c| c == 4), "{per_hinge:?}");
}

#[test]
fn neighbours_are_mutual_and_share_their_edge_in_the_pattern() {
    for t in [paper(), trunk(6, &[(35.0, 2), (31.72, 2)], 900.0)] {
        let facets = kit_facets(&t);
        let width = t.n() as f64 * t.edge_mm();
        let find = |id: &str| facets.iter().find(|f| f.id == id).unwrap();
        let same = |a: [f64; 2], b: [f64; 2]| {
            let dx = (a[0] - b[0]).rem_euclid(width);
            dx.min(width - dx) < 1e-6 && (a[1] - b[1]).abs() < 1e-6
        };
        assert_eq!(facets.len(), 4 * t.n() as usize * t.layer_count());
        for f in &facets {
            // Counter-clockwise, base l, legs equal.
            let [s, e, a] = f.corners_mm;
            let area = 0.5 * ((e[0] - s[0]) * (a[1] - s[1]) - (e[1] - s[1]) * (a[0] - s[0]));
            assert!(
                (area - 0.5 * f.base_mm * f.height_mm).abs() < 1e-6,
                "{}",
                f.id
            );
            for (k, nb) in f.neighbours.iter().enumerate() {
                let edge = (f.corners_mm[k], f.corners_mm[(k + 1) % 3]);
                match nb {
                    None => {
                        assert_eq!(k, 0, "{}: only a base can be the trunk's edge", f.id);
                        assert!(
                            (f.layer == 0 && f.kind == FacetKind::InnerBottom)
                                || (f.layer + 1 == t.layer_count()
                                    && f.kind == FacetKind::InnerTop)
                        );
                    }
                    Some(id) => {
                        let g = find(id);
                        let back = g
                            .neighbours
                            .iter()
                            .position(|m| m.as_deref() == Some(&f.id));
                        let j = back.unwrap_or_else(|| panic!("{} → {id} is not mutual", f.id));
                        let other = (g.corners_mm[j], g.corners_mm[(j + 1) % 3]);
                        // The shared crease, traversed the other way round.
                        assert!(
                            same(edge.0, other.1) && same(edge.1, other.0),
                            "{} | {id}",
                            f.id
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn a_two_module_kit_on_small_sheets_and_the_labels_stay_inside() {
    let t = trunk(3, &[(35.0, 2), (31.72, 2)], 900.0);
    let nest = Nest::new(&t, params([1220.0, 2440.0])).unwrap();
    check_layout(&nest);
    assert_eq!(nest.part_count(), 48);
    for part in nest.sheets.iter().flatten() {
        let f = &nest.facets[part.facet];
        let labels = nest_out::labels(f, part);
        assert_eq!(labels.len(), 1 + f.neighbours.iter().flatten().count());
        for l in labels {
            assert!(inside(l.at_mm, &part.outline_mm), "{}: {l:?}", f.id);
        }
    }
    let svg = nest_out::svg_sheet(&nest, 0, "test");
    assert_eq!(svg.matches("<polygon").count(), nest.sheets[0].len());
    assert_eq!(
        svg.matches("<circle").count(),
        nest.sheets[0].iter().map(|p| p.holes.len()).sum::<usize>()
    );
    let mut dxf = Vec::new();
    nest_out::write_dxf(&nest, 0, &mut dxf).unwrap();
    let text = String::from_utf8(dxf).unwrap();
    assert!(text.contains("LWPOLYLINE") && text.contains("CIRCLE") && text.contains("TEXT"));
}

#[test]
fn refusals_say_what_is_wrong() {
    // The crane's 75 mm facets cannot take M4 hinges.
    let crane = trunk(3, &[(35.0, 2), (31.72, 2)], 75.0);
    let e = Nest::new(&crane, params([600.0, 400.0])).unwrap_err().0;
    assert!(e.contains("too small") && e.contains("--edge-mm ≥"), "{e}");
    let min = min_edge_mm(&crane, INSERT_HOLE_MM).unwrap();
    assert!(Nest::new(
        &trunk(3, &[(35.0, 2), (31.72, 2)], min),
        params([4000.0, 4000.0])
    )
    .is_ok());
    assert!(Nest::new(
        &trunk(3, &[(35.0, 2), (31.72, 2)], min - 0.05),
        params([4000.0, 4000.0])
    )
    .is_err());
    // A 2 ft facet is longer than a 600 × 400 sheet either way.
    let e = Nest::new(&paper(), params([600.0, 400.0])).unwrap_err().0;
    assert!(
        e.contains("does not fit") && e.contains("either way"),
        "{e}"
    );
    for bad in [
        NestParams {
            kerf_mm: -0.1,
            ..params([1220.0, 2440.0])
        },
        NestParams {
            kerf_mm: f64::NAN,
            ..params([1220.0, 2440.0])
        },
        NestParams {
            margin_mm: 700.0,
            ..params([1220.0, 2440.0])
        },
        NestParams {
            spacing_mm: -1.0,
            ..params([1220.0, 2440.0])
        },
        NestParams {
            hole_mm: 0.1,
            ..params([1220.0, 2440.0])
        },
    ] {
        assert!(Nest::new(&paper(), bad).is_err(), "{bad:?}");
    }
    assert_eq!(
        NestParams::parse_sheet("1220x2440").unwrap(),
        [1220.0, 2440.0]
    );
    assert_eq!(
        NestParams::parse_sheet(" 600 X 400 ").unwrap(),
        [600.0, 400.0]
    );
    for bad in ["1220", "x", "0x100", "-5x100", "infx3", "1e6x10", "axb"] {
        assert!(NestParams::parse_sheet(bad).is_err(), "{bad}");
    }
}

#[test]
fn zero_kerf_and_spacing_touch_but_never_overlap() {
    let p = NestParams {
        kerf_mm: 0.0,
        spacing_mm: 0.0,
        margin_mm: 0.0,
        ..params([1220.0, 2440.0])
    };
    let nest = Nest::new(&paper(), p).unwrap();
    check_layout(&nest);
}
