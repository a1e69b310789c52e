//! System clocks: HOCO as the system clock, dividers chosen for the bus limits, flash wait
//! state, and high-speed operating mode.
//!
//! What the Arduino bootloader leaves is not documented, so this code does not rely on it: it
//! reads the HOCO frequency the option bytes select (OFS1.HOCOFRQ1 at 0x0000_0404, read only —
//! the option-setting memory is never written), then sets every divider itself. With the
//! Arduino option bytes HOCO = 48 MHz and the result is ICLK = PCLKA = PCLKC = PCLKD = 48 MHz,
//! PCLKB = FCLK = 24 MHz (the Arduino core's own settings).
//!
//! Limits (RA4M1 hardware manual, clock generation): ICLK, PCLKA ≤ 48 MHz; PCLKB ≤ 32 MHz;
//! PCLKC, PCLKD ≤ 64 MHz; FCLK ≤ 32 MHz (and ≥ 4 MHz for data-flash programming); MEMWAIT = 1
//! when ICLK > 32 MHz; SCKDIVCR bits 18..16 must equal PCKB.

use core::ptr::read_volatile;

use super::regs::{pac, rd, with_clock_regs_unlocked, wr};

/// OFS1 in the option-setting memory (read only!).
const OFS1_ADDR: usize = 0x0000_0404;

/// The frequencies in effect after [`init`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct Clocks {
    /// HOCO (the system clock source).
    pub hoco_hz: u32,
    /// CPU and SysTick.
    pub iclk_hz: u32,
    /// SCI (UART).
    pub pclka_hz: u32,
    /// WDT and most control registers.
    pub pclkb_hz: u32,
    /// ADC conversion clock.
    pub pclkc_hz: u32,
    /// GPT (servo PWM) count source.
    pub pclkd_hz: u32,
    /// Flash interface (data-flash programming).
    pub fclk_hz: u32,
}

/// HOCO frequency from OFS1.HOCOFRQ1 (bits 14..12): 000 = 24, 010 = 32, 100 = 48, 101 = 64 MHz.
#[inline]
pub fn hoco_hz() -> u32 {
    // SAFETY: a read of the option-setting memory in code flash (always mapped, read-only).
    let ofs1 = unsafe { read_volatile(OFS1_ADDR as *const u32) };
    match (ofs1 >> 12) & 0b111 {
        0b000 => 24_000_000,
        0b010 => 32_000_000,
        0b101 => 64_000_000,
        // 0b100 is 48 MHz; the other codes are "setting prohibited": assume the Arduino value.
        _ => 48_000_000,
    }
}

/// Smallest divider 2^k (k ≤ 6) bringing `hz` to `max_hz` or below: (field code, divided Hz).
fn divider(hz: u32, max_hz: u32) -> (u32, u32) {
    let mut k = 0;
    while k < 6 && (hz >> k) > max_hz {
        k += 1;
    }
    (k, hz >> k)
}

/// Brings the clocks up (idempotent) and returns the frequencies.
#[inline]
pub fn init() -> Clocks {
    let hoco = hoco_hz();
    let (ick, iclk) = divider(hoco, 48_000_000);
    let (pcka, pclka) = divider(hoco, 48_000_000);
    let (pckb, pclkb) = divider(hoco, 32_000_000);
    let (pckc, pclkc) = divider(hoco, 64_000_000);
    let (pckd, pclkd) = divider(hoco, 64_000_000);
    // 24 MHz FCLK (not 32/48): half of 48 matches the Arduino core, and any value ≥ 4 MHz
    // is fine for data-flash programming.
    let (fck, fclk) = divider(hoco, 24_000_000);
    let sckdivcr =
        (fck << 28) | (ick << 24) | (pckb << 16) | (pcka << 12) | (pckb << 8) | (pckc << 4) | pckd;

    let already = rd!(pac::SYSTEM.sckscr()) == 0
        && rd!(pac::SYSTEM.sckdivcr()) == sckdivcr
        && rd!(pac::SYSTEM.opccr()) & 0b11 == 0
        && (iclk <= 32_000_000 || rd!(pac::SYSTEM.memwait()) & 1 == 1);
    if !already {
        with_clock_regs_unlocked(|| {
            // HOCO on (HOCOCR.HCSTP = 0) and stable (OSCSF.HOCOSF = 1).
            if rd!(pac::SYSTEM.hococr()) & 1 != 0 {
                wr!(pac::SYSTEM.hococr(), 0);
            }
            while rd!(pac::SYSTEM.oscsf()) & 1 == 0 {}
            // High-speed operating mode (OPCCR.OPCM = 00), waiting out any mode transition
            // (OPCCR.OPCMTSF, bit 4).
            while rd!(pac::SYSTEM.opccr()) & 0x10 != 0 {}
            if rd!(pac::SYSTEM.opccr()) & 0b11 != 0 {
                wr!(pac::SYSTEM.opccr(), 0);
                while rd!(pac::SYSTEM.opccr()) & 0x10 != 0 {}
            }
            // Flash wait state before the CPU may run above 32 MHz (harmless when slower).
            if iclk > 32_000_000 {
                wr!(pac::SYSTEM.memwait(), 1);
            }
            // Dividers first (while still on the old, slower source), then the source.
            wr!(pac::SYSTEM.sckdivcr(), sckdivcr);
            wr!(pac::SYSTEM.sckscr(), 0); // CKSEL = HOCO
                                          // The manual asks for a read-back before relying on the new clock.
            let _ = rd!(pac::SYSTEM.sckscr());
        });
    }
    Clocks {
        hoco_hz: hoco,
        iclk_hz: iclk,
        pclka_hz: pclka,
        pclkb_hz: pclkb,
        pclkc_hz: pclkc,
        pclkd_hz: pclkd,
        fclk_hz: fclk,
    }
}

/// Takes peripherals out of module-stop (MSTPCRB/MSTPCRD bits: 0 = running).
#[inline]
pub fn enable_modules() {
    // MSTPCRB: SCI9 = bit 22. MSTPCRD: GPT ch2..7 = bit 6 (our GPT5, GPT7), ADC140 = bit 16.
    let b = rd!(pac::MSTP.mstpcrb());
    wr!(pac::MSTP.mstpcrb(), b & !(1 << 22));
    let d = rd!(pac::MSTP.mstpcrd());
    wr!(pac::MSTP.mstpcrd(), d & !((1 << 6) | (1 << 16)));
}
