//! The first 100 ms through the real server (issue 13), on a real socket: `--warm-kernels`
//! builds the kernels in the background (the listen line does not wait for it; health reports
//! its progress), after which a job on a built-in scene compiles no kernel and creates no
//! pipeline; and a running job publishes snapshots at the `--snapshot-interval` asked for
//! (passes are sized to a third of it, snapshots resolved off the GPU thread).

use std::time::{Duration, Instant};

use candela_tests::scratch;
use candela_tests::server::Server;
use serde_json::json;

#[test]
fn warm_kernels_and_snapshot_cadence() {
    let dir = scratch("server_snapshots");
    let interval = 0.25;
    let s = Server::start(
        &dir.join("data"),
        &["--snapshot-interval", "0.25", "--warm-kernels", "nee"],
    );
    // Step 1: the warm-up runs after the listen line and ends "ready".
    let start = Instant::now();
    let kernels = loop {
        let (_, h) = s.get("/api/health");
        let k = h["kernels"].clone();
        if k["state"] == "ready" {
            break k;
        }
        assert!(start.elapsed() < Duration::from_secs(600), "warm-up: {k}");
        std::thread::sleep(Duration::from_millis(100));
    };
    println!("warm-up: {kernels}");
    assert!(kernels["variants"].as_u64().unwrap() >= 1, "{kernels}");
    assert_eq!(kernels["built"], kernels["variants"], "{kernels}");

    // Step 2: a job with a time budget; the snapshot events' arrival times.
    let job = s.submit(&json!({
        "scene_name": "cornell", "integrator": "nee", "time_s": 2.5, "width": 32, "height": 24
    }));
    let id = job["id"].as_i64().unwrap();
    let mut events = s.events(id, Some(0));
    let mut arrivals = Vec::new();
    let done = loop {
        let e = events.next_event().expect("the stream ended before done");
        match e.event.as_str() {
            "snapshot" => arrivals.push(Instant::now()),
            "done" => break e.data,
            "error" => panic!("job failed: {}", e.data),
            _ => {}
        }
    };
    // The final snapshot comes with the end, not on the cadence.
    arrivals.pop();
    let gaps: Vec<f64> = arrivals
        .windows(2)
        .map(|w| (w[1] - w[0]).as_secs_f64())
        .collect();
    let mut sorted = gaps.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN);
    println!(
        "{} snapshots in 2.5 s, gaps (s): median {median:.3}, {gaps:.3?}",
        arrivals.len()
    );
    // 10 at the interval asked for; a loaded 2-core CI machine may stretch some passes.
    assert!(arrivals.len() >= 5, "{} snapshots", arrivals.len());
    assert!(
        (0.6 * interval..=2.0 * interval).contains(&median),
        "median gap {median} for an interval of {interval}"
    );

    // Step 3: warmed, the job built no kernel and no pipeline.
    let k = &done["stats"]["kernel_build"];
    assert_eq!(k["compiled"], 0, "{k}");
    assert_eq!(k["pipelines"], 0, "{k}");
}
