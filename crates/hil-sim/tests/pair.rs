//! The whole system in-process on one clock: the real host engine, the real controller and the
//! physics (`hil_sim::pair`).

use geometry::TrunkState;
use hil_sim::pair::{pair, SimShell};
use hil_sim::SimOptions;
use host::{Outcome, RunOptions};
use transition_graph::Graph;

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

/// Every plan reaches its target confirmed and true, except where a step's end is one the
/// sensors cannot confirm on a trunk they know nothing of (docs/firmware.md, "Truth without the
/// simulator's constants"): a manual step (without a probe profile the person's work is not
/// checked), the top's fold over a packed bottom (D&P → F&P: its spike may unpack the bottom)
/// and the bottom's blind folds under a folded top (F&D → F&F, F&F → F&P: no spike). There
/// the run stops unconfirmed, the trunk where that step took it.
#[test]
fn all_36_plans_reach_their_target_confirmed_and_true() {
    let mut reached = 0;
    for from in TrunkState::ALL {
        for to in TrunkState::ALL {
            let (out, truth) = run(from, to, 7);
            assert!(truth.actuators_safe, "{from} → {to}: {truth:?}");
            if out.ok() {
                assert_eq!(out.final_state, Some(to));
                assert!(out.state_confirmed);
                assert_eq!(truth.true_state, Some(to), "{from} → {to}");
                reached += 1;
                continue;
            }
            let failure = out.failure.as_ref().expect("a failure");
            let step = failure.step.as_ref().expect("a step failed");
            let unsensed = step.kind == protocol::messages::StepKind::Manual
                || (step.kind == protocol::messages::StepKind::Tendon
                    && (step.from.bottom == geometry::BottomState::Packed
                        || step.from.top == geometry::TopState::Folded));
            assert!(unsensed, "{from} → {to}: {failure:?}");
            assert!(!out.state_confirmed, "{from} → {to}: {out:?}");
            assert_eq!(truth.true_state, Some(step.to), "{from} → {to}");
        }
    }
    // The 36 less the plans through a step the sensors cannot confirm.
    println!("{reached} of 36 plans reached their target confirmed");
    assert!(reached >= 12, "{reached} of 36");
}

#[test]
fn same_seed_same_run() {
    let a = run("F&P".parse().unwrap(), "D&D".parse().unwrap(), 3);
    let b = run("F&P".parse().unwrap(), "D&D".parse().unwrap(), 3);
    assert_eq!(a.0, b.0);
    assert_eq!(a.1, b.1);
}

#[test]
fn after_a_power_cut_mid_step_the_run_identifies_the_state_first_then_reaches_its_target() {
    use hil_sim::pair::SimIo;
    use hil_sim::Sim;
    use host::{Driver, Host, RunEvent, Timing};
    use protocol::RequestBody;

    let dd: TrunkState = "D&D".parse().unwrap();
    let fd: TrunkState = "F&D".parse().unwrap();
    let mut io = SimIo::new(Sim::new(SimOptions {
        initial: dd,
        seed: 5,
        ..SimOptions::default()
    }));
    {
        // A host starts the tendon pull D&D → F&D; 1.5 s in, the board loses power.
        let mut d = Driver::new(Host::new(Timing::standard(), 1), &mut io);
        d.connect().expect("handshake");
        let plan = Graph::nominal()
            .plan(dd, fd)
            .unwrap()
            .to_protocol(1)
            .unwrap();
        d.command(RequestBody::UploadPlan(plan)).unwrap();
        d.command(RequestBody::StartPlan { plan_id: 1 }).unwrap();
        d.idle(1_500).unwrap();
        d.vanish();
    }
    io.sim.power_cycle();
    io.sim.run_for(100);
    let st = io.sim.controller().status();
    let truth = io.sim.safety().true_state;
    assert!(
        !st.state_confirmed || truth == Some(st.state),
        "boots confident and wrong: {st:?}, truth {truth:?}"
    );
    // A new host: the run identifies first (the simulated operator looks at the trunk), then
    // plans from the identified state.
    let mut d = Driver::new(Host::new(Timing::standard(), 0x4000), &mut io);
    d.connect().expect("handshake");
    let mut shell = SimShell::default();
    let out = d.run_plan(Graph::nominal(), fd, RunOptions::default(), &mut shell);
    drop(d);
    assert!(
        out.ok(),
        "{:?} {:?} {:?}",
        out.failure,
        out.last_status,
        shell.events
    );
    assert_eq!(io.sim.safety().true_state, Some(fd));
    assert!(!st.state_confirmed, "the cut came mid-step: {st:?}");
    assert!(
        st.candidates.contains(truth.expect("at rest")),
        "{st:?} vs {truth:?}"
    );
    // Identified before anything was planned: by the crane's probes, or by the operator, who is
    // then asked among the device's candidates.
    assert!(out.identified);
    if let Some(prompt) = shell.events.iter().find_map(|e| match e {
        RunEvent::IdentifyPrompt { candidates, .. } => Some(candidates.clone()),
        _ => None,
    }) {
        assert!(
            prompt.contains(&truth.expect("at rest")),
            "{prompt:?} vs {truth:?}"
        );
    }
    let first_plan = shell.events.iter().find_map(|e| match e {
        RunEvent::Plan { plan, .. } => Some(plan.from()),
        _ => None,
    });
    assert!(
        first_plan.is_none_or(|f| Some(f) == truth),
        "{first_plan:?} vs {truth:?}"
    );
}
