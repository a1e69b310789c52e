//! Test mode: an `embedded-test` ELF run the way `probe-rs run` runs it on a board, one test
//! case per fresh chip, reported in the same (libtest) format.
//!
//! What probe-rs does (probe-rs-tools `cmd/run.rs`, `rpc/functions/test.rs`, embedded-test
//! protocol version 1), and what this does in its place:
//! - the test cases are the global 12-byte data symbols of the `.embedded_test` section: the
//!   symbol name is a JSON object (`name`, `ignored`, `should_panic`, `timeout`), the data
//!   `(fn() -> !, &'static str)` the case's entry and its module path (crate name stripped);
//! - each case: reset the chip, answer its first SYS_GET_CMDLINE with `run_addr <entry>`, run
//!   until SYS_EXIT / SYS_EXIT_EXTENDED: success is a pass, an error exit (embedded-test's
//!   abort after a panic or an `Err`) is a panic; the case passes when that is what it
//!   expected (`#[should_panic]`); 60 s unless the case sets `#[timeout]` — here *virtual*
//!   seconds, so a run is deterministic and takes milliseconds;
//! - a second SYS_GET_CMDLINE means the board reset in the middle of the case (a test that
//!   resets on purpose resumes from its own setup without asking again): probe-rs aborts on
//!   it, here the case fails naming it;
//! - the RTT up channel is read as a probe reads it and its defmt frames are decoded against
//!   the ELF's table (`defmt-decoder`, probe-rs's one-line format with the location);
//! - the report is libtest-mimic's, as probe-rs prints it (one thread, `--list`, filters,
//!   `--exact`, `--ignored`, `--include-ignored`, `--skip` work the same).
//!
//! Cases in a module named `bench_only` need what the emulator does not model: they are
//! reported `ignored, bench only` (and counted), never run and never silently dropped.
//!
//! The emulated bench has the stimulus fixture of `docs/flashing.md` fitted ([`Fixture`]), so the
//! stimulus tests run here as on a bench with the jumpers in place; where it is fitted comes from
//! the crane's pin map (`firmware::pins`), the one the suites themselves read.

use std::io::Write as _;
use std::sync::Arc;

use firmware::pins::{self, PortPin};
use libtest_mimic::{Arguments, Failed, Trial};
use object::{Object, ObjectSection, ObjectSymbol, SymbolKind};
use ra4m1_emu::{Board, Emulator, Options};

/// One test case of the ELF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Case {
    /// `module::path::name`, without the crate.
    pub name: String,
    /// The entry `run_addr` jumps to.
    pub address: u32,
    /// `#[ignore]`.
    pub ignored: bool,
    /// `#[should_panic]`.
    pub should_panic: bool,
    /// `#[timeout(s)]`, seconds.
    pub timeout_s: Option<u64>,
}

/// The embedded-test cases of `elf`; `None` when it is not an embedded-test binary.
pub fn cases(elf: &[u8]) -> Result<Option<Vec<Case>>, String> {
    let file = object::File::parse(elf).map_err(|e| format!("not an ELF: {e}"))?;
    let Some(section) = file.section_by_name(".embedded_test") else {
        return Ok(None);
    };
    let Some(version) = file.symbol_by_name("EMBEDDED_TEST_VERSION") else {
        return Ok(None);
    };
    let v = section_bytes(&section, version.address(), 4)
        .ok_or("EMBEDDED_TEST_VERSION outside .embedded_test")?;
    let v = u32::from_le_bytes([v[0], v[1], v[2], v[3]]);
    if v != 1 {
        return Err(format!(
            "embedded-test protocol version {v}: this runner speaks version 1 (embedded-test 0.7)"
        ));
    }
    let mut out = Vec::new();
    for sym in file.symbols() {
        if !sym.is_global()
            || sym.kind() != SymbolKind::Data
            || sym.section_index() != Some(section.index())
            || sym.size() != 12
        {
            continue;
        }
        let data = section_bytes(&section, sym.address(), 12).ok_or("test symbol outside")?;
        let word = |i: usize| u32::from_le_bytes([data[i], data[i + 1], data[i + 2], data[i + 3]]);
        let (entry, path_ptr, path_len) = (word(0), word(4), word(8));
        let name = sym.name().map_err(|e| e.to_string())?;
        let def: serde_json::Value =
            serde_json::from_str(name).map_err(|e| format!("test symbol {name}: {e}"))?;
        let field = |k: &str| def.get(k).ok_or(format!("test symbol {name}: no `{k}`"));
        let module = read_str(&file, elf, path_ptr, path_len)?;
        let module = module.split_once("::").map_or("", |(_, rest)| rest);
        let test = field("name")?.as_str().unwrap_or_default();
        out.push(Case {
            name: if module.is_empty() {
                test.to_string()
            } else {
                format!("{module}::{test}")
            },
            address: entry,
            ignored: field("ignored")?.as_bool().unwrap_or(false),
            should_panic: field("should_panic")?.as_bool().unwrap_or(false),
            timeout_s: def.get("timeout").and_then(|t| t.as_u64()),
        });
    }
    out.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(Some(out))
}

