//! Welch's t for a difference of two independent means with estimated variances, and its
//! probability-integral transform to a standard normal score.
//!
//! Why not sum raw t²: with ν degrees of freedom E\[t²\] = ν/(ν−2), so Σt² over many pixels from
//! few passes is inflated and a χ² test on it falsely rejects. Mapping each t through its own
//! distribution function first, z = Φ⁻¹(F_t(t; ν)), gives exactly N(0, 1) scores under H₀.

// `!(x > 0.0)` is deliberate throughout: it treats NaN as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use statrs::distribution::{ContinuousCDF, StudentsT};
use statrs::function::erf::erfc_inv;

/// Smallest one-sided tail probability that is mapped to a normal score; smaller tails (and
/// tails that underflow to 0) are clamped here. Φ⁻¹(1e-300) ≈ −37.05, so |z| ≤ [`Z_MAX`].
/// Any |z| this large is rejected by every test at every sensible α (thresholds are ≈ 4–7),
/// so the clamp never changes the verdict (max|z| rejects anyway); it only keeps Σz² and
/// reports finite.
pub const TAIL_MIN: f64 = 1e-300;
/// The largest |z| produced: −Φ⁻¹(TAIL_MIN) as evaluated by `normal_score_of_tail` (statrs erfc_inv).
pub const Z_MAX: f64 = 37.047_096_299_361_21;

/// Above this many degrees of freedom the t distribution is replaced by the normal: the relative
/// error of a tail probability is ≈ t⁴/(4ν) < 1e-4 for |t| ≤ 6, and the incomplete beta function
/// with a huge first parameter is slow and less accurate than the normal tail.
pub const NU_NORMAL: f64 = 1e7;

/// Welch–Satterthwaite degrees of freedom of a sum of independent variance estimates
/// Σ vᵢ with νᵢ degrees of freedom each: (Σ vᵢ)² / Σ (vᵢ²/νᵢ). Terms with vᵢ = 0 carry no
/// uncertainty and drop out. Returns `None` if the sum is 0 or a positive term has νᵢ ≤ 0.
pub fn welch_dof(terms: impl IntoIterator<Item = (f64, f64)>) -> Option<f64> {
    let (mut sum, mut denom) = (0.0f64, 0.0f64);
    for (v, nu) in terms {
        if v > 0.0 {
            if !(nu > 0.0) {
                return None;
            }
            sum += v;
            denom += v * v / nu;
        }
    }
    if sum > 0.0 && denom > 0.0 {
        let nu = sum * sum / denom;
        nu.is_finite().then_some(nu).or(Some(f64::INFINITY))
    } else {
        None
    }
}

/// Upper tail P(T > |t|) of Student's t with ν degrees of freedom (normal for ν > NU_NORMAL),
/// computed directly as a tail (no 1 − cdf cancellation). In [0, 0.5].
pub fn t_upper_tail(t: f64, nu: f64) -> f64 {
    let a = t.abs();
    if a.is_nan() {
        return 0.5;
    }
    let p = if nu > NU_NORMAL {
        normal_upper_tail(a)
    } else {
        match StudentsT::new(0.0, 1.0, nu) {
            Ok(dist) => dist.sf(a),
            Err(_) => normal_upper_tail(a),
        }
    };
    p.clamp(0.0, 0.5)
}

/// Two-sided p-value of t with ν degrees of freedom.
pub fn t_two_sided_p(t: f64, nu: f64) -> f64 {
    (2.0 * t_upper_tail(t, nu)).min(1.0)
}

/// P(Z > z) for z ≥ 0, via erfc (accurate far into the tail).
pub fn normal_upper_tail(z: f64) -> f64 {
    0.5 * statrs::function::erf::erfc(z / std::f64::consts::SQRT_2)
}

/// Normal score of a one-sided upper tail p ∈ (0, 0.5]: the z ≥ 0 with P(Z > z) = p. Tails
/// below TAIL_MIN are clamped to it (|z| ≤ Z_MAX).
pub fn normal_score_of_tail(p: f64) -> f64 {
    let p = if p.is_nan() {
        0.5
    } else {
        p.clamp(TAIL_MIN, 0.5)
    };
    (std::f64::consts::SQRT_2 * erfc_inv(2.0 * p)).clamp(0.0, Z_MAX)
}

/// z = Φ⁻¹(F_t(t; ν)), evaluated through the tail on t's side so that large |t| does not round
/// F_t to 1 (which would give z = +∞). Odd in t, |z| ≤ Z_MAX, never NaN.
pub fn t_to_z(t: f64, nu: f64) -> f64 {
    if t == 0.0 || t.is_nan() {
        return 0.0;
    }
    let z = normal_score_of_tail(t_upper_tail(t, nu));
    if t > 0.0 {
        z
    } else {
        -z
    }
}

