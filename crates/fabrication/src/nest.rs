//! Cut sheets for the meter-scale kit (paper §7.1): every facet laid on real sheet sizes, with
//! the insert holes of its hinges, its id and the ids of its neighbours.
//!
//! # The facets
//!
//! The kit's facets ([`crate::kit`]) are whole isosceles triangles, base l (a valley fold), legs
//! a (mountain folds). Each is drawn in its **local frame**: base from (−l/2, 0) to (l/2, 0),
//! apex at (0, h), h = w·l/2 — counter-clockwise, the outside of the trunk facing +z. Edge 0 is
//! the base, edge 1 the right leg (base end → apex), edge 2 the left leg (apex → base start).
//! [`kit_facets`] gives each facet its place in the flat pattern (x unwrapped, column 0's
//! rhombus halves reach x < 0) and its neighbour across every edge.
//!
//! Ids are `{layer}{kind}{column}`, layer and column from 1, kind `A` (inner triangle, base on
//! the layer's bottom row, apex up), `V` (inner triangle, base on the top row), `L` (lower half
//! of a rhombus, base on the mid valley fold, apex at B_j), `U` (upper half of a rhombus).
//!
//! # Holes
//!
//! A hinge ([`crate::kit`] places them) bridges one crease with two leaves; each leaf takes two
//! M4 screws into heat-set inserts in its facet (Fig. 6a's inset). The insert holes of a hinge
//! are at ±[`SCREW_PITCH_MM`]/2 along the crease from its centre, [`SCREW_INSET_MM`] into each
//! facet. Every hole must keep [`MIN_WALL_MM`] of material to every edge and to every other hole,
//! or the kit is refused (the facets are too small for M4 hinges).
//!
//! # Layout
//!
//! Cut paths are the facet outlines offset outward by half the kerf (for a triangle, the
//! mitred offset is the triangle scaled about its incentre), hole paths inward by half the
//! kerf, so the parts come out true to size. Parts lie in rows, alternately apex up and apex
//! down, with at least `spacing` of material between neighbouring cut paths (legs are parallel,
//! so the pitch along a row is b′/2 + spacing / sin β); a row holds one module's facets. Rows are
//! packed onto sheets first-fit by decreasing height, inside the margin, in whichever of the
//! sheet's two orientations needs fewer sheets (on a tie, the one leaving the last sheet
//! emptier). The area bound is ⌈Σ cut area / usable sheet
//! area⌉: no layout of these parts can use fewer sheets.

use crate::kit::{MOUNTAIN_FRACTIONS, VALLEY_FRACTIONS};
use crate::trunk::{FabError, Trunk};

/// Distance between the two screws of one hinge leaf, along the crease, mm.
pub const SCREW_PITCH_MM: f64 = 24.0;
/// Distance of the screws (and the insert holes) from the crease, into the facet, mm.
pub const SCREW_INSET_MM: f64 = 12.0;
/// Least material between a hole and a facet's edge or another hole, mm.
pub const MIN_WALL_MM: f64 = 2.0;
/// Default pilot hole of an M4 heat-set insert, mm (a common size; use your insert's datasheet).
pub const INSERT_HOLE_MM: f64 = 5.6;

/// Which triangle of a layer a facet is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FacetKind {
    /// Inner triangle, base on the layer's bottom row (apex up in the pattern).
    InnerBottom,
    /// Inner triangle, base on the layer's top row.
    InnerTop,
    /// Lower half of the rhombus of column j (base on the mid valley fold).
    RhombusLower,
    /// Upper half of the rhombus of column j.
    RhombusUpper,
}

impl FacetKind {
    fn letter(self) -> char {
        match self {
            FacetKind::InnerBottom => 'A',
            FacetKind::InnerTop => 'V',
            FacetKind::RhombusLower => 'L',
            FacetKind::RhombusUpper => 'U',
        }
    }
}

/// One facet of the kit, in the flat pattern.
#[derive(Debug, Clone, PartialEq)]
pub struct KitFacet {
    /// The id written on it, e.g. `1A2`.
    pub id: String,
    /// Layer (bottom first, from 0).
    pub layer: usize,
    /// Module (bottom first, from 0).
    pub module: usize,
    /// Which triangle.
    pub kind: FacetKind,
    /// Column (from 0).
    pub column: usize,
    /// Base start, base end, apex in the flat pattern, mm (counter-clockwise).
    pub corners_mm: [[f64; 2]; 3],
    /// The neighbour's id across the base, the right leg and the left leg (`None`: the trunk's
    /// top or bottom edge, no hinge).
    pub neighbours: [Option<String>; 3],
    /// Base length l, height h, mm.
    pub base_mm: f64,
    /// Height, mm.
    pub height_mm: f64,
    /// β of its module, radians (the base angles).
    pub beta_rad: f64,
}

