//! The persisted record: the last trunk state the controller confirmed (or was told).
//!
//! Byte layout of [`StoredState::to_bytes`] ([`STORED_LEN`] bytes, little-endian):
//!
//! | offset | content                                         |
//! |--------|-------------------------------------------------|
//! | 0–1    | magic `b"YC"`                                   |
//! | 2      | layout version ([`STORED_VERSION`])             |
//! | 3      | trunk state index ([`geometry::TrunkState::index`]) |
//! | 4      | flags: bit 0 = confirmed                        |
//! | 5      | reserved, 0                                     |
//! | 6–7    | CRC-16/CCITT-FALSE over bytes 0–5               |
//!
//! Erased flash (all `0xFF`) or all zeros decode as "nothing stored"; anything else that does not
//! check out is corrupt.

use geometry::TrunkState;

/// Length of the stored record.
pub const STORED_LEN: usize = 8;
/// Layout version of the stored record.
pub const STORED_VERSION: u8 = 1;

/// The state to persist across resets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoredState {
    /// The trunk state.
    pub state: TrunkState,
    /// Whether it was confirmed from sensors, by a person, or declared by the host.
    pub confirmed: bool,
}

/// Why a stored record could not be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoreError {
    /// Shorter than [`STORED_LEN`].
    Truncated,
    /// Wrong magic, version or reserved byte.
    Format,
    /// Checksum mismatch.
    Checksum,
    /// The state index is not one of the six states.
    State,
}

/// How the controller boots, from what the store held.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BootRecord {
    /// Nothing was ever stored: a new crane, in its manufactured state `F&P` (taken as confirmed).
    Empty,
    /// A valid record.
    Stored(StoredState),
    /// The store could not be read or its content is corrupt: the controller assumes `F&P`,
    /// unconfirmed, and raises the StateStorage fault.
    Corrupt,
}

/// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, not reflected, no final xor; the catalogue
/// calls it CRC-16/IBM-3740). Bitwise (`NoTable`): records are a few bytes and are written
/// rarely, so a 512-byte table in flash would buy nothing.
const CCITT_FALSE: crc::Crc<u16, crc::NoTable> =
    crc::Crc::<u16, crc::NoTable>::new(&crc::CRC_16_IBM_3740);

/// CRC-16/CCITT-FALSE of `bytes`: the check of a stored record (bytes 6–7) and of the board's
/// flash-log slots (`board::flash_log`), so both stay one on-flash format.
pub fn crc16(bytes: &[u8]) -> u16 {
    CCITT_FALSE.checksum(bytes)
}

impl StoredState {
    /// The record's bytes.
    pub fn to_bytes(&self) -> [u8; STORED_LEN] {
        let mut b = [
            b'Y',
            b'C',
            STORED_VERSION,
            self.state.index() as u8,
            self.confirmed as u8,
            0,
            0,
            0,
        ];
        let crc = crc16(&b[..6]).to_le_bytes();
        b[6] = crc[0];
        b[7] = crc[1];
        b
    }

    /// Decodes a record: `Ok(None)` for erased storage (all `0xFF` or all `0x00`).
    pub fn from_bytes(bytes: &[u8]) -> Result<Option<Self>, StoreError> {
        let b = bytes.get(..STORED_LEN).ok_or(StoreError::Truncated)?;
        if b.iter().all(|&x| x == 0xFF) || b.iter().all(|&x| x == 0) {
            return Ok(None);
        }
        if crc16(&b[..6]).to_le_bytes() != [b[6], b[7]] {
            return Err(StoreError::Checksum);
        }
        if b[0] != b'Y' || b[1] != b'C' || b[2] != STORED_VERSION || b[5] != 0 || b[4] > 1 {
            return Err(StoreError::Format);
        }
        let state = TrunkState::from_index(b[3] as usize).ok_or(StoreError::State)?;
        Ok(Some(StoredState {
            state,
            confirmed: b[4] == 1,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_is_ccitt_false() {
        // The catalogue's check value for CRC-16/CCITT-FALSE.
        assert_eq!(crc16(b"123456789"), 0x29B1);
    }

    #[test]
    fn record_bytes_are_pinned() {
        // Bytes written by the hand-rolled bitwise CRC this crate used before the `crc` crate:
        // records already in a board's flash must still decode.
        let golden = [b'Y', b'C', 1, 4, 1, 0, 0x99, 0x50];
        let s = StoredState::from_bytes(&golden).unwrap().unwrap();
        assert_eq!(s.state.index(), 4);
        assert!(s.confirmed);
        assert_eq!(s.to_bytes(), golden);
    }

    #[test]
    fn every_state_round_trips() {
        for state in TrunkState::ALL {
            for confirmed in [false, true] {
                let s = StoredState { state, confirmed };
                assert_eq!(StoredState::from_bytes(&s.to_bytes()), Ok(Some(s)));
            }
        }
    }

    #[test]
    fn erased_and_corrupt_records_are_told_apart() {
        assert_eq!(StoredState::from_bytes(&[0xFF; 8]), Ok(None));
        assert_eq!(StoredState::from_bytes(&[0; 8]), Ok(None));
        assert_eq!(StoredState::from_bytes(&[0; 3]), Err(StoreError::Truncated));
        let good = StoredState {
            state: TrunkState::ALL[4],
            confirmed: true,
        }
        .to_bytes();
        // Every single-bit flip is caught.
        for byte in 0..STORED_LEN {
            for bit in 0..8 {
                let mut b = good;
                b[byte] ^= 1 << bit;
                assert!(
                    StoredState::from_bytes(&b).is_err(),
                    "byte {byte} bit {bit}"
                );
            }
        }
    }
}
