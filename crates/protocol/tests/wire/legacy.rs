//! A v1 host's Hello gets a v1 refusal naming this device's version.

use protocol::*;
use serde::Deserialize;

// The v1 wire types as a v1 host reads them (its messages.rs, v1 fields only).
#[derive(Debug, Deserialize, PartialEq)]
enum V1DeviceMessage {
    Response {
        seq: u16,
        result: V1ResultCode,
        body: V1ResponseBody,
    },
}
#[derive(Debug, Deserialize, PartialEq)]
enum V1ResultCode {
    Ok,
    Rejected(V1RejectReason),
}
#[derive(Debug, Deserialize, PartialEq)]
enum V1RejectReason {
    VersionMismatch,
}
#[derive(Debug, Deserialize, PartialEq)]
enum V1ResponseBody {
    None,
    Hello(V1DeviceInfo),
}
#[derive(Debug, Deserialize, PartialEq)]
struct V1DeviceInfo {
    protocol_version: u16,
    schema_id: u32,
    firmware_version: [u8; 3],
    board: Board,
    trunk: TrunkConfig,
}

fn v1_crc() -> crc::Crc<u16> {
    crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC)
}

fn v1_frame(payload: &[u8]) -> Vec<u8> {
    let mut raw = payload.to_vec();
    raw.extend(v1_crc().checksum(payload).to_le_bytes());
    let mut out = vec![0u8; raw.len() + 2];
    let n = cobs::try_encode(&raw, &mut out).unwrap();
    out.truncate(n);
    out.push(0);
    out
}

fn info() -> DeviceInfo {
    let m = ModuleConfig {
        n: 6,
        beta_deg: 35.0,
        edge_mm: 40.0,
        layers: 3,
    };
    DeviceInfo {
        protocol_version: PROTOCOL_VERSION,
        schema_id: SCHEMA_ID,
        firmware_version: [0, 2, 0],
        board: Board::Simulator,
        trunk: TrunkConfig {
            bottom: m,
            top: m,
            pressure_limit_kpa: 40.0,
        },
        session: 0,
        reset_cause: ResetCause::PowerOn,
        signing: false,
    }
}

#[test]
fn a_v1_hello_gets_a_v1_refusal_with_this_devices_versions() {
    // v1 Hello: seq 258, variant 0, version 1, schema 0x221ee9a8 (v1's last SCHEMA_ID).
    let frame = v1_frame(&[0x82, 0x02, 0x00, 0x01, 0xa8, 0xd3, 0xfb, 0x90, 0x02]);
    let mut dec = FrameDecoder::new();
    let got: Vec<_> = dec.feed::<Request>(&frame).collect();
    assert_eq!(got, vec![Err(FrameError::Legacy)]);
    let mut out = [0u8; 128];
    let n = legacy::refuse_v1_hello(dec.last_frame(), &info(), &mut out).expect("a v1 Hello");
    assert_eq!(out[n - 1], 0);
    // What the v1 host decodes.
    let mut stuffed = out[..n - 1].to_vec();
    let m = cobs::decode_in_place(&mut stuffed).unwrap();
    let (payload, check) = stuffed[..m].split_last_chunk::<2>().unwrap();
    assert_eq!(v1_crc().checksum(payload).to_le_bytes(), *check);
    let msg: V1DeviceMessage = postcard::from_bytes(payload).unwrap();
    let V1DeviceMessage::Response { seq, result, body } = msg;
    assert_eq!(seq, 258);
    assert_eq!(
        result,
        V1ResultCode::Rejected(V1RejectReason::VersionMismatch)
    );
    let V1ResponseBody::Hello(i) = body else {
        panic!("{body:?}")
    };
    assert_eq!((i.protocol_version, i.schema_id), (2, SCHEMA_ID));
    assert_eq!(i.firmware_version, [0, 2, 0]);
}

#[test]
fn anything_else_of_v1_gets_no_answer() {
    let mut out = [0u8; 128];
    // A v1 GetStatus (seq 1, variant 1).
    let frame = v1_frame(&[0x01, 0x01]);
    let mut dec = FrameDecoder::new();
    assert_eq!(
        dec.feed::<Request>(&frame).collect::<Vec<_>>(),
        vec![Err(FrameError::Legacy)]
    );
    assert_eq!(
        legacy::refuse_v1_hello(dec.last_frame(), &info(), &mut out),
        None
    );
    // Garbage, and a v2 frame.
    assert_eq!(legacy::refuse_v1_hello(&[1, 2, 3], &info(), &mut out), None);
    assert_eq!(legacy::refuse_v1_hello(&[], &info(), &mut out), None);
    // A short output buffer: no answer, no panic.
    let frame = v1_frame(&[0x01, 0x00, 0x01, 0x05]);
    let mut dec = FrameDecoder::new();
    let _ = dec.feed::<Request>(&frame).count();
    assert_eq!(
        legacy::refuse_v1_hello(dec.last_frame(), &info(), &mut out[..8]),
        None
    );
    assert!(legacy::refuse_v1_hello(dec.last_frame(), &info(), &mut out).is_some());
}
