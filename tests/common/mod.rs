//! Fixtures shared by the end-to-end tests (each file in tests/ is its own crate and includes
//! this module with `mod common;`): running the binary, scratch directories, and the small floor
//! scene the command-line tests render.

#![allow(dead_code)] // every test crate uses a different subset

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root (references/, scripts/, tests/scenes/).
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The `linlight` binary built for this test run.
pub fn command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_linlight"))
}

/// Exit code and output of one run of the binary.
pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

pub fn linlight<S: AsRef<OsStr>>(args: &[S]) -> Run {
    let out = command()
        .args(args)
        .output()
        .expect("the linlight binary runs");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// One run of the binary in the repository root (where `certify` finds references/ by
/// default), with its raw output.
pub fn linlight_in_root(args: &[&str]) -> std::process::Output {
    command()
        .args(args)
        .current_dir(root())
        .output()
        .expect("the linlight binary runs")
}

/// A fresh scratch directory, unique per test crate, process and `name`.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "linlight-{}-{}-{name}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `text` to `dir/name` and returns the path as a string (for argument lists).
pub fn write(dir: &Path, name: &str, text: impl AsRef<[u8]>) -> String {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// Floor, a sphere and a linear light (radiance K/R with K = 2, 1, 0.5), 24×16 film, hidden
/// emitters; `$spp` and `$res` (the film width) are parameters.
pub const FLOOR_SCENE: &str = r#"<scene version="3.0.0">
  <default name="spp" value="4"/>
  <default name="res" value="24"/>
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
      <integer name="width" value="$res"/>
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
