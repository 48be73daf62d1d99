//! GPU faults on the real `candela serve` (lavapipe): a device loss injected mid-job with two
//! jobs rendering fails neither — the worker rebuilds the device and resumes both from their
//! checkpoints, and they end with exactly their spp and the image of an uninterrupted render;
//! the pass watchdog shrinks the passes of a job whose pass runs past the limit and stops a job
//! whose one-sample pass does, while a light job beside them completes.

use std::process::Command;
use std::time::{Duration, Instant};

use candela_tests::server::Server;
use candela_tests::{candela, repo_root, scene_path, scratch};
use reqwest::Method;
use serde_json::{json, Value};

const T: Duration = Duration::from_secs(60);

fn spp(job: &Value) -> u64 {
    job["progress"]["spp"].as_u64().unwrap_or(0)
}

fn ended(j: &Value) -> bool {
    matches!(j["state"].as_str(), Some("done" | "failed" | "canceled"))
}

/// The same Cornell render through `candela render --json`: (report, image).
fn reference(
    spp: u32,
    size: u32,
    seed: u64,
    out: std::path::PathBuf,
) -> (Value, renderer::film::Image) {
    let o = Command::new(candela())
        .arg("render")
        .arg(scene_path("cornell.json"))
        .arg("-o")
        .arg(&out)
        .args(["--spp", &spp.to_string(), "--seed", &seed.to_string()])
        .args([
            "--width",
            &size.to_string(),
            "--height",
            &size.to_string(),
            "--json",
        ])
        .current_dir(repo_root())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).unwrap();
    (report, renderer::film::read_exr(&out).unwrap())
}

/// The largest relative difference of two images' pixels (summation order only may differ).
fn worst_difference(a: &renderer::film::Image, b: &renderer::film::Image) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / q[c].abs().max(1e-2)))
        .fold(0f32, f32::max)
}

