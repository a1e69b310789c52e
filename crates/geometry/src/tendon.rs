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

/// A common shortfall of every tendon: the controller keeps the tendons `margin_mm` short of
/// taut at zero bend (so an error in the modelled heights never compresses the trunk), and
/// commands a bend θ toward φ as each tendon's constant-curvature shortening r_t·θ·cos(φ − φ_i)
/// on top of that. A tendon pulls only once its shortening passes the margin; the trunk, far
/// softer in bending than the tendons are stiff, takes the smallest bend that brings no tendon
/// past its commanded length (the least bending energy under one-sided constraints):
///
/// min |b|² subject to u_i·b ≥ c_i = θ·cos(φ − φ_i) − margin/r_t, i = 0, 1, 2,
///
/// with b the bend vector and u_i the tendons' unit vectors. `docs/geometry.md` ("Tip pose and
/// workspace") derives it and its inverse [`TendonGeometry::command_for`].
impl TendonGeometry {
    /// The bend the trunk takes under the command `commanded` with the tendons `margin_mm`
    /// short of taut (see above). Non-finite input gives [`Bend::STRAIGHT`].
    pub fn held_bend(&self, commanded: Bend, margin_mm: f64) -> Bend {
        if !(commanded.angle.is_finite()
            && commanded.direction.is_finite()
            && margin_mm.is_finite())
        {
            return Bend::STRAIGHT;
        }
        let u = TENDON_ANGLES.map(|a| (libm::cos(a), libm::sin(a)));
        let m = margin_mm.max(0.0) / self.radius_mm;
        let c: [f64; 3] =
            TENDON_ANGLES.map(|a| commanded.angle * libm::cos(commanded.direction - a) - m);
        let feasible = |b: (f64, f64)| (0..3).all(|i| u[i].0 * b.0 + u[i].1 * b.1 >= c[i] - 1e-12);
        let mut best: Option<(f64, (f64, f64))> = None;
        let mut consider = |b: (f64, f64)| {
            if feasible(b) {
                let n = b.0 * b.0 + b.1 * b.1;
                if best.is_none_or(|(bn, _)| n < bn) {
                    best = Some((n, b));
                }
            }
        };
        consider((0.0, 0.0));
        for i in 0..3 {
            consider((c[i] * u[i].0, c[i] * u[i].1));
            let j = (i + 1) % 3;
            // u_i·b = c_i, u_j·b = c_j (a 2×2 system; the tendons are 120° apart).
            let det = u[i].0 * u[j].1 - u[i].1 * u[j].0;
            let bx = (c[i] * u[j].1 - c[j] * u[i].1) / det;
            let by = (u[i].0 * c[j] - u[j].0 * c[i]) / det;
            consider((bx, by));
        }
        let (_, (bx, by)) = best.unwrap_or((0.0, (0.0, 0.0)));
        let angle = libm::hypot(bx, by);
        if angle <= 1e-15 {
            Bend::STRAIGHT
        } else {
            Bend::new(libm::atan2(by, bx), angle)
        }
    }

    /// The command whose [`TendonGeometry::held_bend`] is `desired`: in tendon-shortening
    /// terms v = r_t·b* + 2·margin·(bisector of the two tendons whose sector holds b*), so the
    /// two tendons either side of the bend pull exactly as constant curvature asks and the
    /// third hangs slack. Its angle is at most `desired.angle + 2·margin/r_t`. A straight
    /// `desired` is the straight command.
    pub fn command_for(&self, desired: Bend, margin_mm: f64) -> Bend {
        if !(desired.angle.is_finite() && desired.direction.is_finite() && margin_mm.is_finite())
            || desired.angle == 0.0
        {
            return Bend::STRAIGHT;
        }
        let m = margin_mm.max(0.0);
        let phi = crate::catalogue::wrap_2pi(desired.direction);
        let sector = libm::floor(phi / (2.0 * PI / 3.0)).clamp(0.0, 2.0);
        let bisector = sector * 2.0 * PI / 3.0 + PI / 3.0;
        let vx = self.radius_mm * desired.angle * libm::cos(phi) + 2.0 * m * libm::cos(bisector);
        let vy = self.radius_mm * desired.angle * libm::sin(phi) + 2.0 * m * libm::sin(bisector);
        Bend::new(libm::atan2(vy, vx), libm::hypot(vx, vy) / self.radius_mm)
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
