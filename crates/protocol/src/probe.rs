//! The identification probe, as both ends run it: the device to identify an unconfirmed state
//! (`firmware::controller::identify`), the host's calibration to measure a trunk's signatures
//! (`host-tool calibrate --manual`). Both must run the same primitives and read the same
//! quantity, or a calibration would measure something identification does not.
//!
//! The probe: let the tendons out, vent, settle sealed for [`SETTLE_MS`], fill to [`PROBE_KPA`]
//! through the inlet, hold sealed for [`HOLD_MS`], vent. Its reading is the fill rate: kPa/s from
//! the settle's baseline (the mean of its second half) to the target, over the fill's duration.

use crate::messages::Primitive;

/// Sealed hold after the fill, ms: a pressure that falls by more than [`LEAK_DROP_KPA`] from
/// its first 100 ms (or from the fill's end) to its last 100 ms is a leak, and a leaking trunk
/// fills slower than its volume says: the probe then tells nothing.
pub const HOLD_MS: u32 = 500;
/// See [`HOLD_MS`] (the simulator's tight trunk moves by at most 0.04 kPa).
pub const LEAK_DROP_KPA: f32 = 0.15;
/// The probe's fill target, kPa: under a third of the lowest snap (13.1 kPa on the simulator's
/// calibrated trunk), so the probe cannot change the state it measures.
pub const PROBE_KPA: f32 = 4.0;
/// Sealed settle before the fill, ms; the baseline is the mean of its second half.
pub const SETTLE_MS: u32 = 300;
/// Fill-rate tolerance (fraction of the signature) within which a state is kept.
pub const RATE_TOLERANCE: f32 = 0.05;

/// The probe's primitives: vent, settle sealed, fill, hold sealed (the measurement), vent.
pub const PROBE: [Primitive; 5] = [
    Primitive::Vent { pressure_kpa: 0.0 },
    Primitive::Hold {
        duration_ms: SETTLE_MS,
    },
    Primitive::Inflate {
        pressure_kpa: PROBE_KPA,
        snaps: 0,
    },
    Primitive::Hold {
        duration_ms: HOLD_MS,
    },
    Primitive::Vent { pressure_kpa: 0.0 },
];

/// The fill rate, kPa/s, from a baseline `p0_kpa` to `filled_kpa` in `fill_ms` (`None` for a
/// fill of no duration).
pub fn fill_rate(p0_kpa: f32, filled_kpa: f32, fill_ms: u64) -> Option<f32> {
    (fill_ms > 0).then(|| (filled_kpa - p0_kpa) * 1_000.0 / fill_ms as f32)
}

/// Whether a sealed hold lost pressure like a leak: from its first to its last 100 ms, or from
/// the fill's end to its last 100 ms, by more than [`LEAK_DROP_KPA`].
pub fn leaking(filled_kpa: f32, hold_first_kpa: f32, hold_last_kpa: f32) -> bool {
    hold_first_kpa - hold_last_kpa > LEAK_DROP_KPA || filled_kpa - hold_last_kpa > LEAK_DROP_KPA
}
