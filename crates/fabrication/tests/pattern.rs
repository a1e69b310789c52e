//! Geometry of the crease pattern and of its folded frames.
//!
//! Tolerances: flat lengths and angles are exact constructions, checked to 1e-12 (l, rad);
//! folded frames of feasible states must be isometric to the flat pattern on every face to
//! 1e-9 l (the bound; observed ≲ 1e-14, printed by `isometry_error_is_reported`).

use fabrication::folded::{fold, fold_angles, LayerState};
use fabrication::pattern::{LineKind, Pattern, VertexRole};
use fabrication::{Module, Trunk};
use geometry::{ModuleDesign, ShapeState};

const GOLDEN: f64 = 31.717_474_411_461_005;

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

fn crane() -> Trunk {
    trunk(3, &[(35.0, 2), (31.72, 2)], 75.0)
}

fn dist(p: &Pattern, a: usize, b: usize) -> f64 {
    let (u, v) = (p.vertices[a], p.vertices[b]);
    ((u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2)).sqrt()
}

fn angle_at(p: &Pattern, at: usize, a: usize, b: usize) -> f64 {
    let o = p.vertices[at];
    let (u, v) = (p.vertices[a], p.vertices[b]);
    let (ux, uy, vx, vy) = (u[0] - o[0], u[1] - o[1], v[0] - o[0], v[1] - o[1]);
    (ux * vy - uy * vx).abs().atan2(ux * vx + uy * vy)
}

fn designs() -> Vec<Trunk> {
    vec![
        crane(),
        trunk(3, &[(GOLDEN, 3)], 50.0),
        trunk(4, &[(23.362_132, 1), (30.0, 2)], 65.0),
        trunk(6, &[(15.104_295, 2)], 20.0),
        trunk(5, &[(40.0, 1)], 1.0),
        trunk(12, &[(60.0, 1), (10.0, 1)], 10.0),
    ]
}

#[test]
fn every_valley_fold_has_length_l_and_every_mountain_length_a() {
    for t in designs() {
        let p = Pattern::new(&t, 0.0).unwrap();
        let n = t.n() as usize;
        for (k, &(_, d)) in p.layers().iter().enumerate() {
            for i in 0..n {
                // Mountain folds of layer k.
                let pi = p.p(k, i);
                for v in [p.b(k, i), p.b(k, i + 1), p.b(k + 1, i), p.b(k + 1, i + 1)] {
                    assert!((dist(&p, v, pi) - d.a()).abs() < 1e-12);
                    assert!(p
                        .edges
                        .iter()
                        .any(|e| e.kind == LineKind::Mountain && e.v == [v, pi]));
                }
                // Mid valley fold P_{i}P_{i+1} (split at X_{i+1}) and boundary valley fold
                // B_iB_{i+1} (split at E_i): length 1, straight through the split point.
                let x = p.x(k, i + 1);
                let pn = if i + 1 < n { p.p(k, i + 1) } else { p.p(k, 0) };
                if i + 1 < n {
                    assert!((dist(&p, pi, pn) - 1.0).abs() < 1e-12);
                    assert!((dist(&p, pi, x) + dist(&p, x, pn) - 1.0).abs() < 1e-12);
                }
                let (b0, e, b1) = (p.b(k, i), p.e(k, i), p.b(k, i + 1));
                assert!((dist(&p, b0, b1) - 1.0).abs() < 1e-12);
                assert!((dist(&p, b0, e) + dist(&p, e, b1) - 1.0).abs() < 1e-12);
            }
        }
        // Every valley and mountain edge has one of those lengths.
        for e in &p.edges {
            let len = p.edge_length(e);
            match e.kind {
                LineKind::Valley => assert!((len - 0.5).abs() < 1e-12, "{len}"),
                LineKind::Mountain => {
                    assert!(p.layers().iter().any(|(_, d)| (len - d.a()).abs() < 1e-12))
                }
                _ => {}
            }
        }
    }
}

