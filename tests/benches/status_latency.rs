//! Round-trip latency of a `GetStatus` request over the simulator's pseudo-terminal: the
//! simulator (real firmware controller inside) behind a pty, the client the real host engine
//! (`host::Driver`, one request in flight at a time) on the same serialport settings as
//! `host-tool` (115200 8N1, 2 ms read timeout).
//!
//! `cargo bench -p e2e --bench status_latency [-- N]` (N requests, default 2000).

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use hil_sim::pty::PtySim;
use hil_sim::SimOptions;
use host::{Driver, Host, Timing};
use protocol::ResponseBody;

/// The port on the wall clock; a read returns after the port's timeout when nothing came.
struct Port {
    port: Box<dyn serialport::SerialPort>,
    start: Instant,
}

impl host::Io for Port {
    fn now_ms(&mut self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.port.write_all(bytes)
    }
    fn read(&mut self, _deadline_ms: u64, buf: &mut Vec<u8>) -> std::io::Result<()> {
        let mut chunk = [0u8; 256];
        match self.port.read(&mut chunk) {
            Ok(n) => buf.extend_from_slice(&chunk[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
            Err(e) => return Err(e),
        }
        Ok(())
    }
}

fn main() -> anyhow::Result<()> {
    let n: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(2000);
    let sim = PtySim::spawn(SimOptions::default())?;
    let path = sim.path().to_string_lossy().into_owned();
    let port = serialport::new(&path, 115_200)
        .timeout(Duration::from_millis(2))
        .open()?;
    let io = Port {
        port,
        start: Instant::now(),
    };
    let mut host = Driver::new(Host::new(Timing::standard(), 1), io);
    host.connect()?;
    let mut rtts = Vec::with_capacity(n);
    for _ in 0..n {
        let start = Instant::now();
        let body = host.command(protocol::RequestBody::GetStatus)?;
        rtts.push(start.elapsed());
        anyhow::ensure!(
            matches!(body, ResponseBody::Status(_)),
            "not a status: {body:?}"
        );
    }
    let retries = host.host.session().stats().retries;
    drop(host);
    rtts.sort();
    let pct = |p: f64| rtts[((rtts.len() - 1) as f64 * p).round() as usize];
    println!(
        "GetStatus round trip over the pty, {n} requests: median {:.3} ms, p99 {:.3} ms, \
         min {:.3} ms, max {:.3} ms; {retries} retries",
        pct(0.5).as_secs_f64() * 1e3,
        pct(0.99).as_secs_f64() * 1e3,
        rtts[0].as_secs_f64() * 1e3,
        rtts[rtts.len() - 1].as_secs_f64() * 1e3
    );
    sim.stop();
    Ok(())
}
