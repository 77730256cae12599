//! Convergence: RMSE against the committed Mitsuba reference of `cornell-tube` (64×64) as a
//! function of samples per pixel and of seconds, log–log, one curve per technique, with
//! Mitsuba's own curve (rendered now through the harness when the oracle venv exists and the run
//! is not `--quick`, else from the committed numbers `references/figures/`), and the fitted
//! slopes (−½ for any unbiased Monte Carlo estimator).

use super::imaging::{reference_mse, rmse};
use super::page::{num, plot, row, table};
use super::plot::{log_log, Series, PALETTE};
use super::{csv, Ctx, Section};
use linlight_imagefile::Image;
use linlight_sampling::noise::Noise;
use linlight_sampling::Technique;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::Command;

const SCENE: &str = "references/scenes/cornell-tube.xml";
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

pub fn make(ctx: &Ctx) -> Result<Section, String> {
    let overrides = vec![("res", "64".to_string())];
    let (reference, what) = ctx.reference(SCENE, &overrides)?;
    let scene = ctx.scene(SCENE, &overrides)?;
    let mut spps = vec![1u32];
    while *spps.last().unwrap() < ctx.settings.max_spp {
        spps.push(spps.last().unwrap() * 2);
    }
    let mut curves: Vec<(String, Vec<Point>)> = Vec::new();
    let n = Technique::UNBIASED.len() as f64;
    for (i, t) in Technique::UNBIASED.into_iter().enumerate() {
        let mut pts = Vec::new();
        for &spp in &spps {
            let r = ctx.render(
                &scene,
                t,
                Noise::White,
                spp,
                1,
                ctx.opts.seed.wrapping_add(spp as u64),
            )?;
            pts.push(Point {
                spp: spp as u64,
                rmse: rmse(&r.image, &reference),
                seconds: r.seconds,
            });
        }
        curves.push((t.name().to_string(), pts));
        ctx.progress((i + 1) as f64 / (n + 1.0));
    }
    // Mitsuba's own curve.
    let (mitsuba, mitsuba_source) = match venv(&ctx.opts.root).filter(|_| !ctx.opts.quick) {
        Some(v) => {
            let pts = mitsuba_live(ctx, &v, &reference)?;
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
    };
    ctx.progress(1.0);
    let mitsuba_file = ctx.write_text(
        "mitsuba-convergence.json",
        &serde_json::to_string_pretty(
            &json!({"scene": SCENE, "overrides": "res=64", "points": mitsuba}),
        )
        .map_err(|e| e.to_string())?,
    )?;
    curves.push(("Mitsuba 3 (area sampling)".into(), mitsuba));
    let series = |f: fn(&Point) -> f64| -> Vec<Series> {
        curves
            .iter()
            .enumerate()
            .map(|(i, (name, pts))| Series {
                name: name.clone(),
                points: pts.iter().map(|p| (f(p), p.rmse)).collect(),
                colour: PALETTE[i % PALETTE.len()],
                dashed: name.starts_with("Mitsuba"),
            })
            .collect()
    };
    let by_spp = log_log(
        "RMSE vs samples per pixel",
        "spp",
        "RMSE",
        &series(|p| p.spp as f64),
    )?;
    let by_time = log_log(
        "RMSE vs render time",
        "seconds",
        "RMSE",
        &series(|p| p.seconds),
    )?;
    let mut files = vec![
        ctx.write_text("convergence-spp.svg", &by_spp)?,
        ctx.write_text("convergence-time.svg", &by_time)?,
        mitsuba_file,
    ];
    let mut csv_rows = Vec::new();
    let mut slope_rows = Vec::new();
    let mut slopes = Vec::new();
    for (name, pts) in &curves {
        for p in pts {
            csv_rows.push(vec![
                name.clone(),
                p.spp.to_string(),
                format!("{}", p.rmse),
                format!("{}", p.seconds),
            ]);
        }
        let s = slope(
            &pts.iter()
                .map(|p| (p.spp as f64, p.rmse))
                .collect::<Vec<_>>(),
        );
        let last = pts.last().map_or(f64::NAN, |p| p.rmse);
        slope_rows.push(vec![
            format!("<span style=\"float:left\">{name}</span>"),
            num(s),
            num(last),
            pts.last().map_or(String::new(), |p| p.spp.to_string()),
        ]);
        slopes.push(json!({"curve": name, "slope": s}));
    }
    files.push(ctx.write_text(
        "convergence.csv",
        &csv(&["curve", "spp", "rmse", "seconds"], &csv_rows),
    )?);
    let slope_table = table(
        &[
            "curve",
            "slope of log RMSE vs log spp",
            "last RMSE",
            "at spp",
        ],
        &slope_rows,
    );
    let body = format!("{}{}", row(&[plot(&by_spp), plot(&by_time)]), slope_table);
    let floor = reference_mse(&reference).sqrt();
    let caption = format!(
        "What it shows: every unbiased technique converges at the Monte Carlo rate (slope −½ of log RMSE over \
         log spp); the techniques differ by a constant factor, which is their variance, and at equal time by \
         variance × cost. Settings: the Cornell box at 64×64 (the size of its committed reference), white noise, \
         one render per spp (1 … {} spp, seeds differ), RMSE over pixels and RGB against {what}, its variance \
         (RMSE floor {}) subtracted; Mitsuba's curve is {mitsuba_source}. Fitted slopes: {}.",
        ctx.settings.max_spp,
        num(floor),
        slopes
            .iter()
            .map(|s| format!("{} {}", s["curve"].as_str().unwrap_or(""), num(s["slope"].as_f64().unwrap_or(f64::NAN))))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let summary_html =
        format!("<p>Convergence slopes (log RMSE over log spp; −½ expected):</p>{slope_table}");
    Ok(Section {
        caption,
        body,
        files,
        numbers: json!({
            "reference": what, "reference_rmse_floor": floor,
            "curves": curves.iter().map(|(n, p)| json!({"curve": n, "points": p})).collect::<Vec<_>>(),
            "slopes": slopes, "mitsuba_source": mitsuba_source, "summary_html": summary_html,
        }),
        ..Default::default()
    })
}
