//! TM1637 four-digit seven-segment display, bit-banged on two pins (CLK push-pull, DIO open
//! drain with pull-up: the chip pulls DIO low to acknowledge each byte).
//!
//! Protocol (TM1637 datasheet): start (DIO falls while CLK high), bytes LSB first clocked on
//! CLK rising, ACK in the 9th clock, stop (DIO rises while CLK high). A frame is
//! `0x40` (data command: write, auto-increment), `0xC0` + 4 digit bytes (address command from
//! digit 0), then `0x88 | brightness` (display on). A 5 µs half-period keeps the clock at
//! 100 kHz, well under the chip's 250 kHz limit even with long wires; one `show` takes
//! ~0.7 ms, and the shell only calls it when the content changes.

use embedded_hal::digital::OutputPin;

use super::gpio::{OpenDrain, Output};
use super::time::delay_us;

const HALF_PERIOD_US: u32 = 5;

/// Display write error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tm1637Error {
    /// The chip did not acknowledge a byte (not connected, or no power).
    NoAck,
}

/// The display.
#[derive(Debug)]
pub struct Tm1637 {
    clk: Output,
    dio: OpenDrain,
    brightness: u8,
}

impl Tm1637 {
    /// A display on `clk`/`dio`, brightness 0..=7.
    pub fn new(clk: Output, dio: OpenDrain, brightness: u8) -> Self {
        let mut d = Self {
            clk,
            dio,
            brightness: brightness.min(7),
        };
        d.clk(true);
        d.dio.set(true);
        d
    }

    fn clk(&mut self, high: bool) {
        // The Output pin is infallible.
        let _ = if high {
            self.clk.set_high()
        } else {
            self.clk.set_low()
        };
    }

    fn start(&mut self) {
        self.dio.set(true);
        self.clk(true);
        delay_us(HALF_PERIOD_US);
        self.dio.set(false);
        delay_us(HALF_PERIOD_US);
        self.clk(false);
    }

    fn stop(&mut self) {
        self.clk(false);
        self.dio.set(false);
        delay_us(HALF_PERIOD_US);
        self.clk(true);
        delay_us(HALF_PERIOD_US);
        self.dio.set(true);
        delay_us(HALF_PERIOD_US);
    }

    fn byte(&mut self, b: u8) -> Result<(), Tm1637Error> {
        for i in 0..8 {
            self.clk(false);
            self.dio.set(b & (1 << i) != 0);
            delay_us(HALF_PERIOD_US);
            self.clk(true);
            delay_us(HALF_PERIOD_US);
        }
        // ACK: release DIO, the chip pulls it low during the 9th clock.
        self.clk(false);
        self.dio.set(true);
        delay_us(HALF_PERIOD_US);
        self.clk(true);
        delay_us(HALF_PERIOD_US);
        let ack = !self.dio.is_high();
        self.clk(false);
        if ack {
            Ok(())
        } else {
            Err(Tm1637Error::NoAck)
        }
    }

    fn frame(&mut self, bytes: &[u8]) -> Result<(), Tm1637Error> {
        self.start();
        let mut res = Ok(());
        for &b in bytes {
            // Keep clocking the frame out even after a missing ACK, so the bus ends idle.
            res = res.and(self.byte(b));
        }
        self.stop();
        res
    }
}

impl firmware::hw::SegmentDisplay for Tm1637 {
    type Error = Tm1637Error;

    fn show(&mut self, s: [u8; 4]) -> Result<(), Tm1637Error> {
        let data = self.frame(&[0x40]);
        let digits = self.frame(&[0xC0, s[0], s[1], s[2], s[3]]);
        let on = self.frame(&[0x88 | self.brightness]);
        data.and(digits).and(on)
    }
}
