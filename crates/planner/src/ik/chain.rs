//! Chain covers: a lower bound on the remaining tips that couples them through the frame.
//!
//! [`super::reach`] bounds every remaining tip independently: tip j+k may sit anywhere in its
//! reachable set `R(j,k)`. Here the tips are kept together. For a suffix that starts after `j`
//! placed modules, level k (k = 1..H) holds at most [`MAX_CLUSTERS`] balls (in the frame of the
//! j-th top boundary) covering the k-th next tip of every suffix, and every ball of level k ≥ 2
//! carries the set of level k−1 balls (a bit mask, its *parents*) that hold the (k−1)-th tip of
//! the same suffixes. So every suffix traces a path of balls, one per level, each ball a parent
//! of the next, with its k-th tip in the path's level-k ball. A lower bound on the cost of the
//! next H tips is the cheapest such path, the sum of per-ball lower bounds: a shortest path
//! through a layered graph, solved per node by dynamic programming (H·[`MAX_CLUSTERS`] ball
//! bounds and the parent masks' edges).
//!
//! Built once per problem by the same recursion as the reach covers, with the first module
//! applied on the left (so no rotation doubt ever turns into position doubt: the images of balls
//! under a rigid map are balls of the same radius):
//!
//! - level 1 of suffix j: the points `T(j,a)·0`, each with the virtual root as parent;
//! - level k ≥ 2 of suffix j: the images `T(j,a)·b` of every level k−1 ball b of suffix j+1,
//!   clustered into at most [`MAX_CLUSTERS`] enclosing balls; the image `(a, b)` has as parents
//!   the level k−1 balls of suffix j holding the images `(a, p)` of b's parents p (for k = 2:
//!   the ball holding `T(j,a)·0`); a cluster's parents are the union of its members'.
//!
//! Soundness (by induction over the suffix, proof in `docs/ik.md`): a suffix `(a, s')` of j has
//! tips `T(j,a)·0, T(j,a)·y'_1, …` where `y'_i` are the tips of `s'`, which lie on a path
//! `b'_1, …` of suffix j+1; then the balls of suffix j holding `T(j,a)·0` and the images
//! `(a, b'_i)` form a path of suffix j.

use super::reach::{cluster_indices, enclose, Ball};
use super::{Catalogue, Frame, Objective};

/// Largest number of balls per level (parents are a `u64` mask).
pub const MAX_CLUSTERS: usize = 64;

/// One level of a chain cover.
#[derive(Debug, Clone)]
struct Level {
    balls: Vec<Ball>,
    /// `parents[c]`: bit p set when ball p of the level below may hold the previous tip.
    parents: Vec<u64>,
    /// `of_member[a * n_prev + b]`: the ball of this level holding the image of ball b of the
    /// next suffix's level below (level 1: b = 0, the point `T_a·0`) under candidate a.
    of_member: Vec<u8>,
    /// Number of balls of the next suffix's level below (1 for level 1).
    n_prev: usize,
}

/// Chain covers of the next `horizon` tips for every suffix start j.
#[derive(Debug, Clone)]
pub struct Chains {
    /// `levels[j][k-1]`; only `levels[0]` when the catalogue is uniform.
    levels: Vec<Vec<Level>>,
    uniform: bool,
    m: usize,
    horizon: usize,
}

impl Chains {
    /// Chain covers of a boom of `catalogue` for the next `horizon` tips (at most).
    pub fn new(catalogue: &Catalogue, horizon: usize) -> Self {
        let m = catalogue.len();
        let horizon = horizon.min(m).max(1);
        let uniform = catalogue.is_uniform();
        let count = if uniform { 1 } else { m };
        let mut levels: Vec<Vec<Level>> = vec![Vec::new(); count];
        // Suffix j is built from suffix j+1 (the same one when uniform).
        for j in (0..count).rev() {
            let cands = catalogue.candidates(j);
            let kmax = if uniform { horizon } else { horizon.min(m - j) };
            let mut built: Vec<Level> = Vec::with_capacity(kmax);
            for k in 1..=kmax {
                let level = if k == 1 {
                    let balls: Vec<Ball> = cands
                        .iter()
                        .map(|c| Ball {
                            center: c.frame.translation,
                            radius: 0.0,
                        })
                        .collect();
                    first_level(balls)
                } else {
                    // The next suffix's level k−1 (and its parents' level k−2).
                    let next: &Level = if uniform {
                        &built[k - 2]
                    } else {
                        &levels[j + 1][k - 2]
                    };
                    let below = &built[k - 2];
                    let mut members = Vec::with_capacity(cands.len() * next.balls.len());
                    let mut member_parents = Vec::with_capacity(members.capacity());
                    for (a, c) in cands.iter().enumerate() {
                        for (b, ball) in next.balls.iter().enumerate() {
                            members.push(Ball {
                                center: c.frame.apply_vec(&ball.center).coords,
                                radius: ball.radius,
                            });
                            // Parents: the balls of this suffix's level k−1 holding (a, p).
                            let mask = if k == 2 {
                                1u64 << below.of_member[a * below.n_prev]
                            } else {
                                let mut mask = 0u64;
                                let mut bits = next.parents[b];
                                while bits != 0 {
                                    let p = bits.trailing_zeros() as usize;
                                    bits &= bits - 1;
                                    mask |= 1u64 << below.of_member[a * below.n_prev + p];
                                }
                                mask
                            };
                            member_parents.push(mask);
                        }
                    }
                    merge_level(members, member_parents, next.balls.len())
                };
                built.push(level);
            }
            levels[j] = built;
        }
        Chains {
            levels,
            uniform,
            m,
            horizon,
        }
    }

