//! Shared by the firmware tests: where the `uno-r4` ELF is, and requests framed by hand.
//!
//! Deliberately not the host engine (`crates/host`): these tests time the board itself — a
//! Hello every 20 ms from power-on to find the first pass that answers, requests pipelined on
//! the line to measure the transmit rate, one status round trip to the microsecond — which a
//! stop-and-wait engine retrying every `RESPONSE_TIMEOUT_MS` cannot do.
#![allow(dead_code)] // each test binary uses a part of it

use std::path::PathBuf;

use firmware::pins::{self, PortPin};
use protocol::messages::{DeviceMessage, RequestBody};
use protocol::{encode, FrameDecoder, Request, MAX_FRAME_LEN};
use ra4m1_emu::{Emulator, Options};

/// The board ELF: `$UNO_R4_ELF`, else `cargo firmware`'s output in the workspace target dir.
pub fn elf_path() -> PathBuf {
    if let Some(p) = std::env::var_os("UNO_R4_ELF") {
        return PathBuf::from(p);
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or(root.join("target"), PathBuf::from);
    target.join("thumbv7em-none-eabihf/firmware/uno-r4")
}

/// The ELF's bytes; panics with the command that builds it.
pub fn elf() -> Vec<u8> {
    let p = elf_path();
    std::fs::read(&p).unwrap_or_else(|e| {
        panic!(
            "{}: {e}: build it first with `cargo firmware` (or set UNO_R4_ELF)",
            p.display()
        )
    })
}

/// `P<port><pin>` as the emulator's `(port, pin)`.
pub fn at(p: PortPin) -> (usize, usize) {
    (usize::from(p.port), usize::from(p.pin))
}

/// A booted emulator, the chip wired as the crane's board is (its display where the pin map
/// puts it, [`firmware::pins`]).
pub fn board(options: Options) -> Emulator {
    let options = Options {
        tm1637: Some((at(pins::TM_CLK.pin()), at(pins::TM_DIO.pin()))),
        ..options
    };
    Emulator::new(&elf(), options).expect("the ELF loads")
}

/// Sends a request.
pub fn send(emu: &mut Emulator, seq: u16, body: RequestBody) {
    let mut buf = [0u8; MAX_FRAME_LEN];
    // Session 0: the tests only shake hands and ask for the status (answered for anyone).
    let request = Request {
        seq,
        session: 0,
        body,
    };
    let n = encode(&request, &mut buf).expect("encodes");
    emu.host_send(&buf[..n]);
}

/// Runs in 1 ms steps for at most `max_ms`, decoding what the device sends, until `until`
/// holds for a message; returns it with the virtual time it arrived (ms).
pub fn wait_for(
    emu: &mut Emulator,
    dec: &mut FrameDecoder,
    max_ms: u64,
    mut until: impl FnMut(&DeviceMessage) -> bool,
) -> Option<(DeviceMessage, u64)> {
    let end = emu.now_ns() + max_ms * 1_000_000;
    while emu.now_ns() < end {
        let t = emu.now_ns() + 1_000_000;
        emu.run_until_ns(t)
            .unwrap_or_else(|e| panic!("emulator stopped: {e}"));
        for b in emu.host_take() {
            if let Some(Ok(m)) = dec.push::<DeviceMessage>(b) {
                if until(&m) {
                    return Some((m, emu.now_ns() / 1_000_000));
                }
            }
        }
    }
    None
}

/// Sends Hello every 20 ms until answered (bytes before SCI9 is up are lost); returns the
/// virtual time of the answer, ms.
pub fn handshake(emu: &mut Emulator, dec: &mut FrameDecoder) -> u64 {
    for _ in 0..100 {
        send(emu, 1, RequestBody::hello());
        if let Some((_, t)) = wait_for(emu, dec, 20, |m| {
            matches!(m, DeviceMessage::Response { seq: 1, .. })
        }) {
            return t;
        }
    }
    panic!("no answer to Hello within 2 s");
}
