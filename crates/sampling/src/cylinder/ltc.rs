//! LTC across the section: the azimuth α from a piecewise-linear density q fitted to the LTC
//! mass of the slices, then the elevation by the paper's LTC line sampler on the slice at α
//! (docs/cylinders.md, "LTC across the section").
//!
//! A (shading frame x̂, ŷ, n → cosine space) is the GGX lobe's linearly transformed cosine,
//! D(ω) = |det A| (Aω)_z⁺ / (π |Aω|⁴) per steradian. The slice at α is the segment
//! P(l) = h ĉ_α + l u, l ∈ [a, b] (relative to x); its image A P(l) = P₀ + l V (P₀ = A h ĉ_α,
//! V = A u) is again a segment, with the same parameter l. The LTC line sampler draws l with
//! density ∝ (A P)_z / |A P|⁴ per dl: technique 8 on the image, whose density in the image
//! line's elevation φ_o is ∝ z_o = n_{s,o} sin φ_o + n_{t,o} cos φ_o (normal (0, 0, 1)).
//! W.r.t. ds (s = sin φ on the slice, dΩ = dα ds) that is D(ω)/M(α) with the slice's LTC mass
//!
//! ```text
//! M(α) = ∫ D ds = |det A| h² T_o / (2π d_o² |V|),   T_o = C_o(φ_o,hi) − C_o(φ_o,lo),
//! ```
//!
//! d_o the distance of the image line from the origin and C_o the antiderivative of technique
//! 8 on it, on the part of the slice with n·ω ≥ 0 and (Aω)_z ≥ 0 (both linear in l). So the
//! composed direction has the density per steradian q(α) · D(ω)/M(α) = q(α) · p_R · 2/h(α),
//! p_R the line sampler's density per radius. Everything is in f64 in the view's frame: the
//! images of ĉ, w and u are formed once per shading point, a slice costs one arctangent.
//!
//! Defensive fraction β ([`DEFENSIVE`]): with probability β the elevation is drawn by ours'
//! projected-solid-angle slice instead, so the density is
//! q(α) · [(1 − β) D(ω)/M(α) + β · 2 (n·ω)⁺/T(α)]: positive wherever n·ω > 0 on the front,
//! also beyond the lobe's own horizon (Aω)_z = 0, where a GGX surface still reflects. For
//! A = identity both terms are 2 (n·ω)/T(α) and q is ours': the technique is ours (projected)
//! in distribution. A slice without LTC mass (M = 0) returns no sample from the LTC branch, an
//! estimate of 0 for the probability (1 − β) q(α) dα, which its density accounts for.

use super::projected::{section_nodes, slice_of, Section};
use super::{clamp_xi, CylinderSample, CylinderSampler, CylinderView, SliceAt};
use crate::projected_solid_angle::{PsaCore, DEFAULT_ITERATIONS};
use crate::trig::atan2_f64;
use glam::{DMat3, DVec3};

/// Probability of the projected-solid-angle slice sampler in the mixture (module docs).
pub const DEFENSIVE: f64 = 0.1;
/// Largest accepted ‖A‖³/|det A| (that of the LTC line sampler).
const MAX_ILL_CONDITION: f64 = 1e7;

/// The view's frame in cosine space: A ĉ, A w, A u (world → shading → cosine space).
#[derive(Clone, Copy, Debug)]
struct Lobe {
    c: DVec3,
    w: DVec3,
    u: DVec3,
    /// |A u| and A u/|A u|.
    u_len: f64,
    u_hat: DVec3,
    /// |det A|/π.
    det_over_pi: f64,
}

impl Lobe {
    fn new(view: &CylinderView, frame: DMat3, a: DMat3) -> Option<Self> {
        let det = a.determinant().abs();
        let norm = a.to_cols_array().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if !(det.is_finite() && det * MAX_ILL_CONDITION > norm * norm * norm) {
            return None;
        }
        let m = a * frame.transpose();
        let (c, w, u) = (m * view.c, m * view.w, m * view.u);
        let u_len = u.length();
        (c.is_finite() && w.is_finite() && u_len > 0.0 && u_len.is_finite()).then(|| Self {
            c,
            w,
            u,
            u_len,
            u_hat: u / u_len,
            det_over_pi: det * std::f64::consts::FRAC_1_PI,
        })
    }
}

