//! Output paths are checked before any work is done ("unusable input is detected before
//! anything is rendered" holds for outputs too): the directory must exist, the path must not be
//! a directory or one of the inputs, and the file must be creatable.

use std::path::Path;

/// Checks that `path` can be written without clobbering one of `inputs`. Creates no file that
/// is left behind (a probe file that did not exist is removed again).
pub fn check_writable(path: &Path, inputs: &[&Path]) -> Result<(), String> {
    if path.is_dir() {
        return Err(format!("{} is a directory", path.display()));
    }
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    };
    if let Some(input) = inputs.iter().find(|i| same(path, i)) {
        return Err(format!(
            "output {} would overwrite the input {}",
            path.display(),
            input.display()
        ));
    }
    let existed = path.exists();
    std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    if !existed {
        let _ = std::fs::remove_file(path);
    }
    Ok(())
}

/// The output paths given must also differ from each other.
pub fn check_distinct(paths: &[&Path]) -> Result<(), String> {
    for (i, a) in paths.iter().enumerate() {
        if let Some(b) = paths[i + 1..].iter().find(|b| a == *b) {
            return Err(format!("{} is given as two different outputs", b.display()));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_directories_inputs_and_missing_directories() {
        let dir = std::env::temp_dir().join(format!("linlight-outputs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let input = dir.join("in.exr");
        std::fs::write(&input, b"x").unwrap();
        assert!(check_writable(&dir, &[])
            .unwrap_err()
            .contains("is a directory"));
        let err = check_writable(&input, &[&input]).unwrap_err();
        assert!(err.contains("would overwrite the input"), "{err}");
        let err = check_writable(&dir.join("no/such/dir/out.json"), &[]).unwrap_err();
        assert!(err.starts_with("cannot write"), "{err}");
        let fresh = dir.join("fresh.json");
        check_writable(&fresh, &[&input]).unwrap();
        assert!(!fresh.exists(), "the probe leaves nothing behind");
        assert_eq!(
            std::fs::read(&input).unwrap(),
            b"x",
            "an existing file is kept"
        );
        assert!(check_distinct(&[Path::new("a"), Path::new("b"), Path::new("a")]).is_err());
    }
}
