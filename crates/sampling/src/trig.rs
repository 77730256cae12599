//! atan2 and sin/cos for the f32 hot path, evaluated in f64 without a libm call.
//!
//! glibc's `atan2f` (the target of `f32::atan2`) costs ~130 instructions per call, and the
//! projected-solid-angle samplers make two to five calls per sample; every libm call also forces
//! the caller to spill all live SSE registers (all are caller-saved), which would dominate the
//! Halley loop around `sincosf`. So both are short f64 polynomials here, accurate
//! far beyond f32 (so f32 results are the correctly rounded values except within ~1e-3 ulp of a
//! tie; the exception is `atan2_coarse`, the projected-solid-angle start value's atan2, whose
//! f32 division leaves it within 2 ulp), with relative accuracy kept where the f32 callers need
//! it (sin x and 1 − cos x near 0).
//!
//! atan2: octant reduction to t = min/max ∈ [0, 1], then t > tan(π/8) is mapped to
//! (t − 1)/(t + 1) ∈ [−tan(π/8), 0] with atan t = π/4 + atan((t − 1)/(t + 1)), and atan on
//! |t| ≤ tan(π/8) is t·P(t²) with P the degree-6 Chebyshev fit of atan(√v)/√v on
//! v ∈ [0, tan²(π/8)] (relative error ≤ 2.2e-11, checked below against f64 `atan2`). All in f64,
//! so [`atan2_f64`] of f32 arguments rounded to f32 is the correctly rounded value except within
//! ~1e-4 ulp of a tie (`atan2_coarse` divides in f32: within 2 ulp).

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

/// c₀v⁶ + c₁v⁵ + … + c₆ by Estrin's scheme (shorter dependency chains than Horner's).
#[inline(always)]
fn poly6(c: &[f64; 7], v: f64) -> f64 {
    let v2 = v * v;
    let v4 = v2 * v2;
    v4 * ((c[0] * v + c[1]) * v + c[2]) + ((c[3] * v + c[4]) * v2 + (c[5] * v + c[6]))
}

/// c₀v⁵ + c₁v⁴ + … + c₅ by Estrin's scheme.
#[inline(always)]
fn poly5(c: &[f64; 6], v: f64) -> f64 {
    let v2 = v * v;
    let v4 = v2 * v2;
    v4 * (c[0] * v + c[1]) + ((c[2] * v + c[3]) * v2 + (c[4] * v + c[5]))
}

/// atan t for |t| ≤ tan(π/8).
#[inline(always)]
fn atan_small(t: f64) -> f64 {
    t * poly6(&P, t * t)
}

/// atan2(y, x) in f64 arithmetic (relative error ≤ ~3e-11), same quadrant conventions as
/// `f64::atan2` for finite and signed-zero arguments; NaN in, NaN out.
#[inline(always)]
pub fn atan2_f64(y: f64, x: f64) -> f64 {
    atan2_with(y, x, divide_f64)
}

/// atan2's reduced argument for 0 ≤ num ≤ den: (num − den)/(num + den) where `reduce`, else
/// num/den, correctly rounded in f64 (one division for both: the select is kept before it).
#[inline(always)]
fn divide_f64(reduce: bool, num: f64, den: f64) -> f64 {
    std::hint::select_unpredictable(reduce, num - den, num)
        / std::hint::select_unpredictable(reduce, num + den, den)
}

/// The same for num and den that are f32 values, divided in f32 (for [`atan2_coarse`]): on 8 SIMD
/// lanes one f32 division (a third of an f64 division's time in the divider of an AVX-512 core).
/// num ∓ den are formed in f64, where they are exact (where they are used, num ≥ tan(π/8)·den,
/// so the exponents differ by at most 2), and rounded to f32, which is the f32 sum's rounding;
/// in f32 the sum would overflow for num + den > `f32::MAX` (atan2(2e38, 3.4e38) would be π/4).
/// Above den = 1 both are halved before the rounding (exact there: no result is subnormal), so
/// the quotient is the f32 one bit for bit wherever that did not overflow; below, halving is
/// skipped, as it would round subnormal differences.
#[inline(always)]
fn divide_f32(reduce: bool, num: f64, den: f64) -> f64 {
    let half = std::hint::select_unpredictable(den > 1.0, 0.5, 1.0);
    (std::hint::select_unpredictable(reduce, ((num - den) * half) as f32, num as f32)
        / std::hint::select_unpredictable(reduce, ((num + den) * half) as f32, den as f32))
        as f64
}

