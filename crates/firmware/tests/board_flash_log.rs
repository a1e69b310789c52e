//! The board's data-flash record log (`firmware::flash_log`, the UNO R4 binary's state store)
//! against an emulated NOR flash with the RA4M1 data flash's rules: 1 KiB erase blocks, byte
//! programming that only clears bits, programming a non-erased byte is an error, and a power
//! cut that stops after any number of programmed bytes.

use firmware::flash_log::{FlashError, FlashLog, NorFlash, SLOTS_PER_BLOCK};
use firmware::hw::StateStore;
use firmware::StoredState;
use geometry::TrunkState;

const BLOCK: usize = 1024;
const BLOCKS: usize = 8;

/// RA4M1-like data flash: 8 blocks of 1 KiB, erased = 0xFF.
struct EmuFlash {
    mem: Vec<u8>,
    erases: [u32; BLOCKS],
    /// Bytes that may still be programmed before the "power cut" (None = unlimited).
    budget: Option<usize>,
}

impl EmuFlash {
    fn new() -> Self {
        Self {
            mem: vec![0xFF; BLOCK * BLOCKS],
            erases: [0; BLOCKS],
            budget: None,
        }
    }
}

impl NorFlash for &mut EmuFlash {
    const BLOCK_SIZE: usize = BLOCK;
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        let src = self
            .mem
            .get(offset..offset + buf.len())
            .ok_or(FlashError::OutOfRange)?;
        buf.copy_from_slice(src);
        Ok(())
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), FlashError> {
        if offset + data.len() > self.mem.len() {
            return Err(FlashError::OutOfRange);
        }
        for (i, &d) in data.iter().enumerate() {
            if let Some(b) = self.budget.as_mut() {
                if *b == 0 {
                    return Err(FlashError::Timeout); // power gone mid-write
                }
                *b -= 1;
            }
            if self.mem[offset + i] != 0xFF {
                return Err(FlashError::Program);
            }
            self.mem[offset + i] = d;
        }
        Ok(())
    }
    fn erase(&mut self, block: usize) -> Result<(), FlashError> {
        if block >= BLOCKS {
            return Err(FlashError::OutOfRange);
        }
        if let Some(b) = self.budget {
            if b == 0 {
                return Err(FlashError::Timeout);
            }
        }
        self.mem[block * BLOCK..(block + 1) * BLOCK].fill(0xFF);
        self.erases[block] += 1;
        Ok(())
    }
}

fn st(i: usize, confirmed: bool) -> StoredState {
    let state = TrunkState::ALL[i % TrunkState::ALL.len()];
    if confirmed {
        StoredState::confirmed(state)
    } else {
        // A journaled step: pending toward the next state, both candidates.
        let to = TrunkState::ALL[(i + 1) % TrunkState::ALL.len()];
        StoredState {
            state,
            confirmed: false,
            candidates: protocol::StateSet::single(state).with(to),
            pending: Some(protocol::Transition { from: state, to }),
        }
    }
}

#[test]
fn erased_flash_loads_as_nothing_stored() {
    let mut f = EmuFlash::new();
    let mut log = FlashLog::new(&mut f, 0);
    assert_eq!(log.load(), Ok(None));
}

#[test]
fn each_save_is_loaded_back_after_a_reset() {
    let mut f = EmuFlash::new();
    for i in 0..300 {
        let s = st(i, i % 3 != 0);
        FlashLog::new(&mut f, 0).save(&s).unwrap();
        // A fresh log is what the board sees after a reset: it rescans the flash.
        assert_eq!(FlashLog::new(&mut f, 0).load(), Ok(Some(s)), "save {i}");
    }
}

#[test]
fn wear_is_one_erase_per_block_of_saves_and_spread_over_both_blocks() {
    let mut f = EmuFlash::new();
    let saves = 10 * SLOTS_PER_BLOCK;
    {
        let mut log = FlashLog::new(&mut f, 2);
        for i in 0..saves {
            // Alternate states so that no save is skipped as a duplicate.
            log.save(&st(i % 2, true)).unwrap();
        }
    }
    // Blocks 2 and 3 hold the log; the first fill of each needs no erase.
    let total: u32 = f.erases.iter().sum();
    assert_eq!(
        total as usize,
        saves / SLOTS_PER_BLOCK - 2,
        "erases {:?}",
        f.erases
    );
    assert!(
        f.erases[2].abs_diff(f.erases[3]) <= 1,
        "erases {:?}",
        f.erases
    );
    assert_eq!(
        f.erases[0] + f.erases[1] + f.erases[4..].iter().sum::<u32>(),
        0
    );
}