#[test]
fn facet_angles_equal_beta_and_module_height_equals_w() {
    for t in designs() {
        let p = Pattern::new(&t, 0.0).unwrap();
        let n = t.n() as usize;
        let mut y = 0.0;
        for (k, &(_, d)) in p.layers().iter().enumerate() {
            assert!((p.row_y(k + 1) - p.row_y(k) - d.w()).abs() < 1e-12);
            y += d.w();
            for i in 0..n {
                let beta = d.beta();
                let pi = p.p(k, i);
                // Inner triangles: base angles at B_i, B_{i+1}, T_i, T_{i+1}.
                let (b0, b1) = (p.b(k, i), p.b(k, i + 1));
                let (t0, t1) = (p.b(k + 1, i), p.b(k + 1, i + 1));
                for (at, other) in [(b0, b1), (b1, b0), (t0, t1), (t1, t0)] {
                    assert!((angle_at(&p, at, other, pi) - beta).abs() < 1e-12);
                }
                // Rhombus triangles: base angles at the P ends of the mid valley fold.
                if i + 1 < n {
                    let pn = p.p(k, i + 1);
                    for apex in [p.b(k, i + 1), p.b(k + 1, i + 1)] {
                        assert!((angle_at(&p, pi, pn, apex) - beta).abs() < 1e-12);
                        assert!((angle_at(&p, pn, pi, apex) - beta).abs() < 1e-12);
                    }
                }
            }
        }
        assert!((p.height() - y).abs() < 1e-12);
        assert!((p.height() - t.flat_height()).abs() < 1e-12);
        assert!((p.width() - n as f64).abs() < 1e-15);
    }
}

#[test]
fn the_pattern_is_a_disk_with_8n_faces_per_layer() {
    for t in designs() {
        let p = Pattern::new(&t, 5.0f64.min(t.edge_mm() / 2.0)).unwrap();
        let n = t.n() as usize;
        assert_eq!(p.faces.len(), 8 * n * t.layer_count());
        // Euler characteristic of a disk.
        let chi = p.vertices.len() as i64 - p.edges.len() as i64 + p.faces.len() as i64;
        assert_eq!(chi, 1);
        // Counter-clockwise faces of positive area, tiling the sheet exactly.
        let mut area = 0.0;
        for f in &p.faces {
            let [a, b, c] = f.v.map(|v| p.vertices[v]);
            let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            assert!(cross > 0.0);
            area += 0.5 * cross;
        }
        assert!((area - p.width() * p.height()).abs() < 1e-9);
        // Every non-boundary edge has a face on each side, boundary edges one.
        let adj = fabrication::folded::edge_faces(&p);
        for (e, f) in p.edges.iter().zip(adj) {
            let sides = f.iter().filter(|x| x.is_some()).count();
            assert_eq!(sides, if e.kind == LineKind::Boundary { 1 } else { 2 });
        }
    }
}

#[test]
fn maekawa_holds_at_every_interior_vertex() {
    for t in designs() {
        let p = Pattern::new(&t, 0.0).unwrap();
        let interior = p.interior_vertices();
        // All P, and the B/E/X of inner rows away from the seam, are interior.
        let n = t.n() as usize;
        let layers = t.layer_count();
        let expected = layers * n // P
            + (layers - 1) * (n - 1) + (layers - 1) * n // B, E of inner rows
            + layers * (n - 1); // X
        assert_eq!(interior.len(), expected);
        for v in interior {
            let (mut m, mut val) = (0i32, 0i32);
            for e in p.edges.iter().filter(|e| e.v.contains(&v)) {
                match e.kind {
                    LineKind::Mountain => m += 1,
                    LineKind::Valley => val += 1,
                    _ => {}
                }
            }
            assert_eq!(
                (m - val).abs(),
                2,
                "vertex {v} {:?}: M {m} V {val}",
                p.roles[v]
            );
        }
    }
}

fn all_layers(p: &Pattern, s: LayerState) -> Vec<LayerState> {
    vec![s; p.layers().len()]
}

fn feasible_frames(t: &Trunk) -> Vec<Vec<LayerState>> {
    let p = Pattern::new(t, 0.0).unwrap();
    let first = p.layers()[0].1;
    let mut frames: Vec<Vec<LayerState>> = first
        .shape_states()
        .filter(|s| {
            p.layers().iter().all(|(_, d)| {
                let info = d.state_info(*s);
                info.feasible && info.max_strain <= geometry::catalogue::EXACT_TOLERANCE
            })
        })
        .map(|s| all_layers(&p, LayerState::Shape(s)))
        .collect();
    if p.layers()
        .iter()
        .all(|(_, d)| *d == first && d.can_self_pack())
    {
        frames.push(all_layers(&p, LayerState::SelfPacked));
    }
    frames
}

