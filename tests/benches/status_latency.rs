//! Round-trip latency of a `GetStatus` request over the simulator's pseudo-terminal: the
//! simulator (real firmware controller inside) behind a pty, the client on the same serialport
//! calls as `host-tool` (115200 8N1, 2 ms read timeout), one request in flight at a time.
//!
//! `cargo bench -p e2e --bench status_latency [-- N]` (N requests, default 2000).

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use hil_sim::pty::PtySim;
use hil_sim::SimOptions;
use protocol::{DeviceMessage, FrameDecoder, Request, RequestBody, ResponseBody, MAX_FRAME_LEN};

fn main() -> anyhow::Result<()> {
    let n: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(2000);
    let sim = PtySim::spawn(SimOptions::default())?;
    let path = sim.path().to_string_lossy().into_owned();
    let mut port = serialport::new(&path, 115_200)
        .timeout(Duration::from_millis(2))
        .open()?;
    let mut decoder = FrameDecoder::new();
    let mut seq = 0u16;
    let mut round_trip = |body: RequestBody| -> anyhow::Result<(Duration, ResponseBody)> {
        seq = seq.wrapping_add(1);
        let mut frame = [0u8; MAX_FRAME_LEN + 1];
        let len = protocol::encode(
            &Request {
                seq,
                // GetStatus is answered for anyone: no session needed.
                session: 0,
                body,
            },
            &mut frame[1..],
        )
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        let start = Instant::now();
        port.write_all(&frame[..len + 1])?;
        let mut buf = [0u8; 256];
        loop {
            if start.elapsed() > Duration::from_secs(2) {
                anyhow::bail!("no response to seq {seq}");
            }
            let got = match port.read(&mut buf) {
                Ok(k) => k,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => 0,
                Err(e) => return Err(e.into()),
            };
            for &b in &buf[..got] {
                if let Some(Ok(DeviceMessage::Response { seq: s, body, .. })) =
                    decoder.push::<DeviceMessage>(b)
                {
                    if s == seq {
                        return Ok((start.elapsed(), body));
                    }
                }
            }
        }
    };
    round_trip(RequestBody::hello())?;
    let mut rtts = Vec::with_capacity(n);
    for _ in 0..n {
        let (rtt, body) = round_trip(RequestBody::GetStatus)?;
        anyhow::ensure!(
            matches!(body, ResponseBody::Status(_)),
            "not a status: {body:?}"
        );
        rtts.push(rtt);
    }
    rtts.sort();
    let pct = |p: f64| rtts[((rtts.len() - 1) as f64 * p).round() as usize];
    println!(
        "GetStatus round trip over the pty, {n} requests: median {:.3} ms, p99 {:.3} ms, \
         min {:.3} ms, max {:.3} ms",
        pct(0.5).as_secs_f64() * 1e3,
        pct(0.99).as_secs_f64() * 1e3,
        rtts[0].as_secs_f64() * 1e3,
        rtts[rtts.len() - 1].as_secs_f64() * 1e3
    );
    sim.stop();
    Ok(())
}
