//! `host-tool param get [NAME]` / `param set NAME VALUE`: read and change the device's tunable
//! parameters (pressure cap, servo limits and slew, telemetry rate, link timeout);
//! `param save FILE` / `param load FILE` / `param diff FILE`: all of them as a file, with the
//! firmware's schema id (docs/host.md, "Parameter files").

use clap::Subcommand;
use protocol::{ParamId, RejectReason, RequestBody, ResponseBody};
use serde_json::{json, Value};

use crate::device::{Connection, DeviceArgs};
use crate::failure::Failure;
use host::SessionError;

/// Arguments of `host-tool param`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub action: Action,
}

/// What `param` does.
#[derive(Debug, Subcommand)]
pub enum Action {
    /// Read one parameter, or all of them when NAME is omitted.
    Get {
        /// pressure-limit-kpa, servo-min-deg, servo-max-deg, servo-slew-deg-per-s,
        /// telemetry-hz or link-timeout-ms.
        #[arg(value_name = "NAME", value_parser = crate::arg::usage(parse_param))]
        name: Option<ParamId>,
        #[command(flatten)]
        device: DeviceArgs,
        /// Print one JSON object on stdout.
        #[arg(skip)]
        json: bool,
    },
    /// Change one parameter (checked against its range before anything is sent).
    Set {
        /// pressure-limit-kpa, servo-min-deg, servo-max-deg, servo-slew-deg-per-s,
        /// telemetry-hz or link-timeout-ms.
        #[arg(value_name = "NAME", value_parser = crate::arg::usage(parse_param))]
        name: ParamId,
        /// The new value, in the parameter's unit.
        // Hyphen values allowed so a negative number reaches the range check (exit 2 with the
        // range) instead of being taken for an unknown flag.
        #[arg(value_name = "VALUE", allow_hyphen_values = true)]
        value: String,
        #[command(flatten)]
        device: DeviceArgs,
        /// Print one JSON object on stdout.
        #[arg(skip)]
        json: bool,
    },
    /// Write every parameter to FILE (JSON, with the firmware's schema id).
    Save {
        /// The parameter file to write (replaced whole; `-` for standard output).
        #[arg(value_name = "FILE")]
        file: String,
        #[command(flatten)]
        device: DeviceArgs,
        /// Print one JSON object on stdout (what was written).
        #[arg(skip)]
        json: bool,
    },
    /// Set the parameters of FILE on the device: the whole file is checked first (its
    /// schema, names and ranges), then only the values that differ are written.
    Load {
        /// A file `param save` wrote (`-` for standard input).
        #[arg(value_name = "FILE")]
        file: String,
        /// Check the file and show what would change; write nothing.
        #[arg(long)]
        dry_run: bool,
        #[command(flatten)]
        device: DeviceArgs,
        /// Print one JSON object on stdout.
        #[arg(skip)]
        json: bool,
    },
    /// Compare the device's parameters with FILE's.
    Diff {
        /// A file `param save` wrote (`-` for standard input).
        #[arg(value_name = "FILE")]
        file: String,
        #[command(flatten)]
        device: DeviceArgs,
        /// Print one JSON object on stdout.
        #[arg(skip)]
        json: bool,
    },
}

pub use host::text::{param_name, param_unit};

/// The `format` a parameter file names.
pub const FILE_FORMAT: &str = "yoshimura-crane-params";
/// The parameter file's layout version.
pub const FILE_VERSION: u64 = 1;

/// A parameter file, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamFile {
    /// The schema id of the firmware that saved it.
    pub schema_id: u32,
    /// The firmware version that saved it, as text (for messages).
    pub firmware: String,
    /// The values, in [`ParamId::ALL`]'s order (a file may hold some of them only).
    pub values: Vec<(ParamId, f32)>,
}

impl ParamFile {
    /// The file as JSON text.
    pub fn to_json(&self) -> Value {
        let params: serde_json::Map<String, Value> = self
            .values
            .iter()
            .map(|&(id, v)| (param_name(id).to_owned(), json_f32(v)))
            .collect();
        json!({
            "format": FILE_FORMAT,
            "version": FILE_VERSION,
            "schema_id": self.schema_id,
            "firmware": self.firmware,
            "params": params,
        })
    }

