//! The data directory's storage: free bytes on its filesystem (statvfs), whether that is below the
//! server's `--min-free-space`, a probe that space is writable again, and which write errors
//! mean the storage, not the job, is at fault (ENOSPC, EDQUOT, EROFS, SQLite's "database or disk
//! is full"). The worker pauses a job on such an error and resumes it when the probe succeeds
//! (worker/storage_hold.rs); `POST /api/jobs` answers 507 while space is low.
//!
//! A reserve file (`<data>/space-reserve`, 1 MiB) is kept so that, when the disk fills up, the
//! worker can delete it and still record the pause in the store; it is made again before held
//! jobs resume.
//!
//! Test hook: while the file named by `CANDELA_TEST_DISK_FULL_FILE` exists, every job-file write
//! (checkpoint, image) and the probe fail with ENOSPC, as on a full disk.

use std::io;
use std::path::Path;

use serde::Serialize;

/// The storage as last measured.
#[derive(Debug, Clone, Default, Serialize)]
pub struct StorageStatus {
    /// The data directory.
    pub data_dir: String,
    /// Bytes available to the server on its filesystem.
    pub free_bytes: u64,
    /// `--min-free-space`.
    pub min_free_bytes: u64,
    /// Free space is below the minimum (new jobs are refused with 507).
    pub low: bool,
    /// Jobs the server holds paused for a storage fault.
    pub held_jobs: u64,
}

/// Bytes available to an unprivileged writer on the filesystem holding `dir`.
#[cfg(unix)]
pub fn free_bytes(dir: &Path) -> io::Result<u64> {
    use std::os::unix::ffi::OsStrExt;
    let path = std::ffi::CString::new(dir.as_os_str().as_bytes())
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "NUL in the path"))?;
    let mut st = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `path` is a valid NUL-terminated string and `st` a writable statvfs; on success
    // statvfs has initialised it.
    let rc = unsafe { libc::statvfs(path.as_ptr(), st.as_mut_ptr()) };
    if rc != 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: initialised by the successful call above.
    let st = unsafe { st.assume_init() };
    // (The field types vary by platform: 32-bit on some.)
    #[allow(clippy::unnecessary_cast)]
    Ok((st.f_bavail as u64).saturating_mul(st.f_frsize as u64))
}

/// Without statvfs: unknown, reported as unlimited.
#[cfg(not(unix))]
pub fn free_bytes(_dir: &Path) -> io::Result<u64> {
    Ok(u64::MAX)
}

/// Measures the storage of `data_dir` against `min_free`.
pub fn status(data_dir: &Path, min_free: u64) -> StorageStatus {
    let free = free_bytes(data_dir).unwrap_or(u64::MAX);
    StorageStatus {
        data_dir: data_dir.display().to_string(),
        free_bytes: free,
        min_free_bytes: min_free,
        low: free < min_free,
        held_jobs: 0,
    }
}

/// The test hook: ENOSPC while `CANDELA_TEST_DISK_FULL_FILE` names an existing file.
pub fn injected_fault() -> io::Result<()> {
    match std::env::var_os("CANDELA_TEST_DISK_FULL_FILE") {
        Some(f) if Path::new(&f).exists() => Err(io::Error::from_raw_os_error(libc::ENOSPC)),
        _ => Ok(()),
    }
}

/// Size of the reserve file.
pub const RESERVE_BYTES: u64 = 1 << 20;

fn reserve_path(data_dir: &Path) -> std::path::PathBuf {
    data_dir.join("space-reserve")
}

/// Whether the reserve file is in place.
pub fn has_reserve(data_dir: &Path) -> bool {
    std::fs::metadata(reserve_path(data_dir)).is_ok_and(|m| m.len() == RESERVE_BYTES)
}

/// Makes the reserve file (if it is not there), written and synced so its blocks are allocated.
pub fn make_reserve(data_dir: &Path) -> io::Result<()> {
    use std::io::Write;
    if has_reserve(data_dir) {
        return Ok(());
    }
    injected_fault()?;
    let path = reserve_path(data_dir);
    let made = std::fs::File::create(&path).and_then(|mut f| {
        f.write_all(&vec![0xa5u8; RESERVE_BYTES as usize])?;
        f.sync_all()
    });
    if made.is_err() {
        let _ = std::fs::remove_file(&path);
    }
    made
}

/// Deletes the reserve file to make room; whether there was one.
pub fn release_reserve(data_dir: &Path) -> bool {
    std::fs::remove_file(reserve_path(data_dir)).is_ok()
}

/// Whether space to write is back: writes, syncs and removes a 64 KiB file in `data_dir`.
pub fn probe(data_dir: &Path) -> io::Result<()> {
    use std::io::Write;
    injected_fault()?;
    let path = data_dir.join(".space-probe");
    let written = std::fs::File::create(&path).and_then(|mut f| {
        f.write_all(&[0u8; 64 << 10])?;
        f.sync_all()
    });
    let _ = std::fs::remove_file(&path);
    written
}

/// Whether an I/O error is the storage's (full, over quota, read-only), not the job's.
pub fn is_storage_error(e: &io::Error) -> bool {
    matches!(
        e.raw_os_error(),
        Some(libc::ENOSPC) | Some(libc::EDQUOT) | Some(libc::EROFS)
    ) || e.kind() == io::ErrorKind::StorageFull
}

/// Whether an error message (SQLite's or an I/O error's text) says the storage is full.
pub fn is_storage_message(m: &str) -> bool {
    let m = m.to_ascii_lowercase();
    m.contains("disk is full")
        || m.contains("no space left")
        || m.contains("quota exceeded")
        || m.contains("read-only file system")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_space_and_errors() {
        let free = free_bytes(Path::new(".")).unwrap();
        assert!(free > 0);
        assert!(status(Path::new("."), u64::MAX).low);
        assert!(!status(Path::new("."), 0).low);
        assert!(is_storage_error(&io::Error::from_raw_os_error(
            libc::ENOSPC
        )));
        assert!(!is_storage_error(&io::Error::from_raw_os_error(
            libc::ENOENT
        )));
        assert!(is_storage_message("store: database or disk is full"));
        assert!(!is_storage_message("store: no such table"));
    }
}
