//! Unshadowed reflected radiance of a linear light at a surface point, for any BSDF, by adaptive
//! quadrature along the line: the ground truth of glossy shading that owns nothing of the
//! sampling code (no `LineFrame`, no C(s), no technique, no LTC).
//!
//! Measure. A piece dt of a cylinder of radius R around the segment p(t) = p₀ + t·u (t ∈ [0, L],
//! u unit) seen from x at distance r = |p(t) − x| in direction ω = (p(t) − x)/r subtends the solid
//! angle 2R·|u × ω|·dt / r² (its projected width 2R times its projected length |u × ω| dt, over
//! r²); per radius, dΩ_R = 2 |u × ω| dt / r². With K = radiance × radius held fixed (the R → 0
//! limit the renderer uses), the reflected radiance toward v is
//!
//! ```text
//! L(x, v) = K · ∫₀ᴸ f(v, ω)·max(0, n·ω) · 2 |u × ω| / r² dt,
//! ```
//!
//! with f·cos exactly as the renderer evaluates it (`Bsdf::eval` in the shading frame of the side
//! facing the viewer; the BSDF models are certified against Mitsuba's `BSDF.eval` on their own).
//! No visibility term: this is exact only where nothing can occlude the line (see
//! [`crate::ground_truth::closed_form`] for the scenes it is used on).
//!
//! Quadrature. The integrand is zero below the tangent plane; the interval is cut at the plane
//! crossing t_h = n·(x − p₀)/(n·u) (computed here in f64, not by the samplers' horizon clip) and
//! only the part above is integrated. That part is split into [`PANELS`] pieces of equal angle
//! as seen from x (t = t_⊥ + d·tan θ, t_⊥ the foot of the perpendicular, d the distance to the
//! infinite line), so that a lobe as narrow as α = 0.05 (≳ 6° wide) is seen by many nodes of the
//! panel it falls in, and then refined adaptively (`linlight_quadrature::Adaptive`, Gauss–Legendre halves
//! against a Gauss–Lobatto whole) until the sum of the three colour channels meets a relative
//! error of [`RELATIVE_ERROR`]; each channel is then integrated with the same rule on the final
//! panels (the channels are non-negative, so none is less accurate in absolute terms than the
//! sum).

use glam::DVec3;
use linlight_brdf::lanes::Lanes3;
use linlight_quadrature::{Adaptive, GaussLegendre, BATCH};
use linlight_render::scene::Bsdf;
use linlight_simd::{dispatch, Isa, Kernel};
use std::sync::LazyLock;

/// Initial panels of equal subtended angle on the part of the segment above the horizon.
pub const PANELS: usize = 8;
/// Gauss–Legendre nodes per half panel.
pub const NODES: usize = 8;
/// Relative error target of the integral (of the channel sum).
pub const RELATIVE_ERROR: f64 = 1e-7;

/// The quadrature's shading point (the renderer's own is [`linlight_render::shading::ShadingPoint`]):
/// position, unit normal of the reflecting side, and the orthonormal tangent frame (t, b, n)
/// with v (unit, toward the viewer) expressed in it. Everything in f64.
#[derive(Clone, Copy, Debug)]
pub struct QuadraturePoint {
    pub x: DVec3,
    pub t: DVec3,
    pub b: DVec3,
    pub n: DVec3,
    /// v in the (t, b, n) frame; v.z > 0 on the reflecting side.
    pub v_local: DVec3,
}

impl QuadraturePoint {
    /// The frame at x with reflecting normal `n` and world direction `v` toward the viewer; the
    /// tangent is arbitrary (the supported BSDFs are isotropic).
    pub fn new(x: DVec3, n: DVec3, v: DVec3) -> Self {
        let n = n.normalize();
        let (t, b) = n.any_orthonormal_pair();
        let v = v.normalize();
        Self {
            x,
            t,
            b,
            n,
            v_local: DVec3::new(v.dot(t), v.dot(b), v.dot(n)),
        }
    }

    fn local(&self, w: DVec3) -> DVec3 {
        DVec3::new(w.dot(self.t), w.dot(self.b), w.dot(self.n))
    }
}

/// The sub-interval of [0, len] of the line p₀ + t·u strictly above the tangent plane of `sp`
/// (n·(p(t) − x) > 0), or None.
fn above_horizon(sp: &QuadraturePoint, p0: DVec3, u: DVec3, len: f64) -> Option<(f64, f64)> {
    let h0 = sp.n.dot(p0 - sp.x); // height of p(0) above the plane
    let slope = sp.n.dot(u);
    let (mut a, mut b) = (0.0, len);
    if slope == 0.0 {
        return (h0 > 0.0).then_some((a, b));
    }
    let th = -h0 / slope; // h0 + th·slope = 0
    if slope > 0.0 {
        a = a.max(th);
    } else {
        b = b.min(th);
    }
    (b > a).then_some((a, b))
}

