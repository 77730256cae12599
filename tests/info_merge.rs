//! `linlight info` and `linlight merge` end to end.

mod common;

use common::{linlight, root, scratch, write, FLOOR_SCENE};
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, WritableImage,
};
use linlight_imagefile::{Image, MEAN_CHANNELS, VAR_CHANNELS};

#[test]
fn info_prints_header_statistics_and_counts() {
    let dir = scratch("info");
    let scene = write(&dir, "floor.xml", FLOOR_SCENE);
    let out = dir.join("floor.exr");
    let r = linlight(&[
        "render",
        &scene,
        "-o",
        out.to_str().unwrap(),
        "--passes",
        "4",
        "-q",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let img = Image::read(&out).unwrap();
    let r = linlight(&["info", out.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    // Every header key, the extras included, generically.
    for key in [
        "dof",
        "spp",
        "passes",
        "renderer",
        "scene_sha256",
        "technique",
        "seed",
        "spp_per_pass",
    ] {
        assert!(
            r.stdout.lines().any(|l| l.trim_start().starts_with(key)),
            "{key} missing:\n{}",
            r.stdout
        );
    }
    // Mean ± standard error of the image mean, per channel, as JSON too.
    let r = linlight(&["info", out.to_str().unwrap(), "--json"]);
    assert_eq!(r.code, 0);
    let j: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    let n = (img.width * img.height) as f64;
    for c in 0..3 {
        let mean: f64 = img.mean.iter().map(|p| p[c] as f64).sum::<f64>() / n;
        let se: f64 = img.var.iter().map(|p| p[c] as f64).sum::<f64>().sqrt() / n;
        let ch = &j["channels"][c];
        assert!((ch["mean"].as_f64().unwrap() - mean).abs() <= 1e-9 * mean.abs());
        assert!((ch["standard_error"].as_f64().unwrap() - se).abs() <= 1e-9 * se);
    }
    let zero = img
        .var
        .iter()
        .filter(|v| v.iter().all(|&x| x == 0.0))
        .count();
    assert_eq!(
        j["counts"]["zero_variance"].as_u64().unwrap() as usize,
        zero
    );
    assert_eq!(j["counts"]["nan"], 0);
    assert!(j["problem"].is_null());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn info_counts_invalid_pixels_and_exits_1() {
    let dir = scratch("info-bad");
    let path = dir.join("bad.exr");
    let n = 6;
    let channels = MEAN_CHANNELS
        .iter()
        .chain(&VAR_CHANNELS)
        .map(|c| {
            let mut v = vec![0.5f32; n];
            match *c {
                "R" => v[1] = f32::NAN,
                "G" => v[2] = f32::INFINITY,
                "B" => v[3] = -1.0,
                "var.B" => v[4] = -2.0,
                _ => {}
            }
            AnyChannel::new(*c, FlatSamples::F32(v))
        })
        .collect();
    let layer = Layer::new(
        (3, 2),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(channels),
    );
    exr::prelude::Image::from_layer(layer)
        .write()
        .to_file(&path)
        .unwrap();
    let r = linlight(&["info", path.to_str().unwrap(), "--json"]);
    assert_eq!(r.code, 1, "{}", r.stderr);
    let j: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    let c = &j["counts"];
    assert_eq!(
        (
            &c["nan"],
            &c["infinite"],
            &c["negative_mean"],
            &c["negative_variance"]
        ),
        (&1.into(), &1.into(), &1.into(), &1.into())
    );
    assert!(j["problem"].as_str().unwrap().contains("dof"));
    let r = linlight(&["info", path.to_str().unwrap()]);
    assert!(r.stdout.contains("NOT a valid image"), "{}", r.stdout);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn info_reads_a_mitsuba_reference() {
    let reference = root().join("references/mitsuba/floor-tube.exr");
    let r = linlight(&["info", reference.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("mitsuba 3.9.1"), "{}", r.stdout);
    assert!(r.stdout.contains("overrides"), "{}", r.stdout);
}

/// Two runs with different seeds merge into the image of all their passes (equal spp per
/// pass): dof = P₁ + P₂ − 1, the mean is the pass-weighted mean, and the merged image is as
/// consistent with a third independent run as either input.
#[test]
fn merge_two_runs_into_one() {
    let dir = scratch("merge");
    let scene = write(&dir, "floor.xml", FLOOR_SCENE);
    let render = |seed: &str, passes: &str, name: &str| {
        let out = dir.join(name);
        let r = linlight(&[
            "render",
            &scene,
            "--seed",
            seed,
            "--passes",
            passes,
            "--spp",
            "8",
            "-o",
            out.to_str().unwrap(),
            "-q",
        ]);
        assert_eq!(r.code, 0, "{}", r.stderr);
        out
    };
    let (a, b) = (render("1", "4", "a.exr"), render("2", "12", "b.exr"));
    let m = dir.join("m.exr");
    let r = linlight(&[
        "merge",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "-o",
        m.to_str().unwrap(),
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let (ia, ib, im) = (
        Image::read(&a).unwrap(),
        Image::read(&b).unwrap(),
        Image::read(&m).unwrap(),
    );
    assert_eq!(
        (im.meta.dof, im.meta.passes, im.meta.spp),
        (15.0, 16, ia.meta.spp + ib.meta.spp)
    );
    assert_eq!(im.meta.extra["seed"], "1;2");
    assert_eq!(im.meta.extra["merged_from"], "a.exr;b.exr");
    for p in 0..im.mean.len() {
        let want = 0.25 * ia.mean[p][0] as f64 + 0.75 * ib.mean[p][0] as f64;
        assert!((im.mean[p][0] as f64 - want).abs() <= 1e-5 * want.abs().max(1e-6));
    }
    // The merged variance of the image mean is about 1/16 of a one-pass-per-unit image's, i.e.
    // between a's (4 passes) and b's (12 passes) scaled by their pass counts.
    let total = |i: &Image| i.var.iter().map(|v| v[0] as f64).sum::<f64>();
    let (va, vb, vm) = (total(&ia) * 4.0, total(&ib) * 12.0, total(&im) * 16.0);
    assert!(
        vm > 0.5 * va.min(vb) && vm < 2.0 * va.max(vb),
        "{va} {vb} {vm}"
    );
    // The merge is accepted by compare as an image like any other.
    let c = render("3", "16", "c.exr");
    let r = linlight(&[
        "compare",
        m.to_str().unwrap(),
        c.to_str().unwrap(),
        "--tolerance",
        "0.2",
    ]);
    assert!(r.code == 0, "{}\n{}", r.stdout, r.stderr);
    std::fs::remove_dir_all(&dir).ok();
}
