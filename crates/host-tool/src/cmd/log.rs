//! `host-tool log`: what a recording holds (`summary`), one CSV per channel (`export`), the
//! pressure and servo traces with the snap-throughs marked (`plot`), and a crashed recording
//! rewritten whole (`recover`).
//!
//! Files are read linearly, without the summary section, so a recording whose writer died is
//! read up to its last complete chunk.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::failure::Failure;

/// Arguments of `host-tool log`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub command: LogCommand,
}

/// What to do with a recording.
#[derive(Debug, clap::Subcommand)]
pub enum LogCommand {
    /// What a recording holds: the session, channels, schemas, message counts, time span.
    Summary {
        /// The MCAP file.
        file: PathBuf,
    },
    /// One CSV per channel (fields flattened: servo_deg_0…, log_time_s first).
    Export {
        /// The MCAP file.
        file: PathBuf,
        /// The directory to write the CSV files into (created if missing).
        #[arg(long, value_name = "DIR")]
        csv: PathBuf,
    },
    /// Pressure and servo traces with the snap-throughs marked, as SVG.
    Plot {
        /// The MCAP file.
        file: PathBuf,
        /// The SVG to write.
        #[arg(long, value_name = "FIG.svg")]
        out: PathBuf,
    },
    /// Rewrites a recording whose writer died (no summary) as a complete file.
    Recover {
        /// The damaged MCAP file.
        file: PathBuf,
        /// The complete file to write.
        #[arg(long, value_name = "FILE.mcap")]
        out: PathBuf,
    },
}

/// One message, decoded.
struct Msg {
    channel: u16,
    log_ns: u64,
    publish_ns: u64,
    data: Value,
    raw: Vec<u8>,
}

/// A recording, read.
struct Log {
    bytes: usize,
    complete: bool,
    /// Why reading stopped early.
    truncated: Option<String>,
    metadata: Vec<(String, BTreeMap<String, String>)>,
    /// id → (topic, schema name, schema encoding, schema data, message encoding).
    channels: BTreeMap<u16, (String, String, String, Vec<u8>, String)>,
    messages: Vec<Msg>,
}

impl Log {
    fn topic(&self, topic: &str) -> impl Iterator<Item = &Msg> {
        let id = self
            .channels
            .iter()
            .find(|(_, c)| c.0 == topic)
            .map(|(id, _)| *id);
        self.messages.iter().filter(move |m| Some(m.channel) == id)
    }
}

fn load(path: &Path) -> Result<Log, Failure> {
    let buf =
        std::fs::read(path).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
    if !buf.starts_with(mcap::MAGIC) {
        return Err(Failure::Runtime(anyhow::anyhow!(
            "{} is not an MCAP file (it does not start with the MCAP magic)",
            path.display()
        )));
    }
    let complete = buf.len() >= 2 * mcap::MAGIC.len() && buf.ends_with(mcap::MAGIC);
    let opts: enumset::EnumSet<mcap::read::Options> = mcap::read::Options::IgnoreEndMagic.into();
    let mut log = Log {
        bytes: buf.len(),
        complete,
        truncated: None,
        metadata: Vec::new(),
        channels: BTreeMap::new(),
        messages: Vec::new(),
    };
    // Records in file order, chunks unpacked: schemas and channels as declared (also those
    // that carry no message), messages, metadata; up to the first damaged record.
    let reader = mcap::read::ChunkFlattener::new_with_options(&buf, opts)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let mut schemas: BTreeMap<u16, (String, String, Vec<u8>)> = BTreeMap::new();
    for r in reader {
        match r {
            Ok(mcap::records::Record::Schema { header, data }) => {
                schemas.insert(header.id, (header.name, header.encoding, data.to_vec()));
            }
            Ok(mcap::records::Record::Channel(c)) => {
                let (name, enc, data) = schemas.get(&c.schema_id).cloned().unwrap_or_default();
                log.channels
                    .entry(c.id)
                    .or_insert((c.topic, name, enc, data, c.message_encoding));
            }
            Ok(mcap::records::Record::Message { header, data }) => {
                log.messages.push(Msg {
                    channel: header.channel_id,
                    log_ns: header.log_time,
                    publish_ns: header.publish_time,
                    data: serde_json::from_slice(&data).unwrap_or(Value::Null),
                    raw: data.to_vec(),
                });
            }
            Ok(mcap::records::Record::Metadata(m)) => log.metadata.push((m.name, m.metadata)),
            Ok(_) => {}
            Err(e) => {
                log.truncated = Some(e.to_string());
                break;
            }
        }
    }
    if !complete && log.truncated.is_none() {
        log.truncated = Some("no footer".into());
    }
    Ok(log)
}

