//! The model's refusals and exception handling on tiny hand-assembled programs (no firmware
//! build needed): an access to an unmodelled register stops the run naming its address, a
//! protected register refuses an unlocked write, an undefined instruction escalates to the
//! HardFault handler with the faulting PC stacked (YIELD is a NOP), and the semihosting calls
//! a test harness makes (SYS_GET_CMDLINE once, the exits) behave as a test runner answers them.

use ra4m1_emu::{EmuError, Emulator, Options};

/// A minimal ELF32 (ARM) with one PT_LOAD segment of `image` at 0x4000.
fn elf(image: &[u8]) -> Vec<u8> {
    let mut e = Vec::new();
    e.extend_from_slice(b"\x7fELF\x01\x01\x01\0\0\0\0\0\0\0\0\0");
    let h16 = |e: &mut Vec<u8>, v: u16| e.extend_from_slice(&v.to_le_bytes());
    let h32 = |e: &mut Vec<u8>, v: u32| e.extend_from_slice(&v.to_le_bytes());
    h16(&mut e, 2); // ET_EXEC
    h16(&mut e, 40); // EM_ARM
    h32(&mut e, 1);
    h32(&mut e, 0x4005); // entry
    h32(&mut e, 52); // phoff
    h32(&mut e, 0); // shoff
    h32(&mut e, 0x0500_0400); // flags: EABI5, hard-float
    h16(&mut e, 52);
    h16(&mut e, 32);
    h16(&mut e, 1);
    h16(&mut e, 40);
    h16(&mut e, 0);
    h16(&mut e, 0);
    // Program header.
    h32(&mut e, 1); // PT_LOAD
    h32(&mut e, 84); // offset
    h32(&mut e, 0x4000); // vaddr
    h32(&mut e, 0x4000); // paddr
    h32(&mut e, image.len() as u32);
    h32(&mut e, image.len() as u32);
    h32(&mut e, 5); // R X
    h32(&mut e, 4);
    e.extend_from_slice(image);
    e
}

/// A vector table (SP, reset, …, HardFault) followed by Thumb code at 0x4040.
fn program(code: &[u16], literals: &[u32], hard_fault: Option<u32>) -> Vec<u8> {
    let mut img = vec![0u8; 0x40];
    img[0..4].copy_from_slice(&0x2000_8000u32.to_le_bytes());
    img[4..8].copy_from_slice(&0x4041u32.to_le_bytes());
    if let Some(h) = hard_fault {
        img[12..16].copy_from_slice(&(h | 1).to_le_bytes());
    }
    for h in code {
        img.extend_from_slice(&h.to_le_bytes());
    }
    while !img.len().is_multiple_of(4) {
        img.push(0);
    }
    for l in literals {
        img.extend_from_slice(&l.to_le_bytes());
    }
    img
}

#[test]
fn an_unmodelled_register_is_an_error_naming_its_address() {
    // ldr r0, [pc, #4]; ldr r1, [r0]; b . ; (pad) ; .word 0x4007_0000 (SCI0 SMR: not modelled)
    let img = program(&[0x4801, 0x6801, 0xE7FE, 0x0000], &[0x4007_0000], None);
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    let err = emu
        .run_until_ns(1_000_000)
        .expect_err("the read must stop the run");
    match err {
        EmuError::Unmodelled {
            kind, addr, size, ..
        } => {
            assert_eq!((kind, addr, size), ("read", 0x4007_0000, 4));
        }
        e => panic!("wrong error: {e}"),
    }
}

