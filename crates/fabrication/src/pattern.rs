//! The flat crease pattern of a whole trunk, in units of l.
//!
//! # Layout
//!
//! x runs around the trunk (vertex j of eq 3 at x = j), y up the trunk (layer k between
//! y_k = Σ_{i<k} w_i and y_k + w_k). Each layer has, as in `geometry::construct`:
//!
//! * boundary rows of vertices B_j at (j, y_k) and E_j at (j + ½, y_k) (the midpoint of the
//!   boundary valley fold B_jB_{j+1}, where the virtual crease of the inner triangle ends);
//! * a mid row of P_i at (i + ½, y_k + w/2) and X_j at (j, y_k + w/2) (the centre of the
//!   rhombus B_j P_{j−1} T_j P_j, the midpoint of the mid valley fold).
//!
//! Creases: boundary valley folds (length 1, split at E), mountain folds B_iP_i, B_{i+1}P_i,
//! T_iP_i, T_{i+1}P_i (length a), mid valley folds P_{j−1}P_j (length 1, split at X), and the
//! virtual creases: P_iE_i across each inner triangle (length w/2) and B_jT_j across each
//! rhombus (length w, split at X). A rhombus folds along one diagonal (the mid valley fold
//! when its column is folded, the virtual crease when stretched, `docs/geometry.md`), and the
//! self-packed state bends every triangle along its virtual crease, so every facet triangle is
//! stored as its two right-triangle halves: 8n faces per layer, each counter-clockwise in the
//! plane (normal +z, which becomes the outside of the trunk).
//!
//! The pattern is cut open along the virtual crease B_0T_0: vertex column 0 appears twice,
//! at x = 0 and x = n. The seam allowance is a glue tab of width `seam` beyond x = n (not part
//! of the fold graph; [`Pattern::tab`]).

use geometry::ModuleDesign;

use crate::trunk::{FabError, Trunk};

/// What a line of the pattern is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum LineKind {
    /// Mountain fold (protrudes out of the trunk, towards the viewer of the pattern).
    Mountain,
    /// Valley fold.
    Valley,
    /// The pattern's edge (top and bottom of the trunk, the seam line).
    Boundary,
    /// Cut only, not part of the fold graph: the outline of the seam allowance.
    Cut,
    /// Virtual crease: not creased; the facet bends there in some states.
    Virtual,
}

impl LineKind {
    /// Every kind, in drawing order.
    pub const ALL: [LineKind; 5] = [
        LineKind::Virtual,
        LineKind::Valley,
        LineKind::Mountain,
        LineKind::Boundary,
        LineKind::Cut,
    ];

    /// Upper-case name (the DXF layer name).
    pub fn layer_name(self) -> &'static str {
        match self {
            LineKind::Mountain => "MOUNTAIN",
            LineKind::Valley => "VALLEY",
            LineKind::Boundary => "BOUNDARY",
            LineKind::Cut => "CUT",
            LineKind::Virtual => "VIRTUAL",
        }
    }

    /// FOLD `edges_assignment` of the flat pattern (`U`, unassigned, for virtual creases:
    /// they fold either way or not at all depending on the state).
    pub fn fold_assignment(self) -> &'static str {
        match self {
            LineKind::Mountain => "M",
            LineKind::Valley => "V",
            LineKind::Boundary | LineKind::Cut => "B",
            LineKind::Virtual => "U",
        }
    }
}

/// Which vertex of the layer structure a pattern vertex is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VertexRole {
    /// Boundary-row vertex B_j of row `row` (row k is the bottom of layer k).
    B {
        /// Row index, 0 … layers.
        row: usize,
        /// Column j, 0 … n (n is the seam copy of 0).
        j: usize,
    },
    /// Midpoint E_j of boundary valley fold j of row `row`.
    E {
        /// Row index.
        row: usize,
        /// Edge index j, 0 … n−1.
        j: usize,
    },
    /// Mid-plane vertex P_i of layer `layer`.
    P {
        /// Layer index.
        layer: usize,
        /// i, 0 … n−1.
        i: usize,
    },
    /// Rhombus centre X_j of layer `layer`.
    X {
        /// Layer index.
        layer: usize,
        /// Column j, 0 … n (n is the seam copy of 0).
        j: usize,
    },
}

/// One straight line of the fold graph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// Vertex indices.
    pub v: [usize; 2],
    /// What it is.
    pub kind: LineKind,
}

/// One triangular face (half of a facet triangle), counter-clockwise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Face {
    /// Vertex indices, counter-clockwise in the plane.
    pub v: [usize; 3],
    /// Layer index (bottom first).
    pub layer: usize,
    /// Module index (bottom first).
    pub module: usize,
    /// Which whole facet triangle of the layer it is half of (0 … 4n−1; the two halves of a
    /// facet share it): inner bottom i = i, inner top i = n + i, rhombus lower j = 2n + j,
    /// rhombus upper j = 3n + j (column 0's halves are at both ends of the cut pattern).
    pub facet: usize,
}

