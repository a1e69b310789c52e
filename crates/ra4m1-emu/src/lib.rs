//! An emulator of the Renesas RA4M1 (the Arduino UNO R4's MCU) that runs the unmodified
//! `uno-r4` firmware ELF.
//!
//! The Cortex-M4F core is [Unicorn](https://www.unicorn-engine.org/) (QEMU's TCG as a
//! library, chosen because it is the CPU emulator firmware-rehosting tools such as Fuzzware
//! and HALucinator build on, it installs as a crate that builds its C here, and it exposes
//! exactly the hooks a peripheral model needs: MMIO callbacks, block hooks and interrupt
//! hooks). Unicorn has no NVIC, so this crate does what those tools do: exception entry and
//! return are emulated here (stacking of the basic or FP-extended frame, EXC_RETURN,
//! priorities, PRIMASK/BASEPRI masking, tail-chaining through re-evaluation on return).
//!
//! Everything else of the chip the board uses is modelled register by register
//! ([`periph`]); an access to any other address stops the run with an error naming it
//! ([`EmuError::Unmodelled`]). Time is virtual and deterministic: it advances with the
//! instructions executed ([`cpu`]'s cycle model, flash wait states counted, and the bus bridges'
//! wait states of every peripheral access, [`machine::bridge_wait_cycles`]) and jumps ahead
//! while the CPU sleeps in `WFI`.
//!
//! The chip starts as the Arduino bootloader leaves it at the jump to the application at
//! 0x4000 ([`Emulator::new`]): VTOR = 0x4000, MSP and PC from the application's vector table,
//! PRIMASK = 1, HOCO at 48 MHz (option bytes OFS0 = 0xFFFF_FFFF: both watchdogs in register-
//! start mode, OFS1 = 0xFFFF_CFDF: HOCO 48 MHz, voltage monitor 0 off), the clock dividers of
//! the Arduino core, one flash wait state; the bootloader's interrupt links IELSR0..3 are left
//! set (`arduino-renesas-bootloader`, `src/irq_table.c`: on the WiFi SCI9 TXI, TEI, RXI, ERI; on
//! the Minima USBFS INT, RESUME, FIFO 0, FIFO 1), the first ones with IR and their NVIC lines
//! pending.
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod clock;
pub mod cpu;
mod error;
pub mod machine;
pub mod periph;
pub mod tm1637;

use unicorn_engine::unicorn_const::{Arch, HookType, MemType, Mode, Prot};
use unicorn_engine::{ArmCpuModel, RegisterARM, Unicorn};

pub use error::EmuError;
use machine::{Machine, Wiring, PAGES};
pub use periph::flash::{FlashFault, Timing as FlashTiming};
pub use periph::gpt::Line;
pub use periph::port::PinDrive;
pub use periph::system::ResetKind;
use periph::{scs::exc, Why};

/// The word the stack is painted with at power-on ([`Emulator::stack_high_water`]).
pub const STACK_PAINT: u32 = 0x5AC3_5AC3;
/// Code flash size (R7FA4M1AB: 256 KiB).
pub const CODE_FLASH: u32 = 256 * 1024;
/// SRAM base and size (32 KiB).
pub const RAM: (u32, u32) = (0x2000_0000, 32 * 1024);
/// Where the Arduino bootloader jumps.
pub const APP_BASE: u32 = 0x4000;
/// OFS0 and OFS1 as the Arduino UNO R4 bootloader image programs them.
pub const OFS: (u32, u32) = (0xFFFF_FFFF, 0xFFFF_CFDF);
const EXC_RETURN_PAGE: u32 = 0xFFFF_F000;

/// Which UNO R4.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Board {
    /// UNO R4 WiFi: the host link is SCI9 through the ESP32-S3 bridge; the bootloader leaves
    /// SCI9 running and its TXI/TEI links in IELSR2/3.
    Wifi,
    /// UNO R4 Minima: the bootloader used USB; SCI9 starts in module stop.
    Minima,
}

/// How to build the emulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// The board (bootloader leftovers).
    pub board: Board,
    /// Data-flash program/erase times.
    pub flash_timing: FlashTiming,
    /// Wiring of a TM1637 display module, `(clk, dio)` as `(port, pin)` (default: none, a bare
    /// chip). The chip model knows no board's pins: whoever runs a board's ELF says where its
    /// display is (the crane's from `firmware::pins`: `ra4m1-run`, `hil-sim`'s `elf_board`).
    pub tm1637: Option<((usize, usize), (usize, usize))>,
    /// A debug probe is attached (on-chip-debug mode: DBGSTOPCR's reset value masks the
    /// watchdogs' resets). `ra4m1-run` sets it for test ELFs, as probe-rs runs them.
    pub probe: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            board: Board::Wifi,
            flash_timing: FlashTiming::default(),
            tm1637: None,
            probe: false,
        }
    }
}

/// Counters of what ran.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Instructions executed.
    pub instructions: u64,
    /// ICLK cycles while awake (the cycle model, wait states included).
    pub awake_cycles: u64,
    /// Wake-ups from `WFI`.
    pub wakes: u64,
    /// The longest stretch between a wake-up and the next `WFI`, cycles (a loop pass with
    /// every interrupt it took).
    pub max_awake_cycles: u64,
    /// Resets after the first start.
    pub resets: u64,
    /// When the longest stretch ended, ns of virtual time.
    pub max_awake_at_ns: u64,
}

/// The emulated board.
pub struct Emulator {
    uc: Unicorn<'static, Machine>,
    options: Options,
    flash_image: Vec<u8>,
    resets: Vec<ResetKind>,
    symbols: std::collections::HashMap<String, u32>,
    /// Function symbols `(start, size, name)` sorted by start (Thumb bit cleared).
    functions: Vec<(u32, u32, String)>,
}

impl std::fmt::Debug for Emulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Emulator")
            .field("now_ns", &self.now_ns())
            .field("resets", &self.resets)
            .finish_non_exhaustive()
    }
}

fn cpu_err(what: impl std::fmt::Debug, pc: u32) -> EmuError {
    EmuError::Cpu {
        what: format!("{what:?}"),
        pc,
    }
}

/// The ELF's symbols with their addresses.
fn elf_symbols(elf: &[u8]) -> std::collections::HashMap<String, u32> {
    use object::{Object, ObjectSymbol};
    let Ok(file) = object::read::elf::ElfFile32::<object::Endianness>::parse(elf) else {
        return Default::default();
    };
    file.symbols()
        .filter_map(|s| Some((s.name().ok()?.to_string(), s.address() as u32)))
        .collect()
}

/// The ELF's function symbols `(start, size, name)`, sorted by start, Thumb bit cleared.
fn elf_functions(elf: &[u8]) -> Vec<(u32, u32, String)> {
    use object::{Object, ObjectSymbol, SymbolKind};
    let Ok(file) = object::read::elf::ElfFile32::<object::Endianness>::parse(elf) else {
        return Vec::new();
    };
    let mut f: Vec<(u32, u32, String)> = file
        .symbols()
        .filter(|s| s.kind() == SymbolKind::Text)
        .filter_map(|s| {
            let name = demangle(s.name().ok()?);
            Some((s.address() as u32 & !1, s.size() as u32, name))
        })
        .collect();
    f.sort();
    f
}

