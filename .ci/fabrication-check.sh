#!/usr/bin/env bash
# Reads host-tool's fabrication outputs back with independent readers: FOLD with rabbit-ear
# (npm), DXF with ezdxf, 3MF/STL with trimesh (PyPI), the kit's counts. Installs its own
# packages (tools/fabrication/requirements.txt, package-lock.json). Needs target/release/host-tool.
set -euo pipefail
cd "$(dirname "$0")/.."
H="$PWD/target/release/host-tool"
# The test build of the workspace makes it (a no-op after `cargo test --workspace --release`).
cargo test --workspace --release --locked --no-run -q
python3 -m pip install --quiet --disable-pip-version-check --root-user-action=ignore -r tools/fabrication/requirements.txt
(cd tools/fabrication && npm ci --no-audit --no-fund --silent)
OUT="$(mktemp -d)"
trap 'rm -rf "$OUT"' EXIT
PY="python3 tools/fabrication/check_outputs.py"
FOLDCHECK="node tools/fabrication/check_fold.js"

echo "--- crane trunk (defaults): SVG, DXF, FOLD"
"$H" pattern --svg "$OUT/crane.svg" --dxf "$OUT/crane.dxf" --fold "$OUT/crane.fold"
$PY dxf "$OUT/crane.dxf" --fold "$OUT/crane.fold" --edge-mm 75 --seam-mm 5
$FOLDCHECK "$OUT/crane.fold"
rsvg-convert -w 800 "$OUT/crane.svg" -o "$OUT/crane.png" && echo "ok   SVG renders (rsvg-convert)"

echo "--- golden n = 3 module, 4 layers, every catalogue state and self-packed (FOLD)"
"$H" pattern --n 3 --beta 31.717474411461005 --layers 4 --edge-mm 609.6 --seam-mm 0 \
  --states deployed,folded,edge-0,edge-1,edge-2,vertex-0,vertex-1,vertex-2,self-packed \
  --fold "$OUT/golden.fold" --dxf "$OUT/golden.dxf"
$FOLDCHECK "$OUT/golden.fold" --uniform
$PY dxf "$OUT/golden.dxf" --fold "$OUT/golden.fold" --edge-mm 609.6 --seam-mm 0

echo "--- n = 6, two modules of different beta (FOLD)"
"$H" pattern --n 6 --beta 15.104295,40 --layers 1,2 --edge-mm 20 --fold "$OUT/n6.fold"
$FOLDCHECK "$OUT/n6.fold"

echo "--- crane trunk printable panel: 3MF and one STL per material (trimesh)"
"$H" pattern --3mf "$OUT/crane.3mf" --stl-dir "$OUT/stl"
$PY panel "$OUT/crane.3mf" --stl-dir "$OUT/stl"
"$H" pattern --n 6 --beta 20,30 --layers 1,2 --edge-mm 40 --gap-mm 1,2 --facet-mm 1 --base-mm 0.4 --3mf "$OUT/n6.3mf"
$PY panel "$OUT/n6.3mf"

echo "--- the paper's meter-scale build (four 2 ft golden modules): 180 hinges, 720 screws"
"$H" pattern --beta 31.72 --layers 4 --edge-mm 609.6 --kit "$OUT/kit.json"
$PY kit "$OUT/kit.json" --hinges 180 --screws 720

echo "--- cut sheets of the paper's kit on 4 x 8 ft sheets, and of a two-module n = 4 kit (ezdxf + shapely)"
"$H" pattern --beta 31.72 --layers 4 --edge-mm 609.6 --nest 1220x2440 --nest-dir "$OUT/cut" --kit "$OUT/kit.json" -q
$PY nest "$OUT/cut" --sheet 1220x2440 --n 3 --layers 4 --kit "$OUT/kit.json"
"$H" pattern --n 4 --beta 35,31.72 --layers 2 --edge-mm 400 --nest 1000x1500 --kerf-mm 0.3 --margin-mm 5 \
  --spacing-mm 2 --nest-dir "$OUT/cut4" --kit "$OUT/kit4.json" -q
$PY nest "$OUT/cut4" --sheet 1000x1500 --kerf-mm 0.3 --margin-mm 5 --spacing-mm 2 --n 4 --layers 4 --kit "$OUT/kit4.json"
rsvg-convert -w 800 "$OUT/cut/sheet-1.svg" -o "$OUT/sheet-1.png" && echo "ok   cut sheet SVG renders (rsvg-convert)"

