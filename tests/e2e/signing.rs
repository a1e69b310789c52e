//! Link signing through the binaries: `host-tool signing pair` over `hil-sim --pty`, a command
//! without the key refused and with it obeyed, and raw frames written to the pty as an
//! attacker on the line would: one forged with the session id read off the line, one signed
//! correctly, and a signed one replayed.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use e2e::{hil_sim_pty, host_tool};
use protocol::{
    DeviceMessage, FrameDecoder, ParamId, RejectReason, Request, RequestBody, ResponseBody,
    ResultCode, MAX_FRAME_LEN,
};

const LIMIT: Duration = Duration::from_secs(60);

/// The device's answer to the request with `seq` in what it sends within 2 s.
fn answer(port: &mut Box<dyn serialport::SerialPort>, seq: u16) -> (ResultCode, ResponseBody) {
    let mut d = FrameDecoder::new();
    let until = Instant::now() + Duration::from_secs(2);
    let mut buf = [0u8; 256];
    while Instant::now() < until {
        let n = match port.read(&mut buf) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
            Err(e) => panic!("reading the pty: {e}"),
        };
        for &b in &buf[..n] {
            if let Some(Ok(DeviceMessage::Response {
                seq: s,
                result,
                body,
            })) = d.push::<DeviceMessage>(b)
            {
                if s == seq {
                    return (result, body);
                }
            }
        }
    }
    panic!("no answer to #{seq}");
}

fn send(port: &mut Box<dyn serialport::SerialPort>, frame: &[u8]) {
    port.write_all(&[0]).unwrap();
    port.write_all(frame).unwrap();
    port.flush().unwrap();
}

