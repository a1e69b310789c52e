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
    (Fault::ValveStuckClosed, None, "D&D", "F&P", 3, 0x77b6c3282827d341),
    (Fault::ValveStuckClosed, Some(700), "F&F", "D&F", 3, 0x1fc63c6898428ba0),
    (Fault::ValveStuckOpen, None, "F&P", "D&D", 3, 0xa1159bf9edb512fa),
    (Fault::ValveStuckOpen, None, "D&D", "F&P", 3, 0xa1d1c51e17960151),
    (Fault::ValveStuckOpen, Some(700), "F&F", "D&F", 3, 0x327855f870288570),
    (Fault::Leak, None, "F&P", "D&D", 3, 0x7b0708332f81a312),
    (Fault::Leak, None, "D&D", "F&P", 3, 0xe739e6d85a47f137),
    (Fault::Leak, Some(700), "F&F", "D&F", 3, 0x3f40abace6223852),
    (Fault::ServoStall, None, "F&P", "D&D", 3, 0xfd03db21f056fa74),
    (Fault::ServoStall, None, "D&D", "F&P", 3, 0xcd83c9c1e81ade95),
    (Fault::ServoStall, Some(700), "F&F", "D&F", 3, 0xac9315c3f71eed6f),
    (Fault::TendonBreak, None, "F&P", "D&D", 3, 0x166c8c14aa8f5acb),
    (Fault::TendonBreak, None, "D&D", "F&P", 3, 0x8d55e2dadcdf46e2),
    (Fault::TendonBreak, Some(700), "F&F", "D&F", 3, 0x700e1e9bc6434899),
    (Fault::SensorDropout, None, "F&P", "D&D", 3, 0x9b547e2bedbf204f),
    (Fault::SensorDropout, None, "D&D", "F&P", 3, 0x79d135ecf8aa6cc8),
    (Fault::SensorDropout, Some(700), "F&F", "D&F", 3, 0x27a5a62f3191145b),
    (Fault::LinkDrop, None, "F&P", "D&D", 3, 0xe066390729d6b73a),
    (Fault::LinkDrop, None, "D&D", "F&P", 3, 0x7793df9f2cc6bd7f),
    (Fault::LinkDrop, Some(700), "F&F", "D&F", 3, 0x2f64fc3d304292f3),
    (Fault::LineNoise, None, "F&P", "D&D", 3, 0x006f845add621764),
    (Fault::LineNoise, None, "D&D", "F&P", 3, 0xb8ae3ca433a36470),
    (Fault::LineNoise, Some(700), "F&F", "D&F", 3, 0x87f338c6072d4c9b),
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
    // violations. A change here is a change of behaviour somewhere in the system.
    let r = hil_sim::swarm::swarm(1000, 300, 1);
    assert_eq!(
        (r.runs, r.virtual_ms, r.reached, r.violations.len()),
        (300, 12_617_287, 733, 0)
    );
}
