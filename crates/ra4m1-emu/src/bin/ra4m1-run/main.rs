//! `ra4m1-run`: runs an RA4M1 ELF in the emulator, as a cargo runner for on-target test
//! binaries (or any program) without a board.
//!
//! ```text
//! ra4m1-run [--timeout-ms N] [--board wifi|minima] [--uart] [--rtt PATH] [--bare] ELF [ARGS…]
//! CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER="ra4m1-run" cargo test --target thumbv7em-none-eabihf …
//! ```
//! An `embedded-test` ELF (the on-target suites, `cargo test-board`) runs in test mode
//! ([`tests`]): each case on a fresh chip, as `probe-rs run` runs it on a board, with the
//! stimulus fixture fitted (`--bare`: a bare board, without the display module either); ARGS
//! are libtest's (a filter, `--list`, `--exact`, `--ignored` …) and the report is probe-rs's.
//! Any other ELF runs once, with the crane's display module wired where its pin map
//! (`firmware::pins`) puts it:
//! The program's semihosting output goes to stdout (SCI9's bytes too with `--uart`); the run
//! ends with the program's semihosting exit code (SYS_EXIT / SYS_EXIT_EXTENDED), 124 when the
//! virtual time limit passes first (default 10 s), 1 when the emulator stops on an access it
//! does not model (the message names the address), 2 on a usage error. `--rtt PATH` writes the
//! RTT up-channel's bytes (defmt frames) to PATH, read as a probe would: decode them with
//! `defmt-print -e ELF < PATH`.
#![forbid(unsafe_code)]

use std::io::Write as _;
use std::process::ExitCode;

use ra4m1_emu::{Board, Emulator, Options};

mod tests;

const USAGE: &str =
    "usage: ra4m1-run [--timeout-ms N] [--board wifi|minima] [--uart] [--rtt PATH] [--bare] ELF [ARGS...]";

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let (mut timeout_ms, mut board, mut uart, mut elf) = (10_000u64, Board::Wifi, false, None);
    let mut rtt_path: Option<String> = None;
    let mut bare = false;
    let mut rest: Vec<String> = Vec::new();
    while let Some(a) = args.next() {
        if elf.is_some() {
            // Cargo passes the test binary's own arguments after the ELF: they are the
            // harness's, not ours.
            rest.push(a);
            rest.extend(args.by_ref());
            break;
        }
        match a.as_str() {
            "--bare" => bare = true,
            "--timeout-ms" => match args.next().and_then(|v| v.parse().ok()) {
                Some(v) if v > 0 => timeout_ms = v,
                _ => return usage("--timeout-ms needs a positive number of milliseconds"),
            },
            "--board" => match args.next().as_deref() {
                Some("wifi") => board = Board::Wifi,
                Some("minima") => board = Board::Minima,
                _ => return usage("--board is wifi or minima"),
            },
            "--uart" => uart = true,
            "--rtt" => match args.next() {
                Some(p) => rtt_path = Some(p),
                None => return usage("--rtt needs a file path"),
            },
            "-h" | "--help" => {
                println!("{USAGE}");
                return ExitCode::SUCCESS;
            }
            s if s.starts_with('-') => return usage(&format!("unknown option {s}")),
            s => elf = Some(s.to_string()),
        }
    }
    let Some(path) = elf else {
        return usage("no ELF given");
    };
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("ra4m1-run: {path}: {e}");
            return ExitCode::from(1);
        }
    };
    match tests::cases(&bytes) {
        Ok(Some(cases)) => {
            let settings = tests::Settings {
                board,
                fixture: (!bare).then_some(tests::Fixture),
            };
            return ExitCode::from(tests::run(bytes, cases, settings, &rest));
        }
        Ok(None) => {}
        Err(e) => {
            eprintln!("ra4m1-run: {path}: {e}");
            return ExitCode::from(1);
        }
    }
    let mut emu = match Emulator::new(
        &bytes,
        Options {
            board,
            // The crane's display, where its pin map puts it (an ELF that never clocks those
            // pins sees no difference).
            tm1637: Some(tests::display_wiring()),
            ..Options::default()
        },
    ) {
        Ok(e) => e,
        Err(e) => {
            eprintln!("ra4m1-run: {path}: {e}");
            return ExitCode::from(1);
        }
    };
    let mut rtt = match rtt_path.as_deref().map(std::fs::File::create).transpose() {
        Ok(f) => f,
        Err(e) => {
            eprintln!("ra4m1-run: --rtt: {e}");
            return ExitCode::from(1);
        }
    };
    let mut out = std::io::stdout();
    let end = timeout_ms * 1_000_000;
    while emu.now_ns() < end && emu.exit_code().is_none() {
        let r = emu.run_until_ns((emu.now_ns() + 1_000_000).min(end));
        let _ = out.write_all(&emu.take_semihost_output());
        if let Some(f) = rtt.as_mut() {
            let _ = f.write_all(&emu.rtt_take());
        }
        let tx = emu.host_take();
        if uart {
            let _ = out.write_all(&tx);
        }
        if let Err(e) = r {
            let _ = out.flush();
            eprintln!(
                "ra4m1-run: the emulated board stopped at {} µs: {e}",
                emu.now_ns() / 1_000
            );
            return ExitCode::from(1);
        }
    }
    let _ = out.flush();
    match emu.exit_code() {
        Some(code) => ExitCode::from(code.clamp(0, 255) as u8),
        None => {
            eprintln!("ra4m1-run: no exit within {timeout_ms} ms of virtual time");
            ExitCode::from(124)
        }
    }
}

fn usage(msg: &str) -> ExitCode {
    eprintln!("ra4m1-run: {msg}\n{USAGE}");
    ExitCode::from(2)
}
