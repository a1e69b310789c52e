//! The printable panel (closed solids, gaps, no overlaps, 3MF parts) and the meter-scale kit
//! (counts, hinge positions). Lengths in mm; geometric tolerances 1e-9 mm.

use fabrication::kit::Kit;
use fabrication::panel::{facet_triangles, Panel, PanelParams};
use fabrication::parts::{hinge_leaf, PartParams};
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
    let parts = fabrication::parts::crane_parts(&crane, &PartParams::default()).unwrap();
    let bom = Bom::crane(&panel, &parts);
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
    let leaf = hinge_leaf(&PartParams::default(), kit.hinges.len()).unwrap();
    let bom = Bom::kit(&kit, Some(&nest), &leaf);
    let pcs = |part: &str| bom.rows.iter().find(|r| r.part == part).unwrap().quantity;
    assert_eq!(pcs("HDPE sheet"), 2.0);
    assert_eq!(pcs("hinge"), 180.0);
    assert_eq!(pcs("M4 screw"), nest.hole_count() as f64);
    assert_eq!(pcs("M4 heat-set insert"), 720.0);
    assert_eq!(pcs("facet, module 1"), 48.0);
    let unnested = Bom::kit(&kit, None, &leaf);
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

/// One row of a BOM by its part name.
fn bom_row<'a>(bom: &'a fabrication::bom::Bom, part: &str) -> &'a fabrication::bom::BomRow {
    bom.rows
        .iter()
        .find(|r| r.part == part)
        .unwrap_or_else(|| panic!("no row '{part}' in\n{}", bom.to_csv()))
}

#[test]
fn the_boms_list_every_printed_part_with_its_filament_mass_and_hardware() {
    use fabrication::bom::{Bom, NYLON_G_PER_CM3, PLA_CF_G_PER_CM3, PLA_G_PER_CM3};
    // The crane at two tendon radii: the parts' rows follow the parts' meshes.
    let (_, panel) = crane_panel();
    let crane = trunk(3, &[(35.0, 2), (31.72, 2)], 75.0);
    for r_t in [60.0, 80.0] {
        let params = PartParams {
            tendon_radius_mm: r_t,
            ..Default::default()
        };
        let parts = fabrication::parts::crane_parts(&crane, &params).unwrap();
        let bom = Bom::crane(&panel, &parts);
        let printed: Vec<(&str, f64)> = bom
            .rows
            .iter()
            .filter(|r| r.section == "printed" && r.unit == "pcs")
            .map(|r| (r.part.as_str(), r.quantity))
            .collect();
        assert_eq!(
            printed,
            [
                ("upper cap (upper-cap.stl / .3mf)", 1.0),
                ("lower cap (lower-cap.stl / .3mf)", 1.0),
                ("tendon locator (tendon-locator.stl / .3mf)", 2.0),
                ("gripper mount (gripper-mount.stl / .3mf)", 1.0),
            ]
        );
        // Filament: Σ quantity × mesh volume × density, rounded to 0.1 g.
        let mass = |name: &str, density: f64| -> f64 {
            parts
                .iter()
                .filter(|p| p.material.name == name)
                .map(|p| p.quantity as f64 * p.mesh.volume() / 1000.0 * density)
                .sum()
        };
        let pla = bom_row(&bom, "PLA filament (printed parts)");
        assert_eq!(pla.unit, "g");
        let want = mass("PLA", PLA_G_PER_CM3);
        assert!(
            (pla.quantity - want).abs() <= 0.05 + 1e-9,
            "{} vs {want}",
            pla.quantity
        );
        let nylon = bom_row(&bom, "nylon (PA) filament (printed parts)");
        let want = mass("nylon (PA)", NYLON_G_PER_CM3);
        assert!(
            (nylon.quantity - want).abs() <= 0.05 + 1e-9,
            "{} vs {want}",
            nylon.quantity
        );
        // The upper cap's mass against its dimensions: a disc of outer radius r_t + 5 mm, 6 mm
        // thick, less three ⌀2 tendon holes and three ⌀6.2 × 3.2 magnet pockets (the mesh's
        // 96-gon circles are within 0.07 % of the area).
        let cap = parts.iter().find(|p| p.name == "upper-cap").unwrap();
        let disc = std::f64::consts::PI * (r_t + 5.0).powi(2) * 6.0;
        let holes = 3.0 * std::f64::consts::PI * (1.0f64.powi(2) * 6.0 + 3.1f64.powi(2) * 3.2);
        let nominal_g = (disc - holes) / 1000.0 * NYLON_G_PER_CM3;
        assert!(
            (cap.mass_g() - nominal_g).abs() / nominal_g < 1e-3,
            "{} vs {nominal_g}",
            cap.mass_g()
        );
        assert!((nylon.quantity - cap.mass_g()).abs() <= 0.05 + 1e-9);
        // Hardware: three magnets in the upper cap and three in the gripper mount, the
        // gripper's four M3 screws, three tendons.
        assert_eq!(bom_row(&bom, "disc magnet").quantity, 6.0);
        assert_eq!(bom_row(&bom, "M3 screw").quantity, 4.0);
        let line = bom_row(&bom, "tendon line");
        assert_eq!(line.quantity, 3.0);
        assert!(
            line.specification.contains(&format!("r = {r_t} mm")),
            "{}",
            line.specification
        );
    }
    // The kit: two leaves per hinge, their PLA-CF, one pin per hinge, screws sized from the
    // panel thickness.
    let paper = trunk(3, &[(31.72, 4)], 609.6);
    let kit = Kit::new(&paper);
    for panel_mm in [6.0, 10.0] {
        let params = PartParams {
            panel_mm,
            ..Default::default()
        };
        let leaf = hinge_leaf(&params, kit.hinges.len()).unwrap();
        let bom = Bom::kit(&kit, None, &leaf);
        assert_eq!(bom_row(&bom, "hinge").quantity, 180.0);
        let leaves = bom_row(&bom, "hinge leaf (hinge-leaf.stl / .3mf)");
        assert_eq!((leaves.quantity, leaves.section), (360.0, "printed"));
        assert!(
            leaves.specification.starts_with("PLA-CF: "),
            "{}",
            leaves.specification
        );
        let filament = bom_row(&bom, "PLA-CF filament (printed parts)");
        let want = 360.0 * leaf.mesh.volume() / 1000.0 * PLA_CF_G_PER_CM3;
        assert!(
            (filament.quantity - want).abs() <= 0.05 + 1e-9,
            "{} vs {want}",
            filament.quantity
        );
        // A leaf's volume from its dimensions (`Part::nominal_volume_mm3`) within 0.1 %.
        assert!(
            (leaf.mesh.volume() - leaf.nominal_volume_mm3).abs() / leaf.nominal_volume_mm3 < 1e-3
        );
        let pin = bom_row(&bom, "hinge pin");
        assert_eq!(pin.quantity, 180.0);
        // The hinge is 35.6 mm along the crease: the longest stock pin within it is 35 mm.
        assert!(
            pin.specification.contains("⌀3 × 35 mm"),
            "{}",
            pin.specification
        );
        let screw = bom_row(&bom, "M4 screw");
        assert_eq!(screw.quantity, 720.0);
        // Leaf 3 mm + insert 5.7 mm = 8.7, rounded down to the stock M4 × 8.
        assert!(
            screw.specification.contains("M4 × 8 "),
            "{}",
            screw.specification
        );
        let insert = bom_row(&bom, "M4 heat-set insert");
        assert!(
            insert
                .specification
                .contains(&format!("the {panel_mm} mm HDPE")),
            "{}",
            insert.specification
        );
        assert!(bom.rows.iter().all(|r| r.section != "electronics"));
    }
}