fn facet_id(layer: usize, kind: FacetKind, column: usize) -> String {
    format!("{}{}{}", layer + 1, kind.letter(), column + 1)
}

/// Every facet of the kit of `trunk` (closed cylinder, no seam), layer by layer.
pub fn kit_facets(trunk: &Trunk) -> Vec<KitFacet> {
    let l = trunk.edge_mm();
    let n = trunk.n() as usize;
    let layers = trunk.layers();
    let count = layers.len();
    let mut out = Vec::with_capacity(4 * n * count);
    let mut y0 = 0.0;
    for (layer, &(module, d)) in layers.iter().enumerate() {
        let w = d.w() * l;
        let (ylo, ymid, yhi) = (y0, y0 + 0.5 * w, y0 + w);
        let b = |j: usize| [j as f64 * l, ylo];
        let t = |j: usize| [j as f64 * l, yhi];
        // P_i for any integer i (i = −1 is P_{n−1} one turn to the left).
        let p = |i: i64| [(i as f64 + 0.5) * l, ymid];
        let prev = |j: usize| (j + n - 1) % n;
        let next = |j: usize| (j + 1) % n;
        let id = |k, j| Some(facet_id(layer, k, j));
        let mut push = |kind, column, corners, neighbours| {
            out.push(KitFacet {
                id: facet_id(layer, kind, column),
                layer,
                module,
                kind,
                column,
                corners_mm: corners,
                neighbours,
                base_mm: l,
                height_mm: 0.5 * w,
                beta_rad: d.beta(),
            })
        };
        for i in 0..n {
            let below = (layer > 0).then(|| facet_id(layer - 1, FacetKind::InnerTop, i));
            let above = (layer + 1 < count).then(|| facet_id(layer + 1, FacetKind::InnerBottom, i));
            push(
                FacetKind::InnerBottom,
                i,
                [b(i), b(i + 1), p(i as i64)],
                [
                    below,
                    id(FacetKind::RhombusLower, next(i)),
                    id(FacetKind::RhombusLower, i),
                ],
            );
            push(
                FacetKind::InnerTop,
                i,
                [t(i + 1), t(i), p(i as i64)],
                [
                    above,
                    id(FacetKind::RhombusUpper, i),
                    id(FacetKind::RhombusUpper, next(i)),
                ],
            );
        }
        for j in 0..n {
            let (pl, pr) = (p(j as i64 - 1), p(j as i64));
            push(
                FacetKind::RhombusLower,
                j,
                [pr, pl, b(j)],
                [
                    id(FacetKind::RhombusUpper, j),
                    id(FacetKind::InnerBottom, prev(j)),
                    id(FacetKind::InnerBottom, j),
                ],
            );
            push(
                FacetKind::RhombusUpper,
                j,
                [pl, pr, t(j)],
                [
                    id(FacetKind::RhombusLower, j),
                    id(FacetKind::InnerTop, j),
                    id(FacetKind::InnerTop, prev(j)),
                ],
            );
        }
        y0 = yhi;
    }
    out
}

/// A hole: centre (mm) and diameter (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hole {
    /// Centre.
    pub at_mm: [f64; 2],
    /// Diameter of the finished hole.
    pub diameter_mm: f64,
    /// Which edge's hinge it belongs to (0 base, 1 right leg, 2 left leg).
    pub edge: usize,
    /// The hinge's centre on that edge, mm.
    pub hinge_mm: [f64; 2],
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}
fn add(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] + b[0], a[1] + b[1]]
}
fn scale(a: [f64; 2], s: f64) -> [f64; 2] {
    [a[0] * s, a[1] * s]
}
fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = sub(b, a);
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    norm(sub(p, add(a, scale(ab, t))))
}

/// A facet's local frame: the three corners (base start, base end, apex).
pub fn local_corners(f: &KitFacet) -> [[f64; 2]; 3] {
    let hb = 0.5 * f.base_mm;
    [[-hb, 0.0], [hb, 0.0], [0.0, f.height_mm]]
}

