//! The printable panel (closed solids, gaps, no overlaps, 3MF parts) and the meter-scale kit
//! (counts, hinge positions). Lengths in mm; geometric tolerances 1e-9 mm.

use fabrication::kit::Kit;
use fabrication::panel::{facet_triangles, Panel, PanelParams};
use fabrication::pattern::Pattern;
use fabrication::{Module, Trunk};
use geometry::ModuleDesign;

fn trunk(n: u32, betas: &[(f64, usize)], edge_mm: f64) -> Trunk {
    let modules = betas
        .iter()
        .map(|&(b, layers)| Module {
            design: ModuleDesign::new(n, b).unwrap(),
            layers,
        })
        .collect();
    Trunk::new(modules, edge_mm).unwrap()
}

fn crane_panel() -> (Pattern, Panel) {
    let p = Pattern::new(&trunk(3, &[(35.0, 2), (31.72, 2)], 75.0), 5.0).unwrap();
    let panel = Panel::new(
        &p,
        PanelParams {
            gap_mm: vec![3.0, 1.5],
            facet_mm: 0.6,
            base_mm: 0.2,
        },
    )
    .unwrap();
    (p, panel)
}

fn area(t: &[[f64; 2]]) -> f64 {
    let k = t.len();
    0.5 * (0..k)
        .map(|i| t[i][0] * t[(i + 1) % k][1] - t[i][1] * t[(i + 1) % k][0])
        .sum::<f64>()
}

