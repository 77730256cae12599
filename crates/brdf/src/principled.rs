//! Mitsuba 3.9.1's `principled` BSDF (Burley's Disney BRDF) restricted to its reflection lobes:
//! `sheen`, `clearcoat`, `spec_trans` and `anisotropic` at their default 0 (the loader rejects
//! anything else), so it is one-sided. With w = (1 − metallic), front side (v_z > 0, l_z > 0):
//!
//! f·cos θ_l = F_p(v·h) · D(h) G1(v,h) G1(l,h) / (4 v_z)
//!           + \[w > 0\] · w · l_z · base_color/π · lerp(f_diff + f_retro, f_ss, flatness)
//!
//! - GGX with separable Smith masking, α = max(0.001, roughness²);
//! - F_p = w·(1 − spec_tint)·F_dielectric(v·h, η) + metallic·Schlick(base_color, v·h)
//!   + w·spec_tint·Schlick(c_tint·R₀(η), v·h), c_tint = base_color / luminance(base_color);
//! - Disney diffuse: F_x = (1 − cos θ_x)⁵, f_diff = (1 − F_l/2)(1 − F_v/2),
//!   R_R = 2·roughness·(h·l)², f_retro = R_R (F_l + F_v + F_l F_v (R_R − 1));
//! - Hanrahan–Krueger fake subsurface f_ss = 1.25 (F_ss (1/(l_z + v_z) − 0.5) + 0.5),
//!   F_ss = lerp(1, R_R/2, F_l) · lerp(1, R_R/2, F_v).
//!
//! Back side (v_z < 0, l_z < 0): Mitsuba's value is (1 − metallic)·spec_trans·F_dielectric·…,
//! which is 0 with spec_trans = 0. Everything else (v_z = 0, or v and l on different sides) is 0.

use crate::diffuse::rgb;
use crate::microfacet::{clamp_alpha, ggx_lobe};
use crate::real::{Real, V3};
use crate::{fresnel, Lobes, Rgb, SpecularLobe};
use glam::DVec3;

#[derive(Clone, Debug, PartialEq)]
pub struct Principled {
    pub base_color: Rgb,
    /// Perceptual roughness r; the GGX α is max(0.001, r²).
    pub roughness: f32,
    pub metallic: f32,
    /// Relative index of refraction of the dielectric lobe: `eta`, or from `specular` via
    /// [`Principled::eta_from_specular`] (`specular` = 0.5 ⇒ η = 1.5).
    pub eta: f32,
    pub spec_tint: f32,
    pub flatness: f32,
}

/// Mitsuba's RGB luminance weights (f32 constants).
pub(crate) const LUMINANCE: [f32; 3] = [0.212671, 0.715160, 0.072169];

impl Principled {
    /// Mitsuba's defaults: base_color 0.5, roughness 0.5, metallic 0, specular 0.5, no tint.
    pub fn new() -> Self {
        Principled {
            base_color: [0.5; 3],
            roughness: 0.5,
            metallic: 0.0,
            eta: Self::eta_from_specular(0.5),
            spec_tint: 0.0,
            flatness: 0.0,
        }
    }

    /// η = 2 / (1 − √(0.08·specular)) − 1, in f32 as Mitsuba computes it (finite for
    /// 0 ≤ specular < 12.5).
    pub fn eta_from_specular(specular: f32) -> f32 {
        2.0 * (1.0 / (1.0 - (0.08f32 * specular).sqrt())) - 1.0
    }

    /// The evaluated GGX α: max(0.001, roughness²), then Mitsuba's floor 1e-4.
    #[inline(always)]
    pub fn alpha(&self) -> f64 {
        self.alpha_in()
    }

    /// [`Principled::alpha`] in either precision (max in f32, then the floor).
    #[inline(always)]
    fn alpha_in<T: Real>(&self) -> T {
        let r2 = (self.roughness * self.roughness).max(0.001);
        clamp_alpha(T::of(r2))
    }

    /// F_p per channel at the microfacet cosine `cos_vh` (front side).
    #[inline(always)]
    pub fn fresnel(&self, cos_vh: f64) -> DVec3 {
        self.fresnel_in(cos_vh).into()
    }

