//! `linlight backward-error`: worst backward error (in units of ξ) of the projected-solid-angle
//! inversion of technique 8 over its parameter space, per iteration count, in f32 and f64.
use linlight_sampling::backward_error::{sweep, Case, SweepConfig, SweepRow};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// Only this number of Halley iterations (default: 1, 2 and 3).
    #[arg(long)]
    iterations: Option<u32>,
    /// Also write the table (and the worst cases) as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Normal directions swept (uniform in angle, plus three special ones).
    #[arg(long, default_value_t = 64)]
    normals: u32,
    /// Stratified uniform ξ per sub-interval (plus the guard-band points).
    #[arg(long, default_value_t = 1024)]
    xi_per_interval: u32,
    /// Seed of the ξ jitter.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Values quoted in docs/measures.md (technique 8), for the comparison column.
fn paper_value(iterations: u32) -> &'static str {
    match iterations {
        1 => "1.5e-2 (f64 re-derivation)",
        2 => "1.6e-5 paper; 7e-6 excl. / 1.7e-5 incl. guard (f64 re-derivation)",
        3 => "< 1e-9 (f64 re-derivation)",
        _ => "-",
    }
}

fn case_json(c: &Case) -> serde_json::Value {
    json!({
        "psi": c.psi, "n_s": c.psi.sin(), "n_t": c.psi.cos(),
        "phi_begin": c.phi_begin, "width": c.width, "xi": c.xi,
    })
}

fn row_json(r: &SweepRow) -> serde_json::Value {
    json!({
        "iterations": r.iterations,
        "precision": r.precision.name(),
        "worst_excluding_guard": r.worst_outside_guard,
        "worst_including_guard": r.worst_including_guard,
        "worst_excluding_guard_width_ge_1e-2": r.worst_wide_intervals,
        "worst_excluding_guard_near_ends": r.worst_near_ends,
        "worst_case_excluding_guard": case_json(&r.worst_case),
        "worst_case_including_guard": case_json(&r.worst_case_including_guard),
        "problems": r.samples,
        "paper": paper_value(r.iterations),
    })
}

pub fn run(args: Args) -> ExitCode {
    let cfg = match sweep_config(&args) {
        Ok(cfg) => cfg,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let rows = sweep(&cfg);
    print_table(&cfg, &rows);
    if let Some(path) = &args.json {
        if let Err(e) = write_json(path, &cfg, &rows) {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    }
    ExitCode::SUCCESS
}

/// The sweep the arguments ask for; an unusable `--json` is reported here, before the sweep
/// runs, not after it.
fn sweep_config(args: &Args) -> Result<SweepConfig, String> {
    if let Some(path) = &args.json {
        linlight::outputs::check_writable(path).map_err(|e| format!("--json: {e}"))?;
    }
    let iterations = match args.iterations {
        Some(n) if n == 0 || n > 16 => {
            return Err(format!("--iterations must be in 1..=16 (got {n})"))
        }
        Some(n) => vec![n],
        None => vec![1, 2, 3],
    };
    if args.normals == 0 || args.xi_per_interval == 0 {
        return Err("--normals and --xi-per-interval must be positive".to_string());
    }
    Ok(SweepConfig {
        iterations,
        normals: args.normals,
        xi_per_interval: args.xi_per_interval,
        seed: args.seed,
    })
}

/// The sweep's settings, the worst errors per iteration count and precision, and where each
/// worst case (outside the guard band) lies.
fn print_table(cfg: &SweepConfig, rows: &[SweepRow]) {
    println!(
        "Backward error |C(s_sampled) − C*| / (C(s_e) − C(s_b)) in units of ξ (evaluated in f64)"
    );
    println!(
        "sweep: d = 1, {} normal directions in the line's plane, sub-intervals of the visible arc \
         down to 1e-4 rad (at its ends, inside, and 1e-3 to 1 widths from its ends), {} jittered ξ \
         per interval + guard band (|ξ − 0|, |ξ − 1| < 1e-5), seed {}",
        cfg.normals + 13,
        cfg.xi_per_interval,
        cfg.seed
    );
    println!();
    println!(
        "{:>5}  {:>4}  {:>12}  {:>12}  {:>14}  {:>15}  paper / reference",
        "iter", "prec", "excl. guard", "incl. guard", "excl., w≥1e-2", "excl., near end"
    );
    for r in rows {
        println!(
            "{:>5}  {:>4}  {:>12.3e}  {:>12.3e}  {:>14.3e}  {:>15.3e}  {}",
            r.iterations,
            r.precision.name(),
            r.worst_outside_guard,
            r.worst_including_guard,
            r.worst_wide_intervals,
            r.worst_near_ends,
            paper_value(r.iterations)
        );
    }
    println!();
    for r in rows {
        let c = &r.worst_case;
        println!(
            "worst excl. guard, {} it, {}: n = ({:.4}, {:.4}), φ_b = {:.6}, width = {:.1e}, ξ = {:.7}",
            r.iterations,
            r.precision.name(),
            c.psi.sin(),
            c.psi.cos(),
            c.phi_begin,
            c.width,
            c.xi
        );
    }
}

/// The table and the worst cases as JSON at `path`.
fn write_json(path: &Path, cfg: &SweepConfig, rows: &[SweepRow]) -> Result<(), String> {
    let doc = json!({
        "measure": "backward error in units of xi, evaluated in f64",
        "normals": cfg.normals + 13,
        "xi_per_interval": cfg.xi_per_interval,
        "seed": cfg.seed,
        "guard": linlight_sampling::projected_solid_angle::XI_GUARD,
        "rows": rows.iter().map(row_json).collect::<Vec<_>>(),
    });
    let text =
        serde_json::to_string_pretty(&doc).map_err(|e| format!("cannot serialise JSON: {e}"))?;
    linlight::outputs::write_file(path, text + "\n")
}
