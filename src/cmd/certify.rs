//! `linlight certify`: the sampler suite plus every unbiased technique on every scene against the
//! Mitsuba references (see `linlight::certify`). Exit 0 = everything consistent, 1 = something
//! failed, 2 = unusable input (missing or stale reference, glob matching nothing, bad scene),
//! 3 = nothing failed but a comparison is inconclusive (too noisy to show equivalence).

use indicatif::{ProgressBar, ProgressStyle};
use linlight::certify::budget::BudgetRule;
use linlight::certify::matrix::ExactTubes;
use linlight::certify::shard::{self, Shard};
use linlight::certify::{self, report, report_html, Event, Options, Oracle, Report, Subject};
use linlight::outputs;
use linlight_render::Method;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;

pub const AFTER_HELP: &str = "\
Examples:
  linlight certify                          everything: sampler suite + every scene × technique
                                            (12–17 CPU-minutes, 6.5–9 min on 2 quiet cores)
  linlight certify --full                   the exhaustive budget (as precise as the reference
                                            in 99 % of the pixels; 5× the samples and more)
  linlight certify --scenes 'floor-*' --techniques projected-solid-angle,li2018
  linlight certify --scenes 'finite-tube-*' --techniques exact:projected:mis=off,exact:gamito
                                            the finite-tube family (exact tubes) with two
                                            of its techniques
  linlight certify --shard 1/4 --report-dir shard-1   one part of a CI matrix (1/4 … 4/4)
  linlight certify --merge shard-*/report.json        one verdict from all parts
  linlight certify --quiet --json summary.json
  linlight certify --scenes-dir references/generated --scenes many-meshes --no-sampler-suite
                                            a large generated scene (scripts/make-scenes first;
                                            docs/generated-scenes.md)

Budgets: docs/budget.md. Sharding and a CI matrix: docs/ci.md. Exit codes: docs/exit-codes.md.";

/// `--scenes-dir`'s default: the committed scenes (with the finite-tube family beside them).
const DEFAULT_SCENES_DIR: &str = "references/scenes";

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum OracleArg {
    /// The committed references/mitsuba/<scene>.exr (no Mitsuba needed).
    Committed,
    /// Render the Mitsuba side now with scripts/harness (needs scripts/setup-oracle).
    Live,
}

#[derive(clap::Args)]
pub struct Args {
    /// Also write the full report as JSON to FILE (report.json is always in the report dir).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Directory for report.md, report.json, heat maps and renders.
    #[arg(long, value_name = "DIR", default_value = "certify-report")]
    report_dir: PathBuf,
    /// Scenes to certify: wildcards on the scene name, file name or path, comma-separated
    /// (e.g. 'floor-*' or 'floor-tube,glossy-*').
    #[arg(long, value_name = "GLOB", default_value = "*")]
    scenes: String,
    /// Source of the Mitsuba images.
    #[arg(long, value_enum, default_value = "committed")]
    oracle: OracleArg,
    /// Comma-separated methods: technique names, `ltc`, `mis` (clamped optimal, v = 0.5) or
    /// `mis:HEURISTIC` (balance, power, weighted, clamped-optimal=v); on the finite-tube scenes
    /// `exact:T[:mis=balance|off]` (T: projected, ltc, solid-angle, gamito, area) [default:
    /// every unbiased technique; on glossy scenes also ltc and mis with every heuristic, v in
    /// {0, 0.5, 1}; on the finite-tube scenes every T but ltc with MIS and projected without,
    /// on the glossy one also ltc with MIS].
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    techniques: Vec<String>,
    /// Worker threads [default: all cores; at most 4 per core, or 64].
    #[arg(short = 't', long)]
    threads: Option<usize>,
    /// Today's exhaustive budget: every render at least as precise as the reference in 99 % of
    /// its pixels (docs/budget.md). The default budget gives the tests their stated power at a
    /// fraction of the samples.
    #[arg(long)]
    full: bool,
    /// Run only part i of N of the scene × technique list (round robin, 1 ≤ i ≤ N); part 1 also
    /// runs the sampler suite. Every comparison keeps the level of the full run; join the parts'
    /// report.json with --merge (docs/ci.md).
    #[arg(long, value_name = "i/N", conflicts_with = "merge")]
    shard: Option<Shard>,
    /// Join the JSON reports of all shards of one certification into one report and verdict
    /// (renders nothing). Refuses missing, overlapping or mismatched shards (exit 2).
    #[arg(long, value_name = "JSON", num_args = 1..)]
    merge: Vec<PathBuf>,
    /// Skip the sampler chi-square suite (image comparisons only).
    #[arg(long)]
    no_sampler_suite: bool,
    /// Skip the shader kernels' certification (`linlight samplers --backend gpu`), which runs
    /// in a build with `--features gpu` where wgpu finds an adapter; the report says it was
    /// skipped, and why, in every case.
    #[arg(long)]
    no_gpu_kernels: bool,
    /// No progress bar and no per-comparison lines (the summary is still printed).
    #[arg(short = 'q', long)]
    quiet: bool,
    /// Project root holding references/ and scripts/ [default: the current directory].
    #[arg(long, value_name = "DIR", default_value = ".")]
    root: PathBuf,
    /// Directory of the scenes (`*.xml`), relative to --root; each needs its reference
    /// references/mitsuba/<scene>.exr. By default also the finite-tube family
    /// (references/finite-tubes, rendered with exact tubes; that directory itself is refused:
    /// --scenes 'finite-tube-*' selects it); another DIR is certified alone, as a family of its
    /// own: references/generated holds the large generated scenes (scripts/make-scenes first;
    /// docs/generated-scenes.md).
    #[arg(long, value_name = "DIR", default_value = DEFAULT_SCENES_DIR)]
    scenes_dir: PathBuf,
}

fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight certify: {msg}");
    ExitCode::from(2)
}

pub fn run(args: Args) -> ExitCode {
    if !args.merge.is_empty() {
        return merge(&args);
    }
    let (methods, tubes) = match parse_techniques(&args.techniques) {
        Ok(parsed) => parsed,
        Err(e) => return unusable(e),
    };
    // No --techniques: each scene's default subjects (certify::matrix).
    let subjects: Vec<&dyn Subject> = methods
        .iter()
        .map(|m| m as &dyn Subject)
        .chain(tubes.iter().map(|t| t as &dyn Subject))
        .collect();
    if let Err(e) = check_scenes_dir(&args) {
        return unusable(e);
    }
    let opts = options(&args, &methods);
    let pool = match outputs::thread_pool(args.threads) {
        Ok(p) => p,
        Err(e) => return unusable(e),
    };
    if let Err(e) = check_outputs(&args) {
        return unusable(e);
    }
    let progress = Progress::new(args.quiet);
    let events = |e: Event| progress.event(e);
    let result = pool.install(|| {
        if subjects.is_empty() {
            certify::run_default(&opts, &events)
        } else {
            certify::run(&opts, &subjects, &events)
        }
    });
    progress.bar.finish_and_clear();
    let report = match result {
        Ok(r) => r,
        Err(e) => return unusable(e),
    };
    if !args.quiet {
        println!();
    }
    finish(&args, &report)
}

/// `--techniques`: the line methods and the exact-tube subjects; an error for an unknown name
/// or a technique biased by design.
fn parse_techniques(names: &[String]) -> Result<(Vec<Method>, Vec<ExactTubes>), String> {
    let mut methods: Vec<Method> = Vec::new();
    let mut tubes: Vec<ExactTubes> = Vec::new();
    for name in names {
        if name.trim().starts_with("exact:") {
            tubes.push(name.trim().parse::<ExactTubes>()?);
            continue;
        }
        match name.trim().parse::<Method>()? {
            m if !m.is_unbiased() => {
                return Err(format!(
                    "the {m} technique is biased by design and is not certified"
                ))
            }
            m => methods.push(m),
        }
    }
    Ok((methods, tubes))
}

/// `--scenes-dir` naming the finite-tube family's directory: refused with the way to certify
/// it. Another DIR is certified alone with the line techniques, and these scenes' references
/// are exact tubes (`certify::scenes::FINITE_TUBES_DIR`).
fn check_scenes_dir(args: &Args) -> Result<(), String> {
    let finite = certify::scenes::FINITE_TUBES_DIR;
    let same = |a: PathBuf, b: PathBuf| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same(args.root.join(&args.scenes_dir), args.root.join(finite)) {
        return Err(format!(
            "--scenes-dir {} holds the finite-tube family, which certify renders with exact \
             tubes alongside the default scenes: drop --scenes-dir (and add --scenes \
             'finite-tube-*' to certify only them)",
            args.scenes_dir.display()
        ));
    }
    Ok(())
}

/// The certification's options from the command line (`methods`: those of `--techniques`).
fn options(args: &Args, methods: &[Method]) -> Options {
    let mut opts = Options::new(&args.root);
    if args.scenes_dir != std::path::Path::new(DEFAULT_SCENES_DIR) {
        // Another directory is certified alone, as a family of its own.
        opts.finite_scenes_dir = None;
    }
    opts.scenes_dir = args.root.join(&args.scenes_dir);
    opts.scenes = args.scenes.clone();
    // The blue-noise and light-selection renders of the selected techniques (all by default).
    if !args.techniques.is_empty() {
        opts.variant_renders
            .retain(|r| methods.contains(&Method::Technique(r.technique)));
    }
    opts.oracle = match args.oracle {
        OracleArg::Committed => Oracle::Committed,
        OracleArg::Live => Oracle::Live,
    };
    opts.report_dir = Some(args.report_dir.clone());
    opts.sampler_suite = !args.no_sampler_suite;
    opts.gpu_kernels = !args.no_gpu_kernels;
    if args.full {
        opts.budget = BudgetRule::parity();
    }
    opts.shard = args.shard;
    opts
}

