//! Jobs survive crashes and restarts of the real `candela serve`: killed with SIGKILL mid-render
//! and restarted on the same data directory, a job resumes from its checkpoint and ends with the
//! full sample count and the same statistics (ray count, image) as an uninterrupted render,
//! and a job that was still queued is not lost; SIGTERM writes a final checkpoint and exits 0;
//! a job paused and resumed before the worker let go of it keeps its samples.

use std::process::Command;
use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{candela, repo_root, scene_path, scratch};
use reqwest::Method;
use serde_json::{json, Value};

// Each test runs on SQLite and on PostgreSQL (NAME::sqlite, NAME::postgres).
candela_tests::on_both_databases!(
    sigkill_mid_render_resumes_to_the_same_result,
    sigterm_writes_a_final_checkpoint_and_exits_zero
);

const T: Duration = Duration::from_secs(120);

fn spp(job: &Value) -> u64 {
    job["progress"]["spp"].as_u64().unwrap_or(0)
}

/// The same render through `candela render --json`: (report, image).
fn reference(
    spp: u32,
    w: u32,
    h: u32,
    seed: u64,
    out: &std::path::Path,
) -> (Value, renderer::film::Image) {
    let o = Command::new(candela())
        .arg("render")
        .arg(scene_path("cornell.json"))
        .arg("-o")
        .arg(out)
        .args(["--spp", &spp.to_string(), "--seed", &seed.to_string()])
        .args([
            "--width",
            &w.to_string(),
            "--height",
            &h.to_string(),
            "--json",
        ])
        .current_dir(repo_root())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).unwrap();
    (report, renderer::film::read_exr(out).unwrap())
}

fn sigkill_mid_render_resumes_to_the_same_result() {
    let dir = scratch("server_durability_kill");
    let data = dir.join("data");
    let args = [
        "--checkpoint-interval",
        "0.2",
        "--snapshot-interval",
        "0.1",
        "--max-active",
        "1",
        "--pass-ms",
        "40",
    ];
    let (total, w, h, seed) = (1600u32, 24u32, 24u32, 7u64);
    // The uninterrupted render to compare with, meanwhile.
    let ref_path = dir.join("reference.exr");
    let reference = std::thread::spawn(move || reference(total, w, h, seed, &ref_path));
    let mut s = Server::start(&data, &args);
    let job = s.submit(&json!({"scene_name": "cornell", "spp": total, "seed": seed,
                                "width": w, "height": h, "name": "crash me"}));
    let id = job["id"].as_i64().unwrap();
    let queued = s.submit(&json!({"scene_name": "furnace", "spp": 3, "width": 8, "height": 8}));
    let queued = queued["id"].as_i64().unwrap();

    // Step 1: kill -9 once a checkpoint exists and the render is well under way.
    let ckpt = data.join(format!("jobs/{id}/checkpoint.bin"));
    let before = s.wait_job(id, T, |j| spp(j) >= 30 && ckpt.exists());
    assert!(
        spp(&before) < total as u64,
        "finished before the crash: {before}"
    );
    assert_eq!(s.job(queued)["state"], "queued");
    s.kill9();

    // Step 2: restart on the same data dir; both jobs are there and complete.
    let s = Server::start(&data, &args);
    let after = s.job(id);
    assert!(
        matches!(after["state"].as_str(), Some("running" | "queued")),
        "{after}"
    );
    assert_eq!(after["name"], "crash me");
    assert_eq!(after["settings"]["seed"], seed);
    let done = s.wait_job(id, T, |j| j["state"] == "done");
    assert!(s.log().contains("resumed from checkpoint"), "{}", s.log());
    let q = s.wait_job(queued, T, |j| j["state"] == "done");
    assert_eq!(spp(&q), 3);

    // Step 3: the same sample count and statistics as an uninterrupted render.
    let (report, ref_img) = reference.join().unwrap();
    assert_eq!(spp(&done), total as u64);
    assert_eq!(done["stats"]["spp"], total);
    assert_eq!(done["stats"]["rays"], report["rays"], "ray count differs");
    assert_eq!(done["stats"]["dropped_samples"], report["dropped_samples"]);
    let exr = s
        .request(Method::GET, &format!("/api/jobs/{id}/image.exr"))
        .send()
        .unwrap();
    assert_eq!(exr.status().as_u16(), 200);
    let img = renderer::film::decode_exr(&exr.bytes().unwrap()).unwrap();
    let (m, r) = (img.mean(), ref_img.mean());
    for c in 0..3 {
        assert!(
            (m[c] - r[c]).abs() <= 1e-4 * r[c].abs().max(1e-3),
            "mean {m:?} vs {r:?}"
        );
    }
    // Pixel by pixel, only float summation order may differ.
    let worst = img
        .pixels
        .iter()
        .zip(&ref_img.pixels)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / b[c].abs().max(1e-2)))
        .fold(0f32, f32::max);
    assert!(worst < 1e-3, "largest relative pixel difference {worst}");

    // Step 4: the event log carried over the crash, ids still increasing.
    let events = s.events(id, Some(0)).collect_all();
    let ids: Vec<i64> = events.iter().map(|e| e.id.unwrap()).collect();
    assert!(ids.windows(2).all(|w| w[1] == w[0] + 1), "{ids:?}");
    assert_eq!(events.last().unwrap().event, "done");
}