#[test]
fn saving_the_same_state_twice_costs_no_slot() {
    let mut f = EmuFlash::new();
    {
        let mut log = FlashLog::new(&mut f, 0);
        log.save(&st(1, true)).unwrap();
        log.save(&st(1, true)).unwrap();
    }
    let used = f.mem[..BLOCK]
        .chunks(16)
        .filter(|c| c.iter().any(|&b| b != 0xFF))
        .count();
    assert_eq!(used, 1);
}

#[test]
fn a_power_cut_at_any_byte_keeps_the_previous_or_the_new_record() {
    // Cut power after every possible number of programmed bytes of the save that also has to
    // switch blocks (the worst case: erase + first write in the other block).
    for budget in 0..=14 {
        let mut f = EmuFlash::new();
        {
            let mut log = FlashLog::new(&mut f, 0);
            for i in 0..SLOTS_PER_BLOCK {
                log.save(&st(i % 2, true)).unwrap();
            }
        }
        let before = FlashLog::new(&mut f, 0).load().unwrap();
        let new = st(4, false);
        f.budget = Some(budget);
        let res = FlashLog::new(&mut f, 0).save(&new);
        f.budget = None;
        let after = FlashLog::new(&mut f, 0).load().unwrap();
        if res.is_ok() {
            assert_eq!(after, Some(new), "budget {budget}");
        } else {
            assert!(
                after == before || after == Some(new),
                "budget {budget}: {after:?}"
            );
        }
        // And the log keeps working after the cut.
        let next = st(5, true);
        FlashLog::new(&mut f, 0).save(&next).unwrap();
        assert_eq!(
            FlashLog::new(&mut f, 0).load(),
            Ok(Some(next)),
            "budget {budget}"
        );
    }
}

#[test]
fn garbage_without_a_valid_slot_is_reported_corrupt() {
    let mut f = EmuFlash::new();
    f.mem[5] = 0x12; // a torn slot and nothing else
    assert_eq!(FlashLog::new(&mut f, 0).load(), Err(FlashError::Corrupt));
    // A save still succeeds, and then loads.
    FlashLog::new(&mut f, 0).save(&st(2, true)).unwrap();
    assert_eq!(FlashLog::new(&mut f, 0).load(), Ok(Some(st(2, true))));
}

#[test]
fn a_slot_written_by_the_older_firmware_still_loads() {
    // Pinned bytes of one slot (sequence 7, a confirmed `D&F` record: index 4) as written before
    // the CRC moved to the `crc` crate: the on-flash format must not change.
    let mut f = EmuFlash::new();
    f.mem[..16].copy_from_slice(&[
        7, 0, 0, 0, b'Y', b'C', 1, 4, 1, 0, 0x99, 0x50, 0x25, 0x59, 0xFF, 0xFF,
    ]);
    let loaded = FlashLog::new(&mut f, 0).load().unwrap().unwrap();
    assert_eq!(loaded.state, TrunkState::from_index(4).unwrap());
    assert!(loaded.confirmed);
}

/// The link-key slot (block 2, as the board binary has it).
mod link_key {
    use super::*;

    const KEY_BLOCK: usize = 2;
    const KEY: [u8; 16] = *b"crane-test-key-1";

    fn log(f: &mut EmuFlash) -> FlashLog<&mut EmuFlash> {
        FlashLog::new(f, 0).with_key_block(KEY_BLOCK)
    }

    fn key_block(f: &EmuFlash) -> &[u8] {
        &f.mem[KEY_BLOCK * BLOCK..(KEY_BLOCK + 1) * BLOCK]
    }

