//! The host side of the crane's serial link, as a sans-IO state machine — the mirror of the
//! firmware's `Controller`.
//!
//! - [`session`]: handshake (through [`protocol::check_hello`], the one rule both sides
//!   apply), sequence numbers, retries with the same sequence number, the heartbeat, link loss.
//! - [`runner`]: the plan runner — status, identification of an unconfirmed state, plan,
//!   upload, start, follow, manual prompts, replanning on a surprise — with typed failures
//!   ([`runner::RunFailure`]: kind, step, fault code).
//! - [`engine`]: [`Host`], the session and its job behind `handle_bytes(&[u8], now)`,
//!   `handle_timeout(now)`, `poll_transmit()`, `poll_timeout()`, `poll_event()`.
//! - [`driver`]: the one blocking loop around the engine, over any [`driver::Io`] — a serial
//!   port on the wall clock, or the simulator on its virtual clock.
//! - [`calibration`]: the calibration walk over any [`driver::Io`] and the thresholds plans
//!   take from what it measured.
//! - [`text`]: the words for the wire's enums (faults, refusals, modes, requests).
//!
//! # What this crate must not do
//!
//! It reads no clock, touches no port and never sleeps: time and bytes come in, bytes and
//! events go out. host-tool's serial shell and the simulator's in-process pair both drive it.
//!
//! # Example
//!
//! ```
//! use host::{Host, Timing};
//!
//! let mut host = Host::new(Timing::standard(), 1);
//! host.connect(0);
//! let hello = host.poll_transmit().expect("the handshake goes out at once");
//! assert_eq!(hello.last(), Some(&0x00)); // one frame, delimited
//! // No answer: the same request goes out again after the response timeout.
//! assert_eq!(host.poll_timeout(), Some(u64::from(protocol::RESPONSE_TIMEOUT_MS)));
//! host.handle_timeout(u64::from(protocol::RESPONSE_TIMEOUT_MS));
//! assert_eq!(host.poll_transmit(), Some(hello));
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod calibration;
pub mod driver;
pub mod engine;
pub mod runner;
pub mod session;
pub mod text;

pub use driver::{Driver, Io, RunShell, ShellAction};
pub use engine::{Host, HostEvent};
pub use runner::{
    FailureKind, Outcome, PlanRunner, RunEvent, RunFailure, RunOptions, StepRef, StepReport,
};
pub use session::{Reply, RequestId, Session, SessionError, SessionEvent, SessionStats, Timing};
