//! The UNO R4 WiFi bootloader's SAM-BA dialect, client side, as `bossac` (Arduino's fork,
//! 1.9.1-arduino5) speaks it.
//!
//! The bootloader (`arduino/arduino-renesas-bootloader`, `src/bossa.c`, built with
//! `BOSSA_LOADER` for the WiFi) reads ASCII commands ending in `#` from SCI9 at 230 400 Bd,
//! which the ESP32-S3 bridge relays from USB at whatever rate the host opened the port with:
//!
//! | command | answer | does |
//! |---|---|---|
//! | `N#` | `\n\r` | "binary mode" (nothing to change) |
//! | `V#` | `Arduino Bootloader (SAM-BA extended) 2.0 [Arduino:IKXYZ]\n\r` | its version and the extended commands it has |
//! | `I#` | `nRF52840-QIAA\n\r` | "identify chip": borrowed so that bossac picks its `NullFlash` (4 KiB pages, addresses from 0) |
//! | `X%08X#` | `X\n\r` | "erase from": nothing (the writes erase) |
//! | `S%08X,%08X#` + bytes | none | that many raw bytes into its 8 KiB RAM buffer at that offset |
//! | `Y%08X,0#` | `Y\n\r` | the buffer offset to copy from |
//! | `Y%08X,%08X#` | `Y\n\r` | erase 4 KiB at 0x4000 + addr when it is 2 KiB aligned, then write `size` bytes there |
//! | `Z%08X,%08X#` | `Z%08X#\n\r` | CRC-16 (XMODEM: poly 0x1021, init 0) of `size` ≤ 4096 bytes of flash at 0x4000 + addr |
//! | `K#` | none | system reset (into the application after the bootloader's 500 ms) |
//!
//! Every other command (`R`, `W`, `w`, `G`, `O`, `o`) is silently ignored, so a flash can only
//! be checked by `Z`. Its errors are silences: a flash write that fails still answers `Y`
//! (`R_FLASH_LP_Write`'s result is not looked at), so only the verify finds it; a board that
//! resets or loses its cable stops answering.
//!
//! bossac's sequence for `-U -e -w -R` on this bootloader (`Samba.cpp`, `Flasher.cpp`,
//! `NullFlash.cpp`): `N#`, `V#`, `I#`, `X00000000#`, then per 4 KiB block `S` (the block into
//! the buffer), `Y…,0#`, `Y dst,1000#` (the last block padded with zeros to 4 KiB), its own
//! verify with `Z` per block, and `K#`. This client does the same, with bossac's time limits
//! (100 ms for short answers, 5 s for an erase, a write or a checksum).

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

/// The bootloader's block: its page and write-buffer size.
pub const BLOCK: usize = 4096;
/// What the UNO R4 WiFi's bootloader answers to `V#` up to its capabilities.
pub const VERSION_PREFIX: &str = "Arduino Bootloader (SAM-BA extended)";
/// What it answers to `I#`.
pub const CHIP_ID: &str = "nRF52840-QIAA";
/// The extended commands this client needs from it.
pub const NEEDED: &str = "IKXYZ";
/// The serial rate the bootloader's UART runs at (`run_bootloader`: 230 400 Bd).
pub const BOOTLOADER_BAUD: u32 = 230_400;

const QUICK: Duration = Duration::from_millis(100);
const LONG: Duration = Duration::from_secs(5);

/// Why a SAM-BA exchange failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SambaError {
    /// No (complete) answer in time.
    #[error("no answer to {command} within {ms} ms{got}", ms = .limit.as_millis(),
            got = if .got.is_empty() { String::new() } else { format!(" (got {:?})", String::from_utf8_lossy(.got)) })]
    Timeout {
        /// The command.
        command: String,
        /// The limit.
        limit: Duration,
        /// What did come.
        got: Vec<u8>,
    },
    /// An answer, but not the one the protocol gives.
    #[error("{command} was answered {got:?}, expected {expected}")]
    Unexpected {
        /// The command.
        command: String,
        /// What came.
        got: String,
        /// What should have.
        expected: &'static str,
    },
    /// The port failed.
    #[error("serial I/O: {0}")]
    Io(String),
}

