//! Fault injection as a layer (`hil_sim::fault::FaultInjector`): every fault, given from the
//! start or injected at an onset, gives the same run for the same seed as before the layer —
//! the traces' fingerprints below were recorded with the faults checked inline in `Sim::step`
//! (commit "swarm: fault fingerprints before the layer").

use geometry::TrunkState;
use hil_sim::pair::{pair, SimShell};
use hil_sim::{Fault, SimOptions};
use host::RunOptions;
use transition_graph::Graph;

/// FNV-1a, 64 bit: a stable fingerprint of a trace.
fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The trace (every 20 ms, every snap and event) of a plan from `from` to `to` with `fault`
/// given from the start (`onset: None`) or injected at `onset` ms.
fn trace(fault: Fault, onset: Option<u64>, from: &str, to: &str, seed: u64) -> String {
    let faults = if onset.is_none() {
        vec![fault]
    } else {
        Vec::new()
    };
    let mut p = pair(SimOptions {
        initial: from.parse().unwrap(),
        seed,
        faults,
        ..SimOptions::default()
    });
    p.io.sim.enable_trace(20);
    if let Some(at) = onset {
        p.io.sim.run_for(at);
        p.io.sim.inject_fault(fault);
    }
    let _ = p.connect();
    let to: TrunkState = to.parse().unwrap();
    let out = p.run_plan(
        Graph::nominal(),
        to,
        RunOptions::default(),
        &mut SimShell::default(),
    );
    p.io.sim.run_for(2_000);
    format!(
        "{}{:?} {:?}\n",
        p.io.sim.trace(),
        out.failure.map(|f| f.fault),
        p.io.sim.ground_truth()
    )
}

/// (fault, onset, from, to, seed) and the fingerprint of its trace: each fault given from the
/// start on a pneumatic and a tendon plan, and injected 700 ms in (before the plan starts).
type Case = (Fault, Option<u64>, &'static str, &'static str, u64, u64);
#[rustfmt::skip]
const CASES: [Case; 24] = [
    (Fault::ValveStuckClosed, None, "F&P", "D&D", 3, 0x19b6ed2fe77cbbaa),
    (Fault::ValveStuckClosed, None, "D&D", "F&P", 3, 0x32119617ebd8aa46),
    (Fault::ValveStuckClosed, Some(700), "F&F", "D&F", 3, 0x1fc63c6898428ba0),
    (Fault::ValveStuckOpen, None, "F&P", "D&D", 3, 0x1c4947489db1f791),
    (Fault::ValveStuckOpen, None, "D&D", "F&P", 3, 0x44e6a379966a0f5e),
    (Fault::ValveStuckOpen, Some(700), "F&F", "D&F", 3, 0xe62633686f3010b4),
    (Fault::Leak, None, "F&P", "D&D", 3, 0xc603b946059f6bbe),
    (Fault::Leak, None, "D&D", "F&P", 3, 0x1314c4ed0754a205),
    (Fault::Leak, Some(700), "F&F", "D&F", 3, 0x4689a811cf6b17f7),
    (Fault::ServoStall, None, "F&P", "D&D", 3, 0xaf9670e712ebed8d),
    (Fault::ServoStall, None, "D&D", "F&P", 3, 0x82556f7194e21815),
    (Fault::ServoStall, Some(700), "F&F", "D&F", 3, 0xbc66efc27c70b172),
    (Fault::TendonBreak, None, "F&P", "D&D", 3, 0xc5805630deee6521),
    (Fault::TendonBreak, None, "D&D", "F&P", 3, 0x9d6f035cc5d20530),
    (Fault::TendonBreak, Some(700), "F&F", "D&F", 3, 0xa855aa5ca3bcf0ca),
    (Fault::SensorDropout, None, "F&P", "D&D", 3, 0x9b547e2bedbf204f),
    (Fault::SensorDropout, None, "D&D", "F&P", 3, 0x0b3ebe487e132a44),
    (Fault::SensorDropout, Some(700), "F&F", "D&F", 3, 0x27a5a62f3191145b),
    (Fault::LinkDrop, None, "F&P", "D&D", 3, 0xdbfe7258bd1a03f8),
    (Fault::LinkDrop, None, "D&D", "F&P", 3, 0x0056e74db6bb4b19),
    (Fault::LinkDrop, Some(700), "F&F", "D&F", 3, 0x2f64fc3d304292f3),
    (Fault::LineNoise, None, "F&P", "D&D", 3, 0x8b57b649c4abc72e),
    (Fault::LineNoise, None, "D&D", "F&P", 3, 0x251a8ba23f05e87a),
    (Fault::LineNoise, Some(700), "F&F", "D&F", 3, 0xd3ce53c193d8cf8a),
];

