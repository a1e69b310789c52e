//! SYSTEM (0x4001_E000) and MSTP (0x4004_7000): clock generation, operating power control,
//! register write protection, reset status, low-voltage detection and module stop.
//!
//! - Clock Generation Circuit (UM "Clock Generation Circuit"): SCKDIVCR, SCKSCR, HOCOCR,
//!   MOCOCR, MOSCCR, OSCSF, MEMWAIT. The system clock is HOCO or MOCO; the HOCO frequency comes
//!   from OFS1.HOCOFRQ1 (UM "Option-Setting Memory"). The oscillators are stable at once.
//! - Low Power Modes (UM "Low Power Modes"): OPCCR/SOPCCR (operating power control), SBYCR;
//!   MSTPCRA..D (module stop, reset value all ones but the bootloader's modules).
//! - Register Write Protection (UM "Register Write Protection"): PRCR with key 0xA5; PRC0
//!   guards the clock registers, PRC1 the low-power ones, PRC3 the LVD ones. A write without
//!   the protection open is refused (the chip would ignore it: a firmware bug either way).
//! - Resets (UM "Resets"): RSTSR0 (PORF, LVD0RF, LVD1RF, LVD2RF), RSTSR1 (IWDTRF, WDTRF,
//!   SWRF; write 0 after reading 1 to clear), RSTSR2 (CWSF).
//! - Low Voltage Detection (UM "Low Voltage Detection (LVD)"): LVCMPCR, LVDLVLR, LVD1CR0,
//!   LVD1CR1, LVD1SR (DET 0, MON 1): voltage monitor 1 compares VCC with Vdet1; with RI = 1
//!   a fall below Vdet1 sets LVD1SR.DET and asserts the voltage monitor 1 reset. Its release
//!   follows LVD1CR0.RN (bit 7; FSP `lvd_negation_delay_t`, the PAC's `Lvdcr0::Rn`): RN = 0
//!   releases it [`T_LVD1_NS`] after VCC is back above Vdet1 (the chip is held while VCC is
//!   low), RN = 1 — the reset value — releases it [`T_LVD1_NS`] after it was asserted, whatever
//!   VCC is; the chip then runs on the low supply and the monitor resets it again only after
//!   VCC has risen above Vdet1 and fallen below it anew. The setting procedure (UM "Low Voltage
//!   Detection", as FSP `r_lvd` follows it) is enforced: LVDLVLR is refused while LVCMPCR.LVD1E
//!   = 1, and LVD1CR0.RIE going to 1 is refused while LVD1SR.DET = 1 (a stale detection would
//!   fire at once). The monitor's registers, LVD1SR included, survive its own reset.

use super::{need, refuse, sub_read, Clocks, Why, R};

/// Base of SYSTEM.
pub const BASE: u32 = 0x4001_E000;
/// Base of MSTP (MSTPCRB..D).
pub const MSTP_BASE: u32 = 0x4004_7000;

/// Vdet1 per LVDLVLR.LVD1LVL code, mV (UM "Low Voltage Detection", voltage detection level;
/// FSP `lvd_threshold_t` for the RA4M1).
pub const VDET1_MV: [u32; 16] = [
    4290, 4140, 4020, 3840, 3100, 3000, 2900, 2790, 2680, 2580, 2480, 2200, 1960, 1860, 1750, 1650,
];

/// The voltage monitor 1 reset's release delay tLVD1, ns. The model uses 0.2 ms, the order of
/// the datasheet's figure; no test depends on its exact value.
pub const T_LVD1_NS: u64 = 200_000;

/// Why the chip last reset (RSTSR0/1 flags set by the hardware).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResetKind {
    /// Power-on reset (RSTSR0.PORF).
    PowerOn,
    /// Watchdog timer underflow (RSTSR1.WDTRF).
    Watchdog,
    /// Software reset, AIRCR.SYSRESETREQ (RSTSR1.SWRF).
    Software,
    /// Voltage monitor 1 reset (RSTSR0.LVD1RF): a brown-out.
    BrownOut,
}

/// SYSTEM and MSTP registers.
#[derive(Debug, Clone)]
pub struct System {
    prcr: u16,
    sckdivcr: u32,
    sckscr: u8,
    memwait: u8,
    hococr: u8,
    mococr: u8,
    mosccr: u8,
    opccr: u8,
    sopccr: u8,
    sbycr: u16,
    /// Module stop A..D (A in SYSTEM, B..D in MSTP).
    pub mstpcr: [u32; 4],
    rstsr0: u8,
    rstsr1: u16,
    rstsr2: u8,
    lvcmpcr: u8,
    lvdlvlr: u8,
    lvd1cr0: u8,
    lvd1cr1: u8,
    lvd1sr: u8,
    hoco_hz: u32,
}

