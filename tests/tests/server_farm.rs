//! A render farm on one PostgreSQL store, against the real binaries: an API server that renders
//! nothing (`candela serve --workers 0`) and `candela worker` processes sharing its database and
//! data directory. Jobs submitted to the API are rendered by the workers, each by one worker
//! (the `leases` table records every claim), to exactly their sample count; their events reach
//! the API server's SSE clients live (LISTEN/NOTIFY); and a worker killed mid-job (SIGKILL) has its job taken
//! over, once its lease expires, by the other worker, which resumes it from its checkpoint. A
//! SQLite server cannot share the farm's data directory. A job split into shards
//! (`--shard-spp`) is rendered by three workers at once, three times one of them killed
//! mid-shard and replaced by a new one, and comes out with exactly its samples and the image
//! one worker renders of it whole; a worker killed after a shard's final checkpoint was written
//! but before the shard was marked done (held there by a test hook) has it counted once, by the
//! worker that takes it over, and a worker waiting for its held writes keeps every lease; a
//! worker with `--devices 0,0` claims shards on both its contexts, under two names, each reported by
//! the API server (`/api/workers`, `/metrics`, with its process's memory) until it is lost; a split job paused and resumed
//! ends with exactly its samples, and one canceled leaves no shard files.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use candela_tests::database::{run_on, Backend};
use candela_tests::farm::{claims, psql, rel_mse_to_whole, shard_files, shards, spp, Worker};
use candela_tests::server::Server;
use candela_tests::{candela, scratch};
use serde_json::{json, Value};

const T: Duration = Duration::from_secs(180);

/// The farm runs on PostgreSQL only (SQLite is one process's store).
#[test]
fn two_workers_share_the_jobs() {
    run_on(Backend::Postgres, two_workers_share_the_jobs_on_postgres)
}

#[test]
fn three_workers_split_one_job() {
    run_on(Backend::Postgres, three_workers_split_one_job_on_postgres)
}

#[test]
fn a_worker_killed_while_writing_a_shard_counts_it_once() {
    run_on(
        Backend::Postgres,
        a_worker_killed_while_writing_a_shard_counts_it_once_on_postgres,
    )
}

#[test]
fn a_worker_waiting_for_its_writes_keeps_its_leases() {
    run_on(
        Backend::Postgres,
        a_worker_waiting_for_its_writes_keeps_its_leases_on_postgres,
    )
}

#[test]
fn one_worker_renders_on_two_devices() {
    run_on(
        Backend::Postgres,
        one_worker_renders_on_two_devices_on_postgres,
    )
}

#[test]
fn a_killed_workers_job_is_taken_over() {
    run_on(
        Backend::Postgres,
        a_killed_workers_job_is_taken_over_on_postgres,
    )
}

