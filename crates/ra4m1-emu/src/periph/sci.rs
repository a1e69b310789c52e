//! SCI9 in asynchronous mode (UM "Serial Communications Interface (SCI)"), at 0x4007_0120:
//! SMR, BRR, SCR (TIE 7, RIE 6, TE 5, RE 4, TEIE 2), TDR, SSR (TDRE 7, RDRF 6, ORER 5, FER 4,
//! PER 3, TEND 2), RDR, SCMR, SEMR (BGDM 6, ABCS 4), SNFR. No FIFO on SCI9.
//!
//! Timing: a frame is 1 start + 7/8 data + parity + 1/2 stop bits; a bit lasts
//! 32·4ⁿ·(BRR+1) PCLKA cycles (n = SMR.CKS), halved by SEMR.ABCS and again by SEMR.BGDM.
//! Transmission: a TDR write moves to the shift register at once when it is idle (TDRE → 1,
//! TXI), the byte leaves one frame later, then the next TDR byte follows or TEND → 1 (TEI).
//! Setting TE and TIE in one write raises TXI. Reception: bytes from the host arrive one frame
//! apart at the host's rate; a byte lands in RDR (RDRF, RXI) or, with RDRF still set, is lost
//! with ORER (ERI); a host rate more than 2.5 % off the SCI's gives framing errors (FER, ERI).
//! Reading RDR clears RDRF; the error flags clear by writing 0.

use std::collections::VecDeque;

use super::event::{SCI9_ERI, SCI9_RXI, SCI9_TEI, SCI9_TXI};
use super::{need, refuse, Why, R};
use crate::clock::{ticks_per, TICK_HZ};

/// Base of SCI9.
pub const BASE: u32 = 0x4007_0120;

const TIE: u8 = 1 << 7;
const RIE: u8 = 1 << 6;
const TE: u8 = 1 << 5;
const RE: u8 = 1 << 4;
const TEIE: u8 = 1 << 2;
const ORER: u8 = 1 << 5;
const FER: u8 = 1 << 4;
const PER: u8 = 1 << 3;

/// SCI9.
#[derive(Debug, Clone, Default)]
pub struct Sci {
    smr: u8,
    brr: u8,
    scr: u8,
    scmr: u8,
    semr: u8,
    snfr: u8,
    errors: u8,
    tdr: Option<u8>,
    /// Byte being shifted out and when its stop bit ends.
    tsr: Option<(u8, u64)>,
    rdr: u8,
    rdrf: bool,
    /// Host → device bytes and the tick at which each one's stop bit ends.
    rx_line: VecDeque<(u8, u64)>,
    /// Device → host bytes whose stop bit has passed.
    pub tx_out: Vec<u8>,
    /// Host line rate, Bd.
    pub host_baud: u32,
    /// Bytes lost: overrun, framing, or arriving with RE = 0.
    pub rx_lost: u64,
    /// Of [`Sci::rx_lost`], the overruns: a byte that came while RDR still held the last one
    /// (its RXI not yet served) or ORER was still set.
    pub rx_overruns: u64,
    /// When the last overrun happened, ticks.
    pub last_overrun_at: Option<u64>,
    /// Bytes sent so far.
    pub tx_count: u64,
}

impl Sci {
    /// The reset state (SCMR = 0xF2), host at 115 200 Bd.
    pub fn new() -> Self {
        Self {
            scmr: 0xF2,
            host_baud: 115_200,
            ..Self::default()
        }
    }

    fn ssr(&self) -> u8 {
        let tdre = u8::from(self.tdr.is_none()) << 7;
        let rdrf = u8::from(self.rdrf) << 6;
        let tend = u8::from(self.tdr.is_none() && self.tsr.is_none()) << 2;
        // MPB (1) and MPBT (0) read 0 outside multi-processor mode: idle SSR = 0x84 (TDRE,
        // TEND), its reset value (UM "Serial Communications Interface", SSR).
        tdre | rdrf | self.errors | tend
    }

    /// Ticks per bit at the current settings.
    fn bit_ticks(&self, pclka: u32) -> u64 {
        let n = u64::from(self.smr & 3);
        let mut per_bit = 32 * (1 << (2 * n)) * (u64::from(self.brr) + 1);
        if self.semr & (1 << 4) != 0 {
            per_bit /= 2;
        }
        if self.semr & (1 << 6) != 0 {
            per_bit /= 2;
        }
        per_bit * ticks_per(pclka)
    }

