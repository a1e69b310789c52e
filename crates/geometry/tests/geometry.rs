//! Verification of the geometry crate: every catalogue state is built in 3D and its defining
//! property checked, with stated tolerances. One integration binary for the crate.

use core::f64::consts::PI;

use approx::assert_relative_eq;
use geometry::{
    construct::ColumnFold, fk, popout, DesignError, Module3d, ModuleDesign, Pose, ShapeState,
    SymmetricState,
};
use nalgebra::{Point3, Vector3};
use proptest::prelude::*;

/// Closed forms that should close exactly: this much float error allowed (lengths in l).
const EXACT: f64 = 1e-9;
/// β of the golden-ratio module, tan β = 1/φ.
fn golden_beta_deg() -> f64 {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    (1.0 / phi).atan().to_degrees()
}

fn design(n: u32, beta_deg: f64) -> ModuleDesign {
    ModuleDesign::new(n, beta_deg).unwrap()
}

// ---------------------------------------------------------------- design and names

#[test]
fn design_rejects_invalid_input_with_a_message_saying_what_is_valid() {
    assert_eq!(ModuleDesign::new(2, 30.0), Err(DesignError::TooFewSides(2)));
    assert_eq!(
        ModuleDesign::new(65, 30.0),
        Err(DesignError::TooManySides(65))
    );
    assert_eq!(
        ModuleDesign::new(3, f64::NAN),
        Err(DesignError::BetaNotFinite)
    );
    assert_eq!(
        ModuleDesign::new(3, f64::INFINITY),
        Err(DesignError::BetaNotFinite)
    );
    for b in [0.0, 90.0, -1.0, 120.0] {
        assert_eq!(ModuleDesign::new(3, b), Err(DesignError::BetaOutOfRange(b)));
    }
    assert!(design(3, 30.0).with_edge_mm(0.0).is_err());
    assert!(design(3, 30.0).with_edge_mm(f64::NAN).is_err());
    assert_eq!(
        design(3, 30.0).with_edge_mm(75.0).unwrap().mm_per_l(),
        Some(75.0)
    );
    let msg = DesignError::TooFewSides(2).to_string();
    assert!(msg.contains("[3, 64]"), "{msg}");
    assert!(DesignError::BetaOutOfRange(95.0)
        .to_string()
        .contains("between 0 and 90"));
}

#[test]
fn design_quantities_follow_eqs_1_to_3() {
    let d = design(4, 35.0);
    let b = 35f64.to_radians();
    assert_relative_eq!(d.w(), b.tan(), epsilon = 1e-15);
    assert_relative_eq!(d.a(), 1.0 / (2.0 * b.cos()), epsilon = 1e-15);
    assert_relative_eq!(
        d.r(),
        1.0 / (2.0 * 45f64.to_radians().sin()),
        epsilon = 1e-15
    );
    // Eq 3 polygon: unit edges, circumradius r.
    for n in 3..=12 {
        let d = design(n, 30.0);
        for i in 0..n {
            let (p, q) = (d.bottom_vertex(i), d.bottom_vertex(i + 1));
            assert_relative_eq!((q - p).norm(), 1.0, epsilon = 1e-12);
            assert_relative_eq!(p.coords.norm(), d.r(), epsilon = 1e-12);
        }
    }
}

#[test]
fn catalogue_has_2n_plus_2_states_in_order_and_names_round_trip() {
    for n in 3..=12u32 {
        let d = design(n, 35.0);
        let states: Vec<ShapeState> = d.shape_states().collect();
        assert_eq!(states.len(), 2 * (n as usize + 1));
        assert_eq!(states[0], ShapeState::Deployed);
        assert_eq!(states[1], ShapeState::Folded);
        for i in 0..n as u8 {
            assert_eq!(states[2 + i as usize], ShapeState::Edge(i));
            assert_eq!(states[2 + n as usize + i as usize], ShapeState::Vertex(i));
        }
        for (k, s) in states.iter().enumerate() {
            assert_eq!(s.index(n), k);
            assert_eq!(ShapeState::parse(&s.to_string(), n), Ok(*s));
        }
    }
    assert_eq!(ShapeState::Edge(3).to_string(), "edge-3");
    assert_eq!(ShapeState::Vertex(0).to_string(), "vertex-0");
    assert_eq!(ShapeState::parse(" Edge-2 ", 3), Ok(ShapeState::Edge(2)));
}

#[test]
fn unknown_or_out_of_range_state_names_are_rejected_listing_valid_ones() {
    for bad in [
        "",
        "edge",
        "edge-",
        "edge-3",
        "vertex-9",
        "edge--1",
        "edge-+1",
        "flat",
        "edge-1x",
        "vertex-99999999999",
    ] {
        let err = ShapeState::parse(bad, 3).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("deployed, folded, edge-0 … edge-2, vertex-0 … vertex-2"),
            "{bad}: {msg}"
        );
    }
}

// ---------------------------------------------------------------- eq 5

