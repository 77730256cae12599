//! Convergence: RMSE against the committed Mitsuba reference of `cornell-tube` (64×64) as a
//! function of samples per pixel and of seconds, log–log, one curve per technique, with
//! Mitsuba's own curve (rendered now through the harness when the oracle venv exists and the run
//! is not `--quick`, else from the committed numbers `references/figures/`), and the fitted
//! slopes (−½ for any unbiased Monte Carlo estimator). A second pair of plots does the same for
//! glossy shading (`glossy-blend`, unoccluded): PSA only, LTC only and MIS of both under each
//! heuristic, against the exact line-quadrature image (variance 0).

use super::imaging::{reference_mse, rmse};
use super::page::{num, plot, row, table};
use super::plot::{log_log, Series, PALETTE};
use super::{csv, Ctx, Section};
use linlight_imagefile::Image;
use linlight_render::{Heuristic, Method};
use linlight_sampling::noise::Noise;
use linlight_sampling::Technique;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::Command;

const SCENE: &str = "references/scenes/cornell-tube.xml";
/// The glossy scene of the per-heuristic curves: unoccluded, so its exact image is known.
const GLOSSY: &str = "references/scenes/glossy-blend.xml";
/// Side of the glossy renders in every run: the exact image costs ~25× more at the publication
/// size (320: about 2½ minutes on two loaded cores) and the curves ~25 minutes at 1 … 1024 spp,
/// while the slopes and the ordering of the heuristics do not depend on the film size.
const GLOSSY_RES: u32 = 64;
/// Film positions per pixel side of the exact image (as `linlight unshadowed`'s default).
const EXACT_SUBSAMPLES: u32 = 8;

/// The glossy curves: label and method (one iteration per light and camera sample).
fn glossy_methods() -> Vec<(&'static str, Method)> {
    let mut v = vec![
        (
            "PSA only",
            Method::Technique(Technique::ProjectedSolidAngle),
        ),
        ("LTC only", Method::Ltc),
    ];
    for (label, h) in [
        ("MIS balance", Heuristic::Balance),
        ("MIS power", Heuristic::Power),
        ("MIS weighted balance", Heuristic::Weighted),
        ("MIS clamped optimal v=0.5", Heuristic::ClampedOptimal(0.5)),
    ] {
        v.push((label, Method::Mis(h)));
    }
    v
}
/// Committed numbers of Mitsuba's curve (written by a live run: `mitsuba-convergence.json`).
pub const COMMITTED: &str = "references/figures/mitsuba-convergence-cornell-tube.json";
/// Seeds of Mitsuba's convergence renders start here (the reference used 0 … 31).
const MITSUBA_SEED_OFFSET: u32 = 1000;

/// Least-squares slope of log y over log x.
pub fn slope(points: &[(f64, f64)]) -> f64 {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .map(|p| (p.0.ln(), p.1.ln()))
        .collect();
    let n = pts.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}

/// One point of a curve.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Point {
    pub spp: u64,
    pub rmse: f64,
    pub seconds: f64,
}

