//! What users pick instead: the finite-tube techniques on the committed finite-R scenes
//! (`references/finite-tubes/`), rendered as the tubes they are, against Mitsuba's cylinder
//! (uniform by area on the whole side, with one BSDF sample; its committed reference).
//!
//! Measures, per scene and method, over the pixels whose footprint does not see the tube (the
//! light reflected by the floor; pixels on or at the edge of a visible tube vary with the film
//! position alike for every technique, [`floor_pixels`]):
//! - the relative variance of one camera sample: the mean over those pixels of the per-pixel
//!   variance of one camera sample's estimate (RGB averaged), divided by the square of the
//!   Mitsuba reference's mean over them (the same denominator for every row of a scene); for
//!   our renders the mean over passes of (variance of the pixel mean × spp), for Mitsuba's
//!   reference the same from its 32 passes;
//! - the time per camera sample (wall time / pixels / spp; ours: the sum over the passes, the
//!   methods interleaved pass by pass so that machine load affects them alike; Mitsuba: the
//!   reference's recorded wall time of the whole render, JIT compilation included);
//! - time to equal error ∝ variance × time per sample, relative to Mitsuba's;
//! - the mean over those pixels against the reference's: relative difference and its standard
//!   error (both sides' variance channels, RGB averaged, pixels independent).
//!
//! The shading benchmark times view + preparation + one sample + its pdf per shading point (the
//! floor points seen through the pixel centres), ours against Gamito's, interleaved passes,
//! the least-disturbed pass (minimum) of each.

use super::page::{num, table};
use super::{csv, hit_points, Ctx, Section};
use glam::DVec3;
use linlight_imagefile::Image;
use linlight_render::xml::load_scene;
use linlight_render::{render, Cylinders, LightSelection, Method, RenderOptions, TubeSampling};
use linlight_sampling::cylinder::{Cylinder, CylinderSampler, CylinderTechnique, CylinderView};
use linlight_sampling::noise::Noise;
use linlight_sampling::rng::Pcg32;
use linlight_sampling::Technique;
use serde_json::json;
use std::path::Path;
use std::time::Instant;

/// The committed finite-R scenes (label, file stem).
pub const SCENES: [(&str, &str); 3] = [
    ("diffuse", "finite-tube-diffuse"),
    ("glossy", "finite-tube-glossy"),
    ("contact", "finite-tube-contact"),
];

/// The methods of a row: the emitter technique and whether a BSDF-side sample joins it.
pub const METHODS: [(CylinderTechnique, bool); 10] = [
    (CylinderTechnique::Area, false),
    (CylinderTechnique::Area, true),
    (CylinderTechnique::SolidAngle, false),
    (CylinderTechnique::SolidAngle, true),
    (CylinderTechnique::Gamito, false),
    (CylinderTechnique::Gamito, true),
    (CylinderTechnique::Projected, false),
    (CylinderTechnique::Projected, true),
    (CylinderTechnique::Ltc, false),
    (CylinderTechnique::Ltc, true),
];

/// Film side: the references' size.
pub const RES: u32 = 64;

/// Passes and samples per pixel of each pass.
pub fn sizes(quick: bool) -> (u32, u32) {
    if quick {
        (2, 8)
    } else {
        (4, 64)
    }
}

/// Passes of the shading benchmark (`--quick`, default).
fn bench_passes(quick: bool) -> usize {
    if quick {
        15
    } else {
        51
    }
}

pub fn method_label(technique: CylinderTechnique, mis: bool) -> String {
    let t = match technique {
        CylinderTechnique::Area => "area (front)",
        CylinderTechnique::SolidAngle => "solid angle (uniform)",
        CylinderTechnique::Gamito => "Gamito",
        CylinderTechnique::Projected => "ours (projected)",
        CylinderTechnique::Ltc => "ours (LTC)",
    };
    if mis {
        format!("{t} + BSDF, balance")
    } else {
        t.to_string()
    }
}

