//! pbrt-v4 shapes → candela objects: trianglemesh and plymesh (meshes held in memory, or the PLY
//! referenced as it is when nothing changes), full spheres; each with the current material and
//! the current area light as its emission. Orientation follows pbrt: a mesh with normals has
//! each triangle's geometric normal turned towards its shading normals, one without is flipped
//! by ReverseOrientation; a transform that mirrors keeps facing, as in candela.

use glam::{DMat4, DVec3, Vec2};
use serde_json::{json, Value};

use super::params::Params;
use super::Ctx;
use crate::import::diag::Loc;
use crate::import::meshes::{face_shading_normals, file_error, flip_orientation, read_file};
use crate::import::xform::transform_value;
use crate::scene::mesh::RawMesh;
use crate::scene::{ply, SceneError};

/// A `Shape` directive.
pub(super) fn shape(ctx: &mut Ctx, ty: &str, p: &Params, loc: &Loc) -> Result<(), SceneError> {
    let what = format!("shape \"{ty}\"");
    // Step 1: geometry in object space.
    let object = match ty {
        "trianglemesh" => {
            let raw = triangle_mesh(ctx, p, loc)?;
            Some(oriented(ctx, raw, "trianglemesh"))
        }
        "plymesh" => plymesh(ctx, p, loc)?,
        "sphere" => {
            let r = p.num("radius")?.unwrap_or(1.0);
            let partial = p.num("zmin")?.is_some_and(|z| z > -r)
                || p.num("zmax")?.is_some_and(|z| z < r)
                || p.num("phimax")?.is_some_and(|f| f < 360.0);
            if partial {
                ctx.report.unsupported(
                    loc,
                    "a partial sphere (zmin, zmax, phimax) is not supported",
                    "the whole sphere",
                )?;
            }
            Some(json!({"type": "sphere", "center": [0, 0, 0], "radius": r}))
        }
        _ => {
            ctx.report.unsupported(
                loc,
                &format!("{what} is not supported (trianglemesh, plymesh and sphere are)"),
                "skipped",
            )?;
            None
        }
    };
    let Some(mut o) = object else {
        p.ignore_all();
        return Ok(());
    };
    if p.has("alpha") {
        p.ignore(&["alpha"]);
        ctx.report.unsupported(
            &p.loc("alpha", loc),
            &format!("{what}: \"alpha\" cut-outs are not supported"),
            "ignored",
        )?;
    }
    p.ignore(&["S", "faceIndices", "emissionfilename"]);
    p.finish(&mut ctx.report, &what)?;
    // Step 2: material and emission.
    let mut value = ctx.gs.material.value.clone();
    let mut hint = ctx.gs.material.hint.clone();
    if let Some((l, _)) = &ctx.gs.area {
        if ctx.defining.is_some() {
            return Err(loc.error("area lights inside ObjectBegin / ObjectEnd are not supported (pbrt-v4 refuses them too)"));
        }
        if l.iter().any(|&x| x != 0.0) {
            value["emission"] = json!(l);
            hint += "_emitter";
        }
    }
    o["material"] = json!(ctx.doc.material(&hint, value, loc));
    // Step 3: placement (spheres bake it in; an object definition stays in its own space).
    let m = match &ctx.defining {
        Some(_) => ctx.gs.ctm,
        None => ctx.world * ctx.gs.ctm,
    };
    if ty == "sphere" {
        let s = similarity_scale(&m).ok_or_else(|| {
            loc.error("a sphere under a non-uniform scale or shear is not supported")
        })?;
        // pbrt's sphere faces outwards under any transform; ReverseOrientation turns it inwards.
        if ctx.gs.reverse {
            o["flip_normals"] = json!(true);
        }
        if ctx.defining.is_some() {
            // Instances compose transforms: the sphere stays in object space.
            if let Some(t) = transform_value(&m) {
                o["transform"] = t;
            }
        } else {
            o["center"] = json!(m.transform_point3(DVec3::ZERO).to_array());
            o["radius"] = json!(o["radius"].as_f64().unwrap_or(1.0) * s);
        }
    } else if let Some(t) = transform_value(&m) {
        o["transform"] = t;
    }
    match &mut ctx.defining {
        Some((_, objects, _)) => objects.push((o, loc.clone())),
        None => ctx.doc.object(o, loc),
    }
    Ok(())
}