proptest! {
    #[test]
    fn closed_form_isometry_is_eq_5s_product(d in 0.0f64..3.0, g in 0.0f64..PI, p in -7.0f64..7.0) {
        let pose = Pose::new(d, g, p);
        let (a, b) = (pose.isometry().to_homogeneous(), pose.isometry_by_factors().to_homogeneous());
        prop_assert!((a - b).abs().max() < 1e-12);
        prop_assert!((pose.matrix() - a).abs().max() == 0.0);
        // d is the distance between the centroids; the mid-plane normal is the slant axis.
        prop_assert!((pose.tip().coords.norm() - d).abs() < 1e-12);
        if d > 1e-6 {
            prop_assert!((pose.tip().coords / d - pose.mid_plane_normal()).norm() < 1e-12);
        }
    }

    #[test]
    fn the_mid_plane_mirrors_every_bottom_vertex_onto_its_top_vertex(
        n in 3u32..=12, beta in 5.0f64..85.0, d in 0.0f64..2.0, g in 0.0f64..(PI / 2.0), p in 0.0f64..(2.0 * PI)
    ) {
        let m = Module3d::build(&design(n, beta), &Pose::new(d, g, p));
        let normal = Pose::new(d, g, p).mid_plane_normal();
        let c = normal.dot(&((m.bottom()[0].coords + m.top()[0].coords) / 2.0));
        for (b, t) in m.bottom().iter().zip(m.top()) {
            // top edge lengths stay 1 (T is rigid); B→T is along the normal; midpoint on the plane.
            prop_assert!(((t - b) - normal * normal.dot(&(t - b))).norm() < 1e-9);
            prop_assert!((normal.dot(&((b.coords + t.coords) / 2.0)) - c).abs() < 1e-9);
        }
        for i in 0..n as usize {
            // every mid-plane point P_i lies on the mid-plane
            prop_assert!((normal.dot(&m.mid()[i].coords) - c).abs() < 1e-9);
        }
    }
}

// ---------------------------------------------------------------- the golden module

#[test]
fn golden_ratio_n3_module_closes_every_state_exactly() {
    let d = design(3, golden_beta_deg());
    for s in d.shape_states() {
        let info = d.state_info(s);
        assert!(info.feasible, "{s}");
        assert!(info.max_strain < 1e-12, "{s}: {}", info.max_strain);
        let m = d.build(s);
        for i in 0..3 {
            assert!(m.mountain_length_error(i) < 1e-12, "{s}");
        }
    }
    assert_relative_eq!(
        popout::beta_in_deg(3).unwrap(),
        golden_beta_deg(),
        epsilon = 1e-9
    );
    assert_relative_eq!(
        popout::beta_out_deg(3).unwrap(),
        golden_beta_deg(),
        epsilon = 1e-9
    );
}

// ---------------------------------------------------------------- symmetric states

