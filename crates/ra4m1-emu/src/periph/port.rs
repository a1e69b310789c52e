//! I/O ports (UM "I/O Ports"): PORTm (0x4004_0000 + 0x20·m: PCNTR1 = PODR:PDR, PCNTR2 =
//! EIDR:PIDR, PCNTR3 = PORR:POSR write-only), PmnPFS (0x4004_0800 + 0x40·m + 4·n: PODR 0, PIDR
//! 1, PDR 2, PCR 4, NCODR 6, ASEL 15, PMR 16, PSEL 28..24) and PMISC.PWPR (0x4004_0D03: B0WI
//! 7, PFSWE 6). PCNTR1's PODR/PDR and the PFS bits of the same name are one flip-flop each.
//!
//! The outside world drives a pin ([`Port::drive`]) or leaves it open; a pin's level is the
//! MCU's drive if it drives, else the outside drive, else its pull-up, else low (a floating
//! CMOS input: the model reads it low and reports it as floating).

use super::{need, refuse, Why, R};

/// Base of the PORT/PFS/PMISC page.
pub const BASE: u32 = 0x4004_0000;
/// Ports 0..=9.
pub const PORTS: usize = 10;

/// PFS bits.
pub mod pfs {
    /// Output data.
    pub const PODR: u32 = 1 << 0;
    /// Input data (read only).
    pub const PIDR: u32 = 1 << 1;
    /// Output direction.
    pub const PDR: u32 = 1 << 2;
    /// Pull-up.
    pub const PCR: u32 = 1 << 4;
    /// N-channel open drain.
    pub const NCODR: u32 = 1 << 6;
    /// Analog input.
    pub const ASEL: u32 = 1 << 15;
    /// Peripheral function.
    pub const PMR: u32 = 1 << 16;
    /// Bits a write may set (PSEL, PMR, ASEL, ISEL, EOFR, DSCR, NCODR, PCR, PDR, PODR).
    pub const WRITABLE: u32 = 0x1F01_FC55;
}

/// What drives a pin, as seen from outside the chip.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PinDrive {
    /// The MCU drives it high.
    High,
    /// The MCU drives it low.
    Low,
    /// The MCU does not drive it; `pull_up`: its internal pull-up is on.
    Released {
        /// PCR set.
        pull_up: bool,
    },
    /// A peripheral function owns it (PMR = 1); the board asks that peripheral.
    Peripheral {
        /// PSEL code.
        psel: u8,
    },
    /// Analog input (ASEL = 1).
    Analog,
}

/// The port registers.
#[derive(Debug, Clone)]
pub struct Port {
    /// PmnPFS, `[port][pin]`.
    pub pfs: [[u32; 16]; PORTS],
    /// Outside drive of each pin (`None`: open).
    ext: [[Option<bool>; 16]; PORTS],
    pwpr: u8,
    /// The level a peripheral function drives on a pin (GTIOC outputs), as last synced.
    periph: [[Option<bool>; 16]; PORTS],
    /// A pin's level changed by an MCU write since the board last looked.
    pub changed: bool,
}

impl Default for Port {
    fn default() -> Self {
        Self {
            pfs: [[0; 16]; PORTS],
            ext: [[None; 16]; PORTS],
            pwpr: 0x80,
            periph: [[None; 16]; PORTS],
            changed: false,
        }
    }
}

impl Port {
    /// The reset state with the outside drives of `other` (a reset changes the chip, not the
    /// wiring).
    pub fn reset_keeping_wiring(other: &Port) -> Self {
        Self {
            ext: other.ext,
            ..Self::default()
        }
    }

    /// How the MCU drives `P<port><pin>`.
    pub fn drive_of(&self, port: usize, pin: usize) -> PinDrive {
        let f = self.pfs[port][pin];
        if f & pfs::PMR != 0 {
            PinDrive::Peripheral {
                psel: ((f >> 24) & 0x1F) as u8,
            }
        } else if f & pfs::ASEL != 0 {
            PinDrive::Analog
        } else if f & pfs::PDR != 0 {
            let high = f & pfs::PODR != 0;
            if f & pfs::NCODR != 0 && high {
                PinDrive::Released {
                    pull_up: f & pfs::PCR != 0,
                }
            } else if high {
                PinDrive::High
            } else {
                PinDrive::Low
            }
        } else {
            PinDrive::Released {
                pull_up: f & pfs::PCR != 0,
            }
        }
    }

    /// The pin's level (MCU drive, else outside drive, else pull-up, else low). A pin a
    /// peripheral owns reads its outside drive (the board resolves peripheral outputs).
    pub fn level(&self, port: usize, pin: usize) -> bool {
        let pull_up = self.pfs[port][pin] & pfs::PCR != 0;
        match self.drive_of(port, pin) {
            PinDrive::High => true,
            PinDrive::Low => false,
            PinDrive::Peripheral { .. } => self.periph[port][pin]
                .or(self.ext[port][pin])
                .unwrap_or(pull_up),
            PinDrive::Released { .. } => self.ext[port][pin].unwrap_or(pull_up),
            PinDrive::Analog => false,
        }
    }

