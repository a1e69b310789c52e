//! How much faster than real time the simulator runs headless: a full F&P → D&D plan (three
//! pneumatic steps) driven through the real controller, and idle time.
//!
//! `cargo bench -p hil-sim --bench realtime` prints virtual seconds per wall second.

use std::time::Instant;

use hil_sim::host::SimHost;
use hil_sim::{Sim, SimOptions};
use protocol::messages::Step;

fn plan_fp_to_dd() -> Vec<Step> {
    ["F&P", "F&F", "D&F", "D&D"]
        .windows(2)
        .map(|w| {
            protocol::transitions::transition(w[0].parse().unwrap(), w[1].parse().unwrap())
                .unwrap()
                .step()
        })
        .collect()
}

fn main() {
    let steps = plan_fp_to_dd();
    let runs = 20;
    let mut virtual_ms = 0u64;
    let start = Instant::now();
    for seed in 0..runs {
        let mut sim = Sim::new(SimOptions {
            seed,
            ..SimOptions::default()
        });
        let mut host = SimHost::new();
        sim.run_for(50);
        host.hello(&mut sim).unwrap();
        let (ok, state) = host.run_plan(&mut sim, 1, &steps, 120_000).unwrap();
        assert!(ok && state.name() == "D&D");
        virtual_ms += sim.now_ms();
    }
    let wall = start.elapsed().as_secs_f64();
    let v = virtual_ms as f64 / 1000.0;
    println!(
        "full F&P -> D&D plan: {runs} runs, {:.1} virtual s in {:.3} wall s: {:.0}x real time ({:.2} us per 1 ms step)",
        v,
        wall,
        v / wall,
        wall * 1e6 / virtual_ms as f64
    );

    let mut sim = Sim::new(SimOptions::default());
    let start = Instant::now();
    sim.run_for(600_000);
    let wall = start.elapsed().as_secs_f64();
    println!(
        "idle crane: 600 virtual s in {wall:.3} wall s: {:.0}x real time",
        600.0 / wall
    );
}
