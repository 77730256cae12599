//! `linlight certify`: the whole certification in one run (docs/statistics.md §1 and §2).
//!
//! 1. The sampler chi-square suite (`linlight samplers`), alongside step 2 on the same threads,
//!    then the shader kernels' certification ([`gpu`], `linlight samplers --backend gpu`): run
//!    in a build with the `gpu` feature where wgpu finds an adapter, otherwise reported as
//!    skipped with the reason.
//! 2. For every selected scene: its committed Mitsuba reference (or a live Mitsuba render), and
//!    for every subject (by default [`matrix::default_subjects`]: every unbiased technique, and
//!    on glossy scenes also the glossy-only configurations) a Rust render at a budget from
//!    [`budget::BudgetRule`], compared with the reference (B) by
//!    [`linlight_verify::image_stats::compare`]; for the scenes of [`matrix::EXACT_SCENES`] the
//!    same render is also compared with the exact R → 0 image (closed form on Lambertian
//!    surfaces, quadrature along the line on glossy ones). The scenes of the finite-tube family
//!    (`Options::finite_scenes_dir`) are rendered with exact tubes by
//!    [`matrix::FINITE_SUBJECTS`] and compared with their reference alone.
//!
//! 3. Besides them, the renders of [`NOISE_RENDERS`] (blue noise) and
//!    [`LIGHT_SELECTION_RENDERS`] (one light chosen per light sample, uniformly or by the light
//!    tree, on the two-light scenes; the technique matrix samples every light) on their scenes, against the same oracles.
//!
//! Multiple testing: every comparison runs at the Šidák level α_c = 1 − (1 − α)^(1/m), m the
//! number of comparisons of the *full default* certification (every scene with a reference ×
//! its default subjects × its oracles), so that the family-wise false alarm rate of the image
//! comparisons is α and a subset (`--scenes`, `--techniques`, a test) reproduces exactly the
//! verdicts of the full run. The sampler suite has its own α.
//!
//! Unusable input (missing or stale reference, a glob matching nothing, an unreadable scene) is
//! detected before anything is rendered and is an error ([`Unusable`], exit 2), never a failure.

pub mod budget;
pub mod closed_form;
pub mod cpu;
pub mod gpu;
pub mod matrix;
pub mod oracle;
pub mod planned;
pub mod report;
pub mod report_html;
pub mod sampler_suite;
pub mod scenes;
pub mod shard;

use linlight_imagefile::Image;
use linlight_render::scene::{CropWindow, Scene};
use linlight_render::{
    record_inputs, LightSelection, Method, Prepared, RenderError, RenderOptions,
};
use linlight_sampling::noise::Noise;
use linlight_sampling::Technique;
use linlight_verify::image_stats::{compare, CompareConfig, Comparison, Verdict};
use linlight_verify::z_score::sidak;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

use budget::{Budget, BudgetRule, Precision};
use cpu::ClockedPool;
use gpu::GpuSummary;
use sampler_suite::SuiteSummary;
use scenes::ReferencedScene;

/// A variant render: other primary samples (blue noise) or another light selection (one light
/// per light sample) than the technique matrix's white-noise, every-light renders, certified
/// besides them, so that the noise's unbiasedness across passes and the light choice's are part
/// of the main job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VariantRender {
    pub scene: &'static str,
    pub technique: Technique,
    pub noise: Noise,
    pub lights: LightSelection,
}

/// At least one blue-noise render per scene family: the occluded diffuse box with the paper's
/// jittered blue noise, the diffuse floor with a horizon-crossing light with plain blue noise.
pub const NOISE_RENDERS: [VariantRender; 2] = [
    VariantRender {
        scene: "cornell-tube",
        technique: Technique::ProjectedSolidAngle,
        noise: Noise::BlueJittered,
        lights: LightSelection::Every,
    },
    VariantRender {
        scene: "floor-crossing",
        technique: Technique::ProjectedSolidAngle,
        noise: Noise::Blue,
        lights: LightSelection::Every,
    },
];

/// The renders with one light chosen per light sample (`linlight render --lights one`) on the
/// committed scenes with two lights: the diffuse room (lanes choosing different lights in one
/// packet) and the glossy scene (full BSDF, evaluated lane by lane in the packets), both on the
/// batched path with one light sample and on the scalar path where the budget gives several
/// (several chosen lights per camera sample); and the light tree's choice
/// (`--lights tree`, probabilities from the shading point) on the diffuse room. White noise, one
/// pass, like the matrix's renders.
pub const LIGHT_SELECTION_RENDERS: [VariantRender; 3] = [
    VariantRender {
        scene: "two-tubes",
        technique: Technique::ProjectedSolidAngle,
        noise: Noise::White,
        lights: LightSelection::One,
    },
    VariantRender {
        scene: "glossy-principled",
        technique: Technique::ProjectedSolidAngle,
        noise: Noise::White,
        lights: LightSelection::One,
    },
    VariantRender {
        scene: "two-tubes",
        technique: Technique::ProjectedSolidAngle,
        noise: Noise::White,
        lights: LightSelection::Tree,
    },
];

/// Passes of a noise render: its variance of the mean comes from the pass means (the samples
/// of one jittered pass are stratified, not independent).
pub const NOISE_PASSES: u32 = 16;

impl Subject for VariantRender {
    fn name(&self) -> String {
        if self.noise == Noise::White {
            format!(
                "{} ({} light per sample)",
                self.technique.name(),
                self.lights
            )
        } else {
            format!("{} ({} noise)", self.technique.name(), self.noise.name())
        }
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        scene.render(crop, &self.options(opts), progress)
    }
    /// White-noise renders of a batch technique with one light sample take the packets (the
    /// one-light renders: lanes choosing different lights in one packet).
    fn renders_in_packets(&self, scene: &Scene, opts: &RenderOptions) -> bool {
        linlight_render::packet::applies(scene, &self.options(opts))
    }
}

impl VariantRender {
    /// The options of its render from certify's: its technique, noise and light selection;
    /// with blue noise `opts.spp` samples in total, split over [`NOISE_PASSES`] passes.
    fn options(&self, opts: &RenderOptions) -> RenderOptions {
        let total = opts.spp as u64 * opts.passes as u64;
        let passes = if self.noise == Noise::White {
            opts.passes
        } else {
            NOISE_PASSES
        };
        RenderOptions {
            method: self.technique.into(),
            noise: self.noise,
            lights: self.lights,
            passes,
            spp: total.div_ceil(passes as u64).clamp(1, u32::MAX as u64) as u32,
            ..*opts
        }
    }
}

