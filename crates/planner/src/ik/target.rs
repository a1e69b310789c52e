//! Target curves: a polyline in units of the valley fold length l, from a CSV file or a generator,
//! with fast exact point-to-polyline distances and cheap lower bounds on them.

use std::f64::consts::PI;

use nalgebra::{Point3, Vector3};

use super::IkError;

/// A target curve: a polyline through at least one point (units of l).
///
/// Distances are to the polyline's *segments*, not only its vertices (eq 36 with the nearest
/// point on the curve). A one-point target is a point.
#[derive(Debug, Clone)]
pub struct Target {
    points: Vec<Point3<f64>>,
    segs: Vec<Segment>,
    /// Bounding-volume hierarchy over consecutive segment ranges (a polyline is spatially coherent
    /// along its index, so halving the index range gives a good tree).
    nodes: Vec<BvhNode>,
    /// Cumulative arc length at each vertex.
    arc: Vec<f64>,
    lb: LowerBoundGrid,
    /// A finer grid ([`FINE_CELLS`] cells) for [`Target::dist_lower_bound_fine`], built on
    /// demand by [`Target::prepare_fine_bounds`].
    fine: std::sync::OnceLock<LowerBoundGrid>,
    /// Per-cell candidate segments over the lower-bound grid, built on demand by
    /// [`Target::prepare_fast_queries`] for solvers that query billions of points.
    cells: std::sync::OnceLock<CellLists>,
}

/// For each cell of the lower-bound grid, every segment that can be nearest to some point of
/// the cell: with c the cell centre, h its half-diagonal and D = dist(c, C), the nearest
/// segment s* of any point p of the cell satisfies dist(c, s*) ≤ dist(p, s*) + h ≤ D + 2h.
#[derive(Debug, Clone)]
struct CellLists {
    origin: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    index: Vec<u32>,
}

/// Cell lists use a grid this many times finer (per axis) than the lower-bound grid (2 was
/// tried: no clear gain on a loaded machine, 8× the build time).
const CELL_REFINE: usize = 1;

#[derive(Debug, Clone, Copy)]
struct Segment {
    a: Vector3<f64>,
    d: Vector3<f64>,
    inv_len2: f64,
}

impl Segment {
    #[inline]
    fn dist2(&self, p: &Vector3<f64>) -> f64 {
        let ap = p - self.a;
        let t = (ap.dot(&self.d) * self.inv_len2).clamp(0.0, 1.0);
        (ap - self.d * t).norm_squared()
    }
}

#[derive(Debug, Clone, Copy)]
struct BvhNode {
    min: Vector3<f64>,
    max: Vector3<f64>,
    /// Leaf: segment range `[lo, hi)`; inner: children at `lo` and `hi` (node indices).
    lo: u32,
    hi: u32,
    leaf: bool,
}

#[inline]
fn box_dist2(min: &Vector3<f64>, max: &Vector3<f64>, p: &Vector3<f64>) -> f64 {
    let mut s = 0.0;
    for k in 0..3 {
        let v = if p[k] < min[k] {
            min[k] - p[k]
        } else if p[k] > max[k] {
            p[k] - max[k]
        } else {
            0.0
        };
        s += v * v;
    }
    s
}

/// A grid of exact distances at cell centres; by the 1-Lipschitz property of the distance
/// function, `dist(x) ≥ D(c) − |x − c|` for the centre `c` of the cell holding `x`. Outside the
/// grid the distance to the curve's bounding box is the bound.
#[derive(Debug, Clone)]
struct LowerBoundGrid {
    origin: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    dist: Vec<f64>,
    curve_min: Vector3<f64>,
    curve_max: Vector3<f64>,
}

const LEAF_SIZE: usize = 4;

/// Cells of the lower-bound grid every target has (40³).
const COARSE_CELLS: f64 = 40.0 * 40.0 * 40.0;

/// Cells of the fine lower-bound grid (100³, 8 MB, ≈ 0.1 s to build on two cores): its
/// half-diagonal is 2.5× smaller, and so is the bound's slack.
pub const FINE_CELLS: f64 = 100.0 * 100.0 * 100.0;

