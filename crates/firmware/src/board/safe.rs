//! The safe state without any driver state, for panic, HardFault and unexpected interrupts,
//! when nothing else can be trusted: both valve gates low (closed valves seal the trunk, which
//! holds its shape) and the three servo lines switched from their timer to GPIO outputs driven
//! low (no pulses: the servos go limp, driving nothing). The gripper keeps its level (it holds
//! whatever it holds). Then [`halt`] waits for the watchdog, which restarts the board.
//!
//! Raw register writes only (no PAC handle, no driver): a fault handler may run with any of
//! them in an unknown state. The on-target tests (`tests/board.rs`) check both paths, panic
//! and HardFault, through the same functions the board binary's handlers call.

use super::gpio::pfs;
use crate::pins;

/// Drives every actuator line to its safe level (idempotent).
pub fn outputs() {
    for p in [pins::INLET.pin(), pins::EXHAUST.pin()] {
        let port = 0x4004_0000 + 0x20 * p.port as usize;
        // SAFETY: PCNTR3 (PORR half) of the valve ports: write-only, resets exactly this pin.
        unsafe { core::ptr::write_volatile((port + 8) as *mut u32, 1u32 << (p.pin + 16)) };
    }
    for p in [pins::SERVO0.pin(), pins::SERVO1.pin(), pins::SERVO2.pin()] {
        let pfs = 0x4004_0800 + 0x40 * p.port as usize + 4 * p.pin as usize;
        // SAFETY: PWPR (0x4004_0D03) opened (B0WI = 0, then PFSWE = 1), the servo pin's PFS set
        // to GPIO output low (PDR = 1, PODR = 0, PMR = 0), PWPR closed again.
        unsafe {
            core::ptr::write_volatile(0x4004_0D03 as *mut u8, 0x00);
            core::ptr::write_volatile(0x4004_0D03 as *mut u8, 0x40);
            core::ptr::write_volatile(pfs as *mut u32, pfs::PDR);
            core::ptr::write_volatile(0x4004_0D03 as *mut u8, 0x00);
            core::ptr::write_volatile(0x4004_0D03 as *mut u8, 0x80);
        }
    }
}

/// What every fault handler does: the safe state first, then `report` (a log line; the
/// on-target tests observe the pins here), then [`halt`].
pub fn fault(report: impl FnOnce()) -> ! {
    outputs();
    report();
    halt()
}

/// The safe state, then nothing left to do but wait for the watchdog (it resets the board
/// within 350 ms, counting in sleep too).
pub fn halt() -> ! {
    outputs();
    loop {
        cortex_m::asm::nop();
    }
}
