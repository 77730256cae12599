//! `report.html`: the certification as one self-contained page (no external files: every picture
//! is an inline PNG), built from the same [`Report`] as `report.md` and from the images
//! `write_row_images` leaves in the report directory.
//!
//! Per scene: a table with an efficiency column (variance of the image mean × render time: the
//! time a technique needs for a given precision, relative to the scene's best), a note when two
//! techniques rendered identical images (they are then one piece of evidence, not two), and per
//! comparison the pictures enlarged, labelled Rust | oracle | difference, with colour bars and
//! their ranges, next to the per-pixel z and tile p maps. On top, a forest plot of the relative
//! global difference ± CI of every comparison against the equivalence margin.

use linlight_imagefile::{rgb8_png_bytes, srgb8, Image};
use linlight_verify::heatmap::{
    diverging, sequential, tile_heatmap, z_heatmap, Rgb8, P_DECADES, Z_RANGE,
};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use super::report::io_err;
use super::sampler_suite::SuiteSummary;
use super::{Report, Row, SceneReport, Unusable};

/// Displayed width of the enlarged pictures, in CSS pixels (at least 1× the image).
const PICTURE_WIDTH: usize = 256;
const CHANNEL_COLOURS: [&str; 3] = ["#c0392b", "#27ae60", "#2980b9"];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn data_uri(pixels: &Rgb8) -> String {
    use base64::Engine as _;
    match rgb8_png_bytes(pixels.width, pixels.height, &pixels.data) {
        Ok(png) => format!(
            "data:image/png;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(png)
        ),
        Err(_) => String::new(),
    }
}

/// An enlarged picture (nearest-neighbour) with a caption.
fn picture(pixels: &Rgb8, caption: &str) -> String {
    let scale = (PICTURE_WIDTH / pixels.width.max(1)).max(1);
    format!(
        "<figure><img class=\"px\" src=\"{}\" width=\"{}\" height=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
        data_uri(pixels),
        pixels.width * scale,
        pixels.height * scale,
        esc(caption),
        caption
    )
}

/// A horizontal colour bar from `map(t)`, t ∈ [0, 1], with labels at both ends (and the middle).
fn colour_bar(map: impl Fn(f64) -> [u8; 3], left: &str, middle: &str, right: &str) -> String {
    let n = 128;
    let mut bar = Rgb8::filled(n, 1, [0; 3]);
    for i in 0..n {
        bar.set(i, 0, map(i as f64 / (n - 1) as f64));
    }
    format!(
        "<div class=\"bar\"><img class=\"px\" src=\"{}\" width=\"{PICTURE_WIDTH}\" height=\"10\" alt=\"colour bar\"><div class=\"ticks\"><span>{left}</span><span>{middle}</span><span>{right}</span></div></div>",
        data_uri(&bar)
    )
}

fn luminance(p: [f32; 3]) -> f64 {
    0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64
}

/// The q-quantile of |values| (positive), or `fallback`.
fn abs_quantile(values: impl Iterator<Item = f64>, q: f64, fallback: f64) -> f64 {
    let mut v: Vec<f64> = values.map(f64::abs).filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return fallback;
    }
    v.sort_by(f64::total_cmp);
    let x = v[((v.len() - 1) as f64 * q).round() as usize];
    if x > 0.0 {
        x
    } else {
        v.last().copied().filter(|m| *m > 0.0).unwrap_or(fallback)
    }
}

fn tone(img: &Image, white: f64) -> Rgb8 {
    let mut p = Rgb8::filled(img.width, img.height, [0; 3]);
    let k = (1.0 / white) as f32;
    for (i, m) in img.mean.iter().enumerate() {
        p.set(
            i % img.width,
            i / img.width,
            [srgb8(k * m[0]), srgb8(k * m[1]), srgb8(k * m[2])],
        );
    }
    p
}

