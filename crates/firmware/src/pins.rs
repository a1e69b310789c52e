//! The UNO R4 board's pin map, in RA4M1 port/pin terms: plain data, no register access, built
//! for every target. The board support (`firmware::board`, feature `board-uno-r4`), its on-target
//! suites, the emulator's runner that fits their stimulus fixture (`ra4m1-run`) and the
//! simulator's processor-in-the-loop wiring (`hil-sim`'s `elf_board`, on the host) all read
//! this one map; the emulator itself is a plain RA4M1 and is told the wiring by them. The same binary runs on the UNO R4 Minima and WiFi: every pin
//! below reaches a header on both boards (the header labels differ between the two;
//! `docs/hardware.md` has both columns).
//!
//! Each pin is a type ([`P304`] …), and the functions it carries are trait impls, as in
//! embassy's `ChannelAPin<T>`: [`GtiocPin<T, O>`] says which output `O` of which GPT channel `T`
//! a pin is, [`AnalogPin<C>`] which ADC channel `C`, [`TxdPin<S>`] and [`RxdPin<S>`] which
//! SCI channel's transmit or receive line, [`GpioPin<M>`] which GPIO modes it has ([`mode`]:
//! push-pull, pulled-up input, open drain). Every line of the map names pin and function
//! together: the servo lines ([`Gtioc`]), the analog inputs ([`Analog`]), the host link
//! ([`Txd`], [`Rxd`]), the valve, gripper and button lines and the display's clock and data
//! ([`Gpio`]); only a pairing the chip has compiles. The board's drivers take these lines (a
//! GPT7 timer only GPT7's, the SCI9 link only SCI9's TXD and RXD, an output only a push-pull
//! line, the display's data driver only an open-drain one), so a peripheral cannot be given
//! another one's pin, nor a button's pin driven. The numbers the simulator and the emulator's
//! runner need come from the same definitions ([`Gtioc::line`], [`Analog::channel`],
//! `pin()`).
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
//! the serial link's lines swapped (the transmit pin as the receive line, and the reverse):
//! ```compile_fail,E0277
//! use firmware::pins::{Rxd, Sci9, P109};
//! // P109 is TXD9, not RXD9.
//! const WRONG: Rxd<P109, Sci9> = Rxd::new();
//! ```
//! ```compile_fail,E0277
//! use firmware::pins::{Sci9, Txd, P110};
//! // P110 is RXD9, not TXD9.
//! const WRONG: Txd<P110, Sci9> = Txd::new();
//! ```
//! an input-only pin as an output (a valve gate, the display's clock):
//! ```compile_fail,E0277
//! use firmware::pins::{mode, Gpio, P200};
//! // P200 (NMI) is input only.
//! const WRONG: Gpio<P200, mode::PushPull> = Gpio::new();
//! ```
//! or as the display's open-drain data line:
//! ```compile_fail,E0277
//! use firmware::pins::{mode, Gpio, P200};
//! const WRONG: Gpio<P200, mode::OpenDrain> = Gpio::new();
//! ```
//! and a line of the map in another mode than its own: the display's data line (open drain,
//! which the chip pulls low to acknowledge) is not a push-pull clock, a button (a pulled-up
//! switch to ground) is not an output to drive:
//! ```compile_fail,E0308
//! use firmware::pins::{self, mode, Gpio, P302};
//! const WRONG: Gpio<P302, mode::PushPull> = pins::TM_DIO;
//! ```
//! ```compile_fail,E0308
//! use firmware::pins::{self, mode, Gpio, P105};
//! const WRONG: Gpio<P105, mode::PushPull> = pins::BTN_UP;
//! ```
//! while the map's own pairings do:
//! ```
//! use firmware::pins::{self, GptOutput, PortPin};
//! let servo1 = pins::SERVO1.line();
//! assert_eq!((servo1.pin, servo1.channel, servo1.output), (PortPin::new(3, 3), 7, GptOutput::B));
//! assert_eq!(pins::PRESSURE.channel(), 9);
//! assert_eq!((pins::HOST_TX.pin(), pins::HOST_TX.channel()), (PortPin::new(1, 9), 9));
//! assert_eq!((pins::TM_CLK.pin(), pins::TM_DIO.pin()), (PortPin::new(1, 11), PortPin::new(3, 2)));
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

/// A pin as a type: the pins of the map, and P200 (input only, which no output line takes).
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
    P002 = (0, 2);
    P014 = (0, 14);
    P100 = (1, 0);
    P101 = (1, 1);
    P103 = (1, 3);
    P104 = (1, 4);
    P105 = (1, 5);
    P106 = (1, 6);
    P107 = (1, 7);
    P109 = (1, 9);
    P110 = (1, 10);
    P111 = (1, 11);
    P112 = (1, 12);
    P200 = (2, 0);
    P301 = (3, 1);
    P302 = (3, 2);
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

