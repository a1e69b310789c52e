//! The logging shim: the board's code logs through these macros, which forward to defmt over
//! RTT. Swapping the backend (or compiling logs out) touches only this file.

/// Informational message.
macro_rules! info {
    ($($t:tt)*) => { ::defmt::info!($($t)*) };
}
/// Something unexpected but handled.
macro_rules! log_warn {
    ($($t:tt)*) => { ::defmt::warn!($($t)*) };
}
/// An error.
macro_rules! error {
    ($($t:tt)*) => { ::defmt::error!($($t)*) };
}

pub(crate) use {error, info, log_warn as warn};
