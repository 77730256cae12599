//! The exact R → 0 image of an *unoccluded* plane lit by linear lights, as pixel averages: the
//! closed form for Lambertian surfaces, adaptive quadrature along the line for any other BSDF.
//!
//! At a point x of a surface (normal n facing the viewer, view direction v) lit by a linear light
//! with K = radiance × radius, the reflected radiance in the R → 0 limit is
//! K·∫ f(v, ω)·max(0, n·ω) dΩ_R over the part of the segment above the tangent plane.
//! - Lambertian (f = ρ/π): (ρ/π)·K·Ω⊥_R(x), Ω⊥_R the projected solid angle per radius of the
//!   clipped segment (`LineFrame::clip_to_horizon` then `projected_solid_angle`), in closed form.
//! - Any other BSDF (GGX conductor, principled, blends, twosided of these): the 1-D integral over
//!   the line position t with dΩ_R = 2 |u × ω| dt / r², by adaptive quadrature in f64
//!   ([`crate::ground_truth::line_quadrature`]), which shares nothing with the samplers. It also works for a
//!   Lambertian surface ([`Method::Quadrature`]), which cross-checks the two.
//!
//! This is exact only where no visibility term is needed, i.e. when nothing can stand between x
//! and the line. Supported scenes (anything else is an error, see [`check_supported`]):
//!   - at most one non-emitting shape, and it is planar: a triangle mesh without shading normals
//!     whose triangles all lie in one plane with one orientation (a `rectangle`, or any flat
//!     polygon), or a `disk`. A plane cannot shadow any point of itself; the tangent-plane clip
//!     removes exactly what lies behind it;
//!   - any BSDF, one-sided or inside `twosided` (the normal then faces the viewer);
//!   - any number of linear lights, which may pierce the plane (floor-crossing);
//!   - any perspective sensor and crop window the renderer accepts;
//!   - `hide_emitters` set (the lines the camera sees are not part of the closed form).
//!
//! floor-tube, floor-crossing, two-tubes, glossy-conductor-sharp, glossy-conductor-rough and
//! glossy-blend are of this kind; cornell-tube, mesh-occluder, glossy-principled and
//! glossy-cornell are not. A pixel value is the average of that radiance over an s×s grid of film
//! positions at the centres of the sub-squares of the pixel (midpoint rule on the box filter),
//! traced with the renderer's own camera and intersection code, so it matches the renderer's
//! pixel footprint exactly; positions that hit nothing or the back of a one-sided surface
//! contribute 0. For a pixel entirely on the plane the integrand is smooth and the rule's error
//! is O(1/s²); pixels that contain a silhouette edge converge only as O(1/s).

