//! Jobs split by sample index over several workers (docs/farm.md). Samples are keyed by their
//! index (the counter-based RNG), so renders of disjoint index ranges of one job add up to the
//! render of all of them (renderer/src/render/shards.rs). A job with a sample budget larger than
//! the claiming worker's `--shard-spp` is cut, at its first claim, into shards of that many
//! indices (the last one shorter): rows of `shards`, each the unit of lease, checkpoint
//! (`jobs/<id>/shard-<k>.bin`) and completion. When every shard is done, one more claim — the
//! merge, under the job row's lease — sums the shards' checkpoints into the job's accumulation
//! and finishes the job as a whole render would. A worker that dies mid-shard loses only that
//! shard's samples since its last checkpoint; one that dies mid-merge leaves the job to the next
//! claim after its lease expires. Time budgets, quality targets and `auto` jobs stay whole.

use renderer::render::{Budget, Progress};

use super::db::{params, Conn, Dialect, Row};
use super::{Store, StoreError};
use crate::jobs::model::{now_s, JobId, JobSettings, JobState};

/// One shard: its index and its sample indices `first..first + samples`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShardRange {
    pub idx: u32,
    pub first: u32,
    pub samples: u32,
}

/// What a claim hands a worker.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// The whole job (not split).
    Whole,
    /// One shard of a split job of `count` shards.
    Shard { range: ShardRange, count: u32 },
    /// Every shard of the job (`count` of them) is done: merge them and finish the job.
    Merge { count: u32 },
}

/// A claimed job: its id, state, priority and the part of it that was claimed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Claim {
    pub id: JobId,
    pub state: JobState,
    pub priority: u32,
    pub part: Part,
}

/// The shards (first sample, samples) of a job with `settings` claimed by a worker whose
/// `--shard-spp` is `shard_spp`: none (render it whole) unless the budget is a sample count
/// above `shard_spp` with no quality target and no `auto` pilot.
pub fn plan(settings: &JobSettings, shard_spp: u32) -> Vec<(u32, u32)> {
    let split = shard_spp > 0 && !settings.auto && settings.until_rel_mse.is_none();
    match settings.budget() {
        Budget::Spp(total) if split && total > shard_spp => (0..total)
            .step_by(shard_spp as usize)
            .map(|first| (first, shard_spp.min(total - first)))
            .collect(),
        _ => Vec::new(),
    }
}

/// The sum of shards' progress counters: samples, passes, rays and times add up (the time is
/// the work's, not the wall clock's: the shards may have rendered at once).
pub fn sum_progress<'a>(parts: impl IntoIterator<Item = &'a Progress>) -> Progress {
    let mut t = Progress::default();
    for p in parts {
        t.spp += p.spp;
        t.passes += p.passes;
        t.rays += p.rays;
        t.dropped_samples += p.dropped_samples;
        t.time_s += p.time_s;
        t.gpu_time_s += p.gpu_time_s;
    }
    t
}

/// A shard's row: its range, whether it is done, its last recorded progress.
#[derive(Debug, Clone)]
pub struct ShardRow {
    pub range: ShardRange,
    pub done: bool,
    pub progress: Option<Progress>,
}

fn shard_rows(c: &mut dyn Conn, id: JobId) -> Result<Vec<ShardRow>, StoreError> {
    let rows = c.query(
        "SELECT idx, first_sample, samples, done, progress FROM shards WHERE job_id = ?1 \
         ORDER BY idx",
        params![id],
    )?;
    rows.iter()
        .map(|r| {
            Ok(ShardRow {
                range: ShardRange {
                    idx: r.i64(0)? as u32,
                    first: r.i64(1)? as u32,
                    samples: r.i64(2)? as u32,
                },
                done: r.i64(3)? != 0,
                progress: r.opt_text(4)?.and_then(|t| serde_json::from_str(&t).ok()),
            })
        })
        .collect()
}