    /// Reads a file's text, checking all of it: every problem is named (`what` names the
    /// file in the messages).
    pub fn parse(what: &str, text: &str) -> Result<Self, Failure> {
        let bad = |why: String| Failure::usage(format!("{what}: {why}"));
        let v: Value = serde_json::from_str(text).map_err(|e| {
            bad(format!(
                "not a parameter file (JSON, as `host-tool param save` writes): {e}"
            ))
        })?;
        if v["format"] != FILE_FORMAT {
            return Err(bad(format!(
                "\"format\" is {}, expected \"{FILE_FORMAT}\" (a file `host-tool param save` wrote)",
                v["format"]
            )));
        }
        if v["version"].as_u64() != Some(FILE_VERSION) {
            return Err(bad(format!(
                "\"version\" is {}, this host-tool reads version {FILE_VERSION}",
                v["version"]
            )));
        }
        let schema_id = v["schema_id"]
            .as_u64()
            .and_then(|s| u32::try_from(s).ok())
            .ok_or_else(|| {
                bad(format!(
                    "\"schema_id\" is {}, expected a 32-bit id",
                    v["schema_id"]
                ))
            })?;
        let params = v["params"]
            .as_object()
            .ok_or_else(|| bad("\"params\" must be an object of name: value".into()))?;
        let mut problems = Vec::new();
        let mut values = Vec::new();
        for (name, value) in params {
            let id = match parse_param(name) {
                Ok(id) => id,
                Err(Failure::Usage(m)) => {
                    problems.push(m);
                    continue;
                }
                Err(e) => return Err(e),
            };
            match value.as_f64().map(|x| x as f32) {
                Some(x) if id.accepts(x) => values.push((id, x)),
                _ => {
                    let (lo, hi) = id.range();
                    problems.push(format!(
                        "{name} = {value}: expected a {}number from {lo} to {hi} {}",
                        if id.is_integer() { "whole " } else { "" },
                        param_unit(id)
                    ));
                }
            }
        }
        if !problems.is_empty() {
            return Err(bad(problems.join("; ")));
        }
        if values.is_empty() {
            return Err(bad("\"params\" names no parameter".into()));
        }
        let min = values
            .iter()
            .find(|p| p.0 == ParamId::ServoMinDeg)
            .map(|p| p.1);
        let max = values
            .iter()
            .find(|p| p.0 == ParamId::ServoMaxDeg)
            .map(|p| p.1);
        if let (Some(lo), Some(hi)) = (min, max) {
            if lo > hi {
                return Err(bad(format!(
                    "servo-min-deg {lo} is above servo-max-deg {hi}"
                )));
            }
        }
        values.sort_by_key(|p| ParamId::ALL.iter().position(|id| *id == p.0));
        Ok(Self {
            schema_id,
            firmware: v["firmware"].as_str().unwrap_or("unknown").to_owned(),
            values,
        })
    }
}

fn firmware_text(info: &protocol::DeviceInfo) -> String {
    let [a, b, c] = info.firmware_version;
    format!("{a}.{b}.{c}")
}

/// Reads FILE (`-`: standard input).
fn read_file(path: &str) -> Result<ParamFile, Failure> {
    let text = if path == "-" {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut std::io::stdin(), &mut s)
            .map_err(|e| Failure::usage(format!("reading standard input: {e}")))?;
        s
    } else {
        std::fs::read_to_string(path)
            .map_err(|e| Failure::usage(format!("cannot read the parameter file {path}: {e}")))?
    };
    ParamFile::parse(if path == "-" { "standard input" } else { path }, &text)
}

/// One parameter that differs: its id, the device's value, the file's.
type Difference = (ParamId, f32, f32);

/// What a load found to change, and what the device holds after each write.
type Loaded = (Vec<Difference>, Vec<(ParamId, f32)>);

/// The values that differ between the device's `now` and `file`'s.
fn differences(now: &[(ParamId, f32)], file: &ParamFile) -> Vec<(ParamId, f32, f32)> {
    file.values
        .iter()
        .filter_map(|&(id, want)| {
            let have = now.iter().find(|p| p.0 == id)?.1;
            (have != want).then_some((id, have, want))
        })
        .collect()
}

impl Args {
    /// Whether JSON was asked for.
    pub fn json(&self) -> bool {
        match &self.action {
            Action::Get { json, .. }
            | Action::Set { json, .. }
            | Action::Save { json, .. }
            | Action::Load { json, .. }
            | Action::Diff { json, .. } => *json,
        }
    }

