//! The HTTP API of `candela serve` over a real socket: every endpoint, every error status with
//! its JSON body (400, 401, 404, 405, 409, 413, 422, 429), job control (pause, resume, cancel,
//! priority), images, metrics, the web viewer's files, bearer-token authentication and the
//! refusal to bind a non-loopback address without a token.

use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{candela, repo_root, scratch};
use reqwest::Method;
use serde_json::{json, Value};

// Each test runs on SQLite and on PostgreSQL (NAME::sqlite, NAME::postgres).
candela_tests::on_both_databases!(
    jobs_endpoints_and_errors,
    limits_give_clear_errors,
    token_auth_and_bind_refusal
);

const T: Duration = Duration::from_secs(90);

/// Asserts `status` and the error JSON shape; returns the error object.
fn assert_error(r: &(u16, Value), status: u16, code: &str) -> Value {
    assert_eq!(r.0, status, "{}", r.1);
    let e = &r.1["error"];
    assert_eq!(e["code"], code, "{}", r.1);
    assert!(
        e["message"].as_str().is_some_and(|m| !m.is_empty()),
        "{}",
        r.1
    );
    e.clone()
}

fn state(job: &Value) -> &str {
    job["state"].as_str().unwrap_or("")
}

fn jobs_endpoints_and_errors() {
    let dir = scratch("server_api_jobs");
    let s = Server::start(
        &dir.join("data"),
        &[
            "--max-active",
            "1",
            "--snapshot-interval",
            "0.2",
            "--validation",
        ],
    );

    // Health, viewer, scenes.
    let (st, health) = s.get("/api/health");
    assert_eq!(st, 200);
    assert!(
        health["status"].is_string() && health["jobs"]["queued"].is_u64(),
        "{health}"
    );
    let page = reqwest::blocking::get(s.at("/")).unwrap();
    assert_eq!(page.status().as_u16(), 200);
    assert!(page.headers()["content-type"]
        .to_str()
        .unwrap()
        .starts_with("text/html"));
    let (st, scenes) = s.get("/api/scenes");
    assert_eq!(st, 200);
    let names: Vec<&str> = scenes["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    for n in ["cornell", "furnace", "textured_mesh", "envmap"] {
        assert!(names.contains(&n), "{names:?}");
    }
    let (st, cornell) = s.get("/api/scenes/cornell");
    assert_eq!(st, 200);
    assert!(cornell["camera"].is_object());
    assert_error(&s.get("/api/scenes/nope"), 404, "not_found");

    // A long job holds the only slot; a second one stays queued.
    let resp = s
        .request(Method::POST, "/api/jobs")
        .json(&json!({"scene_name": "cornell", "time_s": 120, "width": 24, "height": 24, "name": "long"}))
        .send()
        .unwrap();
    assert_eq!(resp.status().as_u16(), 201);
    let location = resp.headers()["location"].to_str().unwrap().to_string();
    let long: Value = resp.json().unwrap();
    let l = long["id"].as_i64().unwrap();
    assert_eq!(location, format!("/api/jobs/{l}"));
    assert_eq!(long["name"], "long");
    assert_eq!(long["settings"]["integrator"]["type"], "nee");
    for link in ["self", "events", "image.png", "image.exr"] {
        assert!(
            long["links"][link]
                .as_str()
                .unwrap()
                .starts_with("/api/jobs/"),
            "{long}"
        );
    }
    s.wait_job(l, T, |j| state(j) == "running");
    let q = s.submit(
        &json!({"scene_name": "furnace", "spp": 4, "width": 16, "height": 16,
                              "integrator": {"type": "pt", "max_depth": -1}}),
    );
    let q = q["id"].as_i64().unwrap();
    assert_eq!(state(&s.job(q)), "queued");
    assert_error(
        &s.get(&format!("/api/jobs/{q}/image.png")),
        404,
        "not_found",
    );

    // Listing and filtering.
    let ids = |path: &str| -> Vec<i64> {
        let (st, v) = s.get(path);
        assert_eq!(st, 200, "{v}");
        v["jobs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| j["id"].as_i64().unwrap())
            .collect()
    };
    assert_eq!(ids("/api/jobs?state=queued"), vec![q]);
    assert_eq!(ids("/api/jobs?state=running"), vec![l]);
    assert_eq!(ids("/api/jobs?state=queued,running"), vec![q, l]);
    assert_eq!(ids("/api/jobs"), vec![q, l]);
    assert_error(&s.get("/api/jobs?state=bogus"), 400, "bad_request");

    // Priority.
    let patch = |id: i64, body: &str| {
        s.send(
            s.request(Method::PATCH, &format!("/api/jobs/{id}"))
                .header("content-type", "application/json")
                .body(body.to_string()),
        )
    };
    let r = patch(q, r#"{"priority": 50}"#);
    assert_eq!(r.0, 200, "{}", r.1);
    assert_eq!(r.1["priority"], 50);
    let e = assert_error(&patch(q, r#"{"priority": 0}"#), 422, "invalid_field");
    assert_eq!(e["path"], "priority");
    let e = assert_error(&patch(q, r#"{"prio": 1}"#), 422, "invalid_field");
    assert_eq!(e["path"], "prio");
    assert_error(&patch(q, "{"), 400, "invalid_json");

    // Pause the long job: the queued one gets the slot and finishes.
    let (st, paused) = s.post(&format!("/api/jobs/{l}/pause"), &json!({}));
    assert_eq!((st, state(&paused)), (200, "paused"), "{paused}");
    let done = s.wait_job(q, T, |j| state(j) == "done");
    assert_eq!(done["progress"]["spp"], 4);
    assert_eq!(done["stats"]["spp"], 4);
    assert!(done["finished_at"].is_string());
    s.wait_job(l, T, |_| {
        s.data_dir.join(format!("jobs/{l}/checkpoint.bin")).exists()
    });
    let (st, resumed) = s.post(&format!("/api/jobs/{l}/resume"), &json!({}));
    assert_eq!((st, state(&resumed)), (200, "queued"), "{resumed}");
    assert_error(
        &s.post(&format!("/api/jobs/{l}/resume"), &json!({})),
        409,
        "conflict",
    );

    // Images of the finished job.
    let png = s
        .request(Method::GET, &format!("/api/jobs/{q}/image.png"))
        .send()
        .unwrap();
    assert_eq!(png.status().as_u16(), 200);
    assert_eq!(png.headers()["content-type"], "image/png");
    assert_eq!(png.headers()["x-candela-spp"], "4");
    assert!(png.bytes().unwrap().starts_with(b"\x89PNG"));
    let r = s.request(
        Method::GET,
        &format!("/api/jobs/{q}/image.png?exposure=2&tonemap=aces&spp=4"),
    );
    assert_eq!(r.send().unwrap().status().as_u16(), 200);
    assert_error(
        &s.get(&format!("/api/jobs/{q}/image.png?exposure=abc")),
        400,
        "bad_request",
    );
    assert_error(
        &s.get(&format!("/api/jobs/{q}/image.png?tonemap=filmic")),
        400,
        "bad_request",
    );
    let exr = s
        .request(Method::GET, &format!("/api/jobs/{q}/image.exr"))
        .send()
        .unwrap();
    assert_eq!(exr.status().as_u16(), 200);
    let img = renderer::film::decode_exr(&exr.bytes().unwrap()).unwrap();
    assert_eq!((img.width, img.height), (16, 16));
    // The white furnace renders exactly 1 (up to noise).
    let m = img.mean();
    assert!((m[0] - 1.0).abs() < 0.05, "furnace mean {m:?}");

    // Invalid transitions and cancel.
    let e = assert_error(
        &s.post(&format!("/api/jobs/{q}/pause"), &json!({})),
        409,
        "conflict",
    );
    assert!(e["message"].as_str().unwrap().contains("done"), "{e}");
    assert_error(
        &s.send(s.request(Method::POST, &format!("/api/jobs/{q}/cancel"))),
        409,
        "conflict",
    );
    let (st, canceled) = s.send(s.request(Method::POST, &format!("/api/jobs/{l}/cancel")));
    assert_eq!((st, state(&canceled)), (200, "canceled"), "{canceled}");
    assert_error(
        &s.send(s.request(Method::POST, &format!("/api/jobs/{l}/cancel"))),
        409,
        "conflict",
    );
    let events = s.events(l, None).collect_all();
    let last = events.last().unwrap();
    assert_eq!(
        (last.event.as_str(), &last.data["state"]),
        ("state", &json!("canceled"))
    );

    // Bad submissions.
    assert_error(&s.post_raw("/api/jobs", "{\"spp\": 4"), 400, "invalid_json");
    assert_error(&s.post_raw("/api/jobs", "[1, 2]"), 400, "invalid_json");
    let bad = |body: Value, path: &str, code: &str| {
        let e = assert_error(&s.post("/api/jobs", &body), 422, code);
        assert_eq!(e["path"], path, "{e}");
    };
    bad(
        json!({"scene_name": "cornell", "colour": 1}),
        "colour",
        "invalid_field",
    );
    bad(json!({"scene_name": "nope"}), "scene_name", "invalid_field");
    bad(json!({"spp": 4}), "scene", "invalid_field");
    bad(
        json!({"scene_name": "cornell", "integrator": "bdpt2"}),
        "integrator",
        "invalid_field",
    );
    // Integrator options out of range are refused at submission, naming the field.
    for (integrator, field) in [
        (json!({"type": "vct", "resolution": 96}), "resolution"),
        (json!({"type": "deferred", "cutoff": -1}), "cutoff"),
        (
            json!({"type": "whitted", "area_samples": 0}),
            "area_samples",
        ),
    ] {
        let e = assert_error(
            &s.post(
                "/api/jobs",
                &json!({"scene_name": "cornell", "integrator": integrator}),
            ),
            422,
            "invalid_field",
        );
        assert_eq!(e["path"], "integrator", "{e}");
        assert!(e["message"].as_str().unwrap().contains(field), "{e}");
    }
    bad(
        json!({"scene_name": "cornell", "spp": 4, "time_s": 1}),
        "time_s",
        "invalid_field",
    );
    bad(
        json!({"scene_name": "cornell", "spp": 0}),
        "spp",
        "invalid_field",
    );
    bad(
        json!({"scene_name": "cornell", "width": 100000}),
        "width",
        "invalid_field",
    );
    bad(
        json!({"scene_name": "cornell", "tonemap": "filmic"}),
        "tonemap",
        "invalid_field",
    );
    let scene = json!({"version": 1, "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "materials": {"white": {"type": "diffuse"}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "glas"}]});
    bad(
        json!({"scene": scene}),
        "scene.objects[0].material",
        "invalid_scene",
    );
    assert_error(&s.get("/api/jobs/999"), 404, "not_found");
    assert_error(&s.get("/api/jobs/abc"), 404, "not_found");
    assert_error(&s.get("/api/nothing"), 404, "not_found");
    assert_error(
        &s.send(s.request(Method::PUT, &format!("/api/jobs/{q}"))),
        405,
        "method_not_allowed",
    );

    // ?wait=true returns when the job has ended.
    let (st, waited) = s.post(
        "/api/jobs?wait=true",
        &json!({"scene_name": "furnace", "spp": 2, "width": 8, "height": 8}),
    );
    assert_eq!((st, state(&waited)), (201, "done"), "{waited}");
    assert_eq!(waited["progress"]["spp"], 2);

    // Metrics.
    let text = s
        .request(Method::GET, "/metrics")
        .send()
        .unwrap()
        .text()
        .unwrap();
    for needle in [
        "candela_jobs{state=\"done\"} 2",
        "candela_jobs{state=\"canceled\"} 1",
        "# TYPE candela_samples_rendered_total counter",
        "# TYPE candela_gpu_busy_seconds_total counter",
        "candela_queue_wait_seconds_bucket{le=\"+Inf\"}",
        "candela_queue_wait_seconds_count",
    ] {
        assert!(text.contains(needle), "{needle} not in\n{text}");
    }
    let samples: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("candela_samples_rendered_total "))
        .unwrap()
        .parse()
        .unwrap();
    assert!(samples >= (4 * 16 * 16 + 2 * 8 * 8) as f64, "{text}");
    assert!(!s.log().contains("panicked"), "{}", s.log());
}

fn limits_give_clear_errors() {
    let dir = scratch("server_api_limits");
    let s = Server::start(
        &dir.join("data"),
        &[
            "--max-queued",
            "2",
            "--max-body-mb",
            "1",
            "--max-spp",
            "5000",
            "--max-pixels",
            "10000",
            "--max-triangles",
            "30",
        ],
    );
    // 413: a body over 1 MiB (small enough to be sent whole before the server answers).
    let big = format!(
        "{{\"scene_name\": \"furnace\", \"name\": \"{}\"}}",
        "a".repeat(1_100_000)
    );
    assert_error(&s.post_raw("/api/jobs", big), 413, "payload_too_large");
    // 422: spp, pixels, triangles (cornell has 36).
    let e = assert_error(
        &s.post("/api/jobs", &json!({"scene_name": "furnace", "spp": 6000})),
        422,
        "invalid_field",
    );
    assert_eq!(e["path"], "spp");
    let e = assert_error(
        &s.post(
            "/api/jobs",
            &json!({"scene_name": "furnace", "width": 200, "height": 200}),
        ),
        422,
        "invalid_field",
    );
    assert_eq!(e["path"], "width");
    let e = assert_error(
        &s.post("/api/jobs", &json!({"scene_name": "cornell"})),
        422,
        "invalid_scene",
    );
    assert!(e["message"].as_str().unwrap().contains("triangles"), "{e}");
    // 429: two unfinished jobs is the most.
    let job = json!({"scene_name": "furnace", "time_s": 60, "width": 8, "height": 8});
    let a = s.submit(&job)["id"].as_i64().unwrap();
    let b = s.submit(&job)["id"].as_i64().unwrap();
    let r = s
        .request(Method::POST, "/api/jobs")
        .json(&job)
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 429);
    assert!(r.headers().contains_key("retry-after"));
    let body: Value = r.json().unwrap();
    assert_eq!(body["error"]["code"], "too_many_jobs", "{body}");
    for id in [a, b] {
        let (st, _) = s.send(s.request(Method::POST, &format!("/api/jobs/{id}/cancel")));
        assert_eq!(st, 200);
    }
    let c = s.submit(&job)["id"].as_i64().unwrap();
    s.send(s.request(Method::POST, &format!("/api/jobs/{c}/cancel")));
}

fn token_auth_and_bind_refusal() {
    let dir = scratch("server_api_auth");
    // A non-loopback address without a token is refused with exit status 2.
    let out = std::process::Command::new(candela())
        .args(["serve", "--bind", "0.0.0.0:0", "--data-dir"])
        .arg(dir.join("refused"))
        .env_remove("CANDELA_TOKEN")
        .current_dir(repo_root())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--token") && err.contains("CANDELA_TOKEN"),
        "{err}"
    );
    assert!(!err.contains("panicked"));

    // With CANDELA_TOKEN it starts.
    let d2 = dir.join("env");
    let d2s = d2.to_string_lossy().into_owned();
    let mut env_server = Server::spawn(
        &["--bind", "0.0.0.0:0", "--data-dir", &d2s],
        &d2,
        &[("CANDELA_TOKEN", "from-env")],
    );
    env_server.kill9();

    let s = Server::start(&dir.join("data"), &["--token", "s3cret"]);
    let get = |path: &str, auth: Option<&str>| {
        let mut r = s.request(Method::GET, path);
        if let Some(a) = auth {
            r = r.header("Authorization", a);
        }
        r.send().unwrap()
    };
    let r = get("/api/jobs", None);
    assert_eq!(r.status().as_u16(), 401);
    assert!(r.headers()["www-authenticate"]
        .to_str()
        .unwrap()
        .starts_with("Bearer"));
    let body: Value = r.json().unwrap();
    assert_eq!(body["error"]["code"], "unauthorized");
    assert_eq!(
        get("/api/jobs", Some("Bearer wrong")).status().as_u16(),
        401
    );
    assert_eq!(get("/api/jobs", Some("s3cret")).status().as_u16(), 401);
    assert_eq!(
        get("/api/jobs", Some("Bearer s3cret")).status().as_u16(),
        200
    );
    assert_eq!(get("/api/jobs?token=s3cret", None).status().as_u16(), 200);
    assert_eq!(get("/api/scenes", None).status().as_u16(), 401);
    assert_eq!(get("/metrics", None).status().as_u16(), 401);
    assert_eq!(
        get("/metrics", Some("Bearer s3cret")).status().as_u16(),
        200
    );
    assert_eq!(get("/api/health", None).status().as_u16(), 200);
    assert_eq!(get("/", None).status().as_u16(), 200);
    let r = s
        .request(Method::POST, "/api/jobs")
        .json(&json!({"scene_name": "furnace", "spp": 1, "width": 4, "height": 4}))
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 401);
    let r = s
        .request(Method::POST, "/api/jobs?wait=true")
        .header("Authorization", "Bearer s3cret")
        .json(&json!({"scene_name": "furnace", "spp": 1, "width": 4, "height": 4}))
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 201);
}
