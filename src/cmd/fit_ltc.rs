//! `linlight fit-ltc`: fit the GGX LTC table (deterministic, f64) and report its fit error, or
//! (`--check`) re-fit a sample of α columns and compare them with a table file (by default the
//! one compiled into the renderer). Exit 0 = written / consistent, 1 = the check found a
//! mismatch, 2 = bad usage or unusable input.

use indicatif::{ProgressBar, ProgressStyle};
use linlight::outputs;
use linlight_brdf::ltc::fit::{
    check_columns, fit_table, EntryDeviation, FitSettings, FittedEntry, CHECK_BOUNDS,
};
use linlight_brdf::ltc::table::{GgxLtcTable, COMMITTED_PATH};
use linlight_imagefile::input::{read_capped, MAX_BINARY_BYTES};
use linlight_verify::heatmap::{sequential, Rgb8};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

pub const AFTER_HELP: &str = "\
Examples:
  linlight fit-ltc                          fit the 64×64 table to ggx_ltc.bin (+ ggx_ltc-error.png)
  linlight fit-ltc --out crates/brdf/data/ggx_ltc.bin
                                            regenerate the committed table
  linlight fit-ltc --check                  re-fit 4 α columns, compare with the compiled-in table
  linlight fit-ltc --check --table my.bin --columns 0,10,63
  linlight fit-ltc --size 16 --out small.bin --json small.json

Runtime: the full 64×64 fit takes about 40 CPU-seconds, spread over the threads (77–110 s
wall measured on a shared 2-core machine at load 7–11); --check with the default columns about
3 CPU-seconds.
The error E₁ = ∫ |f cos − ρ_s D_LTC| dω / ρ_s (relative L1, in [0, 2]) of every entry is
reported and drawn as a heat map: √α = 0 … 1 left to right, θ_o = 0 … π/2 top to bottom,
8×8 pixels per entry, colour log10 E₁ from 1e-4 (white) to 1 (dark red).";

#[derive(clap::Args)]
pub struct Args {
    /// Write the fitted table to FILE (the format of crates/brdf/data/ggx_ltc.bin).
    #[arg(
        long,
        value_name = "FILE",
        default_value = "ggx_ltc.bin",
        conflicts_with = "check"
    )]
    out: PathBuf,
    /// Heat map of the fit error per entry [default: <out stem>-error.png next to --out].
    #[arg(long, value_name = "PNG", conflicts_with = "check")]
    heatmap: Option<PathBuf>,
    /// Also write every entry (α, θ_o, ρ_s, E₁, parameters, A) as JSON.
    #[arg(long, value_name = "FILE", conflicts_with = "check")]
    json: Option<PathBuf>,
    /// Grid points per axis (the renderer's table has 64).
    #[arg(long, default_value_t = 64, conflicts_with = "check")]
    size: usize,
    /// Instead of fitting everything: re-fit the α columns of --columns with the table's own
    /// settings and compare them with --table.
    #[arg(long)]
    check: bool,
    /// Table to compare with in --check [default: the one compiled in, crates/brdf/data/ggx_ltc.bin].
    #[arg(long, value_name = "FILE", requires = "check")]
    table: Option<PathBuf>,
    /// √α columns re-fitted by --check (each column is all θ_o of one α) [default: 0, N/3, 2N/3, N−1].
    #[arg(long, value_name = "LIST", value_delimiter = ',', requires = "check")]
    columns: Vec<usize>,
    /// Worker threads [default: all cores]; the result does not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight fit-ltc: {msg}");
    ExitCode::from(2)
}

