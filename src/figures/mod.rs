//! `linlight figures`: every experiment of the paper, regenerated from procedural scenes
//! (`references/scenes/figures/` and the certified scenes of `references/scenes/`), written as
//! PNGs, SVG plots, the numbers behind them (CSV/JSON) and one self-contained `index.html`.
//!
//! Each figure is a function of a [`Ctx`] that returns a [`Section`]: its HTML (pictures inline),
//! a caption whose every number comes from this run, the files it wrote and its numbers. The
//! page links the files; `numbers.json` gathers every figure's numbers.
//!
//! References for RMSE: the committed Mitsuba reference of a certified scene when the figure
//! renders that scene exactly as the reference was rendered (`--quick` renders the certified
//! scenes at the references' 64×64), otherwise a high-spp Rust render with projected-solid-angle
//! sampling (the technique certified against Mitsuba by `linlight certify`); each caption says
//! which.

pub mod imaging;
pub mod page;
pub mod plot;
pub mod shading_cost;

mod backward_error;
mod convergence;
mod cornell;
mod newton;
mod noise;
mod one_spp;
mod specular;
mod timings;
mod tube_radius;
mod tube_sampling;

use crate::certify::scenes::load_referenced;
use linlight_imagefile::Image;
use linlight_render::scene::Scene;
use linlight_render::xml::load_scene;
use linlight_render::{render, LightSelection, Method, RenderOptions};
use linlight_sampling::noise::Noise;
use linlight_sampling::Technique;
use linlight_verify::heatmap::Rgb8;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

/// What the user asked for.
#[derive(Clone, Debug)]
pub struct Options {
    /// Project root (scenes and references are read from here).
    pub root: PathBuf,
    pub out: PathBuf,
    /// Figure names to make (empty: all).
    pub only: Vec<String>,
    /// Small resolutions and sample counts (the test suite's run).
    pub quick: bool,
    /// Seed of every render (references use derived seeds).
    pub seed: u64,
}

/// Sizes of a run.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Settings {
    /// Side of the figure renders (square films).
    pub res: u32,
    /// Samples per pixel of a Rust reference.
    pub reference_spp: u32,
    /// Largest spp of the convergence curves.
    pub max_spp: u32,
    /// Seconds per technique of the equal-time comparison.
    pub equal_time_s: f64,
    /// Pixel stride and repeats of the timing table.
    pub timing_stride: usize,
    pub timing_repeats: usize,
}

impl Settings {
    pub fn of(quick: bool) -> Self {
        if quick {
            Self {
                res: 64,
                reference_spp: 1024,
                max_spp: 64,
                equal_time_s: 0.25,
                timing_stride: 48,
                timing_repeats: 1,
            }
        } else {
            Self {
                res: 320,
                reference_spp: 2048,
                max_spp: 1024,
                equal_time_s: 4.0,
                timing_stride: 8,
                timing_repeats: 5,
            }
        }
    }
}

/// One figure of the page.
#[derive(Clone, Debug, Default)]
pub struct Section {
    pub name: String,
    pub title: String,
    /// What the figure demonstrates, its settings and its measured numbers (HTML).
    pub caption: String,
    /// Pictures, plots and tables (HTML, pictures inline).
    pub body: String,
    /// Files written for this figure, relative to the output directory.
    pub files: Vec<String>,
    pub numbers: serde_json::Value,
    pub seconds: f64,
}

/// A figure: name (for `--only`), title, and the function that makes it.
pub struct Figure {
    pub name: &'static str,
    pub title: &'static str,
    pub make: fn(&Ctx) -> Result<Section, String>,
}

