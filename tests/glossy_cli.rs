//! Glossy shading end to end: `crates/render/tests/scenes/glossy_floor_tube.xml` (GGX rough
//! conductor floor, α = 0.4, rgb η/k, one tube) rendered by `linlight render` with two unbiased
//! techniques must be CONSISTENT under `linlight compare` (defaults: α = 0.01 family-wise,
//! δ = 0.5 %), the same render with α off by 5 % must be DIFFERENT (the comparison has the power
//! to see a wrong BSDF), and — where the Mitsuba oracle venv exists — the render must be
//! CONSISTENT with Mitsuba's render of the same file (skipped with a message otherwise).
//!
//! Budgets (32×32, 16 passes; measured global relative standard errors): projected solid angle
//! 16×128 spp ≈ 0.05 %, area 16×512 spp ≈ 0.05 %, Mitsuba (`direct`, one emitter sample)
//! 16×2048 spp ≈ 0.06 %; each comparison's 99.67 % CI is about ±0.2 %, well inside δ = 0.5 %,
//! while α·1.05 changes the image by several per cent. A few seconds of Rust rendering; Mitsuba
//! ~3 s with llvm_ad_rgb.
//!
//! Seeds are fixed, so each verdict is a fixed outcome; at the family-wise α = 0.01 any seed has
//! about a 1 % chance of a false DIFFERENT. Calibration when this test was written: 30 seeds of
//! the projected-solid-angle budget against a 16×1024-spp render gave relative differences with
//! mean −0.03 % and spread 0.065 % (the expected standard error), two with p ≈ 4e-3 (seeds 11
//! and 20); 8 seed pairs of projected-solid-angle vs area were all within ±0.09 %.

mod common;

use common::root;
use std::path::{Path, PathBuf};
use std::process::Command;

fn scene() -> PathBuf {
    root().join("crates/render/tests/scenes/glossy_floor_tube.xml")
}

fn linlight(args: &[&str]) -> (i32, String) {
    let out = common::command().args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

fn render(out: &Path, technique: &str, spp: u32, seed: u64, defines: &[&str]) {
    let scene = scene();
    let (spp, seed) = (spp.to_string(), seed.to_string());
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--technique",
        technique,
        "--passes",
        "16",
        "--spp",
        &spp,
        "--seed",
        &seed,
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    for d in defines {
        args.extend(["-D", d]);
    }
    let (code, text) = linlight(&args);
    assert_eq!(code, 0, "render {technique}: {text}");
}

/// `linlight compare a b`: (exit code, report).
fn compare(a: &Path, b: &Path) -> (i32, String) {
    linlight(&["compare", a.to_str().unwrap(), b.to_str().unwrap()])
}

#[test]
fn glossy_floor_is_consistent_across_techniques_and_with_mitsuba() {
    let dir = common::scratch("glossy");
    let psa = dir.join("psa.exr");
    let area = dir.join("area.exr");
    render(&psa, "projected-solid-angle", 128, 2, &[]);
    render(&area, "area", 512, 3, &[]);
    let (code, report) = compare(&psa, &area);
    println!("{report}");
    assert_eq!(code, 0, "PSA vs area on the glossy floor:\n{report}");
    assert!(report.contains("verdict: CONSISTENT"), "{report}");

    // Power: the roughness off by 5 % must be seen.
    let rougher = dir.join("psa-alpha-0.42.exr");
    render(&rougher, "projected-solid-angle", 128, 4, &["alpha=0.42"]);
    let (code, report) = compare(&rougher, &area);
    println!("{report}");
    assert_eq!(code, 1, "α·1.05 not detected:\n{report}");
    assert!(report.contains("verdict: DIFFERENT"), "{report}");

    // The live oracle, where it is set up.
    let venv = std::env::var_os("LINLIGHT_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join(".venv"));
    if !(venv.join("bin/python").exists() && venv.join("oracle.env").exists()) {
        println!(
            "skipping the live Mitsuba comparison: no oracle venv at {} (run scripts/setup-oracle \
             or set LINLIGHT_VENV)",
            venv.display()
        );
        return;
    }
    let mitsuba = dir.join("mitsuba.exr");
    let out = Command::new(root().join("scripts/harness"))
        .env("LINLIGHT_VENV", &venv)
        .args([
            "render",
            scene().to_str().unwrap(),
            "--passes",
            "16",
            "--spp",
            "2048",
            "--quiet",
            "--out",
            mitsuba.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "Mitsuba render failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (code, report) = compare(&psa, &mitsuba);
    println!("{report}");
    assert_eq!(code, 0, "Rust vs Mitsuba on the glossy floor:\n{report}");
    let _ = std::fs::remove_dir_all(&dir);
}
