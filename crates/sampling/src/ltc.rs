//! LTC line sampling: sample a linearly transformed cosine restricted to a line (docs/measures.md "LTC").
//!
//! A (3×3, invertible) maps shading space (columns of the shading frame: x̂, ŷ, n) to cosine space.
//! Directions: ω_o = Aω/|Aω|. The line is clipped at the horizon of n (original space), then at
//! the half-space (Aω)_z ≥ 0 (which is the clip at z = 0 in cosine space, done here in the
//! original frame so that [`LineSampler::support`] is exact), transformed (endpoints relative to
//! x, in shading coordinates, times A) and sampled with technique 8 with normal (0, 0, 1).
//!
//! Density per radius of the ORIGINAL line (derivation, checked by quadrature in the tests):
//! technique 8 has density p_o(ω_o) = z_o/Ω⊥_o per radius R_o of the transformed tube. The tube of
//! radius R maps onto a tube whose half-width across the plane through x and the line is
//! R_o = R/κ, κ = |A⁻ᵀm|/|m|, m = u × (begin − x) (the normal of that plane maps to A⁻ᵀm). Solid
//! angle maps with the Jacobian J = |det A|/|Aω|³, so R_o dΩ_{R,o} = J R dΩ_R and
//!
//!   p_s(ω) = p_o(ω_o) · κ · J = κ/Ω⊥_o · max(0, (Aω)_z) · |det A| / |Aω|⁴   (ω in shading coords),
//!
//! on the support, 0 elsewhere.
// `!(x > 0.0)` is deliberate throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::geometry::{antiderivative_at, unit_normal, FrameArc, LineFrame, Segment};
use crate::projected_solid_angle::{ProjectedSolidAngle, PsaCore, DEFAULT_ITERATIONS};
use crate::sampler::{clamp_xi, LineSampler};
use glam::{DVec3, Mat3, Vec3};

/// Smallest ξ the sampler uses: half the spacing 2⁻²⁴ of the renderer's uniforms, so that the
/// lattice point ξ = 0 is sampled at its cell's midpoint (see [`LineSampler::sample`] of
/// [`LtcLine`]).
pub const XI_LATTICE_START: f32 = 1.0 / 33_554_432.0;
/// Largest ξ the sampler uses: the largest f32 below 1 (1 − 2⁻²⁴, the last lattice point).
pub const XI_LATTICE_END: f32 = 1.0 - 1.0 / 16_777_216.0;

/// Largest accepted condition-like ratio ‖A‖³/|det A| (beyond it A counts as singular in f32).
const MAX_ILL_CONDITION: f32 = 1e7;

#[derive(Clone, Copy, Debug)]
pub struct LtcLine {
    /// The original line (world space) restricted to n·ω ≥ 0 and (Aω)_z ≥ 0: where pdf > 0.
    support: LineFrame,
    arc: FrameArc,
    /// World → shading coordinates (transpose of the shading frame).
    to_shading: Mat3,
    a: Mat3,
    /// Cosine space → world: shading_frame · A⁻¹.
    to_world: Mat3,
    /// Technique 8 on the transformed segment, normal (0, 0, 1), shading point at the origin.
    transformed: ProjectedSolidAngle,
    kappa: f32,
    /// κ |det A| / Ω⊥_o.
    scale: f32,
}

impl LtcLine {
    /// `shading_frame` has columns (x̂, ŷ, n); a world direction w has shading coordinates
    /// `shading_frame.transpose() * w`. `None` when the light cannot contribute (clipped away in
    /// either space, degenerate geometry) or A is singular or not finite.
    pub fn prepare(segment: &Segment, x: Vec3, shading_frame: Mat3, a: Mat3) -> Option<Self> {
        Self::on_frame(segment, x, &LineFrame::new(segment, x)?, shading_frame, a)
    }

