//! `host-tool monitor`: live telemetry until Ctrl-C or `--duration`.
//!
//! Asks the device for telemetry at `--rate` Hz (restoring its previous rate at the end) and
//! prints each sample and every event; if the device refuses the rate, it polls the status at
//! that rate instead. With the simulator it runs in real time by default: a person watches.

use std::sync::atomic::Ordering;
use std::time::Duration;

use host::{text, Io as _};

use protocol::{Event, ParamId, RequestBody, ResponseBody, Telemetry};
use serde_json::json;

use crate::device::DeviceArgs;
use crate::failure::Failure;

/// Arguments of `host-tool monitor`.
/// The longest `--duration`, s.
const MAX_DURATION_S: f64 = 1e9;

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Stop after this many seconds [range: > 0 to 1e9 (about 31 years); default: until
    /// Ctrl-C].
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true, value_parser = crate::num::positive_at_most(MAX_DURATION_S))]
    pub duration: Option<f64>,
    /// Samples per second [range: 1–50, whole numbers]: the device's telemetry rate (device
    /// time) and, in text, at most this many lines per wall second.
    #[arg(long, value_name = "HZ", default_value_t = 10, value_parser = crate::num::int_in(1, 50))]
    pub rate: u32,
    /// One JSON object per line on stdout.
    #[arg(skip)]
    pub json: bool,
    /// Also record the session to this MCAP file (`host-tool log` reads it).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<std::path::PathBuf>,
}

/// Runs `host-tool monitor`.
pub fn run(args: Args) -> Result<(), Failure> {
    if let Some(server) = crate::client::server_for(&args.device)? {
        return through_server(&server, &args);
    }
    let device = args.device.validate(Some(1.0))?;
    // In range by its parser: a `Duration` holds it.
    let duration = args.duration.map(Duration::from_secs_f64);
    let cancel = crate::shell::interrupt_flag();
    let recording = args
        .record
        .as_deref()
        .map(|p| crate::device::start_recording(p, "monitor", &device))
        .transpose()?;
    let mut conn = device.connect_recorded(recording)?;
    let s = &mut conn.session;
    let previous = previous_telemetry_rate(s);
    let streaming = s
        .command(RequestBody::SetParam {
            id: ParamId::TelemetryHz,
            value: args.rate as f32,
        })
        .is_ok();
    if !streaming {
        crate::say!(
            "note: the device refused telemetry at {} Hz: polling its status instead",
            args.rate
        );
    }
    // Durations on the engine's clock: wall time on a port, the simulator's (paced) otherwise.
    let start = s.io.now_ms();
    let duration_ms = duration.map(|d| d.as_millis() as u64);
    let status_period_ms = (1000 / u64::from(args.rate)).max(1);
    let mut next_status = start;
    let mut result = Ok(());
    let mut lines = Lines::new(args.json, args.rate);
    while !cancel.load(Ordering::SeqCst)
        && !crate::cli::stdout_closed()
        && duration_ms.is_none_or(|d| s.io.now_ms().saturating_sub(start) < d)
    {
        if !streaming && s.io.now_ms() >= next_status {
            next_status += status_period_ms;
            match s.status() {
                Ok(st) => lines.sample(
                    &Telemetry {
                        uptime_ms: st.uptime_ms,
                        pressure_kpa: st.pressure_kpa,
                        servo_deg: st.servo_deg,
                        inlet_open: st.inlet_open,
                        exhaust_open: st.exhaust_open,
                        state: st.state,
                        state_confirmed: st.state_confirmed,
                    },
                    Some(text::mode(st.mode)),
                ),
                Err(e) => {
                    result = Err(anyhow::anyhow!("{e}"));
                    break;
                }
            }
        }
        // The engine keeps the heartbeat going while it waits.
        if let Err(e) = s.idle(20) {
            result = Err(anyhow::anyhow!("{e}"));
            break;
        }
        while let Some(ev) = s.device_events.pop_front() {
            lines.event(&ev);
        }
    }
    // Whatever ended the watch (the duration, Ctrl-C, a closed stdout, a link error), the
    // device gets its telemetry rate back.
    if let Some(value) = previous {
        let restored = s.command(RequestBody::SetParam {
            id: ParamId::TelemetryHz,
            value,
        });
        match restored {
            Ok(_) => crate::debug!("telemetry rate restored to {value} Hz"),
            Err(e) => crate::say!("note: could not restore the telemetry rate to {value} Hz: {e}"),
        }
    }
    conn.close();
    result.map_err(Failure::Runtime)?;
    if cancel.load(Ordering::SeqCst) {
        return Err(Failure::Interrupted(
            "monitor stopped by Ctrl-C, SIGTERM or SIGHUP (the telemetry rate restored)".into(),
        ));
    }
    Ok(())
}

/// What `monitor` prints: a header, then at most `rate` sample lines per wall second (the
/// latest sample of each interval; every sample in JSON), never two at the same displayed
/// time, and every event.
struct Lines {
    json: bool,
    min_gap: Duration,
    last_shown: Option<std::time::Instant>,
    last_uptime_cs: Option<u32>,
    header: bool,
}

impl Lines {
    fn new(json: bool, rate: u32) -> Self {
        Self {
            json,
            min_gap: Duration::from_secs_f64(1.0 / f64::from(rate.max(1))),
            last_shown: None,
            last_uptime_cs: None,
            header: false,
        }
    }