/// Edges of [`PANELS`] panels of equal angle subtended at x between t = a and t = b.
fn equal_angle_edges(sp: &QuadraturePoint, p0: DVec3, u: DVec3, a: f64, b: f64) -> Vec<f64> {
    let foot = (sp.x - p0).dot(u);
    let d = (p0 + foot * u - sp.x).length();
    if !(d > 0.0) {
        // x on the infinite line: equal steps in t.
        return (0..=PANELS)
            .map(|i| a + (b - a) * i as f64 / PANELS as f64)
            .collect();
    }
    let (ta, tb) = (((a - foot) / d).atan(), ((b - foot) / d).atan());
    let mut edges: Vec<f64> = (0..=PANELS)
        .map(|i| foot + d * (ta + (tb - ta) * i as f64 / PANELS as f64).tan())
        .collect();
    // Exact ends (tan∘atan rounds).
    edges[0] = a;
    edges[PANELS] = b;
    edges
}

/// The adaptive rule of [`unshadowed_line_integral`] and its [`NODES`]-point Gauss–Legendre
/// rule, built once: the exact image integrates ~10⁵ segments, and finding the nodes costs as
/// much as a short integral.
static RULES: LazyLock<(Adaptive, GaussLegendre)> = LazyLock::new(|| {
    let mut q = Adaptive::new(NODES, RELATIVE_ERROR);
    q.noise = 1e-13; // f64 integrand
    q.max_evaluations = 100_000;
    (q, GaussLegendre::new(NODES))
});

/// ∫ f(v, ω)·max(0, n·ω) dΩ_R over the segment [p0, p1] seen from `sp`, per RGB channel (the
/// reflected radiance for K = 1). Zero when the segment is degenerate or entirely below the
/// horizon. Also returns whether every channel met the error target.
pub fn unshadowed_line_integral(
    bsdf: &Bsdf,
    sp: &QuadraturePoint,
    p0: DVec3,
    p1: DVec3,
) -> (DVec3, bool) {
    let len = (p1 - p0).length();
    if !(len > 0.0 && len.is_finite()) {
        return (DVec3::ZERO, true);
    }
    let u = (p1 - p0) / len;
    let Some((a, b)) = above_horizon(sp, p0, u, len) else {
        return (DVec3::ZERO, true);
    };
    let edges = equal_angle_edges(sp, p0, u, a, b);
    let isa = Isa::detect();
    let integrand = |ts: &[f64], out: &mut [DVec3]| {
        let kernel = Integrand {
            bsdf,
            sp,
            p0,
            u,
            ts,
            out,
        };
        dispatch(isa, kernel)
    };
    let (q, gl) = &*RULES;
    // The channel sum drives the refinement; every channel is then integrated on the final
    // panels with the same rule (one BSDF evaluation per node for all three).
    let mut values = [DVec3::ZERO; BATCH];
    let r = q.integrate_partition_batch(&edges, &mut |ts, ys| {
        integrand(ts, &mut values[..ts.len()]);
        for (y, v) in ys.iter_mut().zip(&values) {
            *y = v.element_sum();
        }
    });
    let (mut ts, mut sum) = ([0.0; NODES], DVec3::ZERO);
    for [a, b] in &r.panels {
        let m = 0.5 * (a + b);
        for (lo, hi) in [(*a, m), (m, *b)] {
            let (half, mid) = (0.5 * (hi - lo), 0.5 * (lo + hi));
            for (t, (x, _)) in ts.iter_mut().zip(gl.points()) {
                *t = mid + half * x;
            }
            integrand(&ts, &mut values[..NODES]);
            for (v, (_, w)) in values.iter().zip(gl.points()) {
                sum += *v * (w * half);
            }
        }
    }
    (sum, r.converged)
}

/// [`integrand`] as a kernel of the CPU's widest instruction set (the same bits in every one).
struct Integrand<'a> {
    bsdf: &'a Bsdf,
    sp: &'a QuadraturePoint,
    p0: DVec3,
    u: DVec3,
    ts: &'a [f64],
    out: &'a mut [DVec3],
}

impl Kernel for Integrand<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        integrand(self.bsdf, self.sp, self.p0, self.u, self.ts, self.out)
    }
}

