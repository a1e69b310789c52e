//! Shared by the on-target suites (`tests/board.rs`, `tests/board_fixture.rs`): the bring-up
//! every test starts from, the fault handlers, and a way for a test to go on after a reset it
//! provokes (watchdog, software reset).
//!
//! Across a reset: embedded-test runs one test per boot (the runner resets the chip and
//! answers the test's SYS_GET_CMDLINE with its entry); a second request in the same test means
//! an unexpected reset, and the runner fails the test. A test that resets on purpose
//! registers a continuation first ([`resume_after_reset`]): a record in `.uninit` RAM, which a
//! reset keeps. At the next boot, before asking for its command, the binary's setup runs it
//! ([`resume_if_set`]). The continuation passes by exiting through semihosting ([`pass`]),
//! fails by panicking; it checks the reset cause itself where that is the contract.
//!
//! With a probe attached, probe-rs catches resets and HardFaults (DEMCR.VC_CORERESET and
//! VC_HARDERR, set before each test) and the RA4M1 masks the watchdog's reset in on-chip-debug
//! mode (DBGSTOPCR.DBGSTOP_WDT = 1 after reset): [`resume_after_reset`] clears both. DEMCR
//! keeps its value through a system reset, so the catch bits also tell the test's own reset
//! (clear) from probe-rs's reset before the next test (set again): a record left by a test that
//! timed out before its reset came is dropped then, not run in the next test's place.
#![allow(dead_code)] // each suite uses a part

use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};

use crate::board;
use crate::board::gpio::{pfs, PortPin};
use crate::board::regs::{pac, rd, wr};
use defmt_rtt as _;
use firmware::pins::{self, Gpt5, Gpt7};

/// Runs before each test asks for its command: a pending continuation first.
#[embedded_test::setup]
fn setup() {
    resume_if_set();
}

/// What every test starts from: the board binary's bring-up (interrupt hand-over, clocks,
/// modules, the 1 ms time base), interrupts on. The reset flags of the start are cleared, so
/// a continuation sees only the reset its test provoked.
pub struct Board {
    /// The clock frequencies.
    pub clocks: board::clocks::Clocks,
    /// The 1 ms time base.
    pub clock: board::time::Clock,
}

/// Brings the board up as `uno-r4` does (see `src/bin/uno_r4.rs`).
pub fn init() -> Board {
    cortex_m::interrupt::disable();
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        panic!("cortex-m peripherals taken twice");
    };
    board::irq::clear_bootloader_state(&mut cp.NVIC);
    assert!(board::gpio::self_check(), "PFS/PORT formulas");
    let clocks = board::clocks::init();
    board::clocks::enable_modules();
    let clock = board::time::Clock::start(&mut cp.SYST, &mut cp.DCB, &mut cp.DWT, clocks.iclk_hz);
    let _ = board::wdt::take_reset_cause();
    // SAFETY: SysTick is configured; the UART tests unmask SCI9's lines themselves.
    unsafe { cortex_m::interrupt::enable() };
    Board { clocks, clock }
}

/// The test passed (from a continuation, where there is no test function to return from).
pub fn pass() -> ! {
    defmt::info!("Test exited with () or Ok(..)");
    semihosting::process::exit(0)
}

/// Milliseconds of the time base.
pub fn ms() -> u32 {
    board::time::ticks_ms()
}

/// Waits `ms` milliseconds on the time base, asleep between SysTicks (as the board's loop
/// does), feeding nothing.
pub fn wait_ms(ms: u32) {
    let t0 = board::time::ticks_ms();
    while board::time::ticks_ms().wrapping_sub(t0) < ms {
        cortex_m::asm::wfi();
    }
}

// ---- across a reset ----------------------------------------------------------------------

#[repr(C)]
struct Carry {
    magic: u32,
    resume: usize,
    words: [u32; 8],
}

/// DEMCR (ARMv7-M), with the vector-catch bits a probe sets: reset (bit 0), HardFault (10).
const DEMCR: *mut u32 = 0xE000_EDFC as *mut u32;
const VC_CORERESET: u32 = 1 << 0;
const VC_HARDERR: u32 = 1 << 10;

const MAGIC: u32 = 0x4341_5259;

#[link_section = ".uninit.ON_TARGET_CARRY"]
static mut CARRY: MaybeUninit<Carry> = MaybeUninit::uninit();

