//! Fuzzes the frame decoders with arbitrary bytes: the streaming decoder (both message
//! directions, byte by byte and in chunks) and the one-shot `decode`. Checks, beyond "no
//! panic": every non-empty delimiter-terminated segment is counted exactly once, any message
//! that does decode re-encodes into a frame that decodes to the same message, and after the
//! garbage a valid frame still decodes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use protocol::{
    decode, encode, DeviceMessage, Event, FaultCode, FrameDecoder, FrameError, Request,
    MAX_FRAME_LEN,
};

fn reencodes<T: serde_like::Msg>(msg: &T) {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).expect("a decoded message fits a frame");
    let back: T = decode(&mut buf[..n]).expect("re-encoded frame decodes");
    // Floats may be NaN (NaN != NaN), so compare the wire bytes instead of the values.
    let mut again = [0u8; MAX_FRAME_LEN];
    let m = encode(&back, &mut again).expect("fits");
    assert_eq!(&buf[..n], &again[..m]);
}

mod serde_like {
    /// The two message directions.
    pub trait Msg: serde::Serialize + serde::de::DeserializeOwned {}
    impl Msg for protocol::Request {}
    impl Msg for protocol::DeviceMessage {}
}

fn stream<T: serde_like::Msg>(data: &[u8], chunk: usize) {
    let mut dec = FrameDecoder::new();
    let mut results = 0usize;
    for part in data.chunks(chunk.max(1)) {
        for r in dec.feed::<T>(part) {
            results += 1;
            if let Ok(msg) = r {
                reencodes(&msg);
            }
        }
    }
    let segments = data.split(|&b| b == 0).count() - 1;
    let nonempty = data
        .split(|&b| b == 0)
        .take(segments)
        .filter(|s| !s.is_empty())
        .count();
    assert_eq!(results, nonempty);
    let s = dec.stats();
    assert_eq!((s.frames_ok + s.frames_dropped) as usize, nonempty);
}

fuzz_target!(|data: &[u8]| {
    let chunk = data.first().map_or(1, |&b| b as usize);
    stream::<Request>(data, chunk);
    stream::<DeviceMessage>(data, 1);

    let mut copy = data.to_vec();
    if let Ok(msg) = decode::<Request>(&mut copy) {
        reencodes(&msg);
    }

    // After any garbage plus one delimiter, a valid frame decodes.
    let mut dec = FrameDecoder::new();
    for &b in data {
        let _ = dec.push::<DeviceMessage>(b);
    }
    let msg = DeviceMessage::Event(Event::FaultRaised(FaultCode::Leak));
    let mut frame = [0u8; MAX_FRAME_LEN + 1];
    frame[0] = 0;
    let n = encode(&msg, &mut frame[1..]).expect("fits");
    let mut last: Option<Result<DeviceMessage, FrameError>> = None;
    for &b in &frame[..n + 1] {
        if let Some(r) = dec.push(b) {
            last = Some(r);
        }
    }
    assert_eq!(last, Some(Ok(msg)));
});
