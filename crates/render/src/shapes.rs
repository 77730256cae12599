//! Ray-primitive intersection for the shapes of the scene IR: triangles, spheres, disks and
//! finite open cylinders. Distances t are along the (not necessarily unit) ray direction; a hit
//! counts when `t_min < t < t_max`.

use glam::{Mat4, Vec3};

/// A ray o + t·d restricted to t ∈ (t_min, t_max).
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

/// Axis-aligned box; the empty box has min = +∞, max = −∞.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Half the surface area (enough for SAH ratios); 0 for the empty box.
    pub fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// Intersection record: distance and primitive-specific surface coordinates (barycentrics of
/// vertices 1 and 2 for triangles, unused otherwise).
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub b1: f32,
    pub b2: f32,
}

/// One intersectable primitive. `shape` indexes `Scene::shapes`.
#[derive(Clone, Debug)]
pub enum Primitive {
    Triangle {
        v: [Vec3; 3],
        n: Option<[Vec3; 3]>,
        shape: u32,
    },
    Sphere {
        center: Vec3,
        radius: f32,
        shape: u32,
    },
    /// Unit disk of the local xy-plane; `to_local` is the inverse of its to_world, its
    /// columns as [`Mat4::to_cols_array`] (made by [`Primitive::disk`]). Only the inverse is
    /// stored, and as an array of 4-byte alignment: a 16-byte aligned `Mat4` would pad every
    /// primitive, triangles included, from 84 to 96 bytes.
    Disk {
        to_local: [f32; 16],
        normal: Vec3,
        shape: u32,
    },
    /// Open cylinder around the segment p0 → p0 + axis·length (axis unit).
    Cylinder {
        p0: Vec3,
        axis: Vec3,
        length: f32,
        radius: f32,
        shape: u32,
    },
}

/// Surface point of a closest hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Unit geometric normal (after flip_normals).
    pub ng: Vec3,
    /// Unit shading normal (interpolated vertex normal, else ng; after flip_normals).
    pub ns: Vec3,
    pub shape: u32,
}

impl Primitive {
    /// The unit disk of the local xy-plane under the inverse `to_local` of its to_world.
    pub fn disk(to_local: Mat4, shape: u32) -> Self {
        Primitive::Disk {
            to_local: to_local.to_cols_array(),
            normal: transformed_normal(&to_local),
            shape,
        }
    }

    pub fn shape(&self) -> u32 {
        match *self {
            Primitive::Triangle { shape, .. }
            | Primitive::Sphere { shape, .. }
            | Primitive::Disk { shape, .. }
            | Primitive::Cylinder { shape, .. } => shape,
        }
    }

    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        match *self {
            Primitive::Triangle { v, .. } => v.iter().for_each(|&p| b.grow(p)),
            Primitive::Sphere { center, radius, .. } => {
                b.grow(center - Vec3::splat(radius));
                b.grow(center + Vec3::splat(radius));
            }
            Primitive::Disk { to_local, .. } => {
                let to_world = Mat4::from_cols_array(&to_local).inverse();
                for (x, y) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
                    b.grow(to_world.transform_point3(Vec3::new(x, y, 0.0)));
                }
            }
            Primitive::Cylinder {
                p0,
                axis,
                length,
                radius,
                ..
            } => {
                // Extent of a circle of radius r perpendicular to a along axis i: r·√(1 − a_i²).
                let e = radius * (Vec3::ONE - axis * axis).max(Vec3::ZERO).map(f32::sqrt);
                let p1 = p0 + axis * length;
                b.grow(p0 - e);
                b.grow(p0 + e);
                b.grow(p1 - e);
                b.grow(p1 + e);
            }
        }
        b
    }

    /// Closest intersection in (t_min, t_max), as (t, b1, b2).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32, f32)> {
        match *self {
            Primitive::Triangle { v, .. } => intersect_triangle(ray, v),
            Primitive::Sphere { center, radius, .. } => {
                let oc = (ray.o - center).as_dvec3();
                let d = ray.d.as_dvec3();
                let (a, half_b, c) = (d.dot(d), oc.dot(d), oc.dot(oc) - (radius as f64).powi(2));
                nearest_root(a, half_b, c, ray, |_| true)
            }
            Primitive::Disk { to_local, .. } => {
                let to_local = Mat4::from_cols_array(&to_local);
                let o = to_local.transform_point3(ray.o);
                let d = to_local.transform_vector3(ray.d);
                let t = -o.z / d.z;
                let q = o + t * d;
                (t > ray.t_min && t < ray.t_max && q.x * q.x + q.y * q.y <= 1.0)
                    .then_some((t, 0.0, 0.0))
            }
            Primitive::Cylinder {
                p0,
                axis,
                length,
                radius,
                ..
            } => {
                let a = axis.as_dvec3();
                let o = (ray.o - p0).as_dvec3();
                let d = ray.d.as_dvec3();
                let o_perp = o - o.dot(a) * a;
                let d_perp = d - d.dot(a) * a;
                let (qa, half_b, c) = (
                    d_perp.dot(d_perp),
                    o_perp.dot(d_perp),
                    o_perp.dot(o_perp) - (radius as f64).powi(2),
                );
                let len = length as f64;
                nearest_root(qa, half_b, c, ray, |t| {
                    let h = (o + t * d).dot(a);
                    (0.0..=len).contains(&h)
                })
            }
        }
    }

    /// Surface point of a hit found by `intersect`.
    pub fn surface_point(&self, ray: &Ray, hit: &Hit, flip_normals: bool) -> SurfacePoint {
        let (p, ng, ns, shape) = match *self {
            Primitive::Triangle { v, n, shape } => {
                let b0 = 1.0 - hit.b1 - hit.b2;
                let p = b0 * v[0] + hit.b1 * v[1] + hit.b2 * v[2];
                let ng = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                let ns = n
                    .map(|n| (b0 * n[0] + hit.b1 * n[1] + hit.b2 * n[2]).normalize_or_zero())
                    .filter(|ns| *ns != Vec3::ZERO)
                    .unwrap_or(ng);
                (p, ng, ns, shape)
            }
            Primitive::Sphere {
                center,
                radius,
                shape,
            } => {
                let ng = (ray.o + hit.t * ray.d - center).normalize_or_zero();
                (center + radius * ng, ng, ng, shape)
            }
            Primitive::Disk { normal, shape, .. } => (ray.o + hit.t * ray.d, normal, normal, shape),
            Primitive::Cylinder {
                p0, axis, shape, ..
            } => {
                let p = ray.o + hit.t * ray.d;
                let r = p - p0;
                let ng = (r - r.dot(axis) * axis).normalize_or_zero();
                (p, ng, ng, shape)
            }
        };
        let sign = if flip_normals { -1.0 } else { 1.0 };
        SurfacePoint {
            p,
            ng: sign * ng,
            ns: sign * ns,
            shape,
        }
    }
}

