//! Orientation kinematics: each module's top-face frame, its outward normal, and the compass.
//!
//! The top face of module k is its top boundary polygon. Its frame is the cumulative transform
//! T1⋯Tk of [`crate::fk::frames`]: the origin is the top centroid (the tip x_k of eq 35), the
//! rotation takes the base frame's axes to the face's, and the face's outward normal is the
//! rotation's third column (the top boundary is the bottom boundary, in the xy-plane with
//! normal +z, carried by T1⋯Tk).
//!
//! The base frame (x, y, z with z up, eq 3's bottom vertex 0 on +x) is placed on the compass
//! by its **heading**: the azimuth of its x axis in degrees clockwise from north. Heading 90°
//! puts x east and y north, so base coordinates are east-north-up (ENU). A direction is given
//! on the compass by azimuth (clockwise from north) and elevation (above the horizon).
//!
//! Everything here is allocation-free and total: non-finite inputs give non-finite outputs,
//! never a panic.

use nalgebra::{Isometry3, Point3, Rotation3, Unit, UnitQuaternion, Vector3};

use crate::pose::Pose;

/// The frame of a module's top face in the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TopFace {
    /// Top centroid (the module's tip, eq 35), units of l.
    pub origin: Point3<f64>,
    /// Rotation of the face relative to the base frame (T1⋯Tk's rotation).
    pub rotation: UnitQuaternion<f64>,
    /// Outward unit normal of the face: `rotation · ẑ`.
    pub normal: Unit<Vector3<f64>>,
}

impl TopFace {
    /// The top face of a cumulative frame T1⋯Tk.
    pub fn from_frame(frame: &Isometry3<f64>) -> TopFace {
        let rotation = frame.rotation;
        TopFace {
            origin: Point3::from(frame.translation.vector),
            rotation,
            normal: Unit::new_unchecked(rotation * Vector3::z()),
        }
    }

    /// Angle between the face's normal and the base z axis (its tilt from level), radians.
    pub fn tilt(&self) -> f64 {
        libm::acos(self.normal.z.clamp(-1.0, 1.0))
    }
}

/// Iterator over the top faces of a stack, bottom module first.
#[derive(Debug, Clone)]
pub struct TopFaces<I> {
    frames: crate::fk::Frames<I>,
}

impl<I: Iterator<Item = Pose>> Iterator for TopFaces<I> {
    type Item = TopFace;

    fn next(&mut self) -> Option<TopFace> {
        self.frames.next().map(|f| TopFace::from_frame(&f))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.frames.size_hint()
    }
}

/// The top faces of a stack given each module's pose, bottom module first.
pub fn top_faces<I: IntoIterator<Item = Pose>>(poses: I) -> TopFaces<I::IntoIter> {
    TopFaces {
        frames: crate::fk::frames(poses),
    }
}

/// The outward normal of the whole stack's top face (+z for an empty stack).
pub fn top_normal<I: IntoIterator<Item = Pose>>(poses: I) -> Unit<Vector3<f64>> {
    top_faces(poses)
        .last()
        .map_or_else(Vector3::z_axis, |f| f.normal)
}

/// How the base frame sits on the compass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Heading {
    deg: f64,
}

/// A heading that is not a finite number of degrees.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BadHeading;

impl core::fmt::Display for BadHeading {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("the heading must be a finite number of degrees")
    }
}

impl core::error::Error for BadHeading {}

impl Heading {
    /// The default heading: base x east, y north (ENU).
    pub const EAST: Heading = Heading { deg: 90.0 };

    /// A heading in degrees clockwise from north (any finite value; reduced to [0, 360)).
    pub fn from_deg(deg: f64) -> Result<Heading, BadHeading> {
        if !deg.is_finite() {
            return Err(BadHeading);
        }
        let r = deg % 360.0;
        let r = if r < 0.0 { r + 360.0 } else { r };
        // -0.0 and a remainder that rounds up to 360 both mean north.
        let r = if r >= 360.0 || r == 0.0 { 0.0 } else { r };
        Ok(Heading { deg: r })
    }

    /// Degrees clockwise from north, in [0, 360).
    pub fn deg(&self) -> f64 {
        self.deg
    }

    /// The rotation taking base coordinates to east-north-up coordinates: a turn about z by
    /// 90° − heading (the base x axis, at compass azimuth h, is ENU (sin h, cos h, 0)).
    pub fn base_to_enu(&self) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&Vector3::z_axis(), (90.0 - self.deg).to_radians())
    }

    /// A base-frame direction as compass (azimuth °, elevation °).
    pub fn compass_of(&self, base: &Vector3<f64>) -> (f64, f64) {
        azimuth_elevation_deg(&(self.base_to_enu() * base))
    }

    /// A compass direction (azimuth °, elevation °) in the base frame.
    pub fn base_of(&self, azimuth_deg: f64, elevation_deg: f64) -> Unit<Vector3<f64>> {
        let enu = enu_from_azimuth_elevation(azimuth_deg, elevation_deg);
        Unit::new_unchecked(self.base_to_enu().inverse() * enu.into_inner())
    }
}

impl Default for Heading {
    fn default() -> Self {
        Heading::EAST
    }
}

/// The unit vector in east-north-up coordinates of a direction at compass azimuth
/// `azimuth_deg` (clockwise from north) and `elevation_deg` above the horizon.
pub fn enu_from_azimuth_elevation(azimuth_deg: f64, elevation_deg: f64) -> Unit<Vector3<f64>> {
    let (sa, ca) = (
        libm::sin(azimuth_deg.to_radians()),
        libm::cos(azimuth_deg.to_radians()),
    );
    let (se, ce) = (
        libm::sin(elevation_deg.to_radians()),
        libm::cos(elevation_deg.to_radians()),
    );
    Unit::new_unchecked(Vector3::new(ce * sa, ce * ca, se))
}

/// Compass azimuth (degrees clockwise from north, [0, 360); 0 straight up or down) and
/// elevation (degrees above the horizon) of an east-north-up vector (need not be unit).
pub fn azimuth_elevation_deg(enu: &Vector3<f64>) -> (f64, f64) {
    let horizontal = libm::hypot(enu.x, enu.y);
    let elevation = libm::atan2(enu.z, horizontal).to_degrees();
    let mut azimuth = libm::atan2(enu.x, enu.y).to_degrees();
    if azimuth < 0.0 {
        azimuth += 360.0;
    }
    if azimuth >= 360.0 || horizontal <= 1e-15 * enu.norm() {
        azimuth = if horizontal <= 1e-15 * enu.norm() {
            0.0
        } else {
            azimuth - 360.0
        };
    }
    (azimuth, elevation)
}

/// Angle in degrees between two directions (need not be unit; NaN for a zero vector).
pub fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    // atan2 of |a×b| and a·b keeps full precision near 0° and 180°.
    libm::atan2(a.cross(b).norm(), a.dot(b)).to_degrees()
}
