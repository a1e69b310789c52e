//! The client side of `host-tool serve`: which server serves a device ([`crate::sockets`]:
//! where their sockets are), and its protocol's lines ([`crate::serve_protocol`]) each way. A
//! command given `--port P` goes through the server of P if one answers; a command given
//! neither `--port` nor `--sim` goes through the one server that runs (several: it must be
//! told which).

use std::io::{BufRead as _, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::PathBuf;

use crate::device::DeviceArgs;
use crate::failure::Failure;
use crate::serve_protocol::{DeviceRequest, Reply, Request};
use crate::sockets::{socket_dir, socket_name};

/// The server that serves the device `args` names, if one answers: `--port P` → P's server;
/// neither `--port` nor `--sim` → the one server running. `--sim` is always the in-process
/// simulator.
pub fn server_for(args: &DeviceArgs) -> Result<Option<PathBuf>, Failure> {
    if args.sim {
        return Ok(None);
    }
    let dir = socket_dir();
    if let Some(port) = &args.port {
        let path = dir.join(socket_name(Some(port)));
        let served = UnixStream::connect(&path).is_ok();
        if served && args.take_over {
            return Err(Failure::usage(format!(
                "--take-over takes the device's session directly, but a `host-tool serve` \
                 server holds {port} (socket {}): run the command without --take-over (it goes \
                 through the server), or stop the server first",
                path.display()
            )));
        }
        return Ok(served.then_some(path));
    }
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Ok(None);
    };
    let live: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "sock"))
        .filter(|p| UnixStream::connect(p).is_ok())
        .collect();
    if args.take_over && !live.is_empty() {
        return Err(Failure::usage(
            "--take-over takes the device's session directly, but a `host-tool serve` server \
             holds it: run the command without --take-over (it goes through the server), or \
             stop the server first",
        ));
    }
    match live.len() {
        0 => Ok(None),
        1 => Ok(live.into_iter().next()),
        _ => Err(Failure::usage(format!(
            "{} servers run ({}): give --port PATH to say which",
            live.len(),
            live.iter()
                .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().replace('_', "/")))
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}

/// A connection to a server.
pub struct Client {
    reader: BufReader<UnixStream>,
    writer: UnixStream,
    partial: Vec<u8>,
}

/// What a client says when the server is gone.
pub const SERVER_GONE: &str = "the server went away (host-tool serve ended); if the crane was \
    moving, its link watchdog stops it";

impl Client {
    /// Connects to the server at `path`.
    pub fn connect(path: &std::path::Path) -> Result<Self, Failure> {
        let s = UnixStream::connect(path)
            .map_err(|e| anyhow::anyhow!("cannot reach the server at {}: {e}", path.display()))?;
        Ok(Self {
            reader: BufReader::new(s.try_clone().map_err(anyhow::Error::from)?),
            writer: s,
            partial: Vec::new(),
        })
    }

    /// Sends one request line.
    pub fn send(&mut self, request: &Request) -> Result<(), Failure> {
        let mut line = serde_json::to_string(request)
            .map_err(|e| Failure::Runtime(anyhow::anyhow!("encoding the request: {e}")))?;
        line.push('\n');
        self.writer
            .write_all(line.as_bytes())
            .map_err(|_| Failure::Runtime(anyhow::anyhow!("{SERVER_GONE}")))
    }

    /// The next line from the server; the server's going away is an error that says so.
    pub fn recv(&mut self) -> Result<Reply, Failure> {
        self.writer
            .set_read_timeout(None)
            .map_err(anyhow::Error::from)?;
        loop {
            if let Some(v) = self.recv_timeout()? {
                return Ok(v);
            }
        }
    }

    /// The next line if one comes within a short wait (100 ms), `None` otherwise; an error
    /// line is an error.
    pub fn recv_within(&mut self) -> Result<Option<Reply>, Failure> {
        self.writer
            .set_read_timeout(Some(std::time::Duration::from_millis(100)))
            .map_err(anyhow::Error::from)?;
        match self.recv_timeout()? {
            Some(Reply::Error { error }) => Err(Failure::Runtime(anyhow::anyhow!("{error}"))),
            other => Ok(other),
        }
    }

    fn recv_timeout(&mut self) -> Result<Option<Reply>, Failure> {
        match self.reader.read_until(b'\n', &mut self.partial) {
            Ok(0) => Err(Failure::Runtime(anyhow::anyhow!("{SERVER_GONE}"))),
            Ok(_) if self.partial.ends_with(b"\n") => {
                let line = std::mem::take(&mut self.partial);
                serde_json::from_slice(&line).map(Some).map_err(|e| {
                    Failure::Runtime(anyhow::anyhow!(
                        "the server sent a bad line ({e}): {}",
                        String::from_utf8_lossy(&line)
                    ))
                })
            }
            Ok(_) => Err(Failure::Runtime(anyhow::anyhow!("{SERVER_GONE}"))),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                Ok(None)
            }
            Err(_) => Err(Failure::Runtime(anyhow::anyhow!("{SERVER_GONE}"))),
        }
    }

    /// The next line, or an error line's message as a runtime failure.
    pub fn recv_ok(&mut self) -> Result<Reply, Failure> {
        match self.recv()? {
            Reply::Error { error } => Err(Failure::Runtime(anyhow::anyhow!("{error}"))),
            v => Ok(v),
        }
    }
}

/// A reply of another kind than the request asks for.
fn unexpected(expected: &str, got: &Reply) -> Failure {
    Failure::Runtime(anyhow::anyhow!(
        "the server answered with {} where {expected} was expected",
        got.kind()
    ))
}

/// A run through a server ([`Request::Plan`], [`Request::Identify`]): its notes on stderr,
/// then the outcome (`plan --json`'s document) and whether it reached its target.
pub fn run(
    path: &std::path::Path,
    request: &Request,
) -> Result<(crate::outcome::PlanOutcome, bool), Failure> {
    let mut c = Client::connect(path)?;
    c.send(request)?;
    loop {
        match c.recv_ok()? {
            Reply::Note { note } => crate::say!("{}", note.trim_end()),
            Reply::Outcome { outcome, ok } => return Ok((*outcome, ok)),
            other => return Err(unexpected("a note or the outcome", &other)),
        }
    }
}

/// `status`/`stop`/`declare` through a server: the request (if any), then a status.
pub fn snapshot(
    path: &std::path::Path,
    request: Option<protocol::RequestBody>,
) -> Result<crate::outcome::Snapshot, Failure> {
    let mut c = Client::connect(path)?;
    c.send(&Request::Snapshot {
        request: request.map(DeviceRequest),
    })?;
    match c.recv_ok()? {
        Reply::Snapshot {
            status,
            info,
            truth,
            abort_latency_ms,
        } => Ok(crate::outcome::Snapshot {
            status,
            info,
            truth,
            abort_latency_ms,
            server: Some(path.to_path_buf()),
        }),
        other => Err(unexpected("a snapshot", &other)),
    }
}

/// One request through a server, answered as the engine would (`param`, the primitives).
pub fn call(
    path: &std::path::Path,
    body: protocol::RequestBody,
) -> Result<Result<protocol::ResponseBody, host::SessionError>, Failure> {
    let name = host::text::request_name(&body);
    let mut c = Client::connect(path)?;
    c.send(&Request::Call {
        request: DeviceRequest(body),
    })?;
    match c.recv_ok()? {
        Reply::Call { result, body } => Ok(host::Reply { result, body }.accepted(name)),
        other => Err(unexpected("the device's answer", &other)),
    }
}
