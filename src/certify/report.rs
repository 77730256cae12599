//! What a certification leaves behind: `report.json` (everything), `report.md` (tables), and
//! per scene × subject × oracle the Rust render (EXR), the heat map (per-pixel z | tile Holm
//! p-values) and the side-by-side preview (Rust | oracle | signed luminance difference).

use linlight_imagefile::Image;
use linlight_verify::heatmap::{comparison_heatmap, side_by_side};
use linlight_verify::image_stats::Verdict;
use std::fmt::Write as _;
use std::path::Path;

use super::sampler_suite::SuiteSummary;
use super::{Report, Row, SceneReport, Unusable};
use crate::outputs::write_file;

pub(super) fn io_err(path: &Path, e: impl std::fmt::Display) -> Unusable {
    Unusable(format!("cannot write {}: {e}", path.display()))
}

/// Writes the pictures (and, once per subject, the render) of one row; returns their paths
/// relative to `dir`.
pub fn write_row_images(
    dir: &Path,
    row: &Row,
    image: &Image,
    oracle: &Image,
) -> Result<Vec<String>, Unusable> {
    let sub = dir.join(&row.scene);
    std::fs::create_dir_all(&sub).map_err(|e| io_err(&sub, e))?;
    let stem = format!("{}-vs-{}", row.subject, row.oracle);
    let mut files = Vec::new();
    let render = format!("{}/{}.exr", row.scene, row.subject);
    // The image writers' messages already name the file.
    let written = |e: linlight_imagefile::ImageError| Unusable(e.to_string());
    if !dir.join(&render).exists() || row.oracle == "mitsuba" {
        image.write(&dir.join(&render)).map_err(written)?;
    }
    files.push(render);
    // The oracle image, once per scene and oracle (report.html shows it; a closed form or a
    // live render exists nowhere else).
    let oracle_file = format!("{}/oracle-{}.exr", row.scene, row.oracle);
    if !dir.join(&oracle_file).exists() {
        oracle.write(&dir.join(&oracle_file)).map_err(written)?;
    }
    files.push(oracle_file);
    let heat = format!("{}/{stem}-z-tiles.png", row.scene);
    comparison_heatmap(&row.comparison)
        .write_png(&dir.join(&heat))
        .map_err(written)?;
    files.push(heat);
    let side = format!("{}/{stem}-side-by-side.png", row.scene);
    let (picture, _scale) = side_by_side(image, oracle, None).map_err(written)?;
    picture.write_png(&dir.join(&side)).map_err(written)?;
    files.push(side);
    Ok(files)
}

fn pct(x: f64) -> String {
    format!("{:+.3}%", 100.0 * x)
}

/// The channel with the largest |relative difference|: (channel, diff, CI half-width).
fn worst_channel(row: &Row) -> Option<(&'static str, f64, f64)> {
    (0..3)
        .filter_map(|c| {
            let d = row.rel_diff[c]?;
            let [lo, hi] = row.rel_ci[c]?;
            Some((["R", "G", "B"][c], d, 0.5 * (hi - lo)))
        })
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
}

fn verdict(v: Verdict) -> &'static str {
    v.label()
}

fn rel_cell(row: &Row) -> String {
    worst_channel(row).map_or_else(
        || "undefined".to_string(),
        |(ch, d, h)| format!("{} ± {:.3}% ({ch})", pct(d), 100.0 * h),
    )
}

fn p_cell(p: Option<f64>) -> String {
    p.map_or_else(|| "-".into(), |p| format!("{p:.2e}"))
}

/// The samples per pixel of a row: `N`, or `N–M` when the tiles that need more got up to M.
pub fn spp_text(b: &super::budget::Budget) -> String {
    let range = if b.pixel_spp_max > b.spp {
        format!("{}–{}", b.spp, b.pixel_spp_max)
    } else {
        b.spp.to_string()
    };
    format!("{range}{}", if b.capped { " (cap)" } else { "" })
}