/// Smallest root of a t² + 2·half_b t + c = 0 inside the ray interval that passes `accept`,
/// computed in f64 (thin shapes far from the origin lose everything in f32).
fn nearest_root(
    a: f64,
    half_b: f64,
    c: f64,
    ray: &Ray,
    accept: impl Fn(f64) -> bool,
) -> Option<(f32, f32, f32)> {
    if !(a > 0.0) {
        return None;
    }
    let disc = half_b * half_b - a * c;
    if !(disc >= 0.0) {
        return None;
    }
    // Numerically stable pair of roots.
    let q = -(half_b + disc.sqrt().copysign(half_b));
    let (r1, r2) = if q != 0.0 { (q / a, c / q) } else { (0.0, 0.0) };
    let (lo, hi) = if r1 <= r2 { (r1, r2) } else { (r2, r1) };
    for t in [lo, hi] {
        let tf = t as f32;
        if tf > ray.t_min && tf < ray.t_max && accept(t) {
            return Some((tf, 0.0, 0.0));
        }
    }
    None
}

/// Möller–Trumbore; double-sided. Returns (t, b1, b2).
#[inline]
fn intersect_triangle(ray: &Ray, v: [Vec3; 3]) -> Option<(f32, f32, f32)> {
    intersect_triangle_edges(ray, v[0], v[1] - v[0], v[2] - v[0])
}

/// [`intersect_triangle_edges`] without branches, for the lanes of a ray packet: the same
/// arithmetic (so bitwise the same (t, b1, b2) where it hits), every value computed, and whether
/// it hits within (t_min, t_max).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn intersect_triangle_lane(
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
) -> (f32, f32, f32, bool) {
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    let inv = 1.0 / det;
    let tvec = o - v0;
    let b1 = tvec.dot(pvec) * inv;
    let qvec = tvec.cross(e1);
    let b2 = d.dot(qvec) * inv;
    let t = e2.dot(qvec) * inv;
    // `&`, not `&&`: no branch per condition.
    #[allow(clippy::manual_range_contains)]
    let hit = (det != 0.0)
        & det.is_finite()
        & (b1 >= 0.0)
        & (b1 <= 1.0)
        & (b2 >= 0.0)
        & (b1 + b2 <= 1.0)
        & (t > t_min)
        & (t < t_max);
    (t, b1, b2, hit)
}

/// The sphere test of [`Primitive::intersect`] without branches, for the lanes of a ray
/// packet: the same f64 arithmetic in the same order (so bitwise the same t where it hits),
/// every value computed, and whether the nearest root inside (t_min, t_max) exists. `r2` is
/// `(radius as f64).powi(2)` (exact: the square of an f32 fits an f64).
#[inline(always)]
pub fn intersect_sphere_lane(
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
    center: Vec3,
    r2: f64,
) -> (f32, bool) {
    let oc = (o - center).as_dvec3();
    let d = d.as_dvec3();
    let (a, half_b, c) = (d.dot(d), oc.dot(d), oc.dot(oc) - r2);
    // `nearest_root` with both roots computed and the first one inside the interval selected.
    let disc = half_b * half_b - a * c;
    let q = -(half_b + disc.sqrt().copysign(half_b));
    let nonzero = q != 0.0;
    let (r1, r2) = (
        if nonzero { q / a } else { 0.0 },
        if nonzero { c / q } else { 0.0 },
    );
    let ordered = r1 <= r2;
    let (lo, hi) = (
        (if ordered { r1 } else { r2 }) as f32,
        (if ordered { r2 } else { r1 }) as f32,
    );
    let (lo_in, hi_in) = ((lo > t_min) & (lo < t_max), (hi > t_min) & (hi < t_max));
    let t = if lo_in { lo } else { hi };
    (t, (a > 0.0) & (disc >= 0.0) & (lo_in | hi_in))
}

