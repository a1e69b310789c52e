//! The RA4M1's 8 KiB data flash (0x4010_0000, eight 1 KiB blocks) through its flash sequencer.
//!
//! The RA4M1 has the low-power flash interface (Renesas calls it FACI_LP; "MF3", flash
//! version 3), not the FACI command-issuing area of the larger RA parts: each operation is
//! a few register writes (FSAR/FEAR addresses, FWB data, an FCR command) and a wait for
//! FSTATR1.FRDY. The PAC has no flash-controller registers, so they are addressed here from the
//! RA4M1 register map (base 0x407E_C000). The sequences follow the hardware manual's flow
//! charts (entering/leaving data-flash P/E mode through FENTRYR and the FPR-protected FPMCR,
//! byte program, block erase, forced stop/reset on error) — **not yet verified on a board**;
//! `docs/hardware.md` lists what to check first.
//!
//! Data-flash programming runs while the CPU keeps executing from code flash, so nothing here
//! has to run from RAM. Nothing here waits for the flash: a write programs one byte per call
//! (≈ 52 µs each, bounded by 1 ms), and a block erase (≈ 9 ms typical, up to ~0.5 s) runs in
//! the background; both return [`FlashError::Busy`] until done, each call checking
//! FSTATR1.FRDY once — the caller (the record log, once per loop pass) calls again.
//!
//! Safety limits of this module: it only ever addresses 0x4010_0000..0x4010_2000 (data flash)
//! through FSAR/FEAR, never code flash, never the option-setting memory, and never the extra
//! area (FASR stays 0 = user area; the FEXCR "extra area" commands that can lock the chip are
//! not used at all).

use core::ptr::{read_volatile, write_volatile};

use super::time::{cycles, delay_us};
use super::wdt;
use crate::flash_log::{FlashError, NorFlash};

/// Data flash, as read.
pub const DF_READ_BASE: usize = 0x4010_0000;
/// Data flash, as addressed by the sequencer (FSAR/FEAR): read address + 0xBDF0_0000.
const DF_PE_BASE: u32 = 0xFE00_0000;
/// Data flash size.
pub const DF_SIZE: usize = 8 * 1024;
/// Erase block size.
pub const DF_BLOCK: usize = 1024;

const BASE: usize = 0x407E_C000;
const DFLCTL: usize = BASE + 0x090; // u8: DFLEN (bit 0) = data flash readable
const FPMCR: usize = BASE + 0x100; // u8
const FASR: usize = BASE + 0x104; // u8: EXS (bit 0) = extra area; kept 0
const FSARL: usize = BASE + 0x108; // u16
const FSARH: usize = BASE + 0x110; // u16
const FCR: usize = BASE + 0x114; // u8: OPST (bit 7) | CMD
const FEARL: usize = BASE + 0x118; // u16
const FEARH: usize = BASE + 0x120; // u32 (16 bits used)
const FRESETR: usize = BASE + 0x124; // u32: FRESET (bit 0)
const FSTATR1: usize = BASE + 0x12C; // u32: FRDY (bit 6)
const FWBL0: usize = BASE + 0x130; // u32 (8 bits used for data flash)
const FPR: usize = BASE + 0x180; // u32: write 0xA5 before each FPMCR sequence
const FISR: usize = BASE + 0x1D8; // u32: PCKA (bits 5..0) = FCLK in MHz − 1
const FSTATR2: usize = BASE + 0x1F0; // u32: ERERR 0, PRGERR 1, BCERR 3, ILGLERR 4
const FENTRYR: usize = BASE + 0x3FB2; // u16: key 0xAA | FENTRYD (bit 7) | FENTRY0 (bit 0)

const FENTRYR_READ: u16 = 0xAA00;
const FENTRYR_DF_PE: u16 = 0xAA80;
const FPMCR_READ: u8 = 0x08; // RPDIS
const FPMCR_DF_PE: u8 = 0x10; // FMS1 (high-speed operating mode: no LVPE)
const FCR_WRITE: u8 = 0x81;
const FCR_ERASE: u8 = 0x84;
const FSTATR1_FRDY: u32 = 1 << 6;
const FSTATR2_WRITE_ERR: u32 = 0x12; // PRGERR | ILGLERR
const FSTATR2_ERASE_ERR: u32 = 0x11; // ERERR | ILGLERR

/// tDSTOP (data flash stop recovery) and tMS (mode setup), rounded up.
const T_DSTOP_US: u32 = 6;
const T_MS_US: u32 = 6;
/// Completion bounds, above the manual's maxima (byte write 886 µs, 1 KiB erase 504 ms, both at
/// FCLK 4 MHz; FCLK is 24 MHz here).
const WRITE_TIMEOUT_US: u32 = 1_000;
const ERASE_TIMEOUT_US: u32 = 800_000;