/// The trunk's crease pattern.
#[derive(Debug, Clone)]
pub struct Pattern {
    trunk: Trunk,
    layers: Vec<(usize, ModuleDesign)>,
    row_y: Vec<f64>,
    /// Vertex positions, units of l.
    pub vertices: Vec<[f64; 2]>,
    /// What each vertex is.
    pub roles: Vec<VertexRole>,
    /// Lines of the fold graph.
    pub edges: Vec<Edge>,
    /// Faces.
    pub faces: Vec<Face>,
    seam: f64,
    b_index: Vec<Vec<usize>>,
    e_index: Vec<Vec<usize>>,
    p_index: Vec<Vec<usize>>,
    x_index: Vec<Vec<usize>>,
}

impl Pattern {
    /// Builds the pattern of `trunk` with a seam allowance of `seam_mm` (0 for none, at most
    /// half an edge: the tab lies under the first half-column when the sheet is closed).
    pub fn new(trunk: &Trunk, seam_mm: f64) -> Result<Self, FabError> {
        let l = trunk.edge_mm();
        if !(seam_mm.is_finite() && (0.0..=0.5 * l).contains(&seam_mm)) {
            return Err(FabError::new(format!(
                "the seam allowance must be in [0, {}] mm (0 to half an edge), got {seam_mm}",
                0.5 * l
            )));
        }
        let n = trunk.n() as usize;
        let layers = trunk.layers();
        let count = layers.len();
        let mut row_y = vec![0.0];
        for (_, d) in &layers {
            let last = *row_y.last().unwrap_or(&0.0);
            row_y.push(last + d.w());
        }
        let mut p = Pattern {
            trunk: trunk.clone(),
            layers: layers.clone(),
            row_y,
            vertices: Vec::new(),
            roles: Vec::new(),
            edges: Vec::new(),
            faces: Vec::new(),
            seam: seam_mm / l,
            b_index: Vec::new(),
            e_index: Vec::new(),
            p_index: Vec::new(),
            x_index: Vec::new(),
        };
        for row in 0..=count {
            let y = p.row_y[row];
            let b: Vec<usize> = (0..=n)
                .map(|j| p.push_vertex([j as f64, y], VertexRole::B { row, j }))
                .collect();
            let e: Vec<usize> = (0..n)
                .map(|j| p.push_vertex([j as f64 + 0.5, y], VertexRole::E { row, j }))
                .collect();
            p.b_index.push(b);
            p.e_index.push(e);
        }
        for (layer, (_, d)) in layers.iter().enumerate() {
            let y = p.row_y[layer] + 0.5 * d.w();
            let ps: Vec<usize> = (0..n)
                .map(|i| p.push_vertex([i as f64 + 0.5, y], VertexRole::P { layer, i }))
                .collect();
            let xs: Vec<usize> = (0..=n)
                .map(|j| p.push_vertex([j as f64, y], VertexRole::X { layer, j }))
                .collect();
            p.p_index.push(ps);
            p.x_index.push(xs);
        }
        // Boundary rows.
        for row in 0..=count {
            let kind = if row == 0 || row == count {
                LineKind::Boundary
            } else {
                LineKind::Valley
            };
            for j in 0..n {
                let (b0, e, b1) = (p.b(row, j), p.e(row, j), p.b(row, j + 1));
                p.edges.push(Edge { v: [b0, e], kind });
                p.edges.push(Edge { v: [e, b1], kind });
            }
        }
        for (layer, &(module, _)) in layers.iter().enumerate() {
            let (lo, hi) = (layer, layer + 1);
            for i in 0..n {
                let pi = p.p(layer, i);
                for v in [p.b(lo, i), p.b(lo, i + 1), p.b(hi, i), p.b(hi, i + 1)] {
                    p.edges.push(Edge {
                        v: [v, pi],
                        kind: LineKind::Mountain,
                    });
                }
                p.edges.push(Edge {
                    v: [p.x(layer, i), pi],
                    kind: LineKind::Valley,
                });
                p.edges.push(Edge {
                    v: [pi, p.x(layer, i + 1)],
                    kind: LineKind::Valley,
                });
                for row in [lo, hi] {
                    p.edges.push(Edge {
                        v: [p.e(row, i), pi],
                        kind: LineKind::Virtual,
                    });
                }
            }
            for j in 0..=n {
                let kind = if j == 0 || j == n {
                    LineKind::Boundary
                } else {
                    LineKind::Virtual
                };
                let x = p.x(layer, j);
                p.edges.push(Edge {
                    v: [p.b(lo, j), x],
                    kind,
                });
                p.edges.push(Edge {
                    v: [x, p.b(hi, j)],
                    kind,
                });
            }
            // Faces, counter-clockwise.
            let mut face = |v: [usize; 3], facet: usize| {
                p.faces.push(Face {
                    v,
                    layer,
                    module,
                    facet,
                })
            };
            for i in 0..n {
                let pi = p.p_index[layer][i];
                let (b0, e, b1) = (p.b_index[lo][i], p.e_index[lo][i], p.b_index[lo][i + 1]);
                face([b0, e, pi], i);
                face([e, b1, pi], i);
                let (t0, et, t1) = (p.b_index[hi][i], p.e_index[hi][i], p.b_index[hi][i + 1]);
                face([t1, et, pi], n + i);
                face([et, t0, pi], n + i);
            }
            for j in 0..=n {
                let x = p.x_index[layer][j];
                let (b, t) = (p.b_index[lo][j], p.b_index[hi][j]);
                let col = j % n;
                if j < n {
                    let pr = p.p_index[layer][j];
                    face([b, pr, x], 2 * n + col);
                    face([x, pr, t], 3 * n + col);
                }
                if j > 0 {
                    let pl = p.p_index[layer][j - 1];
                    face([b, x, pl], 2 * n + col);
                    face([x, t, pl], 3 * n + col);
                }
            }
        }
        Ok(p)
    }

