//! Gamito's construction (EGSR 2016, "Solid Angle Sampling of Disk and Cylinder Lights") for
//! uniform solid-angle sampling of the cylinder: sample a spherical rectangle that bounds the
//! visible side uniformly in solid angle, keep the directions that hit the side. The kept
//! directions are uniform on the side's solid angle: p = 1/Ω, 0 elsewhere (no horizon
//! clipping; samples below it contribute 0).
//!
//! The bounding rectangle lies in the plane through the two silhouette lines (perpendicular to
//! ĉ at distance d = (ρ² − R²)/ρ from x), between them (half-width R√(ρ² − R²)/ρ, so it covers
//! exactly the azimuths |α| ≤ α_max), along the axis from l₀ to l₁. The front side lies between
//! x and that plane; a front point at surface angle θ is at depth ρ − R cos θ ≥ ρ − R along ĉ,
//! so seen from x it projects onto the plane at most (ρ + R)/ρ times further along the axis.
//! An end e of the side is therefore covered by l = e·(1 + R/ρ) where it moves away from the
//! foot of x (l₀ for a < 0, l₁ for b > 0), and by l = e itself otherwise.
//!
//! The rectangle is sampled in the view's (α, s = sin φ) coordinates (dΩ = dα ds). At azimuth
//! α the plane is at horizontal distance d/cos α, so the rectangle spans
//! S_l(α) = l cos α / √(d² + l² cos² α) for l ∈ [l₀, l₁], and its azimuth marginal has the
//! primitive G(α) = asin(A₁ sin α) − asin(A₀ sin α), A_l = l/√(d² + l²); Ω_rect = 2 G(α_max).
//! G is inverted in closed form: with t = G(α), P = asin(A₁ sin α) solves
//! A₀ sin P = A₁ sin(P − t), whence
//!
//! ```text
//! sin α = sgn(A₁ cos t − A₀) · sin t / √((A₁ − A₀)² + 4 A₀ A₁ sin²(t/2)),
//! ```
//!
//! then s uniform on [S_{l₀}(α), S_{l₁}(α)]. (This is Ureña et al.'s spherical-rectangle map
//! for a rectangle symmetric about the foot of x.) The acceptance rate is Ω/Ω_rect.
//!
//! Ω itself, the normalisation, is the same quadrature as [`super::CylinderSolidAngle`]'s
//! (relative error ≤ 1e-9), not the paper's own evaluation of it. Rejection: the
//! first candidate uses ξ, later ones a PCG32 stream keyed by the bits of ξ (a deterministic
//! function of ξ). No inverse.

use super::solid_angle::solid_angle_of;
use super::{reject_until_accepted, CylinderSampler, CylinderView};
use glam::DVec3;

/// Most candidates per sample; the acceptance rate Ω/Ω_rect is ≥ 0.39 on the tests'
/// configurations (0.397 at ρ = 1.05 R, 0.25 R beyond an end; ≥ 0.68 elsewhere), so the
/// chance of reaching this is below 1e-400.
const MAX_CANDIDATES: usize = 2000;

#[derive(Clone, Copy, Debug)]
pub struct CylinderGamito {
    view: CylinderView,
    /// 1/Ω of the visible side.
    inv_omega: f64,
    /// Distance of the rectangle's plane from x, along ĉ.
    depth: f64,
    /// The rectangle's axial extent [l₀, l₁] and A_l = l/√(d² + l²) at both.
    l: [f64; 2],
    a_l: [f64; 2],
    /// G(α_max): half the rectangle's solid angle.
    g_max: f64,
}

impl CylinderGamito {
    pub fn new(view: &CylinderView) -> Option<Self> {
        let v = view;
        let depth = (v.rho - v.radius) * (v.rho + v.radius) / v.rho;
        let grow = 1.0 + v.radius / v.rho;
        let l = [
            if v.a < 0.0 { v.a * grow } else { v.a },
            if v.b > 0.0 { v.b * grow } else { v.b },
        ];
        let a_l = l.map(|l| l / l.hypot(depth));
        let sin_max = v.radius / v.rho;
        let g_max = (a_l[1] * sin_max).asin() - (a_l[0] * sin_max).asin();
        let inv_omega = 1.0 / solid_angle_of(v);
        (inv_omega.is_finite() && inv_omega > 0.0 && g_max > 0.0 && depth > 0.0).then_some(Self {
            view: *view,
            inv_omega,
            depth,
            l,
            a_l,
            g_max,
        })
    }

    /// Solid angle Ω of the visible side.
    pub fn solid_angle(&self) -> f64 {
        1.0 / self.inv_omega
    }

    /// Solid angle of the bounding rectangle (Ω / this is the acceptance rate).
    pub fn bounding_solid_angle(&self) -> f64 {
        2.0 * self.g_max
    }

