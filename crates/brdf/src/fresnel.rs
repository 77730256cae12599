//! Fresnel reflectances as Mitsuba 3.9.1 evaluates them (`include/mitsuba/render/fresnel.h` and
//! the principled BSDF's helpers), in f32 or f64 ([`Real`]). All return the unpolarised
//! reflectance ∈ [0, 1] for physical inputs; `cos_theta_i` is the cosine between the incident
//! direction and the (micro)surface normal.

use crate::real::Real;

/// Reflectance of a conductor with complex relative index of refraction η + i·k (Moeller's
/// formula as in Mitsuba's `fresnel_conductor`). η = 0, k = 1 — Mitsuba's values for
/// `material="none"` — gives exactly 1 in exact arithmetic. Branch-free (vectorises in
/// [`crate::Bsdf::eval_lanes`]).
#[inline(always)]
pub fn conductor<T: Real>(cos_theta_i: T, eta: T, k: T) -> T {
    let cos2 = cos_theta_i * cos_theta_i;
    let sin2 = T::one() - cos2;
    let sin4 = sin2 * sin2;
    let temp1 = eta * eta - k * k - sin2;
    let a2pb2 = safe_sqrt(temp1 * temp1 + T::c(4.0) * k * k * eta * eta);
    let a = safe_sqrt(T::c(0.5) * (a2pb2 + temp1));
    let term1 = a2pb2 + cos2;
    let term2 = T::c(2.0) * cos_theta_i * a;
    let r_s = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * cos2 + sin4;
    let term4 = term2 * sin2;
    let r_p = r_s * (term3 - term4) / (term3 + term4);
    T::c(0.5) * (r_s + r_p)
}

/// Reflectance of a dielectric interface with real relative index η (interior over exterior);
/// `cos_theta_i` is signed: negative means the ray arrives from inside (Mitsuba's `fresnel`).
/// Total internal reflection gives 1, an index-matched interface (η = 1) gives 0. Branch-free
/// (computed, then selected: the lanes of [`crate::Bsdf::eval_lanes`] vectorise).
#[inline(always)]
pub fn dielectric<T: Real>(cos_theta_i: T, eta: T) -> T {
    let one = T::one();
    let eta_ti = if cos_theta_i >= T::zero() {
        one / eta
    } else {
        eta
    };
    let eta_it = one / eta_ti;
    let cos_t2 = one - (one - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    let ci = cos_theta_i.abs();
    let ct = safe_sqrt(cos_t2);
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    let r = T::c(0.5) * (a_s * a_s + a_p * a_p);
    if eta == one {
        T::zero()
    } else if ci == T::zero() {
        one
    } else {
        r
    }
}

/// Schlick's weight (1 − c)⁵ with 1 − c clipped to [0, 1].
#[inline(always)]
pub fn schlick_weight<T: Real>(cos: T) -> T {
    // f64::clamp(0, 1) written out (the same result, NaN passes through).
    let m = T::one() - cos;
    let m = if m < T::zero() { T::zero() } else { m };
    let m = if m > T::one() { T::one() } else { m };
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's approximation R₀ + (1 − R₀)·(1 − cos)⁵ as the principled BSDF evaluates it
/// (`calc_schlick`): for η_it ≤ 1 it uses the cosine of the transmitted direction, so that total
/// internal reflection gives 1. Branch-free, as [`dielectric`].
#[inline(always)]
pub fn schlick<T: Real>(r0: T, cos_theta_i: T, eta: T) -> T {
    let one = T::one();
    let outside = cos_theta_i >= T::zero();
    let (eta_it, eta_ti) = if outside {
        (eta, one / eta)
    } else {
        (one / eta, eta)
    };
    let cos_t2 = one - (one - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    let w = if eta_it > one {
        schlick_weight(cos_theta_i.abs())
    } else {
        schlick_weight(safe_sqrt(cos_t2))
    };
    // Mitsuba: lerp(w, 1, R₀) = w·(1 − R₀) + R₀.
    w * (one - r0) + r0
}

/// Normal-incidence reflectance ((η − 1)/(η + 1))² of a dielectric with relative index η.
#[inline(always)]
pub fn schlick_r0<T: Real>(eta: T) -> T {
    let r = (eta - T::one()) / (eta + T::one());
    r * r
}

#[inline(always)]
pub(crate) fn safe_sqrt<T: Real>(x: T) -> T {
    x.max(T::zero()).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conductor_none_is_one_and_normal_incidence_matches_the_textbook() {
        for c in [0.0, 0.01, 0.3, 0.7, 1.0] {
            assert!((conductor::<f64>(c, 0.0, 1.0) - 1.0).abs() < 1e-15, "{c}");
        }
        // Normal incidence: ((η − 1)² + k²) / ((η + 1)² + k²).
        let (eta, k) = (0.2, 3.0);
        let want = ((eta - 1.0f64).powi(2) + k * k) / ((eta + 1.0f64).powi(2) + k * k);
        assert!((conductor::<f64>(1.0, eta, k) - want).abs() < 1e-14);
        // k = 0 reduces to the dielectric.
        for c in [0.1, 0.5, 0.9] {
            assert!(
                (conductor::<f64>(c, 1.5, 0.0) - dielectric::<f64>(c, 1.5)).abs() < 1e-14,
                "{c}"
            );
        }
    }

    #[test]
    fn dielectric_limits() {
        assert!((dielectric::<f64>(1.0, 1.5) - 0.04).abs() < 1e-15);
        assert_eq!(dielectric::<f64>(0.0, 1.5), 1.0);
        assert_eq!(dielectric::<f64>(0.5, 1.0), 0.0);
        // From inside beyond the critical angle: total internal reflection.
        assert_eq!(dielectric::<f64>(-0.2, 1.5), 1.0);
        // Reciprocity of the interface: R(θ_i, η) = R(θ_t, 1/η) seen from the other side.
        let ci: f64 = 0.6;
        let ct = (1.0 - (1.0 - ci * ci) / (1.5 * 1.5)).sqrt();
        assert!((dielectric::<f64>(ci, 1.5) - dielectric::<f64>(-ct, 1.5)).abs() < 1e-14);
    }

    #[test]
    fn schlick_endpoints() {
        assert!((schlick::<f64>(0.04, 1.0, 1.5) - 0.04).abs() < 1e-15);
        assert!((schlick::<f64>(0.04, 0.0, 1.5) - 1.0).abs() < 1e-15);
        assert!((schlick_r0::<f64>(1.5) - 0.04).abs() < 1e-15);
        // η < 1: the transmitted cosine is used; beyond the critical angle that is 0 → weight 1.
        assert!((schlick::<f64>(0.04, 0.3, 1.0 / 1.5) - 1.0).abs() < 1e-15);
        assert_eq!(schlick_weight::<f64>(1.5), 0.0);
        assert_eq!(schlick_weight::<f64>(-0.5), 1.0);
    }
}
