//! The watchdog timer WDT at 0x4004_4200 (UM "Watchdog Timer (WDT)"), register-start mode
//! (OFS0.WDTSTRT = 1): WDTCR (TOPS 1..0: 1024/4096/8192/16384 cycles; CKS 7..4: PCLKB/4, /64,
//! /128, /512, /2048, /8192; RPES/RPSS refresh window), WDTRCR (RSTIRQS 7: reset), WDTCSTPR
//! (SLCSTP 7: stop counting in sleep mode; reset value 1; WDTRCR's reset value is 0x80, reset
//! on underflow), each writable once after a reset and not after the first refresh (a second
//! write is ignored, as the chip does); WDTRR (0x00 then 0xFF refreshes; the first refresh starts the counter); WDTSR
//! (CNTVAL 13..0, UNDFF 14, REFEF 15). An underflow resets the chip (RSTSR1.WDTRF).
//! The IWDT at 0x4004_4400 (UM "Independent Watchdog Timer") is modelled as stopped
//! (OFS0.IWDTSTRT = 1): its refresh register accepts writes, its status reads 0.

use super::{need, refuse, Why, R};
use crate::clock::ticks_per;

/// Base of the WDT.
pub const BASE: u32 = 0x4004_4200;
/// Base of the IWDT.
pub const IWDT_BASE: u32 = 0x4004_4400;

/// The WDT.
#[derive(Debug, Clone)]
pub struct Wdt {
    wdtcr: u16,
    wdtrcr: u8,
    wdtcstpr: u8,
    /// The 0x00 half of a refresh was written.
    armed: bool,
    /// Counting has started (first refresh).
    pub running: bool,
    /// Awake-equivalent ticks left before underflow at `since`.
    left: u64,
    /// Tick at which `left` was measured.
    since: u64,
    /// Refreshes so far.
    pub refreshes: u64,
    /// Underflowed with the reset masked (see [`Wdt::masked_underflow`]).
    pub underflowed: bool,
    /// WDTCR, WDTRCR, WDTCSTPR written since the reset (each takes one write).
    written: [bool; 3],
}

impl Default for Wdt {
    fn default() -> Self {
        Self {
            wdtcr: 0x33F3,
            wdtrcr: 0x80,
            wdtcstpr: 0x80,
            armed: false,
            running: false,
            left: 0,
            since: 0,
            refreshes: 0,
            underflowed: false,
            written: [false; 3],
        }
    }
}

impl Wdt {
    fn period_ticks(&self, pclkb: u32) -> R<u64> {
        let tops = [1024u64, 4096, 8192, 16384][usize::from(self.wdtcr & 3)];
        let div = match (self.wdtcr >> 4) & 0xF {
            0b0001 => 4,
            0b0100 => 64,
            0b1111 => 128,
            0b0110 => 512,
            0b0111 => 2048,
            0b1000 => 8192,
            c => return refuse(format!("WDTCR.CKS = {c:#06b} is a prohibited setting")),
        };
        Ok(tops * div * ticks_per(pclkb))
    }

    /// Counting stops in sleep mode (WDTCSTPR.SLCSTP = 1).
    pub fn stops_in_sleep(&self) -> bool {
        self.wdtcstpr & 0x80 != 0
    }

    /// Moves the counter on to `now`; `counting`: the clock ran over `since..now` (awake, or
    /// asleep with SLCSTP = 0). Returns true on underflow.
    pub fn advance(&mut self, now: u64, counting: bool) -> bool {
        if !self.running || self.underflowed {
            self.since = now;
            return false;
        }
        let dt = now.saturating_sub(self.since);
        self.since = now;
        if counting {
            if dt >= self.left {
                self.left = 0;
                return true;
            }
            self.left -= dt;
        }
        false
    }

    /// Tick of the underflow if the clock keeps counting from `now`.
    pub fn deadline(&self) -> Option<u64> {
        (self.running && !self.underflowed).then(|| self.since + self.left)
    }

    /// The underflow happened with its reset masked (on-chip-debug mode): the counter stays
    /// at 0 until a refresh.
    pub fn masked_underflow(&mut self) {
        self.underflowed = true;
    }

    /// A read at `off` (from WDT base).
    pub fn read(&self, off: u32, size: u32, pclkb: u32) -> R<u32> {
        Ok(match off {
            0x0 => 0xFF,
            0x2 => {
                need(size, 2, "WDTCR")?;
                self.wdtcr.into()
            }
            0x4 => {
                need(size, 2, "WDTSR")?;
                let per = self.period_ticks(pclkb).unwrap_or(1);
                let tops = [1024u64, 4096, 8192, 16384][usize::from(self.wdtcr & 3)];
                if self.running {
                    ((self.left * tops / per.max(1)).min(0x3FFF)) as u32
                } else {
                    0x3FFF
                }
            }
            0x6 => self.wdtrcr.into(),
            0x8 => self.wdtcstpr.into(),
            _ => return Err(Why::Unmodelled),
        })
    }

