//! Render leases: which worker renders a job, so that several processes sharing one database
//! (`candela worker`, `candela serve`) never render the same job at once. A worker claims a
//! runnable job (queued, or running with no live lease) in one transaction — on PostgreSQL the
//! candidate row is picked with `FOR UPDATE SKIP LOCKED`, so concurrent claims take different
//! jobs; on SQLite the write transaction is serialised anyway — and stamps it with its id and an
//! expiry. It renews the expiry by heartbeats while it renders; a worker that dies stops
//! renewing, the lease expires, and another worker claims the job and resumes it from its
//! checkpoint. A worker whose renewal finds the lease gone (expired and taken) stops rendering
//! that job. Every claim is recorded in `leases` (job, worker, time, shard). A job split into
//! shards (shards.rs) is leased shard by shard, on the `shards` rows, and its final merge on the
//! job's row; a worker holds at most one part of a job, so both are renewed by job id.

use std::time::Duration;

use super::db::{params, Dialect};
use super::shards::{claim_part, Claim};
use super::{Store, StoreError};
use crate::jobs::model::{now_s, JobId, JobState};

/// Claims tried when each finds a claimable job's row locked, and the wait between two.
const CLAIM_TRIES: u32 = 20;
const CLAIM_RETRY: Duration = Duration::from_millis(2);

