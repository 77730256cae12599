//! Li et al. 2018 projected-solid-angle sampling (technique 7): Newton with bisection fallback.
//!
//! Density per radius: p_R(ω) = (n·ω)/Ω⊥_R on the horizon-clipped segment (the same density as
//! technique 8; `pdf`, `inverse` and `support` are shared with [`ProjectedSolidAngle`]).
//!
//! The unknown is l, the signed distance along u from the closest point c (r² = l² + d²). With
//! dΩ_R = 2d/r³ dl and n·ω = (n·c + l n_s)/r, the unnormalised CDF is
//!
//!   F(l) = ∫ (n·ω) dΩ_R = n_t'[l/(d r²) + atan(l/d)/d²] + n_s l²/(d r²),  n_t' = n·c = d n_t,
//!
//! (checked: dF/dl = 2d(n_t' + l n_s)/r⁴; the n_s term is −d n_s/r² + n_s/d, an antiderivative
//! up to a constant), and F(l) = C(s(l))/d with C of [`crate::geometry`]: the constants of
//! docs/measures.md are right. F is evaluated as the difference F(l) − F(l_b) in the cancellation-free
//! form of technique 8 (mathematically identical; the textbook form cancels for short or distant
//! segments and then cannot meet the stopping tolerance in f32).
//!
//! Root finding: start at the midpoint of the bracket [l_b, l_e], at most 20 iterations, stop when
//! |F(l) − F(l_b) − ξ(F(l_e) − F(l_b))| < 1e-5 (F(l_e) − F(l_b)); each iteration shrinks the
//! bracket with the sign of the residual and takes the Newton step l − G/F'(l) if it lands strictly
//! inside the bracket, the bracket midpoint otherwise.

use crate::geometry::{EndValues, LineFrame, Segment};
use crate::projected_solid_angle::{ProjectedSolidAngle, DEFAULT_ITERATIONS};
use crate::sampler::{clamp_xi, LineSampler};
use crate::trig::atan2_f64;
use glam::Vec3;

/// Iteration limit of Li et al.
pub const MAX_ITERATIONS: u32 = 20;
/// Stopping tolerance on the CDF residual, relative to the total.
pub const TOLERANCE: f32 = 1e-5;

#[derive(Clone, Copy, Debug)]
pub struct Li2018 {
    /// Shares the clipped frame, the exact density and the exact CDF.
    pub(crate) exact: ProjectedSolidAngle,
    /// n·c = d n_t and n_s = n·u, for F'(l) = 2d(n·c + l n_s)/r⁴, of the sampler's normal
    /// `exact.n` (scaled by a power of two, not unit: the slope is used with `exact.inv_psa`,
    /// which refers to the same normal).
    pub(crate) n_dot_c: f32,
    pub(crate) ns: f32,
    pub(crate) max_iterations: u32,
    /// The residual's CDF value and slope at the first iterate, the bracket's midpoint, which
    /// is the same for every ξ ([`Self::prepare`] computes them once; `None` in the lanes of
    /// [`crate::batch`], which evaluate every step). Equal bit for bit to what [`Self::step`]
    /// computes there, so the samples do not depend on whether they are present.
    pub(crate) at_start: Option<(f32, f32)>,
}

impl Li2018 {
    /// The exact sampler's support, density and CDF ([`ProjectedSolidAngle::prepare`]: the same
    /// inputs rejected, the normal scaled by a power of two, not normalised).
    pub fn prepare(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        ProjectedSolidAngle::prepare(segment, x, n).map(|exact| {
            let li = Self::on_exact(exact);
            let l = li.start_state().l;
            Self {
                at_start: Some((li.exact.cdf_of_l_with(l, atan2_f64), li.slope(l))),
                ..li
            }
        })
    }

    /// Around a prepared exact sampler: the slope's coefficients of the sampler's (scaled)
    /// normal, which its `inv_psa` refers to (the one construction of `prepare` and `lane`).
    #[inline(always)]
    pub(crate) fn on_exact(exact: ProjectedSolidAngle) -> Self {
        let frame = &exact.frame;
        let (ns, nt) = frame.normal_coefficients(exact.n);
        Self {
            n_dot_c: frame.d * nt,
            ns,
            exact,
            max_iterations: MAX_ITERATIONS,
            at_start: None,
        }
    }

