//! What can stop the emulator.

/// An error that stops the emulated board: the firmware did something the model refuses (the
/// message names the register address and the program counter), or the CPU could not go on.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EmuError {
    /// An access to an address no model covers (a register this emulator does not model, a
    /// reserved offset, or unmapped memory).
    #[error("unmodelled {kind} of {size} byte(s) at {addr:#010x} (pc {pc:#010x})")]
    Unmodelled {
        /// "read" or "write".
        kind: &'static str,
        /// The address.
        addr: u32,
        /// Access size in bytes.
        size: u8,
        /// Program counter of the block that made the access.
        pc: u32,
    },
    /// An access the model covers but the hardware would refuse or mis-handle (write to a
    /// protected register, a module in module-stop, a wrong access size …).
    #[error("{what} at {addr:#010x} (pc {pc:#010x})")]
    Refused {
        /// What was wrong.
        what: String,
        /// The address.
        addr: u32,
        /// Program counter of the block that made the access.
        pc: u32,
    },
    /// The ELF could not be loaded.
    #[error("ELF: {0}")]
    Elf(String),
    /// The CPU emulator (Unicorn) reported an error.
    #[error("CPU emulator: {what} (pc {pc:#010x})")]
    Cpu {
        /// Unicorn's error.
        what: String,
        /// Program counter when it happened.
        pc: u32,
    },
    /// An exception return or entry the model does not support (PSP stacks, a bad EXC_RETURN).
    #[error("exception model: {what} (pc {pc:#010x})")]
    Exception {
        /// What was wrong.
        what: String,
        /// Program counter.
        pc: u32,
    },
}
