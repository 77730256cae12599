//! End-to-end: `linlight samplers` at its defaults (what `linlight certify` runs) certifies every
//! technique and rejects every negative control: exit 0, a table, a JSON report that agrees
//! (2 on bad usage). Runtime: about two minutes on two idle cores (N = 10⁶ samples per
//! configuration).

mod common;

use common::command as linlight;

#[test]
fn samplers_writes_a_report_consistent_with_its_exit_code() {
    let dir = common::scratch("samplers");
    let json = dir.join("report.json");
    let out = linlight()
        .args(["samplers", "--json"])
        .arg(&json)
        .output()
        .expect("run linlight");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let code = out.status.code().expect("exit code");
    assert_eq!(code, 0, "the suite must pass at its defaults\n{stdout}");

    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("JSON written")).expect("valid JSON");
    let passed = report["passed"].as_bool().expect("passed: bool");
    assert_eq!(
        code == 0,
        passed,
        "exit code disagrees with the report\n{stdout}"
    );

    // Settings and the multiple-testing correction.
    assert_eq!(
        report["settings"]["samples"].as_u64(),
        Some(linlight_verify::Settings::default().samples as u64)
    );
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
    // LTC driven by the fitted table (its own grid), the one-sample MIS mixture (the suite's
    // configurations and the grid), the cross densities at the samples of the projected solid
    // angle and of LTC: all pass.
    let grid = report["extra_configurations"].as_array().unwrap().len();
    assert_eq!(grid, 48);
    for (name, count) in [
        ("ltc-fitted-table", grid),
        ("mis-mixture-c0.5", configs.len() + grid),
    ] {
        let t = techniques.iter().find(|t| t["name"] == name).unwrap();
        assert_eq!(t["configs"].as_array().unwrap().len(), count, "{name}");
        assert_eq!(t["verdict"], "pass", "{name}: {}", t["failures_by_check"]);
    }
    for name in ["projected-solid-angle", "ltc", "ltc-fitted-table"] {
        let t = techniques.iter().find(|t| t["name"] == name).unwrap();
        let crossed = t["configs"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|c| c.get("cross").is_some())
            .count();
        assert!(crossed > 20, "{name}: cross densities checked on {crossed}");
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
        "projected-solid-angle-1-iteration-own-inverse",
        "projected-solid-angle-tilt-1%",
        "cross-density-without-kappa",
    ] {
        assert!(
            control_names.contains(&name),
            "{name} missing: {control_names:?}"
        );
    }
    for c in controls {
        assert_eq!(c["verdict"], "rejected as expected", "{}", c["name"]);
        assert!(c["failing_configs"].as_u64().unwrap() > 0);
        assert!(c["rejected_as_required"].as_u64() >= c["needed"].as_u64());
    }
    // A control stops once its configurations decide its rejection: the rest are `decided`.
    // Every control here is decided before its last configuration.
    for c in controls {
        let outcomes: Vec<&str> = c["configs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["outcome"].as_str().unwrap())
            .collect();
        let ran = outcomes.iter().take_while(|o| **o != "decided").count();
        assert!(ran < outcomes.len(), "{}: {outcomes:?}", c["name"]);
        assert!(
            outcomes[ran..].iter().all(|o| *o == "decided"),
            "{outcomes:?}"
        );
    }
    // The self-consistent controls are rejected by χ² alone: nothing else can see them.
    for name in [
        "projected-solid-angle-1-iteration-own-inverse",
        "projected-solid-angle-tilt-1%",
    ] {
        let c = controls.iter().find(|c| c["name"] == name).unwrap();
        let checks: Vec<&String> = c["failures_by_check"].as_object().unwrap().keys().collect();
        assert!(
            checks.iter().all(|k| k.starts_with("chi2")),
            "{name}: {checks:?}"
        );
    }
    // The 1 % tilt: rejected in most tested configurations.
    let tilt = controls
        .iter()
        .find(|c| c["name"] == "projected-solid-angle-tilt-1%")
        .unwrap();
    let tested = tilt["tested"].as_u64().unwrap();
    assert!(2 * tilt["rejected_as_required"].as_u64().unwrap() > tested);
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

/// Options that a mode would ignore are refused (exit 2, naming the option), never dropped
/// silently: `--timeout` without `--external`; `--json`, `--seed`, `--random-configs` with
/// `--backend gpu` (refused before any adapter is looked for, so in every build).
#[test]
fn samplers_refuses_options_its_mode_ignores() {
    for (args, named) in [
        (&["--timeout", "5"][..], "--timeout"),
        (&["--timeout", "5", "--tilt-power"][..], "--timeout"),
        (&["--timeout", "5", "--backend", "gpu"][..], "--timeout"),
        (&["--backend", "gpu", "--json", "x.json"][..], "--json"),
        (&["--backend", "gpu", "--seed", "3"][..], "--seed"),
        (
            &["--backend", "gpu", "--random-configs", "3"][..],
            "--random-configs",
        ),
        (
            &["--backend", "gpu", "--full-controls"][..],
            "--full-controls",
        ),
        (&["--tilt-power", "--full-controls"][..], "--full-controls"),
        (
            &["--external", "true", "--full-controls"][..],
            "--full-controls",
        ),
    ] {
        let out = linlight().arg("samplers").args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(named), "{args:?}: {stderr}");
        assert!(
            out.stdout.is_empty(),
            "{args:?} ran: {}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
    // The defaults the help states are the suite's.
    let out = linlight().args(["samplers", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    let d = linlight_verify::Settings::default();
    assert!(
        help.contains(&format!("[default: {}, the", d.seed)),
        "{help}"
    );
    assert!(
        help.contains(&format!("[default: {}]", d.random_configs)),
        "{help}"
    );
    assert!(help.contains("[default: 120]"), "{help}");
}

/// `--tilt-power` prints the power table (share of configurations whose χ² rejects samples tilted
/// by 1 + ε(2F − 1)) for every ε and writes its report; it is a measurement, exit 0. At a small
/// N a 5 % tilt is already rejected somewhere, a 0.5 % tilt almost nowhere.
#[test]
fn tilt_power_prints_the_table() {
    let dir = std::env::temp_dir().join(format!("linlight-tilt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let json = dir.join("tilt.json");
    let out = linlight()
        .args([
            "samplers",
            "--tilt-power",
            "--samples",
            "100000",
            "--random-configs",
            "5",
            "--json",
        ])
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    for e in ["0.5%", "1%", "2%", "5%"] {
        assert!(
            stdout.contains(&format!("projected-solid-angle-tilt-{e}")),
            "{stdout}"
        );
    }
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let rows = report["negative_controls"].as_array().unwrap();
    assert_eq!(rows.len(), 8);
    let rejected = |name: &str| {
        rows.iter().find(|r| r["name"] == name).unwrap()["rejected_as_required"]
            .as_u64()
            .unwrap()
    };
    assert!(rejected("clipped-solid-angle-tilt-5%") > 0, "{stdout}");
    assert!(
        rejected("clipped-solid-angle-tilt-0.5%") <= rejected("clipped-solid-angle-tilt-5%"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