    /// Sets whether JSON was asked for (the global `-j/--json`).
    pub fn set_json(&mut self, on: bool) {
        match &mut self.action {
            Action::Get { json, .. }
            | Action::Set { json, .. }
            | Action::Save { json, .. }
            | Action::Load { json, .. }
            | Action::Diff { json, .. } => *json = on,
        }
    }
}

/// Parses a parameter name; the error lists the six valid names.
pub fn parse_param(name: &str) -> Result<ParamId, Failure> {
    ParamId::ALL
        .iter()
        .copied()
        .find(|&id| param_name(id) == name)
        .ok_or_else(|| {
            let names: Vec<&str> = ParamId::ALL.iter().map(|&id| param_name(id)).collect();
            Failure::usage(format!(
                "unknown parameter '{name}': valid names are {}",
                names.join(", ")
            ))
        })
}

/// Parses a value for `id` and checks it against the parameter's range (the device would
/// refuse it anyway; checking here gives the range in the message and sends nothing).
pub fn parse_value(id: ParamId, value: &str) -> Result<f32, Failure> {
    let (lo, hi) = id.range();
    let out_of_range = || {
        Failure::usage(format!(
            "invalid value '{value}' for {}: it must be a {}number from {} to {} {}",
            param_name(id),
            if id.is_integer() { "whole " } else { "" },
            lo,
            hi,
            param_unit(id)
        ))
    };
    let v: f32 = value.trim().parse().map_err(|_| out_of_range())?;
    if id.accepts(v) {
        Ok(v)
    } else {
        Err(out_of_range())
    }
}

