//! TM1637 four-digit seven-segment display, bit-banged on two pins (CLK push-pull, DIO open
//! drain with pull-up: the chip pulls DIO low to acknowledge each byte).
//!
//! Protocol (TM1637 datasheet): start (DIO falls while CLK high), bytes LSB first clocked on
//! CLK rising, ACK in the 9th clock, stop (DIO rises while CLK high). A frame is
//! `0x40` (data command: write, auto-increment), `0xC0` + 4 digit bytes (address command from
//! digit 0), then `0x88 | brightness` (display on). A 5 µs half-period keeps the clock at
//! 100 kHz, well under the chip's 250 kHz limit even with long wires.
//!
//! A whole redraw would take ~0.7 ms (33 000 cycles), too much for one 1 ms loop pass, so
//! `show` only queues the digits and [`Tm1637::poll`], called once per pass, clocks out one
//! byte (with its frame's start or stop): a redraw is seven passes, ≈ 90 µs each. The loop
//! calls it only in a pass whose step left room for it (`bin/uno_r4.rs`), so a heavy pass does
//! not also carry a display byte. A `show` during a redraw replaces the queued digits (the
//! latest content wins).

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

/// The seven byte transfers of a redraw: (starts a frame, byte index, ends the frame).
const STEPS: [(bool, usize, bool); 7] = [
    (true, 0, true),
    (true, 1, false),
    (false, 2, false),
    (false, 3, false),
    (false, 4, false),
    (false, 5, true),
    (true, 6, true),
];

/// The display.
#[derive(Debug)]
pub struct Tm1637 {
    clk: Output,
    dio: OpenDrain,
    brightness: u8,
    /// The redraw being clocked out, and the next step.
    drawing: Option<([u8; 7], usize)>,
    /// Digits queued while a redraw runs.
    queued: Option<[u8; 4]>,
    /// Bytes the chip did not acknowledge.
    pub missed_acks: u32,
}

impl Tm1637 {
    /// A display on `clk`/`dio`, brightness 0..=7.
    #[inline]
    pub fn new(clk: Output, dio: OpenDrain, brightness: u8) -> Self {
        let mut d = Self {
            clk,
            dio,
            brightness: brightness.min(7),
            drawing: None,
            queued: None,
            missed_acks: 0,
        };
        d.clk(true);
        d.dio.set(true);
        d
    }

    #[inline]
    fn clk(&mut self, high: bool) {
        // The Output pin is infallible.
        let _ = if high {
            self.clk.set_high()
        } else {
            self.clk.set_low()
        };
    }

    #[inline]
    fn start(&mut self) {
        self.dio.set(true);
        self.clk(true);
        delay_us(HALF_PERIOD_US);
        self.dio.set(false);
        delay_us(HALF_PERIOD_US);
        self.clk(false);
    }

    #[inline]
    fn stop(&mut self) {
        self.clk(false);
        self.dio.set(false);
        delay_us(HALF_PERIOD_US);
        self.clk(true);
        delay_us(HALF_PERIOD_US);
        self.dio.set(true);
        delay_us(HALF_PERIOD_US);
    }

    #[inline]
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

    #[inline]
    fn bytes_for(&self, seg: [u8; 4]) -> [u8; 7] {
        [
            0x40,
            0xC0,
            seg[0],
            seg[1],
            seg[2],
            seg[3],
            0x88 | self.brightness,
        ]
    }

    /// Clocks out the next byte of a queued redraw (a no-op when there is none). Call once per
    /// loop pass.
    #[inline]
    pub fn poll(&mut self) {
        if self.drawing.is_none() {
            if let Some(seg) = self.queued.take() {
                self.drawing = Some((self.bytes_for(seg), 0));
            }
        }
        let Some((bytes, step)) = self.drawing else {
            return;
        };
        let (start, i, stop) = STEPS[step];
        if start {
            self.start();
        }
        // Keep clocking after a missing ACK, so the bus ends idle; count it.
        if self.byte(bytes[i]).is_err() {
            self.missed_acks = self.missed_acks.wrapping_add(1);
        }
        if stop {
            self.stop();
        }
        self.drawing = (step + 1 < STEPS.len()).then_some((bytes, step + 1));
    }
}

impl crate::hw::SegmentDisplay for Tm1637 {
    type Error = Tm1637Error;

    /// Queues the digits; [`Tm1637::poll`] clocks them out over the next passes. Never fails
    /// here: a chip that does not acknowledge shows in [`Tm1637::missed_acks`].
    #[inline]
    fn show(&mut self, s: [u8; 4]) -> Result<(), Tm1637Error> {
        self.queued = Some(s);
        Ok(())
    }
}