/// The oracle venv's Python, if set up.
fn venv(root: &Path) -> Option<PathBuf> {
    let dir = std::env::var_os("LINLIGHT_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join(".venv"));
    dir.join("bin/python").is_file().then_some(dir)
}

/// Mitsuba's curve rendered now by `scripts/harness render` (2 passes of spp/2, seeds from
/// MITSUBA_SEED_OFFSET, disjoint from the reference's).
fn mitsuba_live(ctx: &Ctx, venv: &Path, reference: &Image) -> Result<Vec<Point>, String> {
    let root = &ctx.opts.root;
    let tmp = ctx.opts.out.join("mitsuba-convergence");
    std::fs::create_dir_all(&tmp).map_err(|e| e.to_string())?;
    let mut points = Vec::new();
    let mut spp = 2u64;
    let mut k = 0;
    while spp <= ctx.settings.max_spp.min(512) as u64 {
        let out = tmp.join(format!("mitsuba-{spp}spp.exr"));
        let status = Command::new(root.join("scripts/harness"))
            .env("LINLIGHT_VENV", venv)
            .args(["render", SCENE, "--passes", "2", "--spp"])
            .arg((spp / 2).to_string())
            .args(["-D", "res=64", "--quiet", "--seed-offset"])
            .arg((MITSUBA_SEED_OFFSET + 2 * k).to_string())
            .arg("--out")
            .arg(&out)
            .current_dir(root)
            .output()
            .map_err(|e| format!("scripts/harness: {e}"))?;
        if !status.status.success() {
            return Err(format!(
                "scripts/harness render failed: {}",
                String::from_utf8_lossy(&status.stderr)
            ));
        }
        let img = Image::read(&out).map_err(|e| e.to_string())?;
        let seconds = img
            .meta
            .extra
            .get("wall_time_s")
            .and_then(|s| s.parse().ok())
            .unwrap_or(f64::NAN);
        points.push(Point {
            spp,
            rmse: rmse(&img, reference),
            seconds,
        });
        spp *= 2;
        k += 1;
    }
    Ok(points)
}

/// The curves of one scene: (label, method name, points).
type Curves = Vec<(String, String, Vec<Point>)>;

/// RMSE of each method at each spp (one render per spp, seeds differ) against `reference`.
fn curves(
    ctx: &Ctx,
    scene: &linlight_render::scene::Scene,
    reference: &Image,
    methods: &[(String, Method)],
    spps: &[u32],
    progress: &dyn Fn(usize),
) -> Result<Curves, String> {
    let mut out = Vec::new();
    for (i, (label, method)) in methods.iter().enumerate() {
        let mut pts = Vec::new();
        for &spp in spps {
            let r = ctx.render_method(
                scene,
                *method,
                Noise::White,
                spp,
                1,
                ctx.opts.seed.wrapping_add(spp as u64),
            )?;
            pts.push(Point {
                spp: spp as u64,
                rmse: rmse(&r.image, reference),
                seconds: r.seconds,
            });
        }
        out.push((label.clone(), method.name(), pts));
        progress(i + 1);
    }
    Ok(out)
}

/// Slope of log RMSE over log spp of a curve.
fn spp_slope(pts: &[Point]) -> f64 {
    slope(
        &pts.iter()
            .map(|p| (p.spp as f64, p.rmse))
            .collect::<Vec<_>>(),
    )
}

/// Slope of log RMSE over log seconds of a curve.
fn time_slope(pts: &[Point]) -> f64 {
    slope(&pts.iter().map(|p| (p.seconds, p.rmse)).collect::<Vec<_>>())
}

/// The two log–log plots (by spp, by seconds) of `curves`, written as `<stem>-spp.svg` and
/// `<stem>-time.svg`; their SVG texts and file names.
fn plots(
    ctx: &Ctx,
    stem: &str,
    what: &str,
    curves: &Curves,
) -> Result<[(String, String); 2], String> {
    let series = |f: fn(&Point) -> f64| -> Vec<Series> {
        curves
            .iter()
            .enumerate()
            .map(|(i, (name, _, pts))| Series {
                name: name.clone(),
                points: pts.iter().map(|p| (f(p), p.rmse)).collect(),
                colour: PALETTE[i % PALETTE.len()],
                dashed: name.starts_with("Mitsuba"),
            })
            .collect()
    };
    let by_spp = log_log(
        &format!("{what}: RMSE vs samples per pixel"),
        "spp",
        "RMSE",
        &series(|p| p.spp as f64),
    )?;
    let by_time = log_log(
        &format!("{what}: RMSE vs render time"),
        "seconds",
        "RMSE",
        &series(|p| p.seconds),
    )?;
    let f1 = ctx.write_text(&format!("{stem}-spp.svg"), &by_spp)?;
    let f2 = ctx.write_text(&format!("{stem}-time.svg"), &by_time)?;
    Ok([(by_spp, f1), (by_time, f2)])
}

/// Table rows (curve, slopes, last RMSE, at spp) and the slopes as JSON.
fn slope_rows(curves: &Curves) -> (Vec<Vec<String>>, Vec<serde_json::Value>) {
    let mut rows = Vec::new();
    let mut slopes = Vec::new();
    for (name, method, pts) in curves {
        let (s, st) = (spp_slope(pts), time_slope(pts));
        let last = pts.last().map_or(f64::NAN, |p| p.rmse);
        rows.push(vec![
            format!("<span style=\"float:left\">{name}</span>"),
            num(s),
            num(st),
            num(last),
            pts.last().map_or(String::new(), |p| p.spp.to_string()),
        ]);
        slopes.push(json!({"curve": name, "method": method, "slope": s, "slope_time": st}));
    }
    (rows, slopes)
}

const SLOPE_HEADER: [&str; 5] = [
    "curve",
    "slope of log RMSE vs log spp",
    "vs log seconds",
    "last RMSE",
    "at spp",
];

fn slope_list(slopes: &[serde_json::Value]) -> String {
    slopes
        .iter()
        .map(|s| {
            format!(
                "{} {}",
                s["curve"].as_str().unwrap_or(""),
                num(s["slope"].as_f64().unwrap_or(f64::NAN))
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Mitsuba's own curve against `reference`, rendered in this run when the oracle venv is there
/// (and not --quick), else the committed numbers; and where it came from.
fn mitsuba_curve(ctx: &Ctx, reference: &Image) -> Result<(Vec<Point>, String), String> {
    Ok(match venv(&ctx.opts.root).filter(|_| !ctx.opts.quick) {
        Some(v) => {
            let pts = mitsuba_live(ctx, &v, reference)?;
            (pts, "rendered in this run by scripts/harness (Mitsuba 3, emitter sampling of the cylinder = area sampling)".to_string())
        }
        None => {
            let path = ctx.opts.root.join(COMMITTED);
            let text =
                std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
            let pts: Vec<Point> =
                serde_json::from_value(v["points"].clone()).map_err(|e| e.to_string())?;
            (pts, format!("the committed numbers {COMMITTED} (from an earlier run with the oracle venv; no venv, or --quick, in this run)"))
        }
    })
}

/// Every point of both sets of curves as convergence.csv.
fn write_csv(ctx: &Ctx, curves: &Curves, glossy: &Curves) -> Result<String, String> {
    let mut csv_rows = Vec::new();
    for (scene_name, set) in [("cornell-tube", curves), ("glossy-blend", glossy)] {
        for (name, method, pts) in set.iter() {
            for p in pts {
                csv_rows.push(vec![
                    scene_name.to_string(),
                    name.clone(),
                    method.clone(),
                    p.spp.to_string(),
                    format!("{}", p.rmse),
                    format!("{}", p.seconds),
                ]);
            }
        }
    }
    ctx.write_text(
        "convergence.csv",
        &csv(
            &["scene", "curve", "method", "spp", "rmse", "seconds"],
            &csv_rows,
        ),
    )
}

pub fn make(ctx: &Ctx) -> Result<Section, String> {
    let overrides = vec![("res", "64".to_string())];
    let (reference, what) = ctx.reference(SCENE, &overrides)?;
    let scene = ctx.scene(SCENE, &overrides)?;
    let spps = spp_ladder(ctx.settings.max_spp);
    let techniques: Vec<(String, Method)> = Technique::UNBIASED
        .into_iter()
        .map(|t| (t.name().to_string(), t.into()))
        .collect();
    let glossy_list: Vec<(String, Method)> = glossy_methods()
        .into_iter()
        .map(|(l, m)| (l.to_string(), m))
        .collect();
    let steps = (techniques.len() + glossy_list.len() + 2) as f64;
    let mut curves = curves(ctx, &scene, &reference, &techniques, &spps, &|i| {
        ctx.progress(i as f64 / steps)
    })?;
    let (mitsuba_source, mitsuba_file) = add_mitsuba_curve(ctx, &reference, &mut curves)?;
    ctx.progress((techniques.len() + 1) as f64 / steps);
    let base = techniques.len() + 1;
    let (glossy, glossy_what) = glossy_curves(ctx, &glossy_list, &spps, &|i| {
        ctx.progress((base + i) as f64 / steps)
    })?;
    ctx.progress(1.0);

    let [(svg_spp, f_spp), (svg_time, f_time)] = plots(ctx, "convergence", "Cornell box", &curves)?;
    let [(gsvg_spp, gf_spp), (gsvg_time, gf_time)] =
        plots(ctx, "convergence-mis", "glossy-blend", &glossy)?;
    let mut files = vec![f_spp, f_time, gf_spp, gf_time, mitsuba_file];
    files.push(write_csv(ctx, &curves, &glossy)?);
    let (rows, slopes) = slope_rows(&curves);
    let (grows, gslopes) = slope_rows(&glossy);
    let (slope_table, glossy_table) = (table(&SLOPE_HEADER, &rows), table(&SLOPE_HEADER, &grows));
    let body = format!(
        "{}{slope_table}<h3 id=\"mis-heuristics\">Glossy shading: one curve per MIS heuristic</h3>{}{glossy_table}",
        row(&[plot(&svg_spp), plot(&svg_time)]),
        row(&[plot(&gsvg_spp), plot(&gsvg_time)]),
    );
    let floor = reference_mse(&reference).sqrt();
    let caption = caption(
        ctx,
        (&what, &mitsuba_source, &glossy_what),
        floor,
        (&slopes, &gslopes),
        &glossy,
    );
    let summary_html = format!(
        "<p>Convergence slopes (log RMSE over log spp; −½ expected), Cornell box:</p>{slope_table}\
         <p>Glossy shading, one curve per MIS heuristic (<code>{GLOSSY}</code>, against the exact image):</p>{glossy_table}"
    );
    Ok(Section {
        caption,
        body,
        files,
        numbers: numbers_json(
            (&what, &mitsuba_source, &glossy_what),
            floor,
            (&curves, &glossy),
            (slopes, gslopes),
            summary_html,
        ),
        ..Default::default()
    })
}

/// 1, 2, 4, … up to the first power of two ≥ `max_spp`.
fn spp_ladder(max_spp: u32) -> Vec<u32> {
    let mut spps = vec![1u32];
    while *spps.last().unwrap() < max_spp {
        spps.push(spps.last().unwrap() * 2);
    }
    spps
}

/// Mitsuba's curve (live or committed), written to mitsuba-convergence.json and appended to
/// `curves`; where it comes from, and the file.
fn add_mitsuba_curve(
    ctx: &Ctx,
    reference: &Image,
    curves: &mut Curves,
) -> Result<(String, String), String> {
    let (mitsuba, mitsuba_source) = mitsuba_curve(ctx, reference)?;
    let mitsuba_file = ctx.write_text(
        "mitsuba-convergence.json",
        &serde_json::to_string_pretty(
            &json!({"scene": SCENE, "overrides": "res=64", "points": mitsuba}),
        )
        .map_err(|e| e.to_string())?,
    )?;
    curves.push((
        "Mitsuba 3 (area sampling)".into(),
        "mitsuba:area".into(),
        mitsuba,
    ));
    Ok((mitsuba_source, mitsuba_file))
}

/// The figure's numbers: references, every curve's points and fitted slopes.
fn numbers_json(
    (what, mitsuba_source, glossy_what): (&str, &str, &str),
    floor: f64,
    (curves, glossy): (&Curves, &Curves),
    (slopes, gslopes): (Vec<serde_json::Value>, Vec<serde_json::Value>),
    summary_html: String,
) -> serde_json::Value {
    json!({
        "reference": what, "reference_rmse_floor": floor,
        "curves": curves.iter().map(|(n, m, p)| json!({"curve": n, "method": m, "points": p})).collect::<Vec<_>>(),
        "slopes": slopes, "mitsuba_source": mitsuba_source,
        "glossy": {
            "scene": GLOSSY, "res": GLOSSY_RES, "reference": glossy_what,
            "curves": glossy.iter().map(|(n, m, p)| json!({"curve": n, "method": m, "points": p})).collect::<Vec<_>>(),
            "slopes": gslopes,
        },
        "summary_html": summary_html,
    })
}

/// Glossy shading, one curve per MIS heuristic, against the exact image (variance 0: the
/// RMSE has no floor, so the slopes are those of the estimators alone); with what that image is.
fn glossy_curves(
    ctx: &Ctx,
    methods: &[(String, Method)],
    spps: &[u32],
    progress: &dyn Fn(usize),
) -> Result<(Curves, String), String> {
    let glossy_overrides = vec![("res", GLOSSY_RES.to_string())];
    let glossy_scene = ctx.scene(GLOSSY, &glossy_overrides)?;
    let exact = crate::certify::closed_form::image(&glossy_scene, EXACT_SUBSAMPLES)?
        .ok_or_else(|| format!("{GLOSSY}: no exact image"))?;
    let glossy_what = format!(
        "the exact image by {} along the line ({EXACT_SUBSAMPLES}×{EXACT_SUBSAMPLES} film positions per pixel, \
         variance 0; what <code>linlight unshadowed</code> writes and <code>linlight certify</code> tests against)",
        crate::certify::closed_form::oracle_name(&exact)
    );
    let glossy = curves(ctx, &glossy_scene, &exact, methods, spps, progress)?;
    Ok((glossy, glossy_what))
}

/// What the figure shows, its settings (`what`: the Cornell reference, Mitsuba's curve's
/// source, the glossy reference), the fitted slopes and the glossy RMSE at the largest spp.
fn caption(
    ctx: &Ctx,
    (what, mitsuba_source, glossy_what): (&str, &str, &str),
    floor: f64,
    (slopes, gslopes): (&[serde_json::Value], &[serde_json::Value]),
    glossy: &Curves,
) -> String {
    let at = |label: &str| -> f64 {
        glossy
            .iter()
            .find(|c| c.0 == label)
            .and_then(|c| c.2.last())
            .map_or(f64::NAN, |p| p.rmse)
    };
    let (psa_last, mis_last) = (at("PSA only"), at("MIS clamped optimal v=0.5"));
    let max_spp = ctx.settings.max_spp;
    format!(
        "What it shows: every unbiased technique converges at the Monte Carlo rate (slope −½ of log RMSE over \
         log spp); the techniques differ by a constant factor, which is their variance, and at equal time by \
         variance × cost. Settings: the Cornell box at 64×64 (the size of its committed reference), white noise, \
         one render per spp (1 … {max_spp} spp, seeds differ), RMSE over pixels and RGB against {what}, its variance \
         (RMSE floor {}) subtracted; Mitsuba's curve is {mitsuba_source}. Fitted slopes: {}. \
         Second row: glossy shading (<code>{GLOSSY}</code>, a 65 % diffuse / 35 % GGX α = 0.2 blend, unoccluded) at \
         {r}×{r}, white noise, 1 … {max_spp} spp, PSA only and LTC only (one sample per light and camera sample) and \
         MIS of one PSA and one LTC sample under each heuristic (two samples), RMSE against {glossy_what}. \
         Fitted slopes: {}. At {max_spp} spp, MIS clamped optimal (v = 0.5) has RMSE {} against PSA only's {} \
         (ratio {}; MIS takes twice the light samples per spp: the time plot compares at equal cost).",
        num(floor),
        slope_list(slopes),
        slope_list(gslopes),
        num(mis_last),
        num(psa_last),
        num(mis_last / psa_last),
        r = GLOSSY_RES,
    )
}
