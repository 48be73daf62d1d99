//! Mitsuba shapes → candela objects: obj / ply (`mesh`), serialized (a mesh held in memory),
//! rectangle (`quad` [-1,1]² at z = 0 under the same transform), cube (`box` [-1,1]³), sphere,
//! disk (a polygon of equal area: an approximation, warned), shapegroup + instance (candela
//! definitions and `instance` objects, import/groups.rs), each with its BSDF and, through an
//! `area` emitter, its emission.
//!
//! Mesh files are referenced as they are unless candela would read them differently from Mitsuba:
//! `flip_normals`, OBJ with `flip_tex_coords` false, and PLY (Mitsuba puts v = 0 on a PLY's
//! top texel row, candela on the bottom row) under a textured material are rewritten in memory.

use glam::{DMat4, DVec3, Vec2};
use serde_json::{json, Value};

use super::props::{ColorSrc, Plugin};
use super::scene::rgb_value;
use super::{serialized, Ctx, Mat};
use crate::import::diag::Loc;
use crate::import::groups::Group;
use crate::import::meshes::{file_error, flip_orientation, flip_v, read_file, reverse_winding};
use crate::import::xform::transform_value;
use crate::scene::desc::BoxDesc;
use crate::scene::mesh::{FileError, RawMesh};
use crate::scene::{obj, ply, shapes, SceneError};

/// Sides of the polygon standing in for a disk.
const DISK_SIDES: usize = 256;

/// A top-level `<shape>`: its objects are added to the scene.
pub(crate) fn shape(ctx: &mut Ctx, node: usize) -> Result<(), SceneError> {
    let world = ctx.world;
    if ctx.tree.nodes[node].attr("type") == Some("instance") {
        let p = Plugin::new(ctx.tree, node)?;
        return place_instance(ctx, &p, &world);
    }
    for (o, loc) in objects(ctx, node, &world)? {
        ctx.doc.object(o, &loc);
    }
    Ok(())
}

/// The candela objects of a shape, placed by `outer` after its own `to_world`.
fn objects(ctx: &mut Ctx, node: usize, outer: &DMat4) -> Result<Vec<(Value, Loc)>, SceneError> {
    let p = Plugin::new(ctx.tree, node)?;
    let loc = p.loc.clone();
    let known = [
        "obj",
        "ply",
        "serialized",
        "rectangle",
        "cube",
        "sphere",
        "disk",
    ];
    if !known.contains(&p.ty.as_str()) {
        ctx.report.unsupported(
            &loc,
            &format!(
                "{} is not supported (obj, ply, serialized, rectangle, cube, sphere, disk, shapegroup and instance are)",
                p.what()
            ),
            "skipped",
        )?;
        return Ok(Vec::new());
    }
    // Step 1: material and emission.
    let mat = shape_bsdf(ctx, &p)?;
    let emission = area_emitter(ctx, &p)?;
    for medium in ["interior", "exterior"] {
        if p.object(medium)?.is_some() {
            ctx.report.unsupported(
                &p.loc_of(medium),
                &format!("{}: participating media are not supported", p.what()),
                "ignored",
            )?;
        }
    }
    let textured = mat.textured();
    let material = material_name(ctx, &mat, emission, &loc)?;
    // Step 2: geometry.
    let own = p.transform("to_world")?;
    let to_world = *outer * own;
    if !(to_world.determinant().abs() > 0.0 && to_world.is_finite()) {
        return Err(p
            .loc_of("to_world")
            .error(format!("{}: to_world is not invertible", p.what())));
    }
    let flip = p.bool("flip_normals")?.unwrap_or(false);
    let mut o = match p.ty.as_str() {
        "rectangle" => {
            // A mirror along z keeps the points and turns the front (exactly Mitsuba's flip).
            let m = if flip {
                to_world * DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0))
            } else {
                to_world
            };
            placed(
                json!({"type": "quad", "origin": [-1, -1, 0], "edge_u": [2, 0, 0], "edge_v": [0, 2, 0]}),
                &m,
            )
        }
        "cube" if !flip => placed(
            json!({"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1]}),
            &to_world,
        ),
        "cube" => {
            let b = BoxDesc {
                min: [-1.0; 3],
                max: [1.0; 3],
            };
            let mut mesh = shapes::cube(&b, "cube").map_err(|e| loc.error(e.to_string()))?;
            flip_orientation(&mut mesh);
            let o = ctx.doc.mesh_object("cube", &mesh);
            placed(o, &to_world)
        }
        "sphere" => sphere(ctx, &p, &to_world, flip, &mat)?,
        "disk" => {
            ctx.report.warn(
                &loc,
                format!("shape \"disk\" is approximated by a {DISK_SIDES}-sided polygon of the same area"),
            );
            let mut mesh = disk_mesh();
            if flip {
                flip_orientation(&mut mesh);
            }
            let o = ctx.doc.mesh_object("disk", &mesh);
            placed(o, &to_world)
        }
        _ => mesh(ctx, &p, &to_world, own.determinant() < 0.0, flip, textured)?,
    };
    o["material"] = json!(material);
    p.finish(&mut ctx.report)?;
    Ok(vec![(o, loc)])
}

