//! Mitsuba's `diffuse`: a one-sided Lambertian reflector, f = ρ/π.

use crate::real::{Real, V3};
use crate::{Lobes, Rgb};
use glam::DVec3;

/// ρ/π · l_z (cosine included) for v_z > 0 and l_z > 0, else 0, in either precision (evaluate
/// it with `Bsdf::eval`). Branch-free (computed, then selected) for the lanes of
/// `Bsdf::eval_lanes`.
#[inline(always)]
pub(crate) fn eval_in<T: Real>(reflectance: Rgb, v: V3<T>, l: V3<T>) -> V3<T> {
    let value = V3::rgb(reflectance) * (T::c(std::f64::consts::FRAC_1_PI) * l.z);
    if v.z > T::zero() && l.z > T::zero() {
        value
    } else {
        V3::zero()
    }
}

/// ρ_d = ρ (the directional albedo of a Lambertian reflector, exact); no specular lobe.
pub fn lobes(reflectance: Rgb, v: DVec3) -> Lobes {
    if !(v.z > 0.0) {
        return Lobes::BLACK;
    }
    Lobes {
        diffuse: rgb(reflectance),
        specular: None,
    }
}

#[inline(always)]
pub(crate) fn rgb(c: Rgb) -> DVec3 {
    DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{hemisphere_integral, unit};
    use crate::Bsdf;

    #[test]
    fn albedo_is_the_reflectance_and_back_is_black() {
        let rho = [0.2, 0.5, 0.8];
        let eval = |v, l| Bsdf::Diffuse { reflectance: rho }.eval(v, l);
        let v = unit(0.3, -0.2, 0.7);
        let a = hemisphere_integral(|l| eval(v, l), 64);
        assert!((a - rgb(rho)).abs().max_element() < 1e-9, "{a}");
        assert_eq!(eval(-v, v), DVec3::ZERO);
        assert_eq!(eval(v, DVec3::new(v.x, v.y, -v.z)), DVec3::ZERO);
        assert_eq!(lobes(rho, v).diffuse, rgb(rho));
        assert_eq!(lobes(rho, -v), Lobes::BLACK);
    }
}