    /// [`Self::prepare`] with `frame` = `LineFrame::new(segment, x)` given (e.g. from
    /// [`ProjectedSolidAngle::prepare_with_whole_frame`]).
    pub fn on_frame(
        segment: &Segment,
        x: Vec3,
        frame: &LineFrame,
        shading_frame: Mat3,
        a: Mat3,
    ) -> Option<Self> {
        debug_assert_eq!(
            Some(*frame),
            LineFrame::new(segment, x),
            "not the line's frame"
        );
        if !(a.is_finite() && shading_frame.is_finite()) {
            return None;
        }
        let det = a.determinant();
        let norm = a.to_cols_array().iter().fold(0.0f32, |m, v| m.max(v.abs()));
        if !(det.abs() * MAX_ILL_CONDITION > norm * norm * norm && det.is_finite()) {
            return None;
        }
        let a_inv = a.inverse();
        if !a_inv.is_finite() {
            return None;
        }
        let n = unit_normal(shading_frame.z_axis)?;
        let to_shading = shading_frame.transpose();
        // (A Fᵀ p)_z = (F · row₂(A)) · p: the cosine-space horizon as a plane in world space.
        let lobe_normal = shading_frame * a.row(2);
        let support = frame.clip_to_horizon(n)?.clip_to_horizon(lobe_normal)?;

        let to_cosine = |p: Vec3| a * (to_shading * p);
        let seg_o = Segment::new(
            to_cosine(support.point(support.l_begin)),
            to_cosine(support.point(support.l_end)),
        );
        let transformed = ProjectedSolidAngle::prepare_with_iterations(
            &seg_o,
            Vec3::ZERO,
            Vec3::Z,
            DEFAULT_ITERATIONS,
        )?;

        let u_sh = to_shading * frame.u;
        let b_sh = to_shading * (segment.begin - x);
        let m = u_sh.cross(b_sh);
        let kappa = (a_inv.transpose() * m).length() / m.length();
        // Ω⊥_o in f64 from the support's exact endpoints (not from `transformed`, whose f32
        // endpoints are rounded by ε|p|: for a short segment a relative error ε|p|/ℓ of its
        // length, 2.8e-5 of the normalisation on short-oblique).
        let (a64, to_shading64) = (a.as_dmat3(), to_shading.as_dmat3());
        let endpoint = |l: f32| {
            let p = support.d as f64 * support.c_hat.as_dvec3() + l as f64 * support.u.as_dvec3();
            a64 * (to_shading64 * p)
        };
        let psa_o = projected_solid_angle_up(endpoint(support.l_begin), endpoint(support.l_end))?;
        let scale = (kappa as f64 * a64.determinant().abs() / psa_o) as f32;
        (kappa.is_finite() && kappa > 0.0 && scale.is_finite() && scale > 0.0).then(|| Self {
            support,
            arc: FrameArc::of(&support),
            to_shading,
            a,
            to_world: shading_frame * a_inv,
            transformed,
            kappa,
            scale,
        })
    }

    /// κ = |A⁻ᵀm|/|m|: the transformed tube has radius R/κ.
    pub fn kappa(&self) -> f32 {
        self.kappa
    }

    pub fn a(&self) -> Mat3 {
        self.a
    }

    /// Ω⊥ per radius of the transformed (and clipped) segment in cosine space.
    pub fn transformed_projected_solid_angle(&self) -> f32 {
        self.transformed.projected_solid_angle()
    }

    /// p_s(ω) = κ/Ω⊥_o · max(0, (Aω)_z) · |det A| / |Aω|⁴ without the support test: the
    /// density of any direction toward the line's part above the horizon of n (where the
    /// diffuse technique's samples lie), 0 where the lobe is below its own horizon
    /// ((Aω)_z ≤ 0), which is exactly where this sampler's support ends within that part. The
    /// MIS cross density of a diffuse sample; [`LineSampler::pdf`] is this after the test.
    #[inline]
    pub fn density_on_clipped_line(&self, dir: Vec3) -> f32 {
        let aw = self.a * (self.to_shading * dir);
        let len2 = aw.length_squared();
        if !(len2 > 0.0) {
            return 0.0;
        }
        let p = self.scale * aw.z.max(0.0) / (len2 * len2);
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }
}

