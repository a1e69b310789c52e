//! The client side of `host-tool serve`: where a server's socket is, and its protocol's lines
//! ([`crate::serve_protocol`]) each way.
//!
//! Sockets live in a directory only the user can enter (`$XDG_RUNTIME_DIR/host-tool`, else
//! `/tmp/host-tool-UID`, mode 0700; each socket 0600), one per device: the port's path with
//! `/` as `_`, or `sim` for a simulator. A command given `--port P` goes through the server of
//! P if one answers; a command given neither `--port` nor `--sim` goes through the one server
//! that runs (several: it must be told which).

use std::io::{BufRead as _, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::PathBuf;

use crate::device::DeviceArgs;
use crate::failure::Failure;
use crate::serve_protocol::{DeviceRequest, Reply, Request};

/// The directory of the servers' sockets (created 0700 by [`socket_dir_create`]).
pub fn socket_dir() -> PathBuf {
    match std::env::var_os("XDG_RUNTIME_DIR") {
        Some(d) if !d.is_empty() => PathBuf::from(d).join("host-tool"),
        _ => PathBuf::from(format!("/tmp/host-tool-{}", uid())),
    }
}

/// This process's user id (the owner of `/proc/self`).
fn uid() -> u32 {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").map_or(0, |m| m.uid())
}

/// Creates the socket directory, user-only; refuses one that others can enter or that
/// belongs to someone else.
pub fn socket_dir_create() -> anyhow::Result<PathBuf> {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
    let dir = socket_dir();
    if !dir.exists() {
        std::fs::DirBuilder::new()
            .mode(0o700)
            .recursive(true)
            .create(&dir)?;
    }
    let meta = std::fs::metadata(&dir)?;
    if meta.uid() != uid() {
        anyhow::bail!("{} belongs to another user", dir.display());
    }
    if meta.permissions().mode() & 0o077 != 0 {
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700))?;
    }
    Ok(dir)
}

/// The socket's file name for a device: `sim`, or the port's path.
pub fn socket_name(port: Option<&str>) -> String {
    match port {
        None => "sim.sock".into(),
        Some(p) => format!("{}.sock", p.replace('/', "_")),
    }
}

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

/// The devices whose server socket is left behind by a server that no longer runs (killed
/// before it could remove it): the device (`the simulator` or the port) and the socket.
pub fn stale_servers() -> Vec<(String, PathBuf)> {
    let Ok(entries) = std::fs::read_dir(socket_dir()) else {
        return Vec::new();
    };
    let mut stale: Vec<(String, PathBuf)> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "sock"))
        .filter(|p| UnixStream::connect(p).is_err())
        .filter_map(|p| {
            let stem = p.file_stem()?.to_string_lossy().into_owned();
            let device = if stem == "sim" {
                "the simulator".to_string()
            } else {
                stem.replace('_', "/")
            };
            Some((device, p))
        })
        .collect();
    stale.sort();
    stale
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
) -> Result<crate::cmd::status::Snapshot, Failure> {
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
        } => Ok(crate::cmd::status::Snapshot {
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