fn assert_all_creases_exact(m: &Module3d) {
    let n = m.design().n() as usize;
    let (a, w) = (m.design().a(), m.design().w());
    for j in 0..n {
        let k = (j + 1) % n;
        assert!(((m.top()[k] - m.top()[j]).norm() - 1.0).abs() < EXACT);
        assert!(m.mountain_length_error(j) < EXACT, "mountain {j}");
        for x in [m.bottom()[j], m.bottom()[k], m.top()[j], m.top()[k]] {
            assert!(((x - m.mid()[j]).norm() - a).abs() < EXACT);
        }
        assert!(m.column(j).0 < EXACT, "rhombus {j}: {:?}", m.column(j));
        assert!(m.column_length(j) <= w + EXACT);
        assert!(m.mid_fold_length(j) <= 1.0 + EXACT);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn deployed_closes_with_every_column_stretched_to_w(n in 3u32..=12, beta in 0.5f64..89.5) {
        let d = design(n, beta);
        let info = d.state_info(ShapeState::Deployed);
        prop_assert!(info.feasible && info.max_strain < EXACT);
        prop_assert_eq!(info.theta, Some(PI));
        let m = d.build(ShapeState::Deployed);
        assert_all_creases_exact(&m);
        for j in 0..n as usize {
            prop_assert_eq!(m.column(j).1, ColumnFold::Stretched);
            prop_assert!((m.theta_in(j) - PI).abs() < 1e-6 && (m.theta_out(j) - PI).abs() < 1e-6);
        }
    }

    #[test]
    fn folded_closes_with_theta_from_eq_11_for_beta_above_90_over_n(n in 3u32..=12, t in 0.0f64..1.0) {
        let lo = 90.0 / n as f64;
        let beta = lo + 1e-6 + t * (89.5 - lo);
        let d = design(n, beta);
        let info = d.state_info(ShapeState::Folded);
        prop_assert!(info.feasible && info.max_strain < EXACT, "{}", info.max_strain);
        let theta = info.theta.unwrap();
        // eq 10 and eq 11 (with tan β where Table 1 has tan(θ/2))
        prop_assert!((info.pose.d - d.w() * (theta / 2.0).sin()).abs() < 1e-12);
        prop_assert!((d.w() * (theta / 2.0).cos() - (PI / (2.0 * n as f64)).tan()).abs() < 1e-12);
        let m = d.build(ShapeState::Folded);
        assert_all_creases_exact(&m);
        for j in 0..n as usize {
            // every column folded along the mid valley fold; θ_in = θ_out = θ
            prop_assert!((m.mid_fold_length(j) - 1.0).abs() < EXACT);
            prop_assert!((m.theta_in(j) - theta).abs() < 1e-6);
            prop_assert!((m.theta_out(j) - theta).abs() < 1e-6);
        }
    }

    #[test]
    fn folded_does_not_exist_below_90_over_n(n in 3u32..=12, t in 0.01f64..0.99) {
        let d = design(n, t * 90.0 / n as f64);
        let info = d.state_info(ShapeState::Folded);
        prop_assert!(!info.feasible);
        prop_assert!(info.theta.is_none());
        prop_assert!(d.symmetric_pose(SymmetricState::Folded).is_none());
    }
}

#[test]
fn flat_folded_and_self_packed_ranges_follow_table_1() {
    for n in 3..=12u32 {
        let ff = design(n, 90.0 / n as f64);
        assert!(ff.is_flat_foldable());
        assert_eq!(ff.symmetric_height(SymmetricState::FlatFolded), Some(0.0));
        assert!(ff.folded_d().unwrap() < 1e-7);
        assert!(ff.zeta().is_none() && ff.self_packed().is_none());
        let above = design(n, 90.0 / n as f64 + 0.5);
        assert!(above.symmetric_pose(SymmetricState::FlatFolded).is_none());
        // ζ → 0 at the flat-foldable limit (hyperfold generalises flat folding), r_in ≥ 0
        let near = design(n, 90.0 / n as f64 + 1e-7);
        assert!(near.zeta().unwrap() < 1e-3);
        let at45 = design(n, 45.0);
        assert_eq!(at45.r_in(), Some(0.0));
        assert!(at45.zeta().is_some());
        assert!(design(n, 45.1).zeta().is_none() && design(n, 45.1).r_in().is_none());
        for k in 1..20 {
            let b = 90.0 / n as f64 + k as f64 * (45.0 - 90.0 / n as f64) / 20.0;
            let d = design(n, b);
            assert!(d.r_in().unwrap() >= 0.0);
            assert_eq!(d.self_packed(), Some(Pose::straight(0.0)));
            let z = d.zeta().unwrap();
            let s0 = (PI / (2.0 * n as f64)).sin();
            let sb = d.beta().sin();
            assert_relative_eq!(
                z.cos(),
                (2.0 * s0 * s0 - sb * sb) / (sb * sb),
                epsilon = 1e-12
            );
        }
    }
    // the crane's bottom module (n = 3, β = 35°) self-packs, its top module (31.72°) too
    assert!(design(3, 35.0).can_self_pack());
    assert_eq!(
        design(3, 35.0).symmetric_height(SymmetricState::Deployed),
        Some(35f64.to_radians().tan())
    );
}

// ---------------------------------------------------------------- self-packed (hyperfold) in 3D

/// Eq 13 as printed: cos ζ = (2 sin²(90°/n) − sin²β) / sin²β.
fn eq_13_cos_zeta(n: u32, beta: f64) -> f64 {
    let s0 = (PI / (2.0 * n as f64)).sin();
    let sb = beta.sin();
    (2.0 * s0 * s0 - sb * sb) / (sb * sb)
}

/// Eq 13 in its well-conditioned half-angle form (identical algebraically):
/// sin(ζ/2) = √(sin(β − x) sin(β + x)) / sin β, x = 90°/n.
fn eq_13_zeta(n: u32, beta: f64) -> f64 {
    let x = PI / (2.0 * n as f64);
    2.0 * (((beta - x).sin() * (beta + x).sin()).max(0.0).sqrt() / beta.sin())
        .min(1.0)
        .asin()
}

/// Azimuth of `p` measured from `from`, wrapped into (−π, π].
fn azimuth_from(p: Point3<f64>, from: f64) -> f64 {
    let a = p.y.atan2(p.x) - from;
    (a + PI).rem_euclid(2.0 * PI) - PI
}

/// Everything the self-packed module must satisfy, for β ∈ [90°/n, 45°]; the tolerances are
/// the module-wide ones: lengths EXACT (1e-9 l), angles 1e-9 rad.
fn check_self_packed(n: u32, beta_deg: f64) -> Result<(), TestCaseError> {
    let d = design(n, beta_deg);
    let m = d.build_self_packed().unwrap();
    let (beta, w) = (d.beta(), d.w());
    let nn = n as usize;
    // every crease segment keeps its flat length, including the 2n virtual creases (w/2)
    prop_assert_eq!(m.creases().count(), 8 * nn);
    prop_assert_eq!(m.virtual_creases().count(), 2 * nn);
    for c in m.virtual_creases() {
        prop_assert!((c.flat_length - 0.5 * w).abs() < 1e-15);
    }
    prop_assert!(m.max_strain() <= EXACT, "strain {}", m.max_strain());
    // fully compacted: top boundary on the bottom boundary, d = 0
    prop_assert!(m.height() <= 1e-12);
    for (t, b) in m.top().iter().zip(m.bottom()) {
        prop_assert!((t - b).norm() <= 1e-15);
    }
    // the hyperfold angle measured at every virtual crease is eq 13
    let zeta = eq_13_zeta(n, beta);
    for k in 0..2 * nn {
        let z = m.hyperfold_angle(k);
        prop_assert!((z - zeta).abs() <= 1e-9, "k {}: {} vs {}", k, z, zeta);
        prop_assert!((z.cos() - eq_13_cos_zeta(n, beta)).abs() <= 1e-9);
    }
    // the measured inner radius is eq 14
    let r_in = if (beta_deg - 45.0).abs() < 1e-12 {
        0.0
    } else {
        0.5 / (2.0 * beta).tan()
    };
    prop_assert!((m.inner_radius() - r_in).abs() <= EXACT);
    if d.can_self_pack() {
        prop_assert!((d.zeta().unwrap() - m.hyperfold_angle(0)).abs() <= 1e-9);
        prop_assert!((d.r_in().unwrap() - m.inner_radius()).abs() <= EXACT);
    }
    // each facet is a flat sector of the centre (the two half-panels in it are folded flat
    // onto each other) and lies in its own azimuth range [kπ/n, (k+1)π/n]: facets meet only
    // along their shared virtual creases, and the layer keeps r_in ≥ 0 from the centre
    for (k, tri) in m.panels() {
        let [a, b, c] = tri;
        prop_assert!(a.coords.cross(&b.coords).dot(&c.coords).abs() <= EXACT);
        for p in tri {
            if p.coords.norm() > 1e-12 {
                let az = azimuth_from(p, k as f64 * PI / n as f64);
                prop_assert!(az >= -1e-9 && az <= PI / n as f64 + 1e-9, "facet {}", k);
            }
        }
    }
    // the boundary vertices stay a planar regular n-gon (radius 1/(4 sin β cos(90°/n))); each
    // boundary edge is bent by ζ at its midpoint, so its chord is cos(ζ/2)
    let rb = 1.0 / (4.0 * beta.sin() * (PI / (2.0 * n as f64)).cos());
    for j in 0..nn {
        let b = m.bottom()[j];
        prop_assert!((b.z - m.bottom()[0].z).abs() <= 1e-12);
        prop_assert!((Vector3::new(b.x, b.y, 0.0).norm() - rb).abs() <= EXACT);
        let chord = (m.bottom()[(j + 1) % nn] - b).norm();
        prop_assert!((chord - (0.5 * zeta).cos()).abs() <= EXACT);
    }
    // thickness: B nodes at +ρ sin ε, P nodes at −ρ sin ε
    let zmax = m.bottom().iter().map(|p| p.z).fold(f64::MIN, f64::max);
    let zmin = m.mid().iter().map(|p| p.z).fold(f64::MAX, f64::min);
    prop_assert!((zmax - zmin - m.thickness()).abs() <= 1e-12);
    Ok(())
}

proptest! {
    #[test]
    fn self_packed_closes_exactly_with_zeta_of_eq_13_and_r_in_of_eq_14(
        n in 3u32..=12,
        t in 1e-6f64..=1.0,
    ) {
        let lo = 90.0 / n as f64;
        check_self_packed(n, lo + t * (45.0 - lo))?;
    }
}

#[test]
fn self_packed_degenerates_to_flat_folded_at_90_over_n() {
    for n in 3..=12u32 {
        let d = design(n, 90.0 / n as f64);
        check_self_packed(n, 90.0 / n as f64).unwrap();
        let m = d.build_self_packed().unwrap();
        assert_eq!(m.twist_elevation(), 0.0);
        assert!(m.thickness() <= 1e-15);
        for k in 0..2 * n as usize {
            assert!(m.hyperfold_angle(k) <= 1e-7, "ζ = {}", m.hyperfold_angle(k));
        }
        // boundary = eq 3's polygon, mid-plane points on the same circle at 180°/n offsets,
        // nearest panel point = the apothem: the flat-folded state of §3.1.1
        for j in 0..n {
            assert!((m.bottom()[j as usize] - d.bottom_vertex(j)).norm() <= 1e-12);
            let p = m.mid()[j as usize];
            assert_relative_eq!(p.coords.norm(), d.r(), epsilon = 1e-12);
            assert!(p.z.abs() <= 1e-15);
        }
        assert_relative_eq!(m.inner_radius(), d.apothem(), epsilon = 1e-12);
        // and the hyperfold angle grows continuously from 0 just above it
        let just = design(n, 90.0 / n as f64 + 1e-6)
            .build_self_packed()
            .unwrap();
        assert!(just.hyperfold_angle(0) > 0.0 && just.hyperfold_angle(0) < 2e-2);
        assert!(just.thickness() < 1e-2);
    }
}

#[test]
fn self_packed_r_in_vanishes_at_45_and_the_state_does_not_exist_outside_eq_15() {
    for n in 3..=12u32 {
        check_self_packed(n, 45.0).unwrap();
        let m = design(n, 45.0).build_self_packed().unwrap();
        assert!(m.inner_radius() <= 1e-15);
        // every boundary edge midpoint touches the centre: the closed end of eq 15's range
        for j in 0..n as usize {
            assert!(m.edge_bend(j).coords.norm() <= 1e-15);
            assert!(m.mid_fold_bend(j).coords.norm() <= 1e-15);
        }
        // ζ(45°) = acos(1 − 2 cos(180°/n)) (eq 13 at sin²β = 1/2)
        let z45 = (1.0 - 2.0 * (PI / n as f64).cos()).acos();
        assert_relative_eq!(m.hyperfold_angle(1), z45, epsilon = 1e-9);
        // r_in decreases monotonically to 0 over the range
        let lo = 90.0 / n as f64;
        let mut last = f64::INFINITY;
        for k in 0..=20 {
            let r = design(n, lo + k as f64 * (45.0 - lo) / 20.0)
                .build_self_packed()
                .unwrap()
                .inner_radius();
            assert!(r < last);
            last = r;
        }
        assert_eq!(
            design(n, 45.001).build_self_packed().unwrap_err(),
            geometry::SelfPackError::Above45
        );
        assert_eq!(
            design(n, lo - 0.01).build_self_packed().unwrap_err(),
            geometry::SelfPackError::BelowFlatFoldable
        );
    }
}

#[test]
fn crane_modules_self_pack_exactly_with_pinned_figures() {
    // n = 3, β = 35°: the trunk's P module (§5–6)
    let m = design(3, 35.0).build_self_packed().unwrap();
    assert!(m.max_strain() <= 1e-12);
    assert_relative_eq!(
        m.hyperfold_angle(0).to_degrees(),
        58.680_937,
        epsilon = 1e-5
    );
    assert_relative_eq!(m.inner_radius(), 0.181_985_117, epsilon = 1e-8);
    assert_relative_eq!(m.thickness(), 0.345_357_913, epsilon = 1e-8);
    assert_relative_eq!(m.twist_elevation().to_degrees(), 18.937_120, epsilon = 1e-5);
    // golden n = 3 (tan β = 1/φ): cos ζ = φ/2, i.e. ζ = 36°, and r_in = 1/4 exactly
    let g = design(3, golden_beta_deg()).build_self_packed().unwrap();
    assert!(g.max_strain() <= 1e-12);
    for k in 0..6 {
        assert_relative_eq!(g.hyperfold_angle(k).to_degrees(), 36.0, epsilon = 1e-9);
    }
    assert_relative_eq!(g.inner_radius(), 0.25, epsilon = 1e-12);
}

// ---------------------------------------------------------------- pop-out states

/// β range where a pop-out with lever λ exists: w ≤ 2λ.
fn popout_beta(lambda: f64, t: f64) -> f64 {
    let hi = (2.0 * lambda).atan().to_degrees().min(89.5);
    0.5 + t * (hi - 0.5)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn edge_i_makes_bottom_and_top_edge_coincide_and_stretches_the_far_side(
        n in 3u32..=12, i in 0u32..12, t in 0.0f64..1.0
    ) {
        let i = i % n;
        let d0 = design(n, 30.0);
        let d = design(n, popout_beta(d0.lambda_edge(), t));
        let s = ShapeState::Edge(i as u8);
        let m = d.build(s);
        let (iu, ju) = (i as usize, ((i + 1) % n) as usize);
        prop_assert!((m.bottom()[iu] - m.top()[iu]).norm() < EXACT);
        prop_assert!((m.bottom()[ju] - m.top()[ju]).norm() < EXACT);
        prop_assert!(m.theta_in(iu) < 1e-6);
        prop_assert!(m.theta_out(iu) < 1e-6 && m.theta_out(ju) < 1e-6);
        let far = (0..n as usize).map(|j| m.column_length(j)).fold(0.0, f64::max);
        prop_assert!((far - d.w()).abs() < EXACT, "far side {far} vs w {}", d.w());
        // no other vertex coincides, nothing is stretched beyond w, d ≤ w
        prop_assert!(d.pose(s).d <= d.w() + EXACT);
        prop_assert!((d.pose(s).gamma / 2.0).sin() - d.w() / (2.0 * d.lambda_edge()) < 1e-12);
        let info = d.state_info(s);
        prop_assert!(info.theta.is_none());
        prop_assert_eq!(info.feasible, info.max_strain <= geometry::STRAIN_TOLERANCE);
    }

    #[test]
    fn vertex_i_makes_the_vertex_coincide_and_stretches_the_far_side(
        n in 3u32..=12, i in 0u32..12, t in 0.0f64..1.0
    ) {
        let i = (i % n) as usize;
        let d0 = design(n, 30.0);
        let d = design(n, popout_beta(d0.lambda_vertex(), t));
        let s = ShapeState::Vertex(i as u8);
        let m = d.build(s);
        prop_assert!((m.bottom()[i] - m.top()[i]).norm() < EXACT);
        prop_assert!(m.theta_out(i) < 1e-6);
        for j in 0..n as usize {
            if j != i {
                prop_assert!(m.column_length(j) > 1e-6, "vertex {j} coincides too");
            }
        }
        let far = (0..n as usize).map(|j| m.column_length(j)).fold(0.0, f64::max);
        prop_assert!((far - d.w()).abs() < EXACT);
        prop_assert!(d.pose(s).d <= d.w() + EXACT);
    }

    #[test]
    fn pop_outs_of_all_indices_are_rotated_copies(n in 3u32..=12, t in 0.0f64..1.0) {
        let d = design(n, popout_beta(design(n, 30.0).lambda_vertex().min(design(n, 30.0).lambda_edge()), t));
        let e0 = d.state_info(ShapeState::Edge(0));
        let v0 = d.state_info(ShapeState::Vertex(0));
        for i in 1..n as u8 {
            let e = d.state_info(ShapeState::Edge(i));
            let v = d.state_info(ShapeState::Vertex(i));
            prop_assert!((e.max_strain - e0.max_strain).abs() < 1e-9);
            prop_assert!((v.max_strain - v0.max_strain).abs() < 1e-9);
            prop_assert!((e.pose.d - e0.pose.d).abs() < 1e-15 && (e.pose.gamma - e0.pose.gamma).abs() < 1e-15);
            let step = 2.0 * PI / n as f64;
            let dpsi = (e.pose.psi - e0.pose.psi - step * i as f64).rem_euclid(2.0 * PI);
            prop_assert!(dpsi < 1e-9 || 2.0 * PI - dpsi < 1e-9);
        }
    }
}

#[test]
fn pop_outs_do_not_exist_where_w_exceeds_2_lambda() {
    let d = design(3, 70.0); // w = 2.75 > 2λ′ = 1.73
    for s in [ShapeState::Edge(0), ShapeState::Vertex(1)] {
        let info = d.state_info(s);
        assert!(!d.state_exists(s) && !info.feasible, "{s}");
        assert!(info.pose.gamma.is_finite() && info.pose.d.is_finite());
    }
}

// ---------------------------------------------------------------- the paper's formulas as printed

#[test]
fn paper_eq_23_24_32_as_printed_do_not_make_the_edge_or_vertex_coincide() {
    // Regression: these are the paper's values; with eq 3 and eq 5 they miss.
    let d = design(3, golden_beta_deg());
    let n = 3.0;
    let gamma_in = 2.0 * (d.w() / (2.0 * d.lambda_edge())).asin();
    let printed_edge = Pose::new((gamma_in / 2.0).sin() / d.beta().tan(), gamma_in, PI / n);
    let m = Module3d::build(&d, &printed_edge);
    assert!((m.bottom()[0] - m.top()[0]).norm() > 0.1);
    // eq 23's d with the corrected ψ still misses: only d = sin(γ/2)/tan(180°/n) closes
    let fixed_psi = Pose::new(printed_edge.d, gamma_in, PI / n + PI / 2.0);
    let m = Module3d::build(&d, &fixed_psi);
    assert!((m.bottom()[0] - m.top()[0]).norm() > 0.1);
    let gamma_out = 2.0 * (d.w() / (2.0 * d.lambda_vertex())).asin();
    let printed_vertex = Pose::new((gamma_out / 2.0).sin() / (PI / n).sin(), gamma_out, 0.0);
    let m = Module3d::build(&d, &printed_vertex);
    assert!((m.bottom()[0] - m.top()[0]).norm() > 0.1);
    // the corrected ψ is the printed one + 90°, with the same γ (and eq 31's d)
    assert_relative_eq!(d.pose(ShapeState::Vertex(0)).psi, PI / 2.0, epsilon = 1e-12);
    assert_relative_eq!(
        d.pose(ShapeState::Vertex(0)).d,
        printed_vertex.d,
        epsilon = 1e-12
    );
    assert_relative_eq!(
        d.pose(ShapeState::Edge(0)).psi,
        PI / n + PI / 2.0,
        epsilon = 1e-12
    );
}

/// Eqs 17–22 literally: with η from |P − Q| = a (η = 180° − 4β), the residual |Q − R| − a.
fn paper_eq_22_residual(n: u32, beta_deg: f64) -> f64 {
    let d = design(n, beta_deg);
    let (w, a, b) = (d.w(), d.a(), d.beta());
    let g = 2.0 * (w / (2.0 * d.lambda_edge())).asin();
    let eta = PI - 4.0 * b;
    let p = Vector3::new(0.5, w / 2.0, 0.0);
    let q = Vector3::new((eta / 2.0).sin(), (eta / 2.0).cos(), 0.0);
    let t = 2.0 * PI / n as f64;
    let r = Vector3::new(
        0.5 + t.cos(),
        t.sin() * (g / 2.0).cos() + b.tan() / 2.0,
        t.sin() * (g / 2.0).sin(),
    );
    assert!(((p - q).norm() - a).abs() < 1e-12);
    (q - r).norm() - a
}

/// Eqs 25–30 literally: |P − Q| − a.
fn paper_eq_30_residual(n: u32, beta_deg: f64) -> f64 {
    let d = design(n, beta_deg);
    let (w, a) = (d.w(), d.a());
    let g = 2.0 * (w / (2.0 * d.lambda_vertex())).asin();
    let t = PI / n as f64;
    let p = Vector3::new(0.5, w / 2.0, 0.0);
    let q = Vector3::new(
        t.cos(),
        t.sin() * (g / 2.0).cos(),
        t.sin() * (g / 2.0).sin(),
    );
    (p - q).norm() - a
}

fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    let flo = f(lo);
    assert!(
        (flo < 0.0) != (f(hi) < 0.0),
        "no sign change in [{lo}, {hi}]"
    );
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if (f(m) < 0.0) == (flo < 0.0) {
            lo = m;
        } else {
            hi = m;
        }
    }
    0.5 * (lo + hi)
}