    /// Sets the level the pin's peripheral function drives (`None`: it does not drive it).
    pub fn set_peripheral_level(&mut self, port: usize, pin: usize, level: Option<bool>) {
        self.periph[port][pin] = level;
    }

    /// Drives a pin from outside (`None`: leave it open).
    pub fn drive(&mut self, port: usize, pin: usize, level: Option<bool>) {
        self.ext[port][pin] = level;
    }

    fn pidr(&self, port: usize) -> u32 {
        (0..16)
            .filter(|&n| self.level(port, n))
            .map(|n| 1 << n)
            .sum()
    }

    /// A read in the page at `off`.
    pub fn read(&self, off: u32, size: u32) -> R<u32> {
        if off < 0x20 * PORTS as u32 {
            let m = (off / 0x20) as usize;
            match off % 0x20 {
                0x0 => {
                    need(size, 4, "PCNTR1")?;
                    let mut v = 0;
                    for n in 0..16 {
                        let f = self.pfs[m][n];
                        v |= ((f & pfs::PDR) >> 2) << n;
                        v |= (f & pfs::PODR) << (16 + n);
                    }
                    Ok(v)
                }
                0x4 => {
                    need(size, 4, "PCNTR2")?;
                    Ok(self.pidr(m))
                }
                0x8 => refuse("PCNTR3 is write-only"),
                _ => Err(Why::Unmodelled),
            }
        } else if (0x800..0x800 + 0x40 * PORTS as u32).contains(&off) {
            need(size, 4, "PmnPFS")?;
            let m = ((off - 0x800) / 0x40) as usize;
            let n = ((off % 0x40) / 4) as usize;
            let pidr = if self.level(m, n) { pfs::PIDR } else { 0 };
            Ok((self.pfs[m][n] & !pfs::PIDR) | pidr)
        } else if off == 0xD03 {
            Ok(self.pwpr.into())
        } else {
            Err(Why::Unmodelled)
        }
    }

    /// A write in the page at `off`.
    pub fn write(&mut self, off: u32, size: u32, v: u32) -> R<()> {
        if off < 0x20 * PORTS as u32 {
            let m = (off / 0x20) as usize;
            match off % 0x20 {
                0x0 => {
                    need(size, 4, "PCNTR1")?;
                    for n in 0..16 {
                        let f = &mut self.pfs[m][n];
                        *f &= !(pfs::PDR | pfs::PODR);
                        *f |= ((v >> n) & 1) << 2;
                        *f |= (v >> (16 + n)) & 1;
                    }
                }
                0x8 => {
                    need(size, 4, "PCNTR3")?;
                    // POSR (15..0) sets, PORR (31..16) resets; both set: no change (UM).
                    for n in 0..16 {
                        let set = v & (1 << n) != 0;
                        let reset = v & (1 << (16 + n)) != 0;
                        match (set, reset) {
                            (true, false) => self.pfs[m][n] |= pfs::PODR,
                            (false, true) => self.pfs[m][n] &= !pfs::PODR,
                            _ => {}
                        }
                    }
                }
                0x4 => return refuse("PCNTR2 (PIDR/EIDR) is read-only"),
                _ => return Err(Why::Unmodelled),
            }
            self.changed = true;
            Ok(())
        } else if (0x800..0x800 + 0x40 * PORTS as u32).contains(&off) {
            need(size, 4, "PmnPFS")?;
            if self.pwpr & 0x40 == 0 {
                return refuse("PmnPFS written with PWPR.PFSWE = 0");
            }
            let m = ((off - 0x800) / 0x40) as usize;
            let n = ((off % 0x40) / 4) as usize;
            let psel = (v >> 24) & 0x1F;
            if v & pfs::PMR != 0 && v & pfs::ASEL != 0 {
                return refuse("PmnPFS with both PMR and ASEL");
            }
            if v & pfs::PMR == 0 && psel != 0 {
                // Allowed by the chip, but a sign of a mistake: keep it (PSEL is inert).
            }
            self.pfs[m][n] = v & pfs::WRITABLE;
            self.changed = true;
            Ok(())
        } else if off == 0xD03 {
            need(size, 1, "PWPR")?;
            // PFSWE may change only while B0WI = 0; B0WI may always change.
            let b0wi = v as u8 & 0x80;
            if self.pwpr & 0x80 == 0 {
                self.pwpr = b0wi | (v as u8 & 0x40);
            } else {
                self.pwpr = b0wi | (self.pwpr & 0x40);
            }
            Ok(())
        } else {
            Err(Why::Unmodelled)
        }
    }
}
