//! Dynamic programming over frames (paper §4.2, "exploit overlapping subproblems").
//!
//! The subproblem after j modules is determined by the top frame F_j alone: the cost of the
//! remaining tips depends only on F_j (and j). So two prefixes of the same length that reach the
//! same frame share all their futures, and the one with the higher cost so far can be dropped —
//! Bellman's principle, exactly. Distinct state sequences do reach identical frames (e.g. `D`
//! then `F` and `F` then `D` are commuting translations) but rarely, so the DP also **merges
//! near-equal frames**, and that is its approximation:
//!
//! - **Merge rule.** Two prefixes of the same length are merged when their frames fall in the
//!   same cell of a grid with spacing `position_tolerance` (units of l) over the frame origin and
//!   spacing `angle_tolerance_deg` (in radians, as chord length) over the entries of the rotation
//!   matrix. The prefix with the lower cost so far is kept; the other's futures are represented
//!   by its survivor, whose tips differ by at most the cell size plus the lever arm times the
//!   rotation difference. The DP is exact (`optimal: true`) only when both tolerances are 0
//!   (frames then merge only when equal to within 1e-9) and the cap is never hit.
//! - **Cap.** If a layer still holds more than `max_states` frames, only the `max_states` best
//!   by cost-so-far plus the reachable-set bound of the next tip are kept; the solution then
//!   carries no guarantee. The cap keeps memory bounded for long booms.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use super::reach::Reach;
use super::{Control, Frame, IkError, Problem, Raw};

/// Parameters of the frame-merging dynamic programme.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DpParams {
    /// Grid spacing of frame origins, units of l (0 = merge only equal frames).
    pub position_tolerance: f64,
    /// Grid spacing of rotation-matrix entries, as an angle in degrees (0 = merge only equal).
    pub angle_tolerance_deg: f64,
    /// Most frames kept per layer.
    pub max_states: usize,
}

impl Default for DpParams {
    fn default() -> Self {
        DpParams {
            position_tolerance: 0.1,
            angle_tolerance_deg: 5.0,
            max_states: 5_000,
        }
    }
}

/// How many tips ahead the cap's ranking bound looks.
const CAP_HORIZON: usize = 1;

/// A fast hasher for the integer frame keys (multiply–rotate; HashDoS is not a concern here).
#[derive(Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            let mut w = [0u8; 8];
            w.copy_from_slice(c);
            self.write_u64(u64::from_le_bytes(w));
        }
        for b in chunks.remainder() {
            self.write_u64(u64::from(*b));
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}

type KeyMap = HashMap<[i64; 12], u32, BuildHasherDefault<KeyHasher>>;

#[derive(Clone, Copy)]
struct State {
    g: f64,
    frame: Frame,
    parent: u32,
    cand: u16,
}

fn key(f: &Frame, pos: f64, rot: f64) -> [i64; 12] {
    let mut k = [0i64; 12];
    // floor(q) without a libm call.
    let floor = |q: f64| {
        let t = q as i64;
        t - i64::from(q < t as f64)
    };
    for (slot, v) in k.iter_mut().zip(f.translation.iter()) {
        *slot = floor(v / pos);
    }
    for (slot, v) in k[3..].iter_mut().zip(f.rotation.iter()) {
        *slot = floor(v / rot);
    }
    k
}

pub(crate) fn solve(
    problem: &Problem,
    params: DpParams,
    control: &Control,
) -> Result<Raw, IkError> {
    let valid = |x: f64| x.is_finite() && x >= 0.0;
    if !valid(params.position_tolerance)
        || !valid(params.angle_tolerance_deg)
        || params.max_states == 0
    {
        return Err(IkError::Parameter(format!(
            "dp tolerances must be finite and ≥ 0 and the state cap ≥ 1 (got {params:?})"
        )));
    }
    let exact_merge = params.position_tolerance == 0.0 && params.angle_tolerance_deg == 0.0;
    let pos = if params.position_tolerance > 0.0 {
        params.position_tolerance
    } else {
        1e-9
    };
    let rot = if params.angle_tolerance_deg > 0.0 {
        params.angle_tolerance_deg.to_radians()
    } else {
        1e-9
    };
    let m = problem.m();
    let obj = &problem.objective;
    let reach = Reach::new(&problem.catalogue, CAP_HORIZON);
    let mut layers: Vec<Vec<(u32, u16)>> = Vec::with_capacity(m);
    let mut cur = vec![State {
        g: 0.0,
        frame: Frame::identity(),
        parent: 0,
        cand: 0,
    }];
    let mut evaluated = 0u64;
    let mut capped = false;
    let mut interrupted = false;
    for j in 0..m {
        if control.stopped() {
            interrupted = true;
            break;
        }
        let cands = problem.catalogue.candidates(j);
        let mut index = KeyMap::with_capacity_and_hasher(cur.len() * 2, Default::default());
        let mut next: Vec<State> = Vec::with_capacity(cur.len() * 2);
        for (pi, s) in cur.iter().enumerate() {
            for (a, c) in cands.iter().enumerate() {
                let f = s.frame.compose(&c.frame);
                let g = s.g + obj.cost(j, &f.origin());
                let st = State {
                    g,
                    frame: f,
                    parent: pi as u32,
                    cand: a as u16,
                };
                match index.entry(key(&f, pos, rot)) {
                    std::collections::hash_map::Entry::Occupied(e) => {
                        let slot = &mut next[*e.get() as usize];
                        if g < slot.g {
                            *slot = st;
                        }
                    }
                    std::collections::hash_map::Entry::Vacant(e) => {
                        e.insert(next.len() as u32);
                        next.push(st);
                    }
                }
            }
        }
        let expanded = (cur.len() * cands.len()) as u64;
        evaluated += expanded;
        control.add_evaluated(expanded);
        if next.len() > params.max_states {
            capped = true;
            let mut scored: Vec<(f64, State)> = next
                .into_iter()
                .map(|s| {
                    let h = if j + 1 < m {
                        reach.suffix_lower_bound(obj, &s.frame, j + 1, f64::INFINITY)
                    } else {
                        0.0
                    };
                    (s.g + h, s)
                })
                .collect();
            scored.select_nth_unstable_by(params.max_states - 1, |a, b| a.0.total_cmp(&b.0));
            scored.truncate(params.max_states);
            next = scored.into_iter().map(|x| x.1).collect();
        }
        layers.push(next.iter().map(|s| (s.parent, s.cand)).collect());
        cur = next;
    }
    let (states, n) =
        super::beam::trace_back_best(problem, &layers, cur.iter().map(|s| (s.g, s.frame)));
    evaluated += n;
    control.offer_best(problem.cost_sum(&states));
    Ok(Raw {
        states,
        optimal: exact_merge && !capped && !interrupted,
        evaluated,
        interrupted,
        lower_bound: None,
        stop: None,
    })
}
