//! Brown-out reset: voltage monitor 1 (RA4M1 UM, "Low Voltage Detection (LVD)") resets the
//! chip while VCC is below Vdet1 and releases it when VCC is back, so a sagging supply (servos
//! stalling on a weak USB port) restarts the firmware cleanly instead of running it on a
//! voltage where the 5 V ratiometric sensors and the valve drivers misbehave. The reset is
//! reported at the next boot (RSTSR0.LVD1RF → `ResetCause::BrownOut`).
//!
//! Vdet1 = 3.84 V (LVDLVLR.LVD1LVL = 0x03): below the 4.75 V a USB port may sag to under load
//! with margin for the board's reverse-protection diode, far above the RA4M1's 1.6 V minimum.

use super::regs::{pac, rd, wr};

/// LVD1LVL code for 3.84 V.
const LVD1LVL_3V84: u8 = 0x03;
/// PRCR.PRC3: LVD registers.
const PRC3: u16 = 1 << 3;

/// Arms voltage monitor 1 as a reset (the manual's setting procedure: level, enable the
/// circuit, wait its stabilisation time, then enable the comparison and the reset).
pub fn enable_brownout_reset() {
    wr!(pac::SYSTEM.prcr(), super::regs::prcr::KEY | PRC3);
    // LVD1CR0: RIE = 0 and CMPE = 0 while changing the level; RI = 1 (reset), RN = 1
    // (the reset is released a delay after VCC rises above Vdet1).
    wr!(pac::SYSTEM.lvd1cr0(), (1 << 7) | (1 << 6));
    wr!(
        pac::SYSTEM.lvdlvlr(),
        LVD1LVL_3V84 | (rd!(pac::SYSTEM.lvdlvlr()) & 0xE0)
    );
    wr!(pac::SYSTEM.lvcmpcr(), rd!(pac::SYSTEM.lvcmpcr()) | (1 << 5)); // LVD1E
                                                                       // td(E-A): the detection circuit needs ≤ 300 µs after LVD1E before the comparison.
    super::time::delay_us(300);
    wr!(pac::SYSTEM.lvd1cr0(), (1 << 7) | (1 << 6) | (1 << 2)); // CMPE
    wr!(pac::SYSTEM.lvd1cr0(), (1 << 7) | (1 << 6) | (1 << 2) | 1); // RIE
    wr!(pac::SYSTEM.prcr(), super::regs::prcr::KEY);
}
