//! Progress metrics against a reference, against the real `candela serve`: a job naming a done
//! job as its reference carries `metrics` (relMSE, FLIP, SSIM, PSNR, MSE) in every progress
//! event, `metrics_note` once, and its relMSE falls as samples accumulate; bad references are
//! 422 naming the path.

use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{scene_path, scratch};
use reqwest::blocking::multipart::{Form, Part};
use reqwest::Method;
use serde_json::{json, Value};

const T: Duration = Duration::from_secs(120);

fn path_of(body: &Value) -> &str {
    body["error"]["path"].as_str().unwrap_or("")
}

#[test]
fn progress_metrics_against_a_reference_job() {
    let dir = scratch("server_reference");
    let s = Server::start(
        &dir.join("data"),
        &["--snapshot-interval", "0.05", "--pass-ms", "20"],
    );
    // The reference: many samples of a tiny cornell box.
    let a = s.submit(
        &json!({"scene_name": "cornell", "integrator": "nee", "spp": 1024,
        "width": 24, "height": 24}),
    );
    let a = a["id"].as_i64().unwrap();
    s.wait_job(a, T, |j| j["state"] == "done");

    // The test job: fewer samples, another seed, its progress measured against job A.
    let b = s.submit(
        &json!({"scene_name": "cornell", "integrator": "nee", "spp": 128,
        "seed": 7, "width": 24, "height": 24, "reference": {"job": a}}),
    );
    let b = b["id"].as_i64().unwrap();
    let events = s.events(b, Some(0)).collect_all();
    let progress: Vec<&Value> = events
        .iter()
        .filter(|e| e.event == "progress")
        .map(|e| &e.data)
        .collect();
    assert!(progress.len() >= 2, "{events:?}");
    for p in &progress {
        let m = &p["metrics"];
        for k in ["rel_mse", "flip", "ssim", "psnr_db", "mse"] {
            assert!(m[k].is_number(), "{k} missing in {p}");
        }
    }
    let notes = progress
        .iter()
        .filter(|p| p.get("metrics_note").is_some())
        .count();
    assert_eq!(notes, 1, "metrics_note once: {progress:?}");
    assert!(progress[0]["metrics_note"]["rel_mse"].is_string());
    let first = progress[0]["metrics"]["rel_mse"].as_f64().unwrap();
    let last = progress.last().unwrap()["metrics"]["rel_mse"]
        .as_f64()
        .unwrap();
    assert!(
        last < first || last < 0.01,
        "relMSE did not fall: first {first}, last {last}"
    );
    let job_b = s.job(b);
    assert_eq!(job_b["state"], "done");
    assert_eq!(job_b["settings"]["reference"], true);
    assert_eq!(job_b["progress"]["metrics"]["rel_mse"].as_f64(), Some(last));

    // An uploaded EXR as the reference: a part named `reference` (job A's image).
    let exr = s
        .request(Method::GET, &format!("/api/jobs/{a}/image.exr"))
        .send()
        .unwrap()
        .bytes()
        .unwrap()
        .to_vec();
    let scene = std::fs::read_to_string(scene_path("cornell.json")).unwrap();
    let upload = |exr: Vec<u8>, width: u32| {
        let form = Form::new()
            .part(
                "job",
                Part::text(json!({"spp": 8, "width": width, "height": 24}).to_string()),
            )
            .part("scene", Part::text(scene.clone()).file_name("scene.json"))
            .part("reference", Part::bytes(exr).file_name("ref.exr"));
        s.send(s.request(Method::POST, "/api/jobs").multipart(form))
    };
    let (st, c) = upload(exr.clone(), 24);
    assert_eq!(st, 201, "{c}");
    let c = c["id"].as_i64().unwrap();
    s.wait_job(c, T, |j| j["state"] == "done");
    assert!(s.job(c)["progress"]["metrics"]["rel_mse"].is_number());
    let (st, body) = upload(exr.clone(), 32);
    assert_eq!((st, path_of(&body)), (422, "reference"), "{body}");
    let (st, body) = upload(b"not an exr".to_vec(), 24);
    assert_eq!((st, path_of(&body)), (422, "reference"), "{body}");

    // Bad references.
    let bad = |reference: Value, width: u32| {
        s.post(
            "/api/jobs",
            &json!({"scene_name": "cornell", "spp": 4, "width": width, "height": 24,
                "reference": reference}),
        )
    };
    let (st, body) = bad(json!({"job": 999_999}), 24);
    assert_eq!((st, path_of(&body)), (422, "reference.job"), "{body}");
    let (st, body) = bad(json!({"job": "one"}), 24);
    assert_eq!((st, path_of(&body)), (422, "reference.job"), "{body}");
    let (st, body) = bad(json!({"job": a}), 32);
    assert_eq!((st, path_of(&body)), (422, "reference"), "{body}");
    let (st, body) = bad(json!({"image": 1}), 24);
    assert_eq!((st, path_of(&body)), (422, "reference"), "{body}");
    // A job that is not done yet.
    let long = s.submit(&json!({"scene_name": "cornell", "time_s": 60, "width": 24, "height": 24}));
    let long = long["id"].as_i64().unwrap();
    let (st, body) = bad(json!({"job": long}), 24);
    assert_eq!((st, path_of(&body)), (422, "reference.job"), "{body}");
    let (st, _) = s.send(s.request(Method::POST, &format!("/api/jobs/{long}/cancel")));
    assert!(st < 300);
}
