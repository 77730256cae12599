//! End-to-end checks of the renderer on scenes built in code.

use glam::Vec3;
use linlight_imagefile::Image;
use linlight_render::camera::Camera;
use linlight_render::scene::{Bsdf, CropWindow, Scene};
use linlight_render::scene_builder::{cuboid, diffuse, light, scene, sensor};
use linlight_render::{render, LightSelection, RenderOptions};
use linlight_sampling::{LineFrame, Segment, Technique};

const RHO: [f32; 3] = [0.8, 0.5, 0.2];
const K: [f32; 3] = [2.0, 1.0, 0.5];

fn floor() -> linlight_render::scene::Shape {
    linlight_render::scene_builder::floor(3.0, RHO)
}

/// Diffuse floor z = 0 seen from above, one tilted light above it.
fn floor_scene(size: u32, seg: Segment) -> Scene {
    let cam = sensor(
        Vec3::new(0.3, -0.2, 4.0),
        Vec3::ZERO,
        Vec3::Y,
        40.0,
        size,
        size,
    );
    scene(cam, vec![floor()], vec![light(seg.begin, seg.end, K)])
}

fn tilted() -> Segment {
    Segment::new(Vec3::new(-0.5, -0.3, 0.3), Vec3::new(0.7, 0.4, 1.2))
}

fn opts(spp: u32, passes: u32, seed: u64, technique: Technique) -> RenderOptions {
    RenderOptions {
        spp,
        passes,
        seed,
        method: technique.into(),
        light_samples: 1,
        lights: Default::default(),
        noise: Default::default(),
        cylinders: linlight_render::Cylinders::Line,
    }
}

fn quiet(_: usize, _: usize) {}

/// Where the camera ray through full-film pixel position (x, y) meets the plane z = 0.
fn floor_point(cam: &Camera, x: f32, y: f32) -> Vec3 {
    let r = cam.ray(x, y);
    r.o + (-r.o.z / r.d.z) * r.d
}

/// ρ/π·K·Ω⊥_R at a floor point (normal +z), the R → 0 radiance of an unshadowed light.
fn closed_form(seg: &Segment, x: Vec3) -> f64 {
    LineFrame::new(seg, x)
        .and_then(|f| f.clip_to_horizon(Vec3::Z))
        .map_or(0.0, |f| f.projected_solid_angle(Vec3::Z) as f64)
        * (RHO[0] * K[0]) as f64
        / std::f64::consts::PI
}

/// Pixel average of the closed form: midpoint rule on an m × m grid over the pixel.
fn expected_pixel(cam: &Camera, seg: &Segment, px: u32, py: u32, m: u32) -> f64 {
    let mut sum = 0.0;
    for a in 0..m {
        for b in 0..m {
            let x = px as f32 + (a as f32 + 0.5) / m as f32;
            let y = py as f32 + (b as f32 + 0.5) / m as f32;
            sum += closed_form(seg, floor_point(cam, x, y));
        }
    }
    sum / (m * m) as f64
}

fn assert_finite(img: &Image) {
    for (m, v) in img.mean.iter().zip(&img.var) {
        assert!(
            m.iter().chain(v).all(|c| c.is_finite() && *c >= 0.0),
            "{m:?} {v:?}"
        );
    }
}

/// z-scores of channel 0 against the pixel-averaged closed form, scaled by `bias`.
fn z_scores(img: &Image, cam: &Camera, seg: &Segment, bias: f64) -> Vec<f64> {
    let mut z = Vec::new();
    for py in 0..img.height as u32 {
        for px in 0..img.width as u32 {
            let k = (py as usize) * img.width + px as usize;
            let e = bias * expected_pixel(cam, seg, px, py, 16);
            let se = (img.var[k][0] as f64).sqrt();
            assert!(se > 0.0, "pixel {px},{py} has zero variance");
            z.push((img.mean[k][0] as f64 - e) / se);
        }
    }
    z
}

/// Unshadowed diffuse floor: every pixel agrees with the closed form. 256 pixels, two-sided
/// α = 0.01 with Bonferroni: |z| < Φ⁻¹(1 − 0.01/512) = 4.11 (dof = 4095, normal enough).
/// Power: a 3 % error of the expectation must be rejected by the same test.
/// Each technique is tested at its own α = 0.01. Calibration (seeds 100–299, counter-based
/// streams): 1, 2 and 2 of 200 renders exceed the bound for clipped solid angle, projected solid
/// angle and Li 2018; pooled z has mean 0.00 and variance 1.00. The test's seed is 12 (seed 11
/// is one of clipped solid angle's 1 % beyond the bound).
#[test]
fn floor_matches_closed_form() {
    for t in [
        Technique::ClippedSolidAngle,
        Technique::ProjectedSolidAngle,
        Technique::Li2018,
    ] {
        floor_matches_closed_form_with(t);
    }
}