/// One row of the table.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Row {
    pub scene: String,
    pub method: String,
    /// `linlight render` options of the row (empty for Mitsuba).
    pub options: String,
    pub relative_variance: f64,
    pub ns_per_sample: f64,
    /// Relative variance and time to equal error over Mitsuba's.
    pub variance_vs_mitsuba: f64,
    pub time_vs_mitsuba: f64,
    /// (mean − reference mean) / reference mean over the floor pixels, and its standard error.
    pub difference_vs_reference: f64,
    pub difference_error: f64,
}

/// Mean over the masked pixels of the RGB average, and the variance of that mean (pixels
/// independent; the channels of a grey light are fully correlated, so the RGB average's
/// variance is (mean of the channels' standard deviations)²).
fn masked_mean(img: &Image, mask: &[bool]) -> (f64, f64) {
    let (mut m, mut v, mut n) = (0.0, 0.0, 0usize);
    for ((p, var), &keep) in img.mean.iter().zip(&img.var).zip(mask) {
        if keep {
            m += p.iter().map(|&c| c as f64).sum::<f64>() / 3.0;
            v += (var.iter().map(|&c| (c as f64).max(0.0).sqrt()).sum::<f64>() / 3.0).powi(2);
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    (m / n, v / (n * n))
}

/// Mean over the masked pixels of the variance of one camera sample (RGB averaged).
fn per_sample_variance(img: &Image, mask: &[bool]) -> f64 {
    let (mut v, mut n) = (0.0, 0usize);
    for (var, &keep) in img.var.iter().zip(mask) {
        if keep {
            v += var.iter().map(|&c| c as f64).sum::<f64>() / 3.0;
            n += 1;
        }
    }
    v / n.max(1) as f64 * img.meta.spp as f64
}

/// Closest distance between the ray o + t d (t ≥ 0, d unit) and the segment [p0, p1].
fn ray_segment_distance(o: DVec3, d: DVec3, p0: DVec3, p1: DVec3) -> f64 {
    let u = p1 - p0;
    let w = o - p0;
    let (a, b, c) = (u.dot(u), u.dot(d), d.dot(d));
    let (dd, e) = (u.dot(w), d.dot(w));
    let den = a * c - b * b;
    // Parameters along the segment (s) and the ray (t) of the closest points, clamped.
    let mut sp = if den > 1e-300 {
        (dd * c - b * e) / den
    } else {
        0.0
    };
    sp = sp.clamp(0.0, 1.0);
    let mut t = (sp * b - e) / c;
    if t < 0.0 {
        t = 0.0;
        sp = (dd / a).clamp(0.0, 1.0);
    }
    ((o + t * d) - (p0 + sp * u)).length()
}

/// Pixels whose footprint sees no tube: none of a 4 × 4 grid of film positions in the pixel
/// (its edges included) passes within 1.01 R of a tube's axis segment.
pub fn floor_pixels(scene: &linlight_render::scene::Scene) -> Result<Vec<bool>, String> {
    let camera = linlight_render::camera::Camera::new(&scene.sensor)
        .ok_or("the scene has no usable camera")?;
    let film = &scene.sensor.film;
    let tubes: Vec<(DVec3, DVec3, f64)> = scene
        .lights
        .iter()
        .map(|l| (l.begin.as_dvec3(), l.end.as_dvec3(), l.radius as f64 * 1.01))
        .collect();
    let mut mask = Vec::with_capacity((film.width * film.height) as usize);
    for y in 0..film.height {
        for x in 0..film.width {
            let mut sees = false;
            for j in 0..4 {
                for i in 0..4 {
                    let ray = camera.ray(x as f32 + i as f32 / 3.0, y as f32 + j as f32 / 3.0);
                    let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3().normalize());
                    sees |= tubes
                        .iter()
                        .any(|&(p0, p1, r)| ray_segment_distance(o, d, p0, p1) <= r);
                }
            }
            mask.push(!sees);
        }
    }
    Ok(mask)
}

struct Mitsuba {
    seconds_per_sample: f64,
    per_sample_variance: f64,
    mean: f64,
    mean_var: f64,
    renderer: String,
}

fn mitsuba(root: &Path, stem: &str, mask: &[bool]) -> Result<Mitsuba, String> {
    let exr = root.join(format!("references/mitsuba/{stem}.exr"));
    let image = Image::read(&exr).map_err(|e| format!("{}: {e}", exr.display()))?;
    let meta = root.join(format!("references/mitsuba/{stem}.json"));
    let text = std::fs::read_to_string(&meta).map_err(|e| format!("{}: {e}", meta.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", meta.display()))?;
    let wall: f64 = v["metadata"]["wall_time_s"]
        .as_str()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("{}: no metadata.wall_time_s", meta.display()))?;
    if (image.width, image.height) != (RES as usize, RES as usize) {
        return Err(format!("{}: not {RES}×{RES}", exr.display()));
    }
    let samples = (image.width * image.height) as f64 * image.meta.spp as f64;
    let (mean, mean_var) = masked_mean(&image, mask);
    Ok(Mitsuba {
        seconds_per_sample: wall / samples,
        per_sample_variance: per_sample_variance(&image, mask),
        mean,
        mean_var,
        renderer: image.meta.renderer.clone(),
    })
}

/// The renders of one scene: a row per method, Mitsuba's first.
fn scene_rows(
    root: &Path,
    label: &str,
    stem: &str,
    (passes, spp): (u32, u32),
    seed: u64,
    progress: &dyn Fn(f64),
) -> Result<Vec<Row>, String> {
    let path = root.join(format!("references/finite-tubes/{stem}.xml"));
    let scene = load_scene(&path, &[("res".to_string(), RES.to_string())])
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let mask = floor_pixels(&scene)?;
    let mi = mitsuba(root, stem, &mask)?;
    let m2 = mi.mean * mi.mean;
    let mi_cost = mi.per_sample_variance * mi.seconds_per_sample;
    let mut rows = vec![Row {
        scene: label.into(),
        method: format!(
            "Mitsuba (area, whole side, + 1 BSDF sample; {})",
            mi.renderer
        ),
        options: String::new(),
        relative_variance: mi.per_sample_variance / m2,
        ns_per_sample: mi.seconds_per_sample * 1e9,
        variance_vs_mitsuba: 1.0,
        time_vs_mitsuba: 1.0,
        difference_vs_reference: 0.0,
        difference_error: mi.mean_var.sqrt() / mi.mean,
    }];
    let n = METHODS.len();
    let (mut var_sum, mut secs, mut means, mut mean_vars) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for p in 0..passes {
        for (k, &(technique, mis)) in METHODS.iter().enumerate() {
            let opts = RenderOptions {
                spp,
                passes: 1,
                seed: seed.wrapping_add(p as u64),
                method: Method::from(Technique::ProjectedSolidAngle),
                light_samples: scene.integrator.emitter_samples.max(1),
                lights: LightSelection::Every,
                noise: Noise::White,
                cylinders: Cylinders::Exact(TubeSampling { technique, mis }),
            };
            let t = Instant::now();
            let img = render(&scene, &opts, &|_, _| {}).map_err(|e| e.to_string())?;
            secs[k] += t.elapsed().as_secs_f64();
            var_sum[k] += per_sample_variance(&img, &mask);
            let (m, v) = masked_mean(&img, &mask);
            means[k] += m;
            mean_vars[k] += v;
            progress(((p as usize * n + k + 1) as f64) / (passes as usize * n) as f64);
        }
    }
    let pf = passes as f64;
    let samples = (RES * RES) as f64 * (spp * passes) as f64;
    for (k, &(technique, mis)) in METHODS.iter().enumerate() {
        let v = var_sum[k] / pf;
        let sps = secs[k] / samples;
        let (m, mv) = (means[k] / pf, mean_vars[k] / (pf * pf));
        rows.push(Row {
            scene: label.into(),
            method: method_label(technique, mis),
            options: format!(
                "--cylinder-technique {} --cylinder-mis {} --light-samples {}",
                technique.name().trim_start_matches("cylinder-"),
                if mis { "balance" } else { "off" },
                scene.integrator.emitter_samples.max(1)
            ),
            relative_variance: v / m2,
            ns_per_sample: sps * 1e9,
            variance_vs_mitsuba: v / mi.per_sample_variance,
            time_vs_mitsuba: v * sps / mi_cost,
            difference_vs_reference: (m - mi.mean) / mi.mean,
            difference_error: (mv + mi.mean_var).sqrt() / mi.mean,
        });
    }
    Ok(rows)
}

/// Shading benchmark of one scene: ns per shading point (view + prepare + sample + pdf) of
/// each technique, the minimum over interleaved passes.
fn shading_ns(
    root: &Path,
    stem: &str,
    passes: usize,
) -> Result<Vec<(CylinderTechnique, f64)>, String> {
    let path = root.join(format!("references/finite-tubes/{stem}.xml"));
    let scene = load_scene(&path, &[("res".to_string(), RES.to_string())])
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let light = scene.lights.first().ok_or("no light")?;
    let cylinder = Cylinder::from_f32(light.begin, light.end, light.radius)
        .ok_or("the light is not a valid cylinder")?;
    let points: Vec<(DVec3, DVec3)> = hit_points(&scene)?
        .into_iter()
        .flatten()
        .map(|h| (h.p.as_dvec3(), h.n.as_dvec3()))
        .filter(|(x, n)| CylinderView::new(&cylinder, *x, *n).is_some())
        .collect();
    let mut rng = Pcg32::new(0x7475_6265, 1);
    let xi: Vec<[f32; 2]> = points
        .iter()
        .map(|_| [rng.next_f32(), rng.next_f32()])
        .collect();
    // Without `ltc`: it needs the surface's lobe, which this benchmark does not look up.
    let techniques: Vec<CylinderTechnique> = CylinderTechnique::ALL
        .into_iter()
        .filter(|t| *t != CylinderTechnique::Ltc)
        .collect();
    let mut best = vec![f64::INFINITY; techniques.len()];
    for _ in 0..passes {
        for (k, technique) in techniques.iter().enumerate() {
            let t = Instant::now();
            let mut acc = 0.0;
            for ((x, n), u) in points.iter().zip(&xi) {
                let Some(view) = CylinderView::new(&cylinder, *x, *n) else {
                    continue;
                };
                let Some(s) = technique.prepare(&view) else {
                    continue;
                };
                if let Some((dir, _)) = s.sample_with_pdf(*u) {
                    acc += s.pdf(dir);
                }
            }
            std::hint::black_box(acc);
            best[k] = best[k].min(t.elapsed().as_secs_f64() * 1e9 / points.len() as f64);
        }
    }
    Ok(techniques.into_iter().zip(best).collect())
}

/// The mean's relative difference from Mitsuba's ± its standard error, in per cent (Mitsuba's
/// row: ± its own standard error).
fn difference(r: &Row) -> String {
    if r.options.is_empty() {
        format!("± {:.2} %", 100.0 * r.difference_error)
    } else {
        format!(
            "{:+.2} ± {:.2} %",
            100.0 * r.difference_vs_reference,
            100.0 * r.difference_error
        )
    }
}

/// The table as Markdown (what `scripts/tube-table` prints and docs/cylinders.md quotes).
pub fn markdown(rows: &[Row], shading: &[(String, Vec<(CylinderTechnique, f64)>)]) -> String {
    let mut s = String::from(
        "| scene | method | rel. variance of one camera sample | ns / camera sample | variance vs Mitsuba | time to equal error vs Mitsuba | mean vs Mitsuba |\n|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            r.scene,
            r.method,
            num(r.relative_variance),
            num(r.ns_per_sample),
            num(r.variance_vs_mitsuba),
            num(r.time_vs_mitsuba),
            difference(r),
        ));
    }
    s.push_str("\n| scene | area | solid angle | Gamito | ours | ours / Gamito |\n|---|---|---|---|---|---|\n");
    for (scene, ns) in shading {
        let get = |t: CylinderTechnique| ns_of(ns, t);
        s.push_str(&format!(
            "| {scene} | {} | {} | {} | {} | {} |\n",
            num(get(CylinderTechnique::Area)),
            num(get(CylinderTechnique::SolidAngle)),
            num(get(CylinderTechnique::Gamito)),
            num(get(CylinderTechnique::Projected)),
            num(get(CylinderTechnique::Projected) / get(CylinderTechnique::Gamito)),
        ));
    }
    s
}

