//! The watchdog. The WDT is started in register-start mode (its configuration is written once
//! after reset, then the first refresh starts it): PCLKB/2048, 4096 cycles, no refresh window,
//! reset on underflow — 350 ms at PCLKB = 24 MHz. The main loop refreshes it every pass; the
//! data-flash waits refresh it too.
//!
//! The IWDT can only be started by the option bytes (OFS0.IWDTSTRT = 0, auto-start), which this
//! project never writes. If whoever programmed them did start it, it is refreshed as well —
//! otherwise it would reset the board on its own schedule.

use core::ptr::read_volatile;

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
/// Timeout in PCLKB cycles (2048 · 4096).
const TIMEOUT_PCLKB_CYCLES: u64 = 2048 * 4096;

fn ofs0() -> u32 {
    // SAFETY: a read of the option-setting memory in code flash (always mapped, read-only).
    unsafe { read_volatile(OFS0_ADDR as *const u32) }
}

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

/// Why the board last reset, as far as the watchdogs tell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct ResetCause {
    /// RSTSR1.WDTRF or RSTSR1.IWDTRF was set: a watchdog reset.
    pub watchdog: bool,
}

/// Reads and clears the watchdog reset flags (RSTSR1 bits 1 and 0; write 0 after reading 1).
pub fn take_reset_cause() -> ResetCause {
    let r = rd!(pac::SYSTEM.rstsr1());
    let wd = r & 0b11 != 0;
    if wd {
        wr!(pac::SYSTEM.rstsr1(), r & !0b11);
    }
    ResetCause { watchdog: wd }
}

/// Starts the WDT; returns its timeout in ms for the log.
pub fn start(pclkb_hz: u32) -> u32 {
    if ofs0() & OFS0_WDTSTRT != 0 {
        // Register-start mode: these writes are accepted once, before the first refresh.
        wr!(pac::WDT.wdtcr(), WDTCR);
        wr!(pac::WDT.wdtrcr(), WDTRCR_RESET);
    }
    feed();
    (TIMEOUT_PCLKB_CYCLES * 1_000 / pclkb_hz.max(1) as u64) as u32
}
