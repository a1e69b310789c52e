//! Where the drawn trunks' targets go: each scenario whose trunk drawn within ±25 % is
//! feasible (`swarm::feasible`) against the same seed on the base trunk, the seeds that differ
//! and the totals (BENCHMARKS.md, "The swarm with a calibration first"). `CAL=1` calibrates
//! each drawn trunk first, as `swarm --calibrate`.
//!
//! `cargo run --release -p hil-sim --example gap -- FIRST_SEED RUNS`
use hil_sim::swarm::{feasible, run, Scenario, ScenarioOptions};
fn main() {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let (seed0, n) = (args[0], args[1]);
    let opts = ScenarioOptions {
        trunk_spread: 0.25,
        calibrate: std::env::var("CAL").is_ok(),
        ..ScenarioOptions::default()
    };
    let seeds: Vec<u64> = (seed0..seed0 + n).collect();
    let out = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for chunk in seeds.chunks(seeds.len().div_ceil(2)) {
            let out = &out;
            let opts = &opts;
            s.spawn(move || {
                for &seed in chunk {
                    let sc = Scenario::generate_with(seed, opts).unwrap();
                    if !feasible(&sc.trunk) {
                        continue;
                    }
                    let a = run(&Scenario::generate(seed), false).reached;
                    let b = run(&sc, false).reached;
                    out.lock().unwrap().push((seed, sc.targets.len(), a, b));
                }
            });
        }
    });
    let mut v = out.into_inner().unwrap();
    v.sort();
    let (mut ta, mut tb, mut tt) = (0, 0, 0);
    for (seed, t, a, b) in &v {
        ta += a;
        tb += b;
        tt += t;
        if a != b {
            println!("{seed} targets {t} base {a} spread {b}");
        }
    }
    println!("feasible {} targets {tt} base {ta} spread {tb}", v.len());
}