    #[test]
    fn a_paired_key_loads_after_a_reset_and_unpairing_erases_its_block() {
        let mut f = EmuFlash::new();
        assert!(log(&mut f).keeps_link_key());
        assert_eq!(log(&mut f).load_link_key(), Ok(None), "erased: signing off");
        log(&mut f).save(&st(1, true)).unwrap();
        log(&mut f).save_link_key(Some(&KEY)).unwrap();
        assert_eq!(log(&mut f).load_link_key(), Ok(Some(KEY)));
        // Pinned: the key, then its CRC-16/CCITT-FALSE little-endian, the rest erased.
        let crc = firmware::store::crc16(&KEY).to_le_bytes();
        assert_eq!(&key_block(&f)[..16], &KEY);
        assert_eq!(&key_block(&f)[16..18], &crc);
        assert!(key_block(&f)[18..].iter().all(|&b| b == 0xFF));
        // Re-pairing replaces it; the state log is untouched by either.
        let other = *b"crane-test-key-2";
        log(&mut f).save_link_key(Some(&other)).unwrap();
        assert_eq!(log(&mut f).load_link_key(), Ok(Some(other)));
        assert_eq!(log(&mut f).load(), Ok(Some(st(1, true))));
        log(&mut f).save_link_key(None).unwrap();
        assert!(key_block(&f).iter().all(|&b| b == 0xFF), "the key is gone");
        assert_eq!(log(&mut f).load_link_key(), Ok(None));
        assert_eq!(f.erases[KEY_BLOCK], 3);
        assert_eq!(log(&mut f).load(), Ok(Some(st(1, true))));
        // A log without a key block keeps none (the controller then refuses pairing).
        let mut bare = FlashLog::new(&mut f, 0);
        assert!(!bare.keeps_link_key());
        assert_eq!(bare.load_link_key(), Ok(None));
        assert!(bare.save_link_key(Some(&KEY)).is_err());
    }

    #[test]
    fn a_power_cut_at_any_byte_of_a_pairing_leaves_the_old_key_the_new_one_or_none() {
        let new = *b"crane-test-key-2";
        for budget in 0..=18 {
            let mut f = EmuFlash::new();
            log(&mut f).save_link_key(Some(&KEY)).unwrap();
            f.budget = Some(budget);
            let res = log(&mut f).save_link_key(Some(&new));
            f.budget = None;
            let after = log(&mut f).load_link_key();
            match res {
                Ok(()) => assert_eq!(after, Ok(Some(new)), "budget {budget}"),
                // Cut before the erase: the old key; after it: none (erased, or torn and
                // failing its CRC): signing off, never a key nobody paired.
                Err(_) => assert!(
                    matches!(after, Ok(None) | Err(FlashError::Corrupt))
                        || after == Ok(Some(KEY))
                        || after == Ok(Some(new)),
                    "budget {budget}: {after:?}"
                ),
            }
            if budget > 0 && budget < 18 {
                assert!(
                    matches!(after, Ok(None) | Err(FlashError::Corrupt)),
                    "budget {budget}: a torn slot is no key: {after:?}"
                );
            }
            // Pairing again after the cut works.
            log(&mut f).save_link_key(Some(&new)).unwrap();
            assert_eq!(
                log(&mut f).load_link_key(),
                Ok(Some(new)),
                "budget {budget}"
            );
        }
    }

