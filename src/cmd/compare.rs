//! `linlight compare A.exr B.exr`: is A statistically consistent with the reference B? The
//! method is documented in docs/statistics.md. Exit 0 = consistent, 1 = significantly
//! different, 2 = unusable input, 3 = inconclusive (too noisy to show equivalence).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use linlight_imagefile::{write_rgb_exr, Image};
use linlight_verify::heatmap::comparison_heatmap;
use linlight_verify::image_stats::{check_inputs, compare, CompareConfig, Comparison};

use linlight::compare_report::{notes, precision_advice, report_json};
use linlight::outputs::{check_distinct, check_not_input, check_writable};

#[derive(clap::Args)]
#[command(after_help = "Examples:
  linlight compare new.exr references/mitsuba/cornell-tube.exr
  linlight compare new.exr ref.exr --json report.json --heatmap z.png --diff-exr diff.exr --z-exr z.exr

Exit codes: 0 consistent (no difference test rejects and equivalence within ±δ is shown),
1 different, 2 unusable input, 3 inconclusive (no difference found, but too noisy to show
equivalence; the output says which image limits the precision and how many more samples help).
The method: docs/statistics.md.")]
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
    /// Compare images rendered from different scene files (their scene_sha256 differ).
    #[arg(long)]
    pub allow_different_scenes: bool,
    /// Compare images whose cylinders were rendered differently (header `cylinders`: exact
    /// tubes against the R → 0 line limit).
    #[arg(long)]
    pub allow_different_cylinders: bool,
    /// Write the full report as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write a PNG heat map: per-pixel z (left) | tile Holm p-values (right).
    #[arg(long, value_name = "FILE.png")]
    pub heatmap: Option<PathBuf>,
    /// Write the float difference A − B per pixel and channel as an RGB EXR.
    #[arg(long, value_name = "FILE.exr")]
    pub diff_exr: Option<PathBuf>,
    /// Write the per-pixel normal scores z as an RGB EXR (0 where a pixel is not tested).
    #[arg(long, value_name = "FILE.exr")]
    pub z_exr: Option<PathBuf>,
    #[command(flatten)]
    pub memory: super::MemoryLimit,
}

fn unusable(msg: impl std::fmt::Display) -> ExitCode {
    eprintln!("linlight compare: unusable input: {msg}");
    ExitCode::from(2)
}

fn outputs(args: &Args) -> Vec<&Path> {
    [&args.json, &args.heatmap, &args.diff_exr, &args.z_exr]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect()
}

pub fn run(args: Args) -> ExitCode {
    let outs = outputs(&args);
    if let Err(e) = check_distinct(&outs) {
        return unusable(e);
    }
    for out in &outs {
        let inputs = [
            ("image A", args.a.as_path()),
            ("reference B", args.b.as_path()),
        ];
        if let Err(e) = check_not_input(out, &inputs).and_then(|_| check_writable(out)) {
            return unusable(e);
        }
    }
    let limit = match args.memory.bytes() {
        Ok((bytes, _)) => bytes,
        Err(e) => return unusable(e),
    };
    let a = match Image::read_within(&args.a, limit) {
        Ok(img) => img,
        Err(e) => return unusable(e),
    };
    let b = match Image::read_within(&args.b, limit) {
        Ok(img) => img,
        Err(e) => return unusable(e),
    };
    for p in [&args.a, &args.b] {
        if let Some(note) = linlight_imagefile::checksum_note(p) {
            eprintln!("{note}");
        }
    }
    if let Err(e) = check_cylinders(&a, &b, args.allow_different_cylinders) {
        return unusable(e);
    }
    let cfg = CompareConfig {
        alpha: args.alpha,
        tolerance: args.tolerance,
        tile: args.tile,
        allow_different_scenes: args.allow_different_scenes,
        ..CompareConfig::default()
    };
    if let Err(e) = check_inputs(&a, &b, &cfg) {
        return unusable(e);
    }
    let cmp = match compare(&a, &b, &cfg) {
        Ok(c) => c,
        Err(e) => return unusable(e),
    };
    let notes = notes(&a, &b, cmp.verdict.exit_code() == 1);
    print!("{}", table(&cmp, &args, &a, &b));
    for n in &notes {
        println!("note: {n}");
    }
    // Outputs are written for every verdict (a difference is when they are most wanted).
    if let Err(e) = write_outputs(&args, &cmp, &a, &b) {
        return unusable(e);
    }
    ExitCode::from(cmp.verdict.exit_code())
}

