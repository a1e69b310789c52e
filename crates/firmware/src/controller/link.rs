//! Link plumbing: the transmit queue and the last-response cache.

use protocol::{DeviceMessage, MAX_FRAME_LEN};

/// Bytes of the transmit queue.
pub const TX_QUEUE_LEN: usize = 2048;
/// Space kept free for responses: events are queued only when this much stays free after them,
/// so an answer never waits behind telemetry.
pub const RESPONSE_RESERVE: usize = 192;
/// Largest cached response frame (a `Status` response is under 100 bytes).
pub const CACHE_LEN: usize = 192;

/// A byte ring of encoded frames waiting for [`crate::Controller::poll_tx`].
#[derive(Debug, Clone)]
pub struct TxQueue {
    buf: [u8; TX_QUEUE_LEN],
    head: usize,
    len: usize,
    /// Frames not queued for lack of space.
    pub dropped: u32,
}

impl TxQueue {
    /// An empty queue.
    pub const fn new() -> Self {
        Self {
            buf: [0; TX_QUEUE_LEN],
            head: 0,
            len: 0,
            dropped: 0,
        }
    }

    /// Free bytes.
    pub fn free(&self) -> usize {
        TX_QUEUE_LEN - self.len
    }

    /// Bytes queued.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Nothing queued.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends a whole frame, or nothing (counted in `dropped`) if it does not fit with
    /// `reserve` bytes left over.
    pub fn push_frame(&mut self, frame: &[u8], reserve: usize) -> bool {
        if frame.len() + reserve > self.free() {
            self.dropped = self.dropped.wrapping_add(1);
            return false;
        }
        for &b in frame {
            let at = (self.head + self.len) % TX_QUEUE_LEN;
            self.buf[at] = b;
            self.len += 1;
        }
        true
    }

    /// Moves up to `out.len()` bytes out.
    pub fn pop_into(&mut self, out: &mut [u8]) -> usize {
        let n = out.len().min(self.len);
        for o in out.iter_mut().take(n) {
            *o = self.buf[self.head];
            self.head = (self.head + 1) % TX_QUEUE_LEN;
        }
        self.len -= n;
        n
    }
}

impl Default for TxQueue {
    fn default() -> Self {
        Self::new()
    }
}

/// Encodes a device message as one frame into `scratch`; returns its length (0 if it cannot be
/// encoded, which the message sizes rule out).
pub fn encode(msg: &DeviceMessage, scratch: &mut [u8; MAX_FRAME_LEN]) -> usize {
    protocol::encode_device_message(msg, scratch).unwrap_or(0)
}

/// The last response, kept to answer a retried request without executing it twice.
#[derive(Debug, Clone)]
pub struct ResponseCache {
    /// Sequence number of the request it answered.
    pub seq: u16,
    /// Fingerprint of that request's frame bytes (a retry is byte-identical).
    pub fingerprint: u32,
    /// The encoded response frame.
    pub frame: [u8; CACHE_LEN],
    /// Its length (0: nothing cached).
    pub len: usize,
}

impl ResponseCache {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            seq: 0,
            fingerprint: 0,
            frame: [0; CACHE_LEN],
            len: 0,
        }
    }

    /// The cached frame, when it answers the request `(seq, fingerprint)`.
    pub fn lookup(&self, seq: u16, fingerprint: u32) -> Option<&[u8]> {
        (self.len > 0 && self.seq == seq && self.fingerprint == fingerprint)
            .then(|| &self.frame[..self.len])
    }

    /// Remembers `frame` as the answer to `(seq, fingerprint)` (not cached if too long).
    pub fn store(&mut self, seq: u16, fingerprint: u32, frame: &[u8]) {
        if frame.len() <= CACHE_LEN {
            self.frame[..frame.len()].copy_from_slice(frame);
            self.len = frame.len();
            self.seq = seq;
            self.fingerprint = fingerprint;
        } else {
            self.len = 0;
        }
    }
}

impl Default for ResponseCache {
    fn default() -> Self {
        Self::new()
    }
}

/// FNV-1a over the bytes of the frame being received (delimiter excluded).
#[derive(Debug, Clone, Copy)]
pub struct Fingerprint(pub u32);

impl Fingerprint {
    /// The initial value.
    pub const START: Fingerprint = Fingerprint(0x811c_9dc5);

    /// Adds one byte.
    pub fn with(self, b: u8) -> Fingerprint {
        Fingerprint((self.0 ^ b as u32).wrapping_mul(0x0100_0193))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn queue_wraps_and_keeps_frames_whole() {
        let mut q = TxQueue::new();
        let frame = [7u8; 300];
        let mut pushed = 0;
        while q.push_frame(&frame, RESPONSE_RESERVE) {
            pushed += 1;
        }
        assert_eq!(pushed, (TX_QUEUE_LEN - RESPONSE_RESERVE) / 300);
        assert_eq!(q.dropped, 1);
        // Responses may use the reserve.
        assert!(q.push_frame(&[1u8; 100], 0));
        let mut out = [0u8; 1000];
        assert_eq!(q.pop_into(&mut out), 1000);
        assert!(q.push_frame(&[9u8; 900], 0));
        let mut total = 0;
        loop {
            let n = q.pop_into(&mut out);
            if n == 0 {
                break;
            }
            total += n;
        }
        assert_eq!(total, pushed * 300 + 100 - 1000 + 900);
    }

    #[test]
    fn cache_matches_seq_and_fingerprint() {
        let mut c = ResponseCache::new();
        assert!(c.lookup(0, 0).is_none());
        c.store(5, 42, &[1, 2, 3]);
        assert_eq!(c.lookup(5, 42), Some(&[1u8, 2, 3][..]));
        assert!(c.lookup(5, 43).is_none());
        assert!(c.lookup(6, 42).is_none());
        c.store(6, 1, &[0u8; CACHE_LEN + 1]);
        assert!(c.lookup(6, 1).is_none());
    }
}