/// The LTC part of a slice: technique 8 on the image segment, σ_o = P₀·V̂ and d_o (the image
/// line's foot), and 2 d_o² |V| / (h² T_o) = |det A|/(π M(α)).
#[derive(Clone, Copy, Debug)]
struct LtcPart {
    core: PsaCore<f64>,
    sigma: f64,
    d: f64,
    scale: f64,
}

/// Clips [lo, hi] to c₀ + l c₁ ≥ 0; whether lo moved. Empty (hi < lo) if c₁ = 0 and c₀ < 0.
#[inline]
fn clip(lo: &mut f64, hi: &mut f64, c0: f64, c1: f64) -> bool {
    if c1 > 0.0 {
        let l = -c0 / c1;
        if l > *lo {
            *lo = l;
            return true;
        }
    } else if c1 < 0.0 {
        *hi = hi.min(-c0 / c1);
    } else if c0.is_nan() || c0 < 0.0 {
        *hi = f64::NEG_INFINITY;
    }
    false
}

impl LtcPart {
    /// The LTC part of the slice `at`: the parameter interval clipped to n·ω ≥ 0 and
    /// (Aω)_z ≥ 0, its ends as unit vectors (t_o, d_o)/|·| of the image line (one arctangent
    /// for the width, as ours' slices). `None` if it carries no LTC mass.
    fn new(view: &CylinderView, lobe: &Lobe, at: &SliceAt) -> Option<Self> {
        let h = at.h;
        let p0 = h * (at.cos * lobe.c + at.sin * lobe.w);
        let sigma = p0.dot(lobe.u_hat);
        let foot = p0 - sigma * lobe.u_hat;
        let d = foot.length();
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let (ns, nt) = (lobe.u_hat.z, foot.z / d);
        let (mut lo, mut hi) = (view.a, view.b);
        clip(&mut lo, &mut hi, h * at.n_t, view.n_u);
        let on_lobe_horizon = clip(&mut lo, &mut hi, p0.z, lobe.u.z);
        if hi.is_nan() || hi <= lo {
            return None;
        }
        let unit = |l: f64| {
            let t = sigma + l * lobe.u_len;
            let r = (t * t + d * d).sqrt();
            (t / r, d / r)
        };
        let (e_lo, e_hi) = (unit(lo), unit(hi));
        let sh = 0.5 * ((e_hi.0 - e_lo.0).powi(2) + (e_hi.1 - e_lo.1).powi(2)).sqrt();
        let ch = 0.5 * ((e_hi.0 + e_lo.0).powi(2) + (e_hi.1 + e_lo.1).powi(2)).sqrt();
        let width = 2.0 * atan2_f64(sh, ch);
        let p = if on_lobe_horizon {
            (0.0, (ns * ns + nt * nt).sqrt())
        } else {
            (ns * e_lo.0 + nt * e_lo.1, ns * e_lo.1 - nt * e_lo.0)
        };
        let core = PsaCore::with_half_width(ns, nt, e_lo, width, (sh, ch), p)?;
        let scale = 2.0 * d * d * lobe.u_len / (h * h * core.total);
        (scale.is_finite() && scale > 0.0).then_some(Self {
            core,
            sigma,
            d,
            scale,
        })
    }
}

/// The LTC across the section prepared at a shading point (module documentation).
#[derive(Clone, Copy, Debug)]
pub struct CylinderLtc {
    view: CylinderView,
    lobe: Lobe,
    section: Section,
    defensive: f64,
    iterations: u32,
}

/// One slice prepared: what the density along it and a sample on it need, formed once per
/// azimuth ([`CylinderLtc::slice`]).
#[derive(Clone, Copy, Debug)]
pub struct LtcSlice {
    at: SliceAt,
    /// q(α).
    q: f64,
    /// A ĉ_α.
    a_c: DVec3,
    ltc: Option<LtcPart>,
    /// Ours' slice (technique 8 on the slice itself).
    projected: Option<PsaCore<f64>>,
}

impl CylinderLtc {
    /// For the LTC matrix `a` of the shading frame `frame` (columns x̂, ŷ, n; world), with the
    /// defensive fraction [`DEFENSIVE`]. `None` if A is singular, ill-conditioned (as the LTC
    /// line sampler refuses it) or not finite, or the section has no mass.
    #[inline]
    pub fn new(view: &CylinderView, frame: DMat3, a: DMat3) -> Option<Self> {
        Self::with_options(view, frame, a, DEFENSIVE, DEFAULT_ITERATIONS)
    }

