//! The BSDF of a surface: one of Mitsuba's plugins this crate reproduces, evaluated in the
//! shading frame, and the lobe summary that steers multiple importance sampling.

use crate::blendbsdf::Blend;
use crate::lanes::{self, each_lane, Lanes3};
use crate::principled::Principled;
use crate::real::{Real, V3};
use crate::roughconductor::RoughConductor;
use crate::{diffuse, twosided};
use glam::{DVec3, Vec3};

/// Linear RGB parameters, stored in single precision as Mitsuba stores them.
pub type Rgb = [f32; 3];

/// A BSDF as the scene file describes it. Only [`Bsdf::TwoSided`] reflects on the back side;
/// every other variant is one-sided (zero unless v_z > 0 and l_z > 0), as in Mitsuba.
#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    /// `diffuse`: Lambertian, f = reflectance/π.
    Diffuse { reflectance: Rgb },
    /// `roughconductor` (GGX, isotropic).
    RoughConductor(RoughConductor),
    /// `principled` (reflection lobes only).
    Principled(Principled),
    /// `blendbsdf` of two BSDFs.
    Blend(Blend),
    /// `twosided`: the nested BSDF on both sides. `eval` follows Mitsuba anywhere in the tree,
    /// but the scene loader accepts it only as the outermost BSDF, so that a renderer can flip
    /// its shading frame toward the viewer exactly when [`Bsdf::is_two_sided`] says so.
    TwoSided(Box<Bsdf>),
}

/// Per-shading-point summary of a BSDF seen from direction v, for the weights of a
/// diffuse + specular MIS estimator (all per RGB channel, all ≥ 0 for physical parameters):
///
/// - `diffuse` = ρ_d, an estimate of the directional albedo of the non-specular part. The MIS
///   weight of the diffuse (projected-solid-angle) technique is W_d = max(ρ_d, 0.01)·Ω⊥_R, and
///   with no specular lobe the integrator samples diffusely only.
/// - `specular` = the GGX lobe, if any: its α (as evaluated, after Mitsuba's clamping) selects
///   the LTC table entry, and `weight` = k_s is the Fresnel × tint factor the table's F ≡ 1
///   albedo ρ_s multiplies: W_s = k_s·ρ_s·Ω⊥_o/κ.
///
/// The summary is an *estimate*: weights built from it change the variance of an MIS
/// estimator, never its expectation, so models are free to approximate (e.g. Fresnel at the
/// mirror configuration instead of its average over the lobe).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobes {
    pub diffuse: DVec3,
    pub specular: Option<SpecularLobe>,
}

/// The GGX lobe of a [`Lobes`] summary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularLobe {
    /// GGX roughness α of the lobe (isotropic).
    pub alpha: f64,
    /// k_s per channel: the factor between the lobe and the F ≡ 1 GGX lobe of the same α.
    pub weight: DVec3,
}

impl Lobes {
    /// Nothing reflects (the viewer is behind a one-sided BSDF).
    pub const BLACK: Lobes = Lobes {
        diffuse: DVec3::ZERO,
        specular: None,
    };
}

impl Bsdf {
    /// f(v, l)·|l_z|: the BSDF value times the cosine at the light direction, exactly what
    /// Mitsuba's `BSDF.eval(ctx, si, wo)` returns with `si.wi = v`, `wo = l`. Both directions
    /// are unit vectors in the shading frame (z = shading normal), v toward the viewer, l toward
    /// the light. Per RGB channel, f64: for reference computations (the render crate's line
    /// quadrature, its power controls' deliberately wrong models) and tests; the renderer
    /// shades in f32 ([`Bsdf::eval_f32`], [`Bsdf::eval_lanes`]).
    ///
    /// This is the lane code with one lane ([`Bsdf::eval_lanes`]), so that both give the same
    /// bits.
    pub fn eval(&self, v: DVec3, l: DVec3) -> DVec3 {
        debug_assert!(
            (v.length_squared() - 1.0).abs() < 1e-4 && (l.length_squared() - 1.0).abs() < 1e-4,
            "Bsdf::eval: v {v}, l {l} are not unit vectors"
        );
        self.eval_one::<f64>(v.into(), l.into()).into()
    }

    /// [`Bsdf::eval`] in f32, as Mitsuba evaluates its BSDFs: what the renderer shades with,
    /// the lane code with one lane ([`Bsdf::eval_lanes`] in f32), so that the renderer's
    /// scalar path and its packets give the same bits. Within 1e-5 relative (worst measured
    /// 1.1e-6) of the f64 evaluation of the same (f32) directions, per channel, wherever that
    /// exceeds 1e-30 (test `f32_eval_is_the_f64_eval_to_f32_precision`).
    pub fn eval_f32(&self, v: Vec3, l: Vec3) -> Vec3 {
        debug_assert!(
            (v.length_squared() - 1.0).abs() < 1e-4 && (l.length_squared() - 1.0).abs() < 1e-4,
            "Bsdf::eval_f32: v {v}, l {l} are not unit vectors"
        );
        self.eval_one::<f32>(v.into(), l.into()).into()
    }

    /// One lane of [`Bsdf::eval_lanes`] in either precision.
    fn eval_one<T: Real>(&self, v: V3<T>, l: V3<T>) -> V3<T> {
        lanes::one_lane(v, l, |v, l| self.eval_lanes(v, l))
    }