fn plain(req: &Request) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = protocol::encode(req, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn signed(req: &Request, key: &[u8; 16], counter: u64) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = protocol::frame::encode_signed(req, key, counter, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn set_limit(seq: u16, session: u32, kpa: f32) -> Request {
    Request {
        seq,
        session,
        body: RequestBody::SetParam {
            id: ParamId::PressureLimitKpa,
            value: kpa,
        },
    }
}

fn limit(path: &str, key: &str) -> f64 {
    let out = host_tool(
        &[
            "param",
            "get",
            "pressure-limit-kpa",
            "--port",
            path,
            "--link-key",
            key,
            "--json",
        ],
        LIMIT,
    );
    assert_eq!(out.code(), 0, "{}", out.stderr);
    out.json()["params"][0]["value"].as_f64().expect("a value")
}

#[test]
fn pairing_then_forged_replayed_and_signed_frames_over_the_pty() {
    let sim = hil_sim_pty(&["--initial", "D&F", "--seed", "3"]);
    let dir = std::env::temp_dir().join(format!("e2e-signing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let key_file = dir.join("crane.key");
    let _ = std::fs::remove_file(&key_file);
    let kf = key_file.to_str().unwrap();

    // Off by default; pairing writes a user-only key file and turns it on.
    let show = host_tool(&["signing", "show", "--port", &sim.path, "--json"], LIMIT);
    assert_eq!(show.json()["signing"], false, "{}", show.stderr);
    let pair = host_tool(
        &[
            "signing",
            "pair",
            "--port",
            &sim.path,
            "--key-file",
            kf,
            "--json",
        ],
        LIMIT,
    );
    assert_eq!(pair.code(), 0, "{}", pair.stderr);
    assert_eq!(pair.json()["signing"], true);
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(&key_file).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o600);
    let hex = std::fs::read_to_string(&key_file).unwrap();
    let hex = hex.trim();
    assert_eq!(hex.len(), 32, "{hex}");
    let key: [u8; 16] =
        std::array::from_fn(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap());
    // Pairing again over an existing file is refused before anything is sent.
    let again = host_tool(
        &["signing", "pair", "--port", &sim.path, "--key-file", kf],
        LIMIT,
    );
    assert_eq!(again.code(), 2, "{}", again.stderr);
    let show = host_tool(&["signing", "show", "--port", &sim.path, "--json"], LIMIT);
    assert_eq!(show.json()["signing"], true, "the handshake says so");

    // Without the key a parameter change is refused; with it, obeyed.
    let refused = host_tool(
        &[
            "param",
            "set",
            "pressure-limit-kpa",
            "30",
            "--port",
            &sim.path,
        ],
        LIMIT,
    );
    assert_eq!(refused.code(), 1, "{}", refused.stderr);
    assert!(
        refused.stderr.contains("not validly signed") && refused.stderr.contains("--link-key"),
        "{}",
        refused.stderr
    );
    let set = host_tool(
        &[
            "param",
            "set",
            "pressure-limit-kpa",
            "30",
            "--port",
            &sim.path,
            "--link-key",
            kf,
        ],
        LIMIT,
    );
    assert_eq!(set.code(), 0, "{}", set.stderr);
    assert_eq!(limit(&sim.path, kf), 30.0);

    // On the line: a handshake tells anyone the session id.
    let mut port = serialport::new(&sim.path, 115_200)
        .timeout(Duration::from_millis(20))
        .open()
        .expect("the pty opens");
    let hello = Request {
        seq: 9_000,
        session: 0,
        body: RequestBody::hello(),
    };
    send(&mut port, &plain(&hello));
    let (res, body) = answer(&mut port, 9_000);
    assert_eq!(res, ResultCode::Ok);
    let ResponseBody::Hello(info) = body else {
        panic!("{body:?}")
    };
    assert!(info.signing);
    let s = info.session;
    // Forged: the right session id, no signature.
    send(&mut port, &plain(&set_limit(9_001, s, 60.0)));
    assert_eq!(
        answer(&mut port, 9_001).0,
        ResultCode::Rejected(RejectReason::Unsigned)
    );
    // Signed with the key, its counter above host-tool's (µs since 1970): obeyed.
    let base = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_micros() as u64;
    let first = signed(&set_limit(9_002, s, 35.0), &key, base);
    send(&mut port, &first);
    assert_eq!(answer(&mut port, 9_002).0, ResultCode::Ok);
    send(
        &mut port,
        &signed(&set_limit(9_003, s, 36.0), &key, base + 1),
    );
    assert_eq!(answer(&mut port, 9_003).0, ResultCode::Ok);
    // Replayed: the first signed frame again, byte for byte.
    send(&mut port, &first);
    assert_eq!(
        answer(&mut port, 9_002).0,
        ResultCode::Rejected(RejectReason::Unsigned)
    );
    let close = Request {
        seq: 9_004,
        session: s,
        body: RequestBody::Close,
    };
    send(&mut port, &signed(&close, &key, base + 2));
    assert_eq!(answer(&mut port, 9_004).0, ResultCode::Ok);
    drop(port);
    assert_eq!(
        limit(&sim.path, kf),
        36.0,
        "the forged 60 and the replayed 35 never took"
    );

    // Off, with the key; then plain commands are obeyed again.
    let off = host_tool(
        &["signing", "off", "--port", &sim.path, "--link-key", kf],
        LIMIT,
    );
    assert_eq!(off.code(), 0, "{}", off.stderr);
    let show = host_tool(&["signing", "show", "--port", &sim.path, "--json"], LIMIT);
    assert_eq!(show.json()["signing"], false);
    let set = host_tool(
        &[
            "param",
            "set",
            "pressure-limit-kpa",
            "40",
            "--port",
            &sim.path,
        ],
        LIMIT,
    );
    assert_eq!(set.code(), 0, "{}", set.stderr);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A key file that cannot be read, or is not 32 hex digits, is a usage error before anything
/// is opened; so is pairing over an existing key file.
#[test]
fn bad_key_files_are_usage_errors() {
    let dir = std::env::temp_dir().join(format!("e2e-badkey-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let short = dir.join("short.key");
    std::fs::write(&short, "0123abcd\n").unwrap();
    let missing = dir.join("missing.key");
    for (file, why) in [
        (&missing, "cannot read the link key"),
        (&short, "expected 32 hexadecimal digits"),
    ] {
        let out = host_tool(
            &["status", "--sim", "--link-key", file.to_str().unwrap()],
            LIMIT,
        );
        assert_eq!(out.code(), 2, "{}", out.stderr);
        assert!(out.stderr.contains(why), "{}", out.stderr);
    }
    let out = host_tool(
        &[
            "signing",
            "pair",
            "--sim",
            "--key-file",
            short.to_str().unwrap(),
        ],
        LIMIT,
    );
    assert_eq!(out.code(), 2, "{}", out.stderr);
    assert!(out.stderr.contains("never overwrites"), "{}", out.stderr);
    assert_eq!(
        std::fs::read_to_string(&short).unwrap(),
        "0123abcd\n",
        "left as it was"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
