//! `linlight check SCENE.xml`: load a scene without rendering it and say what of it linlight
//! renders, what it refuses (every refusal, in file order, with file:line:col and what to write
//! instead) and what it warns about. Exit 0 when the scene loads (warnings or not), 2 when
//! anything is refused — the same scene `linlight render` refuses.

use linlight_render::scene::{Bsdf, Geometry, Scene};
use linlight_render::xml::check_scene;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
#[command(after_help = "\
Examples:
  linlight check scene.xml
  linlight check scene.xml -D res=64      # with an override, as render takes it

What each Mitsuba plugin and property becomes is listed in docs/scene-support.md.
Exit codes: 0 the scene loads (it may have warnings), 2 something is refused or unreadable.")]
pub struct Args {
    /// Scene file (Mitsuba 3 XML).
    scene: PathBuf,
    /// Override a `$name` default of the scene file (repeatable), as `linlight render -D`.
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    define: Vec<String>,
}

fn bsdf_name(b: &Bsdf) -> &'static str {
    match b {
        Bsdf::Diffuse { .. } => "diffuse",
        Bsdf::RoughConductor(_) => "roughconductor",
        Bsdf::Principled(_) => "principled",
        Bsdf::Blend(_) => "blendbsdf",
        Bsdf::TwoSided(_) => "twosided",
    }
}

/// The lines of "supported": what the renderer will draw.
pub fn supported(scene: &Scene) -> Vec<String> {
    let s = &scene.sensor;
    let f = &s.film;
    let crop = f.crop.map_or_else(String::new, |c| {
        format!(
            ", crop {}×{} at ({}, {})",
            c.width, c.height, c.offset_x, c.offset_y
        )
    });
    let mut out = vec![
        format!(
            "sensor perspective, film {}×{} px{crop}, sampler independent {} spp, seed {}",
            f.width, f.height, s.sample_count, s.seed
        ),
        format!(
            "integrator direct ({} emitter sample(s){})",
            scene.integrator.emitter_samples,
            if scene.integrator.hide_emitters {
                ", hide_emitters"
            } else {
                ""
            }
        ),
    ];
    let mut kinds: Vec<(String, usize)> = Vec::new();
    for sh in &scene.shapes {
        let g = match &sh.geometry {
            Geometry::Mesh { indices, .. } => format!("mesh ({} triangles)", indices.len()),
            Geometry::Sphere { .. } => "sphere".into(),
            Geometry::Disk { .. } => "disk".into(),
            Geometry::Cylinder { .. } => "cylinder".into(),
        };
        let k = format!("{g}, {}", bsdf_name(&sh.bsdf));
        match kinds.iter_mut().find(|(n, _)| *n == k) {
            Some((_, c)) => *c += 1,
            None => kinds.push((k, 1)),
        }
    }
    for (k, c) in kinds {
        out.push(format!("{c} × shape {k}"));
    }
    for l in &scene.lights {
        out.push(format!(
            "linear light at {}: from {:?} to {:?}, radius {}, K = radiance × radius = {:?}",
            l.location, l.begin, l.end, l.radius, l.radiance_times_radius
        ));
    }
    out
}

pub fn run(args: Args) -> ExitCode {
    let mut overrides = Vec::new();
    for d in &args.define {
        match d.split_once('=') {
            Some((n, v)) if !n.is_empty() => overrides.push((n.to_string(), v.to_string())),
            _ => {
                eprintln!("linlight check: -D expects NAME=VALUE, got '{d}'");
                return ExitCode::from(2);
            }
        }
    }
    let c = check_scene(&args.scene, &overrides);
    let verdict = if c.errors.is_empty() {
        "loads"
    } else {
        "REFUSED"
    };
    let mut out = format!("{}: {verdict}\n", args.scene.display());
    if let Some(scene) = &c.scene {
        out += "supported:\n";
        for l in supported(scene) {
            out += &format!("  {l}\n");
        }
    }
    if !c.errors.is_empty() {
        out += &format!("refused ({}, in file order):\n", c.errors.len());
        for e in &c.errors {
            out += &format!("  {e}\n");
        }
    }
    if !c.warnings.is_empty() {
        out += &format!("warned ({}):\n", c.warnings.len());
        for w in &c.warnings {
            out += &format!("  {w}\n");
        }
    }
    // A closed pipe (`| head`) is not an error of the check.
    let _ = std::io::Write::write_all(&mut std::io::stdout(), out.as_bytes());
    if c.errors.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    }
}