#[test]
fn feasible_folded_frames_are_isometric_on_every_face() {
    let mut worst: f64 = 0.0;
    let mut count = 0;
    for t in designs().into_iter().chain([
        trunk(3, &[(30.0, 2)], 10.0),
        trunk(3, &[(45.0, 2)], 10.0),
        trunk(4, &[(22.725_444, 2)], 10.0),
        trunk(8, &[(11.274_698, 1)], 10.0),
    ]) {
        let p = Pattern::new(&t, 0.0).unwrap();
        for states in feasible_frames(&t) {
            let f = fold(&p, &states).unwrap();
            assert!(f.feasible);
            assert!(
                f.max_strain <= 1e-9 && f.max_length_error <= 1e-9,
                "{} {:?}: strain {}",
                t.describe(),
                states[0],
                f.max_strain
            );
            worst = worst.max(f.max_strain);
            count += 1;
        }
    }
    // Golden n = 3: every catalogue state plus self-packed.
    assert!(count >= 20, "{count} frames");
    eprintln!("largest face strain over {count} feasible frames: {worst:e}");
}

#[test]
fn the_golden_module_folds_isometrically_in_every_state_and_mixed_stacks() {
    let t = trunk(3, &[(GOLDEN, 4)], 609.6);
    let p = Pattern::new(&t, 0.0).unwrap();
    let d = p.layers()[0].1;
    let all: Vec<LayerState> = d
        .shape_states()
        .map(LayerState::Shape)
        .chain([LayerState::SelfPacked])
        .collect();
    assert_eq!(all.len(), 9);
    for s in &all {
        let f = fold(&p, &all_layers(&p, *s)).unwrap();
        assert!(f.max_strain < 1e-9, "{s}: {}", f.max_strain);
    }
    // Mixed catalogue states layer by layer chain exactly too.
    let mixed = [
        LayerState::Shape(ShapeState::Edge(1)),
        LayerState::Shape(ShapeState::Deployed),
        LayerState::Shape(ShapeState::Vertex(2)),
        LayerState::Shape(ShapeState::Folded),
    ];
    let f = fold(&p, &mixed).unwrap();
    assert!(f.max_strain < 1e-9, "{}", f.max_strain);
}

#[test]
fn infeasible_states_show_their_strain() {
    // n = 3, β = 35°: the pop-outs leave a 6.6 % (edge) / 7.1 % (vertex) residual.
    let t = trunk(3, &[(35.0, 2)], 75.0);
    let p = Pattern::new(&t, 0.0).unwrap();
    for s in [ShapeState::Edge(0), ShapeState::Vertex(1)] {
        let f = fold(&p, &all_layers(&p, LayerState::Shape(s))).unwrap();
        assert!(!f.feasible);
        assert!(f.max_strain > 0.02, "{s}: {}", f.max_strain);
    }
    // Self-packed modules of different β do not share a boundary: the upper module strains.
    let f = fold(
        &Pattern::new(&crane(), 0.0).unwrap(),
        &[LayerState::SelfPacked; 4],
    )
    .unwrap();
    assert!(f.max_strain > 1e-3, "{}", f.max_strain);
}

