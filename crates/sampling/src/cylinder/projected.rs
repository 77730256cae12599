//! Ours: the azimuth across the visible section from a piecewise-linear approximation of the
//! projected solid angle's marginal, then the elevation along the side by the paper's
//! projected-solid-angle line sampler (technique 8) on the slice at that azimuth.
//!
//! At azimuth α the visible side is a segment parallel to the axis at horizontal distance
//! h(α) (see [`super`]), seen between the elevations φ_a(α), φ_b(α) and clipped to the horizon
//! of n. The line sampler draws s = sin φ on that segment with density per radius
//! p_R = (n·ω)/Ω⊥_R w.r.t. dΩ_R = (2/h) ds, i.e. 2(n·ω)/T(α) w.r.t. ds, where
//! T(α) = C(φ_hi) − C(φ_lo), C(φ) = n_s sin²φ + n_t(sin φ cos φ + φ), n_s = n·u, n_t = n·ĉ_α.
//! Since dΩ = dα ds, the composed direction has the exact density per steradian
//!
//! ```text
//! p(ω) = q(α) · 2 max(0, n·ω) / T(α),
//! ```
//!
//! on the front side above the horizon, 0 elsewhere (docs/cylinders.md derives it). Slices
//! entirely below the horizon (T = 0) carry no projected solid angle: a sample there is
//! `None`, an estimate of 0, which is exact for them. No R → 0 limit enters: for every R the
//! only deviation of the samples from p is the line sampler's own backward error (two Halley
//! steps, ≤ 2e-5 in ξ).
//!
//! The section's density q: the ideal marginal (that of p ∝ n·ω) is T(α)/(2Ω⊥) per unit α. q
//! is g(α)/G, the piecewise-linear interpolant of T at the azimuths α_k of [`SECTION_NODES`]
//! equally spaced surface angles θ_k, plus a floor of [`FLOOR`] × their mean (so that g > 0
//! wherever a slice may be live, also between nodes that are dead), G = ∫ g dα. For a thin tube
//! T is nearly constant across the section and q nearly uniform. The interval is chosen by its
//! area and α inside it by inverting the linear density's quadratic CDF (closed form).
//!
//! Inverse: ξ₁ = the section's CDF at α, ξ₂ = the slice's exact CDF at φ.

use super::{clamp_xi, CylinderSample, CylinderSampler, CylinderView, SliceAt};
use crate::projected_solid_angle::{PsaCore, DEFAULT_ITERATIONS};
use crate::trig::atan2_f64;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// Equally spaced surface angles whose azimuths are the section density's nodes (4 intervals:
/// the nodes are edges of the certification's θ-bins).
pub const SECTION_NODES: usize = 5;
/// Floor of the piecewise-linear section density, relative to the mean of its node values.
pub const FLOOR: f64 = 0.1;

#[derive(Clone, Copy, Debug)]
pub struct CylinderProjected {
    view: CylinderView,
    section: Section,
    iterations: u32,
}

/// The section's piecewise-linear density q(α) = g(α)/G: g the linear interpolant of node
/// values m_k (plus the floor) at the azimuths α_k of [`section_nodes`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Section {
    alpha_max: f64,
    /// The nodes α_k = α(θ_k), θ_k = −θ_max + k Δθ, and g there.
    alpha: [f64; SECTION_NODES],
    g: [f64; SECTION_NODES],
    /// Cumulative trapezoid areas of g (the last is G).
    cumulative: [f64; SECTION_NODES - 1],
}

/// The horizon-clipped elevation interval [φ_lo, φ_hi] of the slice with h(α) and
/// n_t = n·ĉ_α, and n_t; `None` if it is empty.
#[inline]
fn slice_interval(view: &CylinderView, h: f64, nt: f64) -> Option<(f64, f64, f64)> {
    let (mut lo, mut hi) = view.phi_range(h);
    let ns = view.n_u;
    // n·ω(φ) = n_s sin φ + n_t cos φ vanishes at tan φ = −n_t/n_s on (−π/2, π/2).
    if ns != 0.0 {
        let mut phi0 = (-nt).atan2(ns);
        if phi0 > FRAC_PI_2 {
            phi0 -= PI;
        } else if phi0 < -FRAC_PI_2 {
            phi0 += PI;
        }
        if ns > 0.0 {
            lo = lo.max(phi0);
        } else {
            hi = hi.min(phi0);
        }
    } else if nt.is_nan() || nt <= 0.0 {
        return None;
    }
    (hi > lo).then_some((lo, hi, nt))
}