/// `id, id, …` for an `IN (…)` list (ids are integers: nothing to quote); `-1` when empty.
fn id_list(ids: &[JobId]) -> String {
    if ids.is_empty() {
        return "-1".into();
    }
    ids.iter()
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

impl Store {
    /// Claims the next runnable job (or shard of one, store/shards.rs) for `worker` for
    /// `lease`: running before queued, then by priority (highest first), then oldest first; a
    /// job or shard only when its lease expired or is `worker`'s own. `exclude`: jobs the
    /// worker already holds. `shard_spp`: how this worker splits a job it claims first (0:
    /// never). `patient` (a worker with nothing to render): a claim that passed a locked row by
    /// while claimable work was there (PostgreSQL's `SKIP LOCKED`) tries again 2 ms later, up
    /// to 20 times. Shard hand-offs, done marks and other claims lock a split job's row for a
    /// few milliseconds; the devices of a farm sharing one job could otherwise meet it locked
    /// and idle until their next look (not measured on its own: bench/RESULTS.md). (A worker
    /// still rendering claims once: its loop must not wait.)
    pub fn claim_job(
        &self,
        worker: &str,
        lease: Duration,
        exclude: &[JobId],
        shard_spp: u32,
        patient: bool,
    ) -> Result<Option<Claim>, StoreError> {
        let tries = if patient { CLAIM_TRIES } else { 1 };
        for t in 1..=tries {
            match self.claim_once(worker, lease, exclude, shard_spp)? {
                (None, true) if t < tries => std::thread::sleep(CLAIM_RETRY),
                (claim, _) => return Ok(claim),
            }
        }
        Ok(None)
    }

    /// One claim's transaction: the claim, and whether a claimable job was passed by because
    /// its row was locked (PostgreSQL's `SKIP LOCKED`).
    fn claim_once(
        &self,
        worker: &str,
        lease: Duration,
        exclude: &[JobId],
        shard_spp: u32,
    ) -> Result<(Option<Claim>, bool), StoreError> {
        let now = now_s();
        self.write(|c| {
            let free = "(j.lease_owner IS NULL OR j.lease_owner = ?1 OR j.lease_until < ?2)";
            let pick = format!(
                "SELECT id, state, priority, shard_count, settings, started_at FROM jobs j \
                 WHERE state IN ('queued', 'running') AND id NOT IN ({}) AND ( \
                 (shard_count = 0 AND {free}) \
                 OR (shard_count > 0 AND EXISTS (SELECT 1 FROM shards s WHERE s.job_id = j.id \
                     AND s.done = 0 AND (s.lease_owner IS NULL OR s.lease_owner = ?1 \
                     OR s.lease_until < ?2))) \
                 OR (shard_count > 0 AND {free} AND NOT EXISTS (SELECT 1 FROM shards s \
                     WHERE s.job_id = j.id AND s.done = 0))) \
                 ORDER BY state = 'running' DESC, priority DESC, id ASC LIMIT 1",
                id_list(exclude),
            );
            let locking = format!("{pick}{}", c.dialect().skip_locked());
            let Some(row) = c.query_opt(&locking, params![worker, now])? else {
                // (Without the lock clause: what a locked row hid.)
                let skipped = c.dialect() == Dialect::Postgres
                    && c.query_opt(&pick, params![worker, now])?.is_some();
                return Ok(((None, skipped), Vec::new()));
            };
            let id = row.i64(0)?;
            let state = JobState::parse(&row.text(1)?).unwrap_or(JobState::Queued);
            let priority = u32::try_from(row.i64(2)?).unwrap_or(1);
            let until = now + lease.as_secs_f64();
            let part = claim_part(c, &row, worker, until, shard_spp)?;
            let claim = part.map(|part| Claim {
                id,
                state,
                priority,
                part,
            });
            Ok(((claim, false), Vec::new()))
        })
    }

    /// The heartbeat: extends `worker`'s leases on `held` (whole jobs, merges and shards) by
    /// `lease` and gives up its leases on every other job; returns the jobs of `held` whose lease it still has (the others were
    /// taken over after expiring: stop rendering them).
    pub fn renew_leases(
        &self,
        worker: &str,
        held: &[JobId],
        lease: Duration,
    ) -> Result<Vec<JobId>, StoreError> {
        let list = id_list(held);
        self.write(|c| {
            let until = now_s() + lease.as_secs_f64();
            let mut kept: Vec<JobId> = Vec::new();
            // Whole jobs (and merges) on the job's row, shards on theirs.
            for table in ["jobs", "shards"] {
                let key = if table == "jobs" { "id" } else { "job_id" };
                c.exec(
                    &format!(
                        "UPDATE {table} SET lease_owner = NULL, lease_until = NULL \
                         WHERE lease_owner = ?1 AND {key} NOT IN ({list})"
                    ),
                    params![worker],
                )?;
                let rows = c.query(
                    &format!(
                        "UPDATE {table} SET lease_until = ?2 WHERE lease_owner = ?1 \
                         AND {key} IN ({list}) RETURNING {key}"
                    ),
                    params![worker, until],
                )?;
                for r in rows {
                    kept.push(r.i64(0)?);
                }
            }
            Ok((kept, Vec::new()))
        })
    }

    /// Drops every lease (a process that alone uses the store, at its start: a SQLite server).
    pub fn clear_leases(&self) -> Result<(), StoreError> {
        self.read(|c| {
            c.batch(
                "UPDATE jobs SET lease_owner = NULL, lease_until = NULL \
                 WHERE lease_owner IS NOT NULL; \
                 UPDATE shards SET lease_owner = NULL, lease_until = NULL \
                 WHERE lease_owner IS NOT NULL;",
            )
        })?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh SQLite store with jobs 1 (queued, priority 10), 2 (queued, priority 20) and 3
    /// (done).
    fn store(name: &str) -> (Store, std::path::PathBuf) {
        let dir = std::env::temp_dir().join(format!("candela-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let store = Store::open(&dir.join("candela.db")).unwrap();
        let row = |state: &str, priority: u32| {
            format!(
                "INSERT INTO jobs (name, state, priority, settings, scene, source, created_at, \
                 updated_at) VALUES ('j', '{state}', {priority}, '{{}}', '{{}}', 'inline', 1, 1);"
            )
        };
        let sql = [row("queued", 10), row("queued", 20), row("done", 30)].concat();
        store.read(|c| c.batch(&sql)).unwrap();
        (store, dir)
    }

    /// Claims go by priority, never to a job another worker holds while its lease lives, and
    /// to another worker once it expired; the old holder's heartbeat then finds it lost.
    #[test]
    fn claims_exclude_live_leases_and_take_over_expired_ones() {
        let (s, dir) = store("leases");
        let long = Duration::from_secs(60);
        // Step 1: the higher priority first; held jobs are not claimed twice.
        assert_eq!(
            s.claim_job("a", long, &[], 0, false).unwrap().map(|c| c.id),
            Some(2)
        );
        assert_eq!(
            s.claim_job("b", long, &[], 0, false).unwrap().map(|c| c.id),
            Some(1)
        );
        assert_eq!(
            s.claim_job("c", long, &[], 0, false).unwrap(),
            None,
            "done or held"
        );
        // Step 2: a's lease on 2 expires (renewed with a zero lease); c takes it over.
        assert_eq!(s.renew_leases("a", &[2], Duration::ZERO).unwrap(), vec![2]);
        std::thread::sleep(Duration::from_millis(20));
        assert_eq!(
            s.claim_job("c", long, &[], 0, false).unwrap().map(|c| c.id),
            Some(2)
        );
        assert!(s.renew_leases("a", &[2], long).unwrap().is_empty(), "lost");
        assert_eq!(s.renew_leases("c", &[2], long).unwrap(), vec![2]);
        // Step 3: b gives up 1 (a heartbeat without it); a may claim it, and exclude it.
        assert!(s.renew_leases("b", &[], long).unwrap().is_empty());
        assert_eq!(s.claim_job("a", long, &[1], 0, false).unwrap(), None);
        assert_eq!(
            s.claim_job("a", long, &[], 0, false).unwrap().map(|c| c.id),
            Some(1)
        );
        // Every claim is in the history.
        let n = s
            .read(|c| c.query_one("SELECT COUNT(*) FROM leases", &[]))
            .unwrap()
            .i64(0)
            .unwrap();
        assert_eq!(n, 4);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
