//! Test fixtures: the committed reference scenes (`references/scenes/*.xml`), shared by the
//! unit tests that run over every scene instead of each listing the directory itself.

use std::path::{Path, PathBuf};

/// The workspace's `references/scenes` directory.
pub(crate) fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../references/scenes")
}

/// Every committed scene's XML file, sorted by name; at least five (a test over "every scene"
/// that found none would pass without testing anything).
pub(crate) fn committed() -> Vec<PathBuf> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir())
        .expect("references/scenes")
        .filter_map(|e| {
            let p = e.ok()?.path();
            (p.extension()? == "xml").then_some(p)
        })
        .collect();
    paths.sort();
    assert!(paths.len() >= 5, "{paths:?}");
    paths
}