/// Ω⊥ per radius, in f64, of the segment from `b` to `e` (relative to the shading point) for the
/// normal (0, 0, 1): [C(φ_e) − C(φ_b)]/d with C(φ) = n_s sin²φ + n_t (sin φ cos φ + φ) and
/// φ = atan2(l, d). The segment is above the horizon (clipped in the original space); a rounding
/// sliver below it contributes O(ε²). `None` if degenerate or not positive.
fn projected_solid_angle_up(b: DVec3, e: DVec3) -> Option<f64> {
    let axis = e - b;
    let length = axis.length();
    let u = axis / length;
    let sigma = u.dot(b);
    let c = b - sigma * u;
    let d = c.length();
    let (ns, nt) = (u.z, c.z / d);
    let psa =
        (antiderivative_at(ns, nt, sigma + length, d) - antiderivative_at(ns, nt, sigma, d)) / d;
    (psa > 0.0 && psa.is_finite()).then_some(psa)
}

impl LtcLine {
    /// τ = φ − φ_b on the original support of a world direction toward the line, up to rounding
    /// (in f64; any positive length; the component off the plane of the line dropped), to be
    /// clamped by [`FrameArc::direction`].
    fn tau_of_direction(&self, w: DVec3) -> f64 {
        let s = self.support.u.as_dvec3().dot(w);
        let t = self.support.c_hat.as_dvec3().dot(w).max(0.0);
        (s * self.arc.c_b - t * self.arc.s_b).atan2(t * self.arc.c_b + s * self.arc.s_b)
    }

    /// τ of the sample for ξ in technique 8's guard band: the exact cosine-space inverse CDF
    /// (f64), mapped back in f64 (see [`LineSampler::sample`]). Out of line: 2e-5 of the
    /// samples take this path, and the hot path keeps its inlining.
    #[cold]
    #[inline(never)]
    fn tail_tau(&self, xi: f32) -> f64 {
        let w = self.to_world.as_dmat3() * self.transformed.sample_converged(xi);
        self.tau_of_direction(w)
    }
}

impl LineSampler for LtcLine {
    /// Technique 8 in cosine space, mapped back by A⁻¹ and snapped onto the line. For ξ in
    /// technique 8's guard band (within [`XI_GUARD`](crate::projected_solid_angle::XI_GUARD)
    /// of 0 or 1: 2e-5 of the samples) the cosine-space sample is the exact inverse CDF, solved
    /// in f64 ([`ProjectedSolidAngle::sample_converged`]), not the guard's solid-angle start
    /// value: for a sharp lobe A⁻¹ spreads the outermost 1e-5 of the cosine-space mass over a
    /// wide part of the line (α = 0.05, θ_o = 80°: 15 % of its φ-range at each end, where p_s
    /// falls to ~1e-6 of its peak), and the start value had put those samples at the very ends
    /// (docs/sampler-suite.md, "LTC tails").
    ///
    /// ξ is kept within [2⁻²⁵, 1 − 2⁻²⁴] ([`XI_LATTICE_START`], [`XI_LATTICE_END`]): where the
    /// support ends at the lobe's own horizon ((Aω)_z = 0, a line crossing the LTC support's
    /// edge inside the hemisphere) the density vanishes at that end while f·cos does not, and
    /// the renderer's uniforms (k·2⁻²⁴) hit ξ = 0 with probability 2⁻²⁴: a sample on the end
    /// itself has a density that is f32 rounding noise (~1e-9 of its scale), so one such
    /// sample outweighed 10⁵ ordinary ones. Changes the map on a set of measure 3e-8 only.
    fn sample(&self, xi: f32) -> Vec3 {
        let xi = clamp_xi(xi).clamp(XI_LATTICE_START, XI_LATTICE_END);
        let tau = if PsaCore::<f32>::in_guard(xi) {
            self.tail_tau(xi)
        } else {
            let w = (self.to_world * self.transformed.sample(xi)).normalize_or_zero();
            // Snap onto the original line's support (removes rounding off the line / past its
            // ends).
            self.arc
                .tau_in_support(&self.support, w)
                .unwrap_or_else(|| self.tau_of_direction(w.as_dvec3()))
        };
        self.arc.direction(&self.support, tau)
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        if self.arc.tau_in_support(&self.support, dir).is_none() {
            return 0.0;
        }
        self.density_on_clipped_line(dir)
    }

    fn support(&self) -> &LineFrame {
        &self.support
    }

