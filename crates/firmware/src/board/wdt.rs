//! The watchdog. The WDT is started in register-start mode (its configuration is written once
//! after reset, then the first refresh starts it): PCLKB/2048, 4096 cycles, no refresh window,
//! reset on underflow — 350 ms at PCLKB = 24 MHz, counting in sleep mode too (WDTCSTPR). The
//! main loop refreshes it every pass; the data-flash waits refresh it too.
//!
//! With a debug probe attached the chip is in on-chip-debug mode, where DBGSTOPCR's reset
//! value (DBGSTOP_WDT = DBGSTOP_IWDT = 1) masks both watchdogs' resets: a board on the bench
//! with a probe would run unguarded. [`start`] clears both bits, so the watchdog resets a hung
//! board whether a probe is attached or not (no effect without one). A debugging session that
//! halts at breakpoints builds with the feature `probe-masks-watchdog`, which keeps the mask
//! (`docs/flashing.md`).
//!
//! The IWDT can only be started by the option bytes (OFS0.IWDTSTRT = 0, auto-start), which this
//! project never writes. If whoever programmed them did start it, it is refreshed as well —
//! otherwise it would reset the board on its own schedule.

use core::ptr::read_volatile;

use protocol::messages::ResetCause;

use super::regs::{pac, rd, wr};

/// OFS0 in the option-setting memory (read only!).
const OFS0_ADDR: usize = 0x0000_0400;
/// OFS0.IWDTSTRT (bit 1): 0 = IWDT auto-starts after reset.
const OFS0_IWDTSTRT: u32 = 1 << 1;
/// OFS0.WDTSTRT (bit 17): 0 = WDT auto-starts with the OFS0 settings; 1 = register start.
const OFS0_WDTSTRT: u32 = 1 << 17;

/// WDTCR: TOPS = 01 (4096 cycles), CKS = 0111 (PCLKB/2048), RPES = 11 (0 %, no window end),
/// RPSS = 11 (100 %, no window start).
const WDTCR: u16 = 0b01 | (0b0111 << 4) | (0b11 << 8) | (0b11 << 12);
/// WDTRCR.RSTIRQS: underflow or refresh error → reset (not NMI).
const WDTRCR_RESET: u8 = 1 << 7;
/// WDTCSTPR.SLCSTP = 0: keep counting in sleep mode (the reset value 1 stops the count while
/// the CPU sleeps in WFI, so a loop stuck asleep — SysTick stopped — would never be reset).
const WDTCSTPR_COUNT_IN_SLEEP: u8 = 0;
/// Timeout in PCLKB cycles (2048 · 4096).
const TIMEOUT_PCLKB_CYCLES: u32 = 2048 * 4096;

#[inline]
fn ofs0() -> u32 {
    // SAFETY: a read of the option-setting memory in code flash (always mapped, read-only).
    unsafe { read_volatile(OFS0_ADDR as *const u32) }
}

#[inline]
fn iwdt_running() -> bool {
    ofs0() & OFS0_IWDTSTRT == 0
}

/// Refreshes the WDT (and the IWDT if the option bytes started it). Stateless: safe to call
/// from any busy-wait.
pub fn feed() {
    wr!(pac::WDT.wdtrr(), 0x00);
    wr!(pac::WDT.wdtrr(), 0xFF);
    if iwdt_running() {
        wr!(pac::IWDT.iwdtrr(), 0x00);
        wr!(pac::IWDT.iwdtrr(), 0xFF);
    }
}

/// Why the board last reset, from the reset status registers (RA4M1 UM, "Resets": RSTSR1
/// IWDTRF 0, WDTRF 1, SWRF 2; RSTSR0 PORF 0, LVD0RF 1, LVD1RF 2, LVD2RF 3), most telling first:
/// a watchdog, a brown-out, a software reset, power-on; none of them set (the RES pin, or a
/// bootloader that cleared them) is `Unknown`. Reads and clears the flags (write 0 after
/// reading 1) so the next reset starts clean.
#[inline]
pub fn take_reset_cause() -> ResetCause {
    let r1 = rd!(pac::SYSTEM.rstsr1());
    let r0 = rd!(pac::SYSTEM.rstsr0());
    if r1 & 0b111 != 0 {
        wr!(pac::SYSTEM.rstsr1(), r1 & !0b111);
    }
    if r0 & 0b1111 != 0 {
        wr!(pac::SYSTEM.rstsr0(), r0 & !0b1111);
    }
    if r1 & 0b11 != 0 {
        ResetCause::Watchdog
    } else if r0 & 0b1110 != 0 {
        ResetCause::BrownOut
    } else if r1 & 0b100 != 0 {
        ResetCause::Software
    } else if r0 & 1 != 0 {
        ResetCause::PowerOn
    } else {
        ResetCause::Unknown
    }
}

/// A name for the log.
#[inline]
pub fn cause_name(c: ResetCause) -> &'static str {
    match c {
        ResetCause::PowerOn => "power-on",
        ResetCause::Watchdog => "watchdog",
        ResetCause::BrownOut => "brown-out",
        ResetCause::Software => "software",
        ResetCause::Unknown => "unknown",
    }
}

/// Starts the WDT; returns its timeout in ms for the log.
#[inline]
pub fn start(pclkb_hz: u32) -> u32 {
    if ofs0() & OFS0_WDTSTRT != 0 {
        // Register-start mode: these writes are accepted once, before the first refresh.
        wr!(pac::WDT.wdtcr(), WDTCR);
        wr!(pac::WDT.wdtrcr(), WDTRCR_RESET);
        wr!(pac::WDT.wdtcstpr(), WDTCSTPR_COUNT_IN_SLEEP);
    }
    if !cfg!(feature = "probe-masks-watchdog") {
        // DBGSTOPCR: DBGSTOP_IWDT (0) and DBGSTOP_WDT (1) = 0, the resets enabled in
        // on-chip-debug mode too.
        wr!(pac::DBG.dbgstopcr(), rd!(pac::DBG.dbgstopcr()) & !0b11);
    }
    feed();
    // In u32 (PCLKB ≥ 1 kHz on any clock tree): a u64 division would link 0.9 KiB of
    // software 64-bit division for one log line.
    TIMEOUT_PCLKB_CYCLES / (pclkb_hz / 1_000).max(1)
}
