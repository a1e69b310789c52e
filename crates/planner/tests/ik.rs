//! Inverse kinematics on the real module catalogue: `exact` is the global optimum, planted
//! booms are recovered, and every solver's RMS is the RMS of its states recomputed with the
//! geometry crate's forward kinematics.

use geometry::{fk, ModuleDesign, ShapeState};
use nalgebra::Point3;
use planner::ik::{self, dp::DpParams, Algorithm, Catalogue, Control, Metric, Problem, Target};
use proptest::prelude::*;

/// Squared distance from `p` to the polyline `pts`, by brute force over its segments.
fn polyline_dist2(pts: &[Point3<f64>], p: &Point3<f64>) -> f64 {
    if pts.len() == 1 {
        return (p - pts[0]).norm_squared();
    }
    pts.windows(2)
        .map(|w| {
            let d = w[1] - w[0];
            let l2 = d.norm_squared();
            let t = if l2 > 0.0 {
                ((p - w[0]).dot(&d) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p - (w[0] + d * t)).norm_squared()
        })
        .fold(f64::INFINITY, f64::min)
}

/// RMS of a solution recomputed from its state names with `geometry::fk` (eq 36 metric).
fn rms_by_geometry(designs: &[ModuleDesign], names: &[String], target: &[Point3<f64>]) -> f64 {
    let modules: Vec<(ModuleDesign, ShapeState)> = designs
        .iter()
        .zip(names)
        .map(|(d, n)| (*d, ShapeState::parse(n, d.n()).expect("state name")))
        .collect();
    let tips: Vec<Point3<f64>> = fk::tips_of_states(modules).collect();
    assert_eq!(tips.len(), names.len());
    let sum: f64 = tips.iter().map(|t| polyline_dist2(target, t)).sum();
    (sum / tips.len() as f64).sqrt()
}

fn planted(n: u32, beta: f64, m: usize, seed: u64) -> (Problem, Vec<ModuleDesign>) {
    let d = ModuleDesign::new(n, beta).expect("design");
    let designs = vec![d; m];
    let cat = Catalogue::from_designs(&designs, false).expect("catalogue");
    let k = cat.candidates(0).len() as u64;
    let mut x = seed;
    let states: Vec<usize> = (0..m)
        .map(|_| {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((x >> 33) % k) as usize
        })
        .collect();
    let tips = cat.tips(&states);
    let target = Target::new(tips).expect("target");
    (Problem::new(cat, target, Metric::Eq36), designs)
}

#[test]
fn planted_booms_are_recovered_to_1e_9() {
    for (n, beta) in [(3, 31.72), (4, 35.0), (5, 40.0), (6, 30.0)] {
        for m in [1, 4, 8, 12] {
            for seed in 0..2u64 {
                let (p, _) = planted(n, beta, m, seed * 1000 + m as u64);
                let s = ik::solve(&p, Algorithm::Exact, &Control::new()).expect("solve");
                assert!(s.optimal, "n={n} m={m}");
                assert!(s.rms <= 1e-9, "n={n} m={m} seed={seed}: rms {}", s.rms);
            }
        }
    }
}

#[test]
fn every_solver_reports_the_rms_of_its_states() {
    let designs: Vec<ModuleDesign> = [35.0, 31.72, 35.0, 31.72, 35.0, 31.72, 35.0]
        .iter()
        .map(|&b| ModuleDesign::new(4, b).expect("design"))
        .collect();
    let cat = Catalogue::from_designs(&designs, false).expect("catalogue");
    for spec in [
        "helix:radius=1,pitch=3,turns=1",
        "sine",
        "arc:radius=2,angle=120",
    ] {
        let target = ik::target::generate(spec).expect("target");
        let pts = target.points().to_vec();
        let p = Problem::new(cat.clone(), target, Metric::Eq36);
        for algo in [
            Algorithm::Exact,
            Algorithm::Greedy,
            Algorithm::Beam { width: 16 },
            Algorithm::Window { width: 2 },
            Algorithm::Window { width: 3 },
            Algorithm::Dp(DpParams {
                max_states: 500,
                ..DpParams::default()
            }),
        ] {
            let s = ik::solve(&p, algo, &Control::new()).expect("solve");
            let independent = rms_by_geometry(&designs, &s.names, &pts);
            assert!(
                (independent - s.rms).abs() <= 1e-12 * (1.0 + s.rms),
                "{spec} {}: reported {} recomputed {independent}",
                algo.name(),
                s.rms
            );
        }
    }
}

#[test]
fn feasible_only_keeps_only_feasible_states() {
    let d = ModuleDesign::new(4, 35.0).expect("design");
    let all = Catalogue::from_designs(&[d; 3], false).expect("catalogue");
    assert_eq!(all.candidates(0).len(), 10);
    let feasible = Catalogue::from_designs(&[d; 3], true).expect("catalogue");
    let expected = d
        .shape_states()
        .filter(|s| d.state_info(*s).feasible)
        .count();
    assert_eq!(feasible.candidates(0).len(), expected);
}

fn arb_target() -> impl Strategy<Value = Vec<Point3<f64>>> {
    prop::collection::vec((-1.5..1.5f64, -1.5..1.5f64, 0.0..3.0f64), 1..6).prop_map(|v| {
        v.into_iter()
            .map(|(x, y, z)| Point3::new(x, y, z))
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// `exact` = `exhaustive` (RMS within 1e-9) on random small problems: n, per-module β,
    /// m, target and metric all random.
    #[test]
    fn exact_equals_exhaustive(
        n in 3u32..7,
        betas in prop::collection::vec(20.0..60.0f64, 1..5),
        target in arb_target(),
        ordered in any::<bool>(),
        feasible_only in any::<bool>(),
    ) {
        let designs: Vec<ModuleDesign> =
            betas.iter().map(|&b| ModuleDesign::new(n, b).expect("design")).collect();
        let Ok(cat) = Catalogue::from_designs(&designs, feasible_only) else {
            return Ok(()); // no feasible state for this β: a usage error, not a solver case
        };
        let metric = if ordered { Metric::Ordered } else { Metric::Eq36 };
        let p = Problem::new(cat, Target::new(target).expect("target"), metric);
        let ex = ik::solve(&p, Algorithm::Exhaustive, &Control::new()).expect("solve");
        let bb = ik::solve(&p, Algorithm::Exact, &Control::new()).expect("solve");
        prop_assert!(ex.optimal && bb.optimal);
        prop_assert!((ex.rms - bb.rms).abs() <= 1e-9, "exhaustive {} exact {}", ex.rms, bb.rms);
        prop_assert_eq!(u128::from(ex.evaluated), p.catalogue.sequences());
    }
}
