//! Memory and load figures of a render (`candela render --json`, the text report, a server
//! job's stats), and scenes too large for the device refused with an error naming the limit.
//! lavapipe's real limits cannot be reached by a small test, so they are lowered with
//! `CANDELA_GPU_MEMORY_LIMIT` / `CANDELA_GPU_BUFFER_LIMIT`.

use std::time::Duration;

use candela_tests::server::Server;
use candela_tests::*;
use serde_json::{json, Value};

/// `candela render` of the textured mesh at 8×8, 1 spp, with `extra` flags and `env`.
fn render(env: &[(&str, &str)], extra: &[&str]) -> std::process::Output {
    let out = scratch("scene-memory").join("o.exr");
    let scene = scene_path("textured_mesh.json");
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "--no-accel-cache",
    ];
    args.extend_from_slice(extra);
    run_candela_env(&args, env)
}

#[test]
fn render_report_has_memory_and_load_figures() {
    let o = render(&[], &["--json"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let n = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
    let triangles = n("triangles");
    // 48 bytes per primitive at least, plus the BVH's 64-byte nodes.
    assert!(n("geometry_bytes") >= 48.0 * triangles, "{v}");
    assert!(n("accel_bytes") >= 64.0, "{v}");
    assert!(
        n("scene_gpu_bytes") > n("geometry_bytes") + n("accel_bytes"),
        "{v}"
    );
    let per = (n("geometry_bytes") + n("accel_bytes")) / triangles;
    assert!((n("gpu_bytes_per_triangle") - per).abs() < 1e-9, "{v}");
    assert!(n("peak_rss_bytes") > 1e6, "{v}");
    assert!(
        n("load_s") > 0.0 && n("compile_s") >= n("accel_build_s"),
        "{v}"
    );
    println!(
        "{} triangles: {} GPU bytes per triangle, host peak {:.1} MiB, load {:.4} s, compile \
         {:.4} s",
        triangles,
        per,
        n("peak_rss_bytes") / 1048576.0,
        n("load_s"),
        n("compile_s")
    );
    let o = render(&[], &[]);
    let report = text(&o.stdout);
    assert!(
        report.contains("memory      GPU") && report.contains("load        "),
        "{report}"
    );
}

#[test]
fn a_scene_too_large_for_the_device_names_the_limit() {
    let o = render(&[("CANDELA_GPU_MEMORY_LIMIT", "20000")], &[]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    println!("{err}");
    assert!(
        err.contains("does not fit the device")
            && err.contains("20000 bytes")
            && err.contains("CANDELA_GPU_MEMORY_LIMIT"),
        "{err}"
    );
    let o = render(&[("CANDELA_GPU_BUFFER_LIMIT", "4096")], &[]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    println!("{err}");
    assert!(
        err.contains("maxStorageBufferRange") && err.contains("4096 bytes"),
        "{err}"
    );
}

/// The scene's GPU bytes as `candela render --json --integrator <integrator>` reports them.
fn scene_gpu_bytes(integrator: &str) -> u64 {
    let o = render(&[], &["--json", "--integrator", integrator]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    v["scene_gpu_bytes"].as_u64().expect("scene_gpu_bytes")
}

/// The check counts the session's buffers too: a limit the scene's buffers fit but not with
/// the film's, or not with bdpt's splats and light vertices, is refused before anything is
/// allocated.
#[test]
fn the_memory_check_counts_the_film_and_integrator_buffers() {
    let refused = |integrator: &str, limit: u64| {
        let limit = limit.to_string();
        let o = render(
            &[("CANDELA_GPU_MEMORY_LIMIT", &limit)],
            &["--integrator", integrator],
        );
        assert!(!o.status.success(), "{integrator} fitted in {limit} bytes");
        let err = text(&o.stderr);
        println!("{err}");
        assert!(
            err.contains("does not fit the device") && err.contains(&format!("{limit} bytes")),
            "{err}"
        );
    };
    // The 8×8 film's two accumulations (16 bytes per pixel each) and the counters' buffer.
    let film = 2 * 8 * 8 * 16 + 16;
    let (nee, bdpt) = (scene_gpu_bytes("nee"), scene_gpu_bytes("bdpt"));
    refused("nee", nee + film - 16);
    // Room for the scene and the film: nee renders; bdpt, whose splats and light vertices do
    // not fit, does not.
    let o = render(
        &[("CANDELA_GPU_MEMORY_LIMIT", &(nee + film).to_string())],
        &["--integrator", "nee"],
    );
    assert!(
        o.status.success(),
        "nee in {} bytes: {}",
        nee + film,
        text(&o.stderr)
    );
    assert_eq!(nee, bdpt, "one scene");
    refused("bdpt", bdpt + film);
}

#[test]
fn server_job_stats_have_the_figures_and_too_large_jobs_fail_clearly() {
    let dir = scratch("scene-memory-server");
    let t = Duration::from_secs(90);
    let job = json!({"scene_name": "cornell", "spp": 1, "width": 8, "height": 8});
    let ended = |j: &Value| matches!(j["state"].as_str(), Some("done" | "failed"));
    {
        let s = Server::start(&dir.join("ok"), &[]);
        let id = s.submit(&job)["id"].as_i64().unwrap();
        let done = s.wait_job(id, t, ended);
        assert_eq!(done["state"], "done", "{done}");
        let st = &done["stats"];
        for k in [
            "geometry_bytes",
            "accel_bytes",
            "scene_gpu_bytes",
            "peak_rss_bytes",
        ] {
            assert!(st[k].as_u64().is_some_and(|b| b > 0), "{k}: {st}");
        }
        assert!(
            st["gpu_bytes_per_triangle"].as_f64().unwrap() > 48.0,
            "{st}"
        );
        assert!(st["load_s"].as_f64().unwrap() > 0.0, "{st}");
    }
    let s = Server::start_with_env(
        &dir.join("small"),
        &[],
        &[("CANDELA_GPU_MEMORY_LIMIT", "1000")],
    );
    let id = s.submit(&job)["id"].as_i64().unwrap();
    let failed = s.wait_job(id, t, ended);
    assert_eq!(failed["state"], "failed", "{failed}");
    let e = failed["error"].as_str().unwrap();
    assert!(
        e.contains("does not fit the device") && e.contains("1000 bytes"),
        "{failed}"
    );
}
