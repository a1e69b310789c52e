//! Single-precision trigonometry and square root evaluated in `f32` only.
//!
//! Why not `libm`'s `f32` functions: `libm` (musl's algorithms) evaluates `sinf`, `cosf`,
//! `tanf`, `atanf` and `hypotf` through `f64` intermediates and reduces large arguments with
//! the multi-word `rem_pio2_large`. The RA4M1's Cortex-M4F has a single-precision FPU only, so
//! on the board every one of those `f64` operations is software emulation: ≈ 9 KiB of flash
//! (soft-float add/mul/div, conversions, the reduction and its 2/π table) and hundreds of
//! cycles a call. The controller needs none of that range: its angles are bounded (a bend's
//! direction is reduced in degrees first, exactly), so the classic single-precision Cephes
//! kernels (S. L. Moshier, Cephes Math Library, `sinf.c`/`tanf.c`: a three-part Cody–Waite
//! reduction by π/4 and minimax polynomials on [−π/4, π/4]) do, in `f32` registers only.
//!
//! Accuracy (tests below, against the `f64` functions, the result rounded to `f32`): `sin_cos`
//! within 2 ulp + 1e-7 absolute over |x| ≤ 8 192 rad (the limit of the three-part reduction),
//! `tan` within 3 ulp over (−π/2, π/2), `sqrt` correctly rounded (the FPU's `VSQRT` on the
//! board, `libm`'s exact `sqrtf` on the host: both IEEE 754 correctly rounded, so the
//! host-built controller and the board compute the same bits).

/// 4/π.
const FOPI: f32 = 1.273_239_5;
/// π/4 in three parts, each exact in few bits, for the Cody–Waite reduction x − j·π/4.
const DP1: f32 = 0.785_156_25;
const DP2: f32 = 2.418_756_5e-4;
const DP3: f32 = 3.774_895e-8;
/// Beyond this the reduction's error grows past the kernels' (Cephes' `lossth`).
pub const MAX_ARG: f32 = 8192.0;

/// The octant index j (even) and the reduced argument x − j·π/4 ∈ [−π/4, π/4], for x ≥ 0.
#[inline]
fn reduce(x: f32) -> (u32, f32) {
    let mut j = (FOPI * x) as u32;
    let mut y = j as f32;
    if j & 1 == 1 {
        j += 1;
        y += 1.0;
    }
    (j, ((x - y * DP1) - y * DP2) - y * DP3)
}

/// sin on [−π/4, π/4].
#[inline]
fn sin_kernel(x: f32, z: f32) -> f32 {
    ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * x + x
}

/// cos on [−π/4, π/4].
#[inline]
fn cos_kernel(z: f32) -> f32 {
    ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0
}

/// `(sin x, cos x)` for |x| ≤ [`MAX_ARG`]; NaN for a non-finite or larger argument.
pub fn sin_cos(x: f32) -> (f32, f32) {
    let ax = x.abs();
    if ax.is_nan() || ax > MAX_ARG {
        return (f32::NAN, f32::NAN);
    }
    let (j, r) = reduce(ax);
    let z = r * r;
    let (s, c) = (sin_kernel(r, z), cos_kernel(z));
    // j / 2 mod 4 is the quadrant: rotate (s, c) by a quarter turn per quadrant.
    let (s, c) = match (j >> 1) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    (if x < 0.0 { -s } else { s }, c)
}

/// `(sin, cos)` of an angle in degrees, any finite value: reduced to [−180°, 180°] first
/// (`%` and the ±360° are exact in floating point), so the radian argument is within ±π and
/// only its one rounding (≤ 1.2e-7 rad) adds to the kernels' error. NaN for a non-finite angle.
pub fn sin_cos_deg(deg: f32) -> (f32, f32) {
    if !deg.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    let mut r = rem_360(deg);
    if r > 180.0 {
        r -= 360.0;
    } else if r < -180.0 {
        r += 360.0;
    }
    sin_cos(r.to_radians())
}

/// `x` modulo 360 with the sign of `x` (as `x % 360.0`), exact, for finite `x`.
///
/// Why not `%`: on the board it links `fmodf` with a 64-bit software division (1.5 KiB). Here
/// each step subtracts 360·2^k with 360·2^k ≤ r < 360·2^(k+1), which is exact (Sterbenz), the
/// power of two taken from the exponents: at most one step per binade, ≤ 128 for any `f32`.
pub fn rem_360(x: f32) -> f32 {
    const M: f32 = 360.0;
    let mut r = x.abs();
    while r >= M {
        // 360·2^(e_r − e_360), halved if it overshoots r.
        let shift = (r.to_bits() >> 23) - (M.to_bits() >> 23);
        let mut m = f32::from_bits(M.to_bits() + (shift << 23));
        if m > r {
            m *= 0.5;
        }
        r -= m;
    }
    r.copysign(x)
}

/// tan x for |x| ≤ [`MAX_ARG`] (±∞ never: the nearest `f32` to an odd multiple of π/2 is not
/// one); NaN for a non-finite or larger argument.
pub fn tan(x: f32) -> f32 {
    let ax = x.abs();
    if ax.is_nan() || ax > MAX_ARG {
        return f32::NAN;
    }
    let (j, r) = reduce(ax);
    let z = r * r;
    let mut t = if ax > 1e-4 {
        (((((9.385_402e-3 * z + 3.119_922_3e-3) * z + 2.443_013_5e-2) * z + 5.341_128e-2) * z
            + 1.333_879_9e-1)
            * z
            + 3.333_315_7e-1)
            * z
            * r
            + r
    } else {
        r
    };
    if j & 2 != 0 {
        t = -1.0 / t;
    }
    if x < 0.0 {
        -t
    } else {
        t
    }
}

