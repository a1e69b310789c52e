//! Worst-case controller loop pass on the host (see `firmware::bench`).
//!
//! ```text
//! cargo run --release -p firmware --example worst_step            # wall time per pass
//! cargo build --release -p firmware --example worst_step
//! valgrind --tool=callgrind --toggle-collect='*WorstCase*step*' \
//!     $CARGO_TARGET_DIR/release/examples/worst_step count idle 1000   # x86-64 instructions
//! ```
//!
//! `count <idle|running> N` runs N passes (the whole frames arriving at once) and nothing else
//! (for callgrind: divide the collected instruction count by N). Without arguments it times
//! 20 000 passes of each scenario and arrival pattern.

use std::hint::black_box;
use std::time::Instant;

use firmware::bench::{Arrival, Scenario, WorstCase};

fn scenario(name: &str) -> Option<Scenario> {
    match name {
        "idle" => Some(Scenario::Idle),
        "running" => Some(Scenario::Running),
        _ => None,
    }
}

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("count") {
        let (Some(s), Some(n)) = (
            args.get(1).and_then(|a| scenario(a)),
            args.get(2).and_then(|a| a.parse::<u32>().ok()),
        ) else {
            eprintln!("usage: worst_step count <idle|running> <passes>");
            return std::process::ExitCode::from(2);
        };
        let mut w = WorstCase::new(s, Arrival::Whole);
        let mut sent = 0;
        for _ in 0..n {
            w.prepare();
            sent += black_box(w.step());
        }
        println!("{s:?}: {n} passes, {sent} bytes sent");
        return std::process::ExitCode::SUCCESS;
    }
    for (s, a) in [
        (Scenario::Idle, Arrival::Whole),
        (Scenario::Running, Arrival::Whole),
        (Scenario::Idle, Arrival::ShellChunk),
        (Scenario::Running, Arrival::ShellChunk),
        (Scenario::Running, Arrival::Quiet),
    ] {
        let mut w = WorstCase::new(s, a);
        let mut times = Vec::with_capacity(20_000);
        let mut sent = 0;
        for i in 0..21_000 {
            w.prepare();
            let t = Instant::now();
            let n = black_box(w.step());
            let dt = t.elapsed().as_nanos() as u64;
            if i >= 1_000 {
                times.push(dt);
                sent += n;
            }
        }
        times.sort_unstable();
        let mean = times.iter().sum::<u64>() as f64 / times.len() as f64;
        let p = |q: f64| times[((times.len() - 1) as f64 * q) as usize];
        println!(
            "{s:?}/{a:?}: frame {} B, {:.0} B sent/pass; per pass: mean {:.1} µs, median {:.1} µs, p99 {:.1} µs, max {:.1} µs",
            w.frame_len(),
            sent as f64 / times.len() as f64,
            mean / 1e3,
            p(0.5) as f64 / 1e3,
            p(0.99) as f64 / 1e3,
            *times.last().unwrap_or(&0) as f64 / 1e3,
        );
    }
    std::process::ExitCode::SUCCESS
}