#[test]
fn a_device_loss_mid_job_resumes_every_job_exactly() {
    let dir = scratch("server_gpu_faults_loss");
    let trigger = dir.join("lose-device");
    let trigger_s = trigger.to_string_lossy().into_owned();
    let args = [
        "--max-active",
        "2",
        "--checkpoint-interval",
        "0.2",
        "--pass-ms",
        "40",
    ];
    let s = Server::start_with_env(
        &dir.join("data"),
        &args,
        &[("CANDELA_TEST_DEVICE_LOSS_FILE", trigger_s.as_str())],
    );
    let (total, size) = (800u32, 16u32);
    // The uninterrupted renders to compare with, meanwhile.
    let refs: Vec<_> = [1u64, 2]
        .into_iter()
        .map(|seed| {
            let out = dir.join(format!("reference{seed}.exr"));
            std::thread::spawn(move || reference(total, size, seed, out))
        })
        .collect();
    let ids: Vec<i64> = [1u64, 2]
        .into_iter()
        .map(|seed| {
            let job = json!({"scene_name": "cornell", "spp": total, "seed": seed,
                             "width": size, "height": size});
            s.submit(&job)["id"].as_i64().unwrap()
        })
        .collect();

    // Step 1: both rendering, both checkpointed, neither finished: lose the device.
    for &id in &ids {
        let ckpt = s.data_dir.join(format!("jobs/{id}/checkpoint.bin"));
        s.wait_job(id, T, |j| spp(j) >= 20 && ckpt.exists());
    }
    std::fs::write(&trigger, b"").unwrap();
    let deadline = Instant::now() + T;
    while trigger.exists() {
        assert!(
            Instant::now() < deadline,
            "the hook never fired:\n{}",
            s.log()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    for &id in &ids {
        let j = s.job(id);
        assert!(spp(&j) < total as u64, "finished before the loss: {j}");
    }

    // Step 2: both end done with exactly their spp, resumed from checkpoints on a new device.
    for (&id, r) in ids.iter().zip(refs) {
        let done = s.wait_job(id, T, ended);
        assert_eq!(done["state"], "done", "{done}\n{}", s.log());
        assert_eq!(spp(&done), total as u64);
        assert_eq!(done["stats"]["spp"], total);
        let (report, ref_img) = r.join().unwrap();
        assert_eq!(done["stats"]["rays"], report["rays"], "ray count differs");
        let exr = s
            .request(Method::GET, &format!("/api/jobs/{id}/image.exr"))
            .send()
            .unwrap();
        let img = renderer::film::decode_exr(&exr.bytes().unwrap()).unwrap();
        let worst = worst_difference(&img, &ref_img);
        assert!(
            worst < 1e-3,
            "job {id}: largest relative pixel difference {worst}"
        );
    }
    let log = s.log();
    assert!(log.contains("device lost"), "{log}");
    assert!(log.contains("resetting the GPU device"), "{log}");
    let resumed = log
        .lines()
        .filter(|l| l.contains("resumed from checkpoint"))
        .count();
    assert_eq!(resumed, 2, "{log}");
    let metrics = s
        .request(Method::GET, "/metrics")
        .send()
        .unwrap()
        .text()
        .unwrap();
    assert!(
        metrics
            .lines()
            .any(|l| l == "candela_gpu_device_losses_total 1"),
        "{metrics}"
    );
    assert_eq!(s.get("/api/health").1["status"], "ok");
}

#[test]
fn the_pass_watchdog_shrinks_or_stops_a_job_and_the_light_one_completes() {
    let dir = scratch("server_gpu_faults_watchdog");
    // Passes sized for 2 s but limited to 0.25 s: the sizer's growing passes trip the watchdog.
    let args = [
        "--max-active",
        "3",
        "--pass-ms",
        "2000",
        "--snapshot-interval",
        "6",
        "--pass-timeout",
        "0.25",
    ];
    let s = Server::start(&dir.join("data"), &args);
    // Heavy: one sample per pixel of a 256² Cornell box takes over a second on lavapipe.
    let heavy = s.submit(
        &json!({"scene_name": "cornell", "spp": 50, "width": 256, "height": 256,
                                  "name": "heavy"}),
    )["id"]
        .as_i64()
        .unwrap();
    // Medium: cheap samples, but passes grown toward 2 s get capped.
    let medium = s.submit(
        &json!({"scene_name": "cornell", "spp": 300, "width": 32, "height": 32,
                                   "name": "medium"}),
    )["id"]
        .as_i64()
        .unwrap();
    let light = s.submit(
        &json!({"scene_name": "furnace", "spp": 20, "width": 8, "height": 8,
                                  "name": "light"}),
    )["id"]
        .as_i64()
        .unwrap();

    // Step 1: the heavy job stops with the watchdog's reason.
    let h = s.wait_job(heavy, T, ended);
    assert_eq!(h["state"], "failed", "{h}");
    let reason = h["error"].as_str().unwrap();
    assert!(
        reason.contains("pass watchdog") && reason.contains("1 sample per pixel"),
        "{reason}"
    );
    assert!(reason.contains("limit of 0.25 s"), "{reason}");

    // Step 2: the others complete with exactly their spp; the medium job's passes were capped.
    for (id, n) in [(medium, 300), (light, 20)] {
        let j = s.wait_job(id, T, ended);
        assert_eq!(j["state"], "done", "{j}\n{}", s.log());
        assert_eq!(spp(&j), n);
    }
    let events = s.events(medium, Some(0)).collect_all();
    let warning = events
        .iter()
        .find(|e| e.event == "warning")
        .unwrap_or_else(|| panic!("no watchdog warning: {:?}", s.log()));
    // "a pass of N samples per pixel took … s, over the pass limit …; passes are capped at C"
    let msg = warning.data["message"].as_str().unwrap();
    let number_after = |key: &str| -> u32 {
        msg.split(key)
            .nth(1)
            .and_then(|t| t.split_whitespace().next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("{key}: {msg}"))
    };
    let (pass, cap) = (number_after("a pass of "), number_after("capped at "));
    assert!(cap >= 1 && cap < pass, "{msg}");
    assert!(msg.contains("limit of 0.25 s"), "{msg}");
}
