//! The 16-bit general PWM timers GPT162..GPT167 (UM "General PWM Timer (GPT)"), channel n at
//! 0x4007_8000 + 0x100·n. Modelled: GTWP (write protection, key 0xA5), GTCR (CST, MD = 000
//! saw-wave, TPCS prescaler), GTUDDTYC (UD/UDF, OADTY/OBDTY forced 0 %/100 % duty), GTIOR
//! (GTIOA/GTIOB = 0b01001: low at start, high at cycle end, low at compare match; OAE/OBE output
//! enable; OADFLT/OBDFLT level while stopped), GTBER (single buffer GTCCRC → GTCCRA and GTCCRE →
//! GTCCRB at each cycle end), GTCNT, GTCCRA/B/C/E/D/F (in that address order), GTPR, GTPBR, and the source-select registers
//! (stored, no effect: nothing here uses hardware start/stop sources).
//!
//! What a servo sees is [`Line`]: a pulse train (high time and period), a steady level, or a
//! released (Hi-Z) pin when the output is disabled — GTIOR.OAE = 0 gives the pin up.

use super::{need, refuse, Why, R};
use crate::clock::ticks_per;

/// Base of GPT channel 0 (32-bit GPT320); GPT16n is at `BASE + 0x100·n`.
pub const BASE: u32 = 0x4007_8000;

/// One output's waveform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Line {
    /// Output disabled: the timer does not drive the pin.
    Released,
    /// A steady level (stopped counter, 0 %/100 % duty, or a compare beyond the period).
    Level(bool),
    /// A pulse train.
    Pulses {
        /// High time per period, ns.
        high_ns: u64,
        /// Period, ns.
        period_ns: u64,
    },
}

/// A 16-bit GPT channel.
#[derive(Debug, Clone, Default)]
pub struct Gpt {
    gtwp: u32,
    sources: [u32; 10],
    gtcr: u32,
    gtuddtyc: u32,
    gtior: u32,
    gtintad: u32,
    gtst: u32,
    gtber: u32,
    /// GTCCRA, B, C, E, D, F: in address order from 0x4C (UM: GTCCRE sits before GTCCRD).
    gtccr: [u32; 6],
    gtpr: u32,
    gtpbr: u32,
    gtdtcr: u32,
    gtdvu: u32,
    /// GTCNT at `t0` (when it last started or was written).
    cnt0: u32,
    /// Tick of the last start/write of GTCNT.
    t0: u64,
    /// Cycle ends already applied to the buffers, counted from `t0`.
    ends_seen: u64,
}

impl Gpt {
    /// Reset state (GTPR = 0xFFFF, GTIOR = 0, stopped).
    pub fn new() -> Self {
        Self {
            gtpr: 0xFFFF,
            gtpbr: 0xFFFF,
            gtccr: [0xFFFF; 6],
            gtuddtyc: 1,
            ..Self::default()
        }
    }

    fn running(&self) -> bool {
        self.gtcr & 1 != 0
    }

    fn ticks_per_count(&self, pclkd: u32) -> u64 {
        let tpcs = (self.gtcr >> 24) & 7;
        ticks_per(pclkd) << (2 * tpcs.min(5))
    }

    fn period_counts(&self) -> u64 {
        u64::from(self.gtpr) + 1
    }

    fn counts_since(&self, now: u64, pclkd: u32) -> u64 {
        if self.running() {
            (now.saturating_sub(self.t0)) / self.ticks_per_count(pclkd)
        } else {
            0
        }
    }

    /// GTCNT now.
    fn cnt(&self, now: u64, pclkd: u32) -> u32 {
        let c = u64::from(self.cnt0) + self.counts_since(now, pclkd);
        (c % self.period_counts()) as u32
    }

    /// Applies the buffer transfers of every cycle end up to `now`.
    pub fn sync(&mut self, now: u64, pclkd: u32) {
        if !self.running() {
            return;
        }
        let ends = (u64::from(self.cnt0) + self.counts_since(now, pclkd)) / self.period_counts();
        if ends > self.ends_seen {
            self.ends_seen = ends;
            if (self.gtber >> 16) & 3 == 1 {
                self.gtccr[0] = self.gtccr[2];
            }
            if (self.gtber >> 18) & 3 == 1 {
                self.gtccr[1] = self.gtccr[3]; // GTCCRE (at 0x58: the order is A B C E D F)
            }
        }
    }

    fn restart_count(&mut self, now: u64, pclkd: u32) {
        self.cnt0 = self.cnt(now, pclkd);
        self.t0 = now;
        self.ends_seen = 0;
    }

    /// The waveform on output A (`b = false`) or B (`b = true`).
    pub fn line(&self, b: bool, pclkd: u32) -> Line {
        let (io, oe, dflt, duty) = if b {
            (
                self.gtior >> 16,
                self.gtior & (1 << 24),
                self.gtior & (1 << 22),
                self.gtuddtyc >> 24,
            )
        } else {
            (
                self.gtior,
                self.gtior & (1 << 8),
                self.gtior & (1 << 6),
                self.gtuddtyc >> 16,
            )
        };
        if oe == 0 {
            return Line::Released;
        }
        if !self.running() {
            return Line::Level(dflt != 0);
        }
        match duty & 3 {
            2 => return Line::Level(false),
            3 => return Line::Level(true),
            _ => {}
        }
        if io & 0x1F != 0b01001 {
            // Refused at the GTIOR write; unreachable for accepted settings.
            return Line::Level(false);
        }
        let compare = u64::from(self.gtccr[usize::from(b)]);
        let period = self.period_counts();
        let tpc = self.ticks_per_count(pclkd);
        if compare >= period {
            return Line::Level(true);
        }
        Line::Pulses {
            high_ns: crate::clock::ticks_to_ns(compare * tpc),
            period_ns: crate::clock::ticks_to_ns(period * tpc),
        }
    }

