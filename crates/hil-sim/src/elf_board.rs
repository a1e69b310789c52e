//! Processor in the loop: the board's own `uno-r4` ELF running in the RA4M1 emulator
//! ([`ra4m1_emu`]) instead of the host-built controller, wired to the same simulated parts.
//!
//! Each millisecond the simulator's part states (the [`crate::devices`] holders of the shell)
//! are moved across the chip's pins, as the board's own pin map ([`firmware::pins`]) places
//! them: the pressure sensor and the joystick into their ADC channels (AN009/AN000/AN001) as
//! 14-bit counts; the buttons as switches to ground on their port pins
//! (open when released, so the MCU's pull-up reads high; the normally-closed e-stop grounds its
//! pin until pressed); host bytes into SCI9's RXD9 at 115 200 Bd; the TM1637 module on the
//! display's CLK and DIO pins (the emulator is a plain RA4M1: it is told where). Out come the
//! servo pulses from the GPT pins (a pin the timer does not drive — output disabled, 0 % duty
//! — gives no pulse: the servo is limp), the valve and gripper gates from their port pins (a
//! released valve gate is held low by the driver's gate pull-down, a released gripper input
//! high by its fail-closed pull-up), the four digits the firmware clocked into the emulated
//! TM1637, and SCI9's transmitted bytes.

use std::path::Path;

use firmware::flash_log::{self, LINK_KEY_BLOCK, PROBE_PROFILE_BLOCK, STATE_LOG_FIRST_BLOCK};
use firmware::hw::{StateStore, SERVO_PWM_HZ};
use firmware::pins::{self, GptOutput, PortPin};
use firmware::StoredState;
use protocol::messages::{DeviceMessage, Event, Mode, ParamId, ResponseBody};
use protocol::FrameDecoder;
use ra4m1_emu::{Emulator, Line, Options, PinDrive};

use crate::devices::PWM_MAX_DUTY;

/// Why the ELF board could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ElfBoardError {
    /// The file could not be read.
    #[error("{path}: {err}")]
    Read {
        /// The path.
        path: String,
        /// The error.
        err: std::io::Error,
    },
    /// The emulator refused the ELF or stopped.
    #[error("{0}")]
    Emulator(#[from] ra4m1_emu::EmuError),
}

/// A NOR flash view of the emulator's data flash, to write the initial record with the
/// firmware's own log format.
struct DataFlashImage<'a>(&'a mut [u8]);

impl flash_log::NorFlash for DataFlashImage<'_> {
    const BLOCK_SIZE: usize = 1024;
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), flash_log::FlashError> {
        let src = self
            .0
            .get(offset..offset + buf.len())
            .ok_or(flash_log::FlashError::OutOfRange)?;
        buf.copy_from_slice(src);
        Ok(())
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), flash_log::FlashError> {
        let dst = self
            .0
            .get_mut(offset..offset + data.len())
            .ok_or(flash_log::FlashError::OutOfRange)?;
        for (d, s) in dst.iter_mut().zip(data) {
            *d &= *s;
        }
        Ok(())
    }
    fn erase(&mut self, block: usize) -> Result<(), flash_log::FlashError> {
        let b = self
            .0
            .get_mut(block * 1024..(block + 1) * 1024)
            .ok_or(flash_log::FlashError::OutOfRange)?;
        b.fill(0xFF);
        Ok(())
    }
}

/// `P<port><pin>` as the emulator's `(port, pin)`.
fn at(p: PortPin) -> (usize, usize) {
    (usize::from(p.port), usize::from(p.pin))
}

/// Where `cargo firmware` writes the board ELF: `$UNO_R4_ELF` if set, else
/// `thumbv7em-none-eabihf/firmware/uno-r4` under `$CARGO_TARGET_DIR` or the workspace's
/// `target/` (the workspace as this crate was built in). The file may not exist yet.
pub fn built_elf_path() -> std::path::PathBuf {
    use std::path::PathBuf;
    std::env::var_os("UNO_R4_ELF")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
            std::env::var_os("CARGO_TARGET_DIR")
                .map_or(root.join("target"), PathBuf::from)
                .join("thumbv7em-none-eabihf/firmware/uno-r4")
        })
}