    /// With a defensive fraction β ∈ [0, 1] and a number of Halley steps of the line samplers.
    #[inline]
    pub fn with_options(
        view: &CylinderView,
        frame: DMat3,
        a: DMat3,
        defensive: f64,
        iterations: u32,
    ) -> Option<Self> {
        debug_assert!((0.0..=1.0).contains(&defensive), "β = {defensive}");
        let lobe = Lobe::new(view, frame, a)?;
        let nodes = section_nodes(view);
        let m = nodes.map(|(alpha, sin, cos, h)| {
            let at = SliceAt {
                alpha,
                sin,
                cos,
                h,
                n_t: view.n_t_of(sin, cos),
            };
            LtcPart::new(view, &lobe, &at).map_or(0.0, |p| 1.0 / p.scale)
        });
        Some(Self {
            view: *view,
            lobe,
            section: Section::new(view, &nodes, m)?,
            defensive,
            iterations,
        })
    }

    /// q(α): density of the azimuth (per unit α; 0 off the section).
    pub fn azimuth_density(&self, alpha: f64) -> f64 {
        self.section.density(alpha)
    }

    /// The azimuth measure the samples carry at α: q(α) · [(1 − β) [M(α) > 0] + β [T(α) > 0]]
    /// (∫ p dΩ is its integral over α: a slice without mass in a branch yields no sample there).
    pub fn live_mass(&self, alpha: f64) -> f64 {
        let s = self.slice(alpha);
        let b = self.defensive;
        s.q * ((1.0 - b) * s.ltc.is_some() as u8 as f64 + b * s.projected.is_some() as u8 as f64)
    }

    /// The slice at azimuth α (|α| ≤ α_max).
    pub fn slice(&self, alpha: f64) -> LtcSlice {
        self.slice_from(self.view.slice_at(alpha))
    }

    fn slice_from(&self, at: SliceAt) -> LtcSlice {
        let v = &self.view;
        LtcSlice {
            at,
            q: self.section.density(at.alpha),
            a_c: at.cos * self.lobe.c + at.sin * self.lobe.w,
            ltc: LtcPart::new(v, &self.lobe, &at),
            projected: slice_of(v, at.h, at.n_t),
        }
    }

    /// The LTC's density D(ω) = |det A| (Aω)_z⁺/(π |Aω|⁴) of a direction above the horizon of
    /// n (0 below it): the lobe this technique follows.
    pub fn lobe_density(&self, dir: DVec3) -> f64 {
        let dir = dir.normalize_or_zero();
        let n_dot_w = self.view.n.dot(dir);
        if n_dot_w.is_nan() || n_dot_w <= 0.0 {
            return 0.0;
        }
        let l = &self.lobe;
        let aw =
            dir.dot(self.view.c) * l.c + dir.dot(self.view.w) * l.w + dir.dot(self.view.u) * l.u;
        let len2 = aw.length_squared();
        let p = l.det_over_pi * aw.z.max(0.0) / (len2 * len2);
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    /// M(α) = ∫ D ds over the slice at α (closed form; 0 for a slice without LTC mass).
    pub fn slice_lobe_mass(&self, alpha: f64) -> f64 {
        LtcPart::new(&self.view, &self.lobe, &self.view.slice_at(alpha))
            .map_or(0.0, |p| self.lobe.det_over_pi / p.scale)
    }
}

impl LtcSlice {
    /// The density per steradian of the direction with (sin φ, cos φ) = (s, t) on this slice
    /// (within its ends), n·ω = `n_dot_w`.
    #[inline]
    fn density_at(&self, c: &CylinderLtc, s: f64, t: f64, n_dot_w: f64) -> f64 {
        if n_dot_w.is_nan() || n_dot_w <= 0.0 {
            return 0.0;
        }
        let ltc = self.ltc.map_or(0.0, |part| {
            let aw = t * self.a_c + s * c.lobe.u;
            let len2 = aw.length_squared();
            part.scale * aw.z.max(0.0) / (len2 * len2)
        });
        let projected = self
            .projected
            .map_or(0.0, |core| 2.0 * n_dot_w / core.total);
        let p = self.q * ((1.0 - c.defensive) * ltc + c.defensive * projected);
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    /// The density per steradian at elevation φ on this slice (between its ends).
    #[inline]
    pub fn density(&self, c: &CylinderLtc, phi: f64) -> f64 {
        let (s, t) = phi.sin_cos();
        let v = &c.view;
        self.density_at(c, s, t, v.n_u * s + self.at.n_t * t)
    }

    /// (sin φ, cos φ, n·ω) of the sample for ξ ∈ [0, 1] on the LTC part: technique 8 on the
    /// image line, mapped back by A⁻¹ (the image of (cos φ_o, sin φ_o) is ∝ h|V| cos φ_o ĉ_α +
    /// (d_o sin φ_o − σ_o cos φ_o) u).
    fn sample_ltc(&self, c: &CylinderLtc, part: &LtcPart, xi: f64) -> (f64, f64, f64) {
        let (_, (so, to, _)) = part.core.solve_with_values(xi, c.iterations);
        let x_c = self.at.h * c.lobe.u_len * to;
        let x_u = part.d * so - part.sigma * to;
        let r = (x_c * x_c + x_u * x_u).sqrt();
        let (s, t) = (x_u / r, x_c / r);
        (s, t, c.view.n_u * s + self.at.n_t * t)
    }
}

impl CylinderSampler for CylinderLtc {
    fn sample_with_pdf(&self, xi: [f32; 2]) -> Option<(DVec3, f64)> {
        self.sample_toward(xi).map(|s| (s.dir, s.pdf))
    }

