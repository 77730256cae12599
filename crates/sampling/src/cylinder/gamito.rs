//! Gamito's construction (EGSR 2016, "Solid Angle Sampling of Disk and Cylinder Lights") for
//! uniform solid-angle sampling of the cylinder: sample a spherical rectangle that bounds the
//! visible side uniformly in solid angle, keep the directions that hit the side. The kept
//! directions are uniform on the side's solid angle: p = 1/Ω, 0 elsewhere (no horizon
//! clipping; samples below it contribute 0).
//!
//! The bounding rectangle lies in the plane through the two silhouette lines (perpendicular to
//! ĉ at distance d = (ρ² − R²)/ρ from x), between them (half-width R√(ρ² − R²)/ρ, so it covers
//! exactly the azimuths |α| ≤ α_max), along the axis from l₀ to l₁. The front side lies between
//! x and that plane; a front point at surface angle θ is at depth ρ − R cos θ ≥ ρ − R along ĉ,
//! so seen from x it projects onto the plane at most (ρ + R)/ρ times further along the axis.
//! An end e of the side is therefore covered by l = e·(1 + R/ρ) where it moves away from the
//! foot of x (l₀ for a < 0, l₁ for b > 0), and by l = e itself otherwise.
//!
//! The rectangle is sampled in the view's (α, s = sin φ) coordinates (dΩ = dα ds). At azimuth
//! α the plane is at horizontal distance d/cos α, so the rectangle spans
//! S_l(α) = l cos α / √(d² + l² cos² α) for l ∈ [l₀, l₁], and its azimuth marginal has the
//! primitive G(α) = asin(A₁ sin α) − asin(A₀ sin α), A_l = l/√(d² + l²); Ω_rect = 2 G(α_max).
//! G is inverted in closed form: with t = G(α), P = asin(A₁ sin α) solves
//! A₀ sin P = A₁ sin(P − t), whence
//!
//! ```text
//! sin α = sgn(A₁ cos t − A₀) · sin t / √((A₁ − A₀)² + 4 A₀ A₁ sin²(t/2)),
//! ```
//!
//! then s uniform on [S_{l₀}(α), S_{l₁}(α)]. (This is Ureña et al.'s spherical-rectangle map
//! for a rectangle symmetric about the foot of x.) The acceptance rate is Ω/Ω_rect.
//!
//! Ω itself, the normalisation, is Gamito's decomposition ([`gamito_solid_angle`]): the solid
//! angle of the quadrilateral between the two silhouette lines and the ends' planes (closed
//! form), corrected at each end by the solid angle of the cap's circular segment between the
//! silhouette chord and the visible arc (added at an end x is not beyond, subtracted at the
//! end x looks into). Rejection: the first candidate uses ξ, later ones a PCG32 stream keyed by
//! the bits of ξ (a deterministic function of ξ). No inverse.

use super::solid_angle::{sum_sinh_rule, NodeTerm};
use super::{reject_until_accepted, CylinderSample, CylinderSampler, CylinderView};
use glam::DVec3;

/// Most panels per cap segment of [`gamito_solid_angle`]'s quadrature, 8 Gauss–Legendre nodes
/// each, and the widest panel in the graded variable t.
pub const CAP_PANELS: usize = 5;
const PANEL_WIDTH: f64 = 0.9;

/// Ω of the visible side by Gamito's decomposition:
///
/// ```text
/// Ω = Ω_Q(a, b) + C(b) − C(a),   Ω_Q(a, b) = 2 [asin(A_b R/ρ) − asin(A_a R/ρ)],
/// ```
///
/// Ω_Q the solid angle of the quadrilateral in the silhouettes' plane (depth d = (ρ² − R²)/ρ)
/// between the silhouettes and the ends (A_e = e/√(d² + e²), the rectangle map's primitive at
/// α_max), and C(e) (odd in e) the solid angle of the segment of the cap at axial coordinate e
/// that lies between the silhouette chord and the visible arc, [`cap_segment`]. The visible arc
/// bulges toward x from its chord, so its segment is added at an end x is not beyond and
/// subtracted at the end x looks into (there the quadrilateral covers directions that pass in
/// front of the side, into the open end). Relative error ≤ 1e-12 on the tests' configurations.
pub fn gamito_solid_angle(v: &CylinderView) -> f64 {
    let depth = (v.rho - v.radius) * (v.rho + v.radius) / v.rho;
    let sin_max = v.radius / v.rho;
    let quad_edge = |e: f64| (e / e.hypot(depth) * sin_max).asin();
    let quad = 2.0 * (quad_edge(v.b) - quad_edge(v.a));
    let cap = |e: f64| {
        if e == 0.0 {
            0.0
        } else {
            e.signum() * cap_segment(v, e.abs())
        }
    };
    quad + cap(v.b) - cap(v.a)
}

