//! The paper's timing table: every technique shading the cached hit points of a 1920×1080 frame
//! (BRDF evaluated, no shadow rays), 128 lights × 1 spp and 1 light × 128 spp, as ratios to
//! clipped solid angle, next to the paper's frame times (clipped solid angle 1.1 ms, ours
//! 1.1 ms, ours + LTC MIS 1.5 ms). The measurement is [`super::shading_cost`], the same code as
//! `cargo bench -p linlight --bench shading`.

use super::page::{num, table};
use super::shading_cost::{measure, Batched, ConfigTiming, Measurement, RowKind};
use super::{csv, Ctx, Section};
use linlight_sampling::Technique;
use linlight_simd::Isa;
use serde_json::json;

/// The paper's figure 1 frame times (RTX 2080 Ti, 1920×1080, Bistro exterior), ms.
fn paper_ms(kind: RowKind) -> &'static str {
    match kind {
        RowKind::Scalar(Technique::ClippedSolidAngle) => "1.1 ms (1)",
        RowKind::Scalar(Technique::ProjectedSolidAngle) => "1.1 ms (1.0)",
        _ => "",
    }
}

pub fn make(ctx: &Ctx) -> Result<Section, String> {
    let s = ctx.settings;
    let m = measure(
        s.timing_stride,
        s.timing_repeats,
        Isa::detect(),
        &|done, total| ctx.progress(done as f64 / total as f64),
    );
    let (a, b) = (&m.configs[0], &m.configs[1]);
    let (rows, csv_rows, json_rows) = table_rows(a, b);
    let csv_file = write_csv(ctx, &csv_rows)?;
    let header = [
        "technique",
        "128 lights × 1 spp: ns/sample median (min)",
        "÷ clipped SA",
        "ms/frame (CPU, 1 core)",
        "1 light × 128 spp: ns/sample median (min)",
        "÷ clipped SA",
        "paper (GPU, 128 lights)",
    ];
    Ok(Section {
        caption: caption(&m),
        body: table(&header, &rows),
        files: vec![csv_file],
        numbers: json!({
            "stride": m.stride, "repeats": m.repeats, "hit_points": m.hit_points, "isa": m.isa,
            "load": [a.load, b.load],
            "li_iterations_per_batch": [a.li_iterations_per_batch, b.li_iterations_per_batch],
            "rows": json_rows,
            "paper_ms": {"clipped-solid-angle": 1.1, "projected-solid-angle": 1.1, "projected-solid-angle + LTC MIS": 1.5},
            "summary_html": summary_html(a, b),
        }),
        ..Default::default()
    })
}

/// The table's rows (HTML cells), the CSV rows and the JSON rows of the two configurations
/// `a` (128 lights × 1 spp) and `b` (1 light × 128 spp), row by row.
fn table_rows(
    a: &ConfigTiming,
    b: &ConfigTiming,
) -> (Vec<Vec<String>>, Vec<Vec<String>>, Vec<serde_json::Value>) {
    let mut rows = Vec::new();
    let mut csv_rows = Vec::new();
    let mut json_rows = Vec::new();
    for (ra, rb) in a.rows.iter().zip(&b.rows) {
        let (na, na_min) = a.ns_per_sample(ra);
        let (nb, nb_min) = b.ns_per_sample(rb);
        let (qa, qa_min) = a.ratio_to_clipped(ra);
        let (qb, qb_min) = b.ratio_to_clipped(rb);
        let (fa, _) = a.ms_per_frame(ra);
        rows.push(vec![
            format!("<span style=\"float:left\">{}</span>", ra.name),
            format!("{} ({})", num(na), num(na_min)),
            format!("<b>{}</b> ({})", num(qa), num(qa_min)),
            num(fa),
            format!("{} ({})", num(nb), num(nb_min)),
            format!("<b>{}</b> ({})", num(qb), num(qb_min)),
            paper_ms(ra.kind).to_string(),
        ]);
        csv_rows.push(
            [
                ra.name.clone(),
                format!("{na}"),
                format!("{na_min}"),
                format!("{qa}"),
                format!("{qa_min}"),
                format!("{nb}"),
                format!("{nb_min}"),
                format!("{qb}"),
                format!("{qb_min}"),
            ]
            .to_vec(),
        );
        json_rows.push(json!({
            "row": ra.name,
            "ns_per_sample_128x1": [na, na_min], "ratio_128x1": [qa, qa_min], "ms_per_frame_128x1": fa,
            "ns_per_sample_1x128": [nb, nb_min], "ratio_1x128": [qb, qb_min],
        }));
    }
    (rows, csv_rows, json_rows)
}

