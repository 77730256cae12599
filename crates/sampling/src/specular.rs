//! The specular technique of the diffuse + specular estimator (LTC line sampling), as a trait
//! so that tests can substitute deliberately wrong variants (power controls) and the
//! integrator stays monomorphic in production.
//!
//! The estimator combines two techniques per light (the renderer's `Method::Mis`):
//! the diffuse one, [`ProjectedSolidAngle`](crate::projected_solid_angle::ProjectedSolidAngle)
//! on the line clipped at the horizon of n (support: that whole clipped line), and a specular
//! one whose support lies within it. Both densities are per radius. Each technique needs the
//! other's density at its sample (the *cross density*), and both samples lie on the clipped
//! line, so the cross densities need no support test:
//! `ProjectedSolidAngle::density_in_support` and
//! [`SpecularSampler::density_on_clipped_line`].

use crate::ltc::LtcLine;
use crate::sampler::LineSampler;
use glam::Vec3;

/// A specular technique of the two-technique estimator.
pub trait SpecularSampler: LineSampler {
    /// Density per radius of a direction toward the line's part above the horizon of n,
    /// without support test (0 where this technique cannot sample). Must equal `pdf` there.
    fn density_on_clipped_line(&self, dir: Vec3) -> f32;

    /// Ω⊥_o/κ: the MIS technique weight of the lobe is W_s = k_s·ρ_s·Ω⊥_o/κ per channel (an
    /// estimate of the lobe's unshadowed contribution up to the factor the diffuse weight
    /// W_d = max(ρ_d, 0.01)·Ω⊥_R shares with it).
    fn weight_scale(&self) -> f32;
}

impl SpecularSampler for LtcLine {
    #[inline]
    fn density_on_clipped_line(&self, dir: Vec3) -> f32 {
        LtcLine::density_on_clipped_line(self, dir)
    }

    #[inline]
    fn weight_scale(&self) -> f32 {
        self.transformed_projected_solid_angle() / self.kappa()
    }
}