/// The emulated board and what the simulator tracks of it from its messages.
pub struct ElfBoard {
    /// The emulator.
    pub emu: Emulator,
    sniffer: FrameDecoder,
    /// Mode last reported (heartbeat, status).
    pub mode: Mode,
    /// State last reported (telemetry, status, state events).
    pub state: geometry::TrunkState,
    /// The pressure cap the board last reported (its handshake, an answer to `GetParam` or
    /// `SetParam`); its boot value until then ([`boot_pressure_limit_kpa`]).
    pub pressure_limit_kpa: f32,
}

/// The pressure cap the board ELF boots with: the firmware's default configuration's
/// (`crates/firmware/src/bin/uno_r4.rs`), which no reset keeps a change of.
pub fn boot_pressure_limit_kpa() -> f32 {
    firmware::CraneConfig::default()
        .validated()
        .pressure_limit_kpa
}

impl std::fmt::Debug for ElfBoard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ElfBoard")
            .field("emu", &self.emu)
            .finish_non_exhaustive()
    }
}

impl ElfBoard {
    /// Loads the ELF; its data flash holds `initial` as a confirmed record.
    pub fn new(path: &Path, initial: StoredState) -> Result<Self, ElfBoardError> {
        let elf = std::fs::read(path).map_err(|err| ElfBoardError::Read {
            path: path.display().to_string(),
            err,
        })?;
        let mut emu = Emulator::new(
            &elf,
            Options {
                tm1637: Some((at(pins::TM_CLK.pin()), at(pins::TM_DIO.pin()))),
                ..Options::default()
            },
        )?;
        let mut log =
            flash_log::FlashLog::new(DataFlashImage(emu.data_flash_mut()), STATE_LOG_FIRST_BLOCK);
        // Writing into erased memory cannot fail.
        let _ = log.save(&initial);
        Ok(Self {
            emu,
            sniffer: FrameDecoder::default(),
            mode: Mode::Standalone,
            state: initial.state,
            pressure_limit_kpa: boot_pressure_limit_kpa(),
        })
    }

    /// Appends `states` to the data flash's record log (before the board first runs: to wear
    /// the log to a given point, e.g. both blocks full so the next save must erase).
    pub fn save_records(&mut self, states: &[StoredState]) {
        let mut log = flash_log::FlashLog::new(
            DataFlashImage(self.emu.data_flash_mut()),
            STATE_LOG_FIRST_BLOCK,
        );
        for s in states {
            let _ = log.save(s);
        }
    }

    /// The newest complete record in the data flash, as the firmware's own log reads it at boot
    /// (`None` when the log holds none; a torn slot being programmed is skipped).
    pub fn stored_record(&self) -> Option<StoredState> {
        let mut copy = self.emu.data_flash().to_vec();
        flash_log::FlashLog::new(DataFlashImage(&mut copy), STATE_LOG_FIRST_BLOCK)
            .load()
            .ok()
            .flatten()
    }

    /// The link-signing key in the data flash, as the firmware reads it at boot (`None`: the
    /// slot is erased, or torn and so failing its CRC: signing off at the next boot).
    pub fn stored_link_key(&self) -> Option<[u8; 16]> {
        let mut copy = self.emu.data_flash().to_vec();
        flash_log::FlashLog::new(DataFlashImage(&mut copy), STATE_LOG_FIRST_BLOCK)
            .with_key_block(LINK_KEY_BLOCK)
            .load_link_key()
            .ok()
            .flatten()
    }

    /// The probe profile in the data flash, as the firmware reads it at boot (`None`: the slot
    /// is erased, torn (failing its CRC) or of another firmware schema: none at the next boot).
    pub fn stored_probe_profile(&self) -> Option<protocol::ProbeProfile> {
        let mut copy = self.emu.data_flash().to_vec();
        flash_log::FlashLog::new(DataFlashImage(&mut copy), STATE_LOG_FIRST_BLOCK)
            .with_profile_block(PROBE_PROFILE_BLOCK)
            .load_probe_profile()
            .ok()
            .flatten()
            .as_ref()
            .and_then(firmware::store::profile_from_bytes)
    }

