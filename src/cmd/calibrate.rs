//! `linlight calibrate`: false-alarm rate and power of `compare` on real renders (see
//! `linlight::calibrate` and docs/statistics.md). Exit 0 when every false-alarm rate is
//! compatible with ≤ α (its 95 % interval starts at or below α), 1 otherwise, 2 unusable input.

use indicatif::{ProgressBar, ProgressStyle};
use linlight::calibrate::{self, markdown, Options};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use linlight::outputs::check_writable;

#[derive(clap::Args)]
#[command(after_help = "Examples:
  linlight calibrate                       # K = 200 pairs per family, 24×24 films
  linlight calibrate --pairs 20            # a quick look
  linlight calibrate --families occluded --json calibration.json")]
pub struct Args {
    /// Seed pairs per family.
    #[arg(long, default_value_t = 200)]
    pairs: usize,
    /// Film edge in pixels (the scenes' `res`).
    #[arg(long, default_value_t = 24)]
    res: u32,
    /// Comma-separated families [default: all].
    #[arg(long, value_delimiter = ',')]
    families: Vec<String>,
    /// Family-wise α of each comparison.
    #[arg(long, default_value_t = 0.01)]
    alpha: f64,
    /// Also write the full report as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// Project root holding references/scenes [default: the current directory].
    #[arg(long, value_name = "DIR", default_value = ".")]
    root: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight calibrate: {msg}");
    ExitCode::from(2)
}

pub fn run(args: Args) -> ExitCode {
    if let Some(path) = &args.json {
        if let Err(e) = check_writable(path) {
            return unusable(e);
        }
    }
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return unusable(format!("--alpha must lie in (0, 1), is {}", args.alpha));
    }
    let mut opts = Options::new(&args.root);
    opts.pairs = args.pairs;
    opts.res = args.res;
    opts.families = args.families.clone();
    opts.compare.alpha = args.alpha;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = args.threads {
        if t == 0 {
            return unusable("--threads must be at least 1");
        }
        pool = pool.num_threads(t);
    }
    let pool = match pool.build() {
        Ok(p) => p,
        Err(e) => return unusable(format!("cannot start worker threads: {e}")),
    };
    let bar = if !args.quiet && std::io::stderr().is_terminal() {
        ProgressBar::new(0)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:30} {pos}/{len} pairs {elapsed_precise} eta {eta} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let progress = |family: &str, done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        bar.set_message(family.to_string());
    };
    let result = pool.install(|| calibrate::run(&opts, &progress));
    bar.finish_and_clear();
    let report = match result {
        Ok(r) => r,
        Err(e) => return unusable(e),
    };
    println!(
        "calibration of compare (α = {}, δ = ±{}%): {} seed pairs per family, {}×{} films, \
         reference {} passes × {} spp; {:.0} s on {} threads",
        opts.compare.alpha,
        100.0 * opts.compare.tolerance,
        opts.pairs,
        opts.res,
        opts.res,
        opts.reference_passes,
        opts.reference_spp,
        report.seconds,
        report.threads
    );
    print!("{}", markdown(&report));
    if let Some(path) = &args.json {
        let written = serde_json::to_string_pretty(&report)
            .map_err(|e| e.to_string())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
            .and_then(|t| linlight::outputs::write_file(path, t + "\n"));
        if let Err(e) = written {
            return unusable(e);
        }
    }
    let calibrated = report
        .families
        .iter()
        .flat_map(|f| &f.rows)
        .all(|r| r.different.ci95[0] <= opts.compare.alpha);
    if calibrated {
        ExitCode::SUCCESS
    } else {
        eprintln!("linlight calibrate: a false-alarm rate is significantly above α");
        ExitCode::from(1)
    }
}
