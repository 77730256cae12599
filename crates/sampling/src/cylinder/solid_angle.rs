//! Uniform solid-angle sampling of the visible side: p = 1/Ω on every direction that hits the
//! front, 0 elsewhere (no horizon clipping; samples below it contribute 0).
//!
//! Gamito (EGSR 2016, "Solid Angle Sampling of Disk and Cylinder Lights") samples the
//! cylinder's solid angle uniformly. This is an exact uniform solid-angle sampler derived here
//! (docs/cylinders.md), not a transcription of that paper: in (α, s = sin φ) the solid angle is
//! dΩ = dα ds, and the visible side is the region |α| ≤ α_max, s_a(α) ≤ s ≤ s_b(α) with
//! s_e(α) = e/√(h(α)² + e²) (e = a, b). Uniform points of that region are uniform directions.
//!
//! - Ω = ∫ (s_b − s_a) dα has no elementary closed form (elliptic integrals). It is integrated
//!   by Gauss–Legendre in u = tan(θ/2) of the surface angle θ (α(θ) is smooth,
//!   dα/dθ = R(ρ cos θ − R)/h², and rational in u; in α the integrand has a square-root edge at
//!   α_max), mapped by u = u_s sinh t onto the scale u_s on which h grows near the tube, on
//!   panels of t ∈ [0, t_max] no wider than [`PANEL_WIDTH`] of 8 nodes each: 16 evaluations of
//!   arithmetic and two square roots per side beyond ρ ≈ 3.2 R, 32 down to 1.16 R, 48 down
//!   to 1.02 R, at most [`MAX_PANELS`] panels; sinh and cosh of the nodes from one `exp_m1` per panel and
//!   four more by the addition theorems. With both ends on one side of x's foot, s_b − s_a is
//!   formed without cancellation. The tests bound its relative error by 1e-9 against a graded
//!   reference on a grid of shading points from ρ = (1 + 1e-6) R to 1e4 R, close to the rims
//!   and far beyond the ends included.
//! - Sampling is by rejection from an envelope of [`BANDS`] boxes per side in (α, s): on the
//!   band between the surface angles θ_k, θ_{k+1}, h is monotone, so s_b is largest and s_a
//!   smallest at one of the band's ends. A box is chosen by its area, a point uniform in it,
//!   and accepted if it hits. The first candidate uses ξ; later ones come from a PCG32 stream
//!   keyed by the bits of ξ (a deterministic function of ξ, independent of the first
//!   candidate's acceptance). No inverse exists (rejection).

use super::{reject_until_accepted, CylinderSample, CylinderSampler, CylinderView};
use glam::DVec3;
use linlight_simd::{dispatch, Isa, Kernel};

/// Bands of the surface angle per side of the visible arc: the envelope's boxes.
pub const BANDS: usize = 8;
/// Widest panel of Ω's quadrature variable t (u = u_s sinh t), with the 8-point
/// Gauss–Legendre rule on each: one panel where t_max ≤ 1 (ρ ≳ 3.2 R), more closer to the tube.
pub const PANEL_WIDTH: f64 = 1.0;
/// Most panels per side for Ω (t_max ≤ 8 covers ρ − R ≥ 1e-6 R).
pub const MAX_PANELS: usize = 8;
/// Most candidates per sample; the acceptance rate is ≥ 0.5 on the tests' configurations (0.52
/// with x 1e-4 R from a rim, ≥ 0.74 elsewhere), so
/// the chance of reaching this is below 1e-300.
const MAX_CANDIDATES: usize = 2000;

/// 8-point Gauss–Legendre nodes and weights on [0, 1] (the positive half of the symmetric rule).
pub(crate) const GL8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

#[derive(Clone, Copy, Debug)]
pub struct CylinderSolidAngle {
    view: CylinderView,
    /// 1/Ω.
    inv_omega: f64,
    /// Per band: α at its inner end, its α-width, s range of its box, cumulative box area.
    alpha: [f64; BANDS],
    width: [f64; BANDS],
    s_lo: [f64; BANDS],
    s_hi: [f64; BANDS],
    cumulative: [f64; BANDS],
}

