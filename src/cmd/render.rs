//! `linlight render`: render a Mitsuba-XML scene with linear lights into the shared EXR format
//! (mean + variance of the mean), optionally with a PNG preview.
//!
//! Everything that can make the run unusable is checked before rendering: the technique, the
//! `-D` overrides and the scene (loading), the output paths (format from the extension, no
//! output overwriting the scene or another output, writable), the thread count, the memory the
//! film needs, and the `--match-variance` reference.

use indicatif::{ProgressBar, ProgressStyle};
use linlight::certify::budget::BudgetRule;
pub use linlight::compare_report::duration;
use linlight::merge::merge;
use linlight::outputs::{self, ImageFormat};
use linlight_imagefile::Image;
use linlight_render::scene::Scene;
use linlight_render::{record_inputs, render, Cylinders, LightSelection, Method, RenderOptions};
use linlight_sampling::noise::Noise;
use linlight_verify::image_stats::CompareConfig;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use linlight_render::xml;

pub const EXAMPLES: &str = "\
Examples:
  linlight render scene.xml                          # -> scene.exr, the scene's own spp
  linlight render scene.xml --spp 1024 --passes 16 -o out.exr --preview out.png --exposure -2
  linlight render scene.xml -D res=64 -t 2 -q        # override a <default>, 2 threads, quiet
  linlight render scene.xml --match-variance references/mitsuba/scene.exr -o mine.exr
  linlight render scene.xml --spp 256 --time 60      # as many 256-spp passes as fit in 60 s
  linlight render scene.xml --spp 3 --passes 16 --noise blue-jittered   # the paper's stratification
  linlight render glossy.xml --mis balance --light-samples 3   # MIS, balance heuristic, N = 3
  linlight render glossy.xml --mis clamped-optimal=0.25        # the paper's heuristic, v = 0.25
  linlight render glossy.xml --technique ltc                   # LTC only (see below)
  linlight render glossy.xml --technique projected-solid-angle # one technique, full BSDF
  linlight render two-tubes.xml --lights one       # one light per light sample, as Mitsuba
  linlight render many-tubes.xml --lights tree     # one light per light sample, by a light tree
  linlight render scene.xml --cylinders line       # tubes as the R → 0 line limit
  linlight render scene.xml --cylinder-technique solid-angle --cylinder-mis off