impl System {
    /// Reset state, then the Arduino bootloader's settings at the jump to the application:
    /// HOCO (48 MHz with the Arduino option bytes) as the system clock, ICLK = PCLKA = PCLKC =
    /// PCLKD = HOCO, PCLKB = FCLK = HOCO/2, one flash wait state, high-speed mode; the modules
    /// the bootloader used (`running`) out of module stop.
    pub fn after_bootloader(hoco_hz: u32, kind: ResetKind, mstpcrb_running: u32) -> Self {
        let mut s = Self {
            prcr: 0,
            sckdivcr: 0x1001_0100,
            sckscr: 0,
            memwait: 1,
            hococr: 0,
            mococr: 0,
            mosccr: 1,
            opccr: 0,
            sopccr: 0,
            sbycr: 0x4000,
            mstpcr: [0xFFBF_FFFF, !mstpcrb_running, 0xFFFF_FFFF, 0xFFFF_FFFF],
            rstsr0: 0,
            rstsr1: 0,
            rstsr2: 0,
            lvcmpcr: 0,
            lvdlvlr: 0x07,
            lvd1cr0: 0x80,
            lvd1cr1: 0x01,
            lvd1sr: 0x02,
            hoco_hz,
        };
        match kind {
            ResetKind::PowerOn => s.rstsr0 = 1,
            ResetKind::Watchdog => s.rstsr1 = 1 << 1,
            ResetKind::Software => s.rstsr1 = 1 << 2,
            ResetKind::BrownOut => s.rstsr0 = 1 << 2,
        }
        if kind != ResetKind::PowerOn {
            s.rstsr2 = 1; // CWSF: warm start
        }
        s
    }

    /// Keeps the voltage monitor settings of `old` (a voltage monitor 1 reset does not
    /// initialise them).
    pub fn keep_lvd_from(&mut self, old: &System) {
        self.lvcmpcr = old.lvcmpcr;
        self.lvdlvlr = old.lvdlvlr;
        self.lvd1cr0 = old.lvd1cr0;
        self.lvd1cr1 = old.lvd1cr1;
        self.lvd1sr = old.lvd1sr;
    }

    /// LVD1CR0.RN: the reset is released a fixed time after it asserted (1), or after VCC is
    /// back above Vdet1 (0).
    pub fn lvd1_negation_after_assertion(&self) -> bool {
        self.lvd1cr0 & (1 << 7) != 0
    }

    /// Voltage monitor 1's comparison with VCC (`vcc_mv`): returns true when it asserts its
    /// reset now (armed as a reset, VCC has just fallen below Vdet1). Updates LVD1SR (MON:
    /// VCC at or above Vdet1; DET: a fall was detected).
    pub fn lvd1_compare(&mut self, vcc_mv: u32) -> bool {
        let Some(level) = self.lvd1_reset_level_mv() else {
            return false;
        };
        let above = vcc_mv >= level;
        let was_above = self.lvd1sr & 0x02 != 0;
        if above {
            self.lvd1sr |= 0x02;
            false
        } else {
            self.lvd1sr &= !0x02;
            if was_above {
                self.lvd1sr |= 0x01;
            }
            was_above
        }
    }

    /// The clock frequencies in effect.
    pub fn clocks(&self) -> Clocks {
        let src = if self.sckscr == 0 {
            self.hoco_hz
        } else {
            8_000_000
        };
        let d = |shift: u32| src >> ((self.sckdivcr >> shift) & 0x7);
        Clocks {
            iclk: d(24),
            pclka: d(12),
            pclkb: d(8),
            pclkc: d(4),
            pclkd: d(0),
            fclk: d(28),
        }
    }

    /// Flash wait states (MEMWAIT).
    pub fn wait_states(&self) -> u32 {
        u32::from(self.memwait & 1)
    }

    /// Voltage monitor 1 is armed as a reset: returns its level in mV.
    pub fn lvd1_reset_level_mv(&self) -> Option<u32> {
        let enabled = self.lvcmpcr & (1 << 5) != 0;
        let cmpe = self.lvd1cr0 & (1 << 2) != 0;
        let rie = self.lvd1cr0 & 1 != 0;
        let reset = self.lvd1cr0 & (1 << 6) != 0;
        (enabled && cmpe && rie && reset).then(|| VDET1_MV[(self.lvdlvlr & 0x1F).min(15) as usize])
    }

    /// Module `bit` of MSTPCR`x` (0 = A … 3 = D) is stopped.
    pub fn stopped(&self, x: usize, bit: u32) -> bool {
        self.mstpcr[x] & (1 << bit) != 0
    }

    fn guard(&self, bit: u16, name: &str) -> R<()> {
        if self.prcr & bit != 0 {
            Ok(())
        } else {
            refuse(format!(
                "write to {name} with PRCR.PRC{} = 0",
                bit.trailing_zeros()
            ))
        }
    }

