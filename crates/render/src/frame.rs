//! The frame and its tiles, shared by both renderers: tiles of `TILE`² (16²) pixels rendered in
//! parallel, the random stream of each camera sample, the per-pixel mean and variance of the
//! mean from passes or samples, and the image header.
//!
//! Pixel samples are uniform over the pixel (box filter). With one pass, the variance of the
//! mean comes from the spp independent samples (dof = spp − 1); with P > 1 passes, from the P
//! pass means (dof = P − 1). The random stream of a pixel depends only on (seed, pass, full-film
//! pixel index), so an image is bit-identical for any thread count and a crop equals the same
//! window of the full render.

use crate::contacts::{contact_pixels, light_contacts};
use crate::film::Welford;
use crate::options::RenderOptions;
use crate::render_scene::RenderScene;
use crate::scene::Scene;
use crate::visible_line::PixelLine;
use linlight_imagefile::{Image, Metadata};
use linlight_sampling::noise::Noise;
use linlight_sampling::philox::CounterRng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Side of the square tiles distributed over threads.
pub(crate) const TILE: u32 = 16;

/// White-noise stream of one camera sample: Philox of (seed; sample, full-film pixel index,
/// pass). Every pixel, pass and sample has its own counter-based stream (no state shared between
/// pixels, so neighbouring pixels' errors are independent); its numbers are the sample's
/// dimensions: film position (2), then the lights' numbers (`crate::shading`, and the choice of
/// a light per light sample of [`crate::light_choice`]), then those of the visible lines. The renderer draws them through [`NoiseSource::stream`](linlight_sampling::noise::NoiseSource::stream), which returns
/// exactly these numbers for [`Noise::White`].
pub fn sample_rng(seed: u64, pass: u32, pixel_index: u32, sample: u32) -> CounterRng {
    CounterRng::camera_sample(seed, pass, pixel_index, sample)
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
    for (key, value) in opts.cylinders.header() {
        meta.extra.insert(key.into(), value);
    }
    if opts.noise != Noise::White {
        meta.extra.insert("noise".into(), opts.noise.name().into());
    }
    meta
}

/// The tile loop of both renderers (the scalar path here and [`crate::packet`]): tiles of
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
    // One job per tile: rayon runs a chunk of items that no thread stole on one thread, so a
    // chunk of several tiles can leave the other cores idle at the end of the render.
    tiles.par_iter().with_max_len(1).for_each(|&(tx, ty)| {
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
    record_lights(&mut meta, scene, rs, window);
    meta.extra
}

/// Distance (in pixels) from a contact's projection within which pixels are contact pixels.
pub const CONTACT_PIXEL_RADIUS: f64 = 2.0;

/// Header keys about the lights: `radius` (per light, as in the file) and, where a light
/// rendered as a line touches a surface, `contacts` (readable) and `contact_pixels` (`x,y;…`,
/// window coordinates), the pixels `compare` tests apart against the R → 0 limit's allowance.
/// A light rendered as the tube it is (`rs.tubes`) has no contacts: its radiance is finite, so
/// the integrand stays bounded at a contact and no limit is taken there.
fn record_lights(
    meta: &mut Metadata,
    scene: &Scene,
    rs: &RenderScene,
    window: (u32, u32, u32, u32),
) {
    if !scene.lights.is_empty() {
        let radii: Vec<String> = scene.lights.iter().map(|l| l.radius.to_string()).collect();
        meta.extra
            .insert(linlight_imagefile::KEY_RADIUS.into(), radii.join(","));
    }
    let mut contacts = light_contacts(scene, &rs.bvh);
    contacts.retain(|c| rs.tubes.get(c.light).is_none());
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
    let pixels = contact_pixels(&rs.camera, &contacts, window, CONTACT_PIXEL_RADIUS);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::Cylinders;
    use crate::scene_builder::{floor, light, scene, sensor};
    use glam::Vec3;

    /// A tube resting on the floor in view: its contact is recorded (and tested apart by
    /// `compare` against the R → 0 allowance) when it is rendered as a line, not when it is
    /// rendered as the tube it is.
    #[test]
    fn contacts_are_recorded_for_lines_only() {
        let v = Vec3::new;
        let mut l = light(v(-0.8, 0.2, 0.12), v(0.7, 0.7, 0.12), [0.36; 3]);
        l.radius = 0.12;
        let s = scene(
            sensor(v(0.0, -1.6, 2.4), v(0.0, 0.1, 0.0), Vec3::Z, 50.0, 32, 32),
            vec![floor(3.0, [0.5; 3])],
            vec![l],
        );
        let entries = |cylinders| {
            let rs = RenderScene::with_cylinders(&s, cylinders).unwrap();
            pixel_entries(&s, &rs, (0, 0, 32, 32))
        };
        let line = entries(Cylinders::Line);
        assert!(line.contains_key("contacts"), "{line:?}");
        assert!(!line[linlight_imagefile::KEY_CONTACT_PIXELS].is_empty());
        let exact = entries(Cylinders::EXACT);
        assert!(!exact.contains_key("contacts"), "{exact:?}");
        assert!(!exact.contains_key(linlight_imagefile::KEY_CONTACT_PIXELS));
        assert_eq!(exact[linlight_imagefile::KEY_RADIUS], "0.12");
    }
}