/// sinh and cosh of x ≥ 0 from one `exp_m1` (relative error a few ulps, also for small x).
#[inline]
fn sinh_cosh(x: f64) -> (f64, f64) {
    let m = x.exp_m1();
    let e2 = 2.0 * (m + 1.0);
    (m * (m + 2.0) / e2, 1.0 + m * m / e2)
}

/// The nodes of one panel of [`for_sinh_panels`] in the order of the rule's terms: sinh t,
/// cosh t and the weight of each.
pub(crate) struct PanelNodes {
    pub sinh: [f64; PANEL_NODES],
    pub cosh: [f64; PANEL_NODES],
    pub wt: [f64; PANEL_NODES],
}

/// Nodes per panel of [`for_sinh_panels`].
pub(crate) const PANEL_NODES: usize = 2 * GL8.len();

/// The 8-point Gauss–Legendre rule on `panels` equal panels of t ∈ [0, t_max]: calls `f` once
/// per panel with its nodes, in the order the rule's terms are summed (per half-offset d, the
/// node mid − d, then mid + d). sinh and cosh of the nodes mid ± d come from those of the panel
/// middles and of the four half-offsets d by the addition theorems (one `exp_m1` per panel and
/// per offset instead of two functions per node); every term is formed from values of relative
/// error a few ulps, so sinh t keeps a relative error of a few ulps times mid/t ≤ 1/(1 − x₄) ≈
/// 25 at the innermost node.
#[inline]
pub(crate) fn for_sinh_panels(t_max: f64, panels: usize, mut f: impl FnMut(&PanelNodes)) {
    let panel = t_max / panels as f64;
    let offsets = GL8.map(|(x, wt)| (sinh_cosh(0.5 * panel * x), 0.5 * panel * wt));
    let mut nodes = PanelNodes {
        sinh: [0.0; PANEL_NODES],
        cosh: [0.0; PANEL_NODES],
        wt: [0.0; PANEL_NODES],
    };
    for k in 0..panels {
        let (sm, cm) = sinh_cosh((k as f64 + 0.5) * panel);
        for (i, &((sd, cd), wt)) in offsets.iter().enumerate() {
            nodes.sinh[2 * i] = sm * cd - cm * sd;
            nodes.cosh[2 * i] = cm * cd - sm * sd;
            nodes.sinh[2 * i + 1] = sm * cd + cm * sd;
            nodes.cosh[2 * i + 1] = cm * cd + sm * sd;
            (nodes.wt[2 * i], nodes.wt[2 * i + 1]) = (wt, wt);
        }
        f(&nodes);
    }
}

/// Ω of the visible side: ∫ (s_b − s_a) dα, integrated in u = tan(θ/2) (relative error ≤ 1e-9;
/// see the module documentation).
pub(crate) fn solid_angle_of(v: &CylinderView) -> f64 {
    // In u = tan(θ/2) ∈ [0, u_max], u_max = √((ρ − R)/(ρ + R)), with q = u²:
    // dθ = 2 du/(1 + q), h² = ((ρ − R)² + (ρ + R)² q)/(1 + q) and
    // dα/dθ = R(ρ cos θ − R)/h² = R((ρ − R) − (ρ + R) q)/((ρ − R)² + (ρ + R)² q): rational in u,
    // no trigonometric function per node. Then u = u_s sinh t, u_s = (ρ − R)/(2√(ρR)), the
    // scale on which h grows from its least value ρ − R (near the tube the integrand is
    // concentrated there); panels of t of width ≤ [`PANEL_WIDTH`] (at most [`MAX_PANELS`]),
    // the 8-point Gauss–Legendre rule on each.
    let (gap, sum) = (v.rho - v.radius, v.rho + v.radius);
    let u_s = 0.5 * gap / (v.rho * v.radius).sqrt();
    // u_max/u_s = 2√(ρR/((ρ − R)(ρ + R))).
    let t_max = (2.0 * (v.rho * v.radius / (gap * sum)).sqrt()).asinh();
    let panels = ((t_max / PANEL_WIDTH).ceil() as usize).clamp(1, MAX_PANELS);
    let (gap2, sum2, a2, b2) = (gap * gap, sum * sum, v.a * v.a, v.b * v.b);
    let terms = OmegaTerms {
        u_s,
        gap,
        sum,
        gap2,
        sum2,
        a2,
        b2,
        a: v.a,
        b: v.b,
        radius: v.radius,
    };
    2.0 * sum_sinh_rule(t_max, panels, terms)
}

