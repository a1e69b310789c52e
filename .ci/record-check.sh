#!/usr/bin/env bash
# Reads host-tool's MCAP recordings back with the Python `mcap` reader (PyPI): a seeded plan on
# the simulator, a monitor run compared with what it printed, and a recording whose writer was
# killed (then `host-tool log recover`). Installs its own packages. Needs target/release/host-tool.
set -euo pipefail
cd "$(dirname "$0")/.."
H="$PWD/target/release/host-tool"
# The test build of the workspace makes it (a no-op after `cargo test --workspace --release`).
cargo test --workspace --release --locked --no-run -q
python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore -r tools/record/requirements.txt
OUT="$(mktemp -d)"
trap 'rm -rf "$OUT"' EXIT
PY="python3 tools/record/check_mcap.py"

echo "--- plan --sim --record (seed 7, F&P → D&D)"
"$H" plan --sim --seed 7 --target 'D&D' --record "$OUT/plan.mcap" --json >"$OUT/plan.json"
$PY plan "$OUT/plan.mcap" "$OUT/plan.json"
"$H" log summary "$OUT/plan.mcap" | grep -q '^/telemetry .*crane.Telemetry'
"$H" log export "$OUT/plan.mcap" --csv "$OUT/csv" >/dev/null
head -1 "$OUT/csv/telemetry.csv" | grep -q '^log_time_s,publish_time_s,device_ms,'
"$H" log plot "$OUT/plan.mcap" --out "$OUT/plan.svg" >/dev/null
rsvg-convert -w 800 "$OUT/plan.svg" -o "$OUT/plan.png" && echo "ok   log summary, export, plot (SVG renders)"

echo "--- monitor --json, with and without --record: the same seeded run, the same samples"
M=(monitor --sim --seed 3 --duration 2 --rate 50 --sim-speed 1000 --json)
"$H" "${M[@]}" >"$OUT/mon-plain.jsonl"
"$H" "${M[@]}" --record "$OUT/mon.mcap" >"$OUT/mon.jsonl"
cmp "$OUT/mon-plain.jsonl" "$OUT/mon.jsonl" && echo "ok   recording does not change the run"
$PY monitor "$OUT/mon.mcap" "$OUT/mon-plain.jsonl"

echo "--- a killed writer: the file reads up to its last chunk; log recover completes it"
"$H" monitor --sim --seed 3 --sim-speed 1 --duration 60 --rate 50 --record "$OUT/killed.mcap" >/dev/null &
PID=$!
# Wait (bounded) until a few one-second chunks are on disk, then kill without warning.
for _ in $(seq 200); do
  [ "$(stat -c %s "$OUT/killed.mcap" 2>/dev/null || echo 0)" -gt 40000 ] && break
  sleep 0.05
done
kill -9 "$PID"; wait "$PID" 2>/dev/null || true
"$H" log summary "$OUT/killed.mcap" | grep -q INCOMPLETE
"$H" log recover "$OUT/killed.mcap" --out "$OUT/recovered.mcap"
$PY killed "$OUT/killed.mcap" "$OUT/recovered.mcap"
