//! The host link on SCI9 (TXD9 = P109, RXD9 = P110): 115 200 baud, 8N1, embedded-io.
//!
//! SCI9 has no FIFO, so at 115 200 baud a byte arrives every 87 µs: reception runs from the
//! receive-full interrupt (ICU slot IEL0 ← event SCI9_RXI 0xA8) into a lock-free ring that the
//! main loop drains; receive errors (IEL1 ← SCI9_ERI 0xAB) are cleared and counted. A full ring
//! drops the new byte (the protocol's CRC then drops the frame and the host retries).
//!
//! Transmission runs from interrupts too, at the full line rate: `write` copies into a
//! transmit ring and, when the transmitter is idle, starts it (SCR.TIE, then the first byte to
//! TDR); each transmit-data-empty interrupt (IEL2 ← SCI9_TXI 0xA9) moves the next byte to TDR;
//! when the ring runs dry the handler switches to the transmit-end interrupt (IEL3 ← SCI9_TEI
//! 0xAA), which marks the line idle (or restarts it if bytes came in meanwhile). `write` never
//! waits for the line.

use core::cell::UnsafeCell;
use core::convert::Infallible;
use core::sync::atomic::{AtomicBool, AtomicU16, AtomicU32, Ordering};

use cortex_m::peripheral::NVIC;

use super::gpio::pfs;
use super::regs::{pac, rd, wr};
use crate::pins::{Rxd, RxdPin, Sci9, Txd, TxdPin};
use pac::interrupt;

/// Host link speed.
pub const BAUD: u32 = 115_200;

/// ICU event numbers (RA4M1 event table).
const EVENT_SCI9_RXI: u32 = 0xA8;
const EVENT_SCI9_TXI: u32 = 0xA9;
const EVENT_SCI9_TEI: u32 = 0xAA;
const EVENT_SCI9_ERI: u32 = 0xAB;
/// ICU slots used.
const SLOT_RXI: usize = 0;
const SLOT_ERI: usize = 1;
const SLOT_TXI: usize = 2;
const SLOT_TEI: usize = 3;
/// IELSRn.IR: the slot's request flag, cleared by the handler at its entry.
const IELSR_IR: u32 = 1 << 16;

/// SSR bits.
const SSR_ERRORS: u8 = (1 << 5) | (1 << 4) | (1 << 3); // ORER, FER, PER
/// SCR bits.
const SCR_TIE: u8 = 1 << 7;
const SCR_TEIE: u8 = 1 << 2;
const SCR_RIE: u8 = 1 << 6;
const SCR_TE: u8 = 1 << 5;
const SCR_RE: u8 = 1 << 4;

const RING: usize = 512;
/// Bytes one `write` queues at most. The line sends 11.5 a millisecond at 115 200 Bd and the
/// shell writes once a pass, so twice that keeps the line as busy as 64 would (the transmit
/// ring holds the backlog), while a pass queues ≈ 1 200 cycles of bytes, not ≈ 3 100
/// (`Ring::push`, ≈ 49 cycles a byte with the bus and flash waits).
const TX_PER_WRITE: usize = 24;

/// Single-producer (the RXI handler) single-consumer (the main loop) byte ring.
struct Ring {
    buf: UnsafeCell<[u8; RING]>,
    head: AtomicU16, // next write, owned by the producer
    tail: AtomicU16, // next read, owned by the consumer
}

// SAFETY: `buf[head]` is written only by the producer before it publishes `head` (Release), and
// read only by the consumer after it observes `head` (Acquire) and before it publishes `tail`;
// the two never touch the same cell at the same time.
unsafe impl Sync for Ring {}

static RX: Ring = Ring {
    buf: UnsafeCell::new([0; RING]),
    head: AtomicU16::new(0),
    tail: AtomicU16::new(0),
};
/// Bytes lost: ring full, or overrun/framing/parity errors.
static RX_DROPPED: AtomicU32 = AtomicU32::new(0);
/// Bytes to send: produced by `write` (main loop), consumed by the TXI/TEI handlers.
static TX: Ring = Ring {
    buf: UnsafeCell::new([0; RING]),
    head: AtomicU16::new(0),
    tail: AtomicU16::new(0),
};
/// The transmitter is running (set by `write` when it starts it, cleared by TEI when the ring
/// is empty). While it is set only the handlers touch TDR and SCR.TIE/TEIE.
static TX_ACTIVE: AtomicBool = AtomicBool::new(false);

impl Ring {
    fn push(&self, b: u8) -> bool {
        let head = self.head.load(Ordering::Relaxed);
        let next = (head + 1) % RING as u16;
        if next == self.tail.load(Ordering::Acquire) {
            return false;
        }
        // SAFETY: see `impl Sync`: the cell at `head` is not visible to the consumer yet.
        unsafe { (*self.buf.get())[head as usize] = b };
        self.head.store(next, Ordering::Release);
        true
    }

