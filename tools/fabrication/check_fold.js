// Reads a FOLD file written by `host-tool pattern --fold` with rabbit-ear and checks it.
// usage: node check_fold.js FILE [--uniform]   (--uniform: one β for every layer)
// Exit 0 when every check passes; prints one line per check.
"use strict";
const fs = require("fs");
const ear = require("rabbit-ear");

const path = process.argv[2];
const uniform = process.argv.includes("--uniform");
const fold = JSON.parse(fs.readFileSync(path, "utf8"));
let failed = 0;
const check = (ok, what) => {
  console.log(`${ok ? "ok  " : "FAIL"} ${what}`);
  if (!ok) failed += 1;
};

check(fold.file_spec === 1.2, `file_spec 1.2 (${fold.file_spec})`);
const graph = ear.graph.validate(fold);
check(graph.summary === "valid", `rabbit-ear graph.validate: ${graph.summary} ${JSON.stringify(graph)}`);
const cp = ear.cp(JSON.parse(JSON.stringify(fold)));
const v = cp.validate();
check(v.vertices.maekawa.length === 0, `Maekawa at every interior vertex (violations: ${v.vertices.maekawa.length})`);
// Kawasaki holds wherever β is the same above and below a vertex; at a row where two modules
// of different β meet its alternating sum is 180° + 2(β_above − β_below).
const ys = v.vertices.kawasaki.map(i => fold.vertices_coords[i][1]);
const rows = new Set(ys.map(y => y.toFixed(6)));
if (uniform) {
  check(v.vertices.kawasaki.length === 0, `Kawasaki at every interior vertex (violations: ${v.vertices.kawasaki.length})`);
} else {
  const interfaces = (fold["yoshimura:module_interface_y_mm"] || []).map(y => y.toFixed(6));
  check([...rows].every(y => interfaces.includes(y)),
    `Kawasaki fails only on module interface rows (${v.vertices.kawasaki.length} vertices on ${rows.size} of ${interfaces.length} interface rows)`);
}
const nv = fold.vertices_coords.length, ne = fold.edges_vertices.length;
check(fold.edges_assignment.length === ne && fold.edges_foldAngle.length === ne, "per-edge arrays match edges_vertices");
check(fold.faces_vertices.every(f => f.length === 3 && f.every(i => i >= 0 && i < nv)), "faces_vertices reference vertices");
const frames = fold.file_frames || [];
check(frames.length >= 1, `${frames.length} folded frames`);
for (const fr of frames) {
  const merged = Object.assign({}, fold, fr);
  delete merged.file_frames;
  const g = ear.graph.validate(merged);
  check(fr.vertices_coords.length === nv && fr.vertices_coords.every(c => c.length === 3),
    `frame '${fr.frame_title}': ${nv} 3D vertices`);
  check(g.edges.circular.length === 0 && g.edges.duplicate.length === 0 && g.vertices.isolated.length === 0,
    `frame '${fr.frame_title}': graph valid in 3D`);
  // Isometry: every edge keeps its flat length (relative error), for frames marked feasible.
  let worst = 0;
  fold.edges_vertices.forEach(([a, b]) => {
    const p = fold.vertices_coords[a], q = fold.vertices_coords[b];
    const flat = Math.hypot(p[0] - q[0], p[1] - q[1]);
    const P = fr.vertices_coords[a], Q = fr.vertices_coords[b];
    const folded = Math.hypot(P[0] - Q[0], P[1] - Q[1], P[2] - Q[2]);
    worst = Math.max(worst, Math.abs(folded - flat) / flat);
  });
  if (fr["yoshimura:states_feasible"] && fr["yoshimura:max_strain"] < 1e-9) {
    check(worst < 1e-9, `frame '${fr.frame_title}': isometric, largest edge error ${worst.toExponential(2)}`);
  } else {
    console.log(`info frame '${fr.frame_title}': strained (recorded ${fr["yoshimura:max_strain"]}), largest edge error ${worst.toExponential(2)}`);
  }
  check(fr.edges_foldAngle.every((a, i) =>
      fr.edges_assignment[i] === "B" ? a === 0 :
      fr.edges_assignment[i] === "M" ? a < 0 :
      fr.edges_assignment[i] === "V" ? a > 0 : Math.abs(a) <= 1e-6),
    `frame '${fr.frame_title}': fold angle signs match M/V/F`);
}
console.log(failed === 0 ? "check_fold: all checks passed" : `check_fold: ${failed} checks FAILED`);
process.exit(failed === 0 ? 0 : 1);