    fn sample(&mut self, t: &Telemetry, mode: Option<&str>) {
        // The time is shown to 0.01 s: a second sample in the same hundredth adds nothing.
        let cs = t.uptime_ms / 10;
        if self.last_uptime_cs == Some(cs) {
            return;
        }
        if !self.json {
            let now = std::time::Instant::now();
            if self
                .last_shown
                .is_some_and(|last| now.duration_since(last) < self.min_gap)
            {
                return;
            }
            self.last_shown = Some(now);
            if !self.header {
                self.header = true;
                crate::out!("{}", header());
            }
        }
        self.last_uptime_cs = Some(cs);
        print_sample(self.json, t, mode);
    }

    fn event(&mut self, ev: &Event) {
        match ev {
            Event::Telemetry(t) => self.sample(t, None),
            other => print_event(self.json, other),
        }
    }
}

/// The column names above the sample lines.
fn header() -> String {
    format!(
        "{:>11}  {:<5}  {:>9}  {:<27}  {:<12}  {}",
        "device time", "state", "pressure", "servos", "inlet", "exhaust"
    )
}

/// `monitor` through a server: the server's telemetry (at its rate), until Ctrl-C or
/// `--duration` of wall time.
fn through_server(server: &std::path::Path, args: &Args) -> Result<(), Failure> {
    if args.record.is_some() {
        return Err(Failure::usage(
            "a server holds this device and records its session itself: --record is not needed",
        ));
    }
    let cancel = crate::shell::interrupt_flag();
    let mut c = crate::client::Client::connect(server)?;
    c.send(&crate::serve_protocol::Request::Monitor)?;
    let start = std::time::Instant::now();
    // The server streams at its own rate (`serve --rate`): samples closer than 1/--rate in
    // device time are dropped here, so the output keeps to --rate as it does directly.
    let gap_ms = 1000 / args.rate.max(1);
    let mut last_kept: Option<u32> = None;
    let mut lines = Lines::new(args.json, args.rate);
    while !cancel.load(Ordering::SeqCst)
        && !crate::cli::stdout_closed()
        && args
            .duration
            .is_none_or(|d| start.elapsed().as_secs_f64() < d)
    {
        if let Some(crate::serve_protocol::Reply::Event { event: ev }) = c.recv_within()? {
            if let Event::Telemetry(t) = &ev {
                if last_kept.is_some_and(|k| t.uptime_ms.saturating_sub(k) < gap_ms) {
                    continue;
                }
                last_kept = Some(t.uptime_ms);
            }
            lines.event(&ev);
        }
    }
    if cancel.load(Ordering::SeqCst) {
        return Err(Failure::Interrupted(
            "monitor stopped by Ctrl-C, SIGTERM or SIGHUP (the server keeps serving)".into(),
        ));
    }
    Ok(())
}

fn previous_telemetry_rate<I: host::Io>(s: &mut host::Driver<I>) -> Option<f32> {
    match s.command(RequestBody::GetParam(ParamId::TelemetryHz)) {
        Ok(ResponseBody::Param { value, .. }) => Some(value),
        _ => None,
    }
}

/// Sets the device's telemetry rate; returns the previous one to restore (`None`: it could
/// not be read or the device refused the new one).
pub fn set_telemetry_rate<I: host::Io>(s: &mut host::Driver<I>, hz: u32) -> Option<f32> {
    let previous = previous_telemetry_rate(s)?;
    s.command(RequestBody::SetParam {
        id: ParamId::TelemetryHz,
        value: hz as f32,
    })
    .ok()?;
    Some(previous)
}

fn print_sample(json: bool, t: &Telemetry, mode: Option<&str>) {
    if json {
        let mut v = json!({
            "type": "telemetry",
            "uptime_ms": t.uptime_ms,
            "state": t.state.name(),
            "state_confirmed": t.state_confirmed,
            "pressure_kpa": t.pressure_kpa,
            "servo_deg": t.servo_deg,
            "inlet_open": t.inlet_open,
            "exhaust_open": t.exhaust_open,
        });
        // Only status-polled samples know the mode; telemetry events do not carry it.
        if let Some(mode) = mode {
            v["mode"] = json!(mode);
        }
        crate::out!("{}", crate::num::clean(v));
    } else {
        use crate::num::fixed_w;
        crate::out!(
            "{:>9.2} s  {:<5}  {} kPa  servos {}° {}° {}°  inlet {}  exhaust {}{}",
            f64::from(t.uptime_ms) / 1000.0,
            t.state.name(),
            fixed_w(f64::from(t.pressure_kpa), 1, 5),
            fixed_w(f64::from(t.servo_deg[0]), 1, 5),
            fixed_w(f64::from(t.servo_deg[1]), 1, 5),
            fixed_w(f64::from(t.servo_deg[2]), 1, 5),
            if t.inlet_open { "open  " } else { "closed" },
            if t.exhaust_open { "open  " } else { "closed" },
            mode.map_or(String::new(), |m| format!("  {m}"))
        );
    }
}

fn print_event(json: bool, ev: &Event) {
    if let Event::Telemetry(t) = ev {
        return print_sample(json, t, None);
    }
    // Heartbeats and step progress say nothing a person reads (the samples show liveness).
    let (kind, Some(text)) = text::event(ev) else {
        return;
    };
    if json {
        crate::out!("{}", json!({"type": "event", "kind": kind, "text": text}));
    } else {
        crate::out!("event: {text}");
    }
}