Methods (--technique): `mis` (default) takes per light and iteration one projected-solid-angle
(diffuse) and one LTC (specular) sample, both shadow-traced, combined by --mis; `ltc` takes an
LTC sample and covers the directions the LTC cannot sample (below the cosine lobe's horizon)
with the projected-solid-angle sample (weight 1 there, 0 elsewhere); every other name is one
sample of that technique with the full BSDF. All but `baseline` are unbiased on every surface.
Lambertian surfaces are sampled with the projected solid angle only (or the chosen technique).

Light samples: --light-samples N takes N light samples per camera sample and averages them;
its default is the scene's emitter_samples. With --lights every (default) each light sample
samples EVERY light (N × lights shadow rays). With --lights one (Mitsuba's direct integrator)
each light sample picks ONE light j with probability p_j (proportional to the emitters'
sampling_weight, uniform by default) and divides its estimate by p_j: the same work per sample
as Mitsuba, the same expectation, but far more noise where the lights light different regions
(two-tubes: 720× the per-pixel variance for 0.78× the work). With --lights tree each light
sample picks one light from a tree over the lights, with a probability p_j(x) that follows each
light's power and a bound of its projected solid angle at the shading point x, and divides by
it: the work of `one`, for scenes with many lights (docs/light-tree.md). Scenes with one light
render the same image under every selection.

Cylinders (--cylinders): `exact` (default) renders a cylinder with an area emitter as the
cylinder it is (radius R, open ends as in Mitsuba, radiance L on the outer side), sampled by
--cylinder-technique (projected: the line sampler along the axis composed across the section;
solid-angle; gamito: Gamito's uniform solid angle; area) combined with a cosine-weighted BSDF-side sample by the balance heuristic
(--cylinder-mis balance, or off). `line` renders the R → 0 limit with K = radiance × radius
(the behaviour before finite cylinders; --technique and --mis apply to it). docs/cylinders.md.

The header of the .exr records technique, mis, mis_v (clamped optimal), light_samples,
light_selection, cylinders and (exact) cylinder_technique and cylinder_mis.

The output format follows the extension: .exr holds mean and variance of the mean (for
compare, merge, info); .png a tone-mapped preview only.";

#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Scene file (Mitsuba 3 XML).
    scene: PathBuf,
    /// Samples per pixel in each pass [default: the scene's sampler sample_count].
    #[arg(long)]
    spp: Option<u32>,
    /// Seed of the random streams [default: the scene's sampler seed].
    #[arg(long)]
    seed: Option<u64>,
    /// Light sampling method (names listed below).
    #[arg(long, default_value = "mis")]
    technique: String,
    /// Primary samples: white (independent), blue (blue noise, a random toroidal shift per
    /// pass) or blue-jittered (blue noise stratified over the spp of a pass; use --passes > 1
    /// for a variance estimate). Every choice is unbiased across passes.
    #[arg(long, default_value = "white", value_name = "white|blue|blue-jittered")]
    noise: String,
    /// MIS heuristic of --technique mis: balance, power, weighted, clamped-optimal[=v] with the
    /// visibility estimate v in [0, 1] [default: clamped-optimal=0.5].
    #[arg(long, value_name = "HEURISTIC")]
    mis: Option<String>,
    /// Light samples per camera sample [default: the scene's emitter_samples].
    #[arg(long, value_name = "N")]
    light_samples: Option<u32>,
    /// Lights of each light sample: every light, or one chosen at random and divided by its
    /// probability (`one`: Mitsuba's estimator; `tree`: by a light tree; see below).
    #[arg(long, default_value = "every", value_name = "every|one|tree")]
    lights: String,
    /// Cylinders with an area emitter: exact (the tube of radius R) or line (the R → 0 limit).
    #[arg(long, default_value = "exact", value_name = "exact|line")]
    cylinders: String,
    /// Emitter technique of exact cylinders: projected (ours), ltc (ours with the glossy
    /// lobe's LTC; projected on diffuse surfaces), solid-angle, gamito or area.
    #[arg(
        long,
        default_value = "projected",
        value_name = "projected|ltc|solid-angle|gamito|area"
    )]
    cylinder_technique: String,
    /// Combination of exact cylinders' emitter sample with a BSDF-side sample: balance or off.
    #[arg(long, default_value = "balance", value_name = "balance|off")]
    cylinder_mis: String,
    /// Independent passes; with P > 1 the variance comes from the P pass means (dof = P − 1).
    #[arg(long, default_value_t = 1)]
    passes: u32,
    /// Output image, .exr (mean + variance) or .png (preview) [default: <scene stem>.exr].
    #[arg(short = 'o', long)]
    out: Option<PathBuf>,
    /// Also write a tone-mapped PNG preview.
    #[arg(long, value_name = "FILE.png")]
    preview: Option<PathBuf>,
    /// Exposure of the previews in stops: pixels are scaled by 2^E before tone mapping.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Worker threads [default: all cores; at most 4 per core, or 64].
    #[arg(short = 't', long)]
    threads: Option<usize>,
    /// No progress bar, no summary (warnings are always printed).
    #[arg(short = 'q', long)]
    quiet: bool,
    /// Override a `$name` default of the scene file (repeatable; every NAME must be used once).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    define: Vec<String>,
    /// Choose the spp with certify's budget rule so that this render is at least as precise as
    /// REF.exr in 99 % of the pixels (a pilot render estimates the per-sample variance).
    #[arg(long, value_name = "REF.exr", conflicts_with_all = ["spp", "time"])]
    match_variance: Option<PathBuf>,
    /// Render passes of --spp samples until SECONDS have passed (at least one pass); the passes
    /// are merged as by `linlight merge`.
    #[arg(long, value_name = "SECONDS")]
    time: Option<f64>,
    #[command(flatten)]
    memory: super::MemoryLimit,
}

