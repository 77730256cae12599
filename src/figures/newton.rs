//! "Newton is bad for sampling": Li et al. 2018 invert the projected-solid-angle CDF by Newton
//! with a bisection fallback until a residual test passes (≤ 20 iterations); ours takes two
//! Halley steps always. Per sample: the iteration count of Li et al. (histogram), where the 20
//! iterations run out (map), and the cost per sample of both with its spread over pixels.

use super::imaging::enlarge;
use super::page::{num, picture, plot, row, table};
use super::plot::{histogram, PALETTE};
use super::{csv, hit_points, Ctx, HitPoint, Section};
use linlight_sampling::li2018::Li2018;
use linlight_sampling::noise::{Noise, NoiseSource};
use linlight_sampling::projected_solid_angle::ProjectedSolidAngle;
use linlight_sampling::{LineSampler, Segment};
use linlight_verify::heatmap::{sequential, Rgb8};
use serde_json::json;
use std::hint::black_box;
use std::time::Instant;

/// Li et al.'s iteration limit.
const LIMIT: u32 = 20;
const RAN_OUT: [u8; 3] = [0, 170, 0];

fn percentile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// Li et al.'s iteration counts: their histogram over every sample, the per-pixel map, and
/// the pixels' numbers.
struct Iterations {
    /// Samples that took k iterations (k = [`LIMIT`]: ran out).
    counts: Vec<u64>,
    /// Mean iterations per pixel; [`RAN_OUT`] where some sample ran out.
    map: Rgb8,
    total: u64,
    ran_out_pixels: usize,
    /// Each pixel with a light above its horizon: its index and its numbers ξ.
    xis: Vec<(usize, Vec<f32>)>,
}

/// [`Iterations`] of `samples` numbers of `source` per hit point and light.
fn iteration_counts(
    hits: &[Option<HitPoint>],
    segs: &[Segment],
    source: &NoiseSource,
    samples: u32,
    width: u32,
    res: u32,
) -> Iterations {
    let mut counts = vec![0u64; LIMIT as usize + 1];
    let mut map = Rgb8::filled(res as usize, res as usize, super::imaging::NO_VALUE);
    let mut total = 0u64;
    let mut ran_out_pixels = 0usize;
    let mut xis: Vec<(usize, Vec<f32>)> = Vec::new();
    for (i, h) in hits.iter().enumerate() {
        let Some(h) = h else { continue };
        let xi: Vec<f32> = (0..samples)
            .map(|s| {
                let mut st = source.stream(h.x, h.y, h.y * width + h.x, 0, s);
                let _ = st.film_position();
                st.next_f32()
            })
            .collect();
        let mut sum = 0u64;
        let mut n = 0u64;
        let mut out = false;
        for seg in segs {
            let Some(li) = Li2018::prepare(seg, h.p, h.n) else {
                continue;
            };
            for &x in &xi {
                let (_, k) = li.sample_l(x);
                counts[k as usize] += 1;
                sum += k as u64;
                n += 1;
                out |= k >= LIMIT;
            }
        }
        if n > 0 {
            total += n;
            let mean = sum as f64 / n as f64;
            let (x, y) = (i % res as usize, i / res as usize);
            map.set(
                x,
                y,
                if out {
                    RAN_OUT
                } else {
                    sequential(mean / 10.0)
                },
            );
            ran_out_pixels += usize::from(out);
            xis.push((i, xi));
        }
    }
    Iterations {
        counts,
        map,
        total,
        ran_out_pixels,
        xis,
    }
}

