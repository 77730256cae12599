//! `linlight samplers --backend gpu`: the shader kernels certified through the CLI. With the
//! `gpu` feature the run must pass and reject its controls on the adapter wgpu finds (scripts/
//! test's gpu stage runs it after scripts/setup-gpu, with LINLIGHT_REQUIRE_ADAPTER=1); without
//! an adapter it exits 2 saying "skipped (no adapter)". Without the feature it exits 2 and says
//! how to build the backend.

use std::process::Command;

fn samplers_gpu(samples: &str) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_linlight"))
        .args(["samplers", "--backend", "gpu", "--samples", samples])
        .output()
        .expect("run linlight")
}

#[cfg(not(feature = "gpu"))]
#[test]
fn without_the_feature_says_how_to_build_it() {
    let out = samplers_gpu("64");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--features gpu"), "{err}");
}

/// `certify` (image comparisons of one scene and technique, no sampler suite) in a build with
/// the feature and a Vulkan loader told of no driver.
#[cfg(feature = "gpu")]
fn certify(dir: &std::path::Path, no_driver: bool) -> (std::process::Output, serde_json::Value) {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut c = Command::new(env!("CARGO_BIN_EXE_linlight"));
    c.current_dir(root).args([
        "certify",
        "--quiet",
        "--no-sampler-suite",
        "--scenes",
        "floor-tube",
        "--techniques",
        "projected-solid-angle",
        "--report-dir",
        dir.to_str().unwrap(),
    ]);
    if no_driver {
        c.env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
            .env("VK_DRIVER_FILES", "/nonexistent/icd.json");
    }
    let out = c.output().expect("run linlight");
    let report = std::fs::read_to_string(dir.join("report.json"))
        .map(|t| serde_json::from_str(&t).expect("report.json is JSON"))
        .unwrap_or(serde_json::Value::Null);
    (out, report)
}

/// `certify` includes the kernels' certification where an adapter exists (every check in its
/// summary, JSON, report.md and report.html), and says "skipped (no adapter)" where none does;
/// neither case fails the run.
#[cfg(feature = "gpu")]
#[test]
fn certify_includes_the_kernels_or_says_why_not() {
    let scratch = std::env::temp_dir().join(format!("linlight-gpu-certify-{}", std::process::id()));
    let line = "GPU kernels: skipped (no adapter)";
    let dir = scratch.join("no-driver");
    let (out, report) = certify(&dir, true);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains(line), "{stdout}");
    assert_eq!(report["gpu_kernels"]["skipped"], "no adapter");
    for page in ["report.md", "report.html"] {
        let text = std::fs::read_to_string(dir.join(page)).unwrap();
        assert!(text.contains(line), "{page}");
    }

    let dir = scratch.join("adapter");
    let (out, report) = certify(&dir, false);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if stdout.contains(line) {
        let required = std::env::var("LINLIGHT_REQUIRE_ADAPTER").as_deref() == Ok("1");
        assert!(
            !required,
            "LINLIGHT_REQUIRE_ADAPTER=1 but: {stdout}{stderr}"
        );
        eprintln!("SKIPPED: no adapter for the GPU kernels (run scripts/setup-gpu)");
        return;
    }
    assert_eq!(out.status.code(), Some(0), "{stdout}{stderr}");
    assert!(stdout.contains("GPU kernels: PASS on "), "{stdout}");
    let g = &report["gpu_kernels"];
    assert_eq!(g["passed"], true, "{g}");
    assert!(g["skipped"].is_null(), "{g}");
    let checks = g["checks"].as_array().unwrap();
    // 3 agreements, 3 support ends, the sweep, lookup + MIS, 3 mutated kernels, and the suite
    // on the answers: 3 kernels and 3 mutated kernels.
    assert_eq!(checks.len(), 17, "{g}");
    assert!(checks.iter().all(|c| c["passed"] == true), "{g}");
    for name in ["control one-halley-step", "suite gpu-ltc-ltc-wrong-inverse"] {
        assert!(checks.iter().any(|c| c["name"] == name), "{name}: {g}");
    }
    for page in ["report.md", "report.html"] {
        let text = std::fs::read_to_string(dir.join(page)).unwrap();
        assert!(text.contains("GPU kernels: "), "{page}");
        assert!(text.contains("suite gpu-projected-solid-angle"), "{page}");
    }
    std::fs::remove_dir_all(&scratch).ok();
}

#[cfg(feature = "gpu")]
#[test]
fn kernels_pass_and_controls_are_rejected() {
    let out = samplers_gpu("10000");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.code() == Some(2) && stdout.contains("GPU kernels: skipped (no adapter)") {
        let required = std::env::var("LINLIGHT_REQUIRE_ADAPTER").as_deref() == Ok("1");
        assert!(
            !required,
            "LINLIGHT_REQUIRE_ADAPTER=1 but: {stdout}{stderr}"
        );
        eprintln!("SKIPPED: no adapter for the GPU kernels (run scripts/setup-gpu)");
        return;
    }
    println!("{stdout}");
    assert_eq!(out.status.code(), Some(0), "{stdout}\n{stderr}");
    assert!(stdout.contains("adapter: "), "{stdout}");
    assert!(stdout.contains("GPU kernels: pass"), "{stdout}");
    for control in ["one-halley-step", "pdf-x1.01", "ltc-wrong-inverse"] {
        let line = stdout
            .lines()
            .find(|l| l.trim_start().starts_with(control))
            .unwrap_or_else(|| panic!("no line for {control}: {stdout}"));
        assert!(line.contains("rejected:"), "{line}");
    }
    assert!(!stdout.contains("FAIL"), "{stdout}");
    // The suite on the kernels' answers: every technique, and the mutated kernels as controls.
    assert!(
        stdout.contains("sampler suite on the kernels' answers"),
        "{stdout}"
    );
    for subject in [
        "gpu-clipped-solid-angle",
        "gpu-projected-solid-angle",
        "gpu-ltc",
    ] {
        assert!(stdout.contains(subject), "{subject}: {stdout}");
    }
    assert_eq!(
        stdout.matches("rejected as expected").count(),
        3,
        "{stdout}"
    );
}
