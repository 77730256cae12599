//! `linlight figures --quick` end to end: every figure and the page are produced, the page links
//! only files that exist and embeds its pictures, the numbers behind the figures are sane
//! (projected solid angle beats area sampling on the unoccluded diffuse floor, blue noise's
//! low-pass RMSE is below white noise's at equal spp, every convergence curve — one per technique
//! and per MIS heuristic — has slope −½, MIS beats PSA only on the glossy scene), and a second run with the same seed
//! reproduces the seeded numbers exactly.

mod common;

use common::{linlight, root, scratch};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The figures of the page, in order (`linlight figures --only` names).
const FIGURES: [&str; 10] = [
    "one-spp",
    "cornell",
    "specular",
    "backward-error",
    "noise",
    "newton",
    "convergence",
    "timings",
    "tube-radius",
    "tube-sampling",
];

fn run_figures(out: &Path, extra: &[&str]) {
    let mut args = vec![
        "figures",
        "--quick",
        "--out",
        out.to_str().unwrap(),
        "--root",
        root().to_str().unwrap(),
        "--threads",
        "2",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let r = linlight(&args);
    assert_eq!(r.code, 0, "linlight figures failed:\n{}", r.stderr);
}

/// One full `--quick` run shared by the tests of this file.
fn quick() -> &'static PathBuf {
    static OUT: OnceLock<PathBuf> = OnceLock::new();
    OUT.get_or_init(|| {
        let out = scratch("quick");
        run_figures(&out, &[]);
        out
    })
}

fn json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Values of `attr="…"` in `html`.
fn attributes<'a>(html: &'a str, attr: &str) -> Vec<&'a str> {
    let key = format!("{attr}=\"");
    html.match_indices(&key)
        .map(|(i, _)| {
            let rest = &html[i + key.len()..];
            &rest[..rest.find('"').unwrap()]
        })
        .collect()
}

#[test]
fn quick_run_produces_every_figure_and_a_page_that_links_only_existing_files() {
    let out = quick();
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let numbers = json(&out.join("numbers.json"));
    for name in FIGURES {
        assert!(
            numbers["figures"][name].is_object(),
            "numbers.json has no figure {name}"
        );
        assert!(out.join(format!("{name}.json")).is_file(), "{name}.json");
        assert!(
            html.contains(&format!("id=\"{name}\"")),
            "index.html has no section {name}"
        );
    }
    // The per-heuristic convergence curves are drawn (they were once announced as missing).
    assert!(html.contains("id=\"mis-heuristics\"") && !html.contains("not produced"));
    let links = attributes(&html, "href");
    assert!(links.len() > 20, "too few links: {}", links.len());
    for link in links.iter().filter(|l| !l.starts_with('#')) {
        assert!(
            !link.contains("://") && !link.starts_with('/') && !link.contains(".."),
            "the page must be self-contained: {link}"
        );
        assert!(
            out.join(link).is_file(),
            "index.html links a missing file: {link}"
        );
    }
    // Pictures are inline (the page is one file): every <img> is a data: URI.
    let images = attributes(&html, "src");
    assert!(images.len() > 20, "too few pictures: {}", images.len());
    for src in images {
        assert!(
            src.starts_with("data:image/"),
            "picture not inline: {src:.60}"
        );
    }
    for bad in ["NaN", "inf"] {
        assert!(
            !html.contains(&format!(">{bad}<")) && !html.contains(&format!(" {bad},")),
            "the page shows {bad}"
        );
    }
}

#[test]
fn projected_solid_angle_beats_area_sampling_on_the_unoccluded_floor() {
    let one = json(&quick().join("one-spp.json"));
    let rmse = |technique: &str| {
        one["renders"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["scene"] == "floor-tube" && r["technique"] == technique)
            .and_then(|r| r["rmse"].as_f64())
            .unwrap_or_else(|| panic!("no floor-tube {technique} render"))
    };
    let (area, sa, psa) = (
        rmse("area"),
        rmse("solid-angle"),
        rmse("projected-solid-angle"),
    );
    assert!(psa.is_finite() && psa > 0.0, "{psa}");
    assert!(
        psa < sa && sa < area,
        "area {area}, solid angle {sa}, PSA {psa}"
    );
}

