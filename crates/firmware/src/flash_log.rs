//! Wear-aware record log for [`crate::hw::StateStore`] on a small NOR flash (the RA4M1 data
//! flash): pure logic over the [`NorFlash`] trait, built for every target. The board's data
//! flash driver (`board::dataflash`, feature `board-uno-r4`) implements the trait on the chip; the host
//! tests the log against an emulated flash with power-loss injection
//! (`crates/firmware/tests/board_flash_log.rs`), and the simulator writes and reads the
//! emulated board's data flash through it (`hil-sim`'s `elf_board`).
//!
//! Layout: two erase blocks used ping-pong. Each block holds [`SLOTS_PER_BLOCK`] slots of
//! [`SLOT_LEN`] bytes, appended in order:
//!
//! | offset | content                                           |
//! |--------|---------------------------------------------------|
//! | 0–3    | sequence number, u32 LE (newest record = highest) |
//! | 4–11   | [`StoredState::to_bytes`] (carries its own CRC)    |
//! | 12–13  | CRC-16/CCITT-FALSE ([`crc16`]) over bytes 0–11, LE |
//! | 14–15  | never written (stay `0xFF`)                        |
//!
//! A save appends one slot. When the current block is full, the save erases the *other* block
//! and writes there, so the newest valid record survives a power loss at any point: a torn slot
//! fails its CRC and is skipped, and the previous record is still intact. Each block is erased
//! once per `SLOTS_PER_BLOCK` saves (64 with 1 KiB blocks).
//!
//! The link-signing key ([`FlashLog::with_key_block`]) has a block of its own, one slot at its
//! start:
//!
//! | offset | content                                        |
//! |--------|------------------------------------------------|
//! | 0–15   | the key                                        |
//! | 16–17  | CRC-16/CCITT-FALSE over bytes 0–15, LE         |
//!
//! Pairing erases the block and programs the slot; unpairing only erases it (the key is gone
//! from the flash, not merely marked). An erased slot, or one that fails its CRC (a power cut
//! between the erase and the slot's last byte), loads as no key: signing off, which the
//! handshake reports, so the operator pairs again.
//!
//! The identification probe's profile ([`FlashLog::with_profile_block`]) has a block of its
//! own too, one slot at its start written the same way: bytes 0–35
//! [`crate::store::profile_to_bytes`] (schema id, eight f32 fill rates), 36–37 their
//! CRC-16. Storing one erases the block first, so a power cut mid-write leaves an erased or
//! torn slot: it loads as no profile (identification asks the operator), never as a mix of
//! the old and the new.
//!
//! One owner at a time drives the flash: while a state, key or profile save is under way (a
//! background erase, a slot programmed one byte per call), the others return
//! [`FlashError::Busy`] without touching it.

use crate::hw::StateStore;
use crate::store::{crc16, StoredState, PROFILE_LEN, STORED_LEN};

/// The board's data-flash layout (RA4M1: eight blocks of 1 KiB), as the board binary opens its
/// log and the simulator reads the emulated board's data flash: blocks 0 and 1 hold the state
/// log.
pub const STATE_LOG_FIRST_BLOCK: usize = 0;
/// Data-flash block 2 holds the link-signing key.
pub const LINK_KEY_BLOCK: usize = 2;
/// Data-flash block 3 holds the identification probe's calibration profile (blocks 4..7 are
/// free for later use; the on-target tests write 4–6).
pub const PROBE_PROFILE_BLOCK: usize = 3;

/// Bytes per slot.
pub const SLOT_LEN: usize = 16;
/// Bytes of a slot that are programmed (sequence, record, CRC).
const SLOT_USED: usize = 4 + STORED_LEN + 2;

/// A NOR flash with byte programming (bits only go 1 → 0) and block erase (all bytes → `0xFF`).
pub trait NorFlash {
    /// Erase block size in bytes.
    const BLOCK_SIZE: usize;
    /// Reads `buf.len()` bytes at `offset` (from the start of the flash region).
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), FlashError>;
    /// Programs `data` at `offset`; the bytes must be erased beforehand.
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), FlashError>;
    /// Erases block `block` (offset `block * BLOCK_SIZE`). It may return
    /// [`FlashError::Busy`] while the erase runs in the background; a call for the same block
    /// then reports whether it has ended (`Ok`, `Busy` or the erase's error).
    fn erase(&mut self, block: usize) -> Result<(), FlashError>;
}

