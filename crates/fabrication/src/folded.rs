//! The pattern folded into 3D: coordinates of every pattern vertex for a state per layer,
//! from `geometry::Module3d` (catalogue states) and `geometry::SelfPacked3d` (self-packed,
//! flat-folded), chained with the eq 5 transforms as `geometry::fk` does.
//!
//! Per layer, B_j, T_j and P_i come from the construction; E_j is the midpoint of the boundary
//! edge (the bend point of the hyperfold); X_j is the midpoint of the rhombus diagonal its
//! column folds along (`Module3d::column`: the mid valley fold P_{j−1}P_j when folded, the
//! virtual crease B_jT_j when stretched), or K_j of the hyperfold. A boundary row shared by two
//! layers takes the lower layer's top: if the upper layer's bottom differs (a self-packed
//! boundary under a catalogue state, or modules of different β packed together), the upper
//! layer's faces carry that mismatch as strain instead of leaving a hole.

use geometry::construct::ColumnFold;
use geometry::{Module3d, ModuleDesign, Pose, ShapeState, SymmetricState};
use nalgebra::{Isometry3, Point3, Vector3};

use crate::pattern::{LineKind, Pattern, VertexRole};
use crate::trunk::FabError;

/// The state of one layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayerState {
    /// A catalogue state (deployed, folded, edge-i, vertex-i).
    Shape(ShapeState),
    /// Self-packed (the hyperfold, β ∈ (90°/n, 45°]).
    SelfPacked,
    /// Flat-folded (β = 90°/n).
    FlatFolded,
}

impl std::fmt::Display for LayerState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LayerState::Shape(s) => write!(f, "{s}"),
            LayerState::SelfPacked => f.write_str("self-packed"),
            LayerState::FlatFolded => f.write_str("flat-folded"),
        }
    }
}

impl LayerState {
    /// Parses a state name for `design`: `deployed`, `folded`, `edge-i`, `vertex-i`,
    /// `self-packed`, `flat-folded`. A state whose closed form does not exist for this β is
    /// an error that says where it exists.
    pub fn parse(design: &ModuleDesign, name: &str) -> Result<Self, FabError> {
        let t = name.trim();
        let beta = design.beta_deg();
        let ff = design.flat_foldable_beta_deg();
        if t.eq_ignore_ascii_case("self-packed") {
            return if design.can_self_pack() {
                Ok(LayerState::SelfPacked)
            } else {
                Err(FabError::new(format!(
                    "self-packed does not exist for β = {beta}°: it needs β in ({ff:.4}°, 45°]"
                )))
            };
        }
        if t.eq_ignore_ascii_case("flat-folded") {
            return if design.is_flat_foldable() {
                Ok(LayerState::FlatFolded)
            } else {
                Err(FabError::new(format!(
                    "flat-folded does not exist for β = {beta}°: it needs β = 90°/n = {ff:.4}°"
                )))
            };
        }
        let s = ShapeState::parse(t, design.n()).map_err(|e| {
            FabError::new(format!(
                "'{t}': {e} (and self-packed, flat-folded where β allows)"
            ))
        })?;
        if !design.state_exists(s) {
            return Err(FabError::new(format!(
                "state '{s}' does not exist for n = {}, β = {beta}° ({})",
                design.n(),
                match s {
                    ShapeState::Folded => format!("folded needs β ≥ 90°/n = {ff:.4}°"),
                    _ => "pop-outs need w = tan β ≤ 2λ".to_string(),
                }
            )));
        }
        Ok(LayerState::Shape(s))
    }

    /// The pose (for chaining layers): the catalogue pose, or d = 0 for the packed states.
    pub fn pose(&self, design: &ModuleDesign) -> Pose {
        match self {
            LayerState::Shape(s) => design.pose(*s),
            LayerState::SelfPacked => design
                .symmetric_pose(SymmetricState::SelfPacked)
                .unwrap_or(Pose::straight(0.0)),
            LayerState::FlatFolded => design
                .symmetric_pose(SymmetricState::FlatFolded)
                .unwrap_or(Pose::straight(0.0)),
        }
    }

    /// Whether the geometry crate calls this state feasible for `design` (catalogue states:
    /// `StateInfo::feasible`; the packed states exist exactly where they parse).
    pub fn feasible(&self, design: &ModuleDesign) -> bool {
        match self {
            LayerState::Shape(s) => design.state_info(*s).feasible,
            LayerState::SelfPacked => design.can_self_pack(),
            LayerState::FlatFolded => design.is_flat_foldable(),
        }
    }
}

