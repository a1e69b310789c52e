//! The eq 5 transform between a module's bottom and top boundaries.

use nalgebra::{Isometry3, Matrix4, Point3, Translation3, UnitQuaternion, Vector3};

/// The relative placement of a module's top boundary: slant height `d` (units of l), tilt
/// `gamma` (γ, radians, ≥ 0 in the catalogue) and phase `psi` (ψ, radians, in [0, 2π) in the
/// catalogue), in the frame of eq 3 (bottom vertex i at angle 360°·i/n).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Pose {
    /// Slant height: distance between the centroids of the bottom and top boundary, units of l.
    pub d: f64,
    /// Tilt between the bottom and top planes, radians.
    pub gamma: f64,
    /// Phase: direction of the tilt, radians. The hinge line of a tilted module points along
    /// (cos ψ, sin ψ, 0) and lies on the side at angle ψ − 90°.
    pub psi: f64,
}

impl Pose {
    /// A pose from its three parameters.
    pub const fn new(d: f64, gamma: f64, psi: f64) -> Self {
        Self { d, gamma, psi }
    }

    /// The straight pose of height `d` (γ = ψ = 0).
    pub const fn straight(d: f64) -> Self {
        Self {
            d,
            gamma: 0.0,
            psi: 0.0,
        }
    }

    /// T(d, γ, ψ) = Rz(ψ)·Rx(γ/2)·Tz(d)·Rx(γ/2)·Rz(−ψ), exactly eq 5, in closed form:
    /// rotation Rz(ψ)·Rx(γ)·Rz(−ψ) (angle γ about (cos ψ, sin ψ, 0)) and translation
    /// d·(sin ψ sin(γ/2), −cos ψ sin(γ/2), cos(γ/2)) (along the mid-plane normal).
    pub fn isometry(&self) -> Isometry3<f64> {
        let (sp, cp) = (libm::sin(self.psi), libm::cos(self.psi));
        let (sh, ch) = (libm::sin(0.5 * self.gamma), libm::cos(0.5 * self.gamma));
        // Quaternion of a rotation by γ about the unit axis (cos ψ, sin ψ, 0).
        let q = nalgebra::Quaternion::new(ch, sh * cp, sh * sp, 0.0);
        let rotation = UnitQuaternion::new_unchecked(q);
        let translation = Translation3::new(self.d * sp * sh, -self.d * cp * sh, self.d * ch);
        Isometry3::from_parts(translation, rotation)
    }

    /// The same transform as eq 5's literal product of five factors (slower; used to check
    /// [`Pose::isometry`]).
    pub fn isometry_by_factors(&self) -> Isometry3<f64> {
        let rz = |a: f64| Isometry3::rotation(Vector3::z() * a);
        let rx = |a: f64| Isometry3::rotation(Vector3::x() * a);
        let tz = Isometry3::translation(0.0, 0.0, self.d);
        rz(self.psi) * rx(0.5 * self.gamma) * tz * rx(0.5 * self.gamma) * rz(-self.psi)
    }

    /// The 4×4 homogeneous matrix of [`Pose::isometry`].
    pub fn matrix(&self) -> Matrix4<f64> {
        self.isometry().to_homogeneous()
    }

    /// Unit normal of the module's mid-plane (the plane that mirrors bottom onto top):
    /// Rz(ψ)·Rx(γ/2)·ẑ.
    pub fn mid_plane_normal(&self) -> Vector3<f64> {
        let (sp, cp) = (libm::sin(self.psi), libm::cos(self.psi));
        let (sh, ch) = (libm::sin(0.5 * self.gamma), libm::cos(0.5 * self.gamma));
        Vector3::new(sp * sh, -cp * sh, ch)
    }

    /// The top centroid T·x0 (eq 35 for one module).
    pub fn tip(&self) -> Point3<f64> {
        self.isometry() * Point3::origin()
    }
}
