//! Variance at equal sample count and time to equal error of the finite-cylinder techniques on
//! the committed finite-R scenes (docs/cylinders.md, "On the finite-R scenes"), at the sampler
//! level: the unshadowed one-sample estimate L·f(v, ω)·(n·ω)⁺/p(ω) of the light reflected toward
//! the camera, at the floor points seen through a 32 × 32 grid of pixel centres (64 × 64 film),
//! no visibility. Mitsuba's emitter sampling (uniform by area on the whole side, 2πRℓ) is
//! derived from the area technique's moments: it draws the front with probability θ_max/π and
//! contributes 0 otherwise, so E[Y²] = (π/θ_max)·E_area[Y²].
//!
//! Per technique: the relative standard deviation of one sample, √(mean over points of the
//! per-point variance) / (mean over points of the estimate), from 1024 samples per point; the
//! time per sample (view + prepare + sample, a new preparation per sample as for a new shading
//! point; the minimum of 31 passes over the points), and the time to equal error relative to
//! area: variance × time.
//!
//! `ltc` gets the floor's LTC lobe from the renderer's table look-up (once per point, not
//! timed, as the renderer makes it once per shading point); on a Lambertian floor it is ours.
//!
//! Run: `cargo run --release --example cylinder_scenes` (about 20 s).

use glam::{DMat3, DVec3, Vec3};
use linlight_render::camera::Camera;
use linlight_render::hooks::SceneBsdf;
use linlight_render::shading::ShadingPoint;
use linlight_render::xml::load_scene;
use linlight_sampling::cylinder::{Cylinder, CylinderSampler, CylinderTechnique, CylinderView};
use linlight_sampling::rng::Pcg32;
use std::path::Path;
use std::time::Instant;

const SCENES: [&str; 3] = [
    "finite-tube-diffuse",
    "finite-tube-glossy",
    "finite-tube-contact",
];
const GRID: u32 = 32;
const SAMPLES: usize = 1024;
const TIMING_PASSES: usize = 31;

