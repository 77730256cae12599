//! Rendering a scene into an image of per-pixel means and variances of the mean.
//!
//! Pixel samples are uniform over the pixel (box filter). With one pass, the variance of the
//! mean comes from the spp independent samples (dof = spp − 1); with P > 1 passes, from the P
//! pass means (dof = P − 1). The random stream of a pixel depends only on (seed, pass, full-film
//! pixel index), so an image is bit-identical for any thread count and a crop equals the same
//! window of the full render.

use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::contacts::{contact_pixels, light_contacts};
use crate::film::Welford;
use crate::hooks::{with_resolved, BsdfModel, Hooks, LightSampling, Resolved, SpecularSampling};
use crate::integrator::{radiance, RenderScene};
use crate::light_choice::{LightChoice, LightSelection};
use crate::method::Method;
use crate::scene::{Bsdf, Geometry, Scene};
use crate::shadow_culling::ShadowCulling;
use crate::shapes::{transformed_normal, Primitive};
use crate::visible_line::{PixelLine, VisibleLines};
use glam::Vec3;
use linlight_imagefile::{Image, Metadata};
use linlight_sampling::noise::{Noise, NoiseSource};
use linlight_sampling::philox::CounterRng;
use linlight_sampling::Segment;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Side of the square tiles distributed over threads.
pub(crate) const TILE: u32 = 16;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Samples per pixel in each pass.
    pub spp: u32,
    /// Independent passes (≥ 1).
    pub passes: u32,
    pub seed: u64,
    /// How each light is sampled (a single technique, LTC, or MIS with a heuristic).
    pub method: Method,
    /// Iterations per light and camera sample (≥ 1): samples of the single technique, or
    /// pairs of a diffuse and a specular sample; the light's estimate is their mean. The CLI's
    /// default is the scene's `emitter_samples` (see `linlight render --help`).
    pub light_samples: u32,
    /// Which lights each light sample samples: every light (the default) or one chosen at
    /// random (Mitsuba's estimator; [`crate::light_choice`]).
    pub lights: LightSelection,
    /// Where the primary samples come from (white by default; see [`linlight_sampling::noise`]).
    pub noise: Noise,
}

impl Default for RenderOptions {
    /// 1 spp, 1 pass, seed 0, the default method (MIS, clamped optimal, v = 0.5), 1 light
    /// sample of every light, white noise.
    fn default() -> Self {
        Self {
            spp: 1,
            passes: 1,
            seed: 0,
            method: Method::default(),
            light_samples: 1,
            lights: LightSelection::Every,
            noise: Noise::White,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum RenderError {
    /// The scene cannot be rendered as given (film size, crop, camera).
    Scene(String),
    /// The options cannot be used (spp, passes or light samples zero).
    Options(String),
}

impl std::fmt::Display for RenderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RenderError::Scene(m) | RenderError::Options(m) => f.write_str(m),
        }
    }
}
impl std::error::Error for RenderError {}

/// Pixel window actually rendered: the crop, or the whole film.
pub(crate) fn window(scene: &Scene) -> Result<(u32, u32, u32, u32), RenderError> {
    let film = &scene.sensor.film;
    if film.width == 0 || film.height == 0 {
        return Err(RenderError::Scene(format!(
            "film has zero size ({}x{})",
            film.width, film.height
        )));
    }
    if film.width as u64 * film.height as u64 > 1 << 32 {
        return Err(RenderError::Scene(format!(
            "film {}x{} has more than 2^32 pixels (the random streams are indexed by a 32-bit \
             pixel index)",
            film.width, film.height
        )));
    }
    match film.crop {
        None => Ok((0, 0, film.width, film.height)),
        Some(c) => {
            let fits = c.width > 0
                && c.height > 0
                && c.offset_x
                    .checked_add(c.width)
                    .is_some_and(|e| e <= film.width)
                && c.offset_y
                    .checked_add(c.height)
                    .is_some_and(|e| e <= film.height);
            if !fits {
                return Err(RenderError::Scene(format!(
                    "crop window {}x{}+{}+{} does not fit the {}x{} film",
                    c.width, c.height, c.offset_x, c.offset_y, film.width, film.height
                )));
            }
            Ok((c.offset_x, c.offset_y, c.width, c.height))
        }
    }
}

