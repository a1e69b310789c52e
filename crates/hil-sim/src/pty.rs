//! The simulator serving its controller's serial link on a pseudo-terminal.
//!
//! [`PtySim::spawn`] opens a pty pair (raw mode), and runs the simulator on a thread: bytes a
//! client writes to the device path go into the controller's link; what the controller sends
//! comes out of it. Virtual time follows wall time × `speed`.
//!
//! A client on the pty keeps the hardware's timing on the wall clock (a heartbeat every
//! 250 ms, the link lost after 3 s of silence): at `speed` × the device sees those heartbeats
//! `speed` times further apart. So the simulated controller's link timeout is set to
//! 3 s × `speed` (for `speed` > 1), and since the parameter goes up to 60 s, the pty holds a
//! client at every speed up to [`MAX_PTY_SPEED`]; faster ones are refused with that reason.

use std::os::fd::{AsFd, AsRawFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use nix::errno::Errno;
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};

use crate::{GroundTruth, Sim, SimOptions, TruthLog};

/// Bytes the device may have queued for a client that is not reading before the oldest are
/// dropped (a serial line with nobody listening loses its bytes too).
const MAX_PENDING: usize = 64 * 1024;
/// Wall time between loop passes at a finite speed.
const WALL_TICK: Duration = Duration::from_millis(1);
/// Most virtual time one loop pass may run (so a stalled wall clock cannot make it run away).
const MAX_CATCH_UP_MS: u64 = 2_000;

/// The fastest speed at which the pty holds a client on the hardware's timing (the device's
/// link timeout of 3 s × speed reaches its 60 s maximum).
pub const MAX_PTY_SPEED: f64 = 20.0;

/// The slowest speed the pty serves, the slowest `host-tool --sim-speed` takes. Slower, a
/// client on the hardware's timing stops being answered: at ×0.001 a request's bytes and the
/// device's loop pass take longer in wall time than a client's 13 retries over 3.25 s
/// (measured: `host-tool status` answered at ×0.005 in 0.5 s and never at ×0.001).
pub const MIN_PTY_SPEED: f64 = 0.1;

/// Why a speed cannot be served on the pty, if it cannot.
pub fn check_pty_speed(speed: f64) -> Result<(), String> {
    if !(speed.is_finite() && speed > 0.0) {
        return Err(format!(
            "speed {speed} cannot be served on a pty: a client there keeps wall-clock time \
             (give a number from {MIN_PTY_SPEED} to {MAX_PTY_SPEED})"
        ));
    }
    if speed < MIN_PTY_SPEED {
        return Err(format!(
            "speed {speed} is too slow to serve a pty client: the device's answers would come \
             later in wall time than a client waits for them; give {MIN_PTY_SPEED} to \
             {MAX_PTY_SPEED}"
        ));
    }
    if speed > MAX_PTY_SPEED {
        return Err(format!(
            "speed {speed} is too fast for a pty client on the hardware's timing: its 250 ms \
             heartbeats would arrive {:.1} s apart in virtual time, beyond the longest link \
             timeout the controller takes (60 s = ×{MAX_PTY_SPEED}); use --speed \
             {MAX_PTY_SPEED} or less",
            0.25 * speed
        ));
    }
    Ok(())
}

