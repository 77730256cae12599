//! Solid angle sampling (technique 3) and clipped solid angle sampling (technique 4).
//!
//! s is uniform on [s_begin, s_end] of the (clipped) segment, so p_R = 1/Ω_R on the support.
//! Inverse: ξ = (s − s_begin)/(s_end − s_begin).
//!
//! Numerics: s − s_begin and the support test go through the frame's [`FrameArc`] (offset
//! τ = φ − φ_b), not through s = u·ω, which near |s| → 1 is quantised to steps of ε/2 (a short
//! interval there holds only a few f32 values of s, and for ℓ/d ≳ 3000 s_end rounds to 1 so that
//! an s-test would accept the whole rest of the line).

use crate::geometry::{normal_is_valid, unit_normal, EndValues, FrameArc, LineFrame, Segment};
use crate::sampler::{clamp_xi, LineSampler};
use crate::trig::atan2_f64;
use glam::Vec3;

/// s uniform on an interval of the line; shared by the clipped and the unclipped variant.
#[derive(Clone, Copy, Debug)]
pub struct SolidAngle {
    // pub(crate): the structure of arrays of [`crate::batch`] stores and rebuilds them.
    pub(crate) frame: LineFrame,
    pub(crate) arc: FrameArc,
    pub(crate) inv_solid_angle: f32,
}

impl SolidAngle {
    /// Uniform in solid angle over the whole segment (no horizon clipping). The normal only
    /// decides nothing here; it is validated so that every technique rejects the same inputs.
    pub fn prepare(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        if !normal_is_valid(n) {
            return None;
        }
        Self::on_frame(LineFrame::new(segment, x)?)
    }

    /// Uniform in solid angle over the part of the segment above the horizon of `n` (clipped
    /// with the unit normal; the lanes of [`crate::batch`] clip with the same).
    pub fn prepare_clipped(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        let n = unit_normal(n)?;
        let (frame, ends) = LineFrame::clipped_with_ends(segment, x, n)?;
        let (sampler, valid) = Self::lane(frame, ends, atan2_f64);
        valid.then_some(sampler)
    }

    /// Uniform in solid angle over an already prepared interval.
    pub fn on_frame(frame: LineFrame) -> Option<Self> {
        let (sampler, valid) = Self::lane(frame, EndValues::of(&frame), atan2_f64);
        valid.then_some(sampler)
    }

    /// [`Self::on_frame`] without branches, from the frame's [`EndValues`] (as its constructor
    /// computed them) and a given atan2: the sampler and whether `on_frame` returns it (the one
    /// implementation of the scalar path and the lanes of [`crate::batch`]).
    #[inline(always)]
    pub(crate) fn lane(
        frame: LineFrame,
        ends: EndValues,
        atan2: impl Fn(f64, f64) -> f64,
    ) -> (Self, bool) {
        // Ω_R may be subnormal (far line, tiny Δs): its reciprocal must be finite too.
        let inv_solid_angle = 1.0 / frame.solid_angle();
        let arc = FrameArc::on_ends(&frame, ends, atan2);
        let valid = inv_solid_angle > 0.0 && inv_solid_angle.is_finite() && arc.delta_s > 0.0;
        let sampler = Self {
            frame,
            arc,
            inv_solid_angle,
        };
        (sampler, valid)
    }

    /// [`LineSampler::sample_with_pdf`] with a given atan2 (branch-free in [`crate::batch`];
    /// bitwise equal): s uniform on the interval, the density 1/Ω_R.
    #[inline(always)]
    pub(crate) fn sample_lane(&self, xi: f32, atan2: impl Fn(f64, f64) -> f64) -> (Vec3, f32) {
        let y = clamp_xi(xi) as f64 * self.arc.delta_s;
        let tau = self.arc.tau_of_delta_s_with(y, atan2);
        (self.arc.direction(&self.frame, tau), self.inv_solid_angle)
    }
}

impl LineSampler for SolidAngle {
    fn sample(&self, xi: f32) -> Vec3 {
        self.sample_lane(xi, atan2_f64).0
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        if self.arc.contains(&self.frame, dir) {
            self.inv_solid_angle
        } else {
            0.0
        }
    }

    fn support(&self) -> &LineFrame {
        &self.frame
    }

    fn inverse(&self, dir: Vec3) -> Option<f32> {
        let tau = self.arc.tau_in_support(&self.frame, dir)?;
        Some(((self.arc.delta_s_at(tau) / self.arc.delta_s) as f32).clamp(0.0, 1.0))
    }

    #[inline]
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        self.sample_lane(xi, atan2_f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_density_and_round_trip() {
        let seg = Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0));
        let s = SolidAngle::prepare(&seg, Vec3::ZERO, Vec3::Z).unwrap();
        assert!((s.pdf(s.sample(0.3)) - 1.0 / (2.0 * 2f32.sqrt())).abs() < 1e-6);
        for &xi in &[0.0f32, 0.25, 0.5, 0.9, 1.0] {
            assert!((s.inverse(s.sample(xi)).unwrap() - xi).abs() < 1e-5);
        }
    }

    #[test]
    fn clipped_support_is_above_the_horizon() {
        let seg = Segment::new(Vec3::new(1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0));
        let c = SolidAngle::prepare_clipped(&seg, Vec3::ZERO, Vec3::Z).unwrap();
        for i in 0..=10 {
            assert!(c.sample(i as f32 / 10.0).z >= -1e-6);
        }
        assert_eq!(c.pdf(Vec3::new(1.0, 0.0, -1.0).normalize()), 0.0);
    }
}
