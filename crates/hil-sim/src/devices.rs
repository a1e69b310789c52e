//! Simulated parts behind the firmware's own hardware traits (`firmware::hw`): the controller
//! runs through the very [`firmware::hw::Shell`] the board uses, with these parts plugged in.
//!
//! The parts are plain state holders; the simulator ([`crate::Sim`]) moves values between
//! them and the physics every millisecond (sets the pressure sensor's raw count, reads the
//! servo duty cycles and valve pins). Nothing here knows about the controller.

use std::collections::VecDeque;
use std::convert::Infallible;

use embedded_hal::digital::{ErrorType as PinErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};
use firmware::hw::{AnalogInput, SegmentDisplay, StateStore};
use firmware::store::STORED_LEN;
use firmware::StoredState;

/// A digital output pin (valve, gripper): remembers its level.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimOutputPin {
    /// Level last written.
    pub high: bool,
}

impl PinErrorType for SimOutputPin {
    type Error = Infallible;
}

impl OutputPin for SimOutputPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.high = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.high = true;
        Ok(())
    }
}

/// A digital input pin (button, e-stop contact): reads the level the simulator sets.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimInputPin {
    /// Level the pin reads.
    pub high: bool,
}

impl SimInputPin {
    /// A pin reading `high`.
    pub fn new(high: bool) -> Self {
        Self { high }
    }
}

impl PinErrorType for SimInputPin {
    type Error = Infallible;
}

impl InputPin for SimInputPin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.high)
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.high)
    }
}

/// Full-scale duty count of a simulated PWM channel: 1 µs steps of the 20 ms servo period.
pub const PWM_MAX_DUTY: u16 = 20_000;

/// A PWM channel driving a servo: remembers its duty cycle.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimPwm {
    /// Duty cycle last written, out of [`PWM_MAX_DUTY`].
    pub duty: u16,
}

impl PwmErrorType for SimPwm {
    type Error = Infallible;
}

impl SetDutyCycle for SimPwm {
    fn max_duty_cycle(&self) -> u16 {
        PWM_MAX_DUTY
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.duty = duty.min(PWM_MAX_DUTY);
        Ok(())
    }
}

impl SimPwm {
    /// The pulse width on the wire, µs.
    pub fn pulse_us(&self) -> f64 {
        self.duty as f64 / PWM_MAX_DUTY as f64 * (1e6 / firmware::hw::SERVO_PWM_HZ as f64)
    }
}

/// A 14-bit ADC input: returns the raw count the simulator sets, or fails (a dropout).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimAnalog {
    /// Raw count of the next conversion.
    pub raw: u16,
    /// The conversion fails (open wire / dead sensor).
    pub failed: bool,
}

impl SimAnalog {
    /// An input reading `raw`.
    pub fn new(raw: u16) -> Self {
        Self { raw, failed: false }
    }
}

/// A failed conversion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnalogError;

impl AnalogInput for SimAnalog {
    type Error = AnalogError;
    fn read_raw(&mut self) -> Result<u16, AnalogError> {
        if self.failed {
            Err(AnalogError)
        } else {
            Ok(self.raw.min(firmware::ADC_MAX))
        }
    }
}

/// The four-digit display: its content is observable.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimDisplay {
    /// Segments shown, TM1637 order.
    pub segments: [u8; 4],
    /// Writes so far.
    pub writes: u32,
}

impl SegmentDisplay for SimDisplay {
    type Error = Infallible;
    fn show(&mut self, segments: [u8; 4]) -> Result<(), Infallible> {
        self.segments = segments;
        self.writes = self.writes.wrapping_add(1);
        Ok(())
    }
}

impl SimDisplay {
    /// The content as text (each digit decoded back to a character; `.` appended for a lit
    /// decimal point; `?` for a pattern that is no character).
    pub fn text(&self) -> String {
        segments_text(self.segments)
    }
}

/// Decodes seven-segment bitmaps back to text.
pub fn segments_text(segments: [u8; 4]) -> String {
    const CHARS: &[u8] = b"0123456789AbCcdEFHhLnoPrtUu-_ ";
    let mut s = String::new();
    for seg in segments {
        let body = seg & !firmware::display::DP;
        let c = CHARS
            .iter()
            .copied()
            .find(|&c| c != b' ' && firmware::display::glyph(c) == body)
            .map_or(if body == 0 { ' ' } else { '?' }, |c| c as char);
        s.push(c);
        if seg & firmware::display::DP != 0 {
            s.push('.');
        }
    }
    s
}

/// The board's data flash, emulated: a page of bytes, erased to `0xFF`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SimFlash {
    /// The page.
    pub bytes: [u8; STORED_LEN],
    /// Successful writes (flash wear).
    pub writes: u32,
    /// Reads and writes fail (a broken flash).
    pub failed: bool,
    /// The link-signing key kept beside the record (`None`: signing off).
    pub link_key: Option<[u8; 16]>,
    /// The identification probe's profile kept beside it, as the board stores it
    /// (`firmware::store::profile_to_bytes`; `None`: none).
    pub probe_profile: Option<[u8; firmware::store::PROFILE_LEN]>,
}

