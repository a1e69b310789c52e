//! Printable parts: the meter-scale kit's hinge leaf (paper §7.1) and the crane's upper
//! (magnetic) cap, lower cap, tendon locator and gripper mount (§6.1, Fig. 5a).
//!
//! # Meshing
//!
//! Every part is a union of extrusions of 2D **cell complexes**. A cell is a star-shaped
//! counter-clockwise polygon, optionally with one circular hole: a hole cell is triangulated as
//! a ring between the hole's polygon and the cell's boundary along rays from the hole's centre,
//! a plain cell as a fan from its centroid. Cells share edges; every cell's boundary carries
//! every vertex any neighbour put on it, so the 2D mesh has no T-junctions. A *layer* extrudes
//! a subset of the cells between two heights, with each hole open (a wall) or filled (a floor):
//! stacked layers make blind pockets. Blocks are welded by position and every pair of
//! coincident, oppositely oriented triangles (the interface between two blocks) is removed;
//! quads are split along the diagonal through their lexicographically smallest corner, so
//! both sides of an interface split alike. What is left is checked by
//! [`Mesh::check_solid`]: closed, consistently oriented, positive volume.
//!
//! Each part also reports its hole centres (from its dimensions, not from the mesh) and the
//! volume computed from its dimensions (π r² for every circle), which the tests compare with
//! the mesh's.

use std::collections::HashMap;
use std::f64::consts::PI;

use crate::bom::{Filament, NYLON, PLA, PLA_CF};
use crate::mesh::Mesh;
use crate::nest::{SCREW_INSET_MM, SCREW_PITCH_MM};
use crate::threemf;
use crate::trunk::{FabError, Trunk};

/// Segments of a full circle (holes and round outlines): the polygon's area is within
/// 0.07 % of the circle's.
pub const CIRCLE_SEGMENTS: usize = 96;

/// M4 clearance hole (ISO 273, medium), mm.
pub const M4_CLEARANCE_MM: f64 = 4.5;
/// M4 button head (ISO 7380) diameter, mm.
pub const M4_HEAD_DIAMETER_MM: f64 = 7.6;
/// M4 button head (ISO 7380) height, mm.
pub const M4_HEAD_HEIGHT_MM: f64 = 2.2;
/// Length of the M4 heat-set insert the kit assumes (a short one), mm; the panel must be at
/// least this thick so the insert sits fully in it.
pub const INSERT_LENGTH_MM: f64 = 5.7;
/// Hinge leaf plate thickness, mm.
pub const LEAF_MM: f64 = 3.0;
/// Hinge pin: a 3 mm steel dowel (or M3 screw); its hole, mm.
pub const PIN_HOLE_MM: f64 = 3.2;
/// Least wall of printed material, mm.
pub const WALL_MM: f64 = 2.0;
/// Running clearance between the two leaves of a hinge, mm.
pub const CLEARANCE_MM: f64 = 0.5;
/// Tendon hole diameter (for up to 1.5 mm braided line), mm.
pub const TENDON_HOLE_MM: f64 = 2.0;
/// Tendon clearance hole in the gripper mount (room for the tendon's knot), mm.
pub const TENDON_KNOT_HOLE_MM: f64 = 5.0;
/// Disc magnet of the upper cap and the gripper mount (6 × 3 mm N52), its pocket, mm.
pub const MAGNET_POCKET_MM: [f64; 2] = [6.2, 3.2];
/// Air-line hole of the lower cap (6 mm OD tube), mm.
pub const AIR_HOLE_MM: f64 = 6.2;
/// Gripper fixing: four M3 clearance holes on this pitch-circle diameter, mm.
pub const GRIPPER_HOLES: (f64, f64) = (3.4, 40.0);
/// Half the radial width of the ring of tendon and magnet holes, mm.
pub const HOLE_RING_HALF_MM: f64 = 5.0;
/// Radial clearance between the trunk's circumcircle and the tendon locator's bore, mm.
pub const LOCATOR_CLEARANCE_MM: f64 = 1.0;
/// Default tendon radius, mm: the firmware's default `tendon_radius_mm`.
pub const DEFAULT_TENDON_RADIUS_MM: f64 = 60.0;
/// Default kit panel thickness, mm (6 mm HDPE sheet; the paper does not give it).
pub const DEFAULT_PANEL_MM: f64 = 6.0;
/// Angles of the three tendons, degrees (`geometry::tendon::TENDON_ANGLES`).
pub const TENDON_ANGLES_DEG: [f64; 3] = [0.0, 120.0, 240.0];
/// Angles of the three magnets, degrees (between the tendons).
pub const MAGNET_ANGLES_DEG: [f64; 3] = [60.0, 180.0, 300.0];

/// What a hole is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HoleRole {
    /// M4 screw into a heat-set insert in a kit facet.
    Screw,
    /// The hinge pin.
    Pin,
    /// A tendon.
    Tendon,
    /// A magnet pocket (blind).
    Magnet,
    /// The air line.
    Air,
    /// A gripper fixing screw.
    Gripper,
}

impl HoleRole {
    /// Name in reports.
    pub fn name(self) -> &'static str {
        match self {
            HoleRole::Screw => "screw",
            HoleRole::Pin => "pin",
            HoleRole::Tendon => "tendon",
            HoleRole::Magnet => "magnet",
            HoleRole::Air => "air",
            HoleRole::Gripper => "gripper",
        }
    }
}

/// A hole of a part, from its dimensions.
#[derive(Debug, Clone, PartialEq)]
pub struct PartHole {
    /// Purpose.
    pub role: HoleRole,
    /// Centre where the hole meets its start face, mm.
    pub centre_mm: [f64; 3],
    /// Axis direction (unit).
    pub axis: [f64; 3],
    /// Diameter, mm.
    pub diameter_mm: f64,
    /// Depth, mm (the part's thickness for a through hole).
    pub depth_mm: f64,
}

/// One printable part.
#[derive(Debug, Clone)]
pub struct Part {
    /// File stem, e.g. `hinge-leaf`.
    pub name: &'static str,
    /// What it is.
    pub description: String,
    /// How many to print.
    pub quantity: usize,
    /// Filament.
    pub material: Filament,
    /// The solid.
    pub mesh: Mesh,
    /// Holes, from the dimensions.
    pub holes: Vec<PartHole>,
    /// Volume computed from the dimensions, mm³.
    pub nominal_volume_mm3: f64,
    /// Named dimensions (name, mm or degrees), for the report and the docs.
    pub dimensions: Vec<(&'static str, f64)>,
}

/// What the parts are sized from.
#[derive(Debug, Clone, PartialEq)]
pub struct PartParams {
    /// Kit panel (sheet) thickness, mm.
    pub panel_mm: f64,
    /// Largest fold angle the hinge must allow (0 = flat), degrees, (0, 180].
    pub fold_max_deg: f64,
    /// Tendon radius, mm.
    pub tendon_radius_mm: f64,
}

impl Default for PartParams {
    fn default() -> Self {
        PartParams {
            panel_mm: DEFAULT_PANEL_MM,
            fold_max_deg: 180.0,
            tendon_radius_mm: DEFAULT_TENDON_RADIUS_MM,
        }
    }
}

impl Part {
    /// A named dimension (mm or degrees), if the part has it.
    pub fn dimension(&self, name: &str) -> Option<f64> {
        self.dimensions
            .iter()
            .find(|(k, _)| *k == name)
            .map(|(_, v)| *v)
    }

