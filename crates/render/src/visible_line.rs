//! Linear lights seen directly by the camera (`hide_emitters = false`, Mitsuba's default), in the
//! R → 0 limit. The derivation is in `docs/hide-emitters.md`; in short:
//!
//! A tube of radius R around a segment covers, seen from the pinhole, the solid angle R·Ω_R with
//! dΩ_R = 2 sin θ / r² dl (θ between the axis and the line of sight, r the distance, l the arc
//! length), and it emits K/R toward the camera from every point of it (outward normals, one-sided
//! emitter, the camera outside the tube). On the film plane z = 1 of camera space a solid angle
//! dω covers the area dω / cos³θ_c (θ_c off the optical axis), and one unit of that area is
//! (W / 2t)² pixels (t = tan(fov_x / 2), both film axes alike). A pixel value is the mean of the
//! radiance over the pixel's unit area, so the tube adds, as R → 0,
//!
//!   I_pixel = K · (W/2t)² · ∫ V(l) · 2 sin θ / (r² cos³θ_c) dl = K · (W/2t)² · ∫ V(l) · 2 d_c / z³ dl
//!
//! over the points of the segment whose projection falls in the pixel, where z(l) is the
//! camera-space depth (linear in l), d_c = r sin θ the distance from the camera to the line (the
//! same for every point of it) and V the visibility from the camera between the near and far clip
//! planes. Without V the integral is elementary: ∫ dl / z³ = (l_b − l_a)(z_a + z_b) / (2 z_a² z_b²).
//! The points of the segment in a pixel form one interval of l (a projective map of a segment
//! onto a convex pixel square), bounded by four half-lines `x − X·z ≥ 0`, linear in l.
//!
//! Estimator, per camera sample and line crossing the pixel: draw l with density ∝ 1/z³ on the
//! pixel's interval and return I_unoccluded · V(l) — unbiased, exact (zero variance) where the
//! line is unoccluded, Bernoulli where an occluder's silhouette crosses it. It uses one random
//! number per crossing line after the integrator's numbers.

use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::light::Light;
use crate::ray_offset::SHADOW_EPSILON;
use crate::shapes::Ray;
use glam::{DMat4, DVec3, Vec3};

/// A light segment in camera space (+z forward), in f64.
#[derive(Clone, Debug)]
struct CameraLine {
    q0: DVec3,
    /// Unit direction.
    u: DVec3,
    length: f64,
    /// K · (W/2t)² · 2 d_c per channel: the integrand is `weight / z³`.
    weight: DVec3,
}

/// The part of one line inside one pixel: `l ∈ [la, lb]`, depths `za`, `zb` there, and the
/// unoccluded pixel integral.
#[derive(Clone, Copy, Debug)]
pub struct PixelLine {
    line: u32,
    la: f64,
    lb: f64,
    za: f64,
    zb: f64,
    integral: Vec3,
}

/// The lights the camera sees, prepared once per render.
#[derive(Clone, Debug, Default)]
pub struct VisibleLines {
    lines: Vec<CameraLine>,
    to_world: DMat4,
    /// Film mapping: X = x/z on the plane ↔ px = W(½ − ppx) − W·X/(2t), likewise y with H·aspect.
    width: f64,
    height: f64,
    tan_half_x: f64,
    aspect: f64,
    ppx: f64,
    ppy: f64,
    near: f64,
    far: f64,
}

