//! Unit tests over synthetic catalogues (the geometry-backed tests live in `tests/ik.rs`).

use nalgebra::Point3;
use proptest::prelude::*;

use super::chain::Chains;
use super::reach::{covers, Reach};
use super::testutil::synthetic;
use super::*;

fn problem(n: usize, m: usize, points: Vec<Point3<f64>>, metric: Metric) -> Problem {
    let cat = Catalogue::uniform(synthetic(n), m).unwrap();
    Problem::new(cat, Target::new(points).unwrap(), metric)
}

fn planted(n: usize, m: usize, seed: u64) -> (Problem, Vec<usize>) {
    let k = 2 * (n + 1);
    let mut x = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let states: Vec<usize> = (0..m)
        .map(|_| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((x >> 33) % k as u64) as usize
        })
        .collect();
    let cat = Catalogue::uniform(synthetic(n), m).unwrap();
    let tips = cat.tips(&states);
    (
        Problem::new(cat, Target::new(tips).unwrap(), Metric::Eq36),
        states,
    )
}

#[test]
fn reach_covers_contain_every_suffix_tip() {
    let cat = Catalogue::uniform(synthetic(4), 6).unwrap();
    let reach = Reach::new(&cat, 6);
    // All 10^4 four-module suffixes.
    for code in 0..10_000usize {
        let s: Vec<usize> = (0..4).map(|i| (code / 10usize.pow(i)) % 10).collect();
        let tips = cat.tips(&s);
        for (k, t) in tips.iter().enumerate() {
            assert!(covers(reach.cover(0, k + 1), t), "k={} {s:?}", k + 1);
        }
    }
}

#[test]
fn planted_instances_are_recovered_exactly() {
    for n in [3, 4, 6] {
        for m in [1, 5, 9, 12] {
            let (p, _) = planted(n, m, (n * 100 + m) as u64);
            let s = solve(&p, Algorithm::Exact, &Control::new()).unwrap();
            assert!(s.optimal);
            assert!(s.rms <= 1e-9, "n={n} m={m} rms={}", s.rms);
        }
    }
}

#[test]
fn every_solver_reports_the_rms_of_its_states() {
    let (p, _) = planted(4, 8, 7);
    for algo in [
        Algorithm::Exact,
        Algorithm::Greedy,
        Algorithm::Beam { width: 8 },
        Algorithm::Window { width: 2 },
        Algorithm::Window { width: 3 },
        Algorithm::Dp(dp::DpParams {
            max_states: 500,
            ..dp::DpParams::default()
        }),
    ] {
        let s = solve(&p, algo, &Control::new()).unwrap();
        // Recompute with eq 5 products written out here, tip by tip.
        let mut f = Frame::identity();
        let mut sum = 0.0;
        for (i, &a) in s.states.iter().enumerate() {
            f = f.compose(&synthetic(4)[a].frame);
            sum += p.objective.target().dist2(&f.origin());
            assert!((s.tips[i] - f.origin()).norm() < 1e-12);
        }
        let rms = (sum / 8.0).sqrt();
        assert!(
            (rms - s.rms).abs() <= 1e-12,
            "{}: {rms} vs {}",
            algo.name(),
            s.rms
        );
        assert_eq!(s.names.len(), 8);
    }
}

#[test]
fn stop_flag_returns_a_complete_boom() {
    let (p, _) = planted(4, 9, 3);
    let c = Control::new();
    c.stop.store(true, std::sync::atomic::Ordering::Relaxed);
    for algo in [
        Algorithm::Exact,
        Algorithm::Exhaustive,
        Algorithm::Beam { width: 4 },
    ] {
        let s = solve(&p, algo, &c).unwrap();
        assert_eq!(s.states.len(), 9);
        assert!(!s.optimal && s.interrupted);
    }
}

#[test]
fn window_result_is_window_locally_optimal() {
    let pts = vec![
        Point3::origin(),
        Point3::new(2.0, 1.0, 4.0),
        Point3::new(0.0, 3.0, 7.0),
    ];
    let p = problem(3, 6, pts, Metric::Eq36);
    let s = solve(&p, Algorithm::Window { width: 2 }, &Control::new()).unwrap();
    let best = p.cost_sum(&s.states);
    for j in 0..5 {
        for a in 0..8 {
            for b in 0..8 {
                let mut t = s.states.clone();
                t[j] = a;
                t[j + 1] = b;
                assert!(p.cost_sum(&t) >= best * (1.0 - 1e-9));
            }
        }
    }
}