/// A Rust symbol (legacy `_ZN…E` or v0 `_R…`) demangled by `rustc-demangle`, without its hash
/// (`a::b::c`); any other name as it is.
fn demangle(name: &str) -> String {
    format!("{:#}", rustc_demangle::demangle(name))
}

fn load_elf(elf: &[u8]) -> Result<Vec<u8>, EmuError> {
    use object::read::elf::{ElfFile32, ProgramHeader};
    use object::Endianness;
    let file = ElfFile32::<Endianness>::parse(elf).map_err(|e| EmuError::Elf(e.to_string()))?;
    if file.elf_header().e_machine.get(file.endian()) != object::elf::EM_ARM {
        return Err(EmuError::Elf("not an ARM ELF".into()));
    }
    let mut image = vec![0xFF; CODE_FLASH as usize];
    let mut loaded = 0;
    for ph in file.elf_program_headers() {
        let e = file.endian();
        if ph.p_type(e) != object::elf::PT_LOAD || ph.p_filesz(e) == 0 {
            continue;
        }
        let paddr = ph.p_paddr(e);
        let data = ph
            .data(e, elf)
            .map_err(|_| EmuError::Elf("segment data out of the file".into()))?;
        if paddr < APP_BASE || paddr as u64 + data.len() as u64 > u64::from(CODE_FLASH) {
            return Err(EmuError::Elf(format!(
                "a loadable segment at {paddr:#x} (+{:#x}) lies outside the application flash {APP_BASE:#x}..{CODE_FLASH:#x}",
                data.len()
            )));
        }
        image[paddr as usize..paddr as usize + data.len()].copy_from_slice(data);
        loaded += data.len();
    }
    if loaded == 0 {
        return Err(EmuError::Elf("no loadable segment".into()));
    }
    image[0x400..0x404].copy_from_slice(&OFS.0.to_le_bytes());
    image[0x404..0x408].copy_from_slice(&OFS.1.to_le_bytes());
    Ok(image)
}

fn hoco_hz(ofs1: u32) -> u32 {
    match (ofs1 >> 12) & 7 {
        0b000 => 24_000_000,
        0b010 => 32_000_000,
        0b101 => 64_000_000,
        _ => 48_000_000,
    }
}