/// [`spp_text`], and `×N` when the render took N light samples per camera sample.
pub fn spp_cell(row: &Row) -> String {
    let spp = spp_text(&row.budget);
    if row.light_samples > 1 {
        format!("{spp} ×{}", row.light_samples)
    } else {
        spp
    }
}

/// The row's subject, and the subject whose render it shares ([`Row::render_of`]).
pub fn subject_cell(row: &Row) -> String {
    match &row.render_of {
        Some(of) => format!("{} (render of {of})", row.subject),
        None => row.subject.clone(),
    }
}

/// One line per row, for the terminal.
pub fn row_line(row: &Row) -> String {
    format!(
        "{:<15} {:<22} {:<11} {:<10} {:>24} {:>9} {:>11} {:>8.1}s",
        row.scene,
        row.subject,
        row.oracle,
        verdict(row.verdict),
        rel_cell(row),
        p_cell(row.worst_tile_p),
        spp_cell(row),
        row.render_seconds
    )
}

pub fn table_header() -> String {
    format!(
        "{:<15} {:<22} {:<11} {:<10} {:>24} {:>9} {:>11} {:>9}",
        "scene", "technique", "oracle", "verdict", "rel. diff ± CI", "tile p", "spp", "time"
    )
}

/// The summary table printed at the end of `linlight certify`.
pub fn summary(report: &Report) -> String {
    let mut s = String::new();
    if let Some(suite) = &report.sampler_suite {
        let failing: Vec<&str> = suite
            .techniques
            .iter()
            .chain(&suite.negative_controls)
            .filter(|r| !r.passed)
            .map(|r| r.name.as_str())
            .collect();
        let _ = writeln!(
            s,
            "sampler suite: {} ({} techniques, {} negative controls, {} configurations, {:.1} s){}",
            if suite.passed { "PASS" } else { "FAIL" },
            suite.techniques.len(),
            suite.negative_controls.len(),
            suite.configurations,
            suite.elapsed_seconds,
            if failing.is_empty() {
                String::new()
            } else {
                format!("; failing: {}", failing.join(", "))
            }
        );
    }
    if let Some(g) = &report.gpu_kernels {
        let _ = writeln!(s, "{}", g.line());
    }
    let _ = writeln!(
        s,
        "image comparisons: α = {} split over m = {} comparisons (α_c = {:.2e} each), δ = ±{}%",
        report.alpha,
        report.comparisons_in_family,
        report.alpha_per_comparison,
        100.0 * report.tolerance
    );
    let _ = writeln!(s, "{}", table_header());
    for row in report.rows() {
        let _ = writeln!(s, "{}", row_line(row));
    }
    let finite: Vec<&Row> = report
        .scenes
        .iter()
        .filter(|s| s.exact_tubes)
        .flat_map(|s| &s.rows)
        .collect();
    if !finite.is_empty() {
        let _ = writeln!(
            s,
            "finite-tube family (exact tubes): {} of {} comparisons consistent, {:.1} s of pilots and renders",
            finite.iter().filter(|r| r.passed()).count(),
            finite.len(),
            finite
                .iter()
                .map(|r| r.pilot_seconds + r.render_seconds)
                .sum::<f64>()
        );
    }
    let failed: Vec<String> = report
        .rows()
        .filter(|r| !r.passed())
        .map(|r| {
            format!(
                "{}/{} vs {} ({})",
                r.scene,
                r.subject,
                r.oracle,
                r.verdict.label()
            )
        })
        .collect();
    s.push_str(&cpu_lines(report));
    let _ = writeln!(
        s,
        "certify: {} in {:.1} s ({} comparisons{})",
        match report.verdict {
            Verdict::Consistent => "PASS",
            Verdict::Different => "FAIL",
            Verdict::Inconclusive => "INCONCLUSIVE",
        },
        report.elapsed_seconds,
        report.rows().count(),
        if failed.is_empty() {
            String::new()
        } else {
            format!("; not consistent: {}", failed.join(", "))
        }
    );
    s
}

