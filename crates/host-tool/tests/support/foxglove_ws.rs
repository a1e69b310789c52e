//! A small client of Foxglove's WebSocket protocol (`foxglove.websocket.v1`), written from the
//! protocol's specification (foxglove/ws-protocol, docs/spec.md) rather than from the SDK, so
//! the server is checked by an independent reader: `serverInfo` and `advertise` (JSON text
//! frames), `subscribe`, and binary `Message Data` frames (opcode 0x01, u32 subscription id,
//! u64 timestamp ns, payload, little-endian). Every read has a deadline: no sleeps.
//!
//! The Foxglove SDK negotiates that protocol under its new subprotocol name, `foxglove.sdk.v1`
//! (the same messages; `foxglove.sdk.v1.1`, not offered here, moves schemas to a table), and
//! answers a client that offers only `foxglove.websocket.v1` with HTTP 400.

#![allow(dead_code)]

use std::collections::BTreeMap;
use std::net::TcpStream;
use std::time::{Duration, Instant};

use serde_json::{json, Value};
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket};

/// The subprotocol the SDK's server speaks (foxglove.websocket.v1's messages).
pub const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// An advertised channel.
#[derive(Debug, Clone)]
pub struct Channel {
    pub id: u64,
    pub topic: String,
    pub encoding: String,
    pub schema_name: String,
    pub schema_encoding: String,
    pub schema: String,
}

/// One message received on a subscription.
#[derive(Debug, Clone)]
pub struct Received {
    pub topic: String,
    pub timestamp_ns: u64,
    pub payload: Vec<u8>,
    /// When it arrived (this process's clock).
    pub at: Instant,
}

pub struct Client {
    ws: WebSocket<TcpStream>,
    pub server_info: Value,
    /// By topic.
    pub channels: BTreeMap<String, Channel>,
    subscriptions: BTreeMap<u32, String>,
}

impl Client {
    /// Connects offering the subprotocols `offer` (comma-separated) and reads `serverInfo` and
    /// the advertisements until `topics` are all advertised (or the timeout).
    pub fn connect(
        url: &str,
        offer: &str,
        topics: &[&str],
        timeout: Duration,
    ) -> Result<Client, String> {
        let deadline = Instant::now() + timeout;
        let mut req = url.into_client_request().map_err(|e| e.to_string())?;
        req.headers_mut().insert(
            "Sec-WebSocket-Protocol",
            offer.parse().map_err(|_| format!("bad header {offer}"))?,
        );
        let addr = url.trim_start_matches("ws://").trim_end_matches('/');
        let stream = TcpStream::connect(addr).map_err(|e| format!("connect {addr}: {e}"))?;
        stream
            .set_read_timeout(Some(Duration::from_millis(200)))
            .unwrap();
        let (ws, resp) = tungstenite::client(req, stream).map_err(|e| e.to_string())?;
        let proto = resp
            .headers()
            .get("Sec-WebSocket-Protocol")
            .and_then(|v| v.to_str().ok())
            .unwrap_or("");
        if proto != SUBPROTOCOL {
            return Err(format!("the server chose subprotocol '{proto}'"));
        }
        let mut c = Client {
            ws,
            server_info: Value::Null,
            channels: BTreeMap::new(),
            subscriptions: BTreeMap::new(),
        };
        while c.server_info.is_null() || !topics.iter().all(|t| c.channels.contains_key(*t)) {
            if Instant::now() > deadline {
                return Err(format!(
                    "no serverInfo or not all of {topics:?} advertised in {timeout:?}: have {:?}",
                    c.channels.keys().collect::<Vec<_>>()
                ));
            }
            c.read_one()?;
        }
        Ok(c)
    }

    /// Subscribes to `topics` (advertised ones).
    pub fn subscribe(&mut self, topics: &[&str]) -> Result<(), String> {
        let mut subs = Vec::new();
        for (k, t) in topics.iter().enumerate() {
            let ch = self.channels.get(*t).ok_or(format!("{t} not advertised"))?;
            let id = k as u32 + 1;
            self.subscriptions.insert(id, t.to_string());
            subs.push(json!({"id": id, "channelId": ch.id}));
        }
        let m = json!({"op": "subscribe", "subscriptions": subs}).to_string();
        self.ws.send(Message::text(m)).map_err(|e| e.to_string())
    }

    /// The next message on a subscription, by `deadline` (None: the deadline passed).
    pub fn next(&mut self, deadline: Instant) -> Result<Option<Received>, String> {
        while Instant::now() < deadline {
            if let Some(r) = self.read_one()? {
                return Ok(Some(r));
            }
        }
        Ok(None)
    }

    fn read_one(&mut self) -> Result<Option<Received>, String> {
        let msg = match self.ws.read() {
            Ok(m) => m,
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                return Ok(None)
            }
            Err(e) => return Err(format!("websocket: {e}")),
        };
        let at = Instant::now();
        match msg {
            Message::Text(t) => {
                let v: Value = serde_json::from_str(&t).map_err(|e| format!("{e}: {t}"))?;
                match v["op"].as_str() {
                    Some("serverInfo") => self.server_info = v,
                    Some("advertise") => {
                        for ch in v["channels"].as_array().cloned().unwrap_or_default() {
                            let c = Channel {
                                id: ch["id"].as_u64().ok_or("channel id")?,
                                topic: ch["topic"].as_str().unwrap_or("").into(),
                                encoding: ch["encoding"].as_str().unwrap_or("").into(),
                                schema_name: ch["schemaName"].as_str().unwrap_or("").into(),
                                schema_encoding: ch["schemaEncoding"].as_str().unwrap_or("").into(),
                                schema: ch["schema"].as_str().unwrap_or("").into(),
                            };
                            self.channels.insert(c.topic.clone(), c);
                        }
                    }
                    _ => {}
                }
                Ok(None)
            }
            Message::Binary(b) if b.first() == Some(&1) && b.len() >= 13 => {
                let sub = u32::from_le_bytes(b[1..5].try_into().unwrap());
                let ts = u64::from_le_bytes(b[5..13].try_into().unwrap());
                let topic = self
                    .subscriptions
                    .get(&sub)
                    .ok_or(format!("message for unknown subscription {sub}"))?
                    .clone();
                Ok(Some(Received {
                    topic,
                    timestamp_ns: ts,
                    payload: b[13..].to_vec(),
                    at,
                }))
            }
            // Time (0x02) and anything else this client does not use.
            _ => Ok(None),
        }
    }
}
