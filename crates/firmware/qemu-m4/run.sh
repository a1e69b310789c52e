#!/usr/bin/env bash
# Counts the Cortex-M4 (Thumb-2) instructions of the controller's worst-case loop pass
# (firmware::bench) under QEMU's mps2-an386, from a one-instruction-per-block execution trace.
# Deterministic: the same build gives the same counts. Needs qemu-system-arm (Debian package).
#
#   crates/firmware/qemu-m4/run.sh
#
# Prints, per scenario, the instructions of each measured pass (marker cost subtracted) and an
# M4 cycle estimate from the executed instruction mix (see docs/firmware.md, "Timing").
set -euo pipefail
cd "$(dirname "$0")"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-/work/target-fw}/qemu-m4"
cargo build --release --quiet
elf="$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/firmware-qemu-m4"
trace="$(mktemp)"; asmlog="$(mktemp)"
trap 'rm -f "$trace" "$asmlog"' EXIT
qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
  -semihosting-config enable=on,target=native -singlestep \
  -d exec,nochain,in_asm -D "$trace" -kernel "$elf"
start=$(nm "$elf" | awk '$3=="bench_mark_start"{print $1}')
end=$(nm "$elf" | awk '$3=="bench_mark_end"{print $1}')
syms="$(mktemp)"; trap 'rm -f "$trace" "$asmlog" "$syms"' EXIT
nm -C -S "$elf" | awk 'NF>=4 && ($3=="T"||$3=="t"){print $1, $2, substr($0, index($0,$4))}' > "$syms"
python3 - "$trace" "$start" "$end" "$syms" "${PROFILE:-}" <<'PY'
import re, sys, collections, bisect
trace, start, end = sys.argv[1], int(sys.argv[2], 16) & ~1, int(sys.argv[3], 16) & ~1
syms_path, profile = sys.argv[4], sys.argv[5]
asm = {}        # pc -> (mnemonic, operands)
regions = []    # list of Counter(pc -> executions)
cur = None
ins_re = re.compile(r'^0x([0-9a-f]{8}):\s+(?:[0-9a-f]{4,8}\s+)+(\S+)\s*(.*)$')
for line in open(trace, errors='replace'):
    if line.startswith('Trace '):
        pc = int(line.split('[')[1].split('/')[1], 16)
        if pc == start:
            cur = collections.Counter()
        elif pc == end and cur is not None:
            regions.append(cur); cur = None
        elif cur is not None:
            cur[pc] += 1
        continue
    m = ins_re.match(line)
    if m:
        asm[int(m.group(1), 16)] = (m.group(2), m.group(3))

def cycles(counter):
    # Cortex-M4 TRM timings; taken branches and calls refill the 3-stage pipeline (+2);
    # loads 2 cycles (pipelined neighbours 1: not modelled, so an upper estimate).
    total = 0
    for pc, n in counter.items():
        op, args = asm.get(pc, ('?', ''))
        o = op.split('.')[0].lower()
        c = 1
        regs = args.count(',') + 1 if '{' in args else 0
        if o in ('b','bl','blx','bx') or o.startswith('b') and o[1:] in ('eq','ne','cs','cc','mi','pl','vs','vc','hi','ls','ge','lt','gt','le','hs','lo'):
            c = 3   # assume taken (upper estimate for conditional branches)
        elif o in ('cbz','cbnz'):
            c = 3
        elif o.startswith('ldm') or o.startswith('stm') or o in ('push','pop','vpush','vpop') or o.startswith('vldm') or o.startswith('vstm'):
            c = 1 + max(regs, 1) + (2 if o == 'pop' and 'pc' in args else 0)
        elif o.startswith('ldr') or o.startswith('vldr'):
            c = 2 + (2 if 'pc' in args.split(',')[0] else 0)
        elif o in ('udiv','sdiv'):
            c = 12
        elif o in ('vdiv','vsqrt'):
            c = 14
        elif o in ('umull','smull','umlal','smlal'):
            c = 1
        elif o.startswith('tb'):   # tbb/tbh
            c = 4
        total += c * n
    return total


names = ['idle/whole', 'running/whole', 'idle/shell-chunk', 'running/shell-chunk', 'running/quiet']
per = len(regions) // len(names)
for k, name in enumerate(names):
    rs = regions[k*per:(k+1)*per]
    base = sum(rs[0].values())  # the empty region of this scenario
    measured = rs[-5:]
    ins = [sum(r.values()) - base for r in measured]
    cyc = [cycles(r) for r in measured]
    print(f"{name:20s} instructions/pass max {max(ins):6d} (all {ins}); M4 cycles est. max {max(cyc):6d} = {max(cyc)/48000*100:.0f}% of a 1 kHz tick at 48 MHz")

if profile:
    # PROFILE=<scenario>: self instructions per function in that scenario's costliest pass
    # (where LTO inlined a callee, its work is counted in the caller).
    syms = []
    for line in open(syms_path):
        a, size, sym = line.split(' ', 2)
        syms.append((int(a, 16) & ~1, int(size, 16), sym.strip()))
    syms.sort()
    addrs = [a for a, _, _ in syms]
    k = names.index(profile)
    rs = regions[k*per:(k+1)*per][-5:]
    r = max(rs, key=lambda c: sum(c.values()))
    by = collections.Counter()
    for pc, n in r.items():
        i = bisect.bisect_right(addrs, pc) - 1
        a, size, sym = syms[i] if i >= 0 else (0, 0, '?')
        by[sym if pc < a + max(size, 1) else '?'] += n
    for sym, n in by.most_common(25):
        print(f"{n:7d}  {sym[:150]}")
PY
