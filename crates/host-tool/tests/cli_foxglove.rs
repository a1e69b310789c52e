//! `host-tool serve --foxglove`: a Foxglove WebSocket client (foxglove.websocket.v1, written
//! from the protocol's specification in `support/foxglove_ws.rs`) connects to a server on the
//! simulator, sees the recording's channels advertised with their schemas, subscribes, and
//! receives telemetry, state, log lines and the trunk's scene while a plan runs through the
//! server. Bad addresses are refused up front; a port in use is a clear error.

#[path = "support/cli.rs"]
mod cli;
#[path = "support/foxglove_ws.rs"]
mod foxglove_ws;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use cli::cmd;
use foxglove::messages::{FrameTransforms, SceneUpdate};
use foxglove::Decode;
use foxglove_ws::Client;
use serde_json::Value;

const STATES: [&str; 6] = ["F&P", "F&F", "F&D", "D&P", "D&F", "D&D"];

struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `serve --foxglove 127.0.0.1:0` and returns it with the live view's URL (from its
/// "serving" line).
fn serve(dir: &Path, extra: &[&str]) -> (Server, String) {
    let mut args = vec![
        "serve",
        "--sim",
        "--seed",
        "7",
        "--sim-speed",
        "10",
        "--foxglove",
        "127.0.0.1:0",
    ];
    args.extend_from_slice(extra);
    let (child, line) = cli::serve(dir, &args);
    assert!(line.starts_with("serving the simulator on "), "{line}");
    let url = line
        .split("live view for Foxglove on ")
        .nth(1)
        .unwrap_or_else(|| panic!("no live view address in: {line}"))
        .trim()
        .to_string();
    (Server(child), url)
}

/// The recording's channels: topic → (schema name, message encoding, schema encoding).
fn expected_channels() -> BTreeMap<&'static str, (&'static str, &'static str, &'static str)> {
    let j = |s| (s, "json", "jsonschema");
    BTreeMap::from([
        ("/telemetry", j("crane.Telemetry")),
        ("/events", j("crane.Event")),
        ("/faults", j("crane.Fault")),
        ("/state", j("crane.State")),
        ("/log", j("foxglove.Log")),
        ("/link/requests", j("crane.Request")),
        ("/link/responses", j("crane.Response")),
        ("/link/frames", j("crane.RawFrame")),
        ("/plan", j("crane.Plan")),
        ("/run", j("crane.RunEvent")),
        ("/sim/truth", j("crane.GroundTruth")),
        ("/scene", ("foxglove.SceneUpdate", "protobuf", "protobuf")),
        ("/tf", ("foxglove.FrameTransforms", "protobuf", "protobuf")),
    ])
}