/// Cost per sample (ns) of Li et al. and of ours, per pixel of `xis`: prepare once, then all
/// samples of the pixel; three interleaved repeats, the minimum per pixel (least disturbed by
/// the machine's load).
fn cost_per_sample(
    ctx: &Ctx,
    hits: &[Option<HitPoint>],
    segs: &[Segment],
    xis: &[(usize, Vec<f32>)],
) -> (Vec<f64>, Vec<f64>) {
    let repeats = 3;
    let mut li_ns = vec![f64::INFINITY; xis.len()];
    let mut psa_ns = vec![f64::INFINITY; xis.len()];
    for rep in 0..repeats {
        for (j, (i, xi)) in xis.iter().enumerate() {
            let h = hits[*i].expect("hit");
            let t = Instant::now();
            for seg in segs {
                if let Some(li) = Li2018::prepare(seg, h.p, h.n) {
                    for &x in xi {
                        black_box(li.sample_with_pdf(black_box(x)));
                    }
                }
            }
            let li_t = t.elapsed().as_secs_f64();
            let t = Instant::now();
            for seg in segs {
                if let Some(p) = ProjectedSolidAngle::prepare(seg, h.p, h.n) {
                    for &x in xi {
                        black_box(p.sample_with_pdf(black_box(x)));
                    }
                }
            }
            let psa_t = t.elapsed().as_secs_f64();
            let per = 1e9 / (xi.len() * segs.len()) as f64;
            li_ns[j] = li_ns[j].min(li_t * per);
            psa_ns[j] = psa_ns[j].min(psa_t * per);
        }
        ctx.progress(0.3 + 0.7 * (rep + 1) as f64 / repeats as f64);
    }
    (li_ns, psa_ns)
}

pub fn make(ctx: &Ctx) -> Result<Section, String> {
    let res = ctx.settings.res;
    let rel = super::cornell::SCENE;
    let scene = ctx.scene(rel, &[("res", res.to_string())])?;
    let hits = hit_points(&scene)?;
    let segs: Vec<Segment> = scene
        .lights
        .iter()
        .map(|l| Segment::new(l.begin, l.end))
        .collect();
    let samples: u32 = if ctx.opts.quick { 32 } else { 128 };
    let source = NoiseSource::new(Noise::White, ctx.opts.seed, samples);
    let width = scene.sensor.film.width;
    let it = iteration_counts(&hits, &segs, &source, samples, width, res);
    ctx.progress(0.3);
    let (li_ns, psa_ns) = cost_per_sample(ctx, &hits, &segs, &it.xis);
    let (li_s, psa_s) = (Spread::of(&li_ns), Spread::of(&psa_ns));
    let svg = histogram(
        "Li et al. 2018: Newton/bisection iterations per sample",
        "iterations until |CDF − ξ| < 1e-5 (20 = ran out)",
        "samples",
        0,
        &it.counts,
        PALETTE[0],
    )?;
    let files = write_files(ctx, &svg, &it)?;
    let body = body_html(&svg, &it.map, res, &li_s, &psa_s);
    let Iterations {
        counts,
        total,
        ran_out_pixels,
        ..
    } = it;
    let mean_iterations = mean_of_histogram(&counts, total);
    let ran_out = counts[LIMIT as usize];
    Ok(Section {
        caption: caption(
            res,
            samples,
            total,
            mean_iterations,
            ran_out,
            ran_out_pixels,
            &li_s,
            &psa_s,
        ),
        body,
        files,
        numbers: json!({
            "samples": total, "iteration_histogram": counts, "mean_iterations": mean_iterations,
            "ran_out_samples": ran_out, "ran_out_pixels": ran_out_pixels,
            "li_ns_per_sample": li_s.json(),
            "psa_ns_per_sample": psa_s.json(),
        }),
        ..Default::default()
    })
}

/// The histogram and the map side by side, then the table of costs per sample.
fn body_html(svg: &str, map: &Rgb8, res: u32, li_s: &Spread, psa_s: &Spread) -> String {
    let zoom = (256 / res as usize).max(1);
    format!(
        "{}{}{}",
        row(&[
            plot(svg),
            picture(
                &enlarge(map, zoom),
                1,
                "mean iterations of Li et al. per pixel (white 0 → dark red ≥ 10); green: some sample ran out of its 20 iterations"
            ),
        ]),
        "<p>Cost per sample (prepare + sample + pdf, one thread), ns, over pixels:</p>",
        table(
            &["sampler", "mean", "5 %", "median", "95 %", "99.9 %"],
            &[
                li_s.cells("Li et al. 2018"),
                psa_s.cells("projected solid angle (ours, 2 Halley steps)")
            ]
        )
    )
}

