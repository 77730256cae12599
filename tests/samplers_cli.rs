//! End-to-end: `linlight samplers` runs the certification suite, prints its table, writes the
//! JSON report, and its exit code agrees with the report (0 iff everything passed and every
//! negative control was rejected; 2 on bad usage).

mod common;

use common::command as linlight;

#[test]
fn samplers_writes_a_report_consistent_with_its_exit_code() {
    let dir = common::scratch("samplers");
    let json = dir.join("report.json");
    let out = linlight()
        .args([
            "samplers",
            "--random-configs",
            "20",
            "--samples",
            "20000",
            "--json",
        ])
        .arg(&json)
        .output()
        .expect("run linlight");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let code = out.status.code().expect("exit code");
    assert!(code == 0 || code == 1, "exit {code}\n{stdout}");

    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("JSON written")).expect("valid JSON");
    let passed = report["passed"].as_bool().expect("passed: bool");
    assert_eq!(
        code == 0,
        passed,
        "exit code disagrees with the report\n{stdout}"
    );

    // Settings and the multiple-testing correction.
    assert_eq!(report["settings"]["samples"], 20000);
    let alpha_c = report["alpha_per_test"].as_f64().unwrap();
    assert!(alpha_c > 0.0 && alpha_c < 0.01 / 100.0);
    let configs = report["configurations"].as_array().unwrap();
    assert!(
        configs.len() > 20,
        "edge cases are added to the random configurations"
    );

    // Every unbiased technique is a row with per-class summaries and per-config results.
    let techniques = report["techniques"].as_array().unwrap();
    let mut names: Vec<&str> = linlight_sampling::Technique::UNBIASED
        .map(|t| t.name())
        .to_vec();
    names.push("ltc");
    for name in names {
        let t = techniques
            .iter()
            .find(|t| t["name"] == name)
            .unwrap_or_else(|| panic!("{name}"));
        assert_eq!(
            t["configs"].as_array().unwrap().len(),
            configs.len(),
            "{name}"
        );
        assert!(t["classes"].as_array().unwrap().len() >= 8, "{name}");
        assert!(stdout.contains(name), "{name} missing from the table");
    }
    // The implemented reference techniques pass.
    for name in ["solid-angle", "clipped-solid-angle"] {
        let t = techniques.iter().find(|t| t["name"] == name).unwrap();
        assert_eq!(t["verdict"], "pass", "{name}: {}", t["failures_by_check"]);
        let worst_p = t["worst_p_value"].as_f64().unwrap();
        assert!(worst_p >= alpha_c, "{name}: worst p {worst_p}");
    }
    // Negative controls are reported apart, and every one is rejected.
    let controls = report["negative_controls"].as_array().unwrap();
    let control_names: Vec<&str> = controls
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    for name in [
        "clipped-solid-angle-pdf-x1.01",
        "clipped-samples-unclipped-pdf",
        "projected-solid-angle-1-iteration",
        "li2018-2-iterations",
        "ltc-without-kappa",
    ] {
        assert!(
            control_names.contains(&name),
            "{name} missing: {control_names:?}"
        );
    }
    for c in controls {
        assert_eq!(c["verdict"], "rejected as expected", "{}", c["name"]);
        assert!(c["failing_configs"].as_u64().unwrap() > 0);
    }
    assert!(stdout.contains("rejected as expected"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn samplers_bad_usage_exits_2() {
    let out = linlight()
        .args(["samplers", "--samples", "5"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = linlight()
        .args(["samplers", "--no-such-flag"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = linlight()
        .args(["samplers", "--samples", "many"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}
