#!/usr/bin/env bash
# The release image that travels with the docs (docs/flashing.md, "Without a toolchain"):
#  1. builds and checks the board binary (.ci/firmware.sh: layout, size budget);
#  2. writes its flat image from 0x4000 with `host-tool flash --dry-run --save-bin` (the ELF's
#     loadable segments, checked for this flash map; no objcopy needed), and, where
#     llvm-objcopy is installed, checks it byte for byte against `llvm-objcopy -O binary`;
#  3. writes dist/uno-r4.bin.sha256 (sha256sum's format: `sha256sum -c` checks it) and
#     dist/uno-r4.json (size, SHA-256, CRC-16, protocol, schema id and commit it was built from).
set -euo pipefail
cd "$(dirname "$0")/.."

bash .ci/firmware.sh
cargo build --release --locked -p host-tool
target_dir="${CARGO_TARGET_DIR:-target}"
elf="$target_dir/thumbv7em-none-eabihf/firmware/uno-r4"
host_tool="$target_dir/release/host-tool"
mkdir -p dist
"$host_tool" -q flash --image "$elf" --dry-run --save-bin dist/uno-r4.bin -j > dist/.image.json
if command -v llvm-objcopy >/dev/null; then
    llvm-objcopy -O binary "$elf" dist/.objcopy.bin
    cmp dist/uno-r4.bin dist/.objcopy.bin
    rm dist/.objcopy.bin
    echo "dist/uno-r4.bin: identical to llvm-objcopy -O binary"
fi
(cd dist && sha256sum uno-r4.bin > uno-r4.bin.sha256)
python3 - "$("$host_tool" --version)" <<'PY'
import json, sys, hashlib
image = json.load(open("dist/.image.json"))["image"]
version = sys.argv[1]  # host-tool 0.1.0 (protocol 2, schema 0x…, commit …)
inner = version[version.index("(") + 1:version.rindex(")")]
fields = dict(part.split(" ", 1) for part in inner.split(", "))
data = open("dist/uno-r4.bin", "rb").read()
manifest = {
    "file": "uno-r4.bin",
    "bytes": len(data),
    "sha256": hashlib.sha256(data).hexdigest(),
    "crc16": image["crc16"],
    "load_address": "0x4000",
    "firmware_version": version.split()[1],
    "protocol_version": int(fields["protocol"]),
    "schema_id": fields["schema"],
    "commit": fields["commit"],
}
json.dump(manifest, open("dist/uno-r4.json", "w"), indent=2)
open("dist/uno-r4.json", "a").write("\n")
print(f"dist/uno-r4.bin: {len(data)} bytes, sha256 {manifest['sha256']}, "
      f"protocol {manifest['protocol_version']}, schema {manifest['schema_id']}, commit {manifest['commit']}")
PY
rm dist/.image.json