#[inline]
fn w8(a: usize, v: u8) {
    // SAFETY: a flash-controller register of the RA4M1 map above.
    unsafe { write_volatile(a as *mut u8, v) }
}
#[inline]
fn w16(a: usize, v: u16) {
    // SAFETY: as `w8`.
    unsafe { write_volatile(a as *mut u16, v) }
}
#[inline]
fn w32(a: usize, v: u32) {
    // SAFETY: as `w8`.
    unsafe { write_volatile(a as *mut u32, v) }
}
#[inline]
fn r8(a: usize) -> u8 {
    // SAFETY: as `w8`; reads have no side effects.
    unsafe { read_volatile(a as *const u8) }
}
#[inline]
fn r16(a: usize) -> u16 {
    // SAFETY: as `r8`.
    unsafe { read_volatile(a as *const u16) }
}
#[inline]
fn r32(a: usize) -> u32 {
    // SAFETY: as `r8`.
    unsafe { read_volatile(a as *const u32) }
}

/// The data flash.
#[derive(Debug)]
pub struct DataFlash {
    core_hz: u32,
    /// A background erase: its block and the cycle count when it started.
    erasing: Option<(usize, u32)>,
    /// A write programmed one byte per call: where, what, how far, and when the byte in
    /// flight started (`None`: none in flight).
    writing: Option<Writing>,
}

/// A write in progress.
#[derive(Debug, Clone, Copy)]
struct Writing {
    offset: usize,
    data: [u8; 16],
    len: usize,
    next: usize,
    in_flight: Option<u32>,
}

impl DataFlash {
    /// Enables data-flash reads (DFLCTL) and tells the sequencer FCLK (FISR.PCKA).
    #[inline]
    pub fn new(fclk_hz: u32, core_hz: u32) -> Self {
        if r8(DFLCTL) & 1 == 0 {
            w8(DFLCTL, 1);
            delay_us(T_DSTOP_US);
        }
        let df = Self {
            core_hz,
            erasing: None,
            writing: None,
        };
        // FISR is writable only in P/E mode.
        df.enter_pe();
        let mhz = fclk_hz.div_ceil(1_000_000);
        let fisr = r32(FISR);
        w32(FISR, (fisr & !0x3F) | (mhz.saturating_sub(1) & 0x1F));
        let _ = df.exit_pe();
        df
    }

    #[inline]
    fn write_fpmcr(&self, v: u8) {
        // The protected sequence: FPR key, then value, complement, value.
        w32(FPR, 0xA5);
        w8(FPMCR, v);
        w8(FPMCR, !v);
        w8(FPMCR, v);
        let _ = r8(FPMCR);
    }

    fn enter_pe(&self) {
        w16(FENTRYR, FENTRYR_DF_PE);
        delay_us(T_DSTOP_US);
        self.write_fpmcr(FPMCR_DF_PE);
    }

    fn exit_pe(&self) -> Result<(), FlashError> {
        self.write_fpmcr(FPMCR_READ);
        delay_us(T_MS_US);
        w16(FENTRYR, FENTRYR_READ);
        self.wait(|| r16(FENTRYR) == 0, 1_000)
    }

    /// Busy-waits for `done`, refreshing the watchdog, at most `timeout_us`.
    #[inline]
    fn wait(&self, done: impl Fn() -> bool, timeout_us: u32) -> Result<(), FlashError> {
        let per_us = self.core_hz / 1_000_000;
        let start = cycles();
        let mut elapsed_us: u32 = 0;
        let mut last = start;
        while !done() {
            wdt::feed();
            let now = cycles();
            // Accumulate in µs so the 89 s cycle-counter wrap never matters.
            let d = now.wrapping_sub(last);
            if d >= per_us {
                elapsed_us += d / per_us;
                last = now.wrapping_sub(d % per_us);
            }
            if elapsed_us > timeout_us {
                return Err(FlashError::Timeout);
            }
        }
        Ok(())
    }

    /// Waits for the command to finish, clears FCR, checks `err_bits`; on any failure resets
    /// the sequencer. Leaves P/E mode in every case.
    fn finish(&self, timeout_us: u32, err_bits: u32, err: FlashError) -> Result<(), FlashError> {
        let mut res = self.wait(|| r32(FSTATR1) & FSTATR1_FRDY != 0, timeout_us);
        w8(FCR, 0);
        if res.is_ok() {
            res = self.wait(|| r32(FSTATR1) & FSTATR1_FRDY == 0, 1_000);
        }
        if res.is_ok() && r32(FSTATR2) & err_bits != 0 {
            res = Err(err);
        }
        if res.is_err() {
            w32(FRESETR, 1);
            w32(FRESETR, 0);
        }
        let exit = self.exit_pe();
        res.and(exit)
    }

