//! Cost of the parts of one simulation step (for finding where the time goes).
use std::time::Instant;
fn main() {
    let cfg = hil_sim::sim::sim_crane_config();
    let mut ctl = firmware::Controller::new(cfg, firmware::BootRecord::Empty, 0);
    let rest = firmware::Inputs::at_rest(&cfg);
    let n = 2_000_000u64;
    let t = Instant::now();
    for now in 0..n {
        ctl.handle_inputs(&rest, now);
        ctl.handle_time(now);
        std::hint::black_box(ctl.poll_outputs());
        std::hint::black_box(ctl.poll_display());
    }
    println!(
        "controller pass: {:.1} ns",
        t.elapsed().as_nanos() as f64 / n as f64
    );
    let params = hil_sim::physics::TrunkParams::pdf().unwrap();
    let mut trunk = hil_sim::physics::Trunk::new(params, "F&F".parse().unwrap());
    let act = hil_sim::physics::Actuation {
        inlet_open: true,
        ..Default::default()
    };
    let t = Instant::now();
    for _ in 0..n {
        std::hint::black_box(trunk.step(1e-3, &act));
    }
    println!(
        "trunk step (inflating): {:.1} ns",
        t.elapsed().as_nanos() as f64 / n as f64
    );
    let mut sim = hil_sim::Sim::new(Default::default());
    let t = Instant::now();
    for _ in 0..n {
        sim.step();
    }
    println!(
        "sim step idle: {:.1} ns",
        t.elapsed().as_nanos() as f64 / n as f64
    );
}