/// The insert holes of a facet in its local frame: two per hinge on each edge with a
/// neighbour.
pub fn local_holes(f: &KitFacet, diameter_mm: f64) -> Vec<Hole> {
    let c = local_corners(f);
    let mut holes = Vec::new();
    for edge in 0..3 {
        if f.neighbours[edge].is_none() {
            continue;
        }
        let (s, e) = (c[edge], c[(edge + 1) % 3]);
        let d = sub(e, s);
        let len = norm(d);
        let u = scale(d, 1.0 / len);
        let inward = [-u[1], u[0]];
        let fractions: &[f64] = if edge == 0 {
            &VALLEY_FRACTIONS
        } else {
            &MOUNTAIN_FRACTIONS
        };
        for &fr in fractions {
            let hinge = add(s, scale(d, fr));
            for side in [-0.5, 0.5] {
                holes.push(Hole {
                    at_mm: add(
                        add(hinge, scale(u, side * SCREW_PITCH_MM)),
                        scale(inward, SCREW_INSET_MM),
                    ),
                    diameter_mm,
                    edge,
                    hinge_mm: hinge,
                });
            }
        }
    }
    holes
}

/// Checks the holes of a facet keep [`MIN_WALL_MM`] to its edges and to each other.
pub fn check_holes(f: &KitFacet, holes: &[Hole]) -> Result<(), FabError> {
    let c = local_corners(f);
    for h in holes {
        let r = 0.5 * h.diameter_mm;
        for e in 0..3 {
            let d = point_segment_distance(h.at_mm, c[e], c[(e + 1) % 3]) - r;
            // A hole must also be inside: the corners are counter-clockwise.
            let inside = cross(sub(c[(e + 1) % 3], c[e]), sub(h.at_mm, c[e])) > 0.0;
            if !inside || d < MIN_WALL_MM - 1e-9 {
                return Err(FabError::new(format!(
                    "facet {} ({:.1} × {:.1} mm) is too small for the kit's M4 hinges: an insert hole leaves {:.1} mm to an edge, at least {MIN_WALL_MM} mm are needed (screws {SCREW_INSET_MM} mm from the crease, {SCREW_PITCH_MM} mm apart)",
                    f.id,
                    f.base_mm,
                    f.height_mm,
                    if inside { d } else { -d }
                )));
            }
        }
    }
    for (i, a) in holes.iter().enumerate() {
        for b in &holes[i + 1..] {
            let gap = norm(sub(a.at_mm, b.at_mm)) - 0.5 * (a.diameter_mm + b.diameter_mm);
            if gap < MIN_WALL_MM - 1e-9 {
                return Err(FabError::new(format!(
                    "facet {} ({:.1} × {:.1} mm) is too small for the kit's M4 hinges: two insert holes are {gap:.1} mm apart, at least {MIN_WALL_MM} mm are needed",
                    f.id, f.base_mm, f.height_mm
                )));
            }
        }
    }
    Ok(())
}

fn holes_fit(facets: &[KitFacet], hole_mm: f64) -> Result<(), FabError> {
    facets
        .iter()
        .try_for_each(|f| check_holes(f, &local_holes(f, hole_mm)))
}