impl Emulator {
    /// Loads `elf` (the `uno-r4` image, linked at 0x4000) and starts the chip as the Arduino
    /// bootloader leaves it (power-on reset).
    pub fn new(elf: &[u8], options: Options) -> Result<Self, EmuError> {
        let image = load_elf(elf)?;
        let hoco = hoco_hz(OFS.1);
        let sys = periph::system::System::after_bootloader(hoco, ResetKind::PowerOn, 0);
        let clocks = sys.clocks();
        let machine = Machine {
            now: 0,
            awake_cycles: 0,
            instructions: 0,
            deadline: 0,
            stopped: false,
            irq_check: false,
            error: None,
            block_pc: 0,
            last_block_end: 0,
            blocks: Default::default(),
            code: image.clone(),
            asleep: false,
            clocks,
            wait_states: sys.wait_states(),
            sys,
            port: Default::default(),
            gpt: std::array::from_fn(|_| periph::gpt::Gpt::new()),
            adc: Default::default(),
            sci: periph::sci::Sci::new(),
            icu: Default::default(),
            scs: periph::scs::Scs::new(APP_BASE),
            wdt: Default::default(),
            spmon: Default::default(),
            flash: periph::flash::Flash::new(),
            tm1637: tm1637::Tm1637::new(),
            wiring: Wiring {
                tm1637: options.tm1637,
            },
            events: Vec::new(),
            vcc_mv: 5000,
            reset_due: None,
            held_in_reset: false,
            lvd_release_at: None,
            irq_hold: (0, 0),
            probe: options.probe,
            parked: false,
            wakes: 0,
            wake_start_cycles: 0,
            max_awake_cycles: 0,
            max_awake_at: 0,
            profile: None,
            stretch: Default::default(),
            longest_stretch: Default::default(),
            semihost_out: Vec::new(),
            exit_code: None,
            semihost_cmdline: None,
            cmdline_requests: 0,
            dbgstopcr: 3,
        };
        let mut uc = Unicorn::new_with_data(Arch::ARM, Mode::THUMB | Mode::MCLASS, machine)
            .map_err(|e| cpu_err(e, 0))?;
        uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M4 as i32)
            .map_err(|e| cpu_err(e, 0))?;
        uc.mem_map(0, CODE_FLASH as u64, Prot::READ | Prot::EXEC)
            .map_err(|e| cpu_err(e, 0))?;
        uc.mem_write(0, &image).map_err(|e| cpu_err(e, 0))?;
        uc.mem_map(RAM.0.into(), RAM.1.into(), Prot::ALL)
            .map_err(|e| cpu_err(e, 0))?;
        // The EXC_RETURN range (QEMU turns a branch there into an exception-exit trap).
        uc.mem_map(EXC_RETURN_PAGE.into(), 0x1000, Prot::READ | Prot::EXEC)
            .map_err(|e| cpu_err(e, 0))?;
        let spin: Vec<u8> = std::iter::repeat_n([0xFE, 0xE7], 0x800).flatten().collect();
        uc.mem_write(EXC_RETURN_PAGE.into(), &spin)
            .map_err(|e| cpu_err(e, 0))?;
        for &(base, size, page) in PAGES {
            uc.mmio_map(
                base.into(),
                size.into(),
                Some(
                    move |uc: &mut Unicorn<'_, Machine>, off: u64, sz: usize| -> u64 {
                        let m = uc.get_data_mut();
                        match m.read(page, base, off as u32, sz as u32) {
                            Ok(v) => {
                                m.charge_bus_wait(page);
                                u64::from(v)
                            }
                            Err(why) => {
                                let pc = m.block_pc;
                                m.error = Some(to_error(why, "read", base + off as u32, sz, pc));
                                m.stopped = true;
                                let _ = uc.emu_stop();
                                0
                            }
                        }
                    },
                ),
                Some(
                    move |uc: &mut Unicorn<'_, Machine>, off: u64, sz: usize, v: u64| {
                        let m = uc.get_data_mut();
                        let r = m.write(page, base, off as u32, sz as u32, v as u32);
                        if r.is_ok() {
                            m.charge_bus_wait(page);
                        }
                        if let Err(why) = r {
                            let pc = m.block_pc;
                            m.error = Some(to_error(why, "write", base + off as u32, sz, pc));
                            m.stopped = true;
                            let _ = uc.emu_stop();
                        } else if m.reset_due.is_some() {
                            m.stopped = true;
                            let _ = uc.emu_stop();
                        }
                    },
                ),
            )
            .map_err(|e| cpu_err(e, base))?;
        }
        uc.add_block_hook(1, 0, block_hook)
            .map_err(|e| cpu_err(e, 0))?;
        uc.add_intr_hook(intr_hook).map_err(|e| cpu_err(e, 0))?;
        // An undefined instruction (UDF, a bad encoding): UsageFault UNDEFINSTR, escalated to
        // HardFault (no separate UsageFault handler is enabled), faulting PC stacked.
        // The hint instructions this Unicorn build raises as invalid on M-profile: YIELD
        // (`core::hint::spin_loop`), WFE and SEV, reported with the PC after them (an undefined
        // instruction is reported at itself). On the M4 they are NOPs here (WFE may return at
        // once architecturally): execution goes on, unless a UDF follows the hint.
        uc.add_insn_invalid_hook(|uc| {
            let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0) as u32;
            let half = |uc: &Unicorn<'_, Machine>, a: u32| {
                let mut op = [0u8; 2];
                uc.mem_read(u64::from(a), &mut op)
                    .ok()
                    .map(|()| u16::from_le_bytes(op))
            };
            let after_hint = matches!(half(uc, pc.wrapping_sub(2)), Some(0xBF10 | 0xBF20 | 0xBF40));
            let udf = half(uc, pc).is_some_and(|h| h & 0xFF00 == 0xDE00);
            if after_hint && !udf {
                let _ = uc.reg_write(RegisterARM::PC, u64::from(pc | 1));
                let m = uc.get_data_mut();
                m.stopped = true;
                let _ = uc.emu_stop();
                return true;
            }
            let m = uc.get_data_mut();
            m.scs.cfsr |= 1 << 16;
            m.scs.hfsr |= 1 << 30;
            m.scs.hardfault_pending = true;
            m.irq_check = true;
            m.stopped = true;
            let _ = uc.emu_stop();
            true
        })
        .map_err(|e| cpu_err(e, 0))?;
        uc.add_mem_hook(
            HookType::MEM_UNMAPPED | HookType::MEM_PROT,
            1,
            0,
            |uc, kind, addr, size, _v| {
                let pc = uc.get_data().block_pc;
                let m = uc.get_data_mut();
                m.error = Some(match kind {
                    MemType::WRITE_PROT => EmuError::Refused {
                        what: "write to code flash".into(),
                        addr: addr as u32,
                        pc,
                    },
                    MemType::FETCH_UNMAPPED | MemType::FETCH_PROT => EmuError::Refused {
                        what: "instruction fetch from a non-executable address".into(),
                        addr: addr as u32,
                        pc,
                    },
                    MemType::WRITE_UNMAPPED => EmuError::Unmodelled {
                        kind: "write",
                        addr: addr as u32,
                        size: size as u8,
                        pc,
                    },
                    _ => EmuError::Unmodelled {
                        kind: "read",
                        addr: addr as u32,
                        size: size as u8,
                        pc,
                    },
                });
                m.stopped = true;
                false
            },
        )
        .map_err(|e| cpu_err(e, 0))?;
        let mut emu = Self {
            uc,
            options,
            flash_image: image,
            resets: Vec::new(),
            symbols: elf_symbols(elf),
            functions: elf_functions(elf),
        };
        emu.m().flash.timing = options.flash_timing;
        emu.reset(ResetKind::PowerOn)?;
        emu.resets.clear();
        Ok(emu)
    }

    fn m(&mut self) -> &mut Machine {
        self.uc.get_data_mut()
    }

    /// The chip's state (read only: registers, counters, parts).
    pub fn machine(&self) -> &Machine {
        self.uc.get_data()
    }

    /// Resets the chip (`kind` sets the reset flags) and jumps to the application as the
    /// bootloader does. The data flash, the pins' outside drives and the analog inputs stay.
    pub fn reset(&mut self, kind: ResetKind) -> Result<(), EmuError> {
        let board = self.options.board;
        let now = self.machine().now;
        let running_b = match board {
            Board::Wifi => 1 << 22,
            Board::Minima => 1 << 11,
        };
        let m = self.m();
        m.sys = periph::system::System::after_bootloader(hoco_hz(OFS.1), kind, running_b);
        m.clocks = m.sys.clocks();
        m.wait_states = m.sys.wait_states();
        m.port = periph::port::Port::reset_keeping_wiring(&m.port);
        m.gpt = std::array::from_fn(|_| periph::gpt::Gpt::new());
        m.adc = periph::adc::Adc::reset_keeping_inputs(&m.adc);
        let host_baud = m.sci.host_baud;
        m.sci = periph::sci::Sci::new();
        m.sci.host_baud = host_baud;
        m.icu = Default::default();
        m.scs = periph::scs::Scs::new(APP_BASE);
        {
            // The bootloader's links (`src/irq_table.c`): the WiFi's SCI9 UART (TXI, TEI, RXI,
            // ERI; its last transmission left TXI and TEI requesting), the Minima's USBFS (INT,
            // RESUME, FIFO 0, FIFO 1; INT requesting).
            use periph::{event, icu::IR};
            let (links, requesting): ([u16; 4], u32) = match board {
                Board::Wifi => (
                    [
                        event::SCI9_TXI,
                        event::SCI9_TEI,
                        event::SCI9_RXI,
                        event::SCI9_ERI,
                    ],
                    0b0011,
                ),
                Board::Minima => (
                    [
                        event::USBFS_INT,
                        event::USBFS_RESUME,
                        event::USBFS_FIFO_0,
                        event::USBFS_FIFO_1,
                    ],
                    0b0001,
                ),
            };
            for (n, e) in links.into_iter().enumerate() {
                let ir = if requesting & (1 << n) != 0 { IR } else { 0 };
                m.icu.ielsr[n] = u32::from(e) | ir;
            }
            m.scs.pending = requesting;
        }
        m.wdt = Default::default();
        m.spmon = Default::default();
        m.dbgstopcr = 3;
        m.irq_hold = (0, 0);
        m.lvd_release_at = None;
        m.parked = false;
        m.flash.reset(now);
        m.asleep = false;
        m.reset_due = None;
        m.error = None;
        m.irq_check = true;
        if kind == ResetKind::PowerOn {
            // SRAM powers up with unknown contents; here zeros, and the stack (from the ELF's
            // `_stack_end`, cortex-m-rt's end of the static RAM, to the top) painted with
            // [`STACK_PAINT`] so that [`Emulator::stack_high_water`] can tell how deep it went.
            let mut ram = vec![0u8; RAM.1 as usize];
            if let Some(end) = self.symbol("_stack_end") {
                let from = end.saturating_sub(RAM.0).min(RAM.1) as usize & !3;
                for w in ram[from..].chunks_exact_mut(4) {
                    w.copy_from_slice(&STACK_PAINT.to_le_bytes());
                }
            }
            self.uc
                .mem_write(RAM.0.into(), &ram)
                .map_err(|e| cpu_err(e, 0))?;
        }
        let word = |a: u32| {
            u32::from_le_bytes(
                self.flash_image[a as usize..a as usize + 4]
                    .try_into()
                    .unwrap_or([0; 4]),
            )
        };
        let (msp, entry) = (word(APP_BASE), word(APP_BASE + 4));
        let uc = &mut self.uc;
        let w = |uc: &mut Unicorn<'static, Machine>, r: RegisterARM, v: u32| {
            uc.reg_write(r, v.into()).map_err(|e| cpu_err(e, entry))
        };
        w(uc, RegisterARM::CONTROL, 0)?;
        for r in [
            RegisterARM::R0,
            RegisterARM::R1,
            RegisterARM::R2,
            RegisterARM::R3,
            RegisterARM::R12,
        ] {
            w(uc, r, 0)?;
        }
        w(uc, RegisterARM::SP, msp)?;
        w(uc, RegisterARM::LR, 0xFFFF_FFFF)?;
        w(uc, RegisterARM::PRIMASK, 1)?;
        w(uc, RegisterARM::BASEPRI, 0)?;
        w(uc, RegisterARM::APSR_NZCVQG, 0)?;
        w(uc, RegisterARM::EPSR, 1 << 24)?;
        uc.reg_write(RegisterARM::PC, u64::from(entry | 1))
            .map_err(|e| cpu_err(e, entry))?;
        self.resets.push(kind);
        Ok(())
    }

    /// A second reset within the Arduino bootloader's 500 ms window after a reset that was not
    /// a power-on (`arduino-renesas-bootloader`, `src/main.c`: the double-tap magic at
    /// 0x2000_7FF0): the bootloader stays, the application does not start until a power cycle
    /// (or a reset after the window). The pins as the parked bootloader drives them: P111 an
    /// output, low (TinyUSB's `uno_r4` pin table, `board_init`, both boards), then its LED fade
    /// from GPT PWM on LED_FADE_GPIO — GTIOC3A = P111 on the Minima (`Makefile.minima`),
    /// GTIOC2B = P102 on the WiFi (`Makefile.wifi`); every other pin released.
    pub fn park_in_bootloader(&mut self) -> Result<(), EmuError> {
        self.reset(ResetKind::Software)?;
        let board = self.options.board;
        let m = self.m();
        m.parked = true;
        const PDR: u32 = 1 << 2;
        const PMR: u32 = 1 << 16;
        const PSEL_GPT: u32 = 0b00011 << 24;
        m.port.pfs[1][11] = PDR;
        let (port, pin) = match board {
            Board::Minima => (1, 11),
            Board::Wifi => (1, 2),
        };
        m.port.pfs[port][pin] = PMR | PSEL_GPT;
        m.port.changed = true;
        m.update_parts();
        Ok(())
    }

    /// Power cut and back: a power-on reset (RAM cleared, data flash kept).
    pub fn power_cycle(&mut self) -> Result<(), EmuError> {
        self.reset(ResetKind::PowerOn)
    }

    /// Virtual time, ns.
    pub fn now_ns(&self) -> u64 {
        clock::ticks_to_ns(self.machine().now)
    }

    /// Resets so far (after the first start), oldest first.
    pub fn resets(&self) -> &[ResetKind] {
        &self.resets
    }

    /// Counters.
    pub fn stats(&self) -> Stats {
        let m = self.machine();
        Stats {
            instructions: m.instructions,
            awake_cycles: m.awake_cycles,
            wakes: m.wakes,
            max_awake_cycles: m.max_awake_cycles,
            resets: self.resets.len() as u64,
            max_awake_at_ns: clock::ticks_to_ns(m.max_awake_at),
        }
    }

    /// Forgets the longest awake stretch so far (to measure from now on).
    pub fn clear_max_awake(&mut self) {
        let m = self.m();
        m.max_awake_cycles = 0;
        m.longest_stretch = Default::default();
        if let Some(p) = m.profile.as_mut() {
            p.longest.clear();
            p.longest_to_overrun = None;
        }
    }

    /// What the longest awake stretch so far held ([`machine::Stretch`]: its SysTick entries,
    /// so whether it was one pass or passes back to back, and its cycles in handlers).
    pub fn longest_stretch(&self) -> &machine::Stretch {
        &self.machine().longest_stretch
    }

    /// Starts (or stops) recording where the cycles of each awake stretch go, to read the
    /// longest one's with [`Emulator::longest_pass_profile`].
    pub fn profile_passes(&mut self, on: bool) {
        self.m().profile = on.then(Default::default);
    }

    /// The longest awake stretch's cycles per function of the ELF (the symbol covering each
    /// executed block; what the compiler inlined counts in its caller), largest first.
    pub fn longest_pass_profile(&self) -> Vec<(String, u64)> {
        self.machine()
            .profile
            .as_ref()
            .map_or_else(Vec::new, |p| self.per_function(&p.longest))
    }

    /// Of the longest awake stretch, when it held passes back to back
    /// ([`machine::Stretch::back_to_back`]): what ran before its second SysTick — the pass
    /// that overran the tick, up to the tick — per function, largest first (empty otherwise).
    pub fn longest_overrun_profile(&self) -> Vec<(String, u64)> {
        self.machine()
            .profile
            .as_ref()
            .and_then(|p| p.longest_to_overrun.as_ref())
            .map_or_else(Vec::new, |b| self.per_function(b))
    }

    fn per_function(&self, blocks: &std::collections::HashMap<u32, u64>) -> Vec<(String, u64)> {
        let mut per: std::collections::HashMap<&str, u64> = Default::default();
        for (&addr, &cycles) in blocks {
            let i = self.functions.partition_point(|f| f.0 <= addr);
            let name = i
                .checked_sub(1)
                .map(|i| &self.functions[i])
                .filter(|f| addr < f.0 + f.1.max(1))
                .map_or("?", |f| f.2.as_str());
            *per.entry(name).or_default() += cycles;
        }
        let mut out: Vec<(String, u64)> =
            per.into_iter().map(|(n, c)| (n.to_string(), c)).collect();
        out.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        out
    }

    /// Sets the supply voltage (mV): a fall below an armed voltage monitor 1 level resets the
    /// chip, which is released as LVD1CR0.RN says ([`periph::system`]).
    pub fn set_vcc_mv(&mut self, mv: u32) {
        self.m().vcc_mv = mv;
    }

    /// Holds NVIC interrupt line `line` off for `ns` of virtual time from now: its requests
    /// stay pending but are not taken, as when a handler of higher priority or a critical
    /// section delays it; then it is taken as usual. For scenarios of a handler entered late.
    pub fn hold_irq(&mut self, line: u32, ns: u64) {
        let now = self.machine().now;
        let m = self.m();
        m.scs.held |= 1 << line;
        m.irq_hold = (m.scs.held, now + clock::ns_to_ticks(ns));
    }

    /// Drives `P<port><pin>` from outside (`None`: leaves it open).
    pub fn drive_pin(&mut self, port: usize, pin: usize, level: Option<bool>) {
        self.m().port.drive(port, pin, level);
    }

    /// How the MCU drives `P<port><pin>`.
    pub fn pin_drive(&self, port: usize, pin: usize) -> PinDrive {
        self.machine().port.drive_of(port, pin)
    }

    /// What a device on `P<port><pin>` sees, the pin being GTIOC of GPT16`channel`, output B
    /// if `b`: the timer's waveform when the pin is in its GPT function, the GPIO level
    /// otherwise (`Released` when nothing drives it).
    pub fn timer_pin(&mut self, port: usize, pin: usize, channel: usize, b: bool) -> Line {
        let now = self.machine().now;
        let m = self.m();
        match m.port.drive_of(port, pin) {
            PinDrive::Peripheral { psel: 0b00011 } => {
                let pclkd = m.clocks.pclkd;
                m.gpt[channel].sync(now, pclkd);
                m.gpt[channel].line(b, pclkd)
            }
            PinDrive::High => Line::Level(true),
            PinDrive::Low => Line::Level(false),
            _ => Line::Released,
        }
    }

    /// Sets analog input AN`channel` (14-bit count of its voltage against AVCC0).
    pub fn set_analog(&mut self, channel: usize, raw: u16) {
        if let Some(v) = self.m().adc.input.get_mut(channel) {
            *v = raw.min(0x3FFF);
        }
    }

    /// Bytes from the host to SCI9's RXD9, at the host's line rate after those still queued.
    pub fn host_send(&mut self, bytes: &[u8]) {
        let now = self.machine().now;
        self.m().sci.host_send(bytes, now);
    }

    /// Host bytes not yet received by SCI9.
    pub fn host_pending(&self) -> usize {
        self.machine().sci.host_pending()
    }

    /// Takes the bytes SCI9 has finished sending.
    pub fn host_take(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.m().sci.tx_out)
    }

    /// The display.
    pub fn display(&self) -> tm1637::Tm1637 {
        self.machine().tm1637
    }

    /// The data flash contents.
    pub fn data_flash(&self) -> &[u8] {
        &self.machine().flash.mem
    }

    /// The data flash contents, to preload a record.
    pub fn data_flash_mut(&mut self) -> &mut [u8] {
        &mut self.m().flash.mem
    }

    /// Injects (or clears) a data-flash fault.
    pub fn set_flash_fault(&mut self, fault: Option<FlashFault>) {
        self.m().flash.fault = fault;
    }

    /// The exit code a test program gave through semihosting, once it has exited (the run
    /// stops there).
    pub fn exit_code(&self) -> Option<i32> {
        self.machine().exit_code
    }

    /// The command line the program's next SYS_GET_CMDLINE gets (once; a later call fails
    /// with -1, as a test runner answers only the first request of a test).
    pub fn set_semihost_cmdline(&mut self, cmdline: &str) {
        self.m().semihost_cmdline = Some(cmdline.to_string());
    }

    /// How often the program asked for its command line (SYS_GET_CMDLINE): a test program
    /// asks once per boot, so more than one means it reset.
    pub fn cmdline_requests(&self) -> u32 {
        self.machine().cmdline_requests
    }

    /// Takes what the program wrote through semihosting.
    pub fn take_semihost_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.m().semihost_out)
    }

    /// Makes a HardFault pending (as a bus error from outside would).
    pub fn inject_hard_fault(&mut self) {
        let m = self.m();
        m.scs.hardfault_pending = true;
        m.scs.hfsr |= 1 << 30;
        m.irq_check = true;
    }

    fn reg(&self, r: RegisterARM) -> Result<u32, EmuError> {
        self.uc
            .reg_read(r)
            .map(|v| v as u32)
            .map_err(|e| cpu_err(e, 0))
    }

    /// The CPU's program counter.
    pub fn pc(&self) -> u32 {
        self.uc.reg_read(RegisterARM::PC).unwrap_or(0) as u32
    }

    /// The main stack pointer.
    pub fn sp(&self) -> u32 {
        self.uc.reg_read(RegisterARM::SP).unwrap_or(0) as u32
    }

    /// Sets the main stack pointer (a stack that has grown to `sp`, for tests of a guard).
    pub fn set_sp(&mut self, sp: u32) {
        let _ = self.uc.reg_write(RegisterARM::SP, sp.into());
    }

    /// Reads memory as the CPU sees it (RAM or flash; `None` elsewhere).
    pub fn read_u32(&self, addr: u32) -> Option<u32> {
        let mut b = [0u8; 4];
        self.uc.mem_read(addr.into(), &mut b).ok()?;
        Some(u32::from_le_bytes(b))
    }

    /// Attaches (or detaches) a debug probe: DHCSR.C_DEBUGEN reads it, and in on-chip-debug
    /// mode DBGSTOPCR's reset value masks the watchdogs' resets ([`Options::probe`] at start).
    pub fn set_probe(&mut self, attached: bool) {
        self.m().probe = attached;
    }

    /// Writes RAM as a debug probe would (`false` outside RAM).
    pub fn write_u32(&mut self, addr: u32, v: u32) -> bool {
        (RAM.0..RAM.0 + RAM.1 - 3).contains(&addr)
            && self.uc.mem_write(addr.into(), &v.to_le_bytes()).is_ok()
    }

    /// Takes the bytes waiting in RTT up-channel 0 (`_SEGGER_RTT`, as defmt-rtt lays it out)
    /// and marks them read, as a probe does; empty when the ELF has no RTT control block.
    /// For defmt they are frames for `defmt-print -e ELF`.
    pub fn rtt_take(&mut self) -> Vec<u8> {
        let Some(cb) = self.symbol("_SEGGER_RTT") else {
            return Vec::new();
        };
        let mut id = [0u8; 10];
        if self.uc.mem_read(cb.into(), &mut id).is_err() || &id != b"SEGGER RTT" {
            return Vec::new();
        }
        let ch = cb + 24;
        let (Some(buf), Some(size), Some(write), Some(read)) = (
            self.read_u32(ch + 4),
            self.read_u32(ch + 8),
            self.read_u32(ch + 12),
            self.read_u32(ch + 16),
        ) else {
            return Vec::new();
        };
        if size == 0 || write >= size || read >= size {
            return Vec::new();
        }
        let mut out = Vec::new();
        let mut r = read;
        while r != write {
            let end = if write > r { write } else { size };
            let mut chunk = vec![0u8; (end - r) as usize];
            if self.uc.mem_read(u64::from(buf + r), &mut chunk).is_err() {
                return out;
            }
            out.extend(chunk);
            r = end % size;
        }
        self.write_u32(ch + 16, write);
        out
    }

    /// The deepest the main stack has reached since the last power-on, bytes below its top
    /// (`_stack_start`): the lowest word from `_stack_end` up that no longer holds the paint
    /// of the power-on. `None` without cortex-m-rt's stack symbols. (A word the program wrote
    /// with the paint's own value would be missed: the figure is exact up to such a word.)
    pub fn stack_high_water(&self) -> Option<u32> {
        let (end, top) = (self.symbol("_stack_end")?, self.symbol("_stack_start")?);
        let mut a = (end + 3) & !3;
        while a < top && self.read_u32(a) == Some(STACK_PAINT) {
            a += 4;
        }
        Some(top - a)
    }

    /// The stack's room: `_stack_start − _stack_end`, bytes.
    pub fn stack_size(&self) -> Option<u32> {
        Some(self.symbol("_stack_start")? - self.symbol("_stack_end")?)
    }

    /// The address of the ELF symbol `name`.
    pub fn symbol(&self, name: &str) -> Option<u32> {
        self.symbols.get(name).copied()
    }

    /// The exception to take now, if any.
    fn deliverable(&self) -> Result<Option<u16>, EmuError> {
        let m = self.machine();
        let Some((e, p)) = m.scs.best_pending() else {
            return Ok(None);
        };
        if p >= m.scs.running_priority() {
            return Ok(None);
        }
        let primask = self.reg(RegisterARM::PRIMASK)? & 1;
        let basepri = (self.reg(RegisterARM::BASEPRI)? & 0xF0) as i16;
        let masked = (primask != 0 && p >= 0) || (basepri != 0 && p >= basepri);
        Ok((!masked).then_some(e))
    }

    /// Runs until virtual time `t_ns` (or the first error).
    pub fn run_until_ns(&mut self, t_ns: u64) -> Result<(), EmuError> {
        let end = clock::ns_to_ticks(t_ns);
        loop {
            if self.machine().exit_code.is_some() {
                return Ok(());
            }
            if self.machine().parked {
                let m = self.m();
                m.now = m.now.max(end);
                return Ok(());
            }
            if self.machine().held_in_reset {
                let m = self.m();
                let level = m.sys.lvd1_reset_level_mv().unwrap_or(0);
                if m.lvd_release_at.is_none() && m.vcc_mv >= level {
                    // RN = 0: released tLVD1 after VCC is back above Vdet1.
                    m.lvd_release_at = Some(m.now + clock::ns_to_ticks(periph::system::T_LVD1_NS));
                }
                match m.lvd_release_at {
                    Some(t) if t <= end => m.now = m.now.max(t),
                    _ => {
                        m.now = m.now.max(end);
                        return Ok(());
                    }
                }
                m.held_in_reset = false;
                m.lvd_release_at = None;
                // Released: the bootloader runs again and jumps to the application.
                let old = m.sys.clone();
                self.reset(ResetKind::BrownOut)?;
                self.m().sys.keep_lvd_from(&old);
            }
            self.m().advance();
            if let Some(kind) = self.m().reset_due.take() {
                self.hold_in_reset(kind, end)?;
                continue;
            }
            if self.machine().now >= end {
                return Ok(());
            }
            if let Some(e) = self.deliverable()? {
                self.enter_exception(e)?;
                self.wake();
                let m = self.m();
                m.stretch.exceptions += 1;
                if e == periph::scs::exc::SYSTICK {
                    let at = m.awake_cycles - m.wake_start_cycles;
                    m.stretch.ticks_at.push(at);
                    if m.stretch.ticks_at.len() == 2 {
                        if let Some(p) = m.profile.as_mut() {
                            p.current_to_overrun = Some(p.current.clone());
                        }
                    }
                }
            }
            if self.machine().asleep {
                let wake = self
                    .machine()
                    .scs
                    .best_pending()
                    .is_some_and(|(_, p)| p < self.machine().scs.running_priority());
                if wake {
                    self.wake();
                } else {
                    let m = self.m();
                    m.now = m.next_event().min(end).max(m.now);
                    continue;
                }
            }
            let m = self.m();
            m.deadline = m.next_event().min(end);
            m.stopped = false;
            let pc = self.pc();
            let r = self.uc.emu_start(u64::from(pc | 1), 0, 0, 0);
            if let Some(e) = self.m().error.take() {
                return Err(e);
            }
            r.map_err(|e| cpu_err(e, self.pc()))?;
            if !self.machine().stopped {
                // Unicorn returns by itself only when the CPU halts in WFI.
                let m = self.m();
                m.asleep = true;
                let stretch = m.awake_cycles - m.wake_start_cycles;
                m.stretch.cycles = stretch;
                m.stretch.end = m.now;
                if stretch > m.max_awake_cycles {
                    m.max_awake_cycles = stretch;
                    m.max_awake_at = m.now;
                    m.longest_stretch = std::mem::take(&mut m.stretch);
                    if let Some(p) = m.profile.as_mut() {
                        p.longest = std::mem::take(&mut p.current);
                        p.longest_to_overrun = p.current_to_overrun.take();
                    }
                }
            }
        }
    }

    fn wake(&mut self) {
        let m = self.m();
        if m.asleep {
            m.asleep = false;
            m.wakes += 1;
            m.wake_start_cycles = m.awake_cycles;
            m.stretch = Default::default();
            if let Some(p) = m.profile.as_mut() {
                p.current.clear();
                p.current_to_overrun = None;
            }
        }
    }

    /// A reset the hardware decided. A brown-out (voltage monitor 1) holds the chip in reset
    /// until VCC is back above Vdet1; the monitor's settings survive its own reset.
    fn hold_in_reset(&mut self, kind: ResetKind, end: u64) -> Result<(), EmuError> {
        if kind == ResetKind::BrownOut {
            let old = self.machine().sys.clone();
            self.reset(kind)?;
            let now = self.machine().now;
            let m = self.m();
            m.sys.keep_lvd_from(&old);
            m.held_in_reset = true;
            // RN = 1: released tLVD1 after the assertion, whatever VCC is.
            m.lvd_release_at = m
                .sys
                .lvd1_negation_after_assertion()
                .then(|| now + clock::ns_to_ticks(periph::system::T_LVD1_NS));
            let _ = end;
            return Ok(());
        }
        self.reset(kind)
    }

    fn enter_exception(&mut self, e: u16) -> Result<(), EmuError> {
        use RegisterARM::*;
        let pc = self.pc();
        let control = self.reg(CONTROL)?;
        if control & 2 != 0 {
            return Err(EmuError::Exception {
                what: "exception entry with CONTROL.SPSEL = 1 (process stack) is not modelled"
                    .into(),
                pc,
            });
        }
        if e == exc::HARD_FAULT && self.machine().scs.active.contains(&exc::HARD_FAULT) {
            return Err(EmuError::Exception {
                what: "HardFault inside the HardFault handler: lockup".into(),
                pc,
            });
        }
        let fpca = control & 4 != 0;
        let sp = self.reg(SP)?;
        let frame: u32 = if fpca { 0x68 } else { 0x20 };
        let align = sp & 4 != 0;
        let new_sp = (sp - frame) & !7;
        let interrupted = self.machine().scs.active.last().copied().unwrap_or(0);
        let xpsr = (self.reg(XPSR)? & !0x1FF & !(1 << 9))
            | u32::from(interrupted)
            | (u32::from(align) << 9);
        let mut words = vec![
            self.reg(R0)?,
            self.reg(R1)?,
            self.reg(R2)?,
            self.reg(R3)?,
            self.reg(R12)?,
            self.reg(LR)?,
            pc & !1,
            xpsr,
        ];
        if fpca {
            for s in 0..16 {
                words.push(self.reg(s_reg(s))?);
            }
            words.push(self.reg(FPSCR)?);
            words.push(0);
        }
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        self.uc
            .mem_write(new_sp.into(), &bytes)
            .map_err(|_| EmuError::Exception {
                what: format!("stacking at {new_sp:#010x} failed (stack overflow?)"),
                pc,
            })?;
        let nested = !self.machine().scs.active.is_empty();
        let mut exc_return: u32 = if nested { 0xFFFF_FFF1 } else { 0xFFFF_FFF9 };
        if fpca {
            exc_return &= !0x10;
        }
        let vtor = self.machine().scs.vtor;
        let mut v = [0u8; 4];
        self.uc
            .mem_read(u64::from(vtor + 4 * u32::from(e)), &mut v)
            .map_err(|_| EmuError::Exception {
                what: format!("vector table at {vtor:#x} unreadable"),
                pc,
            })?;
        let vector = u32::from_le_bytes(v);
        if vector & 1 == 0 || vector >= CODE_FLASH {
            return Err(EmuError::Exception {
                what: format!("vector {e} is {vector:#010x} (not a Thumb address in flash)"),
                pc,
            });
        }
        let w = |uc: &mut Unicorn<'static, Machine>, r: RegisterARM, v: u32| {
            uc.reg_write(r, v.into()).map_err(|er| cpu_err(er, pc))
        };
        w(&mut self.uc, SP, new_sp)?;
        w(&mut self.uc, LR, exc_return)?;
        w(&mut self.uc, CONTROL, control & !4)?;
        w(&mut self.uc, EPSR, 1 << 24)?;
        self.uc
            .reg_write(RegisterARM::PC, u64::from(vector))
            .map_err(|er| cpu_err(er, pc))?;
        let m = self.m();
        match e {
            exc::HARD_FAULT => m.scs.hardfault_pending = false,
            exc::NMI => m.scs.nmi_pending = false,
            exc::SYSTICK => m.scs.systick_pending = false,
            _ => m.scs.pending &= !(1 << (e - exc::IRQ0)),
        }
        m.scs.active.push(e);
        m.irq_check = true;
        Ok(())
    }
}