/// CRC-16/XMODEM, the bootloader's `serial_add_crc` (and bossac's `checksumCalc`).
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &b in bytes {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// The client over a port whose reads time out quickly (`TimedOut`/`WouldBlock` mean "nothing
/// yet").
pub struct Samba<P: Read + Write> {
    port: P,
}

impl<P: Read + Write> Samba<P> {
    /// A client on `port`.
    pub fn new(port: P) -> Self {
        Self { port }
    }

    fn send(&mut self, bytes: &[u8]) -> Result<(), SambaError> {
        self.port
            .write_all(bytes)
            .and_then(|()| self.port.flush())
            .map_err(|e| SambaError::Io(e.to_string()))
    }

    /// Reads until `done(bytes)` or `limit` passes.
    fn read_until(
        &mut self,
        command: &str,
        limit: Duration,
        done: impl Fn(&[u8]) -> bool,
    ) -> Result<Vec<u8>, SambaError> {
        let until = Instant::now() + limit;
        let mut got = Vec::new();
        let mut buf = [0u8; 64];
        while !done(&got) {
            if Instant::now() >= until {
                return Err(SambaError::Timeout {
                    command: command.to_string(),
                    limit,
                    got,
                });
            }
            match self.port.read(&mut buf) {
                Ok(n) => got.extend_from_slice(&buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(SambaError::Io(e.to_string())),
            }
        }
        Ok(got)
    }

    /// Drops whatever the line holds (reads until it has been quiet for `quiet`).
    pub fn drain(&mut self, quiet: Duration) {
        let mut buf = [0u8; 256];
        let mut last = Instant::now();
        let give_up = Instant::now() + Duration::from_secs(1);
        while last.elapsed() < quiet && Instant::now() < give_up {
            if let Ok(n) = self.port.read(&mut buf) {
                if n > 0 {
                    last = Instant::now();
                }
            }
        }
    }

    /// A command answered by a line ending in `\n\r`; the line without it.
    fn line(&mut self, command: &str, limit: Duration) -> Result<String, SambaError> {
        self.send(command.as_bytes())?;
        let got = self.read_until(command, limit, |g| g.windows(2).any(|w| w == b"\n\r"))?;
        let end = got
            .windows(2)
            .position(|w| w == b"\n\r")
            .unwrap_or(got.len());
        Ok(String::from_utf8_lossy(&got[..end]).into_owned())
    }

    /// `N#`: whether the bootloader answers (its `\n\r`) within `limit`.
    pub fn hello(&mut self, limit: Duration) -> Result<(), SambaError> {
        self.line("N#", limit).map(|_| ())
    }

    /// `V#`: the version line.
    pub fn version(&mut self) -> Result<String, SambaError> {
        self.line("V#", QUICK)
    }

    /// `I#`: the chip the bootloader says it is.
    pub fn identify(&mut self) -> Result<String, SambaError> {
        self.line("I#", QUICK)
    }

    /// `X00000000#`: bossac's `-e` (the bootloader's writes erase as they go).
    pub fn erase(&mut self) -> Result<(), SambaError> {
        let cmd = "X00000000#";
        let got = self.line(cmd, LONG)?;
        expect(cmd, &got, "X", "X\\n\\r")
    }

    /// Writes one block (≤ [`BLOCK`] bytes, padded with zeros to [`BLOCK`] as bossac pads the
    /// last one) to the application's flash at `offset` from its origin.
    pub fn write_block(&mut self, offset: u32, data: &[u8]) -> Result<(), SambaError> {
        let mut block = data.to_vec();
        block.resize(BLOCK, 0);
        self.send(format!("S{:08X},{:08X}#", 0, BLOCK).as_bytes())?;
        self.send(&block)?;
        let cmd = format!("Y{:08X},0#", 0);
        let got = self.line(&cmd, QUICK)?;
        expect(&cmd, &got, "Y", "Y\\n\\r")?;
        let cmd = format!("Y{offset:08X},{BLOCK:08X}#");
        let got = self.line(&cmd, LONG)?;
        expect(&cmd, &got, "Y", "Y\\n\\r")
    }

    /// `Z`: the CRC-16 of `len` ≤ [`BLOCK`] bytes of flash at `offset` from the origin.
    pub fn checksum(&mut self, offset: u32, len: usize) -> Result<u16, SambaError> {
        let cmd = format!("Z{offset:08X},{len:08X}#");
        let got = self.line(&cmd, LONG)?;
        let hex = got
            .strip_prefix('Z')
            .and_then(|g| g.strip_suffix('#'))
            .filter(|h| h.len() == 8);
        hex.and_then(|h| u32::from_str_radix(h, 16).ok())
            .and_then(|v| u16::try_from(v).ok())
            .ok_or(SambaError::Unexpected {
                command: cmd,
                got,
                expected: "Z%08X#\\n\\r with a 16-bit CRC",
            })
    }

    /// `K#`: reset the board (no answer: it is gone).
    pub fn reset(&mut self) -> Result<(), SambaError> {
        self.send(b"K#")
    }
}

fn expect(cmd: &str, got: &str, want: &str, shown: &'static str) -> Result<(), SambaError> {
    if got == want {
        Ok(())
    } else {
        Err(SambaError::Unexpected {
            command: cmd.to_string(),
            got: got.to_string(),
            expected: shown,
        })
    }
}

/// Why a `V#` and `I#` answer is not the UNO R4 WiFi's bootloader, if it is not.
pub fn not_ours(version: &str, chip: Option<&str>) -> Option<String> {
    let caps = version
        .find("[Arduino:")
        .and_then(|i| version[i + 9..].split(']').next());
    if !version.starts_with(VERSION_PREFIX) {
        return Some(format!(
            "its bootloader answered V# with {version:?}, not the UNO R4 WiFi's \
             {VERSION_PREFIX:?} … [Arduino:{NEEDED}]: another board"
        ));
    }
    let missing: String = NEEDED
        .chars()
        .filter(|c| !caps.is_some_and(|k| k.contains(*c)))
        .collect();
    if !missing.is_empty() {
        return Some(format!(
            "its bootloader ({version:?}) lacks the extended commands {missing} that the UNO R4 \
             WiFi's has ([Arduino:{NEEDED}])"
        ));
    }
    match chip {
        Some(c) if c != CHIP_ID => Some(format!(
            "its bootloader identifies as {c:?}; the UNO R4 WiFi's says {CHIP_ID:?}: another board"
        )),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_checksum_is_crc16_xmodem() {
        // The catalogue's check value of CRC-16/XMODEM.
        assert_eq!(crc16(b"123456789"), 0x31C3);
        assert_eq!(crc16(&[]), 0);
    }

    #[test]
    fn only_the_uno_r4_wifi_bootloader_is_taken_for_it() {
        let ours = "Arduino Bootloader (SAM-BA extended) 2.0 [Arduino:IKXYZ]";
        assert_eq!(not_ours(ours, Some(CHIP_ID)), None);
        // A SAMD21 board (Arduino Zero's bootloader): no I or K.
        let zero = "v2.0 [Arduino:XYZ] Mar 19 2018 09:45:14";
        assert!(not_ours(zero, None).unwrap().contains("another board"));
        let old = "Arduino Bootloader (SAM-BA extended) 2.0 [Arduino:XYZ]";
        assert!(not_ours(old, None).unwrap().contains("IK"));
        assert!(not_ours(ours, Some("nRF52840-QFAA"))
            .unwrap()
            .contains("another board"));
    }
}
