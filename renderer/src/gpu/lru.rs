//! The bounds of the in-memory caches held across renders, and the least-recently-used map
//! they are kept in.
//!
//! A render server sees an open-ended stream of scenes, and every feature set of a scene makes
//! another kernel variant (SPIR-V, then a pipeline with the driver's compiled code: on lavapipe
//! a few MB of LLVM output each). Without a bound these caches grow with every variant ever
//! rendered (issue 18's soak). [`CacheLimits`] says how much each keeps; the server sets it
//! from its flags (`--cache-kernels`, `--cache-kernel-bytes`, `--cache-pipelines`,
//! `--cache-volumes`), and `renderer::caches::stats` reports what each holds.
//!
//! [`Lru`] is a hash map whose entries remember when they were last used; `trim` drops the
//! least recently used entries (that the caller allows to go) until the map is within its
//! bounds. Callers drop what `trim` returns after releasing their lock: dropping a pipeline
//! object calls the driver.

use std::collections::HashMap;
use std::hash::Hash;
use std::sync::RwLock;

/// How much each in-memory cache keeps (0: nothing beyond what live renders hold).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct CacheLimits {
    /// SPIR-V modules kept in memory (kernel variants; the disk cache keeps every one).
    pub kernels: usize,
    /// Their total bytes.
    pub kernel_bytes: u64,
    /// Pipeline objects kept per device (the driver's compiled code of a kernel variant).
    pub pipelines: usize,
    /// vct voxel volumes kept (GPU memory).
    pub volumes: usize,
}

impl CacheLimits {
    /// The defaults: room for the kernels of a few dozen scenes' feature sets (one set of an
    /// integrator is 1–4 kernels; SPIR-V is ~90 KB a kernel). Pipelines cost more: on lavapipe
    /// each holds ~10 MB of host memory (issue 18's soak: 82 pipelines, 813 MB of malloc), so 32
    /// of them bound that to ~320 MB while still holding the working set of several jobs.
    pub const DEFAULT: CacheLimits = CacheLimits {
        kernels: 256,
        kernel_bytes: 64 << 20,
        pipelines: 32,
        volumes: 2,
    };
}

impl Default for CacheLimits {
    fn default() -> Self {
        CacheLimits::DEFAULT
    }
}

static LIMITS: RwLock<CacheLimits> = RwLock::new(CacheLimits::DEFAULT);

/// Sets the bounds of every in-memory cache of this process (applied at each cache's next
/// insertion).
pub fn set_cache_limits(limits: CacheLimits) {
    *LIMITS.write().unwrap_or_else(|e| e.into_inner()) = limits;
}

/// The bounds in force.
pub fn cache_limits() -> CacheLimits {
    *LIMITS.read().unwrap_or_else(|e| e.into_inner())
}

/// A map whose least recently used entries go first.
pub(crate) struct Lru<K, V> {
    map: HashMap<K, (V, u64)>,
    tick: u64,
    /// Entries dropped to stay within the bounds, since the map was made.
    pub(crate) evictions: u64,
}

impl<K: Hash + Eq + Clone, V: Clone> Lru<K, V> {
    pub(crate) fn new() -> Self {
        Lru {
            map: HashMap::new(),
            tick: 0,
            evictions: 0,
        }
    }

    /// The value of `key` (made by `make` when missing), marked as just used.
    pub(crate) fn get_or_insert_with(&mut self, key: K, make: impl FnOnce() -> V) -> V {
        self.tick += 1;
        let tick = self.tick;
        let e = self.map.entry(key).or_insert_with(|| (make(), tick));
        e.1 = tick;
        e.0.clone()
    }

    pub(crate) fn len(&self) -> usize {
        self.map.len()
    }

    pub(crate) fn values(&self) -> impl Iterator<Item = &V> {
        self.map.values().map(|(v, _)| v)
    }

    /// Drops least recently used entries for which `evictable` holds until at most
    /// `max_entries` are left and their `size`s sum to at most `max_bytes`; returns them (for
    /// the caller to drop outside its lock).
    pub(crate) fn trim(
        &mut self,
        max_entries: usize,
        max_bytes: u64,
        size: impl Fn(&V) -> u64,
        evictable: impl Fn(&V) -> bool,
    ) -> Vec<V> {
        let mut bytes: u64 = self.values().map(&size).sum();
        let mut out = Vec::new();
        while self.map.len() > max_entries || bytes > max_bytes {
            // Step 1: the oldest entry that may go (a linear scan: caches hold hundreds).
            let Some(key) = self
                .map
                .iter()
                .filter(|(_, (v, _))| evictable(v))
                .min_by_key(|(_, (_, t))| *t)
                .map(|(k, _)| k.clone())
            else {
                break;
            };
            // Step 2: drop it from the map and from the totals.
            let (v, _) = self.map.remove(&key).expect("key just found");
            bytes = bytes.saturating_sub(size(&v));
            self.evictions += 1;
            out.push(v);
        }
        out
    }

    /// Removes every entry.
    pub(crate) fn drain(&mut self) -> Vec<V> {
        self.map.drain().map(|(_, (v, _))| v).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_least_recently_used_go_first_within_count_and_bytes() {
        let mut l: Lru<u32, u64> = Lru::new();
        for k in 0..4 {
            l.get_or_insert_with(k, || 10 * (k as u64 + 1));
        }
        // Using 0 again makes 1 the oldest.
        assert_eq!(l.get_or_insert_with(0, || 999), 10);
        let gone = l.trim(3, u64::MAX, |v| *v, |_| true);
        assert_eq!(gone, vec![20]);
        // Bytes: 10 + 30 + 40 = 80; a limit of 40 drops 30 (key 2), then 40 (key 3).
        let gone = l.trim(10, 40, |v| *v, |_| true);
        assert_eq!(gone, vec![30, 40]);
        assert_eq!(l.len(), 1);
        assert_eq!(l.evictions, 3);
        // An entry that may not go stays, whatever the bound.
        l.get_or_insert_with(7, || 5);
        let gone = l.trim(0, 0, |v| *v, |v| *v != 10);
        assert_eq!(gone, vec![5]);
        assert_eq!(l.values().copied().collect::<Vec<_>>(), vec![10]);
    }
}