fn s_reg(i: u32) -> RegisterARM {
    use RegisterARM::*;
    [
        S0, S1, S2, S3, S4, S5, S6, S7, S8, S9, S10, S11, S12, S13, S14, S15,
    ][i as usize]
}

fn to_error(why: Why, kind: &'static str, addr: u32, size: usize, pc: u32) -> EmuError {
    match why {
        Why::Unmodelled => EmuError::Unmodelled {
            kind,
            addr,
            size: size as u8,
            pc,
        },
        Why::Refused(what) => EmuError::Refused { what, addr, pc },
    }
}

fn block_hook(uc: &mut Unicorn<'_, Machine>, addr: u64, size: u32) {
    let m = uc.get_data_mut();
    if m.stopped {
        return;
    }
    if m.now >= m.deadline || m.reset_due.is_some() {
        m.stopped = true;
        let _ = uc.emu_stop();
        return;
    }
    if m.spmon.enabled() {
        let sp = uc.reg_read(RegisterARM::SP).unwrap_or(0) as u32;
        let m = uc.get_data_mut();
        if m.spmon.check(sp) && m.icu.nmi(12) {
            // NMISR.SPEST: the NMI, taken before this block.
            m.scs.nmi_pending = true;
            m.stopped = true;
            let _ = uc.emu_stop();
            return;
        }
    }
    let m = uc.get_data_mut();
    if m.irq_check {
        m.irq_check = false;
        let candidate = m
            .scs
            .best_pending()
            .filter(|&(_, p)| p < m.scs.running_priority());
        if let Some((_, p)) = candidate {
            let primask = uc.reg_read(RegisterARM::PRIMASK).unwrap_or(1) & 1;
            let basepri = (uc.reg_read(RegisterARM::BASEPRI).unwrap_or(0) & 0xF0) as i16;
            let masked = (primask != 0 && p >= 0) || (basepri != 0 && p >= basepri);
            let m = uc.get_data_mut();
            if masked {
                m.irq_check = true; // look again once the mask is lifted
            } else {
                m.stopped = true;
                let _ = uc.emu_stop();
                return;
            }
        }
    }
    let m = uc.get_data_mut();
    let addr = addr as u32;
    let cost = *m
        .blocks
        .entry((addr, size))
        .or_insert_with(|| cpu::block_cost(&m.code, addr, size));
    let mut cycles = u64::from(cost.cycles);
    if addr < CODE_FLASH {
        cycles += u64::from(cost.fetch_words * m.wait_states);
    }
    if addr != m.last_block_end {
        cycles += 2 + u64::from(m.wait_states);
    }
    m.last_block_end = addr + size;
    m.block_pc = addr;
    m.instructions += u64::from(cost.instructions);
    m.awake_cycles += cycles;
    if !m.scs.active.is_empty() {
        m.stretch.handler_cycles += cycles;
    }
    if let Some(p) = m.profile.as_mut() {
        *p.current.entry(addr).or_default() += cycles;
    }
    m.now += cycles * clock::ticks_per(m.clocks.iclk);
}