#[test]
fn beta_in_and_beta_out_from_the_3d_closure_equal_the_papers_eqs_22_and_30() {
    for n in 3..=12u32 {
        let bi = popout::beta_in_deg(n).unwrap();
        let bo = popout::beta_out_deg(n).unwrap();
        let pi_ = bisect(|b| paper_eq_22_residual(n, b), bi - 1.0, bi + 1.0);
        let po = bisect(|b| paper_eq_30_residual(n, b), bo - 1.0, bo + 1.0);
        assert!((bi - pi_).abs() < 1e-6, "n={n}: β_in {bi} vs eq 22 {pi_}");
        assert!((bo - po).abs() < 1e-6, "n={n}: β_out {bo} vs eq 30 {po}");
        // at β_in / β_out the rhombus next to the collapse closes in 3D
        let m = design(n, bi).build(ShapeState::Edge(0));
        assert!((m.mid_fold_length(1) - 1.0).abs() < 1e-9);
        let m = design(n, bo).build(ShapeState::Vertex(0));
        assert!((m.mid_fold_length(0) - 1.0).abs() < 1e-9);
    }
}

// ---------------------------------------------------------------- forward kinematics

#[test]
fn fk_of_deployed_and_folded_stacks_is_a_straight_column() {
    let d = design(3, 35.0);
    let mut out = [Point3::origin(); 4];
    let k = fk::fill_tips_of_states([(d, ShapeState::Deployed); 4], &mut out).unwrap();
    assert_eq!(k, 4);
    for (i, p) in out.iter().enumerate() {
        assert_relative_eq!(
            p.coords,
            Vector3::new(0.0, 0.0, d.w() * (i + 1) as f64),
            epsilon = 1e-12
        );
    }
    let mut short = [Point3::origin(); 2];
    assert!(fk::fill_tips_of_states([(d, ShapeState::Folded); 3], &mut short).is_err());
    assert_eq!(fk::tips(core::iter::empty()).count(), 0);
}