#[test]
fn a_foxglove_client_sees_the_channels_and_watches_a_plan_run() {
    let dir = cli::temp("foxglove-watch");
    let rec = dir.join("serve.mcap");
    let (_server, url) = serve(&dir, &["--record", rec.to_str().unwrap()]);
    let topics: Vec<&str> = expected_channels().keys().copied().collect();
    // A client that knows the protocol only by its old name is refused (the SDK's rule).
    let old = Client::connect(
        &url,
        "foxglove.websocket.v1",
        &topics,
        Duration::from_secs(20),
    );
    assert!(old.err().is_some_and(|e| e.contains("400")));
    let mut c = Client::connect(
        &url,
        "foxglove.websocket.v1, foxglove.sdk.v1",
        &topics,
        Duration::from_secs(20),
    )
    .unwrap();

    // Advertised: exactly the recording's channels, with their schemas.
    assert_eq!(c.server_info["op"], "serverInfo");
    let caps = c.server_info["capabilities"].as_array().unwrap();
    assert!(caps.iter().any(|v| v == "time"), "{caps:?}");
    let got: BTreeMap<&str, (&str, &str, &str)> = c
        .channels
        .values()
        .map(|ch| {
            (
                ch.topic.as_str(),
                (
                    ch.schema_name.as_str(),
                    ch.encoding.as_str(),
                    ch.schema_encoding.as_str(),
                ),
            )
        })
        .collect();
    assert_eq!(got, expected_channels());
    let tel_schema: Value = serde_json::from_str(&c.channels["/telemetry"].schema).unwrap();
    assert_eq!(tel_schema["properties"]["pressure_kpa"]["type"], "number");
    // Protobuf schemas are base64 FileDescriptorSets; non-trivial.
    assert!(c.channels["/scene"].schema.len() > 1000);

    check_layout(&c);

    c.subscribe(&["/telemetry", "/scene", "/tf", "/state", "/log"])
        .unwrap();
    // Something arrives before any plan: telemetry at 50 Hz while serving.
    let first = c
        .next(Instant::now() + Duration::from_secs(20))
        .unwrap()
        .expect("a message within 20 s");
    assert!(
        ["/telemetry", "/scene", "/tf", "/state", "/log"].contains(&first.topic.as_str()),
        "{}",
        first.topic
    );

    // A plan through the server (F&P → D&D), watched live.
    let planner = cmd(&dir, &["plan", "--target", "D&D", "--json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut tel: Vec<Value> = Vec::new();
    let mut tel_ts: Vec<u64> = Vec::new();
    let mut scenes: Vec<(u64, SceneUpdate)> = Vec::new();
    let mut tfs = 0usize;
    let mut logs: Vec<Value> = Vec::new();
    let mut states: Vec<Value> = Vec::new();
    loop {
        let Some(m) = c.next(deadline).unwrap() else {
            panic!(
                "the plan did not end at D&D in time: {} samples, last {:?}",
                tel.len(),
                tel.last()
            );
        };
        match m.topic.as_str() {
            "/telemetry" => {
                tel.push(serde_json::from_slice(&m.payload).unwrap());
                tel_ts.push(m.timestamp_ns);
            }
            "/scene" => scenes.push((m.timestamp_ns, SceneUpdate::decode(&m.payload[..]).unwrap())),
            "/tf" => {
                let t = FrameTransforms::decode(&m.payload[..]).unwrap();
                assert_eq!(t.transforms.len(), 1);
                assert_eq!(t.transforms[0].parent_frame_id, "base");
                assert_eq!(t.transforms[0].child_frame_id, "tip");
                tfs += 1;
            }
            "/log" => logs.push(serde_json::from_slice(&m.payload).unwrap()),
            "/state" => states.push(serde_json::from_slice(&m.payload).unwrap()),
            t => panic!("unsubscribed topic {t}"),
        }
        let done = logs.iter().any(|l| {
            l["message"]
                .as_str()
                .is_some_and(|s| s.starts_with("outcome:"))
        });
        if done && tel.last().is_some_and(|t| t["state"] == "D&D") && scenes.len() >= 2 {
            let last = &scenes.last().unwrap().1;
            if last.entities[1].texts[0].text.starts_with("D&D") {
                break;
            }
        }
    }
    let out = planner.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    let outcome: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(outcome["final_state"], "D&D");

    // Telemetry: 50 Hz device time, the message timestamp is the device's time, values in
    // range (the pressure cap is 40 kPa), valid state names, the inflation seen.
    assert!(tel.len() >= 100, "{} samples", tel.len());
    for (t, ts) in tel.iter().zip(&tel_ts) {
        assert_eq!(*ts, t["device_ms"].as_u64().unwrap() * 1_000_000);
        let p = t["pressure_kpa"].as_f64().unwrap();
        assert!((-2.0..=42.0).contains(&p), "pressure {p}");
        assert!(STATES.contains(&t["state"].as_str().unwrap()), "{t}");
        assert_eq!(t["servo_deg"].as_array().unwrap().len(), 3);
    }
    assert!(
        tel_ts.windows(2).all(|w| w[1] > w[0]),
        "device time goes forward"
    );
    let gaps: Vec<u64> = tel_ts
        .windows(2)
        .map(|w| (w[1] - w[0]) / 1_000_000)
        .collect();
    let median_gap = {
        let mut g = gaps.clone();
        g.sort();
        g[g.len() / 2]
    };
    assert_eq!(median_gap, 20, "50 Hz telemetry");
    let peak = tel
        .iter()
        .map(|t| t["pressure_kpa"].as_f64().unwrap())
        .fold(f64::MIN, f64::max);
    assert!(peak > 20.0, "the snaps' pressure peaks: {peak}");
    assert!(tel.iter().any(|t| t["inlet_open"] == true));

    // The scene: one entity per module (the device's trunk has two), each a triangle list
    // with valid indices, in frame "base", stamped with the device's time; heights change
    // with the state (F&P packed low, D&D deployed tall), pressure as colour.
    assert!(scenes.len() >= 10, "{} scenes", scenes.len());
    assert!(tfs >= scenes.len().saturating_sub(2), "{tfs} transforms");
    let height = |u: &SceneUpdate| {
        u.entities
            .iter()
            .flat_map(|e| e.triangles[0].points.iter())
            .map(|p| p.z)
            .fold(f64::MIN, f64::max)
    };
    for (ts, u) in &scenes {
        assert_eq!(u.entities.len(), 2);
        for (k, e) in u.entities.iter().enumerate() {
            assert_eq!(e.id, format!("module-{k}"));
            assert_eq!(e.frame_id, "base");
            let stamp = e.timestamp.unwrap();
            assert_eq!(
                u64::from(stamp.sec()) * 1_000_000_000 + u64::from(stamp.nsec()),
                *ts
            );
            let tri = &e.triangles[0];
            assert!(!tri.indices.is_empty() && tri.indices.len() % 3 == 0);
            assert!(tri.indices.iter().all(|&i| (i as usize) < tri.points.len()));
        }
    }
    let label = |u: &SceneUpdate| u.entities[1].texts[0].text.clone();
    let first_fp = scenes
        .iter()
        .find(|(_, u)| label(u).starts_with("F&P"))
        .unwrap();
    let last_dd = scenes.last().unwrap();
    let (h0, h1) = (height(&first_fp.1), height(&last_dd.1));
    assert!(h1 > h0 + 0.1, "D&D {h1} m vs F&P {h0} m");
    let reds: Vec<f64> = scenes
        .iter()
        .map(|(_, u)| u.entities[0].triangles[0].color.unwrap().r)
        .collect();
    let (lo, hi) = reds
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &r| (a.min(r), b.max(r)));
    assert!(
        hi - lo > 0.1,
        "the colour follows the pressure: red {lo}..{hi}"
    );

    // State and log lines: valid names, the outcome reported.
    assert!(states
        .iter()
        .all(|s| STATES.contains(&s["state"].as_str().unwrap())));
    assert!(logs
        .iter()
        .all(|l| (1..=5).contains(&l["level"].as_u64().unwrap())));
    assert!(logs
        .iter()
        .any(|l| l["message"] == "outcome: target reached"));
}

/// The layout in docs/foxglove: every panel of the tree is configured, of a Foxglove panel
/// type, and every topic and field it shows is one the server advertises (a field of the
/// channel's JSON schema); the 3D panel draws `/scene` in the scene's frame.
fn check_layout(c: &Client) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../docs/foxglove/crane-layout.json"
    );
    let layout: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let config = layout["configById"].as_object().unwrap();
    fn leaves(node: &Value, out: &mut Vec<String>) {
        match node {
            Value::String(id) => out.push(id.clone()),
            Value::Object(o) => {
                assert!(["row", "column"].contains(&o["direction"].as_str().unwrap()));
                let pct = o["splitPercentage"].as_f64().unwrap();
                assert!((0.0..=100.0).contains(&pct));
                leaves(&o["first"], out);
                leaves(&o["second"], out);
            }
            v => panic!("not a layout node: {v}"),
        }
    }
    let mut ids = Vec::new();
    leaves(&layout["layout"], &mut ids);
    let mut ids_sorted = ids.clone();
    ids_sorted.sort();
    let mut configured: Vec<String> = config.keys().cloned().collect();
    configured.sort();
    assert_eq!(
        ids_sorted, configured,
        "every panel placed once and configured"
    );
    let mut panel_types: Vec<&str> = ids.iter().map(|i| i.split('!').next().unwrap()).collect();
    panel_types.sort();
    panel_types.dedup();
    assert_eq!(
        panel_types,
        ["3D", "Log", "Plot", "RawMessages", "StateTransitions"]
    );
    let field_of = |path: &str| {
        // "/topic.field[0]" → ("/topic", "field")
        let (topic, rest) = path.split_once('.').unwrap_or((path, ""));
        let field = rest.split(['[', '.']).next().unwrap();
        let ch = c
            .channels
            .get(topic)
            .unwrap_or_else(|| panic!("{topic} not advertised"));
        if !field.is_empty() {
            let schema: Value = serde_json::from_str(&ch.schema).unwrap();
            assert!(
                schema["properties"].get(field).is_some(),
                "{field} is not a field of {topic}"
            );
        }
    };
    let mut n = 0;
    for (id, cfg) in config {
        for p in cfg["paths"].as_array().into_iter().flatten() {
            field_of(p["value"].as_str().unwrap());
            n += 1;
        }
        for key in ["topicPath", "topicToRender"] {
            if let Some(t) = cfg[key].as_str() {
                field_of(t);
                n += 1;
            }
        }
        if id.starts_with("3D!") {
            assert_eq!(cfg["followTf"], "base");
            for t in cfg["topics"].as_object().unwrap().keys() {
                assert_eq!(c.channels[t].schema_name, "foxglove.SceneUpdate");
            }
        }
    }
    assert!(n >= 12, "{n} paths checked");
}

#[test]
fn bad_addresses_are_refused_up_front_and_a_port_in_use_is_named() {
    let dir = cli::temp("foxglove-refuse");
    for (addr, why) in [
        ("127.0.0.1", "no port"),
        ("127.0.0.1:70000", "not 0–65535"),
        ("example.org:8765", "not an IP address"),
        ("::1:8765", "brackets"),
        (":8765", "no host"),
    ] {
        let out = cmd(&dir, &["serve", "--sim", "--no-record", "--foxglove", addr])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{addr}: {err}");
        assert!(err.contains(why), "{addr}: {err}");
    }
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let out = cmd(
        &dir,
        &[
            "serve",
            "--sim",
            "--no-record",
            "--foxglove",
            &format!("127.0.0.1:{port}"),
        ],
    )
    .output()
    .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("the port is in use"), "{err}");
    // Nothing was left behind: no socket, so a next server starts.
    assert!(!dir.join("host-tool").join("sim.sock").exists());
}