/// The slice's line-sampler core: the interval from φ_lo and T(α) = `core.total` (from the
/// angles; for the inverse and reference values, [`slice_of`] on the sampler's paths).
#[inline]
pub(crate) fn slice_core(view: &CylinderView, alpha: f64, h: f64) -> Option<(PsaCore<f64>, f64)> {
    let (lo, hi, nt) = slice_interval(view, h, view.n_t(alpha))?;
    let (s, c) = lo.sin_cos();
    Some((PsaCore::with_frame_values(view.n_u, nt, s, c, hi - lo)?, lo))
}

/// The live slice with h(α) = `h` and n_t = n·ĉ_α: its line-sampler core on the interval of
/// [`slice_interval`], formed from the unit vectors (sin φ, cos φ) of the ends and of the
/// horizon, e = (a or b, h)/|·| and (−n_t, n_s)·sgn n_s/|·|, rather than from their angles: the
/// only transcendental call is the atan2 of Δ/2 = atan2(|e_hi − e_lo|, |e_hi + e_lo|) (both
/// sums of squares: no cancellation), whose sin and cos are those lengths halved; it is
/// [`atan2_f64`] (relative error ≤ 3e-11: the interval's length is off by that much, and the
/// density stays the exact one of the interval sampled). `None` if the horizon-clipped
/// interval is empty.
#[inline]
pub(crate) fn slice_of(view: &CylinderView, h: f64, nt: f64) -> Option<PsaCore<f64>> {
    let ns = view.n_u;
    let unit = |e: f64| {
        let l = (e * e + h * h).sqrt();
        (e / l, h / l)
    };
    let (mut lo, mut hi) = (unit(view.a), unit(view.b));
    // n·ω(φ) = n_s sin φ + n_t cos φ vanishes at the horizon (cos φ ≥ 0); it is positive above
    // it for n_s > 0, below it for n_s < 0. There n·ω = 0 and d(n·ω)/dφ = |(n_s, n_t)|.
    let mut begin_on_horizon = None;
    if ns != 0.0 {
        let norm = (ns * ns + nt * nt).sqrt();
        let horizon = (-nt * ns.signum() / norm, ns.abs() / norm);
        if ns > 0.0 {
            if ns * lo.0 + nt * lo.1 < 0.0 {
                lo = horizon;
                begin_on_horizon = Some(norm);
            }
        } else if ns * hi.0 + nt * hi.1 < 0.0 {
            hi = horizon;
        }
    } else if nt.is_nan() || nt <= 0.0 {
        return None;
    }
    // sin Δ > 0: a non-empty interval (Δ < π, both ends in (−π/2, π/2)).
    let sin_width = hi.0 * lo.1 - hi.1 * lo.0;
    if sin_width.is_nan() || sin_width <= 0.0 {
        return None;
    }
    let sh = 0.5 * ((hi.0 - lo.0) * (hi.0 - lo.0) + (hi.1 - lo.1) * (hi.1 - lo.1)).sqrt();
    let ch = 0.5 * ((hi.0 + lo.0) * (hi.0 + lo.0) + (hi.1 + lo.1) * (hi.1 + lo.1)).sqrt();
    let width = 2.0 * atan2_f64(sh, ch);
    let p = match begin_on_horizon {
        Some(norm) => (0.0, norm),
        None => (ns.mul_add(lo.0, nt * lo.1), ns.mul_add(lo.1, -nt * lo.0)),
    };
    PsaCore::with_half_width(ns, nt, lo, width, (sh, ch), p)
}