/// Refuses two images whose headers both record `cylinders` with different values, unless
/// `allow`. Images without the entry (other renderers, Mitsuba) pass.
pub fn check_cylinders(a: &Image, b: &Image, allow: bool) -> Result<(), String> {
    match (a.meta.extra.get("cylinders"), b.meta.extra.get("cylinders")) {
        (Some(x), Some(y)) if x != y && !allow => Err(format!(
            "A was rendered with --cylinders {x}, B with --cylinders {y}: they differ by the \
             tubes' finite radius by design (pass --allow-different-cylinders to compare them \
             anyway)"
        )),
        _ => Ok(()),
    }
}

fn write_outputs(args: &Args, cmp: &Comparison, a: &Image, b: &Image) -> Result<(), String> {
    if let Some(path) = &args.json {
        let value = report_json(cmp, a, b)?;
        let text = serde_json::to_string_pretty(&value)
            .map_err(|e| format!("cannot serialise the report: {e}"))?;
        linlight::outputs::write_file(path, text + "\n")?;
    }
    if let Some(path) = &args.heatmap {
        comparison_heatmap(cmp)
            .write_png(path)
            .map_err(|e| e.to_string())?;
    }
    let attrs = |what: &str| {
        BTreeMap::from([
            ("content".to_string(), what.to_string()),
            ("image_a".to_string(), args.a.display().to_string()),
            ("image_b".to_string(), args.b.display().to_string()),
        ])
    };
    if let Some(path) = &args.diff_exr {
        let diff: Vec<[f32; 3]> = a
            .mean
            .iter()
            .zip(&b.mean)
            .map(|(x, y)| std::array::from_fn(|c| x[c] - y[c]))
            .collect();
        write_rgb_exr(path, a.width, a.height, &diff, &attrs("A - B (mean)"))
            .map_err(|e| e.to_string())?;
    }
    if let Some(path) = &args.z_exr {
        write_rgb_exr(
            path,
            a.width,
            a.height,
            &cmp.maps.z,
            &attrs("z = normal score of A - B (0 where v_A + v_B = 0)"),
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

fn pct(x: f64) -> String {
    format!("{:+.3}%", 100.0 * x)
}

fn p_str(p: Option<f64>) -> String {
    p.map_or_else(|| "-".to_string(), |p| format!("{p:.2e}"))
}

/// The short human-readable verdict table: the header, one row per channel, the pixel
/// classes, then the findings and the verdict.
fn table(cmp: &Comparison, args: &Args, a: &Image, b: &Image) -> String {
    let mut s = table_header(cmp, args);
    s += &channel_rows(cmp);
    s += &pixel_classes_line(cmp);
    s += &findings(cmp, a, b);
    s += &format!("verdict: {}\n", cmp.verdict.label());
    s
}

/// The two lines that name the images, their sizes and the test settings.
fn table_header(cmp: &Comparison, args: &Args) -> String {
    let spp = |n: u64| {
        if n == 0 {
            "unknown".to_string()
        } else {
            n.to_string()
        }
    };
    let mut s = format!(
        "compare {} against reference {}: {}×{} px, dof {} / {}, spp {} / {}\n",
        args.a.display(),
        args.b.display(),
        cmp.width,
        cmp.height,
        cmp.dof_a,
        cmp.dof_b,
        spp(cmp.spp_a),
        spp(cmp.spp_b)
    );
    s += &format!(
        "α = {} (each of {} tests at {:.2e}, Bonferroni), equivalence δ = ±{}% ({:.2}% CI per channel), tile {} px\n",
        cmp.config.alpha,
        cmp.tests,
        cmp.alpha_test,
        100.0 * cmp.config.tolerance,
        100.0 * (1.0 - cmp.alpha_equivalence),
        cmp.config.tile
    );
    s
}

/// The column heads and one row per channel: global difference and its CI, worst tile,
/// per-pixel χ² and the largest |z|.
fn channel_rows(cmp: &Comparison) -> String {
    let mut s = format!(
        "{:<3} {:>9} {:>22} {:>9} {:>9} {:>12} {:>9} {:>7} {:>12}\n",
        "ch", "rel.diff", "CI", "global p", "tile p", "tile at px", "Σz² p", "max|z|", "at"
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
    s
}

/// How many pixel-channels were tested, and why the others were left out.
fn pixel_classes_line(cmp: &Comparison) -> String {
    let k = &cmp.pixel_classes;
    format!(
        "pixel-channels: {} tested, {} of them undersampled (n < {}·CV², variance floored); \
         left out of the pixel tests: {} zero sample variance (rule-of-three bound), \
         {} heavy-tailed (A {}, B {}), {} near a light–surface contact; \
         {} zero variance on both sides and equal\n",
        k.tested + k.undersampled,
        k.undersampled,
        cmp.config.samples_per_cv2,
        k.zero_sample_variance,
        k.heavy_tail_a + k.heavy_tail_b,
        k.heavy_tail_a,
        k.heavy_tail_b,
        k.contact,
        k.zero_variance_agree
    )
}

/// Contact pixels, error metrics, failed and unshown tests, the worst tile and the
/// precision advice.
fn findings(cmp: &Comparison, a: &Image, b: &Image) -> String {
    let mut s = String::new();
    if !cmp.contact_pixels.is_empty() {
        let worst = cmp
            .channels
            .iter()
            .filter_map(|c| c.contacts.p)
            .min_by(f64::total_cmp);
        s += &format!(
            "contact pixels: {} (allowance ±{:.3}% relative), worst p = {}\n",
            cmp.contact_pixels.len(),
            100.0 * cmp.contact_allowance,
            p_str(worst)
        );
    }
    let m = &cmp.metrics;
    s += &format!(
        "error metrics: MSE {:.4e} (noise alone {:.4e}), relMSE {:.4e}, MAPE {:.4e}\n",
        m.mse, m.mse_noise, m.rel_mse, m.mape
    );
    for f in &cmp.failures {
        s += &format!("FAIL {:?} [{}]: {}\n", f.test, f.channel, f.detail);
    }
    for f in &cmp.not_equivalent {
        s += &format!("NOT SHOWN {:?} [{}]: {}\n", f.test, f.channel, f.detail);
    }
    if let Some((ch, t)) = cmp
        .channels
        .iter()
        .filter_map(|c| c.tiles.worst.as_ref().map(|t| (c.channel, t)))
        .min_by(|x, y| x.1.p_holm.total_cmp(&y.1.p_holm))
    {
        s += &format!(
            "worst tile: tile at pixel ({}, {}), {}×{} (channel {ch}, Holm p {:.2e})\n",
            t.region.x, t.region.y, t.region.width, t.region.height, t.p_holm
        );
    }
    if let Some(h) = &cmp.precision {
        s += &format!("precision: {}\n", precision_advice(h, a, b));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Images of different `--cylinders` are refused, naming the flag; allowed with it, and
    /// when either header lacks the entry (Mitsuba's references).
    #[test]
    fn different_cylinders_are_refused_unless_allowed() {
        let (mut a, mut b) = (Image::new(1, 1), Image::new(1, 1));
        assert!(check_cylinders(&a, &b, false).is_ok());
        a.meta.extra.insert("cylinders".into(), "exact".into());
        assert!(check_cylinders(&a, &b, false).is_ok());
        b.meta.extra.insert("cylinders".into(), "line".into());
        let e = check_cylinders(&a, &b, false).unwrap_err();
        assert!(e.contains("--allow-different-cylinders"), "{e}");
        assert!(
            e.contains("--cylinders exact") && e.contains("--cylinders line"),
            "{e}"
        );
        assert!(check_cylinders(&a, &b, true).is_ok());
        b.meta.extra.insert("cylinders".into(), "exact".into());
        assert!(check_cylinders(&a, &b, false).is_ok());
    }
}
