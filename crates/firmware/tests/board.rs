//! On-target tests of the board shell (`src/board/`) that need nothing but the board: each
//! driver's observable contract, measured by the chip itself (its cycle counter, its pins'
//! input buffers, its reset flags). Run on a bare UNO R4 with a probe, or in the emulator:
//!
//! ```text
//! cargo test-board-bare                                         # probe-rs
//! CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER=ra4m1-run cargo test-board-bare
//! ```
//! The tests that need a stimulus (a jumper, a known voltage) are in `tests/board_fixture.rs`.
#![no_std]
#![no_main]

use firmware::board;
mod on_target;

#[cfg(test)]
#[embedded_test::tests]
mod tests {
    use embedded_hal::pwm::SetDutyCycle as _;
    use embedded_io::Write as _;
    use protocol::messages::ResetCause;

    use crate::board::gpio::PortPin;
    use crate::board::regs::pac;
    use crate::board::regs::rd;
    use crate::board::{dataflash::DataFlash, lvd, pwm, time, uart, wdt};
    use crate::on_target::{self, get, put, Board};
    use firmware::flash_log::{FlashError, FlashLog, NorFlash, SLOT_LEN};
    use firmware::hw::StateStore as _;
    use firmware::pins::{self, Gpt5, Gpt7};
    use firmware::StoredState;
    use geometry::TrunkState;

    #[init]
    fn init() -> Board {
        on_target::init()
    }

    /// HOCO 48 MHz with the Arduino option bytes, the dividers within the bus limits, and the
    /// SysTick time base at 1 kHz of the core clock (checked against the cycle counter).
    #[test]
    fn clocks_are_the_documented_ones_and_the_tick_is_1_ms(b: Board) {
        let c = b.clocks;
        assert_eq!(
            (c.hoco_hz, c.iclk_hz, c.pclka_hz, c.pclkb_hz),
            (48_000_000, 48_000_000, 48_000_000, 24_000_000)
        );
        assert_eq!(
            (c.pclkc_hz, c.pclkd_hz, c.fclk_hz),
            (48_000_000, 48_000_000, 24_000_000)
        );
        // 100 ticks in cycles: 4 800 000 ± 0.1 % (an interrupt's entry is a few cycles).
        let t0 = time::ticks_ms();
        while time::ticks_ms() == t0 {}
        let (t1, c1) = (time::ticks_ms(), time::cycles());
        while time::ticks_ms().wrapping_sub(t1) < 100 {}
        let cycles = time::cycles().wrapping_sub(c1);
        defmt::info!("100 ticks = {=u32} cycles", cycles);
        assert!(
            cycles.abs_diff(4_800_000) <= 4_800,
            "{cycles} cycles in 100 ticks"
        );
    }

    /// Waits for `level` on `pin` (its PIDR bit), at most `limit` cycles after `start`; the
    /// cycle count when it came.
    fn wait_level(pin: PortPin, level: bool, start: u32, limit: u32) -> Option<u32> {
        let pidr = (0x4004_0000 + 0x20 * pin.port as usize + 4) as *const u32;
        loop {
            // SAFETY: PCNTR2 (PIDR in bits 15..0) of the pin's port: a read-only input register.
            let v = unsafe { core::ptr::read_volatile(pidr) };
            let now = time::cycles();
            if (v >> pin.pin) & 1 == u32::from(level) {
                return Some(now);
            }
            if now.wrapping_sub(start) > limit {
                return None;
            }
        }
    }

    /// (high, period) of the pulses on `pin`, in core cycles, as the pin reads back; `None`
    /// if no whole pulse came within three periods.
    fn pulse(pin: PortPin) -> Option<(u32, u32)> {
        const LIMIT: u32 = 3 * 960_000;
        cortex_m::interrupt::free(|_| {
            let start = time::cycles();
            wait_level(pin, false, start, LIMIT)?;
            let rise = wait_level(pin, true, start, LIMIT)?;
            let fall = wait_level(pin, false, start, LIMIT)?;
            let next = wait_level(pin, true, start, LIMIT)?;
            Some((fall.wrapping_sub(rise), next.wrapping_sub(rise)))
        })
    }