fn exception_return(uc: &mut Unicorn<'_, Machine>, exc_return: u32) -> Result<(), EmuError> {
    use RegisterARM::*;
    let pc = exc_return;
    let err = |what: String| EmuError::Exception { what, pc };
    let Some(e) = uc.get_data_mut().scs.active.pop() else {
        return Err(err(format!(
            "branch to {exc_return:#010x} with no exception active"
        )));
    };
    let to_thread = match exc_return {
        0xFFFF_FFF9 | 0xFFFF_FFE9 => true,
        0xFFFF_FFF1 | 0xFFFF_FFE1 => false,
        v => {
            return Err(err(format!(
                "EXC_RETURN {v:#010x} (process stack or reserved) is not modelled"
            )))
        }
    };
    if to_thread != uc.get_data().scs.active.is_empty() {
        return Err(err(format!(
            "EXC_RETURN {exc_return:#010x} does not match the active exceptions"
        )));
    }
    let extended = exc_return & 0x10 == 0;
    let sp = uc.reg_read(SP).map_err(|e| cpu_err(e, pc))? as u32;
    let n = if extended { 26 } else { 8 };
    let mut buf = vec![0u8; n * 4];
    uc.mem_read(sp.into(), &mut buf)
        .map_err(|_| err(format!("unstacking at {sp:#010x} failed")))?;
    let word =
        |i: usize| u32::from_le_bytes([buf[4 * i], buf[4 * i + 1], buf[4 * i + 2], buf[4 * i + 3]]);
    let regs = [R0, R1, R2, R3, R12, LR];
    for (i, r) in regs.iter().enumerate() {
        uc.reg_write(*r, word(i).into())
            .map_err(|e| cpu_err(e, pc))?;
    }
    let ret = word(6);
    let xpsr = word(7);
    if extended {
        for s in 0..16 {
            uc.reg_write(s_reg(s), word(8 + s as usize).into())
                .map_err(|e| cpu_err(e, pc))?;
        }
        uc.reg_write(FPSCR, word(24).into())
            .map_err(|e| cpu_err(e, pc))?;
    }
    let new_sp = sp + 4 * n as u32 + if xpsr & (1 << 9) != 0 { 4 } else { 0 };
    uc.reg_write(SP, new_sp.into())
        .map_err(|e| cpu_err(e, pc))?;
    uc.reg_write(APSR_NZCVQG, (xpsr & 0xF80F_0000).into())
        .map_err(|e| cpu_err(e, pc))?;
    uc.reg_write(EPSR, (xpsr & 0x0700_FC00 | 1 << 24).into())
        .map_err(|e| cpu_err(e, pc))?;
    let control = uc.reg_read(CONTROL).map_err(|e| cpu_err(e, pc))? as u32;
    let control = if extended { control | 4 } else { control & !4 };
    uc.reg_write(CONTROL, control.into())
        .map_err(|e| cpu_err(e, pc))?;
    let m = uc.get_data_mut();
    if e >= exc::IRQ0 && m.icu.requesting(usize::from(e - exc::IRQ0)) {
        m.scs.pending |= 1 << (e - exc::IRQ0);
    }
    m.irq_check = true;
    m.last_block_end = u32::MAX;
    uc.reg_write(RegisterARM::PC, u64::from(ret | 1))
        .map_err(|e| cpu_err(e, pc))?;
    Ok(())
}