/// Records the sum of the shards' progress as the job's.
fn record_total(c: &mut dyn Conn, id: JobId) -> Result<Progress, StoreError> {
    let rows = shard_rows(c, id)?;
    let total = sum_progress(rows.iter().filter_map(|r| r.progress.as_ref()));
    let text = serde_json::to_string(&total).map_err(|e| StoreError::Db(e.to_string()))?;
    c.exec(
        "UPDATE jobs SET progress = ?2, updated_at = ?3 WHERE id = ?1",
        params![id, text, now_s()],
    )?;
    Ok(total)
}

/// Leases shard `idx` of job `id` to `worker` until `until` if it is still free at `now` (not
/// done; never leased, given up, expired, or `worker`'s own); whether it was (exactly one row).
fn take_shard(
    c: &mut dyn Conn,
    id: JobId,
    idx: u32,
    worker: &str,
    until: f64,
    now: f64,
) -> Result<bool, StoreError> {
    let taken = c.exec(
        "UPDATE shards SET lease_owner = ?3, lease_until = ?4 WHERE job_id = ?1 AND idx = ?2 \
         AND done = 0 AND (lease_owner IS NULL OR lease_owner = ?3 OR lease_until < ?5)",
        params![id, idx, worker, until, now],
    )?;
    Ok(taken == 1)
}

/// Locks job `id`'s row (PostgreSQL; SQLite has one writer) before a `shards` row: the order a
/// claim takes them in, so that a shard update and a claim never wait on each other in turn.
fn lock_job(c: &mut dyn Conn, id: JobId) -> Result<(), StoreError> {
    if c.dialect() == Dialect::Sqlite {
        return Ok(());
    }
    let sql = format!(
        "SELECT 1 FROM jobs WHERE id = ?1{}",
        c.dialect().for_update()
    );
    c.query(&sql, params![id])?;
    Ok(())
}

/// Inside a claim's transaction, with job `id`'s row locked: splits the job at its first claim
/// (when [`plan`] says so and it never started: a job rendered whole so far stays whole, its
/// checkpoint holds samples of every index), then takes a free shard (its own first: a worker
/// back after a device loss resumes its shard), or the merge once all are done, or the whole
/// job. None: every undone shard is leased to another worker.
pub(super) fn claim_part(
    c: &mut dyn Conn,
    job: &Row,
    worker: &str,
    until: f64,
    shard_spp: u32,
) -> Result<Option<Part>, StoreError> {
    let now = now_s();
    // (The claim's row: id, state, priority, shard_count, settings, started_at.)
    let (id, mut count) = (job.i64(0)?, job.i64(3)?);
    let never_started = job.opt_f64(5)?.is_none();
    let settings = job.text(4)?;
    // Step 1: the first claim cuts the job into shards.
    if count == 0 && never_started {
        let ranges = serde_json::from_str::<JobSettings>(&settings)
            .map(|s| plan(&s, shard_spp))
            .unwrap_or_default();
        for (idx, (first, samples)) in ranges.iter().enumerate() {
            c.exec(
                "INSERT INTO shards (job_id, idx, first_sample, samples) VALUES (?1, ?2, ?3, ?4)",
                params![id, idx as i64, *first, *samples],
            )?;
        }
        count = ranges.len() as i64;
        if count > 0 {
            c.exec(
                "UPDATE jobs SET shard_count = ?2 WHERE id = ?1",
                params![id, count],
            )?;
        }
    }
    let take_job = |c: &mut dyn Conn, shard: Option<i64>| {
        c.exec(
            "INSERT INTO leases (job_id, worker, claimed_at, shard) VALUES (?1, ?2, ?3, ?4)",
            params![id, worker, now, shard],
        )
    };
    if count == 0 {
        c.exec(
            "UPDATE jobs SET lease_owner = ?2, lease_until = ?3 WHERE id = ?1",
            params![id, worker, until],
        )?;
        take_job(c, None)?;
        return Ok(Some(Part::Whole));
    }
    // Step 2: a free shard (never leased, given up, expired, or this worker's own).
    let free = c.query_opt(
        "SELECT idx, first_sample, samples FROM shards WHERE job_id = ?1 AND done = 0 \
         AND (lease_owner IS NULL OR lease_owner = ?2 OR lease_until < ?3) \
         ORDER BY CASE WHEN lease_owner = ?2 THEN 0 ELSE 1 END, idx LIMIT 1",
        params![id, worker, now],
    )?;
    if let Some(r) = free {
        let range = ShardRange {
            idx: r.i64(0)? as u32,
            first: r.i64(1)? as u32,
            samples: r.i64(2)? as u32,
        };
        if !take_shard(c, id, range.idx, worker, until, now)? {
            return Ok(None);
        }
        take_job(c, Some(range.idx.into()))?;
        return Ok(Some(Part::Shard {
            range,
            count: count as u32,
        }));
    }
    // Step 3: all done: the merge, under the job's own lease.
    let left = c
        .query_one(
            "SELECT COUNT(*) FROM shards WHERE job_id = ?1 AND done = 0",
            params![id],
        )?
        .i64(0)?;
    if left > 0 {
        return Ok(None);
    }
    c.exec(
        "UPDATE jobs SET lease_owner = ?2, lease_until = ?3 WHERE id = ?1",
        params![id, worker, until],
    )?;
    take_job(c, None)?;
    Ok(Some(Part::Merge {
        count: count as u32,
    }))
}