/// Two-sided normal quantile: the z with P(|Z| > z) = p.
pub fn normal_two_sided_quantile(p: f64) -> f64 {
    normal_score_of_tail(0.5 * p)
}

/// Two-sided t quantile: the t with P(|T| > t) = p, for ν degrees of freedom.
pub fn t_two_sided_quantile(p: f64, nu: f64) -> f64 {
    let p = p.clamp(TAIL_MIN, 1.0);
    if nu > NU_NORMAL || !(nu > 0.0) {
        return normal_two_sided_quantile(p);
    }
    match StudentsT::new(0.0, 1.0, nu) {
        Ok(dist) => dist.inverse_cdf(1.0 - 0.5 * p).max(0.0),
        Err(_) => normal_two_sided_quantile(p),
    }
}

/// Šidák per-test level so that m independent tests at that level have family-wise level α:
/// 1 − (1 − α)^(1/m), computed without cancellation.
pub fn sidak(alpha: f64, m: usize) -> f64 {
    if m <= 1 {
        return alpha;
    }
    -((-alpha).ln_1p() / m as f64).exp_m1()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welch_dof_special_cases() {
        // Equal variances and dof: ν_W = 2ν.
        let nu = welch_dof([(2.0, 31.0), (2.0, 31.0)]).unwrap();
        assert!((nu - 62.0).abs() < 1e-12);
        // One exact (zero-variance) side: the other side's dof.
        assert_eq!(welch_dof([(3.0, 9.0), (0.0, 0.0)]), Some(9.0));
        assert_eq!(welch_dof([(0.0, 9.0), (0.0, 9.0)]), None);
        assert_eq!(welch_dof([(1.0, 0.0), (1.0, 9.0)]), None);
        // Between min and sum of dofs.
        let nu = welch_dof([(1.0, 5.0), (7.0, 50.0)]).unwrap();
        assert!(nu > 5.0 && nu < 55.0);
    }

    #[test]
    fn z_matches_known_quantiles() {
        // t(ν=10): P(T > 2.228138851964) = 0.025 ⇒ z = 1.959963984540.
        let z = t_to_z(2.228_138_851_964, 10.0);
        assert!((z - 1.959_963_984_540).abs() < 1e-8, "{z}");
        assert!((t_to_z(-2.228_138_851_964, 10.0) + z).abs() < 1e-14);
        // t(ν=1) is Cauchy: P(T > 1) = 0.25 ⇒ z = 0.674489750196.
        assert!((t_to_z(1.0, 1.0) - 0.674_489_750_196).abs() < 1e-8);
        // Huge ν is the normal.
        assert!((t_to_z(3.0, 1e12) - 3.0).abs() < 1e-9);
        assert!((t_to_z(3.0, f64::INFINITY) - 3.0).abs() < 1e-9);
        assert!((t_to_z(3.0, 9e6) - 3.0).abs() < 1e-5);
        // Normal quantiles.
        assert!((normal_two_sided_quantile(0.05) - 1.959_963_984_540).abs() < 1e-9);
        assert!((t_two_sided_quantile(0.05, 10.0) - 2.228_138_851_964).abs() < 1e-8);
        assert!((Z_MAX - normal_score_of_tail(TAIL_MIN)).abs() < 1e-9);
    }

    #[test]
    fn far_tails_are_finite_monotone_and_clamped() {
        let mut last = 0.0;
        for k in 0..200 {
            let t = 1.2f64.powi(k);
            let z = t_to_z(t, 31.0);
            assert!(
                z.is_finite() && z >= last && z <= Z_MAX,
                "t={t} z={z} last={last}"
            );
            last = z;
        }
        assert_eq!(t_to_z(1e300, 31.0), Z_MAX);
        assert_eq!(t_to_z(-1e300, 3.0), -Z_MAX);
        assert_eq!(t_to_z(f64::INFINITY, 3.0), Z_MAX);
        assert_eq!(t_to_z(f64::NAN, 3.0), 0.0);
        // Deep but representable tail: t(ν=31) at t = 40 has P ≈ 1e-28, z ≈ 11; naive
        // Φ⁻¹(cdf) would give +∞ here because cdf rounds to 1.
        let z = t_to_z(40.0, 31.0);
        assert!(z > 10.0 && z < 12.5, "{z}");
    }

    #[test]
    fn sidak_inverts() {
        let a = sidak(0.01, 12);
        assert!(((1.0 - a).powi(12) - 0.99).abs() < 1e-15);
        assert_eq!(sidak(0.01, 1), 0.01);
    }
}
