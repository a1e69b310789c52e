//! The crane firmware for the Arduino UNO R4 (Minima or WiFi): Renesas RA4M1, Cortex-M4F.
//!
//! A thin shell: bring up the clocks and the peripherals ([`firmware::board`], the pins of
//! [`firmware::pins`]), wrap them in the
//! controller's hardware adapters, then run [`firmware::hw::Shell::step`] once per millisecond
//! and refresh the watchdog. All crane logic (protocol, plans, interlocks, standalone mode)
//! is in [`firmware::Controller`].
//!
//! Build: `cargo firmware` (alias: release `firmware` profile for `thumbv7em-none-eabihf`);
//! flash: `docs/flashing.md`; wiring: `docs/hardware.md`.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception, ExceptionFrame};
use defmt_rtt as _;

use firmware::board;
use firmware::board::gpio::{OpenDrain, Output, PullUpInput};
use firmware::board::log::{error, info, warn};
use firmware::board::pwm;
use firmware::flash_log::{self, LINK_KEY_BLOCK, PROBE_PROFILE_BLOCK, STATE_LOG_FIRST_BLOCK};
use firmware::hw::{PinInputs, PinOutputs, ServoOutput, ServoPulse, Shell};
use firmware::pins::{self, Gpt5, Gpt7};
use firmware::CraneConfig;

/// TM1637 brightness 0..=7.
const DISPLAY_BRIGHTNESS: u8 = 4;
/// How often the loop statistics are logged.
const STATS_PERIOD_MS: u64 = 10_000;
/// A display byte (≈ 6 600 cycles of bit-banging at 100 kHz) is clocked out only in a pass
/// whose step took at most this many cycles; a heavier pass (a frame decoded, validated and
/// answered) leaves it to the next one, so the two never add up: every pass stays within
/// 40 800 cycles, 85 % of the 1 ms tick (BENCHMARKS.md, "Issue 27"). A pass's step is
/// ≈ 8 000 cycles most of the time, so a redraw is late by a pass or two at most.
const DISPLAY_STEP_MAX_CYCLES: u32 = 30_000;

use board::safe::halt;

/// The board this binary is built for (feature `board-minima`; the WiFi otherwise).
const BOARD: protocol::messages::Board = if cfg!(feature = "board-minima") {
    protocol::messages::Board::UnoR4Minima
} else {
    protocol::messages::Board::UnoR4Wifi
};