/// Rust | oracle | difference, with their colour bars. The two renders share one white point
/// (the 99th percentile of the oracle's luminance); the difference is Y_A − Y_B on a diverging
/// map saturating at the 99th percentile of |Y_A − Y_B|.
fn triptych(a: &Image, b: &Image, oracle: &str) -> String {
    let white = abs_quantile(b.mean.iter().map(|p| luminance(*p)), 0.99, 1.0);
    let diff: Vec<f64> = a
        .mean
        .iter()
        .zip(&b.mean)
        .map(|(x, y)| luminance(*x) - luminance(*y))
        .collect();
    let scale = abs_quantile(diff.iter().copied(), 0.99, 1.0);
    let mut d = Rgb8::filled(a.width, a.height, [0; 3]);
    for (i, v) in diff.iter().enumerate() {
        d.set(i % a.width, i / a.width, diverging(v / scale));
    }
    let tone_bar = colour_bar(
        |t| [srgb8(t as f32); 3],
        "0",
        "radiance (linear, sRGB-encoded)",
        &format!("≥ {white:.3e}"),
    );
    let diff_bar = colour_bar(
        |t| diverging(2.0 * t - 1.0),
        &format!("≤ −{scale:.3e}"),
        "Y<sub>Rust</sub> − Y<sub>oracle</sub>",
        &format!("≥ +{scale:.3e}"),
    );
    format!(
        "<div class=\"row\"><div>{}{tone_bar}</div><div>{}{tone_bar}</div><div>{}{diff_bar}</div></div>",
        picture(&tone(a, white), "Rust"),
        picture(&tone(b, white), &esc(&oracle_label(oracle))),
        picture(&d, "difference")
    )
}

fn oracle_label(oracle: &str) -> String {
    match oracle {
        "mitsuba" => "Mitsuba".into(),
        "closed-form" => "closed form (R → 0)".into(),
        "quadrature" => "line quadrature (R → 0)".into(),
        o => o.into(),
    }
}

fn maps(row: &Row) -> String {
    // A merged report (`certify --merge`) holds no full-resolution maps (they are not
    // serialised); its rows point to the shards' heat-map files instead.
    if row.comparison.maps.z.is_empty() {
        return String::new();
    }
    let z_bar = colour_bar(
        |t| diverging(2.0 * t - 1.0),
        &format!("z ≤ −{Z_RANGE}"),
        "0",
        &format!("z ≥ +{Z_RANGE}"),
    );
    let p_bar = colour_bar(
        sequential,
        "p = 1",
        &format!("10<sup>−{}</sup>", P_DECADES / 2.0),
        &format!("p ≤ 10<sup>−{P_DECADES}</sup>"),
    );
    format!(
        "<div class=\"row\"><div>{}{z_bar}</div><div>{}{p_bar}</div></div>",
        picture(
            &z_heatmap(&row.comparison),
            "per-pixel z (grey: zero variance, agreeing; green: disagreeing)"
        ),
        picture(
            &tile_heatmap(&row.comparison),
            "tile Holm p (outlined: rejected; grey: untested)"
        )
    )
}

fn read_image(dir: &Path, rel: &str) -> Option<Image> {
    Image::read(&dir.join(rel)).ok()
}

/// The row's render and oracle image files (relative to the report directory).
fn row_images(row: &Row) -> (Option<&String>, Option<&String>) {
    let exr = |oracle: bool| {
        row.files.iter().find(|f| {
            f.ends_with(".exr")
                && Path::new(f.as_str())
                    .file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with("oracle-") == oracle)
        })
    };
    (exr(false), exr(true))
}

/// Variance of the image mean (average over channels): Σ var / N² per channel.
fn mean_variance(img: &Image) -> f64 {
    let n = img.mean.len() as f64;
    let total: f64 = img
        .var
        .iter()
        .flat_map(|v| v.iter().map(|&x| x as f64))
        .sum();
    total / 3.0 / (n * n)
}

fn fmt_p(p: Option<f64>) -> String {
    p.map_or_else(|| "–".into(), |p| format!("{p:.2e}"))
}

fn pct(x: f64) -> String {
    format!("{:+.3}%", 100.0 * x)
}

