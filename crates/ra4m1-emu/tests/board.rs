//! The board fixes, shown on the unmodified `uno-r4` ELF in the emulator.

mod support;

use firmware::pins::{self, GptOutput};
use protocol::messages::{DeviceMessage, ParamId, RequestBody};
use protocol::FrameDecoder;
use ra4m1_emu::Options;
use support::{at, board, handshake, send, wait_for};

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

/// The servo lines of the pin map: (port, pin, GPT channel, output B).
fn servos() -> [(usize, usize, usize, bool); 3] {
    pins::SERVO_LINES.map(|l| {
        let (port, pin) = at(l.pin);
        (port, pin, l.channel.into(), l.output == GptOutput::B)
    })
}

/// The valve gates of the pin map, `(port, pin)`.
fn valves() -> [(usize, usize); 2] {
    [at(pins::INLET.pin()), at(pins::EXHAUST.pin())]
}

/// The GPT model reads back the timer's waveform on every servo pin of the map (it knows the
/// GTIOC function of those pins): a servo line read through PIDR is the timer's, not a latch.
#[test]
fn the_models_gtioc_pins_cover_every_servo_line_of_the_pin_map() {
    for s in servos() {
        assert!(
            ra4m1_emu::machine::GTIOC_PINS.contains(&s),
            "servo line {s:?} is not a GTIOC pin the model reads back"
        );
    }
}

