//! The logging shim: the board's code logs through these macros, which forward to defmt over
//! RTT. Swapping the backend (or compiling logs out) touches only this file. A crate that logs
//! through them depends on `defmt` itself (its macros name `defmt`), as the board binary does.

/// Informational message (`board::log::info!`).
#[doc(hidden)]
#[macro_export]
macro_rules! __board_info {
    ($($t:tt)*) => { ::defmt::info!($($t)*) };
}
/// Something unexpected but handled (`board::log::warn!`).
#[doc(hidden)]
#[macro_export]
macro_rules! __board_warn {
    ($($t:tt)*) => { ::defmt::warn!($($t)*) };
}
/// An error (`board::log::error!`).
#[doc(hidden)]
#[macro_export]
macro_rules! __board_error {
    ($($t:tt)*) => { ::defmt::error!($($t)*) };
}

/// An error.
pub use crate::__board_error as error;
/// Informational message.
pub use crate::__board_info as info;
/// Something unexpected but handled.
pub use crate::__board_warn as warn;
