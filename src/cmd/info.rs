//! `linlight info IMAGE.exr`: what an image of the shared format holds (in the spirit of pbrt's
//! `imgtool info`): its header, per-channel image mean ± standard error, and counts of the pixels
//! that need attention. Exit 0 for a valid image, 1 when it is not a valid image of the shared
//! format (NaN/inf values, negative variances, no `dof`, or a plain RGB EXR without variance
//! channels: a check failed), 2 when it cannot be read.

use linlight_imagefile::{Image, MEAN_CHANNELS};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
#[command(
    after_help = "Examples:\n  linlight info render.exr\n  linlight info references/mitsuba/floor-tube.exr --json\n\nExit codes: 0 a valid image of the shared format; 1 not a valid one (NaN/inf values,\nnegative variances, no dof, or a plain RGB EXR without var.* channels: make one with\n`linlight stack`); 2 the file cannot be read."
)]
pub struct Args {
    /// Image file (EXR with R, G, B, var.R, var.G, var.B).
    image: PathBuf,
    /// Print the same as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    memory: super::MemoryLimit,
}

/// Per channel: the image mean (average over pixels) and its standard error √(Σ var)/N, with
/// the pixel range of the means.
#[derive(Debug, Serialize)]
pub struct ChannelStats {
    pub channel: &'static str,
    pub mean: f64,
    pub standard_error: f64,
    pub min: f64,
    pub max: f64,
}

/// Pixels (any channel) with a property worth knowing.
#[derive(Debug, Default, Serialize)]
pub struct PixelCounts {
    pub pixels: usize,
    pub nan: usize,
    pub infinite: usize,
    pub negative_mean: usize,
    pub negative_variance: usize,
    pub zero_variance: usize,
}

#[derive(Debug, Serialize)]
pub struct Info {
    pub file: PathBuf,
    pub width: usize,
    pub height: usize,
    /// Every header attribute, by name.
    pub header: Vec<(String, String)>,
    pub channels: Vec<ChannelStats>,
    pub counts: PixelCounts,
    /// Why the file is not a valid image of the shared format (None: it is).
    pub problem: Option<String>,
}

pub fn info(path: PathBuf, img: &Image) -> Info {
    let m = &img.meta;
    let mut header = vec![
        ("dof".to_string(), m.dof.to_string()),
        ("spp".to_string(), m.spp.to_string()),
        ("passes".to_string(), m.passes.to_string()),
        ("renderer".to_string(), m.renderer.clone()),
        ("scene_sha256".to_string(), m.scene_sha256.clone()),
    ];
    header.extend(m.extra.iter().map(|(k, v)| (k.clone(), v.clone())));
    let n = img.mean.len();
    let channels = (0..3)
        .map(|c| {
            let finite = img
                .mean
                .iter()
                .map(|p| p[c] as f64)
                .filter(|x| x.is_finite());
            let (mut sum, mut min, mut max) = (0.0, f64::INFINITY, f64::NEG_INFINITY);
            for x in finite {
                sum += x;
                min = min.min(x);
                max = max.max(x);
            }
            let var: f64 = img.var.iter().map(|v| v[c] as f64).sum();
            ChannelStats {
                channel: MEAN_CHANNELS[c],
                mean: sum / n as f64,
                standard_error: var.sqrt() / n as f64,
                min,
                max,
            }
        })
        .collect();
    let mut counts = PixelCounts {
        pixels: n,
        ..Default::default()
    };
    for (mean, var) in img.mean.iter().zip(&img.var) {
        let all = mean.iter().chain(var);
        counts.nan += usize::from(all.clone().any(|x| x.is_nan()));
        counts.infinite += usize::from(all.clone().any(|x| x.is_infinite()));
        counts.negative_mean += usize::from(mean.iter().any(|&x| x < 0.0));
        counts.negative_variance += usize::from(var.iter().any(|&x| x < 0.0));
        counts.zero_variance += usize::from(var.iter().all(|&x| x == 0.0));
    }
    let problem = if m.dof.is_nan() {
        Some("missing header attribute dof".to_string())
    } else {
        img.validate().err().map(|e| e.to_string())
    };
    Info {
        file: path,
        width: img.width,
        height: img.height,
        header,
        channels,
        counts,
        problem,
    }
}

pub fn text(i: &Info) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {}×{} px ({} pixels)",
        i.file.display(),
        i.width,
        i.height,
        i.counts.pixels
    );
    let width = i.header.iter().map(|(k, _)| k.len()).max().unwrap_or(0);
    for (k, v) in &i.header {
        let _ = writeln!(s, "  {k:<width$}  {v}");
    }
    let _ = writeln!(
        s,
        "channel  image mean ± standard error        pixel min     pixel max"
    );
    for c in &i.channels {
        let rel = if c.mean != 0.0 {
            format!("({:.3}%)", 100.0 * c.standard_error / c.mean.abs())
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "{:<8} {:>12.6e} ± {:<10.3e} {:<9} {:>12.6e} {:>12.6e}",
            c.channel, c.mean, c.standard_error, rel, c.min, c.max
        );
    }
    let c = &i.counts;
    let _ = writeln!(
        s,
        "pixels: {} NaN, {} infinite, {} negative mean, {} negative variance, {} zero variance \
         (of {})",
        c.nan, c.infinite, c.negative_mean, c.negative_variance, c.zero_variance, c.pixels
    );
    if let Some(p) = &i.problem {
        let _ = writeln!(s, "NOT a valid image of the shared format: {p}");
    }
    s
}

pub fn run(args: Args) -> ExitCode {
    let limit = match args.memory.bytes() {
        Ok((bytes, _)) => bytes,
        Err(e) => {
            eprintln!("linlight info: {e}");
            return ExitCode::from(2);
        }
    };
    let img = match Image::read_unchecked_within(&args.image, limit) {
        Ok(i) => i,
        Err(e) => {
            // A readable plain RGB EXR (another renderer's) is an image, not of the shared
            // format: say so, and how to make one.
            if let Ok(p) = super::stack::read_plain(&args.image, limit) {
                println!(
                    "{}: {}×{} px plain RGB image\nNOT a valid image of the shared format: no \
                     variance channels (var.R, var.G, var.B); make one from N ≥ 2 independent \
                     renders with `linlight stack a.exr b.exr … -o out.exr`",
                    args.image.display(),
                    p.width,
                    p.height
                );
                return ExitCode::from(1);
            }
            eprintln!("linlight info: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(note) = linlight_imagefile::checksum_note(&args.image) {
        eprintln!("{note}");
    }
    let i = info(args.image.clone(), &img);
    if args.json {
        match serde_json::to_string_pretty(&i) {
            Ok(t) => println!("{t}"),
            Err(e) => {
                eprintln!("linlight info: cannot serialise: {e}");
                return ExitCode::from(2);
            }
        }
    } else {
        print!("{}", text(&i));
    }
    if i.problem.is_some() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}
