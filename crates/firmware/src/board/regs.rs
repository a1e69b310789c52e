//! Register access helpers. Register *names and addresses* come from the `ra4m1-pac` crate (so a
//! misspelt register does not compile); bit layouts are written as named constants with the
//! RA4M1 hardware manual's field names, because a raw write of a whole register is what the
//! manual's setup procedures describe.

pub use ra4m1_pac as pac;
pub use ra4m1_pac::RegisterValue;

/// Reads a PAC register as its raw integer (`board::regs::rd!`).
#[doc(hidden)]
#[macro_export]
macro_rules! __board_rd {
    ($reg:expr) => {{
        // SAFETY: a volatile read of a memory-mapped register the PAC names; reads of these
        // registers have no side effects (status and data registers are read where the
        // hardware manual says so).
        #[allow(unused_unsafe)]
        unsafe {
            $crate::board::regs::RegisterValue::get_raw(&$reg.read())
        }
    }};
}

/// Writes a raw integer to a PAC register (`board::regs::wr!`).
#[doc(hidden)]
#[macro_export]
macro_rules! __board_wr {
    ($reg:expr, $val:expr) => {{
        // SAFETY: a volatile write to a memory-mapped register the PAC names, with a value whose
        // bit layout is documented at the call site; the board code is single-threaded apart
        // from the UART receive interrupt, which touches only SCI9 and its ICU slot.
        #[allow(unused_unsafe)]
        unsafe {
            $reg.write_raw($val)
        }
    }};
}

/// Reads a PAC register as its raw integer: `rd!(pac::SCI9.ssr())`.
pub use crate::__board_rd as rd;
/// Writes a raw integer to a PAC register: `wr!(pac::SCI9.tdr(), b)`.
pub use crate::__board_wr as wr;

/// Register write protection (PRCR): key `0xA5` in the high byte.
pub mod prcr {
    /// PRC0: clock generation registers.
    pub const PRC0: u16 = 1 << 0;
    /// PRC1: low-power mode registers (OPCCR, SBYCR, ...).
    pub const PRC1: u16 = 1 << 1;
    /// The key that must accompany every PRCR write.
    pub const KEY: u16 = 0xA500;
}

/// Runs `f` with PRCR.PRC0/PRC1 open, and closes them again.
#[inline]
pub fn with_clock_regs_unlocked<R>(f: impl FnOnce() -> R) -> R {
    wr!(pac::SYSTEM.prcr(), prcr::KEY | prcr::PRC0 | prcr::PRC1);
    let r = f();
    wr!(pac::SYSTEM.prcr(), prcr::KEY);
    r
}
