//! End-to-end: `linlight compare` on EXRs written by `Image::write` (and by the raw exr crate
//! for malformed files); checks exit codes 0 / 1 / 2 and the JSON + heat map outputs.

use std::path::{Path, PathBuf};
use std::process::Command;

use linlight_imagefile::Image;
use linlight_sampling::rng::Pcg32;

const W: usize = 64;
const H: usize = 48;
const PASSES: f64 = 32.0;

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("linlight-compare-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn normal(rng: &mut Pcg32) -> f64 {
    let u1 = 1.0 - rng.next_f64();
    let u2 = rng.next_f64();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A smooth truth times `scale`, plus N(0, σ²/P) noise per pixel, σ = 0.1·truth; the stored
/// variance is the exact σ²/P (declared with dof = P − 1, which is conservative).
fn render(seed: u64, scale: f64) -> Image {
    let mut rng = Pcg32::new(seed, 5);
    let mut img = Image::new(W, H);
    img.meta.dof = PASSES - 1.0;
    img.meta.passes = PASSES as u64;
    img.meta.spp = 1024;
    img.meta.renderer = "compare_cli test".into();
    for y in 0..H {
        for x in 0..W {
            let (u, v) = (x as f64 / W as f64, y as f64 / H as f64);
            let truth = [0.3 + 0.5 * u * v, 0.6 - 0.2 * v, 0.2 + 0.3 * u];
            for c in 0..3 {
                let sigma = 0.1 * truth[c] / PASSES.sqrt();
                img.mean[y * W + x][c] = (scale * truth[c] + sigma * normal(&mut rng)) as f32;
                img.var[y * W + x][c] = (sigma * sigma) as f32;
            }
        }
    }
    img
}

fn write(img: &Image, name: &str) -> PathBuf {
    let p = dir().join(name);
    img.write(&p).unwrap();
    p
}

fn run(a: &Path, b: &Path, extra: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_linlight"))
        .arg("compare")
        .arg(a)
        .arg(b)
        .args(extra)
        .output()
        .unwrap();
    (
        out.status.code().expect("exited normally"),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn same_truth_is_consistent_with_json_and_heatmap() {
    let a = write(&render(1, 1.0), "same_a.exr");
    let b = write(&render(2, 1.0), "same_b.exr");
    let json = dir().join("same.json");
    let heat = dir().join("same.png");
    let (code, out, err) = run(
        &a,
        &b,
        &[
            "--json",
            json.to_str().unwrap(),
            "--heatmap",
            heat.to_str().unwrap(),
        ],
    );
    assert_eq!(code, 0, "stdout:\n{out}\nstderr:\n{err}");
    assert!(out.contains("verdict: CONSISTENT"), "{out}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["verdict"], "Consistent");
    assert_eq!(report["width"], W);
    assert_eq!(report["channels"].as_array().unwrap().len(), 3);
    assert_eq!(&std::fs::read(&heat).unwrap()[1..4], b"PNG");
}

#[test]
fn two_percent_scale_error_is_different() {
    let a = write(&render(3, 1.02), "scaled_a.exr");
    let b = write(&render(4, 1.0), "scaled_b.exr");
    let (code, out, err) = run(&a, &b, &[]);
    assert_eq!(code, 1, "stdout:\n{out}\nstderr:\n{err}");
    assert!(
        out.contains("verdict: DIFFERENT") && out.contains("GlobalMean"),
        "{out}"
    );
}

/// An EXR with the given channels (means 1, variances 1e-8) and a dof attribute, via the exr
/// crate.
fn write_raw(name: &str, channels: &[&str], bad: Option<(&str, f32)>) -> PathBuf {
    use exr::prelude::*;
    let n = W * H;
    let list = channels
        .iter()
        .map(|c| {
            let mut v = vec![if c.starts_with("var.") { 1e-8f32 } else { 1.0 }; n];
            if let Some((bc, x)) = bad {
                if bc == *c {
                    v[n / 2] = x;
                }
            }
            AnyChannel::new(*c, FlatSamples::F32(v))
        })
        .collect();
    let mut attrs = LayerAttributes::default();
    attrs
        .other
        .insert(Text::from("dof"), AttributeValue::F32(31.0));
    let layer = Layer::new(
        (W, H),
        attrs,
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(list),
    );
    let p = dir().join(name);
    exr::prelude::Image::from_layer(layer)
        .write()
        .to_file(&p)
        .unwrap();
    p
}

#[test]
fn unusable_inputs_exit_2_with_a_reason() {
    let good = write(&render(5, 1.0), "good.exr");
    let expect_2 = |other: &Path, needle: &str| {
        let (code, out, err) = run(&good, other, &[]);
        assert_eq!(code, 2, "stdout:\n{out}\nstderr:\n{err}");
        assert_eq!(err.lines().count(), 1, "one-line reason: {err}");
        assert!(err.contains(needle), "{err:?} lacks {needle:?}");
    };
    let no_var = write_raw("no_var.exr", &["R", "G", "B", "var.R", "var.G"], None);
    expect_2(&no_var, "missing channel var.B");
    let all = ["R", "G", "B", "var.R", "var.G", "var.B"];
    let nan = write_raw("nan.exr", &all, Some(("G", f32::NAN)));
    expect_2(&nan, "non-finite");
    let mut small = render(6, 1.0);
    small.width = W / 2;
    small.height = H * 2;
    expect_2(&write(&small, "reshaped.exr"), "size mismatch");
    let garbage = dir().join("garbage.exr");
    std::fs::write(&garbage, b"definitely not an OpenEXR file").unwrap();
    expect_2(&garbage, "garbage.exr");
    expect_2(&dir().join("missing.exr"), "missing.exr");
    // A valid raw file with all channels compares fine (exit 0 or 1, not 2).
    let raw = write_raw("raw_ok.exr", &all, None);
    let (code, _, err) = run(&raw, &raw, &[]);
    assert_eq!(code, 0, "{err}");
}
