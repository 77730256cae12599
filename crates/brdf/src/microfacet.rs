//! The GGX (Trowbridge–Reitz) microfacet distribution with Smith's *separable* masking and
//! shadowing, isotropic, as Mitsuba 3's `MicrofacetDistribution` (`ggx`, visible-normal
//! sampling) evaluates it.
//!
//! Measures and invariants:
//! - D is a density of microfacet normals h per solid angle, normalised so that
//!   ∫ D(h) cos θ_h dω_h = 1 over the upper hemisphere.
//! - G1(w, h) ∈ [0, 1], dimensionless; 0 when w sees the back of the microfacet
//!   ((w·h)·w_z ≤ 0), 1 at normal incidence.
//! - [`ggx_cos`] = D(h) G1(v,h) G1(l,h) / (4 v_z) = f(v, l)·l_z with Fresnel F ≡ 1: the lobe
//!   that `roughconductor` with `material="none"` evaluates and that the LTC tables fit.
//! - [`reflection_pdf`] is the density per solid angle of l = reflect(v, h) when h is drawn by
//!   [`sample_visible_normal`]; it integrates to 1 over the whole sphere (l may fall below the
//!   horizon, where the lobe is zero).
//!
//! The scalar formulas are generic ([`Real`]: f32, f64) so that the f64 fitter and the f32
//! renderer evaluate the same expression; they take sin²θ from vector components, as Mitsuba does,
//! so that small α near the normal keeps its precision.

use crate::real::{Real, V3};
use glam::DVec3;

/// Mitsuba clamps roughness from below to this value.
pub const MIN_ALPHA: f64 = 1e-4;

/// Mitsuba flushes D to zero where D·cos θ_h ≤ this value ("numerical issues in other stages").
pub(crate) const D_FLUSH: f64 = 1e-20;

/// α clamped from below as Mitsuba does (NaN stays NaN).
#[inline]
pub fn clamp_alpha<T: Real>(alpha: T) -> T {
    if alpha < T::c(MIN_ALPHA) {
        T::c(MIN_ALPHA)
    } else {
        alpha
    }
}

/// D(h) for a microfacet normal with sin²θ_h = h_x² + h_y² and cos θ_h = h_z (h unit):
/// 1 / (π α² (sin²θ_h/α² + cos²θ_h)²) = α² / (π (sin²θ_h + α² cos²θ_h)²). Zero below the
/// horizon and where Mitsuba flushes it. Branch-free (computed, then selected), so that the
/// lanes of [`crate::Bsdf::eval_lanes`] vectorise.
#[inline(always)]
pub fn d<T: Real>(alpha: T, sin2_theta_h: T, cos_theta_h: T) -> T {
    let a2 = alpha * alpha;
    let denom = sin2_theta_h + a2 * cos_theta_h * cos_theta_h;
    let value = a2 / (T::c(std::f64::consts::PI) * denom * denom);
    if cos_theta_h > T::zero() && value * cos_theta_h > T::c(D_FLUSH) {
        value
    } else {
        T::zero()
    }
}

/// Smith's G1(w, h) for GGX: 2 / (1 + √(1 + α² tan²θ_w)), tan²θ_w = sin²θ_w / cos²θ_w; 1 when
/// sin²θ_w = 0; 0 when (w·h)·cos θ_w ≤ 0. Branch-free, as [`d`].
#[inline(always)]
pub fn g1<T: Real>(alpha: T, sin2_theta_w: T, cos_theta_w: T, w_dot_h: T) -> T {
    let tan2_alpha2 = alpha * alpha * sin2_theta_w / (cos_theta_w * cos_theta_w);
    let value = T::c(2.0) / (T::one() + (T::one() + tan2_alpha2).sqrt());
    let value = if sin2_theta_w == T::zero() {
        T::one()
    } else {
        value
    };
    if w_dot_h * cos_theta_w > T::zero() {
        value
    } else {
        T::zero()
    }
}

/// sin²θ of a unit vector w in the shading frame: w_x² + w_y² (no cancellation near the pole).
#[inline(always)]
pub(crate) fn sin2<T: Real>(w: V3<T>) -> T {
    w.x * w.x + w.y * w.y
}

/// The GGX lobe with F ≡ 1, cosine included: D(h) G1(v,h) G1(l,h) / (4 v_z), h = normalize(v + l),
/// for unit v, l in the shading frame; 0 unless v_z > 0 and l_z > 0. `alpha` is used as given
/// (callers clamp with [`clamp_alpha`] where they model Mitsuba).
pub fn ggx_cos(alpha: f64, v: DVec3, l: DVec3) -> f64 {
    ggx_cos_and_cos_vh(alpha, v, l).0
}

/// [`ggx_cos`] and v·h, the cosine at which a Fresnel factor multiplies the lobe; (0, 0) where
/// the lobe is zero (as Mitsuba's conductor, which skips Fresnel where D = 0). [`ggx_lobe`] in
/// f64.
#[inline(always)]
pub fn ggx_cos_and_cos_vh(alpha: f64, v: DVec3, l: DVec3) -> (f64, f64) {
    ggx_lobe(alpha, v.into(), l.into())
}

