//! hil-sim's integration tests: the real controller driving the simulated crane in-process,
//! the discovered transition graph, faults, determinism, the trace snapshot and the pty.

mod support;

use firmware::Buttons;
use geometry::{BottomState, TopState, TrunkState};
use hil_sim::discovery::{self, RigConfig};
use hil_sim::host::SimHost;
use hil_sim::{Fault, GroundTruth, Sim, SimOptions};
use protocol::messages::{Mode, PlanPhase, Step, StepKind};
use protocol::transitions::{transition, TRANSITIONS};

fn st(s: &str) -> TrunkState {
    s.parse().unwrap()
}

fn sim_at(initial: TrunkState, faults: &[Fault]) -> (Sim, SimHost) {
    let mut sim = Sim::new(SimOptions {
        initial,
        faults: faults.to_vec(),
        ..SimOptions::default()
    });
    let mut host = SimHost::new();
    sim.run_for(50);
    host.hello(&mut sim).expect("handshake");
    (sim, host)
}

/// Runs `steps` from `initial`; returns (plan ok, ground truth after a 2 s settle).
fn run(initial: TrunkState, steps: &[Step], faults: &[Fault]) -> (bool, GroundTruth) {
    let (mut sim, mut host) = sim_at(initial, faults);
    let ok = match host.run_plan(&mut sim, 7, steps, 300_000) {
        Ok((ok, _)) => ok,
        Err(_) => false,
    };
    // The host keeps its heartbeat going while the trunk settles.
    for _ in 0..8 {
        sim.run_for(250);
        let _ = host.send(&mut sim, protocol::RequestBody::Heartbeat);
    }
    (ok, sim.ground_truth())
}

fn assert_clean_success(t: &GroundTruth, target: TrunkState, what: &str) {
    assert_eq!(t.true_state, Some(target), "{what}: {t:?}");
    assert_eq!(t.believed_state, target, "{what}: {t:?}");
    assert!(t.actuators_safe, "{what}: {t:?}");
    assert!(t.max_pressure_kpa <= t.pressure_limit_kpa, "{what}: {t:?}");
}

/// A step whose end the sensors cannot confirm on a trunk they know nothing of: by hand (no
/// probe profile), the top's fold over a packed bottom (its spike may unpack the bottom), and
/// the bottom's folds under a folded top (blind: no spike under the pinning tendons, and the
/// sealed release's rise alone does not count the folds).
fn unsensed(s: &Step) -> bool {
    s.kind == StepKind::Manual
        || (s.kind == StepKind::Tendon
            && (s.from.bottom == BottomState::Packed || s.from.top == TopState::Folded))
}

#[test]
fn every_nominal_edge_lands_where_the_catalogue_says_through_the_real_controller() {
    // The edges the sensors cannot confirm (`unsensed`) land there too, the plan failing
    // honestly (unconfirmed); the others are confirmed by their snaps (docs/firmware.md).
    for t in &TRANSITIONS {
        let (ok, truth) = run(t.from, &[t.step()], &[]);
        let what = format!("{} -> {}", t.from, t.to);
        if unsensed(&t.step()) {
            assert!(!ok, "{what}: {truth:?}");
            assert_eq!(truth.true_state, Some(t.to), "{what}: {truth:?}");
            assert!(truth.actuators_safe, "{what}: {truth:?}");
            continue;
        }
        assert!(ok, "{what}: {truth:?}");
        assert_clean_success(&truth, t.to, &what);
    }
}

#[test]
fn every_state_reaches_every_other_state_with_the_planners_plan() {
    let graph = transition_graph::Graph::nominal();
    let mut reached = 0;
    for from in TrunkState::ALL {
        for to in TrunkState::ALL {
            if from == to {
                continue;
            }
            let plan = graph.plan(from, to).expect("plan");
            let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
            let (ok, truth) = run(from, &steps, &[]);
            let what = format!("{from} -> {to}");
            if let Some(stop) = steps.iter().find(|s| unsensed(s)) {
                // The plan stops unconfirmed at the first step the sensors cannot confirm,
                // the trunk where that step took it.
                assert!(!ok, "{what}: {truth:?}");
                assert_eq!(truth.true_state, Some(stop.to), "{what}: {truth:?}");
                assert!(truth.actuators_safe, "{what}: {truth:?}");
                continue;
            }
            assert!(ok, "{what}: {truth:?}");
            assert_clean_success(&truth, to, &what);
            reached += 1;
        }
    }
    // 30 less the plans through an unsensed step.
    assert!(reached >= 12, "{reached} of 30");
}

