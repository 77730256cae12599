//! Where a light touches or pierces a surface: analytic segment–shape contacts, and the pixels
//! near their projections. There the oracle's emitter sampling by area has infinite variance
//! and its finite-radius bias is largest (see docs/oracle.md), so `compare` tests those pixels
//! apart (header `contact_pixels`).
//!
//! A contact is a point of the light's segment on a shape's surface, within the tolerance
//! tol = max(R, 1e-6·ℓ) (R the light's radius in the file, ℓ its length), computed in f64:
//! - triangles (meshes, rectangles, cubes): the segment crossing the triangle, or passing within
//!   tol of it (closest points of the segment to the triangle's face and edges); a segment lying
//!   in the triangle's plane gives its points within tol, sampled along the segment;
//! - spheres: the segment's crossings of the sphere, or its closest approach within tol;
//! - disks: crossings of the disk (in its local frame);
//! - finite cylinders (occluders): crossings of the side surface.

use crate::camera::Camera;
use crate::scene::{Geometry, Scene};
use glam::{DVec3, Mat4};

/// One point where light `light` meets shape `shape` (indices into the scene's lists).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    pub light: usize,
    pub shape: usize,
    pub point: DVec3,
}

/// Samples along a segment lying in a surface.
const LYING_SAMPLES: usize = 64;

fn v(p: glam::Vec3) -> DVec3 {
    p.as_dvec3()
}

/// Closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Closest points of segments p0p1 and q0q1: (parameter on p, point on p, point on q).
fn closest_segments(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> (DVec3, DVec3) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let (s, t) = if a <= 1e-300 && e <= 1e-300 {
        (0.0, 0.0)
    } else if a <= 1e-300 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= 1e-300 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    (p0 + d1 * s, q0 + d2 * t)
}

/// Contacts of segment p0p1 with triangle (a, b, c).
fn segment_triangle(p0: DVec3, p1: DVec3, tri: [DVec3; 3], tol: f64, out: &mut Vec<DVec3>) {
    let [a, b, c] = tri;
    let n = (b - a).cross(c - a);
    let len = n.length();
    if !(len > 0.0) {
        return;
    }
    let n = n / len;
    let (s0, s1) = (n.dot(p0 - a), n.dot(p1 - a));
    if s0.abs() <= tol && s1.abs() <= tol {
        // Lying in the plane: every sampled point of the segment on the triangle.
        for k in 0..=LYING_SAMPLES {
            let p = p0.lerp(p1, k as f64 / LYING_SAMPLES as f64);
            if (closest_on_triangle(p, a, b, c) - p).length() <= tol {
                out.push(p);
            }
        }
        return;
    }
    if s0 * s1 <= 0.0 && s0 != s1 {
        let p = p0.lerp(p1, s0 / (s0 - s1));
        if (closest_on_triangle(p, a, b, c) - p).length() <= tol {
            out.push(p);
            return;
        }
    }
    // Passing close: the segment's closest approach to the face (from its endpoints) and to
    // the edges.
    let mut best: Option<(f64, DVec3)> = None;
    let mut consider = |on_segment: DVec3, on_triangle: DVec3| {
        let d = (on_segment - on_triangle).length();
        if d <= tol && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, on_segment));
        }
    };
    for p in [p0, p1] {
        consider(p, closest_on_triangle(p, a, b, c));
    }
    for (q0, q1) in [(a, b), (b, c), (c, a)] {
        let (ps, qs) = closest_segments(p0, p1, q0, q1);
        consider(ps, qs);
    }
    if let Some((_, p)) = best {
        out.push(p);
    }
}

/// Contacts of segment p0p1 with the sphere (center, radius).
fn segment_sphere(p0: DVec3, p1: DVec3, center: DVec3, r: f64, tol: f64, out: &mut Vec<DVec3>) {
    let d = p1 - p0;
    let f = p0 - center;
    let (a, b, c) = (
        d.length_squared(),
        2.0 * f.dot(d),
        f.length_squared() - r * r,
    );
    if !(a > 0.0) {
        return;
    }
    let disc = b * b - 4.0 * a * c;
    let mut found = false;
    if disc >= 0.0 {
        let sq = disc.sqrt();
        for t in [(-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)] {
            if (0.0..=1.0).contains(&t) {
                out.push(p0 + d * t);
                found = true;
            }
        }
    }
    if !found {
        let t = (-f.dot(d) / a).clamp(0.0, 1.0);
        let p = p0 + d * t;
        if ((p - center).length() - r).abs() <= tol {
            out.push(p);
        }
    }
}