/// `o` with transform `m`.
fn placed(mut o: Value, m: &DMat4) -> Value {
    if let Some(t) = transform_value(m) {
        o["transform"] = t;
    }
    o
}

/// The shape's BSDF (nested, `<ref>`, or Mitsuba's default diffuse).
fn shape_bsdf(ctx: &mut Ctx, p: &Plugin) -> Result<Mat, SceneError> {
    let mut nodes = p.children("bsdf");
    nodes.extend(p.object("bsdf")?);
    match nodes.as_slice() {
        [] => Ok(Ctx::default_bsdf()),
        [one] => ctx.bsdf(*one),
        _ => Err(p.loc.error(format!("{}: more than one BSDF", p.what()))),
    }
}

/// The radiance of a nested `area` emitter.
fn area_emitter(ctx: &mut Ctx, p: &Plugin) -> Result<Option<[f64; 3]>, SceneError> {
    let nodes = p.children("emitter");
    let Some(&e) = nodes.first() else {
        return Ok(None);
    };
    if nodes.len() > 1 {
        return Err(p.loc.error(format!("{}: more than one emitter", p.what())));
    }
    let ep = Plugin::new(ctx.tree, e)?;
    if ep.ty != "area" {
        ctx.report.unsupported(
            &ep.loc,
            &format!(
                "{} attached to a shape is not supported (area is)",
                ep.what()
            ),
            "skipped",
        )?;
        return Ok(None);
    }
    let radiance = match ep.color("radiance")? {
        None => [1.0; 3],
        Some(ColorSrc::Const(c)) => c,
        Some(ColorSrc::Texture(_)) => {
            ctx.report.unsupported(
                &ep.loc_of("radiance"),
                "emitter \"area\": a textured radiance is not supported",
                "radiance 1",
            )?;
            [1.0; 3]
        }
    };
    ep.finish(&mut ctx.report)?;
    Ok(Some(radiance))
}

/// The scene material for `mat` with `emission`.
fn material_name(
    ctx: &mut Ctx,
    mat: &Mat,
    emission: Option<[f64; 3]>,
    loc: &Loc,
) -> Result<String, SceneError> {
    let mut value = mat.value.clone();
    let mut hint = mat.hint.clone();
    if let Some(e) = emission.filter(|e| e.iter().any(|&x| x != 0.0)) {
        if value.get("alpha_mask").is_some() {
            ctx.report.unsupported(
                loc,
                "an area emitter on a shape with a mask BSDF is not supported (Mitsuba's emitter ignores the mask)",
                "the mask is dropped",
            )?;
            if let Some(m) = value.as_object_mut() {
                m.remove("alpha_mask");
            }
        }
        value["emission"] = rgb_value(e);
        hint += "_emitter";
    }
    Ok(ctx.doc.material(&hint, value, loc))
}