/// Möller–Trumbore with the edges e1 = v1 − v0, e2 = v2 − v0 given (the BVH stores them).
#[inline(always)]
pub fn intersect_triangle_edges(
    ray: &Ray,
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
) -> Option<(f32, f32, f32)> {
    let pvec = ray.d.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let tvec = ray.o - v0;
    let b1 = tvec.dot(pvec) * inv;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let b2 = ray.d.dot(qvec) * inv;
    if !(b2 >= 0.0 && b1 + b2 <= 1.0) {
        return None;
    }
    let t = e2.dot(qvec) * inv;
    (t > ray.t_min && t < ray.t_max).then_some((t, b1, b2))
}

/// Unit normal of the local +z axis under `to_world` (inverse transpose), or +z if singular.
pub fn transformed_normal(to_local: &Mat4) -> Vec3 {
    let n = to_local.transpose().transform_vector3(Vec3::Z);
    let n = n.normalize_or_zero();
    if n == Vec3::ZERO {
        Vec3::Z
    } else {
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: Vec3, d: Vec3) -> Ray {
        Ray {
            o,
            d,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    #[test]
    fn sphere_and_cylinder_hits() {
        let s = Primitive::Sphere {
            center: Vec3::new(0.0, 0.0, 5.0),
            radius: 1.0,
            shape: 0,
        };
        let (t, ..) = s.intersect(&ray(Vec3::ZERO, Vec3::Z)).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        // From inside: the far root.
        let (t, ..) = s
            .intersect(&ray(Vec3::new(0.0, 0.0, 5.0), Vec3::Z))
            .unwrap();
        assert!((t - 1.0).abs() < 1e-5);

        let c = Primitive::Cylinder {
            p0: Vec3::ZERO,
            axis: Vec3::Z,
            length: 2.0,
            radius: 0.5,
            shape: 0,
        };
        let r = ray(Vec3::new(-3.0, 0.0, 1.0), Vec3::X);
        let h = Hit {
            t: c.intersect(&r).unwrap().0,
            prim: 0,
            b1: 0.0,
            b2: 0.0,
        };
        assert!((h.t - 2.5).abs() < 1e-5);
        let sp = c.surface_point(&r, &h, false);
        assert!((sp.ng - Vec3::NEG_X).length() < 1e-6);
        // Above the open end: miss; through the open end from above: hits the inside wall.
        assert!(c
            .intersect(&ray(Vec3::new(-3.0, 0.0, 2.5), Vec3::X))
            .is_none());
        let down = ray(Vec3::new(0.2, 0.0, 3.0), Vec3::new(0.1, 0.0, -1.0));
        let (t, ..) = c.intersect(&down).unwrap();
        assert!((0.2 + 0.1 * t - 0.5).abs() < 1e-4);
    }

    /// The BVH keeps one primitive per triangle, the largest allocation of a large scene:
    /// 84 bytes, a triangle's vertices, optional normals and shape, and the tag (no padding).
    #[test]
    fn primitive_size() {
        assert_eq!(std::mem::size_of::<Primitive>(), 84);
    }

    #[test]
    fn disk_and_triangle_hits() {
        let to_world =
            Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0)) * Mat4::from_scale(Vec3::splat(0.5));
        let d = Primitive::disk(to_world.inverse(), 0);
        assert!(d
            .intersect(&ray(Vec3::new(0.4, 0.0, 0.0), Vec3::Z))
            .is_some());
        assert!(d
            .intersect(&ray(Vec3::new(0.6, 0.0, 0.0), Vec3::Z))
            .is_none());
        let Primitive::Disk { normal, .. } = d else {
            unreachable!("Primitive::disk makes a disk")
        };
        assert_eq!(normal, Vec3::Z);

        let tri = Primitive::Triangle {
            v: [Vec3::ZERO, Vec3::X, Vec3::Y],
            n: Some([Vec3::Z, Vec3::Z, Vec3::new(1.0, 0.0, 1.0)]),
            shape: 0,
        };
        let r = ray(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z);
        let (t, b1, b2) = tri.intersect(&r).unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (b1 - 0.25).abs() < 1e-6 && (b2 - 0.25).abs() < 1e-6);
        let sp = tri.surface_point(&r, &Hit { t, prim: 0, b1, b2 }, true);
        assert_eq!(sp.ng, Vec3::NEG_Z);
        assert!(sp.ns.x < 0.0 && sp.ns.z < 0.0);
        assert!((sp.p - Vec3::new(0.25, 0.25, 0.0)).length() < 1e-6);
    }
}
