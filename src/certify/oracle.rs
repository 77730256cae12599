//! `--oracle live`: render the Mitsuba side now with the harness (`scripts/harness render`), at
//! the budget and overrides recorded in the committed reference.

use linlight_imagefile::Image;
use std::path::{Path, PathBuf};
use std::process::Command;

use super::scenes::ReferencedScene;
use super::Unusable;

/// The oracle venv the harness uses (`$LINLIGHT_VENV`, default `<root>/.venv`).
pub fn venv(root: &Path) -> PathBuf {
    std::env::var_os("LINLIGHT_VENV").map_or_else(|| root.join(".venv"), PathBuf::from)
}

/// Checks that `scripts/setup-oracle` has been run and the harness is there (before any
/// rendering starts). The venv is checked first: it is what a user has to set up.
pub fn check_ready(root: &Path) -> Result<(), Unusable> {
    let venv = venv(root);
    let harness = root.join("scripts/harness");
    if !venv.join("bin/python").exists() || !venv.join("oracle.env").is_file() {
        return Err(Unusable(format!(
            "--oracle live needs the Mitsuba oracle venv at {} (missing): run scripts/setup-oracle \
             first, or use the committed references (--oracle committed)",
            venv.display()
        )));
    }
    if !harness.is_file() {
        return Err(Unusable(format!(
            "--oracle live needs the harness at {}",
            harness.display()
        )));
    }
    Ok(())
}

fn meta_u64(s: &ReferencedScene, key: &str) -> Option<u64> {
    s.reference.meta.extra.get(key).and_then(|v| v.parse().ok())
}

/// Renders the scene with Mitsuba into `out_dir/<scene>.exr` (passes and spp per pass of the
/// committed reference, its `-D` overrides) and reads the result.
pub fn render_live(root: &Path, s: &ReferencedScene, out_dir: &Path) -> Result<Image, Unusable> {
    let passes = s.reference.meta.passes.max(1);
    let spp = meta_u64(s, "spp_per_pass")
        .unwrap_or_else(|| s.reference.meta.spp / passes)
        .max(1);
    std::fs::create_dir_all(out_dir)
        .map_err(|e| Unusable(format!("cannot create {}: {e}", out_dir.display())))?;
    let out = out_dir.join(format!("{}.exr", s.name));
    let mut cmd = Command::new(root.join("scripts/harness"));
    cmd.arg("render")
        .arg(&s.scene_file)
        .args(["--passes", &passes.to_string(), "--spp", &spp.to_string()])
        .arg("--out")
        .arg(&out)
        .arg("--quiet");
    for (k, v) in &s.overrides {
        cmd.arg("-D").arg(format!("{k}={v}"));
    }
    let output = cmd
        .output()
        .map_err(|e| Unusable(format!("cannot run scripts/harness: {e}")))?;
    if !output.status.success() {
        return Err(Unusable(format!(
            "live Mitsuba render of {} failed ({}): {}",
            s.name,
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        )));
    }
    Image::read(&out).map_err(|e| {
        Unusable(format!(
            "cannot read the live render {}: {e}",
            out.display()
        ))
    })
}