fn arb_points() -> impl Strategy<Value = Vec<Point3<f64>>> {
    prop::collection::vec((-3.0..3.0f64, -3.0..3.0f64, 0.0..6.0f64), 1..6).prop_map(|v| {
        v.into_iter()
            .map(|(x, y, z)| Point3::new(x, y, z))
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// exact = exhaustive (RMS within 1e-9) on random small problems, both metrics.
    #[test]
    fn exact_equals_exhaustive(n in 3usize..6, m in 1usize..5, pts in arb_points(), ordered in any::<bool>()) {
        let metric = if ordered { Metric::Ordered } else { Metric::Eq36 };
        let p = problem(n, m, pts, metric);
        let ex = solve(&p, Algorithm::Exhaustive, &Control::new()).unwrap();
        let bb = solve(&p, Algorithm::Exact, &Control::new()).unwrap();
        prop_assert!(ex.optimal && bb.optimal);
        prop_assert!((ex.rms - bb.rms).abs() <= 1e-9, "exhaustive {} exact {}", ex.rms, bb.rms);
        prop_assert_eq!(ex.evaluated, (2 * (n + 1)).pow(m as u32) as u64);
        // Heuristics never beat the optimum.
        for algo in [Algorithm::Greedy, Algorithm::Beam { width: 4 }, Algorithm::Window { width: 2 }] {
            let h = solve(&p, algo, &Control::new()).unwrap();
            prop_assert!(h.rms >= ex.rms - 1e-9);
        }
        // DP with exact merges and no cap is exact too.
        let dp = solve(&p, Algorithm::Dp(dp::DpParams { position_tolerance: 0.0, angle_tolerance_deg: 0.0, max_states: usize::MAX }), &Control::new()).unwrap();
        prop_assert!((dp.rms - ex.rms).abs() <= 1e-9);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The certified lower bound of `exact` never exceeds the optimum found by `exhaustive`: not
    /// at the start, not after any task of any pass, not when it stops at a target gap or a
    /// passed deadline; and the reported gap is honest (rms·(1 − gap) ≤ optimum ≤ rms).
    #[test]
    fn exact_lower_bound_never_exceeds_the_optimum(
        n in 3usize..5,
        m in 2usize..6,
        pts in arb_points(),
        ordered in any::<bool>(),
        target_gap in prop::sample::select(vec![0.0, 0.01, 0.1, 0.5, 0.9]),
        min_tasks in prop::sample::select(vec![1u128, 8, 2048]),
    ) {
        let metric = if ordered { Metric::Ordered } else { Metric::Eq36 };
        let p = problem(n, m, pts, metric);
        let ex = solve(&p, Algorithm::Exhaustive, &Control::new()).unwrap();
        let opt_sum = ex.rms * ex.rms * m as f64;
        let tol = 1e-9 * opt_sum + 1e-15;
        // Half the cases on the fine lower-bound grid (long searches switch to it).
        if min_tasks == 8 || target_gap > 0.2 {
            p.objective.target().prepare_fine_bounds();
        }
        let trace = std::sync::Mutex::new(Vec::new());
        let mut control = Control::new();
        control.target_gap = target_gap;
        // A third of the cases try the coupled (chain) bound at every node.
        let chain_min = if min_tasks == 8 { 0 } else { exact::CHAIN_MIN_REMAINING };
        let raw = exact::solve_with(&p, &control, min_tasks, Some(&trace), chain_min);
        let bounds = trace.into_inner().unwrap();
        prop_assert!(!bounds.is_empty());
        for &lb in &bounds {
            prop_assert!(lb <= opt_sum + tol, "bound {lb} > optimum {opt_sum}");
        }
        let lb = raw.lower_bound.unwrap();
        prop_assert!(lb <= opt_sum + tol);
        let rms = p.rms(&raw.states);
        prop_assert!(rms >= ex.rms - 1e-9);
        if raw.optimal {
            prop_assert!((rms - ex.rms).abs() <= 1e-9, "exact {rms} vs exhaustive {}", ex.rms);
        } else {
            prop_assert_eq!(raw.stop, Some(Stop::Gap));
            let lb_rms = (lb / m as f64).sqrt();
            prop_assert!(relative_gap(rms, lb_rms) <= target_gap);
        }
        // Through `solve`: the reported bound and gap.
        let s = solve(&p, Algorithm::Exact, &control).unwrap();
        let lb_rms = s.lower_bound_rms.unwrap();
        prop_assert!(lb_rms <= ex.rms + 1e-9);
        prop_assert!(s.rms * (1.0 - s.gap.unwrap()) <= ex.rms + 1e-9);
        prop_assert_eq!(s.optimal, s.stop == Stop::Finished);

        // A deadline that has already passed: the bound of the initial tasks alone.
        let mut late = Control::new();
        late.deadline = Some(std::time::Instant::now());
        let s = solve(&p, Algorithm::Exact, &late).unwrap();
        prop_assert!(s.lower_bound_rms.unwrap() <= ex.rms + 1e-9);
        prop_assert!(s.rms >= ex.rms - 1e-9);
        if !s.optimal {
            prop_assert_eq!(s.stop, Stop::TimeLimit);
            prop_assert!(s.interrupted);
        }
    }
}

/// On an instance too hard to finish at once, the certified bound rises over the passes,
/// stays below the incumbent, and a target gap stops the search with `optimal: false`.
#[test]
fn lower_bound_rises_and_a_target_gap_stops_the_search() {
    let pts = vec![
        Point3::origin(),
        Point3::new(1.5, 0.5, 2.0),
        Point3::new(0.0, 2.0, 3.5),
        Point3::new(-1.0, 0.0, 5.0),
    ];
    let p = problem(4, 10, pts, Metric::Eq36);
    let trace = std::sync::Mutex::new(Vec::new());
    let raw = exact::solve_with(
        &p,
        &Control::new(),
        64,
        Some(&trace),
        exact::CHAIN_MIN_REMAINING,
    );
    let bounds = trace.into_inner().unwrap();
    let ub = p.cost_sum(&raw.states);
    assert!(raw.optimal);
    assert!(bounds.len() >= 3, "{bounds:?}");
    assert!(bounds[0] < ub * 0.999, "{bounds:?} vs {ub}");
    assert!((bounds[bounds.len() - 1] - ub).abs() <= 1e-12 * ub);
    for &b in &bounds {
        assert!(b <= ub * (1.0 + 1e-12));
    }
    let mut c = Control::new();
    c.target_gap = 0.2;
    let s = solve(&p, Algorithm::Exact, &c).unwrap();
    let gap = s.gap.unwrap();
    assert!(gap <= 0.2, "{gap}");
    if !s.optimal {
        assert_eq!(s.stop, Stop::Gap);
        assert!(!s.interrupted);
    }
    let opt_rms = (ub / 10.0).sqrt();
    assert!(s.rms >= opt_rms - 1e-12 && s.rms * (1.0 - gap) <= opt_rms + 1e-12);
}

fn arb_planar_points() -> impl Strategy<Value = Vec<Point3<f64>>> {
    prop::collection::vec((-3.0..3.0f64, 0.0..6.0f64), 1..6)
        .prop_map(|v| v.into_iter().map(|(x, z)| Point3::new(x, 0.0, z)).collect())
}

#[test]
fn mirror_symmetry_is_found_only_when_the_target_has_it() {
    let planar = problem(
        4,
        3,
        vec![Point3::origin(), Point3::new(1.0, 0.0, 2.0)],
        Metric::Eq36,
    );
    let mirror = symmetry::find(&planar).expect("planar target, symmetric catalogue");
    // Mirroring y → −y maps deployed and folded to themselves and pairs the pop-outs.
    assert_eq!(mirror.sigma[0][0], 0);
    assert_eq!(mirror.sigma[0][1], 1);
    for (a, &b) in mirror.sigma[0].iter().enumerate() {
        assert_eq!(mirror.sigma[0][b], a, "an involution");
    }
    assert!(mirror.sigma[0].iter().enumerate().any(|(a, &b)| a != b));
    let skew = problem(
        4,
        3,
        vec![
            Point3::origin(),
            Point3::new(1.0, 0.5, 2.0),
            Point3::new(0.0, 1.0, 3.0),
        ],
        Metric::Eq36,
    );
    assert!(symmetry::find(&skew).is_none());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Searching only canonical sequences of a mirror-symmetric problem loses nothing:
    /// exact = exhaustive, and every certified bound stays below the optimum.
    #[test]
    fn mirror_pruned_exact_equals_exhaustive(
        n in 3usize..6,
        m in 1usize..5,
        pts in arb_planar_points(),
        ordered in any::<bool>(),
        min_tasks in prop::sample::select(vec![1u128, 2048]),
    ) {
        let metric = if ordered { Metric::Ordered } else { Metric::Eq36 };
        let p = problem(n, m, pts, metric);
        // The x–z plane is a symmetry plane of the synthetic n-gon's pop-out phases for even n
        // (mirroring maps phase ψ to π − ψ); for odd n it maps edges onto vertices: none.
        prop_assert_eq!(symmetry::find(&p).is_some(), n % 2 == 0);
        let ex = solve(&p, Algorithm::Exhaustive, &Control::new()).unwrap();
        let trace = std::sync::Mutex::new(Vec::new());
        let raw = exact::solve_with(&p, &Control::new(), min_tasks, Some(&trace), 0);
        prop_assert!(raw.optimal);
        let rms = p.rms(&raw.states);
        prop_assert!((rms - ex.rms).abs() <= 1e-9, "exact {rms} exhaustive {}", ex.rms);
        let opt_sum = ex.rms * ex.rms * m as f64;
        for lb in trace.into_inner().unwrap() {
            prop_assert!(lb <= opt_sum * (1.0 + 1e-9) + 1e-15);
        }
    }
}

#[test]
fn fine_grid_bounds_are_bounds_and_tighter() {
    let t = Target::new(vec![
        Point3::origin(),
        Point3::new(1.0, 0.5, 2.0),
        Point3::new(-0.5, 1.0, 3.5),
        Point3::new(0.3, -0.2, 5.0),
    ])
    .unwrap();
    t.prepare_fine_bounds();
    let mut x: u64 = 42;
    let mut rnd = || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut coarse_sum, mut fine_sum) = (0.0, 0.0);
    for _ in 0..20_000 {
        let p = Point3::new(6.0 * rnd() - 3.0, 6.0 * rnd() - 3.0, 9.0 * rnd() - 2.0);
        let r = 0.3 * rnd();
        // Every point of the ball is at least the bound away: check the centre and a point
        // on the sphere.
        let dir = nalgebra::Vector3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
        let fine = t.dist_lower_bound_fine(&p, r);
        let coarse = t.dist_lower_bound(&p, r);
        for q in [p, p + dir * r] {
            assert!(fine <= t.dist(&q) + 1e-12, "{p} {r}");
        }
        coarse_sum += coarse;
        fine_sum += fine;
    }
    assert!(fine_sum > coarse_sum, "{fine_sum} vs {coarse_sum}");
}

/// A boom whose odd modules choose among other transforms than its even ones (a catalogue that
/// is not uniform), in units of l.
fn mixed_catalogue(n: usize, m: usize) -> Catalogue {
    let even = synthetic(n);
    let mut odd = synthetic(n);
    for (i, c) in odd.iter_mut().enumerate() {
        c.frame = super::testutil::eq5(0.4 + 0.1 * i as f64, 0.2 + 0.07 * i as f64, 0.9 * i as f64);
    }
    Catalogue::new(
        (0..m)
            .map(|i| {
                if i % 2 == 0 {
                    even.clone()
                } else {
                    odd.clone()
                }
            })
            .collect(),
    )
    .unwrap()
}

/// The candidate indices of suffix number `code` of modules `j..j+len` (mixed radix).
fn suffix(cat: &Catalogue, j: usize, len: usize, mut code: usize) -> Vec<usize> {
    (j..j + len)
        .map(|i| {
            let k = cat.candidates(i).len();
            let a = code % k;
            code /= k;
            a
        })
        .collect()
}

/// Every suffix of every start traces a path through the chain covers: its k-th tip in a ball
/// of level k whose parents include a ball holding its (k−1)-th tip.
#[test]
fn chain_covers_hold_every_suffix_on_a_path() {
    for cat in [
        Catalogue::uniform(synthetic(4), 5).unwrap(),
        mixed_catalogue(3, 6),
    ] {
        let chains = Chains::new(&cat, 5);
        for j in 0..cat.len() {
            let h = chains.levels_after(j);
            let total: usize = (j..j + h).map(|i| cat.candidates(i).len()).product();
            for code in 0..total {
                let s = suffix(&cat, j, h, code);
                let mut f = Frame::identity();
                // Balls of the previous level that hold the previous tip on some path.
                let mut live = u64::MAX;
                for (k, &a) in s.iter().enumerate() {
                    f = f.compose(&cat.candidates(j + k)[a].frame);
                    let (balls, parents) = chains.level_balls(j, k + 1);
                    let mut next = 0u64;
                    for (c, b) in balls.iter().enumerate() {
                        let inside = (f.translation - b.center).norm() <= b.radius + 1e-9;
                        if inside && (k == 0 || parents[c] & live != 0) {
                            next |= 1 << c;
                        }
                    }
                    assert!(
                        next != 0,
                        "start {j}, suffix {s:?}: no path at level {}",
                        k + 1
                    );
                    live = next;
                }
            }
        }
    }
}

/// The least cost of tips `j..m` over every completion of the modules after `j` from `frame`.
fn cheapest_completion(p: &Problem, frame: &Frame, j: usize) -> f64 {
    if j == p.m() {
        return 0.0;
    }
    p.catalogue
        .candidates(j)
        .iter()
        .map(|c| {
            let f = frame.compose(&c.frame);
            p.objective.cost(j, &f.origin()) + cheapest_completion(p, &f, j + 1)
        })
        .fold(f64::INFINITY, f64::min)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The bound `exact` puts on the tips after a prefix — per-tip, coupled (chain covers) and
    /// their combination, on either distance grid, uniform or mixed catalogues — never exceeds
    /// the cheapest completion found by brute force (n = 3..4, m ≤ 6, tolerance 1e-9).
    #[test]
    fn coupled_bound_never_exceeds_the_cheapest_completion(
        n in 3usize..5,
        m in 3usize..7,
        pts in arb_points(),
        ordered in any::<bool>(),
        mixed in any::<bool>(),
        fine in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let metric = if ordered { Metric::Ordered } else { Metric::Eq36 };
        let cat = if mixed { mixed_catalogue(n, m) } else { Catalogue::uniform(synthetic(n), m).unwrap() };
        let p = Problem::new(cat, Target::new(pts).unwrap(), metric);
        if fine {
            p.objective.target().prepare_fine_bounds();
        }
        let reach = Reach::new(&p.catalogue, m);
        let chains = Chains::new(&p.catalogue, exact::CHAIN_HORIZON);
        // A prefix of 0..m−1 modules, at most 5 left to complete by brute force.
        let lo = m.saturating_sub(5);
        let j = lo + (seed % 8) as usize % (m - lo);
        let prefix = suffix(&p.catalogue, 0, j, (seed >> 8) as usize);
        let frame = p.catalogue.frames(&prefix).last().copied().unwrap_or_else(Frame::identity);
        let best = cheapest_completion(&p, &frame, j);
        let tol = 1e-9 * best + 1e-12;
        let per_tip = reach.suffix_lower_bound_grouped(&p.objective, &frame, j, f64::INFINITY);
        prop_assert!(per_tip <= best + tol, "per-tip {per_tip} > {best}");
        let h = chains.levels_after(j);
        let chain = chains.lower_bound(&p.objective, &frame, j, h, f64::INFINITY);
        let tail = reach.suffix_from(&p.objective, &frame, j, h + 1, f64::INFINITY);
        prop_assert!(chain + tail <= best + tol, "chain {chain} + tail {tail} > {best}");
        for gate in [0.0, 2.0, f64::INFINITY] {
            for budget in [f64::INFINITY, best * 0.5, best * 1.5] {
                let b = exact::remaining_bound(&p.objective, &reach, Some(&chains), gate, &frame, j, budget);
                prop_assert!(b <= best + tol, "combined {b} > {best} (gate {gate}, budget {budget})");
            }
        }
    }
}

/// The coupled bound is tighter than the per-tip one on many prefixes (it is not vacuous).
#[test]
fn chain_bound_beats_the_per_tip_bound_on_many_prefixes() {
    let m = 8;
    let pts: Vec<Point3<f64>> = (0..40)
        .map(|i| {
            let t = i as f64 / 39.0 * std::f64::consts::TAU;
            Point3::new(1.5 * t.cos(), 1.5 * t.sin(), 0.8 * t)
        })
        .collect();
    let p = problem(4, m, pts, Metric::Eq36);
    let reach = Reach::new(&p.catalogue, m);
    let chains = Chains::new(&p.catalogue, exact::CHAIN_HORIZON);
    let (mut better, mut total) = (0, 0);
    for code in 0..1000 {
        let prefix = suffix(&p.catalogue, 0, 3, code);
        let frame = *p.catalogue.frames(&prefix).last().unwrap();
        let h = chains.levels_after(3);
        let head = reach.suffix_range(&p.objective, &frame, 3, 1, h, f64::INFINITY);
        let chain = chains.lower_bound(&p.objective, &frame, 3, h, f64::INFINITY);
        total += 1;
        if chain > head * (1.0 + 1e-6) + 1e-9 {
            better += 1;
        }
    }
    assert!(
        better * 10 >= total,
        "chain bound tighter on only {better} of {total} prefixes"
    );
}
