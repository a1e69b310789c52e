//! Live-view latency: from the moment a telemetry sample is produced, in device time mapped to
//! this process's clock, to its arrival at a Foxglove WebSocket client on the same machine —
//! an upper bound of the time to the server's WebSocket send (loopback delivery included).
//!
//! The device is the simulator (the real firmware controller) behind a pseudo-terminal at ×1,
//! on the hardware's timing; `host-tool serve --port PTY --foxglove 127.0.0.1:0` owns the link
//! exactly as with a crane. The simulator's clock is tied to this process's: virtual time `v`
//! is reached at `epoch + v` (`PtySim::clock`), so a sample stamped `device_ms` was produced
//! at `epoch + device_ms`, within the simulator's 1 ms loop pass (included in the figure, as a
//! UART's transfer time would be on a crane). The client subscribes to every channel (so the
//! server also builds the scene) and records when each message arrives. The server's CPU time
//! over the run comes from /proc.
//!
//! `cargo bench -p host-tool --bench live_latency [-- SECONDS [--record]]` (default 60 s).

#[path = "../tests/support/foxglove_ws.rs"]
mod foxglove_ws;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use hil_sim::pty::PtySim;
use hil_sim::SimOptions;

fn cpu_ticks(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the command's closing parenthesis: state is field 3; utime 14, stime 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    Some(f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?)
}

fn pct(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds: f64 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(60.0);
    let record = args.iter().any(|a| a == "--record");
    let sim = PtySim::spawn(SimOptions {
        speed: 1.0,
        ..SimOptions::default()
    })?;
    let (epoch, v0) = sim.clock();
    let dir = std::env::temp_dir().join(format!("live-latency-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let rec = dir.join("live.mcap");
    let port = sim.path().to_string_lossy().into_owned();
    let mut serve_args = vec![
        "serve",
        "--port",
        &port,
        "--rate",
        "50",
        "--foxglove",
        "127.0.0.1:0",
    ];
    let rec_arg = rec.to_string_lossy().into_owned();
    if record {
        serve_args.extend(["--record", &rec_arg]);
    } else {
        serve_args.push("--no-record");
    }
    let mut server = Command::new(env!("CARGO_BIN_EXE_host-tool"))
        .args(&serve_args)
        .env("XDG_RUNTIME_DIR", &dir)
        .stdin(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()?;
    let mut err = BufReader::new(server.stderr.take().expect("piped"));
    let mut line = String::new();
    err.read_line(&mut line)?;
    let url = line
        .split("live view for Foxglove on ")
        .nth(1)
        .ok_or_else(|| anyhow::anyhow!("serve did not start: {line}"))?
        .trim()
        .to_string();
    std::thread::spawn(move || for _ in err.lines() {});
    let topics = ["/telemetry", "/scene", "/tf", "/events", "/log", "/state"];
    let mut c = foxglove_ws::Client::connect(
        &url,
        foxglove_ws::SUBPROTOCOL,
        &topics,
        Duration::from_secs(10),
    )
    .map_err(|e| anyhow::anyhow!(e))?;
    let all: Vec<String> = c.channels.keys().cloned().collect();
    let all: Vec<&str> = all.iter().map(String::as_str).collect();
    c.subscribe(&all).map_err(|e| anyhow::anyhow!(e))?;
    // Let the subscription settle (one second of samples are not counted).
    let warm = Instant::now() + Duration::from_secs(1);
    while c.next(warm).map_err(|e| anyhow::anyhow!(e))?.is_some() {}
    let cpu0 = cpu_ticks(server.id());
    let t0 = Instant::now();
    let end = t0 + Duration::from_secs_f64(seconds);
    let (mut tel, mut scene) = (Vec::new(), Vec::new());
    while let Some(m) = c.next(end).map_err(|e| anyhow::anyhow!(e))? {
        let device_ms = m.timestamp_ns / 1_000_000;
        let produced = epoch + Duration::from_millis(device_ms.saturating_sub(v0));
        let ms = if m.at >= produced {
            (m.at - produced).as_secs_f64() * 1e3
        } else {
            -((produced - m.at).as_secs_f64() * 1e3)
        };
        match m.topic.as_str() {
            "/telemetry" => tel.push(ms),
            "/scene" => scene.push(ms),
            _ => {}
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    let cpu1 = cpu_ticks(server.id());
    let _ = server.kill();
    let _ = server.wait();
    drop(sim);
    let _ = std::fs::remove_dir_all(&dir);
    anyhow::ensure!(tel.len() > 10, "only {} telemetry samples", tel.len());
    let hz = 100.0; // USER_HZ: /proc's clock ticks per second on Linux
    let cpu = match (cpu0, cpu1) {
        (Some(a), Some(b)) => format!(
            "{:.2} % of one core ({:.2} s CPU in {wall:.1} s)",
            (b - a) as f64 / hz / wall * 100.0,
            (b - a) as f64 / hz
        ),
        _ => "unknown".into(),
    };
    for (name, v) in [("/telemetry", &mut tel), ("/scene", &mut scene)] {
        if v.is_empty() {
            continue;
        }
        v.sort_by(f64::total_cmp);
        println!(
            "{name}: {} messages, device time → client: median {:.2} ms, p99 {:.2} ms, \
             min {:.2} ms, max {:.2} ms",
            v.len(),
            pct(v, 0.5),
            pct(v, 0.99),
            v[0],
            v[v.len() - 1]
        );
    }
    println!(
        "serve ({}): {cpu}",
        if record { "recording" } else { "--no-record" }
    );
    Ok(())
}
