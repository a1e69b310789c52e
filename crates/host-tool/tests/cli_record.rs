//! `plan --record` and `host-tool log` as a user runs them: a seeded simulator run recorded,
//! summarised, cut short as a crashed writer would leave it, and recovered. (The Python `mcap`
//! reader checks the same files independently: `.ci/record-check.sh`.)

use std::process::Command;

fn host_tool(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args(args)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("host-tool runs")
}

fn stdout(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The count on `channel`'s line of `log summary`.
fn count(summary: &str, channel: &str) -> u64 {
    summary
        .lines()
        .find(|l| l.split_whitespace().next() == Some(channel))
        .and_then(|l| l.split_whitespace().nth(2))
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no {channel} line in\n{summary}"))
}

#[test]
fn a_recorded_plan_survives_a_writer_cut_short() {
    let dir = std::env::temp_dir().join(format!("cli-record-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("plan.mcap");
    let f = file.to_str().unwrap();
    let out = host_tool(&[
        "plan", "--sim", "--seed", "7", "--target", "D&D", "--record", f, "--json",
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let sum = host_tool(&["log", "summary", f]);
    assert_eq!(sum.status.code(), Some(0));
    let text = stdout(&sum);
    assert!(
        text.contains("complete (summary and footer present)"),
        "{text}"
    );
    // Telemetry and the simulator's truth at 50 Hz over the plan's device time (F&P → D&D on
    // seed 7: three steps, ≈ 11.4 s) and the handshake before it (< 0.6 s).
    let plan: serde_json::Value = serde_json::from_slice(&out.stdout).expect("plan --json");
    let steps_ms: u64 = plan["steps"]
        .as_array()
        .expect("steps")
        .iter()
        .map(|s| s["duration_ms"].as_u64().expect("duration_ms"))
        .sum();
    let at_50_hz = steps_ms / 20;
    let expected = at_50_hz..=at_50_hz + 30;
    let tel = count(&text, "/telemetry");
    assert!(expected.contains(&tel), "{tel} for {steps_ms} ms");
    assert!(expected.contains(&count(&text, "/sim/truth")), "{text}");
    assert_eq!(count(&text, "/plan"), 1);
    assert_eq!(count(&text, "/faults"), 0);
    // The trunk's scene: at every state change, at most 20 Hz while it moves, ≥ 1 Hz.
    let scenes = count(&text, "/scene");
    let at_most = steps_ms / 50 + 30;
    assert!(
        (10..=at_most).contains(&scenes),
        "{scenes} > {at_most}: {text}"
    );
    assert_eq!(count(&text, "/tf"), scenes);
    let requests = count(&text, "/link/requests");
    let responses = count(&text, "/link/responses");
    // Every request is answered but the last `Close`, which is not waited for.
    assert_eq!(responses + 1, requests, "{text}");

    // A writer that died mid-file: the first 60 % of the bytes.
    let bytes = std::fs::read(&file).unwrap();
    let cut = dir.join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 6 / 10]).unwrap();
    let c = cut.to_str().unwrap();
    let sum = host_tool(&["log", "summary", c]);
    assert_eq!(sum.status.code(), Some(0));
    let text = stdout(&sum);
    assert!(text.contains("INCOMPLETE"), "{text}");
    let partial = count(&text, "/telemetry");
    assert!(partial > 100 && partial < tel, "{partial} of {tel}");

    let fixed = dir.join("fixed.mcap");
    let out = host_tool(&["log", "recover", c, "--out", fixed.to_str().unwrap()]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = stdout(&host_tool(&["log", "summary", fixed.to_str().unwrap()]));
    assert!(
        text.contains("complete (summary and footer present)"),
        "{text}"
    );
    assert_eq!(count(&text, "/telemetry"), partial);

    // CSV: one row per sample, device time first.
    let csv = dir.join("csv");
    let out = host_tool(&["log", "export", f, "--csv", csv.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0));
    let t = std::fs::read_to_string(csv.join("telemetry.csv")).unwrap();
    assert_eq!(t.lines().count() as u64, tel + 1);
    assert!(t.starts_with("log_time_s,publish_time_s,device_ms,"), "{t}");

    let svg = dir.join("plot.svg");
    let out = host_tool(&["log", "plot", f, "--out", svg.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0));
    let s = std::fs::read_to_string(&svg).unwrap();
    assert!(s.contains("pressure (kPa)") && s.contains("device time (s)"));
    // Seed 7's run: four snap-throughs in the simulator, three states confirmed.
    assert!(
        stdout(&out).contains("4 snap-throughs, 3 confirmed states"),
        "{}",
        stdout(&out)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_that_is_not_mcap_is_refused_with_the_reason() {
    let path = std::env::temp_dir().join(format!("not-mcap-{}.mcap", std::process::id()));
    std::fs::write(&path, b"hello").unwrap();
    let out = host_tool(&["log", "summary", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not an MCAP file"));
    let out = host_tool(&["log", "summary", "/nonexistent/x.mcap"]);
    assert_eq!(out.status.code(), Some(1));
    let _ = std::fs::remove_file(&path);
}

#[test]
fn an_unwritable_recording_is_refused_before_the_crane_moves() {
    let out = host_tool(&[
        "plan",
        "--sim",
        "--target",
        "D&D",
        "--record",
        "/nonexistent/dir/x.mcap",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot create the recording"), "{err}");
    assert!(!err.contains("step 1"), "{err}");
}
