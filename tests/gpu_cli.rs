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