impl RenderScene {
    /// Acceleration structure, camera and lights of a scene.
    pub fn new(scene: &Scene) -> Result<Self, RenderError> {
        window(scene)?;
        let camera = Camera::new(&scene.sensor).ok_or_else(|| {
            RenderError::Scene(
                "unusable perspective sensor (field of view outside (0°, 180°) or singular \
                 to_world)"
                    .into(),
            )
        })?;
        let mut prims = Vec::new();
        for (i, shape) in scene.shapes.iter().enumerate() {
            let s = i as u32;
            match &shape.geometry {
                Geometry::Mesh {
                    positions,
                    normals,
                    indices,
                } => {
                    let normals = normals.as_ref().filter(|n| n.len() == positions.len());
                    for tri in indices {
                        let Some(v) = tri
                            .iter()
                            .map(|&k| positions.get(k as usize).copied())
                            .collect::<Option<Vec<_>>>()
                        else {
                            continue; // out-of-range index (the loader should have rejected it)
                        };
                        let n = normals.map(|n| tri.map(|k| n[k as usize]));
                        prims.push(Primitive::Triangle {
                            v: [v[0], v[1], v[2]],
                            n,
                            shape: s,
                        });
                    }
                }
                Geometry::Sphere { center, radius } => prims.push(Primitive::Sphere {
                    center: *center,
                    radius: radius.abs(),
                    shape: s,
                }),
                Geometry::Disk { to_world } => {
                    let det = to_world.determinant();
                    if det != 0.0 && det.is_finite() {
                        let to_local = to_world.inverse();
                        let normal = transformed_normal(&to_local);
                        prims.push(Primitive::Disk {
                            to_local,
                            normal,
                            shape: s,
                        });
                    }
                }
                Geometry::Cylinder { p0, p1, radius } => {
                    let axis = *p1 - *p0;
                    let length = axis.length();
                    if length > 0.0 && length.is_finite() && *radius != 0.0 {
                        prims.push(Primitive::Cylinder {
                            p0: *p0,
                            axis: axis / length,
                            length,
                            radius: radius.abs(),
                            shape: s,
                        });
                    }
                }
            }
        }
        // The integrator flips the shading frame toward the viewer only for a `twosided` at the
        // top (the loader allows it nowhere else); one nested in a blend would be shaded as
        // one-sided from below.
        debug_assert!(
            scene.shapes.iter().all(|s| !nested_two_sided(&s.bsdf)),
            "twosided is supported only as the outermost BSDF"
        );
        let visible = if scene.integrator.hide_emitters {
            VisibleLines::default()
        } else {
            let lights: Vec<(Vec3, Vec3, Vec3)> = scene
                .lights
                .iter()
                .map(|l| (l.begin, l.end, Vec3::from_array(l.radiance_times_radius)))
                .collect();
            VisibleLines::new(&camera, &lights)
        };
        Ok(Self {
            visible,
            dropped: Default::default(),
            camera,
            shadows: ShadowCulling::new(
                &prims,
                &scene
                    .lights
                    .iter()
                    .map(|l| (l.begin, l.end))
                    .collect::<Vec<_>>(),
            ),
            bvh: Bvh::build(prims),
            surfaces: scene
                .shapes
                .iter()
                .map(|s| (s.bsdf.clone(), s.flip_normals))
                .collect(),
            lambert: scene
                .shapes
                .iter()
                .map(|s| {
                    s.bsdf
                        .lambertian()
                        .map(|rho| rho.as_vec3() * std::f32::consts::FRAC_1_PI)
                })
                .collect(),
            lights: scene
                .lights
                .iter()
                .map(|l| {
                    (
                        Segment::new(l.begin, l.end),
                        Vec3::from_array(l.radiance_times_radius),
                    )
                })
                .collect(),
            choice: LightChoice::new(
                &scene
                    .lights
                    .iter()
                    .map(|l| l.sampling_weight)
                    .collect::<Vec<_>>(),
            ),
        })
    }
}

/// Whether a `twosided` occurs below the top of `bsdf`.
fn nested_two_sided(bsdf: &Bsdf) -> bool {
    fn any(b: &Bsdf) -> bool {
        match b {
            Bsdf::TwoSided(_) => true,
            Bsdf::Blend(blend) => blend.bsdfs.iter().any(any),
            _ => false,
        }
    }
    match bsdf {
        Bsdf::TwoSided(inner) => any(inner),
        b => any(b),
    }
}

