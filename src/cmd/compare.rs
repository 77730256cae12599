//! `linlight compare A.exr B.exr`: is A statistically consistent with the reference B? The
//! method is documented in docs/statistics.md. Exit 0 = consistent, 1 = significantly
//! different, 2 = unusable input, 3 = inconclusive (too noisy to show equivalence).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use linlight_imagefile::{write_rgb_exr, Image};
use linlight_verify::heatmap::comparison_heatmap;
use linlight_verify::image_stats::{
    check_inputs, compare, CompareConfig, Comparison, PrecisionHint,
};

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
    if let Err(e) = write_outputs(&args, &cmp, &notes, &a, &b) {
        return unusable(e);
    }
    ExitCode::from(cmp.verdict.exit_code())
}

/// What the reader of a verdict must know about the inputs: checks skipped for want of a
/// header (images written by other tools), and where thin tubes may explain a difference.
pub fn notes(a: &Image, b: &Image, different: bool) -> Vec<String> {
    let mut out = Vec::new();
    for (name, img) in [("A", a), ("B", b)] {
        if img.meta.scene_sha256.is_empty() {
            out.push(format!(
                "{name} has no scene hash (scene_sha256): the same-scene check was skipped"
            ));
        }
        if img.meta.spp == 0 {
            out.push(format!(
                "{name} does not record its samples per pixel (spp): sample hints for {name} \
                 are given as factors only"
            ));
        }
    }
    if different {
        out.extend(thin_tube_notes(a, b));
    }
    out
}

