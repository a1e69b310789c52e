//! The printable dual-material panel (paper §5.3): a TPU 95A base sheet with nylon facets
//! printed on it, a gap between neighbouring facets where the TPU alone forms the hinge.
//!
//! Base: the whole sheet (crease pattern plus seam allowance) as one box, z ∈ [0, t_base].
//! Facets: every facet triangle of the pattern (inner triangles and the two triangles of each
//! rhombus; column 0's rhombus is cut by the seam into halves at both ends of the sheet),
//! inset by half the gap of its module on every side, extruded z ∈ [t_base, t_base + t_facet].
//! So neighbouring facets are exactly one gap apart (two gaps' halves), facets on a module
//! interface are half a gap from each side, and no facet reaches the sheet edge or the tab.
//! The virtual creases are not gapped: the paper prints whole triangular facets.
//!
//! Two objects, two materials, one 3MF (written by [`crate::threemf`]).

use std::io::{Seek, Write};

use crate::mesh::{inradius, inset, Mesh};
use crate::pattern::Pattern;
use crate::threemf;
use crate::trunk::FabError;

/// Panel parameters (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct PanelParams {
    /// Gap between neighbouring facets, one per module (bottom first).
    pub gap_mm: Vec<f64>,
    /// Nylon facet thickness.
    pub facet_mm: f64,
    /// TPU base sheet thickness.
    pub base_mm: f64,
}

/// Largest thickness accepted for either layer, mm.
pub const MAX_THICKNESS_MM: f64 = 20.0;

/// The panel: base sheet and facets.
#[derive(Debug, Clone)]
pub struct Panel {
    /// TPU base sheet.
    pub base: Mesh,
    /// Nylon facets (one closed prism per facet).
    pub facets: Mesh,
    /// Number of facets.
    pub facet_count: usize,
    /// Parameters.
    pub params: PanelParams,
    /// Sheet size (x, y) in mm.
    pub sheet_mm: (f64, f64),
}

/// Facet triangles of every layer, counter-clockwise, in mm, with their module index.
pub fn facet_triangles(p: &Pattern) -> Vec<([[f64; 2]; 3], usize)> {
    let l = p.trunk().edge_mm();
    let n = p.trunk().n() as usize;
    let at = |v: usize| [p.vertices[v][0] * l, p.vertices[v][1] * l];
    let mut out = Vec::new();
    for (k, &(module, _)) in p.layers().iter().enumerate() {
        let (lo, hi) = (k, k + 1);
        for i in 0..n {
            let pi = p.p(k, i);
            out.push(([at(p.b(lo, i)), at(p.b(lo, i + 1)), at(pi)], module));
            out.push(([at(p.b(hi, i + 1)), at(p.b(hi, i)), at(pi)], module));
        }
        for j in 1..n {
            let (pl, pr) = (p.p(k, j - 1), p.p(k, j));
            out.push(([at(p.b(lo, j)), at(pr), at(pl)], module));
            out.push(([at(p.b(hi, j)), at(pl), at(pr)], module));
        }
        // Column 0, cut open by the seam: right halves at x = 0, left halves at x = n.
        let (x0, xn) = (p.x(k, 0), p.x(k, n));
        let (p0, pl) = (p.p(k, 0), p.p(k, n - 1));
        out.push(([at(p.b(lo, 0)), at(p0), at(x0)], module));
        out.push(([at(x0), at(p0), at(p.b(hi, 0))], module));
        out.push(([at(p.b(lo, n)), at(xn), at(pl)], module));
        out.push(([at(xn), at(p.b(hi, n)), at(pl)], module));
    }
    out
}

