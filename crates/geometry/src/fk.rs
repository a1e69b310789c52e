//! Forward kinematics of a stack of modules (eqs 33–35), allocation-free.
//!
//! Module 1 is the bottom module. Its bottom boundary is the eq 3 polygon in the world
//! xy-plane; the frame of module k's bottom boundary is T1⋯T(k−1), so the tip (top centroid)
//! of module k is x_k = T1⋯Tk·x0 with x0 the origin (eq 35). Lengths are in units of l
//! (the valley fold length, the polygon edge), **not** eq 33's d/r: see `docs/geometry.md`.
//! Modules may have different β but must share n (their boundaries must be congruent).

use nalgebra::{Isometry3, Point3};

use crate::design::ModuleDesign;
use crate::pose::Pose;
use crate::state::ShapeState;

/// `out` was too short for the number of modules.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputTooShort {
    /// Capacity of the slice that was passed.
    pub capacity: usize,
}

impl core::fmt::Display for OutputTooShort {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "more modules than the {} output slots", self.capacity)
    }
}

impl core::error::Error for OutputTooShort {}

/// Iterator over the cumulative frames T1, T1·T2, …, T1⋯Tm of a stack, one per pose.
#[derive(Debug, Clone)]
pub struct Frames<I> {
    poses: I,
    acc: Isometry3<f64>,
}

impl<I: Iterator<Item = Pose>> Iterator for Frames<I> {
    type Item = Isometry3<f64>;

    fn next(&mut self) -> Option<Isometry3<f64>> {
        let p = self.poses.next()?;
        self.acc *= p.isometry();
        Some(self.acc)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.poses.size_hint()
    }
}

/// Cumulative frames of the top boundary of each module, bottom module first.
pub fn frames<I: IntoIterator<Item = Pose>>(poses: I) -> Frames<I::IntoIter> {
    Frames {
        poses: poses.into_iter(),
        acc: Isometry3::identity(),
    }
}

/// Iterator over the tips x_1 … x_m (eq 35), bottom module first.
#[derive(Debug, Clone)]
pub struct Tips<I> {
    frames: Frames<I>,
}

impl<I: Iterator<Item = Pose>> Iterator for Tips<I> {
    type Item = Point3<f64>;

    fn next(&mut self) -> Option<Point3<f64>> {
        self.frames
            .next()
            .map(|f| Point3::from(f.translation.vector))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.frames.size_hint()
    }
}

/// The tips x_i = T1⋯Ti·x0 of a stack given each module's pose, bottom module first.
pub fn tips<I: IntoIterator<Item = Pose>>(poses: I) -> Tips<I::IntoIter> {
    Tips {
        frames: frames(poses),
    }
}

/// The tips of a stack given each module's design and catalogue state.
pub fn tips_of_states<I>(modules: I) -> Tips<impl Iterator<Item = Pose>>
where
    I: IntoIterator<Item = (ModuleDesign, ShapeState)>,
{
    tips(
        modules
            .into_iter()
            .map(|(design, state)| design.pose(state)),
    )
}

/// Writes the tips of a stack into `out`, returning how many were written.
pub fn fill_tips<I>(poses: I, out: &mut [Point3<f64>]) -> Result<usize, OutputTooShort>
where
    I: IntoIterator<Item = Pose>,
{
    let capacity = out.len();
    let mut count = 0;
    for tip in tips(poses) {
        let slot = out.get_mut(count).ok_or(OutputTooShort { capacity })?;
        *slot = tip;
        count += 1;
    }
    Ok(count)
}

/// Writes the tips of a stack of (design, state) modules into `out`.
pub fn fill_tips_of_states<I>(modules: I, out: &mut [Point3<f64>]) -> Result<usize, OutputTooShort>
where
    I: IntoIterator<Item = (ModuleDesign, ShapeState)>,
{
    fill_tips(
        modules
            .into_iter()
            .map(|(design, state)| design.pose(state)),
        out,
    )
}

/// The tip of the whole stack (the last x_m), or the origin for an empty stack.
pub fn end_tip<I: IntoIterator<Item = Pose>>(poses: I) -> Point3<f64> {
    tips(poses).last().unwrap_or_else(Point3::origin)
}