fn usage_error(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight render: {msg}");
    ExitCode::from(2)
}

fn warn(msg: impl std::fmt::Display) {
    eprintln!("warning: {msg}");
}

fn parse_define(d: &str) -> Option<(String, String)> {
    let (name, value) = d.split_once('=')?;
    (!name.is_empty()).then(|| (name.to_string(), value.to_string()))
}

fn default_out(scene: &Path) -> PathBuf {
    let stem = scene
        .file_stem()
        .map_or_else(|| "render".into(), |s| s.to_os_string());
    PathBuf::from(stem).with_extension("exr")
}

/// Seed of batch `b` of a `--time` render (batch 0 uses the seed itself): a multiplicative hash,
/// so that the batches of two runs with nearby seeds do not share streams.
fn batch_seed(seed: u64, batch: u64) -> u64 {
    seed ^ batch.wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// The checked output files: (path, format) of --out, and the --preview path.
struct Outputs {
    out: PathBuf,
    format: ImageFormat,
    preview: Option<PathBuf>,
}

fn check_outputs(args: &Args) -> Result<Outputs, String> {
    let out = args.out.clone().unwrap_or_else(|| default_out(&args.scene));
    let scene: (&str, &Path) = ("scene file", &args.scene);
    outputs::check_not_input(&out, &[scene])?;
    let format = ImageFormat::from_path(&out).map_err(|e| format!("--out: {e}"))?;
    if let Some(p) = &args.preview {
        if ImageFormat::from_path(p) != Ok(ImageFormat::Png) {
            return Err(format!(
                "--preview {} must be a .png file (the preview is a tone-mapped PNG)",
                p.display()
            ));
        }
        outputs::check_not_input(p, &[scene, ("--out image", &out)])?;
        outputs::check_writable(p)?;
    }
    outputs::check_writable(&out)?;
    Ok(Outputs {
        out,
        format,
        preview: args.preview.clone(),
    })
}

/// The render window (crop or full film) and the memory it needs, refused above the limit.
fn check_memory(scene: &Scene, limit: u64, why: &str) -> Result<(), String> {
    let film = &scene.sensor.film;
    let (w, h) = film
        .crop
        .map_or((film.width, film.height), |c| (c.width, c.height));
    let prims: u64 = scene
        .shapes
        .iter()
        .map(|s| match &s.geometry {
            linlight_render::scene::Geometry::Mesh { indices, .. } => indices.len() as u64,
            _ => 1,
        })
        .sum();
    let need = outputs::render_memory(w as u64, h as u64, prims);
    if need > limit {
        return Err(format!(
            "the render needs about {} ({w}×{h} px × {} B + geometry), more than the limit of {} \
             ({why})",
            linlight_imagefile::memory_size(need),
            outputs::RENDER_BYTES_PER_PIXEL,
            linlight_imagefile::memory_size(limit)
        ));
    }
    Ok(())
}

/// The method of --technique and --mis.
fn method(args: &Args) -> Result<Method, String> {
    let method = Method::from_technique_name(&args.technique)?;
    match (&args.mis, method) {
        (None, m) => Ok(m),
        (Some(h), Method::Mis(_)) => Ok(Method::Mis(h.parse()?)),
        (Some(_), m) => Err(format!(
            "--mis chooses the heuristic of --technique mis; it does not apply to --technique {}",
            m.technique_name()
        )),
    }
}

/// What the command line asks for, checked before anything is loaded.
struct Request {
    method: Method,
    noise: Noise,
    lights: LightSelection,
    cylinders: Cylinders,
    overrides: Vec<(String, String)>,
    outs: Outputs,
}

/// The loaded scene and everything the render needs, all checked.
struct Plan {
    scene: Scene,
    opts: RenderOptions,
    pool: rayon::ThreadPool,
    reference: Option<Image>,
    load_seconds: f64,
}

/// The rendered image and the times of its parts (seconds).
struct Rendered {
    image: Image,
    notes: Vec<String>,
    build_seconds: f64,
    render_seconds: f64,
}

/// Parse -> plan -> render -> write; each step refuses with exit 2 and a message.
pub fn run(args: Args) -> ExitCode {
    let started = Instant::now();
    let result = parse(&args)
        .and_then(|req| plan(&args, &req, started).map(|p| (req, p)))
        .and_then(|(req, plan)| render_plan(&args, &plan).map(|r| (req, plan, r)))
        .and_then(|(req, plan, r)| write(&args, &req, &plan, r));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => usage_error(e),
    }
}

