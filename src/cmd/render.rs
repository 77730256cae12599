//! `linlight render`: render a Mitsuba-XML scene with linear lights into the shared EXR format
//! (mean + variance of the mean), optionally with a PNG preview.

use indicatif::{ProgressBar, ProgressStyle};
use linlight_render::{record_inputs, render, RenderOptions};
use linlight_sampling::Technique;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use linlight_render::xml;

#[derive(clap::Args)]
pub struct Args {
    /// Scene file (Mitsuba 3 XML).
    scene: PathBuf,
    /// Samples per pixel in each pass [default: the scene's sampler sample_count].
    #[arg(long)]
    spp: Option<u32>,
    /// Seed of the random streams [default: the scene's sampler seed].
    #[arg(long)]
    seed: Option<u64>,
    /// Line-sampling technique.
    #[arg(long, default_value = "projected-solid-angle")]
    technique: String,
    /// Independent passes; with P > 1 the variance comes from the P pass means (dof = P − 1).
    #[arg(long, default_value_t = 1)]
    passes: u32,
    /// Output image [default: <scene stem>.exr].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also write a tone-mapped PNG preview.
    #[arg(long)]
    preview: Option<PathBuf>,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bar, no summary.
    #[arg(long)]
    quiet: bool,
    /// Override a `$name` default of the scene file (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    define: Vec<String>,
}

fn usage_error(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight render: {msg}");
    ExitCode::from(2)
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

pub fn run(args: Args) -> ExitCode {
    let technique: Technique = match args.technique.parse() {
        Ok(t) => t,
        Err(e) => return usage_error(e),
    };
    let mut overrides = Vec::new();
    for d in &args.define {
        match parse_define(d) {
            Some(kv) => overrides.push(kv),
            None => return usage_error(format!("-D expects NAME=VALUE, got '{d}'")),
        }
    }
    if !args.scene.is_file() {
        return usage_error(format!("cannot read scene file {}", args.scene.display()));
    }
    let scene = match xml::load_scene(&args.scene, &overrides) {
        Ok(s) => s,
        Err(e) => return usage_error(e),
    };
    if !args.quiet {
        for w in &scene.warnings {
            eprintln!("warning: {w}");
        }
    }
    let opts = RenderOptions {
        spp: args.spp.unwrap_or(scene.sensor.sample_count),
        passes: args.passes,
        seed: args.seed.unwrap_or(scene.sensor.seed),
        technique,
    };
    if opts.spp == 0 || opts.passes == 0 {
        return usage_error("--spp and --passes must be at least 1");
    }
    if opts.spp == 1 && opts.passes == 1 {
        // Shown even with --quiet: the output cannot be compared.
        eprintln!(
            "warning: one sample per pixel in one pass gives no variance estimate (dof 0):              `linlight compare` refuses such an image; use --spp ≥ 2 or --passes ≥ 2"
        );
    }
    let film = &scene.sensor.film;
    if film.width == 0 || film.height == 0 {
        return usage_error(format!(
            "film has zero size ({}x{})",
            film.width, film.height
        ));
    }
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = args.threads {
        if t == 0 {
            return usage_error("--threads must be at least 1");
        }
        pool = pool.num_threads(t);
    }
    let pool = match pool.build() {
        Ok(p) => p,
        Err(e) => return usage_error(format!("cannot start worker threads: {e}")),
    };

    let show = !args.quiet && std::io::stderr().is_terminal();
    let bar = if show {
        ProgressBar::new(0)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} tiles {elapsed_precise} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let start = Instant::now();
    let mut image = match pool.install(|| render(&scene, &opts, &progress)) {
        Ok(img) => img,
        Err(e) => return usage_error(e),
    };
    record_inputs(&mut image.meta, &args.scene, &overrides);
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();

    let out = args.out.clone().unwrap_or_else(|| default_out(&args.scene));
    // The image file's errors already name the path ("cannot write X: …").
    if let Err(e) = image.write(&out) {
        return usage_error(e);
    }
    if let Some(p) = &args.preview {
        if let Err(e) = image.write_preview_png(p) {
            return usage_error(e);
        }
    }
    if !args.quiet {
        if let Some(c) = image.meta.extra.get("contacts") {
            eprintln!("light–surface contacts (tested apart by compare): {c}");
        }
        let samples = (image.width * image.height) as f64 * image.meta.spp as f64;
        eprintln!(
            "wrote {} ({}x{}, {} spp in {} pass(es), {}, {:.2} s, {:.2} M samples/s)",
            out.display(),
            image.width,
            image.height,
            image.meta.spp,
            image.meta.passes,
            technique,
            seconds,
            samples / seconds.max(1e-9) / 1e6
        );
    }
    ExitCode::SUCCESS
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
    }
}