fn floor_matches_closed_form_with(technique: Technique) {
    let seg = tilted();
    let sc = floor_scene(16, seg);
    let cam = Camera::new(&sc.sensor).unwrap();
    let img = render(&sc, &opts(4096, 1, 12, technique), &quiet).unwrap();
    assert_finite(&img);
    assert_eq!(img.meta.dof, 4095.0);
    let z = z_scores(&img, &cam, &seg, 1.0);
    let worst = z.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    assert!(worst < 4.11, "{technique}: worst |z| = {worst}");
    let chi2: f64 = z.iter().map(|z| z * z).sum();
    // χ²(256) upper 0.1 % point ≈ 336.
    assert!(chi2 < 336.0, "{technique}: sum z² = {chi2}");
    let z_wrong = z_scores(&img, &cam, &seg, 1.03);
    let worst_wrong = z_wrong.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    eprintln!(
        "closed form, {technique}: worst |z| {worst:.2}, sum z² {chi2:.1}, worst |z| at +3 %: {worst_wrong:.1}"
    );
    assert!(
        worst_wrong > 4.11,
        "no power against a 3% error: {worst_wrong}"
    );
    // Other channels scale exactly with ρ·K.
    for (m, _) in img.mean.iter().zip(&img.var) {
        let r = (RHO[1] * K[1]) / (RHO[0] * K[0]);
        assert!((m[1] - r * m[0]).abs() <= 1e-5 * m[0].max(1e-30));
    }
}

/// One light per light sample (`LightSelection::One`) on a floor lit by two lights, chosen
/// uniformly and by `sampling_weight` 3 : 1: every pixel agrees with the sum of both lights'
/// closed forms (the test above: 256 pixels, |z| < 4.11, Σz² < 336, each configuration at
/// α = 0.01). Power: the expectation of choosing 3 : 1 but dividing by the uniform ½
/// (1.5·L₁ + 0.5·L₂) is rejected.
#[test]
fn one_light_per_sample_matches_the_closed_form_of_both_lights() {
    let (a, b) = (
        tilted(),
        Segment::new(Vec3::new(0.8, -0.9, 0.5), Vec3::new(-0.4, 0.9, 0.7)),
    );
    for (weights, seed) in [([1.0, 1.0], 21), ([3.0, 1.0], 22)] {
        let mut sc = floor_scene(16, a);
        sc.lights.push(light(b.begin, b.end, K));
        for (l, w) in sc.lights.iter_mut().zip(weights) {
            l.sampling_weight = w;
        }
        let cam = Camera::new(&sc.sensor).unwrap();
        let o = RenderOptions {
            lights: LightSelection::One,
            ..opts(4096, 1, seed, Technique::ProjectedSolidAngle)
        };
        let img = render(&sc, &o, &quiet).unwrap();
        assert_finite(&img);
        assert_eq!(img.meta.extra["light_selection"], "one");
        let z = |wa: f64, wb: f64| -> Vec<f64> {
            let mut z = Vec::new();
            for py in 0..16u32 {
                for px in 0..16u32 {
                    let k = (py * 16 + px) as usize;
                    let e = wa * expected_pixel(&cam, &a, px, py, 16)
                        + wb * expected_pixel(&cam, &b, px, py, 16);
                    z.push((img.mean[k][0] as f64 - e) / (img.var[k][0] as f64).sqrt());
                }
            }
            z
        };
        let worst = |z: &[f64]| z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let right = z(1.0, 1.0);
        let chi2: f64 = right.iter().map(|z| z * z).sum();
        let wrong = z(1.5, 0.5);
        eprintln!(
            "two lights, weights {weights:?}: worst |z| {:.2}, sum z² {chi2:.1}, worst |z| of \
             the wrong weights {:.1}",
            worst(&right),
            worst(&wrong)
        );
        assert!(
            worst(&right) < 4.11,
            "{weights:?}: worst |z| {}",
            worst(&right)
        );
        assert!(chi2 < 336.0, "{weights:?}: sum z² = {chi2}");
        assert!(
            worst(&wrong) > 4.11,
            "{weights:?}: no power: {}",
            worst(&wrong)
        );
    }
}