    /// Moves the parts' states in, runs the chip to `now_ms`, moves its outputs out.
    pub fn step(
        &mut self,
        shell: &mut crate::sim::SimShell,
        now_ms: u64,
    ) -> Result<(), ElfBoardError> {
        let emu = &mut self.emu;
        let i = &shell.inputs;
        emu.set_analog(
            pins::PRESSURE.channel().into(),
            if i.pressure.failed { 0 } else { i.pressure.raw },
        );
        emu.set_analog(pins::JOY_X.channel().into(), i.joystick_x.raw);
        emu.set_analog(pins::JOY_Y.channel().into(), i.joystick_y.raw);
        // A switch to ground: closed → low, open → the pull-up decides.
        let switch = |high: bool| if high { None } else { Some(false) };
        for (p, level) in [
            (pins::BTN_UP.pin(), i.up.high),
            (pins::BTN_DOWN.pin(), i.down.high),
            (pins::BTN_GRIPPER.pin(), i.gripper.high),
            (pins::BTN_CONFIRM.pin(), i.confirm.high),
            (pins::BTN_SHOW.pin(), i.show_pressure.high),
            (pins::BTN_ESTOP.pin(), i.estop.high),
        ] {
            let (port, pin) = at(p);
            emu.drive_pin(port, pin, switch(level));
        }
        if !shell.link.rx.is_empty() {
            let bytes: Vec<u8> = shell.link.rx.drain(..).collect();
            emu.host_send(&bytes);
        }
        emu.run_until_ns(now_ms * 1_000_000)?;
        let drive = |emu: &Emulator, p: PortPin| {
            let (port, pin) = at(p);
            emu.pin_drive(port, pin)
        };
        let high = |emu: &Emulator, p: PortPin| drive(emu, p) == PinDrive::High;
        shell.outputs.inlet.high = high(emu, pins::INLET.pin());
        shell.outputs.exhaust.high = high(emu, pins::EXHAUST.pin());
        // Fail-closed wiring (docs/hardware.md): a released gripper pin is pulled up, closed.
        shell.outputs.gripper.high = matches!(
            drive(emu, pins::GRIPPER.pin()),
            PinDrive::High | PinDrive::Released { .. }
        );
        let period_us = 1e6 / f64::from(SERVO_PWM_HZ);
        let duty = |line: Line| -> u16 {
            match line {
                Line::Pulses { high_ns, .. } => {
                    (high_ns as f64 / 1e3 / period_us * f64::from(PWM_MAX_DUTY)).round() as u16
                }
                // A steady high is no servo pulse either; low or released: limp.
                Line::Level(_) | Line::Released => 0,
            }
        };
        let d: Vec<u16> = pins::SERVO_LINES
            .iter()
            .map(|l| {
                let (port, pin) = at(l.pin);
                let b = l.output == GptOutput::B;
                duty(emu.timer_pin(port, pin, l.channel.into(), b))
            })
            .collect();
        let s = &mut shell.outputs.servos;
        use embedded_hal::pwm::SetDutyCycle as _;
        let _ = s.0.inner_mut().set_duty_cycle(d[0]);
        let _ = s.1.inner_mut().set_duty_cycle(d[1]);
        let _ = s.2.inner_mut().set_duty_cycle(d[2]);
        let tm = emu.display();
        shell.display.segments.copy_from_slice(&tm.digits[..4]);
        let out = emu.host_take();
        for &b in &out {
            self.track(b);
        }
        shell.link.tx.extend(out);
        Ok(())
    }

    fn track(&mut self, b: u8) {
        match self.sniffer.push::<DeviceMessage>(b) {
            Some(Ok(DeviceMessage::Event(ev))) => match ev {
                Event::Heartbeat { mode, .. } => self.mode = mode,
                Event::Telemetry(t) => self.state = t.state,
                Event::StateReached { state, .. } => self.state = state,
                Event::PlanDone { state, .. } => self.state = state,
                _ => {}
            },
            Some(Ok(DeviceMessage::Response {
                body: ResponseBody::Status(s),
                ..
            })) => {
                self.mode = s.mode;
                self.state = s.state;
            }
            Some(Ok(DeviceMessage::Response {
                body: ResponseBody::Hello(info),
                ..
            })) => self.pressure_limit_kpa = info.trunk.pressure_limit_kpa,
            Some(Ok(DeviceMessage::Response {
                body:
                    ResponseBody::Param {
                        id: ParamId::PressureLimitKpa,
                        value,
                    },
                ..
            })) => self.pressure_limit_kpa = value,
            _ => {}
        }
    }

    /// Cuts the power and restores it: a power-on reset, data flash kept.
    pub fn power_cycle(&mut self) -> Result<(), ElfBoardError> {
        self.emu.power_cycle()?;
        self.sniffer = FrameDecoder::default();
        self.pressure_limit_kpa = boot_pressure_limit_kpa();
        Ok(())
    }
}
