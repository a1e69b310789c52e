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

/// The loop's longest pass, with the storage of one state change in it: with both log blocks
/// full the save must erase a block first. Erasing in the background, programming one byte
/// per pass and backing off a failing flash keep every pass within one 1 ms tick (48 000
/// cycles at 48 MHz, the cycle model with its flash wait state), whatever the flash does —
/// well inside the 2 ms the storage may delay a pass.
#[test]
fn storage_never_stretches_a_loop_pass_beyond_1_ms_even_with_a_broken_flash() {
    use firmware::StoredState;
    use ra4m1_emu::FlashFault;
    for fault in [
        None,
        Some(FlashFault::ProgramError),
        Some(FlashFault::EraseError),
        Some(FlashFault::Hang),
    ] {
        let mut sim = Sim::try_new(SimOptions {
            initial: "D&F".parse().unwrap(),
            firmware_elf: Some(elf()),
            ..SimOptions::default()
        })
        .expect("loads");
        let d_f: TrunkState = "D&F".parse().unwrap();
        // 127 more records (no two in a row alike, or the log would skip one), the newest D&F
        // confirmed: both 64-slot blocks full, so the next save must erase one.
        let f_f: TrunkState = "F&F".parse().unwrap();
        let wear: Vec<StoredState> = (0..127)
            .map(|i| match i {
                126 => StoredState::confirmed(d_f),
                125 => StoredState {
                    state: d_f,
                    confirmed: false,
                    candidates: protocol::StateSet::single(d_f).with(f_f),
                    pending: None,
                },
                _ => StoredState::confirmed(if i % 2 == 0 { f_f } else { d_f }),
            })
            .collect();
        let board = sim.elf_board_mut().expect("ELF mode");
        board.save_records(&wear);
        board.emu.set_flash_fault(fault);
        sim.run_for(50);
        let mut host = SimHost::new();
        host.hello(&mut sim).expect("handshake");
        let erases_before = sim.elf_board().unwrap().emu.machine().flash.erases;
        sim.elf_board_mut().unwrap().emu.clear_max_awake();
        host.request_ok(
            &mut sim,
            protocol::RequestBody::DeclareState("F&F".parse().unwrap()),
            1_000,
        )
        .expect("declared");
        for _ in 0..12 {
            sim.run_for(250);
            let _ = host.send(&mut sim, protocol::RequestBody::Heartbeat);
        }
        let emu = &sim.elf_board().unwrap().emu;
        let worst = emu.stats().max_awake_cycles;
        let erased =
            emu.machine().flash.erases.iter().sum::<u64>() - erases_before.iter().sum::<u64>();
        let df = emu.data_flash();
        let used = |b: usize| (0..64).filter(|k| df[b * 1024 + k * 16] != 0xFF).count();
        eprintln!(
            "flash fault {fault:?}: longest pass {worst} cycles; blocks erased {erased}; slots used {} + {}; programs {}",
            used(0),
            used(1),
            emu.machine().flash.programs
        );
        assert!(sim.board_error().is_none(), "{:?}", sim.board_error());
        assert!(
            worst < 96_000,
            "{fault:?}: a pass took {worst} cycles (> 2 ms)"
        );
        if fault.is_none() {
            assert_eq!(erased, 1, "the full log erased one block in the background");
            // The new state survives a power cut.
            sim.power_cycle();
            sim.run_for(50);
            let mut host = SimHost::new();
            host.hello(&mut sim)
                .expect("handshake after the power cycle");
            let Ok((_, ResponseBody::Status(st))) =
                host.request(&mut sim, protocol::RequestBody::GetStatus, 1_000)
            else {
                panic!("no status")
            };
            assert_eq!(st.state, "F&F".parse().unwrap());
        }
    }
}