/// Solid angle, seen from x, of the circular segment of a cap at axial distance e > 0 from x's
/// foot: the part of the disc of radius R (centre at distance ρ from the foot, in the plane
/// perpendicular to the axis) between the silhouette chord, at distance d = (ρ² − R²)/ρ from
/// the foot, and the arc nearest x.
///
/// In the cap's plane, with X the distance from the foot toward the centre and Y along the
/// chord, the segment is X_arc(Y) ≤ X ≤ d, |Y| ≤ c = R√(ρ² − R²)/ρ, and
/// dΩ = e dX dY / (X² + Y² + e²)^{3/2}. The X-integral is elementary, e/q · [X/√(X² + q)]
/// with q = Y² + e², so
///
/// ```text
/// C(e) = 2 ∫₀^c e (d² − X_arc²) / [(d √(X_arc² + q) + X_arc √(d² + q)) √(d² + q) √(X_arc² + q)] dY,
/// ```
///
/// the difference of the two bracket values written without cancellation (and without the
/// 1/q of the bracket). The arc is parametrised by its surface angle θ (Y = R sin θ,
/// X_arc = ρ − R cos θ, dY = R cos θ dθ, 0 ≤ θ ≤ θ_max): in Y the integrand has a branch
/// point at Y = R, just beyond c for a thin tube, where Gauss–Legendre converges slowly.
/// d − X_arc = R (cos θ − cos θ_max) = 2R sin((θ_max + θ)/2) sin((θ_max − θ)/2) and
/// X_arc = (ρ − R) + 2R sin²(θ/2) are formed without cancellation. The integrand varies on the
/// scale max(ρ − R, e) in Y (the arc's distance from the foot and the height of x), below c
/// near the tube: θ = θ_s sinh t with θ_s = min(θ_max, max(ρ − R, e)/R), panels of t of width
/// ≤ 0.9 (one unless x is within about R θ_max of the tube or of the cap's plane; at most
/// [`CAP_PANELS`]), 8 Gauss–Legendre nodes each, sinh and cosh of the nodes by the addition
/// theorems, sin and cos of θ/2 by [`crate::trig::sin_cos_quarter`] (arithmetic only).
pub fn cap_segment(v: &CylinderView, e: f64) -> f64 {
    let (r, rho) = (v.radius, v.rho);
    let gap = rho - r;
    let depth = gap * (rho + r) / rho;
    let theta_max = v.theta_max;
    let theta_s = theta_max.min(gap.max(e) / r);
    if theta_s.is_nan() || theta_s <= 0.0 {
        return 0.0;
    }
    let t_max = (theta_max / theta_s).asinh();
    // Panels of width ≤ PANEL_WIDTH in t: one for a shading point far from the tube
    // (t_max ≤ asinh(1)), up to CAP_PANELS close to it.
    let panels = ((t_max / PANEL_WIDTH).ceil() as usize).clamp(1, CAP_PANELS);
    // sin, cos of θ_max/2 (cos θ_max = R/ρ): d − X_arc = 2R sin((θ_max + θ)/2) sin((θ_max − θ)/2).
    let (sm, cm) = (0.5 * theta_max).sin_cos();
    let terms = CapTerms {
        theta_s,
        r,
        gap,
        depth,
        sm,
        cm,
        e,
    };
    2.0 * sum_sinh_rule(t_max, panels, terms)
}

/// The per-node terms of [`cap_segment`]'s rule: what they need of the view and the cap.
#[derive(Clone, Copy)]
struct CapTerms {
    theta_s: f64,
    r: f64,
    gap: f64,
    depth: f64,
    /// sin and cos of θ_max/2.
    sm: f64,
    cm: f64,
    e: f64,
}

impl NodeTerm for CapTerms {
    /// The term of the node t (sinh t, cosh t, weight): weight × dθ/dt × dY/dθ × the
    /// integrand at Y(θ), θ = θ_s sinh t.
    #[inline(always)]
    fn term(&self, sinh: f64, cosh: f64, wt: f64) -> f64 {
        let (r, e, depth) = (self.r, self.e, self.depth);
        // θ/2 < θ_max/2 < π/4.
        let (sh, ch) = crate::trig::sin_cos_quarter(0.5 * self.theta_s * sinh);
        let (sin_t, cos_t) = (2.0 * sh * ch, (ch - sh) * (ch + sh));
        let y = r * sin_t;
        let x = self.gap + 2.0 * r * sh * sh;
        let (sm, cm) = (self.sm, self.cm);
        let d_minus_x = 2.0 * r * (sm * ch + cm * sh) * (sm * ch - cm * sh).max(0.0);
        let q = y * y + e * e;
        let (sx, sd) = ((x * x + q).sqrt(), (depth * depth + q).sqrt());
        let f = e * d_minus_x * (depth + x) / ((depth * sx + x * sd) * sd * sx);
        wt * self.theta_s * cosh * r * cos_t * f
    }
}

