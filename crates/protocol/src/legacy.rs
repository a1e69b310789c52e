//! Protocol v1's handshake refusal, so that a v2 device refuses a v1 host in words the v1 host
//! understands (v1 cannot read CRC-32 frames at all).
//!
//! A v1 frame is `COBS(postcard ‖ CRC-16/IBM-SDLC) ‖ 0x00`, and a v1 `Hello` is
//! `Request { seq, Hello { protocol_version, schema_id } }` without a session. The v2
//! [`FrameDecoder`](crate::FrameDecoder) names such a frame
//! [`FrameError::Legacy`](crate::FrameError::Legacy); [`refuse_v1_hello`] turns it into the v1
//! answer
//! `Response { seq, Rejected(VersionMismatch), Hello(DeviceInfo) }` with this device's
//! protocol version and schema identity, which a v1 host reports naming both versions.
//! Nothing else of v1 is spoken.

use serde::{Deserialize, Serialize};

use crate::messages::{Board, DeviceInfo, TrunkConfig};

#[derive(Deserialize)]
struct V1Request {
    seq: u16,
    body: V1RequestBody,
}

/// v1's `RequestBody`, up to its first variant (the others do not decode: not a Hello).
#[derive(Deserialize)]
enum V1RequestBody {
    Hello {
        #[allow(dead_code)] // read by the deserialiser only
        protocol_version: u16,
        #[allow(dead_code)]
        schema_id: u32,
    },
}

#[derive(Serialize)]
enum V1DeviceMessage {
    Response {
        seq: u16,
        result: V1ResultCode,
        body: V1ResponseBody,
    },
}

#[derive(Serialize)]
enum V1ResultCode {
    #[allow(dead_code)] // only its index matters: `Rejected` is variant 1
    Ok,
    Rejected(V1RejectReason),
}

#[derive(Serialize)]
enum V1RejectReason {
    VersionMismatch,
}

#[derive(Serialize)]
enum V1ResponseBody {
    #[allow(dead_code)] // only its index matters: `Hello` is variant 1
    None,
    Hello(V1DeviceInfo),
}

/// v1's `DeviceInfo`: v2's without `session` and `reset_cause`.
#[derive(Serialize)]
struct V1DeviceInfo {
    protocol_version: u16,
    schema_id: u32,
    firmware_version: [u8; 3],
    board: Board,
    trunk: TrunkConfig,
}

const V1_CRC: crc::Crc<u16, crc::NoTable> =
    crc::Crc::<u16, crc::NoTable>::new(&crc::CRC_16_IBM_SDLC);

/// When `raw` (an unstuffed frame with its CRC-16, as [`crate::FrameDecoder::last_frame`]
/// gives it after a [`crate::FrameError::Legacy`]) is a v1 `Hello`, writes the v1 refusal
/// carrying `info`'s versions into `out` as one v1 frame (delimiter included) and returns its
/// length; `None` for anything else.
pub fn refuse_v1_hello(raw: &[u8], info: &DeviceInfo, out: &mut [u8]) -> Option<usize> {
    let (payload, check) = raw.split_last_chunk::<2>()?;
    if V1_CRC.checksum(payload).to_le_bytes() != *check {
        return None;
    }
    let req: V1Request = postcard::from_bytes(payload).ok()?;
    let V1RequestBody::Hello { .. } = req.body;
    let msg = V1DeviceMessage::Response {
        seq: req.seq,
        result: V1ResultCode::Rejected(V1RejectReason::VersionMismatch),
        body: V1ResponseBody::Hello(V1DeviceInfo {
            protocol_version: info.protocol_version,
            schema_id: info.schema_id,
            firmware_version: info.firmware_version,
            board: info.board,
            trunk: info.trunk,
        }),
    };
    let mut raw_out = [0u8; 96];
    let used = postcard::to_slice(&msg, &mut raw_out[..94]).ok()?.len();
    let crc = V1_CRC.checksum(&raw_out[..used]).to_le_bytes();
    raw_out[used..used + 2].copy_from_slice(&crc);
    let n = cobs::try_encode(&raw_out[..used + 2], out).ok()?;
    if n >= out.len() {
        return None;
    }
    out[n] = 0;
    Some(n + 1)
}
