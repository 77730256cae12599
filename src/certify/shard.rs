//! `linlight certify --shard i/N` and `linlight certify --merge`: one certification split over
//! N jobs (a CI matrix) and joined into one verdict.
//!
//! The *plan* is the scene × technique list of the unsharded run, in order (scenes as listed,
//! techniques in the order given). Shard i of N (1-based) runs the items j ≡ i − 1 (mod N):
//! round robin, so that the expensive techniques of every scene spread over the shards. The
//! sampler suite runs in shard 1. Every comparison of every shard runs at the Šidák level of the
//! full default certification (`Report::alpha_per_comparison`, m comparisons), as the unsharded
//! run does; the merge checks that all shards used the same m, α, δ, budget rule, seed, oracle and
//! plan (scene names, techniques and scene hashes), that every item of the plan was run by exactly
//! one shard, and then takes the worst verdict over the suite and all comparisons: the merged
//! report holds exactly the comparisons, verdicts and family-wise level of the unsharded run.
//!
//! The merge trusts no verdict. Each report carries the version of the program that wrote it
//! and a SHA-256 of its own JSON ([`sealed_json`]); the merge refuses another version or a
//! report whose content does not match its hash, recomputes the verdict of every comparison
//! from the statistics it carries at the family's Šidák level ([`recheck_row`]), checks that
//! every item of the plan has exactly its comparisons (one per oracle, no duplicates), that
//! the shards agree on the scene and reference hashes, and that the sampler suite is there
//! (unless the merge is told `--no-sampler-suite`) with every technique and negative control
//! of this version. Any mismatch is an error (exit 2), never a verdict.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use super::gpu::GpuSummary;
use super::sampler_suite::SuiteSummary;
use super::scenes::ReferencedScene;
use super::{matrix, Options, Report, Row, SceneReport, Subject, Unusable};
use linlight_imagefile::input::{read_text_capped, MAX_TEXT_BYTES};
use linlight_verify::image_stats::{
    ChannelReport, CompareConfig, Comparison, Verdict, TESTS_PER_CHANNEL,
};
use linlight_verify::z_score::{normal_upper_tail, sidak, t_two_sided_p};

/// The version written into every report and required of every shard by `--merge`.
pub const TOOL_VERSION: &str = concat!("linlight ", env!("CARGO_PKG_VERSION"));

/// Most shards of one certification (a CI matrix is a few dozen; a larger count in a report
/// is damage or forgery, and listing its missing shards would not end).
pub const MAX_SHARDS: usize = 4096;

/// Name of the report's hash field ([`sealed_json`]).
const HASH_KEY: &str = "content_sha256";

fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The hash of a report's JSON: SHA-256 of its compact serialisation (object keys sorted)
/// without the `content_sha256` field.
pub fn content_hash(value: &Value) -> String {
    let mut v = value.clone();
    if let Value::Object(m) = &mut v {
        m.remove(HASH_KEY);
    }
    sha256_hex(sorted(v).to_string().as_bytes())
}

/// `v` with the keys of every object in sorted order (the hash does not depend on how a
/// JSON library orders them).
fn sorted(v: Value) -> Value {
    match v {
        Value::Object(m) => {
            let entries: BTreeMap<String, Value> =
                m.into_iter().map(|(k, v)| (k, sorted(v))).collect();
            Value::Object(entries.into_iter().collect())
        }
        Value::Array(a) => Value::Array(a.into_iter().map(sorted).collect()),
        other => other,
    }
}

/// The report as pretty JSON with this program's version and the hash of its content
/// (`content_sha256`), as `report.json` and `--json` hold it.
pub fn sealed_json(report: &Report) -> Result<String, String> {
    let mut v = serde_json::to_value(report).map_err(|e| e.to_string())?;
    if let Value::Object(m) = &mut v {
        m.insert("tool_version".into(), Value::from(TOOL_VERSION));
        let hash = content_hash(&Value::Object(m.clone()));
        m.insert(HASH_KEY.into(), Value::from(hash));
    }
    serde_json::to_string_pretty(&v)
        .map(|t| t + "\n")
        .map_err(|e| e.to_string())
}

/// Part i of N (1 ≤ i ≤ N).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    /// "i/N", 1 ≤ i ≤ N.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("--shard expects i/N with 1 ≤ i ≤ N (e.g. 2/4), got '{s}'");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || count == 0 || index > count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl Shard {
    /// Whether item `j` (0-based position in the plan) belongs to this shard.
    pub fn runs(&self, j: usize) -> bool {
        j % self.count == self.index - 1
    }
    /// Whether this shard runs the sampler suite (shard 1).
    pub fn runs_suite(&self) -> bool {
        self.index == 1
    }
}

