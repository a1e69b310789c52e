//! The link's debug trace (`-v`): every frame decoded, one line each, on the engine's clock —
//! `→ #12 GetStatus`, `← #12 ok Status{…} (3 ms)`, `← event Telemetry{…}` — with retries
//! marked (`retry 2 of #12, 300 ms after the first`), each response's round trip, and dropped
//! frames named. `-vv` adds each frame's bytes in hex. The words are `host::text`'s.

use std::collections::VecDeque;

use host::text;
use protocol::{DeviceMessage, FrameDecoder, FrameError, Request};

/// Requests remembered for retry marks and round trips (stop and wait: a handful is plenty).
const REMEMBERED: usize = 16;

/// One request the host sent.
#[derive(Debug, Clone, Copy)]
struct Sent {
    seq: u16,
    first_ms: u64,
    last_ms: u64,
    sends: u32,
}

/// The trace of one link: a decoder for the device's byte stream and the requests sent.
#[derive(Debug, Default)]
pub struct Trace {
    rx: FrameDecoder,
    sent: VecDeque<Sent>,
}

impl Trace {
    /// A trace when `-v` asks for one.
    pub fn if_asked() -> Option<Self> {
        crate::cli::debug().then(Self::default)
    }

    /// Lines for the frames of `bytes` written toward the device at `now_ms`.
    pub fn tx_lines(&mut self, now_ms: u64, bytes: &[u8]) -> Vec<String> {
        let mut lines = Vec::new();
        for frame in bytes.split(|b| *b == 0).filter(|f| !f.is_empty()) {
            let mut copy = frame.to_vec();
            copy.push(0);
            lines.push(match protocol::decode::<Request>(&mut copy) {
                Ok(req) => format!(
                    "{now_ms:>8} ms → {}{}",
                    text::request_line(&req),
                    self.sent(req.seq, now_ms)
                ),
                Err(e) => format!("{now_ms:>8} ms → an undecodable frame ({})", why(e)),
            });
        }
        if crate::cli::trace_bytes() {
            lines.push(format!("{now_ms:>8} ms → {}", hex(bytes)));
        }
        lines
    }

    /// Lines for the frames that `bytes`, read from the device at `now_ms`, complete.
    pub fn rx_lines(&mut self, now_ms: u64, bytes: &[u8]) -> Vec<String> {
        let mut lines = Vec::new();
        if crate::cli::trace_bytes() {
            lines.push(format!("{now_ms:>8} ms ← {}", hex(bytes)));
        }
        let decoded: Vec<_> = self.rx.feed::<DeviceMessage>(bytes).collect();
        for msg in decoded {
            lines.push(match msg {
                Ok(msg) => {
                    let took = match &msg {
                        DeviceMessage::Response { seq, .. } => self
                            .sent
                            .iter()
                            .rev()
                            .find(|s| s.seq == *seq)
                            .map_or(String::new(), |s| {
                                format!(" ({} ms)", now_ms.saturating_sub(s.last_ms))
                            }),
                        DeviceMessage::Event(_) => String::new(),
                    };
                    format!("{now_ms:>8} ms ← {}{took}", text::message_line(&msg))
                }
                Err(e) => format!("{now_ms:>8} ms ← a corrupt frame, dropped ({})", why(e)),
            });
        }
        lines
    }

    /// Notes a request sent; a repeat of the last one's sequence number is a retry.
    fn sent(&mut self, seq: u16, now_ms: u64) -> String {
        if let Some(s) = self.sent.back_mut().filter(|s| s.seq == seq) {
            s.sends += 1;
            s.last_ms = now_ms;
            return format!(
                " (retry {} of #{seq}, {} ms after the first)",
                s.sends - 1,
                now_ms.saturating_sub(s.first_ms)
            );
        }
        if self.sent.len() == REMEMBERED {
            self.sent.pop_front();
        }
        self.sent.push_back(Sent {
            seq,
            first_ms: now_ms,
            last_ms: now_ms,
            sends: 1,
        });
        String::new()
    }
}

/// Why a frame could not be read, in words.
fn why(e: FrameError) -> &'static str {
    match e {
        FrameError::TooLong => "too long",
        FrameError::Cobs => "broken COBS framing",
        FrameError::Crc => "CRC mismatch",
        FrameError::Legacy => "protocol v1's CRC-16: an older build",
        FrameError::Payload => "not a message of this protocol",
        FrameError::Empty => "empty",
    }
}

/// Bytes as `n bytes: 00 0a ff …` (`-vv`).
fn hex(bytes: &[u8]) -> String {
    let mut s = format!("{} bytes:", bytes.len());
    for b in bytes {
        s += &format!(" {b:02x}");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::{RequestBody, ResponseBody, ResultCode};

    fn frame<T: serde::Serialize>(msg: &T) -> Vec<u8> {
        let mut out = vec![0u8; protocol::MAX_FRAME_LEN];
        let n = protocol::encode(msg, &mut out).unwrap();
        out.truncate(n);
        out
    }

    #[test]
    fn retries_are_marked_and_responses_timed_across_split_reads() {
        let mut t = Trace::default();
        let req = frame(&Request {
            seq: 12,
            session: 3,
            body: RequestBody::GetStatus,
        });
        assert_eq!(t.tx_lines(100, &req), ["     100 ms → #12 GetStatus"]);
        assert_eq!(
            t.tx_lines(250, &req),
            ["     250 ms → #12 GetStatus (retry 1 of #12, 150 ms after the first)"]
        );
        let resp = frame(&DeviceMessage::Response {
            seq: 12,
            result: ResultCode::Busy,
            body: ResponseBody::None,
        });
        let (a, b) = resp.split_at(2);
        assert!(t.rx_lines(252, a).is_empty());
        assert_eq!(t.rx_lines(253, b), ["     253 ms ← #12 busy (3 ms)"]);
        let mut bad = resp.clone();
        bad[1] ^= 0x40;
        let lines = t.rx_lines(260, &bad);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].contains("a corrupt frame, dropped"), "{lines:?}");
    }
}