/// Most candidates per sample; the acceptance rate Ω/Ω_rect is ≥ 0.39 on the tests'
/// configurations (0.397 at ρ = 1.05 R, 0.25 R beyond an end; ≥ 0.68 elsewhere), so the
/// chance of reaching this is below 1e-400.
const MAX_CANDIDATES: usize = 2000;

#[derive(Clone, Copy, Debug)]
pub struct CylinderGamito {
    view: CylinderView,
    /// 1/Ω of the visible side.
    inv_omega: f64,
    /// Distance of the rectangle's plane from x, along ĉ.
    depth: f64,
    /// The rectangle's axial extent [l₀, l₁] and A_l = l/√(d² + l²) at both.
    l: [f64; 2],
    a_l: [f64; 2],
    /// G(α_max): half the rectangle's solid angle.
    g_max: f64,
}

impl CylinderGamito {
    #[inline]
    pub fn new(view: &CylinderView) -> Option<Self> {
        let v = view;
        let depth = (v.rho - v.radius) * (v.rho + v.radius) / v.rho;
        let grow = 1.0 + v.radius / v.rho;
        let l = [
            if v.a < 0.0 { v.a * grow } else { v.a },
            if v.b > 0.0 { v.b * grow } else { v.b },
        ];
        let a_l = l.map(|l| l / l.hypot(depth));
        let sin_max = v.radius / v.rho;
        let g_max = (a_l[1] * sin_max).asin() - (a_l[0] * sin_max).asin();
        let inv_omega = 1.0 / gamito_solid_angle(v);
        (inv_omega.is_finite() && inv_omega > 0.0 && g_max > 0.0 && depth > 0.0).then_some(Self {
            view: *view,
            inv_omega,
            depth,
            l,
            a_l,
            g_max,
        })
    }

    /// Solid angle Ω of the visible side ([`gamito_solid_angle`]).
    pub fn solid_angle(&self) -> f64 {
        1.0 / self.inv_omega
    }

    /// Solid angle of the bounding rectangle (Ω / this is the acceptance rate).
    pub fn bounding_solid_angle(&self) -> f64 {
        2.0 * self.g_max
    }

    /// The rectangle's elevation range S_l(α) at azimuth α, for l₀ and l₁, from cos α.
    #[inline]
    fn s_range(&self, cos_alpha: f64) -> (f64, f64) {
        let d2 = self.depth * self.depth;
        let s = |l: f64| {
            let lc = l * cos_alpha;
            lc / (d2 + lc * lc).sqrt()
        };
        (s(self.l[0]), s(self.l[1]))
    }

    /// The candidate for (ξ₀, ξ₁) ∈ [0, 1]², uniform in the rectangle's solid angle: α, sin α,
    /// cos α and s.
    #[inline]
    fn candidate(&self, x0: f64, x1: f64) -> [f64; 4] {
        let t = (2.0 * x0 - 1.0) * self.g_max;
        let [a0, a1] = self.a_l;
        let (sin_t, cos_t) = t.sin_cos();
        // sin²(t/2), without cancellation on either side of |t| = π/2.
        let half2 = if cos_t >= 0.0 {
            sin_t * sin_t / (2.0 * (1.0 + cos_t))
        } else {
            0.5 * (1.0 - cos_t)
        };
        let norm = ((a1 - a0) * (a1 - a0) + 4.0 * a0 * a1 * half2).sqrt();
        let sign = if a1 * cos_t - a0 >= 0.0 { 1.0 } else { -1.0 };
        let sin_max = self.view.radius / self.view.rho;
        let sigma = (sign * sin_t / norm).clamp(-sin_max, sin_max);
        let cos_alpha = ((1.0 - sigma) * (1.0 + sigma)).sqrt();
        let (s0, s1) = self.s_range(cos_alpha);
        [sigma.asin(), sigma, cos_alpha, s0 + x1 * (s1 - s0)]
    }
}

