//! `linlight figures --quick` end to end: every figure and the page are produced, the page links
//! only files that exist and embeds its pictures, the numbers behind the figures are sane
//! (projected solid angle beats area sampling on the unoccluded diffuse floor, blue noise's
//! low-pass RMSE is below white noise's at equal spp), and a second run with the same seed
//! reproduces the seeded numbers exactly.

mod common;

use common::{linlight, root, scratch};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The figures of the page, in order (`linlight figures --only` names).
const FIGURES: [&str; 8] = [
    "one-spp",
    "cornell",
    "specular",
    "backward-error",
    "noise",
    "newton",
    "convergence",
    "timings",
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
    // What the page does not make, it says (no stand-in pictures).
    assert!(html.contains("id=\"mis-heuristics\"") && html.contains("not produced"));
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
    run_figures(&again, &["--only", "backward-error,noise"]);
    for file in ["backward-error.csv", "noise.csv"] {
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