/// An `f32` as JSON with its shortest decimal form (30.1, not 30.100000381469727).
fn json_f32(v: f32) -> Value {
    if v.is_finite() && v.fract() == 0.0 && v.abs() < 9.0e15 {
        // A whole value is written whole (3000, not 3000.0).
        return Value::from(v as i64);
    }
    v.to_string()
        .parse::<f64>()
        .ok()
        .and_then(serde_json::Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

/// A device failure (exit 1), with what the device's reason means for this parameter.
fn device_failure(id: ParamId, err: SessionError) -> Failure {
    let hint = match (&err, id) {
        (
            SessionError::Rejected {
                reason: RejectReason::OutOfRange,
                refusal: None,
                ..
            },
            ParamId::ServoMinDeg | ParamId::ServoMaxDeg,
        ) => " (servo-min-deg must not exceed servo-max-deg)",
        _ => "",
    };
    let mut e = crate::cli::DeviceError::session(&format!("{}: ", param_name(id)), &err);
    e.message += hint;
    Failure::Runtime(anyhow::Error::new(e))
}

/// The device, or the server that holds it.
enum Link {
    Direct(Box<Connection>),
    Server(std::path::PathBuf),
}

impl Link {
    fn open(device: &DeviceArgs) -> Result<Self, Failure> {
        Ok(match crate::client::server_for(device)? {
            Some(path) => Link::Server(path),
            None => Link::Direct(Box::new(device.validate(None)?.connect()?)),
        })
    }

    fn command(
        &mut self,
        body: RequestBody,
    ) -> Result<Result<ResponseBody, SessionError>, Failure> {
        match self {
            Link::Direct(conn) => Ok(conn.session.command(body)),
            Link::Server(path) => crate::client::call(path, body),
        }
    }

    fn close(self) {
        if let Link::Direct(conn) = self {
            conn.close();
        }
    }

    /// Who the device is.
    fn info(&mut self) -> Result<protocol::DeviceInfo, Failure> {
        match self {
            Link::Direct(conn) => Ok(conn.info.clone()),
            Link::Server(path) => Ok(crate::client::snapshot(path, None)?.info),
        }
    }
}

/// Every parameter the device holds.
fn get_all(conn: &mut Link) -> Result<Vec<(ParamId, f32)>, Failure> {
    ParamId::ALL
        .iter()
        .map(|&id| get(conn, id).map(|v| (id, v)))
        .collect()
}

/// Writes `value` to `id`, returning what the device holds after.
fn set(conn: &mut Link, id: ParamId, value: f32) -> Result<f32, Failure> {
    match conn
        .command(RequestBody::SetParam { id, value })?
        .map_err(|e| device_failure(id, e))?
    {
        ResponseBody::Param { id: got, value } if got == id => Ok(value),
        _ => get(conn, id),
    }
}

/// Reads one parameter from the device.
fn get(conn: &mut Link, id: ParamId) -> Result<f32, Failure> {
    match conn
        .command(RequestBody::GetParam(id))?
        .map_err(|e| device_failure(id, e))?
    {
        ResponseBody::Param { id: got, value } if got == id => Ok(value),
        other => Err(Failure::Runtime(anyhow::anyhow!(
            "unexpected answer to GetParam({}): {other:?}",
            param_name(id)
        ))),
    }
}

/// One parameter as a JSON object.
fn param_json(id: ParamId, value: f32) -> Value {
    let (lo, hi) = id.range();
    json!({
        "name": param_name(id),
        "value": json_f32(value),
        "unit": param_unit(id),
        "min": json_f32(lo),
        "max": json_f32(hi),
    })
}

/// One parameter as a line of text.
fn param_line(id: ParamId, value: f32) -> String {
    let (lo, hi) = id.range();
    format!(
        "{:<22}{} {} (range {}–{})",
        param_name(id),
        value,
        param_unit(id),
        lo,
        hi
    )
}

/// Runs `host-tool param`.
pub fn run(args: Args) -> Result<(), Failure> {
    match args.action {
        Action::Save { file, device, json } => run_save(&file, &device, json),
        Action::Load {
            file,
            dry_run,
            device,
            json,
        } => run_load(&file, dry_run, &device, json),
        Action::Diff { file, device, json } => run_diff(&file, &device, json),
        Action::Get { name, device, json } => {
            // Everything the user typed is checked before a device is opened.
            let ids = match name {
                Some(id) => vec![id],
                None => ParamId::ALL.to_vec(),
            };
            let mut conn = Link::open(&device)?;
            let mut values = Vec::with_capacity(ids.len());
            for &id in &ids {
                values.push((id, get(&mut conn, id)?));
            }
            conn.close();
            if json {
                let params: Vec<Value> = values.iter().map(|&(id, v)| param_json(id, v)).collect();
                crate::cli::print_json(json!({ "params": params }));
            } else {
                for (id, v) in values {
                    crate::out!("{}", param_line(id, v));
                }
            }
            Ok(())
        }
        Action::Set {
            name,
            value,
            device,
            json,
        } => {
            let id = name;
            let value = parse_value(id, &value)?;
            let mut conn = Link::open(&device)?;
            let previous = get(&mut conn, id)?;
            let now = match conn
                .command(RequestBody::SetParam { id, value })?
                .map_err(|e| device_failure(id, e))?
            {
                ResponseBody::Param { id: got, value } if got == id => value,
                // The device confirms a write with the value it now holds; read it if not.
                _ => get(&mut conn, id)?,
            };
            conn.close();
            if json {
                let mut v = param_json(id, now);
                v["previous"] = json_f32(previous);
                crate::cli::print_json(v);
            } else {
                crate::out!(
                    "{} set: {} {} (was {} {})",
                    param_name(id),
                    now,
                    param_unit(id),
                    previous,
                    param_unit(id)
                );
            }
            Ok(())
        }
    }
}

fn diff_json(d: &[(ParamId, f32, f32)]) -> Value {
    Value::Array(
        d.iter()
            .map(|&(id, have, want)| {
                json!({"name": param_name(id), "device": json_f32(have), "file": json_f32(want),
                       "unit": param_unit(id)})
            })
            .collect(),
    )
}

fn schema_check(
    file: &ParamFile,
    info: &protocol::DeviceInfo,
    d: &[(ParamId, f32, f32)],
) -> Option<String> {
    (file.schema_id != info.schema_id).then(|| {
        let names: Vec<&str> = d.iter().map(|p| param_name(p.0)).collect();
        format!(
            "the file is from firmware {} (schema {:#010x}), the device runs {} (schema {:#010x}): its values may not mean the same here; parameters that differ: {}",
            file.firmware,
            file.schema_id,
            firmware_text(info),
            info.schema_id,
            if names.is_empty() { "none".to_string() } else { names.join(", ") }
        )
    })
}

fn run_save(file: &str, device: &DeviceArgs, json_out: bool) -> Result<(), Failure> {
    if file != "-" && std::path::Path::new(file).is_dir() {
        return Err(Failure::usage(format!(
            "{file} is a directory: give the parameter file's path"
        )));
    }
    let mut conn = Link::open(device)?;
    let info = conn.info()?;
    let values = get_all(&mut conn);
    conn.close();
    let pf = ParamFile {
        schema_id: info.schema_id,
        firmware: firmware_text(&info),
        values: values?,
    };
    let text = format!(
        "{}\n",
        serde_json::to_string_pretty(&crate::num::clean(pf.to_json()))
            .map_err(|e| anyhow::anyhow!(e))?
    );
    if file == "-" {
        crate::cli::write_stdout(format_args!("{text}"));
        return Ok(());
    }
    let tmp = format!("{file}.tmp");
    std::fs::write(&tmp, &text)
        .and_then(|()| std::fs::rename(&tmp, file))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            Failure::Runtime(anyhow::anyhow!("writing {file}: {e}"))
        })?;
    if json_out {
        crate::cli::print_json(
            json!({"file": file, "bytes": text.len(), "params": pf.values.len(),
                                      "schema_id": pf.schema_id, "firmware": pf.firmware}),
        );
    } else {
        crate::out!(
            "wrote {file}: {} parameters of firmware {} (schema {:#010x}), {} bytes",
            pf.values.len(),
            pf.firmware,
            pf.schema_id,
            text.len()
        );
    }
    Ok(())
}

