//! The board fixes, shown on the unmodified `uno-r4` ELF in the emulator.

mod support;

use protocol::messages::{DeviceMessage, ParamId, RequestBody};
use protocol::FrameDecoder;
use ra4m1_emu::Options;
use support::{board, handshake, send, wait_for};

/// With telemetry at its maximum (50 Hz) the link is busy; a status request must still be
/// answered within 20 ms (request on the wire, one pass, the answer on the wire at 115 200 Bd).
#[test]
fn status_answers_within_20_ms_at_50_hz_telemetry() {
    let mut emu = board(Options::default());
    let mut dec = FrameDecoder::default();
    handshake(&mut emu, &mut dec);
    send(
        &mut emu,
        2,
        RequestBody::SetParam {
            id: ParamId::TelemetryHz,
            value: 50.0,
        },
    );
    wait_for(&mut emu, &mut dec, 200, |m| {
        matches!(m, DeviceMessage::Response { seq: 2, .. })
    })
    .expect("SetParam answered");
    let mut worst = 0;
    let mut sent_bytes = 0;
    for k in 0..20u16 {
        // Spread the requests over the telemetry period.
        emu.run_until_ns(emu.now_ns() + (7 + u64::from(k % 5)) * 1_000_000)
            .unwrap();
        let t0 = emu.now_ns();
        send(&mut emu, 10 + k, RequestBody::GetStatus);
        let before = emu.machine().sci.tx_count;
        let (_, _) = wait_for(
            &mut emu,
            &mut dec,
            2_000,
            |m| matches!(m, DeviceMessage::Response { seq, .. } if *seq == 10 + k),
        )
        .unwrap_or_else(|| panic!("status {k} not answered within 2 s"));
        sent_bytes += emu.machine().sci.tx_count - before;
        worst = worst.max((emu.now_ns() - t0) / 1_000);
    }
    eprintln!(
        "status round trip at 50 Hz telemetry: worst {worst} µs; {sent_bytes} bytes sent meanwhile"
    );
    assert!(worst < 20_000, "worst status round trip {worst} µs");
}

/// Throughput: with 50 Hz telemetry and requests the device sends at the line rate, not one
/// byte per 1 ms pass.
#[test]
fn transmission_runs_at_the_line_rate() {
    let mut emu = board(Options::default());
    let mut dec = FrameDecoder::default();
    handshake(&mut emu, &mut dec);
    // Ask for ten statuses at once: ~600 bytes to send.
    for k in 0..10u16 {
        send(&mut emu, 20 + k, RequestBody::GetStatus);
    }
    let t0 = emu.now_ns();
    let before = emu.machine().sci.tx_count;
    wait_for(&mut emu, &mut dec, 2_000, |m| {
        matches!(m, DeviceMessage::Response { seq: 29, .. })
    })
    .expect("ten statuses answered");
    let bytes = emu.machine().sci.tx_count - before;
    let ms = (emu.now_ns() - t0) as f64 / 1e6;
    // The ten requests themselves take ~10 ms on the wire; the answers follow at 11.5 kB/s.
    let line_ms = bytes as f64 * 10.0 / 115_385.0 * 1e3;
    eprintln!("{bytes} bytes answered in {ms:.1} ms (line time {line_ms:.1} ms)");
    assert!(bytes > 400, "{bytes}");
    assert!(
        ms < line_ms + 15.0,
        "{bytes} bytes took {ms:.1} ms; the line needs {line_ms:.1} ms"
    );
}

fn hello_info(emu: &mut ra4m1_emu::Emulator) -> protocol::messages::DeviceInfo {
    let mut dec = FrameDecoder::default();
    for _ in 0..100 {
        send(emu, 1, RequestBody::hello());
        if let Some((
            DeviceMessage::Response {
                body: protocol::messages::ResponseBody::Hello(info),
                ..
            },
            _,
        )) = wait_for(emu, &mut dec, 20, |m| {
            matches!(m, DeviceMessage::Response { seq: 1, .. })
        }) {
            return info;
        }
    }
    panic!("no answer to Hello within 2 s");
}