    fn push_vertex(&mut self, xy: [f64; 2], role: VertexRole) -> usize {
        self.vertices.push(xy);
        self.roles.push(role);
        self.vertices.len() - 1
    }

    /// Index of B_j in boundary row `row` (j ∈ 0..=n).
    pub fn b(&self, row: usize, j: usize) -> usize {
        self.b_index[row][j]
    }

    /// Index of E_j in boundary row `row` (j ∈ 0..n).
    pub fn e(&self, row: usize, j: usize) -> usize {
        self.e_index[row][j]
    }

    /// Index of P_i of `layer` (i ∈ 0..n).
    pub fn p(&self, layer: usize, i: usize) -> usize {
        self.p_index[layer][i]
    }

    /// Index of X_j of `layer` (j ∈ 0..=n).
    pub fn x(&self, layer: usize, j: usize) -> usize {
        self.x_index[layer][j]
    }

    /// The trunk.
    pub fn trunk(&self) -> &Trunk {
        &self.trunk
    }

    /// (module index, design) of each layer, bottom first.
    pub fn layers(&self) -> &[(usize, ModuleDesign)] {
        &self.layers
    }

    /// y of boundary row `row` (units of l).
    pub fn row_y(&self, row: usize) -> f64 {
        self.row_y[row]
    }

    /// Width of the crease pattern, n (units of l).
    pub fn width(&self) -> f64 {
        self.trunk.n() as f64
    }

    /// Height of the pattern, Σ w (units of l).
    pub fn height(&self) -> f64 {
        *self.row_y.last().unwrap_or(&0.0)
    }

    /// Seam allowance width (units of l).
    pub fn seam(&self) -> f64 {
        self.seam
    }

    /// The seam allowance's outline (cut lines) as segments, units of l; empty without one.
    pub fn tab(&self) -> Vec<([f64; 2], [f64; 2])> {
        if self.seam <= 0.0 {
            return Vec::new();
        }
        let (w, h, s) = (self.width(), self.height(), self.seam);
        vec![
            ([w, 0.0], [w + s, 0.0]),
            ([w + s, 0.0], [w + s, h]),
            ([w + s, h], [w, h]),
        ]
    }

    /// Every line to draw, with its kind, units of l: the fold graph's edges (the seam line
    /// x = n drawn as a virtual crease when a glue tab is attached there) and the tab's cuts.
    pub fn lines(&self) -> Vec<([f64; 2], [f64; 2], LineKind)> {
        let n = self.trunk.n() as usize;
        let with_tab = self.seam > 0.0;
        let mut out: Vec<_> = self
            .edges
            .iter()
            .map(|e| {
                let (a, b) = (self.vertices[e.v[0]], self.vertices[e.v[1]]);
                let on_tab_side = matches!(
                    (self.roles[e.v[0]], self.roles[e.v[1]]),
                    (VertexRole::B { j: ja, .. } | VertexRole::X { j: ja, .. },
                     VertexRole::B { j: jb, .. } | VertexRole::X { j: jb, .. }) if ja == n && jb == n
                );
                let kind = if with_tab && on_tab_side {
                    LineKind::Virtual
                } else {
                    e.kind
                };
                (a, b, kind)
            })
            .collect();
        out.extend(self.tab().into_iter().map(|(a, b)| (a, b, LineKind::Cut)));
        out
    }

    /// Flat length of edge `e` (units of l).
    pub fn edge_length(&self, e: &Edge) -> f64 {
        dist2(self.vertices[e.v[0]], self.vertices[e.v[1]])
    }

    /// Interior vertices: those on no boundary edge.
    pub fn interior_vertices(&self) -> Vec<usize> {
        let mut on_boundary = vec![false; self.vertices.len()];
        for e in &self.edges {
            if e.kind == LineKind::Boundary {
                on_boundary[e.v[0]] = true;
                on_boundary[e.v[1]] = true;
            }
        }
        (0..self.vertices.len())
            .filter(|&v| !on_boundary[v])
            .collect()
    }

    /// The 3D position key of a vertex: vertices that coincide when the sheet is closed (the
    /// seam copies at x = n) share it.
    pub fn closed_role(&self, v: usize) -> VertexRole {
        let n = self.trunk.n() as usize;
        match self.roles[v] {
            VertexRole::B { row, j } => VertexRole::B { row, j: j % n },
            VertexRole::X { layer, j } => VertexRole::X { layer, j: j % n },
            r => r,
        }
    }
}

pub(crate) fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}