/// ARM semihosting (`BKPT 0xAB`, op in r0, argument in r1), the subset test harnesses use:
/// SYS_WRITEC (3), SYS_WRITE0 (4), SYS_WRITE (5) to the host's output, SYS_ERRNO (0x13: EIO),
/// SYS_GET_CMDLINE (0x15, r1 → [buffer, size]: the command line set by
/// [`Emulator::set_semihost_cmdline`], once), SYS_EXIT (0x18, r1 the reason:
/// ADP_Stopped_ApplicationExit 0x2_0026 is success) and SYS_EXIT_EXTENDED (0x20, r1 →
/// [reason, code]). Execution goes on after the BKPT (or stops at an exit).
fn semihosting(uc: &mut Unicorn<'_, Machine>, pc: u32) -> Result<(), EmuError> {
    let reg =
        |uc: &Unicorn<'_, Machine>, r| uc.reg_read(r).map(|v| v as u32).map_err(|e| cpu_err(e, pc));
    let op = reg(uc, RegisterARM::R0)?;
    let arg = reg(uc, RegisterARM::R1)?;
    let bad = |what: String| EmuError::Exception { what, pc };
    let read = |uc: &Unicorn<'_, Machine>, a: u32, n: usize| -> Result<Vec<u8>, EmuError> {
        let mut b = vec![0u8; n];
        uc.mem_read(a.into(), &mut b)
            .map_err(|_| bad(format!("semihosting: {n} bytes at {a:#010x} unreadable")))?;
        Ok(b)
    };
    let word = |b: &[u8], i: usize| {
        u32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
    };
    const APPLICATION_EXIT: u32 = 0x2_0026;
    match op {
        0x03 => {
            let b = read(uc, arg, 1)?;
            uc.get_data_mut().semihost_out.extend(b);
        }
        0x04 => {
            let mut s = Vec::new();
            let mut a = arg;
            loop {
                let b = read(uc, a, 1)?[0];
                if b == 0 || s.len() >= 64 * 1024 {
                    break;
                }
                s.push(b);
                a += 1;
            }
            uc.get_data_mut().semihost_out.extend(s);
        }
        0x05 => {
            let block = read(uc, arg, 12)?;
            let (ptr, len) = (word(&block, 1), word(&block, 2));
            let data = read(uc, ptr, len.min(64 * 1024) as usize)?;
            uc.get_data_mut().semihost_out.extend(data);
            uc.reg_write(RegisterARM::R0, 0)
                .map_err(|e| cpu_err(e, pc))?;
        }
        0x13 => {
            const EIO: u64 = 5;
            uc.reg_write(RegisterARM::R0, EIO)
                .map_err(|e| cpu_err(e, pc))?;
        }
        0x15 => {
            let block = read(uc, arg, 8)?;
            let (ptr, size) = (word(&block, 0), word(&block, 1));
            let m = uc.get_data_mut();
            m.cmdline_requests += 1;
            let ok = match m.semihost_cmdline.take() {
                Some(line) if (line.len() as u32) < size => {
                    let mut bytes = line.into_bytes();
                    let n = bytes.len() as u32;
                    bytes.push(0);
                    uc.mem_write(ptr.into(), &bytes).map_err(|_| {
                        bad(format!(
                            "semihosting: command line buffer at {ptr:#010x} unwritable"
                        ))
                    })?;
                    uc.mem_write(u64::from(arg + 4), &n.to_le_bytes())
                        .map_err(|_| bad("semihosting: parameter block unwritable".into()))?;
                    true
                }
                _ => false,
            };
            let r0: u32 = if ok { 0 } else { u32::MAX };
            uc.reg_write(RegisterARM::R0, r0.into())
                .map_err(|e| cpu_err(e, pc))?;
        }
        0x18 | 0x20 => {
            let code = if op == 0x18 {
                i32::from(arg != APPLICATION_EXIT)
            } else {
                let block = read(uc, arg, 8)?;
                if word(&block, 0) == APPLICATION_EXIT {
                    word(&block, 1) as i32
                } else {
                    1
                }
            };
            let m = uc.get_data_mut();
            m.exit_code = Some(code);
            m.stopped = true;
            let _ = uc.emu_stop();
            return Ok(());
        }
        op => {
            return Err(bad(format!(
                "semihosting operation {op:#x} is not modelled"
            )))
        }
    }
    uc.reg_write(RegisterARM::PC, u64::from((pc + 2) | 1))
        .map_err(|e| cpu_err(e, pc))?;
    Ok(())
}