    fn pdf(&self, dir: DVec3) -> f64 {
        self.pdf_toward(dir).map_or(0.0, |(p, _)| p)
    }

    /// ξ₁ < β: ours' slice with ξ₁/β; otherwise the LTC part with (ξ₁ − β)/(1 − β).
    fn sample_toward(&self, xi: [f32; 2]) -> Option<CylinderSample> {
        let v = &self.view;
        let alpha = self.section.alpha_of_xi(clamp_xi(xi[0]));
        let slice = self.slice_from(v.slice_at(alpha));
        let (x1, beta) = (clamp_xi(xi[1]), self.defensive);
        let (s, t, n_dot_w) = if x1 < beta {
            let core = slice.projected?;
            core.solve_with_values(x1 / beta, self.iterations).1
        } else {
            let part = slice.ltc?;
            let y = ((x1 - beta) / (1.0 - beta)).min(1.0);
            slice.sample_ltc(self, &part, y)
        };
        let at = &slice.at;
        let dir = t * (at.cos * v.c + at.sin * v.w) + s * v.u;
        let pdf = slice.density_at(self, s, t, n_dot_w.max(0.0));
        CylinderSample::checked(dir, pdf, at.h / t)
    }

    /// The hit by the view's `front_hit`, then the slice's density there.
    fn pdf_toward(&self, dir: DVec3) -> Option<(f64, f64)> {
        let hit = self.view.front_hit(dir)?;
        let slice = self.slice_from(hit.slice);
        let p = slice.density_at(self, hit.s, hit.t, hit.n_dot_w);
        Some((p, hit.distance))
    }

    fn view(&self) -> &CylinderView {
        &self.view
    }
}

#[cfg(test)]
mod tests {
    use super::super::projected::CylinderProjected;
    use super::super::test_support::*;
    use super::super::CylinderView;
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// A shading frame (x̂ toward the view's tangential part, ŷ = n × x̂, n).
    fn frame(n: DVec3) -> DMat3 {
        let n = n.normalize();
        let (x, y) = n.any_orthonormal_pair();
        DMat3::from_cols(x, y, n)
    }

    /// An isotropic LTC form (rows [[a,0,b],[0,c,0],[d,0,1]]) of a glossy lobe.
    fn glossy() -> DMat3 {
        DMat3::from_cols(
            DVec3::new(0.3, 0.0, -0.05),
            DVec3::new(0.0, 0.35, 0.0),
            DVec3::new(0.1, 0.0, 1.0),
        )
    }

    /// With A = identity the density is ours' everywhere and the samples are ours' (the
    /// projected branch is ours' sampler; the LTC branch draws the same slice density).
    #[test]
    fn identity_is_ours_in_distribution() {
        for (cyl, x, n) in configs() {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            let ours = CylinderProjected::new(&v).unwrap();
            let ltc = CylinderLtc::new(&v, frame(v.n), DMat3::IDENTITY).unwrap();
            for i in 0..=16 {
                for j in 0..=16 {
                    let dir = v.direction(
                        v.alpha_max * (i as f64 / 8.0 - 1.0) * 0.999,
                        (j as f64 / 16.0 - 0.5) * 3.0,
                    );
                    let (p, q) = (ours.pdf(dir), ltc.pdf(dir));
                    assert!((p - q).abs() <= 1e-9 * p.max(q), "{p} {q}");
                }
            }
            // The LTC branch (β = 0) draws ours' sample for the same ξ, up to the solve.
            let pure = CylinderLtc::with_options(&v, frame(v.n), DMat3::IDENTITY, 0.0, 2).unwrap();
            for i in 1..10 {
                let xi = [i as f32 / 10.0, 0.1 * i as f32 - 0.05];
                let (a, b) = (ours.sample_with_pdf(xi), pure.sample_with_pdf(xi));
                match (a, b) {
                    (Some((da, pa)), Some((db, pb))) => {
                        assert!((da - db).length() < 1e-6, "{da} {db}");
                        assert!((pa - pb).abs() < 1e-6 * pa, "{pa} {pb}");
                    }
                    (None, None) => {}
                    _ => panic!("{a:?} {b:?}"),
                }
            }
        }
    }