/// A sphere: center and radius through the transform (which must be a similarity).
fn sphere(
    ctx: &mut Ctx,
    p: &Plugin,
    m: &DMat4,
    flip: bool,
    mat: &Mat,
) -> Result<Value, SceneError> {
    let center = p.vec3("center")?.unwrap_or(DVec3::ZERO);
    let radius = p.float("radius")?.unwrap_or(1.0);
    let cols = [
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    ];
    let s = (cols[0].length() + cols[1].length() + cols[2].length()) / 3.0;
    let similar = cols.iter().all(|c| (c.length() - s).abs() <= 1e-6 * s)
        && (0..3).all(|i| (0..i).all(|j| cols[i].dot(cols[j]).abs() <= 1e-6 * s * s));
    if !similar {
        return Err(p.loc_of("to_world").error(
            "shape \"sphere\": to_world must be a rotation, translation and uniform scale (candela's spheres stay spheres)",
        ));
    }
    // candela's sphere keeps no frame: its uv and tangent follow the world axes.
    let turned = cols
        .iter()
        .enumerate()
        .any(|(i, c)| (c[i] - s).abs() > 1e-9 * s);
    if turned && (mat.textured() || mat.value.get("anisotropic").is_some()) {
        ctx.report.unsupported(
            &p.loc_of("to_world"),
            "shape \"sphere\": a rotated or mirrored sphere (a mirrored sensor mirrors the scene) with a textured or anisotropic material is not supported (candela's sphere uv frame is the world's)",
            "the rotation is ignored",
        )?;
    }
    let mut o = json!({"type": "sphere", "center": m.transform_point3(center).to_array(), "radius": radius * s});
    if flip {
        o["flip_normals"] = json!(true);
    }
    Ok(o)
}

/// obj / ply / serialized; `mirrored`: the shape's own `to_world` mirrors (not the scene's mirror
/// for a mirrored sensor, which turns Mitsuba's fronts as candela's loader does).
fn mesh(
    ctx: &mut Ctx,
    p: &Plugin,
    to_world: &DMat4,
    mirrored: bool,
    flip: bool,
    textured: bool,
) -> Result<Value, SceneError> {
    let name = p
        .string("filename")?
        .ok_or_else(|| p.loc.error(format!("{} needs \"filename\"", p.what())))?;
    let rel = ctx.tree.resolve(p.node, &name)?;
    let smooth = !p.bool("face_normals")?.unwrap_or(false);
    let flip_tex = p.ty == "obj" && !p.bool("flip_tex_coords")?.unwrap_or(true);
    let index = p.int("shape_index")?;
    if p.ty != "serialized" && index.is_some() {
        return Err(p
            .loc_of("shape_index")
            .error("shape_index applies to serialized files only"));
    }
    let rewrite = flip || flip_tex || p.ty == "serialized" || (p.ty == "ply" && textured);
    let file = json!({"type": "mesh", "file": rel});
    let o = if !rewrite && !mirrored {
        file
    } else {
        let floc = p.loc_of("filename");
        let bytes = read_file(&ctx.tree.scene_dir, &rel, &name).map_err(|m| floc.error(m))?;
        let in_file = |e: FileError| floc.error(file_error(&name, e));
        let max = ctx.limits.max_triangles;
        let mut raw: RawMesh = match p.ty.as_str() {
            "obj" => obj::parse(&bytes, max).map_err(in_file)?.raw,
            "ply" => ply::parse(&bytes, max).map_err(in_file)?,
            _ => serialized::parse(&bytes, index.unwrap_or(0), max)
                .map_err(|e| floc.error(format!("{name}: {e}")))?,
        };
        // candela reads v = 1 on the top texel row; Mitsuba's PLY and serialized (and OBJ without
        // flip_tex_coords) put v = 0 there.
        if p.ty != "obj" || flip_tex {
            flip_v(&mut raw);
        }
        if flip {
            flip_orientation(&mut raw);
        }
        // Mitsuba keeps a mirrored mesh's vertex order, so where no vertex normals set its front
        // (none, or `face_normals`) that front is the other side than the one candela's loader
        // keeps by reversing the winding (pbrt's rule, docs/scene-format.md's transform):
        // reversed here too, the loader gives Mitsuba's order back. With vertex normals
        // Mitsuba's front follows them, as candela's does.
        let reverse = mirrored && (!smooth || raw.normals.is_none());
        if reverse {
            reverse_winding(&mut raw);
        } else if !rewrite {
            return Ok(placed(with_smooth(file, smooth), to_world));
        }
        let stem = std::path::Path::new(&rel)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "mesh".into());
        ctx.doc.mesh_object(&stem, &raw)
    };
    Ok(placed(with_smooth(o, smooth), to_world))
}

