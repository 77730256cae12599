//! Mitsuba's `roughconductor` with `distribution="ggx"`, isotropic: one-sided,
//! f·cos θ_l = F(v·h) · k · D(h) G1(v,h) G1(l,h) / (4 v_z) with separable Smith masking, α
//! clamped to ≥ 1e-4, F the complex-IOR conductor Fresnel (or ≡ 1), k the
//! `specular_reflectance`.

use crate::diffuse::rgb;
use crate::lanes::{self, each_lane, Lanes3};
use crate::microfacet::{clamp_alpha, ggx_lobe};
use crate::real::{Real, V3};
use crate::{fresnel, Lobes, Rgb, SpecularLobe};
use glam::DVec3;

/// The Fresnel factor of a rough conductor.
#[derive(Clone, Debug, PartialEq)]
pub enum ConductorFresnel {
    /// F ≡ 1: `material="none"` without `eta`/`k` (Mitsuba evaluates its conductor formula at
    /// η = 0, k = 1, which is 1 up to f32 rounding).
    One,
    /// Complex relative index of refraction η + i·k per RGB channel.
    Complex { eta: Rgb, k: Rgb },
}

#[derive(Clone, Debug, PartialEq)]
pub struct RoughConductor {
    /// GGX roughness as given in the file (evaluation clamps it to ≥ 1e-4, as Mitsuba does).
    pub alpha: f32,
    pub fresnel: ConductorFresnel,
    /// Multiplies the lobe (Mitsuba's `specular_reflectance`, default 1).
    pub specular_reflectance: Rgb,
}

/// The conductor Fresnel reflectance per channel at cosine `cos_vh`.
#[inline(always)]
fn complex_fresnel<T: Real>(cos_vh: T, eta: &Rgb, k: &Rgb) -> V3<T> {
    V3::new(
        fresnel::conductor(cos_vh, T::of(eta[0]), T::of(k[0])),
        fresnel::conductor(cos_vh, T::of(eta[1]), T::of(k[1])),
        fresnel::conductor(cos_vh, T::of(eta[2]), T::of(k[2])),
    )
}

impl RoughConductor {
    /// The α that is evaluated: the given one clamped to ≥ 1e-4.
    #[inline(always)]
    pub fn alpha(&self) -> f64 {
        self.alpha_in()
    }

    /// [`RoughConductor::alpha`] in either precision (the same clamp of the same f32 value).
    #[inline(always)]
    fn alpha_in<T: Real>(&self) -> T {
        clamp_alpha(T::of(self.alpha))
    }

    /// Fresnel reflectance per channel at cosine `cos_vh`.
    #[inline(always)]
    pub fn fresnel(&self, cos_vh: f64) -> DVec3 {
        match &self.fresnel {
            ConductorFresnel::One => DVec3::ONE,
            ConductorFresnel::Complex { eta, k } => complex_fresnel(cos_vh, eta, k).into(),
        }
    }

    /// f(v, l)·l_z in the shading frame, as Mitsuba's `BSDF.eval` returns it (f64).
    pub fn eval(&self, v: DVec3, l: DVec3) -> DVec3 {
        lanes::one_lane(v.into(), l.into(), |v, l| self.eval_lanes(v, l)).into()
    }

    /// [`RoughConductor::eval`] for N lanes (structure of arrays x, y, z) in either precision:
    /// the same per-lane arithmetic, with the Fresnel model chosen once for all lanes.
    #[inline(always)]
    pub fn eval_lanes<T: Real, const N: usize>(
        &self,
        v: &Lanes3<T, N>,
        l: &Lanes3<T, N>,
    ) -> Lanes3<T, N> {
        match &self.fresnel {
            ConductorFresnel::One => each_lane(
                v,
                l,
                #[inline(always)]
                |v, l| self.eval_with(v, l, |_| V3::splat(T::one())),
            ),
            ConductorFresnel::Complex { eta, k } => each_lane(
                v,
                l,
                #[inline(always)]
                |v, l| self.eval_with(v, l, |cos_vh| complex_fresnel(cos_vh, eta, k)),
            ),
        }
    }

    /// F(v·h)·k·lobe, 0 where the lobe is (branch-free: every lane computes it).
    #[inline(always)]
    fn eval_with<T: Real>(&self, v: V3<T>, l: V3<T>, fresnel: impl Fn(T) -> V3<T>) -> V3<T> {
        let (lobe, cos_vh) = ggx_lobe(self.alpha_in(), v, l);
        let value = fresnel(cos_vh) * V3::rgb(self.specular_reflectance) * lobe;
        if lobe == T::zero() {
            V3::zero()
        } else {
            value
        }
    }

    /// No diffuse part; the specular lobe's weight k_s = specular_reflectance · F(v_z), the
    /// Fresnel factor at the mirror configuration (h = n).
    pub fn lobes(&self, v: DVec3) -> Lobes {
        if !(v.z > 0.0) {
            return Lobes::BLACK;
        }
        Lobes {
            diffuse: DVec3::ZERO,
            specular: Some(SpecularLobe {
                alpha: self.alpha(),
                weight: self.fresnel(v.z.min(1.0)) * rgb(self.specular_reflectance),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::microfacet::ggx_cos;
    use crate::test_util::{hemisphere_integral, unit};

    fn none(alpha: f32) -> RoughConductor {
        RoughConductor {
            alpha,
            fresnel: ConductorFresnel::One,
            specular_reflectance: [1.0; 3],
        }
    }

    #[test]
    fn material_none_is_the_ggx_lobe() {
        let c = none(0.3);
        let (v, l) = (unit(0.4, 0.1, 0.8), unit(-0.3, 0.2, 0.6));
        assert_eq!(c.eval(v, l), DVec3::splat(ggx_cos(0.3f32 as f64, v, l)));
        assert_eq!(c.eval(-v, l), DVec3::ZERO);
        // α below Mitsuba's floor is clamped.
        assert_eq!(none(0.0).alpha(), 1e-4);
    }

    #[test]
    fn reflectance_is_bounded_by_fresnel_and_tint() {
        // White furnace: ∫ f cos ≤ F_max · k, and close to it at α = 0.1 near normal incidence.
        let c = RoughConductor {
            alpha: 0.1,
            fresnel: ConductorFresnel::Complex {
                eta: [0.2, 0.9, 1.1],
                k: [3.9, 2.4, 2.2],
            },
            specular_reflectance: [0.9, 0.8, 0.7],
        };
        let v = unit(0.1, 0.0, 1.0);
        let albedo = hemisphere_integral(|l| c.eval(v, l), 100);
        let k_s = c.lobes(v).specular.unwrap().weight;
        let ratio = albedo / k_s;
        assert!(
            ratio.max_element() < 1.0 && ratio.min_element() > 0.95,
            "albedo {albedo}, k_s {k_s}"
        );
    }
}
