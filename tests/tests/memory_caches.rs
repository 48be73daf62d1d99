//! The in-memory caches held across renders stay within their bounds (issue 18): rendering more
//! kernel variants than the limits keep leaves the SPIR-V and pipeline caches at their limits
//! (the least recently used evicted), a session whose pipelines were evicted meanwhile still
//! renders (its pipelines live until it is dropped; the validation layer would report a
//! destroyed pipeline in use), and a variant rendered again after its eviction gives the same
//! image as before. One test in this file: the limits are process-wide.

use candela_tests::{gpu, render_loaded, scene_path};
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