    /// A read of SYSTEM at `off`.
    pub fn read(&self, off: u32, size: u32) -> R<u32> {
        Ok(match off {
            0x00C => {
                need(size, 2, "SBYCR")?;
                self.sbycr.into()
            }
            0x01C => {
                need(size, 4, "MSTPCRA")?;
                self.mstpcr[0]
            }
            0x020..=0x023 => sub_read(self.sckdivcr, off - 0x20, size),
            0x026 => self.sckscr.into(),
            0x031 => self.memwait.into(),
            0x032 => self.mosccr.into(),
            0x036 => self.hococr.into(),
            0x038 => self.mococr.into(),
            // OSCSF: HOCOSF (0) when HOCO runs; MOSCSF (3) never (no crystal on the board).
            0x03C => u32::from(self.hococr & 1 == 0),
            0x0A0 => self.opccr.into(), // OPCMTSF (bit 4) is 0: transitions are instant
            0x0AA => self.sopccr.into(),
            0x0C0 => {
                need(size, 2, "RSTSR1")?;
                self.rstsr1.into()
            }
            0x0E0 => self.lvd1cr1.into(),
            0x0E1 => self.lvd1sr.into(),
            0x3FE => {
                need(size, 2, "PRCR")?;
                self.prcr.into()
            }
            0x410 => self.rstsr0.into(),
            0x411 => self.rstsr2.into(),
            0x417 => self.lvcmpcr.into(),
            0x418 => self.lvdlvlr.into(),
            0x41A => self.lvd1cr0.into(),
            _ => return Err(Why::Unmodelled),
        })
    }

    /// A write of SYSTEM at `off`.
    pub fn write(&mut self, off: u32, size: u32, v: u32) -> R<()> {
        const PRC0: u16 = 1;
        const PRC1: u16 = 2;
        const PRC3: u16 = 8;
        match off {
            0x00C => {
                need(size, 2, "SBYCR")?;
                self.guard(PRC1, "SBYCR")?;
                if v & 0x8000 != 0 {
                    return refuse("SBYCR.SSBY = 1 (software standby) is not modelled");
                }
                self.sbycr = v as u16;
            }
            0x01C => {
                need(size, 4, "MSTPCRA")?;
                self.guard(PRC1, "MSTPCRA")?;
                self.mstpcr[0] = v;
            }
            0x020 => {
                need(size, 4, "SCKDIVCR")?;
                self.guard(PRC0, "SCKDIVCR")?;
                // The manual requires PCKB (10..8) in bits 18..16 too.
                if (v >> 16) & 7 != (v >> 8) & 7 {
                    return refuse("SCKDIVCR bits 18..16 must equal PCKB (bits 10..8)");
                }
                self.sckdivcr = v;
            }
            0x026 => {
                self.guard(PRC0, "SCKSCR")?;
                match v & 7 {
                    0 if self.hococr & 1 == 0 => self.sckscr = 0,
                    0 => return refuse("SCKSCR = HOCO while HOCOCR.HCSTP = 1"),
                    1 => self.sckscr = 1,
                    c => {
                        return refuse(format!("SCKSCR.CKSEL = {c}: only HOCO and MOCO exist here"))
                    }
                }
            }
            0x031 => {
                self.guard(PRC0, "MEMWAIT")?;
                self.memwait = (v & 1) as u8;
            }
            0x032 => {
                self.guard(PRC0, "MOSCCR")?;
                self.mosccr = (v & 1) as u8;
            }
            0x036 => {
                self.guard(PRC0, "HOCOCR")?;
                if v & 1 != 0 && self.sckscr == 0 {
                    return refuse("HOCOCR.HCSTP = 1 while HOCO is the system clock");
                }
                self.hococr = (v & 1) as u8;
            }
            0x038 => {
                self.guard(PRC0, "MOCOCR")?;
                self.mococr = (v & 1) as u8;
            }
            0x0A0 => {
                self.guard(PRC1, "OPCCR")?;
                self.opccr = (v & 3) as u8;
            }
            0x0AA => {
                self.guard(PRC1, "SOPCCR")?;
                self.sopccr = (v & 1) as u8;
            }
            0x0C0 => {
                need(size, 2, "RSTSR1")?;
                // Flags clear by writing 0 after reading 1; writing 1 has no effect.
                self.rstsr1 &= v as u16;
            }
            0x0E0 => {
                self.guard(PRC3, "LVD1CR1")?;
                self.lvd1cr1 = v as u8;
            }
            0x0E1 => {
                self.guard(PRC3, "LVD1SR")?;
                self.lvd1sr = (self.lvd1sr & !1) | (self.lvd1sr & v as u8 & 1);
            }
            0x3FE => {
                need(size, 2, "PRCR")?;
                if v >> 8 != 0xA5 {
                    return refuse(format!("PRCR written without the key 0xA5 ({v:#06x})"));
                }
                self.prcr = (v & 0x0B) as u16;
            }
            0x410 => self.rstsr0 &= v as u8,
            0x411 => self.rstsr2 |= (v & 1) as u8,
            0x417 => {
                self.guard(PRC3, "LVCMPCR")?;
                self.lvcmpcr = v as u8 & 0x60;
            }
            0x418 => {
                self.guard(PRC3, "LVDLVLR")?;
                if self.lvcmpcr & (1 << 5) != 0 {
                    return refuse(
                        "LVDLVLR written while LVCMPCR.LVD1E = 1 (clear LVD1E first: UM \
                         \"Low Voltage Detection\", FSP r_lvd)",
                    );
                }
                if v & 0x1F > 0x0F {
                    return refuse(format!(
                        "LVDLVLR.LVD1LVL = {:#x} is a prohibited setting",
                        v & 0x1F
                    ));
                }
                self.lvdlvlr = v as u8;
            }
            0x41A => {
                self.guard(PRC3, "LVD1CR0")?;
                if v & 1 != 0 && self.lvd1cr0 & 1 == 0 && self.lvd1sr & 1 != 0 {
                    return refuse(
                        "LVD1CR0.RIE set while LVD1SR.DET = 1 (clear DET first: UM \
                         \"Low Voltage Detection\", FSP r_lvd)",
                    );
                }
                self.lvd1cr0 = v as u8 & 0xC7;
            }
            _ => return Err(Why::Unmodelled),
        }
        Ok(())
    }