fn progress_bar(quiet: bool, total: usize) -> ProgressBar {
    let bar = if !quiet && std::io::stderr().is_terminal() {
        ProgressBar::new(total as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} entries {elapsed_precise} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

fn default_heatmap(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(|| "ggx_ltc".into(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}-error.png"))
}

/// Colour of E₁ on the log scale of the heat map.
fn error_colour(e: f64) -> [u8; 3] {
    sequential((e.max(1e-4).log10() + 4.0) / 4.0)
}

const CELL: usize = 8;

fn write_heatmap(
    path: &Path,
    size: usize,
    error: impl Fn(usize, usize) -> f64,
) -> Result<(), String> {
    let mut img = Rgb8::filled(size * CELL, size * CELL, [255; 3]);
    for j in 0..size {
        for i in 0..size {
            let c = error_colour(error(i, j));
            for y in 0..CELL {
                for x in 0..CELL {
                    img.set(i * CELL + x, j * CELL + y, c);
                }
            }
        }
    }
    img.write_png(path).map_err(|e| e.to_string())
}

fn entry_json(e: &FittedEntry) -> serde_json::Value {
    let t = e.table_entry();
    serde_json::json!({
        "i_alpha": e.i_alpha, "j_theta": e.j_theta, "alpha": e.alpha, "theta": e.theta,
        "rho_s": e.moments.rho, "error_l1": e.error,
        "average_direction": [e.moments.average.x, e.moments.average.y, e.moments.average.z],
        "m11_m22_m13": e.params, "evaluations": e.evaluations, "converged": e.converged,
        "a_b_c_d_e": [t.a, t.b, t.c, t.d, t.e],
    })
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn print_error_summary(entries: &[FittedEntry]) {
    let mut errors: Vec<f64> = entries.iter().map(|e| e.error).collect();
    errors.sort_by(f64::total_cmp);
    println!(
        "fit error E₁ = ∫|f cos − ρ_s D_LTC| dω / ρ_s over {} entries: median {:.2e}, mean {:.2e}, \
         90 % {:.2e}, 99 % {:.2e}, worst {:.3}",
        entries.len(),
        percentile(&errors, 0.5),
        errors.iter().sum::<f64>() / errors.len() as f64,
        percentile(&errors, 0.9),
        percentile(&errors, 0.99),
        errors[errors.len() - 1]
    );
    let mut worst: Vec<&FittedEntry> = entries.iter().collect();
    worst.sort_by(|a, b| b.error.total_cmp(&a.error));
    println!("worst entries:");
    for e in worst.iter().take(8) {
        println!(
            "  √α {:.3} (α {:.4}), θ_o {:.3} rad ({:.2}°): E₁ {:.3}, ρ_s {:.4}",
            e.alpha.sqrt(),
            e.alpha,
            e.theta,
            e.theta.to_degrees(),
            e.error,
            e.moments.rho
        );
    }
    let not_converged = entries.iter().filter(|e| !e.converged).count();
    let evaluations: Vec<usize> = entries.iter().map(|e| e.evaluations).collect();
    println!(
        "Nelder–Mead: {} of {} entries hit the evaluation budget; evaluations per entry {}–{}",
        not_converged,
        entries.len(),
        evaluations.iter().min().unwrap_or(&0),
        evaluations.iter().max().unwrap_or(&0)
    );
}

fn write_json(path: &Path, settings: &FitSettings, entries: &[FittedEntry]) -> Result<(), String> {
    let doc = serde_json::json!({
        "error_measure": "relative L1: integral |f cos - rho_s D_LTC| / rho_s",
        "settings": {
            "size": settings.size, "fit_samples": settings.fit_samples,
            "albedo_samples": settings.albedo_samples, "error_samples": settings.error_samples,
            "max_evaluations": settings.max_evaluations,
        },
        "entries": entries.iter().map(entry_json).collect::<Vec<_>>(),
    });
    let text = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
    outputs::write_file(path, text + "\n")
}

pub fn run(args: Args) -> ExitCode {
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
    if args.check {
        pool.install(|| check(&args))
    } else {
        pool.install(|| fit(&args))
    }
}

fn fit(args: &Args) -> ExitCode {
    if !(2..=1024).contains(&args.size) {
        return unusable(format!("--size must be in 2..=1024 (got {})", args.size));
    }
    let settings = FitSettings {
        size: args.size,
        ..FitSettings::default()
    };
    let heatmap = args
        .heatmap
        .clone()
        .unwrap_or_else(|| default_heatmap(&args.out));
    // Unusable output paths are reported before the fit, not after it: each writable, none
    // the same file as another (by device and inode), none a FIFO or device.
    let outs: Vec<&Path> = [Some(&args.out), Some(&heatmap), args.json.as_ref()]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect();
    if let Err(e) = outputs::check_distinct(&outs) {
        return unusable(e);
    }
    for path in &outs {
        if let Err(e) = outputs::check_writable(path) {
            return unusable(e);
        }
    }
    let bar = progress_bar(args.quiet, settings.size * settings.size);
    let start = Instant::now();
    let fitted = fit_table(&settings, &|| bar.inc(1));
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let table = fitted.table();
    if let Err(e) = outputs::write_file(&args.out, table.to_bytes()) {
        return unusable(e);
    }
    if let Err(e) = write_heatmap(&heatmap, settings.size, |i, j| fitted.entry(i, j).error) {
        return unusable(format!("cannot write {}: {e}", heatmap.display()));
    }
    if let Some(path) = &args.json {
        if let Err(e) = write_json(path, &settings, &fitted.entries) {
            return unusable(format!("cannot write {}: {e}", path.display()));
        }
    }
    println!(
        "fitted the {n}×{n} GGX LTC table (F ≡ 1, separable Smith) in {seconds:.1} s on {} threads: {}",
        rayon::current_num_threads(),
        args.out.display(),
        n = settings.size
    );
    let rho: Vec<f64> = fitted.entries.iter().map(|e| e.moments.rho).collect();
    println!(
        "ρ_s ∈ [{:.4}, {:.4}]",
        rho.iter().copied().fold(f64::INFINITY, f64::min),
        rho.iter().copied().fold(0.0, f64::max)
    );
    print_error_summary(&fitted.entries);
    println!(
        "heat map: {} (√α → right, θ_o → down, log10 E₁ from 1e-4 white to 1 dark red)",
        heatmap.display()
    );
    let committed = GgxLtcTable::ggx();
    println!(
        "{} the table compiled into linlight ({COMMITTED_PATH})",
        if committed == &table {
            "bit-identical to"
        } else {
            "DIFFERS from"
        }
    );
    ExitCode::SUCCESS
}

fn check(args: &Args) -> ExitCode {
    let (table, source) = match &args.table {
        Some(path) => {
            let bytes = match read_capped(path, MAX_BINARY_BYTES) {
                Ok(b) => b,
                Err(e) => return unusable(e),
            };
            match GgxLtcTable::from_bytes(&bytes) {
                Ok(t) => (t, path.display().to_string()),
                Err(e) => return unusable(format!("{}: {e}", path.display())),
            }
        }
        None => (
            GgxLtcTable::ggx().clone(),
            format!("the compiled-in table ({COMMITTED_PATH})"),
        ),
    };
    let settings = *table.settings();
    let n = settings.size;
    let columns = if args.columns.is_empty() {
        let mut c = vec![0, n / 3, 2 * n / 3, n - 1];
        c.dedup();
        c
    } else {
        args.columns.clone()
    };
    if let Some(bad) = columns.iter().find(|&&i| i >= n) {
        return unusable(format!(
            "--columns: {bad} is outside the table's 0..{}",
            n - 1
        ));
    }
    let lowest = columns.iter().min().copied().unwrap_or(0);
    let bar = progress_bar(args.quiet, (n - lowest) + columns.len() * (n - 1));
    let start = Instant::now();
    let deviations = check_columns(&table, &columns, &|| bar.inc(1));
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();

    let worst = |f: fn(&EntryDeviation) -> f32| deviations.iter().map(f).fold(0.0f32, f32::max);
    let identical = deviations.iter().filter(|d| d.identical()).count();
    let failures: Vec<&EntryDeviation> = deviations
        .iter()
        .filter(|d| !d.within(&CHECK_BOUNDS))
        .collect();
    let count = deviations.len();
    let b = CHECK_BOUNDS;
    println!(
        "re-fitted {count} entries (√α columns {columns:?}, all θ_o) in {seconds:.1} s and compared with {source}"
    );
    println!(
        "bit-identical: {identical}/{count}; largest |ΔA| {:.2e} (bound {:.0e}), |Δρ_s|/ρ_s {:.2e} \
         (bound {:.0e}), |ΔE₁| {:.2e} (bound {:.0e})",
        worst(|d| d.a),
        b.a,
        worst(|d| d.rho_relative),
        b.rho_relative,
        worst(|d| d.error),
        b.error
    );
    if failures.is_empty() {
        println!("PASS");
        ExitCode::SUCCESS
    } else {
        println!("FAIL: {} entries outside the bounds:", failures.len());
        for d in failures.iter().take(20) {
            println!(
                "  (√α column {}, θ_o row {}): |ΔA| {:.2e}, |Δρ_s|/ρ_s {:.2e}, |ΔE₁| {:.2e}; stored {:?}, re-fitted {:?}",
                d.i_alpha, d.j_theta, d.a, d.rho_relative, d.error, d.stored, d.fresh
            );
        }
        ExitCode::from(1)
    }
}