impl Default for SimFlash {
    fn default() -> Self {
        Self {
            bytes: [0xFF; STORED_LEN],
            writes: 0,
            failed: false,
            link_key: None,
            probe_profile: None,
        }
    }
}

impl SimFlash {
    /// A flash already holding `state`.
    pub fn holding(state: StoredState) -> Self {
        Self {
            bytes: state.to_bytes(),
            ..Self::default()
        }
    }
}

/// A flash read or write failed, or its content is corrupt.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FlashError;

impl StateStore for SimFlash {
    type Error = FlashError;
    fn load(&mut self) -> Result<Option<StoredState>, FlashError> {
        if self.failed {
            return Err(FlashError);
        }
        StoredState::from_bytes(&self.bytes).map_err(|_| FlashError)
    }
    fn save(&mut self, state: &StoredState) -> Result<(), FlashError> {
        if self.failed {
            return Err(FlashError);
        }
        self.bytes = state.to_bytes();
        self.writes = self.writes.wrapping_add(1);
        Ok(())
    }
    fn keeps_link_key(&self) -> bool {
        true
    }
    fn load_link_key(&mut self) -> Result<Option<[u8; 16]>, FlashError> {
        if self.failed {
            return Err(FlashError);
        }
        Ok(self.link_key)
    }
    fn save_link_key(&mut self, key: Option<&[u8; 16]>) -> Result<(), FlashError> {
        if self.failed {
            return Err(FlashError);
        }
        self.link_key = key.copied();
        self.writes = self.writes.wrapping_add(1);
        Ok(())
    }
    fn keeps_probe_profile(&self) -> bool {
        true
    }
    fn load_probe_profile(
        &mut self,
    ) -> Result<Option<[u8; firmware::store::PROFILE_LEN]>, FlashError> {
        if self.failed {
            return Err(FlashError);
        }
        Ok(self.probe_profile)
    }
    fn save_probe_profile(
        &mut self,
        profile: Option<&[u8; firmware::store::PROFILE_LEN]>,
    ) -> Result<(), FlashError> {
        if self.failed {
            return Err(FlashError);
        }
        self.probe_profile = profile.copied();
        self.writes = self.writes.wrapping_add(1);
        Ok(())
    }
}

/// The controller's serial link: bytes from the host wait in `rx`, bytes to the host in `tx`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SimSerial {
    /// Host → device bytes not yet read by the shell.
    pub rx: VecDeque<u8>,
    /// Device → host bytes not yet taken by the host side.
    pub tx: VecDeque<u8>,
}

impl embedded_io::ErrorType for SimSerial {
    type Error = Infallible;
}

impl embedded_io::Read for SimSerial {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = buf.len().min(self.rx.len());
        for (b, v) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *b = v;
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for SimSerial {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.is_empty())
    }
}

impl embedded_io::Write for SimSerial {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.tx.extend(buf.iter().copied());
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl embedded_io::WriteReady for SimSerial {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::hw::{ServoOutput, ServoPulse};

    #[test]
    fn servo_output_drives_the_pwm_to_the_right_pulse() {
        let mut s = ServoOutput::new(SimPwm::default(), ServoPulse::default());
        s.set_deg(90.0).unwrap();
        assert!((s.inner().pulse_us() - 1500.0).abs() <= 1.0);
        s.set_deg(180.0).unwrap();
        assert!((s.inner().pulse_us() - 2500.0).abs() <= 1.0);
    }

    #[test]
    fn display_decodes_what_the_firmware_encodes() {
        let mut d = SimDisplay::default();
        d.show(firmware::display::text("d-F ")).unwrap();
        assert_eq!(d.text(), "d-F ");
        let mut seg = firmware::display::task(protocol::ManualTask::PackBottomModule);
        seg[3] |= firmware::display::DP;
        assert_eq!(segments_text(seg), "H-Pb.");
        assert_eq!(segments_text(firmware::display::fault(8)), "E-08");
    }

    #[test]
    fn flash_starts_erased_and_keeps_what_is_saved() {
        let mut f = SimFlash::default();
        assert_eq!(f.load(), Ok(None));
        let s = StoredState::confirmed("D&F".parse().unwrap());
        f.save(&s).unwrap();
        assert_eq!(f.load(), Ok(Some(s)));
        f.bytes[3] ^= 0x55;
        assert_eq!(f.load(), Err(FlashError));
    }

    #[test]
    fn serial_moves_bytes_both_ways() {
        use embedded_io::{Read, ReadReady, Write};
        let mut s = SimSerial::default();
        assert!(!s.read_ready().unwrap());
        s.rx.extend([1, 2, 3]);
        let mut b = [0; 2];
        assert_eq!(s.read(&mut b).unwrap(), 2);
        assert_eq!(b, [1, 2]);
        s.write_all(&[9, 8]).unwrap();
        assert_eq!(s.tx, VecDeque::from(vec![9, 8]));
    }

    #[test]
    fn input_pins_and_analog_read_what_was_set() {
        let mut p = SimInputPin::new(true);
        assert!(p.is_high().unwrap());
        p.high = false;
        assert!(p.is_low().unwrap());
        let mut a = SimAnalog::new(1234);
        assert_eq!(a.read_raw(), Ok(1234));
        a.failed = true;
        assert_eq!(a.read_raw(), Err(AnalogError));
    }
}
