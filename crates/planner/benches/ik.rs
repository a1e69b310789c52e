//! Inverse-kinematics benchmarks: a plain bench binary printing medians (no criterion: the
//! interesting figures are solver-level wall times, node counts and solution quality).
//!
//! `cargo bench -p planner --bench ik -- [SUITE…]` with suites `targets`, `exact`, `scaling`,
//! `exhaustive`, `beam`, `heuristics` (default: all). Figures are wall-clock on whatever
//! machine runs them; see BENCHMARKS.md (## ik) for recorded numbers and conditions.

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use geometry::ModuleDesign;
use planner::ik::{self, Algorithm, Catalogue, Control, Metric, Problem, Solution, Target};

/// The smooth-curve suite (units of l), sized for booms of about 10 n = 4 modules.
const SMOOTH: &[&str] = &[
    "helix:radius=1,pitch=4,turns=1",
    "helix:radius=0.5,pitch=2,turns=2",
    "helix:radius=1.5,pitch=3,turns=1",
    "sine:amplitude=1,wavelength=4,length=5",
    "sine:amplitude=0.5,wavelength=3,length=5",
    "sine:amplitude=0.2,wavelength=2,length=4",
];

fn catalogue(n: u32, beta: f64, m: usize) -> Catalogue {
    let d = ModuleDesign::new(n, beta).expect("design");
    Catalogue::from_designs(&vec![d; m], false).expect("catalogue")
}

fn smooth(n: u32, m: usize, spec: &str, metric: Metric) -> Problem {
    Problem::new(
        catalogue(n, 35.0, m),
        ik::target::generate(spec).expect("generator"),
        metric,
    )
}

/// A curve through the tips of a pseudo-random state sequence.
fn planted(n: u32, m: usize, seed: u64) -> Problem {
    let cat = catalogue(n, 35.0, m);
    let k = cat.candidates(0).len() as u64;
    let mut x = seed ^ 0x9e37_79b9_7f4a_7c15;
    let states: Vec<usize> = (0..m)
        .map(|_| {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((x >> 33) % k) as usize
        })
        .collect();
    let tips = cat.tips(&states);
    Problem::new(cat, Target::new(tips).expect("target"), Metric::Eq36)
}

