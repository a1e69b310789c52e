//! Reachable-set covers: where the tips of the remaining modules can be, relative to a frame.
//!
//! For a suffix that starts after `j` placed modules, the tip of the k-th next module (k ≥ 1)
//! lies in `R(j,k) = { T(j,a1)⋯T(j+k−1,ak)·0 }`, a set of ∏K points expressed in the frame of
//! the j-th top boundary. We cover each `R(j,k)` by at most [`MAX_BALLS`] balls, built
//! recursively: `R(j,k) = ∪_a T(j,a)·R(j+1,k−1)`; the images of the balls covering
//! `R(j+1,k−1)` cover `R(j,k)` and are merged greedily into fewer, larger balls. Covers with at
//! most `MAX_BALLS` points are exact (radius 0).
//!
//! A lower bound for the remaining cost from frame F is then
//! `Σ_k min_{balls b of R(j,k)} lb(F·c_b, ρ_b)`, where `lb` bounds the per-tip cost below over
//! a ball. It is admissible because every real suffix puts its k-th tip inside some ball of
//! `R(j,k)`, and each term is minimised independently (a relaxation).

use nalgebra::{Point3, Vector3};

use super::{Catalogue, Frame, Objective};

/// Maximum number of balls per cover.
pub const MAX_BALLS: usize = 64;

/// A ball (centre in a module frame, radius), units of l.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Centre.
    pub center: Vector3<f64>,
    /// Radius.
    pub radius: f64,
}

/// One cover of a reachable set.
#[derive(Debug, Clone)]
struct Cover {
    /// The balls, grouped: group g is `balls[groups[g].1..groups[g].2]`.
    balls: Vec<Ball>,
    /// (enclosing ball, start, end) of each group; empty for small covers.
    groups: Vec<(Ball, usize, usize)>,
}

/// Groups per cover for the two-level minimum of [`Reach::suffix_lower_bound_grouped`].
const GROUPS: usize = 8;

impl Cover {
    /// The cover used for bounds of the k-th next tip. (Coarser covers for larger k were tried:
    /// 64/64/32/16 balls made beam search markedly worse on the smooth-curve suite.) Covers of
    /// more than 2·[`GROUPS`] balls are also clustered into [`GROUPS`] groups, each with a ball
    /// enclosing its members.
    fn new(balls: Vec<Ball>, _k: usize) -> Self {
        if balls.len() <= 2 * GROUPS {
            return Cover {
                balls,
                groups: Vec::new(),
            };
        }
        let mut ordered = Vec::with_capacity(balls.len());
        let mut groups = Vec::new();
        for g in cluster(&balls, GROUPS) {
            let start = ordered.len();
            ordered.extend_from_slice(&g);
            groups.push((enclose(&g), start, ordered.len()));
        }
        Cover {
            balls: ordered,
            groups,
        }
    }
}

/// Covers of `R(j,k)` for every suffix start j and length `k ≤ horizon`.
#[derive(Debug, Clone)]
pub struct Reach {
    /// `covers[j][k-1]`; when the catalogue is uniform only `covers[0]` is stored.
    covers: Vec<Vec<Cover>>,
    uniform: bool,
    m: usize,
    horizon: usize,
    /// Whether [`suffix_lower_bound`](Self::suffix_lower_bound) uses the target's fine grid.
    fine: bool,
}

impl Reach {
    /// These covers, with [`suffix_lower_bound`](Self::suffix_lower_bound) on the target's fine
    /// lower-bound grid (once built: `Target::prepare_fine_bounds`).
    pub fn with_fine_bounds(mut self) -> Self {
        self.fine = true;
        self
    }

    /// Covers for a boom of `catalogue`, for suffix lengths up to `horizon`.
    pub fn new(catalogue: &Catalogue, horizon: usize) -> Self {
        let m = catalogue.len();
        let horizon = horizon.min(m).max(1);
        let uniform = catalogue.is_uniform();
        let mut covers: Vec<Vec<Cover>> = vec![Vec::new(); if uniform { 1 } else { m }];
        if uniform {
            // R(k) = ∪_a T_a · R(k−1), independent of j.
            let cands = catalogue.candidates(0);
            let mut prev = vec![Ball {
                center: Vector3::zeros(),
                radius: 0.0,
            }];
            for _ in 0..horizon {
                let next = cover_union(cands.iter().map(|c| &c.frame), &prev);
                let k = covers[0].len() + 1;
                covers[0].push(Cover::new(next.clone(), k));
                prev = next;
            }
        } else {
            // covers[j][k-1] from the full-resolution cover of (j+1, k-1).
            let mut full: Vec<Vec<Vec<Ball>>> = vec![Vec::new(); m];
            for j in (0..m).rev() {
                let cands = catalogue.candidates(j);
                let kmax = horizon.min(m - j);
                for k in 1..=kmax {
                    let prev: Vec<Ball> = if k == 1 {
                        vec![Ball {
                            center: Vector3::zeros(),
                            radius: 0.0,
                        }]
                    } else {
                        full[j + 1][k - 2].clone()
                    };
                    let c = cover_union(cands.iter().map(|c| &c.frame), &prev);
                    covers[j].push(Cover::new(c.clone(), k));
                    full[j].push(c);
                }
            }
        }
        Reach {
            covers,
            uniform,
            m,
            horizon,
            fine: false,
        }
    }