/// T(α): twice the projected solid angle per unit azimuth of the slice at α.
pub(crate) fn slice_total(view: &CylinderView, alpha: f64, h: f64) -> Option<f64> {
    slice_core(view, alpha, h).map(|(core, _)| core.total)
}

/// The section density's nodes (α_k, sin α_k, cos α_k, h(α_k)) at the surface angles
/// θ_k = −θ_max + k θ_max/2: the silhouettes α = ±α_max (sin α = R/ρ, h = √(ρ² − R²)), the
/// point nearest x (h = ρ − R) and θ = ±θ_max/2, whose sin and cos follow from cos θ_max = R/ρ
/// by the half-angle formulas (one atan2 for the five nodes).
pub(crate) fn section_nodes(v: &CylinderView) -> [(f64, f64, f64, f64); SECTION_NODES] {
    const _: () = assert!(
        SECTION_NODES == 5,
        "the nodes are at θ_max·(−1, −½, 0, ½, 1)"
    );
    let (r, rho) = (v.radius, v.rho);
    let tangent = ((rho - r) * (rho + r)).sqrt();
    let cos_half = (0.5 * (1.0 + r / rho)).sqrt();
    let sin_half = 0.5 * (tangent / rho) / cos_half;
    let (hx, hy) = (rho - r * cos_half, r * sin_half);
    let h_half = (hx * hx + hy * hy).sqrt();
    let alpha_half = atan2_f64(hy, hx);
    let (sin_max, cos_max) = (r / rho, tangent / rho);
    [
        (-v.alpha_max, -sin_max, cos_max, tangent),
        (-alpha_half, -hy / h_half, hx / h_half, h_half),
        (0.0, 0.0, 1.0, rho - r),
        (alpha_half, hy / h_half, hx / h_half, h_half),
        (v.alpha_max, sin_max, cos_max, tangent),
    ]
}

impl CylinderProjected {
    #[inline]
    pub fn new(view: &CylinderView) -> Option<Self> {
        Self::with_iterations(view, DEFAULT_ITERATIONS)
    }

    /// With a given number of Halley steps of the line sampler (the paper's is 2).
    #[inline]
    pub fn with_iterations(view: &CylinderView, iterations: u32) -> Option<Self> {
        let v = view;
        let nodes = section_nodes(v);
        let m = nodes.map(|(_, sin, cos, h)| {
            slice_of(v, h, v.n_t_of(sin, cos)).map_or(0.0, |core| core.total)
        });
        Some(Self {
            view: *view,
            section: Section::new(v, &nodes, m)?,
            iterations,
        })
    }

    /// q(α): density of the azimuth of the sampled slice (per unit α; 0 off the section).
    pub fn azimuth_density(&self, alpha: f64) -> f64 {
        self.section.density(alpha)
    }
}

impl Section {
    /// From the values `m` of the slices at the `nodes` of [`section_nodes`]; `None` if G is
    /// not finite and positive.
    pub(crate) fn new(
        v: &CylinderView,
        nodes: &[(f64, f64, f64, f64); SECTION_NODES],
        m: [f64; SECTION_NODES],
    ) -> Option<Self> {
        let alpha = nodes.map(|node| node.0);
        let mean = m.iter().sum::<f64>() / SECTION_NODES as f64;
        // All nodes dead (a sliver above the horizon between them at most): uniform in θ.
        let floor = if mean > 0.0 { FLOOR * mean } else { 1.0 };
        let g = m.map(|mk| mk + floor);
        let mut cumulative = [0.0; SECTION_NODES - 1];
        let mut area = 0.0;
        for k in 0..SECTION_NODES - 1 {
            area += 0.5 * (g[k] + g[k + 1]) * (alpha[k + 1] - alpha[k]);
            cumulative[k] = area;
        }
        (area.is_finite() && area > 0.0).then_some(Self {
            alpha_max: v.alpha_max,
            alpha,
            g,
            cumulative,
        })
    }

