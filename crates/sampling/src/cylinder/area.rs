//! Area sampling of the visible side: the surface angle θ uniform on [−θ_max, θ_max] and the
//! axial position uniform on [p0, p1], i.e. uniform by area on the front-facing part
//! (area A = 2θ_max R ℓ). Mitsuba samples the whole side uniformly by area instead (2πRℓ): the
//! same distribution on the front with probability θ_max/π and a wasted sample otherwise.
//!
//! Density per steradian of a direction hitting the front at distance r under the surface
//! cosine cos θ_y = n_y·(x − y)/r: p = r² / (A cos θ_y). In the view's coordinates
//! r = h/cos φ and cos θ_y = cos φ · √(R² − ρ² sin² α)/R, so p = h² R / (A cos³φ √(R² − ρ² sin² α)),
//! unbounded at the silhouette (|α| → α_max) where the surface is seen edge-on.
//!
//! Inverse: ξ = ((θ + θ_max)/(2θ_max), (l − a)/(b − a)).

use super::{clamp_xi, CylinderSample, CylinderSampler, CylinderView};
use glam::DVec3;

#[derive(Clone, Copy, Debug)]
pub struct CylinderArea {
    view: CylinderView,
    /// 1/A.
    inv_area: f64,
}

impl CylinderArea {
    #[inline]
    pub fn new(view: &CylinderView) -> Option<Self> {
        let area = 2.0 * view.theta_max * view.radius * (view.b - view.a);
        let inv_area = 1.0 / area;
        (inv_area.is_finite() && inv_area > 0.0).then_some(Self {
            view: *view,
            inv_area,
        })
    }
}

impl CylinderSampler for CylinderArea {
    fn sample_with_pdf(&self, xi: [f32; 2]) -> Option<(DVec3, f64)> {
        self.sample_toward(xi).map(|s| (s.dir, s.pdf))
    }

    fn pdf(&self, dir: DVec3) -> f64 {
        self.pdf_toward(dir).map_or(0.0, |(p, _)| p)
    }

    /// The sample, its density and its distance r = |y − x| from the sampled surface point y.
    fn sample_toward(&self, xi: [f32; 2]) -> Option<CylinderSample> {
        let v = &self.view;
        let theta = v.theta_max * (2.0 * clamp_xi(xi[0]) - 1.0);
        let (t0, t1) = (clamp_xi(xi[1]), 1.0 - clamp_xi(xi[1]));
        let l = t1 * v.a + t0 * v.b;
        let (s, c) = theta.sin_cos();
        // y − x = (ρ − R cos θ) ĉ + R sin θ w + l u; n_y·(x − y) = ρ cos θ − R.
        let d = (v.rho - v.radius * c) * v.c + v.radius * s * v.w + l * v.u;
        let r = d.length();
        let facing = v.rho * c - v.radius;
        let p = r * r * r * self.inv_area / facing;
        if !(facing > 0.0 && p.is_finite()) {
            return None;
        }
        CylinderSample::checked(d / r, p, r)
    }

    /// The hit by the view's `front_hit` (sin α, h, cos φ and the distance as ratios), then the
    /// density there.
    fn pdf_toward(&self, dir: DVec3) -> Option<(f64, f64)> {
        let v = &self.view;
        let hit = v.front_hit(dir)?;
        let (h, c) = (hit.slice.h, hit.t);
        let q = v.rho * hit.slice.sin.abs();
        let k = ((v.radius - q).max(0.0) * (v.radius + q)).sqrt();
        let p = h * h * v.radius * self.inv_area / (c * c * c * k);
        Some((if p.is_finite() { p } else { 0.0 }, hit.distance))
    }

    fn inverse(&self, dir: DVec3) -> Option<[f64; 2]> {
        let v = &self.view;
        let (alpha, phi, h) = v.hit(dir)?;
        let theta = v.theta_of_alpha(alpha);
        let l = h * phi.tan();
        Some([
            ((theta / v.theta_max + 1.0) * 0.5).clamp(0.0, 1.0),
            ((l - v.a) / (v.b - v.a)).clamp(0.0, 1.0),
        ])
    }

    fn view(&self) -> &CylinderView {
        &self.view
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::super::CylinderView;
    use super::*;

    #[test]
    fn normalised_consistent_and_invertible() {
        for (cyl, x, n) in configs() {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            let s = CylinderArea::new(&v).unwrap();
            let total = integrate(&v, &mut |a, p| s.pdf(v.direction(a, p)));
            assert!((total - 1.0).abs() < 1e-6, "{total} R = {}", cyl.radius);
            for i in 1..10 {
                for j in 0..=10 {
                    let xi = [i as f32 / 10.0, j as f32 / 10.0];
                    let (dir, p) = s.sample_with_pdf(xi).unwrap();
                    let q = s.pdf(dir);
                    assert!((p - q).abs() <= 1e-8 * p || j == 0 || j == 10, "{p} {q}");
                    let Some(back) = s.inverse(dir) else {
                        // The rebuilt elevation of an end may round out.
                        assert!(j == 0 || j == 10);
                        continue;
                    };
                    assert!((back[0] - xi[0] as f64).abs() < 1e-8, "{back:?} {xi:?}");
                    assert!((back[1] - xi[1] as f64).abs() < 1e-8, "{back:?} {xi:?}");
                }
            }
        }
    }
}