/// Unusable input: the certification cannot be carried out (exit 2).
#[derive(Clone, Debug, PartialEq)]
pub struct Unusable(pub String);

impl std::fmt::Display for Unusable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for Unusable {}

/// Where the Mitsuba side comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Oracle {
    /// `references/mitsuba/<scene>.exr`, committed (no Mitsuba needed).
    Committed,
    /// Rendered now by `scripts/harness` (needs `scripts/setup-oracle`).
    Live,
}

/// Something that renders a scene: a technique, or (in tests) a deliberately wrong variant.
pub trait Subject: Sync {
    fn name(&self) -> String;
    /// Render the window `crop` of `scene`'s film (full-film pixels; None: the whole film) with
    /// `opts` (its `method` field is the subject's business), as [`Prepared::render`] does.
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError>;
    /// Whether [`Self::render`] with `opts` takes the packet renderer, which renders one light
    /// sample per camera sample (the budget then keeps one: [`BudgetRule::light_samples`]).
    /// False unless a subject says so.
    fn renders_in_packets(&self, _scene: &Scene, _opts: &RenderOptions) -> bool {
        false
    }
    /// Whether the subject renders tubes as the cylinders they are (the finite-tube family's
    /// subjects, [`matrix::ExactTubes`]) rather than as lines: a subject renders the scenes of
    /// its own family only.
    fn exact_tubes(&self) -> bool {
        false
    }
    /// The name of a subject whose render of any scene with any options is this subject's
    /// render, bit for bit (the same estimator under another name), or None. Where both are
    /// certified on a scene, this one's rows reuse that subject's budget and render: its pilots
    /// and render would give the same images.
    fn same_render_as(&self) -> Option<String> {
        None
    }
    /// The image header entries that name the subject's method (`technique`, `mis`, ...),
    /// which a render it shares ([`Subject::same_render_as`]) takes in place of the other's.
    fn header(&self) -> Vec<(&'static str, String)> {
        Vec::new()
    }
}