    /// Each servo line carries the commanded pulse width at 50 Hz, measured on the pin (its
    /// input buffer) in core cycles: high = pulse ± 1 µs (48 cycles: the polling loop),
    /// period 20 ms ± 1 µs; the three outputs are independent (A and B of GPT7, A of GPT5).
    /// A duty of 0 leaves the line low for two whole periods (limp, driven low).
    #[test]
    fn gpt_lines_carry_the_commanded_pulse_widths(b: Board) {
        let gpt7 = pwm::Timer::<Gpt7>::start(b.clocks.pclkd_hz);
        let gpt5 = pwm::Timer::<Gpt5>::start(b.clocks.pclkd_hz);
        let mut chans = [
            (gpt7.channel(pins::SERVO0), pins::SERVO0.pin()),
            (gpt7.channel(pins::SERVO1), pins::SERVO1.pin()),
            (gpt5.channel(pins::SERVO2), pins::SERVO2.pin()),
        ];
        let per_us = b.clocks.iclk_hz / 1_000_000;
        for round in [[1_000u32, 1_500, 2_000], [2_000, 1_000, 1_500]] {
            for ((ch, _), us) in chans.iter_mut().zip(round) {
                let max = u32::from(ch.max_duty_cycle());
                assert_eq!(max, 60_000, "20 ms period in counts");
                let _ = ch.set_duty_cycle((max * us / 20_000) as u16);
            }
            // The new compare values take effect at the next cycle end.
            on_target::wait_ms(45);
            for ((_, pin), us) in chans.iter().zip(round) {
                let Some((high, period)) = pulse(*pin) else {
                    panic!("no pulse on P{}{:02}", pin.port, pin.pin);
                };
                defmt::info!(
                    "P{=u8}{=u8:02}: high {=u32} cycles (want {=u32}), period {=u32}",
                    pin.port,
                    pin.pin,
                    high,
                    us * per_us,
                    period
                );
                assert!(
                    high.abs_diff(us * per_us) <= per_us,
                    "high {high} cycles for {us} µs"
                );
                assert!(
                    period.abs_diff(20_000 * per_us) <= per_us,
                    "period {period} cycles"
                );
            }
        }
        for (ch, _) in chans.iter_mut() {
            let _ = ch.set_duty_cycle(0);
        }
        let start = time::cycles();
        for (_, pin) in chans.iter() {
            assert_eq!(
                wait_level(*pin, true, start, 2 * 960_000),
                None,
                "duty 0: P{}{:02} went high",
                pin.port,
                pin.pin
            );
        }
    }

    /// SCI9 sends at 115 200 Bd ± 1 % (the receiver's tolerance): 200 bytes of 10 bits, from
    /// the start of the first (the first `write` starts the line; `write_all` queues the rest
    /// in a fraction of a byte time each, one `write` taking at most 24) to the transmit end
    /// (`flush`), take 2 000 bit times of the core clock.
    #[test]
    fn sci9_transmits_at_115200_baud(b: Board) {
        let mut link = uart::HostUart::new(b.clocks.pclka_hz, pins::HOST_TX, pins::HOST_RX);
        let bytes = [0x55u8; 200];
        let t0 = time::cycles();
        assert_eq!(link.write_all(&bytes), Ok(()), "the ring takes 200 bytes");
        let _ = link.flush();
        let cycles = time::cycles().wrapping_sub(t0);
        let baud = (2_000u64 * u64::from(b.clocks.iclk_hz) / u64::from(cycles)) as u32;
        defmt::info!("200 bytes in {=u32} cycles: {=u32} Bd", cycles, baud);
        assert!(baud.abs_diff(115_200) <= 1_152, "{baud} Bd");
    }

    /// The transmit interrupt entered late — held off by a critical section three character
    /// times long, twenty times while 200 bytes go out — loses nothing: the line runs dry and
    /// goes idle within the bytes' line time (each handler clears its ICU flag at entry; at its
    /// end it would swallow the TXI its own TDR write raised, and the line would never idle).
    #[test]
    fn a_transmit_interrupt_entered_late_loses_nothing(b: Board) {
        let mut link = uart::HostUart::new(b.clocks.pclka_hz, pins::HOST_TX, pins::HOST_RX);
        assert_eq!(link.write_all(&[0x55u8; 200]), Ok(()));
        for _ in 0..20 {
            cortex_m::interrupt::free(|_| time::delay_us(260));
            time::delay_us(100);
        }
        let t0 = on_target::ms();
        while !link.idle() && on_target::ms().wrapping_sub(t0) < 100 {}
        assert!(link.idle(), "the transmitter stopped with bytes queued");
    }