/// An SCI channel (SCIn).
pub trait SciChannel {
    /// Its number `n`.
    const NUMBER: u8;
}

/// SCI channel 9 (the host link).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sci9;
impl SciChannel for Sci9 {
    const NUMBER: u8 = 9;
}

/// The pin carries TXD`S` (pin function select SCI): the transmit line of SCI channel `S`.
pub trait TxdPin<S: SciChannel>: Pin {}
/// The pin carries RXD`S` (pin function select SCI): the receive line of SCI channel `S`.
pub trait RxdPin<S: SciChannel>: Pin {}

impl TxdPin<Sci9> for P109 {}
impl RxdPin<Sci9> for P110 {}

/// How a GPIO line is configured (PmnPFS with PMR = 0), as types.
pub mod mode {
    /// A GPIO mode ([`PushPull`], [`PullUp`], [`OpenDrain`]).
    pub trait GpioMode {}

    /// Push-pull output.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct PushPull;
    impl GpioMode for PushPull {}

    /// Input with the internal pull-up (a switch to ground reads low when closed).
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct PullUp;
    impl GpioMode for PullUp {}

    /// N-channel open drain with the internal pull-up: driven low or released, and read back.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct OpenDrain;
    impl GpioMode for OpenDrain {}
}

/// The pin can be a GPIO in mode `M`.
pub trait GpioPin<M: mode::GpioMode>: Pin {}

// Every pin of the map is a general I/O port pin, but P200: the NMI pin is input only, so it
// takes neither output mode (and the map reads nothing on it).
macro_rules! io_pins {
    ($($name:ident),*) => {$(
        impl GpioPin<mode::PushPull> for $name {}
        impl GpioPin<mode::PullUp> for $name {}
        impl GpioPin<mode::OpenDrain> for $name {}
    )*};
}

io_pins!(
    P000, P001, P002, P014, P100, P101, P103, P104, P105, P106, P107, P109, P110, P111, P112, P301,
    P302, P303, P304
);

// Clone, Copy, Default and Debug for a line type: a marker of its pin and function, whose
// numbers come from its `pin()` (and the type).
macro_rules! line_impls {
    ($ty:ident<$($p:ident: $bound:path),*>) => {
        impl<$($p: $bound),*> Clone for $ty<$($p),*> {
            fn clone(&self) -> Self {
                *self
            }
        }
        impl<$($p: $bound),*> Copy for $ty<$($p),*> {}
        impl<$($p: $bound),*> Default for $ty<$($p),*> {
            fn default() -> Self {
                Self::new()
            }
        }
        impl<$($p: $bound),*> core::fmt::Debug for $ty<$($p),*> {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.debug_struct(stringify!($ty)).field("pin", &self.pin()).finish()
            }
        }
    };
}

/// A serial transmit line: pin `P` as TXD of SCI channel `S`. Only a pairing the chip has
/// ([`TxdPin`]) names a type.
pub struct Txd<P: TxdPin<S>, S: SciChannel>(PhantomData<(P, S)>);

impl<P: TxdPin<S>, S: SciChannel> Txd<P, S> {
    /// The line.
    pub const fn new() -> Self {
        Self(PhantomData)
    }

    /// Its pin.
    pub const fn pin(&self) -> PortPin {
        P::PORT_PIN
    }

    /// Its SCI channel number.
    pub const fn channel(&self) -> u8 {
        S::NUMBER
    }
}

line_impls!(Txd<P: TxdPin<S>, S: SciChannel>);

/// A serial receive line: pin `P` as RXD of SCI channel `S`. Only a pairing the chip has
/// ([`RxdPin`]) names a type.
pub struct Rxd<P: RxdPin<S>, S: SciChannel>(PhantomData<(P, S)>);

impl<P: RxdPin<S>, S: SciChannel> Rxd<P, S> {
    /// The line.
    pub const fn new() -> Self {
        Self(PhantomData)
    }

    /// Its pin.
    pub const fn pin(&self) -> PortPin {
        P::PORT_PIN
    }

    /// Its SCI channel number.
    pub const fn channel(&self) -> u8 {
        S::NUMBER
    }
}

line_impls!(Rxd<P: RxdPin<S>, S: SciChannel>);

/// A GPIO line: pin `P` in mode `M`. Only a mode the pin has ([`GpioPin`]) names a type, and
/// the board's drivers take only their own mode's lines (an output only a [`mode::PushPull`]
/// line), so a button's pin cannot be driven nor a gate's read as a switch.
pub struct Gpio<P: GpioPin<M>, M: mode::GpioMode>(PhantomData<(P, M)>);

impl<P: GpioPin<M>, M: mode::GpioMode> Gpio<P, M> {
    /// The line.
    pub const fn new() -> Self {
        Self(PhantomData)
    }