    /// [`Bsdf::eval`] of N lanes at once in f32 or f64 (directions and values as structures of
    /// arrays, [`crate::lanes`]); lane k is bit for bit the one-lane evaluation of lane k's
    /// directions in the same precision ([`Bsdf::eval`], [`Bsdf::eval_f32`]). The models'
    /// lane loops vectorise (SIMD width of the instruction set the caller is compiled for:
    /// sixteen f32 or eight f64 lanes per 512-bit register): `twosided`, `blendbsdf` and the
    /// leaf models are written out to that depth, deeper nestings evaluate their inner BSDFs
    /// lane by lane.
    #[inline(always)]
    pub fn eval_lanes<T: Real, const N: usize>(
        &self,
        v: &Lanes3<T, N>,
        l: &Lanes3<T, N>,
    ) -> Lanes3<T, N> {
        match self {
            Bsdf::TwoSided(inner) => {
                let (v, l) = twosided::flip_lanes(v, l);
                inner.eval_one_sided_lanes(&v, &l)
            }
            _ => self.eval_one_sided_lanes(v, l),
        }
    }

    #[inline(always)]
    fn eval_one_sided_lanes<T: Real, const N: usize>(
        &self,
        v: &Lanes3<T, N>,
        l: &Lanes3<T, N>,
    ) -> Lanes3<T, N> {
        match self {
            Bsdf::Blend(b) => b.eval_lanes(
                &b.bsdfs[0].eval_leaf_lanes(v, l),
                &b.bsdfs[1].eval_leaf_lanes(v, l),
            ),
            _ => self.eval_leaf_lanes(v, l),
        }
    }

    #[inline(always)]
    fn eval_leaf_lanes<T: Real, const N: usize>(
        &self,
        v: &Lanes3<T, N>,
        l: &Lanes3<T, N>,
    ) -> Lanes3<T, N> {
        match self {
            Bsdf::Diffuse { reflectance } => each_lane(
                v,
                l,
                #[inline(always)]
                |v, l| diffuse::eval_in(*reflectance, v, l),
            ),
            Bsdf::RoughConductor(c) => c.eval_lanes(v, l),
            Bsdf::Principled(p) => each_lane(
                v,
                l,
                #[inline(always)]
                |v, l| p.eval_in(v, l),
            ),
            // Nested blends and two-sided BSDFs: the one-lane code per lane.
            Bsdf::Blend(_) | Bsdf::TwoSided(_) => each_lane(v, l, |v, l| self.eval_one(v, l)),
        }
    }

    /// The lobe summary seen from v (shading frame); [`Lobes::BLACK`] when the viewer is behind
    /// a one-sided BSDF.
    pub fn lobes(&self, v: DVec3) -> Lobes {
        match self {
            Bsdf::Diffuse { reflectance } => diffuse::lobes(*reflectance, v),
            Bsdf::RoughConductor(c) => c.lobes(v),
            Bsdf::Principled(p) => p.lobes(v),
            Bsdf::Blend(b) => b.lobes(v),
            Bsdf::TwoSided(inner) => twosided::lobes(inner, v),
        }
    }

    /// Whether the BSDF reflects light on the back side too (only `twosided` does).
    #[inline]
    pub fn is_two_sided(&self) -> bool {
        matches!(self, Bsdf::TwoSided(_))
    }

    /// Some(ρ) iff the BSDF is exactly Lambertian on the side it reflects on (eval = ρ/π·l_z
    /// there): `diffuse`, blends of Lambertians, and `twosided` of those. Lets a renderer keep
    /// its fast path for diffuse surfaces.
    pub fn lambertian(&self) -> Option<DVec3> {
        match self {
            Bsdf::Diffuse { reflectance } => Some(diffuse::rgb(*reflectance)),
            Bsdf::Blend(b) => {
                let w = b.weight();
                let [first, second] = &*b.bsdfs;
                Some(first.lambertian()? * (1.0 - w) + second.lambertian()? * w)
            }
            Bsdf::TwoSided(inner) => inner.lambertian(),
            Bsdf::RoughConductor(_) | Bsdf::Principled(_) => None,
        }
    }

    /// Mitsuba's plugin name, for messages.
    pub fn plugin_name(&self) -> &'static str {
        match self {
            Bsdf::Diffuse { .. } => "diffuse",
            Bsdf::RoughConductor(_) => "roughconductor",
            Bsdf::Principled(_) => "principled",
            Bsdf::Blend(_) => "blendbsdf",
            Bsdf::TwoSided(_) => "twosided",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::roughconductor::ConductorFresnel;
    use crate::test_util::unit;

    #[test]
    fn lambertian_fast_path_agrees_with_eval() {
        let d = |r: f32| Bsdf::Diffuse {
            reflectance: [r, 0.5, 0.1],
        };
        let blend = Bsdf::Blend(Blend {
            weight: 0.3,
            bsdfs: Box::new([d(0.2), d(0.9)]),
        });
        let two = Bsdf::TwoSided(Box::new(blend.clone()));
        let (v, l) = (unit(0.3, 0.1, 0.9), unit(-0.5, 0.2, 0.4));
        for b in [d(0.4), blend, two] {
            let rho = b.lambertian().unwrap();
            let want = rho * std::f64::consts::FRAC_1_PI * l.z;
            assert!((b.eval(v, l) - want).abs().max_element() < 1e-15, "{b:?}");
        }
        let c = Bsdf::RoughConductor(RoughConductor {
            alpha: 0.2,
            fresnel: ConductorFresnel::One,
            specular_reflectance: [1.0; 3],
        });
        assert!(c.lambertian().is_none());
        assert_eq!(c.plugin_name(), "roughconductor");
        assert!(Bsdf::TwoSided(Box::new(c.clone())).is_two_sided() && !c.is_two_sided());
    }
}
