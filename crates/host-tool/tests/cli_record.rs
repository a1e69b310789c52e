//! `plan --record` and `host-tool log` as a user runs them: a seeded simulator run recorded,
//! summarised, cut short as a crashed writer would leave it, and recovered. (The Python `mcap`
//! reader checks the same files independently: `.ci/record-check.sh`.)

#[path = "support/cli.rs"]
mod cli;

use cli::host_tool;

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
    // A missing input is a usage error, as in every command (`ik --target-file` too).
    for args in [
        &["log", "summary", "/nonexistent/x.mcap"][..],
        &["log", "export", "/nonexistent/x.mcap", "--csv", "/tmp"][..],
        &[
            "ik",
            "--n",
            "4",
            "--beta",
            "35",
            "--modules",
            "4",
            "--target-file",
            "/nonexistent/x.csv",
        ][..],
    ] {
        let out = host_tool(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("/nonexistent/x."),
            "{args:?}"
        );
    }
    let _ = std::fs::remove_file(&path);
}

/// `log export --topic`, `--from/--to` and `--csv -`, and `log plot` with a declared state and
/// a fault, on a plan whose last step the operator's word decides (F&D → F&F: the device
/// cannot confirm it; the simulated operator declares the truth) — the plot must not draw the
/// declaration as the device's confirmation.
#[test]
fn export_selects_channels_and_a_window_and_the_plot_tells_a_declaration_from_a_confirmation() {
    let dir = std::env::temp_dir().join(format!("cli-record-sel-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mcap = dir.join("declared.mcap");
    let m = mcap.to_str().unwrap();
    let out = host_tool(&[
        "plan",
        "--target",
        "F&F",
        "--sim",
        "--sim-initial",
        "F&D",
        "--record",
        m,
        "-q",
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // One channel to stdout: the header and one row per telemetry sample in the window.
    let all = host_tool(&["log", "export", m, "--csv", "-", "--topic", "/telemetry"]);
    assert_eq!(all.status.code(), Some(0));
    let rows_all = stdout(&all).lines().count() - 1;
    assert!(rows_all > 150, "{rows_all} rows");
    let win = host_tool(&[
        "log",
        "export",
        m,
        "--csv",
        "-",
        "--topic",
        "/telemetry",
        "--from",
        "1",
        "--to",
        "2",
    ]);
    assert_eq!(win.status.code(), Some(0));
    let text = stdout(&win);
    let times: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    // 50 Hz telemetry: 1 s holds 50 ± 2 samples, all inside the window (the first message
    // is at t ≈ 0).
    assert!((48..=52).contains(&times.len()), "{} rows", times.len());
    let t0: f64 = stdout(&all)
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        times
            .iter()
            .all(|t| (t0 + 1.0 - 1e-6..=t0 + 2.0 + 1e-6).contains(t)),
        "{times:?}"
    );

    // A directory export of two channels writes exactly those two files.
    let csv = dir.join("csv");
    let out = host_tool(&[
        "log",
        "export",
        m,
        "--csv",
        csv.to_str().unwrap(),
        "--topic",
        "/faults",
        "--topic",
        "/state",
    ]);
    assert_eq!(out.status.code(), Some(0));
    let mut names: Vec<String> = std::fs::read_dir(&csv)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["faults.csv", "state.csv"]);

    // Refusals, before anything is written.
    for (args, says) in [
        (
            &["log", "export", m, "--csv", "-"][..],
            "name it with --topic",
        ),
        (
            &["log", "export", m, "--csv", "-", "--topic", "/nope"][..],
            "no such channel",
        ),
        (
            &["log", "export", m, "--csv", "-", "--topic", "/scene"][..],
            "not exported to CSV",
        ),
        (
            &[
                "log", "export", m, "--csv", "-", "--topic", "/state", "--from", "2", "--to", "1",
            ][..],
            "later than --from",
        ),
        (
            &[
                "log", "export", m, "--csv", "-", "--topic", "/state", "--from", "-1",
            ][..],
            "expected a number from 0",
        ),
    ] {
        let out = host_tool(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{args:?}: {err}");
    }
    assert!(
        !std::path::Path::new("-").exists(),
        "--csv - made a directory named -"
    );

    // The plot: the declared F&F drawn as declared, the E-04 of the unconfirmable step as a
    // fault; nothing drawn as confirmed by the device.
    let svg = dir.join("declared.svg");
    let out = host_tool(&["log", "plot", m, "--out", svg.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0));
    let said = stdout(&out);
    assert!(
        said.contains("0 confirmed states, 1 declared, 1 faults raised"),
        "{said}"
    );
    let drawn = std::fs::read_to_string(&svg).unwrap();
    assert!(drawn.contains("F&amp;F (declared)"), "no declared label");
    assert!(drawn.contains(">E-04<"), "no fault label");
    let _ = std::fs::remove_dir_all(&dir);
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
