//! The most targets any controller could reach on each scenario's drawn trunk: its targets in
//! order, each counted when the trunk's own graph (`hil-sim discover` on that trunk within the
//! crane's 40 kPa and 185 mm, with the manual edges) leads from where the trunk is to it; an
//! unreachable target leaves the trunk where it was. Faults, stops and noise are left out, so
//! this bounds the rate from above (BENCHMARKS.md, "The swarm with a calibration first").
//!
//! `cargo run --release -p hil-sim --example ceiling -- FIRST_SEED RUNS F`
use geometry::TrunkState;
use hil_sim::discovery::{discover_trunk, RigConfig};
use hil_sim::swarm::{Scenario, ScenarioOptions};

fn reachable(edges: &[(TrunkState, TrunkState)], from: TrunkState, to: TrunkState) -> bool {
    let mut seen = vec![from];
    let mut i = 0;
    while i < seen.len() {
        let s = seen[i];
        for &(a, b) in edges {
            if a == s && !seen.contains(&b) {
                seen.push(b);
            }
        }
        i += 1;
    }
    seen.contains(&to)
}

fn main() {
    let a: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("FIRST_SEED RUNS F"))
        .collect();
    let opts = ScenarioOptions {
        trunk_spread: a[2],
        ..ScenarioOptions::default()
    };
    let (mut asked, mut ceiling) = (0, 0);
    for seed in a[0] as u64..(a[0] + a[1]) as u64 {
        let sc = Scenario::generate_with(seed, &opts).expect("a representable trunk");
        let params = sc.trunk.params().expect("drawn trunks are representable");
        let g = discover_trunk(&params, RigConfig::crane());
        let edges: Vec<(TrunkState, TrunkState)> = g.edges.iter().map(|e| (e.from, e.to)).collect();
        let mut at = sc.initial;
        for &t in &sc.targets {
            asked += 1;
            if reachable(&edges, at, t) {
                ceiling += 1;
                at = t;
            }
        }
    }
    println!(
        "{} scenarios: {ceiling} / {asked} targets reachable ({:.1} %)",
        a[1],
        100.0 * ceiling as f64 / asked as f64
    );
}
