//! Bounded input: every file the project reads is a regular file (a FIFO would block forever,
//! `/dev/zero` never ends) of at most a stated size, checked before it is read.

use std::io::Read;
use std::path::Path;

/// Size cap of text inputs (scene files, includes, shard reports, JSON): 256 MiB.
pub const MAX_TEXT_BYTES: u64 = 256 << 20;
/// Size cap of binary inputs (meshes, tables, images): 4 GiB.
pub const MAX_BINARY_BYTES: u64 = 4 << 30;

/// The size of `path`, refused unless it is a regular file (symbolic links followed) of at most
/// `cap` bytes. The messages name the path.
pub fn regular_file_len(path: &Path, cap: u64) -> Result<u64, String> {
    let m = std::fs::metadata(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    if m.is_dir() {
        return Err(format!("cannot read {}: it is a directory", path.display()));
    }
    if !m.is_file() {
        return Err(format!(
            "cannot read {}: not a regular file (a FIFO, socket or device); inputs must be \
             regular files",
            path.display()
        ));
    }
    if m.len() > cap {
        return Err(format!(
            "cannot read {}: {} bytes is more than the limit of {} bytes for this kind of input",
            path.display(),
            m.len(),
            cap
        ));
    }
    Ok(m.len())
}

/// Reads a regular file of at most `cap` bytes (a file that grows while it is read is cut at
/// the cap and refused).
pub fn read_capped(path: &Path, cap: u64) -> Result<Vec<u8>, String> {
    let len = regular_file_len(path, cap)?;
    let file =
        std::fs::File::open(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(cap.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    if bytes.len() as u64 > cap {
        return Err(format!(
            "cannot read {}: more than the limit of {cap} bytes for this kind of input",
            path.display()
        ));
    }
    Ok(bytes)
}

/// [`read_capped`] as UTF-8 text.
pub fn read_text_capped(path: &Path, cap: u64) -> Result<String, String> {
    String::from_utf8(read_capped(path, cap)?)
        .map_err(|e| format!("cannot read {}: not UTF-8 text ({e})", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_regular_and_oversized_inputs_are_refused() {
        for p in ["/dev/zero", "/dev/null"] {
            if Path::new(p).exists() {
                let e = read_capped(Path::new(p), MAX_TEXT_BYTES).unwrap_err();
                assert!(e.contains(p) && e.contains("not a regular file"), "{e}");
            }
        }
        let dir = std::env::temp_dir().join(format!("linlight-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert!(read_capped(&dir, 10).unwrap_err().contains("directory"));
        let f = dir.join("ten.txt");
        std::fs::write(&f, "0123456789").unwrap();
        assert_eq!(read_text_capped(&f, 10).unwrap(), "0123456789");
        let e = read_capped(&f, 9).unwrap_err();
        assert!(e.contains("limit of 9 bytes"), "{e}");
        let fifo = dir.join("fifo");
        if std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success())
        {
            // Opening a FIFO for reading blocks until a writer comes: refused before opening.
            assert!(read_capped(&fifo, 10)
                .unwrap_err()
                .contains("not a regular file"));
        }
        assert!(read_capped(&dir.join("missing"), 10)
            .unwrap_err()
            .contains("cannot read"));
    }
}
