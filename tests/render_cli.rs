//! `linlight render` end to end: a small scene renders to the shared EXR format; unusable input
//! exits with 2 and a one-line reason.

use linlight_imagefile::Image;
use std::path::{Path, PathBuf};
use std::process::Command;

fn linlight(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_linlight"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("linlight-render-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Floor, a sphere and a linear light (radiance K/R with K = 2, 1, 0.5), 24×16 film.
const SCENE: &str = r#"<scene version="3.0.0">
  <default name="spp" value="4"/>
  <integrator type="direct">
    <integer name="emitter_samples" value="1"/>
    <integer name="bsdf_samples" value="0"/>
    <boolean name="hide_emitters" value="true"/>
  </integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0.3, -0.2, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
    <film type="hdrfilm">
      <integer name="width" value="24"/>
      <integer name="height" value="16"/>
      <string name="component_format" value="float32"/>
      <rfilter type="box"/>
    </film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="3"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.5, 0.2"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" value="0.4, 0.2, 0.3"/>
    <float name="radius" value="0.25"/>
    <bsdf type="diffuse"/>
  </shape>
  <shape type="cylinder">
    <point name="p0" value="-0.5, -0.3, 0.3"/>
    <point name="p1" value="0.7, 0.4, 1.2"/>
    <float name="radius" value="0.0001"/>
    <emitter type="area"><rgb name="radiance" value="20000, 10000, 5000"/></emitter>
  </shape>
</scene>
"#;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn renders_a_scene_to_the_shared_format() {
    let dir = scratch("ok");
    let scene = write(&dir, "floor.xml", SCENE);
    let out = dir.join("floor.exr");
    let png = dir.join("floor.png");
    let (o, p) = (out.to_str().unwrap(), png.to_str().unwrap());
    let args = [
        "render",
        &scene,
        "--out",
        o,
        "--preview",
        p,
        "--passes",
        "3",
        "--seed",
        "5",
    ];
    let (code, err) =
        linlight(&[&args[..], &["-D", "spp=2", "--quiet", "--threads", "2"]].concat());
    assert_eq!(code, 0, "{err}");
    assert!(err.is_empty(), "--quiet must be quiet: {err}");
    assert!(png.is_file());
    let img = Image::read(&out).unwrap();
    assert_eq!((img.width, img.height), (24, 16));
    assert_eq!((img.meta.spp, img.meta.passes, img.meta.dof), (6, 3, 2.0));
    assert_eq!(img.meta.extra["technique"], "projected-solid-angle");
    assert_eq!(img.meta.extra["seed"], "5");
    assert_eq!(img.meta.scene_sha256.len(), 64);
    // Traceable to its inputs: scene file name and the -D overrides.
    assert_eq!(img.meta.extra["scene"], "floor.xml");
    assert_eq!(img.meta.extra["overrides"], "spp=2");
    // The heavy-tail share of the 3 passes, in [0, 2/3].
    let tail = img.tail.as_ref().expect("tail channels");
    assert!(tail
        .iter()
        .flatten()
        .all(|&t| (0.0..=2.0 / 3.0 + 1e-6).contains(&t)));
    assert!(img.mean.iter().any(|m| m[0] > 0.0));
    assert!(img
        .mean
        .iter()
        .chain(&img.var)
        .flatten()
        .all(|c| c.is_finite()));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn one_sample_in_one_pass_warns_even_when_quiet_and_compare_refuses_it() {
    let dir = scratch("spp1");
    let scene = write(&dir, "floor.xml", SCENE);
    let out = dir.join("one.exr");
    let (code, err) = linlight(&[
        "render",
        &scene,
        "--spp",
        "1",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("no variance estimate (dof 0)"), "{err}");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_linlight"))
        .args(["compare", out.to_str().unwrap(), out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("image A has no variance estimate"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_exits_with_2() {
    let dir = scratch("bad");
    let good = write(&dir, "good.xml", SCENE);
    let truncated = write(&dir, "truncated.xml", &SCENE[..400]);
    let zero = write(
        &dir,
        "zero.xml",
        &SCENE.replace(r#"value="24""#, r#"value="0""#),
    );
    let torus = write(
        &dir,
        "torus.xml",
        &SCENE.replace(r#"type="sphere""#, r#"type="torus""#),
    );
    for args in [
        vec!["render", "/nonexistent/scene.xml"],
        vec!["render", &good, "--technique", "no-such-technique"],
        vec!["render", &good, "-D", "novalue"],
        vec!["render", &good, "--spp", "0"],
        vec!["render", &good, "--passes", "0"],
        vec!["render", &truncated],
        vec!["render", &zero],
        vec!["render", &torus],
    ] {
        let (code, err) = linlight(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("linlight render: "), "{err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