/// The forest plot: one line per comparison and channel, relative difference with its CI
/// against the ±δ equivalence band.
fn forest(report: &Report) -> String {
    let rows: Vec<&Row> = report.rows().collect();
    let delta = report.tolerance;
    let mut extent = 2.0 * delta;
    for r in &rows {
        for c in 0..3 {
            if let Some([lo, hi]) = r.rel_ci[c] {
                extent = extent.max(lo.abs()).max(hi.abs());
            }
        }
    }
    extent *= 1.1;
    let (label_w, plot_w, row_h, top) = (300.0, 460.0, 20.0, 24.0);
    let height = top + row_h * rows.len() as f64 + 10.0;
    let x = |v: f64| label_w + plot_w * (0.5 + 0.5 * v / extent);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{height}\" font-size=\"12\" font-family=\"sans-serif\">",
        label_w + plot_w + 20.0
    );
    let _ = write!(
        s,
        "<rect x=\"{:.1}\" y=\"{top}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#e3f2e1\"/>",
        x(-delta),
        x(delta) - x(-delta),
        row_h * rows.len() as f64
    );
    let step = nice_step(extent);
    let mut t = -(extent / step).floor() * step;
    while t <= extent + 1e-12 {
        let _ = write!(
            s,
            "<line x1=\"{0:.1}\" x2=\"{0:.1}\" y1=\"{1}\" y2=\"{2}\" stroke=\"{3}\"/><text x=\"{0:.1}\" y=\"{4}\" text-anchor=\"middle\">{5}</text>",
            x(t),
            top,
            top + row_h * rows.len() as f64,
            if t.abs() < 1e-12 { "#333" } else { "#ddd" },
            top - 6.0,
            format_args!("{:+.2}%", 100.0 * t)
        );
        t += step;
    }
    for (i, r) in rows.iter().enumerate() {
        let y = top + row_h * (i as f64 + 0.5);
        let _ = write!(
            s,
            "<text x=\"4\" y=\"{:.1}\" fill=\"{}\">{} / {} vs {}</text>",
            y + 4.0,
            if r.passed() { "#222" } else { "#b00" },
            esc(&r.scene),
            esc(&r.subject),
            esc(&r.oracle)
        );
        for (c, col) in CHANNEL_COLOURS.iter().enumerate() {
            let yc = y + 4.0 * (c as f64 - 1.0);
            if let (Some(d), Some([lo, hi])) = (r.rel_diff[c], r.rel_ci[c]) {
                let _ = write!(
                    s,
                    "<line x1=\"{:.1}\" x2=\"{:.1}\" y1=\"{yc:.1}\" y2=\"{yc:.1}\" stroke=\"{col}\" stroke-width=\"1.5\"/><circle cx=\"{:.1}\" cy=\"{yc:.1}\" r=\"2.5\" fill=\"{col}\"/>",
                    x(lo),
                    x(hi),
                    x(d),
                );
            }
        }
    }
    s += "</svg>";
    s
}

/// A round tick spacing giving about 4 ticks on each side of 0.
fn nice_step(extent: f64) -> f64 {
    let raw = extent / 4.0;
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p)
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}\
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}\
td:first-child,th:first-child{text-align:left}.pass{color:#1a7f37;font-weight:bold}.fail{color:#b00;font-weight:bold}\
img.px{image-rendering:pixelated;image-rendering:crisp-edges;border:1px solid #aaa}\
figure{margin:0}figcaption{font-size:13px;text-align:center}.row{display:flex;gap:16px;flex-wrap:wrap;margin:6px 0}\
.bar .ticks{display:flex;justify-content:space-between;font-size:11px;width:256px}.note{background:#fff6d6;padding:6px 10px}";

/// Writes [`html`] to `dir/report.html` (next to `report.json` and `report.md` of
/// `report::write_report`).
pub fn write(dir: &Path, report: &Report) -> Result<(), Unusable> {
    let path = dir.join("report.html");
    std::fs::write(&path, html(dir, report)).map_err(|e| io_err(&path, e))
}

/// The page (see the module documentation): the header, the sampler suite, the forest plot,
/// then one section per scene.
pub fn html(dir: &Path, report: &Report) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>linlight certify</title><style>{STYLE}</style></head><body>"
    );
    let _ = write!(
        s,
        "<h1>linlight certify: {}</h1><p>{} comparisons in {:.1} s on {} threads; oracle {:?}; scenes <code>{}</code>. \
         Each comparison runs at the Šidák level α<sub>c</sub> = {:.2e} (family-wise α = {} over m = {}); \
         equivalence margin ±{}% (green band below); render seed {}.</p>",
        verdict(report.passed),
        report.rows().count(),
        report.elapsed_seconds,
        report.threads,
        report.oracle,
        esc(&report.scenes_pattern),
        report.alpha_per_comparison,
        report.alpha,
        report.comparisons_in_family,
        100.0 * report.tolerance,
        report.seed
    );
    if let Some(suite) = &report.sampler_suite {
        s += &suite_section(suite);
    }
    if let Some(g) = &report.gpu_kernels {
        s += &gpu_section(g);
    }
    if report.rows().next().is_some() {
        let _ = write!(
            s,
            "<h2>Relative difference ± CI</h2><p>Per comparison and channel (<span style=\"color:{}\">R</span>, \
             <span style=\"color:{}\">G</span>, <span style=\"color:{}\">B</span>): (A − B)/B of the image means with \
             its equivalence confidence interval; the green band is ±δ.</p>{}",
            CHANNEL_COLOURS[0],
            CHANNEL_COLOURS[1],
            CHANNEL_COLOURS[2],
            forest(report)
        );
    }
    for sc in &report.scenes {
        s += &scene_section(dir, sc);
    }
    s += "</body></html>\n";
    s
}

/// PASS or FAIL, coloured.
fn verdict(ok: bool) -> &'static str {
    if ok {
        "<span class=\"pass\">PASS</span>"
    } else {
        "<span class=\"fail\">FAIL</span>"
    }
}