/// √x, correctly rounded (NaN below 0).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        // SAFETY: a leaf function of the hard-float ABI (argument and result in s0) that only
        // executes VSQRT.F32 on the FPU every eabihf target has.
        unsafe { crane_vsqrtf(x) }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

// `asm!` cannot name an FPU register on stable for this target (the `sreg` class needs the
// unstable `vfp2` feature), so the one instruction is a leaf function of the hard-float ABI.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".section .text.crane_vsqrtf,\"ax\",%progbits",
    ".global crane_vsqrtf",
    ".type crane_vsqrtf,%function",
    ".fpu fpv4-sp-d16",
    ".thumb_func",
    "crane_vsqrtf:",
    "vsqrt.f32 s0, s0",
    "bx lr",
    ".size crane_vsqrtf, . - crane_vsqrtf",
);
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
extern "C" {
    fn crane_vsqrtf(x: f32) -> f32;
}

/// √(x² + y²) for arguments whose squares do not overflow (|x|, |y| < 1.8e19).
#[inline]
pub fn hypot(x: f32, y: f32) -> f32 {
    sqrt(x * x + y * y)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(got: f32, want: f64) -> f64 {
        let w = want as f32;
        let ulp = f64::from(f32::from_bits(w.abs().to_bits() + 1) - w.abs());
        (f64::from(got) - want).abs() / ulp
    }

    #[test]
    fn sin_cos_within_2_ulp_plus_1e_7_over_the_reduction_range() {
        let mut worst = 0.0f64;
        let mut x = -MAX_ARG;
        while x <= MAX_ARG {
            let (s, c) = sin_cos(x);
            let (ws, wc) = (f64::from(x).sin(), f64::from(x).cos());
            for (got, want) in [(s, ws), (c, wc)] {
                let abs = (f64::from(got) - want).abs();
                assert!(
                    ulps(got, want) <= 2.0 || abs <= 1e-7,
                    "x {x}: {got} vs {want} ({} ulp)",
                    ulps(got, want)
                );
                worst = worst.max(abs);
            }
            x += 0.000_731 * (1.0 + x.abs());
        }
        // Every f32 in the first turn, where the controller's angles lie.
        let mut x = 0.0f32;
        while x < 7.0 {
            let (s, c) = sin_cos(x);
            assert!(
                (f64::from(s) - f64::from(x).sin()).abs() <= 1.2e-7,
                "sin {x}"
            );
            assert!(
                (f64::from(c) - f64::from(x).cos()).abs() <= 1.2e-7,
                "cos {x}"
            );
            x = f32::from_bits(x.to_bits() + 97);
        }
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn out_of_range_and_non_finite_arguments_give_nan() {
        for x in [MAX_ARG * 1.01, -1e30, f32::INFINITY, f32::NAN] {
            assert!(sin_cos(x).0.is_nan() && sin_cos(x).1.is_nan(), "{x}");
            assert!(tan(x).is_nan(), "{x}");
        }
        assert!(sin_cos_deg(f32::INFINITY).0.is_nan());
        assert!(sqrt(-1.0).is_nan());
    }

    #[test]
    fn degrees_reduce_exactly_for_any_finite_angle() {
        for deg in [
            0.0f32,
            30.0,
            -30.0,
            359.5,
            720.0 + 45.0,
            -1e7 + 90.0,
            3.0e38,
            -3.0e38,
        ] {
            let r = f64::from(deg % 360.0).to_radians();
            let (s, c) = sin_cos_deg(deg);
            assert!((f64::from(s) - r.sin()).abs() < 3e-7, "{deg}");
            assert!((f64::from(c) - r.cos()).abs() < 3e-7, "{deg}");
        }
        let (s, c) = sin_cos_deg(90.0);
        assert!((s - 1.0).abs() < 1e-7 && c.abs() < 1e-7);
    }

    #[test]
    fn rem_360_is_fmod_exactly() {
        let mut x = 1e-3f32;
        while x < 3.4e38 {
            for v in [x, -x, x.next_up(), (x * 360.0).min(f32::MAX)] {
                let want = v % 360.0;
                assert_eq!(rem_360(v).to_bits(), want.to_bits(), "{v}");
            }
            x *= 1.37;
        }
        for v in [
            0.0f32,
            -0.0,
            360.0,
            -360.0,
            720.0,
            359.999_97,
            f32::MAX,
            -f32::MAX,
        ] {
            assert_eq!(rem_360(v).to_bits(), (v % 360.0).to_bits(), "{v}");
        }
    }

    #[test]
    fn tan_within_3_ulp_on_the_open_quarter_turns() {
        let edge = core::f32::consts::FRAC_PI_2 - 1e-4;
        let mut x = -edge;
        while x < edge {
            let t = tan(x);
            let want = f64::from(x).tan();
            assert!(
                ulps(t, want) <= 3.0 || (f64::from(t) - want).abs() < 1e-7,
                "x {x}: {t} vs {want}"
            );
            x += 1.3e-4;
        }
        // The heights' arguments: β in (0°, 90°) and π/(2n) for n = 3..=64.
        for n in 3..=64 {
            let x = core::f32::consts::PI / (2.0 * n as f32);
            assert!(ulps(tan(x), f64::from(x).tan()) <= 3.0, "n {n}");
        }
    }

    #[test]
    fn sqrt_and_hypot_are_correctly_rounded() {
        for x in [0.0f32, 1e-30, 0.5, 2.0, 3.0, 1e30] {
            assert_eq!(sqrt(x), (f64::from(x).sqrt()) as f32, "{x}");
        }
        assert_eq!(hypot(3.0, 4.0), 5.0);
        assert_eq!(hypot(-1.0, 0.0), 1.0);
    }
}
