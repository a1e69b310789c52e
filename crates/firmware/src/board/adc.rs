//! The 14-bit ADC (ADC140): one software-triggered single-channel conversion per read, against
//! AVCC0 (the board's 5 V), so ratiometric sensors powered from the same 5 V read true. A
//! channel is taken from the pin map's typed inputs ([`crate::pins::Analog`]): pin and channel
//! number come from one pairing the chip has.

use core::convert::Infallible;

use super::gpio::{pfs, PortPin};
use super::regs::{pac, rd, wr};
use crate::pins::{AdcChannel, Analog, AnalogPin};

/// ADCSR.ADST: start / busy.
const ADST: u16 = 1 << 15;
/// Conversion time bound, in polls (one conversion takes ~1 µs at PCLKC 48 MHz; the bound is
/// ~100 µs so a stuck converter is reported, not waited on forever).
const MAX_POLLS: u32 = 5_000;

/// Why a conversion failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdcError {
    /// The converter did not finish in time.
    Timeout,
}

/// The converter (module already out of stop).
#[derive(Debug)]
pub struct Adc(());

impl Adc {
    /// 14-bit resolution, right-aligned results, single scan, software trigger.
    #[inline]
    pub fn new() -> Self {
        wr!(pac::ADC140.adcsr(), 0);
        // ADCER.ADPRC (bits 2..1) = 11: 14-bit.
        wr!(pac::ADC140.adcer(), 0b11 << 1);
        Self(())
    }

    /// The analog input `input`, with a longer sampling time for the 10 kΩ potentiometers and
    /// the sensor's output filter.
    #[inline]
    pub fn channel<P: AnalogPin<C>, C: AdcChannel>(
        &mut self,
        input: Analog<P, C>,
    ) -> AnalogChannel {
        self.channel_on(input.pin(), input.channel())
    }

    /// Channel `an` (AN000 = 0) on `pin`, which carries it ([`Adc::channel`]'s types say so).
    #[inline]
    fn channel_on(&mut self, pin: PortPin, an: u8) -> AnalogChannel {
        pin.configure(pfs::ASEL);
        // ADSSTRn for AN000..AN014 (this board uses AN000, AN001, AN009): 64 states = 1.3 µs.
        match an {
            0 => wr!(pac::ADC140.adsstr0(), 64),
            1 => wr!(pac::ADC140.adsstr1(), 64),
            9 => wr!(pac::ADC140.adsstr9(), 64),
            _ => {}
        }
        AnalogChannel { an }
    }
}

impl Default for Adc {
    #[inline]
    fn default() -> Self {
        Self::new()
    }
}

/// One analog input.
#[derive(Debug)]
pub struct AnalogChannel {
    an: u8,
}

impl AnalogChannel {
    fn convert(&mut self) -> Result<u16, AdcError> {
        let (a0, a1) = if self.an < 16 {
            (1u16 << self.an, 0u16)
        } else {
            (0, 1u16 << (self.an - 16))
        };
        wr!(pac::ADC140.adansa0(), a0);
        wr!(pac::ADC140.adansa1(), a1);
        wr!(pac::ADC140.adcsr(), ADST);
        let mut polls = 0;
        while rd!(pac::ADC140.adcsr()) & ADST != 0 {
            polls += 1;
            if polls > MAX_POLLS {
                wr!(pac::ADC140.adcsr(), 0);
                return Err(AdcError::Timeout);
            }
        }
        // ADDRn sits at ADC140 + 0x20 + 2n. The PAC (ra4m1-pac 0.3.1) only names ADDR16..25
        // (at 0x40..), so ADDR0..15 are addressed from the PAC's base the same way.
        let base = pac::ADC140.adcsr().ptr() as usize;
        let addr = (base + 0x20 + 2 * self.an as usize) as *const u16;
        // SAFETY: ADDRn of a channel this board converts; reading has no side effects.
        let raw = unsafe { core::ptr::read_volatile(addr) };
        Ok(raw & crate::ADC_MAX)
    }
}

impl crate::hw::AnalogInput for AnalogChannel {
    type Error = AdcError;
    fn read_raw(&mut self) -> Result<u16, AdcError> {
        self.convert()
    }
}

/// Never fails; here so `Infallible` conversions compose if a caller wants them.
impl From<Infallible> for AdcError {
    #[inline]
    fn from(e: Infallible) -> Self {
        match e {}
    }
}
