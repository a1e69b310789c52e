//! The cycle model: each executed basic block is decoded once (Thumb-2 instruction lengths and
//! classes) and costed with the Cortex-M4 TRM's instruction timings, then the RA4M1's code-flash
//! wait states are added at run time.
//!
//! | class | cycles (Cortex-M4 TRM, "Instruction timings") |
//! |---|---|
//! | ALU, move, multiply (MUL/MLA/UMULL …), most VFP arithmetic | 1 |
//! | single load/store (LDR/STR/LDRB/…, VLDR/VSTR) | 2 |
//! | LDRD/STRD | 3 |
//! | LDM/STM/PUSH/POP, VLDM/VSTM/VPUSH/VPOP | 1 + registers |
//! | VMLA/VMLS/VFMA/VNMLA … (fused and chained multiply-add) | 3 |
//! | SDIV/UDIV | 7 (the TRM gives 2–12 by operand size; the midpoint) |
//! | VDIV, VSQRT | 14 |
//! | a taken branch (the next block does not follow this one) | + 2 (pipeline refill) |
//!
//! Flash wait states (MEMWAIT, UM "Flash Memory", "Memory Wait Cycle Control Register"): every
//! 32-bit fetch from code flash costs MEMWAIT extra cycles, and so does the refill after a
//! taken branch. There is no flash cache or prefetch credit in this model, so for code running
//! from flash it is an upper bound on fetch stalls (the M4 fetches a word while it executes
//! the previous one, which hides part of them on the chip).
//!
//! Peripheral-bus wait states (the bus bridges to PCLKA, PCLKB and FCLK) are charged per
//! register access by [`crate::machine::Machine::charge_bus_wait`], not per block.

/// What one block costs before wait states.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BlockCost {
    /// Instructions.
    pub instructions: u32,
    /// Cycles with zero wait states, no branch penalty.
    pub cycles: u32,
    /// 32-bit words fetched.
    pub fetch_words: u32,
}

fn hw(code: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes([*code.get(at)?, *code.get(at + 1)?]))
}

/// Cycles of one 16-bit instruction.
fn cost16(h: u16) -> u32 {
    let n = |bits: u16| bits.count_ones();
    match h {
        0x4800..=0x4FFF => 2,                          // LDR (literal)
        0x5000..=0x9FFF => 2,                          // load/store register, immediate, SP
        _ if h & 0xFE00 == 0xB400 => 1 + n(h & 0x1FF), // PUSH
        _ if h & 0xFE00 == 0xBC00 => 1 + n(h & 0x1FF), // POP
        0xC000..=0xCFFF => 1 + n(h & 0xFF),            // LDM/STM
        _ => 1,
    }
}

/// Cycles of one 32-bit instruction.
fn cost32(h1: u16, h2: u16) -> u32 {
    let coproc_fp = (h2 >> 9) & 7 == 0b101; // coprocessor 10/11
    if h1 & 0xFE40 == 0xE800 {
        1 + h2.count_ones() // LDM/STM (T2)
    } else if h1 & 0xFE40 == 0xE840 {
        3 // LDRD/STRD, exclusive, table branch
    } else if h1 & 0xFE00 == 0xF800 {
        2 // single load/store
    } else if (h1 & 0xFFF0 == 0xFB90 || h1 & 0xFFF0 == 0xFBB0) && h2 & 0x00F0 == 0x00F0 {
        7 // SDIV / UDIV
    } else if h1 & 0xEE00 == 0xEC00 && coproc_fp {
        // Extension register load/store.
        let p = h1 & (1 << 8) != 0;
        let w = h1 & (1 << 5) != 0;
        // VMOV of two core registers, VLDR/VSTR: 2; VLDM/VSTM/VPUSH/VPOP: 1 + words.
        if h1 & 0xFFE0 == 0xEC40 || (p && !w) {
            2
        } else {
            1 + u32::from(h2 & 0xFF).div_ceil(if h2 & 0x100 != 0 { 2 } else { 1 })
            // VLDM/VSTM
        }
    } else if h1 & 0xEF00 == 0xEE00 && coproc_fp && h2 & 0x10 == 0 {
        // VFP data processing.
        let opc1 = ((h1 >> 4) & 0xB) as u8; // bits 23, 21, 20 (bit 22 = D masked out)
        let vdiv = h1 & 0xFFB0 == 0xEE80;
        let vsqrt = h1 & 0xFFBF == 0xEEB1 && h2 & 0x00C0 == 0x00C0;
        if vdiv || vsqrt {
            14
        } else if opc1 == 0 || opc1 == 0x9 {
            3 // VMLA/VMLS (opc1 00), VFMA/VFMS/VFNMA (opc1 1x10 → 0x9 with masks)
        } else {
            1
        }
    } else {
        1
    }
}

/// Decodes `[addr, addr + size)` of `code` (the code flash image from address 0).
pub fn block_cost(code: &[u8], addr: u32, size: u32) -> BlockCost {
    let mut c = BlockCost::default();
    let mut at = addr as usize;
    let end = (addr + size) as usize;
    while at < end {
        let Some(h1) = hw(code, at) else { break };
        let is32 = h1 >> 11 >= 0b11101;
        if is32 {
            let h2 = hw(code, at + 2).unwrap_or(0);
            c.cycles += cost32(h1, h2);
            at += 4;
        } else {
            c.cycles += cost16(h1);
            at += 2;
        }
        c.instructions += 1;
    }
    c.fetch_words = (end as u32).div_ceil(4) - addr / 4;
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    fn code(halfwords: &[u16]) -> Vec<u8> {
        halfwords.iter().flat_map(|h| h.to_le_bytes()).collect()
    }

    #[test]
    fn counts_16_and_32_bit_instructions() {
        // movs r0,#1 ; ldr r1,[r2] ; push {r4-r7,lr} ; ldr.w r0,[r1,#4] ; vdiv.f32 s0,s1,s2
        let c = code(&[0x2001, 0x6811, 0xB5F0, 0xF8D1, 0x0004, 0xEE80, 0x0A81]);
        let b = block_cost(&c, 0, c.len() as u32);
        assert_eq!(b.instructions, 5);
        assert_eq!(b.cycles, 1 + 2 + (1 + 5) + 2 + 14);
        assert_eq!(b.fetch_words, 4);
    }
}