/// Runs `host-tool log`.
pub fn run(args: Args) -> Result<(), Failure> {
    match args.command {
        LogCommand::Summary { file } => summary(&file),
        LogCommand::Export { file, csv } => export(&file, &csv),
        LogCommand::Plot { file, out } => plot(&file, &out),
        LogCommand::Recover { file, out } => recover(&file, &out),
    }
}

fn secs(ns: u64) -> f64 {
    ns as f64 / 1e9
}

fn summary(path: &Path) -> Result<(), Failure> {
    let log = load(path)?;
    crate::out!("{}: {} bytes", path.display(), log.bytes);
    match (&log.truncated, log.complete) {
        (None, _) => crate::out!("complete (summary and footer present)"),
        (Some(why), _) => crate::out!(
            "INCOMPLETE: the writer did not finish ({why}); {} messages readable up to the last \
             complete chunk; `host-tool log recover` rewrites it whole",
            log.messages.len()
        ),
    }
    for (name, meta) in &log.metadata {
        for (k, v) in meta {
            crate::out!("{name}.{k}: {v}");
        }
    }
    let (t0, t1) = (
        log.messages.iter().map(|m| m.log_ns).min().unwrap_or(0),
        log.messages.iter().map(|m| m.log_ns).max().unwrap_or(0),
    );
    let span = secs(t1.saturating_sub(t0));
    crate::out!(
        "{} messages, device time {:.3} s – {:.3} s ({:.3} s)",
        log.messages.len(),
        secs(t0),
        secs(t1),
        span
    );
    crate::out!(
        "{:<18} {:<24} {:>9} {:>10}",
        "channel",
        "schema",
        "messages",
        "rate"
    );
    for (id, (topic, schema, ..)) in &log.channels {
        let n = log.messages.iter().filter(|m| m.channel == *id).count();
        let rate = if span > 0.0 {
            format!("{:.1} Hz", n as f64 / span)
        } else {
            "-".into()
        };
        crate::out!("{topic:<18} {schema:<24} {n:>9} {rate:>10}");
    }
    Ok(())
}

/// Flattens a JSON value into (column, cell) pairs.
fn flatten(prefix: &str, v: &Value, out: &mut Vec<(String, String)>) {
    match v {
        Value::Object(map) => {
            for (k, v) in map {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, v, out);
            }
        }
        Value::Array(items) if items.iter().all(|i| !i.is_object() && !i.is_array()) => {
            for (i, item) in items.iter().enumerate() {
                flatten(&format!("{prefix}_{i}"), item, out);
            }
        }
        Value::String(s) => out.push((prefix.to_string(), s.clone())),
        Value::Null => out.push((prefix.to_string(), String::new())),
        other => out.push((prefix.to_string(), other.to_string())),
    }
}

