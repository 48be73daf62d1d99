//! First light: a white furnace built directly from scene types (no JSON), rendered on the
//! default device (lavapipe in CI) with the validation layer on.

use std::sync::Arc;

use glam::{DVec3, Vec3};
use renderer::compile::compile;
use renderer::gpu::{GpuContext, GpuOptions};
use renderer::integrators::IntegratorOptions;
use renderer::render::{render, Budget, RenderSession};
use renderer::scene::*;

fn furnace() -> Scene {
    Scene {
        camera: Camera {
            position: DVec3::new(0.0, 0.0, 5.0),
            look_at: DVec3::ZERO,
            up: DVec3::Y,
            fov_y: 30.0,
            aperture_radius: 0.0,
            focus_distance: 5.0,
        },
        film: Film {
            width: 32,
            height: 32,
            filter: Filter::Box,
            exposure: 0.0,
            tonemap: Tonemap::Clamp,
        },
        materials: vec![Material {
            kind: MaterialKind::Diffuse {
                reflectance: ColorParam::Const(Vec3::ONE),
            },
            emission: Vec3::ZERO,
            alpha_mask: None,
            two_sided: true,
        }],
        material_names: vec!["white".into()],
        textures: vec![],
        meshes: vec![],
        spheres: vec![Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
            flip_normals: false,
            material: 0,
        }],
        prototypes: vec![],
        instances: vec![],
        lights: vec![],
        environment: Some(Environment::Constant {
            radiance: Vec3::ONE,
        }),
        render: RenderDefaults::default(),
    }
}

#[test]
fn white_furnace_renders_one() {
    let ctx = Arc::new(
        GpuContext::new(&GpuOptions {
            device: None,
            validation: true,
            ..Default::default()
        })
        .expect("device"),
    );
    let scene = furnace();
    let compiled = compile(&scene, 32, 32).unwrap();
    for name in ["pt", "nee"] {
        let opts = IntegratorOptions::from_name(name).unwrap();
        let mut s = RenderSession::new(&ctx, &compiled, &opts, Some(-1), 7).unwrap();
        let (img, stats) = render(&mut s, Budget::Spp(64)).unwrap();
        let mean = img.mean();
        println!("{name}: mean {mean:?} stats {stats:?}");
        for c in mean {
            assert!((c - 1.0).abs() < 0.02, "{name}: furnace mean {mean:?}");
        }
        assert_eq!(stats.dropped_samples, 0);
    }
}