/// A subject's budget and render of a scene, for the subjects that share it
/// ([`Subject::same_render_as`]).
#[derive(Clone)]
struct SubjectRender {
    /// The subject that rendered it, and its header entries.
    subject: String,
    header: Vec<(&'static str, String)>,
    image: Image,
    render_seconds: f64,
    planned: Planned,
}

/// The renders of a scene that later subjects share, by the name of the subject that made them.
type SharedRenders = std::collections::HashMap<String, SubjectRender>;

impl SubjectRender {
    /// The render under `subject`'s name: its header entries in place of the renderer's.
    fn relabelled(&self, subject: &dyn Subject) -> SubjectRender {
        let mut r = self.clone();
        let extra = &mut r.image.meta.extra;
        for (key, _) in &self.header {
            extra.remove(*key);
        }
        for (key, value) in subject.header() {
            extra.insert(key.to_string(), value);
        }
        r
    }
}

/// A single technique: the [`Method`] subject of that technique.
impl Subject for Technique {
    fn name(&self) -> String {
        Method::from(*self).name()
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        Method::from(*self).render(scene, crop, opts, progress)
    }
    fn renders_in_packets(&self, scene: &Scene, opts: &RenderOptions) -> bool {
        Method::from(*self).renders_in_packets(scene, opts)
    }
}

/// The verdict of a whole certification: DIFFERENT if the sampler suite or the shader kernels
/// (where they ran) failed or any comparison
/// is DIFFERENT, else INCONCLUSIVE if any is, else CONSISTENT (a run without the suite is judged
/// on its comparisons alone). Shared by a run and by `--merge` of its shards.
pub(crate) fn overall_verdict(
    suite: Option<&SuiteSummary>,
    kernels: Option<&GpuSummary>,
    scenes: &[SceneReport],
) -> Verdict {
    let rows = || scenes.iter().flat_map(|s| &s.rows);
    if !suite.is_none_or(|s| s.passed)
        || kernels.is_some_and(GpuSummary::failed)
        || rows().any(|r| r.verdict == Verdict::Different)
    {
        Verdict::Different
    } else if rows().any(|r| r.verdict == Verdict::Inconclusive) {
        Verdict::Inconclusive
    } else {
        Verdict::Consistent
    }
}

/// `opts` rendered with `method` (the method field is the subject's business).
fn with_method(method: Method, opts: &RenderOptions) -> RenderOptions {
    RenderOptions { method, ..*opts }
}

/// A method (single technique, LTC, MIS with a heuristic) as a subject, named as in reports
/// (`mis:clamped-optimal=0.5`).
impl Subject for Method {
    fn name(&self) -> String {
        Method::name(*self)
    }
    fn render(
        &self,
        scene: &Prepared,
        crop: Option<CropWindow>,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Image, RenderError> {
        scene.render(crop, &with_method(*self, opts), progress)
    }
    fn renders_in_packets(&self, scene: &Scene, opts: &RenderOptions) -> bool {
        linlight_render::packet::applies(scene, &with_method(*self, opts))
    }
    fn same_render_as(&self) -> Option<String> {
        let same = self.same_renders_as();
        (same.name() != self.name()).then(|| same.name())
    }
    fn header(&self) -> Vec<(&'static str, String)> {
        Method::header(*self)
    }
}

#[derive(Clone, Debug)]
pub struct Options {
    /// Project root: `scripts/harness` lives here (live oracle).
    pub root: PathBuf,
    pub scenes_dir: PathBuf,
    /// The scenes of the finite-tube family, rendered with exact tubes
    /// ([`matrix::FINITE_SUBJECTS`]); None: not certified (`--scenes-dir` certifies one
    /// directory alone).
    pub finite_scenes_dir: Option<PathBuf>,
    pub references_dir: PathBuf,
    /// Wildcard pattern selecting scenes (name, file name or path).
    pub scenes: String,
    pub oracle: Oracle,
    /// Where report.md, report.json, heat maps and renders go (None: nowhere).
    pub report_dir: Option<PathBuf>,
    /// Run the sampler chi-square suite first.
    pub sampler_suite: bool,
    /// Run the shader kernels' certification ([`gpu`]; reported as skipped, with the reason,
    /// where the build has no backend or the machine no adapter).
    pub gpu_kernels: bool,
    /// Family-wise α of all image comparisons.
    pub alpha: f64,
    /// Equivalence margin δ on the relative global difference.
    pub tolerance: f64,
    pub budget: BudgetRule,
    /// Seed of every Rust render (the pilot renders use a seed derived from it).
    pub seed: u64,
    /// Sub-samples per pixel side of the closed-form image (Lambertian scenes).
    pub closed_form_subsamples: u32,
    /// Sub-samples per pixel side of the line-quadrature image (glossy scenes): its midpoint
    /// rule is accurate to ~4e-4 per pixel at 8 on glossy-conductor-sharp (α = 0.1), far below
    /// any render's per-pixel standard error, and the quadrature costs ~100 times the closed form.
    pub quadrature_subsamples: u32,
    /// Run only this part of the scene × technique list (`--shard i/N`, [`shard`]).
    pub shard: Option<shard::Shard>,
    /// The renders of [`NOISE_RENDERS`] and [`LIGHT_SELECTION_RENDERS`] whose scene is
    /// selected (and whose technique the command line selected).
    pub variant_renders: Vec<VariantRender>,
}

impl Options {
    /// The defaults of `linlight certify` for the project at `root`.
    pub fn new(root: &Path) -> Self {
        Self {
            root: root.to_path_buf(),
            scenes_dir: root.join("references/scenes"),
            finite_scenes_dir: Some(root.join(scenes::FINITE_TUBES_DIR)),
            references_dir: root.join("references/mitsuba"),
            scenes: "*".into(),
            oracle: Oracle::Committed,
            report_dir: None,
            sampler_suite: true,
            gpu_kernels: true,
            alpha: 0.01,
            tolerance: 0.005,
            budget: BudgetRule::default(),
            seed: 1,
            closed_form_subsamples: 16,
            quadrature_subsamples: 8,
            shard: None,
            variant_renders: NOISE_RENDERS
                .into_iter()
                .chain(LIGHT_SELECTION_RENDERS)
                .collect(),
        }
    }
}

/// Progress notifications (the command line turns them into a progress bar and lines).
pub enum Event<'a> {
    /// The run has this many steps (renders; the sampler suite runs alongside them).
    Plan {
        steps: usize,
    },
    /// A step starts.
    Step {
        label: String,
    },
    /// Progress of the current render, in camera samples (see `linlight_render::render`).
    Tiles {
        done: usize,
        total: usize,
    },
    SuiteDone(&'a SuiteSummary),
    RowDone(&'a Row),
}

/// The committed (or live) reference of a scene, as the report shows it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReferenceInfo {
    pub file: PathBuf,
    pub renderer: String,
    pub spp: u64,
    pub passes: u64,
    pub dof: f64,
    pub overrides: String,
    /// Render time recorded by the harness (s).
    pub wall_time_s: Option<f64>,
    pub scene_sha256: String,
    /// `content_sha256` of the reference image's content (header and pixels).
    #[serde(default)]
    pub reference_sha256: String,
}

/// One comparison: a subject's render of a scene against an oracle image.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Row {
    pub scene: String,
    pub subject: String,
    /// "mitsuba", "closed-form" or "quadrature" (the exact unshadowed image).
    pub oracle: String,
    pub verdict: Verdict,
    pub budget: Budget,
    /// Light samples per light and camera sample of the render ([`BudgetRule::light_samples`]).
    #[serde(default = "budget::one_light_sample")]
    pub light_samples: u32,
    pub seed: u64,
    /// Wall seconds of the subject's pilots and of its render (those of [`Row::render_of`]
    /// where the row shares its render).
    pub pilot_seconds: f64,
    pub render_seconds: f64,
    /// The subject whose budget and render this row reuses, its estimator being this row's bit
    /// for bit ([`Subject::same_render_as`]); None: rendered for this row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render_of: Option<String>,
    /// Of the render against this oracle image.
    pub precision: Precision,
    /// Per channel: relative global difference (A − B)/B and its confidence interval.
    pub rel_diff: [Option<f64>; 3],
    pub rel_ci: [Option<[f64; 2]>; 3],
    /// Smallest Holm-adjusted tile p over the channels.
    pub worst_tile_p: Option<f64>,
    /// Files written for this row, relative to the report directory.
    pub files: Vec<String>,
    pub comparison: Comparison,
}

impl Row {
    pub fn passed(&self) -> bool {
        self.verdict == Verdict::Consistent
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SceneReport {
    pub name: String,
    pub scene_file: PathBuf,
    pub reference: ReferenceInfo,
    /// Wall time of the live Mitsuba render (None: committed reference).
    pub live_oracle_seconds: Option<f64>,
    /// Of the finite-tube family (rendered with exact tubes).
    #[serde(default)]
    pub exact_tubes: bool,
    pub rows: Vec<Row>,
    /// CPU-s of this scene's stages (None: not measured, or a report without them).
    #[serde(default)]
    pub cpu: Option<StageCpu>,
}

/// CPU-s (user + system) of a scene's stages in `certify`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StageCpu {
    /// The exact image (closed form or line quadrature), where the scene has one.
    pub exact_image: f64,
    /// The pilot renders that set the budgets, and the scene's acceleration structures (built
    /// once for every render of the scene).
    pub pilots: f64,
    /// The renders at the budget (crop windows of the per-tile budget included).
    pub renders: f64,
    /// The comparisons with every oracle, and the row's files in the report directory.
    pub comparisons: f64,
}

impl std::ops::Add for StageCpu {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            exact_image: self.exact_image + o.exact_image,
            pilots: self.pilots + o.pilots,
            renders: self.renders + o.renders,
            comparisons: self.comparisons + o.comparisons,
        }
    }
}

impl StageCpu {
    pub fn total(&self) -> f64 {
        self.exact_image + self.pilots + self.renders + self.comparisons
    }
}

/// CPU-s of a whole certification, by stage (docs/certify.md, "Cost").
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CpuTimes {
    /// The whole run: every thread of the process, from the scenes' loading to the report.
    pub process: f64,
    /// Loading the scenes and references and counting the family's comparisons.
    pub loading: f64,
    /// The sampler suite (line techniques and finite cylinders).
    pub sampler_suite: f64,
    /// The shader kernels' checks on the suite's thread (a driver's own threads, e.g.
    /// lavapipe's, count in `process` only).
    pub gpu_kernels: f64,
    /// The scenes' stages, summed.
    pub scenes: StageCpu,
}