/// Every figure, in page order.
pub const FIGURES: [Figure; 10] = [
    Figure {
        name: "one-spp",
        title: "One sample per pixel: area vs solid angle vs projected solid angle",
        make: one_spp::make,
    },
    Figure {
        name: "cornell",
        title: "Cornell box: every technique at 1 spp and at equal time",
        make: cornell::make,
    },
    Figure {
        name: "specular",
        title: "Diffuse + specular: PSA only, LTC only, MIS of both; roughness 0.3 vs 1.0",
        make: specular::make,
    },
    Figure {
        name: "backward-error",
        title: "Backward error of projected-solid-angle sampling",
        make: backward_error::make,
    },
    Figure {
        name: "noise",
        title: "White vs blue vs jittered blue noise",
        make: noise::make,
    },
    Figure {
        name: "newton",
        title: "Newton is bad for sampling: Li et al. 2018 vs ours",
        make: newton::make,
    },
    Figure {
        name: "convergence",
        title: "Convergence: RMSE vs samples and vs time",
        make: convergence::make,
    },
    Figure {
        name: "timings",
        title: "Timings: shading cost of every technique",
        make: timings::make,
    },
    Figure {
        name: "tube-radius",
        title: "Finite tubes: the exact tube approaches its line as R → 0",
        make: tube_radius::make,
    },
    Figure {
        name: "tube-sampling",
        title:
            "Finite tubes: what users pick instead (variance, time to equal error, shading cost)",
        make: tube_sampling::make,
    },
];

/// Progress of a run.
pub enum Event<'a> {
    /// Figure `index` of `count` starts.
    Start {
        name: &'a str,
        title: &'a str,
        index: usize,
        count: usize,
    },
    /// Fraction of the current figure done.
    Progress(f64),
    Done {
        name: &'a str,
        seconds: f64,
    },
}

/// What a figure works with.
pub struct Ctx<'a> {
    pub opts: &'a Options,
    pub settings: Settings,
    progress: &'a (dyn Fn(f64) + Sync),
    references: Mutex<HashMap<String, (Image, String)>>,
}

/// A render with its wall time.
pub struct Timed {
    pub image: Image,
    pub seconds: f64,
}

impl Timed {
    /// Seconds per camera sample (all lights of a sample together).
    pub fn seconds_per_sample(&self) -> f64 {
        self.seconds / (self.image.width * self.image.height) as f64 / self.image.meta.spp as f64
    }
}

