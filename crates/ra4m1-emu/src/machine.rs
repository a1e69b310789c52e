//! The emulated chip's state outside the CPU core, and the bus that routes every peripheral
//! access to its model.

use std::collections::HashMap;

use crate::clock::ticks_per;
use crate::cpu::BlockCost;
use crate::periph::{self, adc::Adc, flash::Flash, gpt::Gpt, icu::Icu, port::Port, sci::Sci};
use crate::periph::{scs::Scs, system::ResetKind, system::System, wdt::Wdt, Clocks, Why};
use crate::tm1637::Tm1637;
use crate::EmuError;

/// A memory-mapped page and the model behind it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Page {
    /// ICU.
    Icu,
    /// SYSTEM.
    System,
    /// PORT/PFS/PMISC.
    Port,
    /// WDT and IWDT.
    Wdt,
    /// MSTPCRB..D.
    Mstp,
    /// ADC140.
    Adc,
    /// SCI0..9 (SCI9 modelled).
    Sci,
    /// GPT (GPT165 and GPT167 modelled).
    Gpt,
    /// Data flash read window (two pages).
    DataFlash,
    /// Flash interface registers.
    Faci,
    /// FENTRYR page.
    FaciEntry,
    /// DWT.
    Dwt,
    /// System control space (NVIC, SCB, SysTick, DCB).
    Scs,
    /// DBG: DBGSTR, DBGSTOPCR (no debugger is attached to the emulated chip).
    Dbg,
    /// MPU page: the CPU stack pointer monitor (SPMON at 0xD00).
    Mpu,
}

/// The bus a page is reached over (RA4M1 User's Manual R01UH0887, "Buses", Table 13.1 "Bus
/// specifications" and the internal peripheral buses' list, with the address map of
/// "Address Space"): what clock its bus bridge runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bus {
    /// Internal peripheral bus 1 (ICU, SYSTEM, MPU, DBG at 0x4000_0000..0x4001_FFFF) and the
    /// Cortex-M4's private peripheral bus (NVIC, SysTick, DWT): synchronous with ICLK, no
    /// bridge.
    Iclk,
    /// Internal peripheral bus 5 (SCI, GPT at 0x4007_0000..0x4007_FFFF): PCLKA.
    Pclka,
    /// Internal peripheral bus 3 (I/O ports, WDT, MSTP, ADC14 at 0x4004_0000..0x4005_FFFF):
    /// PCLKB.
    Pclkb,
    /// Internal peripheral bus 9 (the flash interface, FACI, and the data flash's read window):
    /// FCLK.
    Fclk,
}

impl Page {
    /// The bus this page hangs on.
    pub fn bus(self) -> Bus {
        match self {
            Page::Icu | Page::System | Page::Mpu | Page::Dbg | Page::Dwt | Page::Scs => Bus::Iclk,
            Page::Sci | Page::Gpt => Bus::Pclka,
            Page::Port | Page::Wdt | Page::Mstp | Page::Adc => Bus::Pclkb,
            Page::DataFlash | Page::Faci | Page::FaciEntry => Bus::Fclk,
        }
    }
}

/// Peripheral-bus cycles of one register access behind a bus bridge, in the bridge's clock
/// (the internal peripheral bus's own bus cycles; RA4M1 UM, "I/O Registers" appendix, "Access
/// Cycles": the access cycles are the internal peripheral bus's bus cycles plus the divided
/// clock synchronization cycles). One figure for every page: the appendix's per-module rows
/// were not at hand when this was written, so a module whose row says more is undercounted.
pub const BRIDGE_BUS_CYCLES: u64 = 2;

/// Extra ICLK cycles one CPU access to a register behind a bridge clocked at `pclk` costs, over
/// the 2 cycles (address and data phase) the Cortex-M4 timing of a load or store already
/// counts. RA4M1 UM, "I/O Registers" appendix, "Access Cycles": the access takes the internal
/// peripheral bus's bus cycles ([`BRIDGE_BUS_CYCLES`] of the bridge's clock) plus the divided
/// clock synchronization cycles, which are a constant 0 when ICLK = PCLK and up to one cycle of
/// PCLK when ICLK > PCLK (taken here at that maximum: the model is an upper bound); when ICLK <
/// PCLK the access ends at the next ICLK edge. So, with ICLK = PCLK: 2 ICLK, 1 more than the
/// core counts; ICLK = 2 × PCLK: 3 PCLK = 6 ICLK, 5 more; ICLK = 4 × PCLK: 12 ICLK, 11 more.
/// Writes are charged as reads (the core's write buffer may hide a lone store's wait on the
/// chip: an upper bound again).
pub fn bridge_wait_cycles(iclk: u32, pclk: u32) -> u64 {
    let (iclk, pclk) = (u64::from(iclk.max(1)), u64::from(pclk.max(1)));
    let sync = u64::from(iclk > pclk);
    ((BRIDGE_BUS_CYCLES + sync) * iclk)
        .div_ceil(pclk)
        .saturating_sub(1)
}