/// Largest coordinate magnitude a target point may have, in units of l (a million fold
/// lengths: far beyond any boom of the accepted 10 000 modules, and small enough that every
/// squared distance and sum stays finite).
pub const MAX_COORDINATE: f64 = 1e6;

impl Target {
    /// A target through `points` (at least one, all finite, every coordinate within
    /// ±[`MAX_COORDINATE`]).
    pub fn new(points: Vec<Point3<f64>>) -> Result<Self, IkError> {
        if points.is_empty() {
            return Err(IkError::EmptyTarget);
        }
        for (index, p) in points.iter().enumerate() {
            if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                return Err(IkError::NonFinite {
                    index,
                    x: p.x,
                    y: p.y,
                    z: p.z,
                });
            }
            if p.coords.amax() > MAX_COORDINATE {
                return Err(IkError::TooFar {
                    index,
                    x: p.x,
                    y: p.y,
                    z: p.z,
                });
            }
        }
        let mut segs: Vec<Segment> = points
            .windows(2)
            .map(|w| {
                let d = w[1] - w[0];
                let l2 = d.norm_squared();
                Segment {
                    a: w[0].coords,
                    d,
                    inv_len2: if l2 > 0.0 { 1.0 / l2 } else { 0.0 },
                }
            })
            .collect();
        if segs.is_empty() {
            // One point: a degenerate segment.
            segs.push(Segment {
                a: points[0].coords,
                d: Vector3::zeros(),
                inv_len2: 0.0,
            });
        }
        let mut arc = Vec::with_capacity(points.len());
        let mut acc = 0.0;
        arc.push(0.0);
        for w in points.windows(2) {
            acc += (w[1] - w[0]).norm();
            arc.push(acc);
        }
        let mut nodes = Vec::new();
        build_bvh(&segs, 0, segs.len(), &mut nodes);
        let mut target = Target {
            points,
            segs,
            nodes,
            arc,
            lb: LowerBoundGrid {
                origin: Vector3::zeros(),
                cell: 1.0,
                dims: [0; 3],
                dist: Vec::new(),
                curve_min: Vector3::zeros(),
                curve_max: Vector3::zeros(),
            },
            cells: std::sync::OnceLock::new(),
            fine: std::sync::OnceLock::new(),
        };
        target.lb = target.build_lb_grid(COARSE_CELLS);
        Ok(target)
    }

    /// The polyline's vertices.
    pub fn points(&self) -> &[Point3<f64>] {
        &self.points
    }

    /// Total arc length.
    pub fn length(&self) -> f64 {
        *self.arc.last().unwrap_or(&0.0)
    }

    /// The point at arc length `s` (clamped to `[0, length]`).
    pub fn point_at_arc_length(&self, s: f64) -> Point3<f64> {
        let s = s.clamp(0.0, self.length());
        // First vertex whose cumulative arc length reaches s.
        let i = self.arc.partition_point(|&a| a < s);
        if i == 0 {
            return self.points[0];
        }
        if i >= self.points.len() {
            return self.points[self.points.len() - 1];
        }
        let (s0, s1) = (self.arc[i - 1], self.arc[i]);
        let t = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.0 };
        self.points[i - 1] + (self.points[i] - self.points[i - 1]) * t
    }

    /// Builds per-cell candidate lists so that [`dist2`](Self::dist2) inside the grid scans a
    /// few segments instead of walking the tree (worth it beyond ~10⁶ queries; idempotent).
    pub fn prepare_fast_queries(&self) {
        self.cells.get_or_init(|| self.build_cells());
    }

    fn build_cells(&self) -> CellLists {
        use rayon::prelude::*;
        let lb = &self.lb;
        let cell = lb.cell / CELL_REFINE as f64;
        let dims = lb.dims.map(|d| d * CELL_REFINE);
        let origin = lb.origin;
        let h = 0.5 * cell * 3f64.sqrt();
        let n = dims[0] * dims[1] * dims[2];
        let lists: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map(|c| {
                let k = c % dims[2];
                let j = (c / dims[2]) % dims[1];
                let i = c / (dims[1] * dims[2]);
                let centre =
                    origin + Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * cell;
                let d = self.dist(&Point3::from(centre));
                let r = (d + 2.0 * h) * (1.0 + 1e-9) + 1e-9;
                self.segments_within(&centre, r * r)
            })
            .collect();
        let mut start = Vec::with_capacity(n + 1);
        let mut index = Vec::new();
        for l in lists {
            start.push(index.len() as u32);
            index.extend(l);
        }
        start.push(index.len() as u32);
        CellLists {
            origin,
            cell,
            dims,
            start,
            index,
        }
    }

    /// Indices of the segments within squared distance `r2` of `p`.
    fn segments_within(&self, p: &Vector3<f64>, r2: f64) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if box_dist2(&node.min, &node.max, p) > r2 {
                continue;
            }
            if node.leaf {
                for s in node.lo..node.hi {
                    if self.segs[s as usize].dist2(p) <= r2 {
                        out.push(s);
                    }
                }
            } else {
                stack.push(node.lo);
                stack.push(node.hi);
            }
        }
        out
    }

    /// Squared distance from `p` to the nearest point of the polyline (exact).
    #[inline]
    pub fn dist2(&self, p: &Point3<f64>) -> f64 {
        if let Some(cells) = self.cells.get() {
            let g = cells;
            let rel = (p.coords - g.origin) / g.cell;
            if rel.x >= 0.0
                && rel.y >= 0.0
                && rel.z >= 0.0
                && (rel.x as usize) < g.dims[0]
                && (rel.y as usize) < g.dims[1]
                && (rel.z as usize) < g.dims[2]
            {
                let c =
                    ((rel.x as usize) * g.dims[1] + rel.y as usize) * g.dims[2] + rel.z as usize;
                let (lo, hi) = (cells.start[c] as usize, cells.start[c + 1] as usize);
                let mut best = f64::INFINITY;
                for &s in &cells.index[lo..hi] {
                    let d = self.segs[s as usize].dist2(&p.coords);
                    if d < best {
                        best = d;
                    }
                }
                return best;
            }
        }
        self.dist2_tree(p)
    }

    fn dist2_tree(&self, p: &Point3<f64>) -> f64 {
        let p = p.coords;
        let mut best = f64::INFINITY;
        let mut stack = [0u32; 64];
        let mut sp = 1usize;
        stack[0] = 0;
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if box_dist2(&node.min, &node.max, &p) >= best {
                continue;
            }
            if node.leaf {
                for s in &self.segs[node.lo as usize..node.hi as usize] {
                    let d = s.dist2(&p);
                    if d < best {
                        best = d;
                    }
                }
            } else {
                let (a, b) = (node.lo as usize, node.hi as usize);
                let da = box_dist2(&self.nodes[a].min, &self.nodes[a].max, &p);
                let db = box_dist2(&self.nodes[b].min, &self.nodes[b].max, &p);
                // Push the farther child first so the nearer one is explored first.
                let (near, far, dfar) = if da <= db { (a, b, db) } else { (b, a, da) };
                if dfar < best {
                    stack[sp] = far as u32;
                    sp += 1;
                }
                stack[sp] = near as u32;
                sp += 1;
            }
        }
        best
    }

    /// The nearest point of the polyline to `p` (linear scan; for reporting, not for search).
    pub fn nearest_point(&self, p: &Point3<f64>) -> Point3<f64> {
        let mut best = (f64::INFINITY, *p);
        for s in &self.segs {
            let ap = p.coords - s.a;
            let t = (ap.dot(&s.d) * s.inv_len2).clamp(0.0, 1.0);
            let q = s.a + s.d * t;
            let d = (p.coords - q).norm_squared();
            if d < best.0 {
                best = (d, Point3::from(q));
            }
        }
        best.1
    }

    /// Distance from `p` to the polyline (exact).
    pub fn dist(&self, p: &Point3<f64>) -> f64 {
        self.dist2(p).sqrt()
    }

    /// A cheap lower bound on the distance from any point within `radius` of `center` to the
    /// polyline (never more than the true minimum; 0 when it cannot tell).
    #[inline(always)]
    pub fn dist_lower_bound(&self, center: &Point3<f64>, radius: f64) -> f64 {
        grid_lower_bound(&self.lb, center, radius)
    }

    /// Like [`dist_lower_bound`](Self::dist_lower_bound), on the fine grid once
    /// [`prepare_fine_bounds`](Self::prepare_fine_bounds) has built it (the coarse one before).
    #[inline(always)]
    pub fn dist_lower_bound_fine(&self, center: &Point3<f64>, radius: f64) -> f64 {
        grid_lower_bound(self.fine.get().unwrap_or(&self.lb), center, radius)
    }

    /// Builds the fine lower-bound grid (once; later calls return at once).
    pub fn prepare_fine_bounds(&self) {
        self.fine.get_or_init(|| self.build_lb_grid(FINE_CELLS));
    }

    fn build_lb_grid(&self, max_cells: f64) -> LowerBoundGrid {
        let root = &self.nodes[0];
        let extent = (root.max - root.min).max();
        let margin = extent.max(1.0) * 0.5 + 2.0;
        let origin = root.min - Vector3::repeat(margin);
        let size = root.max - root.min + Vector3::repeat(2.0 * margin);
        let cell = (size.x * size.y * size.z / max_cells).cbrt().max(1e-6);
        let dims = [
            (size.x / cell).ceil() as usize,
            (size.y / cell).ceil() as usize,
            (size.z / cell).ceil() as usize,
        ];
        use rayon::prelude::*;
        let dist: Vec<f64> = (0..dims[0])
            .into_par_iter()
            .flat_map_iter(|i| {
                (0..dims[1]).flat_map(move |j| {
                    (0..dims[2]).map(move |k| {
                        let c = origin
                            + Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * cell;
                        // Shave a rounding margin so the bound stays a bound.
                        self.dist(&Point3::from(c)) * (1.0 - 1e-12) - 1e-12
                    })
                })
            })
            .collect();
        LowerBoundGrid {
            origin,
            cell,
            dims,
            dist,
            curve_min: root.min,
            curve_max: root.max,
        }
    }
}

