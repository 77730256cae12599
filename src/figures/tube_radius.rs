//! The R → 0 limit of a finite tube light: with K = radiance × radius fixed, renders of the tube
//! as the cylinder it is (`--cylinders exact`) approach the render of the linear light of
//! intensity K (`--cylinders line`) at first order in R.
//!
//! Measure: the relative difference of the image means, d(R) = (m_exact − m_line) / m_line,
//! RGB summed. Each pass renders the line and every radius with the same seed (common random
//! numbers: the film positions are the same, so the pixel-footprint noise cancels in the
//! difference); the passes are independent, so the standard error of d is that of the mean of
//! the P per-pass differences (P − 1 degrees of freedom). The slope of log d against log R is
//! fitted by weighted least squares (weights 1/σ² of log d, σ = se/d).

use super::page::{num, plot, table};
use super::plot::{log_log_with_bars, ErrorBars, Series, PALETTE};
use super::{csv, figure_scene, Ctx, Section};
use linlight_imagefile::Image;
use linlight_render::{render, Cylinders, LightSelection, Method, RenderOptions, TubeSampling};
use linlight_sampling::cylinder::CylinderTechnique;
use linlight_sampling::noise::Noise;
use linlight_sampling::Technique;
use serde_json::json;
use std::path::Path;
use std::time::Instant;

/// K = radiance × radius of the scene's tube, fixed while R shrinks.
pub const K: f64 = 0.32;

/// Radii of the figure, three decades (the scene's tube is 1.5 long, 0.45–0.65 above the floor).
pub const RADII: [f64; 7] = [1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4];

/// Sizes of a run: film side, samples per pixel of each pass, passes.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Sizes {
    pub res: u32,
    pub spp: u32,
    pub passes: u32,
}

impl Sizes {
    pub fn of(quick: bool) -> Self {
        if quick {
            Self {
                res: 32,
                spp: 4,
                passes: 8,
            }
        } else {
            Self {
                res: 64,
                spp: 16,
                passes: 16,
            }
        }
    }
}

/// One radius of the figure.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RadiusPoint {
    pub radius: f64,
    /// Relative difference of the image means, exact minus line.
    pub relative_difference: f64,
    /// Its standard error (from the P per-pass differences).
    pub standard_error: f64,
}

/// A weighted least-squares fit of log d = c + k log R.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct SlopeFit {
    pub slope: f64,
    /// Standard error of the slope, scaled up by √(χ²/(n − 2)) when the points scatter more
    /// than their error bars say (curvature from the O(R²) term).
    pub slope_error: f64,
    /// d/R extrapolated to R → 0: exp(c) at k = 1 would be the first-order coefficient.
    pub intercept: f64,
    pub chi2_per_dof: f64,
}