#[test]
fn fold_angles_follow_the_assignment_in_the_folded_state() {
    for t in [
        crane(),
        trunk(4, &[(30.0, 2)], 10.0),
        trunk(6, &[(50.0, 1)], 10.0),
    ] {
        let p = Pattern::new(&t, 0.0).unwrap();
        let f = fold(&p, &all_layers(&p, LayerState::Shape(ShapeState::Folded))).unwrap();
        assert!(f.max_strain < 1e-9);
        let a = fold_angles(&p, &f);
        for (e, ang) in p.edges.iter().zip(&a) {
            match e.kind {
                LineKind::Mountain => assert!(*ang < -1.0, "mountain {ang}"),
                LineKind::Valley => assert!(*ang > 1.0, "valley {ang}"),
                LineKind::Boundary => assert_eq!(*ang, 0.0),
                // Folded columns fold along the mid valley fold: the virtual creases stay flat.
                LineKind::Virtual | LineKind::Cut => assert!(ang.abs() < 1e-6, "virtual {ang}"),
            }
        }
        // Deployed is the n-gonal prism (d = w, P_i at the centre of each flat side): every
        // rhombus folds along its virtual crease B_jT_j by the polygon's exterior angle 360°/n
        // as a mountain (a convex edge seen from outside); every other line stays flat.
        let f = fold(&p, &all_layers(&p, LayerState::Shape(ShapeState::Deployed))).unwrap();
        assert!(f.max_strain < 1e-9);
        let a = fold_angles(&p, &f);
        let exterior = 360.0 / t.n() as f64;
        for (e, ang) in p.edges.iter().zip(&a) {
            let rhombus_diagonal = e.kind == LineKind::Virtual
                && e.v
                    .iter()
                    .any(|&v| matches!(p.roles[v], VertexRole::X { .. }))
                && e.v
                    .iter()
                    .any(|&v| matches!(p.roles[v], VertexRole::B { .. }));
            if rhombus_diagonal {
                assert!((ang + exterior).abs() < 1e-9, "diagonal {ang}");
            } else {
                assert!(ang.abs() < 1e-9, "{:?} {ang}", e.kind);
            }
        }
    }
}

#[test]
fn seam_copies_coincide_when_folded() {
    let t = crane();
    let p = Pattern::new(&t, 5.0).unwrap();
    let f = fold(&p, &all_layers(&p, LayerState::Shape(ShapeState::Deployed))).unwrap();
    let n = t.n() as usize;
    for row in 0..=t.layer_count() {
        assert!((f.coords[p.b(row, 0)] - f.coords[p.b(row, n)]).norm() == 0.0);
    }
    // The deployed crane trunk's height is Σ w (straight, d = w per layer).
    let top = f.coords[p.b(t.layer_count(), 0)].z;
    assert!((top - t.flat_height()).abs() < 1e-12);
}

#[test]
fn states_are_parsed_against_each_design() {
    let d35 = ModuleDesign::new(3, 35.0).unwrap();
    let d20 = ModuleDesign::new(3, 20.0).unwrap();
    assert!(LayerState::parse(&d35, "self-packed").is_ok());
    assert!(LayerState::parse(&d35, " Edge-2 ").is_ok());
    let e = LayerState::parse(&d20, "folded").unwrap_err().to_string();
    assert!(e.contains("folded needs β ≥ 90°/n = 30.0000°"), "{e}");
    let e = LayerState::parse(&d20, "self-packed")
        .unwrap_err()
        .to_string();
    assert!(e.contains("(30.0000°, 45°]"), "{e}");
    assert!(LayerState::parse(&d35, "flat-folded").is_err());
    let e = LayerState::parse(&d35, "edge-3").unwrap_err().to_string();
    assert!(e.contains("edge-0 … edge-2"), "{e}");
    assert!(LayerState::parse(&ModuleDesign::new(3, 30.0).unwrap(), "flat-folded").is_ok());
}

