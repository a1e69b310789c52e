//! Framing over a byte stream: requests out, device messages in.
//!
//! [`Link`] owns the transport and a [`protocol::FrameDecoder`]. It knows nothing of sequence
//! numbers or retries (that is [`crate::session`]); it only turns bytes into messages and back,
//! and never panics on what the wire delivers: a corrupt frame is counted and dropped.

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use protocol::{DeviceMessage, FrameDecoder, Request, MAX_FRAME_LEN};

/// Counters of what the link saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Frames sent.
    pub frames_tx: u64,
    /// Frames received and decoded.
    pub frames_rx: u64,
    /// Frames received but dropped (corrupt, oversized, undecodable).
    pub frames_dropped: u64,
}

/// A framed, bidirectional link to a device over any byte transport.
pub struct Link<T> {
    io: T,
    decoder: FrameDecoder,
    inbox: VecDeque<DeviceMessage>,
    stats: LinkStats,
}

impl<T: Read + Write> Link<T> {
    /// A link over `io`. The transport's reads should block for a short time at most (a serial
    /// port with a few milliseconds of timeout, or a non-blocking in-memory stream).
    pub fn new(io: T) -> Self {
        Self {
            io,
            decoder: FrameDecoder::new(),
            inbox: VecDeque::new(),
            stats: LinkStats::default(),
        }
    }

    /// What the link saw so far.
    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    /// The transport, e.g. to write raw bytes in a test.
    #[cfg(test)]
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.io
    }

    /// Sends one request as a frame.
    ///
    /// The frame is preceded by a lone delimiter: whatever half frame or noise the device's
    /// decoder holds is closed (and dropped) first, so a request is never glued to garbage.
    pub fn send(&mut self, request: &Request) -> io::Result<()> {
        let mut buf = [0u8; MAX_FRAME_LEN + 1];
        let n = protocol::encode(request, &mut buf[1..]).map_err(|e| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("cannot encode request: {e:?}"),
            )
        })?;
        self.io.write_all(&buf[..n + 1])?;
        self.io.flush()?;
        self.stats.frames_tx += 1;
        Ok(())
    }

    /// The next message from the device, waiting until `deadline` at most; `None` when none
    /// arrived in time.
    pub fn recv(&mut self, deadline: Instant) -> io::Result<Option<DeviceMessage>> {
        loop {
            if let Some(msg) = self.inbox.pop_front() {
                return Ok(Some(msg));
            }
            let got = self.fill()?;
            if self.inbox.is_empty() && Instant::now() >= deadline {
                return Ok(None);
            }
            if got == 0 && self.inbox.is_empty() {
                // The transport returned at once with nothing: do not spin on it.
                std::thread::sleep(Duration::from_micros(500));
            }
        }
    }

    /// Reads what the transport has now (one read) and decodes it; returns the bytes read.
    fn fill(&mut self) -> io::Result<usize> {
        let mut buf = [0u8; 256];
        let n = match self.io.read(&mut buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) =>
            {
                0
            }
            Err(e) => return Err(e),
        };
        for &byte in &buf[..n] {
            match self.decoder.push::<DeviceMessage>(byte) {
                Some(Ok(msg)) => {
                    self.stats.frames_rx += 1;
                    self.inbox.push_back(msg);
                }
                Some(Err(protocol::FrameError::Empty)) | None => {}
                Some(Err(_)) => self.stats.frames_dropped += 1,
            }
        }
        Ok(n)
    }
}