    /// The solid's volume from its mesh, mm³.
    pub fn volume_mm3(&self) -> f64 {
        self.mesh.volume()
    }

    /// The filament mass of one part printed solid (the mesh volume × the filament's nominal
    /// density), g.
    pub fn mass_g(&self) -> f64 {
        self.volume_mm3() / 1000.0 * self.material.g_per_cm3
    }

    /// What the 3MF's metadata says (name, value): the part, how many to print, the filament
    /// and its nominal density, the solid's volume and mass, and every named dimension.
    pub fn metadata(&self) -> Vec<(String, String)> {
        let mut m = vec![
            ("ys:part".to_string(), self.name.to_string()),
            ("ys:quantity".to_string(), self.quantity.to_string()),
            ("ys:material".to_string(), self.material.name.to_string()),
            (
                "ys:density_g_per_cm3".to_string(),
                self.material.g_per_cm3.to_string(),
            ),
            (
                "ys:volume_mm3".to_string(),
                format!("{:.3}", self.volume_mm3()),
            ),
            ("ys:mass_g".to_string(), format!("{:.2}", self.mass_g())),
        ];
        for (k, v) in &self.dimensions {
            m.push((format!("ys:{k}"), format!("{}", (v * 1e6).round() / 1e6)));
        }
        m
    }