/// The grid bound of [`Target::dist_lower_bound`] on grid `g`.
#[inline(always)]
fn grid_lower_bound(g: &LowerBoundGrid, center: &Point3<f64>, radius: f64) -> f64 {
    let x = center.coords;
    let rel = (x - g.origin) / g.cell;
    // Truncation is floor for the non-negative coordinates inside the grid (and avoids a
    // libm call).
    let d = if rel.x >= 0.0
        && rel.y >= 0.0
        && rel.z >= 0.0
        && (rel.x as usize) < g.dims[0]
        && (rel.y as usize) < g.dims[1]
        && (rel.z as usize) < g.dims[2]
    {
        let (i, j, k) = (rel.x as usize, rel.y as usize, rel.z as usize);
        let c = g.origin + Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * g.cell;
        g.dist[(i * g.dims[1] + j) * g.dims[2] + k] - (x - c).norm()
    } else {
        box_dist2(&g.curve_min, &g.curve_max, &x).sqrt()
    };
    (d - radius).max(0.0)
}

fn build_bvh(segs: &[Segment], lo: usize, hi: usize, nodes: &mut Vec<BvhNode>) -> usize {
    let mut min = Vector3::repeat(f64::INFINITY);
    let mut max = Vector3::repeat(f64::NEG_INFINITY);
    for s in &segs[lo..hi] {
        let b = s.a + s.d;
        min = min.inf(&s.a).inf(&b);
        max = max.sup(&s.a).sup(&b);
    }
    let index = nodes.len();
    nodes.push(BvhNode {
        min,
        max,
        lo: lo as u32,
        hi: hi as u32,
        leaf: true,
    });
    if hi - lo > LEAF_SIZE {
        let mid = lo + (hi - lo) / 2;
        let a = build_bvh(segs, lo, mid, nodes);
        let b = build_bvh(segs, mid, hi, nodes);
        nodes[index].lo = a as u32;
        nodes[index].hi = b as u32;
        nodes[index].leaf = false;
    }
    index
}