    fn pop(&self) -> Option<u8> {
        let tail = self.tail.load(Ordering::Relaxed);
        if tail == self.head.load(Ordering::Acquire) {
            return None;
        }
        // SAFETY: see `impl Sync`: the producer published this cell and will not write it
        // again before `tail` moves past it.
        let b = unsafe { (*self.buf.get())[tail as usize] };
        self.tail.store((tail + 1) % RING as u16, Ordering::Release);
        Some(b)
    }

    /// Pops up to `buf.len()` bytes at once (one acquire of `head`, one release of `tail`:
    /// the barriers of a byte-by-byte [`Ring::pop`] once per call instead of once per byte).
    #[inline]
    fn pop_into(&self, buf: &mut [u8]) -> usize {
        let mut tail = self.tail.load(Ordering::Relaxed);
        let head = self.head.load(Ordering::Acquire);
        let mut n = 0;
        while n < buf.len() && tail != head {
            // SAFETY: see `impl Sync`: the producer published every cell before `head`.
            buf[n] = unsafe { (*self.buf.get())[tail as usize] };
            tail = (tail + 1) % RING as u16;
            n += 1;
        }
        self.tail.store(tail, Ordering::Release);
        n
    }

    #[inline]
    fn is_empty(&self) -> bool {
        self.tail.load(Ordering::Relaxed) == self.head.load(Ordering::Acquire)
    }

    #[inline]
    fn is_full(&self) -> bool {
        let head = self.head.load(Ordering::Relaxed);
        (head + 1) % RING as u16 == self.tail.load(Ordering::Acquire)
    }
}

/// Clears the slot's request flag. Every handler does this first, as FSP's `r_sci_uart` ISRs
/// do (`R_BSP_IrqStatusClear` at entry): an event that comes while IR is still 1 is no new
/// request, so a flag cleared at the handler's end would swallow the event its own work raised
/// — a TXI entered more than one character time late writes TDR to an idle shifter, which
/// raises the next TXI at once; cleared afterwards, that TXI is lost, the transmitter stops
/// with `TX_ACTIVE` set and nothing is sent again.
fn clear_ir(slot: usize) {
    let v = rd!(pac::ICU.ielsr()[slot]);
    wr!(pac::ICU.ielsr()[slot], v & !IELSR_IR);
    // The flag must read back cleared before the handler's work, or the NVIC sees it again.
    let _ = rd!(pac::ICU.ielsr()[slot]);
}

#[interrupt]
fn IEL0() {
    clear_ir(SLOT_RXI);
    let b = rd!(pac::SCI9.rdr());
    if !RX.push(b) {
        RX_DROPPED.fetch_add(1, Ordering::Relaxed);
    }
}

#[interrupt]
fn IEL2() {
    clear_ir(SLOT_TXI);
    // TDR is empty: the next byte, or (ring empty) wait for the end of the last one.
    match TX.pop() {
        Some(b) => wr!(pac::SCI9.tdr(), b),
        None => {
            let scr = rd!(pac::SCI9.scr());
            wr!(pac::SCI9.scr(), (scr & !SCR_TIE) | SCR_TEIE);
        }
    }
}

#[interrupt]
fn IEL3() {
    clear_ir(SLOT_TEI);
    // The last byte has left: idle, unless `write` queued more since the ring ran dry.
    let scr = rd!(pac::SCI9.scr()) & !SCR_TEIE;
    match TX.pop() {
        Some(b) => {
            wr!(pac::SCI9.scr(), scr | SCR_TIE);
            wr!(pac::SCI9.tdr(), b);
        }
        None => {
            wr!(pac::SCI9.scr(), scr);
            TX_ACTIVE.store(false, Ordering::Release);
        }
    }
}

#[interrupt]
fn IEL1() {
    clear_ir(SLOT_ERI);
    // Read RDR to discard the bad byte, then clear the error flags so reception resumes.
    let _ = rd!(pac::SCI9.rdr());
    let ssr = rd!(pac::SCI9.ssr());
    wr!(pac::SCI9.ssr(), ssr & !SSR_ERRORS);
    RX_DROPPED.fetch_add(1, Ordering::Relaxed);
}

/// The SCI9 host link.
#[derive(Debug)]
pub struct HostUart(());

