//! `linlight unshadowed`: the exact R → 0 image of an unoccluded plane lit by linear lights — the
//! ground truth that `certify` compares renders with besides Mitsuba. Lambertian surfaces in
//! closed form, any other BSDF by adaptive quadrature along the line
//! (`linlight::ground_truth`); variance 0, so that
//! `linlight compare` tests a render (or a Mitsuba reference) against it exactly.

use linlight::ground_truth::closed_form::{unshadowed_pixel_average_with, Method};
use linlight::outputs::{self, ImageFormat};
use linlight_render::xml;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

pub const EXAMPLES: &str = "\
Examples:
  linlight unshadowed references/scenes/glossy-conductor-sharp.xml -D res=64 -o exact.exr
  linlight compare references/mitsuba/glossy-conductor-sharp.exr exact.exr
  linlight unshadowed references/scenes/floor-tube.xml -D res=64 --quadrature -o quad.exr

Supported scenes: one planar shape (rectangle, flat mesh, disk) with any BSDF, any number of
linear lights, hide_emitters set. Anything else is refused (exit 2): the image would lack
shadows or the visible lines.";

#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Scene file (Mitsuba 3 XML).
    scene: PathBuf,
    /// Override a `$name` default of the scene file (repeatable; every NAME must be used once).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    define: Vec<String>,
    /// Film positions per pixel side (an s×s midpoint rule over the pixel's area, box filter).
    #[arg(long, default_value_t = 8)]
    subsamples: u32,
    /// Quadrature along the line also on Lambertian surfaces (instead of the closed form).
    #[arg(long)]
    quadrature: bool,
    /// Output image (.exr: mean, variance 0).
    #[arg(short = 'o', long, default_value = "unshadowed.exr")]
    out: PathBuf,
    /// Worker threads [default: all cores; at most 4 per core, or 64].
    #[arg(short = 't', long)]
    threads: Option<usize>,
    /// No summary.
    #[arg(short = 'q', long)]
    quiet: bool,
}

fn usage_error(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight unshadowed: {msg}");
    ExitCode::from(2)
}

pub fn run(args: Args) -> ExitCode {
    let mut overrides = Vec::new();
    for d in &args.define {
        match d.split_once('=') {
            Some((k, v)) if !k.is_empty() => overrides.push((k.to_string(), v.to_string())),
            _ => return usage_error(format!("-D expects NAME=VALUE, got '{d}'")),
        }
    }
    if args.subsamples == 0 {
        return usage_error("--subsamples must be at least 1");
    }
    if let Err(e) = outputs::check_not_input(&args.out, &[("scene file", &args.scene)])
        .and_then(|()| match ImageFormat::from_path(&args.out) {
            Ok(ImageFormat::Exr) => Ok(()),
            _ => Err(format!(
                "--out {} must be an .exr file (the image is compared, not viewed)",
                args.out.display()
            )),
        })
        .and_then(|()| outputs::check_writable(&args.out))
    {
        return usage_error(e);
    }
    let scene = match xml::load_scene(&args.scene, &overrides) {
        Ok(s) => s,
        Err(e) => return usage_error(e),
    };
    let pool = match outputs::thread_pool(args.threads) {
        Ok(p) => p,
        Err(e) => return usage_error(e),
    };
    let method = if args.quadrature {
        Method::Quadrature
    } else {
        Method::Auto
    };
    let started = Instant::now();
    let image =
        match pool.install(|| unshadowed_pixel_average_with(&scene, args.subsamples, method)) {
            Ok(i) => i,
            Err(e) => return usage_error(format!("{}: {e}", args.scene.display())),
        };
    if let Err(e) = image.write(&args.out) {
        return usage_error(format!("cannot write {}: {e}", args.out.display()));
    }
    let unconverged = image
        .meta
        .extra
        .get("quadrature_unconverged")
        .map_or(0, |n| n.parse::<u64>().unwrap_or(0));
    if unconverged > 0 {
        eprintln!(
            "warning: {unconverged} line integrals missed their error target (see \
             linlight::ground_truth::line_quadrature)"
        );
    }
    if !args.quiet {
        println!(
            "wrote {} ({}×{} px, {}, {}×{} film positions per pixel) in {:.1} s",
            args.out.display(),
            image.width,
            image.height,
            image.meta.renderer,
            args.subsamples,
            args.subsamples,
            started.elapsed().as_secs_f64()
        );
    }
    ExitCode::SUCCESS
}
