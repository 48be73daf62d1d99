//! Random scenes (tests/mitsuba/random_scene.py: every material model with random parameters, textures
//! with channels and srgb, textured scalars, alpha masks, emission on any model, meshes, instances,
//! every light type, thin lens, Gaussian filters up to σ 2, max_depth 2..8 and unbounded)
//! audited three ways, so that what holds on the project's scenes also holds on scenes nobody
//! wrote by hand:
//! 1. the features the loader detects equal the ones the generator placed (60 seeds, no GPU);
//! 2. specialised and generic kernels render the same image for every integrator;
//! 3. nee and bdpt (and pt where no delta light is present) match Mitsuba 3 (the criteria of
//!    `assert_matches_mitsuba`), where the scene is translatable.
//!
//! Parts 2 and 3 render `CANDELA_RANDOM_SCENES` seeds (default 2: lavapipe is slow); the wider
//! sweep on a GPU machine is `tests/mitsuba/audit.py` (bench/RESULTS.md).

use std::path::PathBuf;

use candela_tests::{
    assert_matches_mitsuba, gpu, mitsuba_available, render_mitsuba, render_scene, repo_root,
    scratch, specialised_vs_generic,
};
use renderer::compile::{compile, FeatureSet};
use renderer::integrators::{names, IntegratorOptions};
use serde_json::Value;

/// A generated scene: its file and the generator's facts (random_scene.py's docstring).
struct Generated {
    path: PathBuf,
    facts: Value,
}

fn generate(seed: u64, mitsuba: bool, size: u32) -> Generated {
    let dir = scratch(&format!("random_scene_{seed}_{mitsuba}"));
    let script = repo_root().join("tests/mitsuba/random_scene.py");
    let mut cmd = std::process::Command::new("python3");
    cmd.arg(script)
        .arg(seed.to_string())
        .arg(&dir)
        .args(["--size", &size.to_string()]);
    if mitsuba {
        cmd.arg("--mitsuba");
    }
    let out = cmd.output().expect("python3");
    assert!(
        out.status.success(),
        "random_scene.py {seed}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Generated {
        path: dir.join("scene.json"),
        facts: serde_json::from_slice(&out.stdout).expect("one JSON line of facts"),
    }
}

fn seeds() -> u64 {
    std::env::var("CANDELA_RANDOM_SCENES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2)
}

#[test]
fn random_scenes_detect_exactly_the_features_they_use() {
    for seed in 0..60 {
        let g = generate(seed, false, 8);
        let scene =
            renderer::scene::load_file(&g.path).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let detected = FeatureSet::detect(&scene).names();
        let mut expected: Vec<&str> = g.facts["features"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        let mut got = detected.clone();
        expected.sort();
        got.sort();
        assert_eq!(got, expected, "seed {seed} ({})", g.path.display());
    }
}

#[test]
fn random_scenes_render_alike_with_specialised_and_generic_kernels() {
    let ctx = gpu();
    for seed in 100..100 + seeds() {
        let g = generate(seed, false, 8);
        let scene = renderer::scene::load_file(&g.path).unwrap();
        let compiled = compile(&scene, 8, 8).unwrap();
        for name in names() {
            // vct and deferred render instances only once written out (prepare.rs), which
            // the server does for them; their kernels never see an instance.
            let options = IntegratorOptions::from_name(name).unwrap();
            if !scene.instances.is_empty() && renderer::prepare::expands_instances(&options) {
                continue;
            }
            let (d, tol) = specialised_vs_generic(&scene, &compiled, name)
                .unwrap_or_else(|e| panic!("seed {seed} {name}: {e}"));
            assert!(
                d <= tol,
                "seed {seed} {name} ({}): specialised vs generic differ by {d:e}",
                g.path.display()
            );
        }
    }
    ctx.check_validation().unwrap();
}

#[test]
fn random_scenes_match_mitsuba() {
    assert!(
        mitsuba_available(),
        "Mitsuba 3 is not installed: run scripts/setup.sh"
    );
    const SIZE: u32 = 24;
    for seed in 200..200 + seeds() {
        let g = generate(seed, true, SIZE);
        assert_eq!(g.facts["translatable"], true, "seed {seed}");
        let dir = g.path.parent().unwrap();
        let mi: Vec<_> = (1..=2)
            .map(|s| {
                let out = dir.join(format!("mitsuba{s}.exr"));
                render_mitsuba(&g.path, &out, 2048, SIZE, SIZE, s, None).expect("mitsuba")
            })
            .collect();
        let delta_lights = g.facts["delta_lights"] == true;
        let caustics = delta_lights && g.facts["delta_surfaces"] == true;
        for integrator in ["nee", "bdpt", "pt"] {
            if (integrator == "pt" && delta_lights) || (integrator == "bdpt" && caustics) {
                continue;
            }
            let (c1, _) = render_scene(&g.path, integrator, 1024, SIZE, SIZE, 11, None);
            let (c2, _) = render_scene(&g.path, integrator, 1024, SIZE, SIZE, 12, None);
            let what = format!("seed {seed} {integrator} 1024 spp vs Mitsuba 2048 spp");
            assert_matches_mitsuba(&what, [&c1, &c2], [&mi[0], &mi[1]], &what);
        }
    }
}