/// Servo pins (port, pin, GPT channel, output B).
const SERVOS: [(usize, usize, usize, bool); 3] =
    [(3, 4, 7, false), (3, 3, 7, true), (1, 1, 5, false)];

#[test]
fn limp_servo_lines_are_driven_low_not_released() {
    let mut emu = board(Options::default());
    emu.run_until_ns(100_000_000).unwrap();
    for (port, pin, ch, b) in SERVOS {
        assert_eq!(
            emu.timer_pin(port, pin, ch, b),
            ra4m1_emu::Line::Level(false),
            "servo on P{port}{pin:02}: limp must be a driven low (0 % duty, output enabled)"
        );
    }
}

#[test]
fn the_bootloaders_interrupt_state_is_cleared_and_the_wdt_counts_in_sleep() {
    let mut emu = board(Options::default());
    // Before the first instruction: the WiFi bootloader's SCI9 links with their lines pending.
    assert_ne!(emu.machine().icu.ielsr[2] & (1 << 16), 0);
    assert_ne!(emu.machine().scs.pending & 0b1100, 0);
    emu.run_until_ns(100_000_000).unwrap();
    let m = emu.machine();
    for n in 4..32 {
        assert_eq!(m.icu.ielsr[n], 0, "IELSR{n}");
    }
    assert_eq!(
        m.scs.pending & !m.scs.enabled,
        0,
        "no stale pending line: {:#x}",
        m.scs.pending
    );
    assert_eq!(m.icu.ielsr[2] & (1 << 16), 0, "IELSR2.IR");
    assert!(!m.wdt.stops_in_sleep(), "WDTCSTPR.SLCSTP must be 0");
    assert!(m.wdt.running);
}

#[test]
fn the_minima_boots_without_the_bootloaders_sci9() {
    let mut emu = board(Options {
        board: ra4m1_emu::Board::Minima,
        ..Options::default()
    });
    let info = hello_info(&mut emu);
    assert_eq!(info.reset_cause, protocol::messages::ResetCause::PowerOn);
}

#[test]
fn a_hard_fault_makes_every_output_safe_then_the_watchdog_restarts_and_says_so() {
    use ra4m1_emu::PinDrive;
    let mut emu = board(Options::default());
    assert_eq!(
        hello_info(&mut emu).reset_cause,
        protocol::messages::ResetCause::PowerOn
    );
    emu.inject_hard_fault();
    let t = emu.now_ns();
    emu.run_until_ns(t + 1_000_000).unwrap();
    for (port, pin) in [(1, 4), (1, 11)] {
        assert_eq!(
            emu.pin_drive(port, pin),
            PinDrive::Low,
            "valve P{port}{pin:02} closed"
        );
    }
    for (port, pin, _, _) in SERVOS {
        assert_eq!(
            emu.pin_drive(port, pin),
            PinDrive::Low,
            "servo line P{port}{pin:02} low"
        );
    }
    assert!(emu.resets().is_empty());
    // Halted in the handler: the watchdog (350 ms) restarts the board.
    emu.run_until_ns(t + 400_000_000).unwrap();
    assert_eq!(emu.resets(), &[ra4m1_emu::ResetKind::Watchdog]);
    let info = hello_info(&mut emu);
    assert_eq!(info.reset_cause, protocol::messages::ResetCause::Watchdog);
}

#[test]
fn a_brown_out_holds_the_board_in_reset_and_is_reported() {
    let mut emu = board(Options::default());
    hello_info(&mut emu);
    let t = emu.now_ns();
    emu.set_vcc_mv(3_500);
    emu.run_until_ns(t + 20_000_000).unwrap();
    assert_eq!(emu.resets(), &[ra4m1_emu::ResetKind::BrownOut]);
    assert!(emu.machine().held_in_reset, "held while VCC < Vdet1");
    emu.set_vcc_mv(5_000);
    let info = hello_info(&mut emu);
    assert_eq!(info.reset_cause, protocol::messages::ResetCause::BrownOut);
    assert!(!emu.machine().held_in_reset);
}

