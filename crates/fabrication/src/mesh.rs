//! Triangle meshes: closed prisms for the panel, open sheets for the model, the checks every
//! printable mesh must pass (closed, consistently oriented 2-manifold, positive volume), and
//! binary STL via `stl_io`.

use std::collections::HashMap;

/// An indexed triangle mesh (mm unless stated otherwise), with an optional colour per triangle.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// Name (3MF object name, STL header).
    pub name: String,
    /// Vertex positions.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles, counter-clockwise seen from outside (normals point out).
    pub triangles: Vec<[u32; 3]>,
    /// Linear RGBA colour of each triangle, if coloured.
    pub colours: Vec<[f32; 4]>,
}

/// Why a mesh is not a valid solid.
#[derive(Debug, Clone, PartialEq)]
pub enum SolidError {
    /// An edge is used by other than exactly two triangles, or twice in the same direction.
    NotManifold {
        /// The offending edge's vertices.
        edge: [u32; 2],
        /// How many triangles use it in the direction a → b and b → a.
        uses: (usize, usize),
    },
    /// A triangle has zero area.
    Degenerate(usize),
    /// The enclosed volume is not positive (inside out or empty).
    NonPositiveVolume(f64),
}

impl std::fmt::Display for SolidError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SolidError::NotManifold { edge, uses } => write!(
                f,
                "edge {edge:?} is used {}×/{}× (must be once each way)",
                uses.0, uses.1
            ),
            SolidError::Degenerate(t) => write!(f, "triangle {t} has zero area"),
            SolidError::NonPositiveVolume(v) => write!(f, "volume {v} is not positive"),
        }
    }
}

impl Mesh {
    /// An empty mesh called `name`.
    pub fn new(name: impl Into<String>) -> Self {
        Mesh {
            name: name.into(),
            ..Default::default()
        }
    }

    fn push(&mut self, p: [f64; 3]) -> u32 {
        self.vertices.push(p);
        (self.vertices.len() - 1) as u32
    }

    /// Adds a triangle (with `colour` if the mesh is coloured).
    pub fn triangle(&mut self, a: [f64; 3], b: [f64; 3], c: [f64; 3], colour: Option<[f32; 4]>) {
        let (i, j, k) = (self.push(a), self.push(b), self.push(c));
        self.triangles.push([i, j, k]);
        if let Some(c) = colour {
            self.colours.push(c);
        }
    }

    /// Adds the closed prism over the convex counter-clockwise polygon `poly` between heights
    /// `z0` < `z1`.
    pub fn prism(&mut self, poly: &[[f64; 2]], z0: f64, z1: f64) {
        let k = poly.len();
        let base = self.vertices.len() as u32;
        for p in poly {
            self.vertices.push([p[0], p[1], z0]);
        }
        for p in poly {
            self.vertices.push([p[0], p[1], z1]);
        }
        let b = |i: usize| base + (i % k) as u32;
        let t = |i: usize| base + (k + i % k) as u32;
        for i in 1..k - 1 {
            self.triangles.push([b(0), b(i + 1), b(i)]);
            self.triangles.push([t(0), t(i), t(i + 1)]);
        }
        for i in 0..k {
            self.triangles.push([b(i), b(i + 1), t(i + 1)]);
            self.triangles.push([b(i), t(i + 1), t(i)]);
        }
    }