    /// The board's flash: an erase runs in the background and a write programs one byte per
    /// call, both `Busy` until done (`board/dataflash.rs`); a write of other bytes while one
    /// is under way is refused, as there.
    struct Paced<'a> {
        f: &'a mut EmuFlash,
        erasing: Option<usize>,
        writing: Option<(usize, Vec<u8>, usize)>,
        calls: usize,
    }

    impl NorFlash for Paced<'_> {
        const BLOCK_SIZE: usize = BLOCK;
        fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), FlashError> {
            if self.erasing.is_some() || self.writing.is_some() {
                return Err(FlashError::Busy);
            }
            (&mut *self.f).read(offset, buf)
        }
        fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), FlashError> {
            self.calls += 1;
            if self.erasing.is_some() {
                return Err(FlashError::Busy);
            }
            let (o, d, next) = self.writing.take().unwrap_or((offset, data.to_vec(), 0));
            if o != offset || d != data {
                return Err(FlashError::Program);
            }
            if next == d.len() {
                return Ok(());
            }
            (&mut *self.f).write(o + next, &d[next..next + 1])?;
            self.writing = Some((o, d, next + 1));
            Err(FlashError::Busy)
        }
        fn erase(&mut self, block: usize) -> Result<(), FlashError> {
            self.calls += 1;
            match self.erasing {
                Some(b) if b == block => {
                    self.erasing = None;
                    (&mut *self.f).erase(block)
                }
                Some(_) => Err(FlashError::Busy),
                None if self.writing.is_some() => Err(FlashError::Busy),
                None => {
                    self.erasing = Some(block);
                    Err(FlashError::Busy)
                }
            }
        }
    }

    /// Calls `op` until it is not `Busy` (at most 100 calls); the calls it took.
    fn until_done(mut op: impl FnMut() -> Result<(), FlashError>) -> usize {
        for n in 1..=100 {
            match op() {
                Err(FlashError::Busy) => {}
                r => {
                    assert_eq!(r, Ok(()));
                    return n;
                }
            }
        }
        panic!("still busy after 100 calls");
    }

    #[test]
    fn a_key_save_waits_for_a_state_save_under_way_and_the_other_way_round() {
        let mut f = EmuFlash::new();
        let mut log = FlashLog::new(
            Paced {
                f: &mut f,
                erasing: None,
                writing: None,
                calls: 0,
            },
            0,
        )
        .with_key_block(KEY_BLOCK);
        // A state save starts (its slot programmed one byte per call) ...
        assert_eq!(log.save(&st(3, false)), Err(FlashError::Busy));
        // ... and a key save meanwhile waits, leaving the flash alone.
        for _ in 0..5 {
            assert_eq!(log.save_link_key(Some(&KEY)), Err(FlashError::Busy));
            assert_eq!(log.save(&st(3, false)), Err(FlashError::Busy));
        }
        until_done(|| log.save(&st(3, false)));
        // Now the key's save: an erase, then 18 bytes; a state save waits for it.
        assert_eq!(log.save_link_key(Some(&KEY)), Err(FlashError::Busy));
        assert_eq!(log.save(&st(4, true)), Err(FlashError::Busy));
        let n = until_done(|| log.save_link_key(Some(&KEY)));
        assert!(n >= 18, "one byte per call: {n} calls");
        until_done(|| log.save(&st(4, true)));
        assert_eq!(log.load_link_key(), Ok(Some(KEY)));
        assert_eq!(log.load(), Ok(Some(st(4, true))));
        drop(log);
        // Both records as a fresh boot reads them.
        let mut boot = FlashLog::new(&mut f, 0).with_key_block(KEY_BLOCK);
        assert_eq!(boot.load(), Ok(Some(st(4, true))));
        assert_eq!(boot.load_link_key(), Ok(Some(KEY)));
    }
}

mod backoff {
    use super::*;
    use firmware::flash_log::Backoff;
    use std::sync::atomic::{AtomicU32, Ordering};

    static NOW: AtomicU32 = AtomicU32::new(0);
    fn now() -> u32 {
        NOW.load(Ordering::Relaxed)
    }

    /// A store whose saves fail (or report a background erase) as told, counting attempts.
    struct Flaky {
        result: Result<(), FlashError>,
        attempts: u32,
    }

    impl StateStore for Flaky {
        type Error = FlashError;
        fn load(&mut self) -> Result<Option<StoredState>, FlashError> {
            Ok(None)
        }
        fn save(&mut self, _: &StoredState) -> Result<(), FlashError> {
            self.attempts += 1;
            self.result
        }
    }

    /// A store whose key block is broken: its key saves fail, its state saves succeed.
    struct BrokenKeyBlock {
        state_saves: u32,
        key_saves: u32,
    }

