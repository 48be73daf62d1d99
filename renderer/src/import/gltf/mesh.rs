//! A glTF mesh primitive → a candela `mesh` over a PLY held in memory (one per primitive: a
//! definition placed by an `instance` object per node that uses its mesh, written in place when
//! one node does, import/groups.rs). Triangle strips and fans become
//! triangles; texture v is flipped (glTF puts v = 0 on the top row, candela v = 1); without
//! normals the mesh is flat-shaded, as glTF requires. Vertex colours other than white and points
//! or lines are unsupported.

use glam::{DMat4, DVec3, Vec2};
use serde_json::Value;

use super::{materials, Ctx};
use crate::import::groups::Group;
use crate::scene::mesh::RawMesh;
use crate::scene::SceneError;

/// Places `prim` by the node's transform `m` (its mesh defined at the first placement);
/// false (nothing placed) when it is skipped under --lenient.
pub(super) fn place_primitive(
    ctx: &mut Ctx,
    mesh: &::gltf::Mesh,
    prim: &::gltf::Primitive,
    m: &DMat4,
) -> Result<bool, SceneError> {
    let key = (mesh.index(), prim.index());
    let path = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
    let loc = ctx.at(&path);
    if !ctx.primitives.contains_key(&key) {
        let group = build(ctx, mesh, prim, &path)?
            .map(|(hint, o)| Group::new(&hint, vec![(o, loc.clone())]));
        ctx.primitives.insert(key, group);
    }
    let Some(Some(group)) = ctx.primitives.get_mut(&key) else {
        return Ok(false);
    };
    group.place(&mut ctx.doc, m, &loc);
    Ok(true)
}

fn build(
    ctx: &mut Ctx,
    mesh: &::gltf::Mesh,
    prim: &::gltf::Primitive,
    path: &str,
) -> Result<Option<(String, Value)>, SceneError> {
    use ::gltf::mesh::Mode;
    let at = ctx.at(path);
    let mode = prim.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        ctx.report.unsupported(
            &at,
            &format!("primitive mode {mode:?} is not supported (triangles, strips and fans are)"),
            "skipped",
        )?;
        return Ok(None);
    }
    // Step 1: attributes (owned, so the buffers are free again for the material).
    let (raw, white) = {
        let buffers = &ctx.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let positions: Vec<DVec3> = reader
            .read_positions()
            .ok_or_else(|| at.error("no POSITION attribute"))?
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        let n = positions.len();
        let normals: Option<Vec<DVec3>> = reader.read_normals().map(|it| {
            it.map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                .collect()
        });
        let uvs: Option<Vec<Vec2>> = reader
            .read_tex_coords(0)
            .map(|t| t.into_f32().map(|[u, v]| Vec2::new(u, 1.0 - v)).collect());
        let white = reader.read_colors(0).is_none_or(|c| {
            c.into_rgba_f32()
                .all(|[r, g, b, _]| r >= 0.999 && g >= 0.999 && b >= 0.999)
        });
        let list: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..n as u32).collect(),
        };
        if let Some(&bad) = list.iter().find(|&&i| i as usize >= n) {
            return Err(at.error(format!("index {bad} out of range ({n} vertices)")));
        }
        if normals.as_ref().is_some_and(|v| v.len() != n)
            || uvs.as_ref().is_some_and(|v| v.len() != n)
        {
            return Err(at.error("attribute counts differ from POSITION's"));
        }
        let indices = triangles(&list, mode);
        if indices.len() > ctx.limits.max_triangles {
            return Err(at.error(format!(
                "{} triangles exceed the limit of {}",
                indices.len(),
                ctx.limits.max_triangles
            )));
        }
        (
            RawMesh {
                positions,
                normals,
                uvs,
                indices,
            },
            white,
        )
    };
    if !white {
        ctx.report
            .unsupported(&at, "vertex colours (COLOR_0) are not supported", "ignored")?;
    }
    if raw.indices.is_empty() {
        return Ok(None);
    }
    // Step 2: material and the PLY.
    let material = materials::material(ctx, &prim.material())?;
    let hint = mesh
        .name()
        .map(|n| format!("{n}_{}", prim.index()))
        .unwrap_or_else(|| format!("mesh{}_{}", mesh.index(), prim.index()));
    let mut o = ctx.doc.mesh_object(&hint, &raw);
    o["material"] = Value::from(material);
    Ok(Some((hint, o)))
}

/// Triangles of an index list in `mode` (strips alternate winding; fans share the first vertex).
fn triangles(list: &[u32], mode: ::gltf::mesh::Mode) -> Vec<[u32; 3]> {
    use ::gltf::mesh::Mode;
    match mode {
        Mode::TriangleStrip => (0..list.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [list[i], list[i + 1], list[i + 2]]
                } else {
                    [list[i + 1], list[i], list[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..list.len().saturating_sub(1))
            .map(|i| [list[0], list[i], list[i + 1]])
            .collect(),
        _ => list.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ::gltf::mesh::Mode;

    #[test]
    fn strips_and_fans() {
        assert_eq!(
            triangles(&[0, 1, 2, 3], Mode::TriangleStrip),
            vec![[0, 1, 2], [2, 1, 3]]
        );
        assert_eq!(
            triangles(&[0, 1, 2, 3], Mode::TriangleFan),
            vec![[0, 1, 2], [0, 2, 3]]
        );
        assert_eq!(triangles(&[0, 1, 2, 3], Mode::Triangles), vec![[0, 1, 2]]);
    }
}
