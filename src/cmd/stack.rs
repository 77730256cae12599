//! `linlight stack a.exr b.exr … -o out.exr`: N independent plain RGB renders of one scene (any
//! renderer, different seeds) → one image of the shared format: per pixel and channel the mean
//! of the N values and the variance of that mean, s²/N with the sample variance s² of the N
//! values (dof = N − 1). The header records N and the SHA-256 of every input file.
//!
//! Refused (exit 2): fewer than two inputs, different sizes, two inputs with identical pixels
//! (the same seed twice: the variance would be zero), non-finite pixels, inputs that already
//! hold a variance (use `linlight merge`), unreadable files.

use linlight::outputs::{self, ImageFormat};
use linlight_imagefile::{Image, Metadata};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args)]
#[command(after_help = "\
Examples (Mitsuba 3 as the other renderer; see docs/your-own-renderer.md):
  for s in 1 2 3 4 5 6 7 8; do mitsuba -m scalar_rgb -D seed=$s -o m$s.exr scene.xml; done
  linlight stack m1.exr m2.exr m3.exr m4.exr m5.exr m6.exr m7.exr m8.exr --scene scene.xml \\
      --spp 256 -o mitsuba.exr
  linlight compare mine.exr mitsuba.exr

Each input is one independent render: same scene and settings, a different seed. The variance
comes from the spread of the N inputs, so more inputs give a better variance estimate
(dof = N − 1); compare needs dof ≥ 1, and 8 or more are advisable.")]
pub struct Args {
    /// Plain RGB EXRs (channels R, G, B; any others are ignored), at least two.
    #[arg(required = true, num_args = 1..)]
    images: Vec<PathBuf>,
    /// Output image (.exr, mean + variance of the mean).
    #[arg(short = 'o', long)]
    out: PathBuf,
    /// The scene the inputs were rendered from: its SHA-256 goes into the header, so that
    /// `compare` checks that both images show the same scene file.
    #[arg(long, value_name = "SCENE.xml")]
    scene: Option<PathBuf>,
    /// Samples per pixel of each input (recorded as spp = N × SPP; compare's sample hints need it).
    #[arg(long, value_name = "SPP")]
    spp: Option<u64>,
    /// The renderer of the inputs, for the header [default: "plain RGB images"].
    #[arg(long, value_name = "NAME")]
    renderer: Option<String>,
    /// No summary line.
    #[arg(short = 'q', long)]
    quiet: bool,
    #[command(flatten)]
    memory: super::MemoryLimit,
}

fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight stack: {msg}");
    ExitCode::from(2)
}

/// One plain input: size, RGB pixels, and the SHA-256 of its file.
pub struct Plain {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<[f32; 3]>,
    pub sha256: String,
}

fn hex(d: impl AsRef<[u8]>) -> String {
    d.as_ref().iter().map(|b| format!("{b:02x}")).collect()
}

/// Reads the R, G, B channels of the first layer that has them, refusing an image that needs more
/// than `max_bytes` of memory.
pub fn read_plain(path: &Path, max_bytes: u64) -> Result<Plain, String> {
    // A regular file whose claimed size fits in it and in memory, before anything is allocated.
    linlight_imagefile::check_claimed_size(path, max_bytes).map_err(|e| e.to_string())?;
    let bytes =
        linlight_imagefile::input::read_capped(path, linlight_imagefile::input::MAX_BINARY_BYTES)?;
    use exr::prelude::{ReadChannels, ReadLayers};
    let sha256 = hex(Sha256::digest(&bytes));
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| format!("{} is not a readable OpenEXR file: {e}", path.display()))?;
    let names: Vec<String> = image
        .layer_data
        .iter()
        .flat_map(|l| l.channel_data.list.iter().map(|c| c.name.to_string()))
        .collect();
    let layer = image
        .layer_data
        .iter()
        .find(|l| {
            ["R", "G", "B"]
                .iter()
                .all(|n| l.channel_data.list.iter().any(|c| c.name.eq(n)))
        })
        .ok_or_else(|| {
            format!(
                "{} has no R, G, B channels (found: {})",
                path.display(),
                names.join(", ")
            )
        })?;
    if names.iter().any(|n| n.starts_with("var.")) {
        return Err(format!(
            "{} already holds a variance (var.* channels): it is an image of the shared format; \
             combine such images with `linlight merge`",
            path.display()
        ));
    }
    let (width, height) = (layer.size.x(), layer.size.y());
    let channel = |n: &str| -> Vec<f32> {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(n))
            .expect("checked above");
        c.sample_data.values_as_f32().collect()
    };
    let (r, g, b) = (channel("R"), channel("G"), channel("B"));
    let rgb: Vec<[f32; 3]> = (0..width * height).map(|i| [r[i], g[i], b[i]]).collect();
    if let Some(i) = rgb.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(format!(
            "{} has a non-finite value at pixel ({}, {}): the mean and variance would not be \
             finite",
            path.display(),
            i % width.max(1),
            i / width.max(1)
        ));
    }
    Ok(Plain {
        width,
        height,
        rgb,
        sha256,
    })
}

