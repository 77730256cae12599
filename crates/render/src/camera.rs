//! Mitsuba 3's `perspective` sensor.
//!
//! Film coordinates sx = (i + u)/W, sy = (j + v)/H over the *full* film (row 0 at the top, a crop
//! only selects pixels). Camera space: +x left, +y up, +z forward. The direction through film
//! position (sx, sy) is ∝ ((1 − 2(sx + ppx))·t, (1 − 2(sy + ppy))·t/aspect, 1) with
//! t = tan(fov_x/2), aspect = W/H. Rays start on the near plane and end on the far plane.

use crate::bvh::{RayLanes, PACKET};
use crate::scene::{FovAxis, Sensor};
use crate::shapes::Ray;
use glam::{Mat4, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Camera {
    to_world: Mat4,
    to_camera: Mat4,
    origin: Vec3,
    /// tan(fov_x / 2).
    tan_half_x: f32,
    aspect: f32,
    ppx: f32,
    ppy: f32,
    near: f32,
    far: f32,
    width: u32,
    height: u32,
}

/// The horizontal field of view (degrees) equivalent to `fov_deg` along `axis` on a film of the
/// given aspect ratio W/H, as Mitsuba converts it.
pub fn fov_x_degrees(fov_deg: f64, axis: FovAxis, aspect: f64) -> f64 {
    let half = (fov_deg.to_radians() / 2.0).tan();
    let from_y = || (2.0 * (half * aspect).atan()).to_degrees();
    match axis {
        FovAxis::X => fov_deg,
        FovAxis::Y => from_y(),
        FovAxis::Diagonal => {
            // Half-diagonal of the film plane at z = 1 is `half`; split it by the aspect ratio.
            let half_width = half / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            (2.0 * half_width.atan()).to_degrees()
        }
        FovAxis::Smaller => {
            if aspect > 1.0 {
                from_y()
            } else {
                fov_deg
            }
        }
        FovAxis::Larger => {
            if aspect > 1.0 {
                fov_deg
            } else {
                from_y()
            }
        }
    }
}

/// [`Camera::projection`]: camera to world, full film size, tan(fov_x/2), W/H, principal-point
/// offsets and clip distances.
#[derive(Clone, Copy, Debug)]
pub struct Projection {
    pub to_world: glam::DMat4,
    pub width: f64,
    pub height: f64,
    pub tan_half_x: f64,
    pub aspect: f64,
    pub ppx: f64,
    pub ppy: f64,
    pub near: f64,
    pub far: f64,
}

impl Camera {
    /// `None` for a zero-size film, a non-invertible to_world, or an unusable field of view.
    pub fn new(sensor: &Sensor) -> Option<Self> {
        let (w, h) = (sensor.film.width, sensor.film.height);
        if w == 0 || h == 0 {
            return None;
        }
        let aspect = w as f64 / h as f64;
        let fov_x = fov_x_degrees(sensor.fov_deg as f64, sensor.fov_axis, aspect);
        if !(fov_x > 0.0 && fov_x < 180.0) {
            return None;
        }
        let tan_half_x = (fov_x.to_radians() / 2.0).tan() as f32;
        let det = sensor.to_world.determinant();
        if !(tan_half_x > 0.0 && tan_half_x.is_finite() && det != 0.0 && det.is_finite()) {
            return None;
        }
        Some(Self {
            to_world: sensor.to_world,
            to_camera: sensor.to_world.inverse(),
            origin: sensor.to_world.transform_point3(Vec3::ZERO),
            tan_half_x,
            aspect: aspect as f32,
            ppx: sensor.principal_point_offset_x,
            ppy: sensor.principal_point_offset_y,
            near: sensor.near_clip,
            far: sensor.far_clip,
            width: w,
            height: h,
        })
    }

    /// Camera-space direction (z = 1) through film position (sx, sy) ∈ \[0,1\]².
    #[inline]
    pub fn camera_direction(&self, sx: f32, sy: f32) -> Vec3 {
        let t = self.tan_half_x;
        Vec3::new(
            (1.0 - 2.0 * (sx + self.ppx)) * t,
            (1.0 - 2.0 * (sy + self.ppy)) * t / self.aspect,
            1.0,
        )
    }

    /// Ray through full-film pixel coordinates (x, y) (continuous, in pixels): unit world
    /// direction, from the near plane to the far plane.
    #[inline]
    pub fn ray(&self, px: f32, py: f32) -> Ray {
        let dc = self.camera_direction(px / self.width as f32, py / self.height as f32);
        let inv_len = dc.length_recip();
        // Distance along the unit direction to the plane z = z0 is z0·|dc| (dc.z = 1).
        let d = self.to_world.transform_vector3(dc * inv_len).normalize();
        let len = inv_len.recip();
        Ray {
            o: self.origin,
            d,
            t_min: self.near * len,
            t_max: self.far * len,
        }
    }

    /// [`Self::ray`] for N film positions at once, bit for bit (the same operations lane by
    /// lane, in a loop the compiler vectorises): ray i through (`px[i]`, `py[i]`) into lane i of
    /// `rays`.
    #[inline(always)]
    pub fn ray_lanes<const N: usize>(&self, px: &[f32; N], py: &[f32; N], rays: &mut RayLanes) {
        let (w, h, t) = (self.width as f32, self.height as f32, self.tan_half_x);
        // Columns of the rotation part of to_world.
        let m = [
            self.to_world.x_axis.truncate(),
            self.to_world.y_axis.truncate(),
            self.to_world.z_axis.truncate(),
        ];
        for i in 0..N.min(PACKET) {
            let (sx, sy) = (px[i] / w, py[i] / h);
            let dc = Vec3::new(
                (1.0 - 2.0 * (sx + self.ppx)) * t,
                (1.0 - 2.0 * (sy + self.ppy)) * t / self.aspect,
                1.0,
            );
            let inv_len = dc.length_recip();
            let v = dc * inv_len;
            // transform_vector3 (glam adds the terms in this order).
            let d = (m[0] * v.x + m[1] * v.y) + m[2] * v.z;
            let d = d * d.length_recip();
            let len = inv_len.recip();
            for a in 0..3 {
                rays.o[a][i] = self.origin[a];
                rays.d[a][i] = d[a];
            }
            rays.t_min[i] = self.near * len;
            rays.t_max[i] = self.far * len;
        }
    }

    /// Full-film pixel coordinates (continuous) where a world point is seen, `None` when it lies
    /// behind the camera (or in its plane).
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let q = self.to_camera.transform_point3(p);
        if !(q.z > 0.0) {
            return None;
        }
        let t = self.tan_half_x;
        let sx = 0.5 * (1.0 - q.x / (q.z * t)) - self.ppx;
        let sy = 0.5 * (1.0 - q.y * self.aspect / (q.z * t)) - self.ppy;
        Some(Vec2::new(sx * self.width as f32, sy * self.height as f32))
    }

    /// The camera's parameters in f64, for computations on the film plane.
    pub fn projection(&self) -> Projection {
        Projection {
            to_world: self.to_world.as_dmat4(),
            width: self.width as f64,
            height: self.height as f64,
            tan_half_x: self.tan_half_x as f64,
            aspect: self.aspect as f64,
            ppx: self.ppx as f64,
            ppy: self.ppy as f64,
            near: self.near as f64,
            far: self.far as f64,
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{CropWindow, Film};

    /// The lane form gives the rays of `ray` bit for bit.
    #[test]
    fn ray_lanes_equal_rays() {
        let mut s = sensor(37, 23, 41.0, FovAxis::X);
        s.principal_point_offset_x = 0.03;
        s.to_world *= Mat4::from_rotation_z(0.3);
        let cam = Camera::new(&s).unwrap();
        let px: [f32; 16] = std::array::from_fn(|i| (i as f32 * 2.37) % 37.0);
        let py: [f32; 16] = std::array::from_fn(|i| (i as f32 * 1.71 + 0.5) % 23.0);
        let mut lanes = RayLanes::default();
        cam.ray_lanes(&px, &py, &mut lanes);
        for i in 0..16 {
            let (a, b) = (cam.ray(px[i], py[i]), lanes.get(i));
            assert_eq!(
                (a.o, a.d, a.t_min.to_bits(), a.t_max.to_bits()),
                (b.o, b.d, b.t_min.to_bits(), b.t_max.to_bits())
            );
        }
    }

    /// The loader's `lookat` (the one implementation), in f32.
    fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Mat4 {
        crate::xml::look_at(origin.as_dvec3(), target.as_dvec3(), up.as_dvec3())
            .expect("non-degenerate look-at")
            .as_mat4()
    }

    fn sensor(w: u32, h: u32, fov: f32, axis: FovAxis) -> Sensor {
        Sensor {
            to_world: look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(1.0, 2.0, 0.0), Vec3::Y),
            fov_deg: fov,
            fov_axis: axis,
            principal_point_offset_x: 0.0,
            principal_point_offset_y: 0.0,
            near_clip: 0.01,
            far_clip: 1000.0,
            film: Film {
                width: w,
                height: h,
                crop: None,
            },
            sample_count: 1,
            seed: 0,
        }
    }

    /// World point at angles (ax, ay) off the optical axis of `sensor(..)` (looking down −z
    /// from (1,2,3), up = +y, so camera-left is world −x... computed from the frame itself).
    fn point_at(s: &Sensor, tx: f32, ty: f32) -> Vec3 {
        // Camera space (+x left, +y up, +z forward), at depth 2.
        s.to_world
            .transform_point3(Vec3::new(tx * 2.0, ty * 2.0, 2.0))
    }

    #[test]
    fn projection_for_every_fov_axis() {
        let half = |deg: f32| (deg.to_radians() / 2.0).tan();
        for (w, h) in [(64u32, 32u32), (30, 60), (40, 40)] {
            let aspect = w as f32 / h as f32;
            let fov = 50.0f32;
            let t = half(fov);
            for axis in [
                FovAxis::X,
                FovAxis::Y,
                FovAxis::Diagonal,
                FovAxis::Smaller,
                FovAxis::Larger,
            ] {
                let s = sensor(w, h, fov, axis);
                let cam = Camera::new(&s).unwrap();
                // The optical axis hits the film centre.
                let c = cam.project(point_at(&s, 0.0, 0.0)).unwrap();
                assert!((c - Vec2::new(w as f32 / 2.0, h as f32 / 2.0)).length() < 1e-3);
                // A point at half the fov along the named axis lands on that film edge/corner.
                let axis_is_x = match axis {
                    FovAxis::X => true,
                    FovAxis::Y => false,
                    FovAxis::Smaller => w <= h,
                    FovAxis::Larger => w > h,
                    FovAxis::Diagonal => {
                        // Corner direction: (tx, ty) ∝ (W, H) with tx² + ty² = t².
                        let n = (aspect * aspect + 1.0).sqrt();
                        let p = cam.project(point_at(&s, t * aspect / n, t / n)).unwrap();
                        assert!(p.length() < 1e-3, "{axis:?} {w}x{h}: {p}");
                        let p = cam.project(point_at(&s, -t * aspect / n, -t / n)).unwrap();
                        assert!((p - Vec2::new(w as f32, h as f32)).length() < 1e-3);
                        continue;
                    }
                };
                if axis_is_x {
                    // Camera-left edge is pixel x = 0.
                    let p = cam.project(point_at(&s, t, 0.0)).unwrap();
                    assert!(
                        (p - Vec2::new(0.0, h as f32 / 2.0)).length() < 1e-3,
                        "{axis:?} {p}"
                    );
                } else {
                    // Up edge is row 0.
                    let p = cam.project(point_at(&s, 0.0, t)).unwrap();
                    assert!(
                        (p - Vec2::new(w as f32 / 2.0, 0.0)).length() < 1e-3,
                        "{axis:?} {p}"
                    );
                }
            }
        }
    }

    #[test]
    fn fov_conversions() {
        // fov_y = 90° on a 2:1 film: tan(fx/2) = 2.
        let fx = fov_x_degrees(90.0, FovAxis::Y, 2.0);
        assert!(((fx / 2.0).to_radians().tan() - 2.0).abs() < 1e-12);
        assert_eq!(fov_x_degrees(90.0, FovAxis::Smaller, 2.0), fx);
        assert_eq!(fov_x_degrees(90.0, FovAxis::Larger, 2.0), 90.0);
        assert_eq!(fov_x_degrees(90.0, FovAxis::Smaller, 0.5), 90.0);
    }

    #[test]
    fn rays_and_projection_are_inverse() {
        let mut s = sensor(50, 30, 40.0, FovAxis::X);
        s.principal_point_offset_x = 0.1;
        s.principal_point_offset_y = -0.2;
        let cam = Camera::new(&s).unwrap();
        // Principal point: the optical axis moves to film position (0.5 − ppx, 0.5 − ppy).
        let c = cam.project(point_at(&s, 0.0, 0.0)).unwrap();
        assert!(
            (c - Vec2::new(0.4 * 50.0, 0.7 * 30.0)).length() < 1e-3,
            "{c}"
        );
        for &(x, y) in &[(0.0f32, 0.0f32), (12.3, 4.5), (49.9, 29.9), (25.0, 15.0)] {
            let r = cam.ray(x, y);
            assert!((r.d.length() - 1.0).abs() < 1e-5);
            let p = cam.project(r.o + 3.7 * r.d).unwrap();
            assert!((p - Vec2::new(x, y)).length() < 2e-3, "{x},{y} -> {p}");
        }
        // Near clip: the ray starts on the plane z_cam = near.
        let r = cam.ray(3.0, 7.0);
        let q = cam.to_camera.transform_point3(r.o + r.t_min * r.d);
        assert!((q.z - 0.01).abs() < 1e-6);
        assert!(cam.project(Vec3::new(1.0, 2.0, 4.0)).is_none()); // behind
    }

    #[test]
    fn degenerate_sensors_are_rejected() {
        let mut s = sensor(0, 10, 40.0, FovAxis::X);
        assert!(Camera::new(&s).is_none());
        s.film = Film {
            width: 10,
            height: 10,
            crop: Some(CropWindow {
                offset_x: 0,
                offset_y: 0,
                width: 1,
                height: 1,
            }),
        };
        s.fov_deg = 180.0;
        assert!(Camera::new(&s).is_none());
        s.fov_deg = 40.0;
        s.to_world = Mat4::ZERO;
        assert!(Camera::new(&s).is_none());
    }
}
