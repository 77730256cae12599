//! `linlight figures`: regenerate every experiment of the paper into one directory (PNGs, SVG
//! plots, CSV/JSON numbers and a self-contained index.html).

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use linlight::figures::{self, Event, Options, FIGURES};
use linlight::outputs;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;

pub const AFTER_HELP: &str = "\
Examples:
  linlight figures                          # publication size into figures/ (tens of minutes)
  linlight figures --quick --out /tmp/figs  # small renders, ~1-3 min on two cores
  linlight figures --only noise,timings     # some figures only

Open <out>/index.html: every figure with a caption stating what it demonstrates, its settings and
the numbers measured in this run; the files behind each figure are linked under it.";

#[derive(clap::Args)]
pub struct Args {
    /// Output directory.
    #[arg(long, default_value = "figures")]
    out: PathBuf,
    /// Comma-separated figure names, of: one-spp, cornell, specular, backward-error, noise, newton,
    /// convergence, timings, tube-radius, tube-sampling [default: all].
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Small resolutions and sample counts (what the test suite runs).
    #[arg(long)]
    quick: bool,
    /// Seed of every render.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(short = 't', long)]
    threads: Option<usize>,
    /// No progress bars.
    #[arg(short = 'q', long)]
    quiet: bool,
    /// Project root holding references/ and scripts/.
    #[arg(long, value_name = "DIR", default_value = ".")]
    root: PathBuf,
}

pub fn run(args: Args) -> ExitCode {
    let usage = |m: String| {
        eprintln!("linlight figures: {m}");
        ExitCode::from(2)
    };
    let only: Vec<String> = args
        .only
        .iter()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect();
    if let Err(e) = figures::select(&only) {
        return usage(e);
    }
    let scenes = args.root.join("references/scenes");
    if !scenes.is_dir() {
        return usage(format!(
            "{} is not a directory: run from the project root or pass --root DIR",
            scenes.display()
        ));
    }
    if let Err(e) = std::fs::create_dir_all(&args.out) {
        return usage(format!("cannot create {}: {e}", args.out.display()));
    }
    if let Err(e) = outputs::check_writable(&args.out.join("index.html")) {
        return usage(e);
    }
    let pool = match outputs::thread_pool(args.threads) {
        Ok(p) => p,
        Err(e) => return usage(e),
    };
    let opts = Options {
        root: args.root.clone(),
        out: args.out.clone(),
        only,
        quick: args.quick,
        seed: args.seed,
    };
    let show = !args.quiet && std::io::stderr().is_terminal();
    let multi = MultiProgress::new();
    if !show {
        multi.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let style =
        ProgressStyle::with_template("{prefix:>16} {bar:30} {percent:>3}% {elapsed_precise} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar());
    let current: Mutex<Option<ProgressBar>> = Mutex::new(None);
    let events = |e: Event| match e {
        Event::Start {
            name,
            title,
            index,
            count,
        } => {
            let bar = multi.add(ProgressBar::new(1000));
            bar.set_style(style.clone());
            bar.set_prefix(format!("{}/{} {name}", index + 1, count));
            bar.set_message(title.to_string());
            *current.lock().unwrap() = Some(bar);
        }
        Event::Progress(f) => {
            if let Some(b) = current.lock().unwrap().as_ref() {
                b.set_position((f * 1000.0) as u64);
            }
        }
        Event::Done { seconds, .. } => {
            if let Some(b) = current.lock().unwrap().take() {
                b.set_position(1000);
                b.finish_with_message(format!("done in {seconds:.1} s"));
            }
        }
    };
    match pool.install(|| figures::run(&opts, &events)) {
        Ok(sections) => {
            if !args.quiet {
                eprintln!(
                    "wrote {} figure(s) of {} to {}",
                    sections.len(),
                    FIGURES.len(),
                    args.out.join("index.html").display()
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("linlight figures: {e}");
            ExitCode::from(1)
        }
    }
}