#[test]
fn every_fault_gives_the_run_it_gave_before_the_layer() {
    let mut changed = Vec::new();
    for (fault, onset, from, to, seed, want) in CASES {
        let got = fnv(&trace(fault, onset, from, to, seed));
        if got != want {
            changed.push(format!("{fault} {onset:?} {from} → {to}: {got:#018x}"));
        }
    }
    assert!(changed.is_empty(), "changed runs:\n{}", changed.join("\n"));
    // Each case tells something: the faults change the runs (no two fingerprints alike).
    let mut all: Vec<u64> = CASES.iter().map(|c| c.5).collect();
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), CASES.len());
}

#[test]
fn the_swarm_with_faults_at_random_onsets_runs_as_before_the_layer() {
    // 300 scenarios from seed 1000 on one thread: faults with onsets, line noise, power cuts,
    // host crashes. The totals were recorded before the layer (12 816 703 ms, 734 reached) and
    // held through it; re-blessed once since, after the merges of the manual-step check, the
    // named refusals and the f32 board maths (12 995 477 ms, 735 reached, still 0 violations;
    // which of them moved it was not bisected); and with the snap check (an inflation's snap
    // is evidence once the sealed trunk then holds its pressure: 400 ms more per inflation;
    // 13 063 329 ms, 735 reached on the ChaCha8 stream) and the simulator's noise from
    // xoshiro256++ (another stream, the same distributions): 12 617 287 ms, 733 reached, 0
    // violations. Re-blessed with the evidence that does not depend on the simulator's
    // constants (issue 25: inflations to the cap until their snaps and the hold after them,
    // pneumatic steps vented first, tendon folds confirmed only with their spikes, a manual
    // step and identification without a probe profile left to the operator, the untouched
    // bound at 4 kPa): 13 136 160 ms, 701 reached (fewer: the operator is asked where the
    // probe used to decide), still 0 violations; and with the plan runner identifying the state
    // after a step the device cannot confirm (the operator is asked, the plan goes on from
    // what is identified) and an unconfirmed tendon fold vented like a confirmed one:
    // 13 313 770 ms, 732 reached, 0 violations. With issue 26's edges (operator stops among
    // the scenario's ingredients, drawn last; a status mid-step reporting the step moving, not
    // its start confirmed; identifications counted in a row, not per run, so a resumed plan's
    // blind folds are each identified; a step's reach widened by the air sealed at its start):
    // 13 324 385 ms, 725 reached (stops cut runs), 0 violations; the leak D&D → F&P run now
    // reaches F&P (its three unconfirmed folds each identified by the operator) and the three
    // line-noise runs' bytes changed with the statuses. With the host venting air left sealed
    // first, the rest watch, and link signing's one-byte-longer `Hello` answer (the noise lands
    // elsewhere): 13 739 358 ms, 730 reached, 0 violations. With the grasp task among the
    // ingredients (drawn last; up to 1 kg carried) and a pull's reach holding what the air it
    // compresses may push back up (the D&D → F&P fault runs' statuses carry the wider
    // candidates): 14 197 195 ms, 729 reached, 0 violations; and after the merge of the probe
    // profile's store (which of its changes moved it was not bisected): 14 173 375 ms, 729
    // reached, 0 violations. With the simulated person's folds taking the last 3 s of their
    // 5 s (the trunk's air leaving through the open exhaust meanwhile, not squeezed at once),
    // their answer to an identification given once their hands are off the trunk, the
    // stuck-inlet watch allowing a fold finished after its step stopped waiting, and the top's
    // fold over a packed bottom pulled up to 140 mm: 14 116 668 ms, 731 reached, 0 violations;
    // with the air sealed in a safe-state trunk vented before it is identified, and a refused
    // StartPlan reporting the plan's reach (and a fold by hand ending on its last millisecond,
    // not one after): 14 144 734 ms, 731 reached, 0 violations. With the pack pulled to the
    // winches' whole 185 mm, not 182 (the four D&D → F&P runs above whose plan packs the
    // bottom changed with it): 13 740 276 ms, 732 reached, 0 violations.
    // A change here is a change of behaviour somewhere in the system.
    let r = hil_sim::swarm::swarm(1000, 300, 1);
    assert_eq!(
        (r.runs, r.virtual_ms, r.reached, r.violations.len()),
        (300, 13_740_276, 732, 0)
    );
}