/// White-noise stream of one camera sample: Philox of (seed; sample, full-film pixel index,
/// pass). Every pixel, pass and sample has its own counter-based stream (no state shared between
/// pixels, so neighbouring pixels' errors are independent); its numbers are the sample's
/// dimensions: film position (2), then the lights' numbers (`crate::shading`, and the choice of
/// a light per light sample of [`crate::light_choice`]), then those of the visible lines. The renderer draws them through [`NoiseSource::stream`], which returns
/// exactly these numbers for [`Noise::White`].
pub fn sample_rng(seed: u64, pass: u32, pixel_index: u32, sample: u32) -> CounterRng {
    CounterRng::camera_sample(seed, pass, pixel_index, sample)
}

/// Render `scene`. `progress(done, total)` is called (from worker threads) after each pass of
/// each tile, in camera samples: `total` = pixels × spp × passes.
/// Runs on the current rayon pool (use `ThreadPool::install` to choose the thread count).
///
/// Where it applies ([`crate::batched::applies`]: one light sample, white noise, and a batch
/// technique or a scene with Lambertian surfaces) the batched renderer renders, whose images
/// equal those of the scalar path [`render_with`]`(scene, opts, &Hooks::new(), …)` bit for
/// bit; the scalar path renders everything else.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    if crate::batched::applies(scene, opts) {
        return crate::batched::render(scene, opts, progress);
    }
    render_with(scene, opts, &Hooks::new(), progress)
}

/// Reject options no render can use.
pub(crate) fn check_options(opts: &RenderOptions) -> Result<(), RenderError> {
    if opts.spp == 0 || opts.passes == 0 || opts.light_samples == 0 {
        return Err(RenderError::Options(
            "spp, passes and light samples must be at least 1".into(),
        ));
    }
    Ok(())
}

/// [`render`] with replaced pieces ([`Hooks`]): the hook through which tests render with
/// deliberately wrong techniques, specular samplers or BSDF evaluations (power controls, see
/// [`crate::power_controls`]). `opts.method` still chooses the estimator; the header records
/// the hooks (`technique` of a replaced technique, `specular_hook`, `bsdf_hook`). Always the
/// scalar path (the batched renderer's images equal it bit for bit where it applies).
pub fn render_with<D: LightSampling, S: SpecularSampling, B: BsdfModel>(
    scene: &Scene,
    opts: &RenderOptions,
    hooks: &Hooks<D, S, B>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    check_options(opts)?;
    let mut image = with_resolved!(hooks, opts.method, |r| render_tiles(
        scene, opts, r, progress
    ))?;
    let mut entries = Vec::new();
    if let (Some(t), Method::Technique(_)) = (&hooks.technique, opts.method) {
        entries.push(("technique", t.name()));
    }
    entries.extend(hooks.header());
    image.meta = metadata(opts, scene, std::mem::take(&mut image.meta.extra), entries);
    Ok(image)
}

