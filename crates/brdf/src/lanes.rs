//! N evaluations at once: directions and RGB values of N lanes as a structure of arrays
//! (`[x, y, z]`, each `[T; N]`, T = f32 or f64: [`Real`]), for [`crate::Bsdf::eval_lanes`].
//!
//! Invariant: lane k of a lane evaluation is bit for bit the scalar evaluation (one lane) of
//! lane k's directions in the same precision. Each model's lane code runs the model's own
//! per-lane code ([`each_lane`]); those are branch-free (every value computed, the zero cases
//! selected at the end: the same bits as early returns), so the compiler turns the lane loop
//! into SIMD instructions, and `+ − × ÷ √` round the same in every instruction set (no fused
//! multiply-add is formed), so the bits do not depend on the CPU either.

use crate::real::{Real, V3};

/// N lanes of a 3-vector (a direction in the shading frame, or an RGB value).
pub use linlight_simd::Lanes3;

/// Lane k of `v`.
#[inline(always)]
pub fn get<T: Real, const N: usize>(v: &Lanes3<T, N>, k: usize) -> V3<T> {
    V3::new(v[0][k], v[1][k], v[2][k])
}

/// Sets lane k of `v` to `x`.
#[inline(always)]
pub fn set<T: Real, const N: usize>(v: &mut Lanes3<T, N>, k: usize, x: V3<T>) {
    v[0][k] = x.x;
    v[1][k] = x.y;
    v[2][k] = x.z;
}

/// The lane code `f` run on the one lane (v, l): the scalar evaluation, bit for bit lane k of
/// `f` on N lanes whose lane k holds (v, l).
#[inline(always)]
pub fn one_lane<T: Real>(
    v: V3<T>,
    l: V3<T>,
    f: impl FnOnce(&Lanes3<T, 1>, &Lanes3<T, 1>) -> Lanes3<T, 1>,
) -> V3<T> {
    get(&f(&[[v.x], [v.y], [v.z]], &[[l.x], [l.y], [l.z]]), 0)
}

/// `f(v_k, l_k)` for every lane k: the loop that vectorises when `f` is branch-free.
#[inline(always)]
pub fn each_lane<T: Real, const N: usize>(
    v: &Lanes3<T, N>,
    l: &Lanes3<T, N>,
    f: impl Fn(V3<T>, V3<T>) -> V3<T>,
) -> Lanes3<T, N> {
    let mut out = [[T::zero(); N]; 3];
    for k in 0..N {
        set(&mut out, k, f(get(v, k), get(l, k)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{bsdfs, mirror_pairs, pairs};

    /// In both precisions: eight lanes (sixteen for f32, as the AVX-512 kernel evaluates them)
    /// equal the scalar evaluation, finite, for every model and nesting and the direction pairs
    /// with the degenerate ones.
    #[test]
    fn lanes_equal_the_scalar_eval_bit_for_bit() {
        let pairs = pairs();
        for bsdf in bsdfs() {
            check::<f64, 8>(
                &pairs,
                |a, b| (a.into(), b.into()),
                |a, b| bsdf.eval(a.into(), b.into()).into(),
                |v, l| bsdf.eval_lanes(v, l),
            );
            let narrow = |a: glam::DVec3, b: glam::DVec3| (a.as_vec3().into(), b.as_vec3().into());
            let scalar = |a: V3<f32>, b: V3<f32>| bsdf.eval_f32(a.into(), b.into()).into();
            check::<f32, 8>(&pairs, narrow, scalar, |v, l| bsdf.eval_lanes(v, l));
            check::<f32, 16>(&pairs, narrow, scalar, |v, l| bsdf.eval_lanes(v, l));
        }
    }

    /// The renderer's f32 evaluation against the f64 one of the same (f32) directions: zero
    /// exactly where f64 is zero, and relative error per channel ≤ 1e-5 (≈ 170 ulps of f32)
    /// wherever the f64 value exceeds 1e-30 (below, it stays ≤ 1e-6 of the set's largest), on
    /// the random pairs and on pairs at k·α/4 (k ≤ 40) from the mirror direction for α = 1e-4
    /// (the sharp conductor, whose lobe no random pair meets), 1e-3 and 0.2. Measured over
    /// every model and nesting of `bsdfs()`: worst 1.14e-6 (≈ 19 ulps).
    #[test]
    fn f32_eval_is_the_f64_eval_to_f32_precision() {
        let (mut worst, mut worst_small) = (0.0f64, 0.0f64);
        for bsdf in bsdfs() {
            let pairs: Vec<_> = pairs()
                .into_iter()
                .chain(mirror_pairs(1e-4))
                .chain(mirror_pairs(1e-3))
                .chain(mirror_pairs(0.2))
                .map(|(a, b)| (a.as_vec3(), b.as_vec3()))
                .collect();
            let wide: Vec<_> = pairs
                .iter()
                .map(|&(a, b)| bsdf.eval(a.as_dvec3(), b.as_dvec3()))
                .collect();
            let max = wide.iter().map(|f| f.max_element()).fold(0.0, f64::max);
            for (&(a, b), want) in pairs.iter().zip(&wide) {
                let got = bsdf.eval_f32(a, b).as_dvec3();
                for c in 0..3 {
                    let (g, w) = (got[c], want[c]);
                    assert_eq!(
                        g == 0.0,
                        w == 0.0,
                        "{bsdf:?}, v {a}, l {b}: f32 {g}, f64 {w}"
                    );
                    if w.abs() > 1e-30 {
                        let e = (g - w).abs() / w.abs();
                        worst = worst.max(e);
                        assert!(e <= 1e-5, "{bsdf:?}, v {a}, l {b}: f32 {g}, f64 {w}: {e:e}");
                    } else {
                        worst_small = worst_small.max((g - w).abs() / max);
                        assert!((g - w).abs() <= 1e-6 * max, "{bsdf:?}, v {a}, l {b}");
                    }
                }
            }
        }
        println!("worst relative error {worst:e}; below 1e-6 of the maximum: {worst_small:e}");
    }

    fn check<T: Real, const N: usize>(
        pairs: &[(glam::DVec3, glam::DVec3)],
        convert: impl Fn(glam::DVec3, glam::DVec3) -> (V3<T>, V3<T>),
        scalar: impl Fn(V3<T>, V3<T>) -> V3<T>,
        lanes: impl Fn(&Lanes3<T, N>, &Lanes3<T, N>) -> Lanes3<T, N>,
    ) {
        for chunk in pairs.chunks(N) {
            let (mut v, mut l) = ([[T::zero(); N]; 3], [[T::zero(); N]; 3]);
            for (k, &(a, b)) in chunk.iter().enumerate() {
                let (a, b) = convert(a, b);
                set(&mut v, k, a);
                set(&mut l, k, b);
            }
            let f = lanes(&v, &l);
            for k in 0..chunk.len() {
                let (lane, want) = (get(&f, k), scalar(get(&v, k), get(&l, k)));
                let bits = |x: V3<T>| [x.x, x.y, x.z].map(|c| c.to_f64().map(f64::to_bits));
                assert_eq!(
                    bits(lane),
                    bits(want),
                    "{N} lanes of {}, v {:?}, l {:?}: lane {lane:?}, scalar {want:?}",
                    std::any::type_name::<T>(),
                    get(&v, k),
                    get(&l, k)
                );
                assert!(
                    [want.x, want.y, want.z].iter().all(|c| c.is_finite()),
                    "v {:?}, l {:?}: {want:?}",
                    get(&v, k),
                    get(&l, k)
                );
            }
        }
    }
}
