//! Whole-system speed on one core: the host engine, the controller and the physics in-process
//! on one virtual clock (`hil_sim::pair`). Prints the wall time of all 36 (initial, target)
//! plans (median of 5) and the simulation speed (virtual time / wall time), and beside it the
//! speed per second of this process's own CPU time (Linux `/proc`): on a shared machine the wall
//! figure counts the time other processes had the core.
//!
//! `taskset -c 0 cargo bench -p hil-sim --bench pair`
//!
//! With `-- --once` it runs the 36 plans once and prints their virtual time, nothing else: the
//! run to count instructions with (`valgrind --tool=callgrind`), a figure that does not depend
//! on the machine's load or clock.

use std::time::Instant;

use geometry::TrunkState;
use hil_sim::pair::{pair, SimShell};
use hil_sim::SimOptions;
use host::RunOptions;
use transition_graph::Graph;

/// Nanoseconds this (main) thread has run on a CPU (Linux), if known.
fn cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// CPU seconds of the whole process, every thread (Linux; user + system, in clock ticks of
/// 10 ms), if known.
fn process_cpu_s() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which is in parentheses): utime is the 12th, stime the 13th.
    let rest = s.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: u64 = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

fn all_36() -> (f64, u64, Option<f64>) {
    let cpu0 = cpu_ns();
    let start = Instant::now();
    let mut virtual_ms = 0;
    for from in TrunkState::ALL {
        for to in TrunkState::ALL {
            let mut p = pair(SimOptions {
                initial: from,
                seed: 7,
                ..SimOptions::default()
            });
            p.connect().expect("handshake");
            let out = p.run_plan(
                Graph::nominal(),
                to,
                RunOptions::default(),
                &mut SimShell::default(),
            );
            assert!(out.ok(), "{from} → {to}: {:?}", out.failure);
            virtual_ms += p.io.sim.now_ms();
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu0.zip(cpu_ns()).map(|(a, b)| (b - a) as f64 * 1e-9);
    (wall, virtual_ms, cpu)
}

fn main() {
    if std::env::args().any(|a| a == "--once") {
        let (_, virtual_ms, _) = all_36();
        println!("all 36 plans once: {virtual_ms} ms virtual ({virtual_ms} steps of 1 ms)");
        return;
    }
    let mut runs: Vec<(f64, u64, Option<f64>)> = (0..5).map(|_| all_36()).collect();
    let mut cpus: Vec<f64> = runs.iter().filter_map(|r| r.2).collect();
    cpus.sort_by(f64::total_cmp);
    runs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (wall_s, virtual_ms, _) = runs[2];
    println!(
        "all 36 plans in-process (one core): {:.3} s wall, median of 5 (min {:.3}, max {:.3}); \
         {:.1} s virtual: {:.0}× real time",
        wall_s,
        runs[0].0,
        runs[4].0,
        virtual_ms as f64 / 1000.0,
        virtual_ms as f64 / 1000.0 / wall_s
    );
    if cpus.len() == 5 {
        println!(
            "  per CPU second of this process: {:.3} s, median of 5 (min {:.3}, max {:.3}): {:.0}× \
             (min {:.0}×, max {:.0}×)",
            cpus[2],
            cpus[0],
            cpus[4],
            virtual_ms as f64 / 1000.0 / cpus[2],
            virtual_ms as f64 / 1000.0 / cpus[4],
            virtual_ms as f64 / 1000.0 / cpus[0]
        );
    }
    let cpu0 = process_cpu_s();
    let start = Instant::now();
    let rep = hil_sim::swarm::swarm(0, 500, 1);
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu0.zip(process_cpu_s()).map(|(a, b)| b - a);
    println!(
        "swarm, 500 scenarios on one core: {:.2} virtual hours in {:.2} s: {:.0}× real time \
         (invariants checked every step); {} violation(s)",
        rep.virtual_ms as f64 / 3.6e6,
        wall,
        rep.virtual_ms as f64 / 1000.0 / wall,
        rep.violations.len()
    );
    if let Some(cpu) = cpu {
        println!(
            "  per CPU second of this process: {cpu:.2} s: {:.0}×",
            rep.virtual_ms as f64 / 1000.0 / cpu
        );
    }
}