impl Store {
    /// Job `id`'s shards, by index.
    pub fn shards(&self, id: JobId) -> Result<Vec<ShardRow>, StoreError> {
        self.read(|c| shard_rows(c, id))
    }

    /// Records shard `idx`'s progress (its checkpoint was written) while `worker` holds it, and
    /// returns the job's total; None when the lease is no longer `worker`'s.
    pub fn shard_checkpointed(
        &self,
        id: JobId,
        idx: u32,
        worker: &str,
        progress: &Progress,
    ) -> Result<Option<Progress>, StoreError> {
        self.shard_update(id, idx, worker, progress, false)
    }

    /// Marks shard `idx` done with its final `progress` (its checkpoint holds every sample of
    /// it) and gives up its lease, if `worker` still holds it; returns the job's total (None:
    /// the lease was lost, and the shard is another worker's to finish).
    pub fn shard_done(
        &self,
        id: JobId,
        idx: u32,
        worker: &str,
        progress: &Progress,
    ) -> Result<Option<Progress>, StoreError> {
        self.shard_update(id, idx, worker, progress, true)
    }

    fn shard_update(
        &self,
        id: JobId,
        idx: u32,
        worker: &str,
        progress: &Progress,
        done: bool,
    ) -> Result<Option<Progress>, StoreError> {
        let text = serde_json::to_string(progress).map_err(|e| StoreError::Db(e.to_string()))?;
        self.write(|c| {
            lock_job(c, id)?;
            let sql = if done {
                "UPDATE shards SET progress = ?4, done = 1, lease_owner = NULL, \
                 lease_until = NULL WHERE job_id = ?1 AND idx = ?2 AND lease_owner = ?3 \
                 AND done = 0"
            } else {
                "UPDATE shards SET progress = ?4 WHERE job_id = ?1 AND idx = ?2 \
                 AND lease_owner = ?3 AND done = 0"
            };
            if c.exec(sql, params![id, idx, worker, text])? == 0 {
                return Ok((None, Vec::new()));
            }
            Ok((Some(record_total(c, id)?), Vec::new()))
        })
    }

    /// Hands shard `idx` of job `id`, finished by `from`, to `to` (the name its final
    /// checkpoint's writer holds it under, worker/shard_write.rs) for `lease`, so that `from`'s
    /// next claims and heartbeats pass it by; whether `from` held it (not done). A writer that
    /// dies leaves the lease to expire, and the shard to be rendered again from its last
    /// checkpoint.
    pub fn hand_shard(
        &self,
        id: JobId,
        idx: u32,
        from: &str,
        to: &str,
        lease: std::time::Duration,
    ) -> Result<bool, StoreError> {
        self.write(|c| {
            lock_job(c, id)?;
            let n = c.exec(
                "UPDATE shards SET lease_owner = ?4, lease_until = ?5 WHERE job_id = ?1 \
                 AND idx = ?2 AND lease_owner = ?3 AND done = 0",
                params![id, idx, from, to, now_s() + lease.as_secs_f64()],
            )?;
            Ok((n == 1, Vec::new()))
        })
    }