impl HostUart {
    /// Configures SCI9 for [`BAUD`] 8N1 from `pclka_hz` on `tx`/`rx` (SCI9's own lines of the
    /// pin map: another channel's pin, or the two swapped, does not compile), links its
    /// receive interrupts through the ICU and unmasks them in the NVIC (the bootloader leaves
    /// interrupts disabled; `main` enables them globally afterwards).
    #[inline]
    pub fn new<T: TxdPin<Sci9>, R: RxdPin<Sci9>>(
        pclka_hz: u32,
        tx: Txd<T, Sci9>,
        rx: Rxd<R, Sci9>,
    ) -> Self {
        let (tx, rx) = (tx.pin(), rx.pin());
        wr!(pac::SCI9.scr(), 0); // TE = RE = 0 while configuring
        wr!(pac::SCI9.smr(), 0); // async, 8 bits, no parity, 1 stop, PCLK/1
        wr!(pac::SCI9.scmr(), 0xF2); // reset value: serial mode, LSB first, no inversion
                                     // SEMR: ABCS (bit 4) = 1 and BGDM (bit 6) = 1: 8 base clocks per bit, so
                                     // BRR = PCLK / (8 · baud) − 1 = 51 at 48 MHz (115 385 baud, +0.16 %).
        wr!(pac::SCI9.semr(), (1 << 6) | (1 << 4));
        let brr = (pclka_hz + 4 * BAUD) / (8 * BAUD) - 1;
        wr!(pac::SCI9.brr(), brr.min(255) as u8);
        // At least one bit period before enabling (the manual's setup procedure).
        super::time::delay_us(10);
        let sel = pfs::PMR | (pfs::PSEL_SCI_ODD << pfs::PSEL_SHIFT);
        tx.configure(sel);
        rx.configure(sel | pfs::PCR); // idle high even with the bridge unpowered
        wr!(pac::ICU.ielsr()[SLOT_RXI], EVENT_SCI9_RXI);
        wr!(pac::ICU.ielsr()[SLOT_ERI], EVENT_SCI9_ERI);
        wr!(pac::ICU.ielsr()[SLOT_TXI], EVENT_SCI9_TXI);
        wr!(pac::ICU.ielsr()[SLOT_TEI], EVENT_SCI9_TEI);
        // SAFETY: the handlers above touch only SCI9, the rings and their own ICU slot.
        unsafe {
            NVIC::unmask(pac::Interrupt::IEL0);
            NVIC::unmask(pac::Interrupt::IEL1);
            NVIC::unmask(pac::Interrupt::IEL2);
            NVIC::unmask(pac::Interrupt::IEL3);
        }
        wr!(pac::SCI9.scr(), SCR_TE | SCR_RE | SCR_RIE);
        Self(())
    }

    /// The transmitter has sent everything queued and stopped (`flush` would return).
    #[inline]
    pub fn idle(&self) -> bool {
        !TX_ACTIVE.load(Ordering::Acquire)
    }

    /// Bytes lost so far (ring full or line errors).
    #[inline]
    pub fn dropped(&self) -> u32 {
        RX_DROPPED.load(Ordering::Relaxed)
    }
}

impl embedded_io::ErrorType for HostUart {
    type Error = Infallible;
}

impl embedded_io::ReadReady for HostUart {
    #[inline]
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!RX.is_empty())
    }
}

impl embedded_io::Read for HostUart {
    /// Blocks until at least one byte is there (embedded-io's contract); the shell only calls
    /// it after `read_ready`.
    #[inline]
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        if buf.is_empty() {
            return Ok(0);
        }
        let mut n = 0;
        while n == 0 {
            n = RX.pop_into(buf);
        }
        Ok(n)
    }
}

impl embedded_io::WriteReady for HostUart {
    #[inline]
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!TX.is_full())
    }
}

impl embedded_io::Write for HostUart {
    /// Queues as many bytes as the transmit ring takes (at least one: with the ring full it
    /// waits for the handler to free a slot, ≤ 87 µs) and starts the transmitter if idle.
    #[inline]
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let mut n = 0;
        for &b in buf.iter().take(TX_PER_WRITE) {
            if !TX.push(b) {
                if n > 0 {
                    break;
                }
                while !TX.push(b) {}
            }
            n += 1;
        }
        if n > 0 && !TX_ACTIVE.load(Ordering::Acquire) {
            // Idle: neither TIE nor TEIE is set, so no handler runs; start the line. TIE goes
            // on before the first byte so its move to the shift register raises TXI.
            cortex_m::interrupt::free(|_| {
                if let Some(b) = TX.pop() {
                    TX_ACTIVE.store(true, Ordering::Release);
                    let scr = rd!(pac::SCI9.scr());
                    wr!(pac::SCI9.scr(), scr | SCR_TIE);
                    wr!(pac::SCI9.tdr(), b);
                }
            });
        }
        Ok(n)
    }

    #[inline]
    fn flush(&mut self) -> Result<(), Infallible> {
        while !self.idle() {
            core::hint::spin_loop();
        }
        Ok(())
    }
}
