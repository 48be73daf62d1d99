//! The uniform grid (`accel: "grid"`) against the BVH on lavapipe, the acceleration-structure
//! cache, and the CLI's accel flags.
//!
//! With `grid_bvh_order` the grid stores primitives in the BVH's order, so both structures number
//! primitives and lights alike and, finding the same nearest hits, must give the same image; the
//! tests report how many pixels differ and the relMSE. With the default input order the images
//! are two estimates of the same picture (lights are enumerated differently), compared at noise
//! level.

use candela_tests::accel::{compiled, diff, load, translated};
use candela_tests::*;
use glam::DVec3;
use renderer::accel::{AccelKind, AccelOptions, AccelRequest, CacheStatus};
use renderer::compile::{compile_with, CompileOptions, CompiledScene};
use renderer::metrics::rel_mse;
use renderer::scene::Scene;

fn grid(resolution: Option<u32>) -> AccelOptions {
    AccelOptions {
        kind: AccelKind::Grid,
        grid_resolution: resolution,
        grid_bvh_order: true,
        ..Default::default()
    }
}

/// Renders `scene` with the BVH and with grids of several resolutions; all must agree.
fn grid_matches_bvh(label: &str, scene: &Scene, integrator: &str, w: u32, spp: u32) {
    grid_matches_bvh_at(
        label,
        scene,
        integrator,
        w,
        spp,
        &[Some(1), Some(3), None, Some(64)],
    );
}

fn grid_matches_bvh_at(
    label: &str,
    scene: &Scene,
    integrator: &str,
    w: u32,
    spp: u32,
    resolutions: &[Option<u32>],
) {
    let bvh = compiled(scene, w, AccelOptions::default(), None);
    let (reference, stats) = render_compiled(scene, &bvh, integrator, spp, 7, None);
    assert_eq!(stats.accel, "bvh");
    for &res in resolutions {
        let c = compiled(scene, w, grid(res), None);
        let (img, stats) = render_compiled(scene, &c, integrator, spp, 7, None);
        assert_eq!(stats.accel, "grid");
        let (n, e) = diff(&img, &reference);
        println!(
            "{label} {integrator}: grid {:?} ({} refs, {} bytes): {n} of {} pixels differ, \
             relMSE {e:.3e} against the BVH",
            stats.grid_resolution.unwrap(),
            stats.grid_refs.unwrap(),
            stats.accel_bytes,
            img.pixels.len()
        );
        assert!(e < 1e-5, "{label}: grid {res:?}: relMSE {e}");
    }
}

#[test]
fn grid_matches_bvh_on_the_cornell_box() {
    // The camera looks in from outside the box: primary rays start outside the grid.
    grid_matches_bvh("cornell", &load("cornell.json"), "nee", 24, 4);
}

#[test]
fn grid_matches_bvh_with_spheres_and_meshes() {
    grid_matches_bvh("mirror_glass", &load("mirror_glass.json"), "nee", 24, 4);
    grid_matches_bvh("textured_mesh", &load("textured_mesh.json"), "nee", 24, 4);
}

#[test]
fn grid_serves_every_integrator() {
    let scene = load("cornell.json");
    // Every integrator users can pick (pt, nee, bdpt, whitted, deferred, ...).
    for integrator in renderer::integrators::names() {
        let bvh = compiled(&scene, 16, AccelOptions::default(), None);
        let (reference, _) = render_compiled(&scene, &bvh, integrator, 2, 3, None);
        let (again, _) = render_compiled(&scene, &bvh, integrator, 2, 3, None);
        let c = compiled(&scene, 16, grid(None), None);
        let (img, _) = render_compiled(&scene, &c, integrator, 2, 3, None);
        let (n, e) = diff(&img, &reference);
        let (n0, e0) = diff(&again, &reference);
        println!(
            "cornell {integrator}: grid: {n} pixels differ, relMSE {e:.3e} against the BVH \
             (BVH rerun: {n0} pixels differ, relMSE {e0:.3e})"
        );
        assert!(e < 1e-5, "{integrator}: relMSE {e}");
    }
}

/// Far from the origin (camera-relative coordinates) the grid still finds the BVH's hits, and the
/// picture is that of the scene at the origin.
#[test]
fn grid_far_from_the_origin() {
    let scene = load("mirror_glass.json");
    let far = translated(&scene, DVec3::new(1e5, -1e5, 1e5));
    let bvh = compiled(&far, 24, AccelOptions::default(), None);
    let (reference, _) = render_compiled(&far, &bvh, "nee", 4, 5, None);
    let c = compiled(&far, 24, grid(None), None);
    let (img, _) = render_compiled(&far, &c, "nee", 4, 5, None);
    let (n, e) = diff(&img, &reference);
    println!("mirror_glass translated by 1e5: grid: {n} pixels differ, relMSE {e:.3e} vs BVH");
    assert!(e < 1e-5, "relMSE {e}");
}