/// Parses a target polyline from CSV text: one `x,y,z` row per point (units of l), an optional
/// header row, blank lines and `#` comments ignored.
pub fn parse_csv(text: &str) -> Result<Target, IkError> {
    let mut points = Vec::new();
    let mut seen_data = false;
    for (idx, raw) in text.lines().enumerate() {
        let line_no = idx + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed: Vec<Option<f64>> = fields.iter().map(|f| f.parse::<f64>().ok()).collect();
        if !seen_data && parsed.iter().all(Option::is_none) {
            // A header row (e.g. `x,y,z`): only allowed before the first data row.
            seen_data = true;
            continue;
        }
        seen_data = true;
        if fields.len() != 3 {
            return Err(IkError::Csv {
                line: line_no,
                message: format!(
                    "expected 3 comma-separated numbers `x,y,z`, found {} field(s): `{line}`",
                    fields.len()
                ),
            });
        }
        let mut xyz = [0.0; 3];
        for (k, (f, v)) in fields.iter().zip(&parsed).enumerate() {
            match v {
                Some(v) if v.is_finite() => xyz[k] = *v,
                Some(_) => {
                    return Err(IkError::Csv {
                        line: line_no,
                        message: format!(
                            "{} = `{f}` is not a finite number; coordinates must be finite",
                            ["x", "y", "z"][k]
                        ),
                    })
                }
                None => {
                    return Err(IkError::Csv {
                        line: line_no,
                        message: format!(
                            "{} = `{f}` is not a number; expected `x,y,z` with decimal numbers",
                            ["x", "y", "z"][k]
                        ),
                    })
                }
            }
        }
        points.push(Point3::new(xyz[0], xyz[1], xyz[2]));
    }
    if points.is_empty() {
        return Err(IkError::EmptyTarget);
    }
    Target::new(points)
}