/// Runs `algo` `reps` times; returns the last solution and the median wall time. A run is
/// stopped (Ctrl-C path) after `limit`.
fn timed(p: &Problem, algo: Algorithm, reps: usize, limit: Duration) -> (Solution, Duration) {
    let mut times = Vec::with_capacity(reps);
    let mut last = None;
    for _ in 0..reps {
        let control = Control::new();
        let stop = control.stop.clone();
        let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let d2 = done.clone();
        let watchdog = std::thread::spawn(move || {
            let t0 = Instant::now();
            while !d2.load(Ordering::Relaxed) {
                if t0.elapsed() > limit {
                    stop.store(true, Ordering::Relaxed);
                    return;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
        });
        let t0 = Instant::now();
        let s = ik::solve(p, algo, &control).expect("solve");
        times.push(t0.elapsed());
        done.store(true, Ordering::Relaxed);
        let _ = watchdog.join();
        last = Some(s);
    }
    times.sort();
    (last.expect("reps ≥ 1"), times[times.len() / 2])
}

/// Runs `exact` `reps` times with a deadline and a target gap; returns the last solution, the
/// median wall time and the median certified gap.
fn timed_exact(p: &Problem, reps: usize, limit: Duration, gap: f64) -> (Solution, Duration, f64) {
    let mut times = Vec::with_capacity(reps);
    let mut gaps = Vec::with_capacity(reps);
    let mut last = None;
    for _ in 0..reps {
        let mut control = Control::new();
        control.deadline = Some(Instant::now() + limit);
        control.target_gap = gap;
        let t0 = Instant::now();
        let s = ik::solve(p, Algorithm::Exact, &control).expect("solve");
        times.push(t0.elapsed());
        gaps.push(s.gap.expect("exact reports a gap"));
        last = Some(s);
    }
    times.sort();
    gaps.sort_by(f64::total_cmp);
    (
        last.expect("reps ≥ 1"),
        times[times.len() / 2],
        gaps[gaps.len() / 2],
    )
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn suite_exact() {
    println!("## exact, n = 4, m = 10 (10^10 sequences), median of 5 runs");
    println!("| instance | metric | RMS | optimal | nodes | median ms |");
    println!("|---|---|---|---|---|---|");
    for seed in 0..4 {
        let p = planted(4, 10, seed);
        let (s, t) = timed(&p, Algorithm::Exact, 5, Duration::from_secs(60));
        println!(
            "| planted seed {seed} | eq36 | {:.3e} | {} | {} | {:.1} |",
            s.rms,
            s.optimal,
            s.evaluated,
            ms(t)
        );
    }
    for metric in [Metric::Eq36, Metric::Ordered] {
        for spec in SMOOTH {
            let p = smooth(4, 10, spec, metric);
            let (s, t) = timed(&p, Algorithm::Exact, 5, Duration::from_secs(60));
            println!(
                "| {spec} | {} | {:.6} | {} | {} | {:.1} |",
                metric.name(),
                s.rms,
                s.optimal,
                s.evaluated,
                ms(t)
            );
        }
    }
}

fn suite_scaling() {
    println!("## exact scaling: one run each, stopped after 20 s (then larger m is skipped)");
    println!("| n | m | sequences | instance | RMS | optimal | nodes | median ms |");
    println!("|---|---|---|---|---|---|---|---|");
    for n in [4u32, 6, 8] {
        'm: for m in [12usize, 16, 20, 30, 40, 60] {
            let k = 2.0 * (n as f64 + 1.0);
            let problems = [
                ("planted".to_string(), planted(n, m, 7)),
                (
                    "helix:radius=1,pitch=4,turns=1".to_string(),
                    smooth(n, m, "helix:radius=1,pitch=4,turns=1", Metric::Eq36),
                ),
                (
                    "sine:amplitude=1,wavelength=4,length=5".to_string(),
                    smooth(n, m, "sine:amplitude=1,wavelength=4,length=5", Metric::Eq36),
                ),
            ];
            for (name, p) in problems {
                let (s, t) = timed(&p, Algorithm::Exact, 1, Duration::from_secs(20));
                println!(
                    "| {n} | {m} | 10^{:.1} | {name} | {:.3e} | {} | {} | {:.1} |",
                    m as f64 * k.log10(),
                    s.rms,
                    s.optimal,
                    s.evaluated,
                    ms(t)
                );
                if !s.optimal {
                    break 'm;
                }
            }
        }
    }
}

fn suite_exhaustive() {
    println!("## exhaustive throughput and exact's speed-up (n = 4), one run each");
    println!("| m | instance | sequences | exhaustive s | sequences/s | exact ms | speed-up |");
    println!("|---|---|---|---|---|---|---|");
    for m in [7usize, 8] {
        for (name, p) in [
            ("planted", planted(4, m, 3)),
            (
                "sine:amplitude=1,wavelength=4,length=5",
                smooth(4, m, "sine:amplitude=1,wavelength=4,length=5", Metric::Eq36),
            ),
        ] {
            let (ex, tex) = timed(&p, Algorithm::Exhaustive, 1, Duration::from_secs(600));
            let (bb, tbb) = timed(&p, Algorithm::Exact, 3, Duration::from_secs(60));
            assert!((ex.rms - bb.rms).abs() <= 1e-9, "exact ≠ exhaustive");
            let rate = ex.evaluated as f64 / tex.as_secs_f64();
            println!(
                "| {m} | {name} | {} | {:.2} | {:.3e} | {:.1} | {:.0}× |",
                ex.evaluated,
                tex.as_secs_f64(),
                rate,
                ms(tbb),
                tex.as_secs_f64() / tbb.as_secs_f64()
            );
        }
    }
}

fn suite_beam() {
    println!("## beam k = 64: gap to the exact optimum on the smooth-curve suite");
    println!("| n | m | curve | metric | exact RMS | beam RMS | gap % | beam ms | exact ms |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut worst: f64 = 0.0;
    for (n, m) in [(4u32, 10usize), (4, 14), (6, 10)] {
        for metric in [Metric::Eq36, Metric::Ordered] {
            for spec in SMOOTH {
                let p = smooth(n, m, spec, metric);
                let (e, te) = timed(&p, Algorithm::Exact, 1, Duration::from_secs(120));
                let (b, tb) = timed(
                    &p,
                    Algorithm::Beam { width: 64 },
                    3,
                    Duration::from_secs(60),
                );
                let gap = if e.rms > 0.0 {
                    100.0 * (b.rms / e.rms - 1.0)
                } else {
                    0.0
                };
                worst = worst.max(gap);
                println!(
                    "| {n} | {m} | {spec} | {} | {:.6}{} | {:.6} | {gap:.2} | {:.1} | {:.1} |",
                    metric.name(),
                    e.rms,
                    if e.optimal { "" } else { " (not proven)" },
                    b.rms,
                    ms(tb),
                    ms(te)
                );
            }
        }
    }
    println!("worst gap: {worst:.2} %");
    println!();
    println!("## beam k = 64, n = 6, m = 100: median of 5 runs");
    println!("| curve | RMS | median ms |");
    println!("|---|---|---|");
    for spec in [
        "helix:radius=2,pitch=10,turns=3",
        "sine:amplitude=2,wavelength=10,length=40",
        "arc:radius=15,angle=120",
    ] {
        let p = smooth(6, 100, spec, Metric::Eq36);
        let (s, t) = timed(
            &p,
            Algorithm::Beam { width: 64 },
            5,
            Duration::from_secs(60),
        );
        println!("| {spec} | {:.6} | {:.1} |", s.rms, ms(t));
    }
}

/// The issue-16 targets in one run (full catalogue of 2(n+1) states, β = 35°).
fn suite_targets() {
    println!(
        "## targets: exact certified optimal in ≤ 1 s (median of 5 runs, each stopped at 5 s)"
    );
    println!("| n | m | curve | metric | RMS | optimal (runs) | lower bound | gap % (median) | nodes | median ms |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (n, m, spec) in [
        (4u32, 30usize, "helix:radius=1,pitch=4,turns=1"),
        (6, 20, "sine:amplitude=1,wavelength=4,length=5"),
        (8, 12, "sine:amplitude=1,wavelength=4,length=5"),
    ] {
        for metric in [Metric::Eq36, Metric::Ordered] {
            let p = smooth(n, m, spec, metric);
            let mut proven = 0;
            let mut times = Vec::new();
            let mut gaps = Vec::new();
            let mut last = None;
            for _ in 0..5 {
                let (s, t, g) = timed_exact(&p, 1, Duration::from_secs(5), 0.0);
                proven += usize::from(s.optimal);
                times.push(t);
                gaps.push(g);
                last = Some(s);
            }
            times.sort();
            gaps.sort_by(f64::total_cmp);
            let s = last.expect("5 runs");
            println!(
                "| {n} | {m} | {spec} | {} | {:.6} | {proven}/5 | {:.6} | {:.3} | {} | {:.1} |",
                metric.name(),
                s.rms,
                s.lower_bound_rms.unwrap_or(0.0),
                100.0 * gaps[2],
                s.evaluated,
                ms(times[2])
            );
        }
    }
    println!();
    println!("## targets: n = 6, m = 100, certified gap ≤ 1 % within 1 s (--gap 0.01 --time-limit 1; median of 5)");
    println!("| curve | metric | RMS | lower bound | gap % (median) | stop | median ms |");
    println!("|---|---|---|---|---|---|---|");
    for spec in [
        "helix:radius=2,pitch=10,turns=3",
        "sine:amplitude=2,wavelength=10,length=40",
        "arc:radius=15,angle=120",
    ] {
        for metric in [Metric::Eq36, Metric::Ordered] {
            let p = smooth(6, 100, spec, metric);
            let (s, t, g) = timed_exact(&p, 5, Duration::from_secs(1), 0.01);
            println!(
                "| {spec} | {} | {:.6} | {:.6} | {:.3} | {} | {:.1} |",
                metric.name(),
                s.rms,
                s.lower_bound_rms.unwrap_or(0.0),
                100.0 * g,
                s.stop.name(),
                ms(t)
            );
        }
    }
}

fn suite_heuristics() {
    println!("## heuristics vs exact, n = 4, m = 10, eq36 (gap % to the optimum, median ms of 3)");
    println!("| curve | exact RMS | greedy | beam k=8 | window w=2 | window w=3 | dp (0.1 l, 5°, 5000) |");
    println!("|---|---|---|---|---|---|---|");
    for spec in SMOOTH {
        let p = smooth(4, 10, spec, Metric::Eq36);
        let (e, _) = timed(&p, Algorithm::Exact, 1, Duration::from_secs(60));
        let mut row = format!("| {spec} | {:.6} |", e.rms);
        for algo in [
            Algorithm::Greedy,
            Algorithm::Beam { width: 8 },
            Algorithm::Window { width: 2 },
            Algorithm::Window { width: 3 },
            Algorithm::Dp(ik::dp::DpParams::default()),
        ] {
            let (s, t) = timed(&p, algo, 3, Duration::from_secs(60));
            row.push_str(&format!(
                " {:+.1} % ({:.1} ms) |",
                100.0 * (s.rms / e.rms - 1.0),
                ms(t)
            ));
        }
        println!("{row}");
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let all = args.is_empty();
    let want = |s: &str| all || args.iter().any(|a| a == s);
    println!(
        "threads: {} (rayon), load average at start: {}",
        rayon::current_num_threads(),
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    );
    if want("targets") {
        suite_targets();
    }
    if want("exact") {
        suite_exact();
    }
    if want("beam") {
        suite_beam();
    }
    if want("heuristics") {
        suite_heuristics();
    }
    if want("exhaustive") {
        suite_exhaustive();
    }
    if want("scaling") {
        suite_scaling();
    }
}