/// [`atan2_f64`] with a given division of the reduced argument.
#[inline(always)]
fn atan2_with(y: f64, x: f64, divide: impl Fn(bool, f64, f64) -> f64) -> f64 {
    if y.is_nan() || x.is_nan() {
        return f64::NAN;
    }
    let (ax, ay) = (x.abs(), y.abs());
    let swap = ay > ax;
    let (num, den) = if swap { (ax, ay) } else { (ay, ax) };
    // 0 ≤ num ≤ den. One division either way: above tan(π/8),
    // atan(num/den) = π/4 + atan((num − den)/(num + den)), where num − den is a single rounding
    // (no cancellation of a rounded quotient). den = 0 only for x = y = 0 (then 0); inf/inf
    // (only in the second branch) gives NaN, where std returns π/4. (Branches, not selects:
    // faster on the scalar path, as the division starts on the predicted path.)
    let mut r = if num > TAN_PI_8 * den {
        FRAC_PI_4 + atan_small(divide(true, num, den))
    } else if den > 0.0 {
        let t = divide(false, num, den);
        if t.is_nan() {
            FRAC_PI_4
        } else {
            atan_small(t)
        }
    } else {
        0.0
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

/// [`atan2_f64`] with selects instead of branches (bitwise the same results, also for the
/// special values): for lanes of a SIMD batch, where every lane takes both ways. On the scalar
/// path the branches are faster (the division starts on the predicted path).
#[inline(always)]
pub fn atan2_f64_select(y: f64, x: f64) -> f64 {
    atan2_select_with(y, x, divide_f64)
}

/// [`atan2_f64_select`] with a given division of the reduced argument.
#[inline(always)]
fn atan2_select_with(y: f64, x: f64, divide: impl Fn(bool, f64, f64) -> f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    let swap = ay > ax;
    let num = if swap { ax } else { ay };
    let den = if swap { ay } else { ax };
    let reduce = num > TAN_PI_8 * den;
    // One division and one polynomial for both arms: without the hint (in `divide`) the
    // compiler computes both arms (two divisions, two polynomials) and selects after them.
    let t = divide(reduce, num, den);
    let small = atan_small(t);
    let mut r = if reduce { FRAC_PI_4 + small } else { small };
    // t = NaN: 0/0 (x = y = 0, result 0), inf/inf (π/4) or a NaN input (NaN).
    r = if t.is_nan() {
        if den == 0.0 {
            0.0
        } else {
            FRAC_PI_4
        }
    } else {
        r
    };
    r = if swap { FRAC_PI_2 - r } else { r };
    r = if x.is_sign_negative() { PI - r } else { r };
    r = if y.is_sign_negative() { -r } else { r };
    if y.is_nan() || x.is_nan() {
        f64::NAN
    } else {
        r
    }
}

/// atan2(y, x) for f32 arguments with the reduced argument formed in f32 (only the comparison
/// with tan(π/8) and the polynomial in f64 as in [`atan2_f64`]; the reduction's sum and difference
/// rounded to f32 and divided in f32): within 2 ulp of the correctly rounded value instead of 1
/// (test `coarse_atan2_within_two_ulp`), for one f32 division instead of an f64 one. For the
/// projected-solid-angle start value, which two Halley steps correct (in the ξ guard band it is
/// the sample: the backward-error sweep covers it).
#[inline]
pub(crate) fn atan2_coarse(y: f32, x: f32) -> f32 {
    atan2_with(y as f64, x as f64, divide_f32) as f32
}

/// [`atan2_coarse`] with selects instead of branches (bitwise the same results), for the lanes
/// of [`crate::batch`]. Not for the scalar path: there it is slower than the branches (more
/// instructions and a longer chain in the techniques bench's projected solid angle), as for
/// [`atan2_f64_select`].
#[inline(always)]
pub(crate) fn atan2_coarse_select(y: f32, x: f32) -> f32 {
    atan2_select_with(y as f64, x as f64, divide_f32) as f32
}

/// sin x = x·S(x²) and (1 − cos x)/x² = K(x²): degree-5 Chebyshev fits on x² ∈ [0, 1.0001·(π/2)²]
/// (relative error of sin ≤ 2.7e-11, error of cos ≤ 3e-12, relative near x = 0), highest first.
const S: [f64; 6] = [
    -2.388_910_403_267_558_2e-8,
    2.752_526_349_541_792e-6,
    -1.984_086_105_803_712_7e-4,
    8.333_330_973_271_88e-3,
    -0.166_666_666_167_908_1,
    0.999_999_999_982_908_9,
];
const K: [f64; 6] = [
    -2.004_375_717_333_124e-9,
    2.753_433_865_907_823e-7,
    -2.480_129_412_306_707_2e-5,
    1.388_888_719_588_182e-3,
    -4.166_666_663_088_402e-2,
    0.499_999_999_998_773_8,
];

/// Largest |x| covered by the polynomials of [`sin_cos`].
pub const SIN_COS_RANGE: f64 = 1.570_875;

/// (sin x, cos x) for f32 x with |x| ≤ [`SIN_COS_RANGE`] ⊃ [−π/2, π/2] (the callers' half
/// angles of τ ∈ [0, Δ] ⊂ [0, π]): the polynomials only, no branch (so that SIMD lanes can run
/// it); out-of-range arguments are a caller's bug (debug-asserted).
#[inline(always)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    debug_assert!(
        x.is_nan() || x.abs() <= SIN_COS_RANGE as f32,
        "sin_cos({x}) out of range"
    );
    let (s, c) = sin_cos_poly(x as f64);
    (s as f32, c as f32)
}