use crate::ground_truth::line_quadrature::{unshadowed_line_integral, QuadraturePoint};
use glam::{DVec3, Vec3};
use linlight_imagefile::{Image, Metadata};
use linlight_render::light::Light;
use linlight_render::render_scene::{diffuse_lobe, reflecting_normal, RenderScene};
use linlight_render::scene::{Bsdf, Geometry, Scene};
use linlight_render::RenderError;
use linlight_sampling::LineFrame;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Degrees of freedom written into the image header. The closed form has no sampling error (its
/// variance channels are 0); the quadrature error is deterministic and, for the supported scenes
/// at s ≥ 4, orders of magnitude below any render's standard error. A huge finite dof says "the
/// variance is known exactly"; `compare` skips the Welch–Satterthwaite terms of zero-variance
/// images, so the value only matters to readers of the header.
pub const CLOSED_FORM_DOF: f64 = 1e12;

/// Relative tolerance of the planarity test (distance from the plane over the mesh's extent, and
/// 1 − cos of the angle between face normals).
const PLANAR_TOLERANCE: f64 = 1e-5;

fn unsupported(msg: String) -> RenderError {
    RenderError::Scene(format!("closed form not applicable: {msg}"))
}

/// `Ok` iff the closed form is exact for `scene` (see the module documentation).
pub fn check_supported(scene: &Scene) -> Result<(), RenderError> {
    if !scene.integrator.hide_emitters && !scene.lights.is_empty() {
        return Err(unsupported(
            "hide_emitters is false: the lines the camera sees are not part of the closed form"
                .into(),
        ));
    }
    if scene.shapes.len() > 1 {
        return Err(unsupported(format!(
            "{} non-emitting shapes (at most one planar shape, which cannot shadow itself)",
            scene.shapes.len()
        )));
    }
    for shape in &scene.shapes {
        let at = &shape.location;
        match &shape.geometry {
            Geometry::Mesh {
                positions,
                normals,
                indices,
            } => {
                if normals.is_some() {
                    return Err(unsupported(format!(
                        "mesh at {at} has vertex normals (shading normals)"
                    )));
                }
                check_planar(positions, indices).map_err(|m| unsupported(format!("{m} at {at}")))?
            }
            Geometry::Disk { .. } => {}
            Geometry::Sphere { .. } => {
                return Err(unsupported(format!("sphere at {at} is not planar")));
            }
            Geometry::Cylinder { .. } => {
                return Err(unsupported(format!("cylinder at {at} is not planar")));
            }
        }
    }
    Ok(())
}

/// All referenced vertices within `PLANAR_TOLERANCE`·extent of the plane of the first
/// non-degenerate triangle, and every non-degenerate triangle facing the same way.
fn check_planar(positions: &[Vec3], indices: &[[u32; 3]]) -> Result<(), String> {
    let vertex = |k: u32| {
        positions
            .get(k as usize)
            .map(|p| p.as_dvec3())
            .ok_or_else(|| format!("mesh index {k} out of range"))
    };
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut tris = Vec::with_capacity(indices.len());
    for tri in indices {
        let v = [vertex(tri[0])?, vertex(tri[1])?, vertex(tri[2])?];
        for p in v {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        tris.push(v);
    }
    let extent = (hi - lo).max_element();
    if !(extent > 0.0 && extent.is_finite()) {
        return Err("mesh is empty or degenerate".into());
    }
    let normal = |v: &[DVec3; 3]| (v[1] - v[0]).cross(v[2] - v[0]).try_normalize();
    let Some((n0, p0)) = tris.iter().find_map(|v| normal(v).map(|n| (n, v[0]))) else {
        return Err("mesh has no triangle of positive area".into());
    };
    for v in &tris {
        if v.iter()
            .any(|p| (p - p0).dot(n0).abs() > PLANAR_TOLERANCE * extent)
        {
            return Err("mesh is not planar".into());
        }
        if let Some(n) = normal(v) {
            if n.dot(n0) < 1.0 - PLANAR_TOLERANCE {
                return Err("mesh triangles face different ways".into());
            }
        }
    }
    Ok(())
}

/// How the radiance at a point is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The closed form (ρ/π)·K·Ω⊥_R on a Lambertian surface, quadrature along the line on any
    /// other.
    Auto,
    /// Quadrature along the line for every BSDF (on a Lambertian surface: a cross-check of the
    /// closed form).
    Quadrature,
}

/// The primary-ray hit through full-film pixel position (px, py): the renderer's surface point,
/// its BSDF and the normal of the side that reflects toward the viewer; None when the ray misses
/// or meets the back of a one-sided surface.
fn primary_hit(rs: &RenderScene, px: f32, py: f32) -> Option<(Vec3, Vec3, Vec3, &Bsdf)> {
    let ray = rs.camera.ray(px, py);
    let hit = rs.bvh.intersect(&ray)?;
    let prim = rs.bvh.primitive(hit.prim);
    let (bsdf, flip) = &rs.surfaces[prim.shape() as usize];
    let sp = prim.surface_point(&ray, &hit, *flip);
    let n = reflecting_normal(bsdf, sp.ns, -ray.d)?;
    Some((sp.p, n, -ray.d, bsdf))
}

/// Lambertian closed form at the primary hit through (px, py): (ρ/π)·Σ K·Ω⊥_R, f64.
fn closed_form_at(rs: &RenderScene, px: f32, py: f32) -> [f64; 3] {
    let Some((p, ns, wi, bsdf)) = primary_hit(rs, px, py) else {
        return [0.0; 3];
    };
    let Some((n, albedo)) = diffuse_lobe(bsdf, ns, wi) else {
        return [0.0; 3];
    };
    let mut sum = DVec3::ZERO;
    for Light { segment, k } in &rs.lights {
        let omega = LineFrame::new(segment, p)
            .and_then(|f| f.clip_to_horizon(n))
            .map_or(0.0, |f| f.projected_solid_angle(n));
        // Non-negative in exact arithmetic; rounding may leave −ε when the clipped interval is tiny.
        if omega > 0.0 && omega.is_finite() {
            sum += k.as_dvec3() * omega as f64;
        }
    }
    (albedo.as_dvec3() * std::f64::consts::FRAC_1_PI * sum).to_array()
}

/// Σ K·∫ f·cos dΩ_R by quadrature along each line at the primary hit through (px, py); counts
/// integrals that missed their error target in `unconverged`.
fn quadrature_at(rs: &RenderScene, px: f32, py: f32, unconverged: &AtomicU64) -> [f64; 3] {
    let Some((p, n, wi, bsdf)) = primary_hit(rs, px, py) else {
        return [0.0; 3];
    };
    let sp = QuadraturePoint::new(p.as_dvec3(), n.as_dvec3(), wi.as_dvec3());
    let mut sum = DVec3::ZERO;
    for Light { segment, k } in &rs.lights {
        let (value, converged) =
            unshadowed_line_integral(bsdf, &sp, segment.begin.as_dvec3(), segment.end.as_dvec3());
        if !converged {
            unconverged.fetch_add(1, Ordering::Relaxed);
        }
        sum += k.as_dvec3() * value;
    }
    sum.to_array()
}

/// Per pixel of the window (x0, y0, w, h), the average of `radiance` over an s×s grid of film
/// positions at the sub-square centres (midpoint rule on the box filter).
fn pixel_average(
    window: (u32, u32, u32, u32),
    s: u32,
    radiance: &(dyn Fn(f32, f32) -> [f64; 3] + Sync),
) -> Image {
    let (x0, y0, w, h) = window;
    let inv_s = 1.0 / s as f64;
    let inv_count = inv_s * inv_s;
    let rows: Vec<Vec<[f32; 3]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            (0..w)
                .map(|x| {
                    let (fx, fy) = ((x0 + x) as f64, (y0 + y) as f64);
                    let mut acc = [0.0f64; 3];
                    for b in 0..s {
                        let py = (fy + (b as f64 + 0.5) * inv_s) as f32;
                        for a in 0..s {
                            let px = (fx + (a as f64 + 0.5) * inv_s) as f32;
                            let l = radiance(px, py);
                            for (acc, l) in acc.iter_mut().zip(l) {
                                *acc += l;
                            }
                        }
                    }
                    acc.map(|v| (v * inv_count) as f32)
                })
                .collect()
        })
        .collect();
    let mut image = Image::new(w as usize, h as usize);
    for (dst, src) in image.mean.iter_mut().zip(rows.into_iter().flatten()) {
        *dst = src;
    }
    image
}

