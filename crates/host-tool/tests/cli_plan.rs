//! `host-tool plan` and friends as a user runs them: usage errors, dry runs, and a device that
//! speaks another protocol version (a fake device on a pseudo-terminal).

#[path = "support/cli.rs"]
mod cli;

use cli::host_tool;

use std::io::{Read, Write};
use std::os::fd::AsFd;
use std::time::{Duration, Instant};

use protocol::{
    Board, DeviceInfo, DeviceMessage, FrameDecoder, ModuleConfig, RejectReason, Request,
    RequestBody, ResponseBody, ResultCode, TrunkConfig, MAX_FRAME_LEN, PROTOCOL_VERSION, SCHEMA_ID,
};

#[test]
fn an_invalid_target_is_a_usage_error_listing_the_six_states() {
    let out = host_tool(&["plan", "--target", "D&X", "--dry-run"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    for s in ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"] {
        assert!(err.contains(s), "{err}");
    }
}

#[test]
fn port_and_sim_together_are_a_usage_error() {
    let out = host_tool(&["status", "--port", "/dev/ttyACM0", "--sim"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn a_dry_run_explains_the_plan_without_a_device() {
    let out = host_tool(&["plan", "--target", "D&D", "--dry-run"]);
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("plan F&P → D&D: 3 steps"), "{text}");
    assert_eq!(text.matches("why:").count(), 3, "{text}");
    assert!(text.contains("dry run"), "{text}");
}

/// A device that answers every Hello with another protocol version and schema id. It keeps
/// the pty open until the client has exited (a message on the returned sender), so the client
/// reads the whole answer; the thread gives the number of Hellos it answered.
fn mismatched_device() -> (
    String,
    std::sync::mpsc::Sender<()>,
    std::thread::JoinHandle<u32>,
) {
    let (client_done, done) = std::sync::mpsc::channel::<()>();
    let pty = nix::pty::openpty(None, None).expect("a pty");
    let mut t = nix::sys::termios::tcgetattr(pty.slave.as_fd()).expect("termios");
    nix::sys::termios::cfmakeraw(&mut t);
    nix::sys::termios::tcsetattr(pty.slave.as_fd(), nix::sys::termios::SetArg::TCSANOW, &t)
        .expect("raw mode");
    let path = nix::unistd::ttyname(pty.slave.as_fd()).expect("pty name");
    let handle = std::thread::spawn(move || {
        let _slave = pty.slave; // keep the pty alive while the client opens it
        let mut master = std::fs::File::from(pty.master);
        let mut decoder = FrameDecoder::new();
        let mut hellos = 0;
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut buf = [0u8; 256];
        while Instant::now() < deadline && hellos == 0 {
            let Ok(n) = master.read(&mut buf) else { break };
            for &b in &buf[..n] {
                if let Some(Ok(Request {
                    seq,
                    body: RequestBody::Hello { .. },
                    ..
                })) = decoder.push::<Request>(b)
                {
                    hellos += 1;
                    let module = ModuleConfig {
                        n: 6,
                        beta_deg: 35.0,
                        edge_mm: 40.0,
                        layers: 3,
                    };
                    let reply = DeviceMessage::Response {
                        seq,
                        result: ResultCode::Rejected(RejectReason::VersionMismatch),
                        body: ResponseBody::Hello(DeviceInfo {
                            protocol_version: PROTOCOL_VERSION + 1,
                            schema_id: 0x1234_5678,
                            firmware_version: [9, 9, 9],
                            board: Board::UnoR4Minima,
                            trunk: TrunkConfig {
                                bottom: module,
                                top: module,
                                pressure_limit_kpa: 40.0,
                            },
                            session: 0,
                            reset_cause: protocol::ResetCause::Unknown,
                            signing: false,
                        }),
                    };
                    let mut frame = [0u8; MAX_FRAME_LEN];
                    let len = protocol::encode(&reply, &mut frame).expect("encodes");
                    master.write_all(&frame[..len]).expect("writes");
                }
            }
        }
        // The pty stays until the client has read the answer and exited.
        let _ = done.recv_timeout(Duration::from_secs(30));
        hellos
    });
    (path.to_string_lossy().into_owned(), client_done, handle)
}

#[test]
fn a_protocol_mismatch_exits_1_naming_both_versions_and_schema_ids() {
    let (path, client_done, device) = mismatched_device();
    let out = host_tool(&["plan", "--target", "D&F", "--port", &path, "--json"]);
    client_done.send(()).expect("the fake device waits");
    assert_eq!(device.join().expect("the fake device ran"), 1);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("protocol version {PROTOCOL_VERSION}")),
        "{err}"
    );
    assert!(
        err.contains(&format!("protocol version {}", PROTOCOL_VERSION + 1)),
        "{err}"
    );
    assert!(err.contains(&format!("{SCHEMA_ID:#010x}")), "{err}");
    assert!(err.contains("0x12345678"), "{err}");
    // The JSON report says the same, and nothing was planned or started.
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(v["ok"], false);
    assert!(v["error"].as_str().unwrap().contains("0x12345678"), "{v}");
    assert_eq!(v["steps"], serde_json::json!([]));
    assert!(v["from"].is_null() && v["sim"].is_null(), "{v}");
}

#[test]
fn the_simulator_is_deterministic_end_to_end() {
    let args = [
        "plan",
        "--target",
        "D&D",
        "--sim",
        "--sim-fault",
        "line-noise",
        "--seed",
        "11",
        "--json",
    ];
    let first = host_tool(&args);
    assert_eq!(
        first.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    for _ in 0..4 {
        let again = host_tool(&args);
        assert_eq!(
            again.stdout, first.stdout,
            "same seed, same JSON, byte for byte"
        );
    }
    // Another seed is another run (the noise hits other bytes).
    let other = host_tool(&[
        "plan",
        "--target",
        "D&D",
        "--sim",
        "--sim-fault",
        "line-noise",
        "--seed",
        "12",
        "--json",
    ]);
    assert_ne!(other.stdout, first.stdout);
}

#[test]
fn every_accepted_sim_speed_works_and_the_edges_beyond_are_refused() {
    // The slowest pace on a run that needs only the handshake and one status (≈ 3 ms virtual,
    // 30 ms of wall time), the fastest on a whole plan.
    for (speed, target) in [("0.1", "F&P"), ("1000", "D&F"), ("1", "F&P")] {
        let out = host_tool(&[
            "plan",
            "--target",
            target,
            "--sim",
            "--sim-speed",
            speed,
            "--json",
        ]);
        assert_eq!(
            out.status.code(),
            Some(0),
            "--sim-speed {speed}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["final_state"], target);
    }
    for bad in ["0.09", "1000.5", "nan", "0"] {
        let out = host_tool(&["plan", "--target", "D&F", "--sim", "--sim-speed", bad]);
        assert_eq!(out.status.code(), Some(2), "--sim-speed {bad}");
    }
}

#[test]
fn device_commands_without_port_or_sim_are_usage_errors() {
    for args in [
        &["plan", "--target", "D&F"][..],
        &["stop"][..],
        &["declare", "D&D"][..],
        &["param", "set", "telemetry-hz", "5"][..],
        &["status"][..],
    ] {
        let out = host_tool(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--port") && err.contains("--sim"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn identify_reports_a_confirmed_state_at_once() {
    let out = host_tool(&["identify", "--sim", "--sim-initial", "F&D", "--json"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["state"], "F&D");
    assert_eq!(v["state_confirmed"], true);
    assert_eq!(v["identified"], false);
    assert_eq!(v["sim"]["true_state"], "F&D");
}
