//! Area sampling (technique 2): a point uniform in l on the *unclipped* segment.
//!
//! Density per radius. The point density is 1/ℓ in l. Along the line s(l) = l/√(l² + d²), so
//! ds/dl = d²/(l² + d²)^{3/2} = t³/d with t = √(1 − s²) = d/r, r = √(l² + d²). With
//! dΩ_R = (2/d) ds = (2t³/d²) dl the density per radius is
//!
//! ```text
//! p_R = (1/ℓ) / (2t³/d²) = d²/(2ℓ t³) = r²/(2ℓ sin α),   sin α = t.
//! ```
//!
//! Numerics: for a long segment seen nearly along its axis t is tiny and s ≈ ±1, where
//! √(1 − s²) loses everything in f32. t is therefore read as ĉ·ω (accurate for small t) and the
//! density is evaluated in f64, with t clamped to the smallest t of the support (t = d/r is
//! unimodal in l, so its minimum over an interval sits at an endpoint); `prepare` rejects
//! configurations whose largest density is not representable in f32.
//! Inverse: ξ = (l − l_begin)/ℓ.

use crate::geometry::{normal_is_valid, FrameArc, LineFrame, Segment};
use crate::sampler::{clamp_xi, LineSampler};
use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Area {
    frame: LineFrame,
    /// Support test in φ (see [`FrameArc`]): an s-test admits the whole rest of the line once
    /// s_end rounds to 1 (ℓ/d ≳ 3000), where this density is largest.
    arc: FrameArc,
    /// d² / (2ℓ), in f64 so that d² cannot overflow or underflow.
    scale: f64,
    /// Smallest t = d/r over the support; clamps t in `pdf` so that the density stays bounded.
    t_min: f64,
}

/// t = d/√(l² + d²) of the line point at parameter l, in f64.
#[inline]
fn t_at(l: f32, d: f32) -> f64 {
    // Squares of f32 values cannot overflow in f64: no need for the slower hypot.
    let (l, d) = (l as f64, d as f64);
    d / (l * l + d * d).sqrt()
}

impl Area {
    /// Uniform point on the whole segment (no horizon clipping). The normal is only validated,
    /// so that every technique rejects the same inputs.
    pub fn prepare(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        if !normal_is_valid(n) {
            return None;
        }
        Self::on_frame(LineFrame::new(segment, x)?)
    }

    /// Uniform point on an already prepared interval.
    pub fn on_frame(frame: LineFrame) -> Option<Self> {
        let length = frame.l_end as f64 - frame.l_begin as f64;
        let d = frame.d as f64;
        let scale = d * d / (2.0 * length);
        let t_min = t_at(frame.l_begin, frame.d).min(t_at(frame.l_end, frame.d));
        // Every density of the support, from d²/(2ℓ) (t = 1) to d²/(2ℓ t_min³), must be a
        // finite normal f32. Not so only at absurd scales (density ∝ the scene's length scale).
        let p_max = scale / (t_min * t_min * t_min);
        let representable = scale >= f32::MIN_POSITIVE as f64 && p_max <= f32::MAX as f64;
        representable.then_some(Self {
            frame,
            arc: FrameArc::of(&frame),
            scale,
            t_min,
        })
    }

    /// p_R at a given t (already known to lie in the support).
    #[inline]
    fn density_at_t(&self, t: f64) -> f32 {
        let t = t.clamp(self.t_min, 1.0);
        (self.scale / (t * t * t)).min(f32::MAX as f64) as f32
    }

    #[inline]
    fn l_of_xi(&self, xi: f32) -> f32 {
        // Weighted form: exact at both ends even when |l_begin| ≫ |l_end| (or the reverse).
        let (f, xi) = (&self.frame, clamp_xi(xi));
        ((1.0 - xi) * f.l_begin + xi * f.l_end).clamp(f.l_begin, f.l_end)
    }
}