/// The smallest edge length (mm, to 0.01 mm) at which every insert hole of `trunk`'s kit keeps
/// its walls, or `None` when none up to 10 000 mm does.
pub fn min_edge_mm(trunk: &Trunk, hole_mm: f64) -> Option<f64> {
    let fits = |edge: f64| {
        Trunk::new(trunk.modules().to_vec(), edge)
            .is_ok_and(|t| holes_fit(&kit_facets(&t), hole_mm).is_ok())
    };
    let (mut lo, mut hi) = (0.01, 10_000.0);
    if !fits(hi) {
        return None;
    }
    // The walls only grow with the facets (the holes keep their size), so bisection finds the
    // threshold.
    while hi - lo > 0.01 {
        let mid = 0.5 * (lo + hi);
        if fits(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

impl KitFacet {
    /// Maps a point of the facet's local frame into the flat pattern (mm).
    pub fn to_pattern(&self, p: [f64; 2]) -> [f64; 2] {
        let [s, e, _] = self.corners_mm;
        let d = sub(e, s);
        let u = scale(d, 1.0 / norm(d));
        let v = [-u[1], u[0]];
        let mid = scale(add(s, e), 0.5);
        add(mid, add(scale(u, p[0]), scale(v, p[1])))
    }
}

/// A sheet size and the cutting parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NestParams {
    /// Sheet width and height, mm.
    pub sheet_mm: [f64; 2],
    /// Width of the laser's cut, mm.
    pub kerf_mm: f64,
    /// Clear border of the sheet: no cut path closer to its edge, mm.
    pub margin_mm: f64,
    /// Least material between two parts' cut paths, mm.
    pub spacing_mm: f64,
    /// Finished diameter of the insert holes, mm.
    pub hole_mm: f64,
}

impl NestParams {
    /// Parses `WxH` (mm), e.g. `1220x2440`.
    pub fn parse_sheet(text: &str) -> Result<[f64; 2], FabError> {
        let bad = || {
            FabError::new(format!(
                "a sheet is WIDTHxHEIGHT in mm, each in (0, 100000], e.g. 1220x2440; got '{text}'"
            ))
        };
        let (w, h) = text.trim().split_once(['x', 'X', '×']).ok_or_else(bad)?;
        let parse = |s: &str| -> Result<f64, FabError> {
            let v: f64 = s.trim().parse().map_err(|_| bad())?;
            if v.is_finite() && v > 0.0 && v <= 100_000.0 {
                Ok(v)
            } else {
                Err(bad())
            }
        };
        Ok([parse(w)?, parse(h)?])
    }

    fn validate(&self) -> Result<(), FabError> {
        let [w, h] = self.sheet_mm;
        if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0 && w <= 1e5 && h <= 1e5) {
            return Err(FabError::new(format!(
                "the sheet must be in (0, 100000] mm each way, got {w} × {h}"
            )));
        }
        if !(self.kerf_mm.is_finite() && (0.0..=5.0).contains(&self.kerf_mm)) {
            return Err(FabError::new(format!(
                "--kerf-mm must be in [0, 5] mm, got {}",
                self.kerf_mm
            )));
        }
        if !(self.margin_mm.is_finite() && self.margin_mm >= 0.0 && 2.0 * self.margin_mm < w.min(h))
        {
            return Err(FabError::new(format!(
                "--margin-mm must be ≥ 0 and leave room on the {w} × {h} mm sheet (below {} mm), got {}",
                0.5 * w.min(h),
                self.margin_mm
            )));
        }
        if !(self.spacing_mm.is_finite() && (0.0..=1000.0).contains(&self.spacing_mm)) {
            return Err(FabError::new(format!(
                "--spacing-mm must be in [0, 1000] mm, got {}",
                self.spacing_mm
            )));
        }
        if !(self.hole_mm.is_finite() && self.hole_mm > self.kerf_mm && self.hole_mm <= 20.0) {
            return Err(FabError::new(format!(
                "--insert-hole-mm must be larger than the kerf ({} mm) and at most 20 mm, got {}",
                self.kerf_mm, self.hole_mm
            )));
        }
        Ok(())
    }
}

/// A placement: sheet point = R(quarter turns) · local point + offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Counter-clockwise quarter turns of the local frame (0 … 3).
    pub quarter_turns: u8,
    /// Where the local origin (the base's midpoint) lands, mm.
    pub offset_mm: [f64; 2],
}

impl Placement {
    /// The rotation in degrees.
    pub fn rotation_deg(&self) -> f64 {
        90.0 * f64::from(self.quarter_turns % 4)
    }

    /// Maps a local point onto the sheet (exact: quarter turns only).
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = match self.quarter_turns % 4 {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        };
        [
            c * p[0] - s * p[1] + self.offset_mm[0],
            s * p[0] + c * p[1] + self.offset_mm[1],
        ]
    }
}

/// One part on a sheet.
#[derive(Debug, Clone)]
pub struct Part {
    /// Index into [`Nest::facets`].
    pub facet: usize,
    /// Where it lies.
    pub placement: Placement,
    /// The facet's true outline on the sheet, mm.
    pub outline_mm: [[f64; 2]; 3],
    /// The cut path (outline offset outward by half the kerf), mm.
    pub cut_mm: [[f64; 2]; 3],
    /// Insert holes (centres on the sheet, finished diameter).
    pub holes: Vec<Hole>,
}

/// The cut sheets.
#[derive(Debug, Clone)]
pub struct Nest {
    /// The parameters.
    pub params: NestParams,
    /// Every facet of the kit.
    pub facets: Vec<KitFacet>,
    /// Parts per sheet.
    pub sheets: Vec<Vec<Part>>,
    /// Whether the layout runs along the sheet's height (rows turned a quarter).
    pub turned: bool,
    /// ⌈Σ cut area / usable sheet area⌉.
    pub area_bound: usize,
    /// Σ facet area (true outlines), mm².
    pub facet_area_mm2: f64,
    /// Σ cut area (kerf-offset outlines), mm².
    pub cut_area_mm2: f64,
}