fn intr_hook(uc: &mut Unicorn<'_, Machine>, intno: u32) {
    let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0) as u32;
    if intno == 8 {
        // EXCP_EXCEPTION_EXIT: QEMU raises it for any M-profile fetch at 0xFFFF_FF00 and up,
        // i.e. a branch to an EXC_RETURN value (its bit 0 went to the Thumb state).
        if let Err(e) = exception_return(uc, pc | 1) {
            let m = uc.get_data_mut();
            m.error = Some(e);
            m.stopped = true;
            let _ = uc.emu_stop();
        }
        return;
    }
    if intno == 7 {
        let mut op = [0u8; 2];
        if uc.mem_read(u64::from(pc), &mut op).is_ok() && u16::from_le_bytes(op) == 0xBEAB {
            if let Err(e) = semihosting(uc, pc) {
                let m = uc.get_data_mut();
                m.error = Some(e);
                m.stopped = true;
                let _ = uc.emu_stop();
            }
            return;
        }
    }
    let m = uc.get_data_mut();
    // QEMU's ARM exception numbers: 1 UDEF, 7 BKPT, 17 NOCP, 18 INVSTATE, 22 UNALIGNED.
    let ufsr = match intno {
        1 => Some(1 << 16),
        7 => Some(0),
        17 => Some(1 << 19),
        18 => Some(1 << 17),
        22 => Some(1 << 24),
        _ => None,
    };
    match ufsr {
        Some(bits) => {
            // No debugger and no separate UsageFault handler: it escalates to HardFault.
            m.scs.cfsr |= bits;
            m.scs.hfsr |= 1 << 30;
            m.scs.hardfault_pending = true;
            m.irq_check = true;
        }
        None => {
            m.error = Some(EmuError::Exception {
                what: format!("CPU exception {intno} (SVC, exception exit in handler mode or other) is not modelled"),
                pc,
            });
        }
    }
    m.stopped = true;
    let _ = uc.emu_stop();
}

#[cfg(test)]
mod tests {
    /// Legacy symbols lose their hash; generics and escapes are written out; C names pass.
    #[test]
    fn symbols_demangle_to_their_paths() {
        assert_eq!(
            super::demangle("_ZN8firmware10controller10Controller8progress17h0123456789abcdefE"),
            "firmware::controller::Controller::progress"
        );
        assert_eq!(
            super::demangle("_ZN4core3ptr50drop_in_place$LT$firmware..hw..Shell$LT$u8$GT$$GT$17h0123456789abcdefE"),
            "core::ptr::drop_in_place<firmware::hw::Shell<u8>>"
        );
        assert_eq!(super::demangle("memcpy"), "memcpy");
    }
}