/// Why a flash or log operation failed (no_std: small and `Copy`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlashError {
    /// The sequencer reported a program error.
    Program,
    /// The sequencer reported an erase error.
    Erase,
    /// The sequencer did not finish in time.
    Timeout,
    /// An offset outside the region.
    OutOfRange,
    /// Stored bytes are non-blank but no slot checks out, or the newest record does not decode.
    Corrupt,
    /// Read-back after programming differs from what was written.
    Verify,
    /// An operation runs in the background (a block erase): try again later.
    Busy,
    /// A previous save failed; the next attempt waits out its back-off ([`Backoff`]).
    BackingOff,
}

/// Which record's save drives the flash (the others wait: one sequencer, one write at a time).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Owner {
    State,
    Key,
    Profile,
}

/// Bytes of the probe-profile slot that are programmed (profile, CRC).
pub const PROFILE_SLOT_USED: usize = PROFILE_LEN + 2;

/// The most bytes one data-flash write programs.
const WRITE_MAX: usize = 16;

/// Slots in one block of `F`.
pub const fn slots_per_block(block_size: usize) -> usize {
    block_size / SLOT_LEN
}

/// Slots per block with the RA4M1's 1 KiB data-flash blocks.
pub const SLOTS_PER_BLOCK: usize = slots_per_block(1024);

/// What a slot holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    Blank,
    Torn,
    Valid { seq: u32, record: [u8; STORED_LEN] },
}

fn decode_slot(b: &[u8; SLOT_LEN]) -> Slot {
    if b.iter().all(|&x| x == 0xFF) {
        return Slot::Blank;
    }
    let crc = u16::from_le_bytes([b[12], b[13]]);
    if crc16(&b[..12]) != crc {
        return Slot::Torn;
    }
    let seq = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let mut record = [0u8; STORED_LEN];
    record.copy_from_slice(&b[4..4 + STORED_LEN]);
    Slot::Valid { seq, record }
}

/// Where the newest record is and where the next one goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Cursor {
    /// Newest valid record, if any.
    newest: Option<(u32, [u8; STORED_LEN])>,
    /// Any non-blank byte anywhere (to tell "never written" from "all torn").
    any_data: bool,
    /// Block and slot for the next append.
    next_block: usize,
    next_slot: usize,
}

/// A [`StateStore`] over two blocks of a [`NorFlash`] (blocks `first_block` and
/// `first_block + 1`).
#[derive(Debug)]
pub struct FlashLog<F> {
    flash: F,
    first_block: usize,
    cursor: Option<Cursor>,
    /// A block found blank (or erased) for the slot-0 write now under way: a write that
    /// returned `Busy` is retried without reading the block again (it is not readable while
    /// its byte is being programmed, and it is no longer blank).
    blank: Option<usize>,
    /// A block whose erase this log started and has not seen end: polled through `erase`
    /// until it ends, and then blank without reading it again (a 1 KiB blank check is 1 024
    /// data-flash reads over the flash's bus bridge: tens of thousands of cycles in one pass).
    erasing: Option<usize>,
    /// The link-key block (`None`: no key kept, [`StateStore::keeps_link_key`] false).
    key_block: Option<usize>,
    /// The probe-profile block (`None`: none kept).
    profile_block: Option<usize>,
    /// Where the key's or the profile's save under way is: 0 the erase, then `k` the `k`-th
    /// write of [`WRITE_MAX`] bytes (one owner at a time: see `owner`).
    slot_step: u8,
    /// The save under way (it returned `Busy`), which the other waits for.
    owner: Option<Owner>,
}

impl<F: NorFlash> FlashLog<F> {
    /// A log on blocks `first_block` and `first_block + 1` of `flash`.
    pub fn new(flash: F, first_block: usize) -> Self {
        Self {
            flash,
            first_block,
            cursor: None,
            blank: None,
            erasing: None,
            key_block: None,
            profile_block: None,
            slot_step: 0,
            owner: None,
        }
    }

    /// Keeps the link-signing key in block `block` (outside the state log's two).
    pub fn with_key_block(mut self, block: usize) -> Self {
        self.key_block = Some(block);
        self
    }

    /// Keeps the identification probe's profile in block `block` (outside the others).
    pub fn with_profile_block(mut self, block: usize) -> Self {
        self.profile_block = Some(block);
        self
    }

    /// Runs one attempt of `owner`'s save, unless the other's is under way; a `Busy` attempt
    /// keeps the flash for `owner` until it ends (done or failed).
    fn attempt(
        &mut self,
        owner: Owner,
        save: impl FnOnce(&mut Self) -> Result<(), FlashError>,
    ) -> Result<(), FlashError> {
        if self.owner.is_some_and(|o| o != owner) {
            return Err(FlashError::Busy);
        }
        let res = save(self);
        self.owner = (res == Err(FlashError::Busy)).then_some(owner);
        res
    }