#[test]
fn blue_noise_low_pass_error_is_below_white_noise_at_equal_spp() {
    let noise = json(&quick().join("noise.json"));
    let low_pass = |scene: &str, kind: &str, spp: u64| {
        noise["renders"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["scene"] == scene && r["noise"] == kind && r["spp"] == spp)
            .and_then(|r| r["low_pass_rmse"].as_f64())
            .unwrap_or_else(|| panic!("no {scene} {kind} {spp} spp render"))
    };
    // The unoccluded floor (error from the film position only): blue noise's error is almost
    // all above the filter's pass band. The room (penumbrae, glossy floor) at N = 3.
    for spp in [1, 3] {
        let white = low_pass("floor-tube", "white", spp);
        for kind in ["blue", "blue-jittered"] {
            let blue = low_pass("floor-tube", kind, spp);
            assert!(
                blue < 0.5 * white,
                "floor-tube N = {spp}: {kind} {blue} vs white {white}"
            );
        }
    }
    let white = low_pass("room", "white", 3);
    for kind in ["blue", "blue-jittered"] {
        let blue = low_pass("room", kind, 3);
        assert!(blue < white, "room N = 3: {kind} {blue} vs white {white}");
    }
}

#[test]
fn seeded_numbers_are_reproduced_run_to_run() {
    let first = quick();
    let again = scratch("again");
    run_figures(&again, &["--only", "backward-error,noise,tube-radius"]);
    for file in ["backward-error.csv", "noise.csv", "tube-radius.csv"] {
        let a = std::fs::read(first.join(file)).unwrap();
        let b = std::fs::read(again.join(file)).unwrap();
        assert!(a == b, "{file} differs between two runs with the same seed");
    }
}