    /// The brown-out reset as `lvd::enable_brownout_reset` arms it (RA4M1 UM, LVD; FSP
    /// `r_lvd`): LVD1CR0 = RN 0 (held in reset until VCC is back), RI 1 (reset), CMPE and RIE
    /// on; the circuit on (LVCMPCR.LVD1E), level 3.84 V, no stale detection; arming twice (as
    /// after a brown-out, with the monitor's registers kept) gives the same.
    #[test]
    fn the_brown_out_reset_holds_the_chip_until_vcc_is_back(_b: Board) {
        for _ in 0..2 {
            lvd::enable_brownout_reset();
            assert_eq!(
                rd!(pac::SYSTEM.lvd1cr0()) & 0xC5,
                0x45,
                "RN 0, RI 1, CMPE 1, RIE 1"
            );
            assert_ne!(rd!(pac::SYSTEM.lvcmpcr()) & (1 << 5), 0, "LVD1E");
            assert_eq!(rd!(pac::SYSTEM.lvdlvlr()) & 0x1F, 0x03, "3.84 V");
            assert_eq!(rd!(pac::SYSTEM.lvd1sr()) & 1, 0, "DET clear");
        }
    }

    /// Starting the watchdog unmasks its reset in on-chip-debug mode (DBGSTOPCR.DBGSTOP_WDT and
    /// DBGSTOP_IWDT = 0), so a board with a probe attached is guarded too.
    #[test]
    fn starting_the_watchdog_unmasks_it_in_debug_mode(b: Board) {
        wdt::start(b.clocks.pclkb_hz);
        assert_eq!(rd!(pac::DBG.dbgstopcr()) & 0b11, 0);
    }

    /// The watchdog does not reset a board that feeds it (1 s fed: three timeouts), and resets
    /// a starved one after its timeout (349.5 ms at PCLKB 24 MHz: 345..=355 ms by the tick),
    /// which the next boot reports as a watchdog reset.
    #[test]
    fn the_watchdog_spares_a_fed_board_and_resets_a_starved_one(b: Board) {
        let ms = wdt::start(b.clocks.pclkb_hz);
        assert_eq!(ms, 349);
        let t0 = on_target::ms();
        while on_target::ms().wrapping_sub(t0) < 1_000 {
            wdt::feed();
            on_target::wait_ms(5);
        }
        // Still here: it did not reset while fed. Now starve it.
        on_target::resume_after_reset(after_starving);
        wdt::feed();
        let t1 = on_target::ms();
        loop {
            put(0, on_target::ms().wrapping_sub(t1));
            cortex_m::asm::wfi(); // the WDT counts in sleep too
        }
    }

    fn after_starving() -> ! {
        let cause = wdt::take_reset_cause();
        let survived = get(0);
        defmt::info!("starved for {=u32} ms", survived);
        assert_eq!(cause, ResetCause::Watchdog);
        assert!((345..=355).contains(&survived), "reset after {survived} ms");
        on_target::pass()
    }

    /// A software reset is reported as one, and reading the cause clears it (the next read,
    /// with no reset in between, says `Unknown`).
    #[test]
    fn the_reset_cause_is_reported_once(_b: Board) {
        on_target::resume_after_reset(after_software_reset);
        cortex_m::peripheral::SCB::sys_reset();
    }

    fn after_software_reset() -> ! {
        assert_eq!(wdt::take_reset_cause(), ResetCause::Software);
        assert_eq!(wdt::take_reset_cause(), ResetCause::Unknown);
        on_target::pass()
    }

    /// Data-flash blocks 4 and 5 (and 6 for a key): free in the board binary (its log is on 0
    /// and 1, its link key on 2).
    const BLOCK: usize = 4;

    fn record(k: usize) -> StoredState {
        StoredState::confirmed(TrunkState::ALL[k])
    }

    /// Repeats `op` while the flash is busy (at most 2 s).
    fn done(mut op: impl FnMut() -> Result<(), FlashError>) -> Result<(), FlashError> {
        let t0 = on_target::ms();
        loop {
            match op() {
                Err(FlashError::Busy) if on_target::ms().wrapping_sub(t0) < 2_000 => {}
                r => return r,
            }
        }
    }

    fn flash() -> DataFlash {
        let c = crate::board::clocks::init();
        DataFlash::new(c.fclk_hz, c.iclk_hz)
    }

    fn fresh_log() -> FlashLog<DataFlash> {
        let mut f = flash();
        for block in [BLOCK, BLOCK + 1] {
            assert_eq!(done(|| f.erase(block)), Ok(()), "erase block {block}");
        }
        FlashLog::new(f, BLOCK)
    }

    /// A saved record is the one loaded after a reset.
    #[test]
    fn a_data_flash_record_survives_a_reset(_b: Board) {
        let mut log = fresh_log();
        assert_eq!(log.load(), Ok(None), "erased");
        assert_eq!(done(|| log.save(&record(3))), Ok(()));
        on_target::resume_after_reset(after_save);
        cortex_m::peripheral::SCB::sys_reset();
    }

