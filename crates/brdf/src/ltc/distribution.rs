//! The linearly transformed cosine (LTC) distribution of Heitz, Dupuy, Hill and Neubelt (2016),
//! in f64, for the fitter and the tests.
//!
//! Measure: D_LTC is a probability density per solid angle on the unit sphere. With M the
//! matrix that maps cosine space to shading space and A = M⁻¹,
//!
//!   D_LTC(ω) = D_o(Aω/|Aω|) · |det A| / |Aω|³,   D_o(w) = max(0, w_z)/π,
//!
//! i.e. D_LTC(ω) = max(0, (Aω)_z) |det A| / (π |Aω|⁴). It integrates to 1 over the sphere (its
//! support is the half-space (Aω)_z > 0, which may reach below the shading horizon). It does not
//! depend on the scale of A, which is why the tables may normalise A freely.
//!
//! Sampling: w drawn from D_o (cosine-weighted hemisphere), ω = Mw/|Mw|.

use glam::{DMat3, DVec3};
use std::f64::consts::{FRAC_1_PI, PI};

/// A linearly transformed cosine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ltc {
    /// Cosine space → shading space.
    m: DMat3,
    /// Shading space → cosine space, M⁻¹.
    a: DMat3,
    /// |det A| / π.
    scale: f64,
}

impl Ltc {
    /// The LTC with cosine → shading matrix `m`. `None` if `m` is singular or not finite.
    pub fn from_m(m: DMat3) -> Option<Self> {
        let det = m.determinant();
        if !(det.is_finite() && det != 0.0 && m.is_finite()) {
            return None;
        }
        let a = m.inverse();
        a.is_finite().then(|| Self {
            m,
            a,
            scale: (1.0 / det).abs() * FRAC_1_PI,
        })
    }

    /// The LTC with shading → cosine matrix `a` (the tables' A). `None` if `a` is singular or
    /// not finite.
    pub fn from_a(a: DMat3) -> Option<Self> {
        let det = a.determinant();
        if !(det.is_finite() && det != 0.0 && a.is_finite()) {
            return None;
        }
        let m = a.inverse();
        m.is_finite().then(|| Self {
            m,
            a,
            scale: det.abs() * FRAC_1_PI,
        })
    }

    /// Cosine space → shading space.
    pub fn m(&self) -> DMat3 {
        self.m
    }

    /// Shading space → cosine space.
    pub fn a(&self) -> DMat3 {
        self.a
    }

    /// D_LTC(ω) per solid angle for a unit direction ω in the shading frame.
    #[inline]
    pub fn density(&self, w: DVec3) -> f64 {
        let aw = self.a * w;
        if !(aw.z > 0.0) {
            return 0.0;
        }
        let len2 = aw.length_squared();
        self.scale * aw.z / (len2 * len2)
    }

    /// A unit direction distributed with density [`Ltc::density`], from two numbers in [0, 1).
    #[inline]
    pub fn sample(&self, u1: f64, u2: f64) -> DVec3 {
        self.transform(cosine_sample(u1, u2))
    }

    /// ω = Mw/|Mw| for a cosine-space direction w (samples of D_o map to samples of D_LTC).
    #[inline]
    pub fn transform(&self, w: DVec3) -> DVec3 {
        (self.m * w).normalize()
    }
}

/// A direction of the upper hemisphere with density w_z/π per solid angle (polar mapping of the
/// unit square onto the disk, projected up).
#[inline]
pub fn cosine_sample(u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let (sin_phi, cos_phi) = (2.0 * PI * u2).sin_cos();
    DVec3::new(r * cos_phi, r * sin_phi, (1.0 - u1).max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ltc::test_support::integrate_sphere;
    use linlight_quadrature::GaussLegendre;

    fn rows(r: [[f64; 3]; 3]) -> DMat3 {
        DMat3::from_cols_array_2d(&r).transpose()
    }

    #[test]
    fn density_integrates_to_one() {
        let cases = [
            DMat3::IDENTITY,
            rows([[0.3, 0.0, 0.1], [0.0, 0.25, 0.0], [-0.05, 0.0, 1.0]]),
            // Sharp (α ~ 1e-3) and tilted toward the horizon.
            rows([[1e-3, 0.0, 0.9], [0.0, 2e-3, 0.0], [-1e-3, 0.0, 0.4]]),
            rows([[2.0, 0.0, -0.5], [0.0, 1.5, 0.0], [0.7, 0.0, 1.0]]),
        ];
        for m in cases {
            let ltc = Ltc::from_m(m).unwrap();
            let total = integrate_sphere(&ltc);
            assert!((total - 1.0).abs() < 1e-8, "M = {m:?}: ∫D_LTC = {total}");
            // Scale invariance: the same distribution from 7·A.
            let scaled = Ltc::from_a(7.0 * ltc.a()).unwrap();
            let w = DVec3::new(0.3, -0.2, 0.9).normalize();
            let (d0, d1) = (ltc.density(w), scaled.density(w));
            assert!((d0 - d1).abs() <= 1e-12 * d0.max(1e-300));
        }
    }

    #[test]
    fn samples_follow_the_density() {
        // The mean direction of samples (midpoint grid) against quadrature of ω·D_LTC.
        let m = rows([[0.4, 0.0, 0.3], [0.0, 0.5, 0.0], [-0.1, 0.0, 1.0]]);
        let ltc = Ltc::from_m(m).unwrap();
        let n = 400;
        let mut mean = DVec3::ZERO;
        for i in 0..n {
            for j in 0..n {
                let w = ltc.sample((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                assert!((w.length() - 1.0).abs() < 1e-12);
                mean += w;
            }
        }
        mean /= (n * n) as f64;
        let gl = GaussLegendre::new(64);
        let mut expected = DVec3::ZERO;
        for k in 0..3 {
            expected[k] = gl
                .integrate(0.0, PI, &mut |theta: f64| {
                    let (st, ct) = theta.sin_cos();
                    gl.integrate(0.0, 2.0 * PI, &mut |phi: f64| {
                        let w = DVec3::new(st * phi.cos(), st * phi.sin(), ct);
                        w[k] * ltc.density(w)
                    })
                    .value
                        * st
                })
                .value;
        }
        assert!(
            (mean - expected).length() < 1e-4,
            "{mean:?} vs {expected:?}"
        );
    }

    #[test]
    fn singular_matrices_are_rejected() {
        assert!(Ltc::from_m(DMat3::ZERO).is_none());
        assert!(Ltc::from_a(DMat3::from_cols(DVec3::X, DVec3::X, DVec3::Z)).is_none());
        let mut nan = DMat3::IDENTITY;
        nan.x_axis.x = f64::NAN;
        assert!(Ltc::from_a(nan).is_none());
    }
}
