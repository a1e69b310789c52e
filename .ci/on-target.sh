#!/usr/bin/env bash
# The on-target suites (crates/firmware/tests/board*.rs, embedded-test) in the RA4M1 emulator,
# called from .ci/run (and runnable alone from the repo root): the same test ELFs a bench runs
# with probe-rs (`cargo test-board`), with the cargo runner switched to `ra4m1-run` for this
# command only. Prints probe-rs's per-test report, then the counts; fails when a test fails
# or when no test ran.
set -euo pipefail
cd "$(dirname "$0")/.."

rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true
# The workspace's test build makes ra4m1-run (for ra4m1-emu's tests); asking for it the same way
# keeps cargo's feature resolution, so after `cargo test --workspace --release` this is a no-op
# (`cargo build -p ra4m1-emu` alone resolves features differently and rebuilds every dependency).
cargo test --workspace --release --locked --no-run -q
target_dir="${CARGO_TARGET_DIR:-target}"
case "$target_dir" in /*) ;; *) target_dir="$PWD/$target_dir" ;; esac

run="$target_dir/release/ra4m1-run"
log="$(mktemp)"
trap 'rm -f "$log"' EXIT
# As on a bench: the bare-board suite on a board with nothing attached (--bare), on the WiFi
# and on the Minima (the bootloaders leave SCI9 differently), then the stimulus suite with the
# fixture fitted (ra4m1-run fits it).
set +e
CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER="$run --bare" \
  cargo test-board-bare --locked --no-fail-fast 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER="$run --bare --board minima" \
  cargo test-board-bare --locked --no-fail-fast 2>&1 | tee -a "$log"
status=$((status | PIPESTATUS[0]))
CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER="$run" \
  cargo test-board-fixture --locked --no-fail-fast 2>&1 | tee -a "$log"
status=$((status | PIPESTATUS[0]))
set -e

results="$(grep -E '^test result: ' "$log" || true)"
passed=$(printf '%s\n' "$results" | grep -oE '[0-9]+ passed' | awk '{s += $1} END {print s + 0}')
failed=$(printf '%s\n' "$results" | grep -oE '[0-9]+ failed' | awk '{s += $1} END {print s + 0}')
ignored=$(printf '%s\n' "$results" | grep -oE '[0-9]+ ignored' | awk '{s += $1} END {print s + 0}')
suites=$(printf '%s\n' "$results" | grep -c . || true)
echo
echo "on-target suites in the emulator: $suites runs (bare suite on the WiFi and the Minima, fixture suite); $ignored ignored (bench only)"
echo "on-target: $passed passed, $failed failed"
if [ "$status" -ne 0 ] || [ "$failed" -ne 0 ]; then
  echo "on-target: FAILED (cargo test-board exit $status)" >&2
  exit 1
fi
if [ "$passed" -eq 0 ]; then
  echo "on-target: no test ran" >&2
  exit 1
fi