/// The header of a render: dof, spp, passes, renderer, scene hash; `extra` (the pixels'
/// entries: `nonfinite_dropped`, the lights) with the method's entries, then `entries` (the
/// hooks', which override), light samples, seed and spp per pass.
pub(crate) fn metadata(
    opts: &RenderOptions,
    scene: &Scene,
    extra: std::collections::BTreeMap<String, String>,
    entries: Vec<(&'static str, String)>,
) -> Metadata {
    let dof = if opts.passes > 1 {
        opts.passes - 1
    } else {
        opts.spp - 1
    };
    let mut meta = Metadata {
        dof: dof as f64,
        spp: opts.spp as u64 * opts.passes as u64,
        passes: opts.passes as u64,
        renderer: format!("linlight {}", env!("CARGO_PKG_VERSION")),
        scene_sha256: scene.sha256.clone(),
        extra,
    };
    for (key, value) in opts.method.header().into_iter().chain(entries) {
        meta.extra.insert(key.into(), value);
    }
    meta.extra
        .insert("light_samples".into(), opts.light_samples.to_string());
    meta.extra
        .insert("light_selection".into(), opts.lights.name().into());
    meta.extra.insert("seed".into(), opts.seed.to_string());
    meta.extra
        .insert("spp_per_pass".into(), opts.spp.to_string());
    if opts.noise != Noise::White {
        meta.extra.insert("noise".into(), opts.noise.name().into());
    }
    meta
}

/// The image of [`render_with`] with the pieces resolved; its header holds only the pixels'
/// entries ([`pixel_entries`]).
fn render_tiles<T: LightSampling, S: SpecularSampling, B: BsdfModel>(
    scene: &Scene,
    opts: &RenderOptions,
    pieces: Resolved<T, S, B>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    let (x0, y0, w, h) = window(scene)?;
    let rs = RenderScene::new(scene)?;
    let full_width = scene.sensor.film.width;
    let noise = NoiseSource::new(opts.noise, opts.seed, opts.spp);
    let mut image = render_in_tiles(
        &rs,
        opts,
        (x0, y0, w, h),
        progress,
        |pixels, seen, pass, single| {
            for (i, &(fx, fy)) in pixels.iter().enumerate() {
                // < 2^32: checked by `window`.
                let index = fy.wrapping_mul(full_width).wrapping_add(fx);
                single[i] =
                    render_pixel_pass(&rs, opts, &noise, pieces, fx, fy, index, pass, &seen[i]);
            }
        },
    );
    image.meta = Metadata {
        extra: pixel_entries(scene, &rs, (x0, y0, w, h)),
        ..Default::default()
    };
    Ok(image)
}

/// The tile loop of both renderers (the scalar path here and [`crate::batched`]): tiles of
/// TILE² pixels of `window` in parallel; per tile the lines each pixel sees, then per pass
/// `pass_samples(pixels, seen, pass, single)`, which sets each pixel's accumulator of that
/// pass's samples. The pass means and the last pass's samples give each pixel's value
/// ([`pixel_value`]), written into the image as soon as its tile is done, so the image is the
/// only full-size buffer. `progress` is called with 0 once before the first tile, then
/// advances per tile and pass. The header is left empty.
pub(crate) fn render_in_tiles(
    rs: &RenderScene,
    opts: &RenderOptions,
    (x0, y0, w, h): (u32, u32, u32, u32),
    progress: &(dyn Fn(usize, usize) + Sync),
    pass_samples: impl Fn(&[(u32, u32)], &[Vec<PixelLine>], u32, &mut [Welford]) + Sync,
) -> Image {
    let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let done = AtomicUsize::new(0);
    let total = w as usize * h as usize * opts.spp as usize * opts.passes as usize;
    // Marks the end of the scene's preparation for callers that time it apart.
    progress(0, total);
    let image = std::sync::Mutex::new({
        let mut image = Image::new(w as usize, h as usize);
        image.tail = Some(vec![[0.0f32; 3]; image.mean.len()]);
        image
    });
    tiles.par_iter().for_each(|&(tx, ty)| {
        let pixels: Vec<(u32, u32)> = (ty..(ty + TILE).min(h))
            .flat_map(|y| (tx..(tx + TILE).min(w)).map(move |x| (x0 + x, y0 + y)))
            .collect();
        let mut seen: Vec<Vec<PixelLine>> = vec![Vec::new(); pixels.len()];
        for (&(fx, fy), s) in pixels.iter().zip(&mut seen) {
            rs.visible.pixel(fx, fy, s);
        }
        let mut passes = vec![Welford::default(); pixels.len()];
        let mut single = vec![Welford::default(); pixels.len()];
        for pass in 0..opts.passes {
            single.fill(Welford::default());
            pass_samples(&pixels, &seen, pass, &mut single);
            for (p, s) in passes.iter_mut().zip(&single) {
                p.push(s.mean());
            }
            let step = pixels.len() * opts.spp as usize;
            progress(done.fetch_add(step, Ordering::Relaxed) + step, total);
        }
        let mut image = image.lock().unwrap_or_else(|e| e.into_inner());
        let image = &mut *image;
        let mut values = passes
            .iter()
            .zip(&single)
            .map(|(p, s)| pixel_value(opts, p, s));
        for y in ty..(ty + TILE).min(h) {
            for x in tx..(tx + TILE).min(w) {
                let p = values.next().unwrap_or_default();
                let k = y as usize * w as usize + x as usize;
                (image.mean[k], image.var[k]) = (p.mean, p.var);
                if let Some(tail) = &mut image.tail {
                    tail[k] = p.tail;
                }
            }
        }
    });
    image.into_inner().unwrap_or_else(|e| e.into_inner())
}

/// The header entries the pixels of a render determine: `nonfinite_dropped` (when non-zero)
/// and the lights' entries ([`record_lights`]).
pub(crate) fn pixel_entries(
    scene: &Scene,
    rs: &RenderScene,
    window: (u32, u32, u32, u32),
) -> std::collections::BTreeMap<String, String> {
    let mut meta = Metadata::default();
    let dropped = rs.dropped.get();
    if dropped > 0 {
        meta.extra
            .insert("nonfinite_dropped".into(), dropped.to_string());
    }
    record_lights(&mut meta, scene, &rs.camera, window);
    meta.extra
}

/// Distance (in pixels) from a contact's projection within which pixels are contact pixels.
pub const CONTACT_PIXEL_RADIUS: f64 = 2.0;

/// Header keys about the lights: `radius` (per light, as in the file) and, where a light
/// touches a surface, `contacts` (readable) and `contact_pixels` (`x,y;…`, window coordinates).
fn record_lights(
    meta: &mut Metadata,
    scene: &Scene,
    camera: &Camera,
    window: (u32, u32, u32, u32),
) {
    if !scene.lights.is_empty() {
        let radii: Vec<String> = scene.lights.iter().map(|l| l.radius.to_string()).collect();
        meta.extra
            .insert(linlight_imagefile::KEY_RADIUS.into(), radii.join(","));
    }
    let contacts = light_contacts(scene);
    if contacts.is_empty() {
        return;
    }
    let text: Vec<String> = contacts
        .iter()
        .map(|c| {
            format!(
                "light {} x shape at {} at ({:.4}, {:.4}, {:.4})",
                c.light, scene.shapes[c.shape].location, c.point.x, c.point.y, c.point.z
            )
        })
        .collect();
    meta.extra.insert("contacts".into(), text.join("; "));
    let pixels = contact_pixels(camera, &contacts, window, CONTACT_PIXEL_RADIUS);
    meta.extra.insert(
        linlight_imagefile::KEY_CONTACT_PIXELS.into(),
        linlight_imagefile::format_pixel_list(&pixels),
    );
}

/// Records what an image was rendered from: the scene file's name (`scene`) and the `-D`
/// overrides (`overrides`, `name=value,…` sorted by name), so that an image can be traced to
/// its inputs (the file's hash is `scene_sha256`).
pub fn record_inputs(
    meta: &mut Metadata,
    scene_file: &std::path::Path,
    overrides: &[(String, String)],
) {
    let name = scene_file.file_name().map_or_else(
        || scene_file.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    meta.extra
        .insert(linlight_imagefile::KEY_SCENE_NAME.into(), name);
    let mut sorted: Vec<&(String, String)> = overrides.iter().collect();
    sorted.sort();
    let text: Vec<String> = sorted.iter().map(|(k, v)| format!("{k}={v}")).collect();
    meta.extra
        .insert(linlight_imagefile::KEY_OVERRIDES.into(), text.join(","));
}

/// What a pixel contributes to the image: mean, variance of the mean, heavy-tail share.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PixelResult {
    pub mean: [f32; 3],
    pub var: [f32; 3],
    pub tail: [f32; 3],
}

/// The camera samples of one pixel (full-film coordinates) in one pass; `seen`: the lines the
/// camera sees in this pixel ([`VisibleLines::pixel`]).
#[allow(clippy::too_many_arguments)]
fn render_pixel_pass<T: LightSampling, S: SpecularSampling, B: BsdfModel>(
    rs: &RenderScene,
    opts: &RenderOptions,
    noise: &NoiseSource,
    pieces: Resolved<T, S, B>,
    fx: u32,
    fy: u32,
    index: u32,
    pass: u32,
    seen: &[PixelLine],
) -> Welford {
    let mut acc = Welford::default();
    for sample in 0..opts.spp {
        let mut rng = noise.stream(fx, fy, index, pass, sample);
        let (u, v) = rng.film_position();
        let ray = rs.camera.ray(fx as f32 + u, fy as f32 + v);
        let l = radiance(rs, opts, pieces, &ray, &mut rng);
        let l = if seen.is_empty() {
            l
        } else {
            let mut t = Vec3::from_array(l);
            rs.visible
                .add_estimate(seen, &rs.bvh, || rng.next_f64(), &mut t);
            t.to_array()
        };
        acc.push(l.map(|c| c as f64));
    }
    acc
}

/// Mean, variance of the mean and heavy-tail share of a pixel from its pass means (P > 1) or,
/// with one pass, from its samples.
pub(crate) fn pixel_value(opts: &RenderOptions, passes: &Welford, single: &Welford) -> PixelResult {
    let terms = if opts.passes > 1 { passes } else { single };
    // Every sample is finite (the integrator drops non-finite contributions), so are these.
    PixelResult {
        mean: terms.mean().map(|m| m as f32),
        var: terms.variance_of_mean().map(|v| v as f32),
        tail: terms.tail_share().map(|t| t as f32),
    }
}
