//! Hart et al. 2020 cosine warps in clipped-solid-angle primary space (techniques 5 and 6).
//!
//! Both techniques warp u ∈ [0, 1], which maps to s = s_begin + u (s_end − s_begin) on the
//! horizon-clipped segment (so u uniform is clipped solid angle sampling). The density in u is a
//! polynomial fitted to the cosine n·ω at control points; with Ω_R the clipped solid angle per
//! radius, dΩ_R = Ω_R du, so p_R(ω) = p_u(u(ω)) / Ω_R.
//!
//! - Linear: p_u(u) = lerp(c0, c1, u) · 2/(c0 + c1), c0/c1 the cosine at begin/end.
//! - Quadratic: p_u(u) = B(u) · 3/(c0 + c1 + c2), B the quadratic Bézier with control values
//!   c0 (begin), c1 (cosine at the solid-angle midpoint), c2 (end).
//!
//! The control values are cosines at points of the clipped segment, hence ≥ 0 (n·p(l) is affine
//! in l and ≥ 0 at both clipped endpoints). Their sum is ≈ 0 only for a line (nearly) in the
//! tangent plane; then the shape is rounding noise and the warp falls back to uniform. Sampler,
//! pdf and inverse all use the same stored (normalised) coefficients, so they stay consistent.
//!
//! Inverse: ξ = CDF(u) in closed form.
//!
//! Numerics: u ↔ direction goes through the frame's [`FrameArc`], u = (sin(φ_b + τ) − sin φ_b)/Δs
//! with both differences free of cancellation, not through s = u·ω: near |s| → 1 consecutive
//! f32 s are ε/2 apart, so u = (s − s_begin)/(s_end − s_begin) of a short interval there would
//! be quantised to a few hundred values and the u recomputed from a sampled direction would
//! differ from the sampled u by up to 1e-2 (sample_with_pdf ≠ pdf by 2.5 % for a steep warp).

use crate::geometry::{unit_normal, FrameArc, LineFrame, Segment};
use crate::sampler::{clamp_xi, LineSampler};
use glam::Vec3;

/// Below this sum of control cosines the fit is rounding noise: use the uniform density.
const MIN_COSINE_SUM: f32 = 1e-6;

/// The horizon-clipped frame and the unit normal; `None` when nothing is above the horizon or
/// when even the largest density (≤ 3/Ω_R for both warps) would not be a finite f32.
fn clipped_frame(segment: &Segment, x: Vec3, n: Vec3) -> Option<(LineFrame, FrameArc, Vec3, f32)> {
    let n = unit_normal(n)?;
    let frame = LineFrame::clipped(segment, x, n)?;
    let arc = FrameArc::of(&frame);
    let inv_solid_angle = 1.0 / frame.solid_angle();
    let ok = inv_solid_angle > 0.0 && (3.0 * inv_solid_angle).is_finite() && arc.delta_s > 0.0;
    ok.then_some((frame, arc, n, inv_solid_angle))
}

/// Cosine n·ω of the direction with u·ω = s, clamped to ≥ 0 (clipped endpoints sit at ≈ 0).
#[inline]
fn cosine(frame: &LineFrame, n: Vec3, s: f32) -> f32 {
    n.dot(frame.direction(s)).max(0.0)
}

/// Unit direction at clipped-solid-angle coordinate u ∈ [0, 1].
#[inline]
fn direction_of_u(frame: &LineFrame, arc: &FrameArc, u: f32) -> Vec3 {
    arc.direction(frame, arc.tau_of_delta_s(u as f64 * arc.delta_s))
}

/// u of a direction in the support (up to the arc's rounding tolerance), else `None`.
#[inline]
fn u_of_direction(frame: &LineFrame, arc: &FrameArc, dir: Vec3) -> Option<f32> {
    let tau = arc.tau_in_support(frame, dir)?;
    Some(((arc.delta_s_at(tau) / arc.delta_s) as f32).clamp(0.0, 1.0))
}

// ---------------------------------------------------------------------------------------------
// Linear warp (technique 5)

/// Linear density in u between the cosines at the clipped endpoints.
#[derive(Clone, Copy, Debug)]
pub struct HartLinear {
    frame: LineFrame,
    arc: FrameArc,
    /// Density in u at u = 0 and u = 1, normalised: a + b = 2, so p_u(u) = lerp(a, b, u).
    a: f32,
    b: f32,
    inv_solid_angle: f32,
}

