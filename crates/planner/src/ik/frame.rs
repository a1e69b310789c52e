//! A rigid transform in the compact form the solvers compose millions of times.

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};

/// A rigid transform `x ↦ R·x + t` (rotation matrix and translation, units of l).
///
/// The solvers compose these along a boom: the frame of module i's top boundary is
/// `T1⋯Ti`, and module i's tip is that frame's translation (eq 35).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Rotation part.
    pub rotation: Matrix3<f64>,
    /// Translation part: where the frame maps the origin.
    pub translation: Vector3<f64>,
}

impl Frame {
    /// The identity: the base frame of the boom (bottom centroid at the origin, growing along +z).
    pub fn identity() -> Self {
        Frame {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }

    /// The frame of a nalgebra isometry.
    pub fn from_isometry(iso: &Isometry3<f64>) -> Self {
        Frame {
            rotation: iso.rotation.to_rotation_matrix().into_inner(),
            translation: iso.translation.vector,
        }
    }

    /// `self ∘ other`: first `other`, then `self` (so `base.then(module)` is the frame above
    /// `module` stacked on `base`).
    #[inline]
    pub fn compose(&self, other: &Frame) -> Frame {
        Frame {
            rotation: self.rotation * other.rotation,
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// Where this frame maps a point.
    #[inline]
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.rotation * p.coords + self.translation)
    }

    /// Where this frame maps a point given by its coordinates.
    #[inline]
    pub fn apply_vec(&self, v: &Vector3<f64>) -> Point3<f64> {
        Point3::from(self.rotation * v + self.translation)
    }

    /// The origin of this frame (the tip, for a stacked boom's cumulative frame).
    #[inline]
    pub fn origin(&self) -> Point3<f64> {
        Point3::from(self.translation)
    }
}