proptest! {
    #[test]
    fn fk_tips_are_products_of_transforms_and_top_polygons_chain(
        n in 3u32..=6, betas in proptest::collection::vec(20.0f64..40.0, 1..6), picks in proptest::collection::vec(0usize..100, 6)
    ) {
        let modules: Vec<(ModuleDesign, ShapeState)> = betas.iter().zip(&picks).map(|(b, k)| {
            let d = design(n, *b);
            let s = d.shape_states().nth(k % (2 * n as usize + 2)).unwrap();
            (d, s)
        }).collect();
        let tips: Vec<Point3<f64>> = fk::tips_of_states(modules.iter().copied()).collect();
        prop_assert_eq!(tips.len(), modules.len());
        let mut acc = nalgebra::Isometry3::identity();
        for ((d, s), tip) in modules.iter().zip(&tips) {
            // the top polygon of module k (in world) is the bottom polygon of module k+1
            let top_world: Vec<Point3<f64>> = (0..n).map(|j| acc * d.pose(*s).isometry() * d.bottom_vertex(j)).collect();
            acc *= d.pose(*s).isometry();
            prop_assert!((acc * Point3::origin() - tip).norm() < 1e-12);
            let centroid = top_world.iter().fold(Vector3::zeros(), |c, p| c + p.coords) / n as f64;
            prop_assert!((centroid - tip.coords).norm() < 1e-9);
            for j in 0..n {
                prop_assert!(((acc * d.bottom_vertex(j)) - top_world[j as usize]).norm() < 1e-9);
            }
        }
    }
}