    /// One attempt of a single-slot save (the key's, the profile's): the block erased (in the
    /// background), then `data` and its CRC programmed at the block's start, at most
    /// [`WRITE_MAX`] bytes a write, and read back. `None` only erases.
    fn write_slot(&mut self, block: usize, data: Option<&[u8]>) -> Result<(), FlashError> {
        if self.slot_step == 0 {
            self.flash.erase(block)?;
            self.slot_step = 1;
        }
        let Some(data) = data else {
            self.slot_step = 0;
            return Ok(());
        };
        let n = data.len() + 2;
        let mut slot = [0u8; PROFILE_SLOT_USED];
        slot[..data.len()].copy_from_slice(data);
        slot[data.len()..n].copy_from_slice(&crc16(data).to_le_bytes());
        let off = block * F::BLOCK_SIZE;
        let res = loop {
            let at = (self.slot_step as usize - 1) * WRITE_MAX;
            if at >= n {
                let mut back = [0u8; PROFILE_SLOT_USED];
                break self.flash.read(off, &mut back[..n]).and_then(|()| {
                    if back[..n] == slot[..n] {
                        Ok(())
                    } else {
                        Err(FlashError::Verify)
                    }
                });
            }
            match self.flash.write(off + at, &slot[at..n.min(at + WRITE_MAX)]) {
                Err(FlashError::Busy) => return Err(FlashError::Busy),
                Ok(()) => self.slot_step += 1,
                Err(e) => break Err(e),
            }
        };
        // Done, failed or torn: the next save starts with the erase.
        self.slot_step = 0;
        res
    }

    /// Reads the slot at `block`'s start into `data` (its data bytes; the CRC after them is
    /// checked): `Ok(false)` erased, `Corrupt` when the CRC fails (a torn save).
    #[inline(never)]
    fn read_single_slot(&mut self, block: usize, data: &mut [u8]) -> Result<bool, FlashError> {
        let n = data.len();
        let mut b = [0u8; PROFILE_SLOT_USED];
        self.flash.read(block * F::BLOCK_SIZE, &mut b[..n + 2])?;
        if b[..n + 2].iter().all(|&x| x == 0xFF) {
            return Ok(false);
        }
        data.copy_from_slice(&b[..n]);
        if crc16(data).to_le_bytes() != b[n..n + 2] {
            return Err(FlashError::Corrupt);
        }
        Ok(true)
    }

    fn slots(&self) -> usize {
        slots_per_block(F::BLOCK_SIZE)
    }

    fn slot_offset(&self, block: usize, slot: usize) -> usize {
        (self.first_block + block) * F::BLOCK_SIZE + slot * SLOT_LEN
    }

    fn read_slot(&mut self, block: usize, slot: usize) -> Result<[u8; SLOT_LEN], FlashError> {
        let mut b = [0u8; SLOT_LEN];
        let off = self.slot_offset(block, slot);
        self.flash.read(off, &mut b)?;
        Ok(b)
    }

    /// Scans both blocks (2 × slots reads; done once, then kept up to date by `save`).
    fn scan(&mut self) -> Result<Cursor, FlashError> {
        let mut newest: Option<(u32, [u8; STORED_LEN], usize)> = None;
        let mut any_data = false;
        // Last non-blank slot index per block: appends go right after it.
        let mut last_used = [None::<usize>; 2];
        for (block, last) in last_used.iter_mut().enumerate() {
            for slot in 0..self.slots() {
                let b = self.read_slot(block, slot)?;
                match decode_slot(&b) {
                    Slot::Blank => {}
                    Slot::Torn => {
                        any_data = true;
                        *last = Some(slot);
                    }
                    Slot::Valid { seq, record } => {
                        any_data = true;
                        *last = Some(slot);
                        if newest.is_none_or(|(s, _, _)| seq > s) {
                            newest = Some((seq, record, block));
                        }
                    }
                }
            }
        }
        let (next_block, next_slot) = match newest {
            // Append in the block that holds the newest record.
            Some((_, _, block)) => match last_used[block] {
                Some(s) if s + 1 < self.slots() => (block, s + 1),
                _ => (1 - block, self.slots()), // full: the next save switches blocks
            },
            None => (0, last_used[0].map_or(0, |s| s + 1).min(self.slots())),
        };
        Ok(Cursor {
            newest: newest.map(|(s, r, _)| (s, r)),
            any_data,
            next_block,
            next_slot,
        })
    }