fn section_bytes<'a>(s: &object::Section<'a, '_>, addr: u64, len: u64) -> Option<&'a [u8]> {
    s.data_range(addr, len).ok().flatten()
}

fn read_str<'a>(
    file: &object::File<'a>,
    elf: &'a [u8],
    ptr: u32,
    len: u32,
) -> Result<&'a str, String> {
    let (ptr, len) = (u64::from(ptr), u64::from(len));
    let s = file
        .sections()
        .find(|s| ptr >= s.address() && ptr + len <= s.address() + s.size())
        .ok_or(format!("module path at {ptr:#x} in no section"))?;
    let (start, _) = s
        .file_range()
        .ok_or("module path in a section without file data")?;
    let at = (start + ptr - s.address()) as usize;
    let bytes = elf
        .get(at..at + len as usize)
        .ok_or("module path beyond the file")?;
    std::str::from_utf8(bytes).map_err(|e| format!("module path: {e}"))
}

/// The crane's TM1637 module, `(clk, dio)` as the emulator takes it: where the pin map puts it.
pub fn display_wiring() -> ((usize, usize), (usize, usize)) {
    let at = |p: PortPin| (usize::from(p.port), usize::from(p.pin));
    (at(pins::TM_CLK.pin()), at(pins::TM_DIO.pin()))
}

/// The stimulus fixture the emulated bench has fitted (the jumpers of `docs/flashing.md`), on
/// the pins of the crane's pin map ([`firmware::pins`]): SCI9's TXD9 looped back to RXD9
/// (Minima: a jumper D11–D12; WiFi: the host echoes on the bridge's port), the pressure input
/// (A0, AN009) to GND, joystick x (A1, AN000) to 3V3, joystick y (A2, AN001) to 5 V (AVCC0),
/// and a TM1637 display on the display's CLK (P111: Minima D13, WiFi D6) and DIO (P302: D1).
#[derive(Debug, Clone, Copy)]
pub struct Fixture;

impl Fixture {
    /// 3.3 V against the 5 V reference, 14 bits.
    pub const COUNTS_3V3: u16 = (3300u32 * 16383 / 5000) as u16;

    fn wire(self, emu: &mut Emulator) {
        emu.set_analog(pins::PRESSURE.channel().into(), 0);
        emu.set_analog(pins::JOY_X.channel().into(), Self::COUNTS_3V3);
        emu.set_analog(pins::JOY_Y.channel().into(), 16383);
    }

    /// The loopback: what SCI9 sent comes back on its receive line, at the line rate.
    fn step(self, emu: &mut Emulator) {
        let tx = emu.host_take();
        emu.host_send(&tx);
    }
}

/// Settings of a test run.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// The board.
    pub board: Board,
    /// The fixture (`None`: a bare board).
    pub fixture: Option<Fixture>,
}

/// What a case did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    Pass,
    Panic,
}

struct Log<'t> {
    table: &'t defmt_decoder::Table,
    locations: Option<defmt_decoder::Locations>,
    formatter: defmt_decoder::log::format::Formatter,
}

impl<'t> Log<'t> {
    fn new(table: &'t defmt_decoder::Table, elf: &[u8]) -> Self {
        use defmt_decoder::log::format::{Formatter, FormatterConfig, FormatterFormat};
        let locations = table
            .get_locations(elf)
            .ok()
            .filter(|l| !l.is_empty() && table.indices().all(|i| l.contains_key(&(i as u64))));
        Self {
            table,
            formatter: Formatter::new(FormatterConfig {
                format: FormatterFormat::OneLine {
                    with_location: locations.is_some(),
                },
                is_timestamp_available: table.has_timestamp(),
            }),
            locations,
        }
    }

    /// Decodes what is complete in `decoder` and prints it.
    fn print(&self, decoder: &mut dyn defmt_decoder::StreamDecoder, out: &mut impl std::io::Write) {
        loop {
            match decoder.decode() {
                Ok(frame) => {
                    let loc = self.locations.as_ref().and_then(|l| l.get(&frame.index()));
                    let file = loc.map(|l| l.file.display().to_string());
                    let line = loc.map(|l| l.line as u32);
                    let module = loc.map(|l| l.module.as_str());
                    let s = self
                        .formatter
                        .format_frame(frame, file.as_deref(), line, module);
                    let _ = writeln!(out, "{s}");
                }
                Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
                Err(defmt_decoder::DecodeError::Malformed) => {
                    if !self.table.encoding().can_recover() {
                        let _ = writeln!(
                            out,
                            "(defmt: malformed frame; the rest of this log is lost)"
                        );
                        break;
                    }
                }
            }
        }
    }
}

