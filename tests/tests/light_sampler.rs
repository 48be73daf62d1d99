//! The light BVH sampler (`render.light_sampler: "bvh"`, renderer/src/compile/light_bvh.rs and
//! shaders/common/light_bvh.glsl) on the GPU: nee with it and with the power sampler converge to
//! the same image on a scene of many lights of every bounded kind plus an environment (a wrong
//! pick probability, or MIS weights that disagree with the sampling, would shift the mean), and
//! the BVH's noise is lower there.

use candela_tests::render_loaded;
use renderer::film::Image;
use renderer::metrics::{downsample_box, rel_mse};
use renderer::scene::Scene;

const W: u32 = 24;

/// A floor with a diffuse sphere under 24 small emissive quads spread over a 12 × 12 area at
/// various heights (a third facing up, away from the floor), an emissive sphere, a point light,
/// a spot and a dim constant environment.
fn many_lights(sampler: &str) -> Scene {
    let mut objects = vec![
        serde_json::json!({"type": "quad", "origin": [-6, 0, 6], "edge_u": [12, 0, 0],
                           "edge_v": [0, 0, -12], "material": "floor"}),
        serde_json::json!({"type": "sphere", "center": [0.5, 0.6, 0], "radius": 0.6,
                           "material": "floor"}),
        serde_json::json!({"type": "sphere", "center": [-3, 1.5, 2], "radius": 0.2,
                           "material": "glow"}),
    ];
    for i in 0..24 {
        let x = (i % 6) as f64 * 2.0 - 5.0;
        let z = (i / 6) as f64 * 3.0 - 4.5;
        let y = 1.0 + 0.5 * (i % 4) as f64;
        // Facing down (edge_u × edge_v = −Y) or, every third, up.
        let (eu, ev) = if i % 3 == 2 {
            ([0.0, 0.0, 0.3], [0.3, 0.0, 0.0])
        } else {
            ([0.3, 0.0, 0.0], [0.0, 0.0, 0.3])
        };
        objects.push(
            serde_json::json!({"type": "quad", "origin": [x, y, z], "edge_u": eu,
                                        "edge_v": ev, "material": format!("light{}", i % 3)}),
        );
    }
    let doc = serde_json::json!({
        "version": 1,
        "camera": {"position": [0, 7, 7], "look_at": [0, 0, 0], "fov_y": 60},
        "film": {"width": W, "height": W},
        "materials": {
            "floor": {"type": "diffuse", "reflectance": [0.7, 0.7, 0.7]},
            "glow": {"type": "diffuse", "reflectance": 0, "emission": [20, 16, 10]},
            "light0": {"type": "diffuse", "reflectance": 0, "emission": [30, 30, 30]},
            "light1": {"type": "diffuse", "reflectance": 0, "emission": [10, 30, 10]},
            "light2": {"type": "diffuse", "reflectance": 0, "emission": [30, 10, 10]},
        },
        "objects": objects,
        "lights": [
            {"type": "point", "position": [4, 2, 3], "intensity": [6, 6, 8]},
            {"type": "spot", "position": [-4, 4, -4], "look_at": [-4, 0, -4],
             "intensity": [40, 30, 20], "cutoff_angle": 30},
        ],
        "environment": {"type": "constant", "radiance": [0.05, 0.05, 0.08]},
        "render": {"light_sampler": sampler, "max_depth": 3},
    });

    renderer::scene::load_str(&doc.to_string(), None).unwrap()
}

/// The average of three renders of 128 spp (seeds `seeds`) with `integrator` and the sum of
/// their estimates.
fn renders(integrator: &str, sampler: &str, seeds: [u64; 3]) -> (Image, f64) {
    let scene = many_lights(sampler);
    let mut images = Vec::new();
    let mut estimates = 0.0;
    for seed in seeds {
        let (img, stats) = render_loaded(&scene, integrator, 128, W, W, seed, None);
        assert_eq!(stats.light_sampler, sampler, "{integrator}");
        assert_eq!(stats.dropped_samples, 0, "{sampler}");
        estimates += stats.rel_mse_estimate.unwrap();
        images.push(img);
    }
    let avg = Image::from_fn(W, W, |x, y| {
        let mut p = [0f32; 3];
        for img in &images {
            for (a, v) in p.iter_mut().zip(img.get(x, y)) {
                *a += v / 3.0;
            }
        }
        p
    });
    (avg, estimates)
}

