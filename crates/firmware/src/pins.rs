//! The UNO R4 board's pin map, in RA4M1 port/pin terms: plain data, no register access, built
//! for every target. The board support (`firmware::board`, feature `board-uno-r4`), its on-target
//! suites and the simulator's processor-in-the-loop wiring (`hil-sim`'s `elf_board`, on the
//! host) all read this one map. The same binary runs on the UNO R4 Minima and WiFi: every pin
//! below reaches a header on both boards (the header labels differ between the two;
//! `docs/hardware.md` has both columns).
//!
//! A pin that carries a peripheral function is a type ([`P304`] …), and the functions it
//! carries are trait impls, as in embassy's `ChannelAPin<T>`: [`GtiocPin<T, O>`] says which
//! output `O` of which GPT channel `T` a pin is, [`AnalogPin<C>`] which ADC channel `C`. The
//! map's servo lines ([`Gtioc`]) and analog inputs ([`Analog`]) name pin, channel and output
//! together, and only a pairing the chip has compiles; the board's PWM and ADC setup take
//! these lines, so a timer cannot be given another timer's pin. The numbers the simulator
//! needs come from the same definitions ([`Gtioc::line`], [`Analog::channel`]).
//!
//! A pin wired to the wrong timer output is refused at compile time:
//! ```compile_fail,E0277
//! use firmware::pins::{Gpt5, Gtioc, OutA, P304};
//! // P304 is GTIOC7A, not GTIOC5A.
//! const WRONG: Gtioc<P304, Gpt5, OutA> = Gtioc::new();
//! ```
//! and so is an analog pin read as another ADC channel:
//! ```compile_fail,E0277
//! use firmware::pins::{Analog, An001, P014};
//! // P014 is AN009.
//! const WRONG: Analog<P014, An001> = Analog::new();
//! ```
//! while the map's own pairings do:
//! ```
//! use firmware::pins::{self, GptOutput, PortPin};
//! let servo1 = pins::SERVO1.line();
//! assert_eq!((servo1.pin, servo1.channel, servo1.output), (PortPin::new(3, 3), 7, GptOutput::B));
//! assert_eq!(pins::PRESSURE.channel(), 9);
//! ```

use core::marker::PhantomData;

/// One RA4M1 pin, `P<port><pin>` (P104 = port 1, pin 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PortPin {
    /// Port number 0..=9.
    pub port: u8,
    /// Pin number 0..=15.
    pub pin: u8,
}

impl PortPin {
    /// `P<port><pin>`.
    pub const fn new(port: u8, pin: u8) -> Self {
        Self { port, pin }
    }
}

/// A pin as a type, for the pins that carry a peripheral function here.
pub trait Pin {
    /// Its port and pin numbers.
    const PORT_PIN: PortPin;
}

macro_rules! pin_types {
    ($($name:ident = ($port:literal, $pin:literal);)*) => {$(
        #[doc = concat!("Pin ", stringify!($name), ".")]
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub struct $name;
        impl Pin for $name {
            const PORT_PIN: PortPin = PortPin::new($port, $pin);
        }
    )*};
}

pin_types! {
    P000 = (0, 0);
    P001 = (0, 1);
    P014 = (0, 14);
    P101 = (1, 1);
    P303 = (3, 3);
    P304 = (3, 4);
}

/// A 16-bit GPT channel (GPT16n).
pub trait GptChannel {
    /// Its number `n`.
    const NUMBER: u8;
}

/// GPT channel 5 (GPT165).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gpt5;
impl GptChannel for Gpt5 {
    const NUMBER: u8 = 5;
}

/// GPT channel 7 (GPT167).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gpt7;
impl GptChannel for Gpt7 {
    const NUMBER: u8 = 7;
}

/// Which output of a GPT channel, as a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GptOutput {
    /// GTIOCnA (compare GTCCRA, buffer GTCCRC).
    A,
    /// GTIOCnB (compare GTCCRB, buffer GTCCRE).
    B,
}

/// Which output of a GPT channel, as a type ([`OutA`], [`OutB`]).
pub trait GptOutputKind {
    /// The output as a value.
    const OUTPUT: GptOutput;
}

/// Output A of a GPT channel (GTIOCnA).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutA;
impl GptOutputKind for OutA {
    const OUTPUT: GptOutput = GptOutput::A;
}