#[test]
fn unmapped_memory_is_an_error_too() {
    // ldr r0, [pc, #4]; str r0, [r0]; b . ; .word 0x5000_0000 (nothing there)
    let img = program(&[0x4801, 0x6000, 0xE7FE, 0x0000], &[0x5000_0000], None);
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    let err = emu.run_until_ns(1_000_000).expect_err("must stop");
    assert!(
        matches!(
            err,
            EmuError::Unmodelled {
                kind: "write",
                addr: 0x5000_0000,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn a_protected_clock_register_refuses_a_write_without_prcr() {
    // ldr r0, =SCKDIVCR; ldr r1, =0x1001_0100; str r1, [r0]; b .
    let img = program(
        &[0x4801, 0x4902, 0x6001, 0xE7FE],
        &[0x4001_E020, 0x1001_0100],
        None,
    );
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    let err = emu.run_until_ns(1_000_000).expect_err("must stop");
    match err {
        EmuError::Refused { what, addr, .. } => {
            assert_eq!(addr, 0x4001_E020);
            assert!(what.contains("PRCR.PRC0"), "{what}");
        }
        e => panic!("wrong error: {e}"),
    }
}

#[test]
fn an_undefined_instruction_enters_hardfault_with_the_faulting_pc_stacked() {
    // 0x4040: movs r0, #7; udf #0; b .   HardFault at 0x4046: b .
    let img = program(&[0x2007, 0xDE00, 0xE7FE, 0xE7FE], &[], Some(0x4046));
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    emu.run_until_ns(1_000_000).expect("runs");
    assert_eq!(emu.pc(), 0x4046, "spinning in the HardFault handler");
    let sp = emu.sp();
    assert_eq!(
        sp,
        0x2000_8000 - 0x20,
        "a basic frame (no FP used) on the main stack"
    );
    assert_eq!(emu.read_u32(sp), Some(7), "stacked r0");
    assert_eq!(
        emu.read_u32(sp + 24),
        Some(0x4042),
        "stacked return address: the UDF"
    );
    assert_eq!(
        emu.read_u32(sp + 28).map(|x| x >> 24 & 1),
        Some(1),
        "stacked xPSR.T"
    );
    let m = emu.machine();
    assert_eq!(m.scs.active, vec![3]);
    assert_ne!(m.scs.cfsr & (1 << 16), 0, "CFSR.UNDEFINSTR");
    assert_ne!(m.scs.hfsr & (1 << 30), 0, "HFSR.FORCED");
}

#[test]
fn semihosting_writes_and_exits_with_the_programs_code() {
    // movs r0,#4; ldr r1,=str; bkpt 0xab (SYS_WRITE0); movs r0,#0x18; ldr r1,=0x20026;
    // bkpt 0xab (SYS_EXIT, success); b .   then the string "ok\n".
    let img = program(
        &[
            0x2004, 0x4903, 0xBEAB, 0x2018, 0x4902, 0xBEAB, 0xE7FE, 0x0000,
        ],
        &[0x4058, 0x2_0026, 0x000A_6B6F],
        None,
    );
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    emu.run_until_ns(10_000_000).expect("runs");
    assert_eq!(emu.take_semihost_output(), b"ok\n");
    assert_eq!(emu.exit_code(), Some(0));
    // Another exit reason is a failure.
    let img = program(&[0x2018, 0x2101, 0xBEAB, 0xE7FE], &[], None);
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    emu.run_until_ns(10_000_000).expect("runs");
    assert_eq!(emu.exit_code(), Some(1));
}

#[test]
fn ra4m1_run_is_a_runner_that_returns_the_programs_exit_code() {
    let img = program(
        &[
            0x2004, 0x4903, 0xBEAB, 0x2018, 0x4902, 0xBEAB, 0xE7FE, 0x0000,
        ],
        &[0x4058, 0x2_0026, 0x000A_6B6F],
        None,
    );
    let dir = std::env::temp_dir().join(format!("ra4m1-run-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("prog.elf");
    std::fs::write(&path, elf(&img)).unwrap();
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_ra4m1-run"))
            .args(args)
            .output()
            .expect("ra4m1-run starts")
    };
    let p = path.to_str().unwrap();
    // Cargo appends the harness's own arguments after the ELF: they are passed over.
    let out = run(&[p, "--test-threads", "1"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(out.stdout, b"ok\n");
    // A program that never exits: the virtual time limit.
    let spin = dir.join("spin.elf");
    std::fs::write(&spin, elf(&program(&[0xE7FE, 0x0000], &[], None))).unwrap();
    let out = run(&["--timeout-ms", "5", spin.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(124));
    // Usage errors exit 2 with the usage line.
    let out = run(&[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("usage: ra4m1-run"));
    let out = run(&["--timeout-ms", "zero", p]);
    assert_eq!(out.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn yield_runs_as_a_nop_and_an_undefined_instruction_after_it_still_faults() {
    // yield; movs r0,#0x18; ldr r1,=0x20026; bkpt 0xab (SYS_EXIT, success); b .
    let img = program(
        &[0xBF10, 0x2018, 0x4901, 0xBEAB, 0xE7FE, 0x0000],
        &[0x2_0026],
        None,
    );
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    emu.run_until_ns(1_000_000).expect("runs");
    assert_eq!(emu.exit_code(), Some(0), "went past the YIELD");
    // yield; udf #0; b .   HardFault at 0x4044: b .
    let img = program(&[0xBF10, 0xDE00, 0xE7FE, 0xE7FE], &[], Some(0x4044));
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    emu.run_until_ns(1_000_000).expect("runs");
    assert_eq!(emu.pc(), 0x4044, "in the HardFault handler");
    assert_eq!(
        emu.read_u32(emu.sp() + 24),
        Some(0x4042),
        "stacked PC: the UDF"
    );
    assert_ne!(emu.machine().scs.cfsr & (1 << 16), 0, "CFSR.UNDEFINSTR");
}

#[test]
fn sys_get_cmdline_answers_the_set_command_once_then_fails() {
    // block (0x2000_0100) = [buf 0x2000_0200, 64]; SYS_GET_CMDLINE; SYS_WRITE0 buf; again
    // SYS_GET_CMDLINE (-1 expected); SYS_EXIT_EXTENDED [ApplicationExit, r0 + 1].
    let code = [
        0x4A0B, // ldr r2, =block
        0x4B0C, // ldr r3, =buf
        0x4C0C, // ldr r4, =64
        0x6013, // str r3, [r2]
        0x6054, // str r4, [r2, #4]
        0x2015, // movs r0, #0x15
        0x4611, // mov r1, r2
        0xBEAB, // bkpt 0xab
        0x2004, // movs r0, #4
        0x4619, // mov r1, r3
        0xBEAB, // bkpt 0xab
        0x2015, // movs r0, #0x15
        0x4611, // mov r1, r2
        0xBEAB, // bkpt 0xab
        0x3001, // adds r0, #1
        0x4D07, // ldr r5, =0x20026
        0x6095, // str r5, [r2, #8]
        0x60D0, // str r0, [r2, #12]
        0x4611, // mov r1, r2
        0x3108, // adds r1, #8
        0x2020, // movs r0, #0x20
        0xBEAB, // bkpt 0xab
        0xE7FE, // b .
        0x0000,
    ];
    let img = program(&code, &[0x2000_0100, 0x2000_0200, 64, 0x2_0026], None);
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    emu.set_semihost_cmdline("run_addr 16449");
    emu.run_until_ns(1_000_000).expect("runs");
    assert_eq!(emu.take_semihost_output(), b"run_addr 16449");
    assert_eq!(emu.cmdline_requests(), 2);
    assert_eq!(emu.exit_code(), Some(0), "the second request returned -1");
}

/// ICLK cycles until the semihosting exit of: `ldr r0, =addr`, four loads from `[r0]` (LDR, or
/// LDRB with `byte`), then SYS_EXIT. Programs differing only in `addr` differ only by what the
/// four accesses cost on their bus.
fn cycles_of_four_loads(addr: u32, byte: bool) -> u64 {
    let load = if byte { 0x7801 } else { 0x6801 }; // ldrb/ldr r1, [r0]
                                                   // 0x4040 ldr r0,[pc,#16]; 4 loads; movs r0,#0x18; ldr r1,[pc,#8]; bkpt 0xab; b .; pad
    let img = program(
        &[
            0x4804, load, load, load, load, 0x2018, 0x4902, 0xBEAB, 0xE7FE, 0x0000,
        ],
        &[addr, 0x2_0026],
        None,
    );
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    emu.run_until_ns(1_000_000).expect("runs");
    assert_eq!(emu.exit_code(), Some(0), "the program reached its exit");
    emu.stats().awake_cycles
}

/// The bus bridges' wait states (RA4M1 UM, "I/O Registers" appendix, "Access Cycles"; the
/// buses of "Buses"), at the clocks the Arduino bootloader leaves and the firmware keeps:
/// ICLK = PCLKA = 48 MHz, PCLKB = 24 MHz. An access over internal peripheral bus 3 (PCLKB,
/// ICLK:PCLKB = 2:1) takes 2 bus cycles + 1 synchronization cycle of PCLKB = 6 ICLK, 5 more
/// than the core's own 2-cycle load; over bus 5 (PCLKA, 1:1) 2 PCLKA = 2 ICLK, 1 more; a
/// register on ICLK's internal peripheral bus 1 (ICU, SYSTEM) none.
#[test]
fn peripheral_bus_accesses_cost_the_bridges_wait_states() {
    let icu = cycles_of_four_loads(0x4000_6300, false); // IELSR0: ICLK
    let port = cycles_of_four_loads(0x4004_0000, false); // PCNTR1 of port 0: PCLKB
    assert_eq!(
        port - icu,
        4 * 5,
        "PCLKB at ICLK/2: 5 extra ICLK per access"
    );
    let system = cycles_of_four_loads(0x4001_E026, true); // SCKSCR: ICLK
    let sci = cycles_of_four_loads(0x4007_0124, true); // SCI9 SSR: PCLKA
    assert_eq!(sci - system, 4, "PCLKA at ICLK: 1 extra ICLK per access");
    assert_eq!(icu, system, "two ICLK-bus programs cost the same");
}

/// The emulator's measure of a tick-driven loop tells a pass that overran the 1 ms tick (and
/// the next one, run back to back without a `WFI` between) from a pass that did not: a program
/// with SysTick at 1 kHz whose second pass busy-waits longer than a millisecond.
#[test]
fn a_pass_that_overruns_the_tick_shows_as_two_systicks_in_one_stretch() {
    // 0x4040: cpsie i; SysTick RVR = 47 999, CVR = 0, CSR = 7 (core clock, interrupt, on);
    // r2 = &count (0x2000_0000), r5 = pass = 0.
    // loop: r3 = count; r4 = pass == 1 ? LONG : 10; busy: subs r4, #1; bne busy; pass += 1;
    // wait: if count != r3 goto loop; wfi; b wait.
    // SysTick (0x406E): count += 1; bx lr.
    let code = [
        0xB662, 0x480D, 0x490D, 0x6041, 0x2100, 0x6081, 0x2107, 0x6001, 0x4A0B,
        0x2500, // init
        0x6813, 0x4C0B, 0x2D01, 0xD000, 0x240A, 0x3C01, 0xD1FD, 0x3501, // a pass
        0x6816, 0x429E, 0xD1F4, 0xBF30, 0xE7FA, // the wait for the next millisecond
        0x4804, 0x6801, 0x3101, 0x6001, 0x4770, // SysTick
    ];
    let mut img = program(&code, &[0xE000_E010, 47_999, 0x2000_0000, 12_000], None);
    img[0x3C..0x40].copy_from_slice(&0x406Fu32.to_le_bytes());
    let mut emu = Emulator::new(&elf(&img), Options::default()).expect("loads");
    emu.profile_passes(true);
    emu.run_until_ns(10_000_000).expect("runs");
    let s = emu.longest_stretch().clone();
    assert!(s.back_to_back(), "{s:?}");
    assert_eq!(s.ticks_at.len(), 2, "{s:?}");
    assert_eq!(s.ticks_at[0], 0, "woken by the tick: {s:?}");
    // The next millisecond began 48 000 cycles after the wake-up (the core awake all along),
    // while the long pass still ran; the stretch ends before a third.
    let at = s.overran_at().expect("overran");
    assert!((47_900..=48_100).contains(&at), "{s:?}");
    assert!(s.cycles > at && s.cycles < 96_000, "{s:?}");
    assert!(s.handler_cycles > 0 && s.handler_cycles < 200, "{s:?}");
    let before: u64 = emu.longest_overrun_profile().iter().map(|f| f.1).sum();
    assert!(
        before.abs_diff(at) < 100,
        "the profile before the tick covers its {at} cycles: {before}"
    );
    // The short passes after it: one SysTick each, at the wake-up.
    emu.clear_max_awake();
    emu.run_until_ns(20_000_000).expect("runs");
    let s = emu.longest_stretch();
    assert!(!s.back_to_back() && s.ticks_at == [0], "{s:?}");
    assert!(s.cycles < 1_000, "{s:?}");
    assert!(emu.longest_overrun_profile().is_empty());
}