/// Σ `terms` over the nodes of [`for_sinh_panels`] (`t_max`, `panels`), panel by panel in the
/// CPU's widest kernel ([`PanelTerms`]), added in the rule's order.
#[inline]
pub(crate) fn sum_sinh_rule<T: NodeTerm + Copy>(t_max: f64, panels: usize, terms: T) -> f64 {
    let isa = Isa::detect();
    let mut sum = 0.0;
    for_sinh_panels(t_max, panels, |nodes| {
        for term in dispatch(isa, PanelTerms { terms, nodes }) {
            sum += term;
        }
    });
    sum
}

/// The per-node terms of [`solid_angle_of`]'s rule: what they need of the view.
#[derive(Clone, Copy)]
struct OmegaTerms {
    u_s: f64,
    gap: f64,
    sum: f64,
    gap2: f64,
    sum2: f64,
    a2: f64,
    b2: f64,
    a: f64,
    b: f64,
    radius: f64,
}

impl NodeTerm for OmegaTerms {
    /// The term of the node t (sinh t, cosh t, weight): weight × du/dt × dθ/du × dα/dθ ×
    /// (s_b − s_a).
    #[inline(always)]
    fn term(&self, sinh: f64, cosh: f64, wt: f64) -> f64 {
        let u = self.u_s * sinh;
        let q = u * u;
        let inv_1q = 1.0 / (1.0 + q);
        let num = self.gap2 + self.sum2 * q;
        let h2 = num * inv_1q;
        let jac = self.radius * (self.gap - self.sum * q) / num;
        let (root_a, root_b) = ((h2 + self.a2).sqrt(), (h2 + self.b2).sqrt());
        // s_b − s_a: with both ends on one side of x's foot (a b > 0) the two terms nearly
        // cancel far beyond an end; there b√(h² + a²) − a√(h² + b²) = h²(b − a)(b + a)/(b√(h² +
        // a²) + a√(h² + b²)) is formed without cancellation.
        let (a, b) = (self.a, self.b);
        let ds = if a * b > 0.0 {
            h2 * (b - a) * (b + a) / ((b * root_a + a * root_b) * root_a * root_b)
        } else {
            b / root_b - a / root_a
        };
        wt * self.u_s * cosh * 2.0 * inv_1q * jac * ds
    }
}

/// One term of a rule in sinh t per node ([`for_sinh_panels`]).
pub(crate) trait NodeTerm {
    fn term(&self, sinh: f64, cosh: f64, wt: f64) -> f64;
}

/// The terms of one panel's nodes, in their order: a [`Kernel`], so that the nodes' arithmetic
/// (independent of each other) is vectorised for the CPU's instruction set; every term is the
/// same IEEE operations in the same order as one node at a time, so the bits do not depend on
/// the instruction set. The caller sums them in order.
pub(crate) struct PanelTerms<'a, T> {
    pub terms: T,
    pub nodes: &'a PanelNodes,
}

impl<T: NodeTerm> Kernel for PanelTerms<'_, T> {
    type Output = [f64; PANEL_NODES];
    #[inline(always)]
    fn run(self) -> [f64; PANEL_NODES] {
        let (n, mut out) = (self.nodes, [0.0; PANEL_NODES]);
        for (i, term) in out.iter_mut().enumerate() {
            *term = self.terms.term(n.sinh[i], n.cosh[i], n.wt[i]);
        }
        out
    }
}

impl CylinderSolidAngle {
    pub fn new(view: &CylinderView) -> Option<Self> {
        Self::boxed(view).map(|s| *s)
    }