/// The shader kernels' section of `report.md`: why they were skipped, or one row per check.
fn gpu_markdown(g: &super::gpu::GpuSummary) -> String {
    let mut s = String::new();
    let Some(adapter) = &g.adapter else {
        let _ = writeln!(s, "## {}\n", g.line());
        if let Some(note) = &g.note {
            let _ = writeln!(s, "{note}\n");
        }
        return s;
    };
    let _ = writeln!(
        s,
        "## GPU kernels: {}\n\nOn {adapter}: {} ξ per configuration for the agreement, {} samples \
         per configuration for the sampler suite on the kernels' answers, {:.1} s \
         (docs/kernels.md).\n",
        if g.passed { "PASS" } else { "FAIL" },
        g.agreement_samples,
        g.suite_samples,
        g.elapsed_seconds
    );
    if let Some(e) = &g.error {
        let _ = writeln!(s, "Backend error (the checks after it did not run): {e}\n");
    }
    let _ = writeln!(s, "| check | verdict | detail |\n|---|---|---|");
    for c in &g.checks {
        let _ = writeln!(
            s,
            "| {} | {} | {} |",
            c.name,
            if c.passed { "pass" } else { "FAIL" },
            c.detail.replace('|', "\\|")
        );
    }
    s.push('\n');
    s
}

/// Where the run's CPU time went, by stage and per scene (empty where it was not measured):
/// user + system CPU-s of each stage's threads.
pub fn cpu_lines(report: &Report) -> String {
    let mut s = String::new();
    let Some(c) = &report.cpu else {
        return s;
    };
    let sc = &c.scenes;
    let _ = writeln!(
        s,
        "CPU time: {:.1} CPU-s in {:.1} s wall ({:.2} cores on {} threads): sampler suite {:.1}, \
         GPU kernels {:.1}, loading {:.1}, exact images {:.1}, pilots {:.1}, renders {:.1}, \
         comparisons {:.1}, other {:.1}",
        c.process,
        report.elapsed_seconds,
        c.process / report.elapsed_seconds.max(1e-9),
        report.threads,
        c.sampler_suite,
        c.gpu_kernels,
        c.loading,
        sc.exact_image,
        sc.pilots,
        sc.renders,
        sc.comparisons,
        (c.process - c.sampler_suite - c.gpu_kernels - c.loading - sc.total()).max(0.0),
    );
    for scene in &report.scenes {
        if let Some(t) = &scene.cpu {
            let _ = writeln!(
                s,
                "  {:<24} {:>6.1} CPU-s: exact image {:.1}, pilots {:.1}, renders {:.1}, \
                 comparisons {:.1}",
                scene.name,
                t.total(),
                t.exact_image,
                t.pilots,
                t.renders,
                t.comparisons
            );
        }
    }
    s
}

/// `report.md`.
pub fn markdown(report: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# linlight certify\n");
    let _ = writeln!(
        s,
        "**Verdict: {}** — {} comparisons in {:.1} s on {} threads; oracle: {:?}; scenes `{}`.\n",
        if report.passed { "PASS" } else { "FAIL" },
        report.rows().count(),
        report.elapsed_seconds,
        report.threads,
        report.oracle,
        report.scenes_pattern
    );
    let _ = writeln!(
        s,
        "Each comparison: Rust render (A) against the oracle (B), docs/statistics.md §2, at the Šidák \
         level α_c = {:.2e} (family-wise α = {} over the m = {} comparisons of the full default \
         certification), equivalence margin ±{}%. Budget rule: {}. Render seed {}.\n",
        report.alpha_per_comparison,
        report.alpha,
        report.comparisons_in_family,
        100.0 * report.tolerance,
        report.budget_rule.describe(),
        report.seed
    );
    s += &calibration_section(report.calibration.as_ref());
    if let Some(suite) = &report.sampler_suite {
        s += &suite_section(suite);
    }
    if let Some(g) = &report.gpu_kernels {
        s += &gpu_markdown(g);
    }
    let cpu = cpu_lines(report);
    if !cpu.is_empty() {
        let _ = writeln!(s, "## CPU time\n\n```\n{cpu}```\n");
    }
    for sc in &report.scenes {
        s += &scene_section(sc);
    }
    s
}

