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
use crate::figure::Format;

mod plot;

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
        /// The directory to write the CSV files into (created if missing); `-`: the one
        /// channel --topic selects, to stdout.
        #[arg(long, value_name = "DIR|-")]
        csv: PathBuf,
        /// Only this channel (repeatable), e.g. --topic /telemetry (`log summary` lists them).
        #[arg(long = "topic", value_name = "TOPIC")]
        topics: Vec<String>,
        #[command(flatten)]
        window: Window,
    },
    /// Pressure and servo traces with the snap-throughs marked, one journal column wide:
    /// SVG, PNG (600 dpi) or PDF, by the extension of --out or by --format.
    Plot {
        /// The MCAP file.
        file: PathBuf,
        /// The figure to write: FIG.svg, FIG.png or FIG.pdf.
        #[arg(long, value_name = "FIG")]
        out: PathBuf,
        /// The format (svg, png, pdf) when the extension of --out does not name one.
        #[arg(long, value_name = "FORMAT",
              value_parser = |s: &str| Format::parse(s).map_err(|e| format!("--format: {e}")))]
        format: Option<Format>,
        #[command(flatten)]
        window: Window,
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

/// A time window of a recording, in seconds after its first message.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct Window {
    /// From S seconds after the recording's first message [default: its start].
    #[arg(long, value_name = "S", allow_hyphen_values = true,
          value_parser = crate::num::number_in(0.0, 1e9))]
    from: Option<f64>,
    /// Up to S seconds after the recording's first message [default: its end].
    #[arg(long, value_name = "S", allow_hyphen_values = true,
          value_parser = crate::num::number_in(0.0, 1e9))]
    to: Option<f64>,
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
    // An input that cannot be read is the caller's to fix, as for every command's input file.
    let buf = std::fs::read(path)
        .map_err(|e| Failure::usage(format!("cannot read {}: {e}", path.display())))?;
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
        LogCommand::Export {
            file,
            csv,
            topics,
            window,
        } => export(&file, &csv, &topics, window),
        LogCommand::Plot {
            file,
            out,
            format,
            window,
        } => plot(&file, &out, format, window),
        LogCommand::Recover { file, out } => recover(&file, &out),
    }
}

impl Window {
    /// Refuses a window that ends before it starts.
    fn check(self) -> Result<Self, Failure> {
        match (self.from, self.to) {
            (Some(a), Some(b)) if b <= a => Err(Failure::usage(format!(
                "--to {b} must be later than --from {a} (seconds after the recording's first message)"
            ))),
            _ => Ok(self),
        }
    }

    /// Keeps the messages inside the window; says what it kept when it cut anything.
    fn apply(self, log: &mut Log) {
        if self.from.is_none() && self.to.is_none() {
            return;
        }
        let t0 = log.messages.iter().map(|m| m.log_ns).min().unwrap_or(0);
        let from = t0 + (self.from.unwrap_or(0.0) * 1e9) as u64;
        let to = self.to.map_or(u64::MAX, |s| t0 + (s * 1e9) as u64);
        let before = log.messages.len();
        log.messages.retain(|m| (from..=to).contains(&m.log_ns));
        crate::say!(
            "window {:.3} s – {}: {} of {before} messages",
            secs(from - t0),
            self.to
                .map_or("the end".to_string(), |s| format!("{s:.3} s")),
            log.messages.len()
        );
    }
}

/// Keeps only the channels named by `topics` (all when empty); an unknown name is refused
/// with the channels the recording has.
fn select_topics(log: &mut Log, topics: &[String]) -> Result<(), Failure> {
    if topics.is_empty() {
        return Ok(());
    }
    let known: Vec<&str> = log.channels.values().map(|c| c.0.as_str()).collect();
    if let Some(bad) = topics.iter().find(|t| !known.contains(&t.as_str())) {
        return Err(Failure::usage(format!(
            "--topic {bad}: the recording has no such channel; it has {}",
            known.join(", ")
        )));
    }
    log.channels.retain(|_, c| topics.contains(&c.0));
    Ok(())
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

fn export(path: &Path, dir: &Path, topics: &[String], window: Window) -> Result<(), Failure> {
    let window = window.check()?;
    let to_stdout = dir.as_os_str() == "-";
    if to_stdout && topics.len() != 1 {
        return Err(Failure::usage(
            "--csv - writes one channel to stdout: name it with --topic (e.g. --topic /telemetry); give a directory for several",
        ));
    }
    let mut log = load(path)?;
    select_topics(&mut log, topics)?;
    window.apply(&mut log);
    if to_stdout {
        if let Some((topic, (.., enc))) = log.channels.iter().next().map(|(_, c)| (&c.0, c)) {
            if enc != "json" {
                return Err(Failure::usage(format!(
                    "--topic {topic}: {enc} messages (the 3D scene) are not exported to CSV"
                )));
            }
        }
    } else {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
    }
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
        if to_stdout {
            crate::out!("{}", text.trim_end());
            crate::say!("{topic}: {} rows", rows.len());
            continue;
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

/// The format of `--out`: `--format`, else its extension; the two must agree.
fn figure_format(out: &Path, format: Option<Format>) -> Result<Format, Failure> {
    let by_name = Format::from_path(out);
    match format {
        Some(f) => {
            match by_name {
                Some(e) if e != f => Err(Failure::usage(format!(
                    "--format {} contradicts --out {} (a .{} name); give one of them",
                    f.name(),
                    out.display(),
                    e.name()
                ))),
                _ => Ok(f),
            }
        }
        None => by_name.ok_or_else(|| {
            Failure::usage(format!(
                "cannot tell the figure format of --out {}: name it .svg, .png or .pdf, or give --format ({})",
                out.display(),
                Format::NAMES
            ))
        }),
    }
}

fn plot(path: &Path, out: &Path, format: Option<Format>, window: Window) -> Result<(), Failure> {
    let format = figure_format(out, format)?;
    let window = window.check()?;
    let file = super::output::open_all(&[("--out", out)])?;
    let mut log = match load(path) {
        Ok(log) => log,
        Err(e) => {
            super::output::discard(file);
            return Err(e);
        }
    };
    window.apply(&mut log);
    let t = plot::traces(&log);
    let Some(fig) = plot::render(&t, &plot::title(path, &log)) else {
        super::output::discard(file);
        return Err(Failure::Runtime(anyhow::anyhow!(
            "{} has {} telemetry sample{} on /telemetry: nothing to plot",
            path.display(),
            t.telemetry.len(),
            if t.telemetry.len() == 1 { "" } else { "s" }
        )));
    };
    let bytes = fig
        .encode(format)
        .map_err(|e| anyhow::anyhow!("cannot draw {}: {e}", out.display()))?;
    for o in file {
        o.write(|w| w.write_all(&bytes))?;
    }
    crate::out!(
        "{}: {} samples, {} snap-throughs, {} confirmed states, {} declared, {} faults raised",
        out.display(),
        t.telemetry.len(),
        t.snaps.len(),
        t.reached.len(),
        t.declared.len(),
        t.faults.len()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