/// Output B of a GPT channel (GTIOCnB).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutB;
impl GptOutputKind for OutB {
    const OUTPUT: GptOutput = GptOutput::B;
}

/// The pin carries GTIOC`T``O` (pin function select GPT): output `O` of GPT channel `T`.
pub trait GtiocPin<T: GptChannel, O: GptOutputKind>: Pin {}

impl GtiocPin<Gpt7, OutA> for P304 {}
impl GtiocPin<Gpt7, OutB> for P303 {}
impl GtiocPin<Gpt5, OutA> for P101 {}

/// An ADC140 channel (ANnnn).
pub trait AdcChannel {
    /// Its number (AN000 = 0).
    const NUMBER: u8;
}

macro_rules! adc_channels {
    ($($name:ident = $n:literal;)*) => {$(
        #[doc = concat!("ADC channel ", stringify!($name), ".")]
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub struct $name;
        impl AdcChannel for $name {
            const NUMBER: u8 = $n;
        }
    )*};
}

adc_channels! {
    An000 = 0;
    An001 = 1;
    An009 = 9;
}

/// The pin is analog input `C` (ASEL).
pub trait AnalogPin<C: AdcChannel>: Pin {}

impl AnalogPin<An009> for P014 {}
impl AnalogPin<An000> for P000 {}
impl AnalogPin<An001> for P001 {}

/// A timer output line: pin `P` as output `O` of GPT channel `T`. Only a pairing the chip has
/// ([`GtiocPin`]) names a type.
pub struct Gtioc<P: GtiocPin<T, O>, T: GptChannel, O: GptOutputKind>(PhantomData<(P, T, O)>);

/// A timer output line as numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GtiocLine {
    /// The pin.
    pub pin: PortPin,
    /// The GPT channel number.
    pub channel: u8,
    /// The output of that channel.
    pub output: GptOutput,
}

impl<P: GtiocPin<T, O>, T: GptChannel, O: GptOutputKind> Gtioc<P, T, O> {
    /// The line.
    pub const fn new() -> Self {
        Self(PhantomData)
    }

    /// Its pin.
    pub const fn pin(&self) -> PortPin {
        P::PORT_PIN
    }

    /// Its pin, channel and output as numbers.
    pub const fn line(&self) -> GtiocLine {
        GtiocLine {
            pin: P::PORT_PIN,
            channel: T::NUMBER,
            output: O::OUTPUT,
        }
    }
}

impl<P: GtiocPin<T, O>, T: GptChannel, O: GptOutputKind> Clone for Gtioc<P, T, O> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<P: GtiocPin<T, O>, T: GptChannel, O: GptOutputKind> Copy for Gtioc<P, T, O> {}
impl<P: GtiocPin<T, O>, T: GptChannel, O: GptOutputKind> core::fmt::Debug for Gtioc<P, T, O> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        self.line().fmt(f)
    }
}
impl<P: GtiocPin<T, O>, T: GptChannel, O: GptOutputKind> Default for Gtioc<P, T, O> {
    fn default() -> Self {
        Self::new()
    }
}

/// An analog input: pin `P` as ADC channel `C`. Only a pairing the chip has ([`AnalogPin`])
/// names a type.
pub struct Analog<P: AnalogPin<C>, C: AdcChannel>(PhantomData<(P, C)>);

impl<P: AnalogPin<C>, C: AdcChannel> Analog<P, C> {
    /// The input.
    pub const fn new() -> Self {
        Self(PhantomData)
    }

    /// Its pin.
    pub const fn pin(&self) -> PortPin {
        P::PORT_PIN
    }

    /// Its ADC channel number (AN000 = 0).
    pub const fn channel(&self) -> u8 {
        C::NUMBER
    }
}

impl<P: AnalogPin<C>, C: AdcChannel> Clone for Analog<P, C> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<P: AnalogPin<C>, C: AdcChannel> Copy for Analog<P, C> {}
impl<P: AnalogPin<C>, C: AdcChannel> core::fmt::Debug for Analog<P, C> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Analog")
            .field("pin", &self.pin())
            .field("channel", &self.channel())
            .finish()
    }
}
impl<P: AnalogPin<C>, C: AdcChannel> Default for Analog<P, C> {
    fn default() -> Self {
        Self::new()
    }
}

