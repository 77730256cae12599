//! N evaluations at once: directions and RGB values of N lanes as a structure of arrays
//! (`[x, y, z]`, each `[f64; N]`), for [`crate::Bsdf::eval_lanes`].
//!
//! Invariant: lane k of a lane evaluation is bit for bit the scalar evaluation of lane k's
//! directions. Each model's lane code runs the model's own scalar `eval` per lane
//! ([`each_lane`]); those are branch-free (every value computed, the zero cases selected at
//! the end: the same bits as early returns), so the compiler turns the lane loop into SIMD
//! instructions, and f64 `+ − × ÷ √` round the same in every instruction set (no fused
//! multiply-add is formed), so the bits do not depend on the CPU either.

use glam::DVec3;

/// N lanes of a 3-vector (a direction in the shading frame, or an RGB value).
pub type Lanes3<const N: usize> = [[f64; N]; 3];

/// Lane k of `v`.
#[inline(always)]
pub fn get<const N: usize>(v: &Lanes3<N>, k: usize) -> DVec3 {
    DVec3::new(v[0][k], v[1][k], v[2][k])
}

/// Sets lane k of `v` to `x`.
#[inline(always)]
pub fn set<const N: usize>(v: &mut Lanes3<N>, k: usize, x: DVec3) {
    v[0][k] = x.x;
    v[1][k] = x.y;
    v[2][k] = x.z;
}

/// `f(v_k, l_k)` for every lane k: the loop that vectorises when `f` is branch-free.
#[inline(always)]
pub fn each_lane<const N: usize>(
    v: &Lanes3<N>,
    l: &Lanes3<N>,
    f: impl Fn(DVec3, DVec3) -> DVec3,
) -> Lanes3<N> {
    let mut out = [[0.0; N]; 3];
    for k in 0..N {
        set(&mut out, k, f(get(v, k), get(l, k)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Blend, Bsdf, ConductorFresnel, Principled, RoughConductor};

    fn conductor(alpha: f32, fresnel: ConductorFresnel) -> Bsdf {
        Bsdf::RoughConductor(RoughConductor {
            alpha,
            fresnel,
            specular_reflectance: [0.9, 0.7, 0.5],
        })
    }

    fn blend(weight: f32, a: Bsdf, b: Bsdf) -> Bsdf {
        Bsdf::Blend(Blend {
            weight,
            bsdfs: Box::new([a, b]),
        })
    }

    /// Every model and nesting the lanes write out (and one deeper), with the parameters that
    /// switch terms on and off.
    fn bsdfs() -> Vec<Bsdf> {
        let gold = ConductorFresnel::Complex {
            eta: [0.143, 0.375, 1.442],
            k: [3.983, 2.386, 1.603],
        };
        let diffuse = Bsdf::Diffuse {
            reflectance: [0.25, 0.45, 0.6],
        };
        let principled = |metallic, spec_tint, flatness| {
            Bsdf::Principled(Principled {
                base_color: [0.55, 0.35, 0.25],
                roughness: 0.4,
                metallic,
                spec_tint,
                flatness,
                ..Principled::new()
            })
        };
        let mut out = vec![
            diffuse.clone(),
            conductor(0.3, ConductorFresnel::One),
            conductor(0.0, gold.clone()),
            conductor(0.2, gold.clone()),
            principled(0.0, 0.0, 0.0),
            principled(0.5, 0.3, 0.6),
            principled(1.0, 0.0, 0.0),
            Bsdf::Principled(Principled {
                eta: 1.0,
                ..Principled::new()
            }),
            blend(0.35, diffuse.clone(), conductor(0.2, gold.clone())),
            blend(
                0.5,
                blend(0.3, diffuse.clone(), principled(0.0, 0.0, 0.0)),
                diffuse,
            ),
        ];
        let two: Vec<Bsdf> = out
            .iter()
            .map(|b| Bsdf::TwoSided(Box::new(b.clone())))
            .collect();
        out.extend(two);
        out
    }

    /// Directions: random unit vectors on the sphere (both sides) and the degenerate cases
    /// (v = −l: no half vector; l = v = n; grazing; exactly in the horizon).
    fn pairs() -> Vec<(DVec3, DVec3)> {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut unit = || loop {
            let d = DVec3::new(next(), next(), next());
            if d.length_squared() > 1e-3 && d.length_squared() <= 1.0 {
                return d.normalize();
            }
        };
        let mut out: Vec<(DVec3, DVec3)> = (0..2000).map(|_| (unit(), unit())).collect();
        let v = DVec3::new(0.3, -0.2, 0.9).normalize();
        let grazing = DVec3::new(1.0, 0.0, 1e-9).normalize();
        let horizon = DVec3::new(0.6, 0.8, 0.0);
        out.extend([
            (v, -v),
            (DVec3::Z, DVec3::Z),
            (-DVec3::Z, -DVec3::Z),
            (v, grazing),
            (grazing, v),
            (v, horizon),
            (horizon, v),
            (v, DVec3::new(-v.x, -v.y, v.z)),
        ]);
        out
    }

    #[test]
    fn lanes_equal_the_scalar_eval_bit_for_bit() {
        const N: usize = 8;
        let pairs = pairs();
        for bsdf in bsdfs() {
            for chunk in pairs.chunks(N) {
                let (mut v, mut l) = ([[0.0; N]; 3], [[0.0; N]; 3]);
                for (k, &(a, b)) in chunk.iter().enumerate() {
                    set(&mut v, k, a);
                    set(&mut l, k, b);
                }
                let f = bsdf.eval_lanes(&v, &l);
                for (k, &(a, b)) in chunk.iter().enumerate() {
                    let (lane, scalar) = (get(&f, k), bsdf.eval(a, b));
                    assert_eq!(
                        lane.to_array().map(f64::to_bits),
                        scalar.to_array().map(f64::to_bits),
                        "{bsdf:?}, v {a}, l {b}: lane {lane}, scalar {scalar}"
                    );
                    assert!(scalar.is_finite(), "{bsdf:?}, v {a}, l {b}: {scalar}");
                }
            }
        }
    }
}
