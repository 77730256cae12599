//! Test-only references: the evaluation code that was made branch-free, as it was written
//! before (commit f343024: early returns, skipped terms). The branch-free code must give the
//! same bits; the lane test (`lanes.rs`) cannot show that, since `Bsdf::eval` is the lane code.
//! Every helper that was rewritten since (made branch-free, or generic over f32/f64 in commit
//! 9b0ddbb → glossy-f32: `schlick_weight`, `schlick_r0`, `conductor`, `safe_sqrt`,
//! `clamp_alpha`, the models' α, `Blend::weight`, the conductor's Fresnel per channel,
//! `twosided`'s flip, `sin2`, `c`, `lerp`, `rgb`) is copied as it was at 9b0ddbb, so that the
//! new code is compared with the f64 originals rather than with itself; only constants
//! (`LUMINANCE`, `D_FLUSH`, `MIN_ALPHA`) are shared.

use crate::fresnel;
use crate::microfacet::{self, MIN_ALPHA};
use crate::principled::LUMINANCE;
use crate::test_util::{bsdfs, pairs};
use crate::{Blend, Bsdf, ConductorFresnel, Principled, RoughConductor};
use glam::DVec3;
use num_traits::Float;

fn c<T: Float>(x: f64) -> T {
    T::from(x).expect("constant representable")
}

fn sin2(w: DVec3) -> f64 {
    w.x * w.x + w.y * w.y
}

fn rgb(c: [f32; 3]) -> DVec3 {
    DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + t * (b - a)
}

fn schlick_r0(eta: f64) -> f64 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

fn clamp_alpha<T: Float>(alpha: T) -> T {
    if alpha < c(MIN_ALPHA) {
        c(MIN_ALPHA)
    } else {
        alpha
    }
}

fn conductor_alpha(c: &RoughConductor) -> f64 {
    clamp_alpha(c.alpha as f64)
}

fn principled_alpha(p: &Principled) -> f64 {
    let r2 = (p.roughness * p.roughness).max(0.001);
    clamp_alpha(r2 as f64)
}

fn flip(v: DVec3, l: DVec3) -> (DVec3, DVec3) {
    if v.z.is_sign_negative() {
        (DVec3::new(v.x, v.y, -v.z), DVec3::new(l.x, l.y, -l.z))
    } else {
        (v, l)
    }
}

fn safe_sqrt(x: f64) -> f64 {
    x.max(0.0).sqrt()
}

fn schlick_weight(cos: f64) -> f64 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

fn conductor(cos_theta_i: f64, eta: f64, k: f64) -> f64 {
    let cos2 = cos_theta_i * cos_theta_i;
    let sin2 = 1.0 - cos2;
    let sin4 = sin2 * sin2;
    let temp1 = eta * eta - k * k - sin2;
    let a2pb2 = safe_sqrt(temp1 * temp1 + 4.0 * k * k * eta * eta);
    let a = safe_sqrt(0.5 * (a2pb2 + temp1));
    let term1 = a2pb2 + cos2;
    let term2 = 2.0 * cos_theta_i * a;
    let r_s = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * cos2 + sin4;
    let term4 = term2 * sin2;
    let r_p = r_s * (term3 - term4) / (term3 + term4);
    0.5 * (r_s + r_p)
}

fn conductor_fresnel(c: &RoughConductor, cos_vh: f64) -> DVec3 {
    match &c.fresnel {
        ConductorFresnel::One => DVec3::ONE,
        ConductorFresnel::Complex { eta, k } => DVec3::new(
            conductor(cos_vh, eta[0] as f64, k[0] as f64),
            conductor(cos_vh, eta[1] as f64, k[1] as f64),
            conductor(cos_vh, eta[2] as f64, k[2] as f64),
        ),
    }
}

fn blend_weight(b: &Blend) -> f64 {
    (b.weight as f64).clamp(0.0, 1.0)
}

fn d<T: Float>(alpha: T, sin2_theta_h: T, cos_theta_h: T) -> T {
    if !(cos_theta_h > T::zero()) {
        return T::zero();
    }
    let a2 = alpha * alpha;
    let denom = sin2_theta_h + a2 * cos_theta_h * cos_theta_h;
    let value = a2 / (c::<T>(std::f64::consts::PI) * denom * denom);
    if value * cos_theta_h > c(microfacet::D_FLUSH) {
        value
    } else {
        T::zero()
    }
}