/// The GTIOC functions of the pins the GPT model reads back, from the RA4M1's pin function
/// table: (port, pin, GPT channel, output B) — P304 GTIOC7A, P303 GTIOC7B, P101 GTIOC5A. A
/// read of PIDR (PCNTR2 or PmnPFS) of one of them in its GPT function sees the timer's waveform
/// at that instant; any other pin in its GPT function reads its port level.
pub const GTIOC_PINS: [(usize, usize, usize, bool); 3] =
    [(3, 4, 7, false), (3, 3, 7, true), (1, 1, 5, false)];

/// Every mapped page: (base, size, model).
pub const PAGES: &[(u32, u32, Page)] = &[
    (periph::icu::BASE, 0x1000, Page::Icu),
    (periph::system::BASE, 0x1000, Page::System),
    (periph::port::BASE, 0x1000, Page::Port),
    (0x4004_4000, 0x1000, Page::Wdt),
    (periph::system::MSTP_BASE, 0x1000, Page::Mstp),
    (periph::adc::BASE, 0x1000, Page::Adc),
    (0x4007_0000, 0x1000, Page::Sci),
    (periph::gpt::BASE, 0x1000, Page::Gpt),
    (periph::flash::DF_BASE, 0x2000, Page::DataFlash),
    (periph::flash::BASE, 0x1000, Page::Faci),
    (periph::flash::FENTRY_PAGE, 0x1000, Page::FaciEntry),
    (0xE000_1000, 0x1000, Page::Dwt),
    (0xE000_E000, 0x1000, Page::Scs),
    (0x4001_B000, 0x1000, Page::Dbg),
    (0x4000_0000, 0x1000, Page::Mpu),
];

/// How the board around the chip is wired for the emulator's parts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wiring {
    /// TM1637 CLK and DIO pins, `(port, pin)`.
    pub tm1637: Option<((usize, usize), (usize, usize))>,
}

/// Where the cycles of a loop pass went: cycles per block start address.
#[derive(Debug, Clone, Default)]
pub struct PassProfile {
    /// The stretch running now.
    pub current: HashMap<u32, u64>,
    /// The longest stretch so far.
    pub longest: HashMap<u32, u64>,
    /// Of the stretch running now, what ran before its second SysTick (when it took one):
    /// the pass that overran the tick, up to the tick.
    pub current_to_overrun: Option<HashMap<u32, u64>>,
    /// The same for the longest stretch.
    pub longest_to_overrun: Option<HashMap<u32, u64>>,
}

/// What one awake stretch (a wake-up to the next `WFI`) held. A tick-driven loop
/// (`while now == last { wfi }`) runs one pass per millisecond it sees, so the SysTick
/// exceptions a stretch took tell one pass from passes back to back: a stretch woken by SysTick
/// that takes another one was still running when the next millisecond began — its first pass
/// overran the tick (it had run `ticks_at[1]` cycles by then), and the loop ran the next pass
/// without sleeping. (A stretch woken by another interrupt whose SysTick came before the loop
/// looked at the time holds one pass with its first tick at a small offset.)
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Stretch {
    /// Awake cycles, wake-up to `WFI` (interrupts and bus waits included).
    pub cycles: u64,
    /// Awake cycles after the wake-up at which each SysTick exception was entered (0 for the
    /// one that woke the core).
    pub ticks_at: Vec<u64>,
    /// Cycles spent in exception handlers (handler mode), of [`Stretch::cycles`].
    pub handler_cycles: u64,
    /// Exceptions entered, SysTick included.
    pub exceptions: u32,
    /// When the stretch ended, ticks of virtual time.
    pub end: u64,
}

impl Stretch {
    /// Whether the stretch holds loop passes back to back: it took a second SysTick, so the
    /// pass running then overran the tick and the loop saw a new millisecond without sleeping.
    pub fn back_to_back(&self) -> bool {
        self.ticks_at.len() >= 2
    }