    /// Renews `owner`'s lease on shard `idx` of job `id` (not done) for `lease` from now: a
    /// writer's (`NAME#write`, worker/shard_write.rs), renewed with its worker's heartbeats
    /// while its file is written; whether `owner` still holds it.
    pub fn renew_shard_lease(
        &self,
        id: JobId,
        idx: u32,
        owner: &str,
        lease: std::time::Duration,
    ) -> Result<bool, StoreError> {
        // (A hand-off to itself.)
        self.hand_shard(id, idx, owner, owner, lease)
    }

    /// Gives up `owner`'s lease on shard `idx` of job `id` (not done): free to claim again.
    pub fn release_shard(&self, id: JobId, idx: u32, owner: &str) -> Result<(), StoreError> {
        self.write(|c| {
            lock_job(c, id)?;
            c.exec(
                "UPDATE shards SET lease_owner = NULL, lease_until = NULL WHERE job_id = ?1 \
                 AND idx = ?2 AND lease_owner = ?3 AND done = 0",
                params![id, idx, owner],
            )?;
            Ok(((), Vec::new()))
        })
    }

    /// Whether `worker` still holds shard `idx` of job `id` (not done, its lease not taken).
    pub fn holds_shard(&self, id: JobId, idx: u32, worker: &str) -> Result<bool, StoreError> {
        self.read(|c| {
            let row = c.query_opt(
                "SELECT 1 FROM shards WHERE job_id = ?1 AND idx = ?2 AND lease_owner = ?3 \
                 AND done = 0",
                params![id, idx, worker],
            )?;
            Ok(row.is_some())
        })
    }