fn write_outputs(
    args: &Args,
    cmp: &Comparison,
    notes: &[String],
    a: &Image,
    b: &Image,
) -> Result<(), String> {
    if let Some(path) = &args.json {
        let mut value =
            serde_json::to_value(cmp).map_err(|e| format!("cannot serialise the report: {e}"))?;
        if let Some(o) = value.as_object_mut() {
            o.insert("notes".into(), serde_json::json!(notes));
            if let Some(h) = &cmp.precision {
                o.insert(
                    "precision_advice".into(),
                    serde_json::json!(precision_advice(h, a, b)),
                );
            }
        }
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

/// The short human-readable verdict table.
fn table(cmp: &Comparison, args: &Args, a: &Image, b: &Image) -> String {
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
    s += &format!(
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
    let k = &cmp.pixel_classes;
    s += &format!(
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
    );
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
    s += &format!("verdict: {}\n", cmp.verdict.label());
    s
}

/// More samples than this factor of an image's own count are not advice but a sign that the
/// other image limits the precision.
const MAX_HELPFUL_FACTOR: f64 = 16.0;

/// Seconds one sample per pixel of `img` took, from its header (`wall_time_s` / `spp`, which
/// the Mitsuba harness records; linlight's own images carry no times, so that their bytes
/// depend on their inputs only).
fn seconds_per_spp(img: &Image) -> Option<f64> {
    let s: f64 = img.meta.extra.get("wall_time_s")?.parse().ok()?;
    (img.meta.spp > 0 && s > 0.0).then(|| s / img.meta.spp as f64)
}

/// "≈ 4096 spp per pixel (4.0× its 1024; ≈ 3.2 min at its measured rate)" for `factor` more
/// samples of `img`, as much as the header allows.
fn samples_text(img: &Image, factor: f64) -> String {
    let f = factor.max(1.0);
    if img.meta.spp == 0 {
        return format!("≈ {f:.1}× its samples (its spp is not recorded)");
    }
    let spp = (img.meta.spp as f64 * f).ceil();
    let time = seconds_per_spp(img).map_or_else(String::new, |t| {
        format!(
            "; ≈ {} at its measured rate",
            super::render::duration(t * spp)
        )
    });
    format!(
        "≈ {spp:.0} spp per pixel ({f:.1}× its {}{time})",
        img.meta.spp
    )
}

/// The sample advice of an inconclusive comparison, capped at what can help: when the
/// reference B holds the larger share of the variance and A alone would need more than
/// MAX_HELPFUL_FACTOR× its samples (or cannot reach the precision at all), more samples of A
/// alone cannot decide and the advice is about the reference.
pub fn precision_advice(h: &PrecisionHint, a: &Image, b: &Image) -> String {
    let a_limits = h.limiting == "A";
    let a_helps = h.factor_a.filter(|&f| a_limits || f <= MAX_HELPFUL_FACTOR);
    let share = |of_a: bool| 100.0 * if of_a { h.share_a } else { 1.0 - h.share_a };
    if let Some(f) = a_helps {
        return format!(
            "{} ({:.0}% of the variance of channel {} comes from A): render A with {}",
            if a_limits {
                "A limits the precision"
            } else {
                "A can decide it"
            },
            share(true),
            h.channel,
            samples_text(a, f)
        );
    }
    let reference = match h.factor_b {
        Some(f) => format!("the reference alone would need {}", samples_text(b, f)),
        None => format!(
            "both need more: A {}, the reference {}",
            samples_text(a, h.factor_both),
            samples_text(b, h.factor_both)
        ),
    };
    let why = if a_limits {
        "the reference's own variance is already too large".to_string()
    } else {
        format!(
            "the reference limits the precision ({:.0}% of the variance of channel {} comes from \
             it)",
            share(false),
            h.channel
        )
    };
    format!("{why}: more samples of A alone cannot decide; {reference}")
}

/// For each linear light of A's header whose radius is not negligible: its name, R and the
/// expected size of the finite-R effect (printed when a comparison fails).
fn thin_tube_notes(a: &Image, b: &Image) -> Vec<String> {
    let lights = [a, b]
        .iter()
        .find_map(|i| i.meta.extra.get("finite_radius_effect").cloned());
    match lights {
        None => Vec::new(),
        Some(v) => v
            .split(';')
            .filter(|s| !s.is_empty())
            .map(|s| {
                format!(
                    "a difference where tubes are thin may be Mitsuba's finite radius, which \
                     linlight renders in the limit R → 0: {s} (docs/oracle.md)"
                )
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(spp: u64, seconds: Option<f64>) -> Image {
        let mut i = Image::new(1, 1);
        i.meta.spp = spp;
        if let Some(s) = seconds {
            i.meta.extra.insert("wall_time_s".into(), s.to_string());
        }
        i
    }

    fn hint(
        limiting: &'static str,
        share_a: f64,
        fa: Option<f64>,
        fb: Option<f64>,
    ) -> PrecisionHint {
        PrecisionHint {
            channel: "R",
            limiting,
            share_a,
            factor_a: fa,
            factor_b: fb,
            factor_both: 2.0,
            spp_a: None,
            spp_b: None,
            text: String::new(),
        }
    }

    /// The absurd hint of a reference-limited comparison ("≈ 11442.7× the samples of A
    /// alone") becomes advice about the reference, in spp per pixel and minutes.
    #[test]
    fn advice_is_capped_at_what_helps() {
        let (a, b) = (image(1024, Some(60.0)), image(8192, None));
        let t = precision_advice(&hint("B", 0.1, Some(11442.7), Some(3.0)), &a, &b);
        assert!(t.contains("more samples of A alone cannot decide"), "{t}");
        assert!(
            t.contains("the reference alone would need ≈ 24576 spp per pixel (3.0× its 8192)"),
            "{t}"
        );
        assert!(!t.contains("11442"), "{t}");
        assert!(
            t.starts_with("the reference limits the precision (90% of the variance"),
            "{t}"
        );
        let t = precision_advice(&hint("A", 0.9, Some(4.0), None), &a, &b);
        assert_eq!(
            t,
            "A limits the precision (90% of the variance of channel R comes from A): render A \
             with ≈ 4096 spp per pixel (4.0× its 1024; ≈ 4.0 min at its measured rate)"
        );
        // When A limits, its factor is the advice however large.
        let t = precision_advice(&hint("A", 0.9, Some(240.0), None), &a, &b);
        assert!(t.contains("render A with ≈ 245760 spp per pixel"), "{t}");
        let t = precision_advice(&hint("B", 0.4, Some(40.0), None), &a, &image(0, None));
        assert!(t.contains("A alone cannot decide; both need more"), "{t}");
        assert!(t.contains("its spp is not recorded"), "{t}");
    }

    #[test]
    fn header_less_images_are_noted() {
        let (a, mut b) = (image(0, None), image(8, None));
        b.meta.scene_sha256 = "ab".into();
        let n = notes(&a, &b, false);
        assert_eq!(
            n,
            [
                "A has no scene hash (scene_sha256): the same-scene check was skipped",
                "A does not record its samples per pixel (spp): sample hints for A are given as \
                 factors only"
            ]
        );
        // A failed comparison names each thin tube of the header with its expected effect.
        b.meta.extra.insert(
            "finite_radius_effect".into(),
            "light at s.xml:3:1 (R = 0.001): up to 3.5% per pixel".into(),
        );
        let n = notes(&a, &b, true);
        assert!(
            n[2].contains("light at s.xml:3:1 (R = 0.001): up to 3.5% per pixel"),
            "{n:?}"
        );
        assert_eq!(notes(&a, &b, false).len(), 2);
    }
}