    /// [`Principled::fresnel`] in either precision. The terms that the parameters switch off
    /// are computed and not added (branch-free per lane, the same bits).
    #[inline(always)]
    fn fresnel_in<T: Real>(&self, cos_vh: T) -> V3<T> {
        let one = T::one();
        let eta = T::of(self.eta);
        let metallic = T::of(self.metallic);
        let tint = T::of(self.spec_tint);
        let base = V3::rgb(self.base_color);
        let f_dielectric = fresnel::dielectric(cos_vh, eta);
        let f = V3::splat((one - metallic) * (one - tint) * f_dielectric);
        let metal = base.map(|b| fresnel::schlick(b, cos_vh, eta)) * metallic;
        let f = if metallic != T::zero() { f + metal } else { f };
        let lum = base.dot(V3::rgb(LUMINANCE));
        let c_tint = if lum > T::zero() {
            base / lum
        } else {
            V3::splat(one)
        };
        let eta_it = if cos_vh >= T::zero() { eta } else { one / eta };
        let f0 = c_tint * fresnel::schlick_r0(eta_it);
        let tinted = f0.map(|r0| fresnel::schlick(r0, cos_vh, eta)) * ((one - metallic) * tint);
        if tint != T::zero() {
            f + tinted
        } else {
            f
        }
    }

    /// f(v, l)·l_z in the shading frame, as Mitsuba's `BSDF.eval` returns it (f64).
    #[inline(always)]
    pub fn eval(&self, v: DVec3, l: DVec3) -> DVec3 {
        self.eval_in(v.into(), l.into()).into()
    }

    /// [`Principled::eval`] in either precision. Branch-free: every term is computed and the
    /// ones that do not apply are not added (the same bits as skipping them), so that the
    /// lanes of [`crate::Bsdf::eval_lanes`] vectorise.
    #[inline(always)]
    pub(crate) fn eval_in<T: Real>(&self, v: V3<T>, l: V3<T>) -> V3<T> {
        let (zero, one, half) = (T::zero(), T::one(), T::c(0.5));
        let value = V3::zero();
        let (lobe, cos_vh) = ggx_lobe(self.alpha_in(), v, l);
        // Mitsuba drops the whole specular term where the dielectric Fresnel vanishes (η = 1),
        // even when metallic or tint would contribute.
        let specular = self.fresnel_in(cos_vh) * lobe;
        let value = if lobe != zero && fresnel::dielectric(cos_vh, T::of(self.eta)) > zero {
            value + specular
        } else {
            value
        };
        let w = one - T::of(self.metallic);
        let h = (v + l).normalize();
        let (f_l, f_v) = (fresnel::schlick_weight(l.z), fresnel::schlick_weight(v.z));
        let f_diff = (one - half * f_v) * (one - half * f_l);
        let cos_d = h.dot(l);
        let rr = T::c(2.0) * T::of(self.roughness) * cos_d * cos_d;
        let f_retro = rr * (f_l + f_v + f_l * f_v * (rr - one));
        let flatness = T::of(self.flatness);
        let fss90 = half * rr;
        let fss = lerp(one, fss90, f_l) * lerp(one, fss90, f_v);
        let f_ss = T::c(1.25) * (fss * (one / (l.z + v.z) - half) + half);
        let shape = if flatness != zero {
            lerp(f_diff + f_retro, f_ss, flatness)
        } else {
            f_diff + f_retro
        };
        let diffuse =
            V3::rgb(self.base_color) * (w * l.z * T::c(std::f64::consts::FRAC_1_PI) * shape);
        let value = if w > zero { value + diffuse } else { value };
        if v.z > zero && l.z > zero {
            value
        } else {
            V3::zero()
        }
    }

    /// ρ_d = (1 − metallic)·base_color (the Disney diffuse albedo up to its retro-reflection
    /// term, within about ±20 %), 0 for metallic ≥ 1; the specular lobe has α as evaluated and
    /// k_s = F_p(v_z), the Fresnel factor at the mirror configuration.
    pub fn lobes(&self, v: DVec3) -> Lobes {
        if !(v.z > 0.0) {
            return Lobes::BLACK;
        }
        let w = (1.0 - self.metallic as f64).max(0.0);
        Lobes {
            diffuse: rgb(self.base_color) * w,
            // η = 1: no dielectric reflection, and Mitsuba then drops the whole specular term.
            specular: (self.eta != 1.0).then(|| SpecularLobe {
                alpha: self.alpha(),
                weight: self.fresnel(v.z.min(1.0)),
            }),
        }
    }
}