/// `o` with `smooth` set.
fn with_smooth(mut o: Value, smooth: bool) -> Value {
    o["smooth"] = json!(smooth);
    o
}

/// A regular polygon in the unit disk's place (z = 0, facing +z) with the disk's area, uv polar
/// as Mitsuba's disk (u = r, v = φ / 2π).
fn disk_mesh() -> RawMesh {
    let n = DISK_SIDES;
    let step = std::f64::consts::TAU / n as f64;
    let r = (std::f64::consts::TAU / (n as f64 * step.sin())).sqrt();
    let mut m = RawMesh {
        positions: vec![DVec3::ZERO],
        uvs: Some(vec![Vec2::ZERO]),
        ..Default::default()
    };
    for i in 0..=n {
        let phi = i as f64 * step;
        m.positions
            .push(DVec3::new(r * phi.cos(), r * phi.sin(), 0.0));
        if let Some(uvs) = &mut m.uvs {
            uvs.push(Vec2::new(1.0, (i as f64 / n as f64) as f32));
        }
    }
    for i in 0..n as u32 {
        m.indices.push([0, i + 1, i + 2]);
    }
    m
}

/// `instance`: the referenced shapegroup placed by the instance's transform (its members
/// defined once, groups.rs).
fn place_instance(ctx: &mut Ctx, p: &Plugin, outer: &DMat4) -> Result<(), SceneError> {
    let mut refs = p.children("shape");
    refs.extend(p.object("shapegroup")?);
    let [group] = refs.as_slice() else {
        return Err(p
            .loc
            .error("shape \"instance\" needs one <ref> to a shapegroup"));
    };
    let g = *group;
    if ctx.tree.nodes[g].attr("type") != Some("shapegroup") {
        return Err(p
            .loc
            .error("shape \"instance\" must refer to a shape \"shapegroup\""));
    }
    if !ctx.groups.contains_key(&g) {
        let gp = Plugin::new(ctx.tree, g)?;
        let mut members = Vec::new();
        for s in gp.children("shape") {
            if ctx.tree.nodes[s].attr("type") == Some("instance") {
                return Err(ctx.tree.nodes[s]
                    .loc
                    .error("a shapegroup cannot contain instances"));
            }
            members.extend(objects(ctx, s, &DMat4::IDENTITY)?);
        }
        gp.finish(&mut ctx.report)?;
        let name = ctx.tree.nodes[g].attr("id").unwrap_or("shapegroup");
        ctx.groups.insert(g, Group::new(name, members));
    }
    let to_world = *outer * p.transform("to_world")?;
    p.finish(&mut ctx.report)?;
    if let Some(group) = ctx.groups.get_mut(&g) {
        group.place(&mut ctx.doc, &to_world, &p.loc);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_polygon_keeps_the_area() {
        let m = disk_mesh();
        let area: f64 = m
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                0.5 * (b - a).cross(c - a).z
            })
            .sum();
        assert!((area - std::f64::consts::PI).abs() < 1e-9, "{area}");
    }
}