    /// The balls covering `R(j,k)` (k ≥ 1, `j + k ≤ m`, `k ≤ horizon`).
    #[inline]
    pub fn cover(&self, j: usize, k: usize) -> &[Ball] {
        &self.cover_of(j, k).balls
    }

    #[inline]
    fn cover_of(&self, j: usize, k: usize) -> &Cover {
        if self.uniform {
            &self.covers[0][k - 1]
        } else {
            &self.covers[j][k - 1]
        }
    }

    /// Admissible lower bound on the cost of tips `j..min(m, j+horizon)` (0-based) given the
    /// frame after `j` modules. Stops early (returning a value `> budget`) once the bound
    /// exceeds `budget`.
    #[inline]
    pub fn suffix_lower_bound(&self, obj: &Objective, frame: &Frame, j: usize, budget: f64) -> f64 {
        let kmax = self.horizon.min(self.m - j);
        let mut sum = 0.0;
        for k in 1..=kmax {
            let tip = j + k - 1;
            let cover = self.cover_of(j, k);
            let mut best = f64::INFINITY;
            for b in &cover.balls {
                let v = if self.fine {
                    ball_lb_fine(obj, tip, frame, b)
                } else {
                    ball_lb(obj, tip, frame, b)
                };
                if v < best {
                    best = v;
                    if best == 0.0 {
                        break;
                    }
                }
            }
            sum += best;
            if sum > budget {
                return sum;
            }
        }
        sum
    }

    /// Like [`suffix_lower_bound`](Self::suffix_lower_bound), but each tip's minimum over the
    /// balls is taken group by group, most promising group first, skipping every group whose
    /// enclosing ball's bound is already no better than the best so far. The result is still a
    /// lower bound (every skipped ball lies in a ball whose bound is at least the result), though
    /// it may exceed the plain minimum where the grid bound is not monotone in the radius.
    #[inline]
    pub fn suffix_lower_bound_grouped(
        &self,
        obj: &Objective,
        frame: &Frame,
        j: usize,
        budget: f64,
    ) -> f64 {
        self.suffix_from(obj, frame, j, 1, budget)
    }

    /// Sum of [`tip_lower_bound`](Self::tip_lower_bound) over the offsets `k0..` of the
    /// remaining tips, stopping once it exceeds `budget`.
    #[inline]
    pub fn suffix_from(
        &self,
        obj: &Objective,
        frame: &Frame,
        j: usize,
        k0: usize,
        budget: f64,
    ) -> f64 {
        self.suffix_range(obj, frame, j, k0, usize::MAX, budget)
    }

    /// [`suffix_from`](Self::suffix_from) over the offsets `k0..=k1` only.
    #[inline]
    pub fn suffix_range(
        &self,
        obj: &Objective,
        frame: &Frame,
        j: usize,
        k0: usize,
        k1: usize,
        budget: f64,
    ) -> f64 {
        let kmax = self.horizon.min(self.m - j).min(k1);
        let mut sum = 0.0;
        for k in k0..=kmax {
            sum += self.tip_lower_bound(obj, frame, j, k);
            if sum > budget {
                return sum;
            }
        }
        sum
    }

    /// Lower bound on the cost of the k-th next tip (k ≥ 1) after `j` modules with top frame
    /// `frame`: the two-level minimum over the cover of `R(j,k)` (see
    /// [`suffix_lower_bound_grouped`](Self::suffix_lower_bound_grouped)).
    #[inline]
    pub fn tip_lower_bound(&self, obj: &Objective, frame: &Frame, j: usize, k: usize) -> f64 {
        let tip = j + k - 1;
        let cover = self.cover_of(j, k);
        let mut best = f64::INFINITY;
        if cover.groups.is_empty() {
            for b in &cover.balls {
                let v = ball_lb_fine(obj, tip, frame, b);
                if v < best {
                    best = v;
                    if best == 0.0 {
                        break;
                    }
                }
            }
            return best;
        }
        let mut order = [(0.0f64, 0usize); GROUPS];
        let ng = cover.groups.len().min(GROUPS);
        for (i, (g, slot)) in cover.groups.iter().zip(order.iter_mut()).enumerate() {
            *slot = (ball_lb_fine(obj, tip, frame, &g.0), i);
        }
        order[..ng].sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for &(v, g) in &order[..ng] {
            if v >= best {
                break;
            }
            let (_, lo, hi) = cover.groups[g];
            for b in &cover.balls[lo..hi] {
                let v = ball_lb_fine(obj, tip, frame, b);
                if v < best {
                    best = v;
                    if best == 0.0 {
                        return 0.0;
                    }
                }
            }
        }
        best
    }
}

