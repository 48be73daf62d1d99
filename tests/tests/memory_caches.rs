//! The in-memory caches held across renders stay within their bounds (issue 18): rendering more
//! kernel variants than the limits keep leaves the SPIR-V and pipeline caches at their limits
//! (the least recently used evicted), a session whose pipelines were evicted meanwhile still
//! renders (its pipelines live until it is dropped; the validation layer would report a
//! destroyed pipeline in use), and a variant rendered again after its eviction gives the same
//! image as before (one library test in this file: the limits are process-wide). And the
//! server's `--cache-*` flags set the bounds its `/metrics` reports, with the sizes.

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
    assert!(
        s.kernels <= limits.kernels && s.pipelines <= limits.pipelines,
        "{s:?}"
    );
}

#[test]
fn server_flags_bound_the_caches_and_metrics_show_them() {
    let dir = scratch("memory_caches_server");
    let s = Server::start(
        &dir.join("data"),
        &["--cache-pipelines", "1", "--cache-kernels", "2"],
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
}