    /// Makes a done shard whose checkpoint turned out unusable (at the merge) render again,
    /// unless it was reopened `max` times already; returns how many times it has been reopened
    /// (this time included), or None when it is not reopened (left as it is, in one
    /// transaction: no worker can claim it before the caller fails the job).
    pub fn reopen_shard(&self, id: JobId, idx: u32, max: u32) -> Result<Option<u32>, StoreError> {
        self.write(|c| {
            lock_job(c, id)?;
            let rows = c.query(
                "UPDATE shards SET done = 0, progress = NULL, lease_owner = NULL, \
                 lease_until = NULL, reopened = reopened + 1 \
                 WHERE job_id = ?1 AND idx = ?2 AND reopened < ?3 RETURNING reopened",
                params![id, idx, max],
            )?;
            let times = match rows.first() {
                Some(r) => Some(r.i64(0)? as u32),
                None => None,
            };
            record_total(c, id)?;
            Ok((times, Vec::new()))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(json: &str) -> JobSettings {
        serde_json::from_str(json).unwrap()
    }

    const BASE: &str = r#""integrator": {"type": "nee"}, "seed": 0, "width": 4, "height": 4,
        "scene_max_depth": null, "exposure": 0.0, "tonemap": "clamp""#;

    /// Sample budgets above the shard size are cut into consecutive ranges covering every
    /// index once; small ones, time budgets and quality targets are not.
    #[test]
    fn plans_cover_every_sample_once() {
        let spp = |n: u32, extra: &str| settings(&format!("{{{BASE}, \"spp\": {n}{extra}}}"));
        assert_eq!(
            plan(&spp(10, ""), 4),
            vec![(0, 4), (4, 4), (8, 2)],
            "the last one shorter"
        );
        assert_eq!(plan(&spp(8, ""), 4), vec![(0, 4), (4, 4)]);
        assert!(plan(&spp(4, ""), 4).is_empty(), "one shard: whole");
        assert!(plan(&spp(100, ""), 0).is_empty(), "--shard-spp 0: never");
        assert!(plan(&spp(100, ", \"until_rel_mse\": 0.1"), 4).is_empty());
        assert!(plan(&spp(100, ", \"auto\": true"), 4).is_empty());
        let timed = settings(&format!("{{{BASE}, \"spp\": null, \"time_s\": 5.0}}"));
        assert!(plan(&timed, 4).is_empty(), "time budgets stay whole");
    }

    /// A fresh SQLite store in a temporary folder named after `tag`, holding one queued job of
    /// `spp` samples per pixel (id 1).
    fn store_with_job(tag: &str, spp: u32) -> (std::path::PathBuf, Store) {
        let dir = std::env::temp_dir().join(format!("{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let s = Store::open(&dir.join("candela.db")).unwrap();
        let json = format!("{{{BASE}, \"spp\": {spp}}}");
        s.read(|c| {
            c.exec(
                "INSERT INTO jobs (name, state, priority, settings, scene, source, created_at, \
                 updated_at) VALUES ('j', 'queued', 10, ?1, '{}', 'inline', 1, 1)",
                params![json],
            )
        })
        .unwrap();
        (dir, s)
    }

    /// Three workers split a 10 spp job into shards of 4: each claims one, a fourth gets
    /// nothing while they hold them; an expired shard goes to another worker; once every shard
    /// is done the next claim is the merge, and the job's progress is the shards' sum.
    #[test]
    fn shards_are_claimed_once_then_merged() {
        let (dir, s) = store_with_job("candela-shards", 10);
        let long = std::time::Duration::from_secs(60);
        let part = |w: &str, lease| {
            s.claim_job(w, lease, &[], 4, false)
                .unwrap()
                .map(|c| c.part)
        };
        let range = |idx, first, samples| ShardRange {
            idx,
            first,
            samples,
        };
        // Step 1: one shard each; none left for d.
        assert_eq!(
            part("a", long),
            Some(Part::Shard {
                range: range(0, 0, 4),
                count: 3
            })
        );
        assert_eq!(
            part("b", long),
            Some(Part::Shard {
                range: range(1, 4, 4),
                count: 3
            })
        );
        assert_eq!(
            part("c", long),
            Some(Part::Shard {
                range: range(2, 8, 2),
                count: 3
            })
        );
        assert_eq!(part("d", long), None);
        // (b's lease runs out: renewed for no time.)
        assert_eq!(
            s.renew_leases("b", &[1], std::time::Duration::ZERO)
                .unwrap(),
            vec![1]
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
        // Step 2: b's lease expired: d takes shard 1 over; b's report is refused.
        assert_eq!(
            part("d", long),
            Some(Part::Shard {
                range: range(1, 4, 4),
                count: 3
            })
        );
        assert_eq!(part("e", long), None);
        let p = |spp| Progress {
            spp,
            passes: 1,
            ..Default::default()
        };
        assert!(s.shard_done(1, 1, "b", &p(4)).unwrap().is_none(), "lost");
        assert!(s.renew_leases("b", &[1], long).unwrap().is_empty());
        assert_eq!(s.renew_leases("d", &[1], long).unwrap(), vec![1]);
        // Step 3: all done; the job's progress sums them; the next claim merges.
        assert_eq!(
            s.shard_checkpointed(1, 0, "a", &p(2)).unwrap().unwrap().spp,
            2
        );
        assert_eq!(s.shard_done(1, 0, "a", &p(4)).unwrap().unwrap().spp, 4);
        assert_eq!(s.shard_done(1, 1, "d", &p(4)).unwrap().unwrap().spp, 8);
        assert_eq!(part("e", long), None, "shard 2 is c's");
        assert_eq!(s.shard_done(1, 2, "c", &p(2)).unwrap().unwrap().spp, 10);
        assert_eq!(s.get_job(1).unwrap().progress.map(|p| p.spp), Some(10));
        assert_eq!(part("e", long), Some(Part::Merge { count: 3 }));
        assert_eq!(part("f", long), None, "the merge is e's");
        // A shard found unusable at the merge renders again (the times counted, up to a bound).
        assert_eq!(s.reopen_shard(1, 1, 3).unwrap(), Some(1));
        assert_eq!(
            part("f", long),
            Some(Part::Shard {
                range: range(1, 4, 4),
                count: 3
            })
        );
        // A shard is taken only while free: not another live worker's, not done.
        let take = |idx, w: &str, now| {
            s.read(|c| take_shard(c, 1, idx, w, now + 60.0, now))
                .unwrap()
        };
        let now = now_s();
        assert!(!take(1, "g", now), "f holds it");
        assert!(take(1, "f", now), "its own");
        assert!(take(1, "g", now + 120.0), "expired");
        assert!(!take(0, "g", now), "done");
        assert!(s.holds_shard(1, 1, "g").unwrap() && !s.holds_shard(1, 1, "f").unwrap());
        assert!(!s.holds_shard(1, 0, "a").unwrap(), "done: nobody's");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A shard whose file keeps coming out unusable is reopened at most `max` times; past that
    /// it is left as it is (the merge then fails the job).
    #[test]
    fn a_shard_is_reopened_a_bounded_number_of_times() {
        let (dir, s) = store_with_job("candela-shard-reopen", 10);
        let long = std::time::Duration::from_secs(60);
        assert!(
            s.claim_job("a", long, &[], 4, false).unwrap().is_some(),
            "the shards exist"
        );
        let times: Vec<_> = (0..4).map(|_| s.reopen_shard(1, 0, 3).unwrap()).collect();
        assert_eq!(times, [Some(1), Some(2), Some(3), None]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A finished shard handed to its writer's name (worker/shard_write.rs) is not the
    /// worker's to claim again nor another's while the write's lease lasts; a writer that dies
    /// leaves it, once the lease expires, to another worker, and its late report counts
    /// nothing; a failed write frees it at once.
    #[test]
    fn a_shard_being_written_is_claimed_again_only_when_its_writer_is_gone() {
        let (dir, s) = store_with_job("candela-shardw", 8);
        let long = std::time::Duration::from_secs(60);
        let part = |w: &str| s.claim_job(w, long, &[], 4, false).unwrap().map(|c| c.part);
        let idx = |p: Option<Part>| match p {
            Some(Part::Shard { range, .. }) => Some(range.idx),
            _ => None,
        };
        let p = Progress {
            spp: 4,
            passes: 1,
            ..Default::default()
        };
        // Step 1: a renders shard 0 and hands it to its writer; its next claim is shard 1,
        // and b gets nothing.
        assert_eq!(idx(part("a")), Some(0));
        assert!(s.hand_shard(1, 0, "a", "a#write", long).unwrap());
        assert!(
            !s.hand_shard(1, 0, "a", "a#write", long).unwrap(),
            "not a's now"
        );
        assert_eq!(idx(part("a")), Some(1), "not shard 0 again");
        assert_eq!(part("b"), None);
        // a's heartbeat (of shard 1) neither renews nor drops the writer's lease.
        assert_eq!(s.renew_leases("a", &[1], long).unwrap(), vec![1]);
        assert_eq!(part("b"), None, "shard 0 still being written");
        // Step 2: a writer slower than its lease keeps it when a's heartbeat renews it.
        let expire = || {
            assert!(s
                .hand_shard(1, 0, "a#write", "a#write", std::time::Duration::ZERO)
                .unwrap());
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        expire();
        assert!(s.renew_shard_lease(1, 0, "a#write", long).unwrap());
        assert_eq!(part("b"), None, "renewed: shard 0 still being written");
        // Step 3: the writer dies (its lease expires): b renders shard 0 again; the dead
        // writer's late renewal and report are refused, b's counts once.
        expire();
        assert_eq!(idx(part("b")), Some(0));
        assert!(!s.renew_shard_lease(1, 0, "a#write", long).unwrap());
        assert!(s.shard_done(1, 0, "a#write", &p).unwrap().is_none());
        assert_eq!(s.shard_done(1, 0, "b", &p).unwrap().unwrap().spp, 4);
        // Step 4: shard 1's write fails: freed for anyone at once.
        assert!(s.hand_shard(1, 1, "a", "a#write", long).unwrap());
        s.release_shard(1, 1, "a#write").unwrap();
        assert_eq!(idx(part("c")), Some(1));
        assert_eq!(s.shard_done(1, 1, "c", &p).unwrap().unwrap().spp, 8);
        assert_eq!(part("d"), Some(Part::Merge { count: 2 }));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