    /// A read of MSTP (MSTPCRB at 0, C at 4, D at 8).
    pub fn mstp_read(&self, off: u32, size: u32) -> R<u32> {
        match off {
            0x0 | 0x4 | 0x8 => {
                need(size, 4, "MSTPCRx")?;
                Ok(self.mstpcr[1 + off as usize / 4])
            }
            _ => Err(Why::Unmodelled),
        }
    }

    /// A write of MSTP.
    pub fn mstp_write(&mut self, off: u32, size: u32, v: u32) -> R<()> {
        match off {
            0x0 | 0x4 | 0x8 => {
                need(size, 4, "MSTPCRx")?;
                self.mstpcr[1 + off as usize / 4] = v;
                Ok(())
            }
            _ => Err(Why::Unmodelled),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn armed(rn: bool) -> System {
        let mut s = System::after_bootloader(48_000_000, ResetKind::PowerOn, 0);
        s.write(0x3FE, 2, 0xA508).unwrap();
        s.write(0x41A, 1, 0x40 | (u32::from(rn) << 7)).unwrap();
        s.write(0x418, 1, 0x03).unwrap();
        s.write(0x417, 1, 1 << 5).unwrap();
        s.write(0x0E1, 1, 0).unwrap();
        s.write(0x41A, 1, 0x41 | (u32::from(rn) << 7)).unwrap();
        s.write(0x41A, 1, 0x45 | (u32::from(rn) << 7)).unwrap();
        s
    }

    /// The reset asserts on the fall below Vdet1 (3.84 V for code 3), once: not again while
    /// VCC stays low, again after it has risen and fallen anew; DET latches the fall.
    #[test]
    fn voltage_monitor_1_resets_on_each_fall_below_vdet1() {
        let mut s = armed(false);
        assert_eq!(s.lvd1_reset_level_mv(), Some(3_840));
        assert!(!s.lvd1_compare(5_000));
        assert!(s.lvd1_compare(3_800));
        assert_eq!(s.read(0x0E1, 1), Ok(0x01), "DET = 1, MON = 0");
        assert!(!s.lvd1_compare(3_700), "still low: no new assertion");
        assert!(!s.lvd1_compare(3_900));
        assert!(s.lvd1_compare(3_800));
        assert!(!s.lvd1_negation_after_assertion());
        assert!(armed(true).lvd1_negation_after_assertion());
    }

    /// The setting procedure: LVDLVLR only with LVD1E = 0, RIE only with DET = 0.
    #[test]
    fn the_setting_procedure_is_enforced() {
        let mut s = armed(false);
        assert!(s.write(0x418, 1, 0x03).is_err(), "LVDLVLR with LVD1E = 1");
        assert!(s.lvd1_compare(3_000));
        s.write(0x41A, 1, 0x40).unwrap();
        assert!(s.write(0x41A, 1, 0x41).is_err(), "RIE with DET = 1");
        s.write(0x0E1, 1, 0).unwrap();
        assert_eq!(s.write(0x41A, 1, 0x41), Ok(()));
    }
}
