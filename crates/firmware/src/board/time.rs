//! The 1 ms time base (SysTick exception counting milliseconds) and short busy-wait delays on
//! the DWT cycle counter.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{DCB, DWT, SYST};
use cortex_m_rt::exception;

/// Milliseconds since `start` (wraps after 49.7 days; [`Clock::now_ms`] extends it to 64 bits).
static TICKS_MS: AtomicU32 = AtomicU32::new(0);
/// Core clock, for the µs delays.
static CORE_HZ: AtomicU32 = AtomicU32::new(48_000_000);

#[exception]
fn SysTick() {
    // Single writer (this handler); the main loop only reads.
    TICKS_MS.fetch_add(1, Ordering::Relaxed);
}

/// The running time base.
#[derive(Debug)]
pub struct Clock {
    high: u32,
    last_low: u32,
}

impl Clock {
    /// Starts SysTick at 1 kHz from the core clock and the DWT cycle counter.
    #[inline]
    pub fn start(syst: &mut SYST, dcb: &mut DCB, dwt: &mut DWT, core_hz: u32) -> Self {
        CORE_HZ.store(core_hz, Ordering::Relaxed);
        dcb.enable_trace();
        DWT::unlock();
        dwt.enable_cycle_counter();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(core_hz / 1_000 - 1);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        Self {
            high: 0,
            last_low: 0,
        }
    }

    /// Milliseconds since [`Clock::start`], 64-bit (call at least once per 49 days).
    pub fn now_ms(&mut self) -> u64 {
        let low = TICKS_MS.load(Ordering::Relaxed);
        if low < self.last_low {
            self.high = self.high.wrapping_add(1);
        }
        self.last_low = low;
        ((self.high as u64) << 32) | low as u64
    }
}

/// Milliseconds since the clock started, 32-bit (wraps after 49.7 days; for intervals).
pub fn ticks_ms() -> u32 {
    TICKS_MS.load(Ordering::Relaxed)
}

/// The DWT cycle counter (wraps every 89 s at 48 MHz; differences are wrap-safe).
#[inline]
pub fn cycles() -> u32 {
    DWT::cycle_count()
}

/// Busy-waits at least `us` microseconds.
pub fn delay_us(us: u32) {
    let hz = CORE_HZ.load(Ordering::Relaxed);
    let wait = (hz / 1_000_000).saturating_mul(us);
    let start = cycles();
    while cycles().wrapping_sub(start) < wait {}
}