impl std::ops::Add for CpuTimes {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            process: self.process + o.process,
            loading: self.loading + o.loading,
            sampler_suite: self.sampler_suite + o.sampler_suite,
            gpu_kernels: self.gpu_kernels + o.gpu_kernels,
            scenes: self.scenes + o.scenes,
        }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Report {
    /// Sampler suite passed and every comparison is consistent.
    pub passed: bool,
    /// DIFFERENT if the sampler suite or a comparison failed, else INCONCLUSIVE if a comparison
    /// is, else CONSISTENT.
    pub verdict: Verdict,
    pub oracle: Oracle,
    pub scenes_pattern: String,
    pub alpha: f64,
    /// m of the Šidák split and the level of each comparison.
    pub comparisons_in_family: usize,
    pub alpha_per_comparison: f64,
    pub tolerance: f64,
    pub budget_rule: BudgetRule,
    pub seed: u64,
    pub threads: usize,
    pub sampler_suite: Option<SuiteSummary>,
    /// The shader kernels' certification, or why it was skipped; in the report of a run (or
    /// shard 1 of a sharded one), absent only from reports of versions without it.
    #[serde(default)]
    pub gpu_kernels: Option<GpuSummary>,
    pub scenes: Vec<SceneReport>,
    pub elapsed_seconds: f64,
    /// CPU-s by stage (None: not measured, or a report without them).
    #[serde(default)]
    pub cpu: Option<CpuTimes>,
    /// The committed calibration of the comparison (docs/calibration.json), quoted by report.md.
    pub calibration: Option<serde_json::Value>,
    /// The scene × technique list of the whole run, and the part of it this report holds
    /// (None: all of it); `certify --merge` joins shards ([`shard`]).
    pub plan: Vec<shard::PlanItem>,
    pub shard: Option<shard::Shard>,
    /// Version of the program that wrote the report (`--merge` refuses other versions).
    #[serde(default)]
    pub tool_version: String,
    /// SHA-256 of the report's JSON without this field ([`shard::sealed_json`]), checked by
    /// `--merge`.
    #[serde(default)]
    pub content_sha256: Option<String>,
}

impl Report {
    pub fn rows(&self) -> impl Iterator<Item = &Row> {
        self.scenes.iter().flat_map(|s| s.rows.iter())
    }
}

/// m: comparisons of the full default certification of the scenes in `scenes_dir` and
/// `finite_scenes_dir` that have a reference (each scene loaded with its reference's overrides
/// to tell glossy from diffuse; the scenes of `loaded` are not loaded again).
fn family_size(opts: &Options, loaded: &[ReferencedScene]) -> Result<usize, Unusable> {
    let mut m = 0;
    for (path, exact_tubes) in scene_files(opts)? {
        let name = scenes::scene_name(&path);
        if !scenes::reference_path(&opts.references_dir, &name).is_file() {
            continue;
        }
        m += match loaded.iter().find(|s| s.scene_file == path) {
            Some(s) => matrix::default_comparisons(&name, &s.scene, exact_tubes),
            None => {
                let s = scenes::load_referenced(&path, &opts.references_dir, false)?;
                matrix::default_comparisons(&name, &s.scene, exact_tubes)
            }
        };
        // The scene's blue-noise and light-selection renders, against each of its oracles.
        let oracles = if matrix::has_exact_oracle(&name) {
            2
        } else {
            1
        };
        m += NOISE_RENDERS
            .iter()
            .chain(&LIGHT_SELECTION_RENDERS)
            .filter(|r| r.scene == name)
            .count()
            * oracles;
    }
    Ok(m.max(1))
}

fn reference_info(s: &ReferencedScene) -> ReferenceInfo {
    let m = &s.reference.meta;
    ReferenceInfo {
        file: s.reference_file.clone(),
        renderer: m.renderer.clone(),
        spp: m.spp,
        passes: m.passes,
        dof: m.dof,
        overrides: m.extra.get("overrides").cloned().unwrap_or_default(),
        wall_time_s: m.extra.get("wall_time_s").and_then(|t| t.parse().ok()),
        scene_sha256: m.scene_sha256.clone(),
        reference_sha256: linlight_imagefile::content_sha256(&s.reference),
    }
}

/// Seed of the pilot renders: distinct from the render seed, so that the budget is chosen from
/// samples the final render does not reuse.
pub fn pilot_seed(seed: u64) -> u64 {
    seed ^ 0x5049_4c4f_5453_4545 // "PILOTSEE"
}

/// The scene files of `scenes_dir` and then of `finite_scenes_dir` (where it exists), each with
/// whether it is of the finite-tube family; a scene name in both is unusable input.
fn scene_files(opts: &Options) -> Result<Vec<(PathBuf, bool)>, Unusable> {
    let mut all: Vec<(PathBuf, bool)> = scenes::scene_files(&opts.scenes_dir)?
        .into_iter()
        .map(|p| (p, false))
        .collect();
    if let Some(dir) = opts.finite_scenes_dir.as_ref().filter(|d| d.is_dir()) {
        for p in scenes::scene_files(dir)? {
            let name = scenes::scene_name(&p);
            if let Some((q, _)) = all.iter().find(|(q, _)| scenes::scene_name(q) == name) {
                return Err(Unusable(format!(
                    "scene {name} is in {} and in {}: names must be unique",
                    q.display(),
                    p.display()
                )));
            }
            all.push((p, true));
        }
    }
    Ok(all)
}

/// Selected scenes with their references, all checked before anything is rendered.
pub fn selected_scenes(opts: &Options) -> Result<Vec<ReferencedScene>, Unusable> {
    let all = scene_files(opts)?;
    let chosen: Vec<&(PathBuf, bool)> = all
        .iter()
        .filter(|(p, _)| scenes::selected(&opts.scenes, p))
        .collect();
    if chosen.is_empty() {
        let names: Vec<String> = all.iter().map(|(p, _)| scenes::scene_name(p)).collect();
        return Err(Unusable(format!(
            "--scenes '{}' matches no scene in {} (available: {})",
            opts.scenes,
            opts.scenes_dir.display(),
            if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            }
        )));
    }
    chosen
        .into_iter()
        .map(|(p, exact_tubes)| {
            let mut s =
                scenes::load_referenced(p, &opts.references_dir, opts.oracle == Oracle::Committed)?;
            s.exact_tubes = *exact_tubes;
            Ok(s)
        })
        .collect()
}

fn render_error(scene: &str, subject: &str, e: RenderError) -> Unusable {
    Unusable(format!("cannot render {scene} with {subject}: {e}"))
}

/// Per channel relative difference and CI, and the worst tile p.
type Summary = ([Option<f64>; 3], [Option<[f64; 2]>; 3], Option<f64>);

fn summarise(cmp: &Comparison) -> Summary {
    let mut rel = [None; 3];
    let mut ci = [None; 3];
    for (c, ch) in cmp.channels.iter().enumerate().take(3) {
        rel[c] = ch.global.rel_diff;
        ci[c] = ch.global.rel_ci;
    }
    let tile = cmp
        .channels
        .iter()
        .filter_map(|c| c.tiles.worst.as_ref().map(|t| t.p_holm))
        .min_by(f64::total_cmp);
    (rel, ci, tile)
}