// ---------------------------------------------------------------- tendon kinematics

mod tendon {
    use super::*;
    use geometry::tendon::{joystick_to_bend, Bend, JoystickMap, TendonGeometry, TENDON_ANGLES};

    #[test]
    fn bending_toward_a_tendon_shortens_it_most_and_the_changes_sum_to_zero() {
        let t = TendonGeometry::new(20.0).unwrap();
        let dl = t.length_changes(Bend::new(0.0, 0.5));
        assert_relative_eq!(dl[0], -10.0, epsilon = 1e-12);
        assert_relative_eq!(dl[1], 5.0, epsilon = 1e-12);
        assert_relative_eq!(dl[2], 5.0, epsilon = 1e-12);
        assert_relative_eq!(dl.iter().sum::<f64>(), 0.0, epsilon = 1e-12);
        assert_eq!(t.length_changes(Bend::STRAIGHT), [0.0; 3].map(|x: f64| -x));
        assert!(TendonGeometry::new(0.0).is_err() && TendonGeometry::new(f64::NAN).is_err());
        assert_relative_eq!(TENDON_ANGLES[1], 2.0 * PI / 3.0);
    }

    #[test]
    fn inverse_reports_common_mode_as_axial_and_rejects_nan() {
        let t = TendonGeometry::new(15.0).unwrap();
        let mut dl = t.length_changes(Bend::new(1.0, 0.3));
        dl.iter_mut().for_each(|x| *x += 2.5);
        let s = t.bend_from_length_changes(dl).unwrap();
        assert_relative_eq!(s.axial_mm, 2.5, epsilon = 1e-12);
        assert_relative_eq!(s.bend.angle, 0.3, epsilon = 1e-12);
        assert_relative_eq!(s.bend.direction, 1.0, epsilon = 1e-12);
        assert!(t.bend_from_length_changes([f64::NAN, 0.0, 0.0]).is_err());
        assert_eq!(
            t.bend_from_length_changes([0.0; 3]).unwrap().bend,
            Bend::STRAIGHT
        );
    }

