//! Processor in the loop: the board's `uno-r4` ELF in the RA4M1 emulator drives the simulated
//! crane in-process (the same physics and parts as the host-built controller).

use std::path::PathBuf;
use std::time::Instant;

use geometry::TrunkState;
use hil_sim::host::SimHost;
use hil_sim::{Sim, SimOptions};
use protocol::messages::{ResponseBody, Step};

/// `cargo firmware`'s ELF (or `$UNO_R4_ELF`); panics with the command that builds it.
fn elf() -> PathBuf {
    let p = std::env::var_os("UNO_R4_ELF")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
            std::env::var_os("CARGO_TARGET_DIR")
                .map_or(root.join("target"), PathBuf::from)
                .join("thumbv7em-none-eabihf/firmware/uno-r4")
        });
    assert!(
        p.is_file(),
        "{} is missing: build it with `cargo firmware`",
        p.display()
    );
    p
}

fn sim(initial: &str) -> (Sim, SimHost) {
    let mut sim = Sim::try_new(SimOptions {
        initial: initial.parse().unwrap(),
        firmware_elf: Some(elf()),
        ..SimOptions::default()
    })
    .expect("the ELF loads");
    sim.run_for(50);
    let mut host = SimHost::new();
    let hello = host.hello(&mut sim).expect("the ELF answers the handshake");
    let ResponseBody::Hello(info) = hello else {
        panic!("{hello:?}")
    };
    assert_eq!(info.board, protocol::messages::Board::UnoR4Wifi);
    (sim, host)
}

#[test]
fn the_elf_runs_a_plan_on_the_simulated_crane() {
    let (mut sim, mut host) = sim("F&P");
    let from: TrunkState = "F&P".parse().unwrap();
    let to: TrunkState = "D&D".parse().unwrap();
    let plan = planner::graph::Graph::nominal().plan(from, to).unwrap();
    let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
    let wall = Instant::now();
    let t0 = sim.now_ms();
    let (ok, state) = host
        .run_plan(&mut sim, 3, &steps, 120_000)
        .expect("plan finishes");
    let virt = sim.now_ms() - t0;
    eprintln!(
        "plan {from}->{to}: ok {ok} state {state}; {virt} ms virtual in {:?} wall",
        wall.elapsed()
    );
    let truth = sim.ground_truth();
    assert!(sim.board_error().is_none(), "{:?}", sim.board_error());
    assert!(ok, "{truth:?}");
    assert_eq!(truth.true_state, Some(to), "{truth:?}");
    assert!(truth.actuators_safe, "{truth:?}");
}