/// What the emulated board measured over a pty session (with `firmware_elf`), taken when the
/// simulator stops.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BoardMeasures {
    /// The main stack's high-water mark since the last power-on, bytes
    /// (`ra4m1_emu::Emulator::stack_high_water`: the emulator's paint).
    pub stack_high_water: u32,
    /// The stack's room (`_stack_start − _stack_end`), bytes.
    pub stack_size: u32,
    /// The longest loop pass (wake-up to `WFI`, its interrupts included) after the first
    /// [`BOOT_MS`] of virtual time (the boot's stretch, power-on to the first `WFI`, is not a
    /// loop pass), ICLK cycles of the emulator's cycle model; `None` when the session ended
    /// within those first [`BOOT_MS`].
    pub longest_pass_cycles: Option<u64>,
    /// Where that pass's cycles went: the functions of the ELF that took the most, cycles,
    /// largest first (at most 12).
    pub longest_pass_profile: Vec<(String, u64)>,
    /// The SysTick exceptions that stretch took, cycles after its wake-up
    /// (`ra4m1_emu::machine::Stretch::ticks_at`): one entry (at 0) is one loop pass; a second
    /// is the next millisecond beginning while a pass still ran — that pass overran the tick
    /// and the loop ran the next one back to back, without a `WFI` between.
    pub longest_pass_ticks_at: Vec<u64>,
    /// Of that stretch's cycles, those spent in interrupt handlers.
    pub longest_pass_handler_cycles: u64,
    /// When that stretch held passes back to back: what ran before its second SysTick (the
    /// pass that overran, up to the tick), per function, largest first (at most 12).
    pub longest_pass_overrun_profile: Vec<(String, u64)>,
    /// Host bytes SCI9 lost over the session (overrun, framing, or received with RE = 0).
    pub rx_lost: u64,
    /// Of those, the overruns: a byte that came before the receive handler had taken the last
    /// one (the others are bytes sent before the firmware enabled the receiver, at its boot,
    /// or at a wrong rate).
    pub rx_overruns: u64,
    /// When the last overrun happened, ms of virtual time since the power-on.
    pub last_overrun_ms: Option<u64>,
    /// Resets of the chip after its first start (watchdog, brown-out, software), each one a
    /// boot whose stretch counts as a pass.
    pub resets: usize,
}

/// Virtual time after which the emulated board's loop passes are measured
/// ([`BoardMeasures::longest_pass_cycles`]): its boot is over by then.
pub const BOOT_MS: u64 = 100;

/// A simulator running on its own thread behind a pseudo-terminal.
#[derive(Debug)]
pub struct PtySim {
    path: PathBuf,
    stop: Arc<AtomicBool>,
    truth: Arc<Truth>,
    thread: Option<JoinHandle<()>>,
    clock: (Instant, u64),
    link_timeout_ms: u32,
}

impl PtySim {
    /// Opens a pseudo-terminal and starts the simulator behind it.
    pub fn spawn(opts: SimOptions) -> anyhow::Result<PtySim> {
        Self::spawn_with_truth_log(opts, None)
    }

    /// [`PtySim::spawn`], appending the ground truth to `log` ([`TruthLog`]: a JSON line at
    /// start, at every change of the true state, the actuators' safety or the fault set, and
    /// at [`PtySim::stop`]).
    pub fn spawn_with_truth_log(
        opts: SimOptions,
        log: Option<std::fs::File>,
    ) -> anyhow::Result<PtySim> {
        Self::spawn_in_world(opts, log, crate::world::World::new())
    }

    /// [`PtySim::spawn_with_truth_log`] with objects and a tip load in the simulator's
    /// [`crate::world::World`] from the start.
    pub fn spawn_in_world(
        opts: SimOptions,
        log: Option<std::fs::File>,
        world: crate::world::World,
    ) -> anyhow::Result<PtySim> {
        check_pty_speed(opts.speed).map_err(|e| anyhow::anyhow!(e))?;
        let link_timeout_ms =
            (f64::from(protocol::DEFAULT_LINK_TIMEOUT_MS) * opts.speed.max(1.0)).round() as u32;
        let pty = nix::pty::openpty(None, None).context("opening a pseudo-terminal")?;
        let mut t = tcgetattr(pty.slave.as_fd()).context("reading the pty's terminal settings")?;
        cfmakeraw(&mut t);
        tcsetattr(pty.slave.as_fd(), SetArg::TCSANOW, &t).context("setting the pty to raw mode")?;
        let flags = fcntl(pty.master.as_raw_fd(), FcntlArg::F_GETFL).context("pty flags")?;
        fcntl(
            pty.master.as_raw_fd(),
            FcntlArg::F_SETFL(OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK),
        )
        .context("making the pty non-blocking")?;
        let path = nix::unistd::ttyname(pty.slave.as_fd()).context("naming the pty")?;
        // The simulator is built on its own thread (an emulated board is not `Send`); the
        // first ground truth, or why it could not start, comes back over a channel.
        let truth = Arc::new(Truth::default());
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::sync_channel::<Result<(Instant, u64), String>>(1);
        let thread = {
            let (truth, stop) = (Arc::clone(&truth), Arc::clone(&stop));
            std::thread::Builder::new()
                .name("hil-sim".into())
                .spawn(move || {
                    match Sim::try_new(opts).map(|s| s.with_link_timeout_ms(link_timeout_ms)) {
                        Ok(mut sim) => {
                            let closed = sim.ground_truth().gripper_closed;
                            *sim.world_mut() = world;
                            sim.world_mut().set_gripper(closed);
                            truth.publish(&sim);
                            let clock = (Instant::now(), sim.now_ms());
                            let _ = tx.send(Ok(clock));
                            serve(sim, clock, pty.master, pty.slave, &stop, &truth, log);
                        }
                        Err(e) => {
                            let _ = tx.send(Err(e.to_string()));
                        }
                    }
                })
                .context("starting the simulator thread")?
        };
        let clock = match rx.recv() {
            Ok(Ok(clock)) => clock,
            Ok(Err(e)) => {
                let _ = thread.join();
                anyhow::bail!("{e}");
            }
            Err(_) => anyhow::bail!("the simulator thread died while starting"),
        };
        Ok(PtySim {
            path,
            stop,
            truth,
            thread: Some(thread),
            clock,
            link_timeout_ms,
        })
    }

