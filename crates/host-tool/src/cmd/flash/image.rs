//! The firmware image to write: a flat binary from the application's flash origin, read from
//! the board binary's ELF (its loadable segments at their load addresses, as `objcopy -O binary`
//! lays them out) or taken as a `.bin`, and checked to be an image for this board's flash map
//! before anything is sent.

use std::path::Path;

use object::elf::{FileHeader32, PT_LOAD};
use object::read::elf::{FileHeader as _, ProgramHeader as _};
use object::LittleEndian as LE;

/// The application's flash origin (`memory.x`: `FLASH : ORIGIN = 0x00004000`): the Arduino
/// bootloader owns everything below it.
pub const FLASH_ORIGIN: u32 = 0x4000;
/// The application's flash length (`memory.x`: `LENGTH = 240K`).
pub const FLASH_LENGTH: u32 = 240 * 1024;
/// The RA4M1's SRAM (`memory.x`: `RAM : ORIGIN = 0x20000000, LENGTH = 32K`).
pub const RAM: (u32, u32) = (0x2000_0000, 0x2000_8000);

/// A checked image: `bytes` go to `FLASH_ORIGIN` onwards.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// The flash content from [`FLASH_ORIGIN`].
    pub bytes: Vec<u8>,
    /// The initial stack pointer (word 0 of the vector table).
    pub initial_sp: u32,
    /// The reset vector (word 1).
    pub reset_vector: u32,
}