fn two_workers_share_the_jobs_on_postgres() {
    let dir = scratch("server_farm_two");
    let data = dir.join("data");
    // (The relay's fallback poll a minute: the events reach the stream by LISTEN/NOTIFY.)
    let api = Server::start_with_env(
        &data,
        &["--workers", "0"],
        &[("CANDELA_EVENT_POLL_S", "60")],
    );
    let workers = [
        Worker::start(&data, "w1", "6"),
        Worker::start(&data, "w2", "6"),
    ];
    // The API server alone is healthy: it renders nothing by design.
    let (_, health) = api.get("/api/health");
    assert_eq!(
        (health["status"].as_str(), health["gpu"]["state"].as_str()),
        (Some("ok"), Some("none")),
        "{health}"
    );
    // A SQLite server cannot join the farm's data directory; a worker needs PostgreSQL.
    let sqlite = format!("sqlite://{}", dir.join("other.db").display());
    let run = |cmd: &str| {
        Command::new(candela())
            .arg(cmd)
            .arg("--data-dir")
            .arg(&data)
            .args(["--database", &sqlite, "--bind", "127.0.0.1:0"])
            .env_remove("CANDELA_DATABASE")
            .output()
            .expect("run candela")
    };
    let o = run("serve");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("another candela server is using it"), "{err}");
    let o = Command::new(candela())
        .args(["serve", "--workers", "0", "--data-dir"])
        .arg(dir.join("alone"))
        .env_remove("CANDELA_DATABASE")
        .output()
        .expect("run candela");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--workers 0"), "{err}");
    let o = run("worker");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("postgres://"), "{err}");
    // Step 1: six small jobs; the first one's events followed live from its submission.
    let mut ids: Vec<(i64, u64)> = Vec::new();
    let mut stream = None;
    for i in 0..6u64 {
        let spp = 20 + i;
        let job = api.submit(&json!({"scene_name": "furnace", "spp": spp,
                                     "width": 16, "height": 16, "seed": i}));
        ids.push((job["id"].as_i64().unwrap(), spp));
        if i == 0 {
            stream = Some(api.events(ids[0].0, Some(0)));
        }
    }
    let mut stream = stream.unwrap();
    // Step 2: all complete, each with exactly its samples.
    for (id, want) in &ids {
        let done = api.wait_job(*id, T, |j| {
            matches!(j["state"].as_str(), Some("done" | "failed"))
        });
        assert_eq!(
            done["state"],
            "done",
            "{done}\n{}\n{}",
            workers[0].log(),
            workers[1].log()
        );
        assert_eq!(spp(&done), *want, "{done}");
        assert_eq!(done["stats"]["spp"], *want, "{done}");
    }
    // Step 3: the API server streamed the worker's events: dense ids, through to `done`,
    // notified at once (not at the minute's poll).
    let t = Instant::now();
    let events = stream.collect_all();
    assert!(
        t.elapsed() < Duration::from_secs(10),
        "{:?}: not notified",
        t.elapsed()
    );
    let seqs: Vec<i64> = events.iter().map(|e| e.id.unwrap()).collect();
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    assert_eq!(events.last().unwrap().event, "done", "{events:?}");
    assert!(events.iter().any(|e| e.event == "progress"), "{events:?}");
    // Step 4: each job was claimed by one worker only, and both workers rendered.
    let mut by_job: BTreeMap<i64, BTreeSet<String>> = BTreeMap::new();
    for (job, worker, _) in claims(&data) {
        by_job.entry(job).or_default().insert(worker);
    }
    assert_eq!(by_job.len(), ids.len(), "{by_job:?}");
    assert!(by_job.values().all(|w| w.len() == 1), "{by_job:?}");
    let used: BTreeSet<&String> = by_job.values().flatten().collect();
    assert_eq!(used.len(), 2, "{by_job:?}");
}

fn a_killed_workers_job_is_taken_over_on_postgres() {
    let dir = scratch("server_farm_kill");
    let data = dir.join("data");
    let api = Server::start(&data, &["--workers", "0"]);
    let mut w1 = Worker::start(&data, "w1", "2");
    let total = 1200u64;
    let job = api.submit(&json!({"scene_name": "cornell", "spp": total,
                                 "width": 16, "height": 16, "seed": 3}));
    let id = job["id"].as_i64().unwrap();
    // Step 1: w1 renders it past a checkpoint; then w2 joins and w1 dies.
    let ckpt = data.join(format!("jobs/{id}/checkpoint.bin"));
    let before = api.wait_job(id, T, |j| spp(j) >= 20 && ckpt.exists());
    assert!(spp(&before) < total, "finished before the kill: {before}");
    let w2 = Worker::start(&data, "w2", "2");
    w1.kill9();
    // Step 2: w2 takes it over from the checkpoint and finishes it, exactly.
    let done = api.wait_job(id, T, |j| {
        matches!(j["state"].as_str(), Some("done" | "failed"))
    });
    assert_eq!(done["state"], "done", "{done}\n{}", w2.log());
    assert_eq!(spp(&done), total, "{done}");
    assert_eq!(done["stats"]["spp"], total, "{done}");
    assert!(w2.log().contains("resumed from checkpoint"), "{}", w2.log());
    // Step 3: the lease history: w1, then w2 only after w1's claim.
    let c = claims(&data);
    let who: Vec<&str> = c.iter().map(|(_, w, _)| w.as_str()).collect();
    assert_eq!(who.first(), Some(&"w1"), "{c:?}");
    assert_eq!(who.last(), Some(&"w2"), "{c:?}");
    assert!(
        c.iter().all(|(j, _, _)| *j == id),
        "only the one job: {c:?}"
    );
}