    /// [`Self::new`] built in its heap allocation: the renderer prepares one per shading
    /// point, and building it on the stack cost a copy of its ~500 bytes into the box.
    pub fn boxed(view: &CylinderView) -> Option<Box<Self>> {
        let v = view;
        let mut out = Box::new(Self {
            view: *view,
            inv_omega: 0.0,
            alpha: [0.0; BANDS],
            width: [0.0; BANDS],
            s_lo: [0.0; BANDS],
            s_hi: [0.0; BANDS],
            cumulative: [0.0; BANDS],
        });
        let s = &mut *out;
        let (gap, tangent2) = (v.rho - v.radius, (v.rho - v.radius) * (v.rho + v.radius));
        let (a2, b2) = (v.a * v.a, v.b * v.b);
        // A band end: α and s_a, s_b from h² there (the end at θ = 0 is α = 0, h = ρ − R;
        // at θ_max, α_max and h² = ρ² − R²).
        let end = |alpha: f64, h2: f64| (alpha, v.a / (a2 + h2).sqrt(), v.b / (b2 + h2).sqrt());
        // sin θ, cos θ of the interior ends θ_k = k θ_max/BANDS by rotation (error a few ulps),
        // the front point R(cos θ, sin θ) seen from x at (ρ, 0): α = atan2(R sin θ, ρ − R cos θ).
        let (sin_step, cos_step) = (v.theta_max / BANDS as f64).sin_cos();
        let (mut sin_t, mut cos_t) = (0.0, 1.0);
        let mut area = 0.0;
        let mut inner = end(0.0, gap * gap);
        for k in 0..BANDS {
            let outer = if k + 1 == BANDS {
                end(v.alpha_max, tangent2)
            } else {
                (sin_t, cos_t) = (
                    sin_t * cos_step + cos_t * sin_step,
                    cos_t * cos_step - sin_t * sin_step,
                );
                let (hx, hy) = (v.rho - v.radius * cos_t, v.radius * sin_t);
                end(hy.atan2(hx), hx * hx + hy * hy)
            };
            s.alpha[k] = inner.0;
            s.width[k] = outer.0 - inner.0;
            s.s_lo[k] = inner.1.min(outer.1);
            s.s_hi[k] = inner.2.max(outer.2);
            area += s.width[k] * (s.s_hi[k] - s.s_lo[k]);
            s.cumulative[k] = area;
            inner = outer;
        }
        let inv_omega = 1.0 / solid_angle_of(v);
        s.inv_omega = inv_omega;
        (inv_omega.is_finite() && inv_omega > 0.0 && area > 0.0).then_some(out)
    }

    /// Solid angle Ω of the visible side.
    pub fn solid_angle(&self) -> f64 {
        1.0 / self.inv_omega
    }

    /// The candidate for (ξ₀, ξ₁) ∈ [0, 1]²: (α, s), uniform in the envelope.
    #[inline]
    fn candidate(&self, x0: f64, x1: f64) -> (f64, f64) {
        // ξ₀ picks the side (sign of α) and the band by area, its remainder the α in the band.
        let (side, x0) = if x0 < 0.5 {
            (-1.0, 2.0 * x0)
        } else {
            (1.0, 2.0 * x0 - 1.0)
        };
        let target = (x0 * self.cumulative[BANDS - 1]).min(self.cumulative[BANDS - 1]);
        let mut k = 0;
        while k + 1 < BANDS && target > self.cumulative[k] {
            k += 1;
        }
        let start = if k == 0 { 0.0 } else { self.cumulative[k - 1] };
        let band = self.cumulative[k] - start;
        let f = if band > 0.0 {
            ((target - start) / band).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let alpha = side * (self.alpha[k] + f * self.width[k]);
        let s = self.s_lo[k] + x1 * (self.s_hi[k] - self.s_lo[k]);
        (alpha, s)
    }
}

impl CylinderSampler for CylinderSolidAngle {
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
            0x5a,
            MAX_CANDIDATES,
            |x0, x1| self.candidate(x0, x1),
            |(alpha, s)| self.view.front_sample_at(alpha, s),
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