    /// The number of levels available after `j` placed modules.
    #[inline]
    pub fn levels_after(&self, j: usize) -> usize {
        self.horizon.min(self.m - j)
    }

    #[inline]
    fn level(&self, j: usize, k: usize) -> &Level {
        if self.uniform {
            &self.levels[0][k - 1]
        } else {
            &self.levels[j][k - 1]
        }
    }

    /// A lower bound on the cost of the next `h` tips (tips `j..j+h`, 0-based, `h ≤`
    /// [`levels_after`](Self::levels_after)) after `j` modules with top frame `frame`: the
    /// cheapest path of balls. Returns early (a value `> budget`) once every path's first levels
    /// already cost more than `budget`.
    pub fn lower_bound(
        &self,
        obj: &Objective,
        frame: &Frame,
        j: usize,
        h: usize,
        budget: f64,
    ) -> f64 {
        let mut prev = [0.0f64; MAX_CLUSTERS];
        let mut cur = [0.0f64; MAX_CLUSTERS];
        let mut n_prev = 0;
        for k in 1..=h {
            let level = self.level(j, k);
            let tip = j + k - 1;
            let mut least = f64::INFINITY;
            for (c, b) in level.balls.iter().enumerate() {
                let path = if k == 1 {
                    0.0
                } else {
                    let mut best = f64::INFINITY;
                    let mut bits = level.parents[c];
                    while bits != 0 {
                        let p = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        best = best.min(prev[p]);
                    }
                    best
                };
                let v = if path <= budget {
                    path + obj.ball_lower_bound_fine(tip, &frame.apply_vec(&b.center), b.radius)
                } else {
                    // Already over budget: the path's cost so far is a lower bound for it.
                    path
                };
                cur[c] = v;
                least = least.min(v);
            }
            if least > budget {
                return least;
            }
            n_prev = level.balls.len();
            prev[..n_prev].copy_from_slice(&cur[..n_prev]);
        }
        prev[..n_prev].iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// The balls and parent masks of level k after `j` modules (for tests).
    pub fn level_balls(&self, j: usize, k: usize) -> (&[Ball], &[u64]) {
        let l = self.level(j, k);
        (&l.balls, &l.parents)
    }
}

fn first_level(balls: Vec<Ball>) -> Level {
    let parents = vec![1u64; balls.len()];
    merge_level(balls, parents, 1)
}

/// Clusters `members` (member i has parent mask `parents[i]`; members come in blocks of
/// `n_prev`, one block per candidate) into at most [`MAX_CLUSTERS`] enclosing balls.
fn merge_level(members: Vec<Ball>, parents: Vec<u64>, n_prev: usize) -> Level {
    if members.len() <= MAX_CLUSTERS {
        return Level {
            of_member: (0..members.len()).map(|i| i as u8).collect(),
            balls: members,
            parents,
            n_prev,
        };
    }
    let groups = cluster_indices(&members, MAX_CLUSTERS);
    let mut of_member = vec![0u8; members.len()];
    let mut balls = Vec::with_capacity(groups.len());
    let mut masks = Vec::with_capacity(groups.len());
    for (g, idx) in groups.iter().enumerate() {
        let group: Vec<Ball> = idx.iter().map(|&i| members[i]).collect();
        balls.push(enclose(&group));
        let mut mask = 0u64;
        for &i in idx {
            of_member[i] = g as u8;
            mask |= parents[i];
        }
        masks.push(mask);
    }
    Level {
        balls,
        parents: masks,
        of_member,
        n_prev,
    }
}