#[test]
fn discovered_graph_equals_the_catalogue() {
    let g = discovery::discover(RigConfig::default());
    assert_eq!(g.edges, discovery::catalogue_edges());
    // Every exploration ends in a named state (never half-packed or mid-snap).
    for o in &g.outcomes {
        assert!(o.to.is_some(), "{o:?}");
        assert!(
            o.max_pressure_kpa <= protocol::HARD_MAX_PRESSURE_KPA as f64 + 0.5,
            "{o:?}"
        );
    }
}

#[test]
fn catalogue_primitives_have_margin() {
    // Pressures ±10 % and pull lengths ±10 mm land on the same states, executed by the real
    // controller.
    let bad = discovery::verify_catalogue(0.10, 10.0);
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
fn same_seed_same_run_and_the_seed_matters() {
    let steps = [transition(st("F&P"), st("F&F")).unwrap().step()];
    let trace = |seed| {
        let mut sim = Sim::new(SimOptions {
            seed,
            ..SimOptions::default()
        });
        sim.enable_trace(50);
        let mut host = SimHost::new();
        sim.run_for(50);
        host.hello(&mut sim).unwrap();
        host.run_plan(&mut sim, 1, &steps, 60_000).unwrap();
        (sim.trace().to_string(), sim.controller().pressure_kpa())
    };
    let (a, pa) = trace(1);
    let (b, pb) = trace(1);
    assert_eq!(a, b);
    assert_eq!(pa.to_bits(), pb.to_bits());
    let (_, pc) = trace(2);
    assert_ne!(
        pa.to_bits(),
        pc.to_bits(),
        "sensor noise should follow the seed"
    );
}

/// The compact trace of a full F&P → D&D deployment (pressure, module heights, servo, state,
/// valves, display every 250 ms; every snap, event and operator action), compared exactly.
/// Regenerate with `UPDATE_SNAPSHOTS=1 cargo test -p hil-sim --release --test sim`.
#[test]
fn snapshot_of_a_full_deployment_trace() {
    let graph = transition_graph::Graph::nominal();
    let plan = graph.plan(st("F&P"), st("D&D")).unwrap();
    let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
    let mut sim = Sim::new(SimOptions::default());
    sim.enable_trace(250);
    let mut host = SimHost::new();
    sim.run_for(50);
    host.hello(&mut sim).unwrap();
    let (ok, state) = host.run_plan(&mut sim, 1, &steps, 120_000).unwrap();
    assert!(ok);
    assert_eq!(state, st("D&D"));
    let got = sim.trace();
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/snapshots/fp_to_dd.txt");
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        std::fs::write(path, got).unwrap();
    }
    let want = std::fs::read_to_string(path).expect("snapshot file (UPDATE_SNAPSHOTS=1 to create)");
    assert!(got == want, "trace differs from {path}:\n{got}");
}

fn fault_run(fault: Fault, from: &str, to: &str) -> (bool, GroundTruth) {
    let t = transition(st(from), st(to)).unwrap();
    run(st(from), &[t.step()], &[fault])
}

fn assert_failed_safely(ok: bool, t: &GroundTruth, what: &str) {
    assert!(!ok, "{what}: plan should fail: {t:?}");
    assert!(t.actuators_safe, "{what}: {t:?}");
    assert!(
        t.max_pressure_kpa <= t.pressure_limit_kpa + 1.0,
        "{what}: {t:?}"
    );
    assert_ne!(t.mode, Mode::Running, "{what}: {t:?}");
}

#[test]
fn pneumatic_faults_fail_the_plan_cleanly() {
    for fault in [Fault::ValveStuckClosed, Fault::Leak, Fault::SensorDropout] {
        let (ok, t) = fault_run(fault, "F&F", "D&F");
        assert_failed_safely(ok, &t, fault.name());
    }
}

