//! Mitsuba's `blendbsdf`: (1 − w)·f₀ + w·f₁ with the weight clipped to [0, 1]; f₀ is the first
//! nested BSDF in file order.

use crate::lanes::{each_lane, Lanes3};
use crate::real::{Real, V3};
use crate::{Bsdf, Lobes, SpecularLobe};
use glam::DVec3;

#[derive(Clone, Debug, PartialEq)]
pub struct Blend {
    /// The `weight` as given; evaluation clips it to [0, 1] as Mitsuba does.
    pub weight: f32,
    /// The two nested BSDFs in file order.
    pub bsdfs: Box<[Bsdf; 2]>,
}

impl Blend {
    /// The weight w of the second BSDF, clipped to [0, 1].
    #[inline(always)]
    pub fn weight(&self) -> f64 {
        self.weight_in()
    }

    /// [`Blend::weight`] in either precision (the same clip of the same f32 value).
    #[inline(always)]
    fn weight_in<T: Real>(&self) -> T {
        T::of(self.weight.clamp(0.0, 1.0))
    }

    /// f·cos θ_l = (1 − w)·f₀·cos + w·f₁·cos of N lanes from the children's values f₀·cos and
    /// f₁·cos of each lane (evaluate a blend with [`Bsdf::eval`]).
    #[inline(always)]
    pub fn eval_lanes<T: Real, const N: usize>(
        &self,
        f0: &Lanes3<T, N>,
        f1: &Lanes3<T, N>,
    ) -> Lanes3<T, N> {
        each_lane(
            f0,
            f1,
            #[inline(always)]
            |a, b| self.mix(a, b),
        )
    }

    #[inline(always)]
    fn mix<T: Real>(&self, f0: V3<T>, f1: V3<T>) -> V3<T> {
        let w = self.weight_in::<T>();
        f0 * (T::one() - w) + f1 * w
    }

    /// Weighted sums of the children's summaries. When both children have a specular lobe, the
    /// summary keeps the α of the one with the larger weighted mean k_s and the sum of both k_s
    /// (a specular technique then samples that lobe; the other one is still estimated without
    /// bias by both techniques, only with more variance).
    pub fn lobes(&self, v: DVec3) -> Lobes {
        let w = self.weight();
        let (a, b) = (self.bsdfs[0].lobes(v), self.bsdfs[1].lobes(v));
        let scaled = |s: Option<SpecularLobe>, f: f64| {
            s.map(|s| SpecularLobe {
                alpha: s.alpha,
                weight: s.weight * f,
            })
        };
        let specular = match (scaled(a.specular, 1.0 - w), scaled(b.specular, w)) {
            (Some(x), Some(y)) => {
                let alpha = if x.weight.element_sum() >= y.weight.element_sum() {
                    x.alpha
                } else {
                    y.alpha
                };
                Some(SpecularLobe {
                    alpha,
                    weight: x.weight + y.weight,
                })
            }
            (x, None) => x,
            (None, y) => y,
        };
        Lobes {
            diffuse: a.diffuse * (1.0 - w) + b.diffuse * w,
            specular,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::roughconductor::{ConductorFresnel, RoughConductor};
    use crate::test_util::unit;

    fn blend(weight: f32) -> Blend {
        Blend {
            weight,
            bsdfs: Box::new([
                Bsdf::Diffuse {
                    reflectance: [0.7, 0.2, 0.2],
                },
                Bsdf::RoughConductor(RoughConductor {
                    alpha: 0.4,
                    fresnel: ConductorFresnel::One,
                    specular_reflectance: [1.0; 3],
                }),
            ]),
        }
    }

    #[test]
    fn weight_selects_and_is_clipped() {
        let (v, l) = (unit(0.2, 0.3, 0.8), unit(-0.1, -0.3, 0.7));
        // The renderer's path: `Bsdf::eval` of the blend.
        let eval = |weight| Bsdf::Blend(blend(weight)).eval(v, l);
        let [d, c] = &*blend(0.0).bsdfs;
        assert_eq!(eval(0.0), d.eval(v, l));
        assert_eq!(eval(1.0), c.eval(v, l));
        assert_eq!(eval(-2.0), d.eval(v, l));
        assert_eq!(eval(7.0), c.eval(v, l));
        let mid = eval(0.3);
        let w = 0.3f32 as f64;
        let want = (1.0 - w) * d.eval(v, l) + w * c.eval(v, l);
        assert!((mid - want).abs().max_element() < 1e-15);
    }

    #[test]
    fn summary_mixes_both_lobes() {
        let v = unit(0.2, 0.3, 0.8);
        let s = blend(0.25).lobes(v);
        assert!(
            (s.diffuse - DVec3::new(0.7, 0.2, 0.2) * 0.75)
                .abs()
                .max_element()
                < 1e-7
        );
        let spec = s.specular.unwrap();
        assert!((spec.alpha - 0.4).abs() < 1e-7);
        assert_eq!(spec.weight, DVec3::splat(0.25));
    }
}
