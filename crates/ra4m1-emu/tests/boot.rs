//! The unmodified `uno-r4` ELF boots in the emulator and answers the protocol.

mod support;

use protocol::messages::{Board, DeviceMessage, RequestBody, ResponseBody};
use protocol::{FrameDecoder, PROTOCOL_VERSION, SCHEMA_ID};
use ra4m1_emu::Options;
use support::{board, send, wait_for};

#[test]
fn boots_and_answers_hello_and_status() {
    let mut emu = board(Options::default());
    let mut dec = FrameDecoder::default();
    // A host sends Hello from power-on and repeats it every 20 ms until answered (bytes that
    // arrive before SCI9 is set up are lost, as on the board).
    let mut answer = None;
    for _ in 0..100 {
        send(&mut emu, 1, RequestBody::hello());
        answer = wait_for(&mut emu, &mut dec, 20, |m| {
            matches!(m, DeviceMessage::Response { seq: 1, .. })
        });
        if answer.is_some() {
            break;
        }
    }
    let (hello, t_hello) = answer.expect("an answer to Hello within 2 s");
    let DeviceMessage::Response {
        body: ResponseBody::Hello(info),
        ..
    } = hello
    else {
        panic!("{hello:?}")
    };
    assert_eq!(info.protocol_version, PROTOCOL_VERSION);
    assert_eq!(info.schema_id, SCHEMA_ID);
    assert_eq!(info.board, Board::UnoR4Wifi);
    assert!(
        t_hello < 200,
        "boot to first answer took {t_hello} ms of virtual time"
    );
    send(&mut emu, 2, RequestBody::GetStatus);
    let (status, t) = wait_for(&mut emu, &mut dec, 500, |m| {
        matches!(m, DeviceMessage::Response { seq: 2, .. })
    })
    .expect("a status within 500 ms");
    let DeviceMessage::Response {
        body: ResponseBody::Status(s),
        ..
    } = status
    else {
        panic!("{status:?}")
    };
    eprintln!("hello at {t_hello} ms, status at {t} ms: {s:?}");
    // SysTick runs the controller's clock at 1 kHz: its uptime is the emulator's time less
    // the boot before SysTick started (and the answer's time on the wire).
    let uptime = u64::from(s.uptime_ms);
    assert!(
        uptime <= t && uptime + 10 >= t_hello,
        "uptime {uptime} ms, Hello answered at {t_hello} ms, status at {t} ms"
    );
    assert!(emu.resets().is_empty(), "no reset: {:?}", emu.resets());
    assert!(!s.inlet_open, "the inlet stays closed at boot");
    let stats = emu.stats();
    assert!(
        stats.wakes >= t - 10,
        "the loop sleeps in WFI and wakes every 1 ms: {stats:?}"
    );
}
