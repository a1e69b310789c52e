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

/// `s` plays without breaking an invariant.
fn holds(s: &Scenario) {
    let rep = run(s, false);
    assert!(
        rep.violations.is_empty(),
        "{}: {:?}",
        s.describe(),
        rep.violations
    );
}

#[test]
fn the_seeds_of_fixed_bugs_hold_every_invariant() {
    for seed in FIXED {
        let s = Scenario::generate_without_mistakes(seed);
        holds(&s);
    }
}

/// Seeds the swarm found (10 000 from seed 1000 without the operator's mistakes) before the
/// display named the manual task and the crane checked a person's confirm: the simulated
/// operator, who then learned the task from the link, packed by default when the event was lost
/// and the device took the confirm as the truth (1326: a pack against a pressurised trunk that
/// popped back; 1538, 2135: after host crashes).
const MANUAL_UNCHECKED: [u64; 3] = [1326, 1538, 2135];

/// Seeds found with the operator's mistakes (1 000 from seed 0) before the check: a wrong fold
/// confirmed by the operator taken as the truth.
const WRONG_FOLD: [u64; 7] = [18, 113, 154, 212, 224, 260, 276];

/// Seeds found once the check was in (2 000 and 4 000 from seed 1000, with mistakes): a bottom
/// left half-packed after an interrupted packing confirmed as F&F by the probe (1749, 2397,
/// 2477, 2849), and an unpacking aborted after its first layer's drop confirmed as F&F (3713).
const HALF_PACKED: [u64; 5] = [1749, 2397, 2477, 2849, 3713];

#[test]
fn the_seeds_of_the_manual_step_and_between_state_bugs_hold_every_invariant() {
    let scenarios = MANUAL_UNCHECKED
        .iter()
        .map(|&s| Scenario::generate_without_mistakes(s))
        .chain(
            WRONG_FOLD
                .iter()
                .chain(&HALF_PACKED)
                .map(|&s| Scenario::generate(s)),
        );
    for s in scenarios {
        holds(&s);
    }
    // The wrong folds are made: each of these scenarios has the operator's mistake.
    for seed in WRONG_FOLD {
        assert!(
            matches!(
                Scenario::generate(seed).mistake,
                Some(hil_sim::operator::Mistake::WrongFold(_))
            ),
            "{seed}"
        );
    }
}

/// Found by the gate's 10 000 scenarios from seed 1000 (with mistakes) once the simulator's
/// noise came from xoshiro256++: D&D → F&P → F&F → D&D with a leak opening at 35 894 ms, while
/// D&F → D&D inflated at ≈ 20 kPa; its sudden fall was taken for the bottom's snap and the host
/// and the device reported D&D confirmed with the trunk at D&F, then planned from D&D.
const LEAK_TAKEN_FOR_A_SNAP: u64 = 10754;

#[test]
fn a_leak_opening_mid_inflation_is_not_confirmed_as_the_snap() {
    let s = Scenario::generate(LEAK_TAKEN_FOR_A_SNAP);
    assert!(
        s.describe().contains("leak at 35894 ms"),
        "{}",
        s.describe()
    );
    let rep = run(&s, true);
    assert!(rep.violations.is_empty(), "{:?}", rep.violations);
    // The leak is found and named, not passed over.
    assert!(rep.trace.contains("E-08"), "{}", rep.trace);
}

