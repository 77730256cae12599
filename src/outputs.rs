//! What every command checks before doing any work: that its output files can be written (and
//! do not overwrite an input), that the thread count is sensible, and that a render fits in
//! memory. "Unusable input is detected before anything is rendered."
//!
//! Every output is written atomically by [`write_file`] (or the image writers, which use the
//! same [`linlight_imagefile::atomic`] writer): the target holds the old or the new complete
//! file, whatever happens to the writer.

use std::path::{Path, PathBuf};

pub use linlight_imagefile::atomic::write_file;

/// Output image formats, chosen from the file extension (as Mitsuba's `Bitmap::write` does).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// OpenEXR: mean and variance of the mean (the project's image format).
    Exr,
    /// 8-bit sRGB PNG: a tone-mapped preview of the mean (the variance is not kept).
    Png,
}

impl ImageFormat {
    /// The format of `path` by its extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Self, String> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("exr") => Ok(ImageFormat::Exr),
            Some("png") => Ok(ImageFormat::Png),
            _ => Err(format!(
                "cannot tell the image format of {} from its extension (supported: .exr for \
                 mean + variance, .png for a tone-mapped preview)",
                path.display()
            )),
        }
    }
}

/// `path` made absolute and free of `.`/`..`/symlinks as far as it exists (the file itself may
/// not exist yet), so that two spellings of one file compare equal.
pub fn identity(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let parent = parent.canonicalize().unwrap_or(parent);
    match path.file_name() {
        Some(f) => parent.join(f),
        None => parent,
    }
}

/// The (device, inode) of an existing file (symbolic links followed), as GNU `cp` identifies
/// files: two names of one file (hard links, bind mounts, `..` and links) compare equal.
#[cfg(unix)]
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}
#[cfg(not(unix))]
fn file_id(_: &Path) -> Option<(u64, u64)> {
    None
}

/// Whether `a` and `b` name the same file: by (device, inode) when both exist, else by
/// [`identity`].
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (file_id(a), file_id(b)) {
        (Some(x), Some(y)) => x == y,
        (None, None) => identity(a) == identity(b),
        _ => false,
    }
}

/// Refuses `output` if it is the same file as any of `inputs` (name, path), by (device,
/// inode): a hard link to an input is that input.
pub fn check_not_input(output: &Path, inputs: &[(&str, &Path)]) -> Result<(), String> {
    for (what, input) in inputs {
        if same_file(output, input) {
            return Err(format!(
                "output {} is the {what} ({}); refusing to overwrite it",
                output.display(),
                input.display()
            ));
        }
    }
    Ok(())
}

/// Checks that `path` can be written as a file, without leaving anything behind: it is not a
/// directory, its directory exists, and opening it for writing succeeds (a file created by the
/// probe is removed again; an existing file is not truncated).
pub fn check_writable(path: &Path) -> Result<(), String> {
    // Not a directory, FIFO or device (opening a FIFO would block; see `write_file`).
    linlight_imagefile::atomic::check_output_path(path)?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        return Err(format!(
            "cannot write {}: directory {} does not exist",
            path.display(),
            parent.display()
        ));
    }
    let existed = path.exists();
    std::fs::OpenOptions::new()
        .append(true)
        .create(true)
        .open(path)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    if !existed {
        let _ = std::fs::remove_file(path);
    }
    Ok(())
}

/// Refuses one path given for two different outputs (the same file spelled twice included).
pub fn check_distinct(paths: &[&Path]) -> Result<(), String> {
    for (i, a) in paths.iter().enumerate() {
        if let Some(b) = paths[i + 1..].iter().find(|b| same_file(a, b)) {
            return Err(format!("{} is given as two different outputs", b.display()));
        }
    }
    Ok(())
}

