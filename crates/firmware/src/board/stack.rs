//! The stack guard: the RA4M1's CPU stack pointer monitor (RA4M1 UM, "CPU Stack Pointer
//! Monitor"; `ra4m1-pac` `SPMON`, ICU `NMIER.SPEEN`) watches the main stack pointer and raises
//! the NMI once it leaves `MSPMPUSA..=MSPMPUEA`. The region is the stack (cortex-m-rt's
//! `_stack_end`, the end of the static RAM, to `_stack_start`, the top of RAM) less
//! [`RESERVE`] bytes at its bottom: an overflow is caught while that much real stack is left
//! below the limit, which the NMI handler runs on (its exception frame, FP context included,
//! the safe state, one log line). The handler is the safe state (`board::safe::fault`), then
//! the watchdog. Without the guard an overflow would grow over `.uninit`, `.bss` and `.data`
//! (the UART rings, the RTT buffer, the log state) before anything noticed.
//!
//! Not verified on silicon: the region's format (start with the low two bits 0, end with the
//! low two bits 1) is the PAC's; the emulator models the monitor as described there.

use super::regs::{pac, wr};

/// Stack bytes below the monitored region, for the NMI handler.
pub const RESERVE: u32 = 512;
/// NMIER.SPEEN: the stack pointer monitor's NMI.
const NMIER_SPEEN: u16 = 1 << 12;
/// The key of MSPMPUOAD and MSPMPUPT.
const KEY: u16 = 0xA5 << 8;

extern "C" {
    static _stack_end: u32;
    static _stack_start: u32;
}

/// The monitored region `(start, end)`, end inclusive.
#[inline]
pub fn region() -> (u32, u32) {
    // Linker symbols: only their addresses are taken, never their contents.
    let (end, top) = (
        core::ptr::addr_of!(_stack_end) as u32,
        core::ptr::addr_of!(_stack_start) as u32,
    );
    (((end + RESERVE) + 3) & !3, (top - 1) | 3)
}

/// Arms the monitor (NMI on detection) and locks its registers until the next reset.
#[inline]
pub fn guard() {
    let (start, end) = region();
    wr!(pac::SPMON.mspmpuoad(), KEY); // OAD = 0: NMI
    wr!(pac::SPMON.mspmpusa(), start);
    wr!(pac::SPMON.mspmpuea(), end);
    wr!(pac::ICU.nmier(), NMIER_SPEEN);
    wr!(pac::SPMON.mspmpuctl(), 1); // ENABLE
    wr!(pac::SPMON.mspmpupt(), KEY | 1); // PROTECT
}