/// Tendon servo 0: GTIOC7A (P304: D8 on both boards).
pub const SERVO0: Gtioc<P304, Gpt7, OutA> = Gtioc::new();
/// Tendon servo 1: GTIOC7B (P303: D9 on both boards).
pub const SERVO1: Gtioc<P303, Gpt7, OutB> = Gtioc::new();
/// Tendon servo 2: GTIOC5A (P101: A4/SDA on both boards).
pub const SERVO2: Gtioc<P101, Gpt5, OutA> = Gtioc::new();
/// The three servo lines, servo 0 first, as numbers.
pub const SERVO_LINES: [GtiocLine; 3] = [SERVO0.line(), SERVO1.line(), SERVO2.line()];

/// Inlet valve MOSFET gate, high = open (P104: WiFi D2, Minima D3).
pub const INLET: PortPin = PortPin::new(1, 4);
/// Exhaust valve MOSFET gate, high = open (P301: D0 on both boards). Not P111: the Minima's
/// bootloader fades P111 (its LED_BUILTIN) for as long as it stays in the bootloader after a
/// double reset, which on a valve vents the trunk (`docs/hardware.md`, "Bootloader").
pub const EXHAUST: PortPin = PortPin::new(3, 1);
/// Gripper driver, high = closed (P100: A5/SCL on both boards).
pub const GRIPPER: PortPin = PortPin::new(1, 0);

/// Step-up button to ground (P105: WiFi D3, Minima D2).
pub const BTN_UP: PortPin = PortPin::new(1, 5);
/// Step-down button to ground (P106: WiFi D4, Minima D6).
pub const BTN_DOWN: PortPin = PortPin::new(1, 6);
/// Gripper toggle button to ground (P107: WiFi D5, Minima D7).
pub const BTN_GRIPPER: PortPin = PortPin::new(1, 7);
/// Confirm button to ground (P103: WiFi D10, Minima D4).
pub const BTN_CONFIRM: PortPin = PortPin::new(1, 3);
/// Show-pressure button to ground (P002: A3 on both boards, used as a digital input).
pub const BTN_SHOW: PortPin = PortPin::new(0, 2);
/// E-stop, normally-closed contact to ground (P112: WiFi D7, Minima D10).
pub const BTN_ESTOP: PortPin = PortPin::new(1, 12);

/// TM1637 CLK (P111: WiFi D6, Minima D13 = LED_BUILTIN). The pin the bootloaders drive (low
/// while they wait, faded on the Minima while parked): on the display's clock that only
/// clocks nothing in (DIO stays high: no start condition).
pub const TM_CLK: PortPin = PortPin::new(1, 11);
/// TM1637 DIO (P302: D1 on both boards).
pub const TM_DIO: PortPin = PortPin::new(3, 2);

/// Host link TXD9 (P109: WiFi → ESP32-S3 USB bridge; Minima D11).
pub const HOST_TX: PortPin = PortPin::new(1, 9);
/// Host link RXD9 (P110: WiFi ← ESP32-S3 USB bridge; Minima D12).
pub const HOST_RX: PortPin = PortPin::new(1, 10);

/// Pressure sensor: AN009 (P014: A0 on both boards).
pub const PRESSURE: Analog<P014, An009> = Analog::new();
/// Joystick x: AN000 (P000: A1 on both boards).
pub const JOY_X: Analog<P000, An000> = Analog::new();
/// Joystick y: AN001 (P001: A2 on both boards).
pub const JOY_Y: Analog<P001, An001> = Analog::new();

#[cfg(test)]
mod tests {
    use super::*;

    /// The map's numbers, as `docs/hardware.md`'s wiring table has them.
    #[test]
    fn the_map_has_the_documented_numbers() {
        let servos: [(u8, u8, u8, GptOutput); 3] =
            SERVO_LINES.map(|l| (l.pin.port, l.pin.pin, l.channel, l.output));
        assert_eq!(
            servos,
            [
                (3, 4, 7, GptOutput::A),
                (3, 3, 7, GptOutput::B),
                (1, 1, 5, GptOutput::A)
            ]
        );
        assert_eq!(
            [PRESSURE.pin(), JOY_X.pin(), JOY_Y.pin()],
            [PortPin::new(0, 14), PortPin::new(0, 0), PortPin::new(0, 1)]
        );
        assert_eq!(
            [PRESSURE.channel(), JOY_X.channel(), JOY_Y.channel()],
            [9, 0, 1]
        );
    }
}