/// m of the Šidák split and the configuration of every comparison of a certification.
pub fn comparison_config(opts: &Options) -> Result<(usize, CompareConfig), Unusable> {
    comparison_config_of(opts, &[])
}

/// [`comparison_config`] with the scenes of `loaded` (already loaded) not loaded again.
fn comparison_config_of(
    opts: &Options,
    loaded: &[ReferencedScene],
) -> Result<(usize, CompareConfig), Unusable> {
    let m = family_size(opts, loaded)?;
    Ok((
        m,
        CompareConfig {
            alpha: sidak(opts.alpha, m),
            tolerance: opts.tolerance,
            ..CompareConfig::default()
        },
    ))
}

/// Which subjects render each scene.
#[derive(Clone, Copy)]
enum Plan<'a> {
    /// [`matrix::default_subjects`] of each scene.
    Default,
    /// These subjects on every scene.
    Only(&'a [&'a dyn Subject]),
}

/// Run the default certification: on every selected scene its [`matrix::default_subjects`].
pub fn run_default(opts: &Options, events: &(dyn Fn(Event) + Sync)) -> Result<Report, Unusable> {
    run_plan(opts, Plan::Default, events)
}

/// Run the certification with the given subjects on every selected scene (the command line's
/// `--techniques`, tests' deliberately wrong variants).
pub fn run(
    opts: &Options,
    subjects: &[&dyn Subject],
    events: &(dyn Fn(Event) + Sync),
) -> Result<Report, Unusable> {
    if subjects.is_empty() {
        return Err(Unusable("no technique to certify".into()));
    }
    run_plan(opts, Plan::Only(subjects), events)
}

fn run_plan(
    opts: &Options,
    plan: Plan,
    events: &(dyn Fn(Event) + Sync),
) -> Result<Report, Unusable> {
    let started = Instant::now();
    let cpu_started = cpu::process_seconds();
    let chosen = selected_scenes(opts)?;
    if opts.oracle == Oracle::Live {
        oracle::check_ready(&opts.root)?;
    }
    let (m, cfg) = comparison_config_of(opts, &chosen)?;
    let loading_cpu = cpu_started.zip(cpu::process_seconds()).map(|(a, b)| b - a);
    if let Some(dir) = &opts.report_dir {
        std::fs::create_dir_all(dir).map_err(|e| {
            Unusable(format!(
                "cannot create report directory {}: {e}",
                dir.display()
            ))
        })?;
    }
    let per_scene: Vec<Vec<Box<dyn Subject>>> = chosen
        .iter()
        .map(|s| match plan {
            Plan::Default => matrix::default_subjects(&s.scene, s.exact_tubes),
            Plan::Only(_) => Vec::new(),
        })
        .collect();
    let scene_subjects = scene_subjects(opts, &chosen, &plan, &per_scene);
    if scene_subjects.iter().all(Vec::is_empty) {
        return Err(Unusable(
            "no selected technique applies to the selected scenes (the finite-tube scenes take \
             exact:TECHNIQUE, the others the line techniques)"
                .into(),
        ));
    }
    let plan = shard::plan(&chosen, &scene_subjects);
    // This shard's subjects of each scene (all of them without --shard).
    let mine = shard_subjects(opts, &scene_subjects);
    let live_renders = usize::from(opts.oracle == Oracle::Live)
        * mine.iter().filter(|subjects| !subjects.is_empty()).count();
    events(Event::Plan {
        steps: mine.iter().map(Vec::len).sum::<usize>() + live_renders,
    });
    let done = run_stages(opts, &cfg, events, &chosen, &mine)?;
    let cpu = cpu::process_seconds()
        .zip(cpu_started)
        .zip(loading_cpu)
        .zip(done.suite_cpu)
        .map(|(((end, start), loading), (suite, kernels))| CpuTimes {
            process: end - start,
            loading,
            sampler_suite: suite,
            gpu_kernels: kernels,
            scenes: done
                .scenes
                .iter()
                .filter_map(|s| s.cpu)
                .fold(StageCpu::default(), |a, b| a + b),
        });
    let report = Report {
        elapsed_seconds: started.elapsed().as_secs_f64(),
        cpu,
        plan,
        ..report_of(opts, (m, &cfg), done)
    };
    if let Some(dir) = &opts.report_dir {
        report::write_report(dir, &report)?;
        report_html::write(dir, &report)?;
    }
    Ok(report)
}

/// What [`run_stages`] returns: the suite's and the kernels' results with their CPU-s, and the
/// scenes' reports.
struct Stages {
    sampler_suite: Option<SuiteSummary>,
    gpu_kernels: Option<GpuSummary>,
    /// CPU-s of the sampler suite and of the shader kernels (None: not measured).
    suite_cpu: Option<(f64, f64)>,
    scenes: Vec<SceneReport>,
}

/// The sampler suite (then the shader kernels' certification, on the first shard) alongside
/// the renders of `mine` (each chosen scene's subjects), each stage group on a pool of its own
/// with as many threads as the caller's: the system fills each one's serial stretches (a suite
/// subject's first configuration, a render's last tiles, the comparisons) with the other's
/// work, and each pool's threads' CPU clocks give that group's CPU-s. Neither result depends on
/// the number of threads.
fn run_stages(
    opts: &Options,
    cfg: &CompareConfig,
    events: &(dyn Fn(Event) + Sync),
    chosen: &[ReferencedScene],
    mine: &[Vec<&dyn Subject>],
) -> Result<Stages, Unusable> {
    let first_shard = opts.shard.is_none_or(|s| s.runs_suite());
    let run_suite = opts.sampler_suite && first_shard;
    let threads = rayon::current_num_threads();
    let pool = |what: &str| ClockedPool::new(threads).map_err(|e| Unusable(format!("{what}: {e}")));
    let suite_pool = pool("sampler suite")?;
    let render_pool = pool("renders")?;
    let suite = || {
        let start = suite_pool.cpu_seconds();
        let suite = run_suite.then(|| {
            let s = sampler_suite::run();
            events(Event::SuiteDone(&s));
            s
        });
        let after_suite = suite_pool.cpu_seconds();
        let kernels = first_shard.then(|| {
            if opts.gpu_kernels {
                gpu::run(gpu::AGREEMENT_SAMPLES, gpu::SUITE_SAMPLES, &mut |_| {}).summary
            } else {
                GpuSummary::skipped(gpu::NOT_REQUESTED, None)
            }
        });
        let cpu = start
            .zip(after_suite)
            .zip(suite_pool.cpu_seconds())
            .map(|((a, b), c)| (b - a, c - b));
        (suite, kernels, cpu)
    };
    let run = SceneRun {
        opts,
        cfg,
        events,
        pool: &render_pool,
    };
    let render_all = || -> Result<Vec<SceneReport>, Unusable> {
        chosen
            .iter()
            .zip(mine)
            .filter(|(_, subjects)| !subjects.is_empty())
            .map(|(s, subjects)| run.scene(s, subjects))
            .collect()
    };
    let ((sampler_suite, gpu_kernels, suite_cpu), scenes) = std::thread::scope(|scope| {
        let suite = scope.spawn(|| suite_pool.install(suite));
        let scenes = render_pool.install(render_all);
        let suite = suite
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        (suite, scenes)
    });
    Ok(Stages {
        sampler_suite,
        gpu_kernels,
        suite_cpu,
        scenes: scenes?,
    })
}