    fn cursor(&mut self) -> Result<Cursor, FlashError> {
        match self.cursor {
            Some(c) => Ok(c),
            None => {
                let c = self.scan()?;
                self.cursor = Some(c);
                Ok(c)
            }
        }
    }

    fn block_is_blank(&mut self, block: usize) -> Result<bool, FlashError> {
        let mut buf = [0u8; 32];
        let start = (self.first_block + block) * F::BLOCK_SIZE;
        let mut off = 0;
        while off < F::BLOCK_SIZE {
            let n = buf.len().min(F::BLOCK_SIZE - off);
            self.flash.read(start + off, &mut buf[..n])?;
            if buf[..n].iter().any(|&x| x != 0xFF) {
                return Ok(false);
            }
            off += n;
        }
        Ok(true)
    }

    fn append(&mut self, state: &StoredState) -> Result<(), FlashError> {
        let c = self.cursor()?;
        let seq = c.newest.map_or(1, |(s, _)| s.wrapping_add(1));
        let (mut block, mut slot) = (c.next_block, c.next_slot);
        if slot >= self.slots() {
            // The current block is full (or the free slots of block 0 are used up by torn
            // writes): start the other block. The old block keeps the previous record until
            // the new one is written.
            block = if c.newest.is_some() { block } else { 1 - block };
            slot = 0;
        }
        if slot == 0 && self.blank != Some(block) {
            if self.erasing == Some(block) || !self.block_is_blank(block)? {
                // Busy while the erase runs in the background; a failed erase is started
                // again at the next attempt.
                self.erasing = Some(block);
                self.flash.erase(self.first_block + block)?;
            }
            self.erasing = None;
            self.blank = Some(block);
        }
        let mut b = [0xFFu8; SLOT_LEN];
        b[..4].copy_from_slice(&seq.to_le_bytes());
        b[4..4 + STORED_LEN].copy_from_slice(&state.to_bytes());
        let crc = crc16(&b[..12]).to_le_bytes();
        b[12] = crc[0];
        b[13] = crc[1];
        let off = self.slot_offset(block, slot);
        let next = if slot + 1 < self.slots() {
            (block, slot + 1)
        } else {
            (1 - block, self.slots())
        };
        // A failed or unverified program may have left this slot torn: the next append goes
        // to the slot after it, with the newest record unchanged. (A rescan would find the
        // same, but it reads every slot: milliseconds the loop cannot spare on each retry.)
        let skip = Cursor {
            any_data: true,
            next_block: next.0,
            next_slot: next.1,
            ..c
        };
        match self.flash.write(off, &b[..SLOT_USED]) {
            Ok(()) => {}
            // Under way (or a background erase still runs): retry the same slot and bytes.
            Err(FlashError::Busy) => return Err(FlashError::Busy),
            Err(e) => {
                self.blank = None;
                self.cursor = Some(skip);
                return Err(e);
            }
        }
        self.blank = None;
        let mut back = [0u8; SLOT_LEN];
        if let Err(e) = self.flash.read(off, &mut back) {
            self.cursor = Some(skip);
            return Err(e);
        }
        if back != b {
            self.cursor = Some(skip);
            return Err(FlashError::Verify);
        }
        self.cursor = Some(Cursor {
            newest: Some((seq, state.to_bytes())),
            any_data: true,
            next_block: next.0,
            next_slot: next.1,
        });
        Ok(())
    }
}

impl<F: NorFlash> StateStore for FlashLog<F> {
    type Error = FlashError;

    fn load(&mut self) -> Result<Option<StoredState>, FlashError> {
        let c = self.cursor()?;
        match c.newest {
            Some((_, record)) => StoredState::from_bytes(&record).map_err(|_| FlashError::Corrupt),
            None if c.any_data => Err(FlashError::Corrupt),
            None => Ok(None),
        }
    }

    fn save(&mut self, state: &StoredState) -> Result<(), FlashError> {
        self.attempt(Owner::State, |log| {
            // Saving what is already the newest record costs a slot for nothing.
            if let Ok(c) = log.cursor() {
                if c.newest.map(|(_, r)| r) == Some(state.to_bytes()) {
                    return Ok(());
                }
            }
            log.append(state)
        })
    }

    fn keeps_link_key(&self) -> bool {
        self.key_block.is_some()
    }

    fn load_link_key(&mut self) -> Result<Option<[u8; 16]>, FlashError> {
        let mut key = [0u8; 16];
        match self.key_block {
            Some(block) => Ok(self.read_single_slot(block, &mut key)?.then_some(key)),
            None => Ok(None),
        }
    }