    fn frame_bits(&self) -> u64 {
        let data = if self.smr & (1 << 6) != 0 { 7 } else { 8 };
        let parity = u64::from(self.smr & (1 << 5) != 0);
        let stop = if self.smr & (1 << 3) != 0 { 2 } else { 1 };
        1 + data + parity + stop
    }

    /// The SCI's bit rate, Bd.
    pub fn baud(&self, pclka: u32) -> f64 {
        TICK_HZ as f64 / self.bit_ticks(pclka) as f64
    }

    /// Frame time at the current settings, ticks.
    pub fn frame_ticks(&self, pclka: u32) -> u64 {
        self.bit_ticks(pclka) * self.frame_bits()
    }

    /// Queues bytes from the host; they arrive one host frame apart after the line's last one.
    pub fn host_send(&mut self, bytes: &[u8], now: u64) {
        let frame = TICK_HZ * self.frame_bits() / u64::from(self.host_baud.max(1));
        let mut t = self.rx_line.back().map_or(now, |&(_, t)| t.max(now));
        for &b in bytes {
            t += frame;
            self.rx_line.push_back((b, t));
        }
    }

    /// Bytes still on their way from the host.
    pub fn host_pending(&self) -> usize {
        self.rx_line.len()
    }

    /// Next tick at which something happens here.
    pub fn next_event(&self) -> Option<u64> {
        let tx = self.tsr.map(|(_, t)| t);
        let rx = self.rx_line.front().map(|&(_, t)| t);
        match (tx, rx) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn start_shift(&mut self, now: u64, pclka: u32, ev: &mut Vec<u16>) {
        if self.tsr.is_none() {
            if let Some(b) = self.tdr.take() {
                self.tsr = Some((b, now + self.frame_ticks(pclka)));
                if self.scr & TIE != 0 {
                    ev.push(SCI9_TXI);
                }
            }
        }
    }

    /// Moves the line on to `now`.
    pub fn advance(&mut self, now: u64, pclka: u32, ev: &mut Vec<u16>) {
        loop {
            let tx_due = self.tsr.is_some_and(|(_, t)| t <= now);
            let rx_due = self.rx_line.front().is_some_and(|&(_, t)| t <= now);
            if !tx_due && !rx_due {
                break;
            }
            let tx_t = self.tsr.map_or(u64::MAX, |(_, t)| t);
            let rx_t = self.rx_line.front().map_or(u64::MAX, |&(_, t)| t);
            if tx_due && tx_t <= rx_t {
                let (b, t) = self.tsr.take().unwrap_or((0, now));
                self.tx_out.push(b);
                self.tx_count += 1;
                self.start_shift(t, pclka, ev);
                if self.tsr.is_none() && self.scr & TEIE != 0 {
                    ev.push(SCI9_TEI);
                }
            } else {
                let (b, t) = self.rx_line.pop_front().unwrap_or((0, now));
                let overruns = self.rx_overruns;
                self.receive(b, pclka, ev);
                if self.rx_overruns != overruns {
                    self.last_overrun_at = Some(t);
                }
            }
        }
    }

    fn receive(&mut self, b: u8, pclka: u32, ev: &mut Vec<u16>) {
        if self.scr & RE == 0 {
            self.rx_lost += 1;
            return;
        }
        let off = (self.baud(pclka) - f64::from(self.host_baud)).abs() / f64::from(self.host_baud);
        if off > 0.025 {
            self.errors |= FER;
            self.rx_lost += 1;
            if self.scr & RIE != 0 {
                ev.push(SCI9_ERI);
            }
        } else if self.rdrf || self.errors & ORER != 0 {
            self.errors |= ORER;
            self.rx_lost += 1;
            self.rx_overruns += 1;
            if self.scr & RIE != 0 {
                ev.push(SCI9_ERI);
            }
        } else {
            self.rdr = b;
            self.rdrf = true;
            if self.scr & RIE != 0 {
                ev.push(SCI9_RXI);
            }
        }
    }

    /// A read at `off`.
    pub fn read(&mut self, off: u32, size: u32) -> R<u32> {
        need(size, 1, "an SCI register")?;
        Ok(match off {
            0x0 => self.smr.into(),
            0x1 => self.brr.into(),
            0x2 => self.scr.into(),
            0x3 => self.tdr.unwrap_or(0xFF).into(),
            0x4 => self.ssr().into(),
            0x5 => {
                self.rdrf = false;
                self.rdr.into()
            }
            0x6 => self.scmr.into(),
            0x7 => self.semr.into(),
            0x8 => self.snfr.into(),
            _ => return Err(Why::Unmodelled),
        })
    }

    /// A write at `off`.
    pub fn write(
        &mut self,
        off: u32,
        size: u32,
        v: u32,
        now: u64,
        pclka: u32,
        ev: &mut Vec<u16>,
    ) -> R<()> {
        need(size, 1, "an SCI register")?;
        let v = v as u8;
        let off_while_on = |name: &str| -> R<()> {
            if self.scr & (TE | RE) != 0 {
                refuse(format!("{name} written while SCR.TE or SCR.RE is 1"))
            } else {
                Ok(())
            }
        };
        match off {
            0x0 => {
                off_while_on("SMR")?;
                if v & 0x80 != 0 {
                    return refuse("SMR.CM = 1 (clock-synchronous mode) is not modelled");
                }
                self.smr = v;
            }
            0x1 => {
                off_while_on("BRR")?;
                self.brr = v;
            }
            0x2 => {
                if v & 0x03 != 0 {
                    return refuse("SCR.CKE: only the on-chip baud rate generator is modelled");
                }
                let was = self.scr;
                self.scr = v;
                if v & TE == 0 {
                    self.tdr = None;
                }
                if was & TE == 0 && v & (TE | TIE) == (TE | TIE) {
                    ev.push(SCI9_TXI);
                }
                if was & TEIE == 0 && v & TEIE != 0 && self.tdr.is_none() && self.tsr.is_none() {
                    ev.push(SCI9_TEI);
                }
            }
            0x3 => {
                if self.scr & TE == 0 {
                    return refuse("TDR written with SCR.TE = 0");
                }
                if self.tdr.is_some() {
                    return refuse("TDR written while SSR.TDRE = 0 (the previous byte is lost)");
                }
                self.tdr = Some(v);
                self.start_shift(now, pclka, ev);
            }
            0x4 => {
                // ORER, FER, PER clear by writing 0; the other bits are not writable.
                self.errors &= v | !(ORER | FER | PER);
            }
            0x6 => {
                off_while_on("SCMR")?;
                if v & 0x0D != 0 {
                    return refuse(
                        "SCMR: smart-card mode, inversion or MSB-first are not modelled",
                    );
                }
                self.scmr = v | 0xF2;
            }
            0x7 => {
                off_while_on("SEMR")?;
                self.semr = v;
            }
            0x8 => self.snfr = v & 7,
            _ => return Err(Why::Unmodelled),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SSR reads 0x84 at reset and whenever the transmitter is idle (TDRE, TEND; MPB = 0).
    #[test]
    fn ssr_idle_value_is_0x84() {
        let mut s = Sci::new();
        assert_eq!(s.read(0x4, 1), Ok(0x84));
        let mut ev = Vec::new();
        s.write(0x1, 1, 51, 0, 48_000_000, &mut ev).unwrap();
        s.write(0x2, 1, u32::from(TE), 0, 48_000_000, &mut ev)
            .unwrap();
        s.write(0x3, 1, 0x55, 0, 48_000_000, &mut ev).unwrap();
        assert_eq!(s.read(0x4, 1), Ok(0x80), "shifting: TDRE, not TEND");
        s.advance(u64::MAX / 2, 48_000_000, &mut ev);
        assert_eq!(s.read(0x4, 1), Ok(0x84));
    }

    /// A byte that arrives while RDR still holds the last one (its RXI not served) is an
    /// overrun: lost, counted apart from the bytes lost with the receiver off.
    #[test]
    fn an_unserved_byte_is_an_overrun_and_one_sent_with_re_off_is_not() {
        let mut s = Sci::new();
        let mut ev = Vec::new();
        // 115 200 Bd from PCLKA = 48 MHz: BRR = 12 (32 × 13 PCLKA a bit, 0.2 % fast).
        s.write(0x1, 1, 12, 0, 48_000_000, &mut ev).unwrap();
        s.host_send(&[0x11], 0);
        s.advance(TICK_HZ, 48_000_000, &mut ev);
        assert_eq!(
            (s.rx_lost, s.rx_overruns),
            (1, 0),
            "RE = 0: lost, no overrun"
        );
        s.write(0x2, 1, u32::from(RE | RIE), TICK_HZ, 48_000_000, &mut ev)
            .unwrap();
        s.host_send(&[0x22, 0x33], TICK_HZ);
        s.advance(2 * TICK_HZ, 48_000_000, &mut ev);
        assert_eq!((s.rx_lost, s.rx_overruns), (2, 1), "0x33 overran 0x22");
        assert_eq!(s.read(0x5, 1), Ok(0x22), "RDR keeps the first byte");
    }
}