#[test]
fn a_wrong_fold_is_found_by_the_check_and_the_run_goes_on_from_the_truth() {
    // Seed 18: F&P → D&P, the operator folds the top instead of packing the bottom. The device
    // cannot check a fold by hand without a probe profile: the step ends unconfirmed, the
    // operator looks again and sees F&F, and the plan goes on from there.
    let rep = run(&Scenario::generate(18), true);
    assert!(rep.violations.is_empty(), "{:?}", rep.violations);
    assert!(
        rep.trace.contains("belief D&F (unconfirmed), truth F&F"),
        "{}",
        rep.trace
    );
    assert!(
        rep.trace.contains("operator identifies F&F"),
        "{}",
        rep.trace
    );
    assert_eq!(rep.reached, rep.scenario.targets.len(), "{}", rep.trace);
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

/// The grasp task's invariant: an object let go while the device still reports the gripper
/// closed (here the world drops it behind the device's back) is caught; held and reported
/// closed is not.
#[test]
fn the_checker_catches_an_object_let_go_while_the_device_reports_it_held() {
    use hil_sim::swarm::Checker;
    use hil_sim::world::Object;
    use hil_sim::{Sim, SimOptions};
    let mut sim = Sim::new(SimOptions {
        initial: "F&F".parse().unwrap(),
        ..SimOptions::default()
    });
    sim.run_for(50);
    let tip = sim.true_tip().position_mm;
    sim.world_mut().set_gripper(false);
    sim.world_mut()
        .place(Object {
            name: "task-object".into(),
            position_mm: tip,
            mass_kg: 0.1,
            held: false,
        })
        .unwrap();
    let mut checker = Checker::default();
    for _ in 0..1_500 {
        sim.step();
        checker.check(&sim);
    }
    assert!(
        sim.world().objects()[0].held,
        "the closed gripper caught it"
    );
    assert!(checker.violations.is_empty(), "{:?}", checker.violations);
    // The object falls out of the gripper; the device goes on reporting it closed.
    let trunk = sim.trunk().clone();
    sim.world_mut().after_step(&trunk, false);
    for _ in 0..1_500 {
        sim.step();
        checker.check(&sim);
    }
    let names: Vec<_> = checker.violations.iter().map(|v| v.invariant).collect();
    assert_eq!(names, ["held-reported"], "{:?}", checker.violations);
}

/// The tip invariant: on a trunk unlike the host's model (drawn within ±25 %), whose straight
/// height in its state is more than 10 mm off the model's, the model's tip is caught
/// misplaced; on the calibrated trunk it is not.
#[test]
fn the_checker_catches_a_tip_the_model_misplaces() {
    use hil_sim::swarm::{model_heights, Checker, ScenarioOptions, TIP_TOLERANCE_MM};
    use hil_sim::{Sim, SimOptions};
    let model = model_heights().expect("the simulator's configuration has a model");
    let spread = ScenarioOptions {
        trunk_spread: 0.25,
        ..ScenarioOptions::default()
    };
    let watch = |trunk: hil_sim::physics::TrunkSpec, initial: geometry::TrunkState| {
        let mut sim = Sim::new(SimOptions {
            initial,
            trunk,
            ..SimOptions::default()
        });
        let mut checker = Checker::watching_the_tip(0);
        for _ in 0..2_000 {
            sim.step();
            checker.check(&sim);
        }
        let off = (sim.true_tip().position_mm[2] - model.height_mm(initial)).abs();
        (checker.violations, off)
    };
    let ff: geometry::TrunkState = "F&F".parse().unwrap();
    let (v, off) = watch(hil_sim::physics::TrunkSpec::pdf(), ff);
    assert!(v.is_empty() && off <= TIP_TOLERANCE_MM, "{off} mm: {v:?}");
    let far = (0..200)
        .map(|seed| {
            hil_sim::swarm::Scenario::generate_with(seed, &spread)
                .unwrap()
                .trunk
        })
        .find_map(|trunk| {
            let (v, off) = watch(trunk, ff);
            (off > 10.0).then_some((v, off))
        })
        .expect("a drawn trunk more than 10 mm off the model in F&F");
    let names: Vec<_> = far.0.iter().map(|v| v.invariant).collect();
    assert_eq!(names, ["tip-reported"], "{} mm off: {:?}", far.1, far.0);
}

/// Seeds where the grasp task's invariants fired before their conditions were right: a power
/// cut's boot closing the fail-closed gripper on the object, the task then closing on nothing
/// (1039, 1412); sealed air lengthening F&F (1119); a held 0.8 kg shortening F&F (1371); taut
/// tendons after an aborted pull holding F&P 12.4 mm low (8975). They hold every invariant.
const TASKS: [u64; 5] = [1039, 1119, 1371, 1412, 8975];

#[test]
fn the_seeds_of_the_grasp_tasks_hold_every_invariant() {
    for seed in TASKS {
        holds(&Scenario::generate(seed));
    }
    for seed in [1039, 1371, 1412, 8975] {
        assert!(Scenario::generate(seed).grasp.is_some(), "{seed} grasps");
    }
}

/// Seeds the 10 000 scenarios from seed 1000 found once issue 26's invariants (the host's
/// candidates hold the truth; no status claims a state confirmed while a step moves the trunk;
/// liveness) and the operator's stops were in: a fold started with 28.6 kPa left sealed by a
/// host crash popped the top outside the fold's reach (1230, and the host's candidates after the
/// stop missed D&D); valves stuck open unpacking a resting F&P (2647, 9000) and D&P (8969)
/// while the device held them confirmed (the rest watch).
const EDGES: [u64; 4] = [1230, 2647, 8969, 9000];

/// The same with every scenario's trunk drawn within ±25 %: 37 kPa left sealed by a stopped
/// fold popping a declared F&D's top (4215: the host now vents first), and a second
/// identification in one run that never asked the operator (6708: the run waited past its
/// bound).
const EDGES_SPREAD: [u64; 2] = [4215, 6708];

#[test]
fn the_seeds_of_the_edges_hold_every_invariant() {
    use hil_sim::swarm::ScenarioOptions;
    for seed in EDGES {
        holds(&Scenario::generate(seed));
    }
    let spread = ScenarioOptions {
        trunk_spread: 0.25,
        ..ScenarioOptions::default()
    };
    for seed in EDGES_SPREAD {
        holds(&Scenario::generate_with(seed, &spread).expect("a trunk the physics represents"));
    }
    // The ingredients that found them are drawn: operator stops in 1230, 2647, 9000 and 4215.
    for seed in [1230, 2647, 9000, 4215] {
        assert!(!Scenario::generate(seed).stops.is_empty(), "{seed}");
    }
}

/// `swarm --calibrate`: a calibration walk on a twin of each scenario's crane before the
/// scenario. On the calibrated trunk every walk is accepted, the walks and the scenarios hold
/// every invariant, and the swarm is the same swarm twice; on a trunk drawn within ±25 % a
/// refused walk says why (seed 5007: its bottom deploys above the 40 kPa limit) and its
/// scenario still runs, on the catalogue's thresholds.
#[test]
fn a_calibration_walk_before_each_scenario_holds_every_invariant() {
    use hil_sim::swarm::{swarm_of, ScenarioOptions};
    let opts = ScenarioOptions {
        calibrate: true,
        ..ScenarioOptions::default()
    };
    let make = |seed| Scenario::generate_with(seed, &opts).expect("the calibrated trunk");
    let r = swarm_of(7000, 12, 2, &make);
    assert_eq!((r.calibrations, r.calibrations_refused), (12, 0));
    assert!(r.violations.is_empty(), "{:?}", r.violations);
    // Each walk passes 8 transitions: at least 30 s of virtual time.
    assert!(r.calibration_ms >= 12 * 30_000, "{} ms", r.calibration_ms);
    assert_eq!(swarm_of(7000, 12, 1, &make), r);
    let spread = ScenarioOptions {
        calibrate: true,
        trunk_spread: 0.25,
        ..ScenarioOptions::default()
    };
    let s = Scenario::generate_with(5007, &spread).expect("a trunk the physics represents");
    let rep = run(&s, false);
    let why = rep.calibration.expect("a walk").expect_err("refused");
    assert!(
        why.starts_with("calibration refused: D&F → D&D: no snap seen on the ramp")
            && why.contains("the limit is 40 kPa"),
        "{why}"
    );
    assert!(rep.violations.is_empty(), "{:?}", rep.violations);
    assert_eq!(
        rep.virtual_ms,
        run(
            &Scenario {
                calibrate: false,
                ..s
            },
            false
        )
        .virtual_ms,
        "the scenario itself runs as drawn"
    );
}

/// `feasible`: the calibrated trunk makes every catalogue transition within the crane's limits;
/// one whose bottom deploys at 135 N (41.7 kPa, over the 40 kPa cap) does not.
#[test]
fn a_trunk_is_feasible_when_its_physics_makes_every_catalogue_transition() {
    use hil_sim::physics::TrunkSpec;
    use hil_sim::swarm::feasible;
    assert!(feasible(&TrunkSpec::pdf()));
    let pdf = include_str!("../../../trunks/pdf.toml");
    assert!(pdf.contains("tension_n = 97.0"));
    let stiff = TrunkSpec::from_toml(&pdf.replace("tension_n = 97.0", "tension_n = 135.0"))
        .expect("a trunk the physics represents");
    assert!(!feasible(&stiff));
}
