//! `linlight calibrate`: the false-alarm rate and the power of `compare` measured on real
//! renders, not on synthetic Gaussians.
//!
//! Per scene family (a committed scene, small film) and per pair k = 1…K: a reference-like
//! render B (P passes, like the Mitsuba references, own seed) and two renders A of the same
//! scene with other seeds, one at certify's budget (its pilot and budget rule against B) and one
//! at a user's low budget (256 spp, one pass). Each A is compared with B (`compare`, its default
//! α unless set): the share of DIFFERENT verdicts is the false-alarm rate, with its exact
//! (Clopper–Pearson) 95 % interval; it must be ≤ α. Then the same A with an injected bias — a
//! global scale of 1 + b, or 1 + b on one 16×16 region — gives the power: the share rejected.
//! Pairs are independent (fresh seeds for A and B), so the counts are binomial.

use linlight_imagefile::Image;
use linlight_render::scene::Scene;
use linlight_render::xml::load_scene;
use linlight_render::{LightSelection, Method, Prepared, RenderOptions};
use linlight_sampling::mis::Heuristic;
use linlight_sampling::Technique;
use linlight_verify::image_stats::{compare, CompareConfig, Verdict};
use serde::Serialize;
use statrs::distribution::{Beta, ContinuousCDF};
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::certify::budget::{Budget, BudgetRule};
use crate::certify::planned;
use crate::certify::{pilot_seed, Unusable};

/// A scene family: a name, the committed scene that stands for it and the method its renders
/// use (the paper's MIS estimator on the glossy family, projected solid angle elsewhere).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Family {
    pub name: &'static str,
    pub scene: &'static str,
    #[serde(serialize_with = "method_name")]
    pub method: Method,
}

fn method_name<S: serde::Serializer>(m: &Method, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&m.name())
}

/// The calibrated families; adding one is one line here.
pub const FAMILIES: &[Family] = &[
    Family {
        name: "unoccluded",
        scene: "floor-tube",
        method: Method::Technique(Technique::ProjectedSolidAngle),
    },
    Family {
        name: "occluded",
        scene: "mesh-occluder",
        method: Method::Technique(Technique::ProjectedSolidAngle),
    },
    Family {
        name: "glossy",
        scene: "glossy-blend",
        method: Method::Mis(Heuristic::ClampedOptimal(0.5)),
    },
];

/// Injected global biases (relative scale − 1).
pub const GLOBAL_BIASES: [f64; 4] = [0.0025, 0.005, 0.01, 0.02];
/// Injected biases on one 16×16 region.
pub const LOCAL_BIASES: [f64; 3] = [0.02, 0.05, 0.10];
/// Edge of the local region; it starts at (8, 8), half a tile off the aligned grid.
pub const LOCAL_SIZE: usize = 16;
pub const LOCAL_OFFSET: usize = 8;
/// The user's low budget.
pub const LOW_SPP: u32 = 256;

#[derive(Clone, Debug, Serialize)]
pub struct Options {
    pub scenes_dir: PathBuf,
    /// Seed pairs per family.
    pub pairs: usize,
    /// Film edge (`-D res=…`).
    pub res: u32,
    /// Passes × spp per pass of the reference-like render B.
    pub reference_passes: u32,
    pub reference_spp: u32,
    pub compare: CompareConfig,
    pub budget: BudgetRule,
    /// Families by name (empty: all).
    pub families: Vec<String>,
}

impl Options {
    pub fn new(root: &Path) -> Self {
        Self {
            scenes_dir: root.join("references/scenes"),
            pairs: 200,
            res: 24,
            reference_passes: 16,
            reference_spp: 64,
            compare: CompareConfig::default(),
            budget: BudgetRule::default(),
            families: Vec::new(),
        }
    }
}

/// A count of k of n with its Clopper–Pearson 95 % interval.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Rate {
    pub count: usize,
    pub of: usize,
    pub rate: f64,
    pub ci95: [f64; 2],
}