    impl StateStore for BrokenKeyBlock {
        type Error = FlashError;
        fn load(&mut self) -> Result<Option<StoredState>, FlashError> {
            Ok(None)
        }
        fn save(&mut self, _: &StoredState) -> Result<(), FlashError> {
            self.state_saves += 1;
            Ok(())
        }
        fn keeps_link_key(&self) -> bool {
            true
        }
        fn save_link_key(&mut self, _: Option<&[u8; 16]>) -> Result<(), FlashError> {
            self.key_saves += 1;
            Err(FlashError::Erase)
        }
    }

    /// Its own clock: the tests run in parallel.
    static KEY_NOW: AtomicU32 = AtomicU32::new(0);
    fn key_now() -> u32 {
        KEY_NOW.load(Ordering::Relaxed)
    }

    #[test]
    fn a_failing_key_save_backs_off_without_delaying_the_state_saves() {
        let s = StoredState::confirmed(TrunkState::AS_MANUFACTURED);
        KEY_NOW.store(500, Ordering::Relaxed);
        let mut b = Backoff::new(
            BrokenKeyBlock {
                state_saves: 0,
                key_saves: 0,
            },
            key_now,
        );
        assert!(b.keeps_link_key());
        assert_eq!(b.save_link_key(Some(&[7; 16])), Err(FlashError::Erase));
        assert_eq!(b.save_link_key(Some(&[7; 16])), Err(FlashError::BackingOff));
        // The state's saves go on at once, every pass.
        for t in 501..510 {
            KEY_NOW.store(t, Ordering::Relaxed);
            assert_eq!(b.save(&s), Ok(()));
        }
        // And do not reset the key's back-off: it still waits out its 50 ms, then doubles.
        KEY_NOW.store(549, Ordering::Relaxed);
        assert_eq!(b.save_link_key(Some(&[7; 16])), Err(FlashError::BackingOff));
        KEY_NOW.store(550, Ordering::Relaxed);
        assert_eq!(b.save_link_key(Some(&[7; 16])), Err(FlashError::Erase));
        KEY_NOW.store(649, Ordering::Relaxed);
        assert_eq!(b.save_link_key(Some(&[7; 16])), Err(FlashError::BackingOff));
        assert_eq!(b.save(&s), Ok(()));
    }

    #[test]
    fn a_failing_save_is_retried_with_doubling_waits_and_busy_is_not_a_failure() {
        let s = StoredState::confirmed(TrunkState::AS_MANUFACTURED);
        NOW.store(1_000, Ordering::Relaxed);
        let mut b = Backoff::new(
            Flaky {
                result: Err(FlashError::Program),
                attempts: 0,
            },
            now,
        );
        assert_eq!(b.save(&s), Err(FlashError::Program));
        // Every pass for the next 50 ms: refused at once, the flash untouched.
        for t in [1_001, 1_025, 1_049] {
            NOW.store(t, Ordering::Relaxed);
            assert_eq!(b.save(&s), Err(FlashError::BackingOff));
        }
        NOW.store(1_050, Ordering::Relaxed);
        assert_eq!(b.save(&s), Err(FlashError::Program)); // second attempt
        NOW.store(1_149, Ordering::Relaxed);
        assert_eq!(b.save(&s), Err(FlashError::BackingOff)); // now 100 ms
        NOW.store(1_150, Ordering::Relaxed);
        assert_eq!(b.save(&s), Err(FlashError::Program));
        // The wait doubles up to 5 s.
        let mut t = 1_150;
        for _ in 0..10 {
            NOW.store(t + 5_000, Ordering::Relaxed);
            let _ = b.save(&s);
            t += 5_000;
        }
        NOW.store(t + 4_999, Ordering::Relaxed);
        assert_eq!(b.save(&s), Err(FlashError::BackingOff));
        // A background erase is retried at the next call, without a wait.
        let mut busy = Backoff::new(
            Flaky {
                result: Err(FlashError::Busy),
                attempts: 0,
            },
            now,
        );
        assert_eq!(busy.save(&s), Err(FlashError::Busy));
        assert_eq!(busy.save(&s), Err(FlashError::Busy));
        // Success clears the back-off.
        let mut ok = Backoff::new(
            Flaky {
                result: Ok(()),
                attempts: 0,
            },
            now,
        );
        assert_eq!(ok.save(&s), Ok(()));
        assert_eq!(ok.save(&s), Ok(()));
    }
}
