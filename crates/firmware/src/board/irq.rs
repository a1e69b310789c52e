//! Interrupt state left by the bootloader. The Arduino bootloader hands over with its own
//! ICU event links still set (`arduino-renesas-bootloader`, `src/irq_table.c`: on the UNO R4
//! WiFi IELSR0..3 select SCI9 TXI, TEI, RXI, ERI, the bridge's UART; on the Minima USBFS INT,
//! RESUME, FIFO 0, FIFO 1) and their NVIC lines possibly pending. Before any interrupt is unmasked, every link
//! is cleared (IELSRn = 0 also clears IR) and every NVIC line disabled and un-pended, so a
//! handler only ever runs for a source this firmware configured (RA4M1 UM, "Interrupt
//! Controller Unit": IELSRn; Cortex-M4 NVIC ICER/ICPR).

use cortex_m::peripheral::NVIC;

use super::regs::{pac, wr};

/// ICU slots (and NVIC lines) on the RA4M1.
const SLOTS: usize = 32;

/// Clears every ICU event link and the NVIC's enable and pending state. Call with interrupts
/// disabled, before configuring any peripheral interrupt.
#[inline]
pub fn clear_bootloader_state(nvic: &mut NVIC) {
    for n in 0..SLOTS {
        wr!(pac::ICU.ielsr()[n], 0);
    }
    // SAFETY: ICER/ICPR writes only disable and un-pend; nothing is enabled here.
    unsafe {
        nvic.icer[0].write(u32::MAX);
        nvic.icpr[0].write(u32::MAX);
    }
}