/// The filtered pressure the controller acts on and its inlet command, every millisecond of
/// one step from `from` to `to` until the plan ends (at most 32 s).
fn inflate_trace(from: &str, to: &str, faults: &[Fault], seed: u64) -> Vec<(f32, bool)> {
    let mut sim = Sim::new(SimOptions {
        initial: st(from),
        faults: faults.to_vec(),
        seed,
        ..SimOptions::default()
    });
    let mut host = SimHost::new();
    sim.run_for(50);
    host.hello(&mut sim).expect("handshake");
    let mut plan = protocol::Plan {
        plan_id: 3,
        steps: heapless::Vec::new(),
    };
    plan.steps
        .push(transition(st(from), st(to)).unwrap().step())
        .unwrap();
    host.request_ok(&mut sim, protocol::RequestBody::UploadPlan(plan), 1_000)
        .unwrap();
    host.request_ok(
        &mut sim,
        protocol::RequestBody::StartPlan { plan_id: 3 },
        1_000,
    )
    .unwrap();
    let mut trace = Vec::new();
    while trace.len() < 32_000 && sim.controller().mode() == Mode::Running {
        sim.step();
        if sim.now_ms().is_multiple_of(200) {
            let _ = host.send(&mut sim, protocol::RequestBody::Heartbeat);
            host.poll(&mut sim);
        }
        let c = sim.controller();
        trace.push((c.pressure_kpa(), c.poll_outputs().inlet_open));
    }
    trace
}

#[test]
fn nominal_inflation_rises_far_faster_than_the_rise_watch_asks() {
    // The firmware's stalled-inflation watch (docs/firmware.md, "Safety") wants 0.5 kPa per
    // 3 s with the inlet open. Measured here, on every pneumatic edge and three seeds: the
    // slowest 100 ms of rise before the snap is 7.6 kPa/s (just before the bottom module's
    // snap at ≈ 19 kPa, where the soft top stretches), and the longest the pressure goes
    // without gaining 0.5 kPa with the inlet open is ≤ 71 ms (across the snap's own drop).
    let rw = hil_sim::sim::sim_crane_config().rise_watch;
    assert_eq!((rw.window_ms, rw.min_gain_kpa), (3_000, 0.5));
    for t in TRANSITIONS.iter().filter(|t| t.kind == StepKind::Pneumatic) {
        for seed in [1, 7, 42] {
            let what = format!("{} -> {} seed {seed}", t.from, t.to);
            let tr = inflate_trace(&t.from.to_string(), &t.to.to_string(), &[], seed);
            let first_open = tr.iter().position(|x| x.1).expect(&what);
            let (peak, _) = tr
                .iter()
                .enumerate()
                .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
                .unwrap();
            let slowest = (first_open + 100..=peak)
                .step_by(10)
                .map(|i| (tr[i].0 - tr[i - 100].0) * 10.0)
                .fold(f32::MAX, f32::min);
            assert!(slowest >= 6.0, "{what}: {slowest} kPa/s");
            // The watch's rule with the window shrunk to the longest gap allowed here.
            let mut since: Option<(usize, f32)> = None;
            let mut longest = 0;
            for (i, &(p, open)) in tr.iter().enumerate() {
                if !open {
                    since = None;
                    continue;
                }
                let (i0, base) = since.get_or_insert((i, p));
                *base = base.min(p);
                if p - *base >= rw.min_gain_kpa {
                    since = Some((i, p));
                } else {
                    longest = longest.max(i - *i0);
                }
            }
            assert!(longest <= 150, "{what}: {longest} ms without 0.5 kPa");
            // And it never comes near a full window with the inlet open: each fill (to the
            // snap, and the hold's refill after it) is over in ≤ 2.5 s.
            let mut open_ms = 0;
            let mut longest_open = 0;
            for x in &tr {
                open_ms = if x.1 { open_ms + 1 } else { 0 };
                longest_open = longest_open.max(open_ms);
            }
            assert!(longest_open < 2_500, "{what}: {longest_open} ms open");
        }
    }
}

