//! Virtual time. The master clock ticks at 192 MHz, the least common multiple of every clock the
//! RA4M1's HOCO (24/32/48/64 MHz) and its power-of-two dividers can produce, so every peripheral
//! period is a whole number of ticks and the emulator stays integer and deterministic.

/// Master ticks per second.
pub const TICK_HZ: u64 = 192_000_000;

/// Ticks per nanosecond is not whole; these convert exactly (rounding down).
pub const fn ticks_to_ns(t: u64) -> u64 {
    (t as u128 * 1_000_000_000 / TICK_HZ as u128) as u64
}

/// Nanoseconds to ticks (rounding down).
pub const fn ns_to_ticks(ns: u64) -> u64 {
    (ns as u128 * TICK_HZ as u128 / 1_000_000_000) as u64
}

/// Ticks per period of a clock running at `hz` (which divides [`TICK_HZ`] for every clock the
/// chip can make; other values round down, never to zero).
pub fn ticks_per(hz: u32) -> u64 {
    (TICK_HZ / hz.max(1) as u64).max(1)
}