    /// Change the iteration limit. Analysis and testing only: the density is not corrected, so a
    /// small limit (e.g. 2) samples a different density than `pdf` reports, which the
    /// chi-square suite must detect (its power control).
    pub fn with_max_iterations(self, k: u32) -> Self {
        Self {
            max_iterations: k,
            ..self
        }
    }

    /// l of the sample for ξ, and the number of iterations used.
    pub fn sample_l(&self, xi: f32) -> (f32, u32) {
        let xi = clamp_xi(xi);
        let mut state = self.start_state();
        for k in 0..self.max_iterations {
            state = match self.at_start {
                Some((cdf, slope)) if k == 0 => self.step_at(state, xi, cdf, slope),
                _ => self.step(state, xi, atan2_f64),
            };
            if state.done {
                return (state.l, k);
            }
        }
        (state.l, self.max_iterations)
    }

    /// The bracket [l_b, l_e] and its midpoint, not converged.
    #[inline(always)]
    pub(crate) fn start_state(&self) -> LiState {
        let f = self.exact.support();
        let (lo, hi) = (f.l_begin, f.l_end);
        LiState {
            l: 0.5 * (lo + hi),
            lo,
            hi,
            done: false,
        }
    }

    /// One iteration of the root finding (nothing once converged), without branches: the
    /// residual test, the bracket update and the Newton step, or the bisection where the Newton
    /// step leaves the bracket. `atan2` as in [`ProjectedSolidAngle::cdf_of_l_with`].
    #[inline(always)]
    pub(crate) fn step(&self, s: LiState, xi: f32, atan2: impl Fn(f64, f64) -> f64) -> LiState {
        let cdf = self.exact.cdf_of_l_with(s.l, atan2);
        self.step_at(s, xi, cdf, self.slope(s.l))
    }

    /// F'(l)/total = 2d(n·c + l n_s)/(r⁴ |n| Ω⊥_R) for the sampler's scaled (not unit) n:
    /// total = F(l_e) − F(l_b) = |n|·Ω⊥_R, and `inv_psa` = 1/(|n| Ω⊥_R) of the same n.
    #[inline(always)]
    fn slope(&self, l: f32) -> f32 {
        let d = self.exact.support().d;
        let r2 = l * l + d * d;
        2.0 * d * (self.n_dot_c + l * self.ns) / (r2 * r2) * self.exact.inv_psa
    }

    /// [`Self::step`] with the CDF (in units of the total) and its slope at `s.l` given.
    #[inline(always)]
    fn step_at(&self, s: LiState, xi: f32, cdf: f32, slope: f32) -> LiState {
        let l = s.l;
        let g = cdf - xi;
        let converged = g.abs() < TOLERANCE;
        let lo = if g < 0.0 { l } else { s.lo };
        let hi = if g < 0.0 { s.hi } else { l };
        let newton = l - g / slope;
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if s.done || converged {
            LiState { done: true, ..s }
        } else {
            LiState {
                l: next,
                lo,
                hi,
                done: false,
            }
        }
    }

    /// Prepared lane without branches (for [`crate::batch`]): the sampler and whether
    /// [`Self::prepare`] returns it.
    #[inline(always)]
    pub(crate) fn lane(frame: LineFrame, ends: EndValues, n: Vec3) -> (Self, bool) {
        let (exact, ok) = ProjectedSolidAngle::lane(
            frame,
            ends,
            n,
            DEFAULT_ITERATIONS,
            crate::trig::atan2_f64_select,
        );
        (Self::on_exact(exact), ok)
    }

    /// Direction and density of the sample at line parameter l (the end of `sample_with_pdf`,
    /// scalar and in the lanes of [`crate::batch`]).
    #[inline(always)]
    pub(crate) fn finish(&self, l: f32) -> (Vec3, f32) {
        let f = self.exact.support();
        let dir = f.direction_to(l.max(f.l_begin).min(f.l_end));
        (dir, self.exact.density_in_support(dir))
    }
}

/// Root-finding state of one sample: the iterate, the bracket, and whether it has converged.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct LiState {
    pub l: f32,
    pub lo: f32,
    pub hi: f32,
    pub done: bool,
}