/// Runs one case on a fresh chip.
fn run_case(elf: &[u8], case: &Case, settings: Settings) -> Result<(), Failed> {
    let table = defmt_decoder::Table::parse(elf).ok().flatten();
    let log = table.as_ref().map(|t| Log::new(t, elf));
    let mut decoder = table.as_ref().map(|t| t.new_stream_decoder());
    let mut emu = Emulator::new(
        elf,
        Options {
            board: settings.board,
            // The display module is part of the fixture; a bare board has none.
            tm1637: settings.fixture.map(|_| display_wiring()),
            // probe-rs runs a test with its probe attached: on-chip-debug mode.
            probe: true,
            ..Options::default()
        },
    )
    .map_err(|e| Failed::from(format!("the ELF does not load: {e}")))?;
    if let Some(f) = settings.fixture {
        f.wire(&mut emu);
    }
    emu.set_semihost_cmdline(&format!("run_addr {}", case.address));
    let timeout_s = case.timeout_s.unwrap_or(60);
    let end = timeout_s * 1_000_000_000;
    let mut out = std::io::stdout();
    let result = loop {
        let r = emu.run_until_ns((emu.now_ns() + 1_000_000).min(end));
        let _ = out.write_all(&emu.take_semihost_output());
        if let (Some(log), Some(d)) = (log.as_ref(), decoder.as_mut()) {
            d.received(&emu.rtt_take());
            log.print(d.as_mut(), &mut out);
        }
        match settings.fixture {
            Some(f) => f.step(&mut emu),
            None => drop(emu.host_take()),
        }
        if let Err(e) = r {
            break Err(format!(
                "the emulated board stopped at {} µs: {e}",
                emu.now_ns() / 1_000
            ));
        }
        if emu.cmdline_requests() > 1 {
            break Err(format!(
                "the board reset during the test at {} µs (it asked for its command line again): \
                 resets after the first start {:?}",
                emu.now_ns() / 1_000,
                emu.resets()
            ));
        }
        if let Some(code) = emu.exit_code() {
            break Ok(if code == 0 {
                Outcome::Pass
            } else {
                Outcome::Panic
            });
        }
        if emu.now_ns() >= end {
            break Err(format!("Test timed out after {timeout_s}s (virtual time)"));
        }
    };
    let _ = out.flush();
    let expected = if case.should_panic {
        Outcome::Panic
    } else {
        Outcome::Pass
    };
    match result {
        Ok(o) if o == expected => Ok(()),
        Ok(o) => Err(format!("Test should {expected:?} but it did {o:?}").into()),
        Err(e) => Err(e.into()),
    }
}

/// The libtest trial of one case: a case in a `bench_only` module is ignored with the kind
/// `bench only` (and fails, saying why, if run anyway with `--ignored`).
fn trial(case: Case, elf: Arc<Vec<u8>>, settings: Settings) -> Trial {
    let name = case.name.clone();
    if case.name.split("::").any(|m| m == "bench_only") {
        return Trial::test(name, || {
            Err(
                "bench only: the emulator does not model what this test needs; \
                 run it on a board (docs/flashing.md)"
                    .into(),
            )
        })
        .with_ignored_flag(true)
        .with_kind("bench only");
    }
    let ignored = case.ignored;
    Trial::test(name, move || run_case(&elf, &case, settings)).with_ignored_flag(ignored)
}

/// Runs the cases of `elf` as `probe-rs run` would, with libtest arguments `args` (those
/// cargo passes after the ELF); the process exit code.
pub fn run(elf: Vec<u8>, cases: Vec<Case>, settings: Settings, args: &[String]) -> u8 {
    let mut libtest_args =
        Arguments::from_iter(std::iter::once("ra4m1-run".to_string()).chain(args.iter().cloned()));
    libtest_args.test_threads = Some(1);
    let elf = Arc::new(elf);
    let trials = cases
        .into_iter()
        .map(|case| trial(case, Arc::clone(&elf), settings))
        .collect();
    if libtest_mimic::run(&libtest_args, trials).has_failed() {
        101
    } else {
        0
    }
}

#[cfg(test)]
mod unit {
    use super::*;

    fn case(name: &str, ignored: bool) -> Case {
        Case {
            name: name.into(),
            address: 0x4001,
            ignored,
            should_panic: false,
            timeout_s: None,
        }
    }

    #[test]
    fn bench_only_cases_are_ignored_and_marked_and_the_others_keep_their_flag() {
        let s = Settings {
            board: Board::Wifi,
            fixture: None,
        };
        let elf = Arc::new(Vec::new());
        let t = trial(
            case("tests::bench_only::adc_ref", false),
            Arc::clone(&elf),
            s,
        );
        assert!(t.has_ignored_flag());
        assert_eq!(t.kind(), "bench only");
        let t = trial(case("tests::gpt", false), Arc::clone(&elf), s);
        assert!(!t.has_ignored_flag());
        assert_eq!(t.kind(), "");
        let t = trial(case("tests::slow", true), elf, s);
        assert!(t.has_ignored_flag());
    }

    #[test]
    fn a_file_that_is_not_an_elf_is_refused() {
        assert!(cases(b"not an elf").is_err());
    }
}
