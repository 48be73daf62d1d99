//! The server process's memory as the operating system and the C allocator see it, for
//! `/metrics`: resident bytes (`/proc/self/statm`) and glibc malloc's own account (mallinfo2:
//! bytes handed out, and bytes free inside its arenas, which the process holds but does not
//! use). A resident size far above the allocated bytes points at the allocator (fragmentation,
//! one arena per thread), not at a cache; [`release_free_heap`] returns those pages.

/// Resident bytes of this process (None where there is no /proc).
pub fn resident_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = text.split_whitespace().nth(1)?.parse().ok()?;
    // SAFETY: sysconf has no preconditions.
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    Some(pages * u64::try_from(page).ok()?)
}

/// What glibc's malloc holds, summed over its arenas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeapStats {
    /// Bytes in use by the program (small blocks and mmap'd large blocks).
    pub allocated: u64,
    /// Bytes free inside the arenas (held by the process, not returned to the system).
    pub free: u64,
    /// Bytes of large blocks served by mmap (part of `allocated`).
    pub mmapped: u64,
}

/// glibc malloc's statistics (None with another C library).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub fn heap() -> Option<HeapStats> {
    // SAFETY: mallinfo2 only reads the allocator's state (under its locks).
    let m = unsafe { libc::mallinfo2() };
    Some(HeapStats {
        allocated: (m.uordblks + m.hblkhd) as u64,
        free: m.fordblks as u64,
        mmapped: m.hblkhd as u64,
    })
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn heap() -> Option<HeapStats> {
    None
}

/// Hands the free pages inside glibc malloc's arenas back to the system (`malloc_trim(0)`):
/// after a large release (a lavapipe pipeline frees ~10 MB in pieces), what is free in the
/// middle of an arena otherwise stays resident. A no-op with another C library.
pub fn release_free_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only takes the allocator's own locks.
    unsafe {
        libc::malloc_trim(0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_large_allocation_shows_in_the_heap_and_the_resident_size() {
        let (Some(before), Some(rss_before)) = (heap(), resident_bytes()) else {
            return; // not glibc on Linux
        };
        let block = vec![1u8; 64 << 20];
        let after = heap().unwrap();
        // (Other test threads may free a little meanwhile.)
        assert!(
            after.allocated + (8 << 20) >= before.allocated + (64 << 20),
            "{before:?} → {after:?}"
        );
        assert!(resident_bytes().unwrap() + (8 << 20) >= rss_before + (64 << 20));
        drop(block);
    }
}