/// Whether item `j` of the plan is run by `shard` (None: the unsharded run runs everything).
pub fn runs(shard: Option<Shard>, j: usize) -> bool {
    shard.is_none_or(|s| s.runs(j))
}

/// One scene × technique of the plan.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlanItem {
    pub scene: String,
    pub subject: String,
    /// sha256 of the scene file its reference was rendered from.
    pub scene_sha256: String,
}

/// The plan of a run: every selected scene × its subjects (`subjects[i]` for `scenes[i]`),
/// scene-major.
pub fn plan(scenes: &[ReferencedScene], subjects: &[Vec<&dyn Subject>]) -> Vec<PlanItem> {
    scenes
        .iter()
        .zip(subjects)
        .flat_map(|(s, subjects)| {
            subjects.iter().map(move |t| PlanItem {
                scene: s.name.clone(),
                subject: t.name(),
                scene_sha256: s.reference.meta.scene_sha256.clone(),
            })
        })
        .collect()
}

fn refuse(msg: impl Into<String>) -> Unusable {
    Unusable(format!("--merge: {}", msg.into()))
}

/// Reads a shard's JSON (`report.json` of its report directory, or its `--json`).
pub fn read(path: &Path) -> Result<Report, Unusable> {
    let text = read_text_capped(path, MAX_TEXT_BYTES).map_err(refuse)?;
    let value: Value = serde_json::from_str(&text).map_err(|e| {
        refuse(format!(
            "{}: not a certify report (not JSON: {e})",
            path.display()
        ))
    })?;
    let stored = value
        .get(HASH_KEY)
        .and_then(Value::as_str)
        .map(str::to_owned);
    let mut report: Report = serde_json::from_value(value.clone()).map_err(|e| {
        refuse(format!(
            "{}: not a certify report ({e}){}",
            path.display(),
            if text.contains("\"plan\"") {
                ""
            } else {
                "; shards must be written by `linlight certify --shard i/N` of this version"
            }
        ))
    })?;
    match stored {
        None => {
            return Err(refuse(format!(
                "{}: no {HASH_KEY} (shards must be written by `linlight certify --shard i/N` of \
                 this version)",
                path.display()
            )))
        }
        Some(h) if h != content_hash(&value) => {
            return Err(refuse(format!(
                "{}: the report was changed after it was written (its {HASH_KEY} does not \
                 match its content)",
                path.display()
            )))
        }
        Some(_) => {}
    }
    if report.tool_version != TOOL_VERSION {
        return Err(refuse(format!(
            "{} was written by {:?}, this is {TOOL_VERSION}: merge shards with the version \
             that wrote them",
            path.display(),
            report.tool_version
        )));
    }
    if let Some(s) = report.shard {
        if s.index == 0 || s.index > s.count || s.count > MAX_SHARDS {
            return Err(refuse(format!(
                "{}: shard {}/{} is not a part i/N with 1 ≤ i ≤ N ≤ {MAX_SHARDS}",
                path.display(),
                s.index,
                s.count
            )));
        }
    }
    // Row files are relative to the shard's report directory: point them there.
    let dir = path.parent().unwrap_or(Path::new("."));
    let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    for row in report.scenes.iter_mut().flat_map(|s| s.rows.iter_mut()) {
        for f in &mut row.files {
            if Path::new(f.as_str()).is_relative() {
                *f = dir.join(&*f).to_string_lossy().into_owned();
            }
        }
    }
    Ok(report)
}

/// The settings every shard must share with the others (what makes one family of comparisons).
fn settings(r: &Report) -> String {
    format!(
        "α = {}, m = {} comparisons (α per comparison {:e}), δ = {}, budget {}, seed {}, oracle {:?}",
        r.alpha,
        r.comparisons_in_family,
        r.alpha_per_comparison,
        r.tolerance,
        serde_json::to_string(&r.budget_rule).unwrap_or_default(),
        r.seed,
        r.oracle
    )
}