fn g1<T: Float>(alpha: T, sin2_theta_w: T, cos_theta_w: T, w_dot_h: T) -> T {
    if !(w_dot_h * cos_theta_w > T::zero()) {
        return T::zero();
    }
    if sin2_theta_w == T::zero() {
        return T::one();
    }
    let tan2_alpha2 = alpha * alpha * sin2_theta_w / (cos_theta_w * cos_theta_w);
    c::<T>(2.0) / (T::one() + (T::one() + tan2_alpha2).sqrt())
}

pub(crate) fn ggx_cos_and_cos_vh(alpha: f64, v: DVec3, l: DVec3) -> (f64, f64) {
    if !(v.z > 0.0 && l.z > 0.0) {
        return (0.0, 0.0);
    }
    let h = (v + l).normalize_or_zero();
    if h == DVec3::ZERO {
        return (0.0, 0.0);
    }
    let dh = d(alpha, sin2(h), h.z);
    if dh == 0.0 {
        return (0.0, 0.0);
    }
    let cos_vh = v.dot(h);
    let g = g1(alpha, sin2(v), v.z, cos_vh) * g1(alpha, sin2(l), l.z, l.dot(h));
    (dh * g / (4.0 * v.z), cos_vh)
}

fn dielectric(cos_theta_i: f64, eta: f64) -> f64 {
    let eta_ti = if cos_theta_i >= 0.0 { 1.0 / eta } else { eta };
    let eta_it = 1.0 / eta_ti;
    let cos_t2 = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    let ci = cos_theta_i.abs();
    let ct = safe_sqrt(cos_t2);
    if eta == 1.0 {
        return 0.0;
    }
    if ci == 0.0 {
        return 1.0;
    }
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    0.5 * (a_s * a_s + a_p * a_p)
}

fn schlick(r0: f64, cos_theta_i: f64, eta: f64) -> f64 {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let w = if eta_it > 1.0 {
        schlick_weight(cos_theta_i.abs())
    } else {
        let cos_t2 = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
        schlick_weight(safe_sqrt(cos_t2))
    };
    w * (1.0 - r0) + r0
}

fn principled_fresnel(p: &Principled, cos_vh: f64) -> DVec3 {
    let eta = p.eta as f64;
    let metallic = p.metallic as f64;
    let tint = p.spec_tint as f64;
    let base = rgb(p.base_color);
    let f_dielectric = dielectric(cos_vh, eta);
    let mut f = DVec3::splat((1.0 - metallic) * (1.0 - tint) * f_dielectric);
    if metallic != 0.0 {
        f += metallic * base.map(|b| schlick(b, cos_vh, eta));
    }
    if tint != 0.0 {
        let lum = base.dot(rgb(LUMINANCE));
        let c_tint = if lum > 0.0 { base / lum } else { DVec3::ONE };
        let eta_it = if cos_vh >= 0.0 { eta } else { 1.0 / eta };
        let f0 = c_tint * schlick_r0(eta_it);
        f += (1.0 - metallic) * tint * f0.map(|r0| schlick(r0, cos_vh, eta));
    }
    f
}