/// The sampler chi-square suite: its verdict and one table row per subject.
fn suite_section(suite: &SuiteSummary) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<h2>Sampler chi-square suite: {}</h2><p>{} configurations, {} samples each, α = {} ({:.2e} per test), {:.1} s.</p>\
         <table><tr><th>subject</th><th>role</th><th>verdict</th><th>failing configs</th><th>worst p</th><th>time</th></tr>",
        verdict(suite.passed),
        suite.configurations,
        suite.samples,
        suite.alpha,
        suite.alpha_per_test,
        suite.elapsed_seconds
    );
    for (role, rows) in [
        ("technique", &suite.techniques),
        ("negative control", &suite.negative_controls),
    ] {
        for r in rows {
            let _ = write!(
                s,
                "<tr><td>{}</td><td>{role}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1} s</td></tr>",
                esc(&r.name),
                esc(&r.verdict),
                r.failing_cell(),
                fmt_p(r.worst_p_value),
                r.seconds
            );
        }
    }
    s += "</table>";
    s
}

/// The shader kernels: why they were skipped, or their verdict and one row per check.
fn gpu_section(g: &super::gpu::GpuSummary) -> String {
    let mut s = String::new();
    let Some(adapter) = &g.adapter else {
        let _ = write!(s, "<h2>{}</h2>", esc(&g.line()));
        if let Some(note) = &g.note {
            let _ = write!(s, "<p>{}</p>", esc(note));
        }
        return s;
    };
    let _ = write!(
        s,
        "<h2>GPU kernels: {}</h2><p>On {}: {} ξ per configuration for the agreement, {} samples per \
         configuration for the sampler suite on the kernels' answers, {:.1} s.</p>",
        verdict(g.passed),
        esc(adapter),
        g.agreement_samples,
        g.suite_samples,
        g.elapsed_seconds
    );
    if let Some(e) = &g.error {
        let _ = write!(
            s,
            "<p class=\"note\">Backend error (the checks after it did not run): {}</p>",
            esc(e)
        );
    }
    s += "<table><tr><th>check</th><th>verdict</th><th>detail</th></tr>";
    for c in &g.checks {
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&c.name),
            verdict(c.passed),
            esc(&c.detail)
        );
    }
    s += "</table>";
    s
}

/// A scene: its reference, the table of its comparisons, a note per pair of identical
/// renders, and each comparison's pictures and maps.
fn scene_section(dir: &Path, sc: &SceneReport) -> String {
    let mut s = String::new();
    let r = &sc.reference;
    let _ = write!(
        s,
        "<h2>{}</h2><p>Scene <code>{}</code>; reference <code>{}</code>: {}, {} spp in {} passes (dof {}), overrides <code>{}</code>.</p>",
        esc(&sc.name),
        esc(&sc.scene_file.display().to_string()),
        esc(&r.file.display().to_string()),
        esc(&r.renderer),
        r.spp,
        r.passes,
        r.dof,
        esc(&r.overrides)
    );
    let renders = scene_renders(dir, sc);
    s += &scene_table(sc, &renders);
    let names: Vec<&&str> = renders.keys().collect();
    for (i, a) in names.iter().enumerate() {
        for b in &names[i + 1..] {
            let (x, y) = (&renders[**a], &renders[**b]);
            if x.mean == y.mean && x.var == y.var {
                let _ = write!(
                    s,
                    "<p class=\"note\">{} and {} rendered identical images of this scene (the techniques coincide \
                     here, e.g. no light crosses a horizon): their comparisons are one piece of evidence, not two.</p>",
                    esc(a),
                    esc(b)
                );
            }
        }
    }
    for row in &sc.rows {
        s += &row_detail(dir, row);
    }
    s
}