/// In input order (the default) lights are enumerated differently, so the images are two
/// estimates of the same picture: grid-vs-BVH must be as close as BVH-vs-BVH with another seed.
#[test]
fn grid_in_input_order_converges_to_the_bvh_image() {
    let scene = load("cornell.json");
    let bvh = compiled(&scene, 16, AccelOptions::default(), None);
    let (a, _) = render_compiled(&scene, &bvh, "nee", 16, 1, None);
    let (b, _) = render_compiled(&scene, &bvh, "nee", 16, 2, None);
    let mut opts = grid(None);
    opts.grid_bvh_order = false;
    let c = compiled(&scene, 16, opts, None);
    let (g, _) = render_compiled(&scene, &c, "nee", 16, 1, None);
    let seeds = rel_mse(&b, &a).unwrap();
    let accel = rel_mse(&g, &a).unwrap();
    let (ma, mg) = (mean(&a), mean(&g));
    println!(
        "cornell nee 16 spp: grid (input order) vs BVH relMSE {accel:.3e}, BVH seed 2 vs seed 1 \
         {seeds:.3e}; means {mg:.4?} vs {ma:.4?}"
    );
    assert!(accel < 2.0 * seeds, "grid {accel} vs seed noise {seeds}");
    for k in 0..3 {
        assert!(
            (ma[k] - mg[k]).abs() < 0.03 * ma[k],
            "channel {k}: {ma:?} vs {mg:?}"
        );
    }
}

fn same_buffers(a: &CompiledScene, b: &CompiledScene) -> bool {
    // Compared as printed: unused index fields hold NONE, whose f32 reading is a NaN (never equal
    // to itself), and f32 printing is exact (shortest round-trip form).
    let show = |c: &CompiledScene| {
        format!(
            "{:?} {:?} {:?} {:?} {:?} {:?}",
            c.nodes,
            c.prims,
            c.lights,
            c.alias,
            c.globals,
            c.grid.as_ref().map(|g| (g.info, &g.cells, &g.prims))
        )
    };
    show(a) == show(b)
}

/// The second compile of a scene is a cache hit with identical buffers; a changed scene misses;
/// a corrupt file is rebuilt and overwritten.
#[test]
fn accel_cache_hits_misses_and_repairs() {
    let dir = scratch("accel-cache");
    let scene = load("textured_mesh.json");
    let default = AccelOptions::default();
    for (label, accel) in [("bvh", default), ("grid", grid(Some(16)))] {
        let nocache = compiled(&scene, 16, accel, None);
        assert_eq!(nocache.accel.cache, CacheStatus::Off);
        let first = compiled(&scene, 16, accel, Some(&dir));
        assert_eq!(first.accel.cache, CacheStatus::Miss, "{label}");
        let second = compiled(&scene, 16, accel, Some(&dir));
        assert_eq!(second.accel.cache, CacheStatus::Hit, "{label}");
        assert!(same_buffers(&first, &second) && same_buffers(&first, &nocache));
        println!(
            "{label}: build {:.3} ms, cache load {:.3} ms, {} bytes",
            first.accel.build_time.as_secs_f64() * 1e3,
            second.accel.build_time.as_secs_f64() * 1e3,
            second.accel.bytes
        );
        // A moved sphere or vertex is another scene.
        let mut moved = scene.clone();
        if let Some(s) = moved.spheres.first_mut() {
            s.center.x += 0.01;
        } else {
            moved.meshes[0].positions[0].x += 0.01;
        }
        assert_eq!(
            compiled(&moved, 16, accel, Some(&dir)).accel.cache,
            CacheStatus::Miss
        );
    }
    // Another grid resolution is another key.
    let other = compiled(&scene, 16, grid(Some(17)), Some(&dir));
    assert_eq!(other.accel.cache, CacheStatus::Miss);
    // Corrupt every file: each is ignored, rebuilt and overwritten.
    let files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 5, "{files:?}");
    for f in &files {
        let mut bytes = std::fs::read(f).unwrap();
        let mid = bytes.len() / 2;
        bytes[mid] ^= 0xff;
        std::fs::write(f, &bytes[..bytes.len() - 1]).unwrap();
    }
    for accel in [default, grid(Some(16))] {
        let rebuilt = compiled(&scene, 16, accel, Some(&dir));
        assert_eq!(rebuilt.accel.cache, CacheStatus::Miss);
        let again = compiled(&scene, 16, accel, Some(&dir));
        assert_eq!(again.accel.cache, CacheStatus::Hit);
        assert!(same_buffers(&rebuilt, &again));
    }
    // No temporary files are left behind.
    for e in std::fs::read_dir(&dir).unwrap() {
        let name = e.unwrap().file_name().into_string().unwrap();
        assert!(name.ends_with(".bin") && !name.starts_with('.'), "{name}");
    }
}