/// Vertices and triangles of the first object of a 3MF model's XML.
fn read_3mf_mesh(model: &str) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let attr = |tag: &str, key: &str| -> f64 {
        let tag = format!(" {tag}");
        let i = tag.find(&format!(" {key}=\"")).unwrap() + key.len() + 3;
        tag[i..i + tag[i..].find('"').unwrap()].parse().unwrap()
    };
    let vertices = model
        .split("<vertex ")
        .skip(1)
        .map(|t| [attr(t, "x"), attr(t, "y"), attr(t, "z")])
        .collect();
    let triangles = model
        .split("<triangle ")
        .skip(1)
        .map(|t| {
            [
                attr(t, "v1") as usize,
                attr(t, "v2") as usize,
                attr(t, "v3") as usize,
            ]
        })
        .collect();
    (vertices, triangles)
}

#[test]
fn every_part_3mf_holds_its_mesh_in_mm_with_its_material_and_quantity() {
    let crane = trunk(3, &[(35.0, 2), (31.72, 2)], 75.0);
    let parts = fabrication::parts::all_parts(&crane, &PartParams::default(), 180).unwrap();
    for part in &parts {
        let bytes = part.model("test").to_bytes().unwrap();
        let mut zip = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
        let mut model = String::new();
        std::io::Read::read_to_string(&mut zip.by_name("3D/3dmodel.model").unwrap(), &mut model)
            .unwrap();
        assert!(model.contains(r#"<model unit="millimeter""#));
        assert_eq!(model.matches("<object ").count(), 1);
        assert_eq!(model.matches("<item ").count(), 1);
        assert!(model.contains(&format!(r#"<base name="{}""#, part.material.name)));
        for (k, v) in [
            ("ys:part", part.name.to_string()),
            ("ys:quantity", part.quantity.to_string()),
            ("ys:material", part.material.name.to_string()),
            ("ys:density_g_per_cm3", part.material.g_per_cm3.to_string()),
        ] {
            assert!(
                model.contains(&format!(r#"<metadata name="{k}">{v}</metadata>"#)),
                "{}: {k}",
                part.name
            );
        }
        // The mesh read back from the XML: the same triangles, the volume within 1e-6
        // relative (coordinates are written to 1e-6 mm).
        let (v, t) = read_3mf_mesh(&model);
        assert_eq!(
            (v.len(), t.len()),
            (part.mesh.vertices.len(), part.mesh.triangles.len())
        );
        let volume: f64 = t
            .iter()
            .map(|&[i, j, k]| {
                let (a, b, c) = (v[i], v[j], v[k]);
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum();
        let rel = (volume - part.mesh.volume()).abs() / part.mesh.volume();
        assert!(
            rel < 1e-6,
            "{}: {volume} vs {} ({rel:e})",
            part.name,
            part.mesh.volume()
        );
    }
    let materials: Vec<(&str, &str)> = parts.iter().map(|p| (p.name, p.material.name)).collect();
    assert_eq!(
        materials,
        [
            ("hinge-leaf", "PLA-CF"),
            ("upper-cap", "nylon (PA)"),
            ("lower-cap", "PLA"),
            ("tendon-locator", "PLA"),
            ("gripper-mount", "PLA"),
        ]
    );
}