/// The integrand f(v, ω)·max(0, n·ω)·2|u × ω|/r² at the points p0 + t·u of `ts` (at most
/// [`BATCH`]), into `out`: the BSDF evaluated [`LANES`] points at a time
/// (`Bsdf::eval_lanes`, bit for bit `Bsdf::eval` per lane); zero where r = 0.
#[inline(always)]
fn integrand(
    bsdf: &Bsdf,
    sp: &QuadraturePoint,
    p0: DVec3,
    u: DVec3,
    ts: &[f64],
    out: &mut [DVec3],
) {
    debug_assert!(ts.len() <= BATCH && out.len() == ts.len());
    for (ts, out) in ts.chunks(LANES).zip(out.chunks_mut(LANES)) {
        let v: Lanes3<f64, LANES> = std::array::from_fn(|c| [sp.v_local[c]; LANES]);
        // Lanes past the points and points at r = 0 are evaluated at ω = n (a valid direction)
        // and not used.
        let mut l: Lanes3<f64, LANES> = [[0.0; LANES], [0.0; LANES], [1.0; LANES]];
        let mut scale = [0.0; LANES];
        let mut at_line = [true; LANES];
        for (k, t) in ts.iter().enumerate() {
            let q = p0 + t * u - sp.x;
            let r2 = q.length_squared();
            let w = if r2 > 0.0 { q / r2.sqrt() } else { sp.n };
            let local = sp.local(w);
            for c in 0..3 {
                l[c][k] = local[c];
            }
            scale[k] = 2.0 * u.cross(w).length() / r2;
            at_line[k] = !(r2 > 0.0);
        }
        // eval includes max(0, n·ω) (zero below the horizon).
        let f = bsdf.eval_lanes(&v, &l);
        for (k, out) in out.iter_mut().enumerate() {
            *out = if at_line[k] {
                DVec3::ZERO
            } else {
                DVec3::new(f[0][k], f[1][k], f[2][k]) * scale[k]
            };
        }
    }
}

