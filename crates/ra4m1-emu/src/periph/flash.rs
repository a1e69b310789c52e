//! The data flash (8 KiB at 0x4010_0000, eight 1 KiB blocks) and its flash interface, FACI_LP
//! (UM "Flash Memory": registers at 0x407E_C000; FENTRYR at 0x407E_FFB2). Modelled: DFLCTL
//! (DFLEN), FENTRYR (key 0xAA; FENTRYD = data-flash P/E mode), FPR/FPMCR (the protected
//! sequence 0xA5 to FPR, then value, complement, value), FASR, FSARH/L, FEARH/L, FWBL0, FCR
//! (OPST | CMD: 1 = program, 4 = block erase), FSTATR1 (FRDY 6: the command is done while
//! OPST is still 1), FSTATR2 (ERERR 0, PRGERR 1, BCERR 3, ILGLERR 4), FRESETR, FISR (PCKA).
//!
//! Programming clears bits (NOR: new = old & data) and takes [`Timing::program_byte_ns`];
//! erasing sets a block to 0xFF and takes [`Timing::erase_block_ns`]. The contents survive every
//! reset and power cycle; a power cut during an erase leaves the part of the block already
//! erased (in address order) erased and the rest as it was, and a cut program leaves the byte
//! as it was. Faults can be injected ([`FlashFault`]).

use super::{need, refuse, Why, R};
use crate::clock::ns_to_ticks;

/// FACI register base.
pub const BASE: u32 = 0x407E_C000;
/// Page holding FENTRYR.
pub const FENTRY_PAGE: u32 = 0x407E_F000;
/// Data flash read window.
pub const DF_BASE: u32 = 0x4010_0000;
/// Data flash size.
pub const DF_SIZE: usize = 8 * 1024;
/// Erase block.
pub const DF_BLOCK: usize = 1024;
/// Data flash as the sequencer addresses it (FSAR/FEAR).
const DF_PE_BASE: u32 = 0xFE00_0000;

/// Program/erase times. Defaults are the RA4M1 data sheet's typical data-flash times at
/// FCLK ≥ 4 MHz (1-byte program ≈ 52 µs, 1 KiB erase ≈ 8.7 ms, electrical characteristics,
/// "Data flash memory characteristics"); the maxima are an order of magnitude longer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// One byte.
    pub program_byte_ns: u64,
    /// One 1 KiB block.
    pub erase_block_ns: u64,
}

impl Default for Timing {
    fn default() -> Self {
        Self {
            program_byte_ns: 52_000,
            erase_block_ns: 8_700_000,
        }
    }
}

/// A fault to inject into the flash sequencer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlashFault {
    /// Every program command ends with FSTATR2.PRGERR and changes nothing.
    ProgramError,
    /// Every erase command ends with FSTATR2.ERERR and changes nothing.
    EraseError,
    /// Commands never finish (FRDY stays 0) until the sequencer is reset.
    Hang,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    Program { offset: usize, byte: u8 },
    Erase { block: usize },
}

/// The data flash and its sequencer.
#[derive(Debug, Clone)]
pub struct Flash {
    /// The 8 KiB.
    pub mem: Vec<u8>,
    /// Times.
    pub timing: Timing,
    /// Injected fault.
    pub fault: Option<FlashFault>,
    dflctl: u8,
    fentryr: u16,
    fpr_armed: u8,
    fpmcr_seq: [u8; 3],
    fpmcr: u8,
    fasr: u8,
    fsar: u32,
    fear: u32,
    fwb: u32,
    fcr: u8,
    fstatr2: u32,
    fisr: u32,
    /// The running command and when it ends (`u64::MAX`: hung).
    op: Option<(Op, u64, u64)>,
    /// The last command finished (FRDY while OPST = 1).
    done: bool,
    /// Counters.
    pub programs: u64,
    /// Erase counts per block.
    pub erases: [u64; DF_SIZE / DF_BLOCK],
}

impl Default for Flash {
    fn default() -> Self {
        Self::new()
    }
}

impl Flash {
    /// Erased data flash, sequencer in read mode.
    pub fn new() -> Self {
        Self {
            mem: vec![0xFF; DF_SIZE],
            timing: Timing::default(),
            fault: None,
            dflctl: 0,
            fentryr: 0,
            fpr_armed: 0,
            fpmcr_seq: [0; 3],
            fpmcr: 0x08,
            fasr: 0,
            fsar: 0,
            fear: 0,
            fwb: 0,
            fcr: 0,
            fstatr2: 0,
            fisr: 0,
            op: None,
            done: false,
            programs: 0,
            erases: [0; DF_SIZE / DF_BLOCK],
        }
    }

