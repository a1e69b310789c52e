//! The whole system in-process on one clock: the real host engine, the real controller and the
//! physics (`hil_sim::pair`).

use geometry::TrunkState;
use hil_sim::pair::{pair, SimShell};
use hil_sim::SimOptions;
use host::{Outcome, RunOptions};
use planner::graph::Graph;

fn run(initial: TrunkState, target: TrunkState, seed: u64) -> (Outcome, hil_sim::GroundTruth) {
    let mut p = pair(SimOptions {
        initial,
        seed,
        ..SimOptions::default()
    });
    p.connect().expect("handshake");
    let out = p.run_plan(
        Graph::nominal(),
        target,
        RunOptions::default(),
        &mut SimShell::default(),
    );
    let truth = p.io.sim.ground_truth();
    (out, truth)
}

#[test]
fn all_36_plans_reach_their_target_confirmed_and_true() {
    for from in TrunkState::ALL {
        for to in TrunkState::ALL {
            let (out, truth) = run(from, to, 7);
            assert!(out.ok(), "{from} → {to}: {:?}", out.failure);
            assert_eq!(out.final_state, Some(to));
            assert!(out.state_confirmed);
            assert_eq!(truth.true_state, Some(to), "{from} → {to}");
            assert!(truth.actuators_safe, "{from} → {to}: {truth:?}");
        }
    }
}

#[test]
fn same_seed_same_run() {
    let a = run("F&P".parse().unwrap(), "D&D".parse().unwrap(), 3);
    let b = run("F&P".parse().unwrap(), "D&D".parse().unwrap(), 3);
    assert_eq!(a.0, b.0);
    assert_eq!(a.1, b.1);
}