    #[test]
    fn joystick_maps_direction_and_magnitude_and_never_panics() {
        let b = joystick_to_bend(0.0, 1.0, 0.6);
        assert_relative_eq!(b.direction, PI / 2.0, epsilon = 1e-12);
        assert_relative_eq!(b.angle, 0.6, epsilon = 1e-12);
        assert_relative_eq!(joystick_to_bend(1.0, 1.0, 0.6).angle, 0.6, epsilon = 1e-12); // clamped
        assert_relative_eq!(joystick_to_bend(-0.5, 0.0, 0.6).angle, 0.3, epsilon = 1e-12);
        assert_eq!(joystick_to_bend(f64::NAN, 0.2, 0.6), Bend::STRAIGHT);
        assert_eq!(joystick_to_bend(5.0, -7.0, 0.6).angle, 0.6);
        let m = JoystickMap::new(0.5, 0.1).unwrap();
        assert_eq!(m.bend(0.05, 0.05), Bend::STRAIGHT);
        assert_relative_eq!(m.bend(0.55, 0.0).angle, 0.25, epsilon = 1e-12);
        assert!(JoystickMap::new(0.5, 1.0).is_err() && JoystickMap::new(-1.0, 0.0).is_err());
    }

    proptest! {
        #[test]
        fn lengths_round_trip_through_the_inverse(
            r in 1.0f64..60.0, phi in 0.0f64..(2.0 * PI), theta in 1e-6f64..2.0, axial in -20.0f64..20.0
        ) {
            let t = TendonGeometry::new(r).unwrap();
            let mut dl = t.length_changes(Bend::new(phi, theta));
            dl.iter_mut().for_each(|x| *x += axial);
            let s = t.bend_from_length_changes(dl).unwrap();
            prop_assert!((s.bend.angle - theta).abs() < 1e-9);
            let dphi = (s.bend.direction - phi).rem_euclid(2.0 * PI);
            prop_assert!(dphi < 1e-6 || 2.0 * PI - dphi < 1e-6);
            prop_assert!((s.axial_mm - axial).abs() < 1e-9);
            let back = t.length_changes(s.bend);
            for k in 0..3 {
                prop_assert!((back[k] + axial - dl[k]).abs() < 1e-9);
            }
        }

        #[test]
        fn joystick_bend_is_bounded(x in -3.0f64..3.0, y in -3.0f64..3.0, max in 0.0f64..1.5) {
            let b = joystick_to_bend(x, y, max);
            prop_assert!(b.angle >= 0.0 && b.angle <= max + 1e-12);
            prop_assert!((0.0..2.0 * PI).contains(&b.direction));
        }
    }
}

// ---------------------------------------------------------------- orientation (top faces)

mod orientation {
    use super::*;
    use geometry::orient::{self, Heading};

    /// Normal of the built top polygon by the cross product of two of its edges (independent
    /// of how the frame's rotation is read).
    fn built_top_normal(m: &Module3d) -> Vector3<f64> {
        let t = m.top();
        (t[1] - t[0]).cross(&(t[2] - t[0])).normalize()
    }