impl Rate {
    pub fn new(count: usize, of: usize) -> Self {
        let (k, n) = (count as f64, of as f64);
        let beta = |a: f64, b: f64, p: f64| Beta::new(a, b).map_or(f64::NAN, |d| d.inverse_cdf(p));
        let lo = if count == 0 {
            0.0
        } else {
            beta(k, n - k + 1.0, 0.025)
        };
        let hi = if count >= of {
            1.0
        } else {
            beta(k + 1.0, n - k, 0.975)
        };
        Self {
            count,
            of,
            rate: if of == 0 { 0.0 } else { k / n },
            ci95: [lo, hi],
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct BudgetRow {
    /// "certify" or "256 spp".
    pub budget: String,
    /// Median over the pairs of A's samples per pixel (its mean over the pixels).
    pub median_spp: u32,
    pub different: Rate,
    pub inconclusive: Rate,
    /// Per entry of GLOBAL_BIASES: share rejected (DIFFERENT).
    pub power_global: Vec<Rate>,
    /// Per entry of LOCAL_BIASES.
    pub power_local: Vec<Rate>,
}

#[derive(Clone, Debug, Serialize)]
pub struct FamilyReport {
    pub family: Family,
    pub rows: Vec<BudgetRow>,
    pub seconds: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub options: Options,
    pub global_biases: Vec<f64>,
    pub local_biases: Vec<f64>,
    pub families: Vec<FamilyReport>,
    pub seconds: f64,
    pub threads: usize,
}

/// A with every mean (and standard error) scaled by 1 + b where `inside(x, y)`.
fn biased(a: &Image, b: f64, inside: impl Fn(usize, usize) -> bool) -> Image {
    let mut out = a.clone();
    let k = (1.0 + b) as f32;
    for (i, (m, v)) in out.mean.iter_mut().zip(&mut out.var).enumerate() {
        if inside(i % a.width, i / a.width) {
            *m = m.map(|c| c * k);
            *v = v.map(|c| c * k * k);
        }
    }
    out
}

/// Verdict counts of one budget over the pairs.
#[derive(Default)]
struct Tally {
    spp: Vec<u32>,
    different: usize,
    inconclusive: usize,
    global: Vec<usize>,
    local: Vec<usize>,
}

impl Tally {
    fn add(&mut self, a: &Image, b: &Image, spp: u32, cfg: &CompareConfig) -> Result<(), Unusable> {
        let run = |img: &Image| {
            compare(img, b, cfg)
                .map(|c| c.verdict)
                .map_err(|e| Unusable(format!("calibration compare: {e}")))
        };
        self.spp.push(spp);
        match run(a)? {
            Verdict::Different => self.different += 1,
            Verdict::Inconclusive => self.inconclusive += 1,
            Verdict::Consistent => {}
        }
        self.global.resize(GLOBAL_BIASES.len(), 0);
        self.local.resize(LOCAL_BIASES.len(), 0);
        for (k, &bias) in GLOBAL_BIASES.iter().enumerate() {
            self.global[k] +=
                usize::from(run(&biased(a, bias, |_, _| true))? == Verdict::Different);
        }
        let region = |x: usize, y: usize| {
            (LOCAL_OFFSET..LOCAL_OFFSET + LOCAL_SIZE).contains(&x)
                && (LOCAL_OFFSET..LOCAL_OFFSET + LOCAL_SIZE).contains(&y)
        };
        for (k, &bias) in LOCAL_BIASES.iter().enumerate() {
            self.local[k] += usize::from(run(&biased(a, bias, region))? == Verdict::Different);
        }
        Ok(())
    }

    fn row(mut self, budget: &str, pairs: usize) -> BudgetRow {
        self.spp.sort_unstable();
        BudgetRow {
            budget: budget.into(),
            median_spp: self.spp.get(self.spp.len() / 2).copied().unwrap_or(0),
            different: Rate::new(self.different, pairs),
            inconclusive: Rate::new(self.inconclusive, pairs),
            power_global: self.global.iter().map(|&c| Rate::new(c, pairs)).collect(),
            power_local: self.local.iter().map(|&c| Rate::new(c, pairs)).collect(),
        }
    }
}

fn render_error(what: &str, e: impl std::fmt::Display) -> Unusable {
    Unusable(format!("calibration render ({what}): {e}"))
}

fn options(method: Method, spp: u32, passes: u32, seed: u64) -> RenderOptions {
    RenderOptions {
        spp,
        passes,
        seed,
        method,
        light_samples: 1,
        // As calibrated (the calibration's scenes have one light, where both selections are
        // the same image).
        lights: LightSelection::Every,
        noise: Default::default(),
        // The calibration's references are of the line limit.
        cylinders: linlight_render::Cylinders::Line,
    }
}

/// One family: K pairs at both budgets.
fn calibrate_family(
    family: Family,
    scene: &Scene,
    opts: &Options,
    progress: &dyn Fn(usize, usize),
) -> Result<FamilyReport, Unusable> {
    let started = Instant::now();
    let (mut at_budget, mut at_low) = (Tally::default(), Tally::default());
    let quiet = |_: usize, _: usize| {};
    // The scene built once for all its renders.
    let prepared = Prepared::new(scene).map_err(|e| render_error("the scene", e))?;
    let crop = scene.sensor.film.crop;
    for k in 0..opts.pairs as u64 {
        let base = 1_000_003 * (k + 1);
        let b = prepared
            .render(
                crop,
                &options(
                    family.method,
                    opts.reference_spp,
                    opts.reference_passes,
                    base,
                ),
                &quiet,
            )
            .map_err(|e| render_error("reference", e))?;
        let seed = base + 1;
        let pilot = prepared
            .render(
                crop,
                &options(family.method, opts.budget.pilot_spp, 1, pilot_seed(seed)),
                &quiet,
            )
            .map_err(|e| render_error("pilot", e))?;
        let (
            Budget {
                spp,
                pixel_spp_mean,
                ..
            },
            pixel_spp,
        ) = opts
            .budget
            .plan(&pilot, &b, &opts.compare)
            .map_err(|e| Unusable(format!("budget of {}: {e}", family.name)))?;
        // As certify renders: per-tile counts where the plan has them.
        let a = planned::render(
            &|c, o, p| prepared.render(c, o, p),
            scene,
            &options(family.method, spp, 1, seed),
            pixel_spp.as_deref(),
            &quiet,
        )
        .map_err(|e| render_error("certify budget", e))?;
        // The samples a render costs: per pixel on average (the per-tile budget gives the
        // pixels of hard tiles more than `spp`).
        at_budget.add(&a, &b, pixel_spp_mean.round() as u32, &opts.compare)?;
        let low = prepared
            .render(crop, &options(family.method, LOW_SPP, 1, base + 2), &quiet)
            .map_err(|e| render_error("256 spp", e))?;
        at_low.add(&low, &b, LOW_SPP, &opts.compare)?;
        progress(k as usize + 1, opts.pairs);
    }
    Ok(FamilyReport {
        family,
        rows: vec![
            at_budget.row("certify", opts.pairs),
            at_low.row("256 spp", opts.pairs),
        ],
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The chosen families with their scenes, loaded before anything is rendered.
fn selected(opts: &Options) -> Result<Vec<(Family, Scene)>, Unusable> {
    let unknown: Vec<&String> = opts
        .families
        .iter()
        .filter(|f| !FAMILIES.iter().any(|g| g.name == f.as_str()))
        .collect();
    if let Some(f) = unknown.first() {
        let names: Vec<&str> = FAMILIES.iter().map(|f| f.name).collect();
        return Err(Unusable(format!(
            "unknown family '{f}' (known: {})",
            names.join(", ")
        )));
    }
    FAMILIES
        .iter()
        .filter(|f| opts.families.is_empty() || opts.families.iter().any(|n| n == f.name))
        .map(|f| {
            let path = opts.scenes_dir.join(format!("{}.xml", f.scene));
            let scene = load_scene(&path, &[("res".into(), opts.res.to_string())])
                .map_err(|e| Unusable(format!("cannot load scene {}: {e}", path.display())))?;
            Ok((*f, scene))
        })
        .collect()
}

/// Runs the calibration. `progress(family, done, total)`.
pub fn run(opts: &Options, progress: &dyn Fn(&str, usize, usize)) -> Result<Report, Unusable> {
    if opts.pairs == 0 {
        return Err(Unusable("--pairs must be at least 1".into()));
    }
    if (opts.res as usize) < LOCAL_OFFSET + LOCAL_SIZE {
        return Err(Unusable(format!(
            "--res must be at least {} (the local bias region is {LOCAL_SIZE}×{LOCAL_SIZE} at ({LOCAL_OFFSET}, {LOCAL_OFFSET}))",
            LOCAL_OFFSET + LOCAL_SIZE
        )));
    }
    if opts.reference_passes < 2 {
        return Err(Unusable("the reference needs at least 2 passes".into()));
    }
    let started = Instant::now();
    let chosen = selected(opts)?;
    let mut families = Vec::new();
    for (family, scene) in &chosen {
        families.push(calibrate_family(*family, scene, opts, &|d, t| {
            progress(family.name, d, t)
        })?);
    }
    Ok(Report {
        options: opts.clone(),
        global_biases: GLOBAL_BIASES.to_vec(),
        local_biases: LOCAL_BIASES.to_vec(),
        families,
        seconds: started.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
    })
}

fn pct(x: f64) -> String {
    format!("{:.1}%", 100.0 * x)
}

fn rate_cell(r: &Rate) -> String {
    format!(
        "{}/{} = {} [{}, {}]",
        r.count,
        r.of,
        pct(r.rate),
        pct(r.ci95[0]),
        pct(r.ci95[1])
    )
}

/// The Markdown table of a report (README, certify's report).
pub fn markdown(report: &Report) -> String {
    let mut s = String::from(
        "| family (scene) | A's budget | DIFFERENT (false alarms) [95% CI] | INCONCLUSIVE |",
    );
    for b in &report.global_biases {
        s += &format!(" global +{}% |", 100.0 * b);
    }
    for b in &report.local_biases {
        s += &format!(" 16×16 +{}% |", 100.0 * b);
    }
    s += " time |\n|---|---|---|---|";
    s += &"---|".repeat(report.global_biases.len() + report.local_biases.len() + 1);
    s += "\n";
    for f in &report.families {
        for r in &f.rows {
            s += &format!(
                "| {} ({}) | {} (median {} spp per pixel) | {} | {} |",
                f.family.name,
                f.family.scene,
                r.budget,
                r.median_spp,
                rate_cell(&r.different),
                rate_cell(&r.inconclusive)
            );
            for p in r.power_global.iter().chain(&r.power_local) {
                s += &format!(" {} |", pct(p.rate));
            }
            s += &format!(" {:.0} s |", f.seconds / f.rows.len() as f64);
            s += "\n";
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clopper_pearson_intervals() {
        // 0 of 200: [0, 1.83 %]; 2 of 200: [0.12 %, 3.57 %].
        let r = Rate::new(0, 200);
        assert_eq!(r.ci95[0], 0.0);
        assert!((r.ci95[1] - 0.018_10).abs() < 2e-4, "{:?}", r.ci95);
        let r = Rate::new(2, 200);
        assert!(
            (r.ci95[0] - 0.001_21).abs() < 1e-4 && (r.ci95[1] - 0.035_67).abs() < 2e-4,
            "{:?}",
            r.ci95
        );
        assert_eq!(Rate::new(5, 5).ci95[1], 1.0);
    }
}