impl Panel {
    /// Builds the panel of `pattern`. Every gap must be positive (facets that touch would
    /// share faces: not a printable solid) and smaller than twice the smallest facet's
    /// inradius (the facet would vanish); thicknesses in (0, 20] mm.
    pub fn new(pattern: &Pattern, params: PanelParams) -> Result<Self, FabError> {
        let modules = pattern.trunk().modules().len();
        if params.gap_mm.len() != modules {
            return Err(FabError::new(format!(
                "{} gap widths for {modules} modules",
                params.gap_mm.len()
            )));
        }
        for (name, t) in [("facet", params.facet_mm), ("base", params.base_mm)] {
            if !(t.is_finite() && t > 0.0 && t <= MAX_THICKNESS_MM) {
                return Err(FabError::new(format!(
                    "the {name} thickness must be in (0, {MAX_THICKNESS_MM}] mm, got {t}"
                )));
            }
        }
        let tris = facet_triangles(pattern);
        for (m, &gap) in params.gap_mm.iter().enumerate() {
            let smallest = tris
                .iter()
                .filter(|(_, k)| *k == m)
                .map(|(t, _)| inradius(t))
                .fold(f64::INFINITY, f64::min);
            // Keep at least 1 µm of facet: the limit is strict.
            let limit = 2.0 * smallest;
            if !(gap.is_finite() && gap > 0.0 && gap < limit - 2e-3) {
                return Err(FabError::new(format!(
                    "the gap of module {} must be in (0, {:.3}) mm (positive, and below twice the smallest facet's inradius {:.3} mm), got {gap}",
                    m + 1,
                    limit - 2e-3,
                    smallest
                )));
            }
        }
        let l = pattern.trunk().edge_mm();
        let sheet = ((pattern.width() + pattern.seam()) * l, pattern.height() * l);
        let mut base = Mesh::new("base (TPU 95A)");
        base.prism(
            &[
                [0.0, 0.0],
                [sheet.0, 0.0],
                [sheet.0, sheet.1],
                [0.0, sheet.1],
            ],
            0.0,
            params.base_mm,
        );
        let mut facets = Mesh::new("facets (nylon)");
        let (z0, z1) = (params.base_mm, params.base_mm + params.facet_mm);
        for (t, m) in &tris {
            let poly = inset(t, 0.5 * params.gap_mm[*m]).ok_or_else(|| {
                FabError::new(format!(
                    "the gap {} mm leaves no facet (module {})",
                    params.gap_mm[*m],
                    m + 1
                ))
            })?;
            facets.prism(&poly, z0, z1);
        }
        Ok(Panel {
            base,
            facets,
            facet_count: tris.len(),
            params,
            sheet_mm: sheet,
        })
    }

    /// Writes the 3MF package ([`crate::threemf`]): two objects (base, facets), each with its
    /// base material, and the print parameters as metadata.
    pub fn write_3mf<W: Write + Seek>(
        &self,
        pattern: &Pattern,
        application: &str,
        out: W,
    ) -> std::io::Result<()> {
        self.model(pattern, application).write(out)
    }

    /// The print parameters written to the 3MF metadata (name, value).
    pub fn metadata(&self, pattern: &Pattern) -> Vec<(String, String)> {
        let t = pattern.trunk();
        let list = |v: Vec<String>| v.join(",");
        vec![
            ("ys:base_material".into(), "TPU 95A".into()),
            ("ys:facet_material".into(), "Nylon (PA)".into()),
            ("ys:base_mm".into(), self.params.base_mm.to_string()),
            ("ys:facet_mm".into(), self.params.facet_mm.to_string()),
            (
                "ys:gap_mm".into(),
                list(self.params.gap_mm.iter().map(|g| g.to_string()).collect()),
            ),
            ("ys:edge_mm".into(), t.edge_mm().to_string()),
            (
                "ys:seam_mm".into(),
                (pattern.seam() * t.edge_mm()).to_string(),
            ),
            ("ys:n".into(), t.n().to_string()),
            (
                "ys:beta_deg".into(),
                list(
                    t.modules()
                        .iter()
                        .map(|m| m.design.beta_deg().to_string())
                        .collect(),
                ),
            ),
            (
                "ys:layers".into(),
                list(t.modules().iter().map(|m| m.layers.to_string()).collect()),
            ),
            (
                "ys:sheet_mm".into(),
                format!("{:.3} x {:.3}", self.sheet_mm.0, self.sheet_mm.1),
            ),
            ("ys:facet_count".into(), self.facet_count.to_string()),
        ]
    }

    /// The 3MF model: metadata, the two materials, the two objects.
    pub fn model(&self, pattern: &Pattern, application: &str) -> threemf::Model<'_> {
        let title = format!("Yoshimura trunk panel: {}", pattern.trunk().describe());
        let desc = format!(
            "Dual-material panel (paper §5.3): print the base object in TPU 95A and the facets object in nylon, \
             as one multi-part object at these positions. Sheet {:.1} x {:.1} mm, base {} mm, facets {} mm, gap {} mm. \
             Then coat the back, cure at 120 °C, bond and roll into the cylinder over the seam allowance, \
             heat-treat at 140 °C and anneal at 120 °C for 2 h (§5.3).",
            self.sheet_mm.0,
            self.sheet_mm.1,
            self.params.base_mm,
            self.params.facet_mm,
            self.params.gap_mm.iter().map(|g| g.to_string()).collect::<Vec<_>>().join(",")
        );
        let mut metadata = vec![
            ("Title".to_string(), title),
            ("Designer".to_string(), "host-tool pattern".to_string()),
            ("Application".to_string(), application.to_string()),
            ("Description".to_string(), desc),
        ];
        metadata.extend(self.metadata(pattern));
        let material = |name: &str, colour: &str| threemf::Material {
            name: name.to_string(),
            colour: colour.to_string(),
        };
        threemf::Model {
            metadata,
            materials: vec![
                material("TPU 95A (base sheet)", "#3A3A3AFF"),
                material("Nylon (facets)", "#EDE8D8FF"),
            ],
            objects: vec![
                threemf::Object {
                    mesh: &self.base,
                    material: 0,
                },
                threemf::Object {
                    mesh: &self.facets,
                    material: 1,
                },
            ],
        }
    }
}
