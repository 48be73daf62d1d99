//! Test helper: two loaded scenes are the same scene (an imported one and its hand-written JSON
//! equivalent). Exact where the data allows: materials by content per triangle and sphere (an
//! importer's names and the JSON map's order differ), texels bit for bit, positions to 1e-12;
//! cameras by position, view direction and up (an importer keeps the view direction, not the
//! look-at distance). Instances are compared as the meshes they place (an importer defines
//! repeated geometry once, a hand-written equivalent may write it out).

use crate::scene::{ColorParam, Material, MaterialKind, ScalarParam, Scene};

/// A material with its textures resolved to their texels, comparable across scenes.
fn resolved(s: &Scene, m: &Material) -> String {
    let tex = |i: u32| {
        let t = &s.textures[i as usize];
        let sum: f64 = t.texels.iter().flatten().map(|&x| x as f64).sum();
        format!(
            "tex({}x{}, scale {:?}, sum {sum:.9}, first {:?})",
            t.width,
            t.height,
            t.scale,
            t.texels.first()
        )
    };
    let c = |p: &ColorParam| match p {
        ColorParam::Const(v) => format!("{v:?}"),
        ColorParam::Texture(i) => tex(*i),
    };
    let f = |p: &ScalarParam| match p {
        ScalarParam::Const(v) => format!("{v:?}"),
        ScalarParam::Texture(i) => tex(*i),
    };
    let kind = match &m.kind {
        MaterialKind::Diffuse { reflectance } => format!("diffuse {}", c(reflectance)),
        MaterialKind::Conductor {
            reflectance,
            roughness,
            anisotropy,
            eta_k,
        } => {
            format!(
                "conductor {} {} {} {eta_k:?}",
                c(reflectance),
                f(roughness),
                f(anisotropy)
            )
        }
        MaterialKind::Dielectric {
            ior,
            roughness,
            transmittance,
            reflectance,
        } => {
            format!(
                "dielectric {ior} {} {} {}",
                f(roughness),
                c(transmittance),
                c(reflectance)
            )
        }
        MaterialKind::Principled {
            base_color,
            metallic,
            roughness,
            specular,
            spec_tint,
            anisotropic,
            sheen,
            sheen_tint,
            spec_trans,
            ior,
            subsurface,
            clearcoat,
            clearcoat_gloss,
        } => format!(
            "principled {} {} {} {} {} {} {} {} {} {ior:?} {} {} {}",
            c(base_color),
            f(metallic),
            f(roughness),
            f(specular),
            f(spec_tint),
            f(anisotropic),
            f(sheen),
            f(sheen_tint),
            f(spec_trans),
            f(subsurface),
            f(clearcoat),
            f(clearcoat_gloss)
        ),
        MaterialKind::Phong {
            diffuse,
            specular,
            exponent,
        } => format!("phong {} {} {exponent}", c(diffuse), c(specular)),
    };
    format!(
        "{kind} emission {:?} mask {:?} two_sided {}",
        m.emission,
        m.alpha_mask.map(tex),
        m.two_sided
    )
}

/// Asserts that `a` and `b` are the same scene (see the module docs).
pub(crate) fn assert_same_scene(a: &Scene, b: &Scene) {
    let flat = |s: &Scene| {
        crate::scene::expand::expand_instances(
            s,
            crate::scene::expand::Expand::All,
            "test",
            u64::MAX,
        )
        .unwrap()
    };
    let (fa, fb) = (flat(a), flat(b));
    let (a, b) = (fa.as_ref().unwrap_or(a), fb.as_ref().unwrap_or(b));
    let (c, d) = (&a.camera, &b.camera);
    assert!(
        (c.position - d.position).length() < 1e-12,
        "camera position {} vs {}",
        c.position,
        d.position
    );
    let dir = |x: &crate::scene::Camera| (x.look_at - x.position).normalize();
    assert!(
        (dir(c) - dir(d)).length() < 1e-12,
        "view {} vs {}",
        dir(c),
        dir(d)
    );
    assert!(
        (c.up.normalize() - d.up.normalize()).length() < 1e-12
            || (dir(c).cross(c.up).normalize() - dir(d).cross(d.up).normalize()).length() < 1e-12,
        "up"
    );
    assert!(
        (c.fov_y - d.fov_y).abs() < 1e-12,
        "fov {} vs {}",
        c.fov_y,
        d.fov_y
    );
    assert_eq!(
        (
            c.aperture_radius,
            a.film.width,
            a.film.height,
            a.film.filter
        ),
        (
            d.aperture_radius,
            b.film.width,
            b.film.height,
            b.film.filter
        )
    );
    assert_eq!(a.render, b.render);
    assert_eq!(a.meshes.len(), b.meshes.len(), "meshes");
    for (i, (m, n)) in a.meshes.iter().zip(&b.meshes).enumerate() {
        assert_eq!(m.indices, n.indices, "mesh {i} indices");
        for (p, q) in m.positions.iter().zip(&n.positions) {
            assert!((*p - *q).length() < 1e-12, "mesh {i}: {p} vs {q}");
        }
        assert_eq!(m.normals, n.normals, "mesh {i} normals");
        assert_eq!(m.uvs, n.uvs, "mesh {i} uvs");
        for (&p, &q) in m.materials.iter().zip(&n.materials) {
            assert_eq!(
                resolved(a, &a.materials[p as usize]),
                resolved(b, &b.materials[q as usize]),
                "mesh {i} material"
            );
        }
    }
    assert_eq!(a.spheres.len(), b.spheres.len(), "spheres");
    for (s, t) in a.spheres.iter().zip(&b.spheres) {
        assert!(
            (s.center - t.center).length() < 1e-12 && (s.radius - t.radius).abs() < 1e-12,
            "sphere {s:?} vs {t:?}"
        );
        assert_eq!(s.flip_normals, t.flip_normals);
        assert_eq!(
            resolved(a, &a.materials[s.material as usize]),
            resolved(b, &b.materials[t.material as usize]),
            "sphere material"
        );
    }
    assert_eq!(format!("{:?}", a.lights), format!("{:?}", b.lights));
    assert_eq!(
        format!("{:?}", a.environment),
        format!("{:?}", b.environment)
    );
}
