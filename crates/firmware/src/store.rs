//! The persisted record: the controller's belief about the trunk, journaled around each step.
//!
//! Before a step's first actuation the controller writes the step as *pending* (`from → to`,
//! with the states it may end in); when the step is confirmed it writes the confirmed state.
//! A reset at any instant therefore boots into the truth, or into "unconfirmed: was going
//! `from → to`, one of these candidates" (`docs/firmware.md`, "Crash consistency"); the flash
//! log keeps the old or the new record across a power loss during a write.
//!
//! Byte layout of [`StoredState::to_bytes`] ([`STORED_LEN`] bytes, little-endian), version 2:
//!
//! | offset | content                                                          |
//! |--------|------------------------------------------------------------------|
//! | 0–1    | magic `b"YC"`                                                    |
//! | 2      | layout version ([`STORED_VERSION`])                              |
//! | 3      | bits 0–2: state index ([`geometry::TrunkState::index`]); bit 3: confirmed; bit 4: a step is pending; bits 5–7: 0 |
//! | 4      | candidates, one bit per state index (bits 6–7: 0)               |
//! | 5      | the pending step: bits 0–2 `from`, bits 3–5 `to` (0 when none; bits 6–7: 0) |
//! | 6–7    | CRC-16/CCITT-FALSE over bytes 0–5                                |
//!
//! Version 1 records (`[Y, C, 1, state, confirmed, 0, crc]`, written before the journal
//! existed) still decode: confirmed, or unconfirmed with every state a candidate.
//!
//! Erased flash (all `0xFF`) or all zeros decode as "nothing stored"; anything else that does not
//! check out is corrupt.

use geometry::TrunkState;
use protocol::{StateSet, Transition};

/// Length of the stored record.
pub const STORED_LEN: usize = 8;
/// Layout version of the stored record.
pub const STORED_VERSION: u8 = 2;

/// The belief to persist across resets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoredState {
    /// The trunk state: confirmed, or the last confirmed one.
    pub state: TrunkState,
    /// Whether it was confirmed from sensors, by a person, or declared by the host.
    pub confirmed: bool,
    /// The states the trunk may be in (`{state}` when confirmed).
    pub candidates: StateSet,
    /// The step that was under way (journaled before its first actuation), if any.
    pub pending: Option<Transition>,
}

impl StoredState {
    /// A confirmed state, nothing pending.
    pub const fn confirmed(state: TrunkState) -> Self {
        Self {
            state,
            confirmed: true,
            candidates: StateSet::single(state),
            pending: None,
        }
    }
}

/// Why a stored record could not be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoreError {
    /// Shorter than [`STORED_LEN`].
    Truncated,
    /// Wrong magic, version or reserved bits.
    Format,
    /// Checksum mismatch.
    Checksum,
    /// A state index is not one of the six states.
    State,
}

/// How the controller boots, from what the store held.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BootRecord {
    /// Nothing was ever stored: a new crane, in its manufactured state `F&P` (taken as confirmed).
    Empty,
    /// A valid record.
    Stored(StoredState),
    /// The store could not be read or its content is corrupt: the controller assumes nothing
    /// (every state a candidate) and raises the StateStorage fault.
    Corrupt,
}

/// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, not reflected, no final xor; the catalogue
/// calls it CRC-16/IBM-3740) of `bytes`: the check of a stored record (bytes 6–7) and of the
/// board's flash-log slots ([`crate::flash_log`]), so both stay one on-flash format.
///
/// A byte at a time without a table: for this polynomial the eight bit steps of a byte fold
/// into `x = (r >> 8) ^ b; x ^= x >> 4; r = (r << 8) ^ (x << 12) ^ (x << 5) ^ x` (the high
/// nibble's feedback, 0x1021 = x¹² + x⁵ + 1, is linear in `x`). The board computes it in
/// every pass of a save until the slot's program ends (the slot's 12 bytes and the record's
/// 6), so the bit loop's 4 098 cycles in such a pass were worth folding (≈ 700 now, 16 B less
/// flash; BENCHMARKS.md, "Issue 27"); a 256-entry table would cost 512 B of the flash budget.
/// By hand rather than the `crc` crate's `NoTable` (whose generic step is 3× the size on the
/// board): tests hold it to the crate's and, for every state and byte, to the bit-by-bit
/// definition.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut r = 0xFFFFu16;
    for &b in bytes {
        r = crc16_byte(r, b);
    }
    r
}