/// Checks that the directory `dir` exists or can be created (it is created).
pub fn check_dir_writable(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("cannot create directory {}: {e}", dir.display()))?;
    let probe = dir.join(format!(".linlight-write-probe-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .map_err(|e| format!("cannot write into directory {}: {e}", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// What a caller of a render asked for; `None` takes the scene's value.
#[derive(Clone, Copy, Debug)]
pub struct RenderChoices {
    pub spp: Option<u32>,
    pub passes: u32,
    pub seed: Option<u64>,
    pub method: linlight_render::Method,
    pub light_samples: Option<u32>,
    pub lights: linlight_render::LightSelection,
    pub noise: linlight_sampling::noise::Noise,
    pub cylinders: linlight_render::Cylinders,
}

/// The cylinder mode of `--cylinders`, `--cylinder-technique` and `--cylinder-mis` (spelled by
/// `flag` in the messages, as in [`render_options`]).
pub fn cylinders(
    mode: &str,
    technique: &str,
    mis: &str,
    flag: impl Fn(&str) -> String,
) -> Result<linlight_render::Cylinders, String> {
    let technique = linlight_render::options::cylinder_technique(technique)
        .map_err(|e| format!("{}: {e}", flag("cylinder-technique")))?;
    let mis = match mis {
        "balance" => true,
        "off" => false,
        m => {
            return Err(format!(
                "{}: unknown '{m}' (expected balance or off)",
                flag("cylinder-mis")
            ))
        }
    };
    match mode {
        "exact" => Ok(linlight_render::Cylinders::Exact(
            linlight_render::TubeSampling { technique, mis },
        )),
        "line" => Ok(linlight_render::Cylinders::Line),
        c => Err(format!(
            "{}: unknown '{c}' (expected exact or line)",
            flag("cylinders")
        )),
    }
}

/// The options a render of `scene` runs with, and the warnings `linlight render` gives about
/// them (the scene's own first). `flag` spells an option for the messages ("light-samples" →
/// "--light-samples" on the command line, "light_samples" in Python); `one_sample_warning`
/// is false where one sample in one pass is not the final image (`--match-variance`).
pub fn render_options(
    scene: &linlight_render::scene::Scene,
    c: RenderChoices,
    flag: impl Fn(&str) -> String,
    one_sample_warning: bool,
) -> (linlight_render::RenderOptions, Vec<String>) {
    let mut warnings = scene.warnings.clone();
    if c.cylinders == linlight_render::Cylinders::Line {
        warnings.extend(linlight_render::xml::radius::line_limit_warnings(scene));
    }
    if c.method == linlight_render::Method::Technique(linlight_sampling::Technique::Baseline) {
        warnings.push(
            "the baseline technique is biased by design (its density is not exact); its images \
             are not expected to agree with Mitsuba"
                .into(),
        );
    }
    let light_samples = match c.light_samples {
        Some(n) => n,
        None if scene.integrator.emitter_samples == 0 => {
            warnings.push(format!(
                "the scene's integrator has emitter_samples = 0 (BSDF samples only, which never \
                 hit a linear light); rendering with 1 light sample (set {})",
                flag("light-samples")
            ));
            1
        }
        None => scene.integrator.emitter_samples,
    };
    let opts = linlight_render::RenderOptions {
        spp: c.spp.unwrap_or(scene.sensor.sample_count),
        passes: c.passes,
        seed: c.seed.unwrap_or(scene.sensor.seed),
        method: c.method,
        light_samples,
        lights: c.lights,
        noise: c.noise,
        cylinders: c.cylinders,
    };
    if one_sample_warning && opts.spp == 1 && opts.passes == 1 {
        warnings.push(format!(
            "one sample per pixel in one pass gives no variance estimate (dof 0): `linlight \
             compare` refuses such an image; use {} ≥ 2 or {} ≥ 2",
            flag("spp"),
            flag("passes")
        ));
    }
    (opts, warnings)
}

/// The header value `finite_radius_effect` of a render (docs/image-format.md): under
/// `--cylinders line`, every light whose estimated finite-radius effect exceeds the warning
/// level, `;`-separated (compare repeats it when it finds a difference); None otherwise.
pub fn finite_radius_effect(
    scene: &linlight_render::scene::Scene,
    cylinders: linlight_render::Cylinders,
) -> Option<String> {
    use linlight_render::xml::radius;
    if cylinders != linlight_render::Cylinders::Line {
        return None;
    }
    let effects: Vec<String> = radius::effects(scene)
        .iter()
        .filter(|e| e.per_pixel > radius::WARN_RELATIVE)
        .map(|e| radius::describe(scene, e))
        .collect();
    (!effects.is_empty()).then(|| effects.join(";"))
}

/// Largest radiance × radius K a light may have: a sample's value is K times geometry and BRDF
/// terms of order 1 (up to ~1e6 near a light), and its square is summed in f32 for the variance;
/// K² · 1e12 must stay below f32::MAX (3.4e38).
pub const MAX_RADIANCE_TIMES_RADIUS: f32 = 1e13;

/// Refuses, before rendering, a scene whose light radiance would overflow the f32 variance of
/// the image (a render would otherwise run to its end and fail on an infinite variance).
pub fn check_radiance(scene: &linlight_render::scene::Scene) -> Result<(), String> {
    for light in &scene.lights {
        let k = light.radiance_times_radius;
        if k.iter()
            .any(|c| !c.is_finite() || c.abs() > MAX_RADIANCE_TIMES_RADIUS)
        {
            return Err(format!(
                "{}: the light's radiance × radius is ({:e}, {:e}, {:e}) (radius {}): its \
                 squared samples overflow the image's f32 variance (at most {:e} per channel); \
                 scale the radiance down",
                light.location, k[0], k[1], k[2], light.radius, MAX_RADIANCE_TIMES_RADIUS
            ));
        }
    }
    Ok(())
}

/// Cores of this machine (1 if unknown).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Most worker threads a command accepts: 4 per core, at least 64. More only add overhead (and
/// thousands of threads exhaust the process limits instead of rendering).
pub fn max_threads() -> usize {
    (4 * cores()).max(64)
}

/// A rayon pool of `threads` workers (default: one per core), refusing 0 and more than
/// [`max_threads`].
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool, String> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        if t == 0 {
            return Err("--threads must be at least 1".into());
        }
        let max = max_threads();
        if t > max {
            return Err(format!(
                "--threads {t} is more than {max} (4 per core on this machine's {} cores, at \
                 least 64); more threads than cores only add overhead",
                cores()
            ));
        }
        pool = pool.num_threads(t);
    }
    pool.build()
        .map_err(|e| format!("cannot start worker threads: {e}"))
}

