//! The scenes to certify and their committed Mitsuba references.
//!
//! A scene is `references/scenes/<name>.xml`; its reference is `references/mitsuba/<name>.exr`
//! (+ `.json` sidecar, not needed here: the EXR header carries the same metadata). The reference
//! records the `-D` overrides it was rendered with (`overrides`, `k=v,k=v`) and the sha256 of the
//! scene file (`scene_sha256`); the scene is loaded with the same overrides, and a changed scene
//! file makes the reference stale, which is unusable input (exit 2), never a silent comparison
//! against an image of another scene.

use linlight_imagefile::Image;
use linlight_render::scene::Scene;
use linlight_render::xml::load_scene;
use std::path::{Path, PathBuf};

use super::Unusable;

/// The directory (relative to the project root) of the finite-tube family: scenes whose tubes
/// are rendered as the cylinders they are (docs/cylinders.md), with references in
/// `references/mitsuba/` like the others.
pub const FINITE_TUBES_DIR: &str = "references/finite-tubes";

/// Scene files of `dir` (`*.xml`, not recursive), sorted by name.
pub fn scene_files(dir: &Path) -> Result<Vec<PathBuf>, Unusable> {
    let entries = std::fs::read_dir(dir).map_err(|e| {
        Unusable(format!(
            "cannot read the scene directory {}: {e}",
            dir.display()
        ))
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "xml"))
        .collect();
    files.sort();
    Ok(files)
}

/// Name of a scene: its file stem.
pub fn scene_name(path: &Path) -> String {
    path.file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
}