fn sigterm_writes_a_final_checkpoint_and_exits_zero() {
    let dir = scratch("server_durability_term");
    let data = dir.join("data");
    // No periodic checkpoint: the only one is the shutdown's.
    let args = ["--checkpoint-interval", "3600", "--pass-ms", "60"];
    let mut s = Server::start(&data, &args);
    let job = s.submit(&json!({"scene_name": "cornell", "spp": 100000, "width": 16, "height": 16}));
    let id = job["id"].as_i64().unwrap();
    s.wait_job(id, T, |j| spp(j) >= 8);
    let ckpt = data.join(format!("jobs/{id}/checkpoint.bin"));
    assert!(!ckpt.exists());
    let status = s.terminate(Duration::from_secs(30));
    assert_eq!(status.code(), Some(0), "{}", s.log());
    assert!(ckpt.exists(), "no checkpoint after SIGTERM:\n{}", s.log());
    let log = s.log();
    let line = log
        .lines()
        .find(|l| l.contains("checkpointed for shutdown"));
    let saved: u64 = line
        .and_then(|l| l.split("spp=").nth(1))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no checkpoint line:\n{log}"));
    assert!(saved >= 8, "{log}");
    drop(s);

    // It resumes where it stopped.
    let s = Server::start(&data, &args);
    s.wait_job(id, T, |j| spp(j) > saved);
    let log = s.log();
    let line = log
        .lines()
        .find(|l| l.contains("resumed from checkpoint"))
        .expect("resumed");
    assert!(
        line.contains(&format!("spp={saved}")),
        "{line} (saved {saved})"
    );
    let (st, _) = s.send(s.request(Method::POST, &format!("/api/jobs/{id}/cancel")));
    assert_eq!(st, 200);
}

/// A job paused and resumed again before the worker lets go of it (held there by the test hook:
/// between the worker's two looks at the store) is checkpointed all the same and resumes from
/// that checkpoint, instead of being dropped unsaved and rendered again from 0 spp.
#[test]
fn a_pause_undone_before_the_worker_lets_go_keeps_the_samples() {
    let dir = scratch("server_durability_unpause");
    let data = dir.join("data");
    let hold = dir.join("hold");
    let hold_s = hold.to_string_lossy().into_owned();
    let args = ["--checkpoint-interval", "3600", "--pass-ms", "60"];
    let s = Server::start_with_env(&data, &args, &[("CANDELA_TEST_RETIRE_HOLD_FILE", &hold_s)]);
    let job = s.submit(&json!({"scene_name": "cornell", "spp": 100000, "width": 16, "height": 16}));
    let id = job["id"].as_i64().unwrap();
    s.wait_job(id, T, |j| spp(j) >= 8);
    // Step 1: paused; the worker holds before it reads the job's state.
    std::fs::write(&hold, b"").unwrap();
    let (st, body) = s.post(&format!("/api/jobs/{id}/pause"), &json!({}));
    assert_eq!(st, 200, "{body}");
    let deadline = std::time::Instant::now() + T;
    while !s.log().contains("retire held (test hook)") {
        assert!(std::time::Instant::now() < deadline, "{}", s.log());
        std::thread::sleep(Duration::from_millis(20));
    }
    // Step 2: resumed before it reads it, then let go.
    let (st, body) = s.post(&format!("/api/jobs/{id}/resume"), &json!({}));
    assert_eq!(st, 200, "{body}");
    std::fs::remove_file(&hold).unwrap();
    let saved_line = |log: &str| {
        log.lines()
            .find(|l| l.contains("paused and checkpointed") && l.contains("queued"))
            .map(str::to_string)
    };
    s.wait_job(id, T, |_| s.log().contains("resumed from checkpoint"));
    let log = s.log();
    let saved: u64 = saved_line(&log)
        .and_then(|l| l.split("spp=").nth(1).map(str::to_string))
        .and_then(|v| v.split_whitespace().next().and_then(|v| v.parse().ok()))
        .unwrap_or_else(|| panic!("no checkpoint at the undone pause:\n{log}"));
    assert!(saved >= 8, "{log}");
    let resumed = log
        .lines()
        .find(|l| l.contains("resumed from checkpoint"))
        .unwrap();
    let token = format!("spp={saved}");
    assert!(
        resumed.split_whitespace().any(|t| t == token),
        "{resumed} (saved {saved})"
    );
    let (st, _) = s.send(s.request(Method::POST, &format!("/api/jobs/{id}/cancel")));
    assert_eq!(st, 200);
}
