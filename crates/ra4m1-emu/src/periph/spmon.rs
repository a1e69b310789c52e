//! The CPU stack pointer monitor at 0x4000_0D00 (UM "CPU Stack Pointer Monitor"; `ra4m1-pac`
//! `SPMON`), its main-stack half: MSPMPUOAD (0x00: OAD bit 0, 0 = NMI on detection, 1 = reset;
//! written with the key 0xA5 in bits 15..8), MSPMPUCTL (0x04: ENABLE bit 0, ERROR bit 8),
//! MSPMPUPT (0x06: PROTECT bit 0, with the key), MSPMPUSA (0x08: region start, the low two bits
//! 0) and MSPMPUEA (0x0C: region end, the low two bits 1). While enabled, an SP outside
//! `SA..=EA` sets ERROR and raises the NMI (ICU NMISR.SPEST, if NMIER.SPEEN); the CPU's SP is
//! compared before every translated block, so a detection comes at most one block late. The
//! reset response (OAD = 1) and the process-stack half are not modelled.

use super::{need, refuse, Why, R};

/// Base of SPMON.
pub const BASE: u32 = 0x4000_0D00;

/// The main stack pointer monitor.
#[derive(Debug, Clone, Default)]
pub struct Spmon {
    oad: u16,
    ctl: u16,
    pt: u16,
    /// Region start.
    pub sa: u32,
    /// Region end (inclusive).
    pub ea: u32,
}

impl Spmon {
    /// Monitoring is on.
    pub fn enabled(&self) -> bool {
        self.ctl & 1 != 0
    }

    /// Compares `sp` with the region: true on a new detection (ERROR was clear).
    pub fn check(&mut self, sp: u32) -> bool {
        if !self.enabled() || (self.sa..=self.ea).contains(&sp) || self.ctl & 0x100 != 0 {
            return false;
        }
        self.ctl |= 0x100;
        true
    }

    /// A read at `off`.
    pub fn read(&self, off: u32, size: u32) -> R<u32> {
        match off {
            0x00 => need(size, 2, "MSPMPUOAD").map(|()| self.oad.into()),
            0x04 => need(size, 2, "MSPMPUCTL").map(|()| self.ctl.into()),
            0x06 => need(size, 2, "MSPMPUPT").map(|()| self.pt.into()),
            0x08 => need(size, 4, "MSPMPUSA").map(|()| self.sa),
            0x0C => need(size, 4, "MSPMPUEA").map(|()| self.ea),
            _ => Err(Why::Unmodelled),
        }
    }

    /// A write at `off`.
    pub fn write(&mut self, off: u32, size: u32, v: u32) -> R<()> {
        let protected = |s: &Self, name: &str| -> R<()> {
            if s.pt & 1 != 0 {
                refuse(format!("{name} written with MSPMPUPT.PROTECT = 1"))
            } else {
                Ok(())
            }
        };
        match off {
            0x00 => {
                need(size, 2, "MSPMPUOAD")?;
                if v >> 8 != 0xA5 {
                    return refuse("MSPMPUOAD written without the key 0xA5");
                }
                if v & 1 != 0 {
                    return refuse("MSPMPUOAD.OAD = 1 (reset on detection) is not modelled");
                }
                self.oad = (v & 1) as u16;
            }
            0x04 => {
                need(size, 2, "MSPMPUCTL")?;
                protected(self, "MSPMPUCTL")?;
                // ENABLE as written; ERROR clears by writing 0.
                self.ctl = (v as u16 & 1) | (self.ctl & v as u16 & 0x100);
            }
            0x06 => {
                need(size, 2, "MSPMPUPT")?;
                if v >> 8 != 0xA5 {
                    return refuse("MSPMPUPT written without the key 0xA5");
                }
                self.pt = (v & 1) as u16;
            }
            0x08 => {
                need(size, 4, "MSPMPUSA")?;
                protected(self, "MSPMPUSA")?;
                if v & 3 != 0 || !(0x1FF0_0000..=0x200F_FFFC).contains(&v) {
                    return refuse(format!(
                        "MSPMPUSA = {v:#010x}: low bits 00, 0x1FF00000..0x200FFFFC"
                    ));
                }
                self.sa = v;
            }
            0x0C => {
                need(size, 4, "MSPMPUEA")?;
                protected(self, "MSPMPUEA")?;
                if v & 3 != 3 || !(0x1FF0_0003..=0x200F_FFFF).contains(&v) {
                    return refuse(format!(
                        "MSPMPUEA = {v:#010x}: low bits 11, 0x1FF00003..0x200FFFFF"
                    ));
                }
                self.ea = v;
            }
            _ => return Err(Why::Unmodelled),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Detection once SP leaves the region, once until ERROR is cleared; the key and the
    /// address formats are enforced.
    #[test]
    fn sp_outside_the_region_is_detected_once() {
        let mut s = Spmon::default();
        assert!(s.write(0x08, 4, 0x2000_1001).is_err());
        s.write(0x08, 4, 0x2000_1000).unwrap();
        s.write(0x0C, 4, 0x2000_7FFF).unwrap();
        assert!(!s.check(0x2000_0FF0), "disabled");
        s.write(0x04, 2, 1).unwrap();
        assert!(!s.check(0x2000_4000));
        assert!(s.check(0x2000_0FF8));
        assert!(!s.check(0x2000_0FF0), "ERROR already set");
        assert_eq!(s.read(0x04, 2), Ok(0x101));
        s.write(0x06, 2, 0xA501).unwrap();
        assert!(s.write(0x08, 4, 0x2000_2000).is_err(), "protected");
    }
}
