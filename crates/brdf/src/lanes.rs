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
    use crate::test_util::{bsdfs, pairs};

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
