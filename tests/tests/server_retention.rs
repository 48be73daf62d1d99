//! Retention against the real `candela serve`: `DELETE /api/jobs/{id}` of a finished job removes
//! its record, events and files (204), refuses an unfinished one (409, cancel first) and an
//! unknown one (404); a reference image goes with the last job naming it; event logs of finished
//! jobs are pruned to their final events; the server's periodic pass keeps `--retain-jobs`; and
//! `candela gc` does the same by hand (`--dry-run` changes nothing).

use std::path::Path;
use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{run_candela, scratch, text};
use reqwest::Method;
use serde_json::{json, Value};

// Each test runs on SQLite and on PostgreSQL (NAME::sqlite, NAME::postgres).
candela_tests::on_both_databases!(
    delete_removes_finished_jobs_only,
    retention_pass_and_gc_command,
    a_job_deleted_mid_pass_leaves_no_files
);

const T: Duration = Duration::from_secs(120);

/// A tiny job that ends quickly; `wait=true` answers once it is done.
fn quick(s: &Server, name: &str, extra: Value) -> i64 {
    let mut body =
        json!({"scene_name": "furnace", "spp": 8, "width": 8, "height": 8, "name": name});
    if let (Some(b), Some(e)) = (body.as_object_mut(), extra.as_object()) {
        b.extend(e.clone());
    }
    let (st, job) = s.post("/api/jobs?wait=true", &body);
    assert_eq!(
        (st, job["state"].as_str()),
        (201, Some("done")),
        "{job}\n{}",
        s.log()
    );
    job["id"].as_i64().unwrap()
}

fn delete(s: &Server, id: i64) -> (u16, Value) {
    s.send(s.request(Method::DELETE, &format!("/api/jobs/{id}")))
}

fn job_dir(data: &Path, id: i64) -> std::path::PathBuf {
    data.join("jobs").join(id.to_string())
}

