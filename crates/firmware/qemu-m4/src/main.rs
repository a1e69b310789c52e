//! Cortex-M4 harness: runs `firmware::bench`'s worst-case loop pass under QEMU (mps2-an386)
//! between two marker calls, so `run.sh` can count the instructions executed in between from
//! QEMU's one-instruction-per-block execution trace. Output through semihosting.
#![no_std]
#![no_main]

use core::arch::{asm, global_asm};
use core::hint::black_box;

use firmware::bench::{Arrival, Scenario, WorstCase};

/// Warm-up passes before measuring (the first passes fill the controller's histories).
const WARMUP: u32 = 3;
/// Measured passes per scenario.
const PASSES: u32 = 5;

global_asm!(
    ".section .vectors, \"a\"",
    ".word _stack_top",
    ".word reset_handler",
    ".word fault_handler", // NMI
    ".word fault_handler", // HardFault
    ".word fault_handler", // MemManage
    ".word fault_handler", // BusFault
    ".word fault_handler", // UsageFault
    ".word 0",
    ".word 0",
    ".word 0",
    ".word 0",
    ".word fault_handler", // SVCall
    ".word fault_handler", // DebugMon
    ".word 0",
    ".word fault_handler", // PendSV
    ".word fault_handler", // SysTick
);

fn semihost(op: u32, arg: usize) -> u32 {
    let mut r0 = op;
    // SAFETY: the semihosting breakpoint is handled by QEMU (-semihosting-config enable=on);
    // `arg` points to valid memory for the operations used (WRITE0: a NUL-terminated string).
    unsafe {
        asm!("bkpt #0xab", inout("r0") r0, in("r1") arg, options(nostack));
    }
    r0
}

fn print(s: &[u8]) {
    let mut buf = [0u8; 96];
    let n = s.len().min(buf.len() - 1);
    buf[..n].copy_from_slice(&s[..n]);
    semihost(0x04, buf.as_ptr() as usize); // SYS_WRITE0
}

fn print_num(label: &[u8], v: u32) {
    let mut buf = [0u8; 64];
    let n = label.len().min(40);
    buf[..n].copy_from_slice(&label[..n]);
    let mut digits = [0u8; 10];
    let mut k = 0;
    let mut x = v;
    loop {
        digits[k] = b'0' + (x % 10) as u8;
        k += 1;
        x /= 10;
        if x == 0 {
            break;
        }
    }
    let mut at = n;
    while k > 0 {
        k -= 1;
        buf[at] = digits[k];
        at += 1;
    }
    buf[at] = b'\n';
    print(&buf[..at + 1]);
}

fn exit(code: u32) -> ! {
    // SYS_EXIT: ADP_Stopped_ApplicationExit (0x20026) or RunTimeErrorUnknown (0x20023).
    semihost(0x18, if code == 0 { 0x20026 } else { 0x20023 });
    loop {
        core::hint::spin_loop();
    }
}

static mut PASS: u32 = 0;
static mut SENT: u32 = 0;

/// Start of a measured region (its address is looked up by `run.sh`; it stores to its own
/// static so the linker cannot fold it with [`bench_mark_end`]).
#[inline(never)]
#[no_mangle]
pub extern "C" fn bench_mark_start(pass: u32) {
    // SAFETY: single-threaded, no interrupts enabled.
    unsafe { (&raw mut PASS).write_volatile(pass) };
}

/// End of a measured region.
#[inline(never)]
#[no_mangle]
pub extern "C" fn bench_mark_end(sent: u32) {
    // SAFETY: as above.
    unsafe { (&raw mut SENT).write_volatile(sent) };
}

fn main() -> ! {
    for (name, s, a) in [
        (&b"idle/whole"[..], Scenario::Idle, Arrival::Whole),
        (&b"running/whole"[..], Scenario::Running, Arrival::Whole),
        (
            &b"idle/shell-chunk"[..],
            Scenario::Idle,
            Arrival::ShellChunk,
        ),
        (
            &b"running/shell-chunk"[..],
            Scenario::Running,
            Arrival::ShellChunk,
        ),
        (&b"running/quiet"[..], Scenario::Running, Arrival::Quiet),
    ] {
        let mut w = WorstCase::new(s, a);
        // An empty region: the markers' own cost, subtracted by run.sh.
        bench_mark_start(0);
        bench_mark_end(0);
        for _ in 0..WARMUP {
            w.prepare();
            black_box(w.step());
        }
        let mut sent = 0;
        for pass in 0..PASSES {
            w.prepare();
            bench_mark_start(pass);
            let n = black_box(w.step()) as u32;
            bench_mark_end(n);
            sent += n;
        }
        print(name);
        print_num(b" bytes sent per pass: ", sent / PASSES);
        print_num(b" frame bytes: ", w.frame_len() as u32);
    }
    exit(0)
}

/// Entry after reset: enable the FPU, initialise RAM, run.
///
/// # Safety
/// Called once by the hardware, with the stack pointer from the vector table.
#[no_mangle]
pub unsafe extern "C" fn reset_handler() -> ! {
    extern "C" {
        static mut _sdata: u32;
        static mut _edata: u32;
        static _sidata: u32;
        static mut _sbss: u32;
        static mut _ebss: u32;
    }
    // SAFETY: CPACR is the architectural coprocessor access register; full access to CP10/11
    // before any floating-point instruction runs.
    unsafe {
        let cpacr = 0xE000_ED88 as *mut u32;
        cpacr.write_volatile(cpacr.read_volatile() | (0xF << 20));
        asm!("dsb", "isb", options(nostack));
    }
    // SAFETY: the linker script defines these symbols as word-aligned section bounds.
    unsafe {
        let mut src = &raw const _sidata;
        let mut dst = &raw mut _sdata;
        while dst < &raw mut _edata {
            dst.write_volatile(src.read_volatile());
            dst = dst.add(1);
            src = src.add(1);
        }
        let mut dst = &raw mut _sbss;
        while dst < &raw mut _ebss {
            dst.write_volatile(0);
            dst = dst.add(1);
        }
    }
    main()
}

/// Any fault: report and stop.
#[no_mangle]
pub extern "C" fn fault_handler() -> ! {
    print(b"fault\n");
    exit(1)
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    print(b"panic\n");
    exit(1)
}
