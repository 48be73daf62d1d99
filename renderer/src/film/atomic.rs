//! Atomic file writes: the bytes go to a temporary file in the destination's folder, which is
//! synced (unless the caller can do without: [`write_atomic_parts`]) and then renamed over the
//! destination, so a reader sees the old file or the whole new one, never half a file.

use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temporary files of concurrent writes from one process.
static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically (temporary sibling + rename). On failure the temporary
/// file is removed and `path` is left as it was.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic_parts(path, &[bytes], true)
}

/// [`write_atomic`] of the concatenation of `parts` (written one after the other, never copied
/// into one buffer). `sync` false skips the fsync before the rename: the file is then whole for
/// every reader, but after a power loss it may be missing, empty or of the right length with
/// stale blocks, so only files their readers checksum (and can do without) are written so.
pub fn write_atomic_parts(path: &Path, parts: &[&[u8]], sync: bool) -> io::Result<()> {
    let temp = temp_path(path)?;
    let result = (|| {
        let mut file = File::create_new(&temp)?;
        for part in parts {
            file.write_all(part)?;
        }
        if sync {
            file.sync_all()?;
        }
        drop(file);
        fs::rename(&temp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&temp);
    }
    result
}

/// `DIR/.NAME.PID.N.tmp` next to `path`: same folder, so the rename never crosses filesystems.
fn temp_path(path: &Path) -> io::Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the path names no file"))?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
    Ok(dir.join(format!(
        ".{}.{}.{n}.tmp",
        name.to_string_lossy(),
        std::process::id()
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_and_leaves_no_temp() {
        let dir = crate::film::test_dir("atomic");
        let path = dir.join("out.bin");
        write_atomic(&path, b"first").unwrap();
        write_atomic(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        let names: Vec<_> = fs::read_dir(&*dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("out.bin")]);
    }

    #[test]
    fn missing_folder_fails_cleanly() {
        let dir = crate::film::test_dir("atomic-missing");
        assert!(write_atomic(&dir.join("no/such/dir/x.bin"), b"x").is_err());
        assert!(write_atomic(Path::new("/"), b"x").is_err());
    }
}