fn csv_cell(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn export(path: &Path, dir: &Path) -> Result<(), Failure> {
    let log = load(path)?;
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
    if let Some(why) = &log.truncated {
        crate::say!(
            "note: {} is incomplete ({why}): exporting what is readable",
            path.display()
        );
    }
    for (id, (topic, _, _, _, msg_enc)) in &log.channels {
        if msg_enc != "json" {
            crate::say!("{topic}: {msg_enc} messages (the 3D scene) are not exported to CSV");
            continue;
        }
        let rows: Vec<(&Msg, Vec<(String, String)>)> = log
            .messages
            .iter()
            .filter(|m| m.channel == *id)
            .map(|m| {
                let mut cells = Vec::new();
                flatten("", &m.data, &mut cells);
                (m, cells)
            })
            .collect();
        let mut columns: Vec<String> = Vec::new();
        for (_, cells) in &rows {
            for (k, _) in cells {
                if !columns.contains(k) {
                    columns.push(k.clone());
                }
            }
        }
        let mut text = String::from("log_time_s,publish_time_s");
        for c in &columns {
            text.push(',');
            text.push_str(&csv_cell(c));
        }
        text.push('\n');
        for (m, cells) in &rows {
            let _ = write!(text, "{:.6},{:.6}", secs(m.log_ns), secs(m.publish_ns));
            let cells: BTreeMap<&str, &str> = cells
                .iter()
                .map(|(k, v)| (k.as_str(), v.as_str()))
                .collect();
            for c in &columns {
                text.push(',');
                text.push_str(&csv_cell(cells.get(c.as_str()).copied().unwrap_or("")));
            }
            text.push('\n');
        }
        let name = format!("{}.csv", topic.trim_start_matches('/').replace('/', "_"));
        let file = dir.join(&name);
        std::fs::write(&file, text)
            .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", file.display()))?;
        crate::out!("{} ({} rows)", file.display(), rows.len());
    }
    Ok(())
}

fn recover(path: &Path, out: &Path) -> Result<(), Failure> {
    let log = load(path)?;
    let file = std::fs::File::create(out)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", out.display()))?;
    let write = || -> mcap::McapResult<()> {
        let mut w = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Lz4))
            .profile("")
            .create(std::io::BufWriter::new(file))?;
        let mut ids = BTreeMap::new();
        for (id, (topic, schema, enc, data, msg_enc)) in &log.channels {
            let sid = if schema.is_empty() {
                0
            } else {
                w.add_schema(schema, enc, data)?
            };
            ids.insert(*id, w.add_channel(sid, topic, msg_enc, &BTreeMap::new())?);
        }
        for (name, metadata) in &log.metadata {
            w.write_metadata(&mcap::records::Metadata {
                name: name.clone(),
                metadata: metadata.clone(),
            })?;
        }
        for (seq, m) in log.messages.iter().enumerate() {
            let header = mcap::records::MessageHeader {
                channel_id: ids[&m.channel],
                sequence: seq as u32 + 1,
                log_time: m.log_ns,
                publish_time: m.publish_ns,
            };
            w.write_to_known_channel(&header, &m.raw)?;
        }
        w.finish()?;
        Ok(())
    };
    write().map_err(|e| anyhow::anyhow!("writing {}: {e}", out.display()))?;
    crate::out!(
        "{}: {} messages on {} channels{}",
        out.display(),
        log.messages.len(),
        log.channels.len(),
        match &log.truncated {
            Some(why) => format!(" (the original stopped: {why})"),
            None => " (the original was complete)".into(),
        }
    );
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Plot
// ---------------------------------------------------------------------------------------------

const W: f64 = 960.0;
const LEFT: f64 = 78.0;
const RIGHT: f64 = 24.0;
const PANEL_H: f64 = 230.0;
const TOP: f64 = 64.0;
const GAP: f64 = 56.0;

/// "Nice" tick positions from at or below `lo` to at or above `hi`.
fn ticks(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    let span = (hi - lo).max(1e-9);
    let raw = span / target as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= target as f64 + 0.5)
        .unwrap_or(10.0 * mag);
    let first = (lo / step + 1e-9).floor() as i64;
    let last = (hi / step - 1e-9).ceil() as i64;
    (first..=last.max(first + 1))
        .map(|i| i as f64 * step)
        .collect()
}

fn fmt_tick(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    format!("{v:.decimals$}")
}

struct Panel {
    y0: f64,
    lo: f64,
    hi: f64,
}