impl LineSampler for Area {
    fn sample(&self, xi: f32) -> Vec3 {
        self.frame.direction_to(self.l_of_xi(xi))
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        if !self.arc.contains(&self.frame, dir) {
            return 0.0;
        }
        self.density_at_t(self.frame.c_hat.dot(dir) as f64)
    }

    fn support(&self) -> &LineFrame {
        &self.frame
    }

    /// Directions within the arc's rounding tolerance outside the support count as its endpoint.
    fn inverse(&self, dir: Vec3) -> Option<f32> {
        let f = &self.frame;
        self.arc.tau_in_support(f, dir)?;
        let s = f.s_of(dir);
        // l = d s / t with t = ĉ·ω (see the module comment); clamp t to the support's range.
        let t = (f.c_hat.dot(dir) as f64).clamp(self.t_min, 1.0);
        let l = (f.d as f64 * s as f64 / t).clamp(f.l_begin as f64, f.l_end as f64);
        let xi = (l - f.l_begin as f64) / (f.l_end as f64 - f.l_begin as f64);
        Some((xi as f32).clamp(0.0, 1.0))
    }

    /// The density from the sampled l itself (exact t = d/r), not from the rounded direction.
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        let l = self.l_of_xi(xi);
        (
            self.frame.direction_to(l),
            self.density_at_t(t_at(l, self.frame.d)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sanity() -> Area {
        let seg = Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0));
        Area::prepare(&seg, Vec3::ZERO, Vec3::Z).unwrap()
    }

    /// ∫ p_R dΩ_R = ∫ p_R (2/d) ds over the support, midpoint rule in φ = asin s (f64).
    fn normalisation(a: &Area) -> f64 {
        let f = a.support();
        let (pb, pe) = ((f.s_begin as f64).asin(), (f.s_end as f64).asin());
        let m = 200_000;
        let h = (pe - pb) / m as f64;
        let mut sum = 0.0;
        for i in 0..m {
            let phi = pb + (i as f64 + 0.5) * h;
            let w = f.direction(phi.sin() as f32);
            // ds = cos φ dφ
            sum += a.pdf(w) as f64 * 2.0 / f.d as f64 * phi.cos() * h;
        }
        sum
    }

