//! Servo PWM at 50 Hz on the 16-bit GPT channels (GPT5 and GPT7 here), one embedded-hal
//! `SetDutyCycle` per output pin (GTIOCnA / GTIOCnB). A [`Timer`] is typed by its channel and
//! takes only that channel's lines of the pin map ([`crate::pins::Gtioc`]), so a servo pin
//! cannot be given to a timer whose output it is not.
//!
//! Saw-wave PWM, counting up from 0 to GTPR; the pin goes high at the cycle end and low at the
//! compare match, so duty = compare value. Duty writes go to the buffer registers (GTCCRC for A,
//! GTCCRE for B) and reach the compare registers at the next cycle end: no glitched pulse when
//! the duty changes mid-period. A duty of 0 forces the output to 0 % duty (GTUDDTYC.OADTY/OBDTY
//! = 0b10, applied at once) with the output still enabled: the line is *driven low*, so a limp
//! servo sees a defined 0 V, not a floating input (GTIOR.OAE = 0 would release the pin: Hi-Z).
//! From reset until `start` the pins are inputs — `docs/hardware.md` asks for a pull-down on
//! each servo signal for that window.

use core::convert::Infallible;
use core::marker::PhantomData;

use super::gpio::{pfs, PortPin};
use super::regs::{pac, rd, wr};
use crate::hw::SERVO_PWM_HZ;
use crate::pins::{Gpt5, Gpt7, GptChannel, GptOutput, GptOutputKind, Gtioc, GtiocPin};

/// GTIOR: output A enable.
const OAE: u32 = 1 << 8;
/// GTIOR: output B enable.
const OBE: u32 = 1 << 24;
/// GTIOA/GTIOB = 0b01001: initial low, high at cycle end, low at compare match.
const GTIO_PWM: u32 = 0b01001;
/// GTUDDTYC.UD: count up.
const UD: u32 = 1;
/// GTUDDTYC: output A at 0 % duty (OADTY = 0b10), forced at once (OADTYF).
const A_ZERO: u32 = (0b10 << 16) | (1 << 18);
/// GTUDDTYC: output B at 0 % duty (OBDTY = 0b10), forced at once (OBDTYF).
const B_ZERO: u32 = (0b10 << 24) | (1 << 26);
/// GTUDDTYC.OADTY / OBDTY fields.
const A_DTY: u32 = 0b11 << 16;
const B_DTY: u32 = 0b11 << 24;

/// A 16-bit GPT channel's registers.
pub trait Instance: GptChannel {
    /// The channel's register block.
    fn regs() -> pac::Gpt162;
}

impl Instance for Gpt5 {
    #[inline]
    fn regs() -> pac::Gpt162 {
        pac::GPT165
    }
}

impl Instance for Gpt7 {
    #[inline]
    fn regs() -> pac::Gpt162 {
        pac::GPT167
    }
}

/// A running 50 Hz GPT channel `T`.
pub struct Timer<T> {
    counter: Counter,
    _channel: PhantomData<T>,
}

impl<T> Clone for Timer<T> {
    #[inline]
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Timer<T> {}

impl<T: Instance> Timer<T> {
    /// Sets up channel `T` (module already out of stop) for 50 Hz from `pclkd_hz` and starts
    /// it with both outputs off.
    pub fn start(pclkd_hz: u32) -> Self {
        Self {
            counter: Counter::start(T::regs(), pclkd_hz),
            _channel: PhantomData,
        }
    }

    /// The output `line` of this timer: its pin switched to the timer (GTIOC function).
    #[inline]
    pub fn channel<P: GtiocPin<T, O>, O: GptOutputKind>(&self, line: Gtioc<P, T, O>) -> ServoPwm {
        self.counter.output(O::OUTPUT, line.pin())
    }
}

impl<T> core::fmt::Debug for Timer<T> {
    #[inline]
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        self.counter.fmt(f)
    }
}

/// The running counter of a channel, untyped (one copy of the code for every channel).
#[derive(Clone, Copy)]
struct Counter {
    regs: pac::Gpt162,
    period_counts: u32,
}