    /// A write at `off`.
    pub fn write(&mut self, off: u32, size: u32, v: u32, now: u64, pclkb: u32) -> R<()> {
        // Register-start mode: each of WDTCR, WDTRCR, WDTCSTPR takes one write after the reset
        // and none after the first refresh (UM "Watchdog Timer": the registers can be written
        // once; FSP r_wdt: "configuration registers can only be written to once"). A later
        // write is ignored by the chip: `Ok(false)`.
        let once = |s: &mut Self, i: usize, name: &str| -> R<bool> {
            if s.running {
                return refuse(format!("{name} written after the WDT started (register-start mode: ignored by the chip)"));
            }
            Ok(!std::mem::replace(&mut s.written[i], true))
        };
        match off {
            0x0 => {
                need(size, 1, "WDTRR")?;
                match v as u8 {
                    0x00 => self.armed = true,
                    0xFF if self.armed => {
                        self.armed = false;
                        self.left = self.period_ticks(pclkb)?;
                        self.since = now;
                        self.running = true;
                        self.underflowed = false;
                        self.refreshes += 1;
                    }
                    _ => self.armed = false,
                }
            }
            0x2 => {
                need(size, 2, "WDTCR")?;
                if !once(self, 0, "WDTCR")? {
                    return Ok(());
                }
                if (v >> 8) & 3 != 3 || (v >> 12) & 3 != 3 {
                    return refuse(
                        "WDTCR refresh window (RPES/RPSS) other than 0 %–100 % is not modelled",
                    );
                }
                self.wdtcr = v as u16 & 0x33F3;
                self.period_ticks(pclkb)?;
            }
            0x4 => {
                need(size, 2, "WDTSR")?;
            }
            0x6 => {
                need(size, 1, "WDTRCR")?;
                if !once(self, 1, "WDTRCR")? {
                    return Ok(());
                }
                if v & 0x80 == 0 {
                    return refuse("WDTRCR.RSTIRQS = 0 (NMI on underflow) is not modelled");
                }
                self.wdtrcr = v as u8 & 0x80;
            }
            0x8 => {
                need(size, 1, "WDTCSTPR")?;
                if !once(self, 2, "WDTCSTPR")? {
                    return Ok(());
                }
                self.wdtcstpr = v as u8 & 0x80;
            }
            _ => return Err(Why::Unmodelled),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PCLKB: u32 = 24_000_000;

    /// WDTRCR's reset value is 0x80 (RSTIRQS = 1: reset on underflow), WDTCSTPR's 0x80, WDTCR's
    /// 0x33F3 (UM "Watchdog Timer", register descriptions).
    #[test]
    fn reset_values() {
        let w = Wdt::default();
        assert_eq!(w.read(0x6, 1, PCLKB), Ok(0x80));
        assert_eq!(w.read(0x8, 1, PCLKB), Ok(0x80));
        assert_eq!(w.read(0x2, 2, PCLKB), Ok(0x33F3));
    }

    /// Each configuration register takes one write after the reset; a second one is ignored
    /// (not refused: the chip ignores it), and none is taken after the first refresh.
    #[test]
    fn configuration_registers_are_write_once() {
        let mut w = Wdt::default();
        let first = 0b01 | (0b0111 << 4) | (0b11 << 8) | (0b11 << 12);
        let second = (0b0111 << 4) | (0b11 << 8) | (0b11 << 12);
        assert_eq!(w.write(0x2, 2, first, 0, PCLKB), Ok(()));
        assert_eq!(w.write(0x2, 2, second, 0, PCLKB), Ok(()));
        assert_eq!(w.read(0x2, 2, PCLKB), Ok(first), "the first write holds");
        assert_eq!(w.write(0x8, 1, 0x00, 0, PCLKB), Ok(()));
        assert_eq!(w.write(0x8, 1, 0x80, 0, PCLKB), Ok(()));
        assert_eq!(w.read(0x8, 1, PCLKB), Ok(0x00));
        w.write(0x0, 1, 0x00, 0, PCLKB).unwrap();
        w.write(0x0, 1, 0xFF, 0, PCLKB).unwrap();
        assert!(w.running);
        assert!(
            w.write(0x6, 1, 0x80, 0, PCLKB).is_err(),
            "after the first refresh"
        );
    }

    /// A masked underflow (on-chip-debug mode) stops the count until the next refresh.
    #[test]
    fn a_masked_underflow_waits_for_a_refresh() {
        let mut w = Wdt::default();
        w.write(0x0, 1, 0x00, 0, PCLKB).unwrap();
        w.write(0x0, 1, 0xFF, 0, PCLKB).unwrap();
        let d = w.deadline().unwrap();
        assert!(w.advance(d, true));
        w.masked_underflow();
        assert_eq!(w.deadline(), None);
        assert!(!w.advance(d * 3, true));
        w.write(0x0, 1, 0x00, d * 3, PCLKB).unwrap();
        w.write(0x0, 1, 0xFF, d * 3, PCLKB).unwrap();
        assert_eq!(w.deadline(), Some(d * 3 + d));
    }
}