/// The same with passes: mean and variance of the mean from 8 pass means, dof = 7.
#[test]
fn passes_estimate_the_variance() {
    let seg = tilted();
    let sc = floor_scene(8, seg);
    let cam = Camera::new(&sc.sensor).unwrap();
    let img = render(&sc, &opts(512, 8, 3, Technique::SolidAngle), &quiet).unwrap();
    assert_eq!(
        (img.meta.dof, img.meta.passes, img.meta.spp),
        (7.0, 8, 4096)
    );
    assert_finite(&img);
    // t with 7 dof, 64 pixels, two-sided α = 0.01 Bonferroni: t_crit(1 − 0.01/128; 7) ≈ 6.6.
    let z = z_scores(&img, &cam, &seg, 1.0);
    let worst = z.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    assert!(worst < 6.6, "worst |t| = {worst}");
}

#[test]
fn deterministic_across_thread_counts() {
    let sc = linlight_render::scene_builder::cornell_box(40, 30);
    let o = opts(4, 2, 5, Technique::ClippedSolidAngle);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render(&sc, &o, &quiet).unwrap())
    };
    let a = run(1);
    let b = run(2);
    assert!(a.mean.iter().any(|m| m[0] > 0.0));
    assert_eq!(a, b);
    // A different seed gives a different image.
    let c = render(&sc, &opts(4, 2, 6, Technique::ClippedSolidAngle), &quiet).unwrap();
    assert_ne!(a.mean, c.mean);
}

#[test]
fn crop_is_a_window_of_the_full_render() {
    let mut sc = linlight_render::scene_builder::cornell_box(40, 30);
    let o = opts(3, 1, 9, Technique::SolidAngle);
    let full = render(&sc, &o, &quiet).unwrap();
    let crop = CropWindow {
        offset_x: 7,
        offset_y: 11,
        width: 20,
        height: 13,
    };
    sc.sensor.film.crop = Some(crop);
    let part = render(&sc, &o, &quiet).unwrap();
    assert_eq!((part.width, part.height), (20, 13));
    for y in 0..13 {
        for x in 0..20 {
            let k = (y + 11) * 40 + x + 7;
            assert_eq!(part.mean[y * 20 + x], full.mean[k]);
            assert_eq!(part.var[y * 20 + x], full.var[k]);
        }
    }
    sc.sensor.film.crop = Some(CropWindow {
        offset_x: 30,
        offset_y: 0,
        width: 20,
        height: 13,
    });
    assert!(render(&sc, &o, &quiet).is_err());
    sc.sensor.film.crop = None;
    sc.sensor.film.width = 0;
    assert!(render(&sc, &o, &quiet).is_err());
}

