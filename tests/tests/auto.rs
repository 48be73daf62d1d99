//! `candela render --integrator auto` (renderer/src/auto.rs): a pilot of every unbiased
//! integrator, the cheapest by estimated relMSE × time continues to the budget, and the report
//! says what was chosen and why; the same for a server job with `"integrator": "auto"`
//! (server/src/worker/auto.rs): its stats and an `auto` event carry the choice and the pilots.

use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{run_candela, scratch, text};
use serde_json::{json, Value};

/// Checks an `auto` report (`RenderStats::auto`): every unbiased integrator piloted with at
/// least 8 spp and a cost, and the choice is the cheapest.
fn assert_cheapest_chosen(auto: &Value) {
    assert_cheapest_of(auto, &["pt", "nee", "bdpt"]);
}

/// [`assert_cheapest_chosen`] with the integrators expected to be piloted.
fn assert_cheapest_of(auto: &Value, expected: &[&str]) {
    let pilots = auto["pilots"].as_array().expect("pilots");
    let names: Vec<&str> = pilots
        .iter()
        .map(|p| p["integrator"].as_str().unwrap())
        .collect();
    assert_eq!(names, expected, "{auto}");
    for p in pilots {
        assert!(p["spp"].as_u64().unwrap() >= 8, "{p}");
        assert!(p["cost"].as_f64().is_some_and(|c| c > 0.0), "{p}");
    }
    let cheapest = pilots
        .iter()
        .min_by(|a, b| {
            a["cost"]
                .as_f64()
                .unwrap()
                .total_cmp(&b["cost"].as_f64().unwrap())
        })
        .unwrap();
    assert_eq!(auto["choice"], cheapest["integrator"], "{auto}");
}

