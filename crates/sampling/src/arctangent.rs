//! atan2 for the f32 hot path, evaluated in f64 without a libm call.
//!
//! glibc's `atan2f` (the target of `f32::atan2`) was the single most expensive call of the
//! projected-solid-angle samplers (~130 instructions per call, two to five calls per sample).
//! Here: octant reduction to t = min/max ∈ [0, 1], then t > tan(π/8) is mapped to
//! (t − 1)/(t + 1) ∈ [−tan(π/8), 0] with atan t = π/4 + atan((t − 1)/(t + 1)), and atan on
//! |t| ≤ tan(π/8) is t·P(t²) with P the degree-6 Chebyshev fit of atan(√v)/√v on
//! v ∈ [0, tan²(π/8)] (relative error ≤ 2.2e-11, checked below against f64 `atan2`). All in f64,
//! so the f32 result is the correctly rounded value except within ~1e-4 ulp of a tie.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

const TAN_PI_8: f64 = 0.414_213_562_373_095_03;

/// Coefficients of P, highest degree first (Horner).
const P: [f64; 7] = [
    0.047_073_481_419_680_2,
    -0.084_561_928_869_404_96,
    0.110_404_892_272_182_4,
    -0.142_815_887_726_541_24,
    0.199_998_838_565_513_03,
    -0.333_333_320_976_093_86,
    0.999_999_999_978_398_8,
];

/// atan t for |t| ≤ tan(π/8).
#[inline]
fn atan_small(t: f64) -> f64 {
    let v = t * t;
    let mut p = P[0];
    for &c in &P[1..] {
        p = p * v + c;
    }
    t * p
}

/// atan2(y, x) in f64 arithmetic (relative error ≤ ~3e-11), same quadrant conventions as
/// `f64::atan2` for finite and signed-zero arguments; NaN in, NaN out.
#[inline]
pub fn atan2_f64(y: f64, x: f64) -> f64 {
    if y.is_nan() || x.is_nan() {
        return f64::NAN;
    }
    let (ax, ay) = (x.abs(), y.abs());
    let swap = ay > ax;
    let (num, den) = if swap { (ax, ay) } else { (ay, ax) };
    // den = 0 only for x = y = 0; den = inf: t = 0 (or NaN for inf/inf, then π/4 below).
    let t = if den > 0.0 { num / den } else { 0.0 };
    let mut r = if t > TAN_PI_8 {
        FRAC_PI_4 + atan_small((t - 1.0) / (t + 1.0))
    } else if t.is_nan() {
        FRAC_PI_4
    } else {
        atan_small(t)
    };
    if swap {
        r = FRAC_PI_2 - r;
    }
    if x.is_sign_negative() {
        r = PI - r;
    }
    if y.is_sign_negative() {
        -r
    } else {
        r
    }
}

/// atan2(y, x) for f32 arguments (see the module documentation).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    atan2_f64(y as f64, x as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    #[test]
    fn matches_std_atan2() {
        let mut rng = Pcg32::new(7, 3);
        let mut worst = 0.0f64;
        let mut check = |y: f64, x: f64| {
            let (ours, std) = (atan2_f64(y, x), y.atan2(x));
            let rel = if std == 0.0 {
                ours.abs()
            } else {
                ((ours - std) / std).abs()
            };
            assert!(rel < 5e-11, "atan2({y}, {x}) = {ours}, std {std}");
            worst = worst.max(rel);
            // The f32 version is within an ulp of the correctly rounded value.
            let (y32, x32) = (y as f32, x as f32);
            let (a, b) = (atan2(y32, x32), (y32 as f64).atan2(x32 as f64) as f32);
            assert!((a - b).abs() <= b.abs() * 1.2e-7, "f32 atan2({y32}, {x32}): {a} vs {b}");
        };
        for _ in 0..200_000 {
            let y = (rng.next_f32() as f64 - 0.5) * 10f64.powi((rng.next_f32() * 12.0) as i32 - 6);
            let x = (rng.next_f32() as f64 - 0.5) * 10f64.powi((rng.next_f32() * 12.0) as i32 - 6);
            check(y, x);
        }
        // Octant boundaries and the reduction threshold.
        for &(y, x) in &[
            (1.0, 1.0),
            (-1.0, 1.0),
            (1.0, -1.0),
            (TAN_PI_8, 1.0),
            (TAN_PI_8 * (1.0 + 1e-15), 1.0),
            (1.0, TAN_PI_8),
            (1e-30, 1.0),
            (1.0, 1e-30),
            (3.0, -1e-30),
        ] {
            check(y, x);
        }
        eprintln!("worst relative error of atan2_f64: {worst:.2e}");
    }

    #[test]
    fn special_values_like_std() {
        for &(y, x) in &[
            (0.0f64, 0.0f64),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
            (0.0, 1.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (1.0, 0.0),
            (-1.0, 0.0),
            (f64::INFINITY, 1.0),
            (1.0, f64::INFINITY),
            (1.0, f64::NEG_INFINITY),
            (f64::INFINITY, f64::INFINITY),
        ] {
            let (ours, std) = (atan2_f64(y, x), y.atan2(x));
            assert!(
                (ours - std).abs() <= 1e-15 && ours.is_sign_negative() == std.is_sign_negative(),
                "atan2({y}, {x}) = {ours}, std {std}"
            );
        }
        assert!(atan2_f64(f64::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
    }
}
