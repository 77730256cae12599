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

use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::scene::{Geometry, Scene};
use crate::shapes::Primitive;
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

/// Whether segment p0p1 passes within `tol` of the box [lo, hi] (conservatively: the box is
/// grown by a further 10⁻⁹ of the coordinates' magnitude for the rounding of this test and of
/// the contact tests).
fn segment_near_box(p0: DVec3, p1: DVec3, lo: DVec3, hi: DVec3, tol: f64) -> bool {
    let scale = lo
        .abs()
        .max(hi.abs())
        .max(p0.abs())
        .max(p1.abs())
        .max_element();
    let grow = tol + 1e-9 * scale + f64::MIN_POSITIVE;
    let (lo, hi) = (lo - grow, hi + grow);
    let d = p1 - p0;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for a in 0..3 {
        if d[a] == 0.0 {
            if p0[a] < lo[a] || p0[a] > hi[a] {
                return false;
            }
            continue;
        }
        let (u, w) = ((lo[a] - p0[a]) / d[a], (hi[a] - p0[a]) / d[a]);
        t0 = t0.max(u.min(w));
        t1 = t1.min(u.max(w));
        if !(t0 <= t1) {
            return false;
        }
    }
    true
}

/// Every contact of every light with every shape of `scene`, whose primitives `bvh` holds
/// (built from the scene's shapes in order). Per light, only the triangles whose box the
/// segment passes within tol of are tested (their boxes are exact), every other shape is
/// tested; the result, in the order of the scene's shapes and triangles, is that of testing
/// every triangle.
pub fn light_contacts(scene: &Scene, bvh: &Bvh) -> Vec<Contact> {
    let others: Vec<usize> = (0..scene.shapes.len())
        .filter(|&s| !matches!(scene.shapes[s].geometry, Geometry::Mesh { .. }))
        .collect();
    let mut contacts = Vec::new();
    let mut triangles: Vec<(u32, [DVec3; 3], usize)> = Vec::new();
    for (li, light) in scene.lights.iter().enumerate() {
        let (p0, p1) = (v(light.begin), v(light.end));
        let tol = (light.radius.abs() as f64).max(1e-6 * (p1 - p0).length());
        triangles.clear();
        bvh.visit_overlapping(
            |lo, hi| segment_near_box(p0, p1, v(lo), v(hi), tol),
            |k, p| {
                if let Primitive::Triangle { v: t, shape, .. } = p {
                    triangles.push((k, [v(t[0]), v(t[1]), v(t[2])], *shape as usize));
                }
            },
        );
        triangles.sort_unstable_by_key(|t| t.0);
        // Per shape its points: a mesh's triangles are consecutive in the BVH's order.
        let mut found: Vec<(usize, Vec<DVec3>)> = Vec::new();
        for group in triangles.chunk_by(|a, b| a.2 == b.2) {
            let mut points = Vec::new();
            for (_, t, _) in group {
                segment_triangle(p0, p1, *t, tol, &mut points);
            }
            found.push((group[0].2, points));
        }
        for &si in &others {
            let mut points = Vec::new();
            match &scene.shapes[si].geometry {
                Geometry::Mesh { .. } => {}
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
            found.push((si, points));
        }
        found.sort_by_key(|f| f.0);
        for (si, mut points) in found {
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
    use crate::render_scene::RenderScene;
    use crate::scene_builder::{cuboid, diffuse, light, quad};
    use glam::Vec3;

    /// Every light against every triangle and shape: what [`light_contacts`] must return.
    fn brute_force(scene: &Scene) -> Vec<Contact> {
        let mut contacts = Vec::new();
        for (li, l) in scene.lights.iter().enumerate() {
            let (p0, p1) = (v(l.begin), v(l.end));
            let tol = (l.radius.abs() as f64).max(1e-6 * (p1 - p0).length());
            for (si, shape) in scene.shapes.iter().enumerate() {
                let mut points = Vec::new();
                match &shape.geometry {
                    Geometry::Mesh {
                        positions, indices, ..
                    } => {
                        for t in indices {
                            let t = t.map(|k| v(positions[k as usize]));
                            segment_triangle(p0, p1, t, tol, &mut points);
                        }
                    }
                    Geometry::Sphere { center, radius } => {
                        segment_sphere(p0, p1, v(*center), *radius as f64, tol, &mut points)
                    }
                    Geometry::Disk { to_world } => segment_disk(p0, p1, to_world, &mut points),
                    Geometry::Cylinder {
                        p0: a,
                        p1: b,
                        radius,
                    } => segment_cylinder(p0, p1, v(*a), v(*b), *radius as f64, &mut points),
                }
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

    /// The BVH query finds what testing everything finds: on every committed scene, and on a
    /// box of boxes pierced, touched and grazed by lights (contacts on several shapes, shared
    /// edges, a light lying in a face, one missing everything).
    #[test]
    fn contacts_by_the_bvh_equal_testing_every_shape() {
        let mut scenes: Vec<Scene> = crate::test_scenes::committed()
            .iter()
            .map(|p| crate::xml::load_scene(p, &[]).unwrap())
            .collect();
        let mut box_scene = crate::scene_builder::cornell_box(8, 8);
        let w = Vec3::new;
        for i in 0..40 {
            let x = i as f32 / 40.0;
            box_scene.shapes.push(diffuse(
                cuboid(w(x, 0.2, 0.0), w(x + 0.02, 0.25 + 0.01 * i as f32, 0.3)),
                [0.5; 3],
            ));
        }
        box_scene.shapes.push(diffuse(
            quad(
                w(0., 0., 0.5),
                w(1., 0., 0.5),
                w(1., 1., 0.5),
                w(0., 1., 0.5),
            ),
            [0.5; 3],
        ));
        let k = [1.0; 3];
        box_scene.lights = vec![
            light(w(0.5, 0.5, -0.5), w(0.5, 0.5, 1.5), k), // through floor, shelf, ceiling
            light(w(-0.5, 0.22, 0.1), w(1.5, 0.22, 0.1), k), // through the row of boxes
            light(w(0.1, 0.1, 0.5), w(0.9, 0.9, 0.5), k),  // lying in the shelf
            light(w(0.3, 0.5, 0.95), w(0.7, 0.6, 0.95), k), // touching nothing
            light(w(0.0, 0.0, 0.0), w(1.0, 1.0, 1.0), k),  // corner to corner
        ];
        scenes.push(box_scene);
        let mut total = 0;
        for scene in &scenes {
            let rs = RenderScene::new(scene).unwrap();
            let expected = brute_force(scene);
            assert_eq!(light_contacts(scene, &rs.bvh), expected);
            total += expected.len();
        }
        // Not vacuous: the pierced boxes alone give dozens.
        assert!(total > 50, "{total} contacts");
    }

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