/// Local coordinates of one layer (its own frame: bottom boundary at z = 0 for catalogue
/// states; the hyperfold's boundary plane at z = 0 for the packed states).
struct LayerPoints {
    b: Vec<Point3<f64>>,
    t: Vec<Point3<f64>>,
    p: Vec<Point3<f64>>,
    e_bottom: Vec<Point3<f64>>,
    e_top: Vec<Point3<f64>>,
    x: Vec<Point3<f64>>,
}

fn midpoint(a: Point3<f64>, b: Point3<f64>) -> Point3<f64> {
    Point3::from((a.coords + b.coords) * 0.5)
}

fn layer_points(design: &ModuleDesign, state: LayerState) -> Result<LayerPoints, FabError> {
    let n = design.n() as usize;
    match state {
        LayerState::Shape(s) => {
            let m = Module3d::build(design, &design.pose(s));
            Ok(from_module3d(&m, n))
        }
        LayerState::SelfPacked | LayerState::FlatFolded => {
            let sp = design
                .build_self_packed()
                .map_err(|e| FabError::new(format!("{state}: {e}")))?;
            let lift = -sp.bottom()[0].z;
            let sh = |q: Point3<f64>| q + Vector3::new(0.0, 0.0, lift);
            let b: Vec<_> = sp.bottom().iter().map(|&q| sh(q)).collect();
            let e: Vec<_> = (0..n).map(|j| sh(sp.edge_bend(j))).collect();
            Ok(LayerPoints {
                t: b.clone(),
                b,
                p: sp.mid().iter().map(|&q| sh(q)).collect(),
                e_top: e.clone(),
                e_bottom: e,
                x: (0..n).map(|j| sh(sp.mid_fold_bend(j))).collect(),
            })
        }
    }
}

fn from_module3d(m: &Module3d, n: usize) -> LayerPoints {
    let (b, t, p) = (m.bottom().to_vec(), m.top().to_vec(), m.mid().to_vec());
    let e_bottom = (0..n).map(|j| midpoint(b[j], b[(j + 1) % n])).collect();
    let e_top = (0..n).map(|j| midpoint(t[j], t[(j + 1) % n])).collect();
    let x = (0..n)
        .map(|j| match m.column(j).1 {
            ColumnFold::Folded => midpoint(p[(j + n - 1) % n], p[j]),
            ColumnFold::Stretched => midpoint(b[j], t[j]),
        })
        .collect();
    LayerPoints {
        b,
        t,
        p,
        e_bottom,
        e_top,
        x,
    }
}

/// The pattern in one configuration.
#[derive(Debug, Clone)]
pub struct Folded {
    /// 3D position of every pattern vertex, units of l (seam copies coincide).
    pub coords: Vec<Point3<f64>>,
    /// State of each layer.
    pub states: Vec<LayerState>,
    /// Whether every layer's state is feasible for its design.
    pub feasible: bool,
    /// Largest relative edge-length error of any face against the flat pattern.
    pub max_strain: f64,
    /// Relative edge-length error of each face (same order as `Pattern::faces`).
    pub face_strain: Vec<f64>,
    /// Largest absolute edge-length error of any face, units of l (the isometry
    /// measure; the relative `max_strain` is the stricter one on long edges).
    pub max_length_error: f64,
}