fn run_load(file: &str, dry_run: bool, device: &DeviceArgs, json_out: bool) -> Result<(), Failure> {
    let pf = read_file(file)?;
    let mut conn = Link::open(device)?;
    let r = (|| -> Result<Loaded, Failure> {
        let info = conn.info()?;
        let now = get_all(&mut conn)?;
        let d = differences(&now, &pf);
        if let Some(why) = schema_check(&pf, &info, &d) {
            return Err(Failure::Runtime(anyhow::anyhow!("refused: {why}")));
        }
        if dry_run {
            return Ok((d, Vec::new()));
        }
        // The servo limits move as a pair: when the new minimum is above the present maximum,
        // the maximum goes first (each write must keep min ≤ max).
        let mut order = d.clone();
        let cur_max = now
            .iter()
            .find(|p| p.0 == ParamId::ServoMaxDeg)
            .map_or(f32::MAX, |p| p.1);
        let new_min = order
            .iter()
            .find(|p| p.0 == ParamId::ServoMinDeg)
            .map(|p| p.2);
        if new_min.is_some_and(|m| m > cur_max) {
            order.sort_by_key(|p| u8::from(p.0 != ParamId::ServoMaxDeg));
        }
        let mut written = Vec::new();
        for (id, _, want) in order {
            written.push((id, set(&mut conn, id, want)?));
        }
        Ok((d, written))
    })();
    conn.close();
    let (d, written) = r?;
    if json_out {
        crate::cli::print_json(
            json!({"file": file, "dry_run": dry_run, "changes": diff_json(&d),
                                      "written": written.len()}),
        );
    } else {
        for &(id, have, want) in &d {
            crate::out!("{:<22}{have} → {want} {}", param_name(id), param_unit(id));
        }
        crate::out!(
            "{}: {} of {} parameters {}",
            file,
            d.len(),
            pf.values.len(),
            if dry_run {
                "would change (dry run: nothing written)"
            } else {
                "changed"
            }
        );
    }
    Ok(())
}

