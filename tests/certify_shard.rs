//! `linlight certify --shard i/N` and `--merge` through the binary: two shards merged give the
//! verdict and the comparisons of the unsharded run; bad merges are refused with exit 2.

mod common;

use common::linlight_in_root as linlight;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| common::scratch("shards"))
}

/// A small certification: one scene with a closed form (two comparisons per technique) and
/// three techniques, so that shard 1 of 2 holds items 1 and 3, shard 2 item 2.
const SCENES: &str = "floor-tube";
const TECHNIQUES: &str = "projected-solid-angle,li2018,hart-quadratic";

/// Runs certify into `scratch/name` with extra arguments; returns the report.json path.
fn certify(name: &str, scenes: &str, extra: &[&str]) -> PathBuf {
    let dir = scratch().join(name);
    let mut args = vec![
        "certify",
        "--quiet",
        "--no-sampler-suite",
        "--threads",
        "2",
        "--scenes",
        scenes,
        "--techniques",
        TECHNIQUES,
        "--report-dir",
        dir.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = linlight(&args);
    assert_eq!(
        o.status.code(),
        Some(0),
        "certify {extra:?}: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    dir.join("report.json")
}

struct Runs {
    whole: PathBuf,
    shard1: PathBuf,
    shard2: PathBuf,
    other_scenes: PathBuf,
}

fn runs() -> &'static Runs {
    static RUNS: OnceLock<Runs> = OnceLock::new();
    RUNS.get_or_init(|| Runs {
        whole: certify("whole", SCENES, &[]),
        shard1: certify("shard-1", SCENES, &["--shard", "1/2"]),
        shard2: certify("shard-2", SCENES, &["--shard", "2/2"]),
        other_scenes: certify("other-2", "two-tubes", &["--shard", "2/2"]),
    })
}

fn read(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// What must agree between the sharded and the unsharded run: per comparison its identity,
/// verdict, spp, relative differences and failures, in order.
fn comparisons(report: &Value) -> Vec<Value> {
    report["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|s| s["rows"].as_array().unwrap().clone())
        .map(|r| {
            serde_json::json!([
                r["scene"],
                r["subject"],
                r["oracle"],
                r["verdict"],
                r["budget"]["spp"],
                r["rel_diff"],
                r["comparison"]["failures"],
                r["comparison"]["channels"]
            ])
        })
        .collect()
}

/// `certify --merge` of `shards` into `scratch/name` (the shards ran without the sampler suite,
/// so the merge is told so).
fn merge(name: &str, shards: &[&Path]) -> Output {
    merge_with(name, shards, &["--no-sampler-suite"])
}

fn merge_with(name: &str, shards: &[&Path], extra: &[&str]) -> Output {
    let dir = scratch().join(name);
    let mut args = vec![
        "certify".to_string(),
        "--report-dir".into(),
        dir.to_str().unwrap().into(),
        "--json".into(),
        dir.join("summary.json").to_str().unwrap().into(),
        "--merge".into(),
    ];
    args.extend(shards.iter().map(|p| p.to_str().unwrap().to_string()));
    args.extend(extra.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    linlight(&args)
}

/// `v` with every object's keys sorted.
fn sorted(v: Value) -> Value {
    match v {
        Value::Object(m) => {
            let entries: std::collections::BTreeMap<String, Value> =
                m.into_iter().map(|(k, v)| (k, sorted(v))).collect();
            Value::Object(entries.into_iter().collect())
        }
        Value::Array(a) => Value::Array(a.into_iter().map(sorted).collect()),
        other => other,
    }
}

/// Writes `report` to `scratch/name.json` with its `content_sha256` recomputed, as a forger
/// with `sha256sum` would (docs/reliability.md: the hash catches edits, the recomputation
/// catches forged verdicts).
fn resealed(name: &str, mut report: Value) -> PathBuf {
    use sha2::{Digest, Sha256};
    report.as_object_mut().unwrap().remove("content_sha256");
    let hash: String = Sha256::digest(sorted(report.clone()).to_string().as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    report["content_sha256"] = Value::from(hash);
    let path = scratch().join(format!("{name}.json"));
    std::fs::write(&path, serde_json::to_string_pretty(&report).unwrap()).unwrap();
    path
}

#[test]
fn two_shards_merged_are_the_unsharded_run() {
    let r = runs();
    let (s1, s2) = (read(&r.shard1), read(&r.shard2));
    // The split: items 1 and 3 in shard 1, item 2 in shard 2, each with both oracles.
    assert_eq!(comparisons(&s1).len(), 4);
    assert_eq!(comparisons(&s2).len(), 2);
    let o = merge("merged", &[&r.shard2, &r.shard1]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let whole = read(&r.whole);
    let merged = read(&scratch().join("merged/report.json"));
    assert_eq!(merged, read(&scratch().join("merged/summary.json")));
    assert_eq!(merged["verdict"], whole["verdict"]);
    assert_eq!(merged["passed"], whole["passed"]);
    assert_eq!(comparisons(&merged), comparisons(&whole));
    assert_eq!(comparisons(&merged).len(), 6);
    // One Šidák correction: the level of the full default certification, as unsharded.
    for key in [
        "comparisons_in_family",
        "alpha_per_comparison",
        "alpha",
        "plan",
    ] {
        assert_eq!(merged[key], whole[key], "{key}");
    }
    assert_eq!(merged["shard"], Value::Null);
    assert!(scratch().join("merged/report.md").is_file());
    assert!(
        stdout.contains("CONSISTENT") || stdout.contains("PASS"),
        "{stdout}"
    );
}

/// A bad merge exits 2 with a message naming the problem.
fn refused(name: &str, shards: &[&Path], expect: &str) {
    let o = merge(name, shards);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{name}: {err}");
    assert!(
        err.contains(expect),
        "{name}: expected '{expect}' in: {err}"
    );
    assert!(!scratch().join(name).join("report.json").exists(), "{name}");
}

#[test]
fn bad_merges_are_refused() {
    let r = runs();
    refused("missing", &[&r.shard1], "missing shard(s) 2/2");
    refused(
        "overlap",
        &[&r.shard1, &r.shard1, &r.shard2],
        "both shard 1/2",
    );
    refused(
        "scene-sets",
        &[&r.shard1, &r.other_scenes],
        "different scene sets",
    );
    refused("unsharded", &[&r.whole, &r.shard2], "is not a shard");
    let junk = scratch().join("junk.json");
    std::fs::write(&junk, "{\"verdict\": 1}").unwrap();
    refused("junk", &[&r.shard1, &junk], "not a certify report");
    refused("absent", &[&scratch().join("nope.json")], "cannot read");
    // A shard whose run was cut short (a comparison removed from its JSON).
    let mut cut = read(&r.shard2);
    cut["scenes"][0]["rows"].as_array_mut().unwrap().clear();
    let cut_path = resealed("cut", cut);
    refused(
        "cut",
        &[&r.shard1, &cut_path],
        "no comparison for floor-tube / li2018",
    );
}

/// Forged shards: each edit is refused (exit 2), edited in place (the hash no longer
/// matches) and resealed (the recomputation from the statistics, or a plan check, refuses it).
#[test]
fn forged_shards_are_refused() {
    let r = runs();
    let s2 = read(&r.shard2);
    // A row at +50 % with p = 1e-30, still labelled CONSISTENT.
    let mut forged = s2.clone();
    {
        let g = &mut forged["scenes"][0]["rows"][0]["comparison"]["channels"][0]["global"];
        let b = g["mean_b"].as_f64().unwrap();
        g["mean_a"] = Value::from(1.5 * b);
        g["diff"] = Value::from(0.5 * b);
        g["p"] = Value::from(1e-30);
        g["rel_diff"] = Value::from(0.5);
    }
    let plain = scratch().join("plus50-unsealed.json");
    std::fs::write(&plain, serde_json::to_string(&forged).unwrap()).unwrap();
    refused(
        "plus50-unsealed",
        &[&r.shard1, &plain],
        "changed after it was written",
    );
    let sealed = resealed("plus50", forged);
    refused("plus50", &[&r.shard1, &sealed], "statistics do not support");
    // A DIFFERENT row relabelled CONSISTENT (both labels).
    let mut relabelled = s2.clone();
    {
        let row = &mut relabelled["scenes"][0]["rows"][0];
        let g = &mut row["comparison"]["channels"][1]["global"];
        g["p"] = Value::from(1e-30);
        g["significant"] = Value::from(false);
    }
    let sealed = resealed("relabelled", relabelled);
    refused("relabelled", &[&r.shard1, &sealed], "global p = 1e-30");
    // A duplicated row.
    let mut dup = s2.clone();
    let row = dup["scenes"][0]["rows"][0].clone();
    dup["scenes"][0]["rows"].as_array_mut().unwrap().push(row);
    let sealed = resealed("duplicated", dup);
    refused(
        "duplicated",
        &[&r.shard1, &sealed],
        "duplicated or removed rows",
    );
    // A removed row (one oracle of an item).
    let mut removed = s2.clone();
    removed["scenes"][0]["rows"].as_array_mut().unwrap().pop();
    let sealed = resealed("removed", removed);
    refused(
        "removed",
        &[&r.shard1, &sealed],
        "duplicated or removed rows",
    );
    // α = 1e-300 in every shard (nothing would ever be rejected).
    let at = |mut v: Value, name: &str| {
        v["alpha"] = Value::from(1e-300);
        resealed(name, v)
    };
    let (a1, a2) = (at(read(&r.shard1), "alpha-1"), at(s2.clone(), "alpha-2"));
    refused("alpha", &[&a1, &a2], "α = 1e-300");
    // Shard counts: 0 panicked (remainder by zero), 10⁸ aborted listing the missing shards.
    for (count, name) in [(0u64, "count-0"), (100_000_000, "count-1e8")] {
        let mut v = s2.clone();
        v["shard"]["count"] = Value::from(count);
        if count == 0 {
            v["shard"]["index"] = Value::from(0);
        }
        let sealed = resealed(name, v);
        refused(name, &[&r.shard1, &sealed], "is not a part i/N");
    }
    // Another version.
    let mut old = s2.clone();
    old["tool_version"] = Value::from("linlight 0.0.1");
    let sealed = resealed("version", old);
    refused("version", &[&r.shard1, &sealed], "was written by");
    // The sampler suite removed: refused unless the merge is told to go without it.
    let o = merge_with("no-suite", &[&r.shard1, &r.shard2], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("sampler suite"));
}

#[test]
fn shard_argument_is_checked() {
    for bad in ["0/2", "3/2", "2", "x/y"] {
        let o = linlight(&["certify", "--shard", bad, "--report-dir", "/tmp/unused"]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert!(
            String::from_utf8_lossy(&o.stderr).contains("--shard"),
            "{bad}"
        );
    }
}