/// A power cut mid-step on the board ELF: after the reboot the device reports exactly what the
/// host-built controller reports for the same cut (the journal record survives in the
/// emulated data flash and the same boot logic reads it), and the report is truthful: a
/// confirmed state is the true one, an unconfirmed one names the interrupted step and
/// candidates that include the truth.
#[test]
fn a_power_cut_mid_step_boots_the_elf_into_a_truthful_report() {
    let from: TrunkState = "F&P".parse().unwrap();
    let to: TrunkState = "D&F".parse().unwrap();
    let plan = planner::graph::Graph::nominal().plan(from, to).unwrap();
    let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
    for cut_ms in (200u64..=6_000).step_by(400) {
        let mut reports = Vec::new();
        for elf_mode in [false, true] {
            let mut sim = Sim::try_new(SimOptions {
                initial: from,
                firmware_elf: elf_mode.then(elf),
                ..SimOptions::default()
            })
            .unwrap();
            sim.run_for(50);
            let mut host = SimHost::new();
            host.hello(&mut sim).unwrap();
            let mut p = protocol::messages::Plan {
                plan_id: 5,
                steps: heapless::Vec::new(),
            };
            for s in &steps {
                p.steps.push(s.clone()).unwrap();
            }
            host.request_ok(&mut sim, protocol::RequestBody::UploadPlan(p), 1_000)
                .unwrap();
            host.request_ok(
                &mut sim,
                protocol::RequestBody::StartPlan { plan_id: 5 },
                1_000,
            )
            .unwrap();
            let t0 = sim.now_ms();
            while sim.now_ms() < t0 + cut_ms {
                sim.run_for(50);
                let _ = host.send(&mut sim, protocol::RequestBody::Heartbeat);
                host.poll(&mut sim);
            }
            sim.power_cycle();
            sim.run_for(100);
            let mut host = SimHost::new();
            host.hello(&mut sim).expect("handshake after the cut");
            let Ok((_, ResponseBody::Status(st))) =
                host.request(&mut sim, protocol::RequestBody::GetStatus, 1_000)
            else {
                panic!("no status after the cut")
            };
            // Truthful: a confirmed state is the true one; an unconfirmed report names the
            // step that was cut and its candidates hold the truth.
            let truth = sim
                .ground_truth()
                .true_state
                .expect("at rest in a named state");
            if st.state_confirmed {
                assert_eq!(st.state, truth, "elf {elf_mode}, cut at {cut_ms} ms");
            } else {
                assert!(
                    st.interrupted.is_some(),
                    "elf {elf_mode}, cut at {cut_ms} ms: {st:?}"
                );
                assert!(
                    st.candidates.contains(truth),
                    "elf {elf_mode}, cut at {cut_ms} ms: {st:?}"
                );
            }
            reports.push((st.state, st.state_confirmed, st.candidates, st.interrupted));
        }
        if reports[0] != reports[1] {
            // The board programs a record one byte per pass (≈ 15 ms for a slot): cut within
            // that window after a confirmation, its newest complete record is still the step's
            // journal, while the host-built controller's store is written at once. Both are
            // truthful (checked above); the ELF's must be exactly that journal.
            let (state, confirmed, _, _) = reports[0];
            let (_, elf_confirmed, _, elf_interrupted) = reports[1];
            assert!(
                confirmed && !elf_confirmed && elf_interrupted.is_some_and(|t| t.to == state),
                "cut at {cut_ms} ms: host-built {:?} vs ELF {:?}",
                reports[0],
                reports[1]
            );
        }
    }
}

/// The display decoded from the TM1637 pins and the buttons read from the port pins: the ELF
/// shows what the host-built controller shows, and a press of the gripper button (a switch to
/// ground on P107) opens the gripper, which boots closed (P100 high: fail-closed).
#[test]
fn the_elf_drives_the_display_and_reads_the_buttons_like_the_controller() {
    for initial in ["F&P", "D&F", "D&D"] {
        let mut shown = Vec::new();
        for elf_mode in [false, true] {
            let mut sim = Sim::try_new(SimOptions {
                initial: initial.parse().unwrap(),
                firmware_elf: elf_mode.then(elf),
                ..SimOptions::default()
            })
            .unwrap();
            sim.run_for(500);
            shown.push(sim.ground_truth().display);
            if elf_mode {
                assert!(sim.ground_truth().gripper_closed, "{initial}: boots closed");
                sim.set_buttons(firmware::Buttons {
                    gripper: true,
                    ..Default::default()
                });
                sim.run_for(100);
                sim.set_buttons(firmware::Buttons::default());
                sim.run_for(500);
                assert!(
                    !sim.ground_truth().gripper_closed,
                    "{initial}: the button opens the gripper"
                );
            }
        }
        assert_eq!(shown[0], shown[1], "{initial}: host-built vs ELF display");
        assert!(!shown[1].trim().is_empty(), "{initial}: something is shown");
    }
}