fn carry() -> *mut Carry {
    core::ptr::addr_of_mut!(CARRY).cast()
}

/// Stores word `i` (0..8) for the continuation.
pub fn put(i: usize, v: u32) {
    // SAFETY: a plain RAM word of the carry record; only this boot's code touches it.
    unsafe { core::ptr::addr_of_mut!((*carry()).words[i]).write_volatile(v) }
}

/// Word `i` as the test before the reset left it.
pub fn get(i: usize) -> u32 {
    // SAFETY: as `put`.
    unsafe { core::ptr::addr_of!((*carry()).words[i]).read_volatile() }
}

/// After the next reset, `then` runs instead of a new test. Lets the reset through a debug
/// probe (see the module doc).
pub fn resume_after_reset(then: fn() -> !) {
    for i in 0..8 {
        put(i, 0);
    }
    // SAFETY: the carry record's header; volatile so the stores are done before the reset.
    unsafe {
        core::ptr::addr_of_mut!((*carry()).resume).write_volatile(then as usize);
        core::ptr::addr_of_mut!((*carry()).magic).write_volatile(MAGIC);
    }
    let_resets_through_a_probe();
}

/// Runs a pending continuation (from the suites' `#[embedded_test::setup]`).
pub fn resume_if_set() {
    // SAFETY: reads of the carry record (uninitialised RAM reads as some bit pattern; only the
    // magic number makes it meaningful), then its magic is cleared so it runs once.
    let (magic, resume) = unsafe {
        let c = carry();
        let v = (
            core::ptr::addr_of!((*c).magic).read_volatile(),
            core::ptr::addr_of!((*c).resume).read_volatile(),
        );
        core::ptr::addr_of_mut!((*c).magic).write_volatile(0);
        v
    };
    if magic != MAGIC {
        return;
    }
    // SAFETY: a read of DEMCR, a core debug register without read side effects.
    if unsafe { DEMCR.read_volatile() } & VC_CORERESET != 0 {
        defmt::warn!("a continuation left by a test that timed out: dropped");
        return;
    }
    // SAFETY: `resume` was stored from a `fn() -> !` of this same image by
    // `resume_after_reset`, and the magic number says the record is that one.
    let then: fn() -> ! = unsafe { core::mem::transmute::<usize, fn() -> !>(resume) };
    then()
}

/// Clears the reset and HardFault vector catches (DEMCR bits 0 and 10) and unmasks the
/// watchdog resets in on-chip-debug mode (DBGSTOPCR bits 0 and 1); no effect without a probe.
fn let_resets_through_a_probe() {
    // SAFETY: DEMCR is a read/write core debug register; only the two catch bits change.
    unsafe { DEMCR.write_volatile(DEMCR.read_volatile() & !(VC_CORERESET | VC_HARDERR)) };
    wr!(pac::DBG.dbgstopcr(), rd!(pac::DBG.dbgstopcr()) & !0b11);
}

// ---- faults --------------------------------------------------------------------------------

/// A fault (panic or HardFault) is what the running test provokes: the handlers then do what
/// the board binary's do (`board::safe::fault`), observe the pins in its report step, and let
/// the watchdog restart the board.
static FAULT_EXPECTED: AtomicBool = AtomicBool::new(false);
/// Carry words of the observation.
pub const OBSERVED: usize = 7;
/// [`OBSERVED`]'s value once the handler ran.
pub const OBSERVED_MAGIC: u32 = 0x5AFE_0B5D;
/// Carry word of the unsafe-line mask.
pub const UNSAFE_LINES: usize = 6;
/// Carry word: the gripper line still drives closed (1) after the fault.
pub const GRIPPER_HELD: usize = 5;

/// The next fault is the test's: observe the safe state, then the watchdog, then `then`.
pub fn expect_fault(then: fn() -> !) {
    resume_after_reset(then);
    FAULT_EXPECTED.store(true, Ordering::SeqCst);
}

fn pfs_of(p: PortPin) -> u32 {
    let a = 0x4004_0800 + 0x40 * p.port as usize + 4 * p.pin as usize;
    // SAFETY: the pin's PmnPFS register; reading has no side effects.
    unsafe { core::ptr::read_volatile(a as *const u32) }
}

