//! `linlight compare A.exr B.exr`: is A statistically consistent with the reference B?
//! (STATISTICS.md §2). Exit 0 = consistent, 1 = significantly different, 2 = unusable input.

use std::path::PathBuf;
use std::process::ExitCode;

use linlight_imagefile::Image;
use linlight_verify::heatmap::comparison_heatmap;
use linlight_verify::image_stats::{compare, CompareConfig, Comparison, Verdict};

#[derive(clap::Args)]
pub struct Args {
    /// Image under test (EXR with R, G, B, var.R, var.G, var.B).
    pub a: PathBuf,
    /// Reference image (relative differences are taken relative to it).
    pub b: PathBuf,
    /// Family-wise significance level of all difference tests together.
    #[arg(long, default_value_t = 0.01)]
    pub alpha: f64,
    /// Equivalence margin δ on the relative global difference per channel.
    #[arg(long, default_value_t = 0.005)]
    pub tolerance: f64,
    /// Tile edge length in pixels.
    #[arg(long, default_value_t = 16)]
    pub tile: usize,
    /// Write the full report as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write a PNG heat map: per-pixel z (left) | tile Holm p-values (right).
    #[arg(long, value_name = "FILE.png")]
    pub heatmap: Option<PathBuf>,
}

fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight compare: unusable input: {msg}");
    ExitCode::from(2)
}

pub fn run(args: Args) -> ExitCode {
    let a = match Image::read(&args.a) {
        Ok(img) => img,
        Err(e) => return unusable(e),
    };
    let b = match Image::read(&args.b) {
        Ok(img) => img,
        Err(e) => return unusable(e),
    };
    let cfg = CompareConfig {
        alpha: args.alpha,
        tolerance: args.tolerance,
        tile: args.tile,
        ..CompareConfig::default()
    };
    let cmp = match compare(&a, &b, &cfg) {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    print!("{}", table(&cmp, &args));

    // Outputs are written even for "different" (that is when they are most wanted); failing
    // to write them is an error of its own.
    if let Some(path) = &args.json {
        let text = match serde_json::to_string_pretty(&cmp) {
            Ok(t) => t,
            Err(e) => return unusable(format!("cannot serialise report: {e}")),
        };
        if let Err(e) = std::fs::write(path, text + "\n") {
            return unusable(format!("cannot write {}: {e}", path.display()));
        }
    }
    if let Some(path) = &args.heatmap {
        if let Err(e) = comparison_heatmap(&cmp).write_png(path) {
            return unusable(e);
        }
    }
    match cmp.verdict {
        Verdict::Consistent => ExitCode::SUCCESS,
        Verdict::Different => ExitCode::from(1),
    }
}

fn pct(x: f64) -> String {
    format!("{:+.3}%", 100.0 * x)
}

fn p_str(p: Option<f64>) -> String {
    p.map_or_else(|| "-".to_string(), |p| format!("{p:.2e}"))
}

/// The short human-readable verdict table.
fn table(cmp: &Comparison, args: &Args) -> String {
    let mut s = format!(
        "compare {} against reference {}: {}×{} px, dof {} / {}\n",
        args.a.display(),
        args.b.display(),
        cmp.width,
        cmp.height,
        cmp.dof_a,
        cmp.dof_b
    );
    s += &format!(
        "α = {} (each of 12 tests at {:.2e}), equivalence δ = ±{}% ({:.2}% CI per channel), tile {} px\n",
        cmp.config.alpha,
        cmp.alpha_test,
        100.0 * cmp.config.tolerance,
        100.0 * (1.0 - cmp.alpha_equivalence),
        cmp.config.tile
    );
    s += &format!(
        "{:<3} {:>9} {:>22} {:>9} {:>9} {:>12} {:>9} {:>7} {:>12}\n",
        "ch", "rel.diff", "CI", "global p", "tile p", "worst tile", "Σz² p", "max|z|", "at"
    );
    for ch in &cmp.channels {
        let g = &ch.global;
        let ci = g.rel_ci.map_or_else(
            || "undefined".into(),
            |[lo, hi]| format!("[{}, {}]", pct(lo), pct(hi)),
        );
        let (tile_p, tile_at) = ch.tiles.worst.as_ref().map_or_else(
            || ("-".to_string(), "-".to_string()),
            |t| {
                (
                    format!("{:.2e}", t.p_holm),
                    format!("({}, {})", t.region.x, t.region.y),
                )
            },
        );
        let at = ch
            .pixels
            .max_at
            .map_or_else(|| "-".into(), |r| format!("({}, {})", r.x, r.y));
        s += &format!(
            "{:<3} {:>9} {:>22} {:>9} {:>9} {:>12} {:>9} {:>7.2} {:>12}\n",
            ch.channel,
            g.rel_diff.map_or_else(|| "-".into(), pct),
            ci,
            p_str(g.p),
            tile_p,
            tile_at,
            p_str(ch.pixels.chi2_p),
            ch.pixels.max_abs_z,
            at
        );
    }
    s += &format!(
        "zero-variance pixel values: {} ({} disagree); zero variance in one image only: {}\n",
        cmp.zero_variance.count, cmp.zero_variance.mismatched, cmp.zero_variance.one_sided
    );
    for f in &cmp.failures {
        s += &format!("FAIL {:?} [{}]: {}\n", f.test, f.channel, f.detail);
    }
    s += match cmp.verdict {
        Verdict::Consistent => "verdict: CONSISTENT\n",
        Verdict::Different => "verdict: DIFFERENT\n",
    };
    s
}
