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
            for (c, t) in truth.iter().enumerate() {
                let sigma = 0.1 * t / PASSES.sqrt();
                img.mean[y * W + x][c] = (scale * t + sigma * normal(&mut rng)) as f32;
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

/// Like `render`, with the noise of each pixel multiplied by `noise` (variance by noise²).
fn noisy(seed: u64, scale: f64, noise: f32) -> Image {
    let mut img = render(seed, scale);
    let base = render(seed + 1000, scale);
    for (i, (m, v)) in img.mean.iter_mut().zip(&mut img.var).enumerate() {
        for c in 0..3 {
            m[c] = base.mean[i][c] + noise * (m[c] - base.mean[i][c]) / std::f32::consts::SQRT_2;
            v[c] *= noise * noise;
        }
    }
    img
}

#[test]
fn too_noisy_to_tell_is_inconclusive_with_exit_3_and_the_samples_needed() {
    let a = write(&noisy(7, 1.0, 40.0), "noisy_a.exr");
    let b = write(&render(8, 1.0), "noisy_b.exr");
    let json = dir().join("noisy.json");
    let (code, out, err) = run(&a, &b, &["--json", json.to_str().unwrap()]);
    assert_eq!(code, 3, "stdout:\n{out}\nstderr:\n{err}");
    assert!(out.contains("verdict: INCONCLUSIVE"), "{out}");
    assert!(out.contains("A limits the precision"), "{out}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["verdict"], "Inconclusive");
    assert_eq!(report["precision"]["limiting"], "A");
    assert!(report["precision"]["factor_a"].as_f64().unwrap() > 1.0);
}

#[test]
fn difference_and_z_maps_are_written_as_exr() {
    let a_img = render(9, 1.0);
    let b_img = render(10, 1.0);
    let (a, b) = (write(&a_img, "maps_a.exr"), write(&b_img, "maps_b.exr"));
    let (diff, z) = (dir().join("diff.exr"), dir().join("z.exr"));
    let (code, out, err) = run(
        &a,
        &b,
        &[
            "--diff-exr",
            diff.to_str().unwrap(),
            "--z-exr",
            z.to_str().unwrap(),
        ],
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("error metrics: MSE"), "{out}");
    // Plain RGB EXRs (no variance channels): read them with the exr crate.
    use exr::prelude::*;
    let read = |p: &Path| {
        read_all_flat_layers_from_file(p)
            .unwrap()
            .layer_data
            .remove(0)
            .channel_data
            .list
    };
    let chans = read(&diff);
    assert_eq!(chans.len(), 3);
    let r = chans.iter().find(|c| c.name.eq("R")).unwrap();
    let FlatSamples::F32(values) = &r.sample_data else {
        panic!("float32 expected")
    };
    let i = 5 * W + 7;
    assert_eq!(values[i], a_img.mean[i][0] - b_img.mean[i][0]);
    assert_eq!(read(&z).len(), 3);
}

#[test]
fn bad_outputs_and_inputs_exit_2_before_any_work() {
    let good = write(&render(11, 1.0), "out_good.exr");
    let other = write(&render(12, 1.0), "out_other.exr");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "--json".into(),
                dir().join("no/such/dir/r.json").display().to_string(),
            ],
            "cannot write",
        ),
        (
            vec!["--heatmap".into(), dir().display().to_string()],
            "is a directory",
        ),
        (
            vec!["--diff-exr".into(), good.display().to_string()],
            "refusing to overwrite it",
        ),
        (
            vec![
                "--json".into(),
                dir().join("same").display().to_string(),
                "--heatmap".into(),
                dir().join("same").display().to_string(),
            ],
            "two different outputs",
        ),
    ];
    for (extra, needle) in cases {
        let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
        let (code, out, err) = run(&good, &other, &extra);
        assert_eq!(code, 2, "{extra:?}: {out}{err}");
        assert!(
            out.is_empty(),
            "nothing is compared before the outputs are checked: {out}"
        );
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{err:?} lacks {needle:?}");
        assert_eq!(
            err.matches("cannot write").count().min(1),
            err.matches("cannot write").count(),
            "no doubled message: {err}"
        );
    }
    // An image without a variance estimate (one sample, one pass: dof 0).
    let mut one = render(13, 1.0);
    one.meta.dof = 0.0;
    one.var.iter_mut().for_each(|v| *v = [0.0; 3]);
    let (code, _, err) = run(&write(&one, "dof0.exr"), &other, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("has no variance estimate"), "{err}");
    // Renders of different scene files.
    let mut x = render(14, 1.0);
    let mut y = render(15, 1.0);
    x.meta.scene_sha256 = "1".repeat(64);
    y.meta.scene_sha256 = "2".repeat(64);
    let (x, y) = (write(&x, "scene_x.exr"), write(&y, "scene_y.exr"));
    let (code, _, err) = run(&x, &y, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("different scene files") && err.contains("--allow-different-scenes"),
        "{err}"
    );
    let (code, _, err) = run(&x, &y, &["--allow-different-scenes"]);
    assert_eq!(code, 0, "{err}");
}
