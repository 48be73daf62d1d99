//! The in-memory caches held across renders stay within their bounds (issue 18): rendering more
//! kernel variants than the limits keep leaves the SPIR-V and pipeline caches at their limits
//! (the least recently used evicted), a session whose pipelines were evicted meanwhile still
//! renders (its pipelines live until it is dropped; the validation layer would report a
//! destroyed pipeline in use), and a variant rendered again after its eviction gives the same
//! image as before, and is not counted as a new kernel variant (one library test in this file:
//! the limits are process-wide). And the server's `--cache-*` flags set the bounds its
//! `/metrics` reports, with the sizes, and its render loop reports its memory with its
//! heartbeat (`GET /api/workers`, the `candela_worker_*` series).

use candela_tests::server::Server;
use candela_tests::{gpu, render_loaded, scene_path, scratch};
use renderer::caches::stats;
use renderer::compile::compile;
use renderer::gpu::{set_cache_limits, CacheLimits};
use renderer::integrators::IntegratorOptions;
use renderer::render::{render, Budget, RenderSession};

const W: u32 = 12;
const H: u32 = 12;

#[test]
fn more_variants_than_the_limits_keep_the_caches_at_their_limits() {
    let limits = CacheLimits {
        kernels: 3,
        kernel_bytes: u64::MAX,
        pipelines: 2,
        volumes: 1,
    };
    set_cache_limits(limits);
    let ctx = gpu();
    let scene = renderer::scene::load_file(&scene_path("cornell.json")).expect("cornell");

    // Step 1: a nee session of the Cornell box, kept alive across the other renders.
    let compiled = compile(&scene, W, H).expect("compile");
    let nee = IntegratorOptions::from_name("nee").unwrap();
    let mut kept = RenderSession::new(&ctx, &compiled, &nee, scene.render.max_depth, 7).unwrap();
    let (first, _) = render(&mut kept, Budget::Spp(2)).expect("first render");

    // Step 2: three other integrators (other kernels, other pipelines) go through the caches.
    for integrator in ["pt", "whitted", "deferred"] {
        let (img, _) = render_loaded(&scene, integrator, 1, W, H, 1, None);
        assert!(img.pixels.iter().flatten().all(|v| v.is_finite()));
        let s = stats(Some(&ctx));
        assert!(s.kernels <= limits.kernels, "{integrator}: {s:?}");
        assert!(s.pipelines <= limits.pipelines, "{integrator}: {s:?}");
    }
    let s = stats(Some(&ctx));
    assert!(s.kernel_evictions > 0 && s.pipeline_evictions > 0, "{s:?}");
    assert_eq!(s.limits, limits);
    // Every kernel variant made into a pipeline is counted once, kept or not: nee's and the
    // three others' (at least one kernel each), beyond what the pipeline cache keeps.
    let seen = s.kernel_variants;
    assert!(seen >= 4 && seen > s.pipelines as u64, "{s:?}");

    // Step 3: the kept session's pipelines were evicted from the cache, not destroyed.
    let (more, _) = render(&mut kept, Budget::Spp(2)).expect("the kept session renders on");
    assert!(more.pixels.iter().flatten().all(|v| v.is_finite()));
    ctx.check_validation().expect("validation layer messages");
    drop(kept);
    // Only the cached pipelines are left alive once every session is gone.
    let s = stats(Some(&ctx));
    assert_eq!(s.pipelines_live, s.pipelines as u64, "{s:?}");

    // Step 4: nee again, its kernels and pipelines made afresh: the same image as the first.
    let (again, _) = render_loaded(&scene, "nee", 2, W, H, 7, None);
    assert_eq!(again.pixels, first.pixels, "nee after eviction differs");
    let s = stats(Some(&ctx));
    // (A variant made again after its eviction is not a new one.)
    assert_eq!(s.kernel_variants, seen, "{s:?}");
    assert!(
        s.kernels <= limits.kernels && s.pipelines <= limits.pipelines,
        "{s:?}"
    );
}

#[test]
fn server_flags_bound_the_caches_and_metrics_show_them() {
    let dir = scratch("memory_caches_server");
    // (A short lease: the render loop reports itself every half second.)
    let s = Server::start(
        &dir.join("data"),
        &[
            "--cache-pipelines",
            "1",
            "--cache-kernels",
            "2",
            "--lease",
            "1.5",
        ],
    );
    // Two integrators: more pipelines and kernels than the limits.
    for integrator in ["nee", "whitted"] {
        let (st, job) = s.post(
            "/api/jobs?wait=true",
            &serde_json::json!({"scene_name": "cornell", "integrator": integrator, "spp": 1,
                                "width": 8, "height": 8}),
        );
        assert_eq!((st, job["state"].as_str()), (201, Some("done")), "{job}");
    }
    assert_eq!(
        s.metric(r#"candela_cache_limit_entries{cache="pipelines"}"#),
        1.0
    );
    assert_eq!(
        s.metric(r#"candela_cache_limit_entries{cache="kernels"}"#),
        2.0
    );
    assert_eq!(s.metric(r#"candela_cache_entries{cache="pipelines"}"#), 1.0);
    assert!(s.metric(r#"candela_cache_entries{cache="kernels"}"#) <= 2.0);
    assert!(s.metric(r#"candela_cache_evictions_total{cache="pipelines"}"#) >= 1.0);
    assert!(s.metric(r#"candela_cache_bytes{cache="kernels"}"#) > 1000.0);
    assert!(s.metric("candela_pipelines_live") >= 1.0);
    assert!(s.metric("process_resident_memory_bytes") > 1e6);
    assert!(s.metric(r#"candela_heap_bytes{kind="allocated"}"#) > 1e6);
    let seen = s.metric("candela_kernel_variants_seen_total");
    assert!(seen >= 2.0, "nee and whitted: {seen}");
    // The render loop reports the same with its heartbeat (the workers table): its process's
    // resident size, the one pipeline kept, the variants seen; in /api/workers and /metrics.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
    let w = loop {
        let (_, v) = s.get("/api/workers");
        let w = v["workers"][0].clone();
        if w["kernel_variants_seen"].as_f64() == Some(seen) {
            break w;
        }
        assert!(std::time::Instant::now() < deadline, "{v}");
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    assert!(w["rss_bytes"].as_f64().unwrap() > 1e6, "{w}");
    assert_eq!(w["pipelines_cached"], 1, "{w}");
    let name = w["name"].as_str().unwrap();
    let metrics = s.metrics();
    let line = |series: &str| {
        let head = format!("{series}{{worker=\"{name}\",");
        metrics
            .lines()
            .find(|l| l.starts_with(&head))
            .and_then(|l| l.rsplit(' ').next()?.parse::<f64>().ok())
            .unwrap_or_else(|| panic!("no {series} for {name}:\n{metrics}"))
    };
    assert!(line("candela_worker_rss_bytes") > 1e6);
    assert_eq!(line("candela_worker_pipelines_cached"), 1.0);
    assert!(line("candela_worker_kernel_variants_seen_total") >= seen);
}