#[inline(always)]
fn ball_lb(obj: &Objective, tip: usize, frame: &Frame, b: &Ball) -> f64 {
    obj.ball_lower_bound(tip, &frame.apply_vec(&b.center), b.radius)
}

#[inline(always)]
fn ball_lb_fine(obj: &Objective, tip: usize, frame: &Frame, b: &Ball) -> f64 {
    obj.ball_lower_bound_fine(tip, &frame.apply_vec(&b.center), b.radius)
}

pub(crate) fn cover_union<'a>(frames: impl Iterator<Item = &'a Frame>, prev: &[Ball]) -> Vec<Ball> {
    let mut balls = Vec::new();
    for f in frames {
        for b in prev {
            balls.push(Ball {
                center: f.apply_vec(&b.center).coords,
                radius: b.radius,
            });
        }
    }
    merge(balls, MAX_BALLS)
}

/// Merges `balls` into at most `max` balls that together contain them all: exact duplicates
/// dropped, then [`cluster`]ed, each cluster replaced by its [`enclose`]ing ball.
fn merge(mut balls: Vec<Ball>, max: usize) -> Vec<Ball> {
    // Exact duplicates are common (commuting translations); drop them first.
    balls.sort_by(|a, b| {
        a.center
            .iter()
            .chain(std::iter::once(&a.radius))
            .zip(b.center.iter().chain(std::iter::once(&b.radius)))
            .map(|(x, y)| x.total_cmp(y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    balls.dedup_by(|a, b| (a.center - b.center).norm() < 1e-12 && a.radius <= b.radius);
    if balls.len() <= max {
        return balls;
    }
    cluster(&balls, max).iter().map(|g| enclose(g)).collect()
}

/// Splits `balls` into at most `max` non-empty groups: farthest-point seeds (the first the ball
/// farthest from the centroid), then nearest-seed assignment.
pub(crate) fn cluster(balls: &[Ball], max: usize) -> Vec<Vec<Ball>> {
    cluster_indices(balls, max)
        .into_iter()
        .map(|g| g.into_iter().map(|i| balls[i]).collect())
        .collect()
}

/// [`cluster`], as indices into `balls` (every index in exactly one group).
pub(crate) fn cluster_indices(balls: &[Ball], max: usize) -> Vec<Vec<usize>> {
    let centroid: Vector3<f64> =
        balls.iter().map(|b| b.center).sum::<Vector3<f64>>() / balls.len().max(1) as f64;
    let first = balls
        .iter()
        .max_by(|a, b| {
            (a.center - centroid)
                .norm_squared()
                .total_cmp(&(b.center - centroid).norm_squared())
        })
        .map(|b| b.center)
        .unwrap_or(centroid);
    let mut seeds: Vec<Vector3<f64>> = vec![first];
    let mut near: Vec<f64> = balls
        .iter()
        .map(|b| (b.center - first).norm_squared())
        .collect();
    while seeds.len() < max.min(balls.len()) {
        let (i, _) = near
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &0.0));
        let s = balls[i].center;
        seeds.push(s);
        for (d, b) in near.iter_mut().zip(balls) {
            *d = d.min((b.center - s).norm_squared());
        }
    }
    let mut groups: Vec<Vec<usize>> = vec![Vec::new(); seeds.len()];
    for (bi, b) in balls.iter().enumerate() {
        let (i, _) = seeds
            .iter()
            .enumerate()
            .map(|(i, s)| (i, (b.center - s).norm_squared()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, 0.0));
        groups[i].push(bi);
    }
    groups.retain(|g| !g.is_empty());
    groups
}

/// A ball containing every ball of `group`, centred on the middle of their centres' bounding
/// box (a hair larger so rounding never leaves a point outside).
pub(crate) fn enclose(group: &[Ball]) -> Ball {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for b in group {
        lo = lo.inf(&b.center);
        hi = hi.sup(&b.center);
    }
    let center = (lo + hi) * 0.5;
    let radius = group
        .iter()
        .map(|b| (b.center - center).norm() + b.radius)
        .fold(0.0, f64::max);
    Ball {
        center,
        radius: radius * (1.0 + 1e-12) + 1e-12,
    }
}

/// Whether `p` lies in one of `balls` (for tests).
pub fn covers(balls: &[Ball], p: &Point3<f64>) -> bool {
    balls
        .iter()
        .any(|b| (p.coords - b.center).norm() <= b.radius + 1e-9)
}