    #[test]
    fn every_catalogue_state_tilts_its_top_face_by_gamma_towards_its_hinge_side() {
        for (n, beta) in [
            (3, golden_beta_deg()),
            (4, 23.362132),
            (6, 15.104295),
            (3, 35.0),
        ] {
            let d = design(n, beta);
            for s in d.shape_states() {
                let pose = d.pose(s);
                let face = orient::top_faces([pose]).next().unwrap();
                assert!((face.normal.norm() - 1.0).abs() < 1e-12);
                // The built top boundary lies in the face's plane, with the same normal.
                let m = d.build(s);
                for p in m.top() {
                    assert!((p - face.origin).dot(&face.normal).abs() < EXACT, "{n} {s}");
                }
                let built = built_top_normal(&m);
                assert!((built - face.normal.into_inner()).norm() < EXACT, "{n} {s}");
                // Tilt γ; the normal leans towards the hinge side, at angle ψ − 90°.
                assert!((face.tilt() - pose.gamma).abs() < 1e-9, "{n} {s}");
                if pose.gamma > 1e-6 {
                    let lean = face.normal.y.atan2(face.normal.x);
                    let side = pose.psi - PI / 2.0;
                    let diff = (lean - side).rem_euclid(2.0 * PI);
                    assert!(diff < 1e-9 || 2.0 * PI - diff < 1e-9, "{n} {s}");
                }
            }
        }
    }

    #[test]
    fn edge_and_vertex_pop_outs_face_their_edge_and_vertex() {
        let d = design(3, golden_beta_deg());
        for i in 0..3u8 {
            let e = orient::top_normal([d.pose(ShapeState::Edge(i))]);
            let edge_mid = (d.bottom_vertex(i as u32) + d.bottom_vertex((i as u32 + 1) % 3).coords)
                .coords
                / 2.0;
            let lean = Vector3::new(e.x, e.y, 0.0).normalize();
            assert!((lean - edge_mid.normalize()).norm() < 1e-9);
            let v = orient::top_normal([d.pose(ShapeState::Vertex(i))]);
            let lean = Vector3::new(v.x, v.y, 0.0).normalize();
            assert!((lean - d.bottom_vertex(i as u32).coords.normalize()).norm() < 1e-9);
        }
    }

    #[test]
    fn a_stack_tilts_by_the_sum_of_parallel_hinges_and_matches_the_chained_build() {
        let d = design(3, golden_beta_deg());
        let g = d.pose(ShapeState::Edge(1)).gamma;
        let faces: Vec<_> = orient::top_faces([
            d.pose(ShapeState::Deployed),
            d.pose(ShapeState::Edge(1)),
            d.pose(ShapeState::Edge(1)),
        ])
        .collect();
        assert_eq!(faces.len(), 3);
        assert!(faces[0].tilt() < 1e-12);
        assert!((faces[1].tilt() - g).abs() < 1e-9);
        assert!((faces[2].tilt() - 2.0 * g).abs() < 1e-9);
        // Origins are fk's tips.
        let tips: Vec<_> = fk::tips([
            d.pose(ShapeState::Deployed),
            d.pose(ShapeState::Edge(1)),
            d.pose(ShapeState::Edge(1)),
        ])
        .collect();
        for (f, t) in faces.iter().zip(&tips) {
            assert!((f.origin - t).norm() < 1e-12);
        }
        // Mixed states: the chained 3D build's top polygon has the frame's normal.
        let states = [
            ShapeState::Vertex(0),
            ShapeState::Edge(2),
            ShapeState::Vertex(1),
        ];
        let mut frame = nalgebra::Isometry3::identity();
        for (k, face) in orient::top_faces(states.map(|s| d.pose(s))).enumerate() {
            let m = d.build(states[k]);
            let top: Vec<Point3<f64>> = m.top().iter().map(|p| frame * p).collect();
            let built = (top[1] - top[0]).cross(&(top[2] - top[0])).normalize();
            assert!(
                (built - face.normal.into_inner()).norm() < EXACT,
                "module {k}"
            );
            frame *= d.pose(states[k]).isometry();
        }
        assert!(orient::top_normal(core::iter::empty()).z == 1.0);
    }

    #[test]
    fn heading_places_base_x_on_the_compass() {
        let east = Heading::default();
        assert_eq!(east.deg(), 90.0);
        let (az, el) = east.compass_of(&Vector3::x());
        assert!((az - 90.0).abs() < 1e-12 && el.abs() < 1e-12);
        let (az, _) = east.compass_of(&Vector3::y());
        assert!(az.abs() < 1e-12 || (az - 360.0).abs() < 1e-12);
        let north = Heading::from_deg(0.0).unwrap();
        assert!((north.base_of(0.0, 0.0).into_inner() - Vector3::x()).norm() < 1e-12);
        // y is 90° counter-clockwise of x seen from above: heading − 90°.
        let h = Heading::from_deg(200.0).unwrap();
        let (az, _) = h.compass_of(&Vector3::y());
        assert!((az - 110.0).abs() < 1e-9);
        assert_eq!(Heading::from_deg(-90.0).unwrap().deg(), 270.0);
        assert_eq!(Heading::from_deg(720.0).unwrap().deg(), 0.0);
        assert!(Heading::from_deg(f64::NAN).is_err());
        let (_, el) = east.compass_of(&Vector3::z());
        assert!((el - 90.0).abs() < 1e-12);
    }

    proptest! {
        #[test]
        fn compass_directions_round_trip(h in -720.0f64..720.0, az in 0.0f64..359.999, el in -89.9f64..89.9) {
            let heading = Heading::from_deg(h).unwrap();
            let v = heading.base_of(az, el);
            prop_assert!((v.norm() - 1.0).abs() < 1e-12);
            let (az2, el2) = heading.compass_of(&v);
            prop_assert!((el2 - el).abs() < 1e-9);
            let daz = (az2 - az).rem_euclid(360.0);
            prop_assert!(daz < 1e-9 || 360.0 - daz < 1e-9);
            prop_assert!((orient::angle_deg(&v, &heading.base_of(az, el)) ).abs() < 1e-6);
        }
    }
}