/// Whether `dir` is gone within `limit`. A job canceled and deleted while the worker still
/// renders its last pass loses its folder when the worker lets go of it (worker `retire`), which
/// may come a moment after the DELETE answered.
fn gone_within(dir: &Path, limit: Duration) -> bool {
    let start = std::time::Instant::now();
    while dir.exists() {
        if start.elapsed() > limit {
            return false;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    true
}

fn files_in(dir: &Path) -> usize {
    std::fs::read_dir(dir).map(|d| d.count()).unwrap_or(0)
}

fn delete_removes_finished_jobs_only() {
    let dir = scratch("server_retention_delete");
    let data = dir.join("data");
    let s = Server::start(
        &data,
        &[
            "--max-active",
            "1",
            "--snapshot-interval",
            "0.05",
            "--prune-events-after",
            "0",
            "--gc-interval",
            "1s",
        ],
    );
    // A done job with an image on disk, and one naming it as its reference (a copy under
    // references/).
    let a = quick(&s, "a", json!({}));
    assert!(job_dir(&data, a).join("image.exr").is_file());
    // (A second of rendering: many progress events before pruning.)
    let (st, job) = s.post(
        "/api/jobs?wait=true",
        &json!({"scene_name": "furnace", "time_s": 1.0, "width": 8, "height": 8, "name": "b",
                "reference": {"job": a}}),
    );
    assert_eq!((st, job["state"].as_str()), (201, Some("done")), "{job}");
    let b = job["id"].as_i64().unwrap();
    assert_eq!(files_in(&data.join("references")), 1);

    // Event logs of finished jobs are pruned to the last progress and snapshot (the full log,
    // Last-Event-ID 0, not the compacted replay); the state
    // changes and `done` stay.
    let pruned = |id: i64| {
        let ev = s.events(id, Some(0)).collect_all();
        let n = |k: &str| ev.iter().filter(|e| e.event == k).count();
        (n("progress"), n("snapshot"), n("done"), n("state"))
    };
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while pruned(b).0 > 1 && std::time::Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(200));
    }
    let (progress, snapshot, done, states) = pruned(b);
    assert_eq!((progress, snapshot, done), (1, 1, 1), "{}", s.log());
    assert!(states >= 3, "queued, running, done: {states}");

    // Unfinished: 409, saying to cancel first; unknown: 404.
    let long = s.submit(&json!({"scene_name": "furnace", "time_s": 300, "width": 8, "height": 8}))
        ["id"]
        .as_i64()
        .unwrap();
    let (st, e) = delete(&s, long);
    assert_eq!(st, 409, "{e}");
    assert_eq!(e["error"]["code"], "conflict");
    assert!(
        e["error"]["message"].as_str().unwrap().contains("cancel"),
        "{e}"
    );
    assert_eq!(delete(&s, 99_999).0, 404);

    // Finished: 204, then gone from the API, the list and the disk; its reference copy too.
    let (st, _) = delete(&s, b);
    assert_eq!(st, 204);
    assert_eq!(s.get(&format!("/api/jobs/{b}")).0, 404);
    assert_eq!(delete(&s, b).0, 404);
    assert!(!job_dir(&data, b).exists());
    assert_eq!(
        files_in(&data.join("references")),
        0,
        "the reference copy goes with its job"
    );
    let (_, list) = s.get("/api/jobs");
    let ids: Vec<i64> = list["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["id"].as_i64().unwrap())
        .collect();
    assert!(!ids.contains(&b) && ids.contains(&a), "{ids:?}");
    assert_eq!(delete(&s, a).0, 204);
    assert!(!job_dir(&data, a).exists());

    // Cancel (POST .../cancel), then delete.
    let (st, j) = s.post(&format!("/api/jobs/{long}/cancel"), &json!({}));
    assert_eq!((st, j["state"].as_str()), (200, Some("canceled")), "{j}");
    assert_eq!(delete(&s, long).0, 204);
    assert!(gone_within(&job_dir(&data, long), Duration::from_secs(20)));
}

fn retention_pass_and_gc_command() {
    let dir = scratch("server_retention_gc");
    let data = dir.join("data");
    let data_s = data.to_string_lossy().into_owned();
    // The server's periodic pass keeps the newest finished job.
    let mut s = Server::start(&data, &["--retain-jobs", "1", "--gc-interval", "1s"]);
    let first = quick(&s, "first", json!({}));
    let second = quick(&s, "second", json!({}));
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while s.get(&format!("/api/jobs/{first}")).0 != 404 {
        assert!(
            std::time::Instant::now() < deadline,
            "retention never removed job {first}\n{}",
            s.log()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    assert!(!job_dir(&data, first).exists());
    assert_eq!(s.job(second)["state"], "done");
    s.terminate(T);

    // Three more finished jobs under a server that keeps everything, its event logs included;
    // the last one renders for a second, with many progress events.
    let mut s = Server::start(
        &data,
        &[
            "--retain-jobs",
            "0",
            "--retain-age",
            "0",
            "--retain-size",
            "0",
            "--prune-events-after",
            "30d",
            "--snapshot-interval",
            "0.1",
        ],
    );
    let mut ids: Vec<i64> = (0..2)
        .map(|i| quick(&s, &format!("j{i}"), json!({})))
        .collect();
    let timed = json!({"scene_name": "furnace", "time_s": 1.0, "width": 8, "height": 8});
    let (st, job) = s.post("/api/jobs?wait=true", &timed);
    assert_eq!((st, job["state"].as_str()), (201, Some("done")), "{job}");
    ids.push(job["id"].as_i64().unwrap());
    let kinds = |s: &Server, id: i64, kind: &str| {
        s.events(id, Some(0))
            .collect_all()
            .iter()
            .filter(|e| e.event == kind)
            .count()
    };
    let progress_before = kinds(&s, ids[2], "progress");
    assert!(progress_before >= 3, "{progress_before} progress events");
    s.terminate(T);

    // A folder no job owns, old enough to be an orphan rather than a submission in progress.
    let orphan = job_dir(&data, 777);
    std::fs::create_dir_all(&orphan).unwrap();
    std::fs::write(orphan.join("image.exr"), b"x").unwrap();
    let old = std::time::SystemTime::now() - Duration::from_secs(3600);
    std::fs::File::open(&orphan)
        .unwrap()
        .set_modified(old)
        .unwrap();

    // Dry run: says what would go, removes nothing.
    let o = run_candela(&["gc", "--data", &data_s, "--keep", "2", "--dry-run"]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{out}{}", text(&o.stderr));
    for gone in [second, ids[0]] {
        assert!(out.contains(&format!("would remove job {gone} ")), "{out}");
    }
    assert!(!out.contains(&format!("job {} ", ids[1])), "{out}");
    assert!(out.contains("777"), "{out}");
    assert!(job_dir(&data, second).exists() && orphan.exists());

    // For real.
    let o = run_candela(&["gc", "--data", &data_s, "--keep", "2"]);
    let out = text(&o.stdout);
    assert!(o.status.success(), "{out}{}", text(&o.stderr));
    assert!(out.contains(&format!("removed job {second} ")), "{out}");
    assert!(!job_dir(&data, second).exists() && !job_dir(&data, ids[0]).exists());
    assert!(!orphan.exists());
    assert!(job_dir(&data, ids[1]).exists() && job_dir(&data, ids[2]).exists());
    let pruned: u64 = out
        .lines()
        .find_map(|l| l.strip_prefix("pruned ")?.split(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("{out}"));
    assert!(pruned as usize >= progress_before - 1, "{out}");

    // Age: nothing finished 7 days ago.
    let o = run_candela(&["gc", "--data", &data_s, "--older-than", "7d"]);
    assert!(text(&o.stdout).contains("0 job(s)"), "{}", text(&o.stdout));
    // A directory that is not a data directory: bad input.
    let o = run_candela(&["gc", "--data", &dir.join("nothing").to_string_lossy()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));

    // The server sees what gc left.
    let s = Server::start(&data, &[]);
    let (_, list) = s.get("/api/jobs");
    let left: Vec<i64> = list["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["id"].as_i64().unwrap())
        .collect();
    assert_eq!(left, vec![ids[2], ids[1]]);
    // Its event log keeps how it ended: the last progress and snapshot, the done.
    for (kind, n) in [("progress", 1), ("snapshot", 1), ("done", 1)] {
        assert_eq!(
            kinds(&s, ids[2], kind),
            n,
            "{kind} events of job {}",
            ids[2]
        );
    }
}

/// Canceled and deleted while the worker is still inside the job's (long) pass: the checkpoint
/// and image the worker writes when that pass completes must not outlive the job (bench/soak.py
/// found such an orphaned folder).
fn a_job_deleted_mid_pass_leaves_no_files() {
    let dir = scratch("server_retention_mid_pass");
    let data = dir.join("data");
    let s = Server::start(&data, &["--checkpoint-interval", "0.1"]);
    // One sample per pixel of a 256² Cornell box: over a second on lavapipe.
    let job = s.submit(&json!({"scene_name": "cornell", "spp": 1000, "width": 256, "height": 256}));
    let id = job["id"].as_i64().unwrap();
    s.wait_job(id, T, |j| j["state"] == "running");
    std::thread::sleep(Duration::from_millis(200));
    let (st, _) = s.send(s.request(Method::POST, &format!("/api/jobs/{id}/cancel")));
    assert_eq!(st, 200);
    assert_eq!(delete(&s, id).0, 204);
    // The worker lets go of it once the pass completes.
    let deadline = std::time::Instant::now() + T;
    while !s.log().contains("deleted while the worker held it") {
        assert!(std::time::Instant::now() < deadline, "{}", s.log());
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(!job_dir(&data, id).exists(), "{}", s.log());
}
