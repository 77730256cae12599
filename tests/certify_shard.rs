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

fn merge(name: &str, shards: &[&Path]) -> Output {
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
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    linlight(&args)
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
    let cut_path = scratch().join("cut.json");
    std::fs::write(&cut_path, cut.to_string()).unwrap();
    refused(
        "cut",
        &[&r.shard1, &cut_path],
        "no comparison for floor-tube / li2018",
    );
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