/// The command line alone: method, noise, lights, overrides, outputs, exposure, time.
fn parse(args: &Args) -> Result<Request, String> {
    let method = method(args)?;
    let noise: Noise = args.noise.parse()?;
    let lights: LightSelection = args.lights.parse().map_err(|e| format!("--lights: {e}"))?;
    let cylinders = outputs::cylinders(
        &args.cylinders,
        &args.cylinder_technique,
        &args.cylinder_mis,
        |name| format!("--{name}"),
    )?;
    if args.light_samples == Some(0) {
        return Err("--light-samples must be at least 1".into());
    }
    if args.spp == Some(0) || args.passes == 0 {
        return Err("--spp and --passes must be at least 1".into());
    }
    let overrides = args
        .define
        .iter()
        .map(|d| parse_define(d).ok_or_else(|| format!("-D expects NAME=VALUE, got '{d}'")))
        .collect::<Result<Vec<_>, _>>()?;
    if !args.scene.is_file() {
        return Err(format!("cannot read scene file {}", args.scene.display()));
    }
    let outs = check_outputs(args)?;
    if !args.exposure.is_finite() || args.exposure.abs() > 100.0 {
        return Err(format!(
            "--exposure {} is not a usable number of stops",
            args.exposure
        ));
    }
    if let Some(t) = args.time {
        if !(t > 0.0 && t.is_finite()) {
            return Err(format!(
                "--time must be a positive number of seconds (got {t})"
            ));
        }
    }
    Ok(Request {
        method,
        noise,
        lights,
        cylinders,
        overrides,
        outs,
    })
}

/// Loads the scene (printing its warnings) and fixes the options, memory, threads and the
/// --match-variance reference.
fn plan(args: &Args, req: &Request, started: Instant) -> Result<Plan, String> {
    let (limit, why) = args.memory.bytes()?;
    // Mesh files too large for the limit are refused from their headers, before being read.
    let budget = xml::MeshBudget {
        max_triangles: limit.saturating_sub(outputs::render_memory(0, 0, 0))
            / outputs::render_memory(0, 0, 1).saturating_sub(outputs::render_memory(0, 0, 0)),
        why: format!(
            "the memory limit of {} ({why})",
            linlight_imagefile::memory_size(limit)
        ),
    };
    let scene =
        xml::load_scene_within(&args.scene, &req.overrides, budget).map_err(|e| e.to_string())?;
    let load_seconds = started.elapsed().as_secs_f64();
    // Warnings are printed once every check has passed (a refusal is one line), and never
    // silenced: --quiet only drops progress and the summary.
    let (opts, warnings) = outputs::render_options(
        &scene,
        outputs::RenderChoices {
            spp: args.spp,
            passes: args.passes,
            seed: args.seed,
            method: req.method,
            light_samples: args.light_samples,
            lights: req.lights,
            noise: req.noise,
            cylinders: req.cylinders,
        },
        |name| format!("--{name}"),
        // Shown even with --quiet: the output cannot be compared.
        args.match_variance.is_none(),
    );
    check_memory(&scene, limit, why)?;
    outputs::check_radiance(&scene)?;
    let pool = outputs::thread_pool(args.threads)?;
    let reference = match &args.match_variance {
        None => None,
        Some(path) => {
            let r =
                Image::read_within(path, limit).map_err(|e| format!("--match-variance: {e}"))?;
            let film = &scene.sensor.film;
            let (w, h) = film
                .crop
                .map_or((film.width, film.height), |c| (c.width, c.height));
            if (r.width, r.height) != (w as usize, h as usize) {
                return Err(format!(
                    "--match-variance {} is {}×{} but the scene renders {w}×{h}",
                    path.display(),
                    r.width,
                    r.height
                ));
            }
            Some(r)
        }
    };
    for w in &warnings {
        warn(w);
    }
    Ok(Plan {
        scene,
        opts,
        pool,
        reference,
        load_seconds,
    })
}