/// Folds `pattern` with one state per layer (bottom first).
pub fn fold(pattern: &Pattern, states: &[LayerState]) -> Result<Folded, FabError> {
    let layers = pattern.layers();
    if states.len() != layers.len() {
        return Err(FabError::new(format!(
            "{} states for {} layers",
            states.len(),
            layers.len()
        )));
    }
    let n = pattern.trunk().n() as usize;
    let mut frame = Isometry3::identity();
    let mut row_coords: Vec<Vec<Point3<f64>>> = Vec::with_capacity(layers.len() + 1);
    let mut row_e: Vec<Vec<Point3<f64>>> = Vec::with_capacity(layers.len() + 1);
    let mut mid_p: Vec<Vec<Point3<f64>>> = Vec::new();
    let mut mid_x: Vec<Vec<Point3<f64>>> = Vec::new();
    let mut feasible = true;
    for (k, ((_, design), state)) in layers.iter().zip(states).enumerate() {
        let lp = layer_points(design, *state)?;
        feasible &= state.feasible(design);
        let w = |q: &Point3<f64>| frame * q;
        if k == 0 {
            row_coords.push(lp.b.iter().map(w).collect());
            row_e.push(lp.e_bottom.iter().map(w).collect());
        }
        mid_p.push(lp.p.iter().map(w).collect());
        mid_x.push(lp.x.iter().map(w).collect());
        row_coords.push(lp.t.iter().map(w).collect());
        row_e.push(lp.e_top.iter().map(w).collect());
        frame *= state.pose(design).isometry();
    }
    let coords: Vec<Point3<f64>> = (0..pattern.vertices.len())
        .map(|v| match pattern.roles[v] {
            VertexRole::B { row, j } => row_coords[row][j % n],
            VertexRole::E { row, j } => row_e[row][j],
            VertexRole::P { layer, i } => mid_p[layer][i],
            VertexRole::X { layer, j } => mid_x[layer][j % n],
        })
        .collect();
    let face_strain: Vec<f64> = pattern
        .faces
        .iter()
        .map(|f| {
            (0..3)
                .map(|k| {
                    let (a, b) = (f.v[k], f.v[(k + 1) % 3]);
                    let flat = crate::pattern::dist2(pattern.vertices[a], pattern.vertices[b]);
                    ((coords[a] - coords[b]).norm() - flat).abs() / flat
                })
                .fold(0.0, f64::max)
        })
        .collect();
    let max_strain = face_strain.iter().copied().fold(0.0, f64::max);
    let max_length_error = pattern
        .faces
        .iter()
        .flat_map(|f| (0..3).map(move |k| (f.v[k], f.v[(k + 1) % 3])))
        .map(|(a, b)| {
            let flat = crate::pattern::dist2(pattern.vertices[a], pattern.vertices[b]);
            ((coords[a] - coords[b]).norm() - flat).abs()
        })
        .fold(0.0, f64::max);
    Ok(Folded {
        max_length_error,
        coords,
        states: states.to_vec(),
        feasible,
        max_strain,
        face_strain,
    })
}

/// For each pattern edge, its faces: (the face with the edge counter-clockwise as u → v,
/// the face on the other side), `None` on the boundary.
pub fn edge_faces(pattern: &Pattern) -> Vec<[Option<usize>; 2]> {
    use std::collections::HashMap;
    let mut directed: HashMap<(usize, usize), usize> = HashMap::new();
    for (fi, f) in pattern.faces.iter().enumerate() {
        for k in 0..3 {
            directed.insert((f.v[k], f.v[(k + 1) % 3]), fi);
        }
    }
    pattern
        .edges
        .iter()
        .map(|e| {
            let (u, v) = (e.v[0], e.v[1]);
            [
                directed.get(&(u, v)).copied(),
                directed.get(&(v, u)).copied(),
            ]
        })
        .collect()
}

/// FOLD fold angle of every edge in degrees (valley > 0, mountain < 0, 0 flat and on the
/// boundary), from the 3D face normals. At ±180° (faces folded onto each other, where the sign
/// is numerically undefined) the pattern's assignment gives the sign.
pub fn fold_angles(pattern: &Pattern, folded: &Folded) -> Vec<f64> {
    let adj = edge_faces(pattern);
    let normal = |fi: usize| {
        let f = &pattern.faces[fi];
        let c = &folded.coords;
        (c[f.v[1]] - c[f.v[0]]).cross(&(c[f.v[2]] - c[f.v[0]]))
    };
    pattern
        .edges
        .iter()
        .zip(&adj)
        .map(|(e, faces)| {
            let [Some(f1), Some(f2)] = *faces else {
                return 0.0;
            };
            let (n1, n2) = (normal(f1), normal(f2));
            let (l1, l2) = (n1.norm(), n2.norm());
            if l1 == 0.0 || l2 == 0.0 {
                return 0.0;
            }
            let dir = folded.coords[e.v[1]] - folded.coords[e.v[0]];
            let dl = dir.norm();
            if dl == 0.0 {
                return 0.0;
            }
            let s = n1.cross(&n2).dot(&dir) / (l1 * l2 * dl);
            let c = n1.dot(&n2) / (l1 * l2);
            let mut a = -s.atan2(c).to_degrees();
            if 180.0 - a.abs() < 1e-6 {
                a = match e.kind {
                    LineKind::Mountain => -180.0,
                    LineKind::Valley => 180.0,
                    _ => a,
                };
            }
            if a.abs() < 1e-9 {
                0.0
            } else {
                a
            }
        })
        .collect()
}