    /// Cycles after the wake-up at which the next millisecond began while the stretch was
    /// still awake (the second SysTick's entry): how long the first pass had run by then.
    pub fn overran_at(&self) -> Option<u64> {
        self.ticks_at.get(1).copied()
    }
}

/// The chip outside the CPU core.
#[derive(Debug)]
pub struct Machine {
    /// Master time, ticks.
    pub now: u64,
    /// ICLK cycles executed while awake.
    pub awake_cycles: u64,
    /// Instructions executed.
    pub instructions: u64,
    /// The CPU stops at this tick (next event or the end of the run).
    pub deadline: u64,
    /// The CPU was stopped by us (set before `emu_stop`).
    pub stopped: bool,
    /// Something may be deliverable: check PRIMASK at the next block.
    pub irq_check: bool,
    /// The error that stopped the CPU.
    pub error: Option<EmuError>,
    /// The start address of the block running now (for error messages).
    pub block_pc: u32,
    /// End of the last block (for the taken-branch penalty).
    pub last_block_end: u32,
    /// Per-block cost cache.
    pub blocks: HashMap<(u32, u32), BlockCost>,
    /// The code flash image (for decoding).
    pub code: Vec<u8>,
    /// Asleep in WFI.
    pub asleep: bool,
    /// Clocks from the system registers.
    pub clocks: Clocks,
    /// Flash wait states.
    pub wait_states: u32,
    /// SYSTEM + MSTP.
    pub sys: System,
    /// I/O ports.
    pub port: Port,
    /// GPT162..167 (index 2..=7 used; 5 and 7 on this board).
    pub gpt: [Gpt; 8],
    /// ADC140.
    pub adc: Adc,
    /// SCI9.
    pub sci: Sci,
    /// ICU.
    pub icu: Icu,
    /// NVIC/SCB/SysTick/DWT.
    pub scs: Scs,
    /// WDT.
    pub wdt: Wdt,
    /// The stack pointer monitor.
    pub spmon: periph::spmon::Spmon,
    /// Data flash.
    pub flash: Flash,
    /// The display part.
    pub tm1637: Tm1637,
    /// Its wiring.
    pub wiring: Wiring,
    /// Events raised by models, to route through the ICU.
    pub events: Vec<u16>,
    /// Supply voltage, mV.
    pub vcc_mv: u32,
    /// A reset the hardware decided (WDT underflow, LVD, AIRCR).
    pub reset_due: Option<ResetKind>,
    /// Held in reset by voltage monitor 1 (see [`periph::system`]).
    pub held_in_reset: bool,
    /// When voltage monitor 1 releases the reset (ticks), once that is decided: at the
    /// assertion with LVD1CR0.RN = 1, when VCC is back above Vdet1 with RN = 0.
    pub lvd_release_at: Option<u64>,
    /// NVIC lines held off (not delivered though pending) and until when, ticks
    /// ([`crate::Emulator::hold_irq`]).
    pub irq_hold: (u32, u64),
    /// Parked in the bootloader ([`crate::Emulator::park_in_bootloader`]): the application
    /// does not run until the next reset.
    pub parked: bool,
    /// A debug probe is attached: the chip is in on-chip-debug mode, where DBGSTOPCR masks
    /// the watchdogs' resets (DBGSTOP_WDT, DBGSTOP_IWDT; reset value 1 = masked).
    pub probe: bool,
    /// Count of loop passes (wake-ups) and the longest awake stretch, cycles.
    pub wakes: u64,
    /// Awake cycles at the last wake-up.
    pub wake_start_cycles: u64,
    /// Longest awake stretch, cycles.
    pub max_awake_cycles: u64,
    /// When the longest awake stretch ended, ticks.
    pub max_awake_at: u64,
    /// Cycles per executed block of the current and of the longest awake stretch, when
    /// profiling ([`crate::Emulator::profile_passes`]).
    pub profile: Option<PassProfile>,
    /// What the awake stretch running now holds (SysTick entries, handler cycles).
    pub stretch: Stretch,
    /// The same for the longest awake stretch so far.
    pub longest_stretch: Stretch,
    /// Bytes the program wrote through semihosting (SYS_WRITEC/WRITE0/WRITE).
    pub semihost_out: Vec<u8>,
    /// The exit code the program gave through semihosting (SYS_EXIT/SYS_EXIT_EXTENDED).
    pub exit_code: Option<i32>,
    /// The command line SYS_GET_CMDLINE answers once (then it fails, as after a reset a test
    /// runner has no second command for the same test).
    pub semihost_cmdline: Option<String>,
    /// SYS_GET_CMDLINE calls so far.
    pub cmdline_requests: u32,
    /// DBGSTOPCR (reset value 3: WDT and IWDT resets masked in on-chip-debug mode, which the
    /// emulated chip is in when [`Machine::probe`] is set).
    pub dbgstopcr: u32,
}