/// Crossings of segment p0p1 with the unit disk in the local z = 0 plane of `to_world`.
fn segment_disk(p0: DVec3, p1: DVec3, to_world: &Mat4, out: &mut Vec<DVec3>) {
    let m = to_world.as_dmat4();
    if !(m.determinant().abs() > 0.0) {
        return;
    }
    let inv = m.inverse();
    let (l0, l1) = (inv.transform_point3(p0), inv.transform_point3(p1));
    if l0.z * l1.z <= 0.0 && l0.z != l1.z {
        let t = l0.z / (l0.z - l1.z);
        let l = l0.lerp(l1, t);
        if l.x * l.x + l.y * l.y <= 1.0 {
            out.push(p0.lerp(p1, t));
        }
    }
}

/// Crossings of segment p0p1 with the side of the cylinder (q0, q1, radius r).
fn segment_cylinder(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3, r: f64, out: &mut Vec<DVec3>) {
    let axis = q1 - q0;
    let h = axis.length();
    if !(h > 0.0) {
        return;
    }
    let u = axis / h;
    let perp = |x: DVec3| x - u * u.dot(x);
    let (o, d) = (perp(p0 - q0), perp(p1 - p0));
    let (a, b, c) = (
        d.length_squared(),
        2.0 * o.dot(d),
        o.length_squared() - r * r,
    );
    if !(a > 0.0) {
        return;
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return;
    }
    let sq = disc.sqrt();
    for t in [(-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)] {
        let p = p0.lerp(p1, t);
        let along = u.dot(p - q0);
        if (0.0..=1.0).contains(&t) && (0.0..=h).contains(&along) {
            out.push(p);
        }
    }
}

/// Every contact of every light with every shape of `scene`.
pub fn light_contacts(scene: &Scene) -> Vec<Contact> {
    let mut contacts = Vec::new();
    for (li, light) in scene.lights.iter().enumerate() {
        let (p0, p1) = (v(light.begin), v(light.end));
        let tol = (light.radius.abs() as f64).max(1e-6 * (p1 - p0).length());
        for (si, shape) in scene.shapes.iter().enumerate() {
            let mut points = Vec::new();
            match &shape.geometry {
                Geometry::Mesh {
                    positions, indices, ..
                } => {
                    for tri in indices {
                        let Some(t) = tri
                            .iter()
                            .map(|&k| positions.get(k as usize).map(|p| v(*p)))
                            .collect::<Option<Vec<_>>>()
                        else {
                            continue;
                        };
                        segment_triangle(p0, p1, [t[0], t[1], t[2]], tol, &mut points);
                    }
                }
                Geometry::Sphere { center, radius } => {
                    segment_sphere(p0, p1, v(*center), radius.abs() as f64, tol, &mut points)
                }
                Geometry::Disk { to_world } => segment_disk(p0, p1, to_world, &mut points),
                Geometry::Cylinder {
                    p0: q0,
                    p1: q1,
                    radius,
                } => segment_cylinder(p0, p1, v(*q0), v(*q1), radius.abs() as f64, &mut points),
            }
            // A crossing on a shared mesh edge is found twice.
            points.dedup_by(|a, b| (*a - *b).length() <= tol);
            contacts.extend(points.into_iter().map(|point| Contact {
                light: li,
                shape: si,
                point,
            }));
        }
    }
    contacts
}

