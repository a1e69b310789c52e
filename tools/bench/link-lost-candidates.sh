#!/usr/bin/env bash
# Issue 26 item 1's measure: `host-tool plan --sim --sim-fault link-drop` for every ordered pair
# of the six states and seeds 1-25; counts the runs whose host candidates miss the simulator's
# true state. Run from the repo root after `cargo build --release -p host-tool`.
set -u
cd "$(dirname "$0")/../.."
states=("F&P" "F&F" "F&D" "D&P" "D&F" "D&D")
total=0; lost=0; miss=0
for seed in $(seq 1 25); do
 for from in "${states[@]}"; do
  for to in "${states[@]}"; do
   [ "$from" = "$to" ] && continue
   out=$(target/release/host-tool plan --target "$to" --sim --sim-initial "$from" --seed $seed --sim-fault link-drop --json 2>/dev/null </dev/null)
   r=$(python3 -c "
import json,sys
v=json.loads(sys.argv[1])
k=(v.get('failure') or {}).get('kind')
t=v['sim']['true_state'] if v.get('sim') else None
c=v.get('candidates')
print(k, 1 if (k=='link-lost' and t is not None and c is not None and t not in c) else 0)" "$out")
   total=$((total+1))
   set -- $r
   [ "$1" = "link-lost" ] && lost=$((lost+1))
   miss=$((miss+$2))
  done
 done
done
echo "runs $total, link lost $lost, truth not among the candidates $miss"
