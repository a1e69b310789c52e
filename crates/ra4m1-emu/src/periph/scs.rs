//! The Cortex-M4 system control space (ARMv7-M Architecture Reference Manual, B3; Cortex-M4
//! TRM; the RA4M1 UM "CPU" chapter lists the configuration: 4 priority bits, 32 IRQs):
//! NVIC (ISER/ICER/ISPR/ICPR/IABR/IPR), SCB (CPUID, ICSR, VTOR, AIRCR, SCR, CCR, SHPR1..3,
//! SHCSR, CFSR, HFSR, CPACR, FPCCR/FPCAR), SysTick (CSR, RVR, CVR, CALIB), DCB.DEMCR and the
//! DWT (CTRL, CYCCNT, LAR). Exception entry and return are in [`crate::cpu`]; this module holds
//! the registers and the pending/active state.

use super::{need, refuse, Why, R};

/// IRQ lines (the RA4M1 NVIC has 32).
pub const IRQS: usize = 32;
/// Exception numbers.
pub mod exc {
    /// NMI (priority −2).
    pub const NMI: u16 = 2;
    /// HardFault.
    pub const HARD_FAULT: u16 = 3;
    /// SysTick.
    pub const SYSTICK: u16 = 15;
    /// First external interrupt (IRQ0 = ICU slot 0).
    pub const IRQ0: u16 = 16;
}

/// The system control space state.
#[derive(Debug, Clone)]
pub struct Scs {
    /// NVIC enable bits.
    pub enabled: u32,
    /// NVIC pending bits.
    pub pending: u32,
    /// Lines held off from outside (pending but not taken: a test's stand-in for a handler
    /// entered late, see `Emulator::hold_irq`).
    pub held: u32,
    /// NVIC priorities (upper nibble significant).
    pub ipr: [u8; IRQS],
    /// SysTick pending (ICSR.PENDSTSET).
    pub systick_pending: bool,
    /// HardFault pending.
    pub hardfault_pending: bool,
    /// NMI pending (from the ICU's NMI sources).
    pub nmi_pending: bool,
    /// Active exceptions, innermost last.
    pub active: Vec<u16>,
    /// VTOR.
    pub vtor: u32,
    aircr_prigroup: u32,
    /// SCR (SLEEPONEXIT 1, SLEEPDEEP 2, SEVONPEND 4).
    pub scr: u32,
    ccr: u32,
    /// SHPR1..3 as 12 bytes (exceptions 4..15).
    pub shpr: [u8; 12],
    shcsr: u32,
    /// CFSR (UFSR:BFSR:MMFSR).
    pub cfsr: u32,
    /// HFSR.
    pub hfsr: u32,
    cpacr: u32,
    fpccr: u32,
    fpcar: u32,
    demcr: u32,
    dwt_ctrl: u32,
    /// CYCCNT = `awake cycles - dwt_base` (mod 2^32) while enabled.
    dwt_base: u64,
    dwt_frozen: u32,
    /// SysTick CSR (ENABLE 0, TICKINT 1, CLKSOURCE 2, COUNTFLAG 16).
    pub syst_csr: u32,
    /// SysTick RVR.
    pub syst_rvr: u32,
    /// When SysTick next reaches 0 (tick), while enabled.
    pub syst_next: Option<u64>,
    /// A software reset was requested (AIRCR.SYSRESETREQ).
    pub reset_requested: bool,
}

impl Scs {
    /// Reset state; `vtor` as the bootloader leaves it.
    pub fn new(vtor: u32) -> Self {
        Self {
            enabled: 0,
            pending: 0,
            held: 0,
            ipr: [0; IRQS],
            systick_pending: false,
            hardfault_pending: false,
            nmi_pending: false,
            active: Vec::new(),
            vtor,
            aircr_prigroup: 0,
            scr: 0,
            ccr: 0x200,
            shpr: [0; 12],
            shcsr: 0,
            cfsr: 0,
            hfsr: 0,
            cpacr: 0,
            fpccr: 0xC000_0000,
            fpcar: 0,
            demcr: 0,
            dwt_ctrl: 0x4000_0000,
            dwt_base: 0,
            dwt_frozen: 0,
            syst_csr: 0,
            syst_rvr: 0,
            syst_next: None,
            reset_requested: false,
        }
    }

    /// Priority of exception `e` (lower is more urgent; HardFault is −1).
    pub fn priority(&self, e: u16) -> i16 {
        match e {
            exc::NMI => -2,
            exc::HARD_FAULT => -1,
            4..=15 => i16::from(self.shpr[usize::from(e) - 4] & 0xF0),
            _ => i16::from(self.ipr[usize::from(e - exc::IRQ0)] & 0xF0),
        }
    }