    /// The slicer-ready 3MF model of the part ([`crate::threemf`]): one object in its
    /// material, millimetres, at the STL's coordinates, with [`Part::metadata`].
    pub fn model(&self, application: &str) -> threemf::Model<'_> {
        let mut metadata = vec![
            ("Title".to_string(), self.description.clone()),
            ("Designer".to_string(), "host-tool pattern".to_string()),
            ("Application".to_string(), application.to_string()),
            (
                "Description".to_string(),
                format!(
                    "Print {} in {} (nominal {} g/cm³: {:.1} g each printed solid), millimetres, 1:1.",
                    self.quantity,
                    self.material.name,
                    self.material.g_per_cm3,
                    self.mass_g()
                ),
            ),
        ];
        metadata.extend(self.metadata());
        threemf::Model {
            metadata,
            materials: vec![threemf::Material {
                name: self.material.name.to_string(),
                colour: self.material.colour.to_string(),
            }],
            objects: vec![threemf::Object {
                mesh: &self.mesh,
                material: 0,
            }],
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 2D cell complexes

#[derive(Debug, Clone)]
struct Cell {
    poly: Vec<[f64; 2]>,
    hole: Option<([f64; 2], f64)>,
    /// Edges (index i: poly[i] → poly[i+1]) the hole's rays must not split (glue faces).
    no_split: Vec<usize>,
}

impl Cell {
    fn plain(poly: Vec<[f64; 2]>) -> Self {
        Cell {
            poly,
            hole: None,
            no_split: Vec::new(),
        }
    }
}

/// A triangulated cell complex: points, and per cell its ring (or fan) triangles and, for a
/// hole cell, the triangles that fill the hole.
struct Mesh2 {
    points: Vec<[f64; 2]>,
    solid: Vec<Vec<[usize; 3]>>,
    fill: Vec<Vec<[usize; 3]>>,
}

fn on_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> Option<f64> {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2;
    let q = [a[0] + t * d[0], a[1] + t * d[1]];
    let e = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
    (e < 1e-7 && t > 1e-9 && t < 1.0 - 1e-9).then_some(t)
}

/// Where the ray from `c` at angle `th` leaves the star-shaped polygon: (edge, point).
fn ray_hit(poly: &[[f64; 2]], c: [f64; 2], th: f64) -> Option<(usize, [f64; 2])> {
    let d = [th.cos(), th.sin()];
    let k = poly.len();
    let mut best: Option<(f64, usize)> = None;
    for i in 0..k {
        let (a, b) = (poly[i], poly[(i + 1) % k]);
        let e = [b[0] - a[0], b[1] - a[1]];
        let den = d[0] * e[1] - d[1] * e[0];
        if den.abs() < 1e-14 {
            continue;
        }
        let w = [a[0] - c[0], a[1] - c[1]];
        let s = (w[0] * e[1] - w[1] * e[0]) / den; // along the ray
        let u = (w[0] * d[1] - w[1] * d[0]) / den; // along the edge
        if s > 0.0 && (-1e-12..=1.0 + 1e-12).contains(&u) && best.is_none_or(|(bs, _)| s < bs) {
            best = Some((s, i));
        }
    }
    best.map(|(s, i)| (i, [c[0] + s * d[0], c[1] + s * d[1]]))
}

fn area2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn triangulate(cells: &[Cell]) -> Result<Mesh2, String> {
    // Pass 1: the points every cell puts on its own boundary.
    let mut own: Vec<Vec<[f64; 2]>> = Vec::new();
    for c in cells {
        let mut pts = c.poly.clone();
        if let Some((h, _)) = c.hole {
            for s in 0..CIRCLE_SEGMENTS {
                let th = 2.0 * PI * s as f64 / CIRCLE_SEGMENTS as f64;
                if let Some((edge, p)) = ray_hit(&c.poly, h, th) {
                    if !c.no_split.contains(&edge) {
                        pts.push(p);
                    }
                }
            }
        }
        own.push(pts);
    }
    let all: Vec<[f64; 2]> = own.iter().flatten().copied().collect();
    let mut points: Vec<[f64; 2]> = Vec::new();
    let mut index: HashMap<(i64, i64), usize> = HashMap::new();
    let mut id = |p: [f64; 2], points: &mut Vec<[f64; 2]>| -> usize {
        let key = ((p[0] * 1e6).round() as i64, (p[1] * 1e6).round() as i64);
        *index.entry(key).or_insert_with(|| {
            points.push(p);
            points.len() - 1
        })
    };
    let mut solid = Vec::new();
    let mut fill = Vec::new();
    for (ci, c) in cells.iter().enumerate() {
        // Pass 2: the boundary, in order, with every point anyone put on it.
        let k = c.poly.len();
        let mut boundary: Vec<[f64; 2]> = Vec::new();
        for i in 0..k {
            let (a, b) = (c.poly[i], c.poly[(i + 1) % k]);
            boundary.push(a);
            let mut on: Vec<(f64, [f64; 2])> = all
                .iter()
                .filter_map(|&p| on_segment(p, a, b).map(|t| (t, p)))
                .collect();
            on.sort_by(|x, y| x.0.total_cmp(&y.0));
            on.dedup_by(|x, y| (x.0 - y.0).abs() < 1e-9);
            boundary.extend(on.into_iter().map(|(_, p)| p));
        }
        let ids: Vec<usize> = boundary.iter().map(|&p| id(p, &mut points)).collect();
        let mut tris = Vec::new();
        let mut fills = Vec::new();
        match c.hole {
            None => {
                let n = boundary.len() as f64;
                let cen = boundary
                    .iter()
                    .fold([0.0, 0.0], |s, p| [s[0] + p[0] / n, s[1] + p[1] / n]);
                let ci = id(cen, &mut points);
                for i in 0..ids.len() {
                    tris.push([ci, ids[i], ids[(i + 1) % ids.len()]]);
                }
            }
            Some((h, r)) => {
                let hole: Vec<usize> = boundary
                    .iter()
                    .map(|p| {
                        let th = (p[1] - h[1]).atan2(p[0] - h[0]);
                        id([h[0] + r * th.cos(), h[1] + r * th.sin()], &mut points)
                    })
                    .collect();
                let m = ids.len();
                for i in 0..m {
                    let j = (i + 1) % m;
                    tris.push([hole[i], ids[i], ids[j]]);
                    tris.push([hole[i], ids[j], hole[j]]);
                }
                let hc = id(h, &mut points);
                for i in 0..m {
                    fills.push([hc, hole[i], hole[(i + 1) % m]]);
                }
            }
        }
        for t in tris.iter().chain(&fills) {
            let a = area2(points[t[0]], points[t[1]], points[t[2]]);
            if a <= 1e-12 {
                return Err(format!(
                    "cell {ci}: a triangle is degenerate or inverted (area {a:e})"
                ));
            }
        }
        solid.push(tris);
        fill.push(fills);
    }
    Ok(Mesh2 {
        points,
        solid,
        fill,
    })
}

// ---------------------------------------------------------------------------------------------
// 3D blocks

/// Collects triangles by welded position; interface pairs cancel in [`Builder::finish`].
#[derive(Default)]
struct Builder {
    vertices: Vec<[f64; 3]>,
    index: HashMap<[i64; 3], u32>,
    triangles: Vec<[u32; 3]>,
}

impl Builder {
    fn v(&mut self, p: [f64; 3]) -> u32 {
        let key = p.map(|x| (x * 1e6).round() as i64);
        if let Some(&i) = self.index.get(&key) {
            return i;
        }
        self.vertices.push(p);
        let i = (self.vertices.len() - 1) as u32;
        self.index.insert(key, i);
        i
    }

    fn tri(&mut self, a: [f64; 3], b: [f64; 3], c: [f64; 3]) {
        let t = [self.v(a), self.v(b), self.v(c)];
        self.triangles.push(t);
    }

    /// A planar quad, counter-clockwise seen from outside, split along the diagonal through
    /// its lexicographically smallest corner.
    fn quad(&mut self, q: [[f64; 3]; 4]) {
        let key = |p: &[f64; 3]| p.map(|x| (x * 1e6).round() as i64);
        let m = (0..4).min_by_key(|&i| key(&q[i])).unwrap_or(0);
        let (a, b, c, d) = (q[m], q[(m + 1) % 4], q[(m + 2) % 4], q[(m + 3) % 4]);
        self.tri(a, b, c);
        self.tri(a, c, d);
    }

    /// Extrudes the 2D triangles `tris` of `m` (u, v) along w through `stations` (increasing),
    /// mapped by `map(u, v, w)`, which must be a right-handed rigid map.
    fn extrude(
        &mut self,
        m: &Mesh2,
        tris: &[[usize; 3]],
        stations: &[f64],
        map: &dyn Fn(f64, f64, f64) -> [f64; 3],
    ) {
        let (w0, w1) = (stations[0], stations[stations.len() - 1]);
        let p = |i: usize, w: f64| map(m.points[i][0], m.points[i][1], w);
        let mut edges: HashMap<(usize, usize), usize> = HashMap::new();
        for t in tris {
            self.tri(p(t[0], w0), p(t[2], w0), p(t[1], w0));
            self.tri(p(t[0], w1), p(t[1], w1), p(t[2], w1));
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        let mut boundary: Vec<(usize, usize)> = edges
            .keys()
            .filter(|(a, b)| !edges.contains_key(&(*b, *a)))
            .copied()
            .collect();
        boundary.sort_unstable();
        for (a, b) in boundary {
            for s in stations.windows(2) {
                self.quad([p(a, s[0]), p(b, s[0]), p(b, s[1]), p(a, s[1])]);
            }
        }
    }

    fn finish(self, name: &str) -> Mesh {
        let mut by_set: HashMap<[u32; 3], Vec<usize>> = HashMap::new();
        for (i, t) in self.triangles.iter().enumerate() {
            let mut s = *t;
            s.sort_unstable();
            by_set.entry(s).or_default().push(i);
        }
        let canon = |t: [u32; 3]| {
            let m = (0..3).min_by_key(|&i| t[i]).unwrap_or(0);
            [t[m], t[(m + 1) % 3], t[(m + 2) % 3]]
        };
        let mut dead = vec![false; self.triangles.len()];
        for list in by_set.values() {
            for (x, &i) in list.iter().enumerate() {
                if dead[i] {
                    continue;
                }
                let ti = canon(self.triangles[i]);
                let rev = canon([ti[0], ti[2], ti[1]]);
                if let Some(&j) = list[x + 1..]
                    .iter()
                    .find(|&&j| !dead[j] && canon(self.triangles[j]) == rev)
                {
                    dead[i] = true;
                    dead[j] = true;
                }
            }
        }
        let mut mesh = Mesh::new(name);
        let mut remap: HashMap<u32, u32> = HashMap::new();
        for (i, t) in self.triangles.iter().enumerate() {
            if dead[i] {
                continue;
            }
            let t = t.map(|v| {
                *remap.entry(v).or_insert_with(|| {
                    mesh.vertices.push(self.vertices[v as usize]);
                    (mesh.vertices.len() - 1) as u32
                })
            });
            mesh.triangles.push(t);
        }
        mesh
    }
}

/// A layer of a z-extruded complex: which cells, which holes filled.
struct Layer<'a> {
    z: [f64; 2],
    cells: &'a dyn Fn(usize) -> bool,
    filled: &'a dyn Fn(usize) -> bool,
}

fn extrude_layers(b: &mut Builder, m: &Mesh2, layers: &[Layer<'_>]) {
    for l in layers {
        let mut tris = Vec::new();
        for c in 0..m.solid.len() {
            if (l.cells)(c) {
                tris.extend(&m.solid[c]);
                if (l.filled)(c) {
                    tris.extend(&m.fill[c]);
                }
            }
        }
        b.extrude(m, &tris, &l.z, &|u, v, w| [u, v, w]);
    }
}

// ---------------------------------------------------------------------------------------------
// Polar complexes (round parts)

/// A ring of a polar complex: radii, sector count (dividing [`CIRCLE_SEGMENTS`]) and the
/// angle (degrees) of sector 0's centre.
#[derive(Debug, Clone, Copy)]
struct Ring {
    r: [f64; 2],
    sectors: usize,
    centre0_deg: f64,
}

/// Builds cells: an optional centre disc (radius of the first ring's inner radius, with an
/// optional hole) and the rings' sectors, holes given as (ring, angle_deg, diameter).
/// Returns the cells and the index of each hole's cell.
fn polar(
    centre: Option<Option<f64>>,
    rings: &[Ring],
    holes: &[(usize, f64, f64)],
) -> Result<(Vec<Cell>, Vec<usize>), String> {
    let g = CIRCLE_SEGMENTS;
    let pt = |r: f64, deg: f64| {
        let t = deg.to_radians();
        [r * t.cos(), r * t.sin()]
    };
    let step = 360.0 / g as f64;
    let mut cells = Vec::new();
    if let Some(hole) = centre {
        let r = rings.first().map(|x| x.r[0]).unwrap_or(0.0);
        let poly: Vec<[f64; 2]> = (0..g).map(|i| pt(r, i as f64 * step)).collect();
        cells.push(Cell {
            poly,
            hole: hole.map(|d| ([0.0, 0.0], 0.5 * d)),
            no_split: Vec::new(),
        });
    }
    let mut hole_cells = vec![usize::MAX; holes.len()];
    for (ri, ring) in rings.iter().enumerate() {
        if !g.is_multiple_of(ring.sectors) {
            return Err(format!("ring {ri}: {} sectors", ring.sectors));
        }
        let per = g / ring.sectors;
        let span = 360.0 / ring.sectors as f64;
        let start = ring.centre0_deg - 0.5 * span;
        if ((start / step).round() * step - start).abs() > 1e-9 {
            return Err(format!("ring {ri}: sector boundaries off the grid"));
        }
        for s in 0..ring.sectors {
            let a0 = start + s as f64 * span;
            let mut poly = Vec::new();
            for i in 0..=per {
                poly.push(pt(ring.r[0], a0 + i as f64 * step));
            }
            for i in (0..=per).rev() {
                poly.push(pt(ring.r[1], a0 + i as f64 * step));
            }
            // The inner arc with increasing angle, then the outer arc back, runs clockwise:
            // reversed it is counter-clockwise.
            poly.reverse();
            let centre_deg = a0 + 0.5 * span;
            let mut hole = None;
            for (hi, &(hr, hdeg, hd)) in holes.iter().enumerate() {
                let diff = (hdeg - centre_deg).rem_euclid(360.0);
                if hr == ri && (diff < 1e-9 || (360.0 - diff) < 1e-9) {
                    let rm = 0.5 * (ring.r[0] + ring.r[1]);
                    hole = Some((pt(rm, hdeg), 0.5 * hd));
                    hole_cells[hi] = cells.len();
                }
            }
            cells.push(Cell {
                poly,
                hole,
                no_split: Vec::new(),
            });
        }
    }
    if hole_cells.contains(&usize::MAX) {
        return Err("a hole is not at a sector centre".into());
    }
    Ok((cells, hole_cells))
}

fn circle(d: f64) -> f64 {
    0.25 * PI * d * d
}

// ---------------------------------------------------------------------------------------------
// The parts

/// Dimensions of the kit's hinge leaf (two leaves and a pin make one hinge).
#[derive(Debug, Clone, PartialEq)]
pub struct HingeDims {
    /// Length along the crease, mm.
    pub length_mm: f64,
    /// Plate from the pin axis (y0) to its far edge, mm.
    pub plate_y_mm: [f64; 2],
    /// Plate thickness, mm.
    pub leaf_mm: f64,
    /// Knuckle outer radius = pin axis height above the facet, mm.
    pub knuckle_r_mm: f64,
    /// The knuckle spans x from −length/2 to this, mm.
    pub knuckle_end_mm: f64,
    /// Screw length: leaf + insert, mm (round down to a stock length).
    pub screw_mm: f64,
}

/// Sizes the hinge leaf, or says why the panel or the fold range cannot take one.
pub fn hinge_dims(p: &PartParams) -> Result<HingeDims, FabError> {
    if !(p.panel_mm.is_finite() && p.panel_mm >= INSERT_LENGTH_MM && p.panel_mm <= 50.0) {
        return Err(FabError(format!(
            "--panel-mm must be a sheet thickness in mm in [{INSERT_LENGTH_MM}, 50]: the M4 heat-set inserts are {INSERT_LENGTH_MM} mm long and must sit fully in the panel, got {}",
            p.panel_mm
        )));
    }
    if !(p.fold_max_deg.is_finite() && p.fold_max_deg > 0.0 && p.fold_max_deg <= 180.0) {
        return Err(FabError(format!(
            "--fold-max-deg must be the largest fold angle the hinge must allow, in (0, 180] degrees, got {}",
            p.fold_max_deg
        )));
    }
    let t = LEAF_MM;
    // Folding closes the leaves about the pin (the hinge sits on the inside of its fold).
    // A screw head's top is d = R − t − k below the axis and a = inset − head radius out from
    // it; at fold φ each leaf turns by ψ = φ/2 and the head's corner is a·cosψ + d·sinψ from
    // the mirror plane, which must stay ≥ clearance/2.
    let psi = 0.5 * p.fold_max_deg.to_radians();
    let a = SCREW_INSET_MM - 0.5 * M4_HEAD_DIAMETER_MM;
    let d_min = if psi.sin() > 1e-12 {
        (0.5 * CLEARANCE_MM - a * psi.cos()) / psi.sin()
    } else {
        f64::NEG_INFINITY
    };
    let r = (t + M4_HEAD_HEIGHT_MM + d_min)
        .max(0.5 * PIN_HOLE_MM + WALL_MM)
        .max(t + 0.5);
    let r = (r * 100.0).ceil() / 100.0;
    let y0 = r + CLEARANCE_MM;
    let y1 = SCREW_INSET_MM + 0.5 * M4_HEAD_DIAMETER_MM + WALL_MM;
    if y0 > SCREW_INSET_MM - 0.5 * M4_CLEARANCE_MM - WALL_MM {
        return Err(FabError(format!(
            "a hinge for folds up to {}° needs its pin {r} mm above the facet, which leaves no room for the screws {SCREW_INSET_MM} mm from the crease",
            p.fold_max_deg
        )));
    }
    Ok(HingeDims {
        length_mm: SCREW_PITCH_MM + M4_HEAD_DIAMETER_MM + 2.0 * WALL_MM,
        plate_y_mm: [y0, y1],
        leaf_mm: t,
        knuckle_r_mm: r,
        knuckle_end_mm: -0.5 * CLEARANCE_MM,
        screw_mm: t + INSERT_LENGTH_MM,
    })
}

/// The hinge leaf. Frame: the crease (and the pin axis above it) along x, the hinge centre at
/// x = 0; the facet's face is z = 0, the leaf on it at y > 0; the pin axis at (y, z) = (0, R).
/// Two leaves, the second turned 180° about z, mesh their knuckles.
pub fn hinge_leaf(p: &PartParams, hinges: usize) -> Result<Part, FabError> {
    let h = hinge_dims(p)?;
    let (half, t, r) = (0.5 * h.length_mm, h.leaf_mm, h.knuckle_r_mm);
    let [y0, y1] = h.plate_y_mm;
    let sx = 0.5 * SCREW_PITCH_MM;
    // Each screw hole's cell reaches the plate's end: as wide as the plate's end margin.
    let a = half - sx;
    let cols = [
        -half,
        -sx + a,
        h.knuckle_end_mm,
        -h.knuckle_end_mm,
        sx - a,
        half,
    ];
    let mut cells = Vec::new();
    for w in cols.windows(2) {
        let poly = vec![[w[0], y0], [w[1], y0], [w[1], y1], [w[0], y1]];
        let mid = 0.5 * (w[0] + w[1]);
        if (mid.abs() - sx).abs() < 1e-9 {
            cells.push(Cell {
                poly,
                hole: Some(([mid, SCREW_INSET_MM], 0.5 * M4_CLEARANCE_MM)),
                no_split: Vec::new(),
            });
        } else {
            cells.push(Cell::plain(poly));
        }
    }
    let plate = triangulate(&cells).map_err(|e| FabError(format!("hinge plate: {e}")))?;
    // Knuckle profile in (y, z) about the pin axis (0, r): the circle from the first grid
    // angle above the tab's top corner round to the bottom (0, 0), and the tab to the plate
    // (with the fillet between its top corner and the circle). Star-shaped about the axis.
    let seg = CIRCLE_SEGMENTS as f64;
    let step = 2.0 * PI / seg;
    let th_corner = (t - r).atan2(y0);
    let th_s = ((th_corner / step).floor() + 1.0) * step;
    let th_end = 1.5 * PI;
    let mut prof = vec![[y0, 0.0], [y0, t]];
    let mut i = 0.0;
    loop {
        let th = th_s + i * step;
        if th >= th_end - 1e-9 {
            break;
        }
        prof.push([r * th.cos(), r + r * th.sin()]);
        i += 1.0;
    }
    prof.push([0.0, 0.0]);
    let arc_start = prof[2];
    let prof_cell = Cell {
        poly: prof.clone(),
        hole: Some(([0.0, r], 0.5 * PIN_HOLE_MM)),
        no_split: vec![0],
    };
    let knuckle = triangulate(&[prof_cell]).map_err(|e| FabError(format!("knuckle: {e}")))?;
    let mut b = Builder::default();
    extrude_layers(
        &mut b,
        &plate,
        &[Layer {
            z: [0.0, t],
            cells: &|_| true,
            filled: &|_| false,
        }],
    );
    // Stations along x: the plate's boundary points on y = y0 within the knuckle.
    let mut st: Vec<f64> = plate
        .points
        .iter()
        .filter(|q| (q[1] - y0).abs() < 1e-9 && q[0] <= h.knuckle_end_mm + 1e-9)
        .map(|q| q[0])
        .collect();
    st.sort_by(f64::total_cmp);
    st.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    // (u, v, w) = (y, z, x) is right-handed.
    b.extrude(&knuckle, &knuckle.solid[0], &st, &|u, v, w| [w, u, v]);
    let mesh = b.finish("hinge leaf");
    let knuckle_len = h.knuckle_end_mm + half;
    // From the axis: the circular sector θ_s … 270°, and the triangles to the tab's corners.
    let c = [0.0, r];
    let profile_area = 0.5 * r * r * (th_end - th_s)
        + 0.5 * area2(c, [0.0, 0.0], [y0, 0.0])
        + 0.5 * area2(c, [y0, 0.0], [y0, t])
        + 0.5 * area2(c, [y0, t], arc_start)
        - circle(PIN_HOLE_MM);
    let nominal =
        (h.length_mm * (y1 - y0) - 2.0 * circle(M4_CLEARANCE_MM)) * t + profile_area * knuckle_len;
    let mut holes: Vec<PartHole> = [-sx, sx]
        .iter()
        .map(|&x| PartHole {
            role: HoleRole::Screw,
            centre_mm: [x, SCREW_INSET_MM, 0.0],
            axis: [0.0, 0.0, 1.0],
            diameter_mm: M4_CLEARANCE_MM,
            depth_mm: t,
        })
        .collect();
    holes.push(PartHole {
        role: HoleRole::Pin,
        centre_mm: [-half, 0.0, r],
        axis: [1.0, 0.0, 0.0],
        diameter_mm: PIN_HOLE_MM,
        depth_mm: knuckle_len,
    });
    Ok(Part {
        name: "hinge-leaf",
        description: format!(
            "kit hinge leaf (2 + a {PIN_HOLE_MM:.0} mm pin per hinge; M4 × {} button-head screws into heat-set inserts)",
            h.screw_mm.floor()
        ),
        quantity: 2 * hinges,
        material: PLA_CF,
        mesh,
        holes,
        nominal_volume_mm3: nominal,
        dimensions: vec![
            ("length_mm", h.length_mm),
            ("plate_from_axis_mm", y0),
            ("plate_to_mm", y1),
            ("leaf_mm", t),
            ("knuckle_radius_mm", r),
            ("knuckle_length_mm", knuckle_len),
            ("pin_hole_mm", PIN_HOLE_MM),
            ("pin_length_mm", pin_length_mm(h.length_mm)),
            ("screw_hole_mm", M4_CLEARANCE_MM),
            ("screw_pitch_mm", SCREW_PITCH_MM),
            ("screw_inset_mm", SCREW_INSET_MM),
            ("screw_length_mm", h.screw_mm.floor()),
            ("panel_mm", p.panel_mm),
            ("fold_max_deg", p.fold_max_deg),
        ],
    })
}

/// Stock lengths of 3 mm dowel pins (ISO 2338) and M3 screws, mm.
pub const PIN_STOCK_MM: [f64; 14] = [
    10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0, 60.0,
];

/// The hinge pin: the longest stock length that stays within both leaves' knuckles (the
/// hinge's length along the crease), mm.
pub fn pin_length_mm(hinge_length_mm: f64) -> f64 {
    PIN_STOCK_MM
        .iter()
        .rev()
        .copied()
        .find(|&l| l <= hinge_length_mm)
        .unwrap_or(PIN_STOCK_MM[0])
}

/// The trunk's circumradius (its n-gon's, deployed), mm.
pub fn trunk_radius_mm(trunk: &Trunk) -> f64 {
    trunk.edge_mm() / (2.0 * (PI / trunk.n() as f64).sin())
}

/// The least tendon radius the crane parts take: the tendon locator's bore clears the trunk
/// and keeps a wall to the ring of tendon holes.
pub fn min_tendon_radius_mm(trunk: &Trunk) -> f64 {
    trunk_radius_mm(trunk) + LOCATOR_CLEARANCE_MM + WALL_MM + HOLE_RING_HALF_MM
}

fn check_tendon(trunk: &Trunk, p: &PartParams) -> Result<(), FabError> {
    let lo = min_tendon_radius_mm(trunk);
    let lo = (lo * 100.0).ceil() / 100.0;
    if !(p.tendon_radius_mm.is_finite() && p.tendon_radius_mm >= lo && p.tendon_radius_mm <= 1000.0)
    {
        return Err(FabError(format!(
            "--tendon-radius-mm must be in [{lo}, 1000] mm for this trunk: the tendons run outside it (circumradius {:.2} mm for n = {}, l = {} mm) through a locator ring with a {LOCATOR_CLEARANCE_MM} mm clearance and {WALL_MM} mm walls, got {}",
            trunk_radius_mm(trunk),
            trunk.n(),
            trunk.edge_mm(),
            p.tendon_radius_mm
        )));
    }
    Ok(())
}

/// A round part: z-extruded polar complex, through holes, blind pockets from the top
/// (`from_top`) or the bottom.
struct RoundSpec {
    name: &'static str,
    centre: Option<Option<f64>>,
    rings: Vec<Ring>,
    through: Vec<(usize, f64, f64, HoleRole)>,
    pockets: Vec<(usize, f64, f64, HoleRole)>,
    thickness: f64,
    pocket_depth: f64,
    pockets_from_top: bool,
}

fn round_part(s: RoundSpec) -> Result<(Mesh, Vec<PartHole>, f64), FabError> {
    let mut all: Vec<(usize, f64, f64)> = s.through.iter().map(|h| (h.0, h.1, h.2)).collect();
    all.extend(s.pockets.iter().map(|h| (h.0, h.1, h.2)));
    let (cells, hole_cells) =
        polar(s.centre, &s.rings, &all).map_err(|e| FabError(format!("{}: {e}", s.name)))?;
    let m = triangulate(&cells).map_err(|e| FabError(format!("{}: {e}", s.name)))?;
    let pocket_cells: Vec<usize> = hole_cells[s.through.len()..].to_vec();
    let mut b = Builder::default();
    let t = s.thickness;
    let dz = if s.pockets.is_empty() {
        t
    } else if s.pockets_from_top {
        t - s.pocket_depth
    } else {
        s.pocket_depth
    };
    let fill_pocket = |c: usize| pocket_cells.contains(&c);
    let none = |_| false;
    let first_filled: &dyn Fn(usize) -> bool = if s.pockets_from_top {
        &fill_pocket
    } else {
        &none
    };
    let second_filled: &dyn Fn(usize) -> bool = if s.pockets_from_top {
        &none
    } else {
        &fill_pocket
    };
    let mut layers = vec![Layer {
        z: [0.0, dz],
        cells: &|_| true,
        filled: first_filled,
    }];
    if dz < t {
        layers.push(Layer {
            z: [dz, t],
            cells: &|_| true,
            filled: second_filled,
        });
    }
    extrude_layers(&mut b, &m, &layers);
    let mesh = b.finish(s.name);
    // Nominal volume: outer disc, minus the bore, minus the holes.
    let outer = s.rings.last().map(|r| r.r[1]).unwrap_or(0.0);
    let inner = if s.centre.is_some() {
        0.0
    } else {
        s.rings.first().map(|r| r.r[0]).unwrap_or(0.0)
    };
    let mut vol = PI * (outer * outer - inner * inner) * t;
    if let Some(Some(d)) = s.centre {
        vol -= circle(d) * t;
    }
    let mut holes = Vec::new();
    let rm = |ri: usize| 0.5 * (s.rings[ri].r[0] + s.rings[ri].r[1]);
    for &(ri, deg, d, role) in &s.through {
        vol -= circle(d) * t;
        let a = deg.to_radians();
        holes.push(PartHole {
            role,
            centre_mm: [rm(ri) * a.cos(), rm(ri) * a.sin(), 0.0],
            axis: [0.0, 0.0, 1.0],
            diameter_mm: d,
            depth_mm: t,
        });
    }
    for &(ri, deg, d, role) in &s.pockets {
        vol -= circle(d) * s.pocket_depth;
        let a = deg.to_radians();
        let (z, axis) = if s.pockets_from_top {
            (t, [0.0, 0.0, -1.0])
        } else {
            (0.0, [0.0, 0.0, 1.0])
        };
        holes.push(PartHole {
            role,
            centre_mm: [rm(ri) * a.cos(), rm(ri) * a.sin(), z],
            axis,
            diameter_mm: d,
            depth_mm: s.pocket_depth,
        });
    }
    if let Some(Some(d)) = s.centre {
        holes.push(PartHole {
            role: HoleRole::Air,
            centre_mm: [0.0, 0.0, 0.0],
            axis: [0.0, 0.0, 1.0],
            diameter_mm: d,
            depth_mm: t,
        });
    }
    Ok((mesh, holes, vol))
}

/// Thickness of the caps, mm.
pub const CAP_MM: f64 = 6.0;
/// Thickness of the tendon locator ring, mm.
pub const LOCATOR_MM: f64 = 4.0;
/// Thickness of the gripper mount, mm.
pub const GRIPPER_MOUNT_MM: f64 = 8.0;

/// The ring of tendon and magnet holes: its sectors (one hole each, centred on multiples of
/// 60°) at least a magnet pocket plus two walls wide at the tendon radius.
fn hole_ring(r_t: f64) -> Ring {
    let need = MAGNET_POCKET_MM[0] + 2.0 * 1.0;
    let sectors = [48, 24, 12, 6]
        .into_iter()
        .find(|&s| r_t * 2.0 * PI / s as f64 >= need)
        .unwrap_or(6);
    Ring {
        r: [r_t - HOLE_RING_HALF_MM, r_t + HOLE_RING_HALF_MM],
        sectors,
        centre0_deg: 0.0,
    }
}

fn plain_ring(r0: f64, r1: f64) -> Ring {
    Ring {
        r: [r0, r1],
        sectors: CIRCLE_SEGMENTS / 2,
        centre0_deg: 0.0,
    }
}

fn round_dims(r_t: f64, t: f64) -> Vec<(&'static str, f64)> {
    vec![
        ("outer_diameter_mm", 2.0 * (r_t + HOLE_RING_HALF_MM)),
        ("thickness_mm", t),
        ("tendon_radius_mm", r_t),
    ]
}

/// The crane's printed parts for `trunk` (n, edge) and the tendon radius.
pub fn crane_parts(trunk: &Trunk, p: &PartParams) -> Result<Vec<Part>, FabError> {
    check_tendon(trunk, p)?;
    let r_t = p.tendon_radius_mm;
    let ring = hole_ring(r_t);
    let inner = r_t - HOLE_RING_HALF_MM;
    let tendons = |d: f64| -> Vec<(usize, f64, f64, HoleRole)> {
        TENDON_ANGLES_DEG
            .iter()
            .map(|&a| (1, a, d, HoleRole::Tendon))
            .collect()
    };
    let magnets: Vec<(usize, f64, f64, HoleRole)> = MAGNET_ANGLES_DEG
        .iter()
        .map(|&a| (1, a, MAGNET_POCKET_MM[0], HoleRole::Magnet))
        .collect();
    let centre_r = 8.0_f64.min(0.5 * inner);
    let mut parts = Vec::new();
    // Upper cap: the trunk's top, magnets for the add-ons, the tendons' anchors.
    let (mesh, holes, vol) = round_part(RoundSpec {
        name: "upper cap",
        centre: Some(None),
        rings: vec![plain_ring(centre_r, inner), ring],
        through: tendons(TENDON_HOLE_MM),
        pockets: magnets.clone(),
        thickness: CAP_MM,
        pocket_depth: MAGNET_POCKET_MM[1],
        pockets_from_top: true,
    })?;
    let mut dims = round_dims(r_t, CAP_MM);
    dims.push(("magnet_pocket_mm", MAGNET_POCKET_MM[0]));
    dims.push(("magnet_depth_mm", MAGNET_POCKET_MM[1]));
    dims.push(("tendon_hole_mm", TENDON_HOLE_MM));
    dims.push(("trunk_radius_mm", trunk_radius_mm(trunk)));
    parts.push(Part {
        name: "upper-cap",
        description: format!(
            "upper cap: closes the trunk's top, anchors the 3 tendons at r = {r_t} mm, 3 pockets for 6 × 3 mm magnets (the add-on connector); nylon, as it is installed before the trunk's last 140 °C heat treatment (§5.3)"
        ),
        quantity: 1,
        material: NYLON,
        mesh,
        holes,
        nominal_volume_mm3: vol,
        dimensions: dims,
    });
    // Lower cap: the trunk's base, the air line, the tendons down to the servos.
    let (mesh, holes, vol) = round_part(RoundSpec {
        name: "lower cap",
        centre: Some(Some(AIR_HOLE_MM)),
        rings: vec![plain_ring(centre_r, inner), ring],
        through: tendons(TENDON_HOLE_MM),
        pockets: Vec::new(),
        thickness: CAP_MM,
        pocket_depth: 0.0,
        pockets_from_top: true,
    })?;
    let mut dims = round_dims(r_t, CAP_MM);
    dims.push(("air_hole_mm", AIR_HOLE_MM));
    dims.push(("tendon_hole_mm", TENDON_HOLE_MM));
    dims.push(("trunk_radius_mm", trunk_radius_mm(trunk)));
    parts.push(Part {
        name: "lower-cap",
        description: format!(
            "lower cap: closes the trunk's base around the {AIR_HOLE_MM} mm air line, guides the 3 tendons down at r = {r_t} mm"
        ),
        quantity: 1,
        material: PLA,
        mesh,
        holes,
        nominal_volume_mm3: vol,
        dimensions: dims,
    });
    // Tendon locator: a ring over the trunk's end that holds the tendons at r_t.
    let bore = trunk_radius_mm(trunk) + LOCATOR_CLEARANCE_MM;
    let (mesh, holes, vol) = round_part(RoundSpec {
        name: "tendon locator",
        centre: None,
        rings: vec![plain_ring(bore, inner), ring],
        through: tendons(TENDON_HOLE_MM),
        pockets: Vec::new(),
        thickness: LOCATOR_MM,
        pocket_depth: 0.0,
        pockets_from_top: true,
    })?;
    let mut dims = round_dims(r_t, LOCATOR_MM);
    dims.push(("bore_diameter_mm", 2.0 * bore));
    dims.push(("tendon_hole_mm", TENDON_HOLE_MM));
    parts.push(Part {
        name: "tendon-locator",
        description: format!(
            "tendon locator (top and bottom): a ring over the trunk's end (bore {:.1} mm) holding the 3 tendons at r = {r_t} mm",
            2.0 * bore
        ),
        quantity: 2,
        material: PLA,
        mesh,
        holes,
        nominal_volume_mm3: vol,
        dimensions: dims,
    });
    // Gripper mount: magnets under (onto the upper cap's), the gripper's four M3 on top.
    let (gd, pcd) = GRIPPER_HOLES;
    let gr = 0.5 * pcd;
    let g0 = gr - 6.0;
    let g1 = gr + 6.0;
    if g1 + WALL_MM > inner {
        return Err(FabError(format!(
            "--tendon-radius-mm {r_t}: the gripper mount's {pcd} mm fixing circle needs a tendon radius of at least {} mm",
            g1 + WALL_MM + HOLE_RING_HALF_MM
        )));
    }
    let mut through = vec![];
    for a in [45.0, 135.0, 225.0, 315.0] {
        through.push((1, a, gd, HoleRole::Gripper));
    }
    for &a in &TENDON_ANGLES_DEG {
        through.push((3, a, TENDON_KNOT_HOLE_MM, HoleRole::Tendon));
    }
    let gmag: Vec<(usize, f64, f64, HoleRole)> =
        magnets.iter().map(|h| (3, h.1, h.2, h.3)).collect();
    let (mesh, holes, vol) = round_part(RoundSpec {
        name: "gripper mount",
        centre: Some(None),
        rings: vec![
            plain_ring(centre_r.min(g0 - 1.0), g0),
            Ring {
                r: [g0, g1],
                sectors: 8,
                centre0_deg: 45.0,
            },
            plain_ring(g1, inner),
            ring,
        ],
        through,
        pockets: gmag,
        thickness: GRIPPER_MOUNT_MM,
        pocket_depth: MAGNET_POCKET_MM[1],
        pockets_from_top: false,
    })?;
    let mut dims = round_dims(r_t, GRIPPER_MOUNT_MM);
    dims.push(("magnet_pocket_mm", MAGNET_POCKET_MM[0]));
    dims.push(("magnet_depth_mm", MAGNET_POCKET_MM[1]));
    dims.push(("gripper_hole_mm", gd));
    dims.push(("gripper_pcd_mm", pcd));
    dims.push(("tendon_knot_hole_mm", TENDON_KNOT_HOLE_MM));
    parts.push(Part {
        name: "gripper-mount",
        description: format!(
            "gripper mount: 3 magnet pockets underneath onto the upper cap's, 4 × M3 on a {pcd} mm circle for the gripper, clearance over the tendon knots"
        ),
        quantity: 1,
        material: PLA,
        mesh,
        holes,
        nominal_volume_mm3: vol,
        dimensions: dims,
    });
    Ok(parts)
}

/// Every part: the hinge leaf for `hinges` kit hinges, then the crane's.
pub fn all_parts(trunk: &Trunk, p: &PartParams, hinges: usize) -> Result<Vec<Part>, FabError> {
    let mut v = vec![hinge_leaf(p, hinges)?];
    v.extend(crane_parts(trunk, p)?);
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Defaults;

    fn make(n: u32, betas: &[(f64, usize)], edge_mm: f64) -> Trunk {
        Trunk::new(
            betas
                .iter()
                .map(|&(b, layers)| crate::Module {
                    design: geometry::ModuleDesign::new(n, b).unwrap(),
                    layers,
                })
                .collect(),
            edge_mm,
        )
        .unwrap()
    }

    /// The default crane trunk: n = 3, 35° and 31.72°, two layers each, l = 75 mm.
    fn trunk() -> Trunk {
        make(3, &[(35.0, 2), (31.72, 2)], Defaults::EDGE_MM)
    }

    fn check(part: &Part) {
        part.mesh
            .check_solid()
            .unwrap_or_else(|e| panic!("{}: {e}", part.name));
        let v = part.mesh.volume();
        let rel = (v - part.nominal_volume_mm3).abs() / part.nominal_volume_mm3;
        assert!(
            rel < 0.01,
            "{}: mesh volume {v} vs {} from the dimensions ({:.3} %)",
            part.name,
            part.nominal_volume_mm3,
            100.0 * rel
        );
    }

    /// Vertices on the hole's circle at its start face.
    fn ring_vertices(part: &Part, h: &PartHole) -> usize {
        part.mesh
            .vertices
            .iter()
            .filter(|v| {
                let d = [
                    v[0] - h.centre_mm[0],
                    v[1] - h.centre_mm[1],
                    v[2] - h.centre_mm[2],
                ];
                let along = d[0] * h.axis[0] + d[1] * h.axis[1] + d[2] * h.axis[2];
                let r2 = d.iter().map(|x| x * x).sum::<f64>() - along * along;
                along.abs() < 1e-6 && (r2.sqrt() - 0.5 * h.diameter_mm).abs() < 1e-6
            })
            .count()
    }

    #[test]
    fn every_part_is_a_closed_oriented_solid_of_the_volume_its_dimensions_give() {
        for part in all_parts(&trunk(), &PartParams::default(), 180).unwrap() {
            check(&part);
            for h in &part.holes {
                assert!(
                    ring_vertices(&part, h) >= 8,
                    "{}: no {} hole of {} mm at {:?}",
                    part.name,
                    h.role.name(),
                    h.diameter_mm,
                    h.centre_mm
                );
            }
        }
        for fold in [30.0, 90.0, 150.0] {
            let p = PartParams {
                fold_max_deg: fold,
                ..Default::default()
            };
            check(&hinge_leaf(&p, 1).unwrap());
        }
        for r_t in [51.31, 62.0, 75.0, 200.0] {
            let p = PartParams {
                tendon_radius_mm: r_t,
                ..Default::default()
            };
            for part in crane_parts(&trunk(), &p).unwrap() {
                check(&part);
            }
        }
        // Small and many-sided trunks, each at its least tendon radius and a little more.
        for (n, edge) in [(3, 10.0), (3, 40.0), (6, 20.0), (12, 30.0)] {
            let t = make(n, &[(31.72, 2)], edge);
            let lo = (min_tendon_radius_mm(&t) * 100.0).ceil() / 100.0;
            for r_t in [lo, lo + 3.0, lo + 20.0] {
                let p = PartParams {
                    tendon_radius_mm: r_t,
                    ..Default::default()
                };
                match crane_parts(&t, &p) {
                    Ok(parts) => parts.iter().for_each(check),
                    Err(e) => assert!(
                        e.to_string().contains("gripper mount"),
                        "n {n} l {edge} r_t {r_t}: {e}"
                    ),
                }
            }
        }
    }

    #[test]
    fn the_tendon_holes_sit_at_the_tendon_radius_and_angles() {
        for r_t in [60.0, 81.25] {
            let p = PartParams {
                tendon_radius_mm: r_t,
                ..Default::default()
            };
            for part in crane_parts(&trunk(), &p).unwrap() {
                let t: Vec<&PartHole> = part
                    .holes
                    .iter()
                    .filter(|h| h.role == HoleRole::Tendon)
                    .collect();
                assert_eq!(t.len(), 3, "{}", part.name);
                for g in part.holes.iter().filter(|h| h.role == HoleRole::Gripper) {
                    let r = g.centre_mm[0].hypot(g.centre_mm[1]);
                    assert!(
                        (r - 0.5 * GRIPPER_HOLES.1).abs() < 0.01,
                        "gripper hole at r = {r}"
                    );
                }
                for (h, a) in t.iter().zip(TENDON_ANGLES_DEG) {
                    let a = a.to_radians();
                    assert!((h.centre_mm[0] - r_t * a.cos()).abs() < 0.01);
                    assert!((h.centre_mm[1] - r_t * a.sin()).abs() < 0.01);
                    assert!(ring_vertices(&part, h) >= 8);
                }
            }
        }
    }

    #[test]
    fn the_hinge_screw_holes_are_where_the_kit_puts_the_insert_holes() {
        let kit_trunk = make(3, &[(31.72, 4)], 609.6);
        let facets = crate::nest::kit_facets(&kit_trunk);
        let f = &facets[0];
        let holes = crate::nest::local_holes(f, crate::nest::INSERT_HOLE_MM);
        let leaf = hinge_leaf(&PartParams::default(), 1).unwrap();
        let screws: Vec<&PartHole> = leaf
            .holes
            .iter()
            .filter(|h| h.role == HoleRole::Screw)
            .collect();
        assert_eq!(screws.len(), 2);
        // The kit's two holes of one hinge leaf, in the hinge's frame (x along the crease
        // from the hinge centre, y into the facet).
        let pair: Vec<_> = holes
            .iter()
            .filter(|h| h.hinge_mm == holes[0].hinge_mm)
            .collect();
        assert_eq!(pair.len(), 2);
        let c = local_corners_dir(f, pair[0].edge);
        for (kh, lh) in pair.iter().zip(&screws) {
            let d = [kh.at_mm[0] - kh.hinge_mm[0], kh.at_mm[1] - kh.hinge_mm[1]];
            let along = d[0] * c[0] + d[1] * c[1];
            let into = -d[0] * c[1] + d[1] * c[0];
            assert!(
                (along - lh.centre_mm[0]).abs() < 0.01,
                "{along} vs {:?}",
                lh.centre_mm
            );
            assert!(
                (into - lh.centre_mm[1]).abs() < 0.01,
                "{into} vs {:?}",
                lh.centre_mm
            );
            assert!(ring_vertices(&leaf, lh) >= 8);
        }
    }

    fn local_corners_dir(f: &crate::nest::KitFacet, edge: usize) -> [f64; 2] {
        let c = crate::nest::local_corners(f);
        let (a, b) = (c[edge], c[(edge + 1) % 3]);
        let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        [(b[0] - a[0]) / l, (b[1] - a[1]) / l]
    }

    #[test]
    fn the_hinge_pin_rises_with_the_fold_range_and_bad_input_is_refused() {
        let r = |f: f64| {
            hinge_dims(&PartParams {
                fold_max_deg: f,
                ..Default::default()
            })
            .unwrap()
            .knuckle_r_mm
        };
        assert!(r(60.0) <= r(120.0) && r(120.0) <= r(180.0));
        // Flat fold: the screw heads' tops must stay clearance/2 below the axis.
        assert!((r(180.0) - (LEAF_MM + M4_HEAD_HEIGHT_MM + 0.5 * CLEARANCE_MM)).abs() < 0.01);
        for bad in [0.0, -5.0, 181.0, f64::NAN] {
            let e = hinge_dims(&PartParams {
                fold_max_deg: bad,
                ..Default::default()
            })
            .unwrap_err();
            assert!(e.to_string().contains("--fold-max-deg"), "{e}");
        }
        for bad in [5.0, 0.0, 51.0, f64::INFINITY] {
            let e = hinge_dims(&PartParams {
                panel_mm: bad,
                ..Default::default()
            })
            .unwrap_err();
            assert!(e.to_string().contains("--panel-mm"), "{e}");
        }
        for bad in [40.0, 51.3, 1001.0, f64::NAN] {
            let e = crane_parts(
                &trunk(),
                &PartParams {
                    tendon_radius_mm: bad,
                    ..Default::default()
                },
            )
            .unwrap_err();
            assert!(e.to_string().contains("--tendon-radius-mm"), "{e}");
        }
    }
}