    /// The wall instant at which the simulator's clock read `virt0`, `(instant, virt0)`:
    /// virtual time `v` is reached at `instant + (v − virt0) / speed` (within one loop pass),
    /// so an outside client can map the device's time to its own clock.
    pub fn clock(&self) -> (Instant, u64) {
        self.clock
    }

    /// The device's link watch, virtual ms: scaled with the speed, so that it lasts the
    /// protocol's wall-time timeout for a client on the wall clock.
    pub fn link_timeout_ms(&self) -> u32 {
        self.link_timeout_ms
    }

    /// The device path a serial client opens (e.g. `/dev/pts/7`).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The ground truth now (updated every few wall milliseconds).
    pub fn ground_truth(&self) -> GroundTruth {
        lock(&self.truth.now)
            .clone()
            .unwrap_or_else(|| unreachable!("set before spawn returns"))
    }

    /// Waits until the simulator's clock reads `time_ms` or later and gives the ground truth
    /// then (within one update, a few wall milliseconds); `None` when `limit` of wall time
    /// passed first or the simulator stopped before.
    pub fn ground_truth_at(&self, time_ms: u64, limit: Duration) -> Option<GroundTruth> {
        let deadline = Instant::now() + limit;
        let mut now = lock(&self.truth.now);
        loop {
            if let Some(t) = now.as_ref().filter(|t| t.time_ms >= time_ms) {
                return Some(t.clone());
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() || self.thread.as_ref().is_none_or(|t| t.is_finished()) {
                return None;
            }
            now = match self.truth.changed.wait_timeout(now, left) {
                Ok((g, _)) => g,
                Err(e) => e.into_inner().0,
            };
        }
    }

    /// Places `object` in the simulator's world, as the person at the crane does when asked,
    /// and waits (at most `limit` of wall time) until the simulator has it; refused when an
    /// object of that name is already there.
    pub fn place_object(
        &self,
        object: crate::world::Object,
        limit: Duration,
    ) -> Result<(), crate::world::WorldError> {
        let name = object.name.clone();
        if self.objects().iter().any(|o| o.name == name) {
            return Err(crate::world::WorldError::Duplicate(name));
        }
        lock(&self.truth.inbox).push(object);
        self.wait_until(limit, || {
            lock(&self.truth.objects).iter().any(|o| o.name == name)
        });
        Ok(())
    }

    /// A person moves `module` into `well` of its force curve by hand ([`Sim::move_module_by_hand`]),
    /// and this waits (at most `limit` of wall time) until the simulator has made the fold.
    pub fn move_module_by_hand(
        &self,
        module: crate::physics::trunk::Module,
        well: usize,
        limit: Duration,
    ) {
        lock(&self.truth.folds).push((module, well));
        self.wait_until(limit, || lock(&self.truth.folds).is_empty());
    }

    /// Cuts and restores the board's power ([`Sim::power_cycle`]), and waits (at most `limit`
    /// of wall time) until the simulator has.
    pub fn power_cycle(&self, limit: Duration) {
        *lock(&self.truth.cuts) += 1;
        self.wait_until(limit, || *lock(&self.truth.cuts) == 0);
    }

    /// Waits (at most `limit` of wall time, and not past the simulator thread's end) until
    /// `done` holds, looking again at each update of the ground truth.
    fn wait_until(&self, limit: Duration, done: impl Fn() -> bool) {
        let deadline = Instant::now() + limit;
        let mut now = lock(&self.truth.now);
        while !done() {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() || self.thread.as_ref().is_none_or(|t| t.is_finished()) {
                break;
            }
            now = match self.truth.changed.wait_timeout(now, left) {
                Ok((g, _)) => g,
                Err(e) => e.into_inner().0,
            };
        }
    }

    /// The objects of the simulator's world now (updated with the ground truth).
    pub fn objects(&self) -> Vec<crate::world::Object> {
        lock(&self.truth.objects).clone()
    }

    /// Stops the simulator and returns its final ground truth.
    pub fn stop(mut self) -> GroundTruth {
        self.halt();
        self.ground_truth()
    }

    /// [`PtySim::stop`], with what the emulated board measured over the session (`None` for
    /// the host-built controller, or an ELF without cortex-m-rt's stack symbols).
    pub fn stop_measured(mut self) -> (GroundTruth, Option<BoardMeasures>) {
        self.halt();
        let board = self
            .truth
            .board
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone();
        (self.ground_truth(), board)
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for PtySim {
    fn drop(&mut self) {
        self.halt();
    }
}

/// The simulator thread's latest ground truth, and a signal at every update.
#[derive(Debug, Default)]
struct Truth {
    now: Mutex<Option<GroundTruth>>,
    changed: Condvar,
    board: Mutex<Option<BoardMeasures>>,
    /// Objects a person placed, for the simulator thread to put into its world.
    inbox: Mutex<Vec<crate::world::Object>>,
    /// The world's objects, with each update of the ground truth.
    objects: Mutex<Vec<crate::world::Object>>,
    /// Folds a person made by hand (a module into a well), for the simulator thread to make.
    folds: Mutex<Vec<(crate::physics::trunk::Module, usize)>>,
    /// Power cuts asked for, for the simulator thread to make.
    cuts: Mutex<u32>,
}

impl Truth {
    /// The simulator's ground truth and its world's objects now.
    fn publish(&self, sim: &Sim) {
        *lock(&self.objects) = sim.world().objects().to_vec();
        self.set(sim.ground_truth());
    }

    fn set(&self, t: GroundTruth) {
        *lock(&self.now) = Some(t);
        self.changed.notify_all();
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A poisoned lock only means the simulator thread panicked mid-update: the value is still
    // a complete one (each is replaced whole).
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The simulator thread: moves bytes between the pty and the sim, and runs the sim.
fn serve(
    mut sim: Sim,
    (start, v0): (Instant, u64),
    master: OwnedFd,
    // Held open so the pty stays usable while no client has it open.
    _slave: OwnedFd,
    stop: &AtomicBool,
    truth: &Truth,
    log: Option<std::fs::File>,
) {
    use std::io::Write as _;
    let mut log = log.map(|f| (f, TruthLog::new()));
    let append = |line: String, file: &mut std::fs::File| {
        // A full disk or a closed file must not stop the crane's simulation.
        let _ = writeln!(file, "{line}");
    };
    if let Some((f, l)) = log.as_mut() {
        if let Some(line) = l.observe(&sim) {
            append(line, f);
        }
    }
    let speed = sim.options().speed;
    let mut pending: Vec<u8> = Vec::new();
    let mut buf = [0u8; 4096];
    let mut last_truth = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        // Host → device.
        loop {
            match nix::unistd::read(master.as_raw_fd(), &mut buf) {
                Ok(0) => break,
                Ok(n) => sim.write_host_bytes(&buf[..n]),
                // EAGAIN: nothing to read; EIO: no client has the device open.
                Err(_) => break,
            }
        }
        // Objects a person placed.
        let placed: Vec<_> = lock(&truth.inbox).drain(..).collect();
        if !placed.is_empty() {
            for o in placed {
                // A name already there was refused by `place_object`; a race with a second
                // placement of the same name keeps the first.
                let _ = sim.place_object(o);
            }
            truth.publish(&sim);
        }
        // Folds a person made by hand.
        let folds: Vec<_> = lock(&truth.folds).drain(..).collect();
        if !folds.is_empty() {
            for (module, well) in folds {
                sim.move_module_by_hand(module, well);
            }
            truth.publish(&sim);
        }
        // Power cuts.
        let cuts = std::mem::take(&mut *lock(&truth.cuts));
        if cuts > 0 {
            for _ in 0..cuts {
                sim.power_cycle();
            }
            truth.publish(&sim);
        }
        // Virtual time.
        let target = if speed.is_finite() {
            v0 + (start.elapsed().as_secs_f64() * speed * 1000.0) as u64
        } else {
            sim.now_ms() + 10
        };
        let target = target.min(sim.now_ms() + MAX_CATCH_UP_MS);
        while sim.now_ms() < target {
            if sim.now_ms() == BOOT_MS {
                forget_boot(&mut sim);
            }
            sim.step();
            if let Some((f, l)) = log.as_mut() {
                if let Some(line) = l.observe(&sim) {
                    append(line, f);
                }
            }
        }
        // Device → host.
        pending.extend(sim.read_device_bytes());
        if pending.len() > MAX_PENDING {
            let excess = pending.len() - MAX_PENDING;
            pending.drain(..excess);
        }
        while !pending.is_empty() {
            match nix::unistd::write(master.as_fd(), &pending) {
                Ok(n) => {
                    pending.drain(..n.min(pending.len()));
                }
                Err(Errno::EINTR) => continue,
                Err(_) => break,
            }
        }
        if last_truth.elapsed() >= Duration::from_millis(5) {
            truth.publish(&sim);
            last_truth = Instant::now();
        }
        if speed.is_finite() {
            std::thread::sleep(WALL_TICK);
        }
    }
    *truth.board.lock().unwrap_or_else(|e| e.into_inner()) = board_measures(&sim);
    truth.publish(&sim);
    if let Some((f, l)) = log.as_mut() {
        append(l.finish(&sim), f);
        let _ = f.flush();
    }
}

#[cfg(feature = "pil")]
fn board_measures(sim: &Sim) -> Option<BoardMeasures> {
    let emu = &sim.elf_board()?.emu;
    Some(BoardMeasures {
        stack_high_water: emu.stack_high_water()?,
        stack_size: emu.stack_size()?,
        longest_pass_cycles: (sim.now_ms() > BOOT_MS).then(|| emu.stats().max_awake_cycles),
        longest_pass_profile: emu.longest_pass_profile().into_iter().take(12).collect(),
        longest_pass_ticks_at: emu.longest_stretch().ticks_at.clone(),
        longest_pass_handler_cycles: emu.longest_stretch().handler_cycles,
        longest_pass_overrun_profile: emu.longest_overrun_profile().into_iter().take(12).collect(),
        rx_lost: emu.machine().sci.rx_lost,
        rx_overruns: emu.machine().sci.rx_overruns,
        last_overrun_ms: emu
            .machine()
            .sci
            .last_overrun_at
            .map(|t| ra4m1_emu::clock::ticks_to_ns(t) / 1_000_000),
        resets: emu.resets().len(),
    })
}

#[cfg(not(feature = "pil"))]
fn board_measures(_: &Sim) -> Option<BoardMeasures> {
    None
}

#[cfg(feature = "pil")]
fn forget_boot(sim: &mut Sim) {
    if let Some(b) = sim.elf_board_mut() {
        b.emu.profile_passes(true);
        b.emu.clear_max_awake();
    }
}

#[cfg(not(feature = "pil"))]
fn forget_boot(_: &mut Sim) {}
