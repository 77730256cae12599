//! The one-sample MIS mixture of the diffuse and the specular technique as a sampler of its
//! own: choose the diffuse technique (projected solid angle on the horizon-clipped line) with
//! probability c, else the specular one, and report the mixture density
//!
//!   p(ω) = c·p_d(ω) + (1 − c)·p_s(ω)   (per radius),
//!
//! each term from the technique's cross density when the other technique drew the sample (the
//! functions the two-sample estimator uses). Its support is the diffuse technique's, which
//! contains the specular one. Used by the sampler suite to certify the cross densities
//! together with the samplers; one-sample MIS with the balance heuristic is exactly f/p.

use crate::geometry::{FrameArc, LineFrame};
use crate::projected_solid_angle::ProjectedSolidAngle;
use crate::sampler::{clamp_xi, LineSampler};
use crate::specular::SpecularSampler;
use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Mixture<S> {
    diffuse: ProjectedSolidAngle,
    specular: S,
    arc: FrameArc,
    /// Probability of the diffuse technique, in [0, 1].
    c: f32,
}

impl<S: SpecularSampler> Mixture<S> {
    /// `c`: probability of choosing the diffuse technique (clamped to [0, 1]; NaN → 1).
    /// Both samplers must be prepared for the same light, shading point and normal.
    pub fn new(diffuse: ProjectedSolidAngle, specular: S, c: f32) -> Self {
        let c = if c >= 0.0 {
            c.min(1.0)
        } else if c < 0.0 {
            0.0
        } else {
            1.0
        };
        Self {
            arc: FrameArc::of(diffuse.support()),
            diffuse,
            specular,
            c,
        }
    }

    pub fn diffuse_probability(&self) -> f32 {
        self.c
    }
}

impl<S: SpecularSampler> LineSampler for Mixture<S> {
    fn sample(&self, xi: f32) -> Vec3 {
        self.sample_with_pdf(xi).0
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        if !self.arc.contains(self.diffuse.support(), dir) {
            return 0.0;
        }
        self.c * self.diffuse.density_in_support(dir)
            + (1.0 - self.c) * self.specular.density_on_clipped_line(dir)
    }

    fn support(&self) -> &LineFrame {
        self.diffuse.support()
    }

    /// The technique chosen by ξ < c draws from ξ rescaled to [0, 1]; the density is its own
    /// density plus the other's cross density.
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        let xi = clamp_xi(xi);
        if xi < self.c || self.c >= 1.0 {
            let (dir, p_d) = self.diffuse.sample_with_pdf(xi / self.c);
            let p_s = self.specular.density_on_clipped_line(dir);
            (dir, self.c * p_d + (1.0 - self.c) * p_s)
        } else {
            let (dir, p_s) = self
                .specular
                .sample_with_pdf((xi - self.c) / (1.0 - self.c));
            let p_d = self.diffuse.density_in_support(dir);
            (dir, self.c * p_d + (1.0 - self.c) * p_s)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Segment;
    use glam::Mat3;

    fn setup() -> (ProjectedSolidAngle, LtcLine) {
        let seg = Segment::new(Vec3::new(-1.0, 0.3, -0.2), Vec3::new(1.0, 0.2, 1.2));
        let n = Vec3::Z;
        let v = Vec3::new(0.5, 0.0, 1.0).normalize();
        let xh = (v - n.dot(v) * n).normalize();
        let frame = Mat3::from_cols(xh, n.cross(xh), n);
        let a = Mat3::from_cols(
            Vec3::new(3.0, 0.0, -0.2),
            Vec3::new(0.0, 3.0, 0.0),
            Vec3::new(0.3, 0.0, 1.0),
        );
        (
            ProjectedSolidAngle::prepare(&seg, Vec3::ZERO, n).unwrap(),
            LtcLine::prepare(&seg, Vec3::ZERO, frame, a).unwrap(),
        )
    }
    use crate::ltc::LtcLine;

    /// sample_with_pdf reports the mixture density of its sample, and the density integrates to
    /// 1 over the diffuse support (midpoint rule in φ; dΩ_R = (2/d) cos φ dφ).
    #[test]
    fn density_is_consistent_and_normalised() {
        let (psa, ltc) = setup();
        for c in [0.0, 0.3, 0.5, 1.0] {
            let m = Mixture::new(psa, ltc, c);
            for i in 0..50 {
                let xi = (i as f32 + 0.5) / 50.0;
                let (dir, p) = m.sample_with_pdf(xi);
                let q = m.pdf(dir);
                assert!(
                    (p - q).abs() <= 2e-3 * q.max(1e-3),
                    "c {c} ξ {xi}: {p} vs {q}"
                );
            }
            let f = *m.support();
            let (phi_b, phi_e) = (f.s_begin.asin() as f64, f.s_end.asin() as f64);
            let k = 200_000;
            let h = (phi_e - phi_b) / k as f64;
            let mut total = 0.0;
            for j in 0..k {
                let phi = phi_b + (j as f64 + 0.5) * h;
                let dir = (phi.sin() * f.u.as_dvec3() + phi.cos() * f.c_hat.as_dvec3()).as_vec3();
                total += m.pdf(dir) as f64 * 2.0 / f.d as f64 * phi.cos() * h;
            }
            assert!((total - 1.0).abs() < 2e-3, "c {c}: ∫p = {total}");
        }
    }
}