/// Mean and variance of the mean of N ≥ 2 plain images of one size (two-pass, in f64), dof
/// N − 1. Refuses images with identical pixels (not independent).
pub fn stack(inputs: &[Plain], names: &[String]) -> Result<Image, String> {
    let n = inputs.len();
    if n < 2 {
        return Err(format!(
            "stacking needs at least two independent renders (got {n}): the variance comes \
             from their spread"
        ));
    }
    let (w, h) = (inputs[0].width, inputs[0].height);
    for (p, name) in inputs.iter().zip(names).skip(1) {
        if (p.width, p.height) != (w, h) {
            return Err(format!(
                "{} is {w}×{h} but {name} is {}×{}",
                names[0], p.width, p.height
            ));
        }
    }
    for i in 0..n {
        for j in i + 1..n {
            if inputs[i].rgb == inputs[j].rgb {
                return Err(format!(
                    "{} and {} have identical pixels: the same seed twice, not independent \
                     renders (the variance would be 0); render again with another seed",
                    names[i], names[j]
                ));
            }
        }
    }
    let mut img = Image::new(w, h);
    for k in 0..w * h {
        for c in 0..3 {
            let mean = inputs.iter().map(|p| p.rgb[k][c] as f64).sum::<f64>() / n as f64;
            let ss: f64 = inputs
                .iter()
                .map(|p| (p.rgb[k][c] as f64 - mean).powi(2))
                .sum();
            img.mean[k][c] = mean as f32;
            img.var[k][c] = (ss / (n - 1) as f64 / n as f64) as f32;
        }
    }
    img.meta = Metadata {
        dof: (n - 1) as f64,
        spp: 0,
        passes: n as u64,
        renderer: "plain RGB images".into(),
        scene_sha256: String::new(),
        extra: Default::default(),
    };
    img.meta
        .extra
        .insert("stacked_images".into(), n.to_string());
    let hashes: Vec<String> = inputs.iter().map(|p| p.sha256.clone()).collect();
    img.meta
        .extra
        .insert("stacked_sha256".into(), hashes.join(";"));
    Ok(img)
}