fn mstp_check(sys: &System, x: usize, bit: u32, name: &str) -> Result<(), Why> {
    if sys.stopped(x, bit) {
        Err(Why::Refused(format!(
            "{name} accessed in module-stop (MSTPCR{}.MSTP{}{bit} = 1)",
            ["A", "B", "C", "D"][x],
            ["A", "B", "C", "D"][x]
        )))
    } else {
        Ok(())
    }
}

impl Machine {
    /// The ICLK cycles an access to `page` adds for its bus bridge ([`bridge_wait_cycles`] at
    /// the clocks the system registers set now; 0 for a page on ICLK's own buses).
    pub fn bus_wait_cycles(&self, page: Page) -> u64 {
        let c = &self.clocks;
        match page.bus() {
            Bus::Iclk => 0,
            Bus::Pclka => bridge_wait_cycles(c.iclk, c.pclka),
            Bus::Pclkb => bridge_wait_cycles(c.iclk, c.pclkb),
            Bus::Fclk => bridge_wait_cycles(c.iclk, c.fclk),
        }
    }

    /// Charges the bus wait of one access to `page` to the CPU's time (and to the pass
    /// profile, on the block running now).
    pub fn charge_bus_wait(&mut self, page: Page) {
        let w = self.bus_wait_cycles(page);
        if w == 0 {
            return;
        }
        self.awake_cycles += w;
        if !self.scs.active.is_empty() {
            self.stretch.handler_cycles += w;
        }
        if let Some(p) = self.profile.as_mut() {
            *p.current.entry(self.block_pc).or_default() += w;
        }
        self.now += w * ticks_per(self.clocks.iclk);
    }

    /// Routes a read.
    pub fn read(&mut self, page: Page, base: u32, off: u32, size: u32) -> Result<u32, Why> {
        let now = self.now;
        let v = match page {
            Page::Icu => self.icu.read(off, size),
            Page::System => self.sys.read(off, size),
            Page::Port => {
                self.sync_gpt_pins();
                self.port.read(off, size)
            }
            Page::Wdt => match off {
                0x200..=0x2FF => self.wdt.read(off - 0x200, size, self.clocks.pclkb),
                0x400 => Ok(0xFF),
                0x404 => Ok(0),
                _ => Err(Why::Unmodelled),
            },
            Page::Mstp => self.sys.mstp_read(off, size),
            Page::Adc => {
                mstp_check(&self.sys, 3, 16, "ADC140")?;
                self.adc.read(off, size, now)
            }
            Page::Sci => match off {
                0x120..=0x13F => {
                    mstp_check(&self.sys, 1, 22, "SCI9")?;
                    self.sync_sci();
                    self.sci.read(off - 0x120, size)
                }
                _ => Err(Why::Unmodelled),
            },
            Page::Gpt => {
                let ch = (off / 0x100) as usize;
                if (2..=7).contains(&ch) {
                    mstp_check(&self.sys, 3, 6, "GPT16x")?;
                    let pclkd = self.clocks.pclkd;
                    self.gpt[ch].read(off % 0x100, size, now, pclkd)
                } else {
                    Err(Why::Unmodelled)
                }
            }
            Page::DataFlash => {
                self.flash.readable().map_err(Why::Refused)?;
                let o = (base - periph::flash::DF_BASE + off) as usize;
                let mut v = 0u32;
                for k in 0..size as usize {
                    v |= u32::from(self.flash.mem[o + k]) << (8 * k);
                }
                Ok(v)
            }
            Page::Faci => self.flash.read(base, off, size, now),
            Page::FaciEntry => self.flash.read(base, off, size, now),
            Page::Dwt => self.scs.dwt_read(off, size, self.awake_cycles),
            Page::Mpu => match off {
                0xD00..=0xD0F => self.spmon.read(off - 0xD00, size),
                _ => Err(Why::Unmodelled),
            },
            Page::Dbg => match (off, size) {
                (0x00, 4) => Ok(0),
                (0x10, 4) => Ok(self.dbgstopcr),
                _ => Err(Why::Unmodelled),
            },
            // DHCSR: C_DEBUGEN (bit 0) reads 1 while a probe has halting debug enabled
            // (cortex-m's `DCB::is_debugger_attached` reads its low byte).
            Page::Scs if off == 0xDF0 => Ok(u32::from(self.probe)),
            Page::Scs => {
                let cvr = self.systick_cvr();
                self.scs.read(off, size, cvr)
            }
        }?;
        Ok(v)
    }

