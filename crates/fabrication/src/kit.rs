//! The meter-scale kit (paper §7.1): laser-cut facets joined by printed hinges.
//!
//! The kit is a closed cylinder of separate facets (no seam, no glue tab): every facet is a
//! whole isosceles triangle, base l (a valley fold) and legs a (mountain folds), so all
//! facets of one module are congruent. Every crease between two facets carries hinges; the
//! trunk's top and bottom edges carry none.
//!
//! **Hinge placement.** The paper: hinges "located precisely at one-third intervals along the
//! crosslines, mirrored symmetrically around a perpendicular bisector through the midpoint of
//! the base line", 180 hinges and 720 screws for four 2 ft, β = 31.72° modules. It gives no
//! per-crease counts; we read it as:
//!
//! * a mountain fold (a facet's leg, length a) carries 2 hinges, at 1/3 and 2/3 of its length;
//! * a valley fold (a facet's base, length l) is split by its perpendicular bisector into two
//!   halves, each with hinges at its one-third points: 4 hinges, at 1/6, 1/3, 2/3, 5/6 of l,
//!   mirror images about the bisector;
//! * 4 screws per hinge (two into each facet, into heat-set inserts; Fig. 6a's inset).
//!
//! For n = 3 and four layers that is 2·48 mountain + 4·(12 mid + 9 interface) valley hinges
//! = 96 + 84 = **180 hinges, 720 screws**, the paper's figures (the reading with two hinges per
//! valley fold would give 138 and 552). In general: hinges = 8nL + 4n(2L − 1) = 4n(4L − 1) for
//! L layers in total, screws = 4 × hinges.

use serde_json::{json, Value};

use crate::pattern::Pattern;
use crate::trunk::Trunk;

/// Hinge positions along a mountain fold, as fractions of its length.
pub const MOUNTAIN_FRACTIONS: [f64; 2] = [1.0 / 3.0, 2.0 / 3.0];
/// Hinge positions along a valley fold, as fractions of its length.
pub const VALLEY_FRACTIONS: [f64; 4] = [1.0 / 6.0, 1.0 / 3.0, 2.0 / 3.0, 5.0 / 6.0];
/// Screws per hinge.
pub const SCREWS_PER_HINGE: usize = 4;

/// One facet type of the cut list.
#[derive(Debug, Clone, PartialEq)]
pub struct FacetType {
    /// Module index (bottom first).
    pub module: usize,
    /// β in degrees.
    pub beta_deg: f64,
    /// Base (valley fold) length, mm.
    pub base_mm: f64,
    /// Leg (mountain fold) length, mm.
    pub leg_mm: f64,
    /// Height (base to apex), mm.
    pub height_mm: f64,
    /// Apex angle 180° − 2β.
    pub apex_deg: f64,
    /// Area, mm².
    pub area_mm2: f64,
    /// How many to cut.
    pub count: usize,
}

/// Which crease a hinge sits on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HingeCrease {
    /// A mountain fold.
    Mountain,
    /// A mid valley fold (inside a layer).
    MidValley,
    /// A boundary valley fold between two layers.
    LayerValley,
}

impl HingeCrease {
    fn name(self) -> &'static str {
        match self {
            HingeCrease::Mountain => "mountain",
            HingeCrease::MidValley => "mid-valley",
            HingeCrease::LayerValley => "layer-valley",
        }
    }
}

/// One hinge.
#[derive(Debug, Clone, PartialEq)]
pub struct Hinge {
    /// Crease kind.
    pub crease: HingeCrease,
    /// Layer (for a layer valley: the layer below it).
    pub layer: usize,
    /// Position along the crease from its start (fraction of its length).
    pub fraction: f64,
    /// Position in the flat pattern, mm (x around the trunk, wrapped into [0, n·l)).
    pub at_mm: [f64; 2],
}

/// The kit.
#[derive(Debug, Clone)]
pub struct Kit {
    /// Description of the trunk.
    pub trunk: String,
    /// Cut list.
    pub facets: Vec<FacetType>,
    /// Every hinge.
    pub hinges: Vec<Hinge>,
    /// Creases by kind: (mountain, mid valley, layer valley).
    pub creases: (usize, usize, usize),
}