    /// Its pin.
    pub const fn pin(&self) -> PortPin {
        P::PORT_PIN
    }
}

line_impls!(Gpio<P: GpioPin<M>, M: mode::GpioMode>);

/// Tendon servo 0: GTIOC7A (P304: D8 on both boards).
pub const SERVO0: Gtioc<P304, Gpt7, OutA> = Gtioc::new();
/// Tendon servo 1: GTIOC7B (P303: D9 on both boards).
pub const SERVO1: Gtioc<P303, Gpt7, OutB> = Gtioc::new();
/// Tendon servo 2: GTIOC5A (P101: A4/SDA on both boards).
pub const SERVO2: Gtioc<P101, Gpt5, OutA> = Gtioc::new();
/// The three servo lines, servo 0 first, as numbers.
pub const SERVO_LINES: [GtiocLine; 3] = [SERVO0.line(), SERVO1.line(), SERVO2.line()];

/// Inlet valve MOSFET gate, high = open (P104: WiFi D2, Minima D3).
pub const INLET: Gpio<P104, mode::PushPull> = Gpio::new();
/// Exhaust valve MOSFET gate, high = open (P301: D0 on both boards). Not P111: the Minima's
/// bootloader fades P111 (its LED_BUILTIN) for as long as it stays in the bootloader after a
/// double reset, which on a valve vents the trunk (`docs/hardware.md`, "Bootloader").
pub const EXHAUST: Gpio<P301, mode::PushPull> = Gpio::new();
/// Gripper driver, high = closed (P100: A5/SCL on both boards).
pub const GRIPPER: Gpio<P100, mode::PushPull> = Gpio::new();

/// Step-up button to ground (P105: WiFi D3, Minima D2).
pub const BTN_UP: Gpio<P105, mode::PullUp> = Gpio::new();
/// Step-down button to ground (P106: WiFi D4, Minima D6).
pub const BTN_DOWN: Gpio<P106, mode::PullUp> = Gpio::new();
/// Gripper toggle button to ground (P107: WiFi D5, Minima D7).
pub const BTN_GRIPPER: Gpio<P107, mode::PullUp> = Gpio::new();
/// Confirm button to ground (P103: WiFi D10, Minima D4).
pub const BTN_CONFIRM: Gpio<P103, mode::PullUp> = Gpio::new();
/// Show-pressure button to ground (P002: A3 on both boards, used as a digital input).
pub const BTN_SHOW: Gpio<P002, mode::PullUp> = Gpio::new();
/// E-stop, normally-closed contact to ground (P112: WiFi D7, Minima D10).
pub const BTN_ESTOP: Gpio<P112, mode::PullUp> = Gpio::new();

/// TM1637 CLK, push-pull (P111: WiFi D6, Minima D13 = LED_BUILTIN). The pin the bootloaders
/// drive (low while they wait, faded on the Minima while parked): on the display's clock that
/// only clocks nothing in (DIO stays high: no start condition).
pub const TM_CLK: Gpio<P111, mode::PushPull> = Gpio::new();
/// TM1637 DIO, open drain with pull-up: the chip pulls it low to acknowledge (P302: D1 on both
/// boards).
pub const TM_DIO: Gpio<P302, mode::OpenDrain> = Gpio::new();

/// Host link TXD9 (P109: WiFi → ESP32-S3 USB bridge; Minima D11).
pub const HOST_TX: Txd<P109, Sci9> = Txd::new();
/// Host link RXD9 (P110: WiFi ← ESP32-S3 USB bridge; Minima D12).
pub const HOST_RX: Rxd<P110, Sci9> = Rxd::new();

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
        assert_eq!(
            [INLET.pin(), EXHAUST.pin(), GRIPPER.pin()],
            [PortPin::new(1, 4), PortPin::new(3, 1), PortPin::new(1, 0)]
        );
        assert_eq!(
            [
                BTN_UP.pin(),
                BTN_DOWN.pin(),
                BTN_GRIPPER.pin(),
                BTN_CONFIRM.pin(),
                BTN_SHOW.pin(),
                BTN_ESTOP.pin()
            ],
            [
                PortPin::new(1, 5),
                PortPin::new(1, 6),
                PortPin::new(1, 7),
                PortPin::new(1, 3),
                PortPin::new(0, 2),
                PortPin::new(1, 12)
            ]
        );
        assert_eq!(
            [TM_CLK.pin(), TM_DIO.pin()],
            [PortPin::new(1, 11), PortPin::new(3, 2)]
        );
        assert_eq!(
            [
                (HOST_TX.pin(), HOST_TX.channel()),
                (HOST_RX.pin(), HOST_RX.channel())
            ],
            [(PortPin::new(1, 9), 9), (PortPin::new(1, 10), 9)]
        );
    }
}
