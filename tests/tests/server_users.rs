//! Users and roles against the real `candela serve`: `candela users add/list/remove` (the token
//! printed once), 401 without or with a wrong token once users exist, a viewer reads but cannot
//! POST (403), a submitter manages only its own jobs (403 on another's cancel, pause, priority,
//! delete), an admin manages every job, every change records who made it (`by` in the events),
//! and a removed user's token stops working at once.

use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::{run_candela, scratch, text};
use reqwest::Method;
use serde_json::{json, Value};

// Each test runs on SQLite and on PostgreSQL (NAME::sqlite, NAME::postgres).
candela_tests::on_both_databases!(roles_are_enforced_and_changes_record_who);

fn add_user(data: &str, name: &str, role: &str) -> String {
    let o = run_candela(&["users", "add", name, "--role", role, "--data-dir", data]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let token = text(&o.stdout).trim().to_string();
    assert!(token.starts_with("cdl_") && token.len() == 68, "{token}");
    token
}

fn roles_are_enforced_and_changes_record_who() {
    let dir = scratch("server_users");
    let data = dir.join("data");
    let d = data.to_string_lossy().into_owned();
    let alice = add_user(&d, "alice", "submitter");
    let bob = add_user(&d, "bob", "submitter");
    let vera = add_user(&d, "vera", "viewer");
    let root = add_user(&d, "root", "admin");
    // Names are unique; roles are checked; the list shows names and roles, never tokens.
    let o = run_candela(&["users", "add", "alice", "--role", "admin", "--data-dir", &d]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    let o = run_candela(&["users", "add", "eve", "--role", "god", "--data-dir", &d]);
    assert_eq!(o.status.code(), Some(2));
    let o = run_candela(&["users", "list", "--data-dir", &d]);
    let list = text(&o.stdout);
    for line in [
        "alice\tsubmitter",
        "bob\tsubmitter",
        "vera\tviewer",
        "root\tadmin",
    ] {
        assert!(list.contains(line), "{list}");
    }
    assert!(!list.contains(&alice[4..]), "{list}");
    // Only the hash is stored.
    let db = candela_tests::database::store_bytes(&data);
    assert!(!db.windows(alice.len()).any(|w| w == alice.as_bytes()));

    let s = Server::start(&data, &[]);
    let as_ = |token: &str, method: Method, path: &str, body: Option<Value>| {
        let mut r = s.request(method, path).bearer_auth(token);
        if let Some(b) = body {
            r = r.json(&b);
        }
        s.send(r)
    };
    // No token, or a wrong one: 401; health stays open and says a token is needed.
    assert_eq!(s.get("/api/jobs").0, 401);
    assert_eq!(as_("cdl_nope", Method::GET, "/api/jobs", None).0, 401);
    let (st, h) = s.get("/api/health");
    assert_eq!((st, &h["auth"]), (200, &json!(true)));
    let (_, me) = as_(&bob, Method::GET, "/api/me", None);
    assert_eq!(me, json!({"name": "bob", "role": "submitter"}));

    // Alice submits; the job is hers.
    let long = json!({"scene_name": "furnace", "time_s": 300, "width": 8, "height": 8});
    let (st, job) = as_(&alice, Method::POST, "/api/jobs", Some(long.clone()));
    assert_eq!(st, 201, "{job}");
    assert_eq!(job["owner"], "alice");
    let id = job["id"].as_i64().unwrap();
    let at = |suffix: &str| format!("/api/jobs/{id}{suffix}");

    // A viewer reads, and nothing else.
    assert_eq!(as_(&vera, Method::GET, &at(""), None).0, 200);
    let (st, e) = as_(&vera, Method::POST, "/api/jobs", Some(long.clone()));
    assert_eq!(
        (st, e["error"]["code"].as_str()),
        (403, Some("forbidden")),
        "{e}"
    );
    assert_eq!(
        as_(&vera, Method::POST, &at("/cancel"), Some(json!({}))).0,
        403
    );

    // Every read route is open to a viewer; every write route is 403.
    for path in [
        "/api/jobs",
        &at(""),
        "/api/me",
        "/api/scenes",
        "/api/integrators",
        "/metrics",
    ] {
        let (st, _) = as_(&vera, Method::GET, path, None);
        assert_eq!(st, 200, "viewer GET {path}");
    }
    for (method, path) in [
        (Method::POST, at("/pause")),
        (Method::POST, at("/resume")),
        (Method::PATCH, at("")),
        (Method::DELETE, at("")),
    ] {
        let (st, e) = as_(&vera, method.clone(), &path, Some(json!({"priority": 5})));
        assert_eq!(st, 403, "viewer {method} {path}: {e}");
    }

    // Another submitter: reads, but cannot touch Alice's job.
    assert_eq!(as_(&bob, Method::GET, &at(""), None).0, 200);
    let (st, e) = as_(&bob, Method::POST, &at("/cancel"), Some(json!({})));
    assert_eq!(st, 403, "{e}");
    assert!(
        e["error"]["message"].as_str().unwrap().contains("alice"),
        "{e}"
    );
    assert_eq!(
        as_(&bob, Method::POST, &at("/pause"), Some(json!({}))).0,
        403
    );
    assert_eq!(
        as_(&bob, Method::PATCH, &at(""), Some(json!({"priority": 50}))).0,
        403
    );
    let (_, j) = as_(&alice, Method::GET, &at(""), None);
    assert!(j["state"] != "canceled" && j["priority"] == 10, "{j}");

    // Alice changes her own job; the admin cancels it; Bob still cannot delete it, Alice can.
    let (st, j) = as_(
        &alice,
        Method::PATCH,
        &at(""),
        Some(json!({"priority": 20})),
    );
    assert_eq!((st, &j["priority"]), (200, &json!(20)), "{j}");
    let (st, j) = as_(&root, Method::POST, &at("/cancel"), Some(json!({})));
    assert_eq!((st, j["state"].as_str()), (200, Some("canceled")), "{j}");
    assert_eq!(as_(&bob, Method::DELETE, &at(""), None).0, 403);

    // Who did what: the job's events (read with ?token=, as EventSource does).
    let r = s
        .request(Method::GET, &format!("{}?token={vera}", at("/events")))
        .timeout(Duration::from_secs(60))
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 200);
    let body = r.text().unwrap();
    assert!(
        body.contains("\"by\":\"alice\"") && body.contains("\"state\":\"queued\""),
        "{body}"
    );
    assert!(body.contains("event: priority"), "{body}");
    assert!(body.contains("\"by\":\"root\""), "{body}");
    assert_eq!(as_(&alice, Method::DELETE, &at(""), None).0, 204);

    // Removing a user revokes its token at once, with the server running.
    let o = run_candela(&["users", "remove", "bob", "--data-dir", &d]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(as_(&bob, Method::GET, "/api/jobs", None).0, 401);
    let o = run_candela(&["users", "remove", "bob", "--data-dir", &d]);
    assert_eq!(o.status.code(), Some(2));
}