/// The sampler suite's section of `report.md`: its verdict and one table row per subject.
fn suite_section(suite: &SuiteSummary) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Sampler chi-square suite: {}\n\n{} configurations, {} samples each, α = {} \
         (α per test {:.2e}), {:.1} s.\n",
        if suite.passed { "PASS" } else { "FAIL" },
        suite.configurations,
        suite.samples,
        suite.alpha,
        suite.alpha_per_test,
        suite.elapsed_seconds
    );
    let _ = writeln!(
        s,
        "| subject | role | verdict | failing configs | worst p | time |\n|---|---|---|---|---|---|"
    );
    for (role, rows) in [
        ("technique", &suite.techniques),
        ("negative control", &suite.negative_controls),
    ] {
        for r in rows {
            let _ = writeln!(
                s,
                "| {} | {role} | {} | {} | {} | {:.1} s |",
                r.name,
                r.verdict,
                r.failing_cell(),
                p_cell(r.worst_p_value),
                r.seconds
            );
        }
    }
    s.push('\n');
    s
}

/// One scene's section of `report.md`: its reference, one table row per comparison, and the
/// failures of the comparisons that did not pass.
fn scene_section(sc: &SceneReport) -> String {
    let mut s = String::new();
    let r = &sc.reference;
    let _ = writeln!(s, "## {}\n", sc.name);
    let _ = writeln!(
        s,
        "Scene `{}`; reference `{}`: {}, {} spp in {} passes (dof {}), overrides `{}`, {}{}.\n",
        sc.scene_file.display(),
        r.file.display(),
        r.renderer,
        r.spp,
        r.passes,
        r.dof,
        r.overrides,
        r.wall_time_s.map_or_else(
            || "render time unknown".into(),
            |t| format!("rendered in {t:.0} s")
        ),
        sc.live_oracle_seconds
            .map_or_else(String::new, |t| format!(" (live render now: {t:.0} s)"))
    );
    let _ = writeln!(
        s,
        "| technique | oracle | verdict | rel. diff R | rel. diff G | rel. diff B | worst tile p | Σz² p (min) | max\\|z\\| | spp | v_A ≤ v_B | render | pictures |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for row in &sc.rows {
        s += &markdown_row(row);
    }
    let failures: Vec<&Row> = sc.rows.iter().filter(|r| !r.passed()).collect();
    if !failures.is_empty() {
        s.push('\n');
        for row in failures {
            let c = &row.comparison;
            for f in c.failures.iter().chain(&c.not_equivalent) {
                let _ = writeln!(
                    s,
                    "- {} vs {}: {:?} [{}]: {}",
                    row.subject, row.oracle, f.test, f.channel, f.detail
                );
            }
            if let Some(h) = &c.precision {
                let _ = writeln!(s, "- {} vs {}: {}", row.subject, row.oracle, h.text);
            }
        }
    }
    s.push('\n');
    s
}

/// One comparison's row of a scene's table in `report.md`.
fn markdown_row(row: &Row) -> String {
    let ch = |c: usize| match (row.rel_diff[c], row.rel_ci[c]) {
        (Some(d), Some([lo, hi])) => {
            format!("{} [{}, {}]", pct(d), pct(lo), pct(hi))
        }
        _ => "-".into(),
    };
    let chi2 = row
        .comparison
        .channels
        .iter()
        .filter_map(|c| c.pixels.chi2_p)
        .min_by(f64::total_cmp);
    let maxz = row
        .comparison
        .channels
        .iter()
        .map(|c| c.pixels.max_abs_z)
        .fold(0.0, f64::max);
    let pics: Vec<String> = row
        .files
        .iter()
        .filter(|f| f.ends_with(".png"))
        .map(|f| {
            format!(
                "[{}]({f})",
                // `\|`: a bare `|` would end the table cell.
                if f.contains("z-tiles") {
                    "z"
                } else {
                    "A \\| B \\| Δ"
                }
            )
        })
        .collect();
    format!(
        "| {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {} | {:.1}% | {:.1} s | {} |\n",
        subject_cell(row),
        row.oracle,
        verdict(row.verdict),
        ch(0),
        ch(1),
        ch(2),
        p_cell(row.worst_tile_p),
        p_cell(chi2),
        maxz,
        spp_cell(row),
        100.0 * row.precision.at_least_as_precise,
        row.render_seconds,
        pics.join(" ")
    )
}

