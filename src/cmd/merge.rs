//! `linlight merge A.exr B.exr … --out M.exr`: combine independent mean + variance images of one
//! scene (several runs or machines) into one, as `linlight::merge` describes. Exit 0 on success,
//! 2 for unusable input (unreadable, incompatible or dependent images, bad output path).

use linlight::merge::{check_compatible, merge};
use linlight::outputs::{self, ImageFormat};
use linlight_imagefile::Image;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args)]
#[command(after_help = "\
Examples:
  linlight render scene.xml --seed 1 --passes 16 -o a.exr   # on one machine
  linlight render scene.xml --seed 2 --passes 16 -o b.exr   # on another
  linlight merge a.exr b.exr -o ab.exr                      # = 32 passes, dof 31

Images with passes of equal size merge into exactly the image of all their passes; others are
weighted by their sample counts (Welch–Satterthwaite dof). Images of different scenes,
techniques, overrides or sizes, or with the same seed, are refused.")]
pub struct Args {
    /// Images to merge (at least two).
    #[arg(required = true, num_args = 2..)]
    images: Vec<PathBuf>,
    /// Merged image (.exr).
    #[arg(short = 'o', long)]
    out: PathBuf,
    /// No summary line.
    #[arg(short = 'q', long)]
    quiet: bool,
    #[command(flatten)]
    memory: super::MemoryLimit,
}

fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight merge: {msg}");
    ExitCode::from(2)
}

pub fn run(args: Args) -> ExitCode {
    if ImageFormat::from_path(&args.out) != Ok(ImageFormat::Exr) {
        return unusable(format!(
            "--out {} must be an .exr file (the merged mean and variance)",
            args.out.display()
        ));
    }
    let inputs: Vec<(&str, &Path)> = args.images.iter().map(|p| ("input", p.as_path())).collect();
    if let Err(e) = outputs::check_not_input(&args.out, &inputs) {
        return unusable(e);
    }
    if let Err(e) = outputs::check_writable(&args.out) {
        return unusable(e);
    }
    let limit = match args.memory.bytes() {
        Ok((bytes, _)) => bytes,
        Err(e) => return unusable(e),
    };
    let mut images = Vec::new();
    for p in &args.images {
        match Image::read_within(p, limit) {
            Ok(i) => images.push(i),
            Err(e) => return unusable(e),
        }
        if let Some(note) = linlight_imagefile::checksum_note(p) {
            eprintln!("{note}");
        }
    }
    let names: Vec<String> = args
        .images
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let refs: Vec<&Image> = images.iter().collect();
    if let Err(e) = check_compatible(&refs, &names) {
        return unusable(e);
    }
    let mut merged = match merge(&refs) {
        Ok(m) => m,
        Err(e) => return unusable(e),
    };
    merged
        .meta
        .extra
        .insert("merged_from".into(), outputs::file_names(&args.images));
    if let Err(e) = merged.write(&args.out) {
        return unusable(e);
    }
    if !args.quiet {
        eprintln!(
            "wrote {} ({} images, {} spp, {} pass(es), dof {})",
            args.out.display(),
            images.len(),
            merged.meta.spp,
            merged.meta.passes,
            merged.meta.dof
        );
    }
    ExitCode::SUCCESS
}
