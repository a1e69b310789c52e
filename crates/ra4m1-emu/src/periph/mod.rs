//! The peripheral models, register by register. Each model cites the RA4M1 User's Manual
//! (Renesas R01UH0887, "RA4M1 Group User's Manual: Hardware") chapter it follows, and the
//! `ra4m1-pac` register definitions give the offsets. Every access to an offset a model does
//! not name is refused with its address ([`crate::EmuError::Unmodelled`]).

pub mod adc;
pub mod flash;
pub mod gpt;
pub mod icu;
pub mod port;
pub mod sci;
pub mod scs;
pub mod spmon;
pub mod system;
pub mod wdt;

/// A refusal from a register model: `Unmodelled` (no such register here) or a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Why {
    /// No register at this offset (or not with this access size) is modelled.
    Unmodelled,
    /// The access is modelled but refused.
    Refused(String),
}

/// Register-model result.
pub type R<T> = Result<T, Why>;

/// Shorthand for a refusal.
pub fn refuse<T>(msg: impl Into<String>) -> R<T> {
    Err(Why::Refused(msg.into()))
}

/// Reads `size` bytes at byte offset `off` of a little-endian register of `width` bytes whose
/// value is `v` (narrow reads of a wider register are what the bus does).
pub fn sub_read(v: u32, off_in_reg: u32, size: u32) -> u32 {
    let shifted = v >> (8 * off_in_reg);
    match size {
        1 => shifted & 0xFF,
        2 => shifted & 0xFFFF,
        _ => shifted,
    }
}

/// Checks an access has exactly the register's width.
pub fn need(size: u32, width: u32, name: &str) -> R<()> {
    if size == width {
        Ok(())
    } else {
        refuse(format!(
            "{size}-byte access to the {width}-byte register {name}"
        ))
    }
}

/// Clock frequencies from the clock generation circuit (see [`system`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Clocks {
    /// CPU, SysTick, DWT.
    pub iclk: u32,
    /// SCI.
    pub pclka: u32,
    /// WDT.
    pub pclkb: u32,
    /// ADC.
    pub pclkc: u32,
    /// GPT.
    pub pclkd: u32,
    /// Flash interface.
    pub fclk: u32,
}

/// ICU event numbers the models raise (RA4M1 UM, "Interrupt Controller Unit", event table).
pub mod event {
    /// SCI9 receive data full.
    pub const SCI9_RXI: u16 = 0xA8;
    /// SCI9 transmit data empty.
    pub const SCI9_TXI: u16 = 0xA9;
    /// SCI9 transmit end.
    pub const SCI9_TEI: u16 = 0xAA;
    /// SCI9 receive error.
    pub const SCI9_ERI: u16 = 0xAB;
    /// USBFS interrupt (the Minima bootloader's link).
    pub const USBFS_INT: u16 = 0x33;
    /// USBFS resume.
    pub const USBFS_RESUME: u16 = 0x34;
    /// USBFS FIFO 0 transfer request.
    pub const USBFS_FIFO_0: u16 = 0x31;
    /// USBFS FIFO 1 transfer request.
    pub const USBFS_FIFO_1: u16 = 0x32;
    /// LVD1 (voltage monitor 1 interrupt): 0x19 (FSP `bsp_elc.h` for the RA4M1,
    /// `ELC_EVENT_LVD_LVD1`).
    pub const LVD_LVD1: u16 = 0x19;
}