impl VisibleLines {
    /// The lines of `lights` (world space) as `camera` sees them. Empty when `hide_emitters`
    /// is set.
    pub fn new(camera: &Camera, lights: &[Light]) -> Self {
        let p = camera.projection();
        let to_camera = p.to_world.inverse();
        let film_scale = p.width / (2.0 * p.tan_half_x);
        let lines = lights
            .iter()
            .filter_map(|light| {
                let (a, b, k) = (light.segment.begin, light.segment.end, light.k);
                let q0 = to_camera.transform_point3(a.as_dvec3());
                let q1 = to_camera.transform_point3(b.as_dvec3());
                let length = (q1 - q0).length();
                if !(length > 0.0 && length.is_finite()) {
                    return None;
                }
                let u = (q1 - q0) / length;
                let d_c = q0.cross(u).length();
                let weight = k.as_dvec3() * (film_scale * film_scale * 2.0 * d_c);
                (weight != DVec3::ZERO && weight.is_finite()).then_some(CameraLine {
                    q0,
                    u,
                    length,
                    weight,
                })
            })
            .collect();
        Self {
            lines,
            to_world: p.to_world,
            width: p.width,
            height: p.height,
            tan_half_x: p.tan_half_x,
            aspect: p.aspect,
            ppx: p.ppx,
            ppy: p.ppy,
            near: p.near,
            far: p.far,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }

    /// The plane coordinates X = x/z of film column boundary `px` and Y = y/z of row `py`.
    fn plane_x(&self, px: f64) -> f64 {
        2.0 * self.tan_half_x * (0.5 - self.ppx - px / self.width)
    }
    fn plane_y(&self, py: f64) -> f64 {
        2.0 * self.tan_half_x / self.aspect * (0.5 - self.ppy - py / self.height)
    }

    /// The lines crossing full-film pixel (fx, fy), appended to `out` (cleared first).
    pub fn pixel(&self, fx: u32, fy: u32, out: &mut Vec<PixelLine>) {
        out.clear();
        if self.lines.is_empty() {
            return;
        }
        let (fx, fy) = (fx as f64, fy as f64);
        // X decreases with px, Y with py.
        let (x_lo, x_hi) = (self.plane_x(fx + 1.0), self.plane_x(fx));
        let (y_lo, y_hi) = (self.plane_y(fy + 1.0), self.plane_y(fy));
        for (i, line) in self.lines.iter().enumerate() {
            let (q0, u) = (line.q0, line.u);
            let mut lo = 0.0f64;
            let mut hi = line.length;
            // Each constraint a + b·l ≥ 0 bounds l on one side.
            let mut clip = |a: f64, b: f64| {
                if b > 0.0 {
                    lo = lo.max(-a / b);
                } else if b < 0.0 {
                    hi = hi.min(-a / b);
                } else if a < 0.0 {
                    hi = f64::NEG_INFINITY;
                }
            };
            clip(q0.z - self.near, u.z);
            clip(self.far - q0.z, -u.z);
            clip(q0.x - x_lo * q0.z, u.x - x_lo * u.z);
            clip(x_hi * q0.z - q0.x, x_hi * u.z - u.x);
            clip(q0.y - y_lo * q0.z, u.y - y_lo * u.z);
            clip(y_hi * q0.z - q0.y, y_hi * u.z - u.y);
            if !(hi > lo) {
                continue;
            }
            let (za, zb) = (q0.z + lo * u.z, q0.z + hi * u.z);
            if !(za > 0.0 && zb > 0.0) {
                continue;
            }
            let integral_of_inv_z3 = (hi - lo) * (za + zb) / (2.0 * za * za * zb * zb);
            let integral = (line.weight * integral_of_inv_z3).as_vec3();
            if integral.is_finite() && integral != Vec3::ZERO {
                out.push(PixelLine {
                    line: i as u32,
                    la: lo,
                    lb: hi,
                    za,
                    zb,
                    integral,
                });
            }
        }
    }

    /// One-sample estimate of the lines in `seen` (from [`Self::pixel`]) for the pixel they were
    /// computed for, added to `total`. Draws one uniform number in [0, 1) from `uniform` per
    /// entry of `seen`.
    pub fn add_estimate(
        &self,
        seen: &[PixelLine],
        bvh: &Bvh,
        mut uniform: impl FnMut() -> f64,
        total: &mut Vec3,
    ) {
        for pl in seen {
            let xi = uniform();
            // Density ∝ 1/z³ on [la, lb]: 1/z² is linear in the CDF.
            let (za, zb) = (pl.za, pl.zb);
            let l = if (zb - za).abs() > 1e-12 * za {
                let inv2 = (1.0 - xi) / (za * za) + xi / (zb * zb);
                let z = inv2.sqrt().recip();
                pl.la + (pl.lb - pl.la) * ((z - za) / (zb - za)).clamp(0.0, 1.0)
            } else {
                pl.la + xi * (pl.lb - pl.la)
            };
            let line = &self.lines[pl.line as usize];
            let q = line.q0 + l * line.u;
            if self.visible(q, bvh) {
                *total += pl.integral;
            }
        }
    }

    /// Whether camera-space point `q` (depth within the clip range) is seen from the camera: a
    /// ray from the pinhole, starting on the near plane, ending SHADOW_EPSILON short of `q` as a
    /// shadow ray does.
    fn visible(&self, q: DVec3, bvh: &Bvh) -> bool {
        let o = self.to_world.transform_point3(DVec3::ZERO);
        let p = self.to_world.transform_point3(q);
        let d = p - o;
        let dist = d.length();
        if !(dist > 0.0 && dist.is_finite() && q.z > 0.0) {
            return false;
        }
        let ray = Ray {
            o: o.as_vec3(),
            d: (d / dist).as_vec3(),
            t_min: (self.near * dist / q.z) as f32,
            t_max: (dist * (1.0 - SHADOW_EPSILON as f64)) as f32,
        };
        !bvh.occluded(&ray)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::render;
    use crate::scene_builder::{scene, sensor};
    use crate::RenderOptions;
    use linlight_sampling::{Segment, Technique};

    /// A line in front of the camera, no geometry: the sum over all pixels of the pixel
    /// integrals equals the integral over the whole segment (the pixels tile the film), which
    /// for a segment parallel to the film plane at depth z is K (W/2t)² 2 d_c L / z³.
    #[test]
    fn pixel_integrals_tile_the_segment() {
        let (w, h) = (40u32, 30u32);
        let cam = sensor(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0), Vec3::Y, 50.0, w, h);
        let camera = Camera::new(&cam).unwrap();
        let z = 3.0f32;
        // Camera space: +x left; world = camera here up to the look-at frame (identity-like).
        let (a, b) = (Vec3::new(-0.5, 0.2, z), Vec3::new(0.6, 0.2, z));
        let k = Vec3::new(1.0, 2.0, 0.5);
        let vis = VisibleLines::new(&camera, &[Light::new(Segment::new(a, b), k)]);
        let mut total = DVec3::ZERO;
        let mut seen = Vec::new();
        let mut crossed = 0;
        for y in 0..h {
            for x in 0..w {
                vis.pixel(x, y, &mut seen);
                crossed += seen.len();
                for s in &seen {
                    total += s.integral.as_dvec3();
                }
            }
        }
        let t = (25.0f64).to_radians().tan();
        let scale = (w as f64 / (2.0 * t)).powi(2);
        let d_c = ((0.2f64).powi(2) + (z as f64).powi(2)).sqrt();
        let want = scale * 2.0 * d_c * 1.1 / (z as f64).powi(3);
        assert!(crossed > 10);
        assert!(
            ((total.x - want) / want).abs() < 1e-4,
            "{total:?} vs {want}"
        );
        assert!(((total.y - 2.0 * want) / want).abs() < 2e-4);
    }

    /// The rendered image holds exactly the pixel integrals (zero variance) when nothing
    /// occludes the line, and nothing when hide_emitters is set.
    #[test]
    fn render_adds_the_unoccluded_line_exactly() {
        let cam = sensor(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0), Vec3::Y, 50.0, 20, 16);
        let mut sc = scene(
            cam,
            vec![],
            vec![crate::scene_builder::light(
                Vec3::new(-2.0, -0.5, 3.0),
                Vec3::new(2.0, 0.8, 5.0),
                [1.0, 1.0, 1.0],
            )],
        );
        let opts = RenderOptions {
            spp: 8,
            passes: 1,
            seed: 3,
            method: Technique::ProjectedSolidAngle.into(),
            light_samples: 1,
            lights: Default::default(),
            noise: Default::default(),
            cylinders: crate::options::Cylinders::Line,
        };
        let hidden = render(&sc, &opts, &|_, _| {}).unwrap();
        assert!(hidden.mean.iter().all(|m| *m == [0.0; 3]));
        sc.integrator.hide_emitters = false;
        let img = render(&sc, &opts, &|_, _| {}).unwrap();
        let camera = Camera::new(&sc.sensor).unwrap();
        let vis = VisibleLines::new(&camera, &[Light::of(&sc.lights[0])]);
        let mut seen = Vec::new();
        let mut lit = 0;
        for y in 0..16 {
            for x in 0..20 {
                vis.pixel(x, y, &mut seen);
                let want: f32 = seen.iter().map(|s| s.integral.x).sum();
                let k = (y * 20 + x) as usize;
                assert!(
                    (img.mean[k][0] - want).abs() <= 1e-5 * want.max(1.0),
                    "{x},{y}"
                );
                assert_eq!(img.var[k][0], 0.0);
                lit += usize::from(want > 0.0);
            }
        }
        assert!(lit > 15, "{lit}");
    }
}