    /// Ω within 1e-9 of the reference over a grid of shading points: ρ from R(1 + 1e-6) to
    /// 1e4 R, axial positions from 100 before the tube (length 3) to 50 beyond, close to the
    /// rims included, three azimuths. Measured ≤ 2.2e-10 (one panel, far from the tube),
    /// ≤ 5.1e-11 with two panels or more.
    #[test]
    fn solid_angle_over_a_grid_of_shading_points() {
        let cyl = Cylinder::new(DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0), 0.5).unwrap();
        let ratios = [
            1.000001, 1.00001, 1.0001, 1.001, 1.003, 1.01, 1.03, 1.05, 1.1, 1.2, 1.3, 1.5, 1.7,
            2.0, 2.5, 3.0, 5.0, 10.0, 100.0, 1e4,
        ];
        let axial = [
            -100.0, -5.0, -1.0, -0.3, -0.1, -0.05, -0.02, -0.005, -0.001, -1e-4, 0.0, 1e-4, 0.001,
            0.005, 0.02, 0.05, 0.1, 0.3, 1.0, 1.5, 2.9, 2.99, 2.999, 3.0001, 3.001, 3.01, 3.1, 3.3,
            5.0, 50.0,
        ];
        let mut worst = 0.0f64;
        for rr in ratios {
            for ax in axial {
                for azimuth in [0.0f64, 1.0, 2.5] {
                    let rho = rr * cyl.radius;
                    let x = DVec3::new(ax, rho * azimuth.sin(), rho * azimuth.cos());
                    let v = CylinderView::new(&cyl, x, DVec3::Z).unwrap();
                    let err = (solid_angle_of(&v) / omega_reference(&v) - 1.0).abs();
                    assert!(err < 1e-9, "ρ = {rr} R, x = {x}: {err:e}");
                    worst = worst.max(err);
                }
            }
        }
        assert!(worst > 0.0);
    }

    /// Ω against a graded reference quadrature, and the envelope's acceptance rate.
    #[test]
    fn solid_angle_quadrature_and_acceptance() {
        let mut cases = configs();
        // Very close to the rim of an end (ρ = 1.01 R, 0.01 R beyond the end).
        let cyl = Cylinder::new(DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0), 0.5).unwrap();
        cases.push((cyl, DVec3::new(-0.005, 0.0, 0.505), DVec3::Z));
        // ρ = 1.001 R beside the middle, and a 1e-4 R gap at the rim.
        cases.push((cyl, DVec3::new(1.5, 0.0, 0.5005), DVec3::Z));
        cases.push((cyl, DVec3::new(-5e-5, 0.0, 0.50005), DVec3::Z));
        for (cyl, x, n) in cases {
            let v = CylinderView::new(&cyl, x, n).unwrap();
            let s = CylinderSolidAngle::new(&v).unwrap();
            // In θ and α(θ) from the view, not the quadrature variable under test.
            let reference = omega_reference(&v);
            let coarse = integrate(&v, &mut |_, _| 1.0);
            assert!((coarse / reference - 1.0).abs() < 1e-6);
            let err = (s.solid_angle() / reference - 1.0).abs();
            assert!(err < 1e-9, "Ω {} vs {reference}: {err:e}", s.solid_angle());
            let accepted = (0..10_000)
                .filter(|i| {
                    let (a, sv) =
                        s.candidate((*i as f64 + 0.5) / 1e4, ((i * 7919) % 10_000) as f64 / 1e4);
                    s.view.front_direction(a, sv).is_some()
                })
                .count();
            assert!(
                accepted > 5000,
                "acceptance {accepted}/10000, R = {}",
                cyl.radius
            );
            // Inside (not at the silhouette, where the rebuilt α may round out).
            for i in 1..49 {
                let (dir, p) = s.sample_with_pdf([i as f32 / 49.0, 0.3]).unwrap();
                assert_eq!(s.pdf(dir), p);
            }
        }
    }
}