/// (sin x, cos x) by the polynomials of [`sin_cos_f64`] only, without its branch to libm: for
/// callers whose |x| ≤ [`SIN_COS_RANGE`] holds by construction (half angles of an arc, at most
/// π/2), and for the lanes of a SIMD batch (a lane outside the range gets garbage, not a call).
#[inline(always)]
pub fn sin_cos_poly(x: f64) -> (f64, f64) {
    let v = x * x;
    (x * poly5(&S, v), 1.0 - v * poly5(&K, v))
}

/// Taylor coefficients of sin x / x to x¹⁶ and of cos x to x¹⁶ in v = x², highest first.
const SIN_QUARTER: [f64; 9] = [
    2.811_457_254_345_520_6e-15,
    -7.647_163_731_819_816e-13,
    1.605_904_383_682_161_3e-10,
    -2.505_210_838_544_172e-8,
    2.755_731_922_398_589_3e-6,
    -1.984_126_984_126_984e-4,
    8.333_333_333_333_333e-3,
    -0.166_666_666_666_666_66,
    1.0,
];
const COS_QUARTER: [f64; 9] = [
    4.779_477_332_387_385e-14,
    -1.147_074_559_772_972_5e-11,
    2.087_675_698_786_81e-9,
    -2.755_731_922_398_589e-7,
    2.480_158_730_158_73e-5,
    -1.388_888_888_888_889e-3,
    4.166_666_666_666_666_4e-2,
    -0.5,
    1.0,
];

/// (sin x, cos x) for |x| ≤ π/4 within a few ulps (test `sin_cos_quarter_within_four_ulp`):
/// the Taylor series of sin to x¹⁷ and of cos to x¹⁶ (the next terms are below 1e-17 there),
/// by Horner in x². Arithmetic only, for the nodes of a quadrature (no call into libm).
#[inline(always)]
pub fn sin_cos_quarter(x: f64) -> (f64, f64) {
    debug_assert!(
        x.is_nan() || x.abs() <= std::f64::consts::FRAC_PI_4 * (1.0 + 1e-12),
        "sin_cos_quarter({x}) out of range"
    );
    let v = x * x;
    let horner = |c: &[f64; 9]| c.iter().fold(0.0, |acc, &k| acc * v + k);
    (x * horner(&SIN_QUARTER), horner(&COS_QUARTER))
}

/// (sin x, cos x) in f64 arithmetic: the polynomials of [`sin_cos`] (relative error of sin
/// ≤ 2.7e-11, absolute error of cos ≤ 3e-12) for |x| ≤ ~π/2, libm beyond.
#[inline(always)]
pub fn sin_cos_f64(x: f64) -> (f64, f64) {
    if x.abs() <= SIN_COS_RANGE {
        sin_cos_poly(x)
    } else {
        sin_cos_libm(x)
    }
}