    /// The rectangle's elevation range S_l(α) at azimuth α, for l₀ and l₁.
    #[inline]
    fn s_range(&self, alpha: f64) -> (f64, f64) {
        let c = alpha.cos();
        let s = |l: f64| l * c / (self.depth.hypot(l * c));
        (s(self.l[0]), s(self.l[1]))
    }

    /// The candidate (α, s) for (ξ₀, ξ₁) ∈ [0, 1]², uniform in the rectangle's solid angle.
    #[inline]
    fn candidate(&self, x0: f64, x1: f64) -> (f64, f64) {
        let t = (2.0 * x0 - 1.0) * self.g_max;
        let [a0, a1] = self.a_l;
        let half = (0.5 * t).sin();
        let norm = ((a1 - a0) * (a1 - a0) + 4.0 * a0 * a1 * half * half).sqrt();
        let sign = if a1 * t.cos() - a0 >= 0.0 { 1.0 } else { -1.0 };
        let sin_max = self.view.radius / self.view.rho;
        let sigma = (sign * t.sin() / norm).clamp(-sin_max, sin_max);
        let alpha = sigma.asin();
        let (s0, s1) = self.s_range(alpha);
        (alpha, s0 + x1 * (s1 - s0))
    }
}

impl CylinderSampler for CylinderGamito {
    fn sample_with_pdf(&self, xi: [f32; 2]) -> Option<(DVec3, f64)> {
        let dir = reject_until_accepted(
            xi,
            0x6a,
            MAX_CANDIDATES,
            |x0, x1| self.candidate(x0, x1),
            |alpha, s| self.view.front_direction(alpha, s),
        )?;
        Some((dir, self.inv_omega))
    }

    fn pdf(&self, dir: DVec3) -> f64 {
        if self.view.hit(dir).is_some() {
            self.inv_omega
        } else {
            0.0
        }
    }

    fn view(&self) -> &CylinderView {
        &self.view
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::super::{Cylinder, CylinderView};
    use super::*;

    /// The rectangle's map: G inverted (the candidate's α has the CDF ξ₀), the rectangle covers
    /// the side, and the acceptance rate estimates Ω.
    #[test]
    fn rectangle_map_covers_the_side_and_acceptance_is_omega() {
        let mut cases = configs();
        let cyl = Cylinder::new(DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0), 0.5).unwrap();
        // Beyond an end close to the rim, and beside the middle close to the side.
        cases.push((cyl, DVec3::new(-0.005, 0.0, 0.505), DVec3::Z));
        cases.push((cyl, DVec3::new(1.5, 0.0, 0.5005), DVec3::Z));
        for (cyl, x, n) in cases {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            let s = CylinderGamito::new(&v).unwrap();
            // G(α(ξ₀)) = (2ξ₀ − 1) G_max.
            for i in 0..=64 {
                let x0 = i as f64 / 64.0;
                let (alpha, _) = s.candidate(x0, 0.5);
                let [a0, a1] = s.a_l;
                let g = (a1 * alpha.sin()).asin() - (a0 * alpha.sin()).asin();
                let want = (2.0 * x0 - 1.0) * s.g_max;
                assert!(
                    (g - want).abs() <= 1e-9 * s.g_max,
                    "G {g} vs {want}, R = {}",
                    cyl.radius
                );
            }
            // Every front direction lies in the rectangle.
            for i in 0..=40 {
                let theta = v.theta_max * (i as f64 / 20.0 - 1.0);
                let (alpha, _) = v.alpha_of_theta(theta);
                let (pa, pb) = v.phi_range(v.h(alpha));
                let (s0, s1) = s.s_range(alpha);
                let tol = 1e-12;
                assert!(pa.sin() >= s0 - tol && pb.sin() <= s1 + tol, "θ {theta}");
            }
            // Acceptance of the first candidate on a 256 × 256 grid against Ω/Ω_rect.
            let k = 256;
            let mut accepted = 0usize;
            for i in 0..k {
                for j in 0..k {
                    let (a, sv) =
                        s.candidate((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
                    accepted += s.view.front_direction(a, sv).is_some() as usize;
                }
            }
            let rate = accepted as f64 / (k * k) as f64;
            let want = s.solid_angle() / s.bounding_solid_angle();
            assert!(want > 0.39, "acceptance {want}");
            assert!(
                (rate - want).abs() < 0.01,
                "acceptance {rate} vs Ω/Ω_rect {want}"
            );
            for i in 1..49 {
                let (dir, p) = s.sample_with_pdf([i as f32 / 49.0, 0.3]).unwrap();
                assert_eq!(s.pdf(dir), p);
            }
        }
    }
}