/// A named parameter of a target generator.
#[derive(Debug, Clone, Copy)]
pub struct GeneratorParam {
    /// Name, as written in `key=value`.
    pub name: &'static str,
    /// Value when omitted.
    pub default: f64,
    /// What it means.
    pub meaning: &'static str,
}

/// A built-in target generator.
#[derive(Debug, Clone, Copy)]
pub struct Generator {
    /// Name, as written before the `:`.
    pub name: &'static str,
    /// Its parameters.
    pub params: &'static [GeneratorParam],
    /// The curve it draws.
    pub formula: &'static str,
}

const fn param(name: &'static str, default: f64, meaning: &'static str) -> GeneratorParam {
    GeneratorParam {
        name,
        default,
        meaning,
    }
}

/// The built-in target generators and their named parameters (units of l, degrees for angles).
pub const GENERATORS: &[Generator] = &[
    Generator {
        name: "helix",
        params: &[
            param("radius", 1.0, "radius of the helix"),
            param("pitch", 4.0, "rise per turn along +z"),
            param("turns", 1.0, "number of turns"),
            param("samples", 64.0, "polyline points per turn"),
        ],
        formula: "x = R(cos t − 1), y = R sin t, z = pitch·t/2π, t ∈ [0, 2π·turns]: starts at the origin, axis parallel to +z",
    },
    Generator {
        name: "sine",
        params: &[
            param("amplitude", 1.0, "lateral amplitude along x"),
            param("wavelength", 4.0, "period along z"),
            param("length", 5.0, "height of the curve along z"),
            param("samples", 200.0, "polyline points"),
        ],
        formula: "x = amplitude·sin(2π z / wavelength), y = 0, z ∈ [0, length]",
    },
    Generator {
        name: "arc",
        params: &[
            param("radius", 3.0, "radius of the circular arc"),
            param("angle", 90.0, "swept angle in degrees, 0 < angle ≤ 360"),
            param("samples", 128.0, "polyline points"),
        ],
        formula: "x = R(1 − cos φ), y = 0, z = R sin φ, φ ∈ [0, angle]: starts at the origin tangent to +z, bends toward +x",
    },
];

/// Text listing every generator with its parameters and defaults (for `--help` and errors).
pub fn generators_help() -> String {
    let mut s = String::new();
    for g in GENERATORS {
        let ps: Vec<String> = g
            .params
            .iter()
            .map(|p| format!("{}={}", p.name, p.default))
            .collect();
        s.push_str(&format!("{}:{}\n    {}\n", g.name, ps.join(","), g.formula));
        for p in g.params {
            s.push_str(&format!(
                "    {}: {} (default {})\n",
                p.name, p.meaning, p.default
            ));
        }
    }
    s
}