    /// The chip resets: the sequencer returns to read mode; a running command is cut (see the
    /// module docs); the contents and the injected fault stay.
    pub fn reset(&mut self, now: u64) {
        if let Some((Op::Erase { block }, start, end)) = self.op {
            if end != u64::MAX {
                let frac = (now.saturating_sub(start)) as f64 / (end - start).max(1) as f64;
                let n = ((frac.clamp(0.0, 1.0)) * DF_BLOCK as f64) as usize;
                let base = block * DF_BLOCK;
                self.mem[base..base + n].fill(0xFF);
            }
        }
        let keep = (
            std::mem::take(&mut self.mem),
            self.timing,
            self.fault,
            self.programs,
            self.erases,
        );
        *self = Self::new();
        (
            self.mem,
            self.timing,
            self.fault,
            self.programs,
            self.erases,
        ) = keep;
    }

    /// When the running command ends.
    pub fn next_event(&self) -> Option<u64> {
        self.op.map(|(_, _, end)| end).filter(|&e| e != u64::MAX)
    }

    /// Completes a command due at `now`.
    pub fn advance(&mut self, now: u64) {
        if let Some((op, _, end)) = self.op {
            if end <= now {
                self.op = None;
                self.done = true;
                match op {
                    Op::Program { offset, byte } => {
                        if self.fault == Some(FlashFault::ProgramError) {
                            self.fstatr2 |= 1 << 1;
                        } else {
                            self.mem[offset] &= byte;
                            self.programs += 1;
                        }
                    }
                    Op::Erase { block } => {
                        if self.fault == Some(FlashFault::EraseError) {
                            self.fstatr2 |= 1;
                        } else {
                            let b = block * DF_BLOCK;
                            self.mem[b..b + DF_BLOCK].fill(0xFF);
                            self.erases[block] += 1;
                        }
                    }
                }
            }
        }
    }

    /// Data flash reads are enabled and not in P/E mode.
    pub fn readable(&self) -> Result<(), String> {
        if self.dflctl & 1 == 0 {
            Err("data flash read with DFLCTL.DFLEN = 0".into())
        } else if self.fentryr != 0 {
            Err("data flash read while in P/E mode (FENTRYR.FENTRYD = 1)".into())
        } else {
            Ok(())
        }
    }

    fn pe(&self, name: &str) -> R<()> {
        if self.fentryr & 0x80 == 0 {
            refuse(format!("{name} written outside data-flash P/E mode"))
        } else {
            Ok(())
        }
    }

    fn start(&mut self, cmd: u8, now: u64) -> R<()> {
        self.pe("FCR")?;
        if self.fpmcr != 0x10 {
            return refuse(format!(
                "FCR command with FPMCR = {:#04x} (not data-flash P/E, 0x10)",
                self.fpmcr
            ));
        }
        if self.fasr & 1 != 0 {
            return refuse("FCR command with FASR.EXS = 1: the extra area is never to be touched");
        }
        if self.op.is_some() {
            return refuse("FCR command while one is running");
        }
        let in_df = |a: u32| (DF_PE_BASE..DF_PE_BASE + DF_SIZE as u32).contains(&a);
        let end_of = |ns: u64| {
            if self.fault == Some(FlashFault::Hang) {
                u64::MAX
            } else {
                now + ns_to_ticks(ns)
            }
        };
        match cmd {
            0x01 => {
                if !in_df(self.fsar) {
                    self.fstatr2 |= 1 << 4;
                    self.done = true;
                    return Ok(());
                }
                let offset = (self.fsar - DF_PE_BASE) as usize;
                let op = Op::Program {
                    offset,
                    byte: self.fwb as u8,
                };
                self.op = Some((op, now, end_of(self.timing.program_byte_ns)));
            }
            0x04 => {
                if !in_df(self.fsar)
                    || !in_df(self.fear)
                    || !((self.fsar - DF_PE_BASE) as usize).is_multiple_of(DF_BLOCK)
                {
                    self.fstatr2 |= 1 << 4;
                    self.done = true;
                    return Ok(());
                }
                let first = (self.fsar - DF_PE_BASE) as usize / DF_BLOCK;
                let last = (self.fear - DF_PE_BASE) as usize / DF_BLOCK;
                if last != first {
                    return refuse("erase of more than one block per command is not modelled");
                }
                self.op = Some((
                    Op::Erase { block: first },
                    now,
                    end_of(self.timing.erase_block_ns),
                ));
            }
            c => {
                return refuse(format!(
                    "FCR.CMD = {c:#x} is not modelled (program 1, erase 4)"
                ))
            }
        }
        self.done = false;
        Ok(())
    }

