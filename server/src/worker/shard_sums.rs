//! Finished shards' sums kept in the worker process's memory and added up as they land, so that
//! the merge of a split job (shard.rs `merged`) reads from disk only the shards this process
//! did not render. Without it the merge read and added every shard's file at the job's end, one
//! film-size file per shard (32 files of 265 MB for 4096 spp at 3840×2160: 0.8–1.2 s of a job
//! whose four GPUs rendered for 6.7 s), all of it after the last shard.
//!
//! A shard's writer (shard_write.rs) adds its sums here once its file is whole, before it marks
//! the shard done: every shard this process marked done (and had room for) is in its job's sum
//! by the time any thread can claim the merge. The sums are only a cache of what the files
//! hold:
//! - the merge takes a job's sum and uses a kept shard only when its row is done and has the
//!   same sample range (a shard kept by a writer that then lost its lease holds the same sample
//!   indices as the file of whoever finished it: the same samples, counted once);
//! - a shard kept already is not added again (a shard reopened and rendered again here);
//! - anything amiss (another film, seed or split, a layout that does not match) and the merge
//!   reads every file, as before.
//!
//! Memory is bounded: at most [`MAX_JOBS`] jobs and [`MAX_BYTES`] in all; a job that does not
//! fit evicts the one added to least recently, and a job larger than the bound is not kept. A
//! job's sum leaves at its merge, when the worker sees the job no longer queued or running
//! (merged by another process, canceled, deleted, paused: reconcile.rs; a writer also drops it
//! when it sees the job ended), or when a device reset is noticed during an add (shard_write.rs).
//!
//! Kept shards are added in the order they land, so a merged sum is exact up to the order of
//! float additions but not bit for bit the same from run to run (files are added in index
//! order). A split job's live image takes the kept sum too (`add_kept_into`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use renderer::integrators::ExtraBuffer;
use renderer::render::{merge_accumulation, Progress, RenderSession};

use crate::jobs::model::{JobId, JobSettings};
use crate::store::ShardRange;

/// Jobs whose sums a process keeps at once.
pub const MAX_JOBS: usize = 2;
/// Bytes of sums a process keeps in all (a 3840×2160 nee job's sum is 265 MB).
pub const MAX_BYTES: usize = 2 << 30;

/// What a job's shards must agree on to be added up: film, seed, accumulation layout (its
/// length and the integrator's extra buffers, which say how they add up), split.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    /// Entries (`[f32; 4]`) of the accumulation.
    pub entries: usize,
    pub extra: Vec<ExtraBuffer>,
    /// The job's shard count.
    pub count: u32,
}

impl Layout {
    /// The layout of a job with `settings` rendered by `session`, split into `count` shards.
    pub fn of(settings: &JobSettings, session: &RenderSession, count: u32) -> Layout {
        Layout {
            width: settings.width,
            height: settings.height,
            seed: settings.seed,
            entries: session.accumulation_len(),
            extra: session.extra_buffers(),
            count,
        }
    }
}

/// A job's kept shards: their summed accumulation, and each one's range and progress.
pub struct Kept {
    pub layout: Layout,
    pub sum: Vec<[f32; 4]>,
    pub shards: BTreeMap<u32, (ShardRange, Progress)>,
}

struct Entry {
    /// None once taken by the merge (a writer that found the entry before the take then adds
    /// nothing; one after it starts a new entry, forgotten once the job is seen ended).
    kept: Option<Kept>,
}

/// A kept job: its id, the bytes of its sum, when an add to it last began, and its entry. (The
/// figures the eviction and the reports read are here, under the map's lock, so that neither
/// waits for an add under way on an entry.)
struct Slot {
    id: JobId,
    bytes: usize,
    last_add: Instant,
    entry: Arc<Mutex<Entry>>,
}

/// Every kept job in this process, by the job's folder (a worker's device threads share it).
static JOBS: Mutex<BTreeMap<PathBuf, Slot>> = Mutex::new(BTreeMap::new());

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Adds shard `range`'s sums (`sums`, with its `progress`) to the kept sum of job `id` in
/// folder `job`. Whether it was added (false: kept already, no room, a layout that does not
/// match, or an add that failed half way before).
pub fn add(
    job: &Path,
    id: JobId,
    layout: Layout,
    range: ShardRange,
    progress: Progress,
    sums: &[[f32; 4]],
) -> bool {
    let bytes = layout.entries * 16;
    if sums.len() != layout.entries || bytes > MAX_BYTES {
        return false;
    }
    // Step 1: the job's entry, making room for a new one.
    let entry = {
        let mut jobs = lock(&JOBS);
        if !jobs.contains_key(job) {
            evict_for(&mut jobs, bytes);
            let kept = Kept {
                sum: vec![[0.0; 4]; layout.entries],
                layout: layout.clone(),
                shards: BTreeMap::new(),
            };
            let slot = Slot {
                id,
                bytes,
                last_add: Instant::now(),
                entry: Arc::new(Mutex::new(Entry { kept: Some(kept) })),
            };
            jobs.insert(job.to_path_buf(), slot);
        }
        let slot = jobs.get_mut(job).expect("inserted above");
        slot.last_add = Instant::now();
        slot.entry.clone()
    };
    // Step 2: the add, under the job's own lock (other jobs' writers do not wait). (A lock
    // poisoned by an add that panicked half way: the sum is in doubt, nothing is added to it
    // and the merge will not take it.)
    let Ok(mut e) = entry.lock() else {
        return false;
    };
    let Some(kept) = e.kept.as_mut() else {
        return false;
    };
    if kept.layout != layout || kept.shards.contains_key(&range.idx) {
        return false;
    }
    let pixels = (layout.width * layout.height) as usize;
    if merge_accumulation(&mut kept.sum, sums, pixels, &layout.extra).is_err() {
        return false;
    }
    kept.shards.insert(range.idx, (range, progress));
    true
}