/// One byte of [`crc16`]: the folded form of eight steps of the bit loop.
#[inline(always)]
fn crc16_byte(r: u16, b: u8) -> u16 {
    let mut x = (r >> 8) as u8 ^ b;
    x ^= x >> 4;
    let x = u16::from(x);
    (r << 8) ^ (x << 12) ^ (x << 5) ^ x
}

fn state_at(index: u8) -> Result<TrunkState, StoreError> {
    TrunkState::from_index(index as usize).ok_or(StoreError::State)
}

impl StoredState {
    /// The record's bytes.
    pub fn to_bytes(&self) -> [u8; STORED_LEN] {
        let flags = self.state.index() as u8
            | (self.confirmed as u8) << 3
            | (self.pending.is_some() as u8) << 4;
        let step = self
            .pending
            .map_or(0, |t| t.from.index() as u8 | (t.to.index() as u8) << 3);
        let mut b = [
            b'Y',
            b'C',
            STORED_VERSION,
            flags,
            self.candidates.0 & StateSet::ALL.0,
            step,
            0,
            0,
        ];
        let crc = crc16(&b[..6]).to_le_bytes();
        b[6] = crc[0];
        b[7] = crc[1];
        b
    }

    /// Decodes a record (version 2, or a version-1 record): `Ok(None)` for erased storage (all
    /// `0xFF` or all `0x00`).
    pub fn from_bytes(bytes: &[u8]) -> Result<Option<Self>, StoreError> {
        let b = bytes.get(..STORED_LEN).ok_or(StoreError::Truncated)?;
        if b.iter().all(|&x| x == 0xFF) || b.iter().all(|&x| x == 0) {
            return Ok(None);
        }
        if crc16(&b[..6]).to_le_bytes() != [b[6], b[7]] {
            return Err(StoreError::Checksum);
        }
        if b[0] != b'Y' || b[1] != b'C' {
            return Err(StoreError::Format);
        }
        match b[2] {
            1 => {
                if b[5] != 0 || b[4] > 1 {
                    return Err(StoreError::Format);
                }
                let state = state_at(b[3])?;
                let confirmed = b[4] == 1;
                Ok(Some(StoredState {
                    state,
                    confirmed,
                    candidates: if confirmed {
                        StateSet::single(state)
                    } else {
                        StateSet::ALL
                    },
                    pending: None,
                }))
            }
            STORED_VERSION => {
                if b[3] & 0xE0 != 0 || b[4] & 0xC0 != 0 || b[5] & 0xC0 != 0 {
                    return Err(StoreError::Format);
                }
                let state = state_at(b[3] & 7)?;
                let confirmed = b[3] & 0x08 != 0;
                let pending = if b[3] & 0x10 != 0 {
                    Some(Transition {
                        from: state_at(b[5] & 7)?,
                        to: state_at((b[5] >> 3) & 7)?,
                    })
                } else if b[5] != 0 {
                    return Err(StoreError::Format);
                } else {
                    None
                };
                let candidates = StateSet(b[4]);
                if confirmed && (candidates != StateSet::single(state) || pending.is_some()) {
                    return Err(StoreError::Format);
                }
                Ok(Some(StoredState {
                    state,
                    confirmed,
                    candidates: candidates.with(state),
                    pending,
                }))
            }
            _ => Err(StoreError::Format),
        }
    }
}

/// Bytes of a stored probe profile ([`profile_to_bytes`]): the firmware schema it was measured
/// with ([`protocol::SCHEMA_ID`], u32 LE), then the six states' and two between signatures' fill
/// rates (f32 LE, kPa/s). The flash slot adds its CRC.
pub const PROFILE_LEN: usize = 4 + 8 * 4;

/// The stored form of `p` (measured with this firmware's schema).
pub fn profile_to_bytes(p: &protocol::ProbeProfile) -> [u8; PROFILE_LEN] {
    let mut b = [0u8; PROFILE_LEN];
    b[..4].copy_from_slice(&protocol::SCHEMA_ID.to_le_bytes());
    for i in 0..8 {
        b[4 + 4 * i..8 + 4 * i].copy_from_slice(&p.rate(i).to_le_bytes());
    }
    b
}