    /// A read of the FACI page at `off` (FENTRYR: page `FENTRY_PAGE`, offset 0xFB2).
    pub fn read(&mut self, page: u32, off: u32, size: u32, now: u64) -> R<u32> {
        self.advance(now);
        if page == FENTRY_PAGE {
            return match off {
                0xFB2 => {
                    need(size, 2, "FENTRYR")?;
                    Ok(self.fentryr.into())
                }
                _ => Err(Why::Unmodelled),
            };
        }
        Ok(match off {
            0x090 => self.dflctl.into(),
            0x100 => self.fpmcr.into(),
            0x104 => self.fasr.into(),
            0x108 => self.fsar & 0xFFFF,
            0x110 => self.fsar >> 16,
            0x114 => self.fcr.into(),
            0x118 => self.fear & 0xFFFF,
            0x120 => self.fear >> 16,
            0x124 => 0,
            0x12C => {
                let frdy = self.done && self.fcr & 0x80 != 0;
                u32::from(frdy) << 6 | 1 << 7 // EXRDY (7): no extra-area command runs
            }
            0x130 => self.fwb,
            0x180 => 0,
            0x1D8 => self.fisr,
            0x1F0 => self.fstatr2,
            _ => return Err(Why::Unmodelled),
        })
    }

    /// A write of the FACI page at `off`.
    pub fn write(&mut self, page: u32, off: u32, size: u32, v: u32, now: u64) -> R<()> {
        self.advance(now);
        if page == FENTRY_PAGE {
            return match off {
                0xFB2 => {
                    need(size, 2, "FENTRYR")?;
                    if v >> 8 != 0xAA {
                        return refuse(format!("FENTRYR written without the key 0xAA ({v:#06x})"));
                    }
                    if v & 1 != 0 {
                        return refuse("FENTRYR.FENTRY0 (code-flash P/E) is never to be used here");
                    }
                    if self.op.is_some() && v & 0x80 == 0 {
                        return refuse("FENTRYR: leaving P/E mode while a command runs");
                    }
                    self.fentryr = (v & 0x80) as u16;
                    Ok(())
                }
                _ => Err(Why::Unmodelled),
            };
        }
        match off {
            0x090 => self.dflctl = v as u8 & 1,
            0x100 => {
                need(size, 1, "FPMCR")?;
                // FPR (0xA5), then value, ~value, value.
                let b = v as u8;
                match self.fpr_armed {
                    1 => {
                        self.fpmcr_seq[0] = b;
                        self.fpr_armed = 2;
                    }
                    2 if b == !self.fpmcr_seq[0] => self.fpr_armed = 3,
                    3 if b == self.fpmcr_seq[0] => {
                        self.fpmcr = b;
                        self.fpr_armed = 0;
                    }
                    _ => {
                        self.fpr_armed = 0;
                        return refuse("FPMCR written outside the FPR-protected sequence");
                    }
                }
            }
            0x104 => {
                self.pe("FASR")?;
                self.fasr = v as u8 & 1;
            }
            0x108 => self.fsar = (self.fsar & 0xFFFF_0000) | (v & 0xFFFF),
            0x110 => self.fsar = (self.fsar & 0xFFFF) | ((v & 0xFFFF) << 16),
            0x114 => {
                need(size, 1, "FCR")?;
                let v = v as u8;
                if v & 0x80 != 0 && self.fcr & 0x80 == 0 {
                    self.fcr = v;
                    self.start(v & 0x7F, now)?;
                } else if v & 0x80 == 0 {
                    if self.op.is_some() {
                        return refuse("FCR.OPST cleared before FSTATR1.FRDY = 1");
                    }
                    self.fcr = v;
                    self.done = false;
                }
            }
            0x118 => self.fear = (self.fear & 0xFFFF_0000) | (v & 0xFFFF),
            0x120 => self.fear = (self.fear & 0xFFFF) | ((v & 0xFFFF) << 16),
            0x124 => {
                if v & 1 != 0 {
                    // FRESET: stop everything, clear the errors.
                    self.op = None;
                    self.done = false;
                    self.fstatr2 = 0;
                    self.fcr = 0;
                }
            }
            0x130 => self.fwb = v & 0xFFFF,
            0x180 => {
                self.fpr_armed = if v as u8 == 0xA5 { 1 } else { 0 };
            }
            0x1D8 => {
                self.pe("FISR")?;
                self.fisr = v;
            }
            _ => return Err(Why::Unmodelled),
        }
        Ok(())
    }
}
