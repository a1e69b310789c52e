//! Fuzzes the message deserialisers behind the CRC: arbitrary payload bytes are framed with a
//! valid CRC-32 and COBS, so (unlike the `decoder` target, whose random frames almost never
//! pass the CRC) every input reaches postcard. A payload that decodes must re-encode to the
//! same bytes, or to a shorter canonical form of it (postcard also accepts over-long varints).
#![no_main]

use libfuzzer_sys::fuzz_target;
use protocol::{decode, encode, DeviceMessage, FrameDecoder, Request, MAX_FRAME_LEN, MAX_RAW_LEN};

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

fn check<T: serde::Serialize + serde::de::DeserializeOwned>(payload: &[u8], frame: &[u8]) {
    let mut dec = FrameDecoder::new();
    let got: Vec<_> = dec.feed::<T>(frame).collect();
    assert_eq!(got.len(), 1);
    assert_eq!(dec.stats().frames_ok + dec.stats().frames_dropped, 1);
    let mut copy = frame.to_vec();
    let one_shot = decode::<T>(&mut copy);
    assert_eq!(one_shot.is_ok(), got[0].is_ok());
    if let Ok(msg) = &got[0] {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(msg, &mut buf).expect("a decoded message fits a frame");
        assert!(n <= frame.len(), "re-encoding grew the frame");
        let mut raw = buf[..n].to_vec();
        let back: T = decode(&mut raw).expect("re-encoded frame decodes");
        let mut again = [0u8; MAX_FRAME_LEN];
        let m = encode(&back, &mut again).expect("fits");
        assert_eq!(&buf[..n], &again[..m], "encoding is not stable");
        if n == frame.len() {
            assert_eq!(
                &buf[..n],
                frame,
                "same length but different bytes: {payload:?}"
            );
        }
    }
}

fuzz_target!(|payload: &[u8]| {
    if payload.len() > MAX_RAW_LEN - 2 {
        return;
    }
    let mut raw = payload.to_vec();
    raw.extend(CRC.checksum(payload).to_le_bytes());
    let mut frame = vec![0u8; raw.len() + raw.len() / 254 + 2];
    let n = cobs::try_encode(&raw, &mut frame).expect("sized for the worst case");
    frame.truncate(n);
    frame.push(0);
    check::<Request>(payload, &frame);
    check::<DeviceMessage>(payload, &frame);
});