#[test]
fn a_leak_or_a_closed_inlet_is_named_well_before_the_step_time_limit() {
    // Today's stand-in was the step's 30 s time limit (E-03). The leak plateaus at ≈ 4 kPa
    // (p(t) − p(t − 3 s) < 0.5 kPa at 4.0–4.6 s over edges and seeds); the stuck-closed inlet
    // never leaves 0 kPa (one window: 3.0 s).
    let cases = [
        (
            Fault::Leak,
            protocol::FaultCode::Leak,
            "E-08",
            3_800..=5_000,
        ),
        (
            Fault::ValveStuckClosed,
            protocol::FaultCode::NoPressureRise,
            "E-12",
            3_000..=3_200,
        ),
    ];
    for (fault, code, display, within_ms) in cases {
        for t in TRANSITIONS.iter().filter(|t| t.kind == StepKind::Pneumatic) {
            let what = format!("{} {} -> {}", fault.name(), t.from, t.to);
            let (mut sim, mut host) = sim_at(t.from, &[fault]);
            let start = sim.now_ms();
            let r = host.run_plan(&mut sim, 7, &[t.step()], 60_000);
            assert!(matches!(r, Ok((false, _))), "{what}: {r:?}");
            let took = sim.now_ms() - start;
            assert!(within_ms.contains(&took), "{what}: {took} ms");
            let st = sim.controller().status();
            assert_eq!(
                st.plan.map(|p| p.phase),
                Some(PlanPhase::Failed(code)),
                "{what}"
            );
            assert_eq!(st.faults, code.bit(), "{what}: only the diagnosis");
            let g = sim.ground_truth();
            assert!(g.display.starts_with(display), "{what}: {g:?}");
            // The existing safe state: the trunk where it was, both valves closed.
            assert_eq!(g.true_state, Some(t.from), "{what}: {g:?}");
            assert_eq!(g.believed_state, t.from, "{what}: {g:?}");
            assert!(!g.inlet_open && !g.exhaust_open, "{what}: {g:?}");
            assert!(g.actuators_safe, "{what}: {g:?}");
        }
    }
}

#[test]
fn a_weak_servo_supply_fails_the_pull_cleanly() {
    let (ok, t) = fault_run(Fault::ServoStall, "D&D", "F&D");
    assert!(!ok, "{t:?}");
    assert_eq!(t.mode, Mode::Safe, "{t:?}");
    assert_eq!(t.true_state, Some(st("D&D")), "{t:?}");
    assert_eq!(t.believed_state, st("D&D"), "{t:?}");
    assert!(!t.inlet_open && t.max_pressure_kpa < 5.0, "{t:?}");
    assert!(t.display.starts_with("E-04"), "{t:?}");
    // The safe state stops the pulses: the limp servos push nothing, and the trunk's pull
    // relaxes them to below the gear train's back-drive force (≈ 5 N).
    assert_eq!(t.servos_energised, [false; 3], "{t:?}");
    assert!(t.actuators_safe, "{t:?}");
    assert!(t.tendon_tension_n.iter().all(|&n| n < 6.0), "{t:?}");
}

#[test]
fn a_broken_tendon_leaves_belief_and_truth_consistent() {
    // Two tendons still fold the top (bending the trunk toward them): the controller's claim
    // must match the truth whichever way it goes.
    let (ok, t) = fault_run(Fault::TendonBreak, "D&D", "F&D");
    if ok {
        assert_eq!(t.true_state, Some(t.believed_state), "{t:?}");
    } else {
        assert_failed_safely(ok, &t, "tendon-break");
    }
    assert!(t.tendon_tension_n[0] == 0.0, "{t:?}");
}

#[test]
fn link_drop_mid_plan_sends_the_crane_to_its_safe_state() {
    let graph = transition_graph::Graph::nominal();
    let plan = graph.plan(st("F&P"), st("D&D")).unwrap();
    let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
    let (mut sim, mut host) = sim_at(st("F&P"), &[Fault::LinkDrop]);
    let r = host.run_plan(&mut sim, 3, &steps, 20_000);
    assert!(r.is_err(), "{r:?}");
    let truth = sim.ground_truth();
    assert_eq!(truth.mode, Mode::Safe, "{truth:?}");
    assert!(truth.actuators_safe, "{truth:?}");
    assert!(truth.display.starts_with("E-05"), "{truth:?}");
}

#[test]
fn line_noise_is_survived_with_retries() {
    let t = transition(st("F&P"), st("F&F")).unwrap();
    let (ok, truth) = run(st("F&P"), &[t.step()], &[Fault::LineNoise]);
    assert!(ok, "{truth:?}");
    assert_clean_success(&truth, st("F&F"), "line-noise");
}