#[test]
fn unknown_figure_names_are_refused() {
    let out = scratch("unknown");
    let r = linlight(&[
        "figures",
        "--quick",
        "--only",
        "noise,teaser-of-doom",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("teaser-of-doom"), "{}", r.stderr);
    assert!(!out.join("index.html").exists());
}

#[test]
fn a_missing_project_root_is_a_usage_error() {
    let out = scratch("noroot");
    let r = linlight(&[
        "figures",
        "--quick",
        "--root",
        out.to_str().unwrap(),
        "--out",
        out.join("figs").to_str().unwrap(),
    ]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("--root"), "{}", r.stderr);
}

/// On the glossy shadowed plane at roughness 0.3, MIS of one PSA and one LTC sample beats each
/// technique alone (the paper's roughness figure).
#[test]
fn mis_beats_each_technique_on_the_glossy_plane() {
    let spec = json(&quick().join("specular.json"));
    let rmse = |method: &str| {
        spec["renders"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| {
                r["scene"] == "shadowed-plane" && r["roughness"] == "0.3" && r["method"] == method
            })
            .and_then(|r| r["rmse"].as_f64())
            .unwrap_or_else(|| panic!("no shadowed-plane 0.3 {method} render"))
    };
    let (psa, ltc, mis) = (
        rmse("projected-solid-angle"),
        rmse("ltc"),
        rmse("mis:clamped-optimal=0.5"),
    );
    assert!(mis.is_finite() && mis > 0.0);
    assert!(mis < psa && mis < ltc, "PSA {psa}, LTC {ltc}, MIS {mis}");
}

/// A glossy curve of the convergence figure: label, method name, points (spp, RMSE).
type Curve = (String, String, Vec<(f64, f64)>);

/// The glossy curves of the convergence figure.
fn glossy_curves() -> Vec<Curve> {
    let conv = json(&quick().join("convergence.json"));
    conv["glossy"]["curves"]
        .as_array()
        .expect("convergence.json has no glossy curves")
        .iter()
        .map(|c| {
            let pts = c["points"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| (p["spp"].as_f64().unwrap(), p["rmse"].as_f64().unwrap()))
                .collect();
            (
                c["curve"].as_str().unwrap().to_string(),
                c["method"].as_str().unwrap().to_string(),
                pts,
            )
        })
        .collect()
}

/// One convergence curve per MIS heuristic (and PSA only, LTC only) on the glossy scene, each
/// with its points at 1, 2, …, 64 spp (the `--quick` maximum).
#[test]
fn convergence_has_a_curve_per_mis_heuristic() {
    let curves = glossy_curves();
    let methods: Vec<&str> = curves.iter().map(|c| c.1.as_str()).collect();
    for m in [
        "projected-solid-angle",
        "ltc",
        "mis:balance",
        "mis:power",
        "mis:weighted",
        "mis:clamped-optimal=0.5",
    ] {
        assert!(methods.contains(&m), "no glossy curve for {m}: {methods:?}");
    }
    for (name, _, pts) in &curves {
        let spps: Vec<f64> = pts.iter().map(|p| p.0).collect();
        assert_eq!(spps, [1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0], "{name}");
        assert!(
            pts.iter().all(|p| p.1.is_finite() && p.1 > 0.0),
            "{name}: {pts:?}"
        );
    }
    let csv = std::fs::read_to_string(quick().join("convergence.csv")).unwrap();
    assert!(csv
        .lines()
        .any(|l| l.starts_with("glossy-blend,MIS power,mis:power,64,")));
}

/// Every Rust curve (the Cornell box's techniques, the glossy scene's methods) has slope −½ of
/// log RMSE over log spp. Tolerance ±0.05: each RMSE averages 64×64×3 squared errors, so its
/// log scatters by about 0.01–0.03 (heavier tails at 1 spp); over 7 points at spp 1 … 64 the
/// least-squares slope then scatters by σ/√Σ(ln spp − mean)² = σ/3.7 ≤ 0.01 — the tolerance is
/// ≥ 5 of those, while a biased or noise-floored estimator flattens the slope past it (a bias
/// equal to the 64-spp standard error gives −0.42, twice that −0.32). The glossy reference is exact (variance 0);
/// the Cornell box's has its variance subtracted. Mitsuba's curve (committed numbers) is drawn but
/// not tested here.
#[test]
fn convergence_slopes_are_minus_one_half() {
    let conv = json(&quick().join("convergence.json"));
    let mut slopes: Vec<(String, f64)> = Vec::new();
    for s in conv["slopes"]
        .as_array()
        .unwrap()
        .iter()
        .chain(conv["glossy"]["slopes"].as_array().unwrap())
    {
        let curve = s["curve"].as_str().unwrap();
        if !curve.starts_with("Mitsuba") {
            slopes.push((curve.to_string(), s["slope"].as_f64().unwrap()));
        }
    }
    assert_eq!(slopes.len(), 7 + 6, "{slopes:?}");
    for (curve, s) in &slopes {
        assert!((s + 0.5).abs() < 0.05, "{curve}: slope {s}");
    }
}

/// On the glossy scene at 64 spp (the `--quick` maximum, fixed seed), MIS with the paper's
/// heuristic (clamped optimal, v = 0.5) has an RMSE below PSA only's — by a wide margin (this
/// seed: 0.0016 vs 0.0115, a factor of 7; the test asks for a factor of 2), although
/// at equal spp MIS draws two light samples to PSA's one: variance, not sample count, makes it.
#[test]
fn mis_beats_psa_only_at_equal_spp_on_the_glossy_scene() {
    let curves = glossy_curves();
    let last = |m: &str| {
        curves
            .iter()
            .find(|c| c.1 == m)
            .and_then(|c| c.2.last())
            .map(|p| p.1)
            .unwrap_or_else(|| panic!("no glossy curve {m}"))
    };
    let (psa, mis) = (
        last("projected-solid-angle"),
        last("mis:clamped-optimal=0.5"),
    );
    assert!(mis > 0.0 && 2.0 * mis < psa, "MIS {mis} vs PSA only {psa}");
}

/// The R → 0 figure: with K = L·R fixed, the exact tube's image mean approaches the line's at
/// first order in R. From the figure's own points (7 radii, 1e-4 … 0.1): every difference is
/// resolved (> 5 standard errors, which come from the passes), and the weighted least-squares
/// slope of log difference over log R is within 0.05 of 1. Why 0.05: the fit's standard error
/// is ~0.002 and the O(R²) term moves d/R by a few per cent over the three decades (slope
/// change < 0.01), while the failures it guards against sit far outside: a difference that does
/// not vanish (a K/R conversion lost) has slope 0, an O(√R) one ½, and an R·log(1/R) one (as at a
/// contact) about 1 − 1/ln(1/R) ≈ 0.86 over these radii.
#[test]
fn exact_tubes_approach_the_line_with_slope_one() {
    let fig = json(&quick().join("tube-radius.json"));
    let points = fig["points"]
        .as_array()
        .expect("tube-radius.json has no points");
    assert_eq!(points.len(), 7, "{points:?}");
    for p in points {
        let (d, se) = (
            p["relative_difference"].as_f64().unwrap(),
            p["standard_error"].as_f64().unwrap(),
        );
        assert!(se > 0.0 && d > 5.0 * se, "unresolved difference: {p}");
    }
    let slope = fig["fit"]["slope"].as_f64().unwrap();
    let error = fig["fit"]["slope_error"].as_f64().unwrap();
    assert!((slope - 1.0).abs() < 0.05, "slope {slope} ± {error}");
    assert!(error < 0.01, "slope {slope} ± {error}");
}

/// The finite-tube table: every technique, with and without MIS, on the three finite-R scenes,
/// against Mitsuba's committed reference over the pixels that see only the floor. Every method
/// is unbiased, so each row's mean is within 5 standard errors of Mitsuba's (24 rows; the
/// chance that an unbiased row falls outside is ~6e-7 each under a normal approximation — the
/// area rows' tails are heavier, hence 5 and not the Šidák 3.5); a biased technique or a lost
/// factor (a density off by 1 %, a missing BSDF-side weight) is many standard errors off. Ours
/// has a lower variance per camera sample than area sampling and than Mitsuba on every scene,
/// and the shading benchmark has a finite positive ratio of ours to Gamito on each scene.
#[test]
fn finite_tube_techniques_agree_with_mitsuba_and_ours_has_the_least_variance() {
    let fig = json(&quick().join("tube-sampling.json"));
    let rows = fig["rows"]
        .as_array()
        .expect("tube-sampling.json has no rows");
    assert_eq!(rows.len(), 3 * 11, "{rows:?}");
    for r in rows {
        let (d, e) = (
            r["difference_vs_reference"].as_f64().unwrap(),
            r["difference_error"].as_f64().unwrap(),
        );
        assert!(e > 0.0 && d.abs() < 5.0 * e, "mean off Mitsuba's: {r}");
    }
    for scene in ["diffuse", "glossy", "contact"] {
        let var = |method: &str| {
            rows.iter()
                .find(|r| r["scene"] == scene && r["method"].as_str().unwrap().starts_with(method))
                .and_then(|r| r["relative_variance"].as_f64())
                .unwrap_or_else(|| panic!("no {scene} row {method}"))
        };
        let ours = var("ours (projected)");
        assert!(
            ours > 0.0 && ours < var("area (front)") && ours < var("Mitsuba"),
            "{scene}"
        );
    }
    for s in fig["shading_ns"].as_array().unwrap() {
        let ns = |t: &str| {
            s["ns"]
                .as_array()
                .unwrap()
                .iter()
                .find(|x| x["technique"] == t)
                .and_then(|x| x["ns"].as_f64())
                .unwrap()
        };
        let ratio = ns("cylinder-projected") / ns("cylinder-gamito");
        assert!(ratio.is_finite() && ratio > 0.0, "{s}");
    }
}