/// The report of a run of `opts` from its stages' results, with the Šidák split `(m, cfg)`; its
/// times, CPU-s and plan are the caller's to fill in.
fn report_of(opts: &Options, (m, cfg): (usize, &CompareConfig), done: Stages) -> Report {
    let verdict = overall_verdict(
        done.sampler_suite.as_ref(),
        done.gpu_kernels.as_ref(),
        &done.scenes,
    );
    Report {
        passed: verdict == Verdict::Consistent,
        verdict,
        oracle: opts.oracle,
        scenes_pattern: opts.scenes.clone(),
        alpha: opts.alpha,
        comparisons_in_family: m,
        alpha_per_comparison: cfg.alpha,
        tolerance: opts.tolerance,
        budget_rule: opts.budget,
        seed: opts.seed,
        threads: rayon::current_num_threads(),
        sampler_suite: done.sampler_suite,
        gpu_kernels: done.gpu_kernels,
        scenes: done.scenes,
        elapsed_seconds: 0.0,
        cpu: None,
        calibration: std::fs::read_to_string(opts.root.join("docs/calibration.json"))
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok()),
        plan: Vec::new(),
        shard: opts.shard,
        tool_version: shard::TOOL_VERSION.into(),
        content_sha256: None,
    }
}

/// Per scene: its subjects (`per_scene`'s defaults, or the plan's list), then its blue-noise
/// renders; the plan (and a shard's part of it) is over these, scene-major.
fn scene_subjects<'a>(
    opts: &'a Options,
    chosen: &[ReferencedScene],
    plan: &Plan<'a>,
    per_scene: &'a [Vec<Box<dyn Subject>>],
) -> Vec<Vec<&'a dyn Subject>> {
    chosen
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let own: Vec<&dyn Subject> = match plan {
                Plan::Default => per_scene[i].iter().map(|b| b.as_ref()).collect(),
                Plan::Only(list) => list
                    .iter()
                    .filter(|t| t.exact_tubes() == s.exact_tubes)
                    .copied()
                    .collect(),
            };
            own.into_iter()
                .chain(
                    opts.variant_renders
                        .iter()
                        .filter(|r| r.scene == s.name)
                        .map(|r| r as &dyn Subject),
                )
                .collect()
        })
        .collect()
}

/// The subjects of each scene that this shard runs (item j of the scene-major plan is the
/// shard's when `shard::runs(opts.shard, j)`).
fn shard_subjects<'a>(
    opts: &Options,
    scene_subjects: &[Vec<&'a dyn Subject>],
) -> Vec<Vec<&'a dyn Subject>> {
    let mut j = 0;
    scene_subjects
        .iter()
        .map(|subjects| {
            subjects
                .iter()
                .filter(|_| {
                    j += 1;
                    shard::runs(opts.shard, j - 1)
                })
                .copied()
                .collect()
        })
        .collect()
}

/// What the rows of every scene share: the options, the comparison and the event sink.
struct SceneRun<'a> {
    opts: &'a Options,
    cfg: &'a CompareConfig,
    events: &'a (dyn Fn(Event) + Sync),
    /// The pool the scenes run on, alone: its CPU clock's differences are their stages' CPU-s.
    pool: &'a ClockedPool,
}

/// A subject's budget: the spp (and per-pixel spp), the light samples per camera sample and
/// the seconds its pilot renders took.
#[derive(Clone)]
struct Planned {
    budget: Budget,
    pixel_spp: Option<Vec<u32>>,
    light_samples: u32,
    pilot_seconds: f64,
}