impl Ctx<'_> {
    pub fn progress(&self, fraction: f64) {
        (self.progress)(fraction.clamp(0.0, 1.0));
    }

    /// A scene file of the project with `-D` overrides.
    pub fn scene(&self, rel: &str, overrides: &[(&str, String)]) -> Result<Scene, String> {
        let path = self.opts.root.join(rel);
        let ov: Vec<(String, String)> = overrides
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect();
        load_scene(&path, &ov).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Render `scene` with one sample of `technique` per light and camera sample (timed, on
    /// the current thread pool).
    pub fn render(
        &self,
        scene: &Scene,
        technique: Technique,
        noise: Noise,
        spp: u32,
        passes: u32,
        seed: u64,
    ) -> Result<Timed, String> {
        self.render_method(scene, technique.into(), noise, spp, passes, seed)
    }

    /// Render `scene` with `method` (one iteration per light and camera sample: one sample of
    /// a single technique, or one diffuse and one specular sample for MIS).
    pub fn render_method(
        &self,
        scene: &Scene,
        method: Method,
        noise: Noise,
        spp: u32,
        passes: u32,
        seed: u64,
    ) -> Result<Timed, String> {
        let opts = RenderOptions {
            spp,
            passes,
            seed,
            method,
            light_samples: 1,
            // Every light per light sample (lamps and room have several lights).
            lights: LightSelection::Every,
            noise,
            // The paper's experiments are of linear lights.
            cylinders: linlight_render::Cylinders::Line,
        };
        let t = Instant::now();
        let image = render(scene, &opts, &|_, _| {}).map_err(|e| e.to_string())?;
        Ok(Timed {
            image,
            seconds: t.elapsed().as_secs_f64(),
        })
    }

    /// The reference of `rel` with `overrides` and its description for captions: the committed
    /// Mitsuba reference when `rel` is a certified scene rendered exactly as its reference
    /// (same overrides), else a Rust render of `reference_spp` (projected solid angle, 16
    /// passes), made once per run.
    pub fn reference(
        &self,
        rel: &str,
        overrides: &[(&str, String)],
    ) -> Result<(Image, String), String> {
        let key = format!("{rel} {overrides:?}");
        if let Some(r) = self.references.lock().unwrap().get(&key) {
            return Ok(r.clone());
        }
        let path = self.opts.root.join(rel);
        let committed = self.opts.root.join("references/mitsuba");
        if let Ok(r) = load_referenced(&path, &committed, true) {
            let same = r.overrides.len() == overrides.len()
                && overrides
                    .iter()
                    .all(|(k, v)| r.overrides.iter().any(|(rk, rv)| rk == k && rv == v));
            if same {
                let m = &r.reference.meta;
                let what = format!(
                    "the committed Mitsuba reference ({}, {} spp in {} passes)",
                    m.renderer, m.spp, m.passes
                );
                let out = (r.reference, what);
                self.references.lock().unwrap().insert(key, out.clone());
                return Ok(out);
            }
        }
        let scene = self.scene(rel, overrides)?;
        let spp = self.settings.reference_spp;
        let passes = 16;
        let t = self.render(
            &scene,
            Technique::ProjectedSolidAngle,
            Noise::White,
            spp.div_ceil(passes),
            passes,
            self.opts.seed ^ 0x5245_4645_5245_4e43, // "REFERENC"
        )?;
        let what = format!(
            "a Rust render at {} spp (projected solid angle, white noise, {passes} passes; no \
             Mitsuba reference at this size)",
            t.image.meta.spp
        );
        let out = (t.image, what);
        self.references.lock().unwrap().insert(key, out.clone());
        Ok(out)
    }

    /// Write a picture as `<name>.png` into the output directory; its relative path.
    pub fn write_png(&self, name: &str, p: &Rgb8) -> Result<String, String> {
        let rel = format!("{name}.png");
        p.write_png(&self.opts.out.join(&rel))
            .map_err(|e| format!("{rel}: {e}"))?;
        Ok(rel)
    }

    /// Write a text file (CSV, JSON, SVG) into the output directory; its relative path.
    pub fn write_text(&self, rel: &str, text: &str) -> Result<String, String> {
        crate::outputs::write_file(&self.opts.out.join(rel), text)?;
        Ok(rel.to_string())
    }

    /// Write an image in the shared EXR format; its relative path.
    pub fn write_exr(&self, name: &str, img: &Image) -> Result<String, String> {
        let rel = format!("{name}.exr");
        img.write(&self.opts.out.join(&rel))
            .map_err(|e| format!("{rel}: {e}"))?;
        Ok(rel)
    }
}

/// The figures selected by `only` (all when empty); unknown names are an error.
pub fn select(only: &[String]) -> Result<Vec<&'static Figure>, String> {
    if only.is_empty() {
        return Ok(FIGURES.iter().collect());
    }
    let names: Vec<&str> = FIGURES.iter().map(|f| f.name).collect();
    for o in only {
        if !names.contains(&o.as_str()) {
            return Err(format!(
                "unknown figure '{o}' (expected some of: {})",
                names.join(", ")
            ));
        }
    }
    Ok(FIGURES
        .iter()
        .filter(|f| only.iter().any(|o| o == f.name))
        .collect())
}