fn principled(p: &Principled, v: DVec3, l: DVec3) -> DVec3 {
    if !(v.z > 0.0 && l.z > 0.0) {
        return DVec3::ZERO;
    }
    let mut value = DVec3::ZERO;
    let (lobe, cos_vh) = ggx_cos_and_cos_vh(principled_alpha(p), v, l);
    if lobe != 0.0 && dielectric(cos_vh, p.eta as f64) > 0.0 {
        value += principled_fresnel(p, cos_vh) * lobe;
    }
    let w = 1.0 - p.metallic as f64;
    if w > 0.0 {
        let h = (v + l).normalize();
        let (f_l, f_v) = (schlick_weight(l.z), schlick_weight(v.z));
        let f_diff = (1.0 - 0.5 * f_v) * (1.0 - 0.5 * f_l);
        let cos_d = h.dot(l);
        let rr = 2.0 * p.roughness as f64 * cos_d * cos_d;
        let f_retro = rr * (f_l + f_v + f_l * f_v * (rr - 1.0));
        let flatness = p.flatness as f64;
        let shape = if flatness != 0.0 {
            let fss90 = 0.5 * rr;
            let fss = lerp(1.0, fss90, f_l) * lerp(1.0, fss90, f_v);
            let f_ss = 1.25 * (fss * (1.0 / (l.z + v.z) - 0.5) + 0.5);
            lerp(f_diff + f_retro, f_ss, flatness)
        } else {
            f_diff + f_retro
        };
        value += rgb(p.base_color) * (w * l.z * std::f64::consts::FRAC_1_PI * shape);
    }
    value
}

fn rough_conductor(c: &RoughConductor, v: DVec3, l: DVec3) -> DVec3 {
    let (lobe, cos_vh) = ggx_cos_and_cos_vh(conductor_alpha(c), v, l);
    if lobe == 0.0 {
        return DVec3::ZERO;
    }
    conductor_fresnel(c, cos_vh) * rgb(c.specular_reflectance) * lobe
}

/// `Bsdf::eval` in its scalar form: recursive, one direction pair at a time.
fn eval(bsdf: &Bsdf, v: DVec3, l: DVec3) -> DVec3 {
    match bsdf {
        Bsdf::Diffuse { reflectance } => {
            if !(v.z > 0.0 && l.z > 0.0) {
                return DVec3::ZERO;
            }
            rgb(*reflectance) * (std::f64::consts::FRAC_1_PI * l.z)
        }
        Bsdf::RoughConductor(c) => rough_conductor(c, v, l),
        Bsdf::Principled(p) => principled(p, v, l),
        Bsdf::Blend(b) => {
            let w = blend_weight(b);
            eval(&b.bsdfs[0], v, l) * (1.0 - w) + eval(&b.bsdfs[1], v, l) * w
        }
        Bsdf::TwoSided(inner) => {
            let (v, l) = flip(v, l);
            eval(inner, v, l)
        }
    }
}

fn bits(x: DVec3) -> [u64; 3] {
    x.to_array().map(f64::to_bits)
}

/// The leaf models inside `bsdf` (through blends and two-sided).
fn leaves(bsdf: &Bsdf) -> Vec<&Bsdf> {
    match bsdf {
        Bsdf::Blend(b) => b.bsdfs.iter().flat_map(leaves).collect(),
        Bsdf::TwoSided(inner) => leaves(inner),
        leaf => vec![leaf],
    }
}

/// `Blend::weight` (shared with the f32 path) is the f64 clamp of the file's f32 weight.
#[test]
fn blend_weight_equals_the_f64_clamp() {
    for w in [
        -2.0f32,
        -0.0,
        0.0,
        0.3,
        0.35,
        1.0,
        7.0,
        f32::NAN,
        f32::INFINITY,
    ] {
        let b = Blend {
            weight: w,
            bsdfs: Box::new([
                Bsdf::Diffuse {
                    reflectance: [0.5; 3],
                },
                Bsdf::Diffuse {
                    reflectance: [0.5; 3],
                },
            ]),
        };
        let (new, old) = (b.weight(), blend_weight(&b));
        assert!(
            new.to_bits() == old.to_bits() || (new.is_nan() && old.is_nan()),
            "{w}"
        );
    }
}

#[test]
fn branch_free_eval_equals_the_early_returns() {
    let pairs = pairs();
    for bsdf in bsdfs() {
        for &(v, l) in &pairs {
            let (new, old) = (bsdf.eval(v, l), eval(&bsdf, v, l));
            assert_eq!(
                bits(new),
                bits(old),
                "{bsdf:?}, v {v}, l {l}: {new} ≠ {old}"
            );
        }
    }
}