#[test]
fn limp_servo_lines_are_driven_low_not_released() {
    let mut emu = board(Options::default());
    emu.run_until_ns(100_000_000).unwrap();
    for (port, pin, ch, b) in servos() {
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
    // Before the first instruction: the WiFi bootloader's SCI9 links (IELSR0..3: TXI, TEI,
    // RXI, ERI), TXI and TEI requesting with their lines pending.
    assert_eq!(emu.machine().icu.ielsr[0], 0xA9 | (1 << 16));
    assert_eq!(emu.machine().icu.ielsr[2] & 0x1FF, 0xA8);
    assert_ne!(emu.machine().scs.pending & 0b0011, 0);
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
    assert_eq!(m.icu.ielsr[0] & (1 << 16), 0, "IELSR0.IR");
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
    for (port, pin) in valves() {
        assert_eq!(
            emu.pin_drive(port, pin),
            PinDrive::Low,
            "valve P{port}{pin:02} closed"
        );
    }
    for (port, pin, _, _) in servos() {
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

/// Brown-out (voltage monitor 1, `board/lvd.rs`): the board is held in reset for as long as
/// VCC is below Vdet1 — sampled every 0.1 ms over 20 ms, it never runs (LVD1CR0.RN = 0; with
/// RN = 1 the chip would restart 0.2 ms after the reset asserted and run on the low supply) —
/// is released once VCC is back, reports the brown-out, and is guarded again: the monitor's
/// registers survive its reset (LVD1E still set, DET latched), so the boot re-arms it in the
/// manual's order, and a second sag resets and holds it again.
#[test]
fn a_brown_out_holds_the_board_in_reset_and_is_reported() {
    let mut emu = board(Options::default());
    hello_info(&mut emu);
    for round in 1..=2 {
        let t = emu.now_ns();
        emu.set_vcc_mv(3_500);
        emu.run_until_ns(t + 1_000_000).unwrap();
        for k in 0..200 {
            emu.run_until_ns(emu.now_ns() + 100_000).unwrap();
            assert!(
                emu.machine().held_in_reset,
                "round {round}: running at {} µs after the sag (VCC < Vdet1)",
                k * 100 + 1_000
            );
        }
        let brown_outs = emu
            .resets()
            .iter()
            .filter(|&&r| r == ra4m1_emu::ResetKind::BrownOut)
            .count();
        assert!(brown_outs >= round, "round {round}: {:?}", emu.resets());
        emu.set_vcc_mv(5_000);
        let info = hello_info(&mut emu);
        assert_eq!(info.reset_cause, protocol::messages::ResetCause::BrownOut);
        assert!(!emu.machine().held_in_reset);
    }
}

/// SCI9's transmit-data-empty handler entered late (held off for 3 character times while a
/// response is going out, as a long critical section would): the handler clears its ICU
/// flag first (`board/uart.rs`), so the TXI that its own TDR write raises at once on the idle
/// shifter is not lost — the response completes and the link keeps answering. (Cleared at
/// the end, that TXI is swallowed: the transmitter stops with TX_ACTIVE set, for good.)
#[test]
fn a_transmit_interrupt_entered_late_does_not_stop_the_link() {
    const TXI_LINE: u32 = 2; // IEL2 ← SCI9_TXI (board/uart.rs)
    let mut emu = board(Options::default());
    let mut dec = FrameDecoder::default();
    handshake(&mut emu, &mut dec);
    for k in 0..5u16 {
        let before = emu.machine().sci.tx_count;
        send(&mut emu, 50 + k, RequestBody::GetStatus);
        // Until the response is on the wire, then hold the TXI off for 3 frames (260 µs).
        let end = emu.now_ns() + 50_000_000;
        while emu.machine().sci.tx_count < before + 2 && emu.now_ns() < end {
            emu.run_until_ns(emu.now_ns() + 10_000).unwrap();
        }
        assert!(
            emu.machine().sci.tx_count > before,
            "request {k}: no answer started"
        );
        emu.hold_irq(TXI_LINE, 260_000);
        assert!(
            wait_for(&mut emu, &mut dec, 100, |m| matches!(
                m,
                DeviceMessage::Response { seq, .. } if *seq == 50 + k
            ))
            .is_some(),
            "status {k} not answered after a late TXI"
        );
    }
}

/// With a debug probe attached (on-chip-debug mode, where DBGSTOPCR's reset value masks the
/// watchdog's reset), the board binary still has its watchdog: it clears DBGSTOP_WDT at boot,
/// so a board halted by a fault is restarted within the 350 ms timeout.
#[test]
fn the_watchdog_guards_the_board_with_a_probe_attached() {
    let mut emu = board(Options {
        probe: true,
        ..Options::default()
    });
    hello_info(&mut emu);
    assert_eq!(
        emu.machine().dbgstopcr & 0b11,
        0,
        "DBGSTOP_WDT/IWDT cleared"
    );
    emu.inject_hard_fault();
    let t = emu.now_ns();
    emu.run_until_ns(t + 400_000_000).unwrap();
    assert_eq!(emu.resets(), &[ra4m1_emu::ResetKind::Watchdog]);
}

/// The board parked in the bootloader (a second reset within its 500 ms window,
/// `arduino-renesas-bootloader` `src/main.c`): the bootloader drives P111 (low, and on the
/// Minima fades it from GTIOC3A) and on the WiFi fades P102; no actuator of the board's pin map
/// (`firmware::pins`) is on those pins, so every actuator line is released: the valves' gate
/// pull-downs keep them closed, the servos get no pulse, the gripper's pull-up keeps it closed.
#[test]
fn a_board_parked_in_the_bootloader_drives_no_actuator() {
    use ra4m1_emu::PinDrive;
    // The pin map's actuator lines: the valves, the gripper, the servos.
    let mut actuators = vec![at(pins::GRIPPER.pin())];
    actuators.extend(valves());
    actuators.extend(servos().map(|(port, pin, _, _)| (port, pin)));
    for b in [ra4m1_emu::Board::Minima, ra4m1_emu::Board::Wifi] {
        let mut emu = board(Options {
            board: b,
            ..Options::default()
        });
        hello_info(&mut emu);
        emu.park_in_bootloader().unwrap();
        let t = emu.now_ns();
        emu.run_until_ns(t + 1_000_000_000).unwrap();
        let fade = if b == ra4m1_emu::Board::Minima {
            (1, 11)
        } else {
            (1, 2)
        };
        assert!(
            matches!(emu.pin_drive(fade.0, fade.1), PinDrive::Peripheral { .. }),
            "{b:?}: the bootloader fades its LED pin"
        );
        for &(port, pin) in &actuators {
            assert!(
                matches!(emu.pin_drive(port, pin), PinDrive::Released { .. }),
                "{b:?}: actuator P{port}{pin:02} is {:?} in the parked bootloader",
                emu.pin_drive(port, pin)
            );
        }
        // A power cycle leaves the bootloader (no double-tap magic after a power-on reset).
        emu.power_cycle().unwrap();
        hello_info(&mut emu);
    }
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
    let gripper = at(pins::GRIPPER.pin());
    let mut emu = board(Options::default());
    hello_info(&mut emu);
    assert_eq!(
        emu.pin_drive(gripper.0, gripper.1),
        PinDrive::High,
        "boots closed"
    );
    let watch = |emu: &mut ra4m1_emu::Emulator, ms: u64, what: &str| {
        let end = emu.now_ns() + ms * 1_000_000;
        while emu.now_ns() < end {
            let t = emu.now_ns() + 50_000;
            emu.run_until_ns(t).unwrap();
            let d = emu.pin_drive(gripper.0, gripper.1);
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
    assert_eq!(emu.pin_drive(gripper.0, gripper.1), PinDrive::High);
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
        emu.pin_drive(gripper.0, gripper.1),
        PinDrive::High,
        "driven closed again"
    );
}

/// The stack guard of the board binary (`board/stack.rs`): the stack pointer monitor is armed
/// at boot over the stack less its bottom 512 bytes; a main stack grown below that limit (the
/// SP set there between two blocks of the running loop, as an overflow would leave it) raises
/// the monitor's NMI at once, whose handler drives every actuator line safe; the watchdog then
/// restarts the board. Also the stack's high-water mark of an idle second, by the paint.
#[test]
fn a_stack_overflow_is_caught_by_the_stack_pointer_monitor() {
    use ra4m1_emu::PinDrive;
    let mut emu = board(Options::default());
    hello_info(&mut emu);
    let m = emu.machine();
    assert!(m.spmon.enabled(), "the monitor is armed at boot");
    let end = emu.symbol("_stack_end").expect("cortex-m-rt's _stack_end");
    assert_eq!(m.spmon.sa, end + 512);
    assert_eq!(m.spmon.ea, 0x2000_7FFF);
    let used = emu.stack_high_water().expect("painted");
    let room = emu.stack_size().expect("stack symbols");
    eprintln!("stack: {used} of {room} bytes used after boot and a handshake");
    assert!(used > 1_000 && used < room - 512, "{used}");
    emu.set_sp(end + 400);
    let t = emu.now_ns();
    emu.run_until_ns(t + 1_000_000).unwrap();
    assert_ne!(emu.machine().icu.nmisr & (1 << 12), 0, "NMISR.SPEST");
    let servo_pins = servos().map(|(port, pin, _, _)| (port, pin));
    for (port, pin) in valves().into_iter().chain(servo_pins) {
        assert_eq!(
            emu.pin_drive(port, pin),
            PinDrive::Low,
            "P{port}{pin:02} safe"
        );
    }
    emu.run_until_ns(t + 400_000_000).unwrap();
    assert_eq!(emu.resets(), &[ra4m1_emu::ResetKind::Watchdog]);
}
