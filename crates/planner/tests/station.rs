//! The station planner against brute force: per sample over every state combination (normals
//! from the chained 3D build, not the frames), and the --max-changes schedule over every
//! schedule of a few samples.

use geometry::orient::Heading;
use geometry::{ModuleDesign, ShapeState};
use nalgebra::{Isometry3, Point3, Vector3};
use planner::station::{score, Schedule, Station, StationError, SunDirection};

fn golden() -> ModuleDesign {
    ModuleDesign::new(3, 31.72).unwrap()
}

/// Deterministic pseudo-random suns (a small LCG: the test needs no crate for it).
fn suns(count: usize, seed: u64) -> Vec<SunDirection> {
    let mut x = seed;
    let mut next = || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..count)
        .map(|_| {
            let az = 360.0 * next();
            let el = -10.0 + 100.0 * next();
            SunDirection::from_compass(az, el, el > -0.8)
        })
        .collect()
}

/// The top normal of a stack built module by module in 3D (top polygon's cross product).
fn built_normal(states: &[(ModuleDesign, ShapeState)]) -> Vector3<f64> {
    let mut frame = Isometry3::identity();
    let mut normal = Vector3::z();
    for (d, s) in states {
        let m = d.build(*s);
        let top: Vec<Point3<f64>> = m.top().iter().map(|p| frame * p).collect();
        normal = (top[1] - top[0]).cross(&(top[2] - top[0])).normalize();
        frame *= d.pose(*s).isometry();
    }
    normal
}

#[test]
fn each_sample_takes_the_best_of_every_state_combination() {
    let d = golden();
    for (heading, adjustable) in [(90.0, 2), (17.0, 2), (250.0, 1), (90.0, 3)] {
        let h = Heading::from_deg(heading).unwrap();
        let station = Station::new(vec![d; 4], adjustable, None, h, false).unwrap();
        let configs = station.configurations();
        assert_eq!(configs.len(), 8usize.pow(adjustable as u32));
        let sun = suns(40, 7 + adjustable as u64);
        let scores = station.scores(&sun);
        let plan = station.best_each(&scores);
        for (t, s) in sun.iter().enumerate() {
            // Brute force: every combination of catalogue states, normals built in 3D.
            let mut best = 0.0f64;
            let states: Vec<ShapeState> = d.shape_states().collect();
            let combos = states.len().pow(adjustable as u32);
            for mut k in 0..combos {
                let mut stack: Vec<(ModuleDesign, ShapeState)> =
                    vec![(d, ShapeState::Deployed); 4 - adjustable];
                for _ in 0..adjustable {
                    stack.push((d, states[k % states.len()]));
                    k /= states.len();
                }
                let n = h.base_to_enu() * built_normal(&stack);
                best = best.max(score(&n, s));
            }
            let got = scores[t][plan.choice[t]];
            assert!((got - best).abs() < 1e-9, "t {t}: {got} vs {best}");
            if !s.up {
                assert_eq!(got, 0.0);
            }
        }
    }
}

/// Every schedule of `t` samples over `c` configurations: the best total with ≤ k changes.
fn brute_schedule(scores: &[Vec<f64>], k: usize) -> (f64, usize) {
    let (t, c) = (scores.len(), scores[0].len());
    let mut best = (f64::NEG_INFINITY, usize::MAX);
    let mut choice = vec![0usize; t];
    loop {
        let changes = choice.windows(2).filter(|w| w[0] != w[1]).count();
        if changes <= k {
            let total: f64 = choice.iter().zip(scores).map(|(i, s)| s[*i]).sum();
            if total > best.0 + 1e-12 || ((total - best.0).abs() <= 1e-12 && changes < best.1) {
                best = (total, changes);
            }
        }
        // Next schedule (odometer).
        let mut i = 0;
        loop {
            if i == t {
                return best;
            }
            choice[i] += 1;
            if choice[i] < c {
                break;
            }
            choice[i] = 0;
            i += 1;
        }
    }
}

