//! hil-sim: the simulated Yoshimura trunk and crane hardware, running the real firmware
//! controller.
//!
//! # Map
//! - [`physics`]: the trunk — two multistable modules (force–extension laws with snap-through
//!   and hysteresis), isothermal pneumatics through valve orifices, three tendons bending a
//!   constant-curvature trunk. Every constant and its source: `docs/simulator.md`.
//! - [`devices`]: simulated parts behind the firmware's own hardware traits (`firmware::hw`):
//!   PWM channels, pins, 14-bit ADC inputs, the display, the data flash, the serial link.
//! - [`servo`]: servo dynamics (slew, torque–speed line, stall).
//! - [`operator`]: the simulated person who does manual steps.
//! - [`fault`]: injectable faults.
//! - [`Sim`] ([`sim`]): all of it on one virtual clock with a seeded RNG ([`rng`]); the controller runs
//!   through `firmware::hw::Shell`, the board's own loop body, never a re-implementation.
//! - [`host`]: `SimHost`, short exchanges for tests, the real host engine driven sans-IO.
//! - [`pair`]: the real host engine, the controller and the physics on one virtual clock.
//! - [`swarm`]: random scenarios of the whole system checked against invariants.
//! - [`pty`]: the simulator serving its link on a pseudo-terminal, for any serial client.
//! - [`discovery`]: the transition graph the physics supports, as JSON or Graphviz DOT.
//! - `elf_board` (feature `pil`, on by default): processor in the loop, the board's own ELF in
//!   the RA4M1 emulator (`ra4m1-emu`, which links Unicorn: GPL-2.0) wired to the same parts.
//! - [`world`]: objects on the table, the gripper's capture and release, a tip load, the true
//!   tip pose.
//!
//! Architecture invariant: nothing here decides what the crane does; the controller does, from
//! what the simulated sensors tell it. The simulator never reads the wall clock except in
//! [`pty`], where virtual time follows wall time × speed.
//!
//! # Example
//! ```
//! use hil_sim::{Sim, SimOptions};
//! let mut sim = Sim::new(SimOptions::default());
//! sim.run_for(1_000);
//! let truth = sim.ground_truth();
//! assert_eq!(truth.true_state, Some("F&P".parse().unwrap()));
//! assert!(truth.actuators_safe);
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod cli;
pub mod devices;
pub mod discovery;
#[cfg(feature = "pil")]
pub mod elf_board;
pub mod fault;
pub mod host;
pub mod operator;
pub mod pair;
pub mod physics;
pub mod pty;
pub mod rng;
pub mod servo;
pub mod sim;
pub mod swarm;
pub mod world;

pub use fault::{Fault, ParseFaultError};
pub use sim::{GroundTruth, Sim, SimOptions, TruthLog};
