//! Quality targets: `candela render --until-rel-mse X` and jobs with `"until": {"rel_mse": X}`
//! stop once the estimated relMSE (no reference) reaches X, before their spp cap, and say so.

use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{run_candela, run_json, scratch};
use serde_json::json;

/// An easy target for the Cornell box at 16×16 with nee (its estimate is about 0.1 at 8 spp
/// and falls as 1/spp): reached after tens of samples, far below the cap.
const TARGET: f64 = 0.02;
const CAP: u32 = 100_000;

#[test]
fn cli_render_stops_at_the_target_before_the_cap() {
    let dir = scratch("until_cli");
    let out = dir.join("until.exr");
    let report = run_json(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        &CAP.to_string(),
        "--until-rel-mse",
        &TARGET.to_string(),
        "--json",
        "--no-accel-cache",
    ]);
    println!(
        "stopped by {} at {} spp, estimate {}",
        report["stopped_by"], report["spp"], report["rel_mse_estimate"]
    );
    assert_eq!(report["stopped_by"], "rel_mse", "{report}");
    let spp = report["spp"].as_u64().unwrap();
    assert!((8..CAP as u64).contains(&spp), "{report}");
    let estimate = report["rel_mse_estimate"].as_f64().unwrap();
    assert!(estimate > 0.0 && estimate <= TARGET, "{report}");

    // Without a target: the cap ends it, and the estimate is still reported.
    let report = run_json(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "8",
        "--json",
        "--no-accel-cache",
    ]);
    assert_eq!(report["stopped_by"], "spp", "{report}");
    assert!(
        report["rel_mse_estimate"].as_f64().is_some_and(|e| e > 0.0),
        "{report}"
    );

    // A target must be a positive number.
    let o = run_candela(&[
        "render",
        "scenes/cornell.json",
        "-o",
        out.to_str().unwrap(),
        "--until-rel-mse",
        "0",
    ]);
    candela_tests::assert_bad_input(&o, &["--until-rel-mse"]);
}

#[test]
fn job_with_until_completes_at_its_target() {
    let dir = scratch("until_server");
    let s = Server::start(&dir.join("data"), &["--snapshot-interval", "0.2"]);
    let (status, body) = s.post(
        "/api/jobs",
        &json!({"scene_name": "cornell", "spp": 16, "until": {"rel_mse": -1}}),
    );
    assert_eq!(status, 422, "{body}");
    assert_eq!(body["error"]["path"], "until.rel_mse", "{body}");
    let (status, body) = s.post(
        "/api/jobs",
        &json!({"scene_name": "cornell", "spp": 16, "until": {"relmse": 1}}),
    );
    assert_eq!(status, 422, "{body}");

    let job = s.submit(&json!({
        "scene_name": "cornell", "integrator": "nee", "spp": CAP, "width": 16, "height": 16,
        "until": {"rel_mse": TARGET},
    }));
    let id = job["id"].as_i64().unwrap();
    let done = s.wait_job(id, Duration::from_secs(300), |j| j["state"] == "done");
    let stats = &done["stats"];
    println!(
        "job: stopped by {} at {} spp, estimate {}",
        stats["stopped_by"], stats["spp"], stats["rel_mse_estimate"]
    );
    assert_eq!(stats["stopped_by"], "rel_mse", "{done}");
    let spp = stats["spp"].as_u64().unwrap();
    assert!((8..CAP as u64).contains(&spp), "{done}");
    assert!(
        stats["rel_mse_estimate"]
            .as_f64()
            .is_some_and(|e| e > 0.0 && e <= TARGET),
        "{done}"
    );
    assert_eq!(done["settings"]["until_rel_mse"], TARGET, "{done}");
    // Its progress events carry the estimate, and the last one has reached the target.
    let events = s.events(id, Some(0)).collect_all();
    let estimates: Vec<f64> = events
        .iter()
        .filter(|e| e.event == "progress")
        .filter_map(|e| e.data["rel_mse_estimate"].as_f64())
        .collect();
    println!("progress estimates: {estimates:?}");
    assert!(
        !estimates.is_empty(),
        "no progress event carried rel_mse_estimate"
    );
    assert!(*estimates.last().unwrap() <= TARGET, "{estimates:?}");
}
