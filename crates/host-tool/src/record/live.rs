//! The live view: the recording's channels served over Foxglove's WebSocket protocol
//! (`foxglove.websocket.v1`) by the Foxglove SDK's server (`serve --foxglove HOST:PORT`).
//!
//! [`Live`] owns a Foxglove [`Context`] with one channel per recorded topic (same topic, schema
//! and encoding as in the MCAP file) and the server bound to it. [`crate::record::Recording`]
//! hands every message to it with the message's log time (the device's time), so Foxglove shows
//! exactly what the recording holds. The server runs on the SDK's own tokio threads; logging
//! here only queues the message for the subscribed clients (a client that falls behind loses
//! its oldest messages, it never stalls the link).

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::Arc;

use foxglove::websocket::Capability;
use foxglove::{Context, PartialMetadata, RawChannel, Schema, WebSocketServer};

use super::{Topic, TOPICS};

/// Where the live view listens, validated: an IP address (or `localhost`) and a port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LiveAddr(pub SocketAddr);

impl std::fmt::Display for LiveAddr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

/// Parses `--foxglove`: `HOST:PORT` with HOST an IPv4 address, `[IPv6]` or `localhost`, and
/// PORT 0–65535 (0: any free port, printed at start).
pub fn parse_addr(text: &str) -> Result<LiveAddr, String> {
    let t = text.trim();
    let expected = "expected HOST:PORT with HOST an IP address or localhost and PORT 0–65535 \
                    (e.g. 127.0.0.1:8765)";
    if let Ok(a) = t.parse::<SocketAddr>() {
        return Ok(LiveAddr(a));
    }
    let Some((host, port)) = t.rsplit_once(':') else {
        return Err(format!("invalid --foxglove '{text}': no port; {expected}"));
    };
    let port: u16 = port.parse().map_err(|_| {
        format!("invalid --foxglove '{text}': port '{port}' is not 0–65535; {expected}")
    })?;
    let ip = if host.eq_ignore_ascii_case("localhost") {
        IpAddr::V4(Ipv4Addr::LOCALHOST)
    } else if host.is_empty() {
        return Err(format!("invalid --foxglove '{text}': no host; {expected}"));
    } else if host.contains(':') {
        return Err(format!(
            "invalid --foxglove '{text}': an IPv6 address goes in brackets, e.g. [::1]:8765"
        ));
    } else {
        host.parse::<IpAddr>().map_err(|_| {
            format!("invalid --foxglove '{text}': '{host}' is not an IP address; {expected}")
        })?
    };
    Ok(LiveAddr(SocketAddr::new(ip, port)))
}

/// The running live view.
pub struct Live {
    ctx: Arc<Context>,
    channels: Vec<Arc<RawChannel>>,
    server: Option<foxglove::WebSocketServerHandle>,
    addr: SocketAddr,
}

impl std::fmt::Debug for Live {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Live")
            .field("addr", &self.addr)
            .finish_non_exhaustive()
    }
}

impl Live {
    /// Advertises every topic and starts the server on `addr`; a port in use (or any other
    /// bind failure) is an error that says so.
    pub fn start(addr: LiveAddr, name: &str) -> anyhow::Result<Self> {
        let ctx = Context::new();
        let mut channels = Vec::with_capacity(TOPICS.len());
        for t in TOPICS {
            let (encoding, schema) = t.schema_record();
            let ch = ctx
                .channel_builder(t.name())
                .message_encoding(t.message_encoding())
                .schema(Schema::new(t.schema_name(), encoding, schema))
                .build_raw()
                .map_err(|e| anyhow::anyhow!("live view channel {}: {e}", t.name()))?;
            channels.push(ch);
        }
        let host = match addr.0.ip() {
            IpAddr::V4(ip) => ip.to_string(),
            IpAddr::V6(ip) => format!("[{ip}]"),
        };
        let server = WebSocketServer::new()
            .name(name)
            .context(&ctx)
            .bind(host, addr.0.port())
            .capabilities([Capability::Time])
            .start_blocking()
            .map_err(|e| match e {
                foxglove::FoxgloveError::Bind(io) if io.kind() == std::io::ErrorKind::AddrInUse => {
                    anyhow::anyhow!(
                        "--foxglove {addr}: the port is in use (another server listens there; \
                         pick another port, or 0 for any free one)"
                    )
                }
                foxglove::FoxgloveError::Bind(io) => {
                    anyhow::anyhow!("--foxglove {addr}: cannot listen there: {io}")
                }
                e => anyhow::anyhow!("--foxglove {addr}: {e}"),
            })?;
        let bound = SocketAddr::new(addr.0.ip(), server.port());
        Ok(Self {
            ctx,
            channels,
            server: Some(server),
            addr: bound,
        })
    }

    /// The address it listens on (the actual port when 0 was asked for).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Whether any client subscribes to `topic` (nothing needs building for it otherwise).
    pub fn wanted(&self, topic: Topic) -> bool {
        self.channels[topic as usize].has_sinks()
    }

    /// Sends one message on `topic` to its subscribers, stamped `log_time_ns`.
    pub fn log(&self, topic: Topic, data: &[u8], log_time_ns: u64) {
        self.channels[topic as usize]
            .log_with_meta(data, PartialMetadata::with_log_time(log_time_ns));
        if topic == Topic::Telemetry {
            if let Some(s) = &self.server {
                s.broadcast_time(log_time_ns);
            }
        }
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        if let Some(s) = self.server.take() {
            s.stop().wait_blocking();
        }
        for c in &self.channels {
            c.close();
        }
        let _ = &self.ctx;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_accepted_and_refused_with_the_reason() {
        let ok = |t: &str| parse_addr(t).unwrap().0.to_string();
        assert_eq!(ok("127.0.0.1:8765"), "127.0.0.1:8765");
        assert_eq!(ok("localhost:8765"), "127.0.0.1:8765");
        assert_eq!(ok("LOCALHOST:0"), "127.0.0.1:0");
        assert_eq!(ok("[::1]:65535"), "[::1]:65535");
        assert_eq!(ok("0.0.0.0:1"), "0.0.0.0:1");
        let err = |t: &str| parse_addr(t).unwrap_err();
        assert!(err("127.0.0.1").contains("no port"), "{}", err("127.0.0.1"));
        assert!(err("127.0.0.1:65536").contains("not 0–65535"));
        assert!(err("127.0.0.1:-1").contains("not 0–65535"));
        assert!(err("127.0.0.1:").contains("not 0–65535"));
        assert!(err(":8765").contains("no host"));
        assert!(err("example.org:8765").contains("not an IP address"));
        assert!(err("::1:8765").contains("brackets"));
        assert!(err("999.0.0.1:8765").contains("not an IP address"));
        assert!(err("").contains("no port"));
    }
}