/// A probe that put the RTT channel in blocking mode and went away with the buffer full: with
/// `defmt-rtt`'s `disable-blocking-mode` the board's next log line is dropped, not waited for —
/// no hang, no watchdog reset, the link keeps answering (the stats line is due every 10 s).
#[test]
fn a_probe_gone_in_blocking_mode_does_not_hang_the_board() {
    let mut emu = board(Options::default());
    hello_info(&mut emu);
    let rtt = emu
        .symbol("_SEGGER_RTT")
        .expect("defmt-rtt's control block");
    // Header: 16-byte id, max up/down channels; up channel 0: name, buffer, size, write,
    // read, flags.
    let ch = rtt + 24;
    let size = emu.read_u32(ch + 8).expect("size");
    let write = emu.read_u32(ch + 12).expect("write");
    assert!(
        emu.write_u32(ch + 16, (write + 1) % size),
        "read offset: the buffer is full"
    );
    assert!(
        emu.write_u32(ch + 20, 2),
        "flags: SEGGER_RTT_MODE_BLOCK_IF_FIFO_FULL"
    );
    let t = emu.now_ns();
    emu.run_until_ns(t + 12_000_000_000).unwrap();
    assert!(
        emu.resets().is_empty(),
        "the board hung: {:?}",
        emu.resets()
    );
    let mut dec = FrameDecoder::default();
    send(&mut emu, 40, RequestBody::GetStatus);
    assert!(
        wait_for(&mut emu, &mut dec, 200, |m| matches!(
            m,
            DeviceMessage::Response { seq: 40, .. }
        ))
        .is_some(),
        "the board still answers"
    );
}

/// Fail-closed gripper (P100, high = closed, `docs/hardware.md`): a board holding a load that
/// is reset — by the watchdog after a HardFault, by a brown-out — never drives the gripper
/// open, from the fault through the reset, the bootloader window (the pin released: the
/// recommended pull-up holds it closed) and the boot, to well after the first loop passes.
/// Sampled every 50 µs.
#[test]
fn the_gripper_never_opens_across_a_watchdog_reset_or_a_brown_out() {
    use ra4m1_emu::PinDrive;
    const GRIPPER: (usize, usize) = (1, 0);
    let mut emu = board(Options::default());
    hello_info(&mut emu);
    assert_eq!(
        emu.pin_drive(GRIPPER.0, GRIPPER.1),
        PinDrive::High,
        "boots closed"
    );
    let watch = |emu: &mut ra4m1_emu::Emulator, ms: u64, what: &str| {
        let end = emu.now_ns() + ms * 1_000_000;
        while emu.now_ns() < end {
            let t = emu.now_ns() + 50_000;
            emu.run_until_ns(t).unwrap();
            let d = emu.pin_drive(GRIPPER.0, GRIPPER.1);
            assert!(
                matches!(d, PinDrive::High | PinDrive::Released { .. }),
                "{what}: gripper {d:?} at {} µs",
                emu.now_ns() / 1_000
            );
        }
    };
    // HardFault → safe state (the gripper keeps holding) → watchdog reset → boot.
    emu.inject_hard_fault();
    watch(&mut emu, 600, "watchdog");
    assert_eq!(emu.resets(), &[ra4m1_emu::ResetKind::Watchdog]);
    assert_eq!(emu.pin_drive(GRIPPER.0, GRIPPER.1), PinDrive::High);
    // Brown-out: held in reset (pins released) while VCC is low, then the boot.
    emu.set_vcc_mv(3_500);
    watch(&mut emu, 20, "brown-out");
    assert!(emu.machine().held_in_reset);
    emu.set_vcc_mv(5_000);
    watch(&mut emu, 300, "after the brown-out");
    assert!(emu.resets().starts_with(&[
        ra4m1_emu::ResetKind::Watchdog,
        ra4m1_emu::ResetKind::BrownOut
    ]));
    assert_eq!(
        emu.pin_drive(GRIPPER.0, GRIPPER.1),
        PinDrive::High,
        "driven closed again"
    );
}