/// Scene `render.accel` errors name the JSON path.
#[test]
fn scene_render_block_selects_and_checks_the_accel() {
    let base = std::fs::read_to_string(scene_path("cornell.json")).unwrap();
    let with = |render: serde_json::Value| {
        let mut v: serde_json::Value = serde_json::from_str(&base).unwrap();
        v["render"] = render;
        renderer::scene::load_str(&v.to_string(), Some(&scene_path("")))
    };
    let s = with(serde_json::json!({"accel": "grid", "grid_resolution": 12})).unwrap();
    let o = AccelOptions::resolve(
        AccelRequest::default(),
        s.render.accel_request(),
        s.accel_size(),
    )
    .unwrap();
    assert_eq!((o.kind, o.grid_resolution), (AccelKind::Grid, Some(12)));
    // Overrides win.
    let o = AccelOptions::resolve(
        AccelRequest {
            kind: Some("bvh"),
            grid_resolution: None,
        },
        s.render.accel_request(),
        s.accel_size(),
    )
    .unwrap();
    assert_eq!(o.kind, AccelKind::Bvh);
    assert_eq!(
        AccelOptions::resolve(
            AccelRequest {
                kind: None,
                grid_resolution: Some(3),
            },
            s.render.accel_request(),
            s.accel_size(),
        )
        .unwrap()
        .grid_resolution,
        Some(3)
    );
    let c = compile_with(
        &s,
        8,
        8,
        &CompileOptions {
            accel: o,
            cache: None,
            expand_instances: false,
            max_triangles: None,
        },
    )
    .unwrap();
    assert!(c.grid.is_none());
    for (render, path) in [
        (serde_json::json!({"accel": "kd-tree"}), "render.accel"),
        (
            serde_json::json!({"accel": "grid", "grid_resolution": 0}),
            "render.grid_resolution",
        ),
        (
            serde_json::json!({"accel": "grid", "grid_resolution": 100000}),
            "render.grid_resolution",
        ),
        (
            serde_json::json!({"accel": "bvh", "grid_resolution": 8}),
            "render.grid_resolution",
        ),
        (serde_json::json!({"accel": 3}), "render"),
    ] {
        let e = with(render.clone()).unwrap_err();
        println!("{render}: {e}");
        assert!(e.to_string().contains(path), "{render}: {e}");
    }
}

/// `candela render` flags: bad values are one clear line and exit 2; a grid render reports its
/// accel, and the second run of the same scene hits the cache.
#[test]
fn cli_accel_flags() {
    let dir = scratch("accel-cli");
    let out = dir.join("o.exr");
    let out_s = out.to_str().unwrap();
    let cache = dir.join("cache");
    let cache_s = cache.to_str().unwrap();
    let scene = "scenes/cornell.json";
    let small = ["--width", "8", "--height", "8", "--spp", "1"];
    let run = |extra: &[&str]| {
        let mut args = vec!["render", scene, "-o", out_s];
        args.extend_from_slice(&small);
        args.extend_from_slice(extra);
        run_candela(&args)
    };
    assert_bad_input(
        &run(&["--accel", "octree"]),
        &["--accel", "octree", "auto, bvh, cwbvh, grid"],
    );
    assert_bad_input(
        &run(&["--accel", "grid", "--grid-resolution", "0"]),
        &["--grid-resolution"],
    );
    assert_bad_input(
        &run(&["--accel", "grid", "--grid-resolution", "9999"]),
        &["--grid-resolution"],
    );
    assert_bad_input(
        &run(&["--accel", "bvh", "--grid-resolution", "8"]),
        &["--grid-resolution"],
    );
    let json = |o: std::process::Output| -> serde_json::Value {
        assert!(o.status.success(), "{}", text(&o.stderr));
        serde_json::from_slice(&o.stdout).expect("one JSON object")
    };
    let grid = [
        "--accel",
        "grid",
        "--grid-resolution",
        "6",
        "--json",
        "--accel-cache",
        cache_s,
    ];
    let first = json(run(&grid));
    assert_eq!(first["accel"], "grid");
    assert_eq!(first["accel_cache"], "miss");
    assert_eq!(first["grid_resolution"], serde_json::json!([6, 6, 6]));
    assert!(first["accel_bytes"].as_u64().unwrap() > 0);
    assert!(first["accel_build_s"].as_f64().unwrap() >= 0.0);
    let second = json(run(&grid));
    assert_eq!(second["accel_cache"], "hit");
    let off = json(run(&["--accel", "grid", "--json", "--no-accel-cache"]));
    assert_eq!(
        (off["accel"].as_str(), off["accel_cache"].as_str()),
        (Some("grid"), Some("off"))
    );
    let bvh = json(run(&["--accel", "bvh", "--json", "--accel-cache", cache_s]));
    assert_eq!(
        (bvh["accel"].as_str(), bvh["accel_cache"].as_str()),
        (Some("bvh"), Some("miss"))
    );
    assert!(bvh.get("grid_resolution").is_none() && bvh.get("accel_estimate").is_none());
    // The default, "auto", builds both BVHs on this small scene (the binary one now from the
    // cache, so not a hit until the CWBVH is cached too) and keeps the one its estimates prefer.
    let auto = json(run(&["--json", "--accel-cache", cache_s]));
    assert_eq!(
        (auto["accel"].as_str(), auto["accel_cache"].as_str()),
        (Some("cwbvh"), Some("miss"))
    );
    let e = &auto["accel_estimate"];
    assert!(
        e["cwbvh"].as_f64().unwrap() < e["bvh"].as_f64().unwrap(),
        "{e}"
    );
    let again = json(run(&["--json", "--accel-cache", cache_s]));
    assert_eq!(again["accel_cache"].as_str(), Some("hit"));
    assert_eq!(again["accel_estimate"], auto["accel_estimate"]);
    // The text report names the accel.
    let o = run(&["--accel", "grid", "--accel-cache", cache_s]);
    let t = text(&o.stdout);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(t.contains("accel       grid, "), "{t}");
    println!("first {first}\nsecond {second}");
}

