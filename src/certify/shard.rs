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

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::scenes::ReferencedScene;
use super::{Report, SceneReport, Subject, Unusable};
use linlight_verify::image_stats::Verdict;

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
    let text = std::fs::read_to_string(path)
        .map_err(|e| refuse(format!("cannot read {}: {e}", path.display())))?;
    let mut report: Report = serde_json::from_str(&text).map_err(|e| {
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

/// Joins the shards of one certification into the report of the unsharded run.
pub fn merge(shards: Vec<(PathBuf, Report)>) -> Result<Report, Unusable> {
    let Some((first_path, first)) = shards.first() else {
        return Err(refuse("no shard given"));
    };
    let name = |p: &Path| p.display().to_string();
    let mut seen: BTreeMap<usize, &Path> = BTreeMap::new();
    let mut count = None;
    for (path, r) in &shards {
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
        .collect();
    if !missing.is_empty() {
        return Err(refuse(format!(
            "missing shard(s) {} (given: {})",
            missing.join(", "),
            seen.keys()
                .map(|i| format!("{i}/{n}"))
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }

    // Every plan item once, in plan order (a shard's rows are checked against its part).
    let plan = first.plan.clone();
    let mut rows_of: BTreeMap<usize, Vec<super::Row>> = BTreeMap::new();
    let mut scene_info: BTreeMap<String, SceneReport> = BTreeMap::new();
    for (path, r) in &shards {
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
                rows_of.entry(j).or_default().push(row.clone());
            }
            scene_info
                .entry(s.name.clone())
                .or_insert_with(|| SceneReport {
                    rows: Vec::new(),
                    ..s.clone()
                });
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
    let verdict = super::overall_verdict(sampler_suite.as_ref(), &scenes);
    Ok(Report {
        passed: verdict == Verdict::Consistent,
        verdict,
        sampler_suite,
        scenes,
        shard: None,
        // The wall time of the slowest shard (they run in parallel).
        elapsed_seconds: shards
            .iter()
            .map(|(_, r)| r.elapsed_seconds)
            .fold(0.0, f64::max),
        ..first.clone()
    })
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

#[cfg(test)]
mod tests {
    use super::*;

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
