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
pub mod radius;
mod shapes;
mod transform;
mod tree;
mod values;

#[cfg(test)]
mod tests;

use crate::scene::{Scene, SourceLocation};
pub use build::MeshBudget;
use std::path::Path;
pub use transform::look_at;

/// A loading failure; displays as `file:line:col: message` when the place is known. A scene
/// with several problems gives one error holding the others in `more`, all in file order
/// ([`SceneError::collect`]); it displays one line per problem.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneError {
    pub location: Option<SourceLocation>,
    pub message: String,
    /// Further problems of the same scene, after this one in file order.
    pub more: Vec<SceneError>,
}

impl SceneError {
    pub fn new(location: Option<SourceLocation>, message: impl Into<String>) -> SceneError {
        SceneError {
            location,
            message: message.into(),
            more: Vec::new(),
        }
    }

    /// Every problem, this one first, each without its `more`.
    pub fn all(&self) -> Vec<SceneError> {
        let mut out = vec![SceneError::new(self.location.clone(), self.message.clone())];
        for m in &self.more {
            out.extend(m.all());
        }
        out
    }

    /// One error holding all of `errors` (flattened, without duplicates) in file order: files
    /// in the order they first occur, then line and column. None when `errors` is empty.
    pub fn collect(errors: Vec<SceneError>) -> Option<SceneError> {
        let mut flat: Vec<SceneError> = Vec::new();
        for e in errors.iter().flat_map(SceneError::all) {
            if !flat.contains(&e) {
                flat.push(e);
            }
        }
        let mut files: Vec<std::path::PathBuf> = Vec::new();
        for e in &flat {
            if let Some(l) = &e.location {
                if !files.contains(&l.file) {
                    files.push(l.file.clone());
                }
            }
        }
        let key = |e: &SceneError| match &e.location {
            None => (0, 0, 0),
            Some(l) => (
                1 + files.iter().position(|f| *f == l.file).unwrap_or(0),
                l.line,
                l.column,
            ),
        };
        flat.sort_by_key(key);
        let mut it = flat.into_iter();
        let mut first = it.next()?;
        first.more = it.collect();
        Some(first)
    }

    fn line(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.location {
            Some(l) if l.line > 0 => write!(f, "{l}: {}", self.message),
            Some(l) => write!(f, "{}: {}", l.file.display(), self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.line(f)?;
        let all = self.all();
        for e in &all[1..] {
            writeln!(f)?;
            e.line(f)?;
        }
        if all.len() > 1 {
            write!(
                f,
                "\n{} problems in this scene (listed in file order)",
                all.len()
            )?;
        }
        Ok(())
    }
}

impl std::error::Error for SceneError {}

pub(crate) fn err<T>(loc: &SourceLocation, message: impl Into<String>) -> Result<T, SceneError> {
    Err(SceneError::new(Some(loc.clone()), message))
}

/// What [`check_scene`] found: the scene when it loads, every refusal (in file order) and every
/// warning.
pub struct SceneCheck {
    pub scene: Option<Scene>,
    pub errors: Vec<SceneError>,
    pub warnings: Vec<String>,
}

/// Loads a Mitsuba 3 XML scene. `overrides` play the role of the keyword arguments of
/// Mitsuba's `load_file(path, spp=...)`: they replace the `<default>` of the same name. A scene
/// with several problems fails with all of them ([`SceneError::more`]).
pub fn load_scene(path: &Path, overrides: &[(String, String)]) -> Result<Scene, SceneError> {
    load(path, overrides, None)
}

/// [`load_scene`] refusing, before reading them, mesh files whose PLY headers declare more
/// triangles in all than `budget` allows.
pub fn load_scene_within(
    path: &Path,
    overrides: &[(String, String)],
    budget: MeshBudget,
) -> Result<Scene, SceneError> {
    load(path, overrides, Some(budget))
}

fn load(
    path: &Path,
    overrides: &[(String, String)],
    budget: Option<MeshBudget>,
) -> Result<Scene, SceneError> {
    let c = check(path, overrides, budget);
    match (c.scene, SceneError::collect(c.errors)) {
        (Some(s), None) => Ok(s),
        (_, Some(e)) => Err(e),
        (None, None) => Err(SceneError::new(None, "the scene did not load")),
    }
}

/// Loads a scene as [`load_scene`] does and reports everything: the warnings are kept when the
/// scene is refused (`linlight check`).
pub fn check_scene(path: &Path, overrides: &[(String, String)]) -> SceneCheck {
    check(path, overrides, None)
}

fn check(path: &Path, overrides: &[(String, String)], budget: Option<MeshBudget>) -> SceneCheck {
    let fail = |e: SceneError, warnings: Vec<String>| SceneCheck {
        scene: None,
        errors: e.all(),
        warnings,
    };
    // A regular file of bounded size (a FIFO would block, /dev/zero never ends).
    let bytes = match linlight_imagefile::input::read_capped(
        path,
        linlight_imagefile::input::MAX_TEXT_BYTES,
    ) {
        Ok(b) => b,
        Err(e) => {
            return fail(
                SceneError::new(None, format!("cannot read scene file: {e}")),
                Vec::new(),
            )
        }
    };
    let sha256 = {
        use sha2::{Digest, Sha256};
        Sha256::digest(&bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    };
    let Ok(text) = String::from_utf8(bytes) else {
        return fail(
            SceneError::new(
                Some(tree::file_location(path)),
                "scene file is not valid UTF-8",
            ),
            Vec::new(),
        );
    };
    let top_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut tb = tree::TreeBuilder::new(top_dir, overrides);
    let root = match tb.parse_top(path, &text) {
        Ok(r) => r,
        Err(e) => return fail(e, Vec::new()),
    };
    let unused = tb.unused_overrides();
    if !unused.is_empty() {
        let list: Vec<String> = unused.iter().map(|kv| format!("${kv}")).collect();
        return fail(
            SceneError::new(
                Some(tree::file_location(path)),
                format!(
                    "found unused parameters: {} (Mitsuba refuses them too: a -D must name a \
                     parameter the scene substitutes as $name, once)",
                    list.join(", ")
                ),
            ),
            Vec::new(),
        );
    }
    let mut b = build::Builder::new(&tb);
    b.budget = budget;
    match b.scene(&root) {
        Ok(mut scene) => {
            scene.sha256 = sha256;
            SceneCheck {
                warnings: scene.warnings.clone(),
                scene: Some(scene),
                errors: Vec::new(),
            }
        }
        Err(e) => fail(e, std::mem::take(&mut b.warnings)),
    }
}