/// Per pixel (of the crop window, or the whole film), the average over an s×s grid of film
/// positions (sub-square centres) of the unshadowed reflected radiance at the primary-ray hit
/// point ([`Method::Auto`]: closed form on Lambertian surfaces, quadrature along the line on
/// others); variance 0, dof = [`CLOSED_FORM_DOF`]. Errors if the scene is not supported
/// ([`check_supported`]), if `subsamples` is 0, or if the renderer cannot use the sensor.
pub fn unshadowed_pixel_average(scene: &Scene, subsamples: u32) -> Result<Image, RenderError> {
    unshadowed_pixel_average_with(scene, subsamples, Method::Auto)
}

/// [`unshadowed_pixel_average`] with the method chosen. The header records it: `renderer` is
/// "linlight closed-form" or "linlight line-quadrature", `method` says what was integrated how,
/// and a quadrature image carries `quadrature_unconverged` (integrals that missed their error
/// target; 0 for every supported scene of the repository).
pub fn unshadowed_pixel_average_with(
    scene: &Scene,
    subsamples: u32,
    method: Method,
) -> Result<Image, RenderError> {
    if subsamples == 0 {
        return Err(RenderError::Options("subsamples must be at least 1".into()));
    }
    check_supported(scene)?;
    let rs = RenderScene::new(scene)?;
    let window = match scene.sensor.film.crop {
        Some(c) => (c.offset_x, c.offset_y, c.width, c.height),
        None => (0, 0, scene.sensor.film.width, scene.sensor.film.height),
    };
    let s = subsamples;
    let closed =
        method == Method::Auto && scene.shapes.iter().all(|sh| sh.bsdf.lambertian().is_some());
    let unconverged = AtomicU64::new(0);
    let mut image = if closed {
        pixel_average(window, s, &|px, py| closed_form_at(&rs, px, py))
    } else {
        pixel_average(window, s, &|px, py| {
            quadrature_at(&rs, px, py, &unconverged)
        })
    };
    let mut meta = Metadata {
        dof: CLOSED_FORM_DOF,
        spp: s as u64 * s as u64,
        passes: 1,
        renderer: if closed {
            "linlight closed-form"
        } else {
            "linlight line-quadrature"
        }
        .into(),
        scene_sha256: scene.sha256.clone(),
        ..Default::default()
    };
    let what = if closed {
        "unshadowed (rho/pi) sum K Omega_perp_R".to_string()
    } else {
        format!(
            "unshadowed sum K int f cos dOmega_R, dOmega_R = 2|u x w| dt / r^2, adaptive \
             Gauss-Legendre over the line position t ({} equal-angle panels, relative error {:e})",
            crate::ground_truth::line_quadrature::PANELS,
            crate::ground_truth::line_quadrature::RELATIVE_ERROR
        )
    };
    meta.extra.insert(
        "method".into(),
        format!("{what}, {s}x{s} midpoint rule per pixel"),
    );
    meta.extra.insert("subsamples".into(), s.to_string());
    if !closed {
        meta.extra.insert(
            "quadrature_unconverged".into(),
            unconverged.load(Ordering::Relaxed).to_string(),
        );
    }
    // Its zero variances are exact, not estimates (`compare` trusts them as such).
    meta.extra.insert("variance".into(), "exact".into());
    image.meta = meta;
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_render::camera::Camera;
    use linlight_render::scene::Shape;
    use linlight_render::scene_builder::{cornell_box, cuboid, diffuse, light, scene, sensor};

    const RHO: [f32; 3] = [0.7, 0.5, 0.3];
    const K: [f32; 3] = [1.0, 2.0, 0.5];

    fn floor() -> Shape {
        linlight_render::scene_builder::floor(3.0, RHO)
    }

    /// A floor filling most of the view, a tilted light that crosses the floor's plane (so some
    /// points need horizon clipping), and a second light entirely above it.
    fn floor_scene(w: u32, h: u32) -> Scene {
        let v = Vec3::new;
        let cam = sensor(v(0.2, -2.5, 2.0), v(0.0, 0.3, 0.0), Vec3::Z, 40.0, w, h);
        scene(
            cam,
            vec![floor()],
            vec![
                light(v(-0.6, -0.3, 0.35), v(0.5, 0.4, 0.75), K),
                light(v(0.8, -1.0, -0.3), v(0.2, 0.9, 0.6), [0.3, 0.3, 0.9]),
            ],
        )
    }

    /// ρ/π·K·∫ max(0, n·ω) dΩ_R along the segment with dΩ_R = 2d/r³ dl, by the midpoint rule in
    /// f64 (independent of LineFrame, C(s) and the horizon clip).
    fn quadrature(x: DVec3, n: DVec3, p0: DVec3, p1: DVec3) -> f64 {
        let count = 200_000;
        let len = (p1 - p0).length();
        let u = (p1 - p0) / len;
        let mut sum = 0.0;
        for i in 0..count {
            let p = p0 + (i as f64 + 0.5) / count as f64 * (p1 - p0);
            let v = p - x;
            let r = v.length();
            let d = v.cross(u).length();
            sum += (v.dot(n) / r).max(0.0) * 2.0 * d / (r * r * r);
        }
        sum * len / count as f64
    }

    #[test]
    fn pixel_centres_match_direct_quadrature() {
        let sc = floor_scene(24, 16);
        let img = unshadowed_pixel_average(&sc, 1).unwrap();
        let cam = Camera::new(&sc.sensor).unwrap();
        let mut checked = 0;
        for &(x, y) in &[
            (0usize, 0usize),
            (5, 3),
            (12, 8),
            (23, 15),
            (17, 11),
            (2, 14),
        ] {
            // The floor point seen through the pixel centre, intersected here in f64.
            let r = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            let (o, d) = (r.o.as_dvec3(), r.d.as_dvec3());
            let p = o + (-o.z / d.z) * d;
            assert!(
                p.x.abs() < 3.0 && p.y.abs() < 3.0,
                "pixel {x},{y} must see the floor"
            );
            let mut want = [0.0f64; 3];
            for l in &sc.lights {
                let q = quadrature(p, DVec3::Z, l.begin.as_dvec3(), l.end.as_dvec3());
                for c in 0..3 {
                    want[c] += RHO[c] as f64 / std::f64::consts::PI
                        * l.radiance_times_radius[c] as f64
                        * q;
                }
            }
            let got = img.mean[y * 24 + x];
            for c in 0..3 {
                let rel = (got[c] as f64 - want[c]).abs() / want[c];
                assert!(
                    rel < 2e-5,
                    "pixel {x},{y} channel {c}: {} vs {}",
                    got[c],
                    want[c]
                );
            }
            checked += 1;
        }
        assert_eq!(checked, 6);
        assert!(img.var.iter().all(|v| *v == [0.0; 3]));
        assert_eq!(img.meta.renderer, "linlight closed-form");
        assert_eq!(img.meta.dof, CLOSED_FORM_DOF);
        img.validate().unwrap();
    }

    #[test]
    fn subsamples_average_the_finer_grid() {
        // Pixel (i, j) of a W×H film with s = 2 uses film positions ((i + ¼ or ¾)/W, ...), which
        // are the centres of pixels (2i, 2j)…(2i+1, 2j+1) of a 2W×2H film with s = 1.
        let coarse = unshadowed_pixel_average(&floor_scene(12, 8), 2).unwrap();
        let fine = unshadowed_pixel_average(&floor_scene(24, 16), 1).unwrap();
        for j in 0..8 {
            for i in 0..12 {
                for c in 0..3 {
                    let want: f32 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                        .iter()
                        .map(|&(a, b)| fine.mean[(2 * j + b) * 24 + 2 * i + a][c])
                        .sum::<f32>()
                        / 4.0;
                    let got = coarse.mean[j * 12 + i][c];
                    assert!(
                        (got - want).abs() <= 1e-5 * want.abs(),
                        "{i},{j}: {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn misses_and_back_faces_are_black() {
        let v = Vec3::new;
        // Camera below the floor looking up: it sees the back of the one-sided floor.
        let cam = sensor(v(0.0, 0.0, -2.0), v(0.0, 0.1, 0.0), Vec3::Y, 40.0, 8, 8);
        let sc = scene(
            cam,
            vec![floor()],
            vec![light(v(-1., 0., 1.), v(1., 0., 1.), K)],
        );
        let img = unshadowed_pixel_average(&sc, 2).unwrap();
        assert!(img.mean.iter().all(|m| *m == [0.0; 3]));
        // The same floor two-sided: lit only by what is below it (nothing here) -> still black;
        // with the light below, the back is lit.
        let mut two = floor();
        two.bsdf = Bsdf::TwoSided(Box::new(two.bsdf.clone()));
        let cam = sensor(v(0.0, 0.0, -2.0), v(0.0, 0.1, 0.0), Vec3::Y, 40.0, 8, 8);
        let below = light(v(-1., 0., -1.), v(1., 0., -1.), K);
        let img = unshadowed_pixel_average(&scene(cam, vec![two], vec![below]), 2).unwrap();
        assert!(img.mean.iter().all(|m| m[0] > 0.0));
        // A camera looking away from everything.
        let cam = sensor(v(0.0, 0.0, 2.0), v(0.0, 0.0, 5.0), Vec3::Y, 40.0, 4, 4);
        let sc = scene(
            cam,
            vec![floor()],
            vec![light(v(-1., 0., 1.), v(1., 0., 1.), K)],
        );
        let img = unshadowed_pixel_average(&sc, 3).unwrap();
        assert!(img.mean.iter().all(|m| *m == [0.0; 3]));
    }

    #[test]
    fn crop_is_a_window_of_the_full_film() {
        let full = unshadowed_pixel_average(&floor_scene(20, 12), 2).unwrap();
        let mut sc = floor_scene(20, 12);
        sc.sensor.film.crop = Some(linlight_render::scene::CropWindow {
            offset_x: 5,
            offset_y: 3,
            width: 7,
            height: 4,
        });
        let crop = unshadowed_pixel_average(&sc, 2).unwrap();
        assert_eq!((crop.width, crop.height), (7, 4));
        for y in 0..4 {
            for x in 0..7 {
                assert_eq!(crop.mean[y * 7 + x], full.mean[(y + 3) * 20 + x + 5]);
            }
        }
    }

    #[test]
    fn unsupported_scenes_are_errors() {
        let err = |sc: &Scene| unshadowed_pixel_average(sc, 2).unwrap_err().to_string();
        assert!(err(&cornell_box(8, 8)).contains("non-emitting shapes"));
        let mut sc = floor_scene(8, 8);
        sc.shapes[0] = diffuse(cuboid(Vec3::ZERO, Vec3::ONE), RHO);
        assert!(err(&sc).contains("not planar"), "{}", err(&sc));
        // A flat mesh whose second triangle is wound the other way.
        let v = Vec3::new;
        sc.shapes[0] = diffuse(
            Geometry::Mesh {
                positions: vec![v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)],
                normals: None,
                indices: vec![[0, 1, 2], [0, 3, 2]],
            },
            RHO,
        );
        assert!(err(&sc).contains("different ways"), "{}", err(&sc));
        sc.shapes[0] = diffuse(
            Geometry::Sphere {
                center: Vec3::ZERO,
                radius: 1.0,
            },
            RHO,
        );
        assert!(err(&sc).contains("sphere"));
        let mut sc = floor_scene(8, 8);
        if let Geometry::Mesh { normals, .. } = &mut sc.shapes[0].geometry {
            *normals = Some(vec![Vec3::Z; 4]);
        }
        assert!(err(&sc).contains("shading normals"));
        assert!(unshadowed_pixel_average(&floor_scene(8, 8), 0).is_err());
        // Every BSDF is accepted: Lambertian ones in closed form, the others by quadrature.
        let mut sc = floor_scene(8, 8);
        sc.shapes[0].bsdf = Bsdf::TwoSided(Box::new(conductor(0.4)));
        let img = unshadowed_pixel_average(&sc, 2).unwrap();
        assert_eq!(img.meta.renderer, "linlight line-quadrature");
        assert_eq!(img.meta.extra["quadrature_unconverged"], "0");
        sc.shapes[0].bsdf = Bsdf::Blend(linlight_brdf::Blend {
            weight: 0.5,
            bsdfs: Box::new([
                Bsdf::Diffuse { reflectance: RHO },
                Bsdf::Diffuse {
                    reflectance: [0.1; 3],
                },
            ]),
        });
        let img = unshadowed_pixel_average(&sc, 2).unwrap();
        assert_eq!(img.meta.renderer, "linlight closed-form");
        // A disk is planar and accepted.
        let mut sc = floor_scene(8, 8);
        sc.shapes[0] = diffuse(
            Geometry::Disk {
                to_world: glam::Mat4::from_scale(Vec3::splat(2.0)),
            },
            RHO,
        );
        let img = unshadowed_pixel_average(&sc, 2).unwrap();
        assert!(img.mean.iter().any(|m| m[0] > 0.0));
    }

    fn conductor(alpha: f32) -> Bsdf {
        Bsdf::RoughConductor(linlight_brdf::RoughConductor {
            alpha,
            fresnel: linlight_brdf::ConductorFresnel::One,
            specular_reflectance: [1.0, 0.8, 0.6],
        })
    }

    /// The two methods on a Lambertian floor: the closed form (ρ/π)·K·Ω⊥_R through the
    /// samplers' `LineFrame`, and quadrature along the line that shares nothing with it.
    #[test]
    fn quadrature_equals_the_closed_form_on_a_lambertian_floor() {
        let sc = floor_scene(12, 8);
        let closed = unshadowed_pixel_average(&sc, 2).unwrap();
        let quad = unshadowed_pixel_average_with(&sc, 2, Method::Quadrature).unwrap();
        assert_eq!(quad.meta.renderer, "linlight line-quadrature");
        assert_eq!(quad.meta.extra["quadrature_unconverged"], "0");
        for (a, b) in closed.mean.iter().zip(&quad.mean) {
            for c in 0..3 {
                assert!(
                    (a[c] - b[c]).abs() <= 2e-6 * a[c].abs().max(1e-3),
                    "{a:?} vs {b:?}"
                );
            }
        }
    }

    /// A glossy floor: the quadrature image against the renderer's Monte Carlo estimate
    /// (projected solid angle, full BSDF), per pixel within 4.5 standard errors and in the image
    /// mean within 3.
    #[test]
    fn quadrature_agrees_with_a_monte_carlo_render_of_a_glossy_floor() {
        // A floor that fills the view (no silhouette edge in a pixel), so that the 8×8 midpoint
        // rule over the coarse pixels is accurate to ~1e-3 relative.
        let mut sc = floor_scene(16, 12);
        sc.shapes[0] = linlight_render::scene_builder::floor(30.0, RHO);
        sc.shapes[0].bsdf = conductor(0.25);
        let quad = unshadowed_pixel_average(&sc, 8).unwrap();
        let opts = linlight_render::RenderOptions {
            spp: 16_384,
            passes: 1,
            seed: 7,
            method: linlight_sampling::Technique::ProjectedSolidAngle.into(),
            light_samples: 1,
            ..Default::default()
        };
        let mc = linlight_render::render(&sc, &opts, &|_, _| {}).unwrap();
        let (mut sum_d, mut sum_v, mut worst) = (0.0f64, 0.0f64, 0.0f64);
        for ((q, m), v) in quad.mean.iter().zip(&mc.mean).zip(&mc.var) {
            for c in 0..3 {
                let d = m[c] as f64 - q[c] as f64;
                sum_d += d;
                sum_v += v[c] as f64;
                if v[c] > 0.0 {
                    worst = worst.max(d.abs() / (v[c] as f64).sqrt());
                }
            }
        }
        // 576 pixel channels: P(max |z| > 4.5) ≈ 576 · 6.8e-6 ≈ 4e-3.
        assert!(worst < 4.5, "worst pixel |z| = {worst}");
        eprintln!(
            "worst pixel |z| = {worst}, image mean z = {}",
            sum_d / sum_v.sqrt()
        );
        let z = sum_d / sum_v.sqrt();
        assert!(z.abs() < 3.0, "image mean z = {z}");
        assert!(quad.mean.iter().any(|m| m[0] > 0.1), "the lobe is in view");
    }
}