impl Panel {
    fn y(&self, v: f64) -> f64 {
        self.y0 + PANEL_H - (v - self.lo) / (self.hi - self.lo) * PANEL_H
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn plot(path: &Path, out: &Path) -> Result<(), Failure> {
    let log = load(path)?;
    let tel: Vec<(f64, f64, [f64; 3])> = log
        .topic("/telemetry")
        .filter_map(|m| {
            let p = m.data["pressure_kpa"].as_f64()?;
            let s = &m.data["servo_deg"];
            Some((
                secs(m.log_ns),
                p,
                [s[0].as_f64()?, s[1].as_f64()?, s[2].as_f64()?],
            ))
        })
        .collect();
    if tel.len() < 2 {
        return Err(Failure::Runtime(anyhow::anyhow!(
            "{} has {} telemetry sample(s) on /telemetry: nothing to plot",
            path.display(),
            tel.len()
        )));
    }
    let truth: Vec<(f64, f64, u64)> = log
        .topic("/sim/truth")
        .filter_map(|m| {
            Some((
                secs(m.log_ns),
                m.data["pressure_kpa"].as_f64()?,
                m.data["snaps"].as_u64()?,
            ))
        })
        .collect();
    // Snap-throughs: the simulator's count going up (true), the device's confirmed states.
    let true_snaps: Vec<f64> = truth
        .windows(2)
        .filter(|w| w[1].2 > w[0].2)
        .map(|w| w[1].0)
        .collect();
    let reached: Vec<(f64, String)> = log
        .topic("/events")
        .filter(|m| m.data["kind"] == "state-reached")
        .filter(|m| m.data["event"]["StateReached"]["confirmed"] == true)
        .map(|m| {
            (
                secs(m.log_ns),
                m.data["text"]
                    .as_str()
                    .unwrap_or("")
                    .trim_start_matches("state ")
                    .to_string(),
            )
        })
        .collect();
    let t1 = tel[tel.len() - 1].0;
    let t0 = ticks(tel[0].0, t1, 10)[0];
    let xt: Vec<f64> = ticks(t0, t1, 10)
        .into_iter()
        .filter(|t| *t >= t0 - 1e-9 && *t <= t1 + 1e-9)
        .collect();
    let x = |t: f64| LEFT + (t - t0) / (t1 - t0).max(1e-9) * (W - LEFT - RIGHT);

    let pmax = tel
        .iter()
        .map(|s| s.1)
        .chain(truth.iter().map(|s| s.1))
        .fold(0.0f64, f64::max);
    let pmin = tel
        .iter()
        .map(|s| s.1)
        .chain(truth.iter().map(|s| s.1))
        .fold(0.0f64, f64::min);
    let pt = ticks(pmin, pmax.max(1.0) * 1.05, 6);
    let pressure = Panel {
        y0: TOP,
        lo: pt[0],
        hi: *pt.last().expect("ticks"),
    };
    let smin = tel.iter().flat_map(|s| s.2).fold(0.0f64, f64::min);
    let smax = tel.iter().flat_map(|s| s.2).fold(0.0f64, f64::max);
    let st = ticks(smin.min(0.0), smax.max(10.0), 6);
    let servo = Panel {
        y0: TOP + PANEL_H + GAP,
        lo: st[0],
        hi: *st.last().expect("ticks"),
    };
    let h = servo.y0 + PANEL_H + 110.0;

    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" viewBox="0 0 {W} {h}" font-family="DejaVu Sans, Helvetica, Arial, sans-serif" font-size="12">"#
    );
    let _ = writeln!(svg, r#"<rect width="{W}" height="{h}" fill="white"/>"#);
    let title = log
        .metadata
        .iter()
        .find_map(|(_, m)| m.get("device").map(|d| format!("{} — {d}", path.display())))
        .unwrap_or_else(|| path.display().to_string());
    let _ = writeln!(
        svg,
        r#"<text x="{LEFT}" y="24" font-size="15" font-weight="bold">{}</text>"#,
        esc(&title)
    );
    let _ = writeln!(
        svg,
        r##"<text x="{LEFT}" y="44" fill="#555555">{} telemetry samples over {:.2} s of device time; vertical lines: snap-throughs</text>"##,
        tel.len(),
        t1 - t0
    );

    let panels: [(&Panel, &[f64], &str); 2] = [
        (&pressure, &pt, "pressure (kPa)"),
        (&servo, &st, "servo command (°)"),
    ];
    for (p, yt, label) in panels {
        let (x0, x1) = (LEFT, W - RIGHT);
        let ystep = if yt.len() > 1 { yt[1] - yt[0] } else { 1.0 };
        for &v in yt {
            let y = p.y(v);
            let _ = writeln!(
                svg,
                "<line x1=\"{x0}\" y1=\"{y:.1}\" x2=\"{x1}\" y2=\"{y:.1}\" stroke=\"#e4e4e4\"/>\
                 <text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
                x0 - 6.0,
                y + 4.0,
                fmt_tick(v, ystep)
            );
        }
        let xstep = if xt.len() > 1 { xt[1] - xt[0] } else { 1.0 };
        for &t in &xt {
            let xx = x(t);
            let yb = p.y0 + PANEL_H;
            let _ = writeln!(
                svg,
                "<line x1=\"{xx:.1}\" y1=\"{:.1}\" x2=\"{xx:.1}\" y2=\"{yb:.1}\" stroke=\"#f0f0f0\"/>\
                 <line x1=\"{xx:.1}\" y1=\"{yb:.1}\" x2=\"{xx:.1}\" y2=\"{:.1}\" stroke=\"black\"/>\
                 <text x=\"{xx:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
                p.y0,
                yb + 5.0,
                yb + 18.0,
                fmt_tick(t, xstep)
            );
        }
        let _ = writeln!(
            svg,
            "<rect x=\"{x0}\" y=\"{}\" width=\"{}\" height=\"{PANEL_H}\" fill=\"none\" stroke=\"black\"/>",
            p.y0,
            x1 - x0
        );
        let cy = p.y0 + PANEL_H / 2.0;
        let _ = writeln!(
            svg,
            "<text transform=\"translate(22 {cy:.1}) rotate(-90)\" text-anchor=\"middle\" font-size=\"13\">{label}</text>"
        );
        let _ = writeln!(
            svg,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\" font-size=\"13\">device time (s)</text>",
            (x0 + x1) / 2.0,
            p.y0 + PANEL_H + 36.0
        );
        // Snap markers over both panels.
        for &t in &true_snaps {
            let xx = x(t);
            let _ = writeln!(
                svg,
                "<line x1=\"{xx:.1}\" y1=\"{}\" x2=\"{xx:.1}\" y2=\"{}\" stroke=\"#d62728\" stroke-width=\"1.2\"/>",
                p.y0,
                p.y0 + PANEL_H
            );
        }
        for (t, _) in &reached {
            let xx = x(*t);
            let _ = writeln!(
                svg,
                "<line x1=\"{xx:.1}\" y1=\"{}\" x2=\"{xx:.1}\" y2=\"{}\" stroke=\"#2ca02c\" stroke-width=\"1.2\" stroke-dasharray=\"5 3\"/>",
                p.y0,
                p.y0 + PANEL_H
            );
        }
    }
    for (t, name) in &reached {
        // Right of its line, or left of it near the right edge.
        let (lx, anchor) = if x(*t) > W - RIGHT - 40.0 {
            (x(*t) - 3.0, "end")
        } else {
            (x(*t) + 3.0, "start")
        };
        let _ = writeln!(
            svg,
            "<text x=\"{lx:.1}\" y=\"{:.1}\" fill=\"#2ca02c\" font-size=\"11\" text-anchor=\"{anchor}\">{}</text>",
            pressure.y0 + 13.0,
            esc(name)
        );
    }
    let poly = |pts: &mut dyn Iterator<Item = (f64, f64)>| -> String {
        let mut s = String::new();
        for (a, b) in pts {
            let _ = write!(s, "{a:.1},{b:.1} ");
        }
        s
    };
    if !truth.is_empty() {
        let pts = poly(
            &mut truth
                .iter()
                .filter(|s| s.0 >= t0 && s.0 <= t1)
                .map(|s| (x(s.0), pressure.y(s.1))),
        );
        let _ = writeln!(
            svg,
            "<polyline points=\"{pts}\" fill=\"none\" stroke=\"#999\" stroke-width=\"1\" stroke-dasharray=\"3 2\"/>"
        );
    }
    let pts = poly(&mut tel.iter().map(|s| (x(s.0), pressure.y(s.1))));
    let _ = writeln!(
        svg,
        "<polyline points=\"{pts}\" fill=\"none\" stroke=\"#1f77b4\" stroke-width=\"1.6\"/>"
    );
    let colours = ["#ff7f0e", "#9467bd", "#17becf"];
    for (k, c) in colours.iter().enumerate() {
        let pts = poly(&mut tel.iter().map(|s| (x(s.0), servo.y(s.2[k]))));
        let _ = writeln!(
            svg,
            "<polyline points=\"{pts}\" fill=\"none\" stroke=\"{c}\" stroke-width=\"1.6\"/>"
        );
    }
    // Legend.
    let mut entries: Vec<(&str, &str, &str)> = vec![("measured pressure", "#1f77b4", "")];
    if !truth.is_empty() {
        entries.push(("true pressure (simulator)", "#999", "3 2"));
    }
    entries.extend([
        ("servo 1", colours[0], ""),
        ("servo 2", colours[1], ""),
        ("servo 3", colours[2], ""),
    ]);
    if !true_snaps.is_empty() {
        entries.push(("snap-through (simulator truth)", "#d62728", ""));
    }
    entries.push(("state confirmed by the device", "#2ca02c", "5 3"));
    let mut ly = h - 44.0;
    let mut lx = LEFT;
    for (name, colour, dash) in entries {
        let width = 36.0 + 6.6 * name.chars().count() as f64;
        if lx + width > W - RIGHT {
            lx = LEFT;
            ly += 20.0;
        }
        let _ = writeln!(
            svg,
            "<line x1=\"{lx:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"{colour}\" stroke-width=\"2\" stroke-dasharray=\"{dash}\"/>\
             <text x=\"{:.1}\" y=\"{ly:.1}\">{}</text>",
            ly - 4.0,
            lx + 22.0,
            ly - 4.0,
            lx + 27.0,
            esc(name)
        );
        lx += width;
    }
    svg.push_str("</svg>\n");
    std::fs::write(out, svg).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", out.display()))?;
    crate::out!(
        "{}: {} samples, {} snap-throughs, {} confirmed states",
        out.display(),
        tel.len(),
        true_snaps.len(),
        reached.len()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_cover_the_range_with_round_steps() {
        let t = ticks(0.0, 10.2, 10);
        assert_eq!(t.first(), Some(&0.0));
        assert!(
            *t.last().unwrap() >= 10.2 && *t.last().unwrap() <= 12.0,
            "{t:?}"
        );
        let t = ticks(0.0, 31.7, 6);
        assert_eq!(t[1] - t[0], 5.0, "{t:?}");
        assert_eq!(t.last(), Some(&35.0), "{t:?}");
        let t = ticks(-0.2, 30.0, 6);
        assert!(t[0] <= -0.2 && *t.last().unwrap() >= 30.0, "{t:?}");
    }

    #[test]
    fn nested_values_flatten_to_columns() {
        let mut out = Vec::new();
        flatten(
            "",
            &serde_json::json!({"a": 1, "servo_deg": [1.5, 2, 3], "b": {"c": "x,y"}}),
            &mut out,
        );
        let keys: Vec<&str> = out.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(
            keys,
            ["a", "b.c", "servo_deg_0", "servo_deg_1", "servo_deg_2"]
        );
        assert_eq!(csv_cell("x,y"), "\"x,y\"");
    }
}
