#!/usr/bin/env bash
# Board binary check, called from .ci/run (and runnable alone from the repo root):
#  1. builds `uno-r4` in the `firmware` profile for thumbv7em-none-eabihf (`cargo firmware`);
#  2. checks that no loadable segment or allocated section lies below 0x4000 (the Arduino
#     bootloader and the option-setting memory at 0x400..0x4FF: never written by us);
#  3. reports flash and static RAM, and fails above the budget (45.5 KiB flash, 16 KiB RAM): the
#     budget follows the size reached (BENCHMARKS.md) with a small margin, so a regression is red.
# Needs only cargo and python3 (the ELF is parsed here, no binutils required).
set -euo pipefail
cd "$(dirname "$0")/.."

rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true
cargo firmware --locked

target_dir="${CARGO_TARGET_DIR:-target}"
elf="$target_dir/thumbv7em-none-eabihf/firmware/uno-r4"
python3 - "$elf" <<'PY'
import struct, sys

FLASH_BUDGET = 45 * 1024 + 512      # 45.2 KiB reached with the stored probe profile (BENCHMARKS.md, "Issue 25: the probe profile on the device")
RAM_BUDGET = 16 * 1024
APP_START = 0x4000                      # memory.x FLASH ORIGIN
RAM = (0x2000_0000, 0x2000_8000)        # 32 KiB SRAM

path = sys.argv[1]
data = open(path, "rb").read()
if data[:4] != b"\x7fELF" or data[4] != 1 or data[5] != 1:
    sys.exit(f"{path}: not a 32-bit little-endian ELF")
(e_phoff, e_shoff) = struct.unpack_from("<II", data, 28)
(e_phentsize, e_phnum, e_shentsize, e_shnum, e_shstrndx) = struct.unpack_from("<HHHHH", data, 42)

def section(i):
    return struct.unpack_from("<IIIIIIIIII", data, e_shoff + i * e_shentsize)

strtab = section(e_shstrndx)
def name(off):
    start = strtab[4] + off
    return data[start:data.index(b"\0", start)].decode()

SHF_ALLOC, SHT_NOBITS = 0x2, 8
flash = ram = 0
rows = []
for i in range(e_shnum):
    (sh_name, sh_type, sh_flags, sh_addr, sh_offset, sh_size, *_rest) = section(i)
    if not sh_flags & SHF_ALLOC or sh_size == 0:
        continue
    n = name(sh_name)
    if sh_addr < APP_START:
        sys.exit(f"FAIL: section {n} at {sh_addr:#x} lies below {APP_START:#x} (bootloader/option bytes)")
    in_ram = RAM[0] <= sh_addr < RAM[1]
    if in_ram:
        ram += sh_size
        if sh_type != SHT_NOBITS:       # .data: its initial values are also stored in flash
            flash += sh_size
    else:
        flash += sh_size
    rows.append((n, sh_addr, sh_size, "RAM" if in_ram else "flash"))

PT_LOAD = 1
for i in range(e_phnum):
    (p_type, p_offset, p_vaddr, p_paddr, p_filesz, p_memsz, *_r) = struct.unpack_from(
        "<IIIIIIII", data, e_phoff + i * e_phentsize)
    if p_type == PT_LOAD and p_memsz and p_paddr < APP_START:
        sys.exit(f"FAIL: loadable segment at physical {p_paddr:#x} lies below {APP_START:#x}")

for n, a, s, where in rows:
    print(f"  {n:<24} {a:#010x} {s:>7} B  {where}")
print(f"firmware size: flash {flash} B ({flash / 1024:.1f} KiB, budget {FLASH_BUDGET / 1024:g} KiB), "
      f"static RAM {ram} B ({ram / 1024:.1f} KiB, budget 16 KiB)")
if flash > FLASH_BUDGET or ram > RAM_BUDGET:
    sys.exit("FAIL: firmware over its size budget")
print("firmware: no section below 0x4000; within budget")
PY