impl SceneRun<'_> {
    /// The rows of `subjects` on scene `s`: each rendered with its budget and compared with
    /// the Mitsuba reference and, where the scene has one, the exact image.
    fn scene(
        &self,
        s: &ReferencedScene,
        subjects: &[&dyn Subject],
    ) -> Result<SceneReport, Unusable> {
        let (reference, live_oracle_seconds) = self.reference(s)?;
        let mut cpu = self.pool.cpu_seconds().map(|_| StageCpu::default());
        let exact = self.stage(&mut cpu, |c| &mut c.exact_image, || self.exact(s))?;
        // The renders that a later subject reuses ([`Subject::same_render_as`]), by name.
        let wanted: Vec<String> = subjects.iter().filter_map(|t| t.same_render_as()).collect();
        let mut shared = SharedRenders::new();
        // Built once for every subject's pilots and renders.
        let prepared = self
            .stage(&mut cpu, |c| &mut c.pilots, || Prepared::new(&s.scene))
            .map_err(|e| Unusable(format!("cannot render {}: {e}", s.name)))?;
        let mut rows = Vec::new();
        for &subject in subjects {
            let oracles = (&reference, exact.as_ref());
            let (subject_rows, render) =
                self.subject_rows(&prepared, s, subject, oracles, &shared, &mut cpu)?;
            rows.extend(subject_rows);
            if let Some(render) = render.filter(|_| wanted.contains(&subject.name())) {
                shared.insert(subject.name(), render);
            }
        }
        Ok(SceneReport {
            name: s.name.clone(),
            scene_file: s.scene_file.clone(),
            reference: reference_info(s),
            live_oracle_seconds,
            exact_tubes: s.exact_tubes,
            rows,
            cpu,
        })
    }

    /// `f`, with the pool's CPU-s while it ran added to the stage `field` of `cpu` (which
    /// becomes None if the clock cannot be read).
    fn stage<R>(
        &self,
        cpu: &mut Option<StageCpu>,
        field: impl Fn(&mut StageCpu) -> &mut f64,
        f: impl FnOnce() -> R,
    ) -> R {
        let before = self.pool.cpu_seconds();
        let r = f();
        let spent = before.zip(self.pool.cpu_seconds()).map(|(a, b)| b - a);
        *cpu = cpu.zip(spent).map(|(mut c, t)| {
            *field(&mut c) += t;
            c
        });
        r
    }

    /// The Mitsuba image of `s`: the committed reference, or a live render (and its seconds).
    fn reference(&self, s: &ReferencedScene) -> Result<(Image, Option<f64>), Unusable> {
        match self.opts.oracle {
            Oracle::Committed => Ok((s.reference.clone(), None)),
            Oracle::Live => {
                (self.events)(Event::Step {
                    label: format!("{}: live Mitsuba render", s.name),
                });
                let t = Instant::now();
                let dir = self
                    .opts
                    .report_dir
                    .clone()
                    .unwrap_or_else(std::env::temp_dir)
                    .join("mitsuba");
                let img = oracle::render_live(&self.opts.root, s, &dir)?;
                Ok((img, Some(t.elapsed().as_secs_f64())))
            }
        }
    }

    /// The exact image of `s` (closed form or line quadrature) where the scene has one.
    fn exact(&self, s: &ReferencedScene) -> Result<Option<Image>, Unusable> {
        if !matrix::has_exact_oracle(&s.name) {
            return Ok(None);
        }
        let subsamples = if matrix::is_glossy(&s.scene) {
            self.opts.quadrature_subsamples
        } else {
            self.opts.closed_form_subsamples
        };
        closed_form::image(&s.scene, subsamples)
            .map_err(|e| Unusable(format!("exact image of {}: {e}", s.name)))
    }

    /// The budget of `subject` on `s` from pilot renders: camera samples by `opts.budget`, and
    /// several light samples per camera sample where they are cheaper than camera samples
    /// (docs/budget.md, "Light samples"): planned again from a pilot of as many light samples
    /// at N per camera sample, kept if the cost model says so.
    fn plan(
        &self,
        prepared: &Prepared,
        s: &ReferencedScene,
        subject: &dyn Subject,
        reference: &Image,
        base: &RenderOptions,
    ) -> Result<Planned, Unusable> {
        let name = subject.name();
        let planned = |rule: &BudgetRule, base: &RenderOptions| {
            let t = Instant::now();
            let pilot = subject
                .render(prepared, s.scene.sensor.film.crop, base, &|_, _| {})
                .map_err(|e| render_error(&s.name, &name, e))?;
            let seconds = t.elapsed().as_secs_f64();
            let (budget, pixel_spp) = rule.plan(&pilot, reference, self.cfg).map_err(|e| {
                Unusable(format!(
                    "cannot choose the budget of {} / {name}: {e}",
                    s.name
                ))
            })?;
            Ok::<_, Unusable>((budget, pixel_spp, seconds))
        };
        let (budget, pixel_spp, pilot_seconds) = planned(&self.opts.budget, base)?;
        let mut plan = Planned {
            budget,
            pixel_spp,
            light_samples: 1,
            pilot_seconds,
        };
        let n = self
            .opts
            .budget
            .light_samples(budget.spp, subject.renders_in_packets(&s.scene, base));
        if n > 1 {
            let rule = self.opts.budget.light_sample_pilot(n);
            let trial = RenderOptions {
                light_samples: n,
                spp: rule.pilot_spp,
                ..*base
            };
            let (b, p, seconds) = planned(&rule, &trial)?;
            plan.pilot_seconds += seconds;
            // Every light of the scene per light sample (`--lights every`); fewer (`one`,
            // `tree`) cost less, so the model errs towards one light sample.
            let (lights, exact) = (s.scene.lights.len(), subject.exact_tubes());
            if BudgetRule::light_samples_pay(&budget, &b, n, lights, exact) {
                (plan.budget, plan.pixel_spp, plan.light_samples) = (b, p, n);
            }
        }
        Ok(plan)
    }

    /// `subject` on `s`, rendered with its budget (or, where `shared` holds the render of its
    /// [`Subject::same_render_as`], that render under its name), one row per oracle of
    /// `(reference, exact)`; and the render where this call made it.
    fn subject_rows(
        &self,
        prepared: &Prepared,
        s: &ReferencedScene,
        subject: &dyn Subject,
        (reference, exact): (&Image, Option<&Image>),
        shared: &SharedRenders,
        cpu: &mut Option<StageCpu>,
    ) -> Result<(Vec<Row>, Option<SubjectRender>), Unusable> {
        let name = subject.name();
        (self.events)(Event::Step {
            label: format!("{}: {name}", s.name),
        });
        let (render, render_of) = match subject.same_render_as().and_then(|of| shared.get(&of)) {
            Some(r) => (r.relabelled(subject), Some(r.subject.clone())),
            None => (
                self.render_subject(prepared, s, subject, reference, cpu)?,
                None,
            ),
        };
        let mut oracles = vec![("mitsuba", reference)];
        if let Some(c) = exact {
            oracles.push((closed_form::oracle_name(c), c));
        }
        let rows = self.stage(
            cpu,
            |c| &mut c.comparisons,
            || {
                let mut rows = Vec::new();
                for oracle in oracles {
                    rows.push(self.row(s, &name, &render, oracle, render_of.clone())?);
                }
                Ok(rows)
            },
        )?;
        Ok((rows, render_of.is_none().then_some(render)))
    }

    /// `subject`'s budget from its pilots, and its render of `s` with it.
    fn render_subject(
        &self,
        prepared: &Prepared,
        s: &ReferencedScene,
        subject: &dyn Subject,
        reference: &Image,
        cpu: &mut Option<StageCpu>,
    ) -> Result<SubjectRender, Unusable> {
        let base = pilot_options(self.opts);
        let planned = self.stage(
            cpu,
            |c| &mut c.pilots,
            || self.plan(prepared, s, subject, reference, &base),
        )?;
        let t = Instant::now();
        let mut image = self
            .stage(
                cpu,
                |c| &mut c.renders,
                || self.render_planned(prepared, s, subject, &base, &planned),
            )
            .map_err(|e| render_error(&s.name, &subject.name(), e))?;
        let render_seconds = t.elapsed().as_secs_f64();
        record_inputs(&mut image.meta, &s.scene_file, &s.overrides);
        Ok(SubjectRender {
            subject: subject.name(),
            header: subject.header(),
            image,
            render_seconds,
            planned,
        })
    }

    /// The subject's render of `s` with its planned budget, at certify's seed.
    fn render_planned(
        &self,
        prepared: &Prepared,
        s: &ReferencedScene,
        subject: &dyn Subject,
        base: &RenderOptions,
        planned: &Planned,
    ) -> Result<Image, RenderError> {
        let tiles = |done: usize, total: usize| (self.events)(Event::Tiles { done, total });
        planned::render(
            &|crop, o, p| subject.render(prepared, crop, o, p),
            &s.scene,
            &RenderOptions {
                spp: planned.budget.spp,
                seed: self.opts.seed,
                light_samples: planned.light_samples,
                ..*base
            },
            planned.pixel_spp.as_deref(),
            &tiles,
        )
    }

    /// The row of `render` (subject `name` on `s`; `render_of` the subject that made it, if
    /// another) compared with one oracle's image `b`, its images written to the report
    /// directory if there is one.
    fn row(
        &self,
        s: &ReferencedScene,
        name: &str,
        render: &SubjectRender,
        (oracle_name, b): (&str, &Image),
        render_of: Option<String>,
    ) -> Result<Row, Unusable> {
        let (image, planned) = (&render.image, &render.planned);
        let cmp = compare(image, b, self.cfg).map_err(|e| {
            Unusable(format!(
                "cannot compare {} / {name} with the {oracle_name} image: {e}",
                s.name
            ))
        })?;
        let (rel_diff, rel_ci, worst_tile_p) = summarise(&cmp);
        let mut row = Row {
            scene: s.name.clone(),
            subject: name.to_string(),
            oracle: oracle_name.to_string(),
            verdict: cmp.verdict,
            budget: planned.budget,
            light_samples: planned.light_samples,
            seed: self.opts.seed,
            pilot_seconds: planned.pilot_seconds,
            render_seconds: render.render_seconds,
            render_of,
            precision: budget::precision(image, b),
            rel_diff,
            rel_ci,
            worst_tile_p,
            files: Vec::new(),
            comparison: cmp,
        };
        if let Some(dir) = &self.opts.report_dir {
            row.files = report::write_row_images(dir, &row, image, b)?;
        }
        (self.events)(Event::RowDone(&row));
        Ok(row)
    }
}