/// Most polyline points a generator may produce (a typo such as `turns=1e9` is refused, not
/// allocated).
const MAX_GENERATED_POINTS: f64 = 1_000_000.0;

/// Builds a target from a generator spec `name:key=value,key=value,…` (e.g.
/// `helix:radius=1,pitch=4,turns=1.5`); omitted parameters take their defaults (see
/// [`GENERATORS`]).
pub fn generate(spec: &str) -> Result<Target, IkError> {
    let (name, rest) = match spec.split_once(':') {
        Some((n, r)) => (n.trim(), r.trim()),
        None => (spec.trim(), ""),
    };
    let Some(generator) = GENERATORS.iter().find(|g| g.name == name) else {
        let names: Vec<&str> = GENERATORS.iter().map(|g| g.name).collect();
        return Err(IkError::Generator(format!(
            "unknown target generator `{name}`; valid generators are {} (e.g. `helix:radius=1,pitch=4,turns=1`)",
            names.join(", ")
        )));
    };
    let mut values: Vec<f64> = generator.params.iter().map(|p| p.default).collect();
    let valid: Vec<&str> = generator.params.iter().map(|p| p.name).collect();
    if !rest.is_empty() {
        for kv in rest.split(',') {
            let kv = kv.trim();
            let Some((k, v)) = kv.split_once('=') else {
                return Err(IkError::Generator(format!(
                    "`{kv}` in `{spec}` is not `key=value`; {name} takes {}",
                    valid.join(", ")
                )));
            };
            let (k, v) = (k.trim(), v.trim());
            let Some(i) = valid.iter().position(|p| *p == k) else {
                return Err(IkError::Generator(format!(
                    "unknown parameter `{k}` for generator {name}; valid parameters are {}",
                    valid.join(", ")
                )));
            };
            let value: f64 = v
                .parse()
                .ok()
                .filter(|x: &f64| x.is_finite())
                .ok_or_else(|| {
                    IkError::Generator(format!(
                        "{name} parameter {k} = `{v}` is not a finite number"
                    ))
                })?;
            values[i] = value;
        }
    }
    let get = |k: &str| values[valid.iter().position(|p| *p == k).unwrap_or(0)];
    let positive = |k: &str| -> Result<f64, IkError> {
        let v = get(k);
        if v > 0.0 {
            Ok(v)
        } else {
            Err(IkError::Generator(format!(
                "{name} parameter {k} must be > 0 (got {v})"
            )))
        }
    };
    let samples = |k: &str, v: f64| -> Result<usize, IkError> {
        if (2.0..=MAX_GENERATED_POINTS).contains(&v) {
            Ok(v.round() as usize)
        } else {
            Err(IkError::Generator(format!(
                "{name} parameter {k} must be between 2 and 1e6 (got {v})"
            )))
        }
    };
    let points: Vec<Point3<f64>> = match name {
        "helix" => {
            let (r, p, turns) = (positive("radius")?, get("pitch"), positive("turns")?);
            let per_turn = samples("samples", get("samples"))?;
            let total = (per_turn as f64 * turns).ceil();
            if total > MAX_GENERATED_POINTS {
                return Err(IkError::Generator(format!(
                    "helix samples × turns must be at most {MAX_GENERATED_POINTS} points (got {total})"
                )));
            }
            let count = (total as usize).max(2);
            (0..=count)
                .map(|i| {
                    let t = 2.0 * PI * turns * i as f64 / count as f64;
                    Point3::new(r * (t.cos() - 1.0), r * t.sin(), p * t / (2.0 * PI))
                })
                .collect()
        }
        "sine" => {
            let (a, wl, len) = (
                get("amplitude"),
                positive("wavelength")?,
                positive("length")?,
            );
            let count = samples("samples", get("samples"))?;
            (0..=count)
                .map(|i| {
                    let z = len * i as f64 / count as f64;
                    Point3::new(a * (2.0 * PI * z / wl).sin(), 0.0, z)
                })
                .collect()
        }
        "arc" => {
            let r = positive("radius")?;
            let angle = get("angle");
            if !(angle > 0.0 && angle <= 360.0) {
                return Err(IkError::Generator(format!(
                    "arc parameter angle must be in (0, 360] degrees (got {angle})"
                )));
            }
            let count = samples("samples", get("samples"))?;
            (0..=count)
                .map(|i| {
                    let phi = angle.to_radians() * i as f64 / count as f64;
                    Point3::new(r * (1.0 - phi.cos()), 0.0, r * phi.sin())
                })
                .collect()
        }
        _ => unreachable!("generator names are checked above"),
    };
    Target::new(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(t: &Target, p: &Point3<f64>) -> f64 {
        t.segs
            .iter()
            .map(|s| s.dist2(&p.coords))
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn bvh_distance_matches_brute_force() {
        let t = generate("helix:radius=2,pitch=3,turns=2.5").unwrap();
        let mut x = 0.123_f64;
        for _ in 0..2000 {
            x = (x * 9301.0 + 49297.0) % 233280.0;
            let p = Point3::new((x % 17.0) - 8.0, (x % 13.0) - 6.0, (x % 19.0) - 4.0);
            let (a, b) = (t.dist2(&p), brute(&t, &p));
            assert!((a - b).abs() <= 1e-12 * (1.0 + b), "{a} vs {b}");
            let lb = t.dist_lower_bound(&p, 0.0);
            assert!(lb <= b.sqrt() + 1e-12);
        }
    }

    #[test]
    fn cell_lists_match_brute_force() {
        for spec in [
            "helix:radius=1,pitch=3,turns=2.5",
            "sine",
            "arc:radius=2,angle=300",
        ] {
            let t = generate(spec).unwrap();
            t.prepare_fast_queries();
            let mut x = 0.77_f64;
            for _ in 0..3000 {
                x = (x * 9301.0 + 49297.0) % 233280.0;
                let p = Point3::new((x % 11.0) - 5.0, (x % 7.0) - 3.0, (x % 13.0) - 3.0);
                let (a, b) = (t.dist2(&p), brute(&t, &p));
                assert!(
                    (a - b).abs() <= 1e-12 * (1.0 + b),
                    "{spec} {p:?}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn distance_is_to_segments_not_vertices() {
        let t = Target::new(vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.0, 0.0, 10.0),
        ])
        .unwrap();
        assert!((t.dist(&Point3::new(1.0, 0.0, 5.0)) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn csv_reports_line_numbers() {
        assert!(matches!(parse_csv(""), Err(IkError::EmptyTarget)));
        assert!(matches!(parse_csv("x,y,z\n"), Err(IkError::EmptyTarget)));
        assert!(parse_csv("x,y,z\n0,0,0\n1,2,3\n").is_ok());
        assert!(matches!(
            parse_csv("0,0,0\n1,2\n"),
            Err(IkError::Csv { line: 2, .. })
        ));
        assert!(matches!(
            parse_csv("0,0,0\n\n1,nan,2\n"),
            Err(IkError::Csv { line: 3, .. })
        ));
        assert!(matches!(
            parse_csv("0,0,0\n1,a,2\n"),
            Err(IkError::Csv { line: 2, .. })
        ));
    }

    #[test]
    fn generators_validate_parameters() {
        assert!(generate("helix").is_ok());
        assert!(generate("sine:amplitude=1,wavelength=4,length=8").is_ok());
        assert!(generate("arc:radius=3,angle=180").is_ok());
        assert!(generate("helix:radius=2,bogus=1").is_err());
        assert!(generate("spiral").is_err());
        assert!(generate("helix:radius=-1").is_err());
        assert!(generate("helix:radius=nan").is_err());
    }

    #[test]
    fn a_generator_refuses_an_absurd_point_count() {
        let err = generate("helix:radius=1,pitch=1,turns=1e9").unwrap_err();
        assert!(err.to_string().contains("at most 1000000 points"), "{err}");
        assert!(generate("helix:radius=1,pitch=1,turns=1000,samples=1000").is_ok());
    }

    #[test]
    fn arc_length_points() {
        let t = Target::new(vec![
            Point3::origin(),
            Point3::new(0.0, 0.0, 2.0),
            Point3::new(2.0, 0.0, 2.0),
        ])
        .unwrap();
        assert_eq!(t.length(), 4.0);
        assert_eq!(t.point_at_arc_length(3.0), Point3::new(1.0, 0.0, 2.0));
    }
}