/// The measured false-alarm rates and power of the comparison (`linlight calibrate`, committed
/// as docs/calibration.json), quoted so that a reader can weigh a verdict.
fn calibration_section(calibration: Option<&serde_json::Value>) -> String {
    let Some(c) = calibration else {
        return "Calibration: no docs/calibration.json found (run `linlight calibrate --json \
                docs/calibration.json`).\n\n"
            .into();
    };
    let mut s = String::from("## Calibration of the comparison on real renders\n\n");
    let opts = &c["options"];
    let _ = writeln!(
        s,
        "`linlight calibrate`: {} seed pairs per scene family, {}×{} films, α = {} per \
         comparison (certify runs each at the smaller α_c above, so its rates are lower still). \
         Rates with 95 % Clopper–Pearson intervals; power = share of pairs rejected after \
         injecting a bias.\n",
        opts["pairs"], opts["res"], opts["res"], opts["compare"]["alpha"]
    );
    let pct = |v: &serde_json::Value| format!("{:.1}%", 100.0 * v.as_f64().unwrap_or(f64::NAN));
    let rate = |r: &serde_json::Value| {
        format!(
            "{}/{} [{}, {}]",
            r["count"],
            r["of"],
            pct(&r["ci95"][0]),
            pct(&r["ci95"][1])
        )
    };
    let biases = |key: &str| -> Vec<String> {
        c[key]
            .as_array()
            .map(|a| {
                a.iter()
                    .map(|b| format!("{}%", 100.0 * b.as_f64().unwrap_or(0.0)))
                    .collect()
            })
            .unwrap_or_default()
    };
    let _ = writeln!(
        s,
        "| family | budget | false alarms (DIFFERENT) | INCONCLUSIVE | power, global {} | power, 16×16 {} |\n|---|---|---|---|---|---|",
        biases("global_biases").join(" / "),
        biases("local_biases").join(" / ")
    );
    for f in c["families"].as_array().into_iter().flatten() {
        for r in f["rows"].as_array().into_iter().flatten() {
            let power = |key: &str| {
                r[key]
                    .as_array()
                    .map(|a| {
                        a.iter()
                            .map(|p| pct(&p["rate"]))
                            .collect::<Vec<_>>()
                            .join(" / ")
                    })
                    .unwrap_or_default()
            };
            let _ = writeln!(
                s,
                "| {} ({}) | {} (median {} spp) | {} | {} | {} | {} |",
                f["family"]["name"].as_str().unwrap_or("?"),
                f["family"]["scene"].as_str().unwrap_or("?"),
                r["budget"].as_str().unwrap_or("?"),
                r["median_spp"],
                rate(&r["different"]),
                rate(&r["inconclusive"]),
                power("power_global"),
                power("power_local")
            );
        }
    }
    s.push('\n');
    s
}

/// Writes `report.json` and `report.md` into `dir`.
pub fn write_report(dir: &Path, report: &Report) -> Result<(), Unusable> {
    let json = dir.join("report.json");
    let text = super::shard::sealed_json(report).map_err(|e| io_err(&json, e))?;
    let written = |r: Result<(), String>| r.map_err(Unusable);
    written(write_file(&json, text))?;
    written(write_file(&dir.join("report.md"), markdown(report)))?;
    Ok(())
}