/// Points per BSDF lane call of [`integrand`] (eight f64 lanes fill a 512-bit register).
const LANES: usize = 8;
const _: () = assert!(NODES <= BATCH);

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_brdf::{ConductorFresnel, RoughConductor};

    fn lambert(rho: f64) -> Bsdf {
        Bsdf::Diffuse {
            reflectance: [rho as f32; 3],
        }
    }

    /// Brute force: the midpoint rule with `n` nodes over the line position t of
    /// ∫ f(ω) dΩ_R, dΩ_R = 2 |u × ω| dt / r² (f includes the cosine).
    fn midpoint_rule(x: DVec3, p0: DVec3, p1: DVec3, n: usize, f: impl Fn(DVec3) -> f64) -> f64 {
        let (len, u) = ((p1 - p0).length(), (p1 - p0).normalize());
        let mut sum = 0.0;
        for i in 0..n {
            let t = (i as f64 + 0.5) / n as f64 * len;
            let q = p0 + t * u - x;
            let r = q.length();
            let w = q / r;
            sum += f(w) * 2.0 * u.cross(w).length() / (r * r);
        }
        sum * len / n as f64
    }

    /// A Lambertian plane lit by a segment that crosses its horizon, against a brute-force
    /// midpoint rule with 2·10⁶ nodes.
    #[test]
    fn lambertian_matches_brute_force() {
        let sp = QuadraturePoint::new(
            DVec3::new(0.1, -0.2, 0.0),
            DVec3::Z,
            DVec3::new(0.3, -0.5, 1.0),
        );
        let (p0, p1) = (DVec3::new(-1.0, 0.4, 0.6), DVec3::new(0.8, 0.9, -0.3));
        let (got, ok) = unshadowed_line_integral(&lambert(0.5), &sp, p0, p1);
        assert!(ok);
        let want = midpoint_rule(sp.x, p0, p1, 2_000_000, |w| {
            0.5 / std::f64::consts::PI * w.z.max(0.0)
        });
        assert!(((got.x - want) / want).abs() < 1e-9, "{} vs {want}", got.x);
    }

    #[test]
    fn sharp_lobe_matches_brute_force() {
        // α = 0.05 conductor seen near the mirror direction of the segment's middle.
        let bsdf = Bsdf::RoughConductor(RoughConductor {
            alpha: 0.05,
            fresnel: ConductorFresnel::One,
            specular_reflectance: [1.0; 3],
        });
        let (p0, p1) = (DVec3::new(-1.0, 1.0, 0.8), DVec3::new(1.0, 1.2, 1.0));
        let x = DVec3::ZERO;
        // Mirror of the middle point's direction about the normal.
        let m = ((p0 + p1) * 0.5 - x).normalize();
        let v = DVec3::new(-m.x, -m.y, m.z);
        let sp = QuadraturePoint::new(x, DVec3::Z, v);
        let (got, ok) = unshadowed_line_integral(&bsdf, &sp, p0, p1);
        assert!(ok);
        let want = midpoint_rule(x, p0, p1, 4_000_000, |w| {
            bsdf.eval(sp.v_local, sp.local(w)).x
        });
        assert!(got.x > 1.0, "the lobe is hit: {}", got.x);
        assert!(((got.x - want) / want).abs() < 1e-8, "{} vs {want}", got.x);
    }

    /// The integrand's lanes, in every instruction set this CPU runs, give the bits of the
    /// one-point `Bsdf::eval` formula (what the quadrature integrated before it had lanes),
    /// on a batch that fills no whole lane group, and zero at r = 0.
    #[test]
    fn integrand_lanes_are_the_one_point_evaluation() {
        let conductor = Bsdf::RoughConductor(RoughConductor {
            alpha: 0.2,
            fresnel: ConductorFresnel::One,
            specular_reflectance: [0.9, 0.6, 0.3],
        });
        let sp = QuadraturePoint::new(DVec3::ZERO, DVec3::Z, DVec3::new(0.4, -0.2, 1.0));
        let (p0, u) = (
            DVec3::new(-1.0, 0.5, 0.7),
            DVec3::new(0.8, 0.2, -0.1).normalize(),
        );
        let foot = -p0.dot(u); // t of the line's point closest to x
        let ts: Vec<f64> = (0..13).map(|i| foot + 0.37 * (i as f64 - 6.0)).collect();
        let mut checked = 0;
        for bsdf in [lambert(0.5), conductor] {
            for isa in Isa::ALL.into_iter().filter(|i| i.supported()) {
                let mut out = [DVec3::ONE; 13];
                let (ts, out) = (&ts[..], &mut out[..]);
                let (sp, bsdf) = (&sp, &bsdf);
                dispatch(
                    isa,
                    Integrand {
                        bsdf,
                        sp,
                        p0,
                        u,
                        ts,
                        out,
                    },
                );
                for (t, got) in ts.iter().zip(out.iter()) {
                    let q = p0 + t * u - sp.x;
                    let w = q / q.length_squared().sqrt();
                    let want = bsdf.eval(sp.v_local, sp.local(w))
                        * (2.0 * u.cross(w).length() / q.length_squared());
                    assert_eq!(
                        got.to_array().map(f64::to_bits),
                        want.to_array().map(f64::to_bits)
                    );
                    checked += usize::from(want != DVec3::ZERO);
                }
            }
        }
        assert!(checked > 20, "{checked}");
        // A node at the shading point itself (r = 0) gives zero, not NaN.
        let on_line = QuadraturePoint::new(p0 + 0.3 * u, DVec3::Z, DVec3::Z);
        let mut out = [DVec3::ONE; 1];
        integrand(&lambert(0.5), &on_line, p0, u, &[0.3], &mut out);
        assert_eq!(out[0], DVec3::ZERO);
    }

    #[test]
    fn horizon_cut_and_degenerate_cases() {
        let sp = QuadraturePoint::new(DVec3::ZERO, DVec3::Z, DVec3::Z);
        // Entirely below: zero.
        let (below, ok) = unshadowed_line_integral(
            &lambert(1.0),
            &sp,
            DVec3::new(-1.0, 1.0, -0.1),
            DVec3::new(1.0, 1.0, -0.5),
        );
        assert!(ok && below == DVec3::ZERO);
        // Degenerate segment.
        let p = DVec3::new(0.0, 1.0, 1.0);
        assert_eq!(
            unshadowed_line_integral(&lambert(1.0), &sp, p, p).0,
            DVec3::ZERO
        );
        // A segment crossing the plane equals its part above the plane.
        let (a, b) = (DVec3::new(-0.5, 1.0, -0.4), DVec3::new(0.7, 0.6, 0.8));
        let tc = 0.4 / 1.2;
        let c = a + tc * (b - a);
        let (whole, _) = unshadowed_line_integral(&lambert(0.7), &sp, a, b);
        let (upper, _) = unshadowed_line_integral(&lambert(0.7), &sp, c, b);
        assert!(
            (whole.x - upper.x).abs() < 1e-12 * upper.x,
            "{whole} vs {upper}"
        );
        // The cut is the same from the other end.
        let (rev, _) = unshadowed_line_integral(&lambert(0.7), &sp, b, a);
        assert!((rev.x - whole.x).abs() < 1e-12 * whole.x);
    }
}