/// Renders the plan (after the --match-variance pilot, when asked), with a progress bar on a
/// terminal. The build time ends at the renderer's first progress call (made once the scene's
/// acceleration structure is built).
fn render_plan(args: &Args, plan: &Plan) -> Result<Rendered, String> {
    let show = !args.quiet && std::io::stderr().is_terminal();
    let bar = if show {
        ProgressBar::new(0)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {percent:>3}% {msg} {elapsed_precise} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut notes = Vec::new();
    let mut opts = plan.opts;
    if let Some(r) = &plan.reference {
        let (spp, note) = match_variance(args, plan, r, &bar)?;
        opts.spp = spp;
        notes.push(note);
    }
    let start = Instant::now();
    let built = std::sync::OnceLock::<f64>::new();
    let progress = |done: usize, total: usize| {
        let t = *built.get_or_init(|| start.elapsed().as_secs_f64());
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        let s = start.elapsed().as_secs_f64() - t;
        if s > 0.0 {
            bar.set_message(format!("{:.2} M samples/s", done as f64 / s / 1e6));
        }
    };
    let (scene, pool) = (&plan.scene, &plan.pool);
    let image = match args.time {
        None => pool.install(|| render(scene, &opts, &progress)),
        Some(limit) => pool.install(|| render_for(scene, &opts, limit, &bar, &progress)),
    }
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    let total = start.elapsed().as_secs_f64();
    let build_seconds = built.get().copied().unwrap_or(0.0).min(total);
    Ok(Rendered {
        image,
        notes,
        build_seconds,
        render_seconds: total - build_seconds,
    })
}

/// --match-variance: a pilot render, then the spp of certify's budget rule. Says what it does
/// as it goes (pilot, chosen spp, estimated time), with or without a terminal.
fn match_variance(
    args: &Args,
    plan: &Plan,
    reference: &Image,
    bar: &ProgressBar,
) -> Result<(u32, String), String> {
    let rule = BudgetRule::parity();
    let opts = plan.opts;
    let pilot_opts = RenderOptions {
        spp: rule.pilot_spp,
        passes: 1,
        seed: opts.seed ^ 0x5049_4c4f_5453_4545,
        // White: the budget rule needs the per-sample variance, which is the same for every
        // noise (each sample is uniform), and independent samples to estimate it.
        noise: Noise::White,
        ..opts
    };
    let say = |m: String| {
        if !args.quiet {
            bar.suspend(|| eprintln!("{m}"));
        }
    };
    say(format!(
        "--match-variance: pilot render of {} spp to estimate the per-sample variance …",
        rule.pilot_spp
    ));
    bar.set_message("pilot render");
    let t0 = Instant::now();
    let pilot = plan
        .pool
        .install(|| render(&plan.scene, &pilot_opts, &|_, _| {}))
        .map_err(|e| e.to_string())?;
    let pilot_seconds = t0.elapsed().as_secs_f64();
    let budget = rule
        .choose(&pilot, reference, &CompareConfig::default())
        .map_err(|e| format!("--match-variance: {e}"))?;
    let spp = budget.spp.div_ceil(opts.passes).max(1);
    let total = spp as u64 * opts.passes as u64;
    let eta = pilot_seconds * total as f64 / rule.pilot_spp as f64;
    let note = format!(
        "--match-variance: {total} spp in total (the rule asked for {}{})",
        budget.required_spp.map_or_else(
            || "nothing: no pixel with variance".into(),
            |s| format!("{s:.0}")
        ),
        if budget.capped {
            format!("; capped at {}", rule.max_spp)
        } else {
            String::new()
        }
    );
    say(format!(
        "{note}; the pilot took {pilot_seconds:.2} s, so the render needs about {} ",
        duration(eta)
    ));
    Ok((spp, note))
}

/// --time: passes of `opts` with batch seeds until `limit` seconds have passed (at least one),
/// merged as they come (the merge of equal-size units is exactly the image of their union, so
/// merging one at a time loses nothing but f32 rounding).
fn render_for(
    scene: &Scene,
    opts: &RenderOptions,
    limit: f64,
    bar: &ProgressBar,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, linlight_render::RenderError> {
    let start = Instant::now();
    let mut merged: Option<Image> = None;
    let mut batches = 0u64;
    loop {
        let t0 = Instant::now();
        let seed = batch_seed(opts.seed, batches);
        // Only the first batch reports progress: its first call marks the end of the build.
        let quiet = |_: usize, _: usize| {};
        let report: &(dyn Fn(usize, usize) + Sync) = if batches == 0 { progress } else { &quiet };
        let img = render(scene, &RenderOptions { seed, ..*opts }, report)?;
        batches += 1;
        merged = Some(match merged {
            None => img,
            Some(m) => merge(&[&m, &img]).map_err(linlight_render::RenderError::Options)?,
        });
        let elapsed = start.elapsed().as_secs_f64();
        bar.set_length(1000);
        bar.set_position((1000.0 * (elapsed / limit).min(1.0)) as u64);
        bar.set_message(format!("{batches} batch(es)"));
        if elapsed + t0.elapsed().as_secs_f64() > limit {
            break;
        }
    }
    let mut img = merged.expect("at least one batch");
    img.meta.extra.remove("merged_images");
    img.meta.extra.insert("seed".into(), opts.seed.to_string());
    img.meta
        .extra
        .insert("time_limit_s".into(), limit.to_string());
    img.meta.extra.insert("batches".into(), batches.to_string());
    Ok(img)
}

/// Warnings about the pixels, the preview, the image, and the summary with the time of each
/// step.
fn write(args: &Args, req: &Request, plan: &Plan, r: Rendered) -> Result<(), String> {
    let Rendered {
        mut image,
        notes,
        build_seconds,
        render_seconds,
    } = r;
    // No times in the header: a render's bytes depend on its inputs only.
    record_inputs(&mut image.meta, &args.scene, &req.overrides);
    // The finite-radius effect where it may be visible, for compare's message on a failure.
    if let Some(effects) = linlight::outputs::finite_radius_effect(&plan.scene, plan.opts.cylinders)
    {
        image
            .meta
            .extra
            .insert("finite_radius_effect".into(), effects);
    }
    warn_about_pixels(&image);
    let outs = &req.outs;
    if let Some(p) = &outs.preview {
        image
            .write_preview_png_with_exposure(p, args.exposure)
            .map_err(|e| e.to_string())?;
    }
    // The EXR writer consumes the image (a lower memory peak); what the summary needs first.
    let summary = Summary {
        width: image.width,
        height: image.height,
        spp: image.meta.spp,
        passes: image.meta.passes,
        contacts: image.meta.extra.get("contacts").cloned(),
        build_seconds,
        render_seconds,
    };
    match outs.format {
        ImageFormat::Exr => image.into_exr_file(&outs.out),
        ImageFormat::Png => {
            warn(format!(
                "{} is a tone-mapped preview: the variance is not saved (use .exr for compare, \
                 merge and info)",
                outs.out.display()
            ));
            image.write_preview_png_with_exposure(&outs.out, args.exposure)
        }
    }
    // The image writer's messages already name the file.
    .map_err(|e| e.to_string())?;
    if !args.quiet {
        print_summary(&outs.out, plan, &notes, &summary);
    }
    Ok(())
}

/// Warnings about light samples dropped as non-finite and pixels of negative mean, with
/// Mitsuba's message for such samples.
fn warn_about_pixels(image: &Image) {
    if let Some(n) = image.meta.extra.get("nonfinite_dropped") {
        warn(format!(
            "{n} light samples were not finite (NaN or infinite) and were counted as 0; Mitsuba \
             warns \"Invalid sample value\" for such samples"
        ));
    }
    let negative = image
        .mean
        .iter()
        .filter(|m| m.iter().any(|&c| c < 0.0))
        .count();
    if negative > 0 {
        warn(format!(
            "{negative} pixels have a negative mean (negative radiance or reflectance in the \
             scene); Mitsuba warns \"Invalid sample value\" for such samples"
        ));
    }
}

/// What the summary of a written image reports, taken before the image is consumed.
struct Summary {
    width: usize,
    height: usize,
    spp: u64,
    passes: u64,
    contacts: Option<String>,
    build_seconds: f64,
    render_seconds: f64,
}

/// The renderer's notes, the contacts, what was written and the time of each step.
fn print_summary(out: &Path, plan: &Plan, notes: &[String], s: &Summary) {
    for n in notes {
        eprintln!("{n}");
    }
    if let Some(c) = &s.contacts {
        eprintln!("light–surface contacts (tested apart by compare): {c}");
    }
    let o = &plan.opts;
    eprintln!(
        "wrote {} ({}x{}, {} spp in {} pass(es), {}, {} light sample(s), lights {}, {} \
         noise)",
        out.display(),
        s.width,
        s.height,
        s.spp,
        s.passes,
        o.method,
        o.light_samples,
        o.lights,
        o.noise,
    );
    eprintln!(
        "{}",
        timing(
            plan.load_seconds,
            s.build_seconds,
            s.render_seconds,
            s.width * s.height,
            s.spp
        )
    );
}

/// The summary's times: load, build and render apart, and the rate of the render alone.
fn timing(load: f64, build: f64, render: f64, pixels: usize, spp: u64) -> String {
    let samples = pixels as f64 * spp as f64;
    format!(
        "time: load {load:.2} s, build {build:.2} s, render {render:.2} s ({:.2} M samples/s \
         while rendering)",
        samples / render.max(1e-9) / 1e6
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defines_and_default_output() {
        assert_eq!(parse_define("a=1"), Some(("a".into(), "1".into())));
        assert_eq!(parse_define("a=b=c"), Some(("a".into(), "b=c".into())));
        assert_eq!(parse_define("=1"), None);
        assert_eq!(parse_define("a"), None);
        assert_eq!(
            default_out(Path::new("dir/cornell.xml")),
            PathBuf::from("cornell.exr")
        );
        assert_eq!(batch_seed(7, 0), 7);
        assert_ne!(batch_seed(7, 1), batch_seed(8, 1));
    }

    /// The rate is that of the render alone: a slow load or build does not lower it.
    #[test]
    fn timing_separates_load_build_and_render() {
        let t = timing(8.5, 0.25, 2.0, 1000, 2000);
        assert_eq!(
            t,
            "time: load 8.50 s, build 0.25 s, render 2.00 s (1.00 M samples/s while rendering)"
        );
        assert_eq!(duration(30.0), "30.0 s");
        assert_eq!(duration(600.0), "10.0 min");
        assert_eq!(duration(9000.0), "2.5 h");
    }
}