    fn inverse(&self, dir: Vec3) -> Option<f32> {
        self.arc.tau_in_support(&self.support, dir)?;
        let w_o = (self.a * (self.to_shading * dir)).normalize_or_zero();
        // The transformed support may lose a rounding sliver at its ends: clamp there.
        self.transformed.inverse(w_o).or_else(|| {
            let f = self.transformed.support();
            let s = f.u.dot(w_o);
            Some(if s <= f.s_begin { 0.0 } else { 1.0 })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shading_frame(n: Vec3, v: Vec3) -> Mat3 {
        let n = n.normalize();
        let x = (v - n.dot(v) * n).normalize();
        Mat3::from_cols(x, n.cross(x), n)
    }

    /// Isotropic LTC form M = [[a,0,b],[0,c,0],[d,0,1]] (rows), and some general ones.
    fn matrices() -> Vec<Mat3> {
        let iso = |a: f32, b: f32, c: f32, d: f32| {
            Mat3::from_cols(
                Vec3::new(a, 0.0, d),
                Vec3::new(0.0, c, 0.0),
                Vec3::new(b, 0.0, 1.0),
            )
        };
        vec![
            Mat3::IDENTITY,
            iso(1.0, 0.0, 1.0, 0.0),
            iso(0.3, 0.1, 0.35, -0.05),
            iso(0.05, 0.02, 0.06, 0.0),  // sharp lobe: κ ≫ 1
            iso(0.02, -0.01, 0.5, 0.03), // anisotropic and sharp
            Mat3::from_cols(
                Vec3::new(0.4, 0.1, -0.2),
                Vec3::new(-0.05, 0.2, 0.1),
                Vec3::new(0.3, 0.05, 1.0),
            ),
        ]
    }

    fn scenes() -> Vec<(Segment, Vec3, Mat3)> {
        vec![
            (
                Segment::new(Vec3::new(-1.0, 0.3, 1.0), Vec3::new(1.0, 0.2, 1.2)),
                Vec3::ZERO,
                shading_frame(Vec3::Z, Vec3::new(0.5, 0.0, 1.0)),
            ),
            (
                Segment::new(Vec3::new(-0.3, 0.5, -0.4), Vec3::new(1.2, -0.2, 1.1)),
                Vec3::new(0.05, 0.0, 0.0),
                shading_frame(Vec3::new(0.2, 0.1, 1.0), Vec3::new(-0.3, 0.2, 1.0)),
            ),
            (
                Segment::new(Vec3::new(-3.0, 0.5, 0.4), Vec3::new(3.0, 0.5, 0.4)),
                Vec3::ZERO,
                shading_frame(Vec3::Z, Vec3::new(0.0, 1.0, 0.3)),
            ),
        ]
    }

    /// ∫_0^{τ_max} pdf dΩ_R (dΩ_R = (2/d) cos φ dφ) by the midpoint rule in τ, in f64.
    fn integrate(ltc: &LtcLine, tau_max: f64, m: usize) -> f64 {
        integrate_range(ltc, 0.0, tau_max, m)
    }

    /// ∫_{τ_0}^{τ_1} pdf dΩ_R by the midpoint rule in τ, in f64.
    fn integrate_range(ltc: &LtcLine, tau_0: f64, tau_1: f64, m: usize) -> f64 {
        let f = ltc.support();
        let (s_b, c_b) = (ltc.arc.s_b, ltc.arc.c_b);
        let h = (tau_1 - tau_0) / m as f64;
        let mut sum = 0.0;
        for i in 0..m {
            let tau = tau_0 + (i as f64 + 0.5) * h;
            let (st, ct) = tau.sin_cos();
            let (s, t) = (s_b * ct + c_b * st, c_b * ct - s_b * st);
            let dir = (s as f32) * f.u + (t as f32) * f.c_hat;
            sum += ltc.pdf(dir) as f64 * 2.0 / f.d as f64 * t;
        }
        sum * h
    }

    #[test]
    fn density_is_normalised_for_many_matrices() {
        let mut max_kappa = 0.0f32;
        let mut tested = 0;
        for (seg, x, frame) in scenes() {
            for a in matrices() {
                let Some(ltc) = LtcLine::prepare(&seg, x, frame, a) else {
                    continue;
                };
                tested += 1;
                max_kappa = max_kappa.max(ltc.kappa());
                let total = integrate(&ltc, ltc.arc.width, 400_000);
                assert!(
                    (total - 1.0).abs() < 2e-3,
                    "A = {a:?}, κ = {}: ∫pdf = {total}",
                    ltc.kappa()
                );
            }
        }
        assert!(tested >= 15, "{tested}");
        assert!(
            max_kappa > 10.0,
            "no strongly anisotropic case tested: {max_kappa}"
        );
    }

    /// The sampler follows its density: the CDF of the pdf (quadrature) at a sample equals ξ.
    #[test]
    fn samples_follow_the_density() {
        for (seg, x, frame) in scenes() {
            for a in matrices() {
                let Some(ltc) = LtcLine::prepare(&seg, x, frame, a) else {
                    continue;
                };
                let arc = ltc.arc;
                for &xi in &[0.0f32, 0.05, 0.3, 0.5, 0.77, 0.999, 1.0] {
                    let dir = ltc.sample(xi);
                    assert!((dir.length() - 1.0).abs() < 1e-5);
                    let tau = arc
                        .tau_in_support(ltc.support(), dir)
                        .expect("outside support");
                    let cdf = integrate(&ltc, tau.max(0.0), 100_000);
                    assert!(
                        (cdf - xi as f64).abs() < 2e-3,
                        "A = {a:?} ξ = {xi}: CDF {cdf}"
                    );
                    let back = ltc.inverse(dir).unwrap();
                    assert!((back - xi).abs() < 1e-3, "ξ = {xi}: inverse {back}");
                    if xi > 0.0 && xi < 1.0 {
                        assert!(ltc.pdf(dir) > 0.0);
                    }
                }
            }
        }
    }

    /// The tails (ξ within technique 8's guard band of 0 or 1) follow the density too, relative
    /// to their own mass: the fitted GGX LTC of α = 0.05 at θ_o = 80° (A as the table gives it,
    /// `linlight_brdf::ltc`) and a line across the mirror direction, where A⁻¹ spreads the
    /// outermost 1e-5 of the cosine-space mass over 15 % of the line's φ-range at each end.
    /// With the guard's solid-angle start value the tail mass below the sample for ξ = 1e-6
    /// would be 3.4e-8 (the samples would sit at the ends; the chi-square suite sees the
    /// excess).
    #[test]
    fn tails_follow_the_density() {
        let a = Mat3::from_cols_array(&[
            0.03292253,
            0.0,
            -0.017205663,
            0.0,
            1.0,
            0.0,
            0.18035631,
            0.0,
            0.0042067487,
        ]);
        let mirror = Vec3::new(-1.4772116, 0.0, 0.26047233);
        let seg = Segment::new(mirror - Vec3::Y, mirror + Vec3::Y);
        let frame = shading_frame(Vec3::Z, Vec3::new(0.9848077, 0.0, 0.17364822));
        let ltc = LtcLine::prepare(&seg, Vec3::ZERO, frame, a).unwrap();
        let arc = ltc.arc;
        for xi in [1e-7f32, 1e-6, 5e-6, 9.9e-6, 2e-5, 1e-4] {
            for (upper, xi) in [(false, xi), (true, 1.0 - xi)] {
                let tau = arc.tau_in_support(ltc.support(), ltc.sample(xi)).unwrap();
                // The mass on the side of the sample toward its end: ξ resp. 1 − ξ.
                let (mass, tail) = if upper {
                    let m = integrate_range(&ltc, tau, arc.width, 100_000);
                    (m, 1.0 - xi as f64)
                } else {
                    (integrate(&ltc, tau, 100_000), xi as f64)
                };
                // Relative to the tail (≤ 2.5e-4 measured in the guard band), plus 3e-7 absolute:
                // the backward error of the f32 two-step solve outside the band near ξ = 1,
                // where G = ΔC − ξ·total cancels (1.1e-7 measured at 1 − ξ = 1e-4).
                let err = (mass - tail).abs();
                assert!(
                    err < 1e-3 * tail + 3e-7,
                    "ξ = {xi}: tail mass {mass:e} where {tail:e} is expected"
                );
            }
        }
    }

    /// The uniforms of the renderer lie on the lattice k·2⁻²⁴, so ξ = 0 occurs with probability
    /// 2⁻²⁴. Where the support begins at the lobe's own horizon ((Aω)_z = 0, a line crossing the
    /// edge of the LTC support inside the hemisphere), the density vanishes there while f·cos
    /// does not: the sample for ξ = 0 must not sit on that end, where f32 rounding leaves a
    /// density of ~1e-9 of its scale and K·f·cos/p a single sample worth 10⁵ pixel means
    /// (measured on glossy-principled). Near the edge p ∝ z_o ∝ √ξ, so 1/p at the first
    /// lattice point may exceed that at the second by √2 (the half-cell start 2⁻²⁵), not more;
    /// the same at ξ = 1 with the segment reversed.
    #[test]
    fn lattice_ends_stay_off_the_support_edge() {
        let a = Mat3::from_cols(
            Vec3::new(0.3, 0.0, -0.5),
            Vec3::new(0.0, 0.35, 0.0),
            Vec3::new(0.1, 0.0, 1.0),
        );
        let frame = Mat3::IDENTITY;
        // (Aω)_z = z − 0.5x: below it at the first end, above at the second (both above n).
        let (p, q) = (Vec3::new(2.0, 0.3, 0.2), Vec3::new(-1.0, 0.3, 1.0));
        let z_o = |ltc: &LtcLine, w: Vec3| {
            let aw = ltc.a() * w;
            aw.z / aw.length()
        };
        let step = 1.0 / 16_777_216.0f32;
        for (seg, xi_end, xi_next) in [
            (Segment::new(p, q), 0.0f32, step),
            (Segment::new(q, p), 1.0, 1.0 - 2.0 * step),
        ] {
            let ltc = LtcLine::prepare(&seg, Vec3::ZERO, frame, a).unwrap();
            let (w_end, p_end) = ltc.sample_with_pdf(xi_end);
            let (w_next, p_next) = ltc.sample_with_pdf(xi_next);
            assert!(
                p_end >= 0.5 * p_next && p_end.is_finite(),
                "ξ = {xi_end}: p = {p_end:e} (z_o {:e}) vs p = {p_next:e} at the next lattice \
                 point (z_o {:e})",
                z_o(&ltc, w_end),
                z_o(&ltc, w_next)
            );
        }
    }

    #[test]
    fn identity_is_technique_8() {
        let (seg, x, frame) = scenes()[1];
        let ltc = LtcLine::prepare(&seg, x, frame, Mat3::IDENTITY).unwrap();
        let psa = ProjectedSolidAngle::prepare(&seg, x, frame.z_axis).unwrap();
        assert!((ltc.kappa() - 1.0).abs() < 1e-5);
        for i in 1..20 {
            let xi = i as f32 / 20.0;
            let d = ltc.sample(xi);
            assert!((d - psa.sample(xi)).length() < 1e-4, "{xi}");
            assert!((ltc.pdf(d) - psa.pdf(d)).abs() < 1e-3 * psa.pdf(d), "{xi}");
        }
    }

    #[test]
    fn degenerate_inputs() {
        let (seg, x, frame) = scenes()[0];
        assert!(LtcLine::prepare(&seg, x, frame, Mat3::ZERO).is_none());
        let singular = Mat3::from_cols(Vec3::X, Vec3::X, Vec3::Z);
        assert!(LtcLine::prepare(&seg, x, frame, singular).is_none());
        let mut nan = Mat3::IDENTITY;
        nan.x_axis.x = f32::NAN;
        assert!(LtcLine::prepare(&seg, x, frame, nan).is_none());
        // A lobe pointing below the horizon: (Aω)_z < 0 for every ω above it.
        let flip = Mat3::from_diagonal(Vec3::new(1.0, 1.0, -1.0));
        assert!(LtcLine::prepare(&seg, x, frame, flip).is_none());
        // Light below the horizon.
        let below = Segment::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0));
        assert!(LtcLine::prepare(&below, x, frame, Mat3::IDENTITY).is_none());
    }
}