    /// The most urgent pending exception that is enabled (ignoring masks), and its priority.
    pub fn best_pending(&self) -> Option<(u16, i16)> {
        let mut best: Option<(u16, i16)> = None;
        let mut consider = |e: u16, p: i16| {
            if best.is_none_or(|(_, bp)| p < bp) {
                best = Some((e, p));
            }
        };
        if self.nmi_pending {
            consider(exc::NMI, -2);
        }
        if self.hardfault_pending {
            consider(exc::HARD_FAULT, -1);
        }
        if self.systick_pending {
            consider(exc::SYSTICK, self.priority(exc::SYSTICK));
        }
        let mut lines = self.pending & self.enabled & !self.held;
        while lines != 0 {
            let n = lines.trailing_zeros() as u16;
            lines &= lines - 1;
            consider(exc::IRQ0 + n, self.priority(exc::IRQ0 + n));
        }
        best
    }

    /// The running priority from the active exceptions (256: thread mode, none active).
    pub fn running_priority(&self) -> i16 {
        self.active
            .iter()
            .map(|&e| self.priority(e))
            .min()
            .unwrap_or(256)
    }

    /// CYCCNT given the awake cycle count.
    pub fn cyccnt(&self, awake: u64) -> u32 {
        if self.dwt_ctrl & 1 != 0 {
            (awake.wrapping_sub(self.dwt_base)) as u32
        } else {
            self.dwt_frozen
        }
    }

    /// ICSR.
    fn icsr(&self) -> u32 {
        let active = u32::from(self.active.last().copied().unwrap_or(0));
        let pending = self.best_pending().map_or(0, |(e, _)| u32::from(e));
        let isr_pending = u32::from(self.pending & self.enabled != 0) << 22;
        let rettobase = u32::from(self.active.len() == 1) << 11;
        let pendst = u32::from(self.systick_pending) << 26;
        active | rettobase | (pending << 12) | isr_pending | pendst
    }

    /// A read of the SCS page 0xE000_E000 at `off`; `syst_cvr` is the SysTick current value.
    pub fn read(&mut self, off: u32, size: u32, syst_cvr: u32) -> R<u32> {
        let word = |size| need(size, 4, "an SCS register");
        Ok(match off {
            0x004 => {
                word(size)?;
                0 // ICTR: 32 interrupt lines
            }
            0x010 => {
                word(size)?;
                let v = self.syst_csr;
                self.syst_csr &= !(1 << 16); // COUNTFLAG clears on read
                v
            }
            0x014 => self.syst_rvr,
            0x018 => syst_cvr,
            0x01C => 0x4000_0000, // CALIB: NOREF, no TENMS
            0x100 | 0x180 => self.enabled,
            0x104..=0x11C | 0x184..=0x19C => 0,
            0x200 | 0x280 => self.pending,
            0x204..=0x21C | 0x284..=0x29C => 0,
            0x300 => self
                .active
                .iter()
                .filter(|&&e| e >= exc::IRQ0)
                .fold(0, |a, &e| a | 1 << (e - exc::IRQ0)),
            0x400..=0x41F => {
                let i = (off - 0x400) as usize;
                let mut v = 0u32;
                for k in 0..size as usize {
                    v |= u32::from(self.ipr[i + k]) << (8 * k);
                }
                v
            }
            0xD00 => 0x410F_C241, // CPUID: Cortex-M4 r0p1
            0xD04 => self.icsr(),
            0xD08 => self.vtor,
            0xD0C => 0xFA05_0000 | (self.aircr_prigroup << 8),
            0xD10 => self.scr,
            0xD14 => self.ccr,
            0xD18..=0xD23 => {
                let i = (off - 0xD18) as usize;
                let mut v = 0u32;
                for k in 0..size as usize {
                    v |= u32::from(self.shpr[i + k]) << (8 * k);
                }
                v
            }
            0xD24 => self.shcsr,
            0xD28 => self.cfsr,
            0xD2C => self.hfsr,
            0xD88 => self.cpacr,
            0xDFC => self.demcr,
            0xF34 => self.fpccr,
            0xF38 => self.fpcar,
            _ => return Err(Why::Unmodelled),
        })
    }