/// The pieces on their own, also at the arguments whose result `eval` then discards (both signs
/// of the cosine, f32 as the renderer's cost model calls d and g1).
#[test]
fn branch_free_pieces_equal_the_early_returns() {
    let pairs = pairs();
    let all = bsdfs();
    let leaves: Vec<&Bsdf> = all.iter().flat_map(leaves).collect();
    for leaf in leaves {
        let (alpha, new_alpha, principled) = match leaf {
            Bsdf::RoughConductor(c) => (conductor_alpha(c), c.alpha(), None),
            Bsdf::Principled(p) => (principled_alpha(p), p.alpha(), Some(p)),
            _ => continue,
        };
        assert_eq!(new_alpha.to_bits(), alpha.to_bits(), "α of {leaf:?}");
        for &(v, l) in &pairs {
            let h = (v + l).normalize_or_zero();
            let (cos_vh, cos_lh) = (v.dot(h), l.dot(h));
            let (new, old) = (
                microfacet::ggx_cos_and_cos_vh(alpha, v, l),
                ggx_cos_and_cos_vh(alpha, v, l),
            );
            assert_eq!(
                new.0.to_bits(),
                old.0.to_bits(),
                "lobe, α {alpha}, v {v}, l {l}"
            );
            assert_eq!(
                new.1.to_bits(),
                old.1.to_bits(),
                "v·h, α {alpha}, v {v}, l {l}"
            );
            let args = [
                (sin2(h), h.z, 0.0),
                (sin2(v), v.z, cos_vh),
                (sin2(l), l.z, cos_lh),
            ];
            for (s2, cos, dot) in args {
                let (a, s, c, w) = (alpha, s2, cos, dot);
                assert_eq!(microfacet::d(a, s, c).to_bits(), d(a, s, c).to_bits());
                assert_eq!(
                    microfacet::g1(a, s, c, w).to_bits(),
                    g1(a, s, c, w).to_bits()
                );
                let (a, s, c, w) = (a as f32, s as f32, c as f32, w as f32);
                assert_eq!(microfacet::d(a, s, c).to_bits(), d(a, s, c).to_bits());
                assert_eq!(
                    microfacet::g1(a, s, c, w).to_bits(),
                    g1(a, s, c, w).to_bits()
                );
            }
            for cos in [cos_vh, -cos_vh, v.z, -l.z, 1.0 + l.z, 1e-300] {
                let same = |a: f64, b: f64, what: &str| {
                    assert_eq!(a.to_bits(), b.to_bits(), "{what}({cos})");
                };
                same(
                    fresnel::schlick_weight(cos),
                    schlick_weight(cos),
                    "schlick_weight",
                );
                same(fresnel::safe_sqrt(cos), safe_sqrt(cos), "safe_sqrt");
                same(microfacet::sin2(v.into()), sin2(v), "sin2");
                if let Bsdf::RoughConductor(c) = leaf {
                    let (new, old) = (c.fresnel(cos), conductor_fresnel(c, cos));
                    assert_eq!(bits(new), bits(old), "{c:?}: F({cos})");
                    for (eta, k) in [(0.143, 3.983), (1.5, 0.0), (0.2, 3.0), (0.0, 1.0)] {
                        let (new, old) = (fresnel::conductor(cos, eta, k), conductor(cos, eta, k));
                        same(new, old, "conductor");
                    }
                }
            }
            let Some(p) = principled else { continue };
            let eta = p.eta as f64;
            let r0 = schlick_r0(eta);
            assert_eq!(
                fresnel::schlick_r0(eta).to_bits(),
                r0.to_bits(),
                "R₀({eta})"
            );
            for cos in [cos_vh, -cos_vh, v.z, -l.z] {
                let (new, old) = (fresnel::dielectric(cos, eta), dielectric(cos, eta));
                assert_eq!(new.to_bits(), old.to_bits(), "dielectric({cos}, {eta})");
                for r0 in p.base_color.map(f64::from).into_iter().chain([r0]) {
                    let (new, old) = (fresnel::schlick(r0, cos, eta), schlick(r0, cos, eta));
                    assert_eq!(new.to_bits(), old.to_bits(), "schlick({r0}, {cos}, {eta})");
                }
                let (new, old) = (p.fresnel(cos), principled_fresnel(p, cos));
                assert_eq!(bits(new), bits(old), "{p:?}: F_p({cos})");
            }
        }
    }
}