    /// The level output A (`b = false`) or B drives at `now` (`None`: released), as the pin's
    /// input buffer (PIDR) reads it: in saw-wave PWM high from the cycle end to the compare
    /// match. Call [`Gpt::sync`] first so the buffered compare value is in place.
    pub fn level_at(&self, b: bool, now: u64, pclkd: u32) -> Option<bool> {
        match self.line(b, pclkd) {
            Line::Released => None,
            Line::Level(l) => Some(l),
            Line::Pulses { .. } => Some(self.cnt(now, pclkd) < self.gtccr[usize::from(b)]),
        }
    }

    fn protected(&self, name: &str) -> R<()> {
        if self.gtwp & 1 != 0 {
            refuse(format!("{name} written while GTWP.WP = 1"))
        } else {
            Ok(())
        }
    }

    /// A read at `off` (in the channel).
    pub fn read(&mut self, off: u32, size: u32, now: u64, pclkd: u32) -> R<u32> {
        need(size, 4, "a GPT register")?;
        self.sync(now, pclkd);
        Ok(match off {
            0x00 => self.gtwp & 1,
            0x04..=0x28 => self.sources[(off as usize - 4) / 4],
            0x2C => self.gtcr,
            0x30 => self.gtuddtyc & !0x0404_0002, // forced-set bits read 0
            0x34 => self.gtior,
            0x38 => self.gtintad,
            0x3C => self.gtst,
            0x40 => self.gtber,
            0x48 => self.cnt(now, pclkd),
            0x4C..=0x60 => self.gtccr[(off as usize - 0x4C) / 4],
            0x64 => self.gtpr,
            0x68 => self.gtpbr,
            0x88 => self.gtdtcr,
            0x8C => self.gtdvu,
            _ => return Err(Why::Unmodelled),
        })
    }

    /// A write at `off` (in the channel).
    pub fn write(&mut self, off: u32, size: u32, v: u32, now: u64, pclkd: u32) -> R<()> {
        need(size, 4, "a GPT register")?;
        self.sync(now, pclkd);
        match off {
            0x00 => {
                if (v >> 8) & 0xFF != 0xA5 {
                    return refuse(format!("GTWP written without the key 0xA5 ({v:#x})"));
                }
                self.gtwp = v & 1;
            }
            0x04..=0x28 => {
                self.protected("a GPT source-select register")?;
                self.sources[(off as usize - 4) / 4] = v;
            }
            0x2C => {
                self.protected("GTCR")?;
                if v & 1 != 0 && (v >> 16) & 7 != 0 {
                    return refuse(format!(
                        "GTCR.MD = {}: only saw-wave PWM (0) is modelled",
                        (v >> 16) & 7
                    ));
                }
                if (v >> 24) & 7 > 5 {
                    return refuse("GTCR.TPCS > 5 is a prohibited setting");
                }
                let was = self.running();
                if was {
                    self.restart_count(now, pclkd);
                }
                self.gtcr = v & 0x0707_0001;
                if !was && self.running() {
                    self.t0 = now;
                    self.ends_seen = 0;
                }
            }
            0x30 => {
                self.protected("GTUDDTYC")?;
                if v & 1 == 0 {
                    return refuse("GTUDDTYC.UD = 0 (down-counting) is not modelled");
                }
                self.gtuddtyc = v & 0x0F0F_0003;
            }
            0x34 => {
                self.protected("GTIOR")?;
                for (io, oe, name) in [
                    (v & 0x1F, v & (1 << 8), "GTIOA"),
                    ((v >> 16) & 0x1F, v & (1 << 24), "GTIOB"),
                ] {
                    if oe != 0 && io != 0b01001 {
                        return refuse(format!(
                            "{name} = {io:#07b} with its output enabled: only 0b01001 is modelled"
                        ));
                    }
                }
                self.gtior = v;
            }
            0x38 => {
                self.protected("GTINTAD")?;
                if v & 0xFF != 0 {
                    return refuse("GPT interrupts (GTINTAD) are not modelled");
                }
                self.gtintad = v;
            }
            0x3C => self.gtst &= v, // flags clear by writing 0
            0x40 => {
                self.protected("GTBER")?;
                self.gtber = v;
            }
            0x48 => {
                self.protected("GTCNT")?;
                if self.running() {
                    return refuse("GTCNT written while counting");
                }
                self.cnt0 = v & 0xFFFF;
                self.t0 = now;
                self.ends_seen = 0;
            }
            0x4C..=0x60 => {
                self.protected("GTCCRx")?;
                self.gtccr[(off as usize - 0x4C) / 4] = v & 0xFFFF;
            }
            0x64 => {
                self.protected("GTPR")?;
                if self.running() {
                    self.restart_count(now, pclkd);
                }
                self.gtpr = v & 0xFFFF;
            }
            0x68 => {
                self.protected("GTPBR")?;
                self.gtpbr = v & 0xFFFF;
            }
            0x88 => self.gtdtcr = v,
            0x8C => self.gtdvu = v,
            _ => return Err(Why::Unmodelled),
        }
        Ok(())
    }
}