#[test]
fn without_the_operator_a_manual_step_waits_with_hand_on_the_display() {
    let t = transition(st("D&F"), st("D&P")).unwrap();
    let mut sim = Sim::new(SimOptions {
        initial: st("D&F"),
        operator: false,
        ..SimOptions::default()
    });
    let mut host = SimHost::new();
    sim.run_for(50);
    host.hello(&mut sim).unwrap();
    let r = host.run_plan(&mut sim, 4, &[t.step()], 20_000);
    assert!(r.is_err(), "{r:?}");
    let truth = sim.ground_truth();
    assert_eq!(truth.mode, Mode::WaitingManual, "{truth:?}");
    assert!(truth.display.starts_with("H-Pb"), "{truth:?}");
    assert_eq!(truth.true_state, Some(st("D&F")));
}

#[test]
fn a_stuck_open_inlet_never_drives_a_state_change() {
    // The inlet sticks in the inflate that pops the top (F&F → D&F): that pop was asked for;
    // the stuck inlet must not push on (the bottom deploys at 30 kPa). The vent cannot finish
    // against it; the controller calls it a stuck inlet and keeps the exhaust open.
    let (mut sim, mut host) = sim_at(st("F&F"), &[Fault::ValveStuckOpen]);
    let t = transition(st("F&F"), st("D&F")).unwrap();
    let ok = host
        .run_plan(&mut sim, 7, &[t.step()], 60_000)
        .map(|(ok, _)| ok)
        .unwrap_or(false);
    assert!(!ok);
    let at_fault = sim.ground_truth();
    let mut max_after = 0.0f32;
    for _ in 0..60 {
        sim.run_for(1_000);
        let _ = host.send(&mut sim, protocol::RequestBody::Heartbeat);
        let g = sim.ground_truth();
        max_after = max_after.max(g.pressure_kpa);
        assert_eq!(g.true_state, Some(st("D&F")), "{g:?}");
    }
    let g = sim.ground_truth();
    assert!(g.inlet_open, "the valve is stuck: {g:?}");
    assert!(g.exhaust_open, "{g:?}");
    assert_eq!(g.mode, Mode::Safe, "{g:?}");
    assert!(g.display.starts_with("E-11"), "{g:?}");
    // The pop was seen, but not the sealed trunk holding its pressure after it (gas kept
    // coming in): D&F is the best guess, unconfirmed (the host identifies).
    assert_eq!(g.believed_state, st("D&F"), "{g:?}");
    let st_now = host.request_ok(&mut sim, protocol::RequestBody::GetStatus, 1_000);
    let Ok(protocol::messages::ResponseBody::Status(s)) = st_now else {
        panic!("{st_now:?}")
    };
    assert!(!s.state_confirmed, "{s:?}");
    assert!(s.candidates.contains(st("D&F")), "{s:?}");
    // Held at (or below) the level the safe state found, well under the bottom's 30 kPa.
    assert!(
        max_after <= at_fault.pressure_kpa.max(10.0) + 1.0,
        "{max_after} after {at_fault:?}"
    );
    assert!(g.max_pressure_kpa < 25.0, "{g:?}");
}

#[test]
fn the_pty_serves_the_controller_to_a_serial_client() {
    let sim = hil_sim::pty::PtySim::spawn(SimOptions::default()).expect("pty");
    assert!(sim.path().exists(), "{}", sim.path().display());
    let mut client = support::pty_host(sim.path(), 42);
    let info = client.connect().expect("the handshake is answered");
    assert_eq!(info.board, protocol::Board::Simulator);
    assert_eq!(info.trunk.top.n, 3);
    drop(client);
    let truth = sim.stop();
    assert_eq!(truth.true_state, Some(st("F&P")));
    // Virtual time ran (at 20× wall time) while we talked.
    assert!(truth.time_ms > 0, "{truth:?}");
}

#[test]
fn the_pty_gives_the_ground_truth_at_a_virtual_time() {
    let sim = hil_sim::pty::PtySim::spawn(SimOptions::default()).expect("pty");
    let t0 = sim.ground_truth().time_ms;
    // 200 ms of virtual time at 20× wall time: ≈ 10 ms of wall time.
    let t = sim
        .ground_truth_at(t0 + 200, std::time::Duration::from_secs(30))
        .expect("the clock reaches it");
    assert!(t.time_ms >= t0 + 200, "{} after {t0}", t.time_ms);
    // A time the limit comes before: no truth is invented for it.
    let never = sim.ground_truth_at(u64::MAX, std::time::Duration::from_millis(20));
    assert!(never.is_none(), "{never:?}");
    // The link watch lasts the protocol's 3 s of wall time at 20× wall time.
    assert_eq!(
        sim.link_timeout_ms(),
        protocol::DEFAULT_LINK_TIMEOUT_MS * 20
    );
    assert!(sim.stop().time_ms >= t.time_ms);
}

