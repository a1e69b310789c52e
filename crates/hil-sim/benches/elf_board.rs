//! The board ELF in the RA4M1 emulator: boot to first answer, emulator speed, and the loop's
//! longest pass in the cycle model (Cortex-M4 timings + one flash wait state).
//!
//! ```text
//! cargo firmware && cargo bench -p hil-sim --bench elf_board
//! ```
//! Needs `cargo firmware`'s ELF (or `UNO_R4_ELF`). Prints one line per figure.

use std::path::PathBuf;
use std::time::Instant;

use hil_sim::host::SimHost;
use hil_sim::{Sim, SimOptions};
use protocol::messages::{DeviceMessage, RequestBody, Step};

fn elf() -> PathBuf {
    hil_sim::elf_board::built_elf_path()
}

fn sim(initial: &str) -> Sim {
    Sim::try_new(SimOptions {
        initial: initial.parse().unwrap(),
        firmware_elf: Some(elf()),
        ..SimOptions::default()
    })
    .unwrap_or_else(|e| panic!("{e} (build it with `cargo firmware`)"))
}

fn max_pass(sim: &Sim) -> u64 {
    sim.elf_board()
        .map_or(0, |b| b.emu.stats().max_awake_cycles)
}

fn clear(sim: &mut Sim) {
    if let Some(b) = sim.elf_board_mut() {
        b.emu.clear_max_awake();
    }
}

fn main() {
    // 1. Boot to first answer: a Hello frame every 5 ms from power-on, straight onto the line
    //    (framed by hand, deliberately: the host engine resends only every 250 ms, too coarse
    //    to time the boot).
    let wall = Instant::now();
    let mut s = sim("F&P");
    let hello = protocol::messages::Request {
        seq: 1,
        session: 0,
        body: RequestBody::hello(),
    };
    let mut frame = [0u8; protocol::MAX_FRAME_LEN];
    let n = protocol::encode(&hello, &mut frame).unwrap();
    let mut decoder = protocol::FrameDecoder::new();
    let mut answered = None;
    while s.now_ms() < 2_000 && answered.is_none() {
        if s.now_ms().is_multiple_of(5) {
            s.write_host_bytes(&frame[..n]);
        }
        s.step();
        for b in s.read_device_bytes() {
            if let Some(Ok(DeviceMessage::Response { .. })) = decoder.push::<DeviceMessage>(b) {
                answered = Some(s.now_ms());
            }
        }
    }
    let boot_wall = wall.elapsed();
    println!(
        "boot to first answer: {} ms virtual (Hello every 5 ms from power-on), {:.1} ms wall incl. loading the ELF",
        answered.expect("answered within 2 s"),
        boot_wall.as_secs_f64() * 1e3
    );

    // 2. Idle speed (the simulator's physics included), and the idle pass.
    let mut s = sim("F&P");
    let mut host = SimHost::new();
    s.run_for(50);
    host.hello(&mut s).unwrap();
    clear(&mut s);
    let wall = Instant::now();
    let v0 = s.now_ms();
    for _ in 0..40 {
        s.run_for(250);
        let _ = host.send(&mut s, RequestBody::Heartbeat);
    }
    let w = wall.elapsed().as_secs_f64() * 1e3;
    println!(
        "idle: {:.1} virtual ms per wall ms ({} ms in {:.0} ms); longest pass {} cycles",
        (s.now_ms() - v0) as f64 / w,
        s.now_ms() - v0,
        w,
        max_pass(&s)
    );

    // 3. The largest plan's upload pass (refused or stored), then a real plan running.
    clear(&mut s);
    if let Some(b) = s.elf_board_mut() {
        b.emu.profile_passes(true);
    }
    let _ = host.request(
        &mut s,
        RequestBody::UploadPlan(firmware::bench::largest_plan(9)),
        2_000,
    );
    s.run_for(100);
    println!(
        "upload of the largest plan ({} steps of bends): longest pass {} cycles",
        protocol::MAX_PLAN_STEPS,
        max_pass(&s)
    );
    let profile = s.elf_board().unwrap().emu.longest_pass_profile();
    for (f, c) in profile.iter().take(16) {
        println!("  {c:>7} cycles  {}", &f[..f.len().min(100)]);
    }
    let plan = transition_graph::Graph::nominal()
        .plan("F&P".parse().unwrap(), "D&D".parse().unwrap())
        .unwrap();
    let steps: Vec<Step> = plan.steps().iter().map(|s| s.to_protocol()).collect();
    let wall = Instant::now();
    let v0 = s.now_ms();
    clear(&mut s);
    s.enable_trace(1_000_000);
    let (ok, state) = host.run_plan(&mut s, 3, &steps, 120_000).unwrap();
    let at = s.elf_board().unwrap().emu.stats().max_awake_at_ns / 1_000_000;
    println!("  (the longest pass ended at {at} ms; plan started at {v0} ms; events:)");
    for line in s.trace().lines().filter(|l| l.contains("event")) {
        println!("    {}", &line[..line.len().min(110)]);
    }
    let w = wall.elapsed().as_secs_f64() * 1e3;
    println!(
        "plan F&P → D&D (ok {ok}, {state}): {:.1} virtual ms per wall ms ({} ms in {:.0} ms); longest pass {} cycles (upload, start and run)",
        (s.now_ms() - v0) as f64 / w,
        s.now_ms() - v0,
        w,
        max_pass(&s)
    );
    let st = s.elf_board().unwrap().emu.stats();
    println!(
        "totals: {} instructions, {} cycles awake, {} wake-ups",
        st.instructions, st.awake_cycles, st.wakes
    );
}