    /// Routes a write.
    pub fn write(&mut self, page: Page, base: u32, off: u32, size: u32, v: u32) -> Result<(), Why> {
        let now = self.now;
        match page {
            Page::Icu => {
                self.icu.write(off, size, v)?;
                self.irq_check = true;
            }
            Page::System => {
                self.sys.write(off, size, v)?;
                self.clocks = self.sys.clocks();
                self.wait_states = self.sys.wait_states();
            }
            Page::Port => {
                self.port.write(off, size, v)?;
                self.update_parts();
            }
            Page::Wdt => match off {
                0x200..=0x2FF => {
                    self.wdt.advance(now, true);
                    self.wdt
                        .write(off - 0x200, size, v, now, self.clocks.pclkb)?;
                }
                0x400 => {} // IWDTRR: the IWDT is stopped, a refresh does nothing
                _ => return Err(Why::Unmodelled),
            },
            Page::Mstp => self.sys.mstp_write(off, size, v)?,
            Page::Adc => {
                mstp_check(&self.sys, 3, 16, "ADC140")?;
                self.adc.write(off, size, v, now, self.clocks.pclkc)?;
            }
            Page::Sci => match off {
                0x120..=0x13F => {
                    mstp_check(&self.sys, 1, 22, "SCI9")?;
                    self.sync_sci();
                    let pclka = self.clocks.pclka;
                    self.sci
                        .write(off - 0x120, size, v, now, pclka, &mut self.events)?;
                    self.route_events();
                }
                _ => return Err(Why::Unmodelled),
            },
            Page::Gpt => {
                let ch = (off / 0x100) as usize;
                if (2..=7).contains(&ch) {
                    mstp_check(&self.sys, 3, 6, "GPT16x")?;
                    let pclkd = self.clocks.pclkd;
                    self.gpt[ch].write(off % 0x100, size, v, now, pclkd)?;
                } else {
                    return Err(Why::Unmodelled);
                }
            }
            Page::DataFlash => {
                return Err(Why::Refused(
                    "data flash written directly (use the flash sequencer)".into(),
                ))
            }
            Page::Faci | Page::FaciEntry => self.flash.write(base, off, size, v, now)?,
            Page::Dwt => self.scs.dwt_write(off, size, v, self.awake_cycles)?,
            Page::Mpu => match off {
                0xD00..=0xD0F => self.spmon.write(off - 0xD00, size, v)?,
                _ => return Err(Why::Unmodelled),
            },
            Page::Dbg => match (off, size) {
                (0x10, 4) => self.dbgstopcr = v & 0x0307_0003,
                _ => return Err(Why::Unmodelled),
            },
            Page::Scs => {
                use periph::scs::SystickChange;
                let change = self.scs.write(off, size, v)?;
                let cycle = ticks_per(self.clocks.iclk);
                match change {
                    SystickChange::Start | SystickChange::Clear if self.scs.syst_csr & 1 != 0 => {
                        // Counter cleared (or starting from 0): reloads on the next clock and
                        // reaches 0 after RVR more.
                        self.scs.syst_next = Some(now + cycle * (u64::from(self.scs.syst_rvr) + 1));
                    }
                    _ => {}
                }
                if self.scs.reset_requested {
                    self.reset_due = Some(ResetKind::Software);
                }
                self.irq_check = true;
            }
        }
        Ok(())
    }

    /// Puts the timers' output levels on their GTIOC pins for a read of the port.
    fn sync_gpt_pins(&mut self) {
        let (now, pclkd) = (self.now, self.clocks.pclkd);
        for (port, pin, ch, b) in GTIOC_PINS {
            let level = match self.port.drive_of(port, pin) {
                periph::port::PinDrive::Peripheral { psel: 0b00011 } => {
                    self.gpt[ch].sync(now, pclkd);
                    self.gpt[ch].level_at(b, now, pclkd)
                }
                _ => None,
            };
            self.port.set_peripheral_level(port, pin, level);
        }
    }

    /// SysTick's current value.
    fn systick_cvr(&self) -> u32 {
        match self.scs.syst_next {
            Some(t) => {
                let cycle = ticks_per(self.clocks.iclk);
                (t.saturating_sub(self.now) / cycle).min(u64::from(self.scs.syst_rvr)) as u32
            }
            None => 0,
        }
    }