/// ns per shading point of technique `t` in one scene's shading benchmark (NaN if absent).
fn ns_of(ns: &[(CylinderTechnique, f64)], t: CylinderTechnique) -> f64 {
    ns.iter().find(|x| x.0 == t).map_or(f64::NAN, |x| x.1)
}

/// The rows as CSV, one line per scene × method.
fn rows_csv(rows: &[Row]) -> String {
    csv(
        &[
            "scene",
            "method",
            "options",
            "relative_variance",
            "ns_per_sample",
            "variance_vs_mitsuba",
            "time_vs_mitsuba",
            "difference_vs_reference",
            "difference_error",
        ],
        &rows
            .iter()
            .map(|r| {
                vec![
                    r.scene.clone(),
                    format!("\"{}\"", r.method),
                    r.options.clone(),
                    format!("{:e}", r.relative_variance),
                    format!("{}", r.ns_per_sample),
                    format!("{:e}", r.variance_vs_mitsuba),
                    format!("{:e}", r.time_vs_mitsuba),
                    format!("{:e}", r.difference_vs_reference),
                    format!("{:e}", r.difference_error),
                ]
            })
            .collect::<Vec<_>>(),
    )
}

/// The section's two HTML tables: the rows, then the shading benchmark per scene.
fn html_tables(rows: &[Row], shading: &[(String, Vec<(CylinderTechnique, f64)>)]) -> String {
    let body = format!(
        "{}{}",
        table(
            &[
                "scene",
                "method",
                "rel. variance of one camera sample",
                "ns / camera sample",
                "variance vs Mitsuba",
                "time to equal error vs Mitsuba",
                "mean vs Mitsuba",
            ],
            &rows
                .iter()
                .map(|r| {
                    vec![
                        r.scene.clone(),
                        r.method.clone(),
                        num(r.relative_variance),
                        num(r.ns_per_sample),
                        num(r.variance_vs_mitsuba),
                        num(r.time_vs_mitsuba),
                        difference(r),
                    ]
                })
                .collect::<Vec<_>>(),
        ),
        table(
            &[
                "scene",
                "area ns",
                "solid angle ns",
                "Gamito ns",
                "ours ns",
                "ours / Gamito"
            ],
            &shading
                .iter()
                .map(|(scene, ns)| {
                    let mut r = vec![scene.clone()];
                    let get = |t: CylinderTechnique| ns_of(ns, t);
                    for t in [
                        CylinderTechnique::Area,
                        CylinderTechnique::SolidAngle,
                        CylinderTechnique::Gamito,
                        CylinderTechnique::Projected,
                    ] {
                        r.push(num(get(t)));
                    }
                    r.push(num(
                        get(CylinderTechnique::Projected) / get(CylinderTechnique::Gamito)
                    ));
                    r
                })
                .collect::<Vec<_>>(),
        )
    );
    body
}