impl Default for Principled {
    fn default() -> Self {
        Self::new()
    }
}

/// Mitsuba's `lerp(a, b, t)` = a + t (b − a).
#[inline(always)]
pub(crate) fn lerp<T: Real>(a: T, b: T, t: T) -> T {
    a + t * (b - a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::microfacet::ggx_cos;
    use crate::test_util::{hemisphere_integral, unit};

    #[test]
    fn specular_half_maps_to_eta_one_point_five() {
        assert!((Principled::eta_from_specular(0.5) - 1.5).abs() < 1e-6);
        assert_eq!(Principled::eta_from_specular(0.0), 1.0);
    }

    #[test]
    fn metallic_one_is_schlick_times_the_ggx_lobe() {
        let p = Principled {
            base_color: [0.9, 0.6, 0.3],
            roughness: 0.4,
            metallic: 1.0,
            ..Principled::new()
        };
        let (v, l) = (unit(0.5, 0.2, 0.6), unit(-0.4, 0.1, 0.9));
        let h = (v + l).normalize();
        let w = (1.0 - v.dot(h)).powi(5);
        let want = rgb(p.base_color).map(|b| b + (1.0 - b) * w) * ggx_cos(p.alpha(), v, l);
        assert!((p.eval(v, l) - want).abs().max_element() < 1e-15);
        assert_eq!(p.lobes(v).diffuse, DVec3::ZERO);
    }

    #[test]
    fn dielectric_is_disney_diffuse_plus_fresnel_lobe() {
        let p = Principled {
            base_color: [0.8, 0.3, 0.2],
            roughness: 0.5,
            ..Principled::new()
        };
        let (v, l) = (unit(0.5, 0.2, 0.6), unit(-0.4, 0.1, 0.9));
        let h = (v + l).normalize();
        let spec = fresnel::dielectric(v.dot(h), 1.5) * ggx_cos(0.25, v, l);
        let fl = (1.0 - l.z).powi(5);
        let fv = (1.0 - v.z).powi(5);
        let rr = 2.0 * 0.5 * h.dot(l).powi(2);
        let disney = (1.0 - fl / 2.0) * (1.0 - fv / 2.0) + rr * (fl + fv + fl * fv * (rr - 1.0));
        let want = DVec3::splat(spec) + rgb(p.base_color) / std::f64::consts::PI * disney * l.z;
        assert!((p.eval(v, l) - want).abs().max_element() < 1e-7);
        // One-sided with spec_trans = 0.
        assert_eq!(p.eval(-v, -l), DVec3::ZERO);
        assert_eq!(p.eval(v, -l), DVec3::ZERO);
    }

    #[test]
    fn lobe_summary_estimates_the_albedo() {
        // The summary only steers MIS weights, but it should be the right magnitude: the
        // hemispherical albedo lies within 25 % of ρ_d + k_s·ρ_s (ρ_s from quadrature of the
        // F ≡ 1 lobe).
        for (metallic, roughness, theta) in [(0.0, 0.5, 0.3f64), (1.0, 0.6, 1.0), (0.5, 0.8, 0.7)] {
            let p = Principled {
                base_color: [0.7, 0.5, 0.3],
                roughness,
                metallic,
                ..Principled::new()
            };
            let v = DVec3::new(theta.sin(), 0.0, theta.cos());
            let albedo = hemisphere_integral(|l| p.eval(v, l), 100);
            let rho_s = hemisphere_integral(|l| DVec3::splat(ggx_cos(p.alpha(), v, l)), 100);
            let lobes = p.lobes(v);
            let estimate = lobes.diffuse + lobes.specular.unwrap().weight * rho_s;
            let ratio = albedo / estimate;
            assert!(
                ratio.max_element() < 1.25 && ratio.min_element() > 0.8,
                "metallic {metallic}: albedo {albedo}, estimate {estimate}"
            );
        }
    }
}