/// Out of line and cold, so that the register spills around the libm call stay off the hot path.
#[cold]
#[inline(never)]
fn sin_cos_libm(x: f64) -> (f64, f64) {
    x.sin_cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    #[test]
    fn sin_cos_quarter_within_four_ulp() {
        let n = 200_000;
        for i in 0..=n {
            let x = std::f64::consts::FRAC_PI_4 * i as f64 / n as f64;
            for x in [x, -x, x * 1e-6] {
                let (s, c) = sin_cos_quarter(x);
                let eps = f64::EPSILON;
                assert!((s - x.sin()).abs() <= 4.0 * eps * x.sin().abs(), "sin {x}");
                assert!((c - x.cos()).abs() <= 4.0 * eps * x.cos(), "cos {x}");
            }
        }
    }

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
            // Rounded to f32, within an ulp of the correctly rounded value.
            let (y32, x32) = (y as f32, x as f32);
            let (a, b) = (
                atan2_f64(y32 as f64, x32 as f64) as f32,
                (y32 as f64).atan2(x32 as f64) as f32,
            );
            assert!(
                (a - b).abs() <= b.abs() * 1.2e-7,
                "f32 atan2({y32}, {x32}): {a} vs {b}"
            );
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
    fn sin_cos_matches_std() {
        let mut worst = (0.0f64, 0.0f64);
        let n = 400_000;
        for i in 0..=n {
            // Uniform on [−1.6, 1.6] (beyond the range: the libm fallback), plus tiny values.
            let x = -1.6 + 3.2 * i as f64 / n as f64;
            for x in [x, x * 1e-6, x * 1e-30] {
                let x32 = x as f32;
                let (s, c) = if (x32.abs() as f64) <= SIN_COS_RANGE {
                    sin_cos(x32)
                } else {
                    let (s, c) = sin_cos_f64(x32 as f64);
                    (s as f32, c as f32)
                };
                let (se, ce) = (x32 as f64).sin_cos();
                let es = if se == 0.0 {
                    s.abs() as f64
                } else {
                    ((s as f64 - se) / se).abs()
                };
                let ec = (c as f64 - ce).abs() / ce.abs().max(0.5);
                // Correct rounding of the f64 value is all that can be asked: half an ulp of f32
                // plus the polynomial's 3e-11.
                assert!(
                    es <= 6.0e-8 && ec <= 6.0e-8,
                    "sin_cos({x32}) = ({s}, {c}), std ({se}, {ce})"
                );
                worst = (worst.0.max(es), worst.1.max(ec));
            }
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert!(sin_cos(f32::NAN).0.is_nan());
        eprintln!(
            "worst relative error of f32 sin, cos: {:.2e} {:.2e}",
            worst.0, worst.1
        );
    }

    /// The spacing of the f32 values around x (f64, finite): next above minus next below |x|
    /// where |x| is an f32 value, else the gap of the two f32 values that bracket it.
    fn f32_ulp(x: f64) -> f64 {
        let r = (x.abs() as f32).min(f32::MAX);
        let (lo, hi) = if (r as f64) > x.abs() {
            (f32::from_bits(r.to_bits() - 1), r)
        } else {
            (r, f32::from_bits(r.to_bits() + 1))
        };
        hi as f64 - lo as f64
    }

    /// The coarse f32 atan2 (f32 division) is within 2 ulp (the true spacing of the f32 values
    /// around the exact result) of the correctly rounded value over the whole f32 range, from
    /// subnormals to `f32::MAX` (where num + den overflows f32), and its branch-free variant is
    /// the same function bit for bit.
    #[test]
    fn coarse_atan2_within_two_ulp() {
        let mut rng = Pcg32::new(13, 9);
        let mut worst = (0.0f64, 0.0f32, 0.0f32);
        let mut check = |y: f32, x: f32| {
            let (a, b) = (atan2_coarse(y, x), atan2_coarse_select(y, x));
            assert_eq!(a.to_bits(), b.to_bits(), "atan2_coarse({y}, {x})");
            let exact = (y as f64).atan2(x as f64);
            let err = (a as f64 - exact).abs() / f32_ulp(exact);
            assert!(
                err <= 2.0,
                "atan2_coarse({y:e}, {x:e}) = {a}, exact {exact}: {err} ulp"
            );
            if err > worst.0 {
                worst = (err, y, x);
            }
        };
        // Magnitudes 10^k, k ∈ [−45, 38]: subnormals (below 1.2e-38) to 1e38.
        let value =
            |r: f32, k: f32| (((2.0 * r - 1.0) as f64) * 10f64.powi((k * 84.0) as i32 - 45)) as f32;
        for k in 0..1_000_000 {
            let x = value(rng.next_f32(), rng.next_f32());
            // Every 4th pair near the reduction threshold tan(π/8) and the diagonal, every 4th
            // with both of the same magnitude (near the top, num + den overflows f32).
            let y = match k % 4 {
                0 => x * (0.3 + 0.8 * rng.next_f32()),
                1 => (2.0 * rng.next_f32() - 1.0) * x,
                _ => value(rng.next_f32(), rng.next_f32()),
            };
            check(y, x);
        }
        let m = f32::MAX;
        let sub = f32::from_bits(1);
        for &(y, x) in &[
            (2e38f32, 3.4e38f32),
            (m, m),
            (-m, m),
            (m, 0.5 * m),
            (0.7 * m, -m),
            (3.0 * sub, 4.0 * sub),
            (sub, sub),
            (5.0 * sub, -7.0 * sub),
            (sub, 1e38),
            (1e-38, 1.0),
        ] {
            check(y, x);
            check(x, y);
        }
        for &(y, x) in &[
            (0.0f32, 0.0f32),
            (-0.0, -1.0),
            (1.0, 0.0),
            (f32::INFINITY, f32::INFINITY),
        ] {
            let std = (y as f64).atan2(x as f64) as f32;
            assert_eq!(atan2_coarse(y, x), std, "atan2_coarse({y}, {x})");
            assert_eq!(atan2_coarse_select(y, x), std, "({y}, {x})");
        }
        assert!(
            atan2_coarse(f32::NAN, 1.0).is_nan() && atan2_coarse_select(1.0, f32::NAN).is_nan()
        );
        eprintln!(
            "worst error of atan2_coarse: {:.3} ulp at ({:e}, {:e})",
            worst.0, worst.1, worst.2
        );
    }

    /// `divide_f32` is the plain f32 arithmetic (f32 sum, difference and quotient) bit for bit
    /// wherever that does not overflow, so the overflow guard changes no start value there;
    /// where plain f32 overflows, the quotient is the right one.
    #[test]
    fn divide_f32_is_f32_arithmetic_where_that_is_finite() {
        let plain = |reduce: bool, num: f32, den: f32| {
            if reduce {
                (num - den) / (num + den)
            } else {
                num / den
            }
        };
        let mut rng = Pcg32::new(17, 1);
        let mut compared = 0u32;
        for k in 0..1_000_000 {
            let den = (rng.next_f32() as f64 * 10f64.powi((k % 84) - 45)) as f32;
            let num = den * (0.3 + 0.7 * rng.next_f32());
            let reduce = num as f64 > TAN_PI_8 * den as f64;
            let want = plain(reduce, num, den);
            if (num + den).is_finite() && !want.is_nan() {
                let got = divide_f32(reduce, num as f64, den as f64);
                assert_eq!(
                    got.to_bits(),
                    (want as f64).to_bits(),
                    "{reduce} {num:e} {den:e}"
                );
                compared += 1;
            }
        }
        assert!(compared > 900_000, "{compared}");
        let q = divide_f32(true, 2e38f32 as f64, 3.4e38f32 as f64);
        let exact = (2e38f32 as f64 - 3.4e38f32 as f64) / (2e38f32 as f64 + 3.4e38f32 as f64);
        assert!((q - exact).abs() <= exact.abs() * 1.2e-7, "{q} vs {exact}");
        assert!((atan2_coarse(2e38, 3.4e38) - 0.531_724_1).abs() < 1e-6);
    }

    /// The branch-free variant is the same function, bit for bit.
    #[test]
    fn select_variant_is_bitwise_equal() {
        let mut rng = Pcg32::new(11, 5);
        let mut values = vec![
            0.0f64,
            -0.0,
            1.0,
            -1.0,
            TAN_PI_8,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            1e-300,
            -3e300,
        ];
        for _ in 0..20_000 {
            let scale = 10f64.powi((rng.next_f32() * 40.0) as i32 - 20);
            values.push((rng.next_f32() as f64 - 0.5) * scale);
        }
        for (i, &y) in values.iter().enumerate() {
            for &x in values.iter().skip(i % 97).step_by(97) {
                let (a, b) = (atan2_f64(y, x), atan2_f64_select(y, x));
                assert!(
                    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "{y} {x}"
                );
            }
        }
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
        assert!(atan2_f64(f64::NAN, 1.0).is_nan() && atan2_f64(1.0, f64::NAN).is_nan());
    }
}