    #[test]
    fn density_matches_the_closed_form() {
        let a = sanity();
        // Closest point (l = 0, t = 1): p_R = d²/(2ℓ) = 1/4.
        assert!((a.pdf(Vec3::Z) - 0.25).abs() < 1e-7);
        // Endpoint direction (−1,0,1)/√2: r² = 2, sin α = 1/√2, p_R = 2/(4/√2) = 1/√2.
        let w = Vec3::new(-1.0, 0.0, 1.0).normalize();
        assert!((a.pdf(w) - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6);
        assert_eq!(a.pdf(Vec3::new(-2.0, 0.0, 1.0).normalize()), 0.0);
    }

    #[test]
    fn normalised() {
        let a = sanity();
        assert!((normalisation(&a) - 1.0).abs() < 1e-5);
        let seg = Segment::new(Vec3::new(-0.3, 0.5, 0.4), Vec3::new(3.2, -0.2, 1.1));
        let b = Area::prepare(&seg, Vec3::new(0.1, 0.0, -0.2), Vec3::Z).unwrap();
        let z = normalisation(&b);
        assert!((z - 1.0).abs() < 1e-5, "{z}");
    }

    #[test]
    fn inverse_round_trip_and_support() {
        let seg = Segment::new(Vec3::new(-0.3, 0.5, 0.4), Vec3::new(3.2, -0.2, 1.1));
        let a = Area::prepare(&seg, Vec3::new(0.1, 0.0, -0.2), Vec3::Z).unwrap();
        for i in 0..=100 {
            let xi = i as f32 / 100.0;
            let (w, p) = a.sample_with_pdf(xi);
            assert!((w.length() - 1.0).abs() < 1e-6);
            let r = a.inverse(w);
            assert!(r.is_some_and(|r| (r - xi).abs() < 1e-5), "{xi} {r:?}");
            // pdf is strict at the support's ends, where the rebuilt s may be an ulp outside.
            let q = a.pdf(w);
            assert!(
                (p - q).abs() <= 1e-4 * p || (q == 0.0 && (i == 0 || i == 100)),
                "{p} {q}"
            );
            if i > 0 && i < 100 {
                assert!(a.support().contains_s(a.support().s_of(w)));
            }
        }
    }

    #[test]
    fn uniform_in_l_histogram() {
        // Equal-length pieces of the segment receive equal shares of the samples: bin by l.
        let seg = Segment::new(Vec3::new(-2.0, 0.0, 0.5), Vec3::new(3.0, 0.0, 0.5));
        let a = Area::prepare(&seg, Vec3::ZERO, Vec3::Z).unwrap();
        let f = *a.support();
        let mut rng = crate::rng::Pcg32::new(3, 1);
        let (bins, n) = (10usize, 100_000usize);
        let mut count = vec![0usize; bins];
        for _ in 0..n {
            let w = a.sample(rng.next_f32());
            let l = f.l_of_s(f.s_of(w));
            let k = ((l - f.l_begin) / (f.l_end - f.l_begin) * bins as f32) as usize;
            count[k.min(bins - 1)] += 1;
        }
        // Binomial sd = √(n p (1−p)) = 94.9; 5 sd per bin.
        for c in count {
            assert!((c as f64 - 10_000.0).abs() < 5.0 * 94.9, "{c}");
        }
    }

    /// ℓ/d = 1e4: s_end rounds to 1 in f32, but the density must still vanish beyond the end
    /// (a density left at its maximum on the rest of the line would integrate to 1.5).
    #[test]
    fn density_vanishes_beyond_the_end_where_s_end_rounds_to_one() {
        let seg = Segment::new(Vec3::new(0.0, 0.0, 1.0), Vec3::new(1e4, 0.0, 1.0));
        let a = Area::prepare(&seg, Vec3::ZERO, Vec3::Z).unwrap();
        let f = *a.support();
        assert_eq!(f.s_end, 1.0);
        let (d, le) = (f.d as f64, f.l_end as f64);
        for k in [1.1, 2.0, 100.0] {
            let phi = (k * le).atan2(d);
            let w = (phi.sin() * f.u.as_dvec3() + phi.cos() * f.c_hat.as_dvec3()).as_vec3();
            assert_eq!(a.pdf(w), 0.0, "l = {k} l_end");
        }
        let (w, p) = a.sample_with_pdf(1.0);
        assert!(p > 0.0 && (a.pdf(w) - p).abs() <= 1e-3 * p);
    }

    #[test]
    fn long_segment_seen_along_its_axis() {
        // t at the far end is ~1e-6: the density must stay finite and positive.
        let seg = Segment::new(Vec3::new(1e3, 1.0, 0.0), Vec3::new(1e6, 1.0, 0.0));
        let a = Area::prepare(&seg, Vec3::ZERO, Vec3::Y).unwrap();
        for i in 0..=20 {
            let (w, p) = a.sample_with_pdf(i as f32 / 20.0);
            let q = a.pdf(w);
            assert!(w.is_finite() && p.is_finite() && p > 0.0 && q.is_finite() && q >= 0.0);
            assert!(a.inverse(w).is_none_or(|xi| (0.0..=1.0).contains(&xi)));
        }
        // A unit segment at distance 1e38: p_R ≈ d²/(2ℓ) overflows f32, the contribution
        // (∝ 1/p_R) is far too small to matter; rejected instead of returning inf.
        let far = Segment::new(Vec3::new(0.0, 1e38, 0.0), Vec3::new(1.0, 1e38, 0.0));
        assert!(Area::prepare(&far, Vec3::ZERO, Vec3::Y).is_none());
    }
}
