//! The whole system on one virtual clock: the real host engine ([`host::Host`]), the real
//! controller (through `firmware::hw::Shell`) and the physics, stepped together with seeded
//! randomness — quinn-proto's test `Pair`, for a crane.
//!
//! [`SimIo`] is the engine's I/O: writing puts bytes on the simulated line, waiting steps the
//! simulator (1 ms a step) until the device has sent something or the engine's deadline comes.
//! Nothing reads the wall clock unless [`SimIo::pace`] asks for wall pacing so a person can
//! watch; same seed, same run, byte for byte.

use std::time::{Duration, Instant};

use host::{Driver, Host, Io, Timing};

use crate::{Sim, SimOptions};

/// Wall pacing: virtual time runs at most `speed` times faster than wall time.
#[derive(Debug, Clone, Copy)]
struct Pacer {
    speed: f64,
    wall0: Instant,
    virt0: u64,
}

/// Called after every simulator step while the engine waits (the swarm tester's invariant
/// checks and scripted events).
pub type Monitor = Box<dyn FnMut(&mut Sim)>;

/// The simulator as the host engine's I/O.
pub struct SimIo {
    /// The simulator.
    pub sim: Sim,
    pacer: Option<Pacer>,
    /// Runs after every step.
    pub monitor: Option<Monitor>,
}

impl std::fmt::Debug for SimIo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimIo")
            .field("sim", &self.sim)
            .field("paced", &self.pacer.is_some())
            .finish_non_exhaustive()
    }
}

impl SimIo {
    /// The simulator, unpaced (as fast as the CPU allows).
    pub fn new(sim: Sim) -> Self {
        Self {
            sim,
            pacer: None,
            monitor: None,
        }
    }

    /// Paces virtual time to `speed` × wall time from now on (`None`: as fast as possible).
    pub fn pace(&mut self, speed: Option<f64>) {
        self.pacer = speed
            .filter(|s| s.is_finite() && *s > 0.0)
            .map(|speed| Pacer {
                speed,
                wall0: Instant::now(),
                virt0: self.sim.now_ms(),
            });
    }

    /// One simulator step, then the monitor.
    pub fn step(&mut self) {
        self.sim.step();
        if let Some(m) = self.monitor.as_mut() {
            m(&mut self.sim);
        }
    }

    fn wait_for_wall(&self) {
        if let Some(p) = self.pacer {
            let virt = (self.sim.now_ms() - p.virt0) as f64;
            let due = p.wall0 + Duration::from_secs_f64(virt / 1000.0 / p.speed);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
    }
}

impl Io for SimIo {
    fn now_ms(&mut self) -> u64 {
        self.sim.now_ms()
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.sim.write_host_bytes(bytes);
        Ok(())
    }

    fn read(&mut self, deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
        while !self.sim.has_device_bytes() && self.sim.now_ms() < deadline_ms {
            self.step();
            // Pace in 10 ms slices: fine enough to watch, coarse enough to cost nothing.
            if self.pacer.is_some() && self.sim.now_ms().is_multiple_of(10) {
                self.wait_for_wall();
            }
        }
        self.sim.read_device_bytes_into(buf);
        Ok(())
    }
}

/// The host engine driving the simulated crane, in-process, on the simulator's clock.
pub type Pair = Driver<SimIo>;

/// A pair: a new simulator with `opts` and a fresh host engine (not yet connected).
pub fn pair(opts: SimOptions) -> Pair {
    Driver::new(Host::new(Timing::standard(), 1), SimIo::new(Sim::new(opts)))
}

/// A shell for runs on the simulator: it keeps every run event, and the simulated person at
/// the crane answers an identify prompt by looking at the trunk (its true state; "cannot
/// tell" while it is between states). Manual steps are the simulator's own operator's job
/// (the crane's confirm button).
#[derive(Debug, Default)]
pub struct SimShell {
    /// Every run event, in order.
    pub events: Vec<host::RunEvent>,
    /// Asked the trunk's state, not answered yet.
    asked: bool,
}

impl SimShell {
    fn on_event(&mut self, event: &host::RunEvent) {
        if let host::RunEvent::IdentifyPrompt { .. } = event {
            self.asked = true;
        }
        self.events.push(event.clone());
    }
}

impl AsMut<SimIo> for SimIo {
    fn as_mut(&mut self) -> &mut SimIo {
        self
    }
}

/// For the simulator owned by a driver, or borrowed by one (`Driver<&mut SimIo>`).
impl<I: AsMut<SimIo>> host::RunShell<I> for SimShell {
    fn event(&mut self, event: &host::RunEvent, _io: &mut I) {
        self.on_event(event);
    }

    fn poll(&mut self, io: &mut I) -> Option<host::ShellAction> {
        // The person answers once their hands are off the trunk.
        let truth = io.as_mut().sim.person_names().filter(|_| self.asked)?;
        self.asked = false;
        Some(host::ShellAction::Declare(truth))
    }
}