/// Joins the shards of one certification into the report of the unsharded run, rechecking
/// everything they claim (module documentation). `require_suite`: refuse a merge without the
/// sampler suite (the command line's default; `--no-sampler-suite` drops it).
pub fn merge(shards: Vec<(PathBuf, Report)>, require_suite: bool) -> Result<Report, Unusable> {
    let Some((first_path, first)) = shards.first() else {
        return Err(refuse("no shard given"));
    };
    let alpha_c = family_level(first_path, first)?;
    check_split(&shards)?;
    // Every plan item once, in plan order (a shard's rows are checked against its part).
    let plan = first.plan.clone();
    let (rows_of, scene_info) = rows_by_item(&shards, &plan, alpha_c, first.tolerance)?;
    check_one_row_per_oracle(&plan, &rows_of)?;
    let scenes = scenes_in_plan_order(&plan, rows_of, &scene_info)?;
    let sampler_suite = merged_suite(&shards, require_suite)?;
    let gpu_kernels = merged_kernels(&shards)?;
    let verdict = super::overall_verdict(sampler_suite.as_ref(), gpu_kernels.as_ref(), &scenes);
    Ok(Report {
        passed: verdict == Verdict::Consistent,
        verdict,
        sampler_suite,
        gpu_kernels,
        scenes,
        shard: None,
        content_sha256: None,
        // The wall time of the slowest shard (they run in parallel).
        elapsed_seconds: shards
            .iter()
            .map(|(_, r)| r.elapsed_seconds)
            .fold(0.0, f64::max),
        // The CPU-s of all shards (None unless every shard measured them).
        cpu: shards
            .iter()
            .map(|(_, r)| r.cpu)
            .try_fold(super::CpuTimes::default(), |a, c| c.map(|c| a + c)),
        ..first.clone()
    })
}

/// The family's Šidák level per comparison, after checking that `first` (read from
/// `first_path`) ran at the command line's α and δ over at least the plan's comparisons.
fn family_level(first_path: &Path, first: &Report) -> Result<f64, Unusable> {
    let defaults = Options::new(Path::new("."));
    if first.alpha != defaults.alpha || first.tolerance != defaults.tolerance {
        return Err(refuse(format!(
            "{}: α = {:e}, δ = {}; `linlight certify` runs at α = {}, δ = {}",
            name_of(first_path),
            first.alpha,
            first.tolerance,
            defaults.alpha,
            defaults.tolerance
        )));
    }
    let alpha_c = sidak(first.alpha, first.comparisons_in_family.max(1));
    if first.alpha_per_comparison != alpha_c || first.comparisons_in_family < first.plan.len() {
        return Err(refuse(format!(
            "{}: α per comparison {:e} over m = {} is not the Šidák level {alpha_c:e} of a \
             family of at least the plan's {} items",
            name_of(first_path),
            first.alpha_per_comparison,
            first.comparisons_in_family,
            first.plan.len()
        )));
    }
    Ok(alpha_c)
}