/// Weighted least squares of log d against log R over the points with d > 0 and a finite
/// error; `None` with fewer than 3 such points.
pub fn fit_slope(points: &[RadiusPoint]) -> Option<SlopeFit> {
    let pts: Vec<(f64, f64, f64)> = points
        .iter()
        .filter(|p| p.relative_difference > 0.0 && p.standard_error > 0.0)
        .map(|p| {
            let sigma = p.standard_error / p.relative_difference;
            (
                p.radius.ln(),
                p.relative_difference.ln(),
                1.0 / (sigma * sigma),
            )
        })
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let sw: f64 = pts.iter().map(|p| p.2).sum();
    let mx = pts.iter().map(|p| p.2 * p.0).sum::<f64>() / sw;
    let my = pts.iter().map(|p| p.2 * p.1).sum::<f64>() / sw;
    let sxx: f64 = pts.iter().map(|p| p.2 * (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| p.2 * (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    let c = my - slope * mx;
    let chi2: f64 = pts
        .iter()
        .map(|p| p.2 * (p.1 - c - slope * p.0).powi(2))
        .sum();
    let chi2_per_dof = chi2 / (pts.len() - 2) as f64;
    Some(SlopeFit {
        slope,
        slope_error: (1.0 / sxx).sqrt() * chi2_per_dof.max(1.0).sqrt(),
        intercept: c.exp(),
        chi2_per_dof,
    })
}

/// RGB-summed image mean.
fn image_mean(img: &Image) -> f64 {
    let sum: f64 = img
        .mean
        .iter()
        .map(|p| p.iter().map(|&c| c as f64).sum::<f64>())
        .sum();
    sum / img.mean.len() as f64
}

/// The figure's data: per radius, the relative difference of the exact tube's image mean from
/// the line's, with its standard error; and the seconds spent rendering.
pub fn measure(
    root: &Path,
    sizes: Sizes,
    seed: u64,
    progress: &dyn Fn(f64),
) -> Result<(Vec<RadiusPoint>, f64), String> {
    let path = root.join(figure_scene("thin-tube"));
    let load = |radius: f64| {
        let ov = [
            ("res".to_string(), sizes.res.to_string()),
            ("radius".to_string(), format!("{radius:e}")),
            ("radiance".to_string(), format!("{:e}", K / radius)),
        ];
        linlight_render::xml::load_scene(&path, &ov).map_err(|e| format!("{}: {e}", path.display()))
    };
    let opts = |seed: u64, cylinders: Cylinders| RenderOptions {
        spp: sizes.spp,
        passes: 1,
        seed,
        method: Method::from(Technique::ProjectedSolidAngle),
        light_samples: 1,
        lights: LightSelection::Every,
        noise: Noise::White,
        cylinders,
    };
    // Ours without MIS: for the diffuse floor its estimate varies only through the section's
    // density, so the difference is resolved at the smallest radius.
    let exact = Cylinders::Exact(TubeSampling {
        technique: CylinderTechnique::Projected,
        mis: false,
    });
    let line_scene = load(1e-2)?;
    let scenes = RADII
        .iter()
        .map(|&r| load(r))
        .collect::<Result<Vec<_>, _>>()?;
    let started = Instant::now();
    let mut diffs = vec![Vec::new(); RADII.len()];
    for p in 0..sizes.passes {
        let s = seed.wrapping_add(p as u64);
        let line = render(&line_scene, &opts(s, Cylinders::Line), &|_, _| {})
            .map_err(|e| e.to_string())?;
        let m_line = image_mean(&line);
        for (i, scene) in scenes.iter().enumerate() {
            let img = render(scene, &opts(s, exact), &|_, _| {}).map_err(|e| e.to_string())?;
            diffs[i].push((image_mean(&img) - m_line) / m_line);
        }
        progress((p + 1) as f64 / sizes.passes as f64);
    }
    let n = sizes.passes as f64;
    let points = RADII
        .iter()
        .zip(&diffs)
        .map(|(&radius, d)| {
            let mean = d.iter().sum::<f64>() / n;
            let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
            RadiusPoint {
                radius,
                relative_difference: mean,
                standard_error: (var / n).sqrt(),
            }
        })
        .collect();
    Ok((points, started.elapsed().as_secs_f64()))
}

pub fn make(ctx: &Ctx) -> Result<Section, String> {
    let sizes = Sizes::of(ctx.opts.quick);
    let (points, seconds) = measure(&ctx.opts.root, sizes, ctx.opts.seed, &|f| ctx.progress(f))?;
    let fit = fit_slope(&points).ok_or("fewer than 3 radii with a positive difference")?;
    let svg = plot_points(&points, &fit)?;
    let files = vec![
        ctx.write_text("tube-radius.svg", &svg)?,
        ctx.write_text("tube-radius.csv", &points_csv(&points))?,
    ];
    let body = format!("{}{}", plot(&svg), points_table(&points));
    let summary = format!(
        "<p>R → 0 with K fixed: the exact tube's image differs from the line's by d ≈ {}·R^{} (slope {} ± {}, \
         R = {} … {}).</p>",
        num(fit.intercept),
        num(fit.slope),
        num(fit.slope),
        num(fit.slope_error),
        num(RADII[RADII.len() - 1]),
        num(RADII[0]),
    );
    Ok(Section {
        caption: caption(ctx, sizes, seconds, &fit),
        body,
        files,
        numbers: json!({
            "scene": figure_scene("thin-tube"),
            "K": K,
            "sizes": sizes,
            "render_seconds": seconds,
            "points": points,
            "fit": fit,
            "summary_html": summary,
        }),
        ..Default::default()
    })
}

/// The log-log plot (SVG) of the relative differences with their error bars and the fit.
fn plot_points(points: &[RadiusPoint], fit: &SlopeFit) -> Result<String, String> {
    let colour = PALETTE[0];
    let data = Series {
        name: "exact vs line (image mean)".into(),
        points: points
            .iter()
            .map(|p| (p.radius, p.relative_difference))
            .collect(),
        colour,
        dashed: false,
    };
    let fitted = Series {
        name: format!("fit: slope {}", num(fit.slope)),
        points: [RADII[0], RADII[RADII.len() - 1]]
            .iter()
            .map(|&r| (r, fit.intercept * r.powf(fit.slope)))
            .collect(),
        colour: PALETTE[10],
        dashed: true,
    };
    let bars = ErrorBars {
        bars: points
            .iter()
            .map(|p| {
                let (d, e) = (p.relative_difference, p.standard_error);
                (p.radius, d, d - e, d + e)
            })
            .collect(),
        colour,
    };
    log_log_with_bars(
        "Exact tube vs its R → 0 line, K = L·R fixed",
        "radius R (scene units)",
        "relative difference of the image mean",
        &[data, fitted],
        &[bars],
    )
}

/// tube-radius.csv: per radius the difference, its standard error and difference / R.
fn points_csv(points: &[RadiusPoint]) -> String {
    let rows: Vec<Vec<String>> = points
        .iter()
        .map(|p| {
            vec![
                format!("{:e}", p.radius),
                format!("{:e}", p.relative_difference),
                format!("{:e}", p.standard_error),
                format!("{:e}", p.relative_difference / p.radius),
            ]
        })
        .collect();
    let header = [
        "radius",
        "relative_difference",
        "standard_error",
        "difference_over_radius",
    ];
    csv(&header, &rows)
}

/// The HTML table of the points.
fn points_table(points: &[RadiusPoint]) -> String {
    let rows: Vec<Vec<String>> = points
        .iter()
        .map(|p| {
            vec![
                num(p.radius),
                num(p.relative_difference),
                num(p.standard_error),
                num(p.relative_difference / p.radius),
            ]
        })
        .collect();
    let header = [
        "R",
        "relative difference",
        "± standard error",
        "difference / R",
    ];
    table(&header, &rows)
}

/// The figure's caption: the scene, the sizes, the render time `seconds` and the `fit`.
fn caption(ctx: &Ctx, sizes: Sizes, seconds: f64, fit: &SlopeFit) -> String {
    let renders = sizes.passes as usize * (RADII.len() + 1);
    format!(
        "What it shows: a tube light of radius R rendered as the cylinder it is approaches its R → 0 \
         limit, the linear light of intensity K = L·R, at first order in R. Scene \
         <code>{}</code>: a diffuse floor under one tilted tube 1.5 long, hidden from camera rays; K = {K} \
         fixed, L = K/R. Per radius the relative difference of the image mean (exact − line)/line, RGB \
         summed; error bars ± one standard error from {} independent passes, each rendering the line \
         and every radius with the same seed (so the film positions are shared and their noise cancels). \
         Exact: ours (the line sampler along the axis composed across the section), no MIS; line: \
         projected solid angle. {}×{} px, {} spp per pass, seed {}; {renders} renders in {} s. Weighted \
         least-squares slope of log difference vs log R: <b>{} ± {}</b> (χ²/dof {}), i.e. the difference \
         is O(R): d ≈ {}·R. (At a contact between tube and surface the difference would go as \
         R·log(1/R); this scene has none.)",
        figure_scene("thin-tube"),
        sizes.passes,
        sizes.res,
        sizes.res,
        sizes.spp,
        ctx.opts.seed,
        num(seconds),
        num(fit.slope),
        num(fit.slope_error),
        num(fit.chi2_per_dof),
        num(fit.intercept),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fit recovers the slope and coefficient of d = c·R^k from exact points, and a
    /// point with d ≤ 0 is left out.
    #[test]
    fn fit_recovers_a_power_law() {
        let mut pts: Vec<RadiusPoint> = RADII
            .iter()
            .map(|&r| RadiusPoint {
                radius: r,
                relative_difference: 0.12 * r.powf(1.07),
                standard_error: 0.01 * 0.12 * r.powf(1.07),
            })
            .collect();
        pts.push(RadiusPoint {
            radius: 1e-5,
            relative_difference: -1e-6,
            standard_error: 1e-6,
        });
        let f = fit_slope(&pts).unwrap();
        assert!((f.slope - 1.07).abs() < 1e-12, "{f:?}");
        assert!((f.intercept - 0.12).abs() < 1e-12, "{f:?}");
        assert!(f.chi2_per_dof < 1e-20, "{f:?}");
    }
}