/// Reads `path`: an ELF (by its magic) or a flat binary from [`FLASH_ORIGIN`].
pub fn load(path: &Path) -> Result<Image, String> {
    let data = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let bytes = if data.starts_with(b"\x7fELF") {
        elf_to_bin(&data).map_err(|e| format!("{}: {e}", path.display()))?
    } else {
        data
    };
    check(bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// The flat binary of an ELF's loadable segments from [`FLASH_ORIGIN`], by their load
/// (physical) addresses: `.text`, `.rodata` and the initial values of `.data` as the linker
/// placed them in flash. Gaps between segments are zero, as objcopy fills them. A segment
/// outside the application's flash is refused.
pub fn elf_to_bin(data: &[u8]) -> Result<Vec<u8>, String> {
    let header = FileHeader32::<LE>::parse(data)
        .map_err(|e| format!("not a 32-bit little-endian ELF (the board's is): {e}"))?;
    let endian = header.endian().map_err(|e| format!("ELF: {e}"))?;
    if header.e_machine.get(endian) != object::elf::EM_ARM {
        return Err(format!(
            "an ELF for machine {} (the board is an ARM Cortex-M4, machine {})",
            header.e_machine.get(endian),
            object::elf::EM_ARM
        ));
    }
    let segments = header
        .program_headers(endian, data)
        .map_err(|e| format!("ELF program headers: {e}"))?;
    let mut pieces = Vec::new();
    for ph in segments {
        if ph.p_type(endian) != PT_LOAD || ph.p_filesz(endian) == 0 {
            continue;
        }
        let addr = ph.p_paddr(endian);
        let bytes = ph
            .data(endian, data)
            .map_err(|_| format!("a segment at {addr:#x} lies outside the file"))?;
        let end = u64::from(addr) + bytes.len() as u64;
        if addr < FLASH_ORIGIN || end > u64::from(FLASH_ORIGIN + FLASH_LENGTH) {
            return Err(format!(
                "a loadable segment at {addr:#010x}..{end:#010x} lies outside the application's \
                 flash {FLASH_ORIGIN:#010x}..{:#010x} (memory.x): not an image for this board's \
                 bootloader layout",
                FLASH_ORIGIN + FLASH_LENGTH
            ));
        }
        pieces.push((addr - FLASH_ORIGIN, bytes));
    }
    if pieces.is_empty() {
        return Err("no loadable segment with content".into());
    }
    let len = pieces
        .iter()
        .map(|(o, b)| *o as usize + b.len())
        .max()
        .unwrap_or(0);
    let mut out = vec![0u8; len];
    for (o, b) in pieces {
        out[o as usize..o as usize + b.len()].copy_from_slice(b);
    }
    Ok(out)
}

/// Checks that `bytes` is an application image for this flash map: it fits, and its vector
/// table (at its start, where the bootloader jumps) holds an initial stack pointer in SRAM and
/// a Thumb reset vector inside the image.
pub fn check(bytes: Vec<u8>) -> Result<Image, String> {
    if bytes.len() < 8 {
        return Err(format!(
            "{} bytes: too short for a vector table (8 bytes at least)",
            bytes.len()
        ));
    }
    if bytes.len() > FLASH_LENGTH as usize {
        return Err(format!(
            "{} bytes do not fit the application's flash: {} bytes from {FLASH_ORIGIN:#x} \
             (memory.x)",
            bytes.len(),
            FLASH_LENGTH
        ));
    }
    let word = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let (sp, reset) = (word(0), word(4));
    if !(RAM.0 < sp && sp <= RAM.1) {
        return Err(format!(
            "its first word {sp:#010x} is no initial stack pointer in SRAM \
             ({:#010x}..={:#010x}): not a Cortex-M image starting at its vector table",
            RAM.0, RAM.1
        ));
    }
    let end = FLASH_ORIGIN as u64 + bytes.len() as u64;
    if reset & 1 == 0
        || u64::from(reset & !1) < u64::from(FLASH_ORIGIN)
        || u64::from(reset & !1) >= end
    {
        return Err(format!(
            "its reset vector {reset:#010x} is not a Thumb address inside the image \
             ({FLASH_ORIGIN:#010x}..{end:#010x}): an image linked for another flash origin \
             (this board's application starts at {FLASH_ORIGIN:#x}, behind the bootloader)"
        ));
    }
    Ok(Image {
        bytes,
        initial_sp: sp,
        reset_vector: reset,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal ARM ELF32 with one loadable segment per `(paddr, bytes)`.
    fn elf(machine: u16, segments: &[(u32, &[u8])]) -> Vec<u8> {
        let phoff = 52u32;
        let data_at = phoff + 32 * segments.len() as u32;
        let mut out = Vec::new();
        out.extend_from_slice(b"\x7fELF\x01\x01\x01\0\0\0\0\0\0\0\0\0");
        let h16 = |v: u16, o: &mut Vec<u8>| o.extend_from_slice(&v.to_le_bytes());
        let h32 = |v: u32, o: &mut Vec<u8>| o.extend_from_slice(&v.to_le_bytes());
        h16(2, &mut out); // ET_EXEC
        h16(machine, &mut out);
        h32(1, &mut out);
        h32(segments.first().map_or(0, |s| s.0 + 1), &mut out); // entry
        h32(phoff, &mut out);
        h32(0, &mut out); // shoff
        h32(0x0500_0400, &mut out); // flags
        h16(52, &mut out);
        h16(32, &mut out);
        h16(segments.len() as u16, &mut out);
        h16(40, &mut out);
        h16(0, &mut out);
        h16(0, &mut out);
        let mut off = data_at;
        for (paddr, bytes) in segments {
            h32(PT_LOAD, &mut out);
            h32(off, &mut out);
            h32(*paddr, &mut out); // vaddr
            h32(*paddr, &mut out);
            h32(bytes.len() as u32, &mut out);
            h32(bytes.len() as u32, &mut out);
            h32(5, &mut out);
            h32(4, &mut out);
            off += bytes.len() as u32;
        }
        for (_, bytes) in segments {
            out.extend_from_slice(bytes);
        }
        out
    }

    fn vectors() -> Vec<u8> {
        let mut v = Vec::new();
        v.extend_from_slice(&0x2000_8000u32.to_le_bytes());
        v.extend_from_slice(&0x0000_4101u32.to_le_bytes());
        v.resize(0x200, 0xAB);
        v
    }

    #[test]
    fn the_memory_map_is_the_one_memory_x_gives_the_linker() {
        let text = include_str!("../../../../../memory.x");
        assert!(
            text.contains("FLASH : ORIGIN = 0x00004000, LENGTH = 240K"),
            "memory.x changed: update FLASH_ORIGIN/FLASH_LENGTH"
        );
        assert!(text.contains("RAM   : ORIGIN = 0x20000000, LENGTH = 32K"));
        assert_eq!((FLASH_ORIGIN, FLASH_LENGTH), (0x4000, 245_760));
    }

    #[test]
    fn an_elf_becomes_its_segments_from_the_flash_origin_with_gaps_zeroed() {
        let text = vectors();
        let data = [1u8, 2, 3, 4];
        let bin = elf_to_bin(&elf(40, &[(0x4000, &text), (0x4300, &data)])).unwrap();
        assert_eq!(bin.len(), 0x304);
        assert_eq!(&bin[..0x200], &text[..]);
        assert!(bin[0x200..0x300].iter().all(|b| *b == 0));
        assert_eq!(&bin[0x300..], &data);
        let img = check(bin).unwrap();
        assert_eq!((img.initial_sp, img.reset_vector), (0x2000_8000, 0x4101));
    }

    #[test]
    fn images_for_another_layout_or_machine_are_refused_with_the_reason() {
        let text = vectors();
        // Linked at 0 (a bare chip's layout): over the bootloader.
        let e = elf_to_bin(&elf(40, &[(0x0, &text)])).unwrap_err();
        assert!(e.contains("outside the application's flash"), "{e}");
        let e = elf_to_bin(&elf(62, &[(0x4000, &text)])).unwrap_err();
        assert!(e.contains("machine 62"), "{e}");
        // A .bin whose reset vector points below the origin (linked for 0x0000).
        let mut at_zero = text.clone();
        at_zero[4..8].copy_from_slice(&0x0000_0101u32.to_le_bytes());
        let e = check(at_zero).unwrap_err();
        assert!(e.contains("another flash origin"), "{e}");
        // Not a vector table at all.
        let e = check(vec![0xFF; 64]).unwrap_err();
        assert!(e.contains("stack pointer"), "{e}");
        // Too big.
        let mut big = text.clone();
        big.resize(FLASH_LENGTH as usize + 1, 0);
        let e = check(big).unwrap_err();
        assert!(e.contains("do not fit"), "{e}");
        assert!(check(vec![0; 4]).unwrap_err().contains("too short"));
    }
}