impl Kit {
    /// The kit for `trunk` (edge length = the facet base, e.g. 609.6 mm = 2 ft).
    pub fn new(trunk: &Trunk) -> Self {
        let l = trunk.edge_mm();
        let n = trunk.n() as usize;
        let facets = trunk
            .modules()
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let d = m.design;
                let h = 0.5 * d.w() * l;
                FacetType {
                    module: k,
                    beta_deg: d.beta_deg(),
                    base_mm: l,
                    leg_mm: d.a() * l,
                    height_mm: h,
                    apex_deg: 180.0 - 2.0 * d.beta_deg(),
                    area_mm2: 0.5 * l * h,
                    count: 4 * n * m.layers,
                }
            })
            .collect();
        // Pattern geometry without seam (positions wrap around the closed cylinder).
        let pattern = Pattern::new(trunk, 0.0).ok();
        let mut hinges = Vec::new();
        let mut creases = (0, 0, 0);
        if let Some(p) = &pattern {
            let width = n as f64 * l;
            let at = |v: usize| [p.vertices[v][0] * l, p.vertices[v][1] * l];
            let mut place = |crease, layer, a: [f64; 2], b: [f64; 2], fr: &[f64]| {
                for &f in fr {
                    let x = (a[0] + f * (b[0] - a[0])).rem_euclid(width);
                    hinges.push(Hinge {
                        crease,
                        layer,
                        fraction: f,
                        at_mm: [x, a[1] + f * (b[1] - a[1])],
                    });
                }
            };
            let layers = p.layers().len();
            for k in 0..layers {
                for i in 0..n {
                    let pi = at(p.p(k, i));
                    for b in [p.b(k, i), p.b(k, i + 1), p.b(k + 1, i), p.b(k + 1, i + 1)] {
                        place(HingeCrease::Mountain, k, at(b), pi, &MOUNTAIN_FRACTIONS);
                        creases.0 += 1;
                    }
                    // Mid valley fold P_i → P_{i+1} (P_{n−1} → P_0 crosses the closed seam).
                    let next = if i + 1 < n {
                        at(p.p(k, i + 1))
                    } else {
                        let q = at(p.p(k, 0));
                        [q[0] + width, q[1]]
                    };
                    place(HingeCrease::MidValley, k, pi, next, &VALLEY_FRACTIONS);
                    creases.1 += 1;
                }
                if k + 1 < layers {
                    for j in 0..n {
                        let (a, b) = (at(p.b(k + 1, j)), at(p.b(k + 1, j + 1)));
                        place(HingeCrease::LayerValley, k, a, b, &VALLEY_FRACTIONS);
                        creases.2 += 1;
                    }
                }
            }
        }
        Kit {
            trunk: trunk.describe(),
            facets,
            hinges,
            creases,
        }
    }

    /// Number of facets.
    pub fn facet_count(&self) -> usize {
        self.facets.iter().map(|f| f.count).sum()
    }

    /// Number of screws (and heat-set inserts).
    pub fn screws(&self) -> usize {
        SCREWS_PER_HINGE * self.hinges.len()
    }

    /// JSON form.
    pub fn to_json(&self) -> Value {
        json!({
            "trunk": self.trunk,
            "facet_count": self.facet_count(),
            "facets": self.facets.iter().map(|f| json!({
                "module": f.module + 1,
                "beta_deg": f.beta_deg,
                "shape": "isosceles triangle",
                "base_mm": f.base_mm,
                "leg_mm": f.leg_mm,
                "height_mm": f.height_mm,
                "base_angle_deg": f.beta_deg,
                "apex_angle_deg": f.apex_deg,
                "area_mm2": f.area_mm2,
                "count": f.count,
                "hinge_centres_along_base": VALLEY_FRACTIONS,
                "hinge_centres_along_each_leg": MOUNTAIN_FRACTIONS,
            })).collect::<Vec<_>>(),
            "creases": {
                "mountain": self.creases.0,
                "mid_valley": self.creases.1,
                "layer_valley": self.creases.2,
            },
            "hinges_per_crease": { "mountain": MOUNTAIN_FRACTIONS.len(), "valley": VALLEY_FRACTIONS.len() },
            "hinges": self.hinges.len(),
            "screws_per_hinge": SCREWS_PER_HINGE,
            "screws": self.screws(),
            "heat_set_inserts": self.screws(),
            "hinge_positions": self.hinges.iter().map(|h| json!({
                "crease": h.crease.name(),
                "layer": h.layer + 1,
                "fraction": h.fraction,
                "x_mm": h.at_mm[0],
                "y_mm": h.at_mm[1],
            })).collect::<Vec<_>>(),
            "rule": "mountain folds: hinges at 1/3 and 2/3; valley folds: at the one-third points of each half (1/6, 1/3, 2/3, 5/6), mirrored about the base's perpendicular bisector; 4 screws per hinge",
        })
    }

    /// Human-readable table.
    pub fn table(&self) -> String {
        let mut s = format!("meter-scale kit: {}\n\n", self.trunk);
        s += "  facets (laser-cut, isosceles triangles)\n";
        s += &format!(
            "  {:>6} {:>8} {:>10} {:>10} {:>10} {:>9} {:>6}\n",
            "module", "β (°)", "base (mm)", "leg (mm)", "height", "apex (°)", "count"
        );
        for f in &self.facets {
            s += &format!(
                "  {:>6} {:>8.3} {:>10.1} {:>10.1} {:>10.1} {:>9.2} {:>6}\n",
                f.module + 1,
                f.beta_deg,
                f.base_mm,
                f.leg_mm,
                f.height_mm,
                f.apex_deg,
                f.count
            );
        }
        s += &format!("  total facets {}\n\n", self.facet_count());
        s += &format!(
            "  creases: {} mountain × {} hinges, {} mid valley + {} layer valley × {} hinges\n",
            self.creases.0,
            MOUNTAIN_FRACTIONS.len(),
            self.creases.1,
            self.creases.2,
            VALLEY_FRACTIONS.len()
        );
        s += "  hinge centres: mountain folds at 1/3, 2/3; valley folds at 1/6, 1/3, 2/3, 5/6 (mirrored)\n";
        s += &format!(
            "  hinges {}   screws {} ({} per hinge)   heat-set inserts {}\n",
            self.hinges.len(),
            self.screws(),
            SCREWS_PER_HINGE,
            self.screws()
        );
        s
    }
}
