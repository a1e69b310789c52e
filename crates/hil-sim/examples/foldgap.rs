//! Per trunk drawn within ±F: the shortest pull from F&D whose sealed release holds the bottom
//! folded, the sealed rise it leaves, and the shortest pull that leaves it beyond F&F
//! (half-packed or packed), at 1 mm (BENCHMARKS.md, "The bottom's fold, searched").
//!
//! `cargo run --release -p hil-sim --example foldgap -- FIRST_SEED RUNS F`
use geometry::TrunkState;
use hil_sim::discovery::{Rig, RigConfig};
use hil_sim::swarm::{feasible, Scenario, ScenarioOptions};
fn main() {
    let a: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let opts = ScenarioOptions {
        trunk_spread: a[2],
        ..ScenarioOptions::default()
    };
    let fd: TrunkState = "F&D".parse().unwrap();
    let ff: TrunkState = "F&F".parse().unwrap();
    for seed in a[0] as u64..(a[0] + a[1]) as u64 {
        let sc = Scenario::generate_with(seed, &opts).unwrap();
        let params = sc.trunk.params().unwrap();
        let (mut fold, mut beyond, mut rise) = (None, None, 0.0);
        let mut l = 50.0;
        while l <= 185.0 {
            let mut rig = Rig::with_params(params.clone(), fd, RigConfig::crane());
            let p0 = rig.trunk.pressure_kpa();
            rig.pull(l, 0);
            rig.release_sealed(0.0);
            let s = rig.trunk.state();
            if fold.is_none() && s != Some(fd) {
                fold = Some(l);
                rise = rig.trunk.pressure_kpa() - p0;
            }
            if s != Some(fd) && s != Some(ff) {
                beyond = Some(l);
                break;
            }
            l += 1.0;
        }
        println!(
            "{seed} {} fold {:?} rise {rise:.2} beyond {:?}",
            feasible(&sc.trunk),
            fold,
            beyond
        );
    }
}