fn three_workers_split_one_job_on_postgres() {
    let dir = scratch("server_farm_split");
    let data = dir.join("data");
    let api = Server::start(&data, &["--workers", "0"]);
    let split = ["--shard-spp", "100"];
    let start = |n: &str| Worker::start_with(&data, n, "2", &split);
    let mut workers: Vec<Worker> = ["w1", "w2", "w3"].map(start).into();
    let logs = |ws: &[Worker]| ws.iter().map(|w| w.log()).collect::<Vec<_>>().join("\n");
    // Step 1: a job of 16 shards. Three times, a worker holding a checkpointed shard dies
    // (SIGKILL) before finishing it, and a new worker takes its place.
    // (Shards of about a second each on lavapipe, five checkpoint intervals.)
    let (total, seed, kills) = (1600u64, 11, 3);
    let body = json!({"scene_name": "cornell", "spp": total, "width": 24, "height": 24,
                      "seed": seed});
    let id = api.submit(&body)["id"].as_i64().unwrap();
    let deadline = Instant::now() + T;
    let name = |w: &Worker| w.log.file_stem().unwrap().to_string_lossy().into_owned();
    // (Who was killed, holding which shard, at what spp; their processes, for their logs.)
    let (mut victims, mut dead): (Vec<(String, u32, u64)>, Vec<Worker>) = (vec![], vec![]);
    while victims.len() < kills {
        // (The claims first, then the shards: the rows a victim is chosen by are the
        // freshest.)
        let claimers: BTreeSet<String> = claims(&data).into_iter().map(|c| c.1).collect();
        let rows = shards(&data, id);
        assert!(
            Instant::now() < deadline && (rows.is_empty() || !rows.iter().all(|r| r.1)),
            "{victims:?} {rows:?}\n{}",
            logs(&workers)
        );
        // (A shard being rendered by a live worker, not by one killed before whose lease has
        // not run out yet, and not taken over before, so that a checkpoint is the holder's
        // own, not one it has claimed but perhaps not resumed yet.)
        let alive = |owner: &str| workers.iter().any(|w| name(w) == owner);
        let fresh = |idx: u32| !victims.iter().any(|v| v.1 == idx);
        let held = rows
            .iter()
            .filter(|r| !r.1 && alive(&r.2) && fresh(r.0))
            .max_by_key(|r| r.3);
        if let (true, Some(r)) = (claimers.len() >= 3, held) {
            // Its holder is frozen, then the shard read again once a commit it had sent has
            // landed: killed if it has checkpointed the shard and not finished it, else let
            // go on. (The reads are slow on a loaded machine, the shards quick: frozen, it
            // cannot finish between the read and the kill.)
            let at = workers.iter().position(|w| name(w) == r.2).unwrap();
            workers[at].freeze();
            std::thread::sleep(Duration::from_millis(200));
            let now = shards(&data, id).into_iter().find(|s| s.0 == r.0);
            match now {
                Some(s) if !s.1 && s.2 == r.2 && s.3 > 0 => {
                    let mut victim = workers.remove(at);
                    victim.kill9();
                    victims.push((s.2, s.0, s.3));
                    dead.push(victim);
                    // (Not waited for: the others render on meanwhile.)
                    let name = format!("w{}", 3 + dead.len());
                    workers.push(Worker::spawn(&data, &name, "2", &split, &[]));
                }
                _ => workers[at].thaw(),
            }
            continue;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    eprintln!("killed (worker, shard, spp checkpointed): {victims:?}");
    // Step 2: the others finish every shard (the victims' from their checkpoints) and merge
    // them: exactly the job's samples, no shard counted twice or lost.
    let done = api.wait_job(id, T, |j| {
        matches!(j["state"].as_str(), Some("done" | "failed"))
    });
    // (Every worker's log, the victims' too.)
    let logs = |ws: &[Worker]| logs(ws) + "\n" + &logs(&dead);
    assert_eq!(done["state"], "done", "{done}\n{}", logs(&workers));
    assert_eq!(spp(&done), total, "{done}");
    assert_eq!(done["stats"]["spp"], total, "{done}");
    let rows = shards(&data, id);
    assert_eq!(rows.len(), 16, "{rows:?}");
    assert!(
        rows.iter().all(|r| r.1 && r.3 == 100),
        "every shard whole: {rows:?}"
    );
    let c = claims(&data);
    let by: BTreeSet<&str> = c.iter().map(|(_, w, _)| w.as_str()).collect();
    assert!(by.len() >= 4, "the three and a replacement rendered: {c:?}");
    // Each victim's shard was claimed again after the kill and resumed from its checkpoint.
    for (victim, shard, at) in &victims {
        let sql = format!(
            "SELECT worker FROM leases WHERE job_id = {id} AND shard = {shard} ORDER BY claimed_at"
        );
        let by = psql(&data, &sql);
        let by: Vec<&str> = by.iter().map(|f| f[0].as_str()).collect();
        assert!(
            by.contains(&victim.as_str()) && by.last() != Some(&victim.as_str()),
            "shard {shard} ({victim} killed at {at} spp): {by:?}"
        );
    }
    let resumed = logs(&workers).matches("resumed from checkpoint").count();
    assert!(resumed >= kills, "{resumed} resumes\n{}", logs(&workers));
    // A worker's next shard of the job reuses its session (no scene loaded again).
    let reused = "reusing the session of the job's last shard";
    assert!(logs(&workers).contains(reused), "{}", logs(&workers));
    assert_eq!(
        shard_files(&data, id),
        0,
        "the shards' checkpoints are removed at the end"
    );
    // Step 3: one worker, splitting nothing, renders the same job whole: the same image.
    drop(workers);
    let e = rel_mse_to_whole(&api, &data, &body, id);
    assert!(e < 1e-8, "split vs whole relMSE {e}");
}

/// An API server on a fresh data directory and a worker `w1` (lease 2 s, shards of 20 spp)
/// whose shard writes the test hook holds before they are marked done while the returned
/// `hold` file exists: (data dir, API server, hold file, w1).
fn farm_with_held_writes(tag: &str) -> (PathBuf, Server, PathBuf, Worker) {
    let dir = scratch(tag);
    let data = dir.join("data");
    let api = Server::start(&data, &["--workers", "0"]);
    let hold = dir.join("hold");
    std::fs::write(&hold, b"").unwrap();
    let env = [("CANDELA_TEST_SHARD_WRITE_HOLD_FILE", hold.as_path())];
    let w1 = Worker::start_env(&data, "w1", "2", &["--shard-spp", "20"], &env);
    (data, api, hold, w1)
}

/// A shard's final checkpoint is written off the render thread, and the shard marked done only
/// after (worker/shard_write.rs): a worker killed between the two (held there by the test
/// hook) leaves the shard to another worker once the writer's lease expires, and the job ends
/// with exactly its samples.
fn a_worker_killed_while_writing_a_shard_counts_it_once_on_postgres() {
    let (data, api, _hold, mut w1) = farm_with_held_writes("server_farm_write_kill");
    let split = ["--shard-spp", "20"];
    let total = 60u64;
    let body = json!({"scene_name": "cornell", "spp": total, "width": 16, "height": 16,
                      "seed": 5});
    let id = api.submit(&body)["id"].as_i64().unwrap();
    // Step 1: w1's first shard is on disk, held by its writer, not done: w1 dies.
    let deadline = Instant::now() + T;
    // (The lease is handed before the writer starts, and the hook logs after the fsync: wait
    // for both.)
    while !(shards(&data, id).iter().any(|r| r.2 == "w1#write")
        && w1.log().contains("held before done (test hook)"))
    {
        assert!(Instant::now() < deadline, "{}", w1.log());
        std::thread::sleep(Duration::from_millis(20));
    }
    w1.kill9();
    let rows = shards(&data, id);
    assert!(rows.iter().all(|r| !r.1), "none done yet: {rows:?}");
    // Step 2: w2 takes every shard over once the leases expire and finishes the job.
    let w2 = Worker::start_with(&data, "w2", "2", &split);
    let done = api.wait_job(id, T, |j| {
        matches!(j["state"].as_str(), Some("done" | "failed"))
    });
    assert_eq!(done["state"], "done", "{done}\n{}", w2.log());
    assert_eq!(spp(&done), total, "{done}");
    assert_eq!(done["stats"]["spp"], total, "{done}");
    let rows = shards(&data, id);
    assert!(rows.iter().all(|r| r.1 && r.3 == 20), "{rows:?}");
    // (A held shard's file was whole: w2 resumed it at its full 20 spp rather than rendering
    // it again. Only a writer writes a shard's file at its full spp.)
    let whole = |l: &&str| l.contains("resumed from checkpoint") && l.contains("spp=20");
    assert!(w2.log().lines().any(|l| whole(&l)), "{}", w2.log());
    assert_eq!(shard_files(&data, id), 0, "{}", w2.log());
}

/// A worker whose shard ends while its two writes are held (a slow disk: the test hook) waits
/// for the oldest, renewing its leases meanwhile, so a second worker finds none to take over:
/// every shard is claimed once, none is lost, and the job ends with exactly its samples.
fn a_worker_waiting_for_its_writes_keeps_its_leases_on_postgres() {
    let (data, api, hold, w1) = farm_with_held_writes("server_farm_write_wait");
    let split = ["--shard-spp", "20"];
    let total = 80u64;
    let body = json!({"scene_name": "cornell", "spp": total, "width": 16, "height": 16,
                      "seed": 8});
    let id = api.submit(&body)["id"].as_i64().unwrap();
    // Step 1: two writes held; a third shard's end waits for the oldest.
    let deadline = Instant::now() + T;
    while !w1.log().contains("waiting for the oldest shard write") {
        assert!(Instant::now() < deadline, "{}", w1.log());
        std::thread::sleep(Duration::from_millis(20));
    }
    // Step 2: a second worker looks for work for three leases' time, then the writes go on.
    let w2 = Worker::start_with(&data, "w2", "2", &split);
    std::thread::sleep(Duration::from_secs(6));
    std::fs::remove_file(&hold).unwrap();
    let done = api.wait_job(id, T, |j| {
        matches!(j["state"].as_str(), Some("done" | "failed"))
    });
    assert_eq!(done["state"], "done", "{done}\n{}\n{}", w1.log(), w2.log());
    assert_eq!(spp(&done), total, "{done}");
    assert!(!w1.log().contains("lost the shard's lease"), "{}", w1.log());
    // (Each shard claimed once: by w1, which held them all; the merge by either.)
    let rows = shards(&data, id);
    assert!(rows.iter().all(|r| r.1 && r.3 == 20), "{rows:?}");
    let shard_claims = claims(&data).iter().filter(|c| c.0 == id).count();
    assert!(
        shard_claims <= 4 + 1,
        "shards claimed again: {:?}",
        claims(&data)
    );
}

fn one_worker_renders_on_two_devices_on_postgres() {
    let dir = scratch("server_farm_devices");
    let data = dir.join("data");
    let api = Server::start(&data, &["--workers", "0"]);
    // (Two contexts on lavapipe's one device, as `candela render --devices 0,0`.)
    let mut w = Worker::start_with(&data, "w", "2", &["--devices", "0,0", "--shard-spp", "20"]);
    let total = 160u64;
    // (cornell: a furnace image is ~1 everywhere, whatever was summed.)
    let body = json!({"scene_name": "cornell", "spp": total, "width": 16, "height": 16,
                      "seed": 2});
    let id = api.submit(&body)["id"].as_i64().unwrap();
    let done = api.wait_job(id, T, |j| {
        matches!(j["state"].as_str(), Some("done" | "failed"))
    });
    assert_eq!(done["state"], "done", "{done}\n{}", w.log());
    assert_eq!(spp(&done), total, "{done}");
    // The merge added the 8 shards from the process's memory (shard_sums.rs), no file read;
    // the image is checked against a whole render at the end.
    let merged = format!("merged the shards job={id} shards=8 from_memory=8 ");
    assert!(w.log().contains(&merged), "{}", w.log());
    let split_job = id;
    // Both threads claimed shards, each under its own name.
    let by: BTreeSet<String> = claims(&data).into_iter().map(|c| c.1).collect();
    let want: BTreeSet<String> = ["w/gpu0", "w/gpu1"].map(String::from).into();
    assert_eq!(by, want, "{}", w.log());
    // Step 2: the API server reports both from their heartbeats: device, passes, samples (all
    // of the job's, once each), no job held.
    let deadline = Instant::now() + Duration::from_secs(30);
    let workers = loop {
        let (_, v) = api.get("/api/workers");
        let list = v["workers"].as_array().cloned().unwrap_or_default();
        let samples = |w: &Value| w["samples"].as_u64().unwrap_or(0);
        let idle = |w: &Value| w["jobs"].as_array().is_some_and(|j| j.is_empty());
        if list.len() == 2
            && list.iter().all(|w| samples(w) > 0 && idle(w))
            && list.iter().map(samples).sum::<u64>() == total * 16 * 16
        {
            break list;
        }
        assert!(Instant::now() < deadline, "{v}");
        std::thread::sleep(Duration::from_millis(100));
    };
    for (x, name) in workers.iter().zip(["w/gpu0", "w/gpu1"]) {
        assert_eq!(
            (x["name"].as_str(), x["state"].as_str()),
            (Some(name), Some("running"))
        );
        assert!(x["device"].as_str().unwrap().contains("llvmpipe"), "{x}");
        assert!(x["passes"].as_u64().unwrap() >= 1, "{x}");
        // Its memory: the worker process's resident size, the pipelines its context keeps and
        // the kernel variants the process compiled (cornell's nee, at least one kernel).
        assert!(x["rss_bytes"].as_u64().unwrap() > 1 << 20, "{x}");
        assert!(x["pipelines_cached"].as_u64().unwrap() >= 1, "{x}");
        assert!(x["kernel_variants_seen"].as_u64().unwrap() >= 1, "{x}");
        // And the bytes of finished shards' sums its process keeps for their merge.
        assert!(x["kept_shard_bytes"].as_u64().is_some(), "{x}");
    }
    let metrics = api.metrics();
    for name in ["w/gpu0", "w/gpu1"] {
        for series in [
            "candela_worker_up",
            "candela_worker_rss_bytes",
            "candela_worker_kept_shard_bytes",
        ] {
            let line = format!("{series}{{worker=\"{name}\",device=\"llvmpipe");
            assert!(metrics.contains(&line), "{metrics}");
        }
    }
    // Step 3: a split job paused mid-render keeps its shards' samples and, resumed, ends with
    // exactly its spp.
    let total = 400u64;
    let id = api.submit(&json!({"scene_name": "cornell", "spp": total,
                                "width": 16, "height": 16, "seed": 4}))["id"]
        .as_i64()
        .unwrap();
    api.wait_job(id, T, |j| spp(j) >= 40);
    let (code, _) = api.post(&format!("/api/jobs/{id}/pause"), &json!({}));
    assert_eq!(code, 200);
    let paused = api.wait_job(id, T, |j| j["state"] == "paused");
    std::thread::sleep(Duration::from_millis(500));
    let held = spp(&api.job(id));
    assert!(held >= spp(&paused) && held < total, "{held} of {total}");
    let (code, _) = api.post(&format!("/api/jobs/{id}/resume"), &json!({}));
    assert_eq!(code, 200);
    let done = api.wait_job(id, T, |j| {
        matches!(j["state"].as_str(), Some("done" | "failed"))
    });
    assert_eq!(done["state"], "done", "{done}\n{}", w.log());
    assert_eq!(
        (spp(&done), done["stats"]["spp"].as_u64()),
        (total, Some(total))
    );
    // (A shard in progress at the pause was checkpointed and resumed; every one whole.)
    let rows = shards(&data, id);
    assert_eq!(rows.len(), 20, "{rows:?}");
    assert!(rows.iter().all(|r| r.1 && r.3 == 20), "{rows:?}");
    // Step 3b: a split job canceled mid-render leaves no shard files (done shards' included).
    let id = api.submit(&json!({"scene_name": "cornell", "spp": total,
                                "width": 16, "height": 16, "seed": 5}))["id"]
        .as_i64()
        .unwrap();
    api.wait_job(id, T, |j| spp(j) >= 60);
    assert!(shard_files(&data, id) > 0, "checkpointed shards");
    let (code, _) = api.post(&format!("/api/jobs/{id}/cancel"), &json!({}));
    assert_eq!(code, 200);
    api.wait_job(id, T, |j| j["state"] == "canceled");
    let deadline = Instant::now() + Duration::from_secs(30);
    while shard_files(&data, id) > 0 {
        assert!(Instant::now() < deadline, "shard files left\n{}", w.log());
        std::thread::sleep(Duration::from_millis(100));
    }
    // Step 4: killed, both are reported lost once their lease runs out.
    w.kill9();
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let (_, v) = api.get("/api/workers");
        let states: Vec<&str> = v["workers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w["state"].as_str().unwrap())
            .collect();
        if states == ["lost", "lost"] {
            break;
        }
        assert!(Instant::now() < deadline, "{v}");
        std::thread::sleep(Duration::from_millis(200));
    }
    assert!(api
        .metrics()
        .contains("candela_worker_up{worker=\"w/gpu0\""));
    // Step 5: the job of step 1 rendered whole by a worker that splits nothing: the same
    // image as the merge of the sums kept in memory.
    let e = rel_mse_to_whole(&api, &data, &body, split_job);
    assert!(e < 1e-8, "split (summed in memory) vs whole relMSE {e}");
    // `serve` renders on one device.
    let o = Command::new(candela())
        .args(["serve", "--devices", "0", "--data-dir"])
        .arg(dir.join("other"))
        .output()
        .expect("run candela");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("candela worker"), "{err}");
}