/// The actuator lines not in their safe state, one bit each: inlet 0, exhaust 1, servos
/// 2..=4. Safe = a GPIO output (PMR = 0, PDR = 1) set low (PODR = 0) and reading low (PIDR).
pub fn unsafe_lines() -> u32 {
    let lines = [
        pins::INLET.pin(),
        pins::EXHAUST.pin(),
        pins::SERVO0.pin(),
        pins::SERVO1.pin(),
        pins::SERVO2.pin(),
    ];
    let mut mask = 0;
    for (i, p) in lines.into_iter().enumerate() {
        let f = pfs_of(p);
        let safe =
            f & pfs::PMR == 0 && f & pfs::PDR != 0 && f & pfs::PODR == 0 && f & (1 << 1) == 0;
        if !safe {
            mask |= 1 << i;
        }
    }
    mask
}

/// Whether the gripper line drives its closed level (high: GPIO output, PODR = 1, reads high).
pub fn gripper_closed() -> bool {
    let f = pfs_of(pins::GRIPPER.pin());
    f & pfs::PMR == 0 && f & pfs::PDR != 0 && f & pfs::PODR != 0 && f & (1 << 1) != 0
}

/// Every actuator line out of its safe state: both valves open, the three servos pulsing at
/// 1.5 ms; the gripper holding (closed); the watchdog running (so a halted board restarts).
pub fn actuate(b: &Board) {
    use embedded_hal::digital::OutputPin as _;
    use embedded_hal::pwm::SetDutyCycle as _;
    let _ = board::gpio::Output::new_high(pins::GRIPPER);
    let _ = board::gpio::Output::new(pins::INLET).set_high();
    let _ = board::gpio::Output::new(pins::EXHAUST).set_high();
    let gpt7 = board::pwm::Timer::<Gpt7>::start(b.clocks.pclkd_hz);
    let gpt5 = board::pwm::Timer::<Gpt5>::start(b.clocks.pclkd_hz);
    for mut ch in [
        gpt7.channel(pins::SERVO0),
        gpt7.channel(pins::SERVO1),
        gpt5.channel(pins::SERVO2),
    ] {
        let d = (u32::from(ch.max_duty_cycle()) * 1_500 / 20_000) as u16;
        let _ = ch.set_duty_cycle(d);
    }
    board::wdt::start(b.clocks.pclkb_hz);
}

/// The fault tests: every line actuated (checked), the fault expected, then `fault` (a panic,
/// an undefined instruction); [`after_fault`] checks the rest after the watchdog's reset.
pub fn provoke_fault(b: &Board, fault: fn() -> !) -> ! {
    actuate(b);
    assert_eq!(unsafe_lines(), 0b1_1111, "all lines actuated");
    assert!(gripper_closed(), "the gripper holding");
    expect_fault(after_fault);
    fault()
}

fn observe() {
    put(UNSAFE_LINES, unsafe_lines());
    put(GRIPPER_HELD, u32::from(gripper_closed()));
    put(OBSERVED, OBSERVED_MAGIC);
}

/// The continuation of the fault tests: the handler ran and found every line safe, and the
/// watchdog restarted the board.
pub fn after_fault() -> ! {
    let cause = board::wdt::take_reset_cause();
    assert_eq!(
        get(OBSERVED),
        OBSERVED_MAGIC,
        "the fault handler never reached its report"
    );
    assert_eq!(
        get(UNSAFE_LINES),
        0,
        "lines not safe after the fault (bit 0 inlet, 1 exhaust, 2..4 servos)"
    );
    assert_eq!(get(GRIPPER_HELD), 1, "the gripper let go in the fault");
    assert_eq!(cause, protocol::messages::ResetCause::Watchdog);
    pass()
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    if FAULT_EXPECTED.swap(false, Ordering::SeqCst) {
        board::safe::fault(observe)
    }
    defmt::error!("panicked: {}", defmt::Display2Format(info));
    semihosting::process::abort()
}

/// The stack pointer monitor's NMI (`board::stack`), as the board binary handles it.
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    if FAULT_EXPECTED.swap(false, Ordering::SeqCst) {
        board::safe::fault(observe)
    }
    defmt::error!("NMI (stack pointer monitor)");
    semihosting::process::abort()
}

#[cortex_m_rt::exception]
unsafe fn HardFault(ef: &cortex_m_rt::ExceptionFrame) -> ! {
    if FAULT_EXPECTED.swap(false, Ordering::SeqCst) {
        board::safe::fault(observe)
    }
    defmt::error!("hard fault at pc {=u32:#010x}", ef.pc());
    semihosting::process::abort()
}