fn triangle_area(c: &[[f64; 2]; 3]) -> f64 {
    0.5 * cross(sub(c[1], c[0]), sub(c[2], c[0]))
}

/// Cut-path geometry of one facet type in its local frame.
struct CutShape {
    /// Cut path corners, local frame.
    cut: [[f64; 2]; 3],
    /// Cut base width b′ and height h′.
    width: f64,
    height: f64,
    /// Row pitch along x between consecutive parts (alternating orientation).
    pitch: f64,
}

fn cut_shape(f: &KitFacet, p: &NestParams) -> CutShape {
    let c = local_corners(f);
    let a = norm(sub(c[2], c[0]));
    let r = f.base_mm * f.height_mm / (f.base_mm + 2.0 * a);
    let s = (r + 0.5 * p.kerf_mm) / r;
    let centre = [0.0, r];
    let cut = c.map(|v| add(centre, scale(sub(v, centre), s)));
    let width = s * f.base_mm;
    CutShape {
        cut,
        width,
        height: s * f.height_mm,
        pitch: 0.5 * width + p.spacing_mm / f.beta_rad.sin(),
    }
}

/// A row: which module's facets and how many.
struct Row {
    module_facets: Vec<usize>,
    height: f64,
}

fn layout(
    facets: &[KitFacet],
    p: &NestParams,
    usable: [f64; 2],
) -> Result<Vec<Vec<(usize, Placement)>>, FabError> {
    // Facet indices by module.
    let modules = facets.iter().map(|f| f.module).max().map_or(0, |m| m + 1);
    let mut rows: Vec<Row> = Vec::new();
    for m in 0..modules {
        let of: Vec<usize> = (0..facets.len())
            .filter(|&i| facets[i].module == m)
            .collect();
        let Some(&first) = of.first() else { continue };
        let shape = cut_shape(&facets[first], p);
        if shape.width > usable[0] + 1e-9 || shape.height > usable[1] + 1e-9 {
            return Err(FabError::new(format!(
                "a {:.1} × {:.1} mm facet (its cut path {:.1} × {:.1} mm) does not fit in the {:.1} × {:.1} mm inside the margins",
                facets[first].base_mm, facets[first].height_mm, shape.width, shape.height, usable[0], usable[1]
            )));
        }
        let per_row = 1 + ((usable[0] - shape.width) / shape.pitch + 1e-9).floor() as usize;
        for chunk in of.chunks(per_row) {
            rows.push(Row {
                module_facets: chunk.to_vec(),
                height: shape.height,
            });
        }
    }
    rows.sort_by(|a, b| b.height.total_cmp(&a.height));
    // First fit: each sheet's used height.
    let mut sheets: Vec<(f64, Vec<(usize, Placement)>)> = Vec::new();
    for row in rows {
        let need = row.height;
        let slot = sheets.iter().position(|(used, _)| {
            let start = if *used > 0.0 {
                used + p.spacing_mm
            } else {
                0.0
            };
            start + need <= usable[1] + 1e-9
        });
        let idx = match slot {
            Some(i) => i,
            None => {
                sheets.push((0.0, Vec::new()));
                sheets.len() - 1
            }
        };
        let (used, parts) = &mut sheets[idx];
        let y = if *used > 0.0 {
            *used + p.spacing_mm
        } else {
            0.0
        };
        let shape = cut_shape(&facets[row.module_facets[0]], p);
        for (k, &fi) in row.module_facets.iter().enumerate() {
            let cx = 0.5 * shape.width + k as f64 * shape.pitch;
            // The cut path's base lies on the row's bottom (apex up) or top (apex down); the
            // local cut base is at y = −kerf/2.
            let placement = if k % 2 == 0 {
                Placement {
                    quarter_turns: 0,
                    offset_mm: [cx, y - shape.cut[0][1]],
                }
            } else {
                Placement {
                    quarter_turns: 2,
                    offset_mm: [cx, y + shape.height + shape.cut[0][1]],
                }
            };
            parts.push((fi, placement));
        }
        *used = y + need;
    }
    Ok(sheets.into_iter().map(|(_, p)| p).collect())
}