    fn save_link_key(&mut self, key: Option<&[u8; 16]>) -> Result<(), FlashError> {
        let Some(block) = self.key_block else {
            return Err(FlashError::OutOfRange);
        };
        self.attempt(Owner::Key, |log| {
            log.write_slot(block, key.map(|k| k.as_slice()))
        })
    }

    fn keeps_probe_profile(&self) -> bool {
        self.profile_block.is_some()
    }

    fn load_probe_profile(&mut self) -> Result<Option<[u8; PROFILE_LEN]>, FlashError> {
        let mut p = [0u8; PROFILE_LEN];
        match self.profile_block {
            Some(block) => Ok(self.read_single_slot(block, &mut p)?.then_some(p)),
            None => Ok(None),
        }
    }

    fn save_probe_profile(
        &mut self,
        profile: Option<&[u8; PROFILE_LEN]>,
    ) -> Result<(), FlashError> {
        let Some(block) = self.profile_block else {
            return Err(FlashError::OutOfRange);
        };
        self.attempt(Owner::Profile, |log| {
            log.write_slot(block, profile.map(|p| p.as_slice()))
        })
    }
}

/// Retries a failing store with exponential back-off: after a failed save the next attempt
/// waits [`Backoff::FIRST_MS`], doubling up to [`Backoff::MAX_MS`]; meanwhile `save` returns
/// [`FlashError::BackingOff`] at once without touching the flash, so a broken flash costs the
/// loop one failed attempt per back-off period, not one per pass. [`FlashError::Busy`] (a
/// background erase) is not a failure: it is retried at the next call. The state's saves and
/// the link key's and the profile's back off apart (a failing key block never delays a step's journal). `now_ms`
/// is the board's millisecond clock.
#[derive(Debug)]
pub struct Backoff<S> {
    inner: S,
    now_ms: fn() -> u32,
    /// The state's saves' back-off, the key's and the profile's: the current wait and when it
    /// ends.
    waits: [(u32, u32); 3],
}

impl<S> Backoff<S> {
    /// First wait after a failure.
    pub const FIRST_MS: u32 = 50;
    /// Longest wait.
    pub const MAX_MS: u32 = 5_000;

    /// Wraps `inner`.
    pub fn new(inner: S, now_ms: fn() -> u32) -> Self {
        Self {
            inner,
            now_ms,
            waits: [(0, 0); 3],
        }
    }
}

impl<S> Backoff<S> {
    /// One attempt of `save` on the inner store (`which`: 0 the state's, 1 the key's, 2 the
    /// profile's), unless that save's back-off still runs.
    fn attempt(
        &mut self,
        which: usize,
        save: impl FnOnce(&mut S) -> Result<(), FlashError>,
    ) -> Result<(), FlashError> {
        let now = (self.now_ms)();
        let (wait_ms, next_ms) = &mut self.waits[which];
        if *wait_ms > 0 && (now.wrapping_sub(*next_ms) as i32) < 0 {
            return Err(FlashError::BackingOff);
        }
        match save(&mut self.inner) {
            Ok(()) => {
                *wait_ms = 0;
                Ok(())
            }
            Err(FlashError::Busy) => Err(FlashError::Busy),
            Err(e) => {
                *wait_ms = (*wait_ms * 2).clamp(Self::FIRST_MS, Self::MAX_MS);
                *next_ms = now.wrapping_add(*wait_ms);
                Err(e)
            }
        }
    }
}

impl<S: StateStore<Error = FlashError>> StateStore for Backoff<S> {
    type Error = FlashError;

    fn load(&mut self) -> Result<Option<StoredState>, FlashError> {
        self.inner.load()
    }

    fn save(&mut self, state: &StoredState) -> Result<(), FlashError> {
        self.attempt(0, |s| s.save(state))
    }

    fn keeps_link_key(&self) -> bool {
        self.inner.keeps_link_key()
    }

    fn load_link_key(&mut self) -> Result<Option<[u8; 16]>, FlashError> {
        self.inner.load_link_key()
    }

    fn save_link_key(&mut self, key: Option<&[u8; 16]>) -> Result<(), FlashError> {
        self.attempt(1, |s| s.save_link_key(key))
    }

    fn keeps_probe_profile(&self) -> bool {
        self.inner.keeps_probe_profile()
    }

    fn load_probe_profile(&mut self) -> Result<Option<[u8; PROFILE_LEN]>, FlashError> {
        self.inner.load_probe_profile()
    }

    fn save_probe_profile(
        &mut self,
        profile: Option<&[u8; PROFILE_LEN]>,
    ) -> Result<(), FlashError> {
        self.attempt(2, |s| s.save_probe_profile(profile))
    }
}