/// The outputs are checked before anything runs (the report directory is created here).
fn check_outputs(args: &Args) -> Result<(), String> {
    outputs::check_dir_writable(&args.report_dir)?;
    if let Some(path) = &args.json {
        let inside = ["report.json", "report.md", "report.html"].map(|f| args.report_dir.join(f));
        let named: Vec<(&str, &std::path::Path)> = inside
            .iter()
            .map(|p| ("report written by certify", p.as_path()))
            .collect();
        outputs::check_not_input(path, &named)
            .and_then(|_| outputs::check_writable(path))
            .map_err(|e| format!("--json: {e}"))?;
    }
    Ok(())
}

/// The progress bar (on a terminal, unless `--quiet`) and the lines printed as the run goes.
struct Progress {
    bar: ProgressBar,
    /// The current step's label.
    label: Mutex<String>,
    /// Whether the table's header was printed (before the first row).
    header_printed: Mutex<bool>,
    quiet: bool,
}

impl Progress {
    fn new(quiet: bool) -> Self {
        let bar = if !quiet && std::io::stderr().is_terminal() {
            ProgressBar::new(0)
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed_precise} {wide_msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        Self {
            bar,
            label: Mutex::new(String::new()),
            header_printed: Mutex::new(false),
            quiet,
        }
    }

    fn event(&self, e: Event) {
        let bar = &self.bar;
        match e {
            Event::Plan { steps } => bar.set_length(steps as u64),
            Event::Step { label: l } => {
                if let Ok(mut g) = self.label.lock() {
                    if !g.is_empty() {
                        bar.inc(1);
                    }
                    *g = l.clone();
                }
                bar.set_message(l);
            }
            Event::Tiles { done, total } => {
                if let Ok(g) = self.label.lock() {
                    let pct = 100.0 * done as f64 / total.max(1) as f64;
                    bar.set_message(format!("{} ({pct:.0} %)", *g));
                }
            }
            Event::SuiteDone(s) if !self.quiet => bar.suspend(|| {
                println!(
                    "sampler suite: {} ({:.1} s)",
                    if s.passed { "PASS" } else { "FAIL" },
                    s.elapsed_seconds
                )
            }),
            Event::RowDone(row) if !self.quiet => bar.suspend(|| {
                if let Ok(mut h) = self.header_printed.lock() {
                    if !*h {
                        println!("{}", report::table_header());
                        *h = true;
                    }
                }
                println!("{}", report::row_line(row));
            }),
            Event::SuiteDone(_) | Event::RowDone(_) => {}
        }
    }
}

/// Summary, `--json` and the exit code of a finished (or merged) certification.
fn finish(args: &Args, report: &Report) -> ExitCode {
    print!("{}", report::summary(report));
    println!("report: {}", args.report_dir.join("report.md").display());
    if let Some(path) = &args.json {
        let written = shard::sealed_json(report)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
            .and_then(|t| outputs::write_file(path, t));
        if let Err(e) = written {
            return unusable(e);
        }
    }
    ExitCode::from(report.verdict.exit_code())
}

/// `--merge`: one report from the shards' JSON.
fn merge(args: &Args) -> ExitCode {
    let mut shards = Vec::new();
    for path in &args.merge {
        match shard::read(path) {
            Ok(r) => shards.push((path.clone(), r)),
            Err(e) => return unusable(e),
        }
    }
    let n = shards.len();
    let report = match shard::merge(shards, !args.no_sampler_suite) {
        Ok(r) => r,
        Err(e) => return unusable(e),
    };
    if let Err(e) = outputs::check_dir_writable(&args.report_dir) {
        return unusable(e);
    }
    let inputs: Vec<(&str, &std::path::Path)> = args
        .merge
        .iter()
        .map(|p| ("shard report", p.as_path()))
        .collect();
    for out in ["report.json", "report.md", "report.html"].map(|f| args.report_dir.join(f)) {
        if let Err(e) = outputs::check_not_input(&out, &inputs) {
            return unusable(format!("--report-dir: {e}"));
        }
    }
    if let Some(path) = &args.json {
        if let Err(e) =
            outputs::check_not_input(path, &inputs).and_then(|_| outputs::check_writable(path))
        {
            return unusable(format!("--json: {e}"));
        }
    }
    if let Err(e) = report::write_report(&args.report_dir, &report)
        .and_then(|()| report_html::write(&args.report_dir, &report))
    {
        return unusable(e);
    }
    println!("merged {n} shards: one Šidák correction over the full family, as unsharded");
    finish(args, &report)
}