/// timings.csv: the medians and minima of [`table_rows`].
fn write_csv(ctx: &Ctx, csv_rows: &[Vec<String>]) -> Result<String, String> {
    ctx.write_text(
        "timings.csv",
        &csv(
            &[
                "row",
                "ns_per_sample_128x1_median",
                "ns_per_sample_128x1_min",
                "ratio_128x1_median",
                "ratio_128x1_min",
                "ns_per_sample_1x128_median",
                "ns_per_sample_1x128_min",
                "ratio_1x128_median",
                "ratio_1x128_min",
            ],
            csv_rows,
        ),
    )
}

/// The figure's caption: settings and the measured ratios of `m`.
fn caption(m: &Measurement) -> String {
    let (a, b) = (&m.configs[0], &m.configs[1]);
    let ratio = |c: &ConfigTiming, t: Technique| {
        c.row(RowKind::Scalar(t))
            .map_or(f64::NAN, |r| c.ratio_to_clipped(r).0)
    };
    let psa = (
        ratio(a, Technique::ProjectedSolidAngle),
        ratio(b, Technique::ProjectedSolidAngle),
    );
    let li = (ratio(a, Technique::Li2018), ratio(b, Technique::Li2018));
    let x8 = RowKind::Batched;
    format!(
        "What it shows: the cost of each sampling technique in a shading loop, as the paper's timing table — every \
         technique prepares and draws one sample per light and sample, evaluates Lambert + GGX (F0 = 0.04, α in ten \
         stripes from 0.05 to 1) and divides by the density; no shadow rays. Settings: cached hit points of a \
         1920×1080 frame of two planes (every {}th pixel of every {}th row: {} hit points), 128 lights × 1 spp and \
         1 light × 128 spp, {} interleaved repeats, one thread, batch kernel {}; load average {} and {} (timings on \
         a shared machine are noisy: compare rows of this run only). Measured: projected solid angle (ours) costs \
         {}× and {}× clipped solid angle (paper, GPU: 1.1 ms vs 1.1 ms, i.e. 1.0×; with LTC MIS 1.5 ms), Li et al. \
         {}× and {}×; the 8-wide batches of ours run {}× and {}× the scalar clipped solid angle, and {}× and {}× \
         the 8-wide batches of clipped solid angle (like for like). Ratios are median over median (minimum over \
         minimum in parentheses).",
        m.stride,
        m.stride,
        m.hit_points,
        m.repeats,
        m.isa,
        a.load,
        b.load,
        num(psa.0),
        num(psa.1),
        num(li.0),
        num(li.1),
        num(a.row(RowKind::Batched(Batched::ProjectedSolidAngle))
            .map_or(f64::NAN, |r| a.ratio_to_clipped(r).0)),
        num(b.row(RowKind::Batched(Batched::ProjectedSolidAngle))
            .map_or(f64::NAN, |r| b.ratio_to_clipped(r).0)),
        num(a.ratio(x8(Batched::ProjectedSolidAngle), x8(Batched::ClippedSolidAngle)).0),
        num(b.ratio(x8(Batched::ProjectedSolidAngle), x8(Batched::ClippedSolidAngle)).0),
    )
}

/// The short table of ratios to clipped solid angle (HTML), for the summary page.
fn summary_html(a: &ConfigTiming, b: &ConfigTiming) -> String {
    let summary_rows: Vec<Vec<String>> = a
        .rows
        .iter()
        .zip(&b.rows)
        .map(|(ra, rb)| {
            vec![
                format!("<span style=\"float:left\">{}</span>", ra.name),
                num(a.ratio_to_clipped(ra).0),
                num(b.ratio_to_clipped(rb).0),
                paper_ms(ra.kind).to_string(),
            ]
        })
        .collect();
    format!(
        "<p>Timing ratios to clipped solid angle (median):</p>{}",
        table(
            &["technique", "128 × 1", "1 × 128", "paper (GPU)"],
            &summary_rows
        )
    )
}