echo "--- the 1:1 crane pattern tiled on A4 and on Letter: reassembled from the marks = the full pattern within 0.1 mm"
"$H" pattern --svg "$OUT/full.svg" --page a4 --page-dir "$OUT/a4" -q
$PY tiles "$OUT/full.svg" "$OUT"/a4/page-*.svg
"$H" pattern --beta 31.72 --layers 4 --edge-mm 200 --svg "$OUT/big.svg" --page letter --page-dir "$OUT/letter" -q
$PY tiles "$OUT/big.svg" "$OUT"/letter/page-*.svg
rsvg-convert -w 600 "$OUT/a4/page-1.svg" -o "$OUT/page-1.png" && echo "ok   page SVG renders (rsvg-convert)"

echo "--- the legend below, right of or off the sheet, on the --svg page and on the tiles: rendered inside its box, clear of every crease line"
$PY legend "$OUT/crane.svg" "$OUT/full.svg" "$OUT/big.svg"
for place in right none; do
  "$H" pattern --svg "$OUT/legend-$place.svg" --legend "$place" --page a4 --page-dir "$OUT/a4-$place" -j > "$OUT/a4-$place.json"
  "$H" pattern --beta 31.72 --layers 4 --edge-mm 200 --svg "$OUT/big-$place.svg" --legend "$place" --page letter --page-dir "$OUT/letter-$place" -q
  $PY tiles "$OUT/legend-$place.svg" "$OUT"/a4-$place/page-*.svg
  $PY tiles "$OUT/big-$place.svg" "$OUT"/letter-$place/page-*.svg
done
$PY legend "$OUT/legend-right.svg" "$OUT/big-right.svg"
$PY legend "$OUT/legend-none.svg" "$OUT/big-none.svg" "$OUT"/a4-none/page-*.svg "$OUT"/letter-none/page-*.svg --expect none
# The one tile of each that prints the legend (grep: the others have none).
$PY legend $(grep -l 'id="legend"' "$OUT"/a4/page-*.svg "$OUT"/letter/page-*.svg "$OUT"/a4-right/page-*.svg "$OUT"/letter-right/page-*.svg) --footer-mm 14

echo "--- printable parts (hinge leaf, caps, tendon locator, gripper mount): trimesh reads each STL and 3MF back"
"$H" pattern --parts "$OUT/parts" -j > "$OUT/parts.json"
$PY parts "$OUT/parts.json" --tendon-radius-mm 60
"$H" pattern --n 6 --edge-mm 30 --beta 31.72 --parts "$OUT/parts6" --tendon-radius-mm 45 --panel-mm 10 --fold-max-deg 120 -j > "$OUT/parts6.json"
$PY parts "$OUT/parts6.json" --tendon-radius-mm 45
"$H" pattern --parts "$OUT/parts-stl" --parts-format stl -j > "$OUT/parts-stl.json"
$PY parts "$OUT/parts-stl.json" --tendon-radius-mm 60 --formats stl

echo "--- the printed parts in the bills of materials: quantities and filament = quantity x STL volume x density"
"$H" pattern --bom "$OUT/crane-bom.csv" -q
$PY bom "$OUT/crane-bom.csv" --parts "$OUT/parts.json"
"$H" pattern --n 6 --edge-mm 30 --beta 31.72 --tendon-radius-mm 45 --bom "$OUT/crane6-bom.csv" -q
$PY bom "$OUT/crane6-bom.csv" --parts "$OUT/parts6.json"
"$H" pattern --beta 31.72 --layers 4 --edge-mm 609.6 --kit "$OUT/kit.json" --bom "$OUT/kit-bom.csv" \
  --parts "$OUT/kit-parts" --tendon-radius-mm 400 -j > "$OUT/kit-parts.json"
$PY bom "$OUT/kit-bom.csv" --parts "$OUT/kit-parts.json" --expect hinge-leaf
$PY render "$OUT/parts/hinge-leaf.stl" "$OUT/hinge-leaf.png" --elev 35

echo "--- 3D models: glTF read with numpy alone (the gltf crate validates them in cargo test), OBJ/STL with trimesh"
"$H" model --states deployed --gltf "$OUT/dd.glb" --obj "$OUT/dd.obj" --stl "$OUT/dd.stl"
"$H" model --beta 31.717474411461005 --layers 4 --states edge-0,deployed,vertex-1,folded --gltf "$OUT/golden.glb"
"$H" model --beta 35 --layers 3 --states edge-0 --gltf "$OUT/strained.glb"
$PY glb "$OUT/dd.glb" "$OUT/golden.glb" --expect-red no
$PY glb "$OUT/strained.glb" --expect-red yes
$PY mesh "$OUT/dd.obj" "$OUT/dd.stl"
"$H" ik --n 3 --beta 31.72 --modules 8 --target helix:radius=1,pitch=4,turns=1 --algo greedy --gltf "$OUT/ik.glb" >/dev/null
$PY glb "$OUT/ik.glb"
$PY render "$OUT/dd.glb" "$OUT/dd.png"

echo "fabrication-check: all readers passed"