#[test]
fn auto_pilots_every_unbiased_integrator_and_keeps_the_cheapest() {
    let out = scratch("auto").join("auto.exr");
    let o = run_candela(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--integrator",
        "auto",
        "--spp",
        "64",
        "--width",
        "16",
        "--height",
        "16",
        "--json",
        "--no-accel-cache",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    let auto = &report["auto"];
    println!("{auto}");
    assert_cheapest_chosen(auto);
    // The choice renders the image and reaches the budget.
    assert_eq!(report["integrator"], auto["choice"], "{report}");
    assert_eq!(report["spp"], 64, "{report}");
    // On the diffuse Cornell box path tracing without light sampling is far behind.
    assert_ne!(auto["choice"], "pt", "{auto}");
}

/// pt never sees point, spot or directional lights: on a scene lit by them its image is dark and
/// its estimated error small, which made it the "cheapest" (found on the GPU with the `lights`
/// scene). It is no candidate there.
#[test]
fn auto_leaves_out_pt_where_the_scene_has_delta_lights() {
    let out = scratch("auto_delta").join("auto.exr");
    let o = run_candela(&[
        "render",
        "scenes/lights.json",
        "-o",
        out.to_str().unwrap(),
        "--integrator",
        "auto",
        "--spp",
        "32",
        "--width",
        "16",
        "--height",
        "12",
        "--json",
        "--no-accel-cache",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    let auto = &report["auto"];
    println!("{auto}");
    assert!(
        report["features"].to_string().contains("delta_lights"),
        "{report}"
    );
    assert_cheapest_of(auto, &["nee", "bdpt"]);
}

/// A server job with `"integrator": "auto"`: the worker pilots, renders with the cheapest to the
/// job's spp, and reports the choice in an `auto` event and in the job's stats; `auto` with a
/// quality target is refused.
#[test]
fn job_with_auto_reports_its_choice() {
    let dir = scratch("auto_server");
    let s = Server::start(&dir.join("data"), &["--snapshot-interval", "0.2"]);
    let (status, body) = s.post(
        "/api/jobs",
        &json!({"scene_name": "cornell", "integrator": "auto", "spp": 16,
                "until": {"rel_mse": 0.01}}),
    );
    assert_eq!(status, 422, "{body}");
    assert_eq!(body["error"]["path"], "until", "{body}");

    // The registry endpoint (which the web form lists) offers `auto`, choosing among the
    // unbiased integrators.
    let (status, catalog) = s.get("/api/integrators");
    assert_eq!(status, 200, "{catalog}");
    assert_eq!(catalog["auto"]["name"], "auto", "{catalog}");
    let unbiased: Vec<&str> = catalog["integrators"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|i| i["unbiased"] == true)
        .filter_map(|i| i["name"].as_str())
        .collect();
    assert_eq!(catalog["auto"]["candidates"], json!(unbiased), "{catalog}");
    assert!(unbiased.contains(&"nee"), "{catalog}");

    let job = s.submit(&json!({
        "scene_name": "cornell", "integrator": "auto", "spp": 64, "width": 16, "height": 16,
    }));
    let id = job["id"].as_i64().unwrap();
    assert_eq!(job["settings"]["auto"], true, "{job}");
    let done = s.wait_job(id, Duration::from_secs(300), |j| j["state"] == "done");
    let stats = &done["stats"];
    let auto = &stats["auto"];
    println!("job: {auto}");
    assert_cheapest_chosen(auto);
    assert_eq!(stats["integrator"], auto["choice"], "{done}");
    assert_eq!(stats["spp"], 64, "{done}");
    // The `auto` event (once, with the same choice and pilots) comes before `done`.
    let events = s.events(id, Some(0)).collect_all();
    let kinds: Vec<&str> = events.iter().map(|e| e.event.as_str()).collect();
    let at = |k: &str| kinds.iter().position(|e| *e == k);
    let (a, d) = (
        at("auto").expect("an auto event"),
        at("done").expect("done"),
    );
    assert!(a < d, "{kinds:?}");
    assert_eq!(
        kinds.iter().filter(|k| **k == "auto").count(),
        1,
        "{kinds:?}"
    );
    assert_eq!(&events[a].data, auto, "{kinds:?}");
}

/// An `auto` job paused after its pilot and resumed continues with the saved choice from its
/// checkpoint: no second pilot (one `auto` event), the same choice in its stats.
#[test]
fn auto_job_resumes_with_its_choice() {
    let dir = scratch("auto_server_resume");
    let s = Server::start(&dir.join("data"), &["--snapshot-interval", "0.2"]);
    let job = s.submit(&json!({
        "scene_name": "cornell", "integrator": "auto", "time_s": 40, "width": 16, "height": 16,
    }));
    let id = job["id"].as_i64().unwrap();
    // Step 1: the pilot's event, then a pause. (The pilots' time counts against the budget,
    // cold kernel builds included: on lavapipe with an empty kernel cache they take 10–12 s, and
    // with a budget of 4 s the job ended with its pilots, before the pause could find it.)
    let mut r = s.events(id, Some(0));
    let first = loop {
        let e = r
            .next_event()
            .expect("the stream ended before the auto event");
        if e.event == "auto" {
            break e.data;
        }
    };
    let (st, body) = s.post(&format!("/api/jobs/{id}/pause"), &json!({}));
    assert_eq!(st, 200, "{body}");
    s.wait_job(id, Duration::from_secs(60), |j| j["state"] == "paused");
    // (The worker lets go of it at its next look at the store: resumed before that, the job
    // would simply go on in the session it has.)
    let t0 = std::time::Instant::now();
    while !s.log().contains("paused and checkpointed") {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "never checkpointed:\n{}",
            s.log()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // Step 2: resumed, it finishes with the same integrator and no new pilot.
    let (st, body) = s.post(&format!("/api/jobs/{id}/resume"), &json!({}));
    assert_eq!(st, 200, "{body}");
    let done = s.wait_job(id, Duration::from_secs(300), |j| j["state"] == "done");
    let stats = &done["stats"];
    assert_eq!(stats["auto"], first, "{done}");
    assert_eq!(stats["integrator"], first["choice"], "{done}");
    let events = s.events(id, Some(0)).collect_all();
    let autos = events.iter().filter(|e| e.event == "auto").count();
    assert_eq!(autos, 1, "a second pilot ran");
    assert!(
        s.log().contains("resumed from checkpoint"),
        "the resume did not use the checkpoint:\n{}",
        s.log()
    );
}