/// The render of each subject of a scene (one per subject, shared by its oracles), read back
/// from the report directory.
fn scene_renders<'a>(dir: &Path, sc: &'a SceneReport) -> BTreeMap<&'a str, Image> {
    let mut renders: BTreeMap<&str, Image> = BTreeMap::new();
    for row in &sc.rows {
        if let (Some(f), false) = (
            row_images(row).0,
            renders.contains_key(row.subject.as_str()),
        ) {
            if let Some(img) = read_image(dir, f) {
                renders.insert(row.subject.as_str(), img);
            }
        }
    }
    renders
}

/// A scene's comparisons as a table, with the efficiency (variance × time) of each render.
fn scene_table(sc: &SceneReport, renders: &BTreeMap<&str, Image>) -> String {
    let mut s = String::new();
    let seconds: BTreeMap<&str, f64> = sc
        .rows
        .iter()
        .map(|r| (r.subject.as_str(), r.render_seconds))
        .collect();
    let cost: BTreeMap<&str, f64> = renders
        .iter()
        .filter_map(|(k, img)| Some((*k, mean_variance(img) * seconds.get(k)?)))
        .filter(|(_, c)| *c > 0.0)
        .collect();
    let best = cost.values().copied().fold(f64::INFINITY, f64::min);
    let _ = write!(
        s,
        "<table><tr><th>technique</th><th>oracle</th><th>verdict</th><th>rel. diff ± CI (worst channel)</th>\
         <th>worst tile p</th><th>spp</th><th>render time</th><th>variance × time</th><th>relative to best</th></tr>"
    );
    for row in &sc.rows {
        let worst = (0..3)
            .filter_map(|c| Some((c, row.rel_diff[c]?, row.rel_ci[c]?)))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
        let rel = worst.map_or_else(
            || "undefined".into(),
            |(c, d, [lo, hi])| {
                format!(
                    "{} [{}, {}] ({})",
                    pct(d),
                    pct(lo),
                    pct(hi),
                    ["R", "G", "B"][c]
                )
            },
        );
        let tile = row
            .comparison
            .channels
            .iter()
            .filter_map(|c| c.tiles.worst.as_ref().map(|t| t.p_holm))
            .min_by(f64::total_cmp);
        let (eff, ratio) = cost.get(row.subject.as_str()).map_or_else(
            || ("–".to_string(), "–".to_string()),
            |c| (format!("{c:.3e}"), format!("{:.2}×", c / best)),
        );
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{rel}</td><td>{}</td><td>{}</td><td>{:.1} s</td><td>{eff}</td><td>{ratio}</td></tr>",
            esc(&super::report::subject_cell(row)),
            esc(&oracle_label(&row.oracle)),
            if row.passed() {
                format!("<span class=\"pass\">{:?}</span>", row.verdict)
            } else {
                format!("<span class=\"fail\">{:?}</span>", row.verdict)
            },
            fmt_p(tile),
            super::report::spp_cell(row),
            row.render_seconds
        );
    }
    s += "</table><p>Variance × time: variance of the image mean (average over channels) times the render time; \
          lower is better, the ratio is the time a technique needs for the precision of the best one.</p>";
    s
}

/// One comparison: heading, the pictures (Rust | oracle | difference), the z and tile maps,
/// and the failed tests.
fn row_detail(dir: &Path, row: &Row) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<h3>{} vs {}: {}</h3>",
        esc(&row.subject),
        esc(&oracle_label(&row.oracle)),
        if row.passed() {
            "consistent"
        } else {
            "DIFFERENT"
        }
    );
    let (fa, fb) = row_images(row);
    match (
        fa.and_then(|f| read_image(dir, f)),
        fb.and_then(|f| read_image(dir, f)),
    ) {
        (Some(a), Some(b)) if (a.width, a.height) == (b.width, b.height) => {
            s += &triptych(&a, &b, &row.oracle);
        }
        _ => s += "<p>(images not found in the report directory)</p>",
    }
    s += &maps(row);
    for f in &row.comparison.failures {
        let _ = write!(
            s,
            "<p class=\"fail\">{:?} [{}]: {}</p>",
            f.test,
            esc(f.channel),
            esc(&f.detail)
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_escaping() {
        assert_eq!(nice_step(0.04), 0.01);
        assert_eq!(nice_step(0.011), 0.005);
        assert_eq!(esc("a<b & \"c\">"), "a&lt;b &amp; &quot;c&quot;&gt;");
        let q = abs_quantile([0.0, -3.0, 1.0, 2.0].into_iter(), 0.5, 9.0);
        assert!(q == 1.0 || q == 2.0);
        assert_eq!(abs_quantile([0.0, 0.0].into_iter(), 0.99, 9.0), 9.0);
    }
}
