//! The 14-bit A/D converter ADC140 at 0x4005_C000 (UM "14-Bit A/D Converter (ADC14)"):
//! single scan, software trigger. ADCSR.ADST starts a scan of the channels in ADANSA0/1; each
//! channel takes its sampling time (ADSSTRn states, reset value 0x0D) plus the 14-bit conversion
//! (≈ 37 ADCLK states), ADCLK = PCLKC; then ADDRn holds the result and ADST returns to 0.
//! Results are right-aligned (ADCER.ADRFMT = 0) at the resolution of ADCER.ADPRC (14/12/10
//! bits). The analog input of each channel is set from outside as a 14-bit count
//! ([`Adc::set_input`]), i.e. the ideal conversion of its voltage against AVCC0.

use super::{need, refuse, Why, R};
use crate::clock::ticks_per;

/// Base of ADC140.
pub const BASE: u32 = 0x4005_C000;
/// Conversion states after sampling (14-bit mode).
const CONVERT_STATES: u64 = 37;
/// Channels AN000..AN025 (ADDR0..ADDR25 at 0x20 + 2n; some numbers are not bonded out).
const CHANNELS: usize = 26;

/// ADC140.
#[derive(Debug, Clone)]
pub struct Adc {
    adcsr: u16,
    adansa: [u16; 2],
    adads: [u16; 2],
    adadc: u8,
    adcer: u16,
    adstrgr: u16,
    adexicr: u16,
    adsstr: [u8; 16],
    adhvrefcnt: u8,
    addr: [u16; CHANNELS],
    /// The analog input of each channel, 14-bit counts.
    pub input: [u16; CHANNELS],
    /// When the running scan completes.
    pub done_at: Option<u64>,
    /// Conversions done so far.
    pub conversions: u64,
}

impl Default for Adc {
    fn default() -> Self {
        Self {
            adcsr: 0,
            adansa: [0; 2],
            adads: [0; 2],
            adadc: 0,
            adcer: 0,
            adstrgr: 0,
            adexicr: 0,
            adsstr: [0x0D; 16],
            adhvrefcnt: 0,
            addr: [0; CHANNELS],
            input: [0; CHANNELS],
            done_at: None,
            conversions: 0,
        }
    }
}

impl Adc {
    /// A reset converter with the analog inputs of `other` (they are outside the chip).
    pub fn reset_keeping_inputs(other: &Adc) -> Self {
        Self {
            input: other.input,
            ..Self::default()
        }
    }

    fn selected(&self) -> impl Iterator<Item = usize> + '_ {
        (0..CHANNELS).filter(|&n| self.adansa[n / 16] & (1 << (n % 16)) != 0)
    }

    /// Completes a scan due at or before `now`.
    pub fn advance(&mut self, now: u64) {
        if self.done_at.is_some_and(|t| t <= now) {
            self.done_at = None;
            let shift = match (self.adcer >> 1) & 3 {
                3 => 0,
                0 => 2,
                _ => 4,
            };
            let chans: Vec<usize> = self.selected().collect();
            for n in chans {
                self.addr[n] = self.input[n].min(0x3FFF) >> shift;
                self.conversions += 1;
            }
            self.adcsr &= !0x8000;
        }
    }

    /// A read at `off`.
    pub fn read(&mut self, off: u32, size: u32, now: u64) -> R<u32> {
        self.advance(now);
        Ok(match off {
            0x00 => {
                need(size, 2, "ADCSR")?;
                self.adcsr.into()
            }
            0x04 | 0x06 => self.adansa[(off as usize - 4) / 2].into(),
            0x08 | 0x0A => self.adads[(off as usize - 8) / 2].into(),
            0x0C => self.adadc.into(),
            0x0E => self.adcer.into(),
            0x10 => self.adstrgr.into(),
            0x12 => self.adexicr.into(),
            0x20..=0x53 if off.is_multiple_of(2) => {
                need(size, 2, "ADDRn")?;
                self.addr[(off as usize - 0x20) / 2].into()
            }
            0x8A => self.adhvrefcnt.into(),
            0xE0..=0xEF => self.adsstr[off as usize - 0xE0].into(),
            _ => return Err(Why::Unmodelled),
        })
    }

    /// A write at `off`.
    pub fn write(&mut self, off: u32, size: u32, v: u32, now: u64, pclkc: u32) -> R<()> {
        self.advance(now);
        let busy = self.adcsr & 0x8000 != 0;
        if busy && off != 0x00 {
            return refuse("ADC register written during a conversion");
        }
        match off {
            0x00 => {
                need(size, 2, "ADCSR")?;
                let v = v as u16;
                if v & 0x6000 != 0 {
                    return refuse("ADCSR.ADCS: only single scan (00) is modelled");
                }
                if v & 0x0200 != 0 {
                    return refuse("ADCSR.TRGE: hardware triggers are not modelled");
                }
                if v & 0x8000 != 0 && !busy {
                    let states: u64 = self
                        .selected()
                        .map(|n| u64::from(*self.adsstr.get(n).unwrap_or(&0x0D)) + CONVERT_STATES)
                        .sum();
                    self.done_at = Some(now + states.max(1) * ticks_per(pclkc));
                } else if v & 0x8000 == 0 {
                    self.done_at = None; // ADST = 0 stops a scan
                }
                self.adcsr = v;
            }
            0x04 | 0x06 => self.adansa[(off as usize - 4) / 2] = v as u16,
            0x08 | 0x0A => self.adads[(off as usize - 8) / 2] = v as u16,
            0x0C => self.adadc = v as u8,
            0x0E => {
                if v & 0x8000 != 0 {
                    return refuse("ADCER.ADRFMT = 1 (left-aligned) is not modelled");
                }
                self.adcer = v as u16;
            }
            0x10 => self.adstrgr = v as u16,
            0x12 => self.adexicr = v as u16,
            0x8A => {
                if v & 3 != 0 {
                    return refuse("ADHVREFCNT.HVSEL: only AVCC0 as the reference is modelled");
                }
                self.adhvrefcnt = v as u8;
            }
            0xE0..=0xEF => {
                need(size, 1, "ADSSTRn")?;
                if v < 5 {
                    return refuse(format!("ADSSTRn = {v}: below the minimum of 5 states"));
                }
                self.adsstr[off as usize - 0xE0] = v as u8;
            }
            _ => return Err(Why::Unmodelled),
        }
        Ok(())
    }
}
