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
    let p = hil_sim::elf_board::built_elf_path();
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
    let plan = transition_graph::Graph::nominal().plan(from, to).unwrap();
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
/// per pass, taking a block it erased as blank without reading it back, and backing off a
/// failing flash keep every pass within one 1 ms tick (48 000 cycles at 48 MHz, the cycle
/// model with its flash and bus wait states; 29 227 measured), whatever the flash does —
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
        sim.elf_board_mut().unwrap().emu.profile_passes(true);
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
        print_profile(emu, &format!("the save, flash fault {fault:?}"));
        assert!(sim.board_error().is_none(), "{:?}", sim.board_error());
        // The bound for storage is 2 ms (96 000 cycles); every pass, this one too,
        // must fit the 1 ms tick with issue 27's 15 % margin (40 800 of 48 000).
        assert!(
            worst <= 40_800,
            "{fault:?}: a pass took {worst} cycles (> 40 800, 85 % of 1 ms)"
        );
        if fault.is_none() {
            assert_eq!(erased, 1, "the full log erased one block in the background");
            // The new state survives a power cut.
            stack_headroom(&sim, &format!("saves with flash fault {fault:?}"));
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
    for cut_ms in (200u64..=6_000).step_by(400) {
        let mut reports = Vec::new();
        for elf_mode in [false, true] {
            let (mut sim, mut host, _) = started_plan(elf_mode);
            let t0 = sim.now_ms();
            while sim.now_ms() < t0 + cut_ms {
                sim.run_for(50);
                let _ = host.send(&mut sim, protocol::RequestBody::Heartbeat);
                host.poll(&mut sim);
            }
            let st = status_after_a_power_cut(&mut sim);
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

/// Issue 27's loop-pass target: 40 800 cycles, 85 % of the 1 ms tick (48 000 at 48 MHz), in
/// the cycle model with its flash wait state and the bus bridges' wait states. The largest
/// plan's upload pass and every pass of a whole plan are held to it (BENCHMARKS.md, "Issue
/// 27": 40 624 and 37 436 when this was set), as the storage test holds the save's.
const PASS_BUDGET_CYCLES: u64 = 40_800;

/// The pass that receives, validates and stores the largest plan (8 steps × 4 bends, accepted:
/// the crane is in their `F&F`), with a status request right behind it on the line; the
/// upload signed under `signed` (key, counter) when given. Returns its cycles (the longest
/// pass from the burst to both answers).
fn largest_upload_pass(sim: &mut Sim, host: &SimHost, signed: Option<(&[u8; 16], u64)>) -> u64 {
    use protocol::messages::{DeviceMessage, Request, RequestBody};
    use protocol::ResultCode;
    sim.run_for(20);
    let _ = sim.read_device_bytes();
    sim.elf_board_mut().unwrap().emu.profile_passes(true);
    sim.elf_board_mut().unwrap().emu.clear_max_awake();
    let session = host.session();
    // Both frames on the line at once, as no host engine sends them (it waits for each
    // answer): framed by hand, deliberately — the pass that receives both is under test.
    let mut line = Vec::new();
    for (seq, body) in [
        (
            100,
            RequestBody::UploadPlan(firmware::bench::largest_plan(9)),
        ),
        (101, RequestBody::GetStatus),
    ] {
        let req = Request { seq, session, body };
        let mut buf = [0u8; protocol::MAX_FRAME_LEN];
        let n = match signed {
            Some((key, counter)) if seq == 100 => {
                protocol::frame::encode_signed(&req, key, counter, &mut buf)
            }
            _ => protocol::encode(&req, &mut buf),
        }
        .unwrap();
        line.extend_from_slice(&buf[..n]);
    }
    sim.write_host_bytes(&line);
    let mut dec = protocol::FrameDecoder::new();
    let mut answers = Vec::new();
    for _ in 0..200 {
        sim.step();
        for b in sim.read_device_bytes() {
            if let Some(Ok(DeviceMessage::Response { seq, result, .. })) =
                dec.push::<DeviceMessage>(b)
            {
                answers.push((seq, result));
            }
        }
    }
    assert_eq!(
        answers,
        [(100, ResultCode::Ok), (101, ResultCode::Ok)],
        "the plan stored, the status answered"
    );
    let what = if signed.is_some() {
        "the largest plan's signed upload"
    } else {
        "the largest plan's upload"
    };
    print_profile(&sim.elf_board().unwrap().emu, what);
    sim.elf_board().unwrap().emu.stats().max_awake_cycles
}

/// The largest plan's upload pass (with a status behind it) and every pass of a whole plan
/// after it stay within the budget.
#[test]
fn the_plan_upload_pass_and_every_pass_of_a_plan_stay_within_the_cycle_budget() {
    let ff: TrunkState = "F&F".parse().unwrap();
    let mut sim = Sim::try_new(SimOptions {
        initial: ff,
        firmware_elf: Some(elf()),
        ..SimOptions::default()
    })
    .expect("loads");
    sim.run_for(50);
    let mut host = SimHost::new();
    host.hello(&mut sim).expect("handshake");
    let upload = largest_upload_pass(&mut sim, &host, None);
    assert!(
        upload <= PASS_BUDGET_CYCLES,
        "upload pass {upload} cycles > {PASS_BUDGET_CYCLES}"
    );
    let one_pass = |sim: &Sim| {
        let s = sim.elf_board().unwrap().emu.longest_stretch();
        !s.back_to_back()
    };
    assert!(one_pass(&sim), "the upload's stretch is one pass");

    sim.elf_board_mut().unwrap().emu.clear_max_awake();
    let plan = transition_graph::Graph::nominal()
        .plan(ff, "D&D".parse().unwrap())
        .unwrap();
    let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
    let (ok, state) = host.run_plan(&mut sim, 3, &steps, 120_000).unwrap();
    assert!(ok && state == "D&D".parse().unwrap(), "{ok} {state}");
    let run = sim.elf_board().unwrap().emu.stats().max_awake_cycles;
    print_profile(&sim.elf_board().unwrap().emu, "a plan");
    assert!(
        run <= PASS_BUDGET_CYCLES,
        "longest pass of the plan {run} cycles > {PASS_BUDGET_CYCLES}"
    );
    assert!(one_pass(&sim), "the plan's longest stretch is one pass");
    eprintln!("upload pass {upload} cycles, longest pass of a plan {run}");
    stack_headroom(&sim, "the largest plan's upload and a plan");
}

/// The same upload signed, with signing on (the key paired and in flash): the MAC runs on
/// every received byte and its tag is checked at the delimiter, and the pass that receives,
/// verifies, validates and stores the largest plan stays within the budget; so does every pass
/// of a whole plan run by a host that signs.
#[test]
fn the_signed_plan_upload_pass_and_every_pass_of_a_signed_plan_stay_within_the_cycle_budget() {
    let (mut sim, _, _) = paired_board();
    sim.power_cycle();
    sim.run_for(100);
    let mut host = SimHost::new();
    let ResponseBody::Hello(info) = host.hello(&mut sim).expect("handshake") else {
        panic!("no device info")
    };
    assert!(info.signing, "{info:?}");
    let upload = largest_upload_pass(&mut sim, &host, Some((&LINK_KEY, 1)));
    eprintln!("signed upload pass {upload} cycles");
    assert!(
        upload <= PASS_BUDGET_CYCLES,
        "signed upload pass {upload} cycles > {PASS_BUDGET_CYCLES}"
    );
    assert!(
        !sim.elf_board()
            .unwrap()
            .emu
            .longest_stretch()
            .back_to_back(),
        "the upload's stretch is one pass"
    );

    // A plan F&F -> D&D from a host that signs every request (counters above the upload's).
    host.set_signing(Some(LINK_KEY), 1_000);
    sim.elf_board_mut().unwrap().emu.clear_max_awake();
    let (ff, dd): (TrunkState, TrunkState) = ("F&F".parse().unwrap(), "D&D".parse().unwrap());
    let plan = transition_graph::Graph::nominal().plan(ff, dd).unwrap();
    let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
    let (ok, state) = host.run_plan(&mut sim, 3, &steps, 120_000).unwrap();
    assert!(ok && state == dd, "a signed plan: {ok} {state}");
    let run = sim.elf_board().unwrap().emu.stats().max_awake_cycles;
    print_profile(&sim.elf_board().unwrap().emu, "a signed plan");
    eprintln!("longest pass of a signed plan {run} cycles");
    assert!(
        run <= PASS_BUDGET_CYCLES,
        "longest pass of the signed plan {run} cycles > {PASS_BUDGET_CYCLES}"
    );
    stack_headroom(&sim, "the largest plan's signed upload and a signed plan");
}

/// Prints where the longest pass's cycles went, per ELF function (largest first).
fn print_profile(emu: &ra4m1_emu::Emulator, what: &str) {
    let p = emu.longest_pass_profile();
    let total: u64 = p.iter().map(|f| f.1).sum();
    let s = emu.longest_stretch();
    eprintln!(
        "longest pass of {what}: {total} cycles (SysTicks at {:?}, {} in handlers)",
        s.ticks_at, s.handler_cycles
    );
    for (name, cycles) in p.iter().take(8) {
        eprintln!("  {cycles:>6}  {name}");
    }
}

/// The stack's high-water mark since the power-on (the emulator's paint) stays clear of the
/// stack guard's limit (`board/stack.rs`: 512 bytes above the stack's end).
fn stack_headroom(sim: &Sim, what: &str) {
    let emu = &sim.elf_board().unwrap().emu;
    let (used, room) = (emu.stack_high_water().unwrap(), emu.stack_size().unwrap());
    eprintln!(
        "stack high-water after {what}: {used} of {room} bytes ({} left)",
        room - used
    );
    assert!(used + 512 < room, "{what}: stack {used} of {room} bytes");
}

/// Whether the ELF actuates: the inlet or the exhaust open (their gate pins high), or a servo
/// away from where it stood at the start (`rest`, degrees).
fn actuating(sim: &Sim, rest: [f32; 3]) -> bool {
    let emu = &sim.elf_board().unwrap().emu;
    let valve = [(1, 4), (3, 1)]
        .iter()
        .any(|&(p, n)| emu.pin_drive(p, n) == ra4m1_emu::PinDrive::High);
    let servo = sim.ground_truth().servo_deg;
    valve || servo.iter().zip(rest).any(|(a, b)| (a - b).abs() > 0.5)
}

/// Cuts the power, boots, and asks a new host's status.
fn status_after_a_power_cut(sim: &mut Sim) -> protocol::messages::Status {
    sim.power_cycle();
    sim.run_for(100);
    let mut host = SimHost::new();
    host.hello(sim).expect("handshake after the cut");
    match host.request(sim, protocol::RequestBody::GetStatus, 1_000) {
        Ok((_, ResponseBody::Status(st))) => st,
        other => panic!("no status after the cut: {other:?}"),
    }
}

/// Uploads and starts the plan F&P → D&F on a fresh board (the ELF, or the host-built
/// controller); returns the sim, its host and the step that starts (its journal record is
/// what the board writes first).
fn started_plan(elf_mode: bool) -> (Sim, SimHost, Step) {
    let from: TrunkState = "F&P".parse().unwrap();
    let plan = transition_graph::Graph::nominal()
        .plan(from, "D&F".parse().unwrap())
        .unwrap();
    let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
    let mut sim = Sim::try_new(SimOptions {
        initial: from,
        firmware_elf: elf_mode.then(elf),
        ..SimOptions::default()
    })
    .unwrap();
    sim.run_for(50);
    let mut host = SimHost::new();
    host.hello(&mut sim).unwrap();
    let p = protocol::messages::Plan {
        plan_id: 5,
        steps: heapless::Vec::from_slice(&steps).unwrap(),
    };
    host.request_ok(&mut sim, protocol::RequestBody::UploadPlan(p), 1_000)
        .unwrap();
    host.request_ok(
        &mut sim,
        protocol::RequestBody::StartPlan { plan_id: 5 },
        1_000,
    )
    .unwrap();
    (sim, host, steps[0].clone())
}

/// The board writes a journal record one byte per pass (≈ 15 ms): the step's first actuation
/// waits until the shell reports the record in flash. Measured pass by pass on the ELF, then a
/// power cut at every millisecond of that window and a few past the first actuation: the boot
/// is truthful — the pre-step state confirmed only if nothing actuated, else unconfirmed with
/// the interrupted step and candidates that hold the truth.
#[test]
fn a_step_actuates_only_after_its_journal_is_in_flash_and_a_cut_before_boots_truthful() {
    let (mut sim, _host, first) = started_plan(true);
    let journal = protocol::Transition {
        from: first.from,
        to: first.to,
    };
    let t0 = sim.now_ms();
    let rest = sim.ground_truth().servo_deg;
    let (mut recorded, mut actuated) = (None, None);
    while sim.now_ms() < t0 + 500 && actuated.is_none() {
        sim.step();
        let t = sim.now_ms() - t0;
        let rec = sim.elf_board().unwrap().stored_record();
        if recorded.is_none() && rec.is_some_and(|r| r.pending == Some(journal)) {
            recorded = Some(t);
        }
        if actuating(&sim, rest) {
            actuated = Some(t);
        }
    }
    let (recorded, actuated) = (recorded.expect("journaled"), actuated.expect("actuated"));
    assert!(
        recorded < actuated,
        "journal complete at {recorded} ms, first actuation at {actuated} ms after the start"
    );
    assert!(
        recorded >= 5,
        "the record takes passes to write: {recorded} ms"
    );
    eprintln!("journal in flash {recorded} ms after the start, first actuation at {actuated} ms");

    for cut_ms in 0..=actuated + 5 {
        let (mut sim, _host, _) = started_plan(true);
        let t0 = sim.now_ms();
        let rest = sim.ground_truth().servo_deg;
        let mut moved = false;
        while sim.now_ms() < t0 + cut_ms {
            sim.step();
            moved |= actuating(&sim, rest);
        }
        let st = status_after_a_power_cut(&mut sim);
        let truth = sim.ground_truth().true_state.expect("at rest");
        if st.state_confirmed {
            assert!(
                !moved,
                "cut at {cut_ms} ms: confirmed after an actuation: {st:?}"
            );
            assert_eq!(
                (st.state, truth),
                (first.from, first.from),
                "cut at {cut_ms} ms"
            );
        } else {
            assert_eq!(st.interrupted, Some(journal), "cut at {cut_ms} ms: {st:?}");
            assert!(st.candidates.contains(truth), "cut at {cut_ms} ms: {st:?}");
        }
        if cut_ms > recorded {
            assert!(
                !st.state_confirmed,
                "cut at {cut_ms} ms, after the journal: {st:?}"
            );
        }
    }
}

/// The key the signing tests pair with.
const LINK_KEY: [u8; 16] = *b"crane-test-key-1";

/// Frames `body` (signed under `key` with `counter`, or plain with `None`), puts it on the
/// line as one burst, and steps the board until the answer to `seq` comes (`None`: none in
/// 200 ms, the frame dropped).
fn exchange(
    sim: &mut Sim,
    session: u32,
    seq: u16,
    body: protocol::RequestBody,
    signed: Option<(&[u8; 16], u64)>,
) -> (Vec<u8>, Option<(protocol::ResultCode, ResponseBody)>) {
    let req = protocol::messages::Request { seq, session, body };
    let mut buf = [0u8; protocol::MAX_FRAME_LEN];
    let n = match signed {
        Some((key, counter)) => protocol::frame::encode_signed(&req, key, counter, &mut buf),
        None => protocol::encode(&req, &mut buf),
    }
    .expect("the request frames");
    let frame = buf[..n].to_vec();
    (frame.clone(), answer_to(sim, &frame, seq))
}

/// Puts `frame` on the line and steps the board until the answer to `seq` (≤ 200 ms).
fn answer_to(
    sim: &mut Sim,
    frame: &[u8],
    seq: u16,
) -> Option<(protocol::ResultCode, ResponseBody)> {
    use protocol::messages::DeviceMessage;
    let _ = sim.read_device_bytes();
    sim.write_host_bytes(frame);
    let mut dec = protocol::FrameDecoder::new();
    for _ in 0..200 {
        sim.step();
        for b in sim.read_device_bytes() {
            if let Some(Ok(DeviceMessage::Response {
                seq: s,
                result,
                body,
            })) = dec.push::<DeviceMessage>(b)
            {
                if s == seq {
                    return Some((result, body));
                }
            }
        }
    }
    None
}

fn pressure_limit(host: &mut SimHost, sim: &mut Sim) -> f32 {
    use protocol::messages::ParamId;
    match host.request(
        sim,
        protocol::RequestBody::GetParam(ParamId::PressureLimitKpa),
        1_000,
    ) {
        Ok((protocol::ResultCode::Ok, ResponseBody::Param { value, .. })) => value,
        other => panic!("{other:?}"),
    }
}

/// The judge holds the pressure to the cap the running board has, not the simulator's boot
/// copy nor its host-built controller's: a `SetParam` the board accepted moves it (the safety
/// check and the ground truth alike, equal to the board's `GetParam` answer), a refused one
/// does not, and a power cut brings back the board's boot cap (no reset keeps a change).
#[test]
fn the_judge_holds_the_pressure_to_the_cap_the_board_elf_has_now() {
    use protocol::messages::{ParamId, RequestBody};
    use protocol::ResultCode;
    let (mut sim, mut host) = sim("F&P");
    let boot = hil_sim::elf_board::boot_pressure_limit_kpa();
    assert_eq!(pressure_limit(&mut host, &mut sim), boot);
    assert_eq!(sim.pressure_limit_kpa(), boot);
    for kpa in [25.0, 52.5] {
        let set = RequestBody::SetParam {
            id: ParamId::PressureLimitKpa,
            value: kpa,
        };
        let (res, _) = host.request(&mut sim, set, 1_000).expect("answered");
        assert_eq!(res, ResultCode::Ok);
        assert_eq!(pressure_limit(&mut host, &mut sim), kpa);
        assert_eq!(sim.safety().pressure_limit_kpa, kpa);
        assert_eq!(sim.ground_truth().pressure_limit_kpa, kpa);
        // The host-built controller the simulator also holds never saw the change.
        assert_eq!(sim.controller().config().pressure_limit_kpa, boot);
    }
    let set = RequestBody::SetParam {
        id: ParamId::PressureLimitKpa,
        value: protocol::HARD_MAX_PRESSURE_KPA + 1.0,
    };
    let (res, _) = host.request(&mut sim, set, 1_000).expect("answered");
    assert!(matches!(res, ResultCode::Rejected(_)), "{res:?}");
    assert_eq!(sim.safety().pressure_limit_kpa, 52.5);

    sim.power_cycle();
    assert_eq!(sim.safety().pressure_limit_kpa, boot);
    sim.run_for(100);
    let mut host = SimHost::new();
    host.hello(&mut sim).expect("handshake after the cut");
    assert_eq!(pressure_limit(&mut host, &mut sim), boot);
    assert_eq!(sim.ground_truth().pressure_limit_kpa, boot);
}

/// Steps the board until `done` (at most `limit_ms`); the milliseconds it took.
fn until(sim: &mut Sim, limit_ms: u64, done: impl Fn(&Sim) -> bool) -> Option<u64> {
    let t0 = sim.now_ms();
    while sim.now_ms() < t0 + limit_ms {
        if done(sim) {
            return Some(sim.now_ms() - t0);
        }
        sim.step();
        let _ = sim.read_device_bytes();
    }
    None
}

/// A board ELF at `F&F`, paired with [`LINK_KEY`] by its first host and the key written to
/// the data flash; returns the sim, that host, and the longest loop pass (cycles) from the
/// pairing request to the key's last byte in flash.
fn paired_board() -> (Sim, SimHost, u64) {
    use protocol::messages::RequestBody;
    use protocol::ResultCode;
    let mut sim = Sim::try_new(SimOptions {
        initial: "F&F".parse().unwrap(),
        firmware_elf: Some(elf()),
        ..SimOptions::default()
    })
    .expect("the ELF loads");
    sim.run_for(50);
    let mut host = SimHost::new();
    let ResponseBody::Hello(info) = host.hello(&mut sim).expect("handshake") else {
        panic!("no device info")
    };
    assert!(!info.signing, "a fresh board: signing off ({info:?})");
    assert_eq!(sim.elf_board().unwrap().stored_link_key(), None);
    sim.elf_board_mut().unwrap().emu.clear_max_awake();
    let (res, _) = host
        .request(
            &mut sim,
            RequestBody::SetSigning {
                key: LINK_KEY,
                enabled: true,
            },
            1_000,
        )
        .expect("answered");
    assert_eq!(res, ResultCode::Ok, "the board pairs");
    let took = until(&mut sim, 500, |s| {
        s.elf_board().unwrap().stored_link_key() == Some(LINK_KEY)
    })
    .expect("the key reaches the data flash");
    let worst = sim.elf_board().unwrap().emu.stats().max_awake_cycles;
    eprintln!("key in data flash {took} ms after the pairing was answered; longest pass {worst}");
    (sim, host, worst)
}

/// Link signing on the board ELF (its key in data-flash block 2, `board/flash_log.rs`):
/// pairing writes the key without a pass beyond the budget; after a power cut the handshake
/// says signing is on; an unsigned parameter change or plan is refused, a forged frame (wrong
/// key) dropped, a replayed one refused, a correctly signed one obeyed and answered; unpairing
/// (itself signed) erases the key's block, and the next boot says signing is off.
#[test]
fn the_board_elf_keeps_its_paired_key_across_a_power_cut_and_obeys_only_signed_frames() {
    use protocol::messages::{ParamId, RejectReason, RequestBody};
    use protocol::ResultCode;
    let (mut sim, _, pairing_pass) = paired_board();
    assert!(
        pairing_pass <= PASS_BUDGET_CYCLES,
        "a pass of the key's save {pairing_pass} cycles > {PASS_BUDGET_CYCLES}"
    );

    sim.power_cycle();
    sim.run_for(100);
    let mut host = SimHost::new();
    let ResponseBody::Hello(info) = host.hello(&mut sim).expect("handshake after the cut") else {
        panic!("no device info")
    };
    assert!(info.signing, "the key survived the power cut ({info:?})");
    let session = host.session();
    let set = |kpa: f32| RequestBody::SetParam {
        id: ParamId::PressureLimitKpa,
        value: kpa,
    };

    // Unsigned, from the session's owner or anyone who read its id: refused.
    let (res, _) = host.request(&mut sim, set(60.0), 1_000).expect("answered");
    assert_eq!(res, ResultCode::Rejected(RejectReason::Unsigned));
    let plan = RequestBody::UploadPlan(firmware::bench::largest_plan(9));
    let (res, _) = host.request(&mut sim, plan, 1_000).expect("answered");
    assert_eq!(res, ResultCode::Rejected(RejectReason::Unsigned));
    assert_eq!(pressure_limit(&mut host, &mut sim), 40.0);

    // Correctly signed: obeyed and answered.
    let (first, ans) = exchange(&mut sim, session, 4_321, set(30.0), Some((&LINK_KEY, 7)));
    assert!(matches!(ans, Some((ResultCode::Ok, _))), "{ans:?}");
    assert_eq!(pressure_limit(&mut host, &mut sim), 30.0);

    // Forged: signed under another key, the trailer does not check out: dropped, unanswered.
    let dropped = |host: &mut SimHost, sim: &mut Sim| match host
        .request(sim, RequestBody::GetStatus, 1_000)
        .expect("answered")
    {
        (ResultCode::Ok, ResponseBody::Status(s)) => s.frames_dropped,
        other => panic!("{other:?}"),
    };
    let before = dropped(&mut host, &mut sim);
    let (_, ans) = exchange(
        &mut sim,
        session,
        4_322,
        set(60.0),
        Some((b"not-the-crane-ky", u64::MAX)),
    );
    assert_eq!(ans, None, "a forged frame is not answered");
    assert_eq!(dropped(&mut host, &mut sim), before + 1);
    assert_eq!(pressure_limit(&mut host, &mut sim), 30.0);

    // Replayed: a later signed change, then the first frame again (its counter is not above
    // the last accepted): refused, its value not set again.
    let (_, ans) = exchange(&mut sim, session, 4_323, set(35.0), Some((&LINK_KEY, 8)));
    assert!(matches!(ans, Some((ResultCode::Ok, _))), "{ans:?}");
    let ans = answer_to(&mut sim, &first, 4_321);
    assert!(
        matches!(ans, Some((ResultCode::Rejected(RejectReason::Unsigned), _))),
        "{ans:?}"
    );
    // The same change under a new seq with an old counter: refused too.
    let (_, ans) = exchange(&mut sim, session, 4_324, set(20.0), Some((&LINK_KEY, 8)));
    assert!(
        matches!(ans, Some((ResultCode::Rejected(RejectReason::Unsigned), _))),
        "{ans:?}"
    );
    assert_eq!(pressure_limit(&mut host, &mut sim), 35.0);

    // Unpairing, signed: the key's block is erased; plain changes are obeyed again.
    let unpair = RequestBody::SetSigning {
        key: [0; 16],
        enabled: false,
    };
    let (_, ans) = exchange(&mut sim, session, 4_325, unpair, Some((&LINK_KEY, 9)));
    assert!(matches!(ans, Some((ResultCode::Ok, _))), "{ans:?}");
    let block = firmware::flash_log::LINK_KEY_BLOCK * 1024;
    let erased = until(&mut sim, 1_000, |s| {
        s.elf_board().unwrap().emu.data_flash()[block..block + 1024]
            .iter()
            .all(|&b| b == 0xFF)
    });
    assert!(erased.is_some(), "the key's block is erased");
    let (res, _) = host.request(&mut sim, set(33.0), 1_000).expect("answered");
    assert_eq!(res, ResultCode::Ok);
    assert_eq!(pressure_limit(&mut host, &mut sim), 33.0);
    sim.power_cycle();
    sim.run_for(100);
    let ResponseBody::Hello(info) = SimHost::new().hello(&mut sim).expect("handshake") else {
        panic!("no device info")
    };
    assert!(
        !info.signing,
        "unpaired: signing off after a boot ({info:?})"
    );
}

/// A key slot torn by a power cut mid-write (its CRC fails) boots with signing off, and the
/// board pairs again.
#[test]
fn a_torn_key_slot_boots_the_board_elf_with_signing_off() {
    use protocol::messages::RequestBody;
    use protocol::ResultCode;
    let (mut sim, _, _) = paired_board();
    let block = firmware::flash_log::LINK_KEY_BLOCK * 1024;
    // The last CRC byte never programmed, as when the power goes before it.
    assert_ne!(sim.elf_board().unwrap().emu.data_flash()[block + 17], 0xFF);
    sim.elf_board_mut().unwrap().emu.data_flash_mut()[block + 17] = 0xFF;
    sim.power_cycle();
    sim.run_for(100);
    let mut host = SimHost::new();
    let ResponseBody::Hello(info) = host.hello(&mut sim).expect("handshake") else {
        panic!("no device info")
    };
    assert!(!info.signing, "a torn slot: signing off ({info:?})");
    let (res, _) = host
        .request(
            &mut sim,
            RequestBody::SetSigning {
                key: *b"crane-test-key-2",
                enabled: true,
            },
            1_000,
        )
        .expect("answered");
    assert_eq!(res, ResultCode::Ok);
    let took = until(&mut sim, 500, |s| {
        s.elf_board().unwrap().stored_link_key() == Some(*b"crane-test-key-2")
    });
    assert!(took.is_some(), "paired again over the torn slot");
}

/// The loop's periodic statistics line (every 10 s, `uno_r4.rs`) is a defmt frame, a critical
/// section: written with a host streaming requests, it masked interrupts across more than one
/// character time and SCI9 (no receive FIFO) overran — one host byte lost, seen once in a CI
/// run's 36 plans over the pty. Without a probe nobody reads RTT and the line is not written:
/// requests streamed across the 10 s and 20 s marks lose no byte and are all answered. With a
/// probe attached the line is there (and its cost is the probe-attached bench's, documented).
#[test]
fn requests_streamed_across_the_statistics_period_lose_no_byte_without_a_probe() {
    use protocol::messages::{Request, RequestBody};
    let (mut sim, host) = sim("F&P");
    let session = host.session();
    let mut seq: u16 = 500;
    // 16 heartbeats every 10 ms (more than 10 ms of line: it never idles) from 9.98 s to
    // 10.02 s, and again around 20 s.
    for mark in [10_000u64, 20_000] {
        while sim.now_ms() < mark - 20 {
            sim.step();
            let _ = sim.read_device_bytes();
        }
        let _ = sim.elf_board_mut().unwrap().emu.rtt_take();
        for _ in 0..4 {
            let mut line = Vec::new();
            for _ in 0..16 {
                let mut buf = [0u8; protocol::MAX_FRAME_LEN];
                let n = protocol::encode(
                    &Request {
                        seq,
                        session,
                        body: RequestBody::Heartbeat,
                    },
                    &mut buf,
                )
                .unwrap();
                line.extend_from_slice(&buf[..n]);
                seq = seq.wrapping_add(1);
            }
            sim.write_host_bytes(&line);
            for _ in 0..10 {
                sim.step();
                let _ = sim.read_device_bytes();
            }
        }
        let sci = &sim.elf_board().unwrap().emu.machine().sci;
        assert_eq!(
            (sci.rx_lost, sci.rx_overruns),
            (0, 0),
            "host bytes lost across the {mark} ms mark"
        );
        assert!(
            sim.elf_board_mut().unwrap().emu.rtt_take().is_empty(),
            "no statistics line without a probe at the {mark} ms mark"
        );
    }
    // A probe attaches: the next pass writes the line into RTT.
    sim.elf_board_mut().unwrap().emu.set_probe(true);
    sim.run_for(20);
    assert!(
        !sim.elf_board_mut().unwrap().emu.rtt_take().is_empty(),
        "the statistics line is written once a probe is attached"
    );
}

/// The board's probe profile (`SetProbeProfile`, kept in data-flash block 3).
mod probe_profile {
    use super::*;
    use firmware::controller::identify::{ProbeProfile, SIM_PROFILE};
    use firmware::store::StoredState;
    use protocol::messages::RequestBody;
    use protocol::{ResultCode, StateSet, SCHEMA_ID};

    fn st(name: &str) -> TrunkState {
        name.parse().unwrap()
    }

    fn set(profile: Option<ProbeProfile>) -> RequestBody {
        RequestBody::SetProbeProfile {
            schema_id: SCHEMA_ID,
            profile,
        }
    }

    fn read(host: &mut SimHost, sim: &mut Sim) -> Option<ProbeProfile> {
        match host.request(sim, RequestBody::GetProbeProfile, 1_000) {
            Ok((ResultCode::Ok, ResponseBody::ProbeProfile(p))) => p,
            other => panic!("{other:?}"),
        }
    }

    fn status(host: &mut SimHost, sim: &mut Sim) -> protocol::Status {
        match host.request(sim, RequestBody::GetStatus, 1_000) {
            Ok((ResultCode::Ok, ResponseBody::Status(s))) => s,
            other => panic!("{other:?}"),
        }
    }

    /// A board ELF at D&P whose profile is `SIM_PROFILE`, stored and on flash; the longest
    /// loop pass from the request to the slot's last byte.
    fn stored_board() -> (Sim, SimHost, u64) {
        let (mut sim, mut host) = sim("D&P");
        assert_eq!(read(&mut host, &mut sim), None, "a fresh board holds none");
        assert_eq!(sim.elf_board().unwrap().stored_probe_profile(), None);
        sim.elf_board_mut().unwrap().emu.clear_max_awake();
        let (res, _) = host
            .request(&mut sim, set(Some(SIM_PROFILE)), 1_000)
            .expect("answered");
        assert_eq!(res, ResultCode::Ok);
        assert_eq!(
            read(&mut host, &mut sim),
            Some(SIM_PROFILE),
            "in force at once"
        );
        let took = until(&mut sim, 500, |s| {
            s.elf_board().unwrap().stored_probe_profile() == Some(SIM_PROFILE)
        })
        .expect("the profile reaches the data flash");
        let worst = sim.elf_board().unwrap().emu.stats().max_awake_cycles;
        eprintln!(
            "profile in data flash {took} ms after the request was answered; longest pass {worst}"
        );
        (sim, host, worst)
    }

    /// Boots the board again unconfirmed between D&F and D&P (a hand fold that was under way),
    /// the trunk truly at D&P, and runs an identification; the belief after it.
    fn identify_after_boot(sim: &mut Sim) -> (protocol::Status, SimHost) {
        let record = StoredState {
            state: st("D&F"),
            confirmed: false,
            candidates: StateSet::single(st("D&F")).with(st("D&P")),
            pending: Some(protocol::Transition {
                from: st("D&F"),
                to: st("D&P"),
            }),
        };
        sim.elf_board_mut().unwrap().save_records(&[record]);
        sim.power_cycle();
        sim.run_for(200);
        let mut host = SimHost::new();
        host.hello(sim).expect("handshake after the cut");
        let s = status(&mut host, sim);
        assert!(!s.state_confirmed, "{s:?}");
        let (res, _) = host
            .request(sim, RequestBody::Identify, 1_000)
            .expect("answered");
        assert_eq!(res, ResultCode::InProgress);
        let mut last = status(&mut host, sim);
        for _ in 0..40 {
            sim.run_for(250);
            last = status(&mut host, sim);
            if last.state_confirmed {
                break;
            }
        }
        (last, host)
    }

    #[test]
    fn the_board_elf_keeps_its_probe_profile_across_a_power_cycle_and_identifies_with_it() {
        let (mut sim, mut host, worst) = stored_board();
        assert!(
            worst <= PASS_BUDGET_CYCLES,
            "a pass of the profile's save {worst} cycles > {PASS_BUDGET_CYCLES}"
        );
        // Refusals change nothing on the flash.
        let mut bad = SIM_PROFILE;
        bad.states[1] = f32::NAN;
        let (res, _) = host.request(&mut sim, set(Some(bad)), 1_000).unwrap();
        assert_eq!(
            res,
            ResultCode::Rejected(protocol::RejectReason::OutOfRange)
        );
        let (res, _) = host
            .request(
                &mut sim,
                RequestBody::SetProbeProfile {
                    schema_id: SCHEMA_ID ^ 0x100,
                    profile: Some(SIM_PROFILE),
                },
                1_000,
            )
            .unwrap();
        assert_eq!(
            res,
            ResultCode::Rejected(protocol::RejectReason::VersionMismatch)
        );
        sim.run_for(100);
        assert_eq!(
            sim.elf_board().unwrap().stored_probe_profile(),
            Some(SIM_PROFILE)
        );

        // After a power cycle the profile is there, and the probe decides: D&P (14.1 kPa/s,
        // its own window) from {D&F, D&P}, with nobody asked.
        let (s, mut host) = identify_after_boot(&mut sim);
        assert_eq!(
            read(&mut host, &mut sim),
            Some(SIM_PROFILE),
            "reloaded at boot"
        );
        assert_eq!((s.state, s.state_confirmed), (st("D&P"), true), "{s:?}");

        // Erased: the block is blank, and the same identification asks the operator (it stays
        // unconfirmed: nobody answers here).
        let (res, _) = host.request(&mut sim, set(None), 1_000).unwrap();
        assert_eq!(res, ResultCode::Ok);
        let block = firmware::flash_log::PROBE_PROFILE_BLOCK * 1024;
        let erased = until(&mut sim, 1_000, |s| {
            s.elf_board().unwrap().emu.data_flash()[block..block + 1024]
                .iter()
                .all(|&b| b == 0xFF)
        });
        assert!(erased.is_some(), "the profile's block is erased");
        let (s, mut host) = identify_after_boot(&mut sim);
        assert!(
            !s.state_confirmed,
            "without a profile nothing decides alone: {s:?}"
        );
        assert_eq!(read(&mut host, &mut sim), None);
    }

    /// A power cut while a new profile is being written (its block erased, its slot part
    /// programmed) boots with no profile (the old one was erased first), never a mix; and the
    /// board stores one again.
    #[test]
    fn a_power_cut_mid_write_boots_the_board_elf_with_no_profile_never_a_mix() {
        let (mut sim, mut host, _) = stored_board();
        let new = ProbeProfile {
            states: [20.0, 21.0, 22.0, 23.0, 24.0, 25.0],
            between: [20.5, 23.5],
        };
        let (res, _) = host.request(&mut sim, set(Some(new)), 1_000).unwrap();
        assert_eq!(res, ResultCode::Ok);
        let block = firmware::flash_log::PROBE_PROFILE_BLOCK * 1024;
        // Step until the slot is part-programmed: its first bytes written, its CRC not yet.
        let torn = until(&mut sim, 1_000, |s| {
            let f = &s.elf_board().unwrap().emu.data_flash()[block..block + 38];
            f[0] != 0xFF && f[36..38] == [0xFF, 0xFF]
        });
        assert!(torn.is_some(), "caught the slot mid-write");
        assert_eq!(sim.elf_board().unwrap().stored_probe_profile(), None);
        sim.power_cycle();
        sim.run_for(200);
        let mut host = SimHost::new();
        host.hello(&mut sim).unwrap();
        assert_eq!(read(&mut host, &mut sim), None, "no profile, not a mix");
        let (res, _) = host.request(&mut sim, set(Some(new)), 1_000).unwrap();
        assert_eq!(res, ResultCode::Ok);
        let took = until(&mut sim, 500, |s| {
            s.elf_board().unwrap().stored_probe_profile() == Some(new)
        });
        assert!(took.is_some(), "stored again over the torn slot");
    }
}