    /// A write of the SCS page at `off`. `now_cycles`: ICLK cycles now (SysTick reload);
    /// returns whether SysTick was (re)started.
    pub fn write(&mut self, off: u32, size: u32, v: u32) -> R<SystickChange> {
        let mut change = SystickChange::None;
        match off {
            0x010 => {
                need(size, 4, "SYST_CSR")?;
                if v & 1 != 0 && v & 4 == 0 {
                    return refuse(
                        "SYST_CSR.CLKSOURCE = 0: the RA4M1 has no SysTick reference clock",
                    );
                }
                let was = self.syst_csr & 1;
                self.syst_csr = (self.syst_csr & (1 << 16)) | (v & 7);
                if was == 0 && v & 1 != 0 {
                    change = SystickChange::Start;
                } else if v & 1 == 0 {
                    self.syst_next = None;
                }
            }
            0x014 => {
                need(size, 4, "SYST_RVR")?;
                self.syst_rvr = v & 0x00FF_FFFF;
            }
            0x018 => {
                need(size, 4, "SYST_CVR")?;
                // Any write clears the counter and COUNTFLAG; it reloads on the next clock.
                self.syst_csr &= !(1 << 16);
                change = SystickChange::Clear;
            }
            0x100 => self.enabled |= v,
            0x180 => self.enabled &= !v,
            0x200 => self.pending |= v,
            0x280 => self.pending &= !v,
            0x104..=0x11C | 0x184..=0x19C | 0x204..=0x21C | 0x284..=0x29C => {
                if v != 0 {
                    return refuse("NVIC bit for an interrupt above IRQ31 (the RA4M1 has 32)");
                }
            }
            0x400..=0x41F => {
                let i = (off - 0x400) as usize;
                for k in 0..size as usize {
                    self.ipr[i + k] = (v >> (8 * k)) as u8 & 0xF0;
                }
            }
            0xD04 => {
                if v & (1 << 26) != 0 {
                    self.systick_pending = true;
                }
                if v & (1 << 25) != 0 {
                    self.systick_pending = false;
                }
                if v & (1 << 31 | 1 << 28 | 1 << 27) != 0 {
                    return refuse("ICSR: NMI and PendSV are not modelled");
                }
            }
            0xD08 => {
                need(size, 4, "VTOR")?;
                self.vtor = v & 0xFFFF_FF80;
            }
            0xD0C => {
                need(size, 4, "AIRCR")?;
                if v >> 16 != 0x05FA {
                    return refuse(format!("AIRCR written without VECTKEY 0x05FA ({v:#010x})"));
                }
                self.aircr_prigroup = (v >> 8) & 7;
                if v & 4 != 0 {
                    self.reset_requested = true;
                }
            }
            0xD10 => {
                if v & 2 != 0 {
                    return refuse("SCR.SLEEPONEXIT is not modelled");
                }
                self.scr = v & 0x16;
            }
            0xD14 => self.ccr = v | 0x200,
            0xD18..=0xD23 => {
                let i = (off - 0xD18) as usize;
                for k in 0..size as usize {
                    self.shpr[i + k] = (v >> (8 * k)) as u8 & 0xF0;
                }
            }
            0xD24 => {
                if v & 0x7_0000 != 0 {
                    return refuse(
                        "SHCSR: separate MemManage/BusFault/UsageFault handlers are not modelled",
                    );
                }
                self.shcsr = v;
            }
            0xD28 => self.cfsr &= !v,
            0xD2C => self.hfsr &= !v,
            0xD88 => self.cpacr = v,
            0xDFC => self.demcr = v,
            0xF34 => self.fpccr = v,
            0xF38 => self.fpcar = v,
            _ => return Err(Why::Unmodelled),
        }
        Ok(change)
    }

    /// A read of the DWT page 0xE000_1000 at `off`.
    pub fn dwt_read(&self, off: u32, size: u32, awake: u64) -> R<u32> {
        need(size, 4, "a DWT register")?;
        match off {
            0x000 => Ok(self.dwt_ctrl),
            0x004 => Ok(self.cyccnt(awake)),
            0xFB4 => Ok(0), // LSR: unlocked
            _ => Err(Why::Unmodelled),
        }
    }

    /// A write of the DWT page at `off`.
    pub fn dwt_write(&mut self, off: u32, size: u32, v: u32, awake: u64) -> R<()> {
        need(size, 4, "a DWT register")?;
        match off {
            0x000 => {
                if v & 1 != 0 && self.demcr & (1 << 24) == 0 {
                    return refuse("DWT_CTRL.CYCCNTENA set with DEMCR.TRCENA = 0");
                }
                let cnt = self.cyccnt(awake);
                if v & 1 != 0 && self.dwt_ctrl & 1 == 0 {
                    self.dwt_base = awake.wrapping_sub(u64::from(cnt));
                } else if v & 1 == 0 {
                    self.dwt_frozen = cnt;
                }
                self.dwt_ctrl = 0x4000_0000 | (v & 1);
            }
            0x004 => {
                self.dwt_base = awake.wrapping_sub(u64::from(v));
                self.dwt_frozen = v;
            }
            0xFB0 => {} // LAR: any key accepted (the M4 has no lock)
            _ => return Err(Why::Unmodelled),
        }
        Ok(())
    }
}

/// What a SysTick register write did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SystickChange {
    /// Nothing.
    None,
    /// ENABLE went 0 → 1.
    Start,
    /// CVR written (cleared).
    Clear,
}
