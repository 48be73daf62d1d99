//! Helpers of the farm tests (tests/tests/server_farm*.rs): `candela worker` processes on a
//! test PostgreSQL store and the data directory of an API server, and what the store and the
//! data directory say of a farm's jobs (claims, shards, shard files).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use renderer::film::read_exr;
use renderer::metrics::rel_mse;
use serde_json::{json, Value};

use crate::database::{cluster, database_env};
use crate::server::Server;
use crate::{candela, repo_root};

/// A `candela worker` process, killed when dropped; its output goes to `<name>.log`.
pub struct Worker {
    child: Child,
    /// Its output: `<data>/../<name>.log`.
    pub log: PathBuf,
}

impl Worker {
    /// Starts worker `name` on `data`'s store and waits for its `rendering` line.
    pub fn start(data: &Path, name: &str, lease_s: &str) -> Worker {
        Worker::start_with(data, name, lease_s, &[])
    }

    /// [`Worker::start`] with more arguments.
    pub fn start_with(data: &Path, name: &str, lease_s: &str, extra: &[&str]) -> Worker {
        Worker::start_env(data, name, lease_s, extra, &[])
    }

    /// [`Worker::start_with`] with more environment variables.
    pub fn start_env(
        data: &Path,
        name: &str,
        lease_s: &str,
        extra: &[&str],
        env: &[(&str, &Path)],
    ) -> Worker {
        let w = Worker::spawn(data, name, lease_s, extra, env);
        w.wait_ready();
        w
    }

    /// [`Worker::start_env`] without waiting for the worker to be up.
    pub fn spawn(
        data: &Path,
        name: &str,
        lease_s: &str,
        extra: &[&str],
        env: &[(&str, &Path)],
    ) -> Worker {
        let log = data.parent().unwrap().join(format!("{name}.log"));
        let out = std::fs::File::create(&log).unwrap();
        let url = database_env(data).expect("a PostgreSQL database");
        let child = Command::new(candela())
            .arg("worker")
            .arg("--data-dir")
            .arg(data)
            .args(["--database", &url, "--worker-id", name, "--lease", lease_s])
            .args(["--pass-ms", "40", "--checkpoint-interval", "0.2"])
            .args(["--snapshot-interval", "0.2", "--max-active", "2"])
            .args(["--warm-kernels", "none"])
            .args(extra)
            .current_dir(repo_root())
            .env("CANDELA_LOG", "info")
            .envs(env.iter().copied())
            .stdin(Stdio::null())
            .stdout(out.try_clone().unwrap())
            .stderr(out)
            .spawn()
            .expect("start candela worker");
        Worker { child, log }
    }

    /// Waits (a minute at most) for the worker's start line.
    pub fn wait_ready(&self) {
        let deadline = Instant::now() + Duration::from_secs(60);
        while !self.log().contains("candela: worker") {
            assert!(
                Instant::now() < deadline,
                "{}:\n{}",
                self.log.display(),
                self.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    pub fn kill9(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Stops the process (SIGSTOP) where it stands: it writes nothing more until thawed.
    pub fn freeze(&self) {
        self.signal("-STOP");
    }

    /// Lets a frozen process go on (SIGCONT).
    pub fn thaw(&self) {
        self.signal("-CONT");
    }

    fn signal(&self, sig: &str) {
        let pid = self.child.id().to_string();
        let s = Command::new("kill").args([sig, &pid]).status();
        assert!(s.map(|s| s.success()).unwrap_or(false), "kill {sig} {pid}");
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        self.kill9();
    }
}

/// The rows of `sql` on `data`'s store, each as its fields.
pub fn psql(data: &Path, sql: &str) -> Vec<Vec<String>> {
    let url = database_env(data).unwrap();
    let o = Command::new(cluster().tool("psql"))
        .args([&url, "-At", "-F", "|", "-c", sql])
        .output()
        .expect("run psql");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| l.split('|').map(str::to_string).collect())
        .collect()
}

/// Every claim in the store's lease history: (job, worker, claimed_at), in claim order.
pub fn claims(data: &Path) -> Vec<(i64, String, f64)> {
    psql(
        data,
        "SELECT job_id, worker, claimed_at FROM leases ORDER BY claimed_at, job_id",
    )
    .into_iter()
    .map(|f| (f[0].parse().unwrap(), f[1].clone(), f[2].parse().unwrap()))
    .collect()
}

/// A job's `progress.spp`.
pub fn spp(job: &Value) -> u64 {
    job["progress"]["spp"].as_u64().unwrap_or(0)
}

/// Job `id`'s shards: (index, done, lease owner, spp checkpointed).
pub fn shards(data: &Path, id: i64) -> Vec<(u32, bool, String, u64)> {
    let sql = format!(
        "SELECT idx, done, COALESCE(lease_owner, ''), COALESCE(progress, '{{}}') FROM shards \
         WHERE job_id = {id} ORDER BY idx"
    );
    psql(data, &sql)
        .into_iter()
        .map(|f| {
            let p: Value = serde_json::from_str(&f[3]).unwrap();
            (
                f[0].parse().unwrap(),
                f[1] == "1",
                f[2].clone(),
                spp(&json!({ "progress": p })),
            )
        })
        .collect()
}

/// How many files `shard-*` (a shard's checkpoint, or a temporary one) job `id`'s folder holds.
pub fn shard_files(data: &Path, id: i64) -> usize {
    std::fs::read_dir(data.join(format!("jobs/{id}")))
        .map(|d| {
            d.filter(|e| {
                let name = e.as_ref().unwrap().file_name();
                let name = name.to_string_lossy();
                name.starts_with("shard-") || name.starts_with(".shard-")
            })
            .count()
        })
        .unwrap_or(0)
}

/// The relMSE of split job `split`'s image against job `body` rendered again whole, through
/// `api` on `data`, by a new worker (`whole`) that splits nothing: a split job's image equals
/// the whole render up to the order of float additions (< 1e-8).
pub fn rel_mse_to_whole(api: &Server, data: &Path, body: &Value, split: i64) -> f64 {
    let _one = Worker::start_with(data, "whole", "2", &["--shard-spp", "0"]);
    let whole = api.submit(body)["id"].as_i64().unwrap();
    let done = api.wait_job(whole, Duration::from_secs(180), |j| {
        matches!(j["state"].as_str(), Some("done" | "failed"))
    });
    assert_eq!(done["state"], "done", "{done}");
    assert!(shards(data, whole).is_empty(), "rendered whole");
    let image = |id: i64| read_exr(&data.join(format!("jobs/{id}/image.exr"))).unwrap();
    rel_mse(&image(split), &image(whole)).unwrap()
}