#[test]
fn nee_with_the_bvh_and_the_power_sampler_agree_on_many_lights() {
    let (pe, be) = bvh_and_power_agree("nee");
    // Step 3: the spatially aware sampler is less noisy here.
    assert!(be < pe, "bvh {be:.3e} is not below power {pe:.3e}");
}

/// bdpt with the BVH for its s = 1 connections (its light subpaths still start ∝ power; the MIS
/// weights take NEE's pick from the BVH, bdpt/vertex.glsl nee_density_ratio) converges to
/// bdpt with the power sampler: wrong weights would shift the mean.
#[test]
fn bdpt_with_the_bvh_and_the_power_sampler_agree_on_many_lights() {
    let (pe, be) = bvh_and_power_agree("bdpt");
    // Less noisy with the BVH too (the weights are unbiased whatever density they use for
    // s = 1, as long as every strategy uses the same: NEE's real one is what lowers the noise;
    // with the power pick's in its place the BVH read 2.16e-2 here, with NEE's 1.91e-2).
    assert!(be < pe, "bdpt: bvh {be:.3e} is not below power {pe:.3e}");
}

/// `integrator` with the power and the BVH sampler, three renders of each: the same mean, and
/// a difference the noise explains. Returns the sums of their estimates (power, bvh).
fn bvh_and_power_agree(integrator: &str) -> (f64, f64) {
    // Three renders of each (independent seeds): at 24×24 a few pixels decide the error, and
    // one render's estimate varies by 1.5× from seed to seed.
    let (power, pe) = renders(integrator, "power", [1, 2, 3]);
    let (bvh, be) = renders(integrator, "bvh", [11, 12, 13]);
    // Step 1: the same mean brightness per channel (a bias would shift it).
    let (pm, bm) = (power.mean(), bvh.mean());
    println!("{integrator}: mean power {pm:?}, bvh {bm:?}");
    for c in 0..3 {
        let rel = (bm[c] - pm[c]).abs() / pm[c];
        assert!(
            rel < 0.03,
            "{integrator} channel {c}: power {} vs bvh {}",
            pm[c],
            bm[c]
        );
    }
    // Step 2: per 2×2 block, the difference is what the two noises explain (each average's
    // relMSE is about a third of its renders' mean estimate, Σ/9, and averaging 2×2 blocks
    // divides independent noise by about 4: allowed twice that).
    let diff = rel_mse(&downsample_box(&bvh, 2), &downsample_box(&power, 2)).unwrap();
    let noise = (pe + be) / 9.0;
    println!(
        "{integrator} 3 × 128 spp: estimated relMSE (mean of 3) power {:.3e}, bvh {:.3e}; relMSE between \
         the averages on 2×2 blocks {diff:.3e} (noise {noise:.3e})",
        pe / 3.0,
        be / 3.0
    );
    assert!(
        diff < 2.0 * noise / 4.0,
        "{integrator}: {diff:.3e} vs noise {noise:.3e}"
    );
    (pe, be)
}

#[test]
fn pt_and_vct_take_the_bvh_sampler() {
    // pt's MIS weights and vct's direct light use the sampler's pdf: both still render finite
    // images with the BVH (pt at max_depth 2: emitters seen after one bounce).
    for integrator in ["pt", "vct", "bdpt"] {
        let (img, stats) = render_loaded(&many_lights("bvh"), integrator, 4, W, W, 3, Some(2));
        assert_eq!(stats.dropped_samples, 0, "{integrator}");
        // The registry says who takes the BVH (IntegratorInfo::light_bvh), the stats report it.
        let takes = renderer::integrators::info(integrator).unwrap().light_bvh;
        assert!(takes, "{integrator}");
        assert_eq!(stats.light_sampler, "bvh", "{integrator}");
        assert!(
            img.mean().iter().all(|c| c.is_finite() && *c > 0.0),
            "{integrator}"
        );
    }
}
