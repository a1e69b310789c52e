//! The swarm tester's regression seeds: scenarios that broke an invariant before the fix that
//! made them hold (docs/simulator.md, BENCHMARKS.md "Swarm tester"). Each must now hold every
//! invariant, and replay the same way twice.

use hil_sim::swarm::{run, Scenario};

/// Seeds the swarm found (seed 0 onward) before the belief, the journal and the host's
/// stale-status fix: power cuts mid-step booting confident and wrong (12, 13, 15, 22, 27, 107),
/// a leak or a stuck valve leaving the device confirmed where the trunk was not (7, 67), a host
/// reporting a stale state as confirmed after a reboot (12), a refused manual step waiting past
/// any bound (24), a stuck inlet behind a dead sensor (58).
const FIXED: [u64; 11] = [7, 12, 13, 15, 22, 24, 27, 58, 67, 107, 424];

#[test]
fn the_seeds_of_fixed_bugs_hold_every_invariant() {
    for seed in FIXED {
        let s = Scenario::generate_without_mistakes(seed);
        let rep = run(&s, false);
        assert!(
            rep.violations.is_empty(),
            "{}: {:?}",
            s.describe(),
            rep.violations
        );
    }
}

#[test]
fn a_scenario_replays_exactly() {
    let s = Scenario::generate(12);
    let a = run(&s, true);
    let b = run(&s, true);
    assert_eq!(a.trace, b.trace);
    assert_eq!(a.virtual_ms, b.virtual_ms);
    assert!(a.trace.contains("power cut"), "{}", a.trace);
}

#[test]
fn the_checker_catches_a_device_confident_and_wrong() {
    // A person declares the wrong state: the device says D&F confirmed, the trunk is at D&D.
    use hil_sim::host::SimHost;
    use hil_sim::swarm::Checker;
    use hil_sim::{Sim, SimOptions};
    let mut sim = Sim::new(SimOptions {
        initial: "D&D".parse().unwrap(),
        ..SimOptions::default()
    });
    let mut host = SimHost::new();
    host.hello(&mut sim).expect("handshake");
    host.request_ok(
        &mut sim,
        protocol::RequestBody::DeclareState("D&F".parse().unwrap()),
        1_000,
    )
    .expect("declared");
    let mut checker = Checker::default();
    for _ in 0..1_500 {
        host.poll(&mut sim);
        checker.check(&sim);
    }
    let names: Vec<_> = checker.violations.iter().map(|v| v.invariant).collect();
    assert_eq!(
        names,
        ["device-confirmed-truth"],
        "{:?}",
        checker.violations
    );
}