/// The uniform scale of a similarity transform, else None.
fn similarity_scale(m: &DMat4) -> Option<f64> {
    let c = [
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    ];
    let s = (c[0].length() + c[1].length() + c[2].length()) / 3.0;
    let ok = c.iter().all(|v| (v.length() - s).abs() <= 1e-6 * s)
        && (0..3).all(|i| (0..i).all(|j| c[i].dot(c[j]).abs() <= 1e-6 * s * s));
    (ok && s > 0.0).then_some(s)
}

/// A trianglemesh's P / N / uv / indices.
fn triangle_mesh(ctx: &Ctx, p: &Params, loc: &Loc) -> Result<RawMesh, SceneError> {
    let pos = p
        .nums("P")?
        .ok_or_else(|| loc.error("shape \"trianglemesh\" needs \"point3 P\""))?;
    if pos.len() % 3 != 0 {
        return Err(p
            .loc("P", loc)
            .error("\"P\" must hold 3 numbers per vertex"));
    }
    let n = pos.len() / 3;
    let idx = match p.nums("indices")? {
        Some(i) => i,
        None if n == 3 => vec![0.0, 1.0, 2.0],
        None => return Err(loc.error(
            "shape \"trianglemesh\" needs \"integer indices\" (unless it has exactly 3 vertices)",
        )),
    };
    if idx.len() % 3 != 0 {
        return Err(p
            .loc("indices", loc)
            .error("\"indices\" must hold 3 numbers per triangle"));
    }
    if idx.len() / 3 > ctx.limits.max_triangles {
        return Err(loc.error(format!("more than {} triangles", ctx.limits.max_triangles)));
    }
    let mut indices = Vec::with_capacity(idx.len() / 3);
    for t in idx.chunks(3) {
        let mut tri = [0u32; 3];
        for (k, &i) in t.iter().enumerate() {
            if !(i >= 0.0 && (i as usize) < n && i.fract() == 0.0) {
                return Err(p
                    .loc("indices", loc)
                    .error(format!("index {i} out of range ({n} vertices)")));
            }
            tri[k] = i as u32;
        }
        indices.push(tri);
    }
    let triples = |v: Vec<f64>| {
        v.chunks(3)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect::<Vec<_>>()
    };
    let normals = match p.nums("N")? {
        Some(v) if v.len() == pos.len() => Some(triples(v)),
        Some(_) => {
            return Err(p
                .loc("N", loc)
                .error("\"N\" must hold one normal per vertex"))
        }
        None => None,
    };
    let uvs = match p.nums("uv")? {
        Some(v) if v.len() == 2 * n => Some(
            v.chunks(2)
                .map(|c| Vec2::new(c[0] as f32, c[1] as f32))
                .collect(),
        ),
        Some(_) => {
            return Err(p
                .loc("uv", loc)
                .error("\"uv\" must hold one point2 per vertex"))
        }
        None => None,
    };
    Ok(RawMesh {
        positions: triples(pos),
        normals,
        uvs,
        indices,
    })
}

/// A mesh turned as pbrt turns it, held in memory.
fn oriented(ctx: &mut Ctx, mut raw: RawMesh, hint: &str) -> Value {
    if raw.normals.is_some() {
        face_shading_normals(&mut raw);
    } else if ctx.gs.reverse {
        flip_orientation(&mut raw);
    }
    ctx.doc.mesh_object(hint, &raw)
}

/// plymesh: the file as it is when nothing needs turning, else read and held in memory.
fn plymesh(ctx: &mut Ctx, p: &Params, loc: &Loc) -> Result<Option<Value>, SceneError> {
    let name = p
        .string("filename")?
        .ok_or_else(|| loc.error("shape \"plymesh\" needs \"string filename\""))?;
    let floc = p.loc("filename", loc);
    if name.ends_with(".gz") {
        ctx.report.unsupported(
            &floc,
            "compressed .ply.gz meshes are not supported",
            "skipped",
        )?;
        return Ok(None);
    }
    if p.has("displacement") {
        p.ignore(&["displacement", "edgelength"]);
        ctx.report.unsupported(
            &floc,
            "shape \"plymesh\": displacement is not supported",
            "ignored",
        )?;
    }
    let rel = ctx.file(&name, &floc)?;
    let bytes = read_file(&ctx.scene_dir, &rel, &name).map_err(|m| floc.error(m))?;
    let raw = ply::parse(&bytes, ctx.limits.max_triangles)
        .map_err(|e| floc.error(file_error(&name, e)))?;
    if raw.normals.is_none() && !ctx.gs.reverse {
        return Ok(Some(json!({"type": "mesh", "file": rel, "smooth": false})));
    }
    let stem = std::path::Path::new(&rel)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "plymesh".into());
    Ok(Some(oriented(ctx, raw, &stem)))
}
