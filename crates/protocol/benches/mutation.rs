//! The CRC-32 mutation campaign: `N` real frames (default 10^8), each hit by 1–4 random bit
//! flips or a 2–32-bit burst, fed to a receiver; prints how many a receiver accepted (an
//! undetected error), for protocol v2's CRC-32 and, on the same mutations, v1's CRC-16.
//!
//! `cargo bench -p protocol --bench mutation -- 100000000` (BENCHMARKS.md, `## protocol`).
//! Runs on every core; deterministic for a given N and core count split (seed per thread).

use std::time::Instant;

#[path = "support/mutation_campaign.rs"]
mod mutation_campaign;

use mutation_campaign::{campaign, Report};

fn main() {
    let n: u64 = std::env::args()
        .skip(1)
        .find_map(|a| a.replace('_', "").parse().ok())
        .unwrap_or(100_000_000);
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get()) as u64;
    let start = Instant::now();
    let report = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let share = n / threads + u64::from(t < n % threads);
                s.spawn(move || campaign(share, 0xC0FFEE + t, true))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("campaign thread"))
            .fold(Report::default(), Report::plus)
    });
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{} mutated frames ({} with 1-4 bit errors, {} with 2-32-bit bursts) in {secs:.1} s on {threads} threads",
        report.frames,
        report.bit_error_frames,
        report.frames - report.bit_error_frames
    );
    println!(
        "accepted: CRC-32 (protocol v2) {}, CRC-16 (protocol v1, same mutations) {}",
        report.accepted_v2, report.accepted_v1
    );
}