/// Make the selected figures, write `index.html` and `numbers.json` into `opts.out`.
pub fn run(opts: &Options, events: &(dyn Fn(Event) + Sync)) -> Result<Vec<Section>, String> {
    let figures = select(&opts.only)?;
    std::fs::create_dir_all(&opts.out)
        .map_err(|e| format!("cannot create {}: {e}", opts.out.display()))?;
    let settings = Settings::of(opts.quick);
    let progress = |f: f64| events(Event::Progress(f));
    let ctx = Ctx {
        opts,
        settings,
        progress: &progress,
        references: Mutex::new(HashMap::new()),
    };
    let started = Instant::now();
    let mut sections = Vec::new();
    for (index, f) in figures.iter().enumerate() {
        events(Event::Start {
            name: f.name,
            title: f.title,
            index,
            count: figures.len(),
        });
        let t = Instant::now();
        let mut s = (f.make)(&ctx).map_err(|e| format!("figure {}: {e}", f.name))?;
        s.name = f.name.to_string();
        s.title = f.title.to_string();
        s.seconds = t.elapsed().as_secs_f64();
        let json = serde_json::to_string_pretty(&s.numbers).map_err(|e| e.to_string())?;
        let rel = ctx.write_text(&format!("{}.json", f.name), &json)?;
        s.files.push(rel);
        events(Event::Done {
            name: f.name,
            seconds: s.seconds,
        });
        sections.push(s);
    }
    let all: serde_json::Map<String, serde_json::Value> = sections
        .iter()
        .map(|s| (s.name.clone(), s.numbers.clone()))
        .collect();
    let numbers = serde_json::json!({
        "settings": settings,
        "quick": opts.quick,
        "seed": opts.seed,
        "elapsed_seconds": started.elapsed().as_secs_f64(),
        "figures": all,
    });
    ctx.write_text(
        "numbers.json",
        &serde_json::to_string_pretty(&numbers).map_err(|e| e.to_string())?,
    )?;
    let html = page::html(
        &sections,
        &settings,
        opts.quick,
        started.elapsed().as_secs_f64(),
    );
    ctx.write_text("index.html", &html)?;
    Ok(sections)
}

/// Path of a figure scene relative to the project root.
pub fn figure_scene(name: &str) -> String {
    format!("references/scenes/figures/{name}.xml")
}

/// A relative file path as it appears in the page (for the test that every link exists).
pub fn exists(out: &Path, rel: &str) -> bool {
    out.join(rel).is_file()
}

/// A CSV document from a header and rows.
pub fn csv(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = header.join(",");
    s.push('\n');
    for r in rows {
        s.push_str(&r.join(","));
        s.push('\n');
    }
    s
}

/// The surface a pixel's centre sees: position, the normal of the side facing the camera, the
/// direction to the camera, and the Lambertian albedo (None for glossy BSDFs).
#[derive(Clone, Copy, Debug)]
pub struct HitPoint {
    pub x: u32,
    pub y: u32,
    pub p: glam::Vec3,
    pub n: glam::Vec3,
    pub wi: glam::Vec3,
    pub albedo: Option<glam::Vec3>,
}

/// Primary hits through the pixel centres of a scene's film (row-major; None: nothing hit, or
/// the back of a one-sided surface).
pub fn hit_points(scene: &Scene) -> Result<Vec<Option<HitPoint>>, String> {
    use linlight_render::render_scene::{reflecting_normal, RenderScene};
    let rs = RenderScene::new(scene).map_err(|e| e.to_string())?;
    let film = &scene.sensor.film;
    let mut out = Vec::with_capacity((film.width * film.height) as usize);
    for y in 0..film.height {
        for x in 0..film.width {
            let ray = rs.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            let hp = rs.bvh.intersect(&ray).and_then(|hit| {
                let prim = rs.bvh.primitive(hit.prim);
                let shape = prim.shape() as usize;
                let (bsdf, flip) = &rs.surfaces[shape];
                let sp = prim.surface_point(&ray, &hit, *flip);
                let n = reflecting_normal(bsdf, sp.ns, -ray.d)?;
                Some(HitPoint {
                    x,
                    y,
                    p: sp.p,
                    n,
                    wi: -ray.d,
                    albedo: bsdf.lambertian().map(|r| r.as_vec3()),
                })
            });
            out.push(hp);
        }
    }
    Ok(out)
}