/// Distance from point q to segment ab.
fn seg_dist(q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let t = (((q[0] - a[0]) * dx + (q[1] - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
    ((q[0] - a[0] - t * dx).powi(2) + (q[1] - a[1] - t * dy).powi(2)).sqrt()
}

#[test]
fn the_crane_panel_is_two_closed_solids_with_the_right_volumes() {
    let (p, panel) = crane_panel();
    panel.base.check_solid().unwrap();
    panel.facets.check_solid().unwrap();
    // 230 × 197.745 mm sheet (3 × 75 + 5 mm seam; 2 × 75 tan 35° + 2 × 75 tan 31.72°).
    let (w, h) = panel.sheet_mm;
    assert!((w - 230.0).abs() < 1e-9);
    let h_expected = 150.0 * (35f64.to_radians().tan() + 31.72f64.to_radians().tan());
    assert!((h - h_expected).abs() < 1e-9, "{h}");
    assert!((panel.base.volume() - w * h * 0.2).abs() < 1e-6);
    // 14 facets per layer for n = 3: 2n inner, 2(n − 1) rhombus triangles, 4 seam halves.
    assert_eq!(panel.facet_count, 4 * 14);
    // Facet volume = Σ inset areas × 0.6, every facet on top of the base, inside the sheet.
    let (lo, hi) = panel.facets.bounds();
    assert!((lo[2] - 0.2).abs() < 1e-12 && (hi[2] - 0.8).abs() < 1e-12);
    assert!(lo[0] > 0.0 && lo[1] > 0.0 && hi[0] < 225.0 && hi[1] < h);
    let tris = facet_triangles(&p);
    let inset_area: f64 = tris
        .iter()
        .map(|(t, m)| area(&fabrication::mesh::inset(t, [1.5, 0.75][*m]).unwrap()))
        .sum();
    assert!((panel.facets.volume() - 0.6 * inset_area).abs() < 1e-6);
    // The uninset facets tile the pattern exactly (no overlap, no hole).
    let total: f64 = tris.iter().map(|(t, _)| area(t)).sum();
    assert!((total - 225.0 * h).abs() < 1e-6, "{total}");
}

#[test]
fn neighbouring_facets_are_one_gap_apart_and_never_overlap() {
    let (p, _) = crane_panel();
    let tris = facet_triangles(&p);
    let insets: Vec<(Vec<[f64; 2]>, usize)> = tris
        .iter()
        .map(|(t, m)| (fabrication::mesh::inset(t, [1.5, 0.75][*m]).unwrap(), *m))
        .collect();
    let mut min_same_module = f64::INFINITY;
    for (i, (a, ma)) in insets.iter().enumerate() {
        for (b, mb) in insets.iter().skip(i + 1) {
            // Distance between two disjoint convex polygons: min over vertex-edge pairs.
            let mut d = f64::INFINITY;
            for q in a {
                for k in 0..b.len() {
                    d = d.min(seg_dist(*q, b[k], b[(k + 1) % b.len()]));
                }
            }
            for q in b {
                for k in 0..a.len() {
                    d = d.min(seg_dist(*q, a[k], a[(k + 1) % a.len()]));
                }
            }
            let want = 0.5 * ([3.0, 1.5][*ma] + [3.0, 1.5][*mb]);
            assert!(
                d >= want - 1e-9,
                "facets {i} closer than the gap: {d} < {want}"
            );
            if ma == mb {
                min_same_module = min_same_module.min(d / want);
            }
        }
    }
    // Across a shared crease the distance is exactly the gap.
    assert!((min_same_module - 1.0).abs() < 1e-9, "{min_same_module}");
}

#[test]
fn panel_parameters_are_validated() {
    let p = Pattern::new(&trunk(3, &[(35.0, 1)], 75.0), 5.0).unwrap();
    let make = |gap: f64, facet: f64, base: f64| {
        Panel::new(
            &p,
            PanelParams {
                gap_mm: vec![gap],
                facet_mm: facet,
                base_mm: base,
            },
        )
    };
    assert!(make(3.0, 0.6, 0.2).is_ok());
    assert!(make(1e-6, 20.0, 20.0).is_ok());
    for gap in [0.0, -1.0, f64::NAN, 1e9] {
        let e = make(gap, 0.6, 0.2).unwrap_err().to_string();
        assert!(e.contains("must be in (0, "), "{e}");
    }
    // The smallest facets are the seam halves: right triangles with legs 37.5 × 26.26 mm.
    let e = make(100.0, 0.6, 0.2).unwrap_err().to_string();
    let limit: f64 = e
        .split("(0, ")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(make(limit - 0.01, 0.6, 0.2).is_ok());
    assert!(make(limit + 0.01, 0.6, 0.2).is_err());
    for t in [0.0, 20.01, f64::INFINITY] {
        assert!(make(1.0, t, 0.2).is_err());
        assert!(make(1.0, 0.6, t).is_err());
    }
}

#[test]
fn the_3mf_package_has_two_objects_two_materials_and_the_print_parameters() {
    let (p, panel) = crane_panel();
    let mut buf = std::io::Cursor::new(Vec::new());
    panel.write_3mf(&p, "test", &mut buf).unwrap();
    let mut zip = zip::ZipArchive::new(std::io::Cursor::new(buf.into_inner())).unwrap();
    let mut names: Vec<String> = zip.file_names().map(str::to_string).collect();
    names.sort();
    assert_eq!(
        names,
        ["3D/3dmodel.model", "[Content_Types].xml", "_rels/.rels"]
    );
    let mut model = String::new();
    std::io::Read::read_to_string(&mut zip.by_name("3D/3dmodel.model").unwrap(), &mut model)
        .unwrap();
    assert_eq!(model.matches("<object ").count(), 2);
    assert_eq!(model.matches("<base ").count(), 2);
    assert!(model.contains(r#"pid="1" pindex="0""#) && model.contains(r#"pid="1" pindex="1""#));
    for (k, v) in panel.metadata(&p) {
        assert!(
            model.contains(&format!(r#"<metadata name="{k}">{v}</metadata>"#)),
            "{k}"
        );
    }
    assert!(model.contains(r#"<metadata name="ys:gap_mm">3,1.5</metadata>"#));
    // basematerials is declared before the objects that reference it.
    assert!(model.find("<basematerials").unwrap() < model.find("<object").unwrap());
}

#[test]
fn the_papers_meter_scale_build_needs_180_hinges_and_720_screws() {
    // Four 2 ft (609.6 mm) golden modules, n = 3 (§7.1).
    for t in [
        trunk(3, &[(31.72, 4)], 609.6),
        trunk(3, &[(31.72, 1), (31.72, 1), (31.72, 1), (31.72, 1)], 609.6),
    ] {
        let kit = Kit::new(&t);
        assert_eq!(kit.hinges.len(), 180);
        assert_eq!(kit.screws(), 720);
        assert_eq!(kit.facet_count(), 48);
        assert_eq!(kit.creases, (48, 12, 9));
        let f = &kit.facets[0];
        assert!((f.base_mm - 609.6).abs() < 1e-12);
        assert!((f.leg_mm - 609.6 / (2.0 * 31.72f64.to_radians().cos())).abs() < 1e-9);
        let json = kit.to_json();
        assert_eq!(json["hinges"], 180);
        assert_eq!(json["screws"], 720);
        assert_eq!(json["hinge_positions"].as_array().unwrap().len(), 180);
    }
}

#[test]
fn hinge_counts_follow_the_rule_for_any_trunk_and_sit_mirrored_on_the_creases() {
    for (n, layers) in [(3usize, 1usize), (3, 2), (4, 3), (6, 5), (12, 1)] {
        let t = trunk(n as u32, &[(40.0, layers)], 100.0);
        let kit = Kit::new(&t);
        assert_eq!(
            kit.hinges.len(),
            4 * n * (4 * layers - 1),
            "n {n} L {layers}"
        );
        assert_eq!(kit.screws(), 4 * kit.hinges.len());
        assert_eq!(kit.facet_count(), 4 * n * layers);
        // Every hinge lies inside the closed sheet; fractions are mirror-symmetric.
        for h in &kit.hinges {
            assert!(h.at_mm[0] >= 0.0 && h.at_mm[0] < n as f64 * 100.0);
            assert!(h.at_mm[1] > 0.0 && h.at_mm[1] < t.flat_height() * 100.0);
        }
        let mut fr: Vec<f64> = kit.hinges.iter().map(|h| h.fraction).collect();
        let mut mirrored: Vec<f64> = fr.iter().map(|f| 1.0 - f).collect();
        fr.sort_by(f64::total_cmp);
        mirrored.sort_by(f64::total_cmp);
        for (a, b) in fr.iter().zip(&mirrored) {
            assert!((a - b).abs() < 1e-12);
        }
    }
}

#[test]
fn bills_of_materials_count_what_the_files_make() {
    use fabrication::bom::{Bom, NYLON_G_PER_CM3, TPU_G_PER_CM3};
    use fabrication::nest::{Nest, NestParams, INSERT_HOLE_MM};
    let crane = Trunk::new(
        vec![
            Module {
                design: geometry::ModuleDesign::new(3, 35.0).unwrap(),
                layers: 2,
            },
            Module {
                design: geometry::ModuleDesign::new(3, 31.72).unwrap(),
                layers: 2,
            },
        ],
        75.0,
    )
    .unwrap();
    let pattern = Pattern::new(&crane, 5.0).unwrap();
    let panel = Panel::new(
        &pattern,
        PanelParams {
            gap_mm: vec![3.0, 1.5],
            facet_mm: 0.6,
            base_mm: 0.2,
        },
    )
    .unwrap();
    let bom = Bom::crane(&panel);
    let grams = |part: &str| {
        bom.rows
            .iter()
            .find(|r| r.part.starts_with(part))
            .unwrap()
            .quantity
    };
    // Base sheet: the sheet's area × its thickness; facets: their volume, each × its density.
    let (w, h) = panel.sheet_mm;
    let base_g = w * h * 0.2 / 1000.0 * TPU_G_PER_CM3;
    assert!(
        (grams("TPU") - base_g).abs() <= 0.05 + 1e-9,
        "{} vs {base_g}",
        grams("TPU")
    );
    let nylon_g = panel.facets.volume() / 1000.0 * NYLON_G_PER_CM3;
    assert!((grams("nylon") - nylon_g).abs() <= 0.05 + 1e-9);
    let pcs = |part: &str| bom.rows.iter().find(|r| r.part == part).unwrap().quantity;
    assert_eq!(pcs("tendon servo"), 3.0);
    assert_eq!(pcs("solenoid valve"), 2.0);
    assert_eq!(pcs("push button"), 5.0);
    let csv = bom.to_csv();
    assert!(csv.starts_with("section,part,quantity,unit,specification\n"));
    assert_eq!(csv.lines().count(), bom.rows.len() + 1);
    // The kit: the nest's sheet count, the kit's hinges, one screw and one insert per hole.
    let paper = Trunk::new(
        vec![Module {
            design: geometry::ModuleDesign::new(3, 31.72).unwrap(),
            layers: 4,
        }],
        609.6,
    )
    .unwrap();
    let kit = Kit::new(&paper);
    let nest = Nest::new(
        &paper,
        NestParams {
            sheet_mm: [1220.0, 2440.0],
            kerf_mm: 0.2,
            margin_mm: 10.0,
            spacing_mm: 3.0,
            hole_mm: INSERT_HOLE_MM,
        },
    )
    .unwrap();
    let bom = Bom::kit(&kit, Some(&nest));
    let pcs = |part: &str| bom.rows.iter().find(|r| r.part == part).unwrap().quantity;
    assert_eq!(pcs("HDPE sheet"), 2.0);
    assert_eq!(pcs("hinge"), 180.0);
    assert_eq!(pcs("M4 screw"), nest.hole_count() as f64);
    assert_eq!(pcs("M4 heat-set insert"), 720.0);
    assert_eq!(pcs("facet, module 1"), 48.0);
    let unnested = Bom::kit(&kit, None);
    let area = unnested
        .rows
        .iter()
        .find(|r| r.unit == "m²")
        .unwrap()
        .quantity;
    assert!(
        (area - 48.0 * kit.facets[0].area_mm2 / 1e6).abs() < 1e-3,
        "{area}"
    );
}
