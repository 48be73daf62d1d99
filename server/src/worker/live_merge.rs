//! How often a split job's live image (the merge of every shard's latest checkpoint, written
//! with a shard's checkpoint: shard.rs) is rebuilt. Each rebuild reads the other shards'
//! checkpoint files — up to (shards − 1) film-size reads; the shards this process finished come
//! from its memory (shard_sums.rs) — so at a shard checkpoint it is rebuilt
//! only when this process rebuilt the job's image no sooner than `every` ago and no other
//! rebuild of it is under way; a skipped one leaves the image (and its `snapshot` event) as it
//! was. The job's final image is the merge's claim (exact), never this one.

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use std::path::{Path, PathBuf};

/// A job's last rebuild, and whether one is under way.
struct Gate {
    last: Option<Instant>,
    busy: bool,
}

/// Every job's gate in this process, by the job's folder (a worker's device threads share it).
static GATES: Mutex<BTreeMap<PathBuf, Gate>> = Mutex::new(BTreeMap::new());

/// The right to rebuild a job's live image; dropping it ends the rebuild.
pub struct Ticket(PathBuf);

/// A ticket when the live image of the job in folder `job` may be rebuilt now (see the module
/// doc).
pub fn try_begin(job: &Path, every: Duration) -> Option<Ticket> {
    let mut gates = GATES.lock().unwrap_or_else(|e| e.into_inner());
    let gate = gates.entry(job.to_path_buf()).or_insert(Gate {
        last: None,
        busy: false,
    });
    if gate.busy || gate.last.is_some_and(|t| t.elapsed() < every) {
        return None;
    }
    gate.busy = true;
    Some(Ticket(job.to_path_buf()))
}

/// Forgets the job in folder `job` (it left this process).
pub fn forget(job: &Path) {
    GATES.lock().unwrap_or_else(|e| e.into_inner()).remove(job);
}

impl Drop for Ticket {
    fn drop(&mut self) {
        let mut gates = GATES.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(g) = gates.get_mut(&self.0) {
            g.busy = false;
            g.last = Some(Instant::now());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One rebuild at a time, then none until the interval has passed.
    #[test]
    fn one_at_a_time_then_at_the_cadence() {
        let (id, other) = (Path::new("/nowhere/job-a"), Path::new("/nowhere/job-b"));
        let every = Duration::from_millis(50);
        let t = try_begin(id, every).expect("the first rebuild");
        assert!(try_begin(id, every).is_none(), "one under way");
        assert!(try_begin(other, every).is_some(), "other jobs are not held");
        drop(t);
        assert!(try_begin(id, every).is_none(), "too soon");
        std::thread::sleep(every);
        assert!(try_begin(id, every).is_some(), "due again");
        forget(id);
        forget(other);
    }
}
