//! The Yoshimura Space Crane controller: a `no_std`, allocation-free, sans-IO state machine, and
//! the narrow hardware traits that the board binary and the simulator implement.
//!
//! # Map
//! - [`controller`]: [`Controller`], the whole crane logic — protocol handling (handshake,
//!   plans, parameters, telemetry, heartbeats, link-loss watch), the actuation primitives, the
//!   snap-through detector, state tracking, safety interlocks and standalone (joystick and
//!   button) operation.
//! - [`config`]: [`CraneConfig`], calibrations, limits and detector tuning; `Default` is the
//!   paper's crane.
//! - [`hw`]: hardware traits ([`hw::AnalogInput`], [`hw::SegmentDisplay`], [`hw::StateStore`],
//!   embedded-hal 1.0 pins and PWM, embedded-io serial), adapters ([`hw::ServoOutput`],
//!   [`hw::PinInputs`], [`hw::PinOutputs`]) and [`hw::Shell`], the one loop body shared by the
//!   board and the simulator.
//! - [`display`]: seven-segment encoding (TM1637 order).
//! - [`store`]: [`StoredState`], the persisted record with its checksum.
//! - [`flash_log`]: the wear-aware record log of that record (and the link key and probe
//!   profile) on a NOR flash, and the board's data-flash layout; pure logic over a flash trait.
//! - [`pins`]: the UNO R4 board's pin map, plain data: servo pins paired with their GPT channel
//!   and output, analog pins with their ADC channel, by type.
//! - [`bench`]: the worst-case loop pass as a reproducible workload (host bench, M4 harness).
//! - `board` (feature `board-uno-r4`, thumbv7em only): the register-level board support for the
//!   RA4M1, used by the `uno-r4` binary and the on-target suites.
//!
//! Architecture invariant: the controller never reads a clock, touches a register, sleeps,
//! allocates or panics on input; time and inputs come in through `handle_*`, commands and bytes
//! go out through `poll_*`. The same code runs on the board, in the simulator and in the tests.
//!
//! # API
//! ```text
//! Controller::new(config: CraneConfig, boot: BootRecord, now_ms: u64) -> Controller
//! ctl.handle_rx(&bytes, now_ms)          // bytes from the host link, any chunking
//! ctl.handle_inputs(&inputs, now_ms)     // one sample of every sensor and button
//! ctl.handle_time(now_ms)                // the control-loop tick
//! ctl.poll_tx(&mut buf) -> usize         // bytes to send to the host (0 = none)
//! ctl.poll_outputs() -> Outputs          // actuator commands now
//! ctl.poll_display() -> [u8; 4]          // seven-segment bitmaps, TM1637 order
//! ctl.poll_store() -> Option<StoredState>// state to persist (once per change)
//! ctl.poll_deadline() -> u64             // next now_ms at which handle_time must run
//! ctl.status() -> protocol::Status       // the snapshot GetStatus returns
//! ctl.report_watchdog_reset()            // the board restarted through its watchdog
//! ```
//!
//! # Example: one loop pass, without hardware
//! ```
//! use firmware::{BootRecord, Controller, CraneConfig, Inputs};
//! let cfg = CraneConfig::default();
//! let mut ctl = Controller::new(cfg, BootRecord::Empty, 0);
//! let rest = Inputs::at_rest(&cfg); // 0 kPa, joystick centred, no button
//! for now_ms in 0..100 {
//!     ctl.handle_inputs(&rest, now_ms);
//!     ctl.handle_time(now_ms);
//! }
//! let out = ctl.poll_outputs();
//! assert!(!out.inlet_open && !out.exhaust_open);
//! assert_eq!(ctl.poll_display(), firmware::display::text("F-P "));
//! ```
//!
//! On hardware, [`hw::Shell`] does exactly this with real parts: `shell.step(&mut ctl, now_ms)`.
#![no_std]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod bench;
pub mod config;
pub mod controller;
pub mod display;
pub mod flash_log;
pub mod hw;
pub mod mathf;
pub mod pins;
pub mod store;

#[cfg(feature = "board-uno-r4")]
pub mod board;

pub use config::CraneConfig;
pub use controller::{Buttons, Controller, Inputs, Outputs};
pub use store::{BootRecord, StoredState};

/// Largest raw count of the 14-bit ADC.
pub const ADC_MAX: u16 = (1 << 14) - 1;

/// `v` limited to `lo..=hi` without `f32::clamp`'s panic on inverted or NaN bounds (whose
/// message alone pulls ~12 KiB of float formatting into the board binary); a NaN `v` gives `lo`.
#[inline]
pub(crate) fn clampf(v: f32, lo: f32, hi: f32) -> f32 {
    v.max(lo).min(hi)
}
