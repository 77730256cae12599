//! Atomic output files: every output of the project is written to a temporary file in the
//! target's directory, flushed, fsynced and renamed over the target. A reader of the target
//! sees the old complete file or the new complete file, never a partial one: a killed writer
//! (any signal), a full disk or two writers racing for one path leave at most a stale
//! temporary file (`.NAME.PID.N.tmp`) next to the target, never a damaged target.
//!
//! Outputs must be regular files (or not exist yet): a FIFO, a device (`/dev/full`,
//! `/dev/null`) or a directory is refused before anything is written.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes the temporary files of one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Refuses `path` as an output if it exists and is not a regular file (after following
/// symbolic links), or if it is empty or ends in `/` or `..`.
pub fn check_output_path(path: &Path) -> Result<(), String> {
    if path.as_os_str().is_empty() {
        return Err("empty output path".into());
    }
    if path.file_name().is_none() {
        return Err(format!("cannot write {}: not a file name", path.display()));
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(format!(
            "cannot write {}: it is a directory",
            path.display()
        )),
        Ok(m) if !m.is_file() => Err(format!(
            "cannot write {}: not a regular file (a FIFO, socket or device); outputs are \
             written to a temporary file and renamed, which needs a regular file",
            path.display()
        )),
        _ => Ok(()),
    }
}

/// The file a write to `path` replaces: `path` with a symbolic link resolved (so that the link
/// keeps pointing at the new file instead of being replaced by it).
fn resolve(path: &Path) -> PathBuf {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => path.canonicalize().unwrap_or_else(|_| {
            // A dangling link: write where it points.
            let target = std::fs::read_link(path).unwrap_or_else(|_| path.to_path_buf());
            match path.parent() {
                Some(dir) if target.is_relative() => dir.join(target),
                _ => target,
            }
        }),
        _ => path.to_path_buf(),
    }
}

/// An output being written: a temporary file next to the target, renamed over it by
/// [`AtomicFile::commit`]. Dropped without a commit (an error, a panic), the temporary file is
/// removed and the target is untouched.
pub struct AtomicFile {
    target: PathBuf,
    tmp: PathBuf,
    file: Option<File>,
}

impl AtomicFile {
    /// Starts writing `path` (refused if it is not a regular file, see [`check_output_path`]).
    pub fn create(path: &Path) -> Result<Self, String> {
        check_output_path(path)?;
        let target = resolve(path);
        check_output_path(&target)?;
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let cannot = |e: io::Error| format!("cannot write {}: {e}", path.display());
        loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let tmp = dir.join(format!(".{name}.{}.{n}.tmp", std::process::id()));
            match std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create_new(true)
                .open(&tmp)
            {
                Ok(file) => {
                    // An existing target keeps its permissions.
                    if let Ok(m) = std::fs::metadata(&target) {
                        let _ = file.set_permissions(m.permissions());
                    }
                    return Ok(Self {
                        target,
                        tmp,
                        file: Some(file),
                    });
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(cannot(e)),
            }
        }
    }

    /// The temporary file (write, seek and read it; buffered writers must be flushed and
    /// their errors checked before [`AtomicFile::commit`]).
    pub fn file(&mut self) -> &mut File {
        self.file
            .as_mut()
            .expect("an AtomicFile holds its file until commit")
    }

    /// The path the file is committed to.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flushes the file to the disk (fsync: a full disk or an I/O error surfaces here at the
    /// latest), renames it over the target and syncs the directory.
    pub fn commit(mut self) -> io::Result<()> {
        let mut file = self.file.take().expect("committed once");
        file.flush()?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&self.tmp, &self.target)?;
        if let Some(dir) = self.target.parent() {
            let dir = if dir.as_os_str().is_empty() {
                Path::new(".")
            } else {
                dir
            };
            // Best effort: the rename is done; a directory that cannot be synced (some file
            // systems) does not make the file unreadable.
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all();
            }
        }
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path` atomically; the error names the path.
pub fn write_file(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), String> {
    let mut out = AtomicFile::create(path)?;
    let cannot = |e: io::Error| format!("cannot write {}: {e}", path.display());
    out.file().write_all(bytes.as_ref()).map_err(cannot)?;
    out.commit().map_err(cannot)
}

/// Writes `path` atomically through a buffered writer filled by `fill`; the error names the
/// path.
pub fn write_with(
    path: &Path,
    fill: impl FnOnce(&mut io::BufWriter<&mut File>) -> io::Result<()>,
) -> Result<(), String> {
    let mut out = AtomicFile::create(path)?;
    let cannot = |e: io::Error| format!("cannot write {}: {e}", path.display());
    {
        let mut w = io::BufWriter::new(out.file());
        fill(&mut w).map_err(cannot)?;
        w.flush().map_err(cannot)?;
    }
    out.commit().map_err(cannot)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("linlight-atomic-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn replaces_whole_files_and_leaves_nothing_behind() {
        let d = dir("replace");
        let p = d.join("out.json");
        write_file(&p, "old").unwrap();
        write_file(&p, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(entries(&d), ["out.json"]);
        // An error half-way: the target keeps the old content, the temporary file is gone.
        let err = write_with(&p, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("disk on fire"))
        })
        .unwrap_err();
        assert!(
            err.contains("out.json") && err.contains("disk on fire"),
            "{err}"
        );
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(entries(&d), ["out.json"]);
        // Uncommitted (a panic unwinding, an early return): the same.
        {
            let mut f = AtomicFile::create(&p).unwrap();
            f.file().write_all(b"never").unwrap();
        }
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(entries(&d), ["out.json"]);
    }

    #[cfg(unix)]
    #[test]
    fn symlinks_are_followed_and_permissions_kept() {
        use std::os::unix::fs::PermissionsExt;
        let d = dir("links");
        let real = d.join("real.txt");
        std::fs::write(&real, "a").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        let link = d.join("link.txt");
        std::os::unix::fs::symlink("real.txt", &link).unwrap();
        write_file(&link, "b").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "b");
        let mode = std::fs::metadata(&real).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o640);
    }

    #[cfg(unix)]
    #[test]
    fn non_regular_outputs_are_refused_before_writing() {
        for p in ["/dev/full", "/dev/null"] {
            let err = write_file(Path::new(p), "x").unwrap_err();
            assert!(
                err.contains(p) && err.contains("not a regular file"),
                "{err}"
            );
        }
        let d = dir("nonregular");
        let err = write_file(&d, "x").unwrap_err();
        assert!(err.contains("directory"), "{err}");
        let fifo = d.join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            // Opening a FIFO for writing would block until a reader comes: refused instead.
            let err = write_file(&fifo, "x").unwrap_err();
            assert!(err.contains("not a regular file"), "{err}");
        }
        assert!(write_file(Path::new(""), "x").is_err());
    }

    #[test]
    fn concurrent_writers_leave_one_complete_file() {
        let d = dir("race");
        let p = d.join("merged.bin");
        let contents: Vec<Vec<u8>> = (0..8u8).map(|i| vec![i; 1 << 18]).collect();
        std::thread::scope(|s| {
            for c in &contents {
                let p = &p;
                s.spawn(move || {
                    for _ in 0..4 {
                        write_file(p, c).unwrap();
                    }
                });
            }
        });
        let got = std::fs::read(&p).unwrap();
        assert!(contents.contains(&got), "a mixture of writers");
        assert_eq!(entries(&d), ["merged.bin"]);
    }
}