#[test]
fn the_max_changes_schedule_is_the_best_of_every_schedule() {
    let d = golden();
    // One adjustable module (8 configurations) over 6 samples: 8^6 = 262 144 schedules.
    let station = Station::new(vec![d; 2], 1, None, Heading::default(), false).unwrap();
    for seed in 1..6u64 {
        let sun = suns(6, seed);
        let scores = station.scores(&sun);
        for k in 0..=5 {
            let plan: Schedule = station.best_with_changes(&scores, k).unwrap();
            let (total, changes) = brute_schedule(&scores, k);
            assert!(
                (plan.total - total).abs() < 1e-9,
                "seed {seed} k {k}: {} vs {total}",
                plan.total
            );
            assert!(plan.changes <= k);
            assert_eq!(
                plan.changes, changes,
                "seed {seed} k {k}: fewest refolds among the best"
            );
            let recomputed: f64 = plan.choice.iter().zip(&scores).map(|(c, s)| s[*c]).sum();
            assert!((recomputed - plan.total).abs() < 1e-12);
        }
    }
    // Two adjustable modules (64 configurations) over 3 samples: 64^3 schedules.
    let station =
        Station::new(vec![d; 3], 2, None, Heading::from_deg(33.0).unwrap(), false).unwrap();
    let sun = suns(3, 99);
    let scores = station.scores(&sun);
    for k in 0..=2 {
        let plan = station.best_with_changes(&scores, k).unwrap();
        let (total, _) = brute_schedule(&scores, k);
        assert!((plan.total - total).abs() < 1e-9, "k {k}");
    }
}

#[test]
fn fewer_refolds_never_gain_and_enough_refolds_reach_the_per_sample_optimum() {
    let station = Station::new(vec![golden(); 4], 2, None, Heading::default(), false).unwrap();
    let scores = station.scores(&suns(200, 3));
    let free = station.best_each(&scores);
    let mut last = f64::NEG_INFINITY;
    for k in 0..=free.changes {
        let p = station.best_with_changes(&scores, k).unwrap();
        assert!(p.total >= last - 1e-9);
        assert!(p.total <= free.total + 1e-9);
        last = p.total;
    }
    assert!((last - free.total).abs() < 1e-9);
}

#[test]
fn a_design_without_feasible_pop_outs_keeps_its_top_level() {
    // n = 4, β = 35°: every pop-out strains its creases by > 1 %.
    let d = ModuleDesign::new(4, 35.0).unwrap();
    let s = Station::new(vec![d; 4], 2, None, Heading::default(), false).unwrap();
    assert!(!s.has_pop_outs());
    assert_eq!(s.configurations().len(), 4); // deployed / folded each
    for c in s.configurations() {
        assert!((c.normal_enu - Vector3::z()).norm() < 1e-12);
    }
    // With the strained catalogue the top would tilt.
    let all = Station::new(vec![d; 4], 2, None, Heading::default(), true).unwrap();
    assert!(all.has_pop_outs());
}

#[test]
fn bad_stations_are_refused() {
    let d = golden();
    assert_eq!(
        Station::new(vec![d; 4], 5, None, Heading::default(), false).unwrap_err(),
        StationError::Adjustable {
            adjustable: 5,
            modules: 4
        }
    );
    assert!(Station::new(vec![d; 4], 0, None, Heading::default(), false).is_err());
    assert!(Station::new(vec![], 1, None, Heading::default(), false).is_err());
    assert!(matches!(
        Station::new(
            vec![d; 4],
            2,
            Some(vec![ShapeState::Deployed]),
            Heading::default(),
            false
        ),
        Err(StationError::FixedCount {
            given: 1,
            expected: 2
        })
    ));
    let strained = ModuleDesign::new(3, 35.0).unwrap();
    assert!(matches!(
        Station::new(
            vec![strained; 2],
            1,
            Some(vec![ShapeState::Edge(0)]),
            Heading::default(),
            false
        ),
        Err(StationError::FixedInfeasible { module: 1, .. })
    ));
    let mixed = vec![d, ModuleDesign::new(4, 23.36).unwrap()];
    assert_eq!(
        Station::new(mixed, 1, None, Heading::default(), false).unwrap_err(),
        StationError::MixedN
    );
    assert!(matches!(
        Station::new(vec![d; 5], 5, None, Heading::default(), false),
        Err(StationError::TooMany(32768))
    ));
}

#[test]
fn a_fixed_tilted_module_below_tilts_every_configuration() {
    let d = golden();
    let s = Station::new(
        vec![d; 3],
        1,
        Some(vec![ShapeState::Edge(0), ShapeState::Deployed]),
        Heading::default(),
        false,
    )
    .unwrap();
    let deployed = &s.configurations()[0];
    assert_eq!(deployed.states, vec![ShapeState::Deployed]);
    let g = d.pose(ShapeState::Edge(0)).gamma;
    assert!((deployed.normal_base.z - g.cos()).abs() < 1e-12);
}
