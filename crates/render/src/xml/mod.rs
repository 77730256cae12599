//! Mitsuba 3 XML scene loader for the subset this project renders, producing [`Scene`].
//!
//! Supported: `<scene version="3.0.0">`, `default`/`$name`, `ref`/`id`, `include`, transforms
//! (`translate`, `rotate`, `scale`, `matrix`, `lookat`), `sensor perspective` with `film hdrfilm`
//! (`rfilter box`) and `sampler independent`, `integrator direct`, shapes `rectangle`, `cube`,
//! `sphere`, `disk`, `cylinder`, `obj`, `ply`, BSDFs `diffuse`, `roughconductor` (GGX),
//! `principled`, `blendbsdf` and `twosided` (see `bsdf.rs` for what of each), and `area` emitters
//! on cylinders, which become linear lights with K = radiance × radius.
//! Everything else is an error naming file:line:column and the element — never a silent
//! difference from Mitsuba.
//!
//! `integrator direct` accepts `emitter_samples`, `bsdf_samples` and `shading_samples` so that
//! the same file renders in Mitsuba. The Rust renderer samples the linear lights only (these
//! options change Mitsuba's variance, not its expectation); `emitter_samples` (default
//! `shading_samples`, default 1) reaches the IR as the default of `linlight render
//! --light-samples`. What Mitsuba refuses is refused here too (no sample at all,
//! `shading_samples` with either).
//! `hide_emitters` (default false, as in Mitsuba) reaches the IR: the renderer then draws the
//! lines the camera sees (`crate::visible_line`).
//!
//! `-D` overrides follow Mitsuba 3.9's parser: one that is never substituted is an error
//! ("found unused parameters"), see `tree`. Cylinders are placed as Mitsuba places them
//! (`to_world · translate(p0) · frame · scale(r, r, L)`), so the idiom `scale(r, r, L) · rotate ·
//! translate` works; shears and unequal scales across the axis are refused (Mitsuba only warns,
//! and the radius would not be defined).
//!
//! Relative file names (`include`, `obj`/`ply` `filename`) resolve against the directory of the
//! top scene file, as Mitsuba's file resolver does (it would try the working directory first;
//! we do not, so that loading never depends on where the program runs).

mod bsdf;
mod build;
mod obj;
mod ply;
mod shapes;
mod transform;
mod tree;
mod values;

#[cfg(test)]
mod tests;

use crate::scene::{Scene, SourceLocation};
use std::path::Path;
pub use transform::look_at;

/// A loading failure; displays as `file:line:col: message` when the place is known.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneError {
    pub location: Option<SourceLocation>,
    pub message: String,
}

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.location {
            Some(l) if l.line > 0 => write!(f, "{l}: {}", self.message),
            Some(l) => write!(f, "{}: {}", l.file.display(), self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

impl std::error::Error for SceneError {}

pub(crate) fn err<T>(loc: &SourceLocation, message: impl Into<String>) -> Result<T, SceneError> {
    Err(SceneError {
        location: Some(loc.clone()),
        message: message.into(),
    })
}

/// Loads a Mitsuba 3 XML scene. `overrides` play the role of the keyword arguments of
/// Mitsuba's `load_file(path, spp=...)`: they replace the `<default>` of the same name.
pub fn load_scene(path: &Path, overrides: &[(String, String)]) -> Result<Scene, SceneError> {
    // A regular file of bounded size (a FIFO would block, /dev/zero never ends).
    let bytes =
        linlight_imagefile::input::read_capped(path, linlight_imagefile::input::MAX_TEXT_BYTES)
            .map_err(|e| SceneError {
                location: None,
                message: format!("cannot read scene file: {e}"),
            })?;
    let sha256 = {
        use sha2::{Digest, Sha256};
        Sha256::digest(&bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    };
    let text = String::from_utf8(bytes).map_err(|_| SceneError {
        location: Some(tree::file_location(path)),
        message: "scene file is not valid UTF-8".into(),
    })?;
    let top_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut tb = tree::TreeBuilder::new(top_dir, overrides);
    let root = tb.parse_top(path, &text)?;
    let unused = tb.unused_overrides();
    if !unused.is_empty() {
        let list: Vec<String> = unused.iter().map(|kv| format!("${kv}")).collect();
        return Err(SceneError {
            location: Some(tree::file_location(path)),
            message: format!(
                "found unused parameters: {} (Mitsuba refuses them too: a -D must name a \
                 parameter the scene substitutes as $name, once)",
                list.join(", ")
            ),
        });
    }
    let mut scene = build::Builder::new(&tb).scene(&root)?;
    scene.sha256 = sha256;
    Ok(scene)
}