    fn after_save() -> ! {
        on_target::init();
        let mut log = FlashLog::new(flash(), BLOCK);
        assert_eq!(log.load(), Ok(Some(record(3))));
        on_target::pass()
    }

    /// Data-flash block 6 holds the link key in these tests (block 2 in the board binary).
    const KEY_BLOCK: usize = BLOCK + 2;
    const KEY: [u8; 16] = *b"crane-test-key-1";

    /// A link key saved beside the log (an erase in the background, then its slot one byte
    /// per call) is the one loaded after a reset; unpairing erases it.
    #[test]
    fn a_link_key_survives_a_reset_and_unpairing_erases_it(_b: Board) {
        let mut log = fresh_log().with_key_block(KEY_BLOCK);
        assert_eq!(done(|| log.save_link_key(None)), Ok(()), "erase the block");
        assert_eq!(log.load_link_key(), Ok(None), "erased: no key");
        assert_eq!(done(|| log.save_link_key(Some(&KEY))), Ok(()));
        on_target::resume_after_reset(after_key_save);
        cortex_m::peripheral::SCB::sys_reset();
    }

    fn after_key_save() -> ! {
        on_target::init();
        let mut log = FlashLog::new(flash(), BLOCK).with_key_block(KEY_BLOCK);
        assert_eq!(log.load_link_key(), Ok(Some(KEY)));
        assert_eq!(done(|| log.save_link_key(None)), Ok(()));
        assert_eq!(log.load_link_key(), Ok(None), "unpaired: erased");
        on_target::pass()
    }

    /// A reset in the middle of a save (a few of the slot's bytes programmed) keeps the
    /// previous record; the next save goes past the torn slot and is the one loaded.
    #[test]
    fn a_torn_write_keeps_the_previous_record(_b: Board) {
        let mut log = fresh_log();
        assert_eq!(done(|| log.save(&record(1))), Ok(()));
        // Each call checks the byte in flight and starts the next: ≈ 5 of 14 bytes.
        for _ in 0..6 {
            assert_eq!(log.save(&record(4)), Err(FlashError::Busy));
            time::delay_us(1_000);
        }
        on_target::resume_after_reset(after_torn_write);
        cortex_m::peripheral::SCB::sys_reset();
    }

    fn after_torn_write() -> ! {
        on_target::init();
        let mut f = flash();
        // The slot after the first record was written to, and is not a valid record.
        let mut slot = [0u8; SLOT_LEN];
        assert_eq!(f.read(BLOCK * 1024 + SLOT_LEN, &mut slot), Ok(()));
        assert!(
            slot.iter().any(|&b| b != 0xFF),
            "nothing was written: not torn"
        );
        let mut log = FlashLog::new(f, BLOCK);
        assert_eq!(log.load(), Ok(Some(record(1))), "the previous record");
        assert_eq!(done(|| log.save(&record(5))), Ok(()));
        let mut again = FlashLog::new(flash(), BLOCK);
        assert_eq!(
            again.load(),
            Ok(Some(record(5))),
            "the next save, after a rescan"
        );
        on_target::pass()
    }

    /// A panic drives every actuator line to its safe level (valves closed, servos limp and
    /// driven low) while the gripper keeps holding (closed), then the watchdog restarts the
    /// board and the next boot says so.
    #[test]
    fn a_panic_leaves_every_output_safe_then_the_watchdog_restarts(b: Board) {
        on_target::provoke_fault(&b, || panic!("deliberate panic (on-target test)"));
    }

    /// A stack overflow (unbounded recursion, 256 bytes a frame) with the stack guard armed
    /// (`board::stack`): the stack pointer monitor's NMI comes while `stack::RESERVE` bytes are
    /// left, the handler drives every actuator line safe while the gripper keeps holding, and
    /// the watchdog restarts the board. (Unguarded, the recursion would run through `.bss` and
    /// `.data` and off the bottom of RAM.)
    #[test]
    fn a_stack_overflow_leaves_every_output_safe_then_the_watchdog_restarts(b: Board) {
        on_target::provoke_fault(&b, overflow);
    }

    fn overflow() -> ! {
        crate::board::stack::guard();
        let n = deep(1_000_000);
        panic!("returned from the recursion: {}", n)
    }

    #[inline(never)]
    fn deep(n: u32) -> u32 {
        let frame = core::hint::black_box([n; 64]);
        if n == 0 {
            return 0;
        }
        deep(n - 1).wrapping_add(core::hint::black_box(frame)[7])
    }

    /// The same for a HardFault (an undefined instruction).
    #[test]
    fn a_hard_fault_leaves_every_output_safe_then_the_watchdog_restarts(b: Board) {
        on_target::provoke_fault(&b, cortex_m::asm::udf);
    }
}
