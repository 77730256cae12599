//! Quadratures shared by the LTC tests, independent of the fitter's sampling: Gauss–Legendre
//! (the verify crate's rule) in polar coordinates, with the integrands' edges found in closed
//! form so that no panel contains a discontinuity.

use super::distribution::Ltc;
use crate::microfacet::{ggx_cos, reflect};
use glam::DVec3;
use linlight_quadrature::GaussLegendre;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// ∫_a^b f by `panels` equal panels of the rule `gl`.
fn panels(gl: &GaussLegendre, a: f64, b: f64, n: usize, f: &mut impl FnMut(f64) -> f64) -> f64 {
    let h = (b - a) / n as f64;
    (0..n)
        .map(|k| {
            let x = a + k as f64 * h;
            gl.integrate(x, x + h, f).value
        })
        .sum()
}

/// Edges between `a` and `b` graded geometrically toward both ends (ratio 1.5, smallest step
/// 1e-6·(b − a)), for integrands with square-root behaviour at the ends.
fn graded(a: f64, b: f64) -> Vec<f64> {
    let len = b - a;
    if !(len > 0.0) {
        return vec![];
    }
    let mut steps = vec![];
    let mut t = 1e-6;
    while t < 0.25 {
        steps.push(t);
        t *= 1.5;
    }
    let mut edges = vec![a];
    edges.extend(steps.iter().map(|s| a + s * len));
    // Uniform middle.
    for k in 1..16 {
        edges.push(a + len * (0.25 + 0.5 * k as f64 / 16.0));
    }
    edges.extend(steps.iter().rev().map(|s| b - s * len));
    edges.push(b);
    edges.sort_by(f64::total_cmp);
    edges.dedup();
    edges
}

/// ∫ D_LTC dω over the sphere by Gauss–Legendre in polar coordinates (θ, φ) about the lobe
/// peak p = Mẑ/|Mẑ| (the shading-space parametrisation, not the cosine-space substitution that
/// defines D_LTC). The support is the half-space a₃·ω > 0 (a₃ the last row of A); each ring θ
/// meets it in one arc, found in closed form, so no panel contains its edge. θ panels are
/// geometric from 1e-7 (lobes as narrow as 1e-4) with extra edges where the rings start and
/// stop meeting the support boundary. Resolves lobes with an aspect ratio up to ~10.
pub fn integrate_sphere(ltc: &Ltc) -> f64 {
    let gl = GaussLegendre::new(20);
    let pole = ltc.transform(DVec3::Z);
    let t1 = pole.any_orthonormal_vector();
    let t2 = pole.cross(t1);
    let a3 = ltc.a().row(2).normalize();
    let (c1, c2, cp) = (a3.dot(t1), a3.dot(t2), a3.dot(pole));
    let elevation = cp.clamp(-1.0, 1.0).asin();
    let mut edges = vec![0.0, elevation, PI - elevation, PI];
    let mut t = 1e-7;
    while t < PI {
        edges.push(t);
        t *= 1.2;
    }
    edges.retain(|e| (0.0..=PI).contains(e));
    edges.sort_by(f64::total_cmp);
    let ring = |theta: f64| {
        let (st, ct) = theta.sin_cos();
        // a₃·ω(φ) = r cos(φ − φ0) + c > 0 on the arc φ0 ± half.
        let (r, c) = (st * c1.hypot(c2), ct * cp);
        let phi0 = c2.atan2(c1);
        let half = if c >= r {
            PI
        } else if c <= -r {
            return 0.0;
        } else {
            (-c / r).acos()
        };
        let mut density = |phi: f64| {
            let (sp, cph) = phi.sin_cos();
            ltc.density(st * (cph * t1 + sp * t2) + ct * pole)
        };
        panels(&gl, phi0 - half, phi0 + half, 8, &mut density) * st
    };
    edges
        .windows(2)
        .map(|w| gl.integrate(w[0], w[1], &mut |theta| ring(theta)).value)
        .sum()
}

