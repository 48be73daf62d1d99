//! Progress over Server-Sent Events and GPU sharing, against the real `candela serve`: events
//! arrive in order with increasing ids, a reconnect with `Last-Event-ID` resumes without
//! duplicates or gaps, a late subscriber gets a compacted replay, keep-alive comments flow while
//! nothing happens, snapshot URLs serve the image they announce; and a small job submitted
//! behind a long one finishes first (the scheduler interleaves their passes).

use std::time::Duration;

use candela_tests::scratch;
use candela_tests::server::{Server, SseEvent};
use reqwest::Method;
use serde_json::json;

// Each test runs on SQLite and on PostgreSQL (NAME::sqlite, NAME::postgres).
candela_tests::on_both_databases!(
    events_in_order_and_resume_with_last_event_id,
    keep_alive_comments_while_paused,
    small_job_finishes_while_long_one_runs
);

const T: Duration = Duration::from_secs(90);

fn ids(events: &[SseEvent]) -> Vec<i64> {
    events
        .iter()
        .map(|e| e.id.expect("every event has an id"))
        .collect()
}

fn events_in_order_and_resume_with_last_event_id() {
    let dir = scratch("server_sse_events");
    let s = Server::start(
        &dir.join("data"),
        &["--snapshot-interval", "0.1", "--pass-ms", "40"],
    );
    // A time budget, so the render lasts as long on a fast machine as on a slow one.
    let job = s.submit(&json!({"scene_name": "cornell", "time_s": 1.5, "width": 24, "height": 24}));
    let id = job["id"].as_i64().unwrap();

    // Step 1: read until a few progress events, then drop the connection.
    let mut first = Vec::new();
    {
        // Last-Event-ID 0: the full log (without it, a replay is compacted).
        let mut r = s.events(id, Some(0));
        while first
            .iter()
            .filter(|e: &&SseEvent| e.event == "progress")
            .count()
            < 3
        {
            let e = r.next_event().expect("stream ended early");
            assert_ne!(
                e.event, "done",
                "the job finished before the reconnect: {first:?}"
            );
            first.push(e);
        }
    }
    assert_eq!(first[0].event, "state");
    assert_eq!(first[0].data["state"], "queued");
    let last = *ids(&first).last().unwrap();

    // Step 2: reconnect after the last id seen; read to the end.
    let rest = s.events(id, Some(last)).collect_all();
    assert!(!rest.is_empty());
    let all: Vec<SseEvent> = first.iter().chain(&rest).cloned().collect();
    let all_ids = ids(&all);
    let expected: Vec<i64> = (1..=all_ids.len() as i64).collect();
    assert_eq!(
        all_ids, expected,
        "ids must be 1, 2, 3... without gaps or duplicates"
    );

    // Step 3: the order of what happened.
    let kinds: Vec<&str> = all.iter().map(|e| e.event.as_str()).collect();
    let states: Vec<&str> = all
        .iter()
        .filter(|e| e.event == "state")
        .map(|e| e.data["state"].as_str().unwrap())
        .collect();
    assert_eq!(states, ["queued", "running", "done"], "{kinds:?}");
    assert_eq!(kinds.last(), Some(&"done"), "{kinds:?}");
    let spps: Vec<u64> = all
        .iter()
        .filter(|e| e.event == "progress")
        .map(|e| e.data["spp"].as_u64().unwrap())
        .collect();
    assert!(spps.windows(2).all(|w| w[0] <= w[1]), "{spps:?}");
    let total = *spps.last().unwrap();
    assert!(total > 0);
    let p = all.iter().rev().find(|e| e.event == "progress").unwrap();
    for key in [
        "elapsed_s",
        "msamples_per_s",
        "rays_per_s",
        "eta_s",
        "dropped_samples",
    ] {
        assert!(
            p.data.get(key).is_some(),
            "progress lacks {key}: {}",
            p.data
        );
    }
    assert!(p.data["msamples_per_s"].as_f64().unwrap() > 0.0);
    let done = all.last().unwrap();
    assert_eq!(done.data["spp"], total);
    assert_eq!(done.data["stats"]["spp"], total);
    assert!(done.data["stats"]["time_s"].as_f64().unwrap() >= 1.5);

    // Step 4: the last snapshot URL serves the final image.
    let snap = all.iter().rev().find(|e| e.event == "snapshot").unwrap();
    assert_eq!(snap.data["spp"], total);
    let url = snap.data["url"].as_str().unwrap();
    let png = s.request(Method::GET, url).send().unwrap();
    assert_eq!(png.status().as_u16(), 200);
    assert_eq!(png.headers()["x-candela-spp"], total.to_string().as_str());

    // Step 5: a late subscriber gets the compacted log and the stream ends by itself.
    let late = s.events(id, None).collect_all();
    let late_kinds: Vec<&str> = late.iter().map(|e| e.event.as_str()).collect();
    assert_eq!(
        late_kinds.iter().filter(|k| **k == "progress").count(),
        1,
        "{late_kinds:?}"
    );
    assert_eq!(
        late_kinds.iter().filter(|k| **k == "snapshot").count(),
        1,
        "{late_kinds:?}"
    );
    assert_eq!(late_kinds.last(), Some(&"done"));
    assert!(ids(&late).windows(2).all(|w| w[0] < w[1]));
    // Resuming after the final event sends nothing and ends.
    let end = *all_ids.last().unwrap();
    assert!(s.events(id, Some(end)).collect_all().is_empty());
    assert_eq!(
        s.send(
            s.request(Method::GET, &format!("/api/jobs/{id}/events"))
                .header("Last-Event-ID", "x")
        )
        .0,
        400
    );
}