/// Checks that `shards` are the N shards of one split (each once, none missing) of one plan
/// with the same settings as the first.
fn check_split(shards: &[(PathBuf, Report)]) -> Result<(), Unusable> {
    let (first_path, first) = &shards[0];
    let name = |p: &Path| p.display().to_string();
    let mut seen: BTreeMap<usize, &Path> = BTreeMap::new();
    let mut count = None;
    for (path, r) in shards {
        let Some(s) = r.shard else {
            return Err(refuse(format!(
                "{} is not a shard (written without --shard i/N)",
                name(path)
            )));
        };
        match count {
            None => count = Some(s.count),
            Some(n) if n != s.count => {
                return Err(refuse(format!(
                    "{} is shard {s} but {} is shard {} of {n}: shards of different splits",
                    name(path),
                    name(first_path),
                    first.shard.map_or(String::new(), |f| f.to_string())
                )))
            }
            _ => {}
        }
        if let Some(other) = seen.insert(s.index, path) {
            return Err(refuse(format!(
                "{} and {} are both shard {s} (overlapping shards)",
                name(other),
                name(path)
            )));
        }
        if r.plan != first.plan {
            return Err(refuse(format!(
                "{} and {} certify different scene sets (scenes, techniques or scene files differ: {} vs {})",
                name(first_path),
                name(path),
                plan_summary(&first.plan),
                plan_summary(&r.plan)
            )));
        }
        if settings(r) != settings(first) {
            return Err(refuse(format!(
                "{} and {} used different settings ({} vs {})",
                name(first_path),
                name(path),
                settings(first),
                settings(r)
            )));
        }
    }
    let n = count.unwrap_or(0);
    let missing: Vec<String> = (1..=n)
        .filter(|i| !seen.contains_key(i))
        .map(|i| format!("{i}/{n}"))
        .take(10)
        .collect();
    if !missing.is_empty() {
        let more = n - seen.len() - missing.len();
        return Err(refuse(format!(
            "missing shard(s) {}{} (given: {})",
            missing.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            },
            seen.keys()
                .map(|i| format!("{i}/{n}"))
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok(())
}

/// The rows of each plan item (by its index in the plan).
type RowsByItem = BTreeMap<usize, Vec<Row>>;

/// The rows of every shard by plan item, each rechecked at the family's level `alpha_c` and
/// tolerance, and each scene's report without its rows (the shards must agree on it).
fn rows_by_item(
    shards: &[(PathBuf, Report)],
    plan: &[PlanItem],
    alpha_c: f64,
    tolerance: f64,
) -> Result<(RowsByItem, BTreeMap<String, SceneReport>), Unusable> {
    let name = |p: &Path| p.display().to_string();
    let mut rows_of = RowsByItem::new();
    let mut scene_info: BTreeMap<String, SceneReport> = BTreeMap::new();
    for (path, r) in shards {
        let shard = r.shard.expect("checked above");
        for s in &r.scenes {
            for row in &s.rows {
                let j = plan
                    .iter()
                    .position(|p| p.scene == row.scene && p.subject == row.subject)
                    .ok_or_else(|| {
                        refuse(format!(
                            "{}: comparison {} / {} is not in the plan",
                            name(path),
                            row.scene,
                            row.subject
                        ))
                    })?;
                if !shard.runs(j) {
                    return Err(refuse(format!(
                        "{}: shard {shard} holds {} / {}, which belongs to another shard",
                        name(path),
                        row.scene,
                        row.subject
                    )));
                }
                if row.scene != s.name {
                    return Err(refuse(format!(
                        "{}: comparison {} / {} is listed under scene {}",
                        name(path),
                        row.scene,
                        row.subject,
                        s.name
                    )));
                }
                recheck_row(row, alpha_c, tolerance).map_err(|e| {
                    refuse(format!(
                        "{}: {} / {} against {}: {e}",
                        name(path),
                        row.scene,
                        row.subject,
                        row.oracle
                    ))
                })?;
                rows_of.entry(j).or_default().push(row.clone());
            }
            if let Some(item) = plan.iter().find(|p| p.scene == s.name) {
                if s.reference.scene_sha256 != item.scene_sha256 {
                    return Err(refuse(format!(
                        "{}: the reference of {} was rendered from scene {}, the plan has {}",
                        name(path),
                        s.name,
                        s.reference.scene_sha256,
                        item.scene_sha256
                    )));
                }
            }
            // A scene's CPU-s are split over the shards that ran its rows: the merged report
            // has the sum over shards only.
            let info = SceneReport {
                rows: Vec::new(),
                cpu: None,
                ..s.clone()
            };
            let json = |r: &SceneReport| serde_json::to_string(&r.reference).unwrap_or_default();
            match scene_info.get(&s.name) {
                Some(other) if json(other) != json(&info) => {
                    return Err(refuse(format!(
                        "{}: the reference of {} differs from another shard's ({} vs {})",
                        name(path),
                        s.name,
                        json(&info),
                        json(other)
                    )))
                }
                Some(_) => {}
                None => {
                    scene_info.insert(s.name.clone(), info);
                }
            }
        }
    }
    Ok((rows_of, scene_info))
}

/// Checks that every plan item has exactly one comparison per oracle (Mitsuba, and the exact
/// image on the scenes that have one): no duplicated, removed or absent rows.
fn check_one_row_per_oracle(plan: &[PlanItem], rows_of: &RowsByItem) -> Result<(), Unusable> {
    for (j, rows) in rows_of {
        let p = &plan[*j];
        let oracles: BTreeSet<&str> = rows.iter().map(|r| r.oracle.as_str()).collect();
        let want = 1 + usize::from(matrix::has_exact_oracle(&p.scene));
        if oracles.len() != rows.len() || rows.len() != want || !oracles.contains("mitsuba") {
            return Err(refuse(format!(
                "{} / {} has {} comparison(s) against [{}]; it must have {want}, one per oracle \
                 (duplicated or removed rows)",
                p.scene,
                p.subject,
                rows.len(),
                rows.iter()
                    .map(|r| r.oracle.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    }
    let absent: Vec<String> = plan
        .iter()
        .enumerate()
        .filter(|(j, _)| !rows_of.contains_key(j))
        .map(|(_, p)| format!("{} / {}", p.scene, p.subject))
        .collect();
    if !absent.is_empty() {
        return Err(refuse(format!(
            "the shards hold no comparison for {} (a shard was cut short?)",
            absent.join(", ")
        )));
    }
    Ok(())
}

/// The scenes of the plan in plan order, each with its items' rows in plan order.
fn scenes_in_plan_order(
    plan: &[PlanItem],
    mut rows_of: RowsByItem,
    scene_info: &BTreeMap<String, SceneReport>,
) -> Result<Vec<SceneReport>, Unusable> {
    let mut scenes: Vec<SceneReport> = Vec::new();
    for (j, p) in plan.iter().enumerate() {
        if scenes.last().is_none_or(|s| s.name != p.scene) {
            let info = scene_info
                .get(&p.scene)
                .cloned()
                .ok_or_else(|| refuse(format!("no shard reports scene {}", p.scene)))?;
            scenes.push(info);
        }
        let last = scenes.last_mut().expect("pushed above");
        last.rows.extend(rows_of.remove(&j).unwrap_or_default());
    }
    Ok(scenes)
}

/// The GPU kernels' summary of the one shard that carries it (shard 1), checked against its
/// rows; `None` if no shard carries it (reports of versions without it).
fn merged_kernels(shards: &[(PathBuf, Report)]) -> Result<Option<GpuSummary>, Unusable> {
    let kernels: Vec<&(PathBuf, Report)> = shards
        .iter()
        .filter(|(_, r)| r.gpu_kernels.is_some())
        .collect();
    if kernels.len() > 1 {
        return Err(refuse(format!(
            "{} shards carry the GPU kernels' certification ({}); only shard 1 runs it",
            kernels.len(),
            kernels
                .iter()
                .map(|(p, _)| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let gpu_kernels = kernels.first().and_then(|(_, r)| r.gpu_kernels.clone());
    if let Some(g) = &gpu_kernels {
        g.check_consistency().map_err(refuse)?;
    }
    Ok(gpu_kernels)
}

/// The sampler suite of the one shard that carries it (shard 1), rechecked; `None` only if
/// no shard carries it and `require_suite` is false.
fn merged_suite(
    shards: &[(PathBuf, Report)],
    require_suite: bool,
) -> Result<Option<SuiteSummary>, Unusable> {
    let name = |p: &Path| p.display().to_string();
    let suites: Vec<&(PathBuf, Report)> = shards
        .iter()
        .filter(|(_, r)| r.sampler_suite.is_some())
        .collect();
    if suites.len() > 1 {
        return Err(refuse(format!(
            "{} shards carry a sampler suite ({}); only shard 1 runs it",
            suites.len(),
            suites
                .iter()
                .map(|(p, _)| name(p))
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let sampler_suite = suites.first().and_then(|(_, r)| r.sampler_suite.clone());
    match &sampler_suite {
        Some(s) => recheck_suite(s).map_err(refuse)?,
        None if require_suite => {
            return Err(refuse(
                "no shard carries the sampler suite (shard 1 runs it); merge with \
                 --no-sampler-suite to judge the image comparisons alone",
            ))
        }
        None => {}
    }
    Ok(sampler_suite)
}

fn name_of(p: &Path) -> String {
    p.display().to_string()
}

fn plan_summary(plan: &[PlanItem]) -> String {
    let mut scenes: Vec<&str> = plan.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    let mut subjects: Vec<&str> = plan.iter().map(|p| p.subject.as_str()).collect();
    subjects.sort_unstable();
    subjects.dedup();
    format!(
        "{} item(s): scenes [{}] × techniques [{}]",
        plan.len(),
        scenes.join(", "),
        subjects.join(", ")
    )
}

/// Relative agreement required of a p-value recomputed from the statistics it came from.
const P_AGREEMENT: f64 = 1e-6;

fn p_agrees(stored: f64, recomputed: f64) -> bool {
    (stored - recomputed).abs() <= P_AGREEMENT * stored.abs().max(recomputed.abs()) + 1e-300
}

/// The verdict of one comparison recomputed from the statistics it carries, at the family's
/// level `alpha_c` and margin `tolerance`: the global p from its difference, standard error
/// and dof; the relative difference from the two means; equivalence from the stored interval
/// (which must contain the relative difference and be at least as wide as the normal
/// interval of the stored variances); tiles, pixels (χ² from Σz², max|z| by Šidák) and contacts
/// from their p-values; an exact-value mismatch. Any stored flag or label that disagrees with
/// the recomputation, or a comparison run at another level, is an error.
pub fn recheck_row(row: &Row, alpha_c: f64, tolerance: f64) -> Result<(), String> {
    let c = &row.comparison;
    let bad = |what: String| Err(format!("statistics do not support the report: {what}"));
    let alpha_test = recheck_level(c, alpha_c, tolerance)?;
    if c.channels.len() != 3 {
        return bad(format!("{} channels instead of 3", c.channels.len()));
    }
    let mut different = c.zero_variance.mismatched > 0;
    let mut inconclusive = false;
    let z_eq = linlight_verify::z_score::normal_two_sided_quantile(alpha_c / 3.0);
    for (k, ch) in c.channels.iter().enumerate() {
        let name = ch.channel;
        let g = &ch.global;
        let (significant, equivalent) = recheck_global(ch, alpha_test, z_eq, tolerance)?;
        different |= significant;
        inconclusive |= !equivalent;
        if row.rel_diff[k] != g.rel_diff || row.rel_ci[k] != g.rel_ci {
            return bad(format!(
                "channel {name}: the row's summary differs from its comparison"
            ));
        }
        different |= recheck_local(ch, alpha_test)?;
    }
    let verdict = if different {
        Verdict::Different
    } else if inconclusive {
        Verdict::Inconclusive
    } else {
        Verdict::Consistent
    };
    if row.verdict != verdict || c.verdict != verdict {
        return bad(format!(
            "labelled {}, but its statistics give {} at α = {alpha_c:e}",
            row.verdict.label(),
            verdict.label()
        ));
    }
    if c.failures.is_empty() == different {
        return bad(format!(
            "{} failure(s) listed for a {} comparison",
            c.failures.len(),
            verdict.label()
        ));
    }
    Ok(())
}

/// Checks that comparison `c` ran at the family's configuration (level `alpha_c`, margin
/// `tolerance`) and its number of tests; returns the level of one test.
fn recheck_level(c: &Comparison, alpha_c: f64, tolerance: f64) -> Result<f64, String> {
    let bad = |what: String| Err(format!("statistics do not support the report: {what}"));
    let want_cfg = CompareConfig {
        alpha: alpha_c,
        tolerance,
        ..CompareConfig::default()
    };
    let json = |c: &CompareConfig| serde_json::to_string(c).unwrap_or_default();
    if json(&c.config) != json(&want_cfg) {
        return bad(format!(
            "compared with {} instead of the family's configuration {}",
            json(&c.config),
            json(&want_cfg)
        ));
    }
    let tests = 3 * (TESTS_PER_CHANNEL + usize::from(!c.contact_pixels.is_empty()));
    let alpha_test = alpha_c / tests as f64;
    if c.tests != tests || c.alpha_test != alpha_test || c.alpha_equivalence != alpha_c / 3.0 {
        return bad(format!(
            "{} tests at α {:e} (equivalence {:e}); the family's level gives {tests} at {:e}",
            c.tests, c.alpha_test, c.alpha_equivalence, alpha_test
        ));
    }
    Ok(alpha_test)
}

/// Channel `ch`'s global test recomputed at the level `alpha_test` of one test, and its
/// equivalence at the quantile `z_eq` and margin `tolerance`: (significant, equivalent), each
/// checked against its stored flag.
fn recheck_global(
    ch: &ChannelReport,
    alpha_test: f64,
    z_eq: f64,
    tolerance: f64,
) -> Result<(bool, bool), String> {
    let bad = |what: String| Err(format!("statistics do not support the report: {what}"));
    let name = ch.channel;
    let g = &ch.global;
    let finite = [
        g.mean_a,
        g.mean_b,
        g.diff,
        g.std_err,
        g.rel_var_a,
        g.rel_var_b,
    ];
    if finite.iter().any(|x| !x.is_finite()) || g.std_err < 0.0 {
        return bad(format!("channel {name}: non-finite global statistics"));
    }
    if (g.diff - (g.mean_a - g.mean_b)).abs() > 1e-9 * g.mean_a.abs().max(g.mean_b.abs()) {
        return bad(format!(
            "channel {name}: difference {} is not mean A − mean B = {}",
            g.diff,
            g.mean_a - g.mean_b
        ));
    }
    let p = match (g.p, g.dof) {
        (Some(p), Some(dof)) if g.std_err > 0.0 && dof > 0.0 => {
            let re = t_two_sided_p(g.diff / g.std_err, dof);
            if !p_agrees(p, re) {
                return bad(format!(
                    "channel {name}: global p = {p:e}, but its difference, standard error \
                     and dof give {re:e}"
                ));
            }
            Some(re)
        }
        (None, None) if g.std_err == 0.0 => None,
        _ => return bad(format!("channel {name}: global p without a standard error")),
    };
    let significant = p.is_some_and(|p| p <= alpha_test);
    if g.significant != significant {
        return bad(format!(
            "channel {name}: global test flagged {}",
            g.significant
        ));
    }
    // Relative difference and its interval.
    let rel = if g.mean_b != 0.0 {
        Some(g.mean_a / g.mean_b - 1.0)
    } else {
        (g.mean_a == 0.0).then_some(0.0)
    };
    match (g.rel_diff, rel) {
        (Some(a), Some(b)) if (a - b).abs() <= 1e-9 * (1.0 + b.abs()) => {}
        (None, None) => {}
        (stored, re) => {
            return bad(format!(
                "channel {name}: relative difference {stored:?}, its means give {re:?}"
            ))
        }
    }
    let min_half = z_eq * (g.rel_var_a + g.rel_var_b).sqrt() * (1.0 - 1e-9);
    let equivalent = match (rel, g.rel_ci) {
        (Some(r), Some([lo, hi])) => {
            if !(lo <= r + 1e-12 && r - 1e-12 <= hi && (hi - lo) / 2.0 >= min_half) {
                return bad(format!(
                    "channel {name}: interval [{lo:e}, {hi:e}] does not hold the relative \
                     difference {r:e} with half-width ≥ {min_half:e}"
                ));
            }
            lo >= -tolerance && hi <= tolerance
        }
        (_, None) => false,
        (None, Some(_)) => return bad(format!("channel {name}: interval without a difference")),
    };
    if g.equivalent != equivalent {
        return bad(format!(
            "channel {name}: equivalence flagged {}",
            g.equivalent
        ));
    }
    Ok((significant, equivalent))
}

/// Channel `ch`'s local tests recomputed from their p-values at the level `alpha_test` of one
/// test — tiles (Holm-adjusted), pixels (χ² from Σz², max|z| by Šidák) and contacts — and
/// checked against their stored flags: whether any rejects.
fn recheck_local(ch: &ChannelReport, alpha_test: f64) -> Result<bool, String> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let bad = |what: String| Err(format!("statistics do not support the report: {what}"));
    let name = ch.channel;
    let t = &ch.tiles;
    let tile_rejects = match &t.worst {
        Some(w) => {
            if !((0.0..=1.0).contains(&w.p) && w.p <= w.p_holm && w.p_holm <= 1.0) {
                return bad(format!(
                    "channel {name}: tile p {} / Holm {}",
                    w.p, w.p_holm
                ));
            }
            w.p_holm <= alpha_test
        }
        None => false,
    };
    if tile_rejects != (t.rejected > 0) {
        return bad(format!(
            "channel {name}: {} tiles flagged rejected",
            t.rejected
        ));
    }
    let mut different = tile_rejects;
    let px = &ch.pixels;
    if px.tested > 0 {
        if !(px.sum_z2 >= 0.0 && px.max_abs_z >= 0.0) {
            return bad(format!("channel {name}: negative Σz² or max|z|"));
        }
        let chi2 = ChiSquared::new(px.tested as f64)
            .map(|d| d.sf(px.sum_z2).clamp(0.0, 1.0))
            .map_err(|e| format!("channel {name}: {e}"))?;
        let p_min = (2.0 * normal_upper_tail(px.max_abs_z)).min(1.0);
        let max_p = (-(px.tested as f64 * (-p_min).ln_1p()).exp_m1()).clamp(0.0, 1.0);
        match (px.chi2_p, px.max_p) {
            (Some(a), Some(b)) if p_agrees(a, chi2) && p_agrees(b, max_p) => {}
            (a, b) => {
                return bad(format!(
                    "channel {name}: pixel p-values {a:?}, {b:?}; Σz² and max|z| over {} \
                     pixels give {chi2:e}, {max_p:e}",
                    px.tested
                ))
            }
        }
        different |= chi2 <= alpha_test || max_p <= alpha_test;
    } else if px.chi2_p.is_some() || px.max_p.is_some() {
        return bad(format!(
            "channel {name}: pixel p-values without tested pixels"
        ));
    }
    if let Some(p) = ch.contacts.p {
        if !(0.0..=1.0).contains(&p) {
            return bad(format!("channel {name}: contact p = {p}"));
        }
        different |= p <= alpha_test;
    }
    Ok(different)
}

/// The sampler suite as the merge requires it: every technique and negative control of this
/// version, each row's flag consistent with its failing configurations, and the suite's verdict
/// the conjunction of its rows.
fn recheck_suite(suite: &SuiteSummary) -> Result<(), String> {
    use linlight_verify::subjects::{certified, negative_controls};
    let names = |v: &[super::sampler_suite::SuiteRow]| -> Vec<String> {
        v.iter().map(|r| r.name.clone()).collect()
    };
    let want_t: Vec<String> = certified().into_iter().map(|s| s.name).collect();
    let want_c: Vec<String> = negative_controls().into_iter().map(|s| s.name).collect();
    if names(&suite.techniques) != want_t || names(&suite.negative_controls) != want_c {
        return Err(format!(
            "the sampler suite lists techniques [{}] and controls [{}]; this version's suite is \
             [{}] and [{}]",
            names(&suite.techniques).join(", "),
            names(&suite.negative_controls).join(", "),
            want_t.join(", "),
            want_c.join(", ")
        ));
    }
    for t in &suite.techniques {
        if t.passed && (t.failing_configs > 0 || t.verdict.starts_with("panicked")) {
            return Err(format!(
                "sampler suite: {} is marked passed with {} failing configuration(s) ({})",
                t.name, t.failing_configs, t.verdict
            ));
        }
    }
    let passed = suite.techniques.iter().all(|r| r.passed)
        && suite.negative_controls.iter().all(|r| r.passed);
    if suite.passed != passed {
        return Err(format!(
            "sampler suite marked {} but its rows give {}",
            if suite.passed { "passed" } else { "failed" },
            if passed { "passed" } else { "failed" }
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn suite() -> SuiteSummary {
        use super::super::sampler_suite::SuiteRow;
        use linlight_verify::subjects::{certified, negative_controls};
        let row = |name: String| SuiteRow {
            name,
            passed: true,
            verdict: "PASS".into(),
            failing_configs: 0,
            configurations_run: None,
            worst_p_value: Some(0.3),
            seconds: 1.0,
        };
        SuiteSummary {
            passed: true,
            configurations: 10,
            samples: 1000,
            alpha: 0.01,
            alpha_per_test: 1e-4,
            techniques: certified().into_iter().map(|s| row(s.name)).collect(),
            negative_controls: negative_controls()
                .into_iter()
                .map(|s| row(s.name))
                .collect(),
            elapsed_seconds: 1.0,
        }
    }

    #[test]
    fn forged_sampler_suites_are_refused() {
        assert_eq!(recheck_suite(&suite()), Ok(()));
        // A failed technique marked passed.
        let mut s = suite();
        s.techniques[1].failing_configs = 3;
        assert!(recheck_suite(&s).unwrap_err().contains("3 failing"));
        // A failed technique left failed under a passing suite.
        let mut s = suite();
        s.techniques[0].passed = false;
        assert!(recheck_suite(&s).unwrap_err().contains("marked passed"));
        // A technique or a control removed.
        let mut s = suite();
        s.techniques.remove(2);
        assert!(recheck_suite(&s)
            .unwrap_err()
            .contains("this version's suite"));
        let mut s = suite();
        s.negative_controls.pop();
        assert!(recheck_suite(&s).is_err());
    }

    #[test]
    fn sealed_reports_hash_their_content() {
        let v: Value = serde_json::json!({"b": 1, "a": [1.5, {"z": null, "y": "x"}]});
        let h = content_hash(&v);
        // Key order does not matter; content does; the hash field itself is not hashed.
        let reordered: Value =
            serde_json::from_str(r#"{"a": [1.5, {"y": "x", "z": null}], "b": 1}"#).unwrap();
        assert_eq!(content_hash(&reordered), h);
        let mut with_hash = v.clone();
        with_hash[HASH_KEY] = Value::from(h.clone());
        assert_eq!(content_hash(&with_hash), h);
        let mut changed = v.clone();
        changed["b"] = Value::from(2);
        assert_ne!(content_hash(&changed), h);
    }

    #[test]
    fn parses_and_splits_round_robin() {
        let s: Shard = "2/3".parse().unwrap();
        assert_eq!(s, Shard { index: 2, count: 3 });
        let runs: Vec<usize> = (0..8).filter(|&j| s.runs(j)).collect();
        assert_eq!(runs, [1, 4, 7]);
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        // Every item in exactly one shard.
        for n in 1..6 {
            for j in 0..20 {
                let owners = (1..=n)
                    .filter(|&i| Shard { index: i, count: n }.runs(j))
                    .count();
                assert_eq!(owners, 1);
            }
        }
    }
}