struct Point {
    x: DVec3,
    /// Unit direction toward the camera.
    v: DVec3,
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    println!(
        "{:<22} {:<22} {:>10} {:>10} {:>12} {:>14}",
        "scene", "technique", "rel sd", "ns/sample", "var ratio", "time ratio"
    );
    for name in SCENES {
        let path = root.join(format!("references/finite-tubes/{name}.xml"));
        let overrides = [("res".to_string(), "64".to_string())];
        let scene = load_scene(&path, &overrides).unwrap_or_else(|e| panic!("{name}: {e}"));
        let camera = Camera::new(&scene.sensor).expect("camera");
        let light = &scene.lights[0];
        let radiance = light.radiance_times_radius[0] as f64 / light.radius as f64;
        let cylinder = Cylinder::from_f32(light.begin, light.end, light.radius).expect("cylinder");
        let bsdf = &scene.shapes[0].bsdf;
        // Floor points z = 0 (normal +z) through the pixel centres of a GRID² subgrid.
        let mut points = Vec::new();
        for j in 0..GRID {
            for i in 0..GRID {
                let (px, py) = ((2 * i + 1) as f32, (2 * j + 1) as f32);
                let ray = camera.ray(px, py);
                if ray.d.z >= 0.0 {
                    continue;
                }
                let t = -ray.o.z / ray.d.z;
                let x: Vec3 = ray.o + t * ray.d;
                points.push(Point {
                    x: DVec3::new(x.x as f64, x.y as f64, 0.0),
                    v: -ray.d.as_dvec3().normalize(),
                });
            }
        }
        // f(v, ω)·(n·ω)⁺ in the floor's frame (z = n), channel-averaged.
        let integrand = |p: &Point, dir: DVec3| bsdf.eval(p.v, dir).element_sum() / 3.0;
        let techniques = CylinderTechnique::ALL;
        // The floor's glossy lobe per point (frame, LTC matrix; `None` on a Lambertian floor):
        // the renderer's look-up, made once per point outside the timings.
        let lobes: Vec<Option<(DMat3, DMat3)>> = points
            .iter()
            .map(|p| {
                let (x, v) = (p.x.as_vec3(), p.v.as_vec3());
                ShadingPoint::new(&SceneBsdf, bsdf, x, Vec3::Z, v)
                    .ltc_lobe(&SceneBsdf)
                    .map(|(f, a)| (f.as_dmat3(), a.as_dmat3()))
            })
            .collect();
        let mut rows = Vec::new();
        let mut moments = Vec::new();
        for (t, technique) in techniques.iter().enumerate() {
            let (mut var_sum, mut mean_sum, mut second_sum, mut count) = (0.0, 0.0, 0.0, 0usize);
            let mut per_point = Vec::new();
            for (k, p) in points.iter().enumerate() {
                let mut rng = Pcg32::new(7 + k as u64, t as u64);
                let (mut s1, mut s2) = (0.0, 0.0);
                let Some(view) = CylinderView::new(&cylinder, p.x, DVec3::Z) else {
                    continue;
                };
                let Some(prepared) = technique.prepare_with_lobe(&view, lobes[k]) else {
                    continue;
                };
                let draws = (0..SAMPLES)
                    .filter_map(|_| prepared.sample_with_pdf([rng.next_f32(), rng.next_f32()]));
                for (dir, pdf) in draws {
                    let y = radiance * integrand(p, dir) / pdf;
                    s1 += y;
                    s2 += y * y;
                }
                let n = SAMPLES as f64;
                let mean = s1 / n;
                var_sum += (s2 / n - mean * mean).max(0.0) * n / (n - 1.0);
                mean_sum += mean;
                second_sum += s2 / n;
                count += 1;
                per_point.push((mean, s2 / n));
            }
            let c = count as f64;
            moments.push(per_point);
            rows.push((
                technique.name().to_string(),
                var_sum / c,
                mean_sum / c,
                second_sum / c,
                0.0,
            ));
        }
        // Time per sample: view + prepare + one sample at every point, the minimum over
        // TIMING_PASSES passes interleaved across the techniques (the least disturbed pass on a
        // shared machine).
        let mut best = vec![f64::INFINITY; rows.len()];
        for pass in 0..TIMING_PASSES {
            for (t, technique) in techniques.iter().enumerate() {
                let mut rng = Pcg32::new(99 + pass as u64, t as u64);
                let mut acc = 0.0;
                let start = Instant::now();
                for (p, lobe) in points.iter().zip(&lobes) {
                    let xi = [rng.next_f32(), rng.next_f32()];
                    if let Some((dir, pdf)) = CylinderView::new(&cylinder, p.x, DVec3::Z)
                        .and_then(|view| technique.prepare_with_lobe(&view, *lobe))
                        .and_then(|s| s.sample_with_pdf(xi))
                    {
                        acc += dir.z / pdf;
                    }
                }
                std::hint::black_box(acc);
                best[t] = best[t].min(start.elapsed().as_secs_f64() * 1e9 / points.len() as f64);
            }
        }
        for (row, ns) in rows.iter_mut().zip(best) {
            row.4 = ns;
        }
        // Mitsuba: whole-side area sampling, from the area technique's per-point moments and
        // the pooled mean of all techniques as the truth.
        let mut mitsuba_var = 0.0;
        let mut used = 0usize;
        for (k, p) in points
            .iter()
            .filter(|p| CylinderView::new(&cylinder, p.x, DVec3::Z).is_some())
            .enumerate()
        {
            let view = CylinderView::new(&cylinder, p.x, DVec3::Z).expect("filtered");
            let truth: f64 = moments.iter().map(|m| m[k].0).sum::<f64>() / moments.len() as f64;
            let second = std::f64::consts::PI / view.theta_max * moments[0][k].1;
            mitsuba_var += second - truth * truth;
            used += 1;
        }
        let mitsuba_var = mitsuba_var / used as f64;
        let mean = rows.iter().map(|r| r.2).sum::<f64>() / rows.len() as f64;
        let (area_var, area_time) = (rows[0].1, rows[0].4);
        println!(
            "{:<22} {:<22} {:>10.3e} {:>10} {:>12.3e} {:>14}",
            name,
            "mitsuba (area, 2πRℓ)",
            mitsuba_var.sqrt() / mean,
            "-",
            mitsuba_var / area_var,
            "-"
        );
        for (technique, var, _, _, ns) in &rows {
            println!(
                "{:<22} {:<22} {:>10.3e} {:>10.1} {:>12.3e} {:>14.3e}",
                name,
                technique,
                var.sqrt() / mean,
                ns,
                var / area_var,
                var * ns / (area_var * area_time)
            );
        }
        let ns = |n: &str| {
            rows.iter()
                .find(|r| r.0 == n)
                .map(|r| r.4)
                .unwrap_or(f64::NAN)
        };
        println!(
            "{:<22} time per sample ours : Gamito = {:.3}",
            name,
            ns("cylinder-projected") / ns("cylinder-gamito")
        );
    }
}