/// A stored profile back, or `None` when it was measured with another firmware schema or
/// holds a rate the device would refuse ([`protocol::ProbeProfile::out_of_range`]).
pub fn profile_from_bytes(b: &[u8; PROFILE_LEN]) -> Option<protocol::ProbeProfile> {
    let word = |i: usize| [b[i], b[i + 1], b[i + 2], b[i + 3]];
    if u32::from_le_bytes(word(0)) != protocol::SCHEMA_ID {
        return None;
    }
    let r = |i: usize| f32::from_le_bytes(word(4 + 4 * i));
    let p = protocol::ProbeProfile {
        states: [r(0), r(1), r(2), r(3), r(4), r(5)],
        between: [r(6), r(7)],
    };
    p.out_of_range().is_none().then_some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_is_the_crates_ccitt_false() {
        let crate_crc = crc::Crc::<u16, crc::NoTable>::new(&crc::CRC_16_IBM_3740);
        let mut x = 0x2545_f491u32;
        let bytes: [u8; 40] = core::array::from_fn(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as u8
        });
        for n in 0..=bytes.len() {
            assert_eq!(
                crc16(&bytes[..n]),
                crate_crc.checksum(&bytes[..n]),
                "{n} bytes"
            );
        }
    }

    #[test]
    fn the_folded_byte_step_is_eight_bit_steps_for_every_state_and_byte() {
        let bitwise = |mut r: u16, b: u8| {
            r ^= u16::from(b) << 8;
            for _ in 0..8 {
                r = if r & 0x8000 != 0 {
                    (r << 1) ^ 0x1021
                } else {
                    r << 1
                };
            }
            r
        };
        for r in 0..=u16::MAX {
            for b in 0..=u8::MAX {
                assert_eq!(
                    crc16_byte(r, b),
                    bitwise(r, b),
                    "state {r:#06x}, byte {b:#04x}"
                );
            }
        }
    }

    #[test]
    fn crc_is_ccitt_false() {
        // The catalogue's check value for CRC-16/CCITT-FALSE.
        assert_eq!(crc16(b"123456789"), 0x29B1);
    }

    #[test]
    fn version_1_records_still_decode() {
        // Bytes written by the hand-rolled bitwise CRC this crate used before the `crc` crate:
        // records already in a board's flash must still decode.
        let golden = [b'Y', b'C', 1, 4, 1, 0, 0x99, 0x50];
        let s = StoredState::from_bytes(&golden).unwrap().unwrap();
        assert_eq!(s, StoredState::confirmed(TrunkState::ALL[4]));
        // An unconfirmed v1 record: nothing is known but the guess.
        let mut v1 = [b'Y', b'C', 1, 2, 0, 0, 0, 0];
        let crc = crc16(&v1[..6]).to_le_bytes();
        v1[6..].copy_from_slice(&crc);
        let s = StoredState::from_bytes(&v1).unwrap().unwrap();
        assert!(!s.confirmed);
        assert_eq!(s.candidates, StateSet::ALL);
        assert_eq!(s.pending, None);
    }

    #[test]
    fn version_2_bytes_are_pinned() {
        let pending = StoredState {
            state: TrunkState::ALL[5],
            confirmed: false,
            candidates: StateSet(0b10_0110),
            pending: Some(Transition {
                from: TrunkState::ALL[5],
                to: TrunkState::ALL[2],
            }),
        };
        let b = pending.to_bytes();
        assert_eq!(&b[..6], &[b'Y', b'C', 2, 0x15, 0x26, 0x15]);
        assert_eq!(StoredState::from_bytes(&b), Ok(Some(pending)));
    }

    #[test]
    fn every_record_round_trips() {
        for state in TrunkState::ALL {
            let s = StoredState::confirmed(state);
            assert_eq!(StoredState::from_bytes(&s.to_bytes()), Ok(Some(s)));
            for to in TrunkState::ALL {
                for cand in [0u8, 0b1, 0b11_1111, 0b10_1010] {
                    let s = StoredState {
                        state,
                        confirmed: false,
                        candidates: StateSet(cand).with(state),
                        pending: (to != state).then_some(Transition { from: state, to }),
                    };
                    assert_eq!(StoredState::from_bytes(&s.to_bytes()), Ok(Some(s)));
                }
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
            confirmed: false,
            candidates: StateSet(0b11_0000),
            pending: Some(Transition {
                from: TrunkState::ALL[4],
                to: TrunkState::ALL[5],
            }),
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