/// "scene ratio" of ours to Gamito's shading cost, per scene.
fn ours_over_gamito(shading: &[(String, Vec<(CylinderTechnique, f64)>)]) -> Vec<String> {
    let ratio: Vec<String> = shading
        .iter()
        .map(|(scene, ns)| {
            let get = |t: CylinderTechnique| ns_of(ns, t);
            format!(
                "{scene} {}",
                num(get(CylinderTechnique::Projected) / get(CylinderTechnique::Gamito))
            )
        })
        .collect();
    ratio
}

/// Per scene, the method (with options) fastest to equal error, and its time vs Mitsuba's.
fn fastest(rows: &[Row]) -> Vec<String> {
    let best: Vec<String> = SCENES
        .iter()
        .map(|(label, _)| {
            let r = rows
                .iter()
                .filter(|r| r.scene == *label && !r.options.is_empty())
                .min_by(|a, b| a.time_vs_mitsuba.total_cmp(&b.time_vs_mitsuba));
            match r {
                Some(r) => format!(
                    "{label}: {} ({} of Mitsuba's time)",
                    r.method,
                    num(r.time_vs_mitsuba)
                ),
                None => format!("{label}: –"),
            }
        })
        .collect();
    best
}

pub fn make(ctx: &Ctx) -> Result<Section, String> {
    let root = &ctx.opts.root;
    let (passes, spp) = sizes(ctx.opts.quick);
    let started = Instant::now();
    let mut rows = Vec::new();
    let mut shading = Vec::new();
    for (i, (label, stem)) in SCENES.iter().enumerate() {
        let base = i as f64 / SCENES.len() as f64;
        let progress = |f: f64| ctx.progress(base + 0.9 * f / SCENES.len() as f64);
        rows.extend(scene_rows(
            root,
            label,
            stem,
            (passes, spp),
            ctx.opts.seed,
            &progress,
        )?);
        shading.push((
            label.to_string(),
            shading_ns(root, stem, bench_passes(ctx.opts.quick))?,
        ));
        ctx.progress((i + 1) as f64 / SCENES.len() as f64);
    }
    let seconds = started.elapsed().as_secs_f64();
    let md = markdown(&rows, &shading);
    let files = vec![
        ctx.write_text("tube-sampling.md", &md)?,
        ctx.write_text("tube-sampling.csv", &rows_csv(&rows))?,
    ];
    let body = html_tables(&rows, &shading);
    let ratio = ours_over_gamito(&shading);
    let best = fastest(&rows);
    let caption = format!(
        "What it shows: which technique to pick for a tube light of finite radius. The committed scenes \
         <code>references/finite-tubes/</code> (diffuse floor, R = 0.08; rough conductor, GGX α = 0.25, \
         R = 0.06; a tube resting on a diffuse floor, R = 0.12) rendered as the tubes they are \
         (<code>--cylinders exact</code>), {RES}×{RES} px, {passes} passes of {spp} spp per method (interleaved), \
         seed {}, the scene's emitter samples per camera sample (each with one BSDF-side sample under MIS), \
         shadow rays; against Mitsuba's cylinder (uniform by area on the whole side, the scene's emitter samples \
         and one BSDF sample, power heuristic), whose numbers come from its committed reference \
         (<code>references/mitsuba/finite-tube-*.exr</code>: variance channels and recorded wall time, which \
         includes its JIT compilation). Relative variance: mean over pixels of one camera sample's variance over \
         the squared reference mean. Time to equal error ∝ variance × time per camera sample. z: our image mean \
         against the reference's, in combined standard errors (every method is unbiased). Wall times on this \
         machine ({} s for the section); on a loaded machine compare rows of one run. Fastest to equal error: {}. \
         Shading benchmark (view + preparation + one sample + its pdf per floor point seen through a pixel centre, \
         minimum of {} interleaved passes): ours / Gamito = {}.",
        ctx.opts.seed,
        num(seconds),
        best.join("; "),
        bench_passes(ctx.opts.quick),
        ratio.join(", "),
    );
    let summary = format!(
        "<p>Finite tubes, fastest to equal error: {}. Shading cost ours / Gamito: {}.</p>",
        best.join("; "),
        ratio.join(", ")
    );
    Ok(Section {
        caption,
        body,
        files,
        numbers: json!({
            "res": RES,
            "passes": passes,
            "spp_per_pass": spp,
            "rows": rows,
            "shading_ns": shading.iter().map(|(s, ns)| json!({
                "scene": s,
                "ns": ns.iter().map(|(t, v)| json!({"technique": t.name(), "ns": v})).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "summary_html": summary,
        }),
        ..Default::default()
    })
}