/// Drops kept jobs, least recently added to first, until `bytes` more fit (the jobs and bytes
/// bounds).
fn evict_for(jobs: &mut BTreeMap<PathBuf, Slot>, bytes: usize) {
    loop {
        let used: usize = jobs.values().map(|s| s.bytes).sum();
        if jobs.len() < MAX_JOBS && used + bytes <= MAX_BYTES {
            return;
        }
        let Some(oldest) = jobs.iter().min_by_key(|(_, s)| s.last_add) else {
            return;
        };
        let oldest = oldest.0.clone();
        jobs.remove(&oldest);
    }
}

/// Adds the kept sum of the job in folder `job` (when its layout is `layout` and it does not
/// hold shard `rendering`, whose samples `into` has already) to `into`, for a live image of the
/// job; returns the shards it holds and their samples (the live image reads the other shards'
/// checkpoints). None: nothing added.
pub fn add_kept_into(
    job: &Path,
    layout: &Layout,
    rendering: u32,
    into: &mut [[f32; 4]],
) -> Option<(BTreeSet<u32>, u32)> {
    let entry = lock(&JOBS).get(job)?.entry.clone();
    let e = entry.lock().ok()?;
    let kept = e.kept.as_ref();
    let kept = kept.filter(|k| k.layout == *layout && !k.shards.contains_key(&rendering))?;
    let pixels = (layout.width * layout.height) as usize;
    merge_accumulation(into, &kept.sum, pixels, &layout.extra).ok()?;
    let spp = kept.shards.values().map(|(_, p)| p.spp).sum();
    Some((kept.shards.keys().copied().collect(), spp))
}

/// Takes the kept sums of the job in folder `job` for its merge (none are kept after).
pub fn take(job: &Path) -> Option<Kept> {
    let entry = lock(&JOBS).remove(job)?.entry;
    let mut e = entry.lock().ok()?;
    e.kept.take()
}

/// The jobs kept (their folder and id): a worker forgets those it sees ended. (Never waits for
/// an add under way on the job itself.)
pub fn kept_jobs() -> Vec<(PathBuf, JobId)> {
    let jobs = lock(&JOBS);
    jobs.iter().map(|(k, s)| (k.clone(), s.id)).collect()
}

/// Bytes of the sums this process keeps, for its worker reports (never waits for an add).
pub fn kept_bytes() -> u64 {
    lock(&JOBS).values().map(|s| s.bytes as u64).sum()
}

/// Forgets the job in folder `job` (it ended, or its merge is another process's).
pub fn forget(job: &Path) {
    lock(&JOBS).remove(job);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout(count: u32) -> Layout {
        Layout {
            width: 2,
            height: 1,
            seed: 7,
            entries: 4, // 2 pixels + their odd half
            extra: Vec::new(),
            count,
        }
    }

    fn range(idx: u32) -> ShardRange {
        ShardRange {
            idx,
            first: idx * 10,
            samples: 10,
        }
    }

    fn progress(spp: u32) -> Progress {
        Progress {
            spp,
            ..Default::default()
        }
    }

    /// Shards add up once each; a layout that does not match is refused; the merge takes them;
    /// the least recently added job is evicted.
    #[test]
    fn shards_add_up_once_and_leave_with_the_merge() {
        let job = Path::new("/nowhere/shard-sums-a");
        let sums = [[1.0, 2.0, 3.0, 1.0]; 4];
        assert!(add(job, 1, layout(3), range(0), progress(10), &sums));
        assert!(add(job, 1, layout(3), range(2), progress(10), &sums));
        assert!(
            !add(job, 1, layout(3), range(2), progress(10), &sums),
            "kept already"
        );
        assert_eq!(
            kept_bytes(),
            4 * 16,
            "one sum of 4 entries, however many shards"
        );
        let mut other = layout(3);
        other.seed = 8;
        assert!(
            !add(job, 1, other, range(1), progress(10), &sums),
            "another seed"
        );
        let mut live = vec![[1.0; 4]; 4];
        assert!(
            add_kept_into(job, &layout(3), 2, &mut live).is_none(),
            "holds shard 2"
        );
        let (held, spp) = add_kept_into(job, &layout(3), 1, &mut live).expect("kept");
        assert_eq!(
            (held.into_iter().collect::<Vec<_>>(), spp),
            (vec![0, 2], 20)
        );
        assert_eq!(live, vec![[3.0, 5.0, 7.0, 3.0]; 4], "the live image's sum");
        let kept = take(job).expect("kept");
        assert_eq!(kept.shards.keys().copied().collect::<Vec<_>>(), vec![0, 2]);
        assert_eq!(kept.sum, vec![[2.0, 4.0, 6.0, 2.0]; 4]);
        assert!(take(job).is_none(), "taken");
        assert_eq!(kept_bytes(), 0);
        // (A writer after the take starts a new entry: forgotten when it sees the job ended.)
        assert!(add(job, 1, layout(3), range(1), progress(10), &sums));
        forget(job);
        assert!(take(job).is_none());
        // At most MAX_JOBS jobs: a new one evicts the one added to least recently. (One test:
        // the kept jobs are the process's.)
        let jobs: Vec<PathBuf> = (0..=MAX_JOBS)
            .map(|i| PathBuf::from(format!("/nowhere/shard-sums-evict-{i}")))
            .collect();
        for j in &jobs {
            assert!(add(j, 1, layout(2), range(0), progress(10), &sums));
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        assert!(take(&jobs[0]).is_none(), "the oldest was evicted");
        for j in &jobs[1..] {
            assert!(take(j).is_some());
        }
    }
}
