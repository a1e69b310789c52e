//! Constant-curvature three-tendon kinematics for the crane's bending (firmware and host).
//!
//! Three tendons run parallel to the trunk axis at radius `r_t` (mm) and angles
//! φ_i = 0°, 120°, 240° around it (measured in the base frame, φ = 0 along +x). A
//! constant-curvature bend of angle θ toward direction φ changes tendon i's length by
//!
//! Δl_i = −r_t · θ · cos(φ − φ_i)
//!
//! **Sign convention: negative Δl = the tendon is shorter (reeled in), positive = longer
//! (paid out).** The tendon on the inside of the bend (φ_i = φ) shortens most. The three
//! changes of a pure bend sum to zero; a common offset is an axial length change, reported
//! separately by [`TendonGeometry::bend_from_length_changes`].

use core::f64::consts::PI;

/// Angles of the three tendons around the trunk axis, radians: 0°, 120°, 240°.
pub const TENDON_ANGLES: [f64; 3] = [0.0, 2.0 * PI / 3.0, 4.0 * PI / 3.0];

/// A constant-curvature bend.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Bend {
    /// Direction φ the tip bends toward, radians in [0, 2π) (0 when straight).
    pub direction: f64,
    /// Bend angle θ ≥ 0, radians.
    pub angle: f64,
}

impl Bend {
    /// No bend.
    pub const STRAIGHT: Bend = Bend {
        direction: 0.0,
        angle: 0.0,
    };

    /// A bend from a direction and an angle; a negative angle bends the other way. Non-finite
    /// input gives [`Bend::STRAIGHT`].
    pub fn new(direction: f64, angle: f64) -> Self {
        if !(direction.is_finite() && angle.is_finite()) {
            return Bend::STRAIGHT;
        }
        if angle < 0.0 {
            Bend {
                direction: crate::catalogue::wrap_2pi(direction + PI),
                angle: -angle,
            }
        } else if angle == 0.0 {
            Bend::STRAIGHT
        } else {
            Bend {
                direction: crate::catalogue::wrap_2pi(direction),
                angle,
            }
        }
    }

    /// The bend as a vector θ·(cos φ, sin φ).
    pub fn as_vector(&self) -> (f64, f64) {
        (
            self.angle * libm::cos(self.direction),
            self.angle * libm::sin(self.direction),
        )
    }
}

/// Result of inverting tendon length changes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TendonSolution {
    /// The bend.
    pub bend: Bend,
    /// Common-mode length change (mm): the mean of the three Δl, an axial extension (> 0) or
    /// compression (< 0) of the trunk rather than a bend.
    pub axial_mm: f64,
}

/// Why tendon kinematics refused an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TendonError {
    /// The tendon radius is not a finite positive number.
    BadRadius,
    /// An input was NaN or infinite.
    NotFinite,
}

impl core::fmt::Display for TendonError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            TendonError::BadRadius => f.write_str("tendon radius must be finite and positive (mm)"),
            TendonError::NotFinite => f.write_str("tendon kinematics input must be finite"),
        }
    }
}

impl core::error::Error for TendonError {}

/// Where the three tendons run: radius `r_t` (mm) around the trunk axis.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TendonGeometry {
    radius_mm: f64,
}

impl TendonGeometry {
    /// Tendons at `radius_mm` (finite, > 0) from the axis.
    pub fn new(radius_mm: f64) -> Result<Self, TendonError> {
        if radius_mm.is_finite() && radius_mm > 0.0 {
            Ok(Self { radius_mm })
        } else {
            Err(TendonError::BadRadius)
        }
    }

    /// The tendon radius r_t, mm.
    pub fn radius_mm(&self) -> f64 {
        self.radius_mm
    }

    /// Length change of each tendon (mm) for a bend: Δl_i = −r_t·θ·cos(φ − φ_i);
    /// negative = shorter.
    pub fn length_changes(&self, bend: Bend) -> [f64; 3] {
        let k = self.radius_mm * bend.angle;
        TENDON_ANGLES.map(|phi_i| -k * libm::cos(bend.direction - phi_i))
    }

    /// Inverse of [`Self::length_changes`] (plus an axial part): the mean of `dl` is the axial
    /// change; the rest is fitted to −r_t·θ·cos(φ − φ_i) exactly (three tendons, two
    /// unknowns, one common mode).
    pub fn bend_from_length_changes(&self, dl: [f64; 3]) -> Result<TendonSolution, TendonError> {
        if !dl.iter().all(|x| x.is_finite()) {
            return Err(TendonError::NotFinite);
        }
        let axial_mm = (dl[0] + dl[1] + dl[2]) / 3.0;
        // Σ cos²φ_i = Σ sin²φ_i = 3/2 and Σ cos φ_i sin φ_i = 0 for three tendons 120° apart.
        let (mut cx, mut cy) = (0.0, 0.0);
        for (d, phi_i) in dl.iter().zip(TENDON_ANGLES) {
            let e = d - axial_mm;
            cx += e * libm::cos(phi_i);
            cy += e * libm::sin(phi_i);
        }
        let s = -2.0 / (3.0 * self.radius_mm);
        let (x, y) = (s * cx, s * cy);
        let angle = libm::hypot(x, y);
        let bend = if angle <= 1e-15 {
            Bend::STRAIGHT
        } else {
            Bend::new(libm::atan2(y, x), angle)
        };
        Ok(TendonSolution { bend, axial_mm })
    }
}

/// Maps a joystick to a bend: deflection (x, y) ∈ [−1, 1]² points the bend direction
/// φ = atan2(y, x) and its magnitude (clamped to 1) scales the bend angle up to `max_bend`.
/// Deflections inside `deadzone` give no bend; the range outside it is rescaled so the bend
/// starts at 0.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct JoystickMap {
    max_bend: f64,
    deadzone: f64,
}

impl JoystickMap {
    /// A map with maximum bend angle `max_bend` (radians, finite, ≥ 0) and a dead zone radius
    /// in [0, 1).
    pub fn new(max_bend: f64, deadzone: f64) -> Result<Self, TendonError> {
        if !(max_bend.is_finite() && max_bend >= 0.0 && (0.0..1.0).contains(&deadzone)) {
            return Err(TendonError::NotFinite);
        }
        Ok(Self { max_bend, deadzone })
    }

    /// Maximum bend angle, radians.
    pub fn max_bend(&self) -> f64 {
        self.max_bend
    }

    /// The bend for a joystick deflection. Non-finite input (a broken ADC reading) gives
    /// [`Bend::STRAIGHT`]; never panics.
    pub fn bend(&self, x: f64, y: f64) -> Bend {
        if !(x.is_finite() && y.is_finite()) {
            return Bend::STRAIGHT;
        }
        let (x, y) = (x.clamp(-1.0, 1.0), y.clamp(-1.0, 1.0));
        let m = libm::hypot(x, y).min(1.0);
        if m <= self.deadzone {
            return Bend::STRAIGHT;
        }
        let scaled = (m - self.deadzone) / (1.0 - self.deadzone);
        Bend::new(libm::atan2(y, x), self.max_bend * scaled)
    }
}

/// The bend for a joystick deflection (x, y) ∈ [−1, 1]² with maximum bend `max_bend`
/// (radians) and no dead zone. See [`JoystickMap`].
pub fn joystick_to_bend(x: f64, y: f64, max_bend: f64) -> Bend {
    match JoystickMap::new(max_bend, 0.0) {
        Ok(map) => map.bend(x, y),
        Err(_) => Bend::STRAIGHT,
    }
}