#[test]
fn seam_allowance_range_is_enforced() {
    let t = crane();
    assert!(Pattern::new(&t, 0.0).is_ok());
    assert!(Pattern::new(&t, 37.5).is_ok());
    for bad in [-0.1, 37.6, f64::NAN, f64::INFINITY] {
        let e = Pattern::new(&t, bad).unwrap_err().to_string();
        assert!(e.contains("[0, 37.5] mm"), "{e}");
    }
    let p = Pattern::new(&t, 5.0).unwrap();
    let cuts: Vec<_> = p
        .lines()
        .into_iter()
        .filter(|l| l.2 == LineKind::Cut)
        .collect();
    assert_eq!(cuts.len(), 3);
    assert!(Pattern::new(&t, 0.0).unwrap().tab().is_empty());
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Deployed and folded (where it exists) are exact for every (n, β): the folded frames
        /// are isometric to 1e-9 l whatever the design, layer count or module mix.
        #[test]
        fn deployed_and_folded_are_isometric_for_any_design(
            n in 3u32..=16,
            b1 in 0.5f64..89.5,
            b2 in 0.5f64..89.5,
            layers in 1usize..=3,
        ) {
            let t = trunk(n, &[(b1, layers), (b2, 1)], 10.0);
            let p = Pattern::new(&t, 0.0).unwrap();
            let f = fold(&p, &all_layers(&p, LayerState::Shape(ShapeState::Deployed))).unwrap();
            prop_assert!(f.max_strain <= 1e-9, "deployed {}", f.max_strain);
            let ff = 90.0 / n as f64;
            if b1 >= ff && b2 >= ff {
                let f = fold(&p, &all_layers(&p, LayerState::Shape(ShapeState::Folded))).unwrap();
                prop_assert!(f.max_strain <= 1e-9, "folded {}", f.max_strain);
            }
        }

        /// Self-packed layers of one β close exactly over the whole range (90°/n, 45°].
        #[test]
        fn self_packed_is_isometric_over_its_range(n in 3u32..=12, s in 0.001f64..=1.0, layers in 1usize..=3) {
            let ff = 90.0 / n as f64;
            let beta = ff + s * (45.0 - ff);
            let t = trunk(n, &[(beta, layers)], 10.0);
            let p = Pattern::new(&t, 0.0).unwrap();
            let f = fold(&p, &all_layers(&p, LayerState::SelfPacked)).unwrap();
            prop_assert!(f.max_strain <= 1e-9, "β = {beta}: {}", f.max_strain);
        }
    }

    #[test]
    fn extreme_designs_build_and_fold() {
        for (n, b) in [
            (3u32, 0.001),
            (3, 89.999),
            (64, 0.001),
            (64, 89.999),
            (64, 45.0),
        ] {
            let t = trunk(n, &[(b, 1)], 1.0);
            let p = Pattern::new(&t, 0.5).unwrap();
            assert_eq!(p.faces.len(), 8 * n as usize);
            let f = fold(&p, &all_layers(&p, LayerState::Shape(ShapeState::Deployed))).unwrap();
            // Slivers of height w/2 ≈ 9e-6 l at 0.001°: the absolute 1e-9 l bound.
            assert!(
                f.max_length_error <= 1e-9,
                "n {n} β {b}: {}",
                f.max_length_error
            );
            assert!(f.coords.iter().all(|c| c.iter().all(|x| x.is_finite())));
        }
    }
}

#[test]
fn kawasaki_holds_except_where_two_modules_of_different_beta_meet() {
    // Alternating sum of the sector angles between consecutive M/V creases around a vertex:
    // π at every interior vertex of one β; π + 2(β_above − β_below) on a module interface.
    for t in designs() {
        let p = Pattern::new(&t, 0.0).unwrap();
        for v in p.interior_vertices() {
            let o = p.vertices[v];
            let mut dirs: Vec<f64> = p
                .edges
                .iter()
                .filter(|e| {
                    e.v.contains(&v) && matches!(e.kind, LineKind::Mountain | LineKind::Valley)
                })
                .map(|e| {
                    let w = p.vertices[if e.v[0] == v { e.v[1] } else { e.v[0] }];
                    (w[1] - o[1]).atan2(w[0] - o[0])
                })
                .collect();
            dirs.sort_by(f64::total_cmp);
            let k = dirs.len();
            let sectors: Vec<f64> = (0..k)
                .map(|i| {
                    let d = dirs[(i + 1) % k] - dirs[i];
                    if i + 1 == k {
                        d + std::f64::consts::TAU
                    } else {
                        d
                    }
                })
                .collect();
            let even: f64 = sectors.iter().step_by(2).sum();
            let expected = match p.roles[v] {
                VertexRole::B { row, .. } if p.layers()[row].1 != p.layers()[row - 1].1 => {
                    let (below, above) = (p.layers()[row - 1].1.beta(), p.layers()[row].1.beta());
                    // Either alternating sum, depending on where the sort starts.
                    let d = std::f64::consts::PI + 2.0 * (above - below);
                    if (even - d).abs() < 1e-9 {
                        d
                    } else {
                        std::f64::consts::TAU - d
                    }
                }
                _ => std::f64::consts::PI,
            };
            assert!(
                (even - expected).abs() < 1e-9,
                "{:?}: {even} vs {expected}",
                p.roles[v]
            );
        }
    }
}
