//! The lane layout of 3-vectors, and lanes on a cache line.

use glam::Vec3;

/// N lanes of a 3-vector as a structure of arrays: `[x, y, z]`, each `[T; N]` (T = f32 or
/// f64). The one layout of the samplers' batches, the BSDF lanes and the packet renderer.
pub type Lanes3<T, const N: usize> = [[T; N]; 3];

/// Lane k of `v` as `[x, y, z]`.
#[inline(always)]
pub fn lane3<T: Copy, const N: usize>(v: &Lanes3<T, N>, k: usize) -> [T; 3] {
    [v[0][k], v[1][k], v[2][k]]
}

/// Sets lane k of `v` to `x`.
#[inline(always)]
pub fn set_lane3<T: Copy, const N: usize>(v: &mut Lanes3<T, N>, k: usize, x: [T; 3]) {
    (v[0][k], v[1][k], v[2][k]) = (x[0], x[1], x[2]);
}

/// Lane k of f32 lanes as a vector.
#[inline(always)]
pub fn get3<const N: usize>(v: &Lanes3<f32, N>, k: usize) -> Vec3 {
    Vec3::new(v[0][k], v[1][k], v[2][k])
}

/// Sets lane k of f32 lanes to `x`.
#[inline(always)]
pub fn set3<const N: usize>(v: &mut Lanes3<f32, N>, k: usize, x: Vec3) {
    (v[0][k], v[1][k], v[2][k]) = (x.x, x.y, x.z);
}

/// `v` in every lane.
#[inline(always)]
pub fn splat3<const N: usize>(v: Vec3) -> Lanes3<f32, N> {
    [[v.x; N], [v.y; N], [v.z; N]]
}

/// Zero in every lane (arrays of a generic length have no `Default`).
#[inline(always)]
pub fn zero3<const N: usize>() -> Lanes3<f32, N> {
    [[0.0; N]; 3]
}

/// `T` at a 64-byte boundary. Lane arrays are read and written as whole registers (16 f32
/// lanes: 64 bytes with AVX-512); at the 4-byte alignment of `[f32; 16]` most of those accesses
/// split a cache line, and a store split over two lines does not forward to the whole-register
/// load that reads it back. Locals of lanes are wrapped in it; structs of lanes are
/// `#[repr(C, align(64))]` with their arrays first.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct Aligned<T>(pub T);

impl<T> std::ops::Deref for Aligned<T> {
    type Target = T;
    #[inline(always)]
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<T> std::ops::DerefMut for Aligned<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut T {
        &mut self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_round_trip_and_align() {
        let mut v = zero3::<16>();
        set3(&mut v, 5, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(get3(&v, 5), Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(lane3(&v, 5), [1.0, 2.0, 3.0]);
        assert_eq!(get3(&v, 4), Vec3::ZERO);
        let mut w: Lanes3<f64, 2> = [[0.0; 2]; 3];
        set_lane3(&mut w, 1, [4.0, 5.0, 6.0]);
        assert_eq!(w, [[0.0, 4.0], [0.0, 5.0], [0.0, 6.0]]);
        assert_eq!(splat3::<2>(Vec3::X), [[1.0; 2], [0.0; 2], [0.0; 2]]);
        assert_eq!(std::mem::align_of::<Aligned<[f32; 16]>>(), 64);
    }
}