#[test]
fn the_step_up_button_unpacks_the_trunk_without_a_host() {
    let mut sim = Sim::new(SimOptions::default());
    sim.run_for(100);
    sim.set_buttons(Buttons {
        up: true,
        ..Default::default()
    });
    sim.run_for(100);
    sim.set_buttons(Buttons::default());
    let done = sim.run_until(30_000, |s| {
        let t = s.ground_truth();
        t.believed_state == st("F&F") && t.mode == Mode::Standalone && !t.exhaust_open
    });
    let t = sim.ground_truth();
    assert!(done, "{t:?}");
    assert_eq!(t.true_state, Some(st("F&F")), "{t:?}");
    assert_eq!(t.display.trim_end(), "F-F", "{t:?}");
}

/// In every flexible state the joystick takes up the tendons' slack (46–105 mm, from the
/// state's height) and bends the trunk around it: full +x deflection bends the tip toward
/// tendon 0 (φ = 0°), +y toward 90°, without changing the state; centred, it straightens.
/// D&P (no folded module) is stiff: the controller limits it to an 8° command, which bends
/// it ≈ 2.6° at ≈ 31 N of tendon, well below the 75 N that buckles its top.
#[test]
fn the_joystick_bends_the_trunk_in_every_flexible_state() {
    for (name, min_bend_deg) in [("F&F", 15.0), ("D&F", 15.0), ("F&D", 15.0), ("D&P", 1.5)] {
        let mut sim = Sim::new(SimOptions {
            initial: st(name),
            ..SimOptions::default()
        });
        sim.run_for(100);
        let straight = sim.trunk().bend_deg().0;
        for (x, y, phi_want) in [(1.0, 0.0, 0.0), (0.0, 1.0, 90.0)] {
            sim.set_joystick(x, y);
            sim.run_for(4_000);
            let t = sim.ground_truth();
            let (theta, phi) = sim.trunk().bend_deg();
            assert!(
                theta > min_bend_deg,
                "{name} ({x}, {y}): bend {theta:.1}° {t:?}"
            );
            assert!(t.tendon_tension_n.iter().all(|&n| n < 40.0), "{t:?}");
            // Between two tendons the third stays 2 mm short of taut (the take-up margin), so
            // the bend leans toward the pulling one (at most to its own direction, 120° for
            // +y, as in stiff D&P).
            assert!(
                (phi - phi_want).abs() <= 30.5,
                "{name} ({x}, {y}): bend {theta:.1}° toward {phi:.1}°"
            );
            assert_eq!(t.true_state, Some(st(name)), "{name}: {t:?}");
        }
        sim.set_joystick(0.0, 0.0);
        sim.run_for(4_000);
        let (theta, _) = sim.trunk().bend_deg();
        assert!(theta < straight + 2.0, "{name}: {theta:.1}° after centring");
        assert_eq!(sim.ground_truth().true_state, Some(st(name)));
    }
}

#[test]
fn a_power_cycle_boots_from_the_emulated_flash() {
    let t = transition(st("F&P"), st("F&F")).unwrap();
    let (mut sim, mut host) = sim_at(st("F&P"), &[]);
    let (ok, _) = host.run_plan(&mut sim, 1, &[t.step()], 60_000).unwrap();
    assert!(ok);
    sim.power_cycle();
    sim.run_for(100);
    let truth = sim.ground_truth();
    assert_eq!(truth.believed_state, st("F&F"), "{truth:?}");
    assert!(sim.controller().status().state_confirmed);
    assert!(sim.flash_writes() >= 1);
}