fn run_diff(file: &str, device: &DeviceArgs, json_out: bool) -> Result<(), Failure> {
    let pf = read_file(file)?;
    let mut conn = Link::open(device)?;
    let r = (|| -> Result<_, Failure> { Ok((conn.info()?, get_all(&mut conn)?)) })();
    conn.close();
    let (info, now) = r?;
    let d = differences(&now, &pf);
    let schema = schema_check(&pf, &info, &d);
    if json_out {
        crate::cli::print_json(json!({"file": file, "same_schema": schema.is_none(),
                                      "differ": diff_json(&d), "compared": pf.values.len()}));
    } else {
        if let Some(s) = &schema {
            crate::say!("note: {s}");
        }
        crate::out!("{:<22}{:>12}{:>12}", "parameter", "device", "file");
        for &(id, have, want) in &d {
            crate::out!(
                "{:<22}{have:>12}{want:>12} {}",
                param_name(id),
                param_unit(id)
            );
        }
        crate::out!("{} of {} parameters differ", d.len(), pf.values.len());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_round_trips_and_names_are_distinct() {
        for id in ParamId::ALL {
            assert_eq!(parse_param(param_name(id)).unwrap(), id);
        }
        let Err(Failure::Usage(msg)) = parse_param("pressure_limit_kpa") else {
            panic!("snake case is not a valid name")
        };
        for id in ParamId::ALL {
            assert!(msg.contains(param_name(id)), "{msg}");
        }
    }

    #[test]
    fn values_are_checked_against_the_range_with_its_bounds_in_the_message() {
        assert_eq!(parse_value(ParamId::PressureLimitKpa, "30").unwrap(), 30.0);
        assert_eq!(parse_value(ParamId::PressureLimitKpa, "60").unwrap(), 60.0);
        for bad in ["60.5", "-1", "NaN", "inf", "thirty", ""] {
            let Err(Failure::Usage(msg)) = parse_value(ParamId::PressureLimitKpa, bad) else {
                panic!("{bad} accepted")
            };
            assert!(msg.contains("from 0 to 60 kPa"), "{msg}");
        }
        assert!(parse_value(ParamId::LinkTimeoutMs, "199").is_err());
    }

    #[test]
    fn a_device_refusal_is_a_runtime_failure_with_its_reason() {
        let err = SessionError::Rejected {
            request: "SetParam",
            reason: RejectReason::OutOfRange,
            refusal: None,
        };
        let Failure::Runtime(e) = device_failure(ParamId::ServoMinDeg, err) else {
            panic!("a refusal is exit 1")
        };
        let msg = format!("{e:#}");
        assert!(msg.contains("a value is out of range"), "{msg}");
        assert!(msg.contains("must not exceed servo-max-deg"), "{msg}");
        // A device that names the field: its value and the limit are in the message.
        let err = SessionError::Rejected {
            request: "SetParam",
            reason: RejectReason::OutOfRange,
            refusal: Some(protocol::Refusal {
                step: None,
                field: protocol::RefusedField::Param(ParamId::ServoMinDeg),
                value: 120.0,
                limit: 100.0,
            }),
        };
        let Failure::Runtime(e) = device_failure(ParamId::ServoMinDeg, err) else {
            panic!("a refusal is exit 1")
        };
        let msg = format!("{e:#}");
        assert!(
            msg.contains("servo-min-deg 120 deg would pass servo-max-deg = 100 deg"),
            "{msg}"
        );
    }

    #[test]
    fn a_parameter_file_round_trips_and_every_problem_is_named() {
        let pf = ParamFile {
            schema_id: 0xdead_beef,
            firmware: "0.1.0".into(),
            values: ParamId::ALL.iter().map(|&id| (id, id.range().0)).collect(),
        };
        let text = pf.to_json().to_string();
        assert_eq!(ParamFile::parse("f", &text).unwrap(), pf);
        let with = |params: &str| {
            format!(r#"{{"format":"{FILE_FORMAT}","version":1,"schema_id":1,"params":{params}}}"#)
        };
        let err = |t: &str| match ParamFile::parse("f", t) {
            Err(Failure::Usage(m)) => m,
            other => panic!("{other:?}"),
        };
        let m = err(&with(
            r#"{"pressure-limit-kpa": 99, "nope": 1, "link-timeout-ms": 250.5}"#,
        ));
        assert!(
            m.contains("pressure-limit-kpa = 99: expected a number from 0 to 60 kPa"),
            "{m}"
        );
        assert!(m.contains("unknown parameter 'nope'"), "{m}");
        assert!(
            m.contains("link-timeout-ms = 250.5: expected a whole number"),
            "{m}"
        );
        let m = err(&with(r#"{"servo-min-deg": 100, "servo-max-deg": 90}"#));
        assert!(
            m.contains("servo-min-deg 100 is above servo-max-deg 90"),
            "{m}"
        );
        assert!(err(&with("{}")).contains("names no parameter"));
        assert!(err("{").contains("not a parameter file"));
        assert!(err(r#"{"format":"x"}"#).contains("\"format\""));
        let v2 = text.replace("\"version\":1", "\"version\":2");
        assert!(err(&v2).contains("reads version 1"), "{}", err(&v2));
        // A partial file is a file: only its values are compared and loaded.
        let one = ParamFile::parse("f", &with(r#"{"telemetry-hz": 5}"#)).unwrap();
        assert_eq!(one.values, vec![(ParamId::TelemetryHz, 5.0)]);
    }

    #[test]
    fn json_values_keep_their_short_decimal_form() {
        assert_eq!(json_f32(30.1).to_string(), "30.1");
        assert_eq!(json_f32(f32::NAN), Value::Null);
        assert_eq!(json_f32(3000.0).to_string(), "3000");
        assert_eq!(json_f32(-2.0).to_string(), "-2");
    }
}