impl Nest {
    /// Lays out the kit of `trunk` on sheets.
    pub fn new(trunk: &Trunk, params: NestParams) -> Result<Self, FabError> {
        params.validate()?;
        let facets = kit_facets(trunk);
        if let Err(e) = holes_fit(&facets, params.hole_mm) {
            return Err(match min_edge_mm(trunk, params.hole_mm) {
                Some(min) => FabError::new(format!(
                    "{e}; this trunk's kit needs --edge-mm ≥ {:.1} (the paper's is 609.6)",
                    (min * 10.0).ceil() / 10.0
                )),
                None => e,
            });
        }
        let [w, h] = params.sheet_mm;
        let m = params.margin_mm;
        let usable = [w - 2.0 * m, h - 2.0 * m];
        let along_width = layout(&facets, &params, usable);
        let along_height = layout(&facets, &params, [usable[1], usable[0]]);
        let (sheets, turned) = match (along_width, along_height) {
            (Ok(a), Ok(b)) => {
                // Fewer sheets; on a tie, the emptier last sheet (its offcut is the larger).
                let key =
                    |s: &Vec<Vec<(usize, Placement)>>| (s.len(), s.last().map_or(0, Vec::len));
                if key(&b) < key(&a) {
                    (b, true)
                } else {
                    (a, false)
                }
            }
            (Ok(a), Err(_)) => (a, false),
            (Err(_), Ok(b)) => (b, true),
            (Err(e), Err(_)) => {
                return Err(FabError::new(format!(
                    "{e} of the {w} × {h} mm sheet, either way round"
                )))
            }
        };
        let mut cut_area = 0.0;
        let mut facet_area = 0.0;
        let sheets: Vec<Vec<Part>> = sheets
            .into_iter()
            .map(|parts| {
                parts
                    .into_iter()
                    .map(|(fi, pl)| {
                        let f = &facets[fi];
                        let placement = if turned {
                            // Layout frame (u, v) → sheet (x, y) = (w − v, u): a quarter turn.
                            Placement {
                                quarter_turns: (pl.quarter_turns + 1) % 4,
                                offset_mm: [w - m - pl.offset_mm[1], m + pl.offset_mm[0]],
                            }
                        } else {
                            Placement {
                                quarter_turns: pl.quarter_turns,
                                offset_mm: [m + pl.offset_mm[0], m + pl.offset_mm[1]],
                            }
                        };
                        let shape = cut_shape(f, &params);
                        let outline = local_corners(f).map(|c| placement.apply(c));
                        let cut = shape.cut.map(|c| placement.apply(c));
                        cut_area += triangle_area(&cut);
                        facet_area += triangle_area(&outline);
                        let holes = local_holes(f, params.hole_mm)
                            .into_iter()
                            .map(|h| Hole {
                                at_mm: placement.apply(h.at_mm),
                                hinge_mm: placement.apply(h.hinge_mm),
                                ..h
                            })
                            .collect();
                        Part {
                            facet: fi,
                            placement,
                            outline_mm: outline,
                            cut_mm: cut,
                            holes,
                        }
                    })
                    .collect()
            })
            .collect();
        let area_bound = (cut_area / (usable[0] * usable[1]) - 1e-9).ceil().max(1.0) as usize;
        Ok(Nest {
            params,
            facets,
            sheets,
            turned,
            area_bound,
            facet_area_mm2: facet_area,
            cut_area_mm2: cut_area,
        })
    }

    /// Σ facet area over the area of the sheets used.
    pub fn utilisation(&self) -> f64 {
        let [w, h] = self.params.sheet_mm;
        self.facet_area_mm2 / (self.sheets.len() as f64 * w * h)
    }

    /// Number of parts on all sheets.
    pub fn part_count(&self) -> usize {
        self.sheets.iter().map(Vec::len).sum()
    }

    /// Number of holes on all sheets.
    pub fn hole_count(&self) -> usize {
        self.sheets.iter().flatten().map(|p| p.holes.len()).sum()
    }

    /// The one-line summary, e.g. `48 facets on 2 sheets of 1220 × 2440 mm (area bound 1)`.
    pub fn summary(&self) -> String {
        let [w, h] = self.params.sheet_mm;
        format!(
            "{} facets, {} insert holes on {} sheet{} of {w} × {h} mm (area bound: {} sheet{}; the facets cover {:.1} % of the sheets used)",
            self.part_count(),
            self.hole_count(),
            self.sheets.len(),
            if self.sheets.len() == 1 { "" } else { "s" },
            self.area_bound,
            if self.area_bound == 1 { "" } else { "s" },
            100.0 * self.utilisation()
        )
    }
}
