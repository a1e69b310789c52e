//! GPIO: pin function select (PmnPFS) and the port registers, with embedded-hal 1.0
//! `OutputPin`/`InputPin` for the valves, the gripper and the buttons. Each driver takes only
//! its own mode's lines of the pin map ([`crate::pins::Gpio`]): an [`Output`] a push-pull
//! line, a [`PullUpInput`] a pulled-up one, an [`OpenDrain`] an open-drain one.
//!
//! Addressing (RA4M1 hardware manual, I/O ports): PmnPFS at `0x4004_0800 + 0x40·m + 4·n`;
//! PORTm at `0x4004_0000 + 0x20·m` with PCNTR1 (PDR | PODR<<16), PCNTR2 (PIDR) and PCNTR3
//! (POSR | PORR<<16, write-only set/reset, so no read-modify-write race with the interrupt).
//! [`self_check`] compares these formulas with the PAC's own addresses at boot.

use core::convert::Infallible;
use core::ptr::{read_volatile, write_volatile};

use super::regs::{pac, wr};
pub use crate::pins::PortPin;
use crate::pins::{mode, Gpio, GpioPin};

/// PmnPFS bits.
pub mod pfs {
    /// Output data.
    pub const PODR: u32 = 1 << 0;
    /// Direction: 1 = output.
    pub const PDR: u32 = 1 << 2;
    /// Input pull-up enable.
    pub const PCR: u32 = 1 << 4;
    /// N-channel open drain.
    pub const NCODR: u32 = 1 << 6;
    /// Analog input enable.
    pub const ASEL: u32 = 1 << 15;
    /// Peripheral mode (PSEL selects the function).
    pub const PMR: u32 = 1 << 16;
    /// Peripheral select field shift.
    pub const PSEL_SHIFT: u32 = 24;
    /// PSEL: GPT timer I/O (GTIOCnA/B).
    pub const PSEL_GPT: u32 = 0b00011;
    /// PSEL: SCI1/3/5/7/9.
    pub const PSEL_SCI_ODD: u32 = 0b00101;
}

/// The pin's registers (the pin map's [`PortPin`] is plain numbers; its register access is
/// here, on the board only).
impl PortPin {
    #[inline]
    const fn pfs_addr(self) -> usize {
        0x4004_0800 + 0x40 * self.port as usize + 4 * self.pin as usize
    }

    #[inline]
    const fn port_addr(self) -> usize {
        0x4004_0000 + 0x20 * self.port as usize
    }

    /// Writes this pin's PmnPFS register (PFS write protection is opened and closed around it).
    #[inline]
    pub fn configure(self, value: u32) {
        // PWPR: clear B0WI first, then set PFSWE; the reverse order to lock again.
        wr!(pac::PMISC.pwpr(), 0x00);
        wr!(pac::PMISC.pwpr(), 0x40);
        // SAFETY: the PFS register of a pin in the RA4M1's map (see self_check); PFS writes are
        // open (PWPR.PFSWE = 1) and only this function writes PFS registers.
        unsafe { write_volatile(self.pfs_addr() as *mut u32, value) };
        wr!(pac::PMISC.pwpr(), 0x00);
        wr!(pac::PMISC.pwpr(), 0x80);
    }

    #[inline]
    fn set(self, high: bool) {
        let bit = 1u32 << self.pin;
        let v = if high { bit } else { bit << 16 };
        // SAFETY: PCNTR3 of this port: a write-only set/reset register, so the write changes
        // this one pin atomically.
        unsafe { write_volatile((self.port_addr() + 8) as *mut u32, v) };
    }

    fn level(self) -> bool {
        // SAFETY: PCNTR2 (PIDR) of this port: reading has no side effects.
        let v = unsafe { read_volatile((self.port_addr() + 4) as *const u32) };
        v & (1 << self.pin) != 0
    }

    #[inline]
    fn output_latch(self) -> bool {
        // SAFETY: PCNTR1 (PODR in bits 31..16) of this port: reading has no side effects.
        let v = unsafe { read_volatile(self.port_addr() as *const u32) };
        v & (1 << (self.pin + 16)) != 0
    }
}

