//! End-to-end: `linlight samplers --external COMMAND` (docs/external-protocol.md) with the
//! numpy-free client tests/external/client.py (system `python3`): a correct solid-angle sampler
//! passes (exit 0), wrong answers fail their checks (exit 1), and every way of not answering
//! — crash, non-zero exit, hang, not the protocol, a short or miscounted answer — ends in one
//! line on stderr and exit 2, without a panic and within the timeout. The numpy examples of
//! harness/examples/ run in scripts/test-external (they need the oracle venv).

mod common;

use std::time::{Duration, Instant};

/// Run the suite on `client.py mode` at a small N (2 random configurations + the edge cases).
fn run(mode: &str, extra: &[&str]) -> (common::Run, Duration) {
    let client = common::root().join("tests/external/client.py");
    let command = format!("python3 '{}' {mode}", client.display());
    let mut args = vec![
        "samplers",
        "--external",
        &command,
        "--samples",
        "2000",
        "--random-configs",
        "2",
    ];
    args.extend_from_slice(extra);
    let started = Instant::now();
    let r = common::linlight(&args);
    (r, started.elapsed())
}

/// Exit 2 with exactly one line on stderr that contains `expect`, with the timeout `timeout`
/// seconds (generous where the client is not meant to hang: a loaded machine may take seconds
/// to start Python).
fn assert_refused_within(mode: &str, expect: &str, timeout: u64) {
    let (r, elapsed) = run(mode, &["--timeout", &timeout.to_string()]);
    assert_eq!(r.code, 2, "{mode}: {}\n{}", r.stdout, r.stderr);
    let lines: Vec<&str> = r.stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{mode}: one line expected:\n{}", r.stderr);
    assert!(
        lines[0].starts_with("error: external sampler"),
        "{mode}: {}",
        lines[0]
    );
    assert!(lines[0].contains(expect), "{mode}: {}", lines[0]);
    assert!(!r.stderr.contains("panicked"), "{mode}: {}", r.stderr);
    // At most the timeout once, plus the program's start and the suite's own work.
    assert!(
        elapsed < Duration::from_secs(timeout + 30),
        "{mode}: {elapsed:?}"
    );
}

fn assert_refused(mode: &str, expect: &str) {
    assert_refused_within(mode, expect, 60);
}

/// Exit 1, and the report names `check` among the failing checks.
fn assert_failed_by(mode: &str, check: &str) {
    let dir = common::scratch(mode);
    let json = dir.join("report.json");
    let (r, _) = run(mode, &["--json", json.to_str().unwrap()]);
    assert_eq!(r.code, 1, "{mode}: {}\n{}", r.stdout, r.stderr);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("JSON written")).unwrap();
    let subject = &report["techniques"][0];
    assert_eq!(subject["verdict"], "FAIL", "{mode}");
    assert!(
        subject["failures_by_check"][check].as_u64().unwrap_or(0) > 0,
        "{mode}: {}",
        subject["failures_by_check"]
    );
}

#[test]
fn a_correct_client_passes_with_every_check_run() {
    let dir = common::scratch("ok");
    let json = dir.join("report.json");
    let (r, _) = run("ok", &["--json", json.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}\n{}", r.stdout, r.stderr);
    assert!(r.stdout.contains("protocol: "), "{}", r.stdout);
    assert!(r.stdout.contains("PASS"), "{}", r.stdout);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("JSON written")).unwrap();
    assert_eq!(report["passed"], true);
    let subject = &report["techniques"][0];
    assert_eq!(subject["verdict"], "pass");
    let configs = subject["configs"].as_array().unwrap();
    let tested: Vec<_> = configs
        .iter()
        .filter(|c| c["outcome"] == "tested")
        .collect();
    assert!(tested.len() > 30, "{}", tested.len());
    for c in tested {
        assert!(c["chi2"]["p_value"].as_f64().is_some(), "{c}");
        assert_eq!(c["reported_inverse"]["checked"], 2000, "{c}");
        assert_eq!(c["pdf_queries"]["queried"], 2000, "{c}");
        assert!(c["round_trip"]["checked"].as_u64().unwrap() > 0, "{c}");
    }
}

#[test]
fn a_crash_is_reported_with_its_status_and_stderr() {
    assert_refused("crash", "exited with status 3");
    let (r, _) = run("crash", &[]);
    assert!(r.stderr.contains("crashing on purpose"), "{}", r.stderr);
}

#[test]
fn a_non_zero_exit_after_the_last_request_is_an_error() {
    assert_refused("exit-1-at-end", "exited with status 1");
}

#[test]
fn a_hang_ends_at_the_timeout() {
    // (If Python is slower than 2 s to start, "hang" ends at its hello instead: the same
    // timeout.)
    assert_refused_within("hang", "within 2 s (--timeout)", 2);
    assert_refused_within("silent", "no hello line within 2 s", 2);
}

#[test]
fn output_that_is_not_the_protocol_is_refused() {
    assert_refused("garbage-hello", "hello line is not the protocol's");
    assert_refused("version-3", "version 3");
    assert_refused("unknown-technique", "\"my-own-sampler\"");
    assert_refused("garbage-header", "answer header that is not the protocol's");
}

#[test]
fn a_short_or_miscounted_answer_is_refused() {
    assert_refused(
        "short",
        "ended after 20000 of the answer's 40000 payload bytes",
    );
    assert_refused(
        "wrong-count",
        "an answer of 1999 entries to a request of 2000",
    );
}

#[test]
fn wrong_numbers_fail_their_checks() {
    assert_failed_by("nan", "answer");
    assert_failed_by("negative", "answer");
    assert_failed_by("off-sphere", "direction");
    assert_failed_by("wrong-pdf", "cross-density");
}

/// Names of the configurations an `ltc` probe was asked on (it answers wrongly: exit 1).
fn ltc_probe_configs(mode: &str) -> Vec<String> {
    let dir = common::scratch(mode);
    let json = dir.join("report.json");
    let (r, _) = run(mode, &["--json", json.to_str().unwrap()]);
    assert_eq!(r.code, 1, "{mode}: {}\n{}", r.stdout, r.stderr);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("JSON written")).unwrap();
    report["techniques"][0]["configs"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["outcome"] == "tested")
        .map(|c| c["config"].as_str().unwrap().to_string())
        .collect()
}

/// Protocol version 2: an `ltc` program is also asked on the fitted GGX table's grid, and
/// exactly those configurations carry `ggx` (α, cos θ_o); a version-1 program is asked as
/// before, without the key (the probe exits 3 otherwise: exit 2 here).
#[test]
fn version_2_adds_the_fitted_table_grid_for_ltc() {
    let grid = linlight_verify::configs::ltc_table_configs();
    let v2 = ltc_probe_configs("ltc-v2-probe");
    let asked_on_grid = grid.iter().filter(|c| v2.contains(&c.name)).count();
    assert!(
        asked_on_grid >= grid.len() / 2,
        "{asked_on_grid} of {}: {v2:?}",
        grid.len()
    );
    let v1 = ltc_probe_configs("ltc-v1-probe");
    assert!(v1.iter().all(|n| !n.starts_with("ggx-")), "{v1:?}");
    assert_eq!(v2.len(), v1.len() + asked_on_grid);
}

#[test]
fn bad_usage_exits_2() {
    let r = common::linlight(&["samplers", "--external", "true", "--timeout", "0"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("--timeout"), "{}", r.stderr);
    let r = common::linlight(&["samplers", "--external", "true", "--tilt-power"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
}