/// [`ggx_cos_and_cos_vh`] in either precision ([`Real`]). Branch-free: every value is computed
/// and the zero cases are selected at the end (the same bits as the early returns), so that
/// the lanes of [`crate::Bsdf::eval_lanes`] vectorise.
#[inline(always)]
pub fn ggx_lobe<T: Real>(alpha: T, v: V3<T>, l: V3<T>) -> (T, T) {
    // h = normalize_or_zero(v + l), written out (glam's expression) to select instead of branch.
    let sum = v + l;
    let rcp = sum.length_recip();
    let h = if rcp.is_finite() && rcp > T::zero() {
        sum * rcp
    } else {
        V3::zero()
    };
    let dh = d(alpha, sin2(h), h.z);
    let cos_vh = v.dot(h);
    let g = g1(alpha, sin2(v), v.z, cos_vh) * g1(alpha, sin2(l), l.z, l.dot(h));
    let lobe = dh * g / (T::c(4.0) * v.z);
    let zero = T::zero();
    if v.z > zero && l.z > zero && h != V3::zero() && dh != zero {
        (lobe, cos_vh)
    } else {
        (zero, zero)
    }
}

/// A microfacet normal visible from `v` (v_z > 0), drawn with density
/// D_v(h) = G1(v,h) max(0, v·h) D(h) / v_z per solid angle (Heitz 2018, "Sampling the GGX
/// distribution of visible normals"), from two uniform numbers in [0, 1).
pub fn sample_visible_normal(alpha: f64, v: DVec3, u1: f64, u2: f64) -> DVec3 {
    // Stretch to the configuration α = 1, where visible normals are a projected hemisphere.
    let vh = DVec3::new(alpha * v.x, alpha * v.y, v.z).normalize();
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 {
        DVec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
    } else {
        DVec3::X
    };
    let t2 = vh.cross(t1);
    // A uniform disk point, warped onto the visible half of the projected hemisphere.
    let r = u1.sqrt();
    let (sin_phi, cos_phi) = (2.0 * std::f64::consts::PI * u2).sin_cos();
    let p1 = r * cos_phi;
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin_phi;
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    // Unstretch.
    DVec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// Mirror `v` about the microfacet normal `h`.
#[inline]
pub fn reflect(v: DVec3, h: DVec3) -> DVec3 {
    2.0 * v.dot(h) * h - v
}

/// Density per solid angle of l = reflect(v, h) with h from [`sample_visible_normal`]:
/// D_v(h) / (4 v·h) = G1(v,h) D(h) / (4 v_z), h = normalize(v + l). Defined on the whole sphere
/// (l below the horizon included); 0 when v_z ≤ 0.
pub fn reflection_pdf(alpha: f64, v: DVec3, l: DVec3) -> f64 {
    if !(v.z > 0.0) {
        return 0.0;
    }
    let h = (v + l).normalize_or_zero();
    if h == DVec3::ZERO {
        return 0.0;
    }
    g1(alpha, sin2(v.into()), v.z, v.dot(h)) * d(alpha, sin2(h.into()), h.z) / (4.0 * v.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{dir, gauss};
    use std::f64::consts::PI;

    #[test]
    fn projected_normal_density_integrates_to_one() {
        // ∫ D cos θ_h dω_h = 2π ∫ D(θ) cos θ sin θ dθ; substitute θ = atan(α·t) so that the peak
        // of width α is resolved for every α.
        for alpha in [1e-3, 1e-2, 0.1, 0.3, 0.7, 1.0] {
            let integrand = |w: f64| {
                // t = tan(w), w ∈ [0, π/2): θ = atan(α tan w), dθ/dw = α sec²w / (1 + α² tan²w).
                let t = w.tan();
                let theta = (alpha * t).atan();
                let jac = alpha / (w.cos().powi(2) * (1.0 + alpha * alpha * t * t));
                let (s, co) = theta.sin_cos();
                2.0 * PI * d(alpha, s * s, co) * co * s * jac
            };
            let total = gauss(integrand, 0.0, PI / 2.0 - 1e-12, 400);
            assert!((total - 1.0).abs() < 1e-9, "α = {alpha}: ∫D cos = {total}");
        }
    }

    #[test]
    fn g1_matches_its_closed_form_and_orientation_rule() {
        let alpha = 0.3f64;
        let w = dir(1.0, 0.4);
        let h = dir(0.2, 0.1);
        let tan2 = 1.0f64.tan().powi(2);
        let expected = 2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt());
        let got = g1(alpha, sin2(w.into()), w.z, w.dot(h));
        assert!((got - expected).abs() < 1e-14);
        assert_eq!(g1(alpha, sin2(w.into()), w.z, -w.dot(h)), 0.0);
        assert_eq!(g1(alpha, 0.0, 1.0, 1.0), 1.0);
        // f32 and f64 evaluate the same expression.
        let got32 = g1(
            alpha as f32,
            sin2(w.into()) as f32,
            w.z as f32,
            w.dot(h) as f32,
        );
        assert!((got32 as f64 - expected).abs() < 1e-6);
    }

    #[test]
    fn reflection_pdf_integrates_to_one_over_the_sphere() {
        for (alpha, theta_v) in [(0.1, 0.3), (0.5, 1.2), (1.0, 0.0), (0.3, 1.5)] {
            let v = dir(theta_v, 0.0);
            // Integrate over h (the pdf's own variable) with the Jacobian dω_l = 4 (v·h) dω_h,
            // θ_h substituted as in the D test so small α is resolved.
            let outer = |w: f64| {
                let t = w.tan();
                let th = (alpha * t).atan();
                let jac = alpha / (w.cos().powi(2) * (1.0 + alpha * alpha * t * t));
                let inner = |phi: f64| {
                    let h = dir(th, phi);
                    let vh = v.dot(h);
                    if vh <= 0.0 {
                        return 0.0;
                    }
                    reflection_pdf(alpha, v, reflect(v, h)) * 4.0 * vh
                };
                gauss(inner, 0.0, 2.0 * PI, 64) * th.sin() * jac
            };
            let total = gauss(outer, 0.0, PI / 2.0 - 1e-12, 200);
            assert!(
                (total - 1.0).abs() < 1e-6,
                "α = {alpha}, θ_v = {theta_v}: {total}"
            );
        }
    }

    #[test]
    fn visible_normal_samples_follow_the_reflection_pdf() {
        // Compare E[l_z] and E[l_x] of sampled directions with quadrature of the pdf; 4σ bounds.
        let alpha = 0.4;
        let v = dir(0.9, 0.0);
        let n = 200_000;
        let mut state = 0x853c_49e6_748f_ea9bu64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut sz, mut szz, mut sx, mut sxx) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..n {
            let h = sample_visible_normal(alpha, v, next(), next());
            let l = reflect(v, h);
            assert!((l.length() - 1.0).abs() < 1e-12);
            sz += l.z;
            szz += l.z * l.z;
            sx += l.x;
            sxx += l.x * l.x;
        }
        let nf = n as f64;
        let moment = |g: &dyn Fn(DVec3) -> f64| {
            let outer = |theta: f64| {
                gauss(
                    |phi| {
                        let l = dir(theta, phi);
                        g(l) * reflection_pdf(alpha, v, l)
                    },
                    0.0,
                    2.0 * PI,
                    64,
                ) * theta.sin()
            };
            gauss(outer, 0.0, PI, 200)
        };
        for (sum, sum2, g) in [
            (sz, szz, &(|l: DVec3| l.z) as &dyn Fn(DVec3) -> f64),
            (sx, sxx, &|l: DVec3| l.x),
        ] {
            let mean = sum / nf;
            let se = ((sum2 / nf - mean * mean) / nf).sqrt();
            let expected = moment(g);
            assert!(
                (mean - expected).abs() < 4.0 * se,
                "sample mean {mean} vs quadrature {expected} (se {se})"
            );
        }
    }

    #[test]
    fn lobe_is_reciprocal_and_one_sided() {
        let alpha = 0.25;
        let (v, l) = (dir(0.7, 0.3), dir(0.4, 2.0));
        let f_vl = ggx_cos(alpha, v, l) / l.z;
        let f_lv = ggx_cos(alpha, l, v) / v.z;
        assert!((f_vl - f_lv).abs() < 1e-12 * f_vl);
        assert_eq!(ggx_cos(alpha, v, DVec3::new(l.x, l.y, -l.z)), 0.0);
        assert_eq!(ggx_cos(alpha, DVec3::new(v.x, v.y, -v.z), l), 0.0);
    }

    /// The lobe as written before it was made branch-free (early returns, with the d and g1 of
    /// then): the same bits on a grid of α and directions.
    #[test]
    fn branch_free_lobe_equals_the_early_returns() {
        let reference = crate::early_returns::ggx_cos_and_cos_vh;
        let v0 = dir(0.7, 0.3);
        for alpha in [1e-4, 0.01, 0.3, 1.0] {
            for i in 0..=60 {
                for j in 0..12 {
                    let l = dir(i as f64 * PI / 60.0, j as f64 * 0.5);
                    for v in [v0, dir(1.5, 2.0), DVec3::Z, -l, l] {
                        let (a, b) = (ggx_cos_and_cos_vh(alpha, v, l), reference(alpha, v, l));
                        assert_eq!(
                            (a.0.to_bits(), a.1.to_bits()),
                            (b.0.to_bits(), b.1.to_bits()),
                            "α {alpha}, v {v}, l {l}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn alpha_is_clamped_like_mitsuba() {
        assert_eq!(clamp_alpha(0.0f64), MIN_ALPHA);
        assert_eq!(clamp_alpha(0.5f32), 0.5);
        assert!(clamp_alpha(f64::NAN).is_nan());
    }
}