/// Shell-style wildcard match of the whole `text`: `*` any run (also empty), `?` one character,
/// everything else literal.
pub fn wildcard_match(pattern: &str, text: &str) -> bool {
    let (p, t): (Vec<char>, Vec<char>) = (pattern.chars().collect(), text.chars().collect());
    // Greedy with backtracking to the last `*`: linear in practice, O(|p|·|t|) worst case.
    let (mut i, mut j) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while j < t.len() {
        if i < p.len() && (p[i] == '?' || p[i] == t[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            i = si + 1;
            j = sj + 1;
            star = Some((si, sj + 1));
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

/// Whether a scene file is selected by `--scenes GLOB[,GLOB...]`: a pattern may name the scene
/// (`floor-*`), its file (`floor-*.xml`) or its path (`references/scenes/floor-*.xml`); any of
/// the comma-separated patterns selects.
pub fn selected(patterns: &str, path: &Path) -> bool {
    let name = scene_name(path);
    let file = path
        .file_name()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    patterns.split(',').map(str::trim).any(|pattern| {
        wildcard_match(pattern, &name)
            || wildcard_match(pattern, &file)
            || wildcard_match(pattern, &path.to_string_lossy())
    })
}

/// `-D` overrides recorded in a reference (`k=v,k=v`; empty: none).
pub fn parse_overrides(text: &str) -> Result<Vec<(String, String)>, String> {
    text.split(',')
        .map(str::trim)
        .filter(|kv| !kv.is_empty())
        .map(|kv| match kv.split_once('=') {
            Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
            _ => Err(format!("malformed override '{kv}' (expected NAME=VALUE)")),
        })
        .collect()
}

/// A scene with its committed reference, checked to belong together.
pub struct ReferencedScene {
    pub name: String,
    pub scene_file: PathBuf,
    pub reference_file: PathBuf,
    pub overrides: Vec<(String, String)>,
    /// Loaded with the reference's overrides.
    pub scene: Scene,
    pub reference: Image,
    /// Of the finite-tube family: rendered with exact tubes ([`super::matrix::FINITE_SUBJECTS`]).
    pub exact_tubes: bool,
}

/// The reference file of a scene.
pub fn reference_path(references_dir: &Path, name: &str) -> PathBuf {
    references_dir.join(format!("{name}.exr"))
}

/// The message of a stale reference (also documented in the README).
pub fn stale_message(reference_file: &Path) -> String {
    format!(
        "reference {} is stale (scene changed), run scripts/make-references",
        reference_file.display()
    )
}

/// Load a scene with the overrides of its reference, and check that the reference was rendered
/// from this very scene file. `check_sha`: false for a live oracle (the reference then only
/// supplies overrides and budget, the oracle image is rendered from the current file).
pub fn load_referenced(
    scene_file: &Path,
    references_dir: &Path,
    check_sha: bool,
) -> Result<ReferencedScene, Unusable> {
    let name = scene_name(scene_file);
    let reference_file = reference_path(references_dir, &name);
    if !reference_file.is_file() {
        return Err(Unusable(format!(
            "no reference for scene {name}: {} is missing (run scripts/make-references {name})",
            reference_file.display()
        )));
    }
    let reference = Image::read(&reference_file).map_err(|e| {
        Unusable(format!(
            "cannot read reference {}: {e}",
            reference_file.display()
        ))
    })?;
    let overrides = parse_overrides(
        reference
            .meta
            .extra
            .get("overrides")
            .map_or("", String::as_str),
    )
    .map_err(|e| Unusable(format!("reference {}: {e}", reference_file.display())))?;
    let scene = load_scene(scene_file, &overrides)
        .map_err(|e| Unusable(format!("cannot load scene {}: {e}", scene_file.display())))?;
    if check_sha && reference.meta.scene_sha256 != scene.sha256 {
        return Err(Unusable(stale_message(&reference_file)));
    }
    let film = &scene.sensor.film;
    let (w, h) = film
        .crop
        .map_or((film.width, film.height), |c| (c.width, c.height));
    if (w as usize, h as usize) != (reference.width, reference.height) {
        return Err(Unusable(format!(
            "reference {} is {}×{} but scene {} with overrides [{}] renders {w}×{h}",
            reference_file.display(),
            reference.width,
            reference.height,
            scene_file.display(),
            reference
                .meta
                .extra
                .get("overrides")
                .map_or("", String::as_str)
        )));
    }
    Ok(ReferencedScene {
        name,
        scene_file: scene_file.to_path_buf(),
        reference_file,
        overrides,
        scene,
        reference,
        exact_tubes: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards() {
        assert!(wildcard_match("*", ""));
        assert!(wildcard_match("*", "floor-tube"));
        assert!(wildcard_match("floor-*", "floor-tube"));
        assert!(wildcard_match("floor-*", "floor-"));
        assert!(!wildcard_match("floor-*", "cornell-tube"));
        assert!(wildcard_match("*-tube", "cornell-tube"));
        assert!(wildcard_match("*o*u*", "two-tubes"));
        assert!(!wildcard_match("*o*o*", "two-tubes"));
        assert!(wildcard_match("tw?-tubes", "two-tubes"));
        assert!(!wildcard_match("tw?-tubes", "tw-tubes"));
        assert!(!wildcard_match("floor", "floor-tube"));
        assert!(wildcard_match("a*b*c", "aXbYbZc"));
        assert!(!wildcard_match("a*b*c", "aXbYbZ"));
    }

    #[test]
    fn selection_by_name_file_or_path() {
        let p = Path::new("references/scenes/floor-tube.xml");
        assert!(selected("floor-tube", p));
        assert!(selected("floor-*.xml", p));
        assert!(selected("references/scenes/floor*", p));
        assert!(!selected("cornell*", p));
        assert!(selected("cornell*,floor-tube", p));
        assert!(selected("glossy-*, floor-*", p));
        assert!(!selected("cornell*,glossy-*", p));
    }

    #[test]
    fn overrides_round_trip() {
        assert_eq!(parse_overrides("").unwrap(), vec![]);
        assert_eq!(
            parse_overrides("res=64,spp=8").unwrap(),
            vec![("res".into(), "64".into()), ("spp".into(), "8".into())]
        );
        assert!(parse_overrides("res").is_err());
        assert!(parse_overrides("=3").is_err());
    }
}