/// The options of a subject's pilot renders (the subject replaces the method; the render
/// keeps the rest with its own spp, seed and light samples).
fn pilot_options(opts: &Options) -> RenderOptions {
    RenderOptions {
        spp: opts.budget.pilot_spp.max(2),
        passes: 1,
        seed: pilot_seed(opts.seed),
        method: Technique::ProjectedSolidAngle.into(), // replaced by the subject
        light_samples: 1,
        // Every light (`linlight render`'s default); the choice of one light is
        // certified by the renders of `LIGHT_SELECTION_RENDERS`.
        lights: LightSelection::Every,
        noise: Default::default(),
        // The committed scenes' thin tubes as lines (their allowances assume the limit).
        cylinders: linlight_render::Cylinders::Line,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_render::Heuristic;

    /// The committed scene `name` alone: no sampler suite, shader kernels or variant renders.
    fn scene_only(name: &str) -> Options {
        let mut opts = Options::new(Path::new(env!("CARGO_MANIFEST_DIR")));
        opts.scenes = name.into();
        opts.sampler_suite = false;
        opts.gpu_kernels = false;
        opts.variant_renders.clear();
        opts
    }

    /// A certification's verdicts, budgets and statistics do not depend on the number of
    /// threads (renders, crop windows and exact images are collected in order; the comparisons
    /// are serial), and its CPU time is measured by stage.
    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let opts = scene_only("floor-tube");
        let subjects: [&dyn Subject; 1] = [&Technique::ProjectedSolidAngle];
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool");
            let report = pool
                .install(|| run(&opts, &subjects, &|_| {}))
                .expect("usable input");
            let rows: Vec<String> = report
                .rows()
                .map(|r| {
                    format!(
                        "{} {} {:?} {:?} {}",
                        r.subject,
                        r.oracle,
                        r.budget,
                        r.rel_diff.map(|d| d.map(f64::to_bits)),
                        serde_json::to_string(&r.comparison).expect("serialisable")
                    )
                })
                .collect();
            (rows, report.cpu, report.scenes[0].cpu)
        };
        let (one, cpu, scene_cpu) = run(1);
        assert_eq!(one.len(), 2, "{one:?}"); // mitsuba and closed form
        assert_eq!(one, run(3).0);
        if cfg!(target_os = "linux") {
            let (cpu, scene) = (cpu.expect("measured"), scene_cpu.expect("measured"));
            assert_eq!(cpu.scenes, scene);
            assert!(scene.pilots > 0.0 && scene.renders > 0.0 && scene.comparisons > 0.0);
            assert!(scene.exact_image > 0.0, "{scene:?}");
            assert!(cpu.process >= cpu.loading + scene.total(), "{cpu:?}");
            // Neither ran: the suite's pool only started its threads.
            assert!(cpu.sampler_suite + cpu.gpu_kernels < 0.1, "{cpu:?}");
        }
    }

    /// A subject whose render is another's ([`Subject::same_render_as`]) reuses that render
    /// where it ran before on the scene, and renders itself where it did not; either way its
    /// rows are the other's: the same budget and comparison.
    #[test]
    fn subjects_of_the_same_render_share_it() {
        let opts = scene_only("glossy-cornell");
        let methods = [
            Heuristic::ClampedOptimal(1.0),
            Heuristic::Balance,
            Heuristic::Weighted,
            Heuristic::ClampedOptimal(0.0),
        ]
        .map(Method::Mis);
        let subjects: Vec<&dyn Subject> = methods.iter().map(|m| m as &dyn Subject).collect();
        let report = run(&opts, &subjects, &|_| {}).expect("usable input");
        let rows: Vec<&Row> = report.rows().collect();
        assert_eq!(rows.len(), 4, "one oracle");
        let of: Vec<Option<&str>> = rows.iter().map(|r| r.render_of.as_deref()).collect();
        assert_eq!(of, [None, None, None, Some("mis:balance")]);
        let key = |r: &Row| {
            let cmp = serde_json::to_string(&r.comparison).expect("serialisable");
            format!("{:?} {} {cmp}", r.budget, r.light_samples)
        };
        // Rendered apart (clamped optimal at v = 1 before weighted) or shared: the same rows.
        assert_eq!(key(rows[0]), key(rows[2]));
        assert_eq!(key(rows[1]), key(rows[3]));
        assert_ne!(key(rows[0]), key(rows[1]));
    }
}