impl LineSampler for Li2018 {
    fn sample(&self, xi: f32) -> Vec3 {
        self.finish(self.sample_l(xi).0).0
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        self.exact.pdf(dir)
    }

    fn support(&self) -> &LineFrame {
        self.exact.support()
    }

    fn inverse(&self, dir: Vec3) -> Option<f32> {
        self.exact.inverse(dir)
    }

    /// The sample lies in the support by construction, so its density is (n·ω)/Ω⊥_R without
    /// the support test of `pdf` (as in technique 8; keeps the timing comparison fair).
    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        self.finish(self.sample_l(xi).0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn configs() -> Vec<(Segment, Vec3, Vec3)> {
        vec![
            (
                Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0)),
                Vec3::ZERO,
                Vec3::Z,
            ),
            (
                Segment::new(Vec3::new(-0.3, 0.5, -0.4), Vec3::new(1.2, -0.2, 1.1)),
                Vec3::ZERO,
                Vec3::new(0.2, 0.1, 1.0),
            ),
            (
                Segment::new(Vec3::new(-5.0, 0.0, 0.05), Vec3::new(5.0, 0.0, 0.05)),
                Vec3::ZERO,
                Vec3::new(0.3, 0.0, 1.0),
            ),
            (
                Segment::new(Vec3::new(-1.0, 1.0, 0.02), Vec3::new(1.0, 1.0, 0.02)),
                Vec3::ZERO,
                Vec3::Z,
            ),
        ]
    }

    /// `prepare` is homogeneous of degree 0 in the normal, like the exact sampler it wraps: n·s
    /// gives bit for bit the samples of n for a power of two s, and for other s samples whose
    /// CDF values (the base's exact CDF) differ by at most twice the stopping tolerance (each
    /// is within it of ξ) plus 1e-6.
    #[test]
    fn prepare_is_homogeneous_in_the_normal() {
        for (seg, x, n) in configs() {
            let base = Li2018::prepare(&seg, x, n).unwrap();
            for s in [2f32.powi(-60), 0.5, 1024.0, 0.3, 3.7, 1e30] {
                let p = Li2018::prepare(&seg, x, n * s).unwrap();
                let exact = s.to_bits() & 0x007f_ffff == 0;
                for i in 0..=64 {
                    let xi = (i as f32 + 0.01) / 64.02;
                    let ((l, _), (l0, _)) = (p.sample_l(xi), base.sample_l(xi));
                    if exact {
                        assert_eq!(l.to_bits(), l0.to_bits(), "s = {s:e}, ξ = {xi}");
                        let (d, d0) = (p.sample(xi), base.sample(xi));
                        assert_eq!(
                            d.to_array().map(f32::to_bits),
                            d0.to_array().map(f32::to_bits)
                        );
                    } else {
                        let (u, u0) = (base.exact.cdf_of_l(l), base.exact.cdf_of_l(l0));
                        assert!(
                            (u - u0).abs() <= 2.0 * TOLERANCE + 1e-6,
                            "s = {s:e}, ξ = {xi}: CDF {u} vs {u0}"
                        );
                    }
                }
            }
        }
    }

    /// The first step's CDF value and slope computed once by `prepare` give bit for bit the
    /// samples and iteration counts of evaluating them in the step.
    #[test]
    fn start_values_change_no_sample() {
        for (seg, x, n) in configs() {
            let li = Li2018::prepare(&seg, x, n).unwrap();
            assert!(li.at_start.is_some());
            let evaluated = Li2018 {
                at_start: None,
                ..li
            };
            for i in 0..=4096 {
                let xi = i as f32 / 4096.0;
                let ((l, k), (l0, k0)) = (li.sample_l(xi), evaluated.sample_l(xi));
                assert_eq!((l.to_bits(), k), (l0.to_bits(), k0), "{seg:?} ξ = {xi}");
            }
        }
    }

    /// The closed form F(l) of the paper, in f64, against midpoint quadrature of
    /// ∫ (n·ω) dΩ_R = ∫ (n·c + l n_s)/r · 2d/r³ dl.
    #[test]
    fn cdf_formula_matches_quadrature() {
        let (d, nc, ns) = (0.7f64, 0.4f64, -0.3f64); // n·c = d n_t
        let big_f = |l: f64| {
            let r2 = l * l + d * d;
            nc * (l / (d * r2) + (l / d).atan() / (d * d)) + ns * l * l / (d * r2)
        };
        let (a, b) = (-0.5f64, 2.0f64);
        let m = 100_000;
        let h = (b - a) / m as f64;
        let mut sum = 0.0;
        for i in 0..m {
            let l = a + (i as f64 + 0.5) * h;
            let r = (l * l + d * d).sqrt();
            sum += (nc + l * ns) / r * 2.0 * d / (r * r * r);
        }
        sum *= h;
        assert!((sum - (big_f(b) - big_f(a))).abs() < 1e-8, "{sum}");
    }

    #[test]
    fn agrees_with_peters_and_the_exact_inverse() {
        for (seg, x, n) in configs() {
            let li = Li2018::prepare(&seg, x, n).unwrap();
            let peters = ProjectedSolidAngle::prepare(&seg, x, n).unwrap();
            let mut max_k = 0;
            for i in 0..=2000 {
                let xi = i as f32 / 2000.0;
                let (_, k) = li.sample_l(xi);
                assert!(k < MAX_ITERATIONS, "{seg:?} ξ={xi}: no convergence");
                max_k = max_k.max(k);
                let dir = li.sample(xi);
                assert!(dir.is_finite() && (dir.length() - 1.0).abs() < 1e-5);
                let back = li.inverse(dir).expect("Li sample outside the support");
                assert!((back - xi).abs() < 3e-5, "{seg:?} ξ={xi}: inverse {back}");
                let pd = peters.sample(xi);
                let back_p = peters.inverse(pd).unwrap();
                assert!(
                    (back - back_p).abs() < 4e-5,
                    "{seg:?} ξ={xi}: {back} vs {back_p}"
                );
                assert!(li.pdf(dir) >= 0.0 && li.pdf(dir).is_finite());
                let (dir2, pdf2) = li.sample_with_pdf(xi);
                assert_eq!(dir2, dir);
                assert!(
                    (pdf2 - li.pdf(dir)).abs() <= 1e-6 * pdf2,
                    "{pdf2} vs {}",
                    li.pdf(dir)
                );
            }
            eprintln!("{seg:?}: at most {max_k} iterations");
        }
    }

    #[test]
    fn two_iterations_are_visibly_wrong() {
        let (seg, x, n) = configs()[2];
        let li = Li2018::prepare(&seg, x, n).unwrap().with_max_iterations(2);
        let worst = (0..=100)
            .map(|i| {
                let xi = i as f32 / 100.0;
                (li.inverse(li.sample(xi)).unwrap() - xi).abs()
            })
            .fold(0.0f32, f32::max);
        assert!(worst > 0.05, "{worst}");
    }

    #[test]
    fn density_is_normalised_and_edges() {
        for (seg, x, n) in configs() {
            let li = Li2018::prepare(&seg, x, n).unwrap();
            let f = *li.support();
            // ∫ pdf dΩ_R = ∫ pdf (2d/r³) dl, midpoint in l.
            let m = 200_000;
            let h = (f.l_end - f.l_begin) as f64 / m as f64;
            let mut sum = 0.0f64;
            for i in 0..m {
                let l = f.l_begin as f64 + (i as f64 + 0.5) * h;
                let r = (l * l + (f.d as f64).powi(2)).sqrt();
                let dir = f.point(l as f32).normalize();
                sum += li.pdf(dir) as f64 * 2.0 * f.d as f64 / (r * r * r);
            }
            assert!((sum * h - 1.0).abs() < 1e-3, "{seg:?}: {}", sum * h);
            // ξ = 0, 1 give the endpoints (to the tolerance), iteration count within the limit.
            for &xi in &[0.0f32, 1.0] {
                let (l, k) = li.sample_l(xi);
                assert!(k <= MAX_ITERATIONS && l >= f.l_begin && l <= f.l_end);
                assert!((li.inverse(li.sample(xi)).unwrap() - xi).abs() < 2e-5);
            }
        }
        let seg = configs()[0].0;
        assert!(Li2018::prepare(&seg, Vec3::ZERO, -Vec3::Z).is_none());
        assert!(Li2018::prepare(&seg, Vec3::new(0.5, 0.0, 1.0), Vec3::Z).is_none());
    }
}