    /// Checks a background erase once: `Busy` while it runs, its result when it has ended.
    fn poll_erase(&mut self) -> Result<(), FlashError> {
        let Some((_, started)) = self.erasing else {
            return Ok(());
        };
        if r32(FSTATR1) & FSTATR1_FRDY == 0 {
            let elapsed_us = cycles().wrapping_sub(started) / (self.core_hz / 1_000_000).max(1);
            if elapsed_us <= ERASE_TIMEOUT_US {
                return Err(FlashError::Busy);
            }
            self.erasing = None;
            w32(FRESETR, 1);
            w32(FRESETR, 0);
            let _ = self.exit_pe();
            return Err(FlashError::Timeout);
        }
        self.erasing = None;
        self.finish(1_000, FSTATR2_ERASE_ERR, FlashError::Erase)
    }

    #[inline]
    fn set_range(start: u32, end_inclusive: u32) {
        w8(FASR, 0); // user area, never the extra area
        w16(FSARH, (start >> 16) as u16);
        w16(FSARL, start as u16);
        w32(FEARH, end_inclusive >> 16);
        w16(FEARL, end_inclusive as u16);
    }
}

impl NorFlash for DataFlash {
    const BLOCK_SIZE: usize = DF_BLOCK;

    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        if offset + buf.len() > DF_SIZE {
            return Err(FlashError::OutOfRange);
        }
        self.poll_erase()?;
        if self.writing.is_some_and(|w| w.in_flight.is_some()) {
            return Err(FlashError::Busy); // in P/E mode: not readable
        }
        for (i, b) in buf.iter_mut().enumerate() {
            // SAFETY: inside the data flash's read window, readable since DFLCTL.DFLEN = 1.
            *b = unsafe { read_volatile((DF_READ_BASE + offset + i) as *const u8) };
        }
        Ok(())
    }

    /// Programs `data` one byte per call: each call checks the byte in flight once (FRDY),
    /// starts the next and returns [`FlashError::Busy`] until the last byte is done, so no
    /// loop pass waits for the flash (≈ 52 µs a byte). Call it again with the same `offset`
    /// and `data` to go on; different ones while a write is under way are refused
    /// ([`FlashError::Program`]: the bytes already programmed make that slot torn).
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), FlashError> {
        if offset + data.len() > DF_SIZE || data.len() > 16 {
            return Err(FlashError::OutOfRange);
        }
        self.poll_erase()?;
        let mut w = match self.writing {
            Some(w) if w.offset == offset && &w.data[..w.len] == data => w,
            Some(_) => {
                self.writing = None;
                return Err(FlashError::Program);
            }
            None => {
                let mut buf = [0xFF; 16];
                buf[..data.len()].copy_from_slice(data);
                Writing {
                    offset,
                    data: buf,
                    len: data.len(),
                    next: 0,
                    in_flight: None,
                }
            }
        };
        if let Some(started) = w.in_flight {
            if r32(FSTATR1) & FSTATR1_FRDY == 0 {
                let per_us = (self.core_hz / 1_000_000).max(1);
                if cycles().wrapping_sub(started) / per_us <= WRITE_TIMEOUT_US {
                    self.writing = Some(w);
                    return Err(FlashError::Busy);
                }
                self.writing = None;
                w32(FRESETR, 1);
                w32(FRESETR, 0);
                let _ = self.exit_pe();
                return Err(FlashError::Timeout);
            }
            w.in_flight = None;
            if let Err(e) = self.finish(WRITE_TIMEOUT_US, FSTATR2_WRITE_ERR, FlashError::Program) {
                self.writing = None;
                return Err(e);
            }
            w.next += 1;
        }
        if w.next >= w.len {
            self.writing = None;
            return Ok(());
        }
        let a = DF_PE_BASE + (offset + w.next) as u32;
        self.enter_pe();
        w8(FASR, 0);
        w16(FSARH, (a >> 16) as u16);
        w16(FSARL, a as u16);
        w32(FWBL0, w.data[w.next] as u32);
        w8(FCR, FCR_WRITE);
        w.in_flight = Some(cycles());
        self.writing = Some(w);
        Err(FlashError::Busy)
    }

    fn erase(&mut self, block: usize) -> Result<(), FlashError> {
        if block >= DF_SIZE / DF_BLOCK {
            return Err(FlashError::OutOfRange);
        }
        match self.erasing {
            // This block's erase is running: has it ended?
            Some((b, _)) if b == block => return self.poll_erase(),
            Some(_) => {
                self.poll_erase()?;
            }
            None => {}
        }
        let start = DF_PE_BASE + (block * DF_BLOCK) as u32;
        self.enter_pe();
        Self::set_range(start, start + DF_BLOCK as u32 - 1);
        w8(FCR, FCR_ERASE);
        self.erasing = Some((block, cycles()));
        Err(FlashError::Busy)
    }
}
