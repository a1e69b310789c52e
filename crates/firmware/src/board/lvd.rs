//! Brown-out reset: voltage monitor 1 (RA4M1 UM, "Low Voltage Detection (LVD)") resets the
//! chip when VCC falls below Vdet1 and holds it in reset until VCC is back above Vdet1, so a
//! sagging supply (servos stalling on a weak USB port) restarts the firmware cleanly instead of
//! running it on a voltage where the 5 V ratiometric sensors and the valve drivers misbehave.
//! The reset is reported at the next boot (RSTSR0.LVD1RF → `ResetCause::BrownOut`).
//!
//! The hold is LVD1CR0.RN = 0: "negation follows a stabilization time (tLVD1) after VCC >
//! Vdet1 is detected" (the PAC's `Lvdcr0::Rn`, FSP `LVD_NEGATION_DELAY_FROM_VOLTAGE`). RN = 1,
//! the reset value, would release the reset tLVD1 after it asserted, whatever VCC is — the
//! firmware would run on the low supply, and the monitor would not reset it again until VCC
//! had risen above Vdet1 and fallen anew.
//!
//! Vdet1 = 3.84 V (LVDLVLR.LVD1LVL = 0x03): below the 4.75 V a USB port may sag to under load
//! with margin for the board's reverse-protection diode, far above the RA4M1's 1.6 V minimum.

use super::regs::{pac, rd, wr};

/// LVD1LVL code for 3.84 V.
const LVD1LVL_3V84: u8 = 0x03;
/// PRCR.PRC3: LVD registers.
const PRC3: u16 = 1 << 3;
/// LVD1CR0 bits: RIE (0), CMPE (2), RI (6: reset, not interrupt); RN (7) stays 0.
const RIE: u8 = 1 << 0;
const CMPE: u8 = 1 << 2;
const RI: u8 = 1 << 6;
/// LVCMPCR.LVD1E: the detection circuit.
const LVD1E: u8 = 1 << 5;

/// Arms voltage monitor 1 as a reset, in the order of FSP's `r_lvd` (`r_lvd_hw_configure`),
/// which follows the manual's setting procedure: the comparison off (RIE = CMPE = 0) with the
/// reset mode chosen; the detection circuit off (LVD1E = 0) while the level is written, then
/// on; a stale detection flag cleared (LVD1SR.DET = 0) before the reset is enabled (RIE); the
/// circuit's stabilisation time; then the comparison (CMPE). Also after a brown-out, when the
/// monitor's registers (not reset by its own reset) still hold the previous boot's settings.
#[inline]
pub fn enable_brownout_reset() {
    wr!(pac::SYSTEM.prcr(), super::regs::prcr::KEY | PRC3);
    wr!(pac::SYSTEM.lvd1cr0(), RI);
    wr!(pac::SYSTEM.lvcmpcr(), rd!(pac::SYSTEM.lvcmpcr()) & !LVD1E);
    wr!(
        pac::SYSTEM.lvdlvlr(),
        LVD1LVL_3V84 | (rd!(pac::SYSTEM.lvdlvlr()) & 0xE0)
    );
    wr!(pac::SYSTEM.lvcmpcr(), rd!(pac::SYSTEM.lvcmpcr()) | LVD1E);
    wr!(pac::SYSTEM.lvd1sr(), 0); // DET = 0
    wr!(pac::SYSTEM.lvd1cr0(), RI | RIE);
    // td(E-A): the detection circuit needs ≤ 300 µs after LVD1E before the comparison.
    super::time::delay_us(300);
    wr!(pac::SYSTEM.lvd1cr0(), RI | RIE | CMPE);
    wr!(pac::SYSTEM.prcr(), super::regs::prcr::KEY);
}