impl HartLinear {
    pub fn prepare(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        let (frame, arc, n, inv_solid_angle) = clipped_frame(segment, x, n)?;
        let c0 = cosine(&frame, n, frame.s_begin);
        let c1 = cosine(&frame, n, frame.s_end);
        let (a, b) = linear_coefficients(c0, c1);
        Some(Self {
            frame,
            arc,
            a,
            b,
            inv_solid_angle,
        })
    }

    #[inline]
    fn density_u(&self, u: f32) -> f32 {
        (1.0 - u) * self.a + u * self.b
    }
}

/// Normalised endpoint densities (a, b) with a + b = 2; uniform when c0 + c1 is noise.
fn linear_coefficients(c0: f32, c1: f32) -> (f32, f32) {
    let sum = c0 + c1;
    if sum >= MIN_COSINE_SUM {
        let scale = 2.0 / sum;
        (c0 * scale, c1 * scale)
    } else {
        (1.0, 1.0)
    }
}

/// u with CDF(u) = ξ for p_u = lerp(a, b, u), a + b = 2, a, b ≥ 0. The root of
/// (b − a)/2 u² + a u − ξ = 0, rationalised so that a = b needs no special case:
/// u = ξ(a + b) / (a + √((1 − ξ)a² + ξb²)). The denominator vanishes only for a = ξ = 0 (u = 0).
#[inline]
fn linear_inverse_cdf(a: f32, b: f32, xi: f32) -> f32 {
    let denom = a + ((1.0 - xi) * a * a + xi * b * b).max(0.0).sqrt();
    if denom > 0.0 {
        (xi * (a + b) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// CDF of p_u = lerp(a, b, u): a u + (b − a) u²/2, written with non-negative terms.
#[inline]
fn linear_cdf(a: f32, b: f32, u: f32) -> f32 {
    (u * ((1.0 - 0.5 * u) * a + 0.5 * u * b)).clamp(0.0, 1.0)
}

impl LineSampler for HartLinear {
    fn sample(&self, xi: f32) -> Vec3 {
        let u = linear_inverse_cdf(self.a, self.b, clamp_xi(xi));
        direction_of_u(&self.frame, &self.arc, u)
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        match u_of_direction(&self.frame, &self.arc, dir) {
            Some(u) => self.density_u(u) * self.inv_solid_angle,
            None => 0.0,
        }
    }

    fn support(&self) -> &LineFrame {
        &self.frame
    }

    fn inverse(&self, dir: Vec3) -> Option<f32> {
        let u = u_of_direction(&self.frame, &self.arc, dir)?;
        Some(linear_cdf(self.a, self.b, u))
    }

    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        let u = linear_inverse_cdf(self.a, self.b, clamp_xi(xi));
        let dir = direction_of_u(&self.frame, &self.arc, u);
        (dir, self.density_u(u) * self.inv_solid_angle)
    }
}

// ---------------------------------------------------------------------------------------------
// Quadratic warp (technique 6)

/// Quadratic Bézier density in u with control values at begin, solid-angle midpoint and end.
#[derive(Clone, Copy, Debug)]
pub struct HartQuadratic {
    frame: LineFrame,
    arc: FrameArc,
    /// Bézier control values of p_u, normalised: k0 + k1 + k2 = 3, so ∫₀¹ p_u = 1.
    k: [f32; 3],
    /// [`newton_start`] of `k`: a function of k alone, formed once here instead of per sample.
    start: (f64, f64),
    inv_solid_angle: f32,
}

impl HartQuadratic {
    pub fn prepare(segment: &Segment, x: Vec3, n: Vec3) -> Option<Self> {
        let (frame, arc, n, inv_solid_angle) = clipped_frame(segment, x, n)?;
        let s_mid = 0.5 * (frame.s_begin + frame.s_end);
        let c = [
            cosine(&frame, n, frame.s_begin),
            cosine(&frame, n, s_mid),
            cosine(&frame, n, frame.s_end),
        ];
        let k = quadratic_coefficients(c);
        Some(Self {
            frame,
            arc,
            k,
            start: newton_start(k),
            inv_solid_angle,
        })
    }

    #[inline]
    fn density_u(&self, u: f32) -> f32 {
        bezier_density(self.k, u as f64) as f32
    }
}

/// Normalised control values (sum 3); uniform when c0 + c1 + c2 is noise.
fn quadratic_coefficients(c: [f32; 3]) -> [f32; 3] {
    let sum = c[0] + c[1] + c[2];
    if sum >= MIN_COSINE_SUM {
        let scale = 3.0 / sum;
        c.map(|ci| ci * scale)
    } else {
        [1.0; 3]
    }
}

/// B(u) = (1−u)² k0 + 2u(1−u) k1 + u² k2.
#[inline]
fn bezier_density(k: [f32; 3], u: f64) -> f64 {
    let v = 1.0 - u;
    v * v * k[0] as f64 + 2.0 * u * v * k[1] as f64 + u * u * k[2] as f64
}

/// ∫₀ᵘ B = [k0 (1 − (1−u)³) + k1 (3u² − 2u³) + k2 u³] / 3, each term ≥ 0 on [0, 1], so the
/// value is accurate and monotone in u (no cancellation between terms of the power form).
#[inline]
fn bezier_cdf(k: [f32; 3], u: f64) -> f64 {
    let v = 1.0 - u;
    let (k0, k1, k2) = (k[0] as f64, k[1] as f64, k[2] as f64);
    (k0 * (1.0 - v * v * v) + k1 * u * u * (3.0 - 2.0 * u) + k2 * u * u * u) / 3.0
}

/// The first iterate of [`quadratic_inverse_cdf`] is the linear warp through the end values
/// (exact when k1 = (k0 + k2)/2): its normalised end densities (a, b), a + b = 2.
fn newton_start(k: [f32; 3]) -> (f64, f64) {
    let (k0, k2) = (k[0] as f64, k[2] as f64);
    if k0 + k2 > 0.0 {
        (2.0 * k0 / (k0 + k2), 2.0 * k2 / (k0 + k2))
    } else {
        (1.0, 1.0)
    }
}

/// u ∈ [0, 1] with ∫₀ᵘ B = ξ (k normalised to sum 3).
///
/// The CDF is a cubic whose cubic (k0 − 2k1 + k2) and quadratic (3(k1 − k0)) coefficients may
/// vanish or nearly vanish, which makes closed-form cubic roots ill-conditioned. Instead:
/// Newton's method in f64 on the bracket [lo, hi] ∋ root, which starts at [0, 1] because the
/// CDF is monotone with CDF(0) = 0, CDF(1) = 1; every iterate shrinks the bracket, and a Newton
/// step that leaves it (or a zero derivative, as at u = 0 when k0 = 0) is replaced by bisection.
/// Converged to ~1e-12 in u, far below the f32 spacing of the result, so the f32 result is
/// monotone in ξ. Degenerate cases need no branch: equal k gives a linear CDF (one step).
/// `start` must be [`newton_start`]`(k)`.
fn quadratic_inverse_cdf(k: [f32; 3], start: (f64, f64), xi: f32) -> f32 {
    debug_assert_eq!(start, newton_start(k), "start of other control values");
    let xi = xi as f64;
    if xi <= 0.0 {
        return 0.0;
    }
    if xi >= 1.0 {
        return 1.0;
    }
    let (a, b) = start;
    let mut u = {
        let denom = a + ((1.0 - xi) * a * a + xi * b * b).sqrt();
        if denom > 0.0 {
            (2.0 * xi / denom).clamp(0.0, 1.0)
        } else {
            xi
        }
    };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..64 {
        let g = bezier_cdf(k, u) - xi;
        if g == 0.0 {
            break;
        }
        if g < 0.0 {
            lo = u;
        } else {
            hi = u;
        }
        let dg = bezier_density(k, u);
        let newton = u - g / dg;
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        let step = (next - u).abs();
        u = next;
        if step <= 1e-12 || hi - lo <= 1e-12 {
            break;
        }
    }
    (u as f32).clamp(0.0, 1.0)
}

impl LineSampler for HartQuadratic {
    fn sample(&self, xi: f32) -> Vec3 {
        let u = quadratic_inverse_cdf(self.k, self.start, clamp_xi(xi));
        direction_of_u(&self.frame, &self.arc, u)
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        match u_of_direction(&self.frame, &self.arc, dir) {
            Some(u) => self.density_u(u) * self.inv_solid_angle,
            None => 0.0,
        }
    }

    fn support(&self) -> &LineFrame {
        &self.frame
    }

    fn inverse(&self, dir: Vec3) -> Option<f32> {
        let u = u_of_direction(&self.frame, &self.arc, dir)?;
        Some((bezier_cdf(self.k, u as f64) as f32).clamp(0.0, 1.0))
    }

    fn sample_with_pdf(&self, xi: f32) -> (Vec3, f32) {
        let u = quadratic_inverse_cdf(self.k, self.start, clamp_xi(xi));
        let dir = direction_of_u(&self.frame, &self.arc, u);
        (dir, self.density_u(u) * self.inv_solid_angle)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// Short interval seen almost along its axis (s ≈ 0.9998, Δs ≈ 2e-4, a few thousand f32
    /// values of s) with a steep warp: sample_with_pdf and pdf(sample) must agree, which they
    /// do not (by percents) if u is recomputed from the quantised s.
    #[test]
    fn density_of_samples_near_the_axis() {
        let seg = Segment::new(Vec3::new(0.01, 0.0, 0.5), Vec3::new(0.01, 0.0, 0.52));
        // Horizon at l = 0.51: the clipped interval [0.51, 0.52] has Δs ≈ 7e-6 (≈ 120 f32
        // values of s) and cosine 0 at its begin (a = 0, b = 2: the steepest linear warp).
        let n = Vec3::new(-51.0, 0.0, 1.0).normalize();
        let lin = HartLinear::prepare(&seg, Vec3::ZERO, n).unwrap();
        let quad = HartQuadratic::prepare(&seg, Vec3::ZERO, n).unwrap();
        let samplers: [&dyn LineSampler; 2] = [&lin, &quad];
        for p in samplers {
            for i in 0..=1000 {
                let xi = i as f32 / 1000.0;
                let (w, q) = p.sample_with_pdf(xi);
                let r = p.pdf(w);
                // Relative, plus the density's change over ~ε of φ (slope ≤ 6/(Ω_R Δφ)).
                let omega = p.support().solid_angle();
                let width = FrameArc::of(p.support()).width as f32;
                let tol = 1e-4 * q.max(r) + 6.0 / (omega * width) * 4.0 * f32::EPSILON;
                assert!((q - r).abs() <= tol, "ξ = {xi}: {q} vs {r} (tol {tol})");
                let back = p.inverse(w).unwrap();
                assert!((back - xi).abs() < 1e-4, "ξ = {xi}: {back}");
            }
        }
    }

    /// (segment, shading point, normal): plain, horizon-crossing, grazing, long and oblique.
    fn configurations() -> Vec<(Segment, Vec3, Vec3)> {
        vec![
            (
                Segment::new(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0)),
                Vec3::ZERO,
                Vec3::Z,
            ),
            (
                Segment::new(Vec3::new(1.0, 0.0, -1.0), Vec3::new(1.0, 0.5, 1.0)),
                Vec3::ZERO,
                Vec3::new(0.1, 0.2, 1.0),
            ),
            (
                Segment::new(Vec3::new(-0.3, 0.5, 0.4), Vec3::new(3.2, -0.2, 1.1)),
                Vec3::new(0.1, 0.0, -0.2),
                Vec3::new(0.4, -0.3, 1.0),
            ),
            // Nearly parallel to the tangent plane, slightly above it.
            (
                Segment::new(Vec3::new(-2.0, 1.0, 0.02), Vec3::new(2.0, 1.0, 0.05)),
                Vec3::ZERO,
                Vec3::Z,
            ),
            // Long segment seen nearly along its axis.
            (
                Segment::new(Vec3::new(0.5, 0.3, 0.2), Vec3::new(60.0, 0.4, 5.0)),
                Vec3::ZERO,
                Vec3::new(-0.2, 0.1, 1.0),
            ),
            // Normal pointing at the segment: cosine peaks in the middle.
            (
                Segment::new(Vec3::new(-3.0, 0.0, 1.0), Vec3::new(3.0, 0.0, 1.0)),
                Vec3::ZERO,
                Vec3::Z,
            ),
        ]
    }

    fn both(seg: &Segment, x: Vec3, n: Vec3) -> [Box<dyn LineSampler>; 2] {
        [
            Box::new(HartLinear::prepare(seg, x, n).unwrap()),
            Box::new(HartQuadratic::prepare(seg, x, n).unwrap()),
        ]
    }

    /// ∫_{s0}^{s1} p_R (2/d) ds by Gauss–Legendre (8 nodes) on `m` panels in φ = asin s, f64.
    fn integral(p: &dyn LineSampler, s0: f64, s1: f64, m: usize) -> f64 {
        const X: [f64; 4] = [
            0.183_434_642_495_65,
            0.525_532_409_916_329,
            0.796_666_477_413_627,
            0.960_289_856_497_536,
        ];
        const W: [f64; 4] = [
            0.362_683_783_378_362,
            0.313_706_645_877_887,
            0.222_381_034_453_374,
            0.101_228_536_290_376,
        ];
        let f = p.support();
        let (pb, pe) = (s0.asin(), s1.asin());
        let h = (pe - pb) / m as f64;
        let mut sum = 0.0;
        for i in 0..m {
            let mid = pb + (i as f64 + 0.5) * h;
            for (x, w) in X.iter().zip(W) {
                for phi in [mid - 0.5 * h * x, mid + 0.5 * h * x] {
                    let dir = f.direction(phi.sin() as f32);
                    sum += w * 0.5 * h * p.pdf(dir) as f64 * 2.0 / f.d as f64 * phi.cos();
                }
            }
        }
        sum
    }

    #[test]
    fn normalised() {
        for (seg, x, n) in configurations() {
            for p in both(&seg, x, n) {
                let f = p.support();
                let z = integral(p.as_ref(), f.s_begin as f64, f.s_end as f64, 2000);
                assert!((z - 1.0).abs() < 1e-5, "{z} for {seg:?}");
            }
        }
    }

    #[test]
    fn density_matches_the_formulas_of_the_paper() {
        let (seg, x, n) = configurations()[2];
        let f = LineFrame::new(&seg, x)
            .unwrap()
            .clip_to_horizon(n.normalize())
            .unwrap();
        let cos = |s: f32| n.normalize().dot(f.direction(s)) as f64;
        let (c0, c2) = (cos(f.s_begin), cos(f.s_end));
        let c1 = cos(0.5 * (f.s_begin + f.s_end));
        let omega = f.solid_angle() as f64;
        let lin = HartLinear::prepare(&seg, x, n).unwrap();
        let quad = HartQuadratic::prepare(&seg, x, n).unwrap();
        for &u in &[0.1f64, 0.5, 0.8] {
            let dir = f.direction((f.s_begin as f64 + u * (f.s_end - f.s_begin) as f64) as f32);
            let p_lin = ((1.0 - u) * c0 + u * c2) * 2.0 / ((c0 + c2) * omega);
            let b = (1.0 - u).powi(2) * c0 + 2.0 * u * (1.0 - u) * c1 + u * u * c2;
            let p_quad = b * 3.0 / ((c0 + c1 + c2) * omega);
            assert!((lin.pdf(dir) as f64 - p_lin).abs() < 1e-4 * p_lin);
            assert!((quad.pdf(dir) as f64 - p_quad).abs() < 1e-4 * p_quad);
        }
    }

    #[test]
    fn inverse_round_trip_support_and_horizon() {
        for (seg, x, n) in configurations() {
            let nn = n.normalize();
            for p in both(&seg, x, n) {
                let f = *p.support();
                for i in 0..=200 {
                    let xi = i as f32 / 200.0;
                    let (dir, pdf) = p.sample_with_pdf(xi);
                    assert!((dir.length() - 1.0).abs() < 1e-5);
                    assert!(nn.dot(dir) > -1e-5, "below the horizon: {dir} {seg:?}");
                    let back = p.inverse(dir);
                    assert!(
                        back.is_some_and(|b| (b - xi).abs() < 1e-4),
                        "{xi} {back:?} {seg:?}"
                    );
                    assert!(pdf.is_finite() && pdf >= 0.0);
                    if i > 0 && i < 200 {
                        assert!(f.contains_s(f.s_of(dir)));
                        let q = p.pdf(dir);
                        assert!((q - pdf).abs() <= 1e-3 * pdf + 1e-6, "{q} {pdf}");
                    }
                }
            }
        }
    }

    #[test]
    fn quadratic_solver_is_monotone_and_handles_degenerate_shapes() {
        let shapes = [
            [1.0, 1.0, 1.0], // uniform: cubic and quadratic coefficients vanish
            [0.0, 1.5, 1.5], // zero density at u = 0: cubic coefficient vanishes
            [0.0, 0.0, 3.0], // density u²: CDF u³
            [3.0, 0.0, 0.0], // density (1−u)²
            [0.0, 3.0, 0.0], // zero at both ends
            [1.4, 0.2, 1.4], // dip in the middle
            [0.5, 1.0, 1.5], // linear: k1 = (k0 + k2)/2
        ];
        for k in shapes {
            let mut prev = 0.0f32;
            for i in 0..=100_000 {
                let xi = i as f32 / 100_000.0;
                let u = quadratic_inverse_cdf(k, newton_start(k), xi);
                assert!(
                    (0.0..=1.0).contains(&u) && u >= prev,
                    "{k:?} {xi} {u} {prev}"
                );
                assert!(
                    (bezier_cdf(k, u as f64) - xi as f64).abs() < 1e-6,
                    "{k:?} {xi} {u}"
                );
                prev = u;
            }
            assert_eq!(quadratic_inverse_cdf(k, newton_start(k), 0.0), 0.0);
            assert_eq!(quadratic_inverse_cdf(k, newton_start(k), 1.0), 1.0);
        }
        let k = [0.0, 0.0, 3.0];
        let u = quadratic_inverse_cdf(k, newton_start(k), 0.125);
        assert!((u - 0.5).abs() < 1e-6);
    }

    #[test]
    fn linear_inverse_handles_zero_endpoints() {
        assert_eq!(linear_inverse_cdf(0.0, 2.0, 0.0), 0.0);
        assert!((linear_inverse_cdf(0.0, 2.0, 0.25) - 0.5).abs() < 1e-7); // CDF u²
        assert!((linear_inverse_cdf(2.0, 0.0, 1.0) - 1.0).abs() < 1e-7);
        assert!((linear_inverse_cdf(1.0, 1.0, 0.3) - 0.3).abs() < 1e-7);
        let mut prev = 0.0;
        for i in 0..=10_000 {
            let xi = i as f32 / 10_000.0;
            let u = linear_inverse_cdf(0.3, 1.7, xi);
            assert!(u >= prev && (linear_cdf(0.3, 1.7, u) - xi).abs() < 1e-6);
            prev = u;
        }
    }

    #[test]
    fn in_plane_line_falls_back_to_uniform() {
        // Endpoint cosines 1e-9: the fit is noise, both warps become clipped solid angle sampling.
        let seg = Segment::new(Vec3::new(-1.0, 1.0, 1e-9), Vec3::new(1.0, 1.0, 1e-9));
        for p in both(&seg, Vec3::ZERO, Vec3::Z) {
            let omega = p.support().solid_angle();
            for i in 0..=10 {
                let (dir, pdf) = p.sample_with_pdf(i as f32 / 10.0);
                assert!(dir.is_finite() && (pdf * omega - 1.0).abs() < 1e-5, "{pdf}");
            }
        }
    }

    /// Samples binned in s against the expected counts from quadrature of `pdf`: each of 20
    /// bins within 5 binomial standard deviations (a sanity check; the chi-square suite is in
    /// crates/verify).
    #[test]
    fn histogram_matches_pdf() {
        let (bins, n) = (20usize, 200_000usize);
        for (ci, (seg, x, nrm)) in configurations().into_iter().enumerate() {
            for (pi, p) in both(&seg, x, nrm).iter().enumerate() {
                let f = *p.support();
                let mut rng = Pcg32::new(11, (2 * ci + pi) as u64);
                let mut count = vec![0usize; bins];
                let edge = |k: usize| {
                    f.s_begin as f64 + k as f64 / bins as f64 * (f.s_end - f.s_begin) as f64
                };
                for _ in 0..n {
                    let s = f.s_of(p.sample(rng.next_f32())) as f64;
                    let k = ((s - f.s_begin as f64) / (f.s_end - f.s_begin) as f64 * bins as f64)
                        as usize;
                    count[k.min(bins - 1)] += 1;
                }
                for (k, &c) in count.iter().enumerate() {
                    let prob = integral(p.as_ref(), edge(k), edge(k + 1), 50);
                    let (mean, sd) = (n as f64 * prob, (n as f64 * prob * (1.0 - prob)).sqrt());
                    assert!(
                        (c as f64 - mean).abs() <= 5.0 * sd + 1.0,
                        "config {ci}/{pi} bin {k}: {c} vs {mean}"
                    );
                }
            }
        }
    }
}
