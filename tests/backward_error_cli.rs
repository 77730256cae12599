//! End-to-end test of `linlight backward-error` (small sweep): exit codes and the JSON report.
mod common;

use common::command as linlight;

#[test]
fn small_sweep_writes_json_and_orders_iterations() {
    let dir = common::scratch("be");
    let json = dir.join("be.json");
    let out = linlight()
        .args([
            "backward-error",
            "--normals",
            "6",
            "--xi-per-interval",
            "32",
            "--json",
        ])
        .arg(&json)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = doc["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 6); // 1, 2, 3 iterations × f32, f64
    let worst = |k: u64, p: &str| {
        rows.iter()
            .find(|r| r["iterations"] == k && r["precision"] == p)
            .unwrap()["worst_excluding_guard"]
            .as_f64()
            .unwrap()
    };
    assert!(worst(1, "f64") > 1e-3);
    assert!(worst(2, "f64") < 2e-5);
    assert!(worst(3, "f64") < worst(2, "f64"));
    // The near-end intervals are swept (one step fails there) and reported.
    let near = |k: u64| {
        rows.iter()
            .find(|r| r["iterations"] == k && r["precision"] == "f32")
            .unwrap()["worst_excluding_guard_near_ends"]
            .as_f64()
            .unwrap()
    };
    assert!(near(1) > 1e-3, "{}", near(1));
    assert!(near(2) < 2e-5, "{}", near(2));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_usage_exits_2() {
    for args in [
        &["backward-error", "--iterations", "0"][..],
        &["backward-error", "--nope"][..],
    ] {
        let out = linlight().args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}
