//! The interface every technique implements.
//!
//! A technique is *prepared* once per (light, shading point, normal) and then draws any number of
//! samples. Densities are per radius (w.r.t. dΩ_R = (2/d) ds, see [`crate::geometry`]).
//! Preparation returns `None` whenever the light cannot contribute (zero length, fully clipped,
//! shading point on the line, non-finite input): a prepared sampler always has a non-empty
//! support, so no NaN/inf can leave it.

use crate::geometry::LineFrame;
use glam::Vec3;

/// A technique prepared for one light at one shading point.
pub trait LineSampler {
    /// Unit direction toward the line for a primary sample ξ ∈ [0, 1] (values outside are
    /// clamped). Always a direction into the support.
    fn sample(&self, xi: f32) -> Vec3;

    /// Density per radius of a direction toward the line. Evaluable for *any* direction toward
    /// the line (MIS needs the density of another technique's sample): 0 outside the support.
    /// The direction is identified by s = u·ω, so it must point at the line (not only at the
    /// plane through the shading point and the line).
    fn pdf(&self, dir: Vec3) -> f32;

    /// The interval of the line on which `pdf` may be positive (the frame of the whole line,
    /// restricted). For chi-square tests and the renderer's bookkeeping.
    fn support(&self) -> &LineFrame;

    /// Primary sample ξ that maps to `dir`, where a closed-form (or exactly invertible) CDF
    /// exists; `None` for techniques without an inverse, and for directions outside the support.
    fn inverse(&self, _dir: Vec3) -> Option<f32> {
        None
    }

    /// Sample and its density. The default evaluates `pdf`; techniques may override it with a
    /// cheaper value, which must equal `pdf(sample(ξ))` up to rounding.
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        let dir = self.sample(xi);
        (dir, self.pdf(dir))
    }
}

/// Clamp a primary sample to [0, 1]; NaN becomes 0.
#[inline]
pub(crate) fn clamp_xi(xi: f32) -> f32 {
    if xi >= 0.0 {
        xi.min(1.0)
    } else {
        0.0
    }
}