#[entry]
fn main() -> ! {
    // Interrupts stay off (the bootloader leaves PRIMASK set; make sure) until every handler's
    // peripheral is ready.
    cortex_m::interrupt::disable();
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        halt()
    };
    // The bootloader's interrupt links (IELSR0..3: SCI9 on the WiFi, USBFS on the Minima) and
    // NVIC state go
    // before anything is configured.
    board::irq::clear_bootloader_state(&mut cp.NVIC);
    if !board::gpio::self_check() {
        error!("PFS/PORT address formulas disagree with the PAC");
        halt();
    }

    let clocks = board::clocks::init();
    board::clocks::enable_modules();
    let mut clock =
        board::time::Clock::start(&mut cp.SYST, &mut cp.DCB, &mut cp.DWT, clocks.iclk_hz);
    let reset = board::wdt::take_reset_cause();
    let wdt_ms = board::wdt::start(clocks.pclkb_hz);
    board::lvd::enable_brownout_reset();
    board::stack::guard();
    info!(
        "uno-r4: {} reset {=str} wdt {} ms",
        clocks,
        board::wdt::cause_name(reset),
        wdt_ms
    );

    // Actuators first, in their safe state: valves closed, servos driven low (limp), and the
    // gripper high = closed, as the fail-closed wiring (docs/hardware.md) held it through the
    // reset: the init never opens it; only the controller's first output decides.
    let inlet = Output::new(pins::INLET);
    let exhaust = Output::new(pins::EXHAUST);
    let gripper = Output::new_high(pins::GRIPPER);
    let gpt7 = pwm::Timer::<Gpt7>::start(clocks.pclkd_hz);
    let gpt5 = pwm::Timer::<Gpt5>::start(clocks.pclkd_hz);
    let pulse = ServoPulse::default();
    let servos = (
        ServoOutput::new(gpt7.channel(pins::SERVO0), pulse),
        ServoOutput::new(gpt7.channel(pins::SERVO1), pulse),
        ServoOutput::new(gpt5.channel(pins::SERVO2), pulse),
    );
    let outputs = PinOutputs {
        servos,
        inlet,
        exhaust,
        gripper,
    };

    let mut adc = board::adc::Adc::new();
    let inputs = PinInputs {
        pressure: adc.channel(pins::PRESSURE),
        joystick_x: adc.channel(pins::JOY_X),
        joystick_y: adc.channel(pins::JOY_Y),
        up: PullUpInput::new(pins::BTN_UP),
        down: PullUpInput::new(pins::BTN_DOWN),
        gripper: PullUpInput::new(pins::BTN_GRIPPER),
        estop: PullUpInput::new(pins::BTN_ESTOP),
        confirm: PullUpInput::new(pins::BTN_CONFIRM),
        show_pressure: PullUpInput::new(pins::BTN_SHOW),
    };

    let display = board::tm1637::Tm1637::new(
        Output::new(pins::TM_CLK),
        OpenDrain::new(pins::TM_DIO),
        DISPLAY_BRIGHTNESS,
    );
    let flash = board::dataflash::DataFlash::new(clocks.fclk_hz, clocks.iclk_hz);
    // A failing save is retried with back-off; an erase runs in the background (DataFlash).
    let store = flash_log::Backoff::new(
        flash_log::FlashLog::new(flash, STATE_LOG_FIRST_BLOCK)
            .with_key_block(LINK_KEY_BLOCK)
            .with_profile_block(PROBE_PROFILE_BLOCK),
        board::time::ticks_ms,
    );
    let link = board::uart::HostUart::new(clocks.pclka_hz, pins::HOST_TX, pins::HOST_RX);

    let mut shell = Shell::new(inputs, outputs, display, store, link);
    let config = CraneConfig {
        board: BOARD,
        ..CraneConfig::default()
    };
    let mut ctl = shell.boot(config, clock.now_ms());
    if reset == protocol::messages::ResetCause::Watchdog {
        warn!("restarted by the watchdog");
        ctl.report_watchdog_reset();
    } else {
        ctl.set_reset_cause(reset);
    }
    // SAFETY: every interrupt source is configured (SysTick, SCI9 RXI/ERI/TXI/TEI); nothing
    // else is unmasked in the NVIC.
    unsafe { cortex_m::interrupt::enable() };

    let mut worst_cycles: u32 = 0;
    let mut next_stats_ms = STATS_PERIOD_MS;
    loop {
        let now = clock.now_ms();
        let t0 = board::time::cycles();
        shell.step(&mut ctl, now);
        // One byte of a display redraw per pass (a whole one would take 0.7 ms), in a pass
        // with room for it.
        let mut spent = board::time::cycles().wrapping_sub(t0);
        if spent <= DISPLAY_STEP_MAX_CYCLES {
            shell.display.poll();
            spent = board::time::cycles().wrapping_sub(t0);
        }
        worst_cycles = worst_cycles.max(spent);
        board::wdt::feed();
        // Only with a probe attached, the one reader of the RTT log: a defmt frame is a
        // critical section (for this line interrupts stay off longer than one character at
        // 115 200 Bd, and SCI9 has no receive FIFO: the emulator saw a host byte overrun in
        // it), so with nobody reading RTT the line would cost host bytes for nothing.
        if now >= next_stats_ms && cortex_m::peripheral::DCB::is_debugger_attached() {
            next_stats_ms = now + STATS_PERIOD_MS;
            let s = shell.stats;
            info!(
                "step worst {} cycles; errors out {} disp {} store {} link {}; rx dropped {}",
                worst_cycles,
                s.output_errors,
                shell.display.missed_acks,
                s.store_errors,
                s.link_errors,
                shell.link.dropped()
            );
        }
        // 1 kHz: sleep until the next SysTick (or a received byte) moves time on.
        while clock.now_ms() == now {
            cortex_m::asm::wfi();
        }
    }
}

/// The panic info is not read: touching it (even only its location) keeps `core::fmt` and
/// every panic site's message and file path in the image, 3.2 KiB of the 40 KiB flash budget.
/// The controller has no panicking path by construction (`deny(clippy::unwrap_used, …)`; what
/// is left are index checks the optimiser could not prove), so a panic here is a firmware
/// defect: the log says so, the actuators go safe, and the watchdog reset is reported to the
/// host; the site is found by running the same input in the emulator (`ra4m1-run`).
#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    board::safe::fault(|| error!("panic"))
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    board::safe::fault(|| error!("hard fault at pc {=u32:#010x}", ef.pc()))
}

/// The stack pointer monitor (`board::stack`): the stack overflowed into its last
/// `board::stack::RESERVE` bytes. The safe state, then the watchdog.
#[exception]
unsafe fn NonMaskableInt() {
    board::safe::fault(|| error!("stack overflow (stack pointer monitor)"))
}

/// An exception or interrupt nobody configured (every unused vector): the safe state, then
/// the watchdog.
#[exception]
unsafe fn DefaultHandler(irqn: i16) -> ! {
    board::safe::fault(|| error!("unexpected exception {=i16}", irqn))
}

defmt::timestamp!("{=u32:us}", {
    // Cycle counter → µs: a relative stamp for ordering log lines (wraps every 89 s).
    board::time::cycles() / 48
});
