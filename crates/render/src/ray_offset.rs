//! Where rays start and stop: the offsets that keep a ray leaving a surface from hitting that
//! surface again and a shadow ray from hitting the light it aims at (Mitsuba's epsilons). Both
//! renderers and the shadow structures use these, so they sit below all of them.

use crate::shapes::{Ray, SurfacePoint};
use glam::Vec3;

/// Mitsuba's ray epsilon for f32 variants: 1500 ulp(1) = 1500·2⁻²⁴.
pub const RAY_EPSILON: f32 = 1500.0 / 16_777_216.0;
/// Shadow rays stop this fraction of their length short of the target.
pub const SHADOW_EPSILON: f32 = 10.0 * RAY_EPSILON;

/// Origin of a ray leaving surface point `p` (geometric normal `ng`) in direction `d`: pushed
/// off the surface to the side `d` points to, by (1 + max|p_i|)·RAY_EPSILON, as Mitsuba does.
#[inline]
pub fn offset_origin(p: Vec3, ng: Vec3, d: Vec3) -> Vec3 {
    let mag = (1.0 + p.abs().max_element()) * RAY_EPSILON;
    let mag = if ng.dot(d) < 0.0 { -mag } else { mag };
    p + mag * ng
}

/// Shadow ray from a surface point to `target`, ending (1 − SHADOW_EPSILON)·distance along.
#[inline]
pub fn shadow_ray_to(sp: &SurfacePoint, target: Vec3) -> Option<Ray> {
    let o = offset_origin(sp.p, sp.ng, target - sp.p);
    let d = target - o;
    let dist = d.length();
    if !(dist > 0.0 && dist.is_finite()) {
        return None;
    }
    Some(Ray {
        o,
        d: d / dist,
        t_min: 0.0,
        t_max: dist * (1.0 - SHADOW_EPSILON),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epsilons_match_mitsuba() {
        assert!((RAY_EPSILON - 8.940697e-5).abs() < 1e-10);
        assert!((1.0 - SHADOW_EPSILON - (1.0 - 8.94e-4)).abs() < 1e-6);
    }

    #[test]
    fn offset_moves_to_the_side_of_the_direction() {
        let p = Vec3::new(3.0, 0.0, 0.0);
        let o = offset_origin(p, Vec3::Z, Vec3::new(1.0, 0.0, -1.0));
        assert!((o - p + Vec3::Z * 4.0 * RAY_EPSILON).length() < 1e-9);
    }
}