    fn sync_sci(&mut self) {
        let pclka = self.clocks.pclka;
        self.sci.advance(self.now, pclka, &mut self.events);
        self.route_events();
    }

    /// Routes raised events through the ICU into the NVIC.
    pub fn route_events(&mut self) {
        for e in std::mem::take(&mut self.events) {
            let lines = self.icu.raise(e);
            if lines != 0 {
                self.scs.pending |= lines;
                self.irq_check = true;
            }
        }
    }

    /// Re-evaluates the parts wired to pins (the TM1637) after a pin change.
    pub fn update_parts(&mut self) {
        if !std::mem::take(&mut self.port.changed) {
            return;
        }
        if let Some(((cp, cn), (dp, dn))) = self.wiring.tm1637 {
            use periph::port::PinDrive;
            let clk = self.port.level(cp, cn);
            let dio = match self.port.drive_of(dp, dn) {
                PinDrive::Low => false,
                PinDrive::High => true,
                // Released: the module's pull-up (and the MCU's) hold it high.
                _ => true,
            };
            self.tm1637.update(clk, dio);
            self.port.drive(dp, dn, self.tm1637.acking.then_some(false));
        }
    }

    /// The next tick at which a model has something to do.
    pub fn next_event(&self) -> u64 {
        let mut t = u64::MAX;
        for e in [
            self.scs.syst_next.filter(|_| self.scs.syst_csr & 1 != 0),
            self.sci.next_event(),
            self.adc.done_at,
            self.flash.next_event(),
            (self.irq_hold.0 != 0).then_some(self.irq_hold.1),
            if self.asleep && self.wdt.stops_in_sleep() {
                None
            } else {
                self.wdt.deadline()
            },
        ]
        .into_iter()
        .flatten()
        {
            t = t.min(e);
        }
        t
    }

    /// Runs every model's due work up to `now` (the CPU is between blocks).
    pub fn advance(&mut self) {
        let now = self.now;
        let counting = !(self.asleep && self.wdt.stops_in_sleep());
        if self.wdt.advance(now, counting) {
            if self.probe && self.dbgstopcr & 0b10 != 0 {
                // On-chip-debug mode with DBGSTOP_WDT = 1: the underflow's reset is masked;
                // the counter stays at 0 until the next refresh.
                self.wdt.masked_underflow();
            } else {
                self.reset_due = Some(ResetKind::Watchdog);
            }
        }
        if let Some(mut t) = self.scs.syst_next {
            if self.scs.syst_csr & 1 != 0 {
                let period = ticks_per(self.clocks.iclk) * (u64::from(self.scs.syst_rvr) + 1);
                while t <= now {
                    self.scs.syst_csr |= 1 << 16;
                    if self.scs.syst_csr & 2 != 0 {
                        self.scs.systick_pending = true;
                        self.irq_check = true;
                    }
                    t += period.max(1);
                }
                self.scs.syst_next = Some(t);
            }
        }
        self.sync_sci();
        self.adc.advance(now);
        self.flash.advance(now);
        if self.sys.lvd1_compare(self.vcc_mv) {
            self.reset_due = Some(ResetKind::BrownOut);
        }
        if self.irq_hold.0 != 0 && now >= self.irq_hold.1 {
            self.scs.held = 0;
            self.irq_hold = (0, 0);
            self.irq_check = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bridge_waits_follow_the_iclk_to_pclk_ratio() {
        // ICLK = PCLK (the board's PCLKA): 2 PCLKA, 1 ICLK over the core's 2.
        assert_eq!(bridge_wait_cycles(48_000_000, 48_000_000), 1);
        // ICLK = 2 × PCLK (the board's PCLKB, FCLK): 2 + 1 synchronization = 3 PCLKB = 6 ICLK.
        assert_eq!(bridge_wait_cycles(48_000_000, 24_000_000), 5);
        // ICLK = 4 × PCLK: 3 PCLK = 12 ICLK.
        assert_eq!(bridge_wait_cycles(48_000_000, 12_000_000), 11);
        // ICLK < PCLK (PCLKD-style 64 MHz bridge under a 32 MHz CPU): 2 PCLK end within 1 ICLK.
        assert_eq!(bridge_wait_cycles(32_000_000, 64_000_000), 0);
        assert_eq!(Page::Port.bus(), Bus::Pclkb);
        assert_eq!(Page::Sci.bus(), Bus::Pclka);
        assert_eq!(Page::Icu.bus(), Bus::Iclk);
    }
}