/// The mean iteration count of a histogram of `total` samples (bin k: k iterations).
fn mean_of_histogram(counts: &[u64], total: u64) -> f64 {
    counts
        .iter()
        .enumerate()
        .map(|(k, &c)| k as f64 * c as f64)
        .sum::<f64>()
        / total.max(1) as f64
}

/// The mean and percentiles of the cost per sample over pixels (ns).
struct Spread {
    mean: f64,
    p5: f64,
    median: f64,
    p95: f64,
    p999: f64,
}

impl Spread {
    fn of(v: &[f64]) -> Self {
        let mut v = v.to_vec();
        let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
        Self {
            mean,
            p5: percentile(&mut v, 0.05),
            median: percentile(&mut v, 0.5),
            p95: percentile(&mut v, 0.95),
            p999: percentile(&mut v, 0.999),
        }
    }

    /// A table row: the sampler's name, then mean, 5 %, median, 95 % and 99.9 %.
    fn cells(&self, name: &str) -> Vec<String> {
        vec![
            name.to_string(),
            num(self.mean),
            num(self.p5),
            num(self.median),
            num(self.p95),
            num(self.p999),
        ]
    }

    fn json(&self) -> serde_json::Value {
        json!({"mean": self.mean, "p5": self.p5, "median": self.median, "p95": self.p95, "p99.9": self.p999})
    }
}

/// The histogram (SVG), the per-pixel map (PNG) and the histogram's CSV.
fn write_files(ctx: &Ctx, svg: &str, it: &Iterations) -> Result<Vec<String>, String> {
    let mut files = vec![ctx.write_text("newton-iterations.svg", svg)?];
    files.push(ctx.write_png("newton-li-iterations-map", &it.map)?);
    files.push(
        ctx.write_text(
            "newton-iterations.csv",
            &csv(
                &["iterations", "samples"],
                &it.counts
                    .iter()
                    .enumerate()
                    .map(|(k, c)| vec![k.to_string(), c.to_string()])
                    .collect::<Vec<_>>(),
            ),
        )?,
    );
    Ok(files)
}

/// What the figure shows, its settings, and the iterations and costs measured.
#[allow(clippy::too_many_arguments)]
fn caption(
    res: u32,
    samples: u32,
    total: u64,
    mean_iterations: f64,
    ran_out: u64,
    ran_out_pixels: usize,
    li_s: &Spread,
    psa_s: &Spread,
) -> String {
    format!(
        "What it shows: Newton's method converges fast when it converges, but its iteration count varies with the \
         sample, so its cost per sample varies (bad for a GPU warp, which waits for its slowest lane) and it has to \
         stop somewhere. Li et al. 2018 stop after 20 iterations; ours always takes two Halley steps. Settings: the \
         Cornell box, {res}×{res} pixel centres, {samples} white-noise samples per pixel and light ({total} samples). \
         Measured: Li et al. took {} iterations on average; {ran_out} samples ({} %) in {ran_out_pixels} pixels ran \
         out of the 20 iterations without meeting the residual test (green in the map: where the CDF is flat, near \
         horizon-clipped ends). Cost per sample over pixels: Li et al. median {} ns (5–95 %: {}–{}), ours median {} ns \
         ({}–{}); Li et al. / ours = {} (median).",
        num(mean_iterations),
        num(100.0 * ran_out as f64 / total.max(1) as f64),
        num(li_s.median),
        num(li_s.p5),
        num(li_s.p95),
        num(psa_s.median),
        num(psa_s.p5),
        num(psa_s.p95),
        num(li_s.median / psa_s.median),
    )
}
