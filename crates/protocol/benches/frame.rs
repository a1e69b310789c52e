//! Encode + decode time per frame on the host, and the largest frame's size.
//!
//! `cargo bench -p protocol --bench frame` (results in BENCHMARKS.md, `## protocol`).
#![allow(missing_docs)] // criterion_group! generates an undocumented pub fn

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use protocol::{encode, FrameDecoder, MAX_FRAME_LEN};
use serde::{de::DeserializeOwned, Serialize};

#[path = "../tests/wire/samples.rs"]
mod samples;

/// Encodes `msg` and pushes the frame through a streaming decoder.
fn round_trip<T: Serialize + DeserializeOwned>(msg: &T, dec: &mut FrameDecoder) -> Option<T> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).ok()?;
    let mut out = None;
    for &b in &buf[..n] {
        if let Some(Ok(m)) = dec.push::<T>(b) {
            out = Some(m);
        }
    }
    out
}

fn frame_len<T: Serialize>(msg: &T) -> usize {
    let mut buf = [0u8; MAX_FRAME_LEN];
    encode(msg, &mut buf).unwrap_or(usize::MAX)
}

fn bench(c: &mut Criterion) {
    let small = samples::get_status();
    let status = samples::status_response();
    let largest = samples::largest_request();
    eprintln!(
        "frame sizes (bytes, delimiter included): GetStatus {}, Status response {}, \
         full UploadPlan {} (MAX_FRAME_LEN {MAX_FRAME_LEN})",
        frame_len(&small),
        frame_len(&status),
        frame_len(&largest),
    );

    let mut dec = FrameDecoder::new();
    let mut g = c.benchmark_group("encode+decode");
    g.bench_function("GetStatus", |b| {
        b.iter(|| round_trip(black_box(&small), &mut dec))
    });
    g.bench_function("Status response", |b| {
        b.iter(|| round_trip(black_box(&status), &mut dec))
    });
    g.bench_function("UploadPlan 8x4", |b| {
        b.iter(|| round_trip(black_box(&largest), &mut dec))
    });
    g.finish();

    let mut g = c.benchmark_group("encode");
    let mut buf = [0u8; MAX_FRAME_LEN];
    g.bench_function("UploadPlan 8x4", |b| {
        b.iter(|| encode(black_box(&largest), &mut buf))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
