//! A linear light as the renderer samples it ([`Light`]): its segment and K = radiance × radius
//! (the tube's radiance K/R times its solid angle R·Ω_R, so K is what the estimators weight by
//! as R → 0). Built once per render from the scene's [`LinearLight`]s and used as it is by
//! [`RenderScene`](crate::render_scene::RenderScene), the light tree, the scalar integrator and
//! the packet renderer, whose lanes hold a light as its [`LightRow`].

use crate::hooks::LightSampling;
use crate::scene::LinearLight;
use glam::Vec3;
use linlight_sampling::Segment;

/// A linear light: its segment (world space) and K = radiance × radius per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    pub segment: Segment,
    pub k: Vec3,
}

/// A light in the packet renderer's lanes, nine f32: K (or K/p for a chosen light) at
/// [`ROW_K`]..+3, the segment's begin at [`ROW_BEGIN`]..+3 and end at [`ROW_END`]..+3
/// ([`Light::row`]).
pub type LightRow = [f32; 9];

/// The first of K's three values in a [`LightRow`].
pub const ROW_K: usize = 0;
/// The first of the segment begin's three values in a [`LightRow`].
pub const ROW_BEGIN: usize = 3;
/// The first of the segment end's three values in a [`LightRow`].
pub const ROW_END: usize = 6;

impl Light {
    pub fn new(segment: Segment, k: Vec3) -> Self {
        Self { segment, k }
    }

    /// The light a scene describes (its radius enters only through K).
    pub fn of(light: &LinearLight) -> Self {
        Self::new(
            Segment::new(light.begin, light.end),
            Vec3::from_array(light.radiance_times_radius),
        )
    }

    /// The light's segment.
    #[inline(always)]
    pub fn segment(&self) -> &Segment {
        &self.segment
    }

    /// K = radiance × radius.
    #[inline(always)]
    pub fn k(&self) -> Vec3 {
        self.k
    }

    /// K/p of this light chosen with probability p, given 1/p rounded to f32 (the distribution
    /// of `--lights one`: [`crate::light_choice::LightChoice::inverse_probability`]).
    #[inline(always)]
    pub fn k_over_probability(&self, inverse_probability: f32) -> Vec3 {
        self.k * inverse_probability
    }

    /// K/p of this light chosen with probability `pmf` (the light tree's, in f64): K times
    /// [`inverse_pmf`], on both render paths.
    #[inline(always)]
    pub fn k_over_pmf(&self, pmf: f64) -> Vec3 {
        self.k_over_probability(inverse_pmf(pmf))
    }

    /// The sampler of `technique` for this light seen from `x` with unit normal `n` (the
    /// reflecting side's): its `sample` and `pdf` (per radius, dΩ_R) are what the estimators
    /// call; `None` when the light contributes nothing there (e.g. below the horizon).
    #[inline(always)]
    pub fn sampler<T: LightSampling>(&self, technique: &T, x: Vec3, n: Vec3) -> Option<T::Sampler> {
        technique.prepare(&self.segment, x, n)
    }

    /// This light with K = `k` (its own K, or K/p when chosen) as a [`LightRow`].
    #[inline(always)]
    pub fn row(&self, k: Vec3) -> LightRow {
        let mut row = [0.0; 9];
        for (at, v) in [
            (ROW_K, k),
            (ROW_BEGIN, self.segment.begin),
            (ROW_END, self.segment.end),
        ] {
            row[at..at + 3].copy_from_slice(&v.to_array());
        }
        row
    }
}

/// 1/p of a light tree's pmf, rounded to f32 once: what K is multiplied by.
#[inline(always)]
pub fn inverse_pmf(pmf: f64) -> f32 {
    (1.0 / pmf) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_holds_k_and_the_segment_at_their_offsets() {
        let light = Light::new(
            Segment::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, 5.0, 6.0)),
            Vec3::new(7.0, 8.0, 9.0),
        );
        let row = light.row(light.k_over_probability(2.0));
        assert_eq!(row[ROW_K..ROW_K + 3], [14.0, 16.0, 18.0]);
        assert_eq!(row[ROW_BEGIN..ROW_BEGIN + 3], [1.0, 2.0, 3.0]);
        assert_eq!(row[ROW_END..ROW_END + 3], [4.0, 5.0, 6.0]);
        assert_eq!(light.k_over_pmf(0.25), Vec3::new(28.0, 32.0, 36.0));
    }
}