fn keep_alive_comments_while_paused() {
    let dir = scratch("server_sse_keepalive");
    let s = Server::start(&dir.join("data"), &["--sse-keepalive", "0.2"]);
    let job = s.submit(&json!({"scene_name": "furnace", "time_s": 60, "width": 8, "height": 8}));
    let id = job["id"].as_i64().unwrap();
    let (st, _) = s.post(&format!("/api/jobs/{id}/pause"), &json!({}));
    assert_eq!(st, 200);
    let mut r = s.events(id, None);
    let mut events = Vec::new();
    while events.len() < 2 {
        events.push(r.next_event().unwrap());
    }
    // Nothing more happens: only keep-alives until the cancel ends the stream.
    let s2 = std::thread::scope(|scope| {
        let h = scope.spawn(|| r.collect_all());
        std::thread::sleep(Duration::from_millis(1200));
        let st = s
            .send(s.request(Method::POST, &format!("/api/jobs/{id}/cancel")))
            .0;
        (st, h.join().unwrap())
    });
    assert_eq!(s2.0, 200);
    assert!(r.comments >= 3, "keep-alive comments: {}", r.comments);
    let tail = s2.1;
    assert_eq!(tail.last().unwrap().data["state"], "canceled", "{tail:?}");
}

fn small_job_finishes_while_long_one_runs() {
    let dir = scratch("server_sse_fairness");
    let s = Server::start(&dir.join("data"), &["--pass-ms", "100"]);
    let long = s.submit(
        &json!({"scene_name": "cornell", "time_s": 60, "width": 32, "height": 32, "name": "long"}),
    );
    let long = long["id"].as_i64().unwrap();
    s.wait_job(long, T, |j| j["progress"]["spp"].as_u64().unwrap_or(0) > 0);
    let small = s.submit(
        &json!({"scene_name": "cornell", "spp": 32, "width": 16, "height": 16, "name": "small"}),
    );
    let small = small["id"].as_i64().unwrap();
    let done = s.wait_job(small, T, |j| j["state"] == "done");
    assert_eq!(done["progress"]["spp"], 32);
    let l = s.job(long);
    assert_eq!(l["state"], "running", "{l}");
    assert!(l["progress"]["time_s"].as_f64().unwrap() < 60.0);
    // Both got GPU time: the long job kept rendering while the small one ran.
    let before = l["progress"]["spp"].as_u64().unwrap();
    let l = s.wait_job(long, T, |j| j["progress"]["spp"].as_u64().unwrap() > before);
    assert_eq!(l["state"], "running");
    let (st, _) = s.send(s.request(Method::POST, &format!("/api/jobs/{long}/cancel")));
    assert_eq!(st, 200);
}