    /// The slice's elevation range split at the horizons of n and of the lobe (the density
    /// jumps at the first and has a kink at the second).
    fn pieces(v: &CylinderView, s: &CylinderLtc, alpha: f64) -> Vec<(f64, f64)> {
        let (pa, pb) = v.phi_range(v.h(alpha));
        let fold = |h: f64| {
            if h > FRAC_PI_2 {
                h - PI
            } else if h < -FRAC_PI_2 {
                h + PI
            } else {
                h
            }
        };
        let a_c = s.slice(alpha).a_c;
        let mut cuts = vec![
            pa,
            pb,
            fold((-v.n_t(alpha)).atan2(v.n_u)),
            fold((-a_c.z).atan2(s.lobe.u.z)),
        ];
        cuts.retain(|&c| c >= pa && c <= pb);
        cuts.sort_by(f64::total_cmp);
        cuts.windows(2).map(|w| (w[0], w[1])).collect()
    }

    /// ∫ p dΩ = (1 − β) ∫ q [M > 0] dα + β ∫ q [T > 0] dα; the slice masses in closed form
    /// against quadrature of D; samples carry their own pdf. Quadrature: θ-panels × 16 φ-panels
    /// of 8 nodes per piece of [`pieces`].
    #[test]
    fn normalised_and_consistent_for_a_glossy_lobe() {
        for (cyl, x, n) in configs() {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            let s = CylinderLtc::new(&v, frame(v.n), glossy()).unwrap();
            let (mut total, mut lobe, mut live, mut closed) = (0.0, 0.0, 0.0, 0.0);
            let (nodes, fine) = (gauss_legendre(24), gauss_legendre(8));
            let panels = 16;
            let wdt = 2.0 * v.theta_max / panels as f64;
            for k in 0..panels {
                for &(x, wt) in &nodes {
                    let th = -v.theta_max + wdt * (k as f64 + 0.5 * (x + 1.0));
                    let (a, j) = v.alpha_of_theta(th);
                    let sl = s.slice(a);
                    let w = 0.5 * wdt * wt * j;
                    live += w
                        * s.azimuth_density(a)
                        * ((1.0 - DEFENSIVE) * sl.ltc.is_some() as u8 as f64
                            + DEFENSIVE * sl.projected.is_some() as u8 as f64);
                    closed += w * s.slice_lobe_mass(a);
                    for (p, q) in pieces(&v, &s, a) {
                        let step = (q - p) / 16.0;
                        for m in 0..16 {
                            for &(y, wy) in &fine {
                                let phi = p + step * (m as f64 + 0.5 * (y + 1.0));
                                let c = w * 0.5 * step * wy * phi.cos();
                                total += c * sl.density(&s, phi);
                                lobe += c * s.lobe_density(v.direction(a, phi));
                            }
                        }
                    }
                }
            }
            assert!((total - live).abs() < 1e-6, "{total} {live}");
            assert!(
                (lobe - closed).abs() < 1e-6 * lobe.max(1e-3),
                "{lobe} {closed}"
            );
            for i in 0..=10 {
                for j in 0..=10 {
                    let xi = [i as f32 / 10.0, j as f32 / 10.0];
                    let Some((dir, p)) = s.sample_with_pdf(xi) else {
                        continue;
                    };
                    let edge = i == 0 || i == 10 || j == 0 || j == 10;
                    let q = s.pdf(dir);
                    assert!((p - q).abs() <= 1e-9 * p || edge, "{p} {q} {i} {j}");
                    let (alpha, phi) = v.angles(dir);
                    let r = s.slice(alpha).density(&s, phi);
                    assert!((r - q).abs() <= 1e-9 * q || edge, "{r} {q}");
                }
            }
        }
    }
}