/// Checks the address formulas above against the PAC for pins of every port the board uses.
#[inline]
pub fn self_check() -> bool {
    let pfs = [
        (PortPin::new(0, 14), pac::PFS.p014pfs().ptr() as usize),
        (PortPin::new(1, 4), pac::PFS.p104pfs().ptr() as usize),
        (PortPin::new(1, 12), pac::PFS.p112pfs().ptr() as usize),
        (PortPin::new(3, 2), pac::PFS.p302pfs().ptr() as usize),
    ];
    let ports = [
        (PortPin::new(0, 0), pac::PORT0.pcntr1().ptr() as usize),
        (PortPin::new(1, 0), pac::PORT1.pcntr1().ptr() as usize),
        (PortPin::new(3, 0), pac::PORT3.pcntr1().ptr() as usize),
    ];
    pfs.iter().all(|&(p, a)| p.pfs_addr() == a) && ports.iter().all(|&(p, a)| p.port_addr() == a)
}

/// A push-pull output (valve MOSFET gate, gripper driver, TM1637 CLK).
#[derive(Debug)]
pub struct Output(PortPin);

impl Output {
    /// Configures `line` as a push-pull output, initially low (valves closed).
    #[inline]
    pub fn new<P: GpioPin<mode::PushPull>>(line: Gpio<P, mode::PushPull>) -> Self {
        let pin = line.pin();
        pin.configure(pfs::PDR);
        Self(pin)
    }

    /// Configures `line` as a push-pull output, initially high (PODR set in the same PFS
    /// write: no low glitch).
    #[inline]
    pub fn new_high<P: GpioPin<mode::PushPull>>(line: Gpio<P, mode::PushPull>) -> Self {
        let pin = line.pin();
        pin.configure(pfs::PDR | pfs::PODR);
        Self(pin)
    }
}

impl embedded_hal::digital::ErrorType for Output {
    type Error = Infallible;
}

impl embedded_hal::digital::OutputPin for Output {
    #[inline]
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.set(false);
        Ok(())
    }
    #[inline]
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0.set(true);
        Ok(())
    }
}

impl embedded_hal::digital::StatefulOutputPin for Output {
    #[inline]
    fn is_set_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.output_latch())
    }
    #[inline]
    fn is_set_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.output_latch())
    }
}

/// An input with the internal pull-up on (buttons to ground, the NC e-stop).
#[derive(Debug)]
pub struct PullUpInput(PortPin);

impl PullUpInput {
    /// Configures `line` as an input with pull-up.
    #[inline]
    pub fn new<P: GpioPin<mode::PullUp>>(line: Gpio<P, mode::PullUp>) -> Self {
        let pin = line.pin();
        pin.configure(pfs::PCR);
        Self(pin)
    }
}

impl embedded_hal::digital::ErrorType for PullUpInput {
    type Error = Infallible;
}

impl embedded_hal::digital::InputPin for PullUpInput {
    #[inline]
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.level())
    }
    #[inline]
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.0.level())
    }
}

/// An open-drain line with the internal pull-up (TM1637 DIO: the chip pulls it low to ACK).
#[derive(Debug)]
pub struct OpenDrain(PortPin);

impl OpenDrain {
    /// Configures `line` as an open-drain output, released (high through the pull-up).
    #[inline]
    pub fn new<P: GpioPin<mode::OpenDrain>>(line: Gpio<P, mode::OpenDrain>) -> Self {
        let pin = line.pin();
        pin.configure(pfs::PDR | pfs::NCODR | pfs::PCR | pfs::PODR);
        Self(pin)
    }

    /// Drives the line low (`false`) or releases it (`true`).
    #[inline]
    pub fn set(&mut self, high: bool) {
        self.0.set(high);
    }

    /// The line's level.
    #[inline]
    pub fn is_high(&self) -> bool {
        self.0.level()
    }
}