    /// The interval of α and the fraction x ∈ [0, 1] of the way through it.
    #[inline]
    fn locate(&self, alpha: f64) -> (usize, f64) {
        let mut k = 0;
        while k + 1 < SECTION_NODES - 1 && alpha > self.alpha[k + 1] {
            k += 1;
        }
        let width = self.alpha[k + 1] - self.alpha[k];
        (k, ((alpha - self.alpha[k]) / width).clamp(0.0, 1.0))
    }

    /// q(α) (per unit α; 0 off the section).
    pub(crate) fn density(&self, alpha: f64) -> f64 {
        if alpha.is_nan() || alpha.abs() > self.alpha_max {
            return 0.0;
        }
        let (k, x) = self.locate(alpha);
        (self.g[k] * (1.0 - x) + self.g[k + 1] * x) / self.cumulative[SECTION_NODES - 2]
    }

    /// α for ξ ∈ [0, 1]: the interval by its area, then the linear density's CDF inverted.
    pub(crate) fn alpha_of_xi(&self, xi: f64) -> f64 {
        let total = self.cumulative[SECTION_NODES - 2];
        let target = xi * total;
        let mut k = 0;
        while k + 1 < SECTION_NODES - 1 && target > self.cumulative[k] {
            k += 1;
        }
        let start = if k == 0 { 0.0 } else { self.cumulative[k - 1] };
        // Area y = Δα (g₀ x + (g₁ − g₀) x²/2) on x ∈ [0, 1]: x = 2y' / (g₀ + √(g₀² + 2(g₁ − g₀)y'))
        // with y' = y/Δα (no cancellation: g₀ > 0).
        let width = self.alpha[k + 1] - self.alpha[k];
        let y = ((target - start) / width).max(0.0);
        let (g0, g1) = (self.g[k], self.g[k + 1]);
        let disc = (g0 * g0 + 2.0 * (g1 - g0) * y).max(0.0);
        let x = (2.0 * y / (g0 + disc.sqrt())).clamp(0.0, 1.0);
        (self.alpha[k] + x * width).clamp(-self.alpha_max, self.alpha_max)
    }

    /// The section's CDF at α (inverse of [`Self::alpha_of_xi`]).
    pub(crate) fn xi_of_alpha(&self, alpha: f64) -> f64 {
        let (k, x) = self.locate(alpha);
        let start = if k == 0 { 0.0 } else { self.cumulative[k - 1] };
        let (g0, g1) = (self.g[k], self.g[k + 1]);
        let width = self.alpha[k + 1] - self.alpha[k];
        let area = start + width * (g0 * x + 0.5 * (g1 - g0) * x * x);
        (area / self.cumulative[SECTION_NODES - 2]).clamp(0.0, 1.0)
    }
}

impl CylinderSampler for CylinderProjected {
    fn sample_with_pdf(&self, xi: [f32; 2]) -> Option<(DVec3, f64)> {
        self.sample_toward(xi).map(|s| (s.dir, s.pdf))
    }

    fn pdf(&self, dir: DVec3) -> f64 {
        self.pdf_toward(dir).map_or(0.0, |(p, _)| p)
    }

    /// The sample, its density and distance from the slice's own values: (sin φ, cos φ, n·ω)
    /// at the sample from the line sampler's solve (n·ω accurate near a clipped end, not the
    /// rounded n·dir), the distance h/cos φ.
    fn sample_toward(&self, xi: [f32; 2]) -> Option<CylinderSample> {
        let v = &self.view;
        let alpha = self.section.alpha_of_xi(clamp_xi(xi[0]));
        let at: SliceAt = v.slice_at(alpha);
        let core = slice_of(v, at.h, at.n_t)?;
        let (_, (s, t, n_dot_w)) = core.solve_with_values(clamp_xi(xi[1]), self.iterations);
        let dir = t * (at.cos * v.c + at.sin * v.w) + s * v.u;
        let pdf = self.azimuth_density(alpha) * 2.0 * n_dot_w.max(0.0) / core.total;
        CylinderSample::checked(dir, pdf, at.h / t)
    }