/// Segment p → q crosses the box (slab test, independent of the BVH).
fn segment_hits_box(p: Vec3, q: Vec3, min: Vec3, max: Vec3) -> bool {
    let d = q - p;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for i in 0..3 {
        if d[i].abs() < 1e-12 {
            if p[i] < min[i] || p[i] > max[i] {
                return false;
            }
            continue;
        }
        let (a, b) = ((min[i] - p[i]) / d[i], (max[i] - p[i]) / d[i]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    t0 <= t1
}

/// A box between floor and light: pixels whose whole footprint is in the umbra become exactly
/// black; pixels whose footprint sees the whole light (and not the box) are unchanged, bit for
/// bit (same random numbers, no occlusion).
#[test]
fn box_casts_the_right_shadow() {
    let seg = Segment::new(Vec3::new(1.2, -0.6, 1.0), Vec3::new(1.2, 0.6, 1.3));
    let (bmin, bmax) = (Vec3::new(0.3, -0.8, 0.25), Vec3::new(0.6, 0.8, 0.45));
    let size = 24;
    let open = floor_scene(size, seg);
    let mut shadowed = open.clone();
    shadowed.shapes.push(diffuse(cuboid(bmin, bmax), [0.5; 3]));
    let o = opts(16, 1, 1, Technique::ClippedSolidAngle);
    let a = render(&open, &o, &quiet).unwrap();
    let b = render(&shadowed, &o, &quiet).unwrap();
    assert_finite(&b);
    let cam = Camera::new(&open.sensor).unwrap();
    let eye = cam.ray(0.0, 0.0).o;
    let (mut umbra, mut lit) = (0, 0);
    for py in 0..size {
        for px in 0..size {
            let mut all_blocked = true;
            let mut none_blocked = true;
            let mut camera_clear = true;
            for i in 0..=4 {
                for j in 0..=4 {
                    let x =
                        floor_point(&cam, px as f32 + i as f32 / 4.0, py as f32 + j as f32 / 4.0);
                    camera_clear &= !segment_hits_box(eye, x, bmin, bmax);
                    for k in 0..=64 {
                        let q = seg.begin + (seg.end - seg.begin) * (k as f32 / 64.0);
                        let blocked = segment_hits_box(x, q, bmin, bmax);
                        all_blocked &= blocked;
                        none_blocked &= !blocked;
                    }
                }
            }
            if !camera_clear {
                continue;
            }
            let k = (py * size + px) as usize;
            if all_blocked {
                umbra += 1;
                assert!(a.mean[k][0] > 0.0);
                assert_eq!(
                    b.mean[k], [0.0; 3],
                    "pixel {px},{py} should be in the umbra"
                );
            } else if none_blocked {
                lit += 1;
                assert_eq!(b.mean[k], a.mean[k], "pixel {px},{py} should be unshadowed");
            }
        }
    }
    eprintln!("shadow: {umbra} umbra pixels, {lit} fully lit pixels");
    assert!(
        umbra >= 20 && lit >= 100,
        "test scene too weak: umbra {umbra}, lit {lit}"
    );
}

/// Lights touching, crossing and lying in the floor, zero-length lights, lights through the
/// camera: finite, non-negative output with every implemented technique.
#[test]
fn degenerate_lights_give_finite_images() {
    let v = Vec3::new;
    let segments = [
        Segment::new(v(0.0, 0.0, 0.0), v(0.3, 0.2, 1.0)), // touching
        Segment::new(v(-0.4, 0.1, -0.5), v(0.4, -0.1, 0.8)), // crossing
        Segment::new(v(-0.5, 0.2, 0.0), v(0.5, 0.2, 0.0)), // in the floor
        Segment::new(v(0.2, 0.2, 0.5), v(0.2, 0.2, 0.5)), // zero length
        Segment::new(v(0.3, -0.2, 3.0), v(0.3, -0.2, 5.0)), // through the camera
        Segment::new(v(-0.5, 0.0, -1.0), v(0.5, 0.0, -0.5)), // below the floor
    ];
    for seg in segments {
        let sc = floor_scene(12, seg);
        for t in [
            Technique::Baseline,
            Technique::SolidAngle,
            Technique::ClippedSolidAngle,
        ] {
            let img = render(&sc, &opts(8, 1, 2, t), &quiet).unwrap();
            assert_finite(&img);
        }
    }
}

/// Light contributions that overflow to infinity are dropped (counted as 0) and counted in the
/// header, so that the command line can warn as Mitsuba does; the image stays finite.
#[test]
fn non_finite_contributions_are_counted() {
    let mut sc = floor_scene(8, tilted());
    let img = render(&sc, &opts(4, 1, 2, Technique::Area), &quiet).unwrap();
    assert!(!img.meta.extra.contains_key("nonfinite_dropped"));
    // One sample per pixel: the variance of the finite (huge) samples is then not estimated.
    sc.lights[0].radiance_times_radius = [f32::MAX; 3];
    let img = render(&sc, &opts(1, 1, 2, Technique::Area), &quiet).unwrap();
    assert_finite(&img);
    let dropped: u64 = img.meta.extra["nonfinite_dropped"].parse().unwrap();
    assert!(dropped > 0 && dropped < 8 * 8, "{dropped}");
}

/// One-sided diffuse is black from behind; twosided reflects on both sides.
#[test]
fn one_and_two_sided_floor_from_below() {
    let seg = Segment::new(Vec3::new(-0.5, 0.0, -1.0), Vec3::new(0.5, 0.2, -1.2));
    let cam = sensor(Vec3::new(0.0, 0.0, -4.0), Vec3::ZERO, Vec3::Y, 40.0, 8, 8);
    let mut sc = scene(cam, vec![floor()], vec![light(seg.begin, seg.end, K)]);
    let o = opts(8, 1, 4, Technique::ClippedSolidAngle);
    let img = render(&sc, &o, &quiet).unwrap();
    assert!(img.mean.iter().all(|m| *m == [0.0; 3]));
    sc.shapes[0].bsdf = Bsdf::TwoSided(Box::new(sc.shapes[0].bsdf.clone()));
    let img = render(&sc, &o, &quiet).unwrap();
    assert!(img.mean.iter().all(|m| m[0] > 0.0));
    // flip_normals on the one-sided floor lights it from below as well.
    sc.shapes[0].bsdf = Bsdf::Diffuse { reflectance: RHO };
    sc.shapes[0].flip_normals = true;
    let img2 = render(&sc, &o, &quiet).unwrap();
    assert_eq!(img.mean, img2.mean);
}

#[test]
fn metadata() {
    let mut sc = floor_scene(4, tilted());
    sc.sha256 = "abc".into();
    let img = render(&sc, &opts(5, 1, 42, Technique::SolidAngle), &quiet).unwrap();
    assert_eq!(img.meta.dof, 4.0);
    assert_eq!(img.meta.spp, 5);
    assert_eq!(img.meta.passes, 1);
    assert_eq!(img.meta.scene_sha256, "abc");
    assert!(img.meta.renderer.starts_with("linlight "));
    assert_eq!(img.meta.extra["technique"], "solid-angle");
    assert_eq!(img.meta.extra["seed"], "42");
}

#[test]
fn progress_advances_per_pass_of_each_tile_in_samples() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let sc = floor_scene(40, tilted()); // 3 × 3 tiles of 16
    let total_samples = 40 * 40 * 3 * 4;
    let last = AtomicUsize::new(0);
    let calls = AtomicUsize::new(0);
    let progress = |done: usize, total: usize| {
        assert_eq!(total, total_samples);
        last.fetch_max(done, Ordering::Relaxed);
        calls.fetch_add(1, Ordering::Relaxed);
    };
    render(&sc, &opts(3, 4, 0, Technique::SolidAngle), &progress).unwrap();
    // One call with 0 before the first tile (the end of the scene's preparation), then one per
    // tile and pass.
    assert_eq!(
        (last.into_inner(), calls.into_inner()),
        (total_samples, 1 + 9 * 4)
    );
}

/// First hit of a camera ray with the unit sphere at the origin (f64, independent of the
/// renderer's intersection code).
fn unit_sphere_hit(cam: &Camera, x: f32, y: f32) -> Option<glam::DVec3> {
    let r = cam.ray(x, y);
    let (o, d) = (r.o.as_dvec3(), r.d.as_dvec3());
    let b = o.dot(d);
    let disc = b * b - (o.dot(o) - 1.0);
    (disc > 0.0).then(|| o + (-b - disc.sqrt()) * d)
}

/// A diffuse sphere lit by one light: on a convex surface self-shadowing is exactly horizon
/// clipping, so every pixel inside the silhouette must match ρ/π·K·Ω⊥_R(x, n) averaged over the
/// pixel. Bonferroni over the tested pixels, two-sided α = 0.01.
#[test]
fn sphere_matches_closed_form() {
    let v = Vec3::new;
    let seg = Segment::new(v(-1.5, 1.2, 0.8), v(1.5, 1.5, 1.6));
    let cam_sensor = sensor(v(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 30.0, 16, 16);
    let ball = linlight_render::scene::Geometry::Sphere {
        center: Vec3::ZERO,
        radius: 1.0,
    };
    let sc = scene(
        cam_sensor,
        vec![diffuse(ball, RHO)],
        vec![light(seg.begin, seg.end, K)],
    );
    let cam = Camera::new(&sc.sensor).unwrap();
    let img = render(
        &sc,
        &opts(4096, 1, 21, Technique::ClippedSolidAngle),
        &quiet,
    )
    .unwrap();
    assert_finite(&img);
    let radiance = |p: glam::DVec3| {
        let (x, n) = (p.as_vec3(), p.normalize().as_vec3());
        LineFrame::new(&seg, x)
            .and_then(|f| f.clip_to_horizon(n))
            .map_or(0.0, |f| f.projected_solid_angle(n) as f64)
            * (RHO[0] * K[0]) as f64
            / std::f64::consts::PI
    };
    let mut z = Vec::new();
    let mut lit = 0;
    for py in 0..16u32 {
        for px in 0..16u32 {
            let inside = (0..=4).all(|i| {
                (0..=4).all(|j| {
                    unit_sphere_hit(&cam, px as f32 + i as f32 / 4.0, py as f32 + j as f32 / 4.0)
                        .is_some()
                })
            });
            if !inside {
                continue;
            }
            let m = 16;
            let mut e = 0.0;
            for a in 0..m {
                for b in 0..m {
                    let (x, y) = (
                        px as f32 + (a as f32 + 0.5) / m as f32,
                        py as f32 + (b as f32 + 0.5) / m as f32,
                    );
                    e += radiance(unit_sphere_hit(&cam, x, y).unwrap());
                }
            }
            e /= (m * m) as f64;
            let k = (py * 16 + px) as usize;
            let se = (img.var[k][0] as f64).sqrt();
            if e == 0.0 {
                assert_eq!(img.mean[k][0], 0.0, "pixel {px},{py} should be black");
                continue;
            }
            lit += 1;
            z.push((img.mean[k][0] as f64 - e) / se);
        }
    }
    // Two-sided per-pixel p < 1e-4 (|z| > 3.89) for n ≤ 100 pixels: family-wise α ≤ 0.01.
    let worst = z.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    eprintln!("sphere: {lit} lit pixels inside the silhouette, worst |z| {worst:.2}");
    assert!(
        (60..=100).contains(&lit),
        "unexpected number of lit pixels: {lit}"
    );
    assert!(worst < 3.89, "worst |z| = {worst}");
}

/// Self-normalised correlation of neighbouring standardised errors: T = Σ zᵢzⱼ / √(Σ zᵢ²zⱼ²)
/// over the pairs (i, j) = (pixel, pixel + offset). With independent pixels and E zᵢ = 0 the
/// products are uncorrelated (also overlapping ones: E zᵢzⱼ²z_k = 0), so T ≈ N(0, 1).
fn neighbour_correlation(z: &[f64], width: usize, (dx, dy): (usize, usize)) -> f64 {
    let height = z.len() / width;
    let (mut sum, mut sum_sq) = (0.0, 0.0);
    for y in 0..height - dy {
        for x in 0..width - dx {
            let p = z[y * width + x] * z[(y + dy) * width + x + dx];
            sum += p;
            sum_sq += p * p;
        }
    }
    sum / sum_sq.sqrt()
}

/// Neighbouring pixels' errors are uncorrelated within their standard error (every pixel,
/// pass and sample has its own random stream). Unshadowed floor, 64×64 px, solid angle sampling
/// at 16 spp; error e = mean − pixel-averaged closed form (exact up to ~1e-4 of quadrature,
/// far below the noise), standardised by σ from an independent render (another seed, 256 spp)
/// so that E z = 0 exactly. Right, lower and second-right neighbours (where the replaced
/// same-seed PCG streams were correlated): three two-sided tests, Šidák at α = 0.01 →
/// |T| < Φ⁻¹(1 − 0.003345/2) = 2.934. Power: the same statistic on errors averaged with their
/// right neighbour (correlation ½) is far beyond the threshold.
#[test]
fn neighbouring_pixel_errors_are_uncorrelated() {
    const SIZE: u32 = 64;
    const THRESHOLD: f64 = 2.934;
    let seg = tilted();
    let sc = floor_scene(SIZE, seg);
    let cam = Camera::new(&sc.sensor).unwrap();
    let img = render(&sc, &opts(16, 1, 2024, Technique::SolidAngle), &quiet).unwrap();
    let scale = render(&sc, &opts(256, 1, 4048, Technique::SolidAngle), &quiet).unwrap();
    let n = (SIZE * SIZE) as usize;
    let mut z = Vec::with_capacity(n);
    for py in 0..SIZE {
        for px in 0..SIZE {
            let k = (py * SIZE + px) as usize;
            let sigma = (scale.var[k][0] as f64 * 256.0 / 16.0).sqrt();
            assert!(sigma > 0.0, "pixel {px},{py} has no variance");
            let e = img.mean[k][0] as f64 - expected_pixel(&cam, &seg, px, py, 16);
            z.push(e / sigma);
        }
    }
    let w = SIZE as usize;
    for offset in [(1, 0), (0, 1), (2, 0)] {
        let t = neighbour_correlation(&z, w, offset);
        eprintln!("neighbour {offset:?}: T = {t:.2}");
        assert!(t.abs() < THRESHOLD, "neighbours {offset:?}: T = {t}");
    }
    let correlated: Vec<f64> = (0..n)
        .map(|k| {
            let right = if (k + 1) % w == 0 { k } else { k + 1 };
            (z[k] + z[right]) / 2f64.sqrt()
        })
        .collect();
    let t = neighbour_correlation(&correlated, w, (1, 0));
    eprintln!("control with correlation ½: T = {t:.1}");
    assert!(t > 5.0 * THRESHOLD, "no power: T = {t}");
}
