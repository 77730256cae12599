//! Mitsuba's `twosided` with one nested BSDF: seen from below (v_z < 0) both directions are
//! mirrored through the surface, so the nested one-sided BSDF reflects on both sides.

use crate::lanes::{self, Lanes3};
use crate::real::{Real, V3};
use crate::{Bsdf, Lobes};
use glam::DVec3;

/// Mitsuba's rule: l_z takes the sign of v_z relative to the flip, v_z becomes |v_z|.
#[inline(always)]
fn flip<T: Real>(v: V3<T>, l: V3<T>) -> (V3<T>, V3<T>) {
    if v.z.is_sign_negative() {
        (V3::new(v.x, v.y, -v.z), V3::new(l.x, l.y, -l.z))
    } else {
        (v, l)
    }
}

/// [`flip`] of N lanes (v, l as structures of arrays).
#[inline(always)]
pub(crate) fn flip_lanes<T: Real, const N: usize>(
    v: &Lanes3<T, N>,
    l: &Lanes3<T, N>,
) -> (Lanes3<T, N>, Lanes3<T, N>) {
    let (mut fv, mut fl) = (*v, *l);
    for k in 0..N {
        let (a, b) = flip(lanes::get(v, k), lanes::get(l, k));
        lanes::set(&mut fv, k, a);
        lanes::set(&mut fl, k, b);
    }
    (fv, fl)
}

/// The nested BSDF's summary on the viewer's side.
pub fn lobes(inner: &Bsdf, v: DVec3) -> Lobes {
    inner.lobes(flip::<f64>(v.into(), v.into()).0.into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::principled::Principled;
    use crate::test_util::unit;

    #[test]
    fn below_mirrors_above() {
        let inner = Bsdf::Principled(Principled {
            metallic: 0.3,
            ..Principled::new()
        });
        let (v, l) = (unit(0.2, 0.3, 0.8), unit(-0.1, -0.3, 0.7));
        let m = |d: DVec3| DVec3::new(d.x, d.y, -d.z);
        let two = Bsdf::TwoSided(Box::new(inner.clone()));
        assert_eq!(two.eval(m(v), m(l)), inner.eval(v, l));
        assert_eq!(two.eval(v, l), inner.eval(v, l));
        assert_eq!(two.eval(m(v), l), DVec3::ZERO);
        assert_eq!(lobes(&inner, m(v)), inner.lobes(v));
    }
}
