//! Inverse-kinematics benchmarks (a plain bench binary: median of repeated runs).
//!
//! `cargo bench -p planner --bench ik -- [suite…]`; suites: `probe`.

use std::time::Instant;

use geometry::ModuleDesign;
use planner::ik::{self, Algorithm, Catalogue, Control, Metric, Problem, Target};

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    if args.iter().any(|a| a == "probe") {
        let d = ModuleDesign::new(4, 35.0).unwrap();
        for s in d.shape_states() {
            let i = d.state_info(s);
            println!(
                "{s}: {:?} feasible={} tip={:?}",
                i.pose,
                i.feasible,
                i.pose.tip()
            );
        }
        let cat = Catalogue::from_designs(&[d; 10], false).unwrap();
        for spec in [
            "helix:radius=1,pitch=4,turns=1",
            "sine:amplitude=1,wavelength=4,length=5",
        ] {
            let t = ik::target::generate(spec).unwrap();
            let p = Problem::new(cat.clone(), t, Metric::Eq36);
            for algo in [Algorithm::Beam { width: 64 }, Algorithm::Exact] {
                let t0 = Instant::now();
                let s = ik::solve(&p, algo, &Control::new()).unwrap();
                println!(
                    "{spec} {}: rms={:.6} opt={} eval={} {:?} {:?}",
                    algo.name(),
                    s.rms,
                    s.optimal,
                    s.evaluated,
                    t0.elapsed(),
                    s.names
                );
            }
        }
    }
    if args.iter().any(|a| a == "scan") {
        let d = ModuleDesign::new(4, 35.0).unwrap();
        let cat = Catalogue::from_designs(&[d; 10], false).unwrap();
        let specs = [
            "helix:radius=1,pitch=4,turns=1",
            "helix:radius=0.5,pitch=2,turns=2",
            "helix:radius=2,pitch=6,turns=1",
            "helix:radius=0.3,pitch=1.5,turns=3",
            "helix:radius=1.5,pitch=3,turns=1",
            "sine:amplitude=1,wavelength=4,length=5",
            "sine:amplitude=0.5,wavelength=3,length=5",
            "sine:amplitude=2,wavelength=6,length=6",
            "sine:amplitude=0.2,wavelength=2,length=4",
            "arc:radius=3,angle=90",
            "arc:radius=2,angle=180",
            "arc:radius=5,angle=60",
        ];
        for metric in [Metric::Eq36, Metric::Ordered] {
            for spec in specs {
                let t = ik::target::generate(spec).unwrap();
                let p = Problem::new(cat.clone(), t, metric);
                let b = ik::solve(&p, Algorithm::Beam { width: 64 }, &Control::new()).unwrap();
                let e = ik::solve(&p, Algorithm::Exact, &Control::new()).unwrap();
                println!(
                    "{:8} {spec:40} beam {:.5} exact {:.5} ({:+.2}%) nodes {:>10} {:>8.1?}",
                    metric.name(),
                    b.rms,
                    e.rms,
                    100.0 * (b.rms / e.rms - 1.0),
                    e.evaluated,
                    e.elapsed
                );
            }
        }
    }
    if args.iter().any(|a| a == "algos") {
        let d = ModuleDesign::new(4, 35.0).unwrap();
        for m in [7usize, 10, 20] {
            let cat = Catalogue::from_designs(&vec![d; m], false).unwrap();
            let t = ik::target::generate("sine").unwrap();
            let p = Problem::new(cat, t, Metric::Eq36);
            for algo in [
                Algorithm::Greedy,
                Algorithm::Beam { width: 16 },
                Algorithm::Window { width: 2 },
                Algorithm::Window { width: 3 },
                Algorithm::Dp(ik::dp::DpParams::default()),
                Algorithm::Exact,
            ] {
                let s = ik::solve(&p, algo, &Control::new()).unwrap();
                println!(
                    "m={m} {:10} rms {:.6} eval {:>9} {:?}",
                    algo.name(),
                    s.rms,
                    s.evaluated,
                    s.elapsed
                );
            }
        }
    }
    if args.iter().any(|a| a == "beam100") {
        let d = ModuleDesign::new(6, 35.0).unwrap();
        let cat = Catalogue::from_designs(&vec![d; 100], false).unwrap();
        for spec in [
            "helix:radius=2,pitch=10,turns=3",
            "sine:amplitude=2,wavelength=10,length=40",
        ] {
            let p = Problem::new(
                cat.clone(),
                ik::target::generate(spec).unwrap(),
                Metric::Eq36,
            );
            for w in [16usize, 64] {
                let s = ik::solve(&p, Algorithm::Beam { width: w }, &Control::new()).unwrap();
                println!("beam100 {spec} k={w} rms {:.6} {:?}", s.rms, s.elapsed);
            }
        }
    }
    let _ = Target::new;
}