#[test]
fn the_gripper_button_toggles_the_gripper_and_the_e_stop_latches() {
    let mut sim = Sim::new(SimOptions::default());
    sim.run_for(100);
    let press = |sim: &mut Sim, held: Buttons| {
        sim.set_buttons(held);
        sim.run_for(100);
        sim.set_buttons(Buttons::default());
        sim.run_for(500);
    };
    // Fail-closed: it boots closed; the button opens it, and closes it again.
    assert!(sim.ground_truth().gripper_closed);
    let gripper = Buttons {
        gripper: true,
        ..Default::default()
    };
    press(&mut sim, gripper);
    assert!(!sim.ground_truth().gripper_closed);
    press(&mut sim, gripper);
    assert!(sim.ground_truth().gripper_closed);
    press(
        &mut sim,
        Buttons {
            estop: true,
            ..Default::default()
        },
    );
    let t = sim.ground_truth();
    assert_eq!(t.mode, Mode::EStop, "{t:?}");
    assert!(t.actuators_safe, "{t:?}");
    assert!(t.display.starts_with("E-06"), "{t:?}");
}

/// Link signing's key is kept in the emulated flash: after a power cycle the device boots
/// signing, and its handshake says so.
#[test]
fn a_paired_link_key_survives_a_power_cycle() {
    use protocol::messages::{RequestBody, ResponseBody};
    let mut sim = Sim::new(SimOptions::default());
    sim.run_for(100);
    let mut host = SimHost::new();
    let ResponseBody::Hello(info) = host.hello(&mut sim).unwrap() else {
        panic!("no device info")
    };
    assert!(!info.signing, "off by default");
    let writes = sim.flash_writes();
    host.request_ok(
        &mut sim,
        RequestBody::SetSigning {
            key: *b"crane-test-key-1",
            enabled: true,
        },
        1_000,
    )
    .unwrap();
    sim.run_for(10);
    assert_eq!(sim.flash_writes(), writes + 1, "the key went to the flash");
    sim.power_cycle();
    sim.run_for(100);
    assert!(sim.controller().signing());
    let mut next = SimHost::new();
    let ResponseBody::Hello(info) = next.hello(&mut sim).unwrap() else {
        panic!("no device info")
    };
    assert!(
        info.signing,
        "the handshake after the power cycle says signing is on"
    );
}

/// The device's cap as it answers `GetParam`.
fn device_cap(host: &mut SimHost, sim: &mut Sim) -> f32 {
    use protocol::messages::{ParamId, RequestBody, ResponseBody};
    match host.request_ok(sim, RequestBody::GetParam(ParamId::PressureLimitKpa), 1_000) {
        Ok(ResponseBody::Param { value, .. }) => value,
        other => panic!("{other:?}"),
    }
}

/// The judge holds the pressure to the cap the running controller has: a `SetParam` the
/// controller accepted moves the judge's cap (the safety check, the ground truth and
/// `actuators_safe` alike), a refused one does not; never the boot copy.
#[test]
fn the_judge_holds_the_pressure_to_the_cap_the_controller_has_now() {
    use protocol::messages::{ParamId, RequestBody, ResponseBody};
    use protocol::ResultCode;
    let (mut sim, mut host) = sim_at(st("F&P"), &[]);
    assert_eq!(device_cap(&mut host, &mut sim), 40.0);
    assert_eq!(sim.pressure_limit_kpa(), 40.0);
    for kpa in [25.0, 52.5] {
        let set = RequestBody::SetParam {
            id: ParamId::PressureLimitKpa,
            value: kpa,
        };
        match host.request(&mut sim, set, 1_000) {
            Ok((ResultCode::Ok, ResponseBody::Param { value, .. })) => assert_eq!(value, kpa),
            other => panic!("{other:?}"),
        }
        assert_eq!(device_cap(&mut host, &mut sim), kpa);
        assert_eq!(sim.pressure_limit_kpa(), kpa);
        assert_eq!(sim.safety().pressure_limit_kpa, kpa);
        assert_eq!(sim.ground_truth().pressure_limit_kpa, kpa);
    }
    // Above the hard maximum: refused, the cap stays.
    let set = RequestBody::SetParam {
        id: ParamId::PressureLimitKpa,
        value: protocol::HARD_MAX_PRESSURE_KPA + 1.0,
    };
    let (res, _) = host.request(&mut sim, set, 1_000).expect("answered");
    assert!(matches!(res, ResultCode::Rejected(_)), "{res:?}");
    assert_eq!(device_cap(&mut host, &mut sim), 52.5);
    assert_eq!(sim.safety().pressure_limit_kpa, 52.5);
    assert_eq!(sim.ground_truth().pressure_limit_kpa, 52.5);
}
