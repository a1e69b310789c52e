//! The interrupt controller unit (UM "Interrupt Controller Unit (ICU)") at 0x4000_6000: the 32
//! event link registers IELSR0..31 (0x300 + 4n: IELS 8..0 selects the event, IR 16 is the
//! request flag, DTCE 24). An event sets IR in every slot that selects it, and a slot with IR
//! set requests NVIC interrupt n (as a level: it is pending again after the handler returns
//! while IR is still 1). IR clears by writing 0. An event that comes while IR is already 1 is
//! no new request: IR stays 1, the NVIC line is not pended again, so a handler that clears IR
//! at its end loses the event that came while it ran (FSP clears IR first, at the handler's
//! entry: `R_BSP_IrqStatusClear` in `r_sci_uart`'s ISRs).

use super::{need, refuse, Why, R};

/// Base of the ICU.
pub const BASE: u32 = 0x4000_6000;
/// IELSRn.IR.
pub const IR: u32 = 1 << 16;

/// The ICU.
#[derive(Debug, Clone, Default)]
pub struct Icu {
    /// IELSR0..31.
    pub ielsr: [u32; 32],
    /// NMIER (0x120): NMI sources enabled; bits can only be set (FSP `r_lvd`: "NMIER bits
    /// can only be set"). SPEEN is bit 12.
    pub nmier: u16,
    /// NMISR (0x140): NMI sources detected; cleared through NMICLR (0x130).
    pub nmisr: u16,
}

impl Icu {
    /// Raises `event`: returns the NVIC lines to pend.
    pub fn raise(&mut self, event: u16) -> u32 {
        let mut lines = 0;
        for (n, s) in self.ielsr.iter_mut().enumerate() {
            if *s & 0x1FF == u32::from(event) && event != 0 && *s & IR == 0 {
                *s |= IR;
                lines |= 1 << n;
            }
        }
        lines
    }

    /// Slot `n` still requests its interrupt.
    pub fn requesting(&self, n: usize) -> bool {
        self.ielsr[n] & IR != 0 && self.ielsr[n] & 0x1FF != 0
    }

    /// The NMI source `bit` detected: returns true when it raises the NMI (enabled in NMIER).
    pub fn nmi(&mut self, bit: u16) -> bool {
        self.nmisr |= 1 << bit;
        self.nmier & (1 << bit) != 0
    }

    /// A read at `off`.
    pub fn read(&self, off: u32, size: u32) -> R<u32> {
        match off {
            0x120 => need(size, 2, "NMIER").map(|()| self.nmier.into()),
            0x140 => need(size, 2, "NMISR").map(|()| self.nmisr.into()),
            0x300..=0x37F if off.is_multiple_of(4) => {
                need(size, 4, "IELSRn")?;
                Ok(self.ielsr[(off as usize - 0x300) / 4])
            }
            _ => Err(Why::Unmodelled),
        }
    }

    /// A write at `off`.
    pub fn write(&mut self, off: u32, size: u32, v: u32) -> R<()> {
        match off {
            0x120 => {
                need(size, 2, "NMIER")?;
                self.nmier |= v as u16;
                Ok(())
            }
            0x130 => {
                need(size, 2, "NMICLR")?;
                self.nmisr &= !(v as u16);
                Ok(())
            }
            0x300..=0x37F if off.is_multiple_of(4) => {
                need(size, 4, "IELSRn")?;
                let n = (off as usize - 0x300) / 4;
                if v & (1 << 24) != 0 {
                    return refuse("IELSRn.DTCE: the DTC is not modelled");
                }
                let old = self.ielsr[n];
                if v & IR != 0 && old & IR == 0 {
                    return refuse("IELSRn.IR can only be cleared (write 0), not set");
                }
                self.ielsr[n] = v & (0x1FF | IR);
                Ok(())
            }
            _ => Err(Why::Unmodelled),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An event raises a request only when IR was clear: a second event with IR still set is
    /// no new request (the line is not pended again), one after IR was cleared is.
    #[test]
    fn an_event_while_ir_is_set_is_no_new_request() {
        let mut icu = Icu::default();
        icu.write(0x300 + 4 * 2, 4, 0xA9).unwrap();
        assert_eq!(icu.raise(0xA9), 1 << 2);
        assert_eq!(icu.raise(0xA9), 0, "IR still set");
        icu.write(0x308, 4, 0xA9).unwrap();
        assert_eq!(icu.raise(0xA9), 1 << 2, "after IR was cleared");
    }
}