impl CylinderSampler for CylinderGamito {
    fn sample_with_pdf(&self, xi: [f32; 2]) -> Option<(DVec3, f64)> {
        self.sample_toward(xi).map(|s| (s.dir, s.pdf))
    }

    fn pdf(&self, dir: DVec3) -> f64 {
        self.pdf_toward(dir).map_or(0.0, |(p, _)| p)
    }

    /// The accepted candidate's direction and its distance h/cos φ from the acceptance test's
    /// own values.
    fn sample_toward(&self, xi: [f32; 2]) -> Option<CylinderSample> {
        let (dir, distance) = reject_until_accepted(
            xi,
            0x6a,
            MAX_CANDIDATES,
            |x0, x1| self.candidate(x0, x1),
            |[alpha, sin, cos, s]| {
                let v = &self.view;
                (alpha.abs() <= v.alpha_max).then(|| v.front_sample(sin, cos, s))?
            },
        )?;
        CylinderSample::checked(dir, self.inv_omega, distance)
    }

    /// 1/Ω where the view's `front_hit` meets the side.
    fn pdf_toward(&self, dir: DVec3) -> Option<(f64, f64)> {
        let hit = self.view.front_hit(dir)?;
        Some((self.inv_omega, hit.distance))
    }

    fn view(&self) -> &CylinderView {
        &self.view
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::*;
    use super::super::{Cylinder, CylinderView};
    use super::*;

    /// The hard configurations of Ω: the suite's, x close to a rim beyond an end, close beside
    /// the middle, and a thin tube seen from near its axis line beyond an end.
    fn omega_cases() -> Vec<(Cylinder, DVec3, DVec3)> {
        let mut cases = configs();
        let cyl = Cylinder::new(DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0), 0.5).unwrap();
        cases.push((cyl, DVec3::new(-0.005, 0.0, 0.505), DVec3::Z));
        cases.push((cyl, DVec3::new(1.5, 0.0, 0.5005), DVec3::Z));
        cases.push((cyl, DVec3::new(-5e-5, 0.0, 0.50005), DVec3::Z));
        cases.push((cyl, DVec3::new(3.2, 0.0, 0.8), DVec3::Z));
        cases.push((cyl, DVec3::new(0.0, 0.0, 0.9), DVec3::Z));
        let thin = Cylinder::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0), 1e-3).unwrap();
        cases.push((thin, DVec3::new(1.5, 0.0, 0.01), DVec3::Z));
        cases
    }

    /// Gamito's decomposition of Ω (quadrilateral in closed form, cap segments by quadrature)
    /// against the graded reference quadrature of ∫ (s_b − s_a) dα, and against the uniform
    /// sampler's Ω. All three are f64 functions of the same f64 view (an f32 scene's view is
    /// converted exactly before any of them), so rounding (~1e-16 per operation, ≤ ~1e-14 over
    /// a few hundred terms) is far below the bounds, which are those of the quadratures:
    /// 1e-12 for the decomposition (measured ≤ 7e-13, for the thin tube seen from beyond its
    /// end, the reference's own error there; ≤ 1e-13 elsewhere, x 1e-4 R from a rim included)
    /// and 1e-9 (the uniform sampler's documented bound; measured ≤ 1.8e-10, a thin tube seen
    /// from afar on one panel) plus 1e-12 between the two Ω's.
    #[test]
    fn gamito_solid_angle_agrees_with_the_reference_and_with_ours() {
        for (cyl, x, n) in omega_cases() {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            let reference = omega_reference(&v);
            let gamito = gamito_solid_angle(&v);
            let ours = super::super::solid_angle::solid_angle_of(&v);
            let err = (gamito / reference - 1.0).abs();
            assert!(
                err < 1e-12,
                "Gamito's Ω {gamito} vs reference {reference}: {err:e} (x = {x})"
            );
            let diff = (gamito / ours - 1.0).abs();
            assert!(
                diff < 1e-9 + 1e-11,
                "Gamito's Ω {gamito} vs ours {ours}: {diff:e}"
            );
            // The sampler's density is 1/Ω of this Ω.
            let s = CylinderGamito::new(&v).unwrap();
            assert!((s.solid_angle() / gamito - 1.0).abs() < 1e-15);
        }
    }

    /// A cap segment seen from straight above its chord's midpoint at height e, against a
    /// direct 2-D quadrature of e/(X² + Y² + e²)^{3/2} over the segment.
    #[test]
    fn cap_segment_against_a_direct_area_integral() {
        let cyl = Cylinder::new(DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), 0.3).unwrap();
        for (rho, e) in [(0.5, 0.4), (0.31, 0.05), (1.2, 2.0), (0.3003, 0.001)] {
            let x = DVec3::new(-e, 0.0, rho);
            let v = CylinderView::new(&cyl, x, DVec3::Z).unwrap();
            assert!((v.a - e).abs() < 1e-12);
            let (r, d) = (0.3f64, (rho * rho - 0.09) / rho);
            let c = r * (1.0 - r * r / (rho * rho)).sqrt();
            // Y on [0, c] graded toward 0, X from the arc to the chord, 24 nodes each way.
            let nodes = gauss_legendre(24);
            let mut direct = 0.0;
            let mut hi = c;
            for k in 0..=50 {
                let lo = if k == 50 { 0.0 } else { 0.5 * hi };
                for &(yn, yw) in &nodes {
                    let y = 0.5 * (lo + hi) + 0.5 * (hi - lo) * yn;
                    let x_arc = rho - (r * r - y * y).sqrt();
                    // X graded toward the arc (the integrand peaks there near the tube).
                    let mut xhi = d - x_arc;
                    for j in 0..=40 {
                        let xlo = if j == 40 { 0.0 } else { 0.5 * xhi };
                        for &(xn, xw) in &nodes {
                            let xx = x_arc + 0.5 * (xlo + xhi) + 0.5 * (xhi - xlo) * xn;
                            let f = e / (xx * xx + y * y + e * e).powf(1.5);
                            direct += 0.25 * (hi - lo) * (xhi - xlo) * yw * xw * f;
                        }
                        xhi = xlo;
                    }
                }
                hi = lo;
            }
            direct *= 2.0;
            let ours = cap_segment(&v, e);
            assert!(
                (ours / direct - 1.0).abs() < 1e-10,
                "ρ {rho}, e {e}: {ours} vs {direct}"
            );
        }
    }

    /// The rectangle's map: G inverted (the candidate's α has the CDF ξ₀), the rectangle covers
    /// the side, and the acceptance rate estimates Ω.
    #[test]
    fn rectangle_map_covers_the_side_and_acceptance_is_omega() {
        let mut cases = configs();
        let cyl = Cylinder::new(DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0), 0.5).unwrap();
        // Beyond an end close to the rim, and beside the middle close to the side.
        cases.push((cyl, DVec3::new(-0.005, 0.0, 0.505), DVec3::Z));
        cases.push((cyl, DVec3::new(1.5, 0.0, 0.5005), DVec3::Z));
        for (cyl, x, n) in cases {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            let s = CylinderGamito::new(&v).unwrap();
            // G(α(ξ₀)) = (2ξ₀ − 1) G_max.
            for i in 0..=64 {
                let x0 = i as f64 / 64.0;
                let [alpha, sin, cos, _] = s.candidate(x0, 0.5);
                assert!((sin - alpha.sin()).abs() <= 1e-15 && (cos - alpha.cos()).abs() <= 1e-15);
                let [a0, a1] = s.a_l;
                let g = (a1 * alpha.sin()).asin() - (a0 * alpha.sin()).asin();
                let want = (2.0 * x0 - 1.0) * s.g_max;
                assert!(
                    (g - want).abs() <= 1e-9 * s.g_max,
                    "G {g} vs {want}, R = {}",
                    cyl.radius
                );
            }
            // Every front direction lies in the rectangle.
            for i in 0..=40 {
                let theta = v.theta_max * (i as f64 / 20.0 - 1.0);
                let (alpha, _) = v.alpha_of_theta(theta);
                let (pa, pb) = v.phi_range(v.h(alpha));
                let (s0, s1) = s.s_range(alpha.cos());
                let tol = 1e-12;
                assert!(pa.sin() >= s0 - tol && pb.sin() <= s1 + tol, "θ {theta}");
            }
            // Acceptance of the first candidate on a 256 × 256 grid against Ω/Ω_rect.
            let k = 256;
            let mut accepted = 0usize;
            for i in 0..k {
                for j in 0..k {
                    let [a, _, _, sv] =
                        s.candidate((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
                    accepted += s.view.front_direction(a, sv).is_some() as usize;
                }
            }
            let rate = accepted as f64 / (k * k) as f64;
            let want = s.solid_angle() / s.bounding_solid_angle();
            assert!(want > 0.39, "acceptance {want}");
            assert!(
                (rate - want).abs() < 0.01,
                "acceptance {rate} vs Ω/Ω_rect {want}"
            );
            for i in 1..49 {
                let (dir, p) = s.sample_with_pdf([i as f32 / 49.0, 0.3]).unwrap();
                assert_eq!(s.pdf(dir), p);
            }
        }
    }
}