/// Pixels of the render window (x0, y0, w, h) (full-film offsets) within `radius_px` pixels of
/// the projection of a contact (distance from the projected point to the pixel's square), in
/// window coordinates, sorted and without duplicates. Contacts behind the camera have none.
pub fn contact_pixels(
    camera: &Camera,
    contacts: &[Contact],
    window: (u32, u32, u32, u32),
    radius_px: f64,
) -> Vec<[usize; 2]> {
    let (x0, y0, w, h) = window;
    let mut pixels = Vec::new();
    for c in contacts {
        let Some(p) = camera.project(c.point.as_vec3()) else {
            continue;
        };
        let (px, py) = (p.x as f64 - x0 as f64, p.y as f64 - y0 as f64);
        if !(px.is_finite() && py.is_finite()) {
            continue;
        }
        let reach = radius_px.ceil() as i64 + 1;
        let (cx, cy) = (px.floor() as i64, py.floor() as i64);
        for y in (cy - reach).max(0)..=(cy + reach).min(h as i64 - 1) {
            for x in (cx - reach).max(0)..=(cx + reach).min(w as i64 - 1) {
                let dx = (px - px.clamp(x as f64, x as f64 + 1.0)).abs();
                let dy = (py - py.clamp(y as f64, y as f64 + 1.0)).abs();
                if dx.hypot(dy) <= radius_px {
                    pixels.push([x as usize, y as usize]);
                }
            }
        }
    }
    pixels.sort_by_key(|&[x, y]| (y, x));
    pixels.dedup();
    pixels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_crossing_touch_and_miss() {
        let tri = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let mut out = Vec::new();
        // Crossing at (0.25, 0.25, 0).
        segment_triangle(
            DVec3::new(0.25, 0.25, -1.0),
            DVec3::new(0.25, 0.25, 1.0),
            tri,
            1e-6,
            &mut out,
        );
        assert_eq!(out.len(), 1);
        assert!((out[0] - DVec3::new(0.25, 0.25, 0.0)).length() < 1e-12);
        // Ending on the face.
        out.clear();
        segment_triangle(
            DVec3::new(0.2, 0.2, 0.0),
            DVec3::new(0.2, 0.2, 1.0),
            tri,
            1e-6,
            &mut out,
        );
        assert_eq!(out.len(), 1);
        // Passing 1e-7 above an edge: a touch; 1e-3 above: nothing.
        out.clear();
        segment_triangle(
            DVec3::new(0.5, -1.0, 1e-7),
            DVec3::new(0.5, 1.0, 1e-7),
            tri,
            1e-6,
            &mut out,
        );
        assert!(!out.is_empty());
        out.clear();
        segment_triangle(
            DVec3::new(0.5, -1.0, 1e-3),
            DVec3::new(0.5, 1.0, 1e-3),
            tri,
            1e-6,
            &mut out,
        );
        assert!(out.is_empty());
        // Crossing the plane outside the triangle.
        segment_triangle(
            DVec3::new(2.0, 2.0, -1.0),
            DVec3::new(2.0, 2.0, 1.0),
            tri,
            1e-6,
            &mut out,
        );
        assert!(out.is_empty());
        // Lying in the plane across the triangle: sampled points on it.
        segment_triangle(
            DVec3::new(-1.0, 0.1, 0.0),
            DVec3::new(1.0, 0.1, 0.0),
            tri,
            1e-6,
            &mut out,
        );
        assert!(out.len() > 10 && out.iter().all(|p| p.x >= -1e-9 && p.x <= 0.9 + 1e-9));
    }

    #[test]
    fn sphere_disk_and_cylinder_crossings() {
        let mut out = Vec::new();
        // Entering a unit sphere at z = −1 and ending inside: one crossing.
        segment_sphere(
            DVec3::new(0.0, 0.0, -2.0),
            DVec3::ZERO,
            DVec3::ZERO,
            1.0,
            1e-6,
            &mut out,
        );
        assert_eq!(out.len(), 1);
        assert!((out[0].z + 1.0).abs() < 1e-12);
        // Tangent at (1, 0, 0).
        out.clear();
        segment_sphere(
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::ZERO,
            1.0,
            1e-6,
            &mut out,
        );
        assert!(!out.is_empty() && (out[0] - DVec3::X).length() < 1e-3);
        // Inside without touching: nothing.
        out.clear();
        segment_sphere(
            DVec3::new(-0.5, 0.0, 0.0),
            DVec3::new(0.5, 0.0, 0.0),
            DVec3::ZERO,
            1.0,
            1e-6,
            &mut out,
        );
        assert!(out.is_empty());
        let disk = Mat4::from_scale(glam::Vec3::splat(2.0));
        segment_disk(
            DVec3::new(1.5, 0.0, -1.0),
            DVec3::new(1.5, 0.0, 1.0),
            &disk,
            &mut out,
        );
        assert_eq!(out.len(), 1);
        segment_disk(
            DVec3::new(2.5, 0.0, -1.0),
            DVec3::new(2.5, 0.0, 1.0),
            &disk,
            &mut out,
        );
        assert_eq!(out.len(), 1, "outside the disk");
        out.clear();
        segment_cylinder(
            DVec3::new(-2.0, 0.0, 0.5),
            DVec3::new(2.0, 0.0, 0.5),
            DVec3::ZERO,
            DVec3::Z,
            0.5,
            &mut out,
        );
        assert_eq!(out.len(), 2);
    }
}