/// (∫ f cos dω, ∫ ω f cos dω) of the GGX lobe ([`ggx_cos`]) for the view v = (sin θ_v, 0,
/// cos θ_v), integrated over the half-vector: dω_l = 4 (v·h) dω_h, θ_h = atan(α tan w) so that
/// the peak of width α is resolved in w. The lobe is nonzero where l_z > 0, which for each ring
/// θ_h is |φ_h| < φ_max with cos φ_max = −cot θ_v · cot 2θ_h (whole rings for
/// θ_h < π/4 − θ_v/2, none beyond π/4 + θ_v/2): those edges are panel edges, graded.
/// Without `with_average` the first moment is returned as zero (a third of the work).
pub fn lobe_moments_by_quadrature(alpha: f64, theta_v: f64, with_average: bool) -> (f64, DVec3) {
    let gl = GaussLegendre::new(16);
    let v = DVec3::new(theta_v.sin(), 0.0, theta_v.cos());
    let w_of = |theta_h: f64| (theta_h.tan() / alpha).atan();
    let w_lo = w_of((FRAC_PI_4 - 0.5 * theta_v).max(0.0));
    let w_hi = w_of((FRAC_PI_4 + 0.5 * theta_v).min(FRAC_PI_2 - 1e-12));
    // The lobe is even in φ_h (mirror y → −y): the y moment vanishes, the others are twice the
    // integral over φ_h ∈ [0, φ_max].
    let mut total = [0.0; 4];
    for k in [3, 0, 2] {
        if k != 3 && !with_average {
            continue;
        }
        let mut ring = |w: f64| {
            let t = w.tan();
            let theta_h = (alpha * t).atan();
            let jac = alpha / (w.cos().powi(2) * (1.0 + alpha * alpha * t * t));
            let (sh, ch) = theta_h.sin_cos();
            let phi_max = if theta_v == 0.0 {
                if theta_h < FRAC_PI_4 {
                    PI
                } else {
                    0.0
                }
            } else {
                let k = -(theta_v.cos() / theta_v.sin()) * (2.0 * theta_h).cos()
                    / (2.0 * theta_h).sin();
                k.clamp(-1.0, 1.0).acos()
            };
            let mut f = |phi: f64| {
                let h = DVec3::new(sh * phi.cos(), sh * phi.sin(), ch);
                let l = reflect(v, h);
                let value = ggx_cos(alpha, v, l) * 4.0 * v.dot(h);
                if k == 3 {
                    value
                } else {
                    value * l[k]
                }
            };
            // Symmetric in φ: twice the integral over [0, φ_max].
            2.0 * panels(&gl, 0.0, phi_max, 16, &mut f) * sh * jac
        };
        let mut edges = graded(0.0, w_lo);
        edges.extend(graded(w_lo, w_hi));
        edges.push(FRAC_PI_2 - 1e-12);
        edges.sort_by(f64::total_cmp);
        edges.dedup();
        total[k] = edges
            .windows(2)
            .map(|e| gl.integrate(e[0], e[1], &mut ring).value)
            .sum();
    }
    (total[3], DVec3::new(total[0], total[1], total[2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quadrature itself: at α = 1, D = 1/π and G1(w) = 2 w_z/(1 + w_z), so at normal
    /// incidence f cos = D G1(v) G1(l)/(4 v_z) = l_z/(2π (1 + l_z)) and
    /// ρ_s = ∫_0^1 μ/(1+μ) dμ = 1 − ln 2.
    #[test]
    fn albedo_quadrature_is_exact_at_alpha_one() {
        let (rho, first) = lobe_moments_by_quadrature(1.0, 0.0, true);
        let expected = 1.0 - 2f64.ln();
        assert!((rho - expected).abs() < 1e-10, "{rho} vs {expected}");
        assert!(first.x.abs() < 1e-12, "{first:?}");
        // ∫ l_z f cos dω = ∫_0^1 μ²/(1+μ) dμ = ln 2 − 1/2.
        assert!((first.z - (2f64.ln() - 0.5)).abs() < 1e-10, "{first:?}");
    }
}