/// A dense mesh (a 20k-triangle bumpy sphere in the Cornell box, bench/make_big_scene.py): many
/// small triangles spanning cell faces. Resolutions from 16 up only: lavapipe (llvmpipe) ends
/// every loop of an invocation once 65535 iterations have run in all of them together
/// (`LP_MAX_TGSI_LOOP_ITERATIONS` in Mesa's gallivm), which a grid of one cell holding all 20k
/// triangles exceeds, silently truncating the kernel's loops; real GPUs have no such limit.
#[test]
fn grid_matches_bvh_on_a_dense_mesh() {
    let dir = scratch("accel-big");
    let ok = std::process::Command::new("python3")
        .arg(repo_root().join("bench/make_big_scene.py"))
        .arg(&dir)
        .args(["--triangles", "20000"])
        .output()
        .expect("python3");
    assert!(ok.status.success(), "{}", text(&ok.stderr));
    let scene = renderer::scene::load_file(&dir.join("big.json")).unwrap();
    for integrator in ["nee", "whitted"] {
        grid_matches_bvh_at(
            "bumpy sphere",
            &scene,
            integrator,
            24,
            2,
            &[Some(16), None, Some(64)],
        );
    }
}

/// A server job picks the grid with `accel`; its stats say so, and the second job of the same
/// scene loads the structure from the cache under the data dir.
#[test]
fn server_job_accel_and_cache() {
    use candela_tests::server::Server;
    use std::time::Duration;
    let dir = scratch("accel-server");
    let s = Server::start(&dir.join("data"), &[]);
    let body = serde_json::json!({
        "scene_name": "cornell", "spp": 1, "width": 8, "height": 8,
        "accel": {"type": "grid", "grid_resolution": 5}
    });
    let mut stats = Vec::new();
    for _ in 0..2 {
        let job = s.submit(&body);
        assert_eq!(job["settings"]["accel"], body["accel"], "{job}");
        let id = job["id"].as_i64().unwrap();
        let done = s.wait_job(id, Duration::from_secs(60), |j| j["state"] == "done");
        stats.push(done["stats"].clone());
    }
    assert_eq!(stats[0]["accel"], "grid");
    assert_eq!(stats[0]["grid_resolution"], serde_json::json!([5, 5, 5]));
    assert_eq!(
        (
            stats[0]["accel_cache"].as_str(),
            stats[1]["accel_cache"].as_str()
        ),
        (Some("miss"), Some("hit"))
    );
    assert!(dir.join("data/accel-cache").read_dir().unwrap().count() >= 1);
    // A bad value is refused at submission, naming the field.
    let (st, e) = s.post(
        "/api/jobs",
        &serde_json::json!({"scene_name": "cornell", "accel": "octree"}),
    );
    assert_eq!(st, 422, "{e}");
    assert!(e.to_string().contains("accel.type"), "{e}");
    println!("server job stats: {}", stats[1]);
}