/// Bytes a render needs per pixel of its window: the per-tile results (mean and variance, f32
/// RGB: 24 B), the image (24 B), the EXR writer's channel copies (24 B) and its compression
/// buffers (≤ 24 B).
pub const RENDER_BYTES_PER_PIXEL: u64 = 96;

/// Memory a render of a `width` × `height` window over `primitives` primitives needs, roughly
/// (pixels × [`RENDER_BYTES_PER_PIXEL`] + 128 B per primitive for the BVH + 64 MiB of program).
pub fn render_memory(width: u64, height: u64, primitives: u64) -> u64 {
    width
        .saturating_mul(height)
        .saturating_mul(RENDER_BYTES_PER_PIXEL)
        .saturating_add(primitives.saturating_mul(128))
        .saturating_add(64 << 20)
}

/// The inputs' file names (the whole path where there is none), `;`-separated: the provenance
/// list that `merge` and `stack` record in their output's header.
pub fn file_names(paths: &[std::path::PathBuf]) -> String {
    let names: Vec<String> = paths
        .iter()
        .map(|p| {
            p.file_name()
                .map_or_else(|| p.display().to_string(), |f| f.to_string_lossy().into())
        })
        .collect();
    names.join(";")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_from_extensions() {
        assert_eq!(
            ImageFormat::from_path(Path::new("a/b.EXR")),
            Ok(ImageFormat::Exr)
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("b.png")),
            Ok(ImageFormat::Png)
        );
        assert!(ImageFormat::from_path(Path::new("b.jpg")).is_err());
        assert!(ImageFormat::from_path(Path::new("b")).is_err());
    }

    #[test]
    fn collisions_and_probes() {
        let dir = std::env::temp_dir().join(format!("linlight-outputs-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let scene = dir.join("scene.xml");
        std::fs::write(&scene, "x").unwrap();
        let other = dir.join("sub/../scene.xml");
        assert!(check_not_input(&other, &[("scene file", &scene)]).is_err());
        assert!(check_not_input(&dir.join("out.exr"), &[("scene file", &scene)]).is_ok());
        // The probe neither truncates an existing file nor leaves a new one behind.
        check_writable(&scene).unwrap();
        assert_eq!(std::fs::read_to_string(&scene).unwrap(), "x");
        let fresh = dir.join("fresh.exr");
        check_writable(&fresh).unwrap();
        assert!(!fresh.exists());
        assert!(check_writable(&dir.join("missing/x.exr"))
            .unwrap_err()
            .contains("does not exist"));
        assert!(check_writable(&dir).unwrap_err().contains("directory"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn memory_estimate() {
        let m = render_memory(100_000, 100_000, 12);
        assert!(m > 800 << 30, "{}", linlight_imagefile::memory_size(m));
        assert!(render_memory(64, 64, 1000) < 128 << 20);
        assert!(thread_pool(Some(0)).is_err());
        assert!(thread_pool(Some(1_000_000)).is_err());
    }
}