    /// The hit by the view's `front_hit`, then the slice's density there.
    fn pdf_toward(&self, dir: DVec3) -> Option<(f64, f64)> {
        let hit = self.view.front_hit(dir)?;
        let p = match slice_of(&self.view, hit.slice.h, hit.slice.n_t) {
            Some(core) => {
                self.azimuth_density(hit.slice.alpha) * 2.0 * hit.n_dot_w.max(0.0) / core.total
            }
            None => 0.0,
        };
        Some((p, hit.distance))
    }

    fn inverse(&self, dir: DVec3) -> Option<[f64; 2]> {
        let v = &self.view;
        let (alpha, phi, h) = v.hit(dir)?;
        let (core, lo) = slice_core(v, alpha, h)?;
        Some([self.section.xi_of_alpha(alpha), core.cdf(phi - lo)])
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

    #[test]
    fn normalised_to_the_live_slices_and_consistent() {
        for (cyl, x, n) in configs() {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            let s = CylinderProjected::new(&v).unwrap();
            let total = integrate(&v, &mut |a, p| s.pdf(v.direction(a, p)));
            // Mass of the live slices: ∫ q(α) [T(α) > 0] dα, in θ.
            let live = {
                let nodes = gauss_legendre(24);
                let mut m = 0.0;
                let panels = 16;
                let wdt = 2.0 * v.theta_max / panels as f64;
                for k in 0..panels {
                    for &(x, wt) in &nodes {
                        let th = -v.theta_max + wdt * (k as f64 + 0.5 * (x + 1.0));
                        let (a, j) = v.alpha_of_theta(th);
                        if slice_total(&v, a, v.h(a)).is_some() {
                            m += 0.5 * wdt * wt * j * s.azimuth_density(a);
                        }
                    }
                }
                m
            };
            assert!(
                (total - live).abs() < 1e-6,
                "{total} {live} R = {}",
                cyl.radius
            );
            for i in 0..=10 {
                for j in 0..=10 {
                    let xi = [i as f32 / 10.0, j as f32 / 10.0];
                    let Some((dir, p)) = s.sample_with_pdf(xi) else {
                        continue;
                    };
                    // At the silhouette (i = 0, 10) and the ends the rebuilt angles may round out.
                    let edge = i == 0 || i == 10 || j == 0 || j == 10;
                    let q = s.pdf(dir);
                    assert!((p - q).abs() <= 1e-9 * p || edge, "{p} {q} {i} {j}");
                    let Some(back) = s.inverse(dir) else {
                        assert!(edge);
                        continue;
                    };
                    assert!((back[0] - xi[0] as f64).abs() < 1e-9);
                    assert!((back[1] - xi[1] as f64).abs() < 3e-5, "{back:?} {xi:?}");
                }
            }
        }
    }

    /// A diffuse receiver under a long tube whose whole front is above the horizon: the
    /// estimate L (n·ω)/p is T(α)/(2q) — constant only where T does not depend on α.
    #[test]
    fn thin_tube_estimate_is_the_projected_solid_angle() {
        let cyl =
            Cylinder::new(DVec3::new(-1.0, 0.0, 1.0), DVec3::new(1.0, 0.0, 1.0), 1e-4).unwrap();
        let v = CylinderView::new(&cyl, DVec3::ZERO, DVec3::Z).unwrap();
        let s = CylinderProjected::new(&v).unwrap();
        let reference = v.projected_solid_angle_quadrature(4, &gauss_legendre(16));
        // Line limit: Ω⊥ → R·Ω⊥_R with Ω⊥_R = 1 + π/2 (the sanity line of the line techniques).
        assert!((reference / (1e-4 * (1.0 + FRAC_PI_2)) - 1.0).abs() < 1e-3);
        for i in 0..16 {
            let (dir, p) = s.sample_with_pdf([i as f32 / 15.0, 0.37]).unwrap();
            let est = dir.dot(v.n) / p;
            assert!((est / reference - 1.0).abs() < 1e-3, "{est} {reference}");
        }
    }
}