impl Counter {
    fn start(regs: pac::Gpt162, pclkd_hz: u32) -> Self {
        // Smallest prescaler (÷1, 4, 16, 64, 256, 1024) whose period fits 16 bits: the finest
        // pulse resolution (÷16 at 48 MHz: 60 000 counts per 20 ms, 0.33 µs a count).
        let mut tpcs = 0u32;
        let mut counts = pclkd_hz / SERVO_PWM_HZ;
        while counts > 0x1_0000 && tpcs < 5 {
            tpcs += 1;
            counts = pclkd_hz / (1 << (2 * tpcs)) / SERVO_PWM_HZ;
        }
        wr!(regs.gtwp(), 0xA500); // write protection off (PRKEY 0xA5, WP = 0)
        wr!(regs.gtcr(), tpcs << 24); // stopped, saw-wave PWM (MD = 000), prescaler
        wr!(regs.gtuddtyc(), 0b11); // count up (UD), forced (UDF) ...
        wr!(regs.gtuddtyc(), 0b01); // ... then released
        wr!(regs.gtpr(), counts - 1);
        wr!(regs.gtcnt(), 0);
        wr!(regs.gtccra(), 0);
        wr!(regs.gtccrb(), 0);
        wr!(regs.gtccrc(), 0);
        wr!(regs.gtccre(), 0);
        // Single buffer GTCCRC → GTCCRA and GTCCRE → GTCCRB at each cycle end.
        wr!(regs.gtber(), (0b01 << 16) | (0b01 << 18));
        // Both outputs enabled and held at 0 % duty: driven low until a servo is commanded
        // (OADFLT/OBDFLT = 0: low while the counter is stopped, too).
        wr!(regs.gtuddtyc(), UD | A_ZERO | B_ZERO);
        wr!(regs.gtior(), GTIO_PWM | OAE | ((GTIO_PWM << 16) | OBE));
        wr!(regs.gtcr(), (tpcs << 24) | 1); // CST: count
        Self {
            regs,
            period_counts: counts,
        }
    }

    /// Output `output` on `pin`, which carries that GTIOC function ([`Timer::channel`]'s types
    /// say so).
    #[inline]
    fn output(&self, output: GptOutput, pin: PortPin) -> ServoPwm {
        pin.configure(pfs::PMR | (pfs::PSEL_GPT << pfs::PSEL_SHIFT));
        ServoPwm {
            timer: *self,
            output,
        }
    }
}

impl core::fmt::Debug for Counter {
    #[inline]
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Timer")
            .field("period_counts", &self.period_counts)
            .finish_non_exhaustive()
    }
}

/// One servo output: 50 Hz, duty in timer counts (full scale = one 20 ms period).
#[derive(Debug)]
pub struct ServoPwm {
    timer: Counter,
    output: GptOutput,
}

impl embedded_hal::pwm::ErrorType for ServoPwm {
    type Error = Infallible;
}

impl embedded_hal::pwm::SetDutyCycle for ServoPwm {
    #[inline]
    fn max_duty_cycle(&self) -> u16 {
        // ≤ 65 536 counts by construction; 65 535 if the period is exactly 2^16.
        self.timer.period_counts.min(u16::MAX as u32) as u16
    }

    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        let r = self.timer.regs;
        let duty = (duty as u32).min(self.timer.period_counts);
        let (field, zero) = match self.output {
            GptOutput::A => {
                wr!(r.gtccrc(), duty);
                (A_DTY, A_ZERO)
            }
            GptOutput::B => {
                wr!(r.gtccre(), duty);
                (B_DTY, B_ZERO)
            }
        };
        // The forced-setting bits read as 0, so this read-modify-write keeps the other output.
        let dty = rd!(r.gtuddtyc());
        let want = if duty == 0 {
            (dty & !field) | zero
        } else {
            dty & !field
        };
        if want & !(1 << 18 | 1 << 26) != dty {
            wr!(r.gtuddtyc(), want | UD);
        }
        Ok(())
    }
}