    /// Signed enclosed volume (divergence theorem); positive for outward normals.
    pub fn volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum()
    }

    /// Checks the mesh is a closed, consistently oriented 2-manifold of positive volume
    /// (vertices are compared by index; [`Mesh::prism`] shares them).
    pub fn check_solid(&self) -> Result<(), SolidError> {
        let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
        for (ti, t) in self.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|i| self.vertices[i as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            if n.iter().all(|x| *x == 0.0) {
                return Err(SolidError::Degenerate(ti));
            }
            for k in 0..3 {
                *uses.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &uses {
            let back = uses.get(&(b, a)).copied().unwrap_or(0);
            if n != 1 || back != 1 {
                return Err(SolidError::NotManifold {
                    edge: [a, b],
                    uses: (n, back),
                });
            }
        }
        let v = self.volume();
        if v.is_nan() || v <= 0.0 {
            return Err(SolidError::NonPositiveVolume(v));
        }
        Ok(())
    }

    /// Axis-aligned bounds (min, max).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for v in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        (lo, hi)
    }

    /// Writes binary STL (`stl_io`), coordinates as they are (mm).
    pub fn write_stl<W: std::io::Write + ?Sized>(&self, out: &mut W) -> std::io::Result<()> {
        let tris: Vec<stl_io::Triangle> = self
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let mut n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if l > 0.0 {
                    n = n.map(|x| x / l);
                }
                let f = |p: [f64; 3]| stl_io::Vertex::new(p.map(|x| x as f32));
                stl_io::Triangle {
                    normal: stl_io::Normal::new(n.map(|x| x as f32)),
                    vertices: [f(a), f(b), f(c)],
                }
            })
            .collect();
        let mut buf = Vec::new();
        stl_io::write_stl(&mut buf, tris.iter())?;
        out.write_all(&buf)
    }
}

/// Offsets the convex counter-clockwise polygon `poly` inwards by `delta` (each edge moved
/// along its inward normal, consecutive lines intersected). `None` if it vanishes or inverts.
pub fn inset(poly: &[[f64; 2]], delta: f64) -> Option<Vec<[f64; 2]>> {
    let k = poly.len();
    let lines: Vec<([f64; 2], [f64; 2])> = (0..k)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % k]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let l = (dx * dx + dy * dy).sqrt();
            let nrm = [-dy / l, dx / l]; // inward for counter-clockwise
            ([a[0] + nrm[0] * delta, a[1] + nrm[1] * delta], [dx, dy])
        })
        .collect();
    let mut out = Vec::with_capacity(k);
    for i in 0..k {
        let (p, r) = lines[(i + k - 1) % k];
        let (q, s) = lines[i];
        let den = r[0] * s[1] - r[1] * s[0];
        if den.abs() < 1e-300 {
            return None;
        }
        let t = ((q[0] - p[0]) * s[1] - (q[1] - p[1]) * s[0]) / den;
        out.push([p[0] + t * r[0], p[1] + t * r[1]]);
    }
    // Still counter-clockwise with positive area?
    let area: f64 = (0..k)
        .map(|i| {
            let (a, b) = (out[i], out[(i + 1) % k]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        * 0.5;
    (area > 0.0).then_some(out)
}

/// Inradius of a triangle.
pub fn inradius(t: &[[f64; 2]; 3]) -> f64 {
    let d = |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
    let (a, b, c) = (d(t[1], t[2]), d(t[2], t[0]), d(t[0], t[1]));
    let s = 0.5 * (a + b + c);
    let area = ((s * (s - a) * (s - b) * (s - c)).max(0.0)).sqrt();
    area / s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prism_is_a_solid_with_the_right_volume() {
        let mut m = Mesh::new("p");
        m.prism(&[[0.0, 0.0], [2.0, 0.0], [0.0, 3.0]], 1.0, 1.5);
        m.check_solid().unwrap();
        assert!((m.volume() - 3.0 * 0.5).abs() < 1e-12);
        let mut inside_out = m.clone();
        for t in &mut inside_out.triangles {
            t.swap(1, 2);
        }
        assert!(matches!(
            inside_out.check_solid(),
            Err(SolidError::NonPositiveVolume(_))
        ));
        let mut open = m.clone();
        open.triangles.pop();
        assert!(matches!(
            open.check_solid(),
            Err(SolidError::NotManifold { .. })
        ));
    }

    #[test]
    fn inset_of_a_triangle_keeps_its_incentre_and_shrinks_its_inradius() {
        let t = [[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]]; // inradius 1
        assert!((inradius(&t) - 1.0).abs() < 1e-12);
        let s = inset(&t, 0.25).unwrap();
        let s3 = [s[0], s[1], s[2]];
        assert!((inradius(&s3) - 0.75).abs() < 1e-12);
        assert!(inset(&t, 1.0 + 1e-9).is_none());
    }
}