pub fn run(args: Args) -> ExitCode {
    if ImageFormat::from_path(&args.out) != Ok(ImageFormat::Exr) {
        return unusable(format!(
            "--out {} must be an .exr file (the mean and variance)",
            args.out.display()
        ));
    }
    if args.images.len() < 2 {
        return unusable(format!(
            "stacking needs at least two independent renders (got {}): the variance comes from \
             their spread",
            args.images.len()
        ));
    }
    let mut inputs: Vec<(&str, &Path)> =
        args.images.iter().map(|p| ("input", p.as_path())).collect();
    if let Some(s) = &args.scene {
        inputs.push(("--scene", s.as_path()));
    }
    if let Err(e) = outputs::check_not_input(&args.out, &inputs) {
        return unusable(e);
    }
    if let Err(e) = outputs::check_writable(&args.out) {
        return unusable(e);
    }
    let scene_sha256 = match &args.scene {
        None => String::new(),
        Some(s) => match linlight_imagefile::input::read_capped(
            s,
            linlight_imagefile::input::MAX_TEXT_BYTES,
        ) {
            Ok(b) => hex(Sha256::digest(&b)),
            Err(e) => return unusable(format!("--scene: {e}")),
        },
    };
    let limit = match args.memory.bytes() {
        Ok((bytes, _)) => bytes,
        Err(e) => return unusable(e),
    };
    let mut plain = Vec::new();
    for p in &args.images {
        match read_plain(p, limit) {
            Ok(i) => plain.push(i),
            Err(e) => return unusable(e),
        }
    }
    let names: Vec<String> = args
        .images
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let mut img = match stack(&plain, &names) {
        Ok(i) => i,
        Err(e) => return unusable(e),
    };
    img.meta.scene_sha256 = scene_sha256;
    if let Some(r) = &args.renderer {
        img.meta.renderer = r.clone();
    }
    if let Some(s) = args.spp {
        img.meta.spp = s * plain.len() as u64;
        img.meta.extra.insert("spp_per_pass".into(), s.to_string());
    }
    img.meta
        .extra
        .insert("stacked_from".into(), outputs::file_names(&args.images));
    let dof = img.meta.dof;
    if let Err(e) = img.write(&args.out) {
        return unusable(e);
    }
    if !args.quiet {
        eprintln!(
            "wrote {} (mean and variance of {} plain images, dof {dof}{})",
            args.out.display(),
            plain.len(),
            if args.scene.is_none() {
                "; no --scene: compare will skip its same-scene check"
            } else {
                ""
            }
        );
    }
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plain(v: &[[f32; 3]]) -> Plain {
        Plain {
            width: v.len(),
            height: 1,
            rgb: v.to_vec(),
            sha256: format!("{:?}", v),
        }
    }

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("in{i}.exr")).collect()
    }

    #[test]
    fn mean_and_variance_of_the_mean() {
        let inputs = [
            plain(&[[1.0, 0.0, 2.0], [0.5, 0.5, 0.5]]),
            plain(&[[3.0, 0.0, 2.0], [0.5, 0.5, 0.5]]),
            plain(&[[2.0, 0.0, 5.0], [0.5, 0.5, 0.5]]),
        ];
        let img = stack(&inputs, &names(3)).unwrap();
        assert_eq!(img.mean[0], [2.0, 0.0, 3.0]);
        // s² = ((1−2)² + (3−2)² + 0) / 2 = 1, variance of the mean 1/3; blue: s² = 3, 1.
        assert!((img.var[0][0] - 1.0 / 3.0).abs() < 1e-7);
        assert_eq!(img.var[0][1], 0.0);
        assert!((img.var[0][2] - 1.0).abs() < 1e-7);
        assert_eq!(img.var[1], [0.0; 3]);
        assert_eq!(img.meta.dof, 2.0);
        assert_eq!(img.meta.extra["stacked_images"], "3");
        assert_eq!(img.meta.extra["stacked_sha256"].split(';').count(), 3);
        assert!(img.validate().is_ok());
    }

    #[test]
    fn refusals() {
        let a = plain(&[[1.0; 3]]);
        let b = plain(&[[2.0; 3]]);
        let wide = plain(&[[1.0; 3], [1.0; 3]]);
        let one = stack(&[plain(&[[1.0; 3]])], &names(1)).unwrap_err();
        assert!(one.contains("at least two"), "{one}");
        let size = stack(&[plain(&[[1.0; 3]]), wide], &names(2)).unwrap_err();
        assert!(size.contains("in0.exr is 1×1 but in1.exr is 2×1"), "{size}");
        let same = stack(&[a, b, plain(&[[1.0; 3]])], &names(3)).unwrap_err();
        assert!(
            same.contains("in0.exr and in2.exr have identical pixels"),
            "{same}"
        );
    }
}
