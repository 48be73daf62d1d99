//! Built-in shapes as object-space triangle meshes: `quad` (Mitsuba `rectangle`), `box` (Mitsuba
//! `cube`, normals outward) and inline `triangles`. Spheres stay analytic (see `assemble`).
//!
//! Winding follows the scene convention: the geometric normal of [i0, i1, i2] is
//! normalize(cross(p1 − p0, p2 − p0)); a quad faces normalize(edge_u × edge_v), a box outward.

use glam::{DVec3, Vec2};

use super::desc::{BoxDesc, NumList, QuadDesc, TrianglesDesc};
use super::error::{join_path, SceneError};
use super::mesh::RawMesh;
use super::validate::{direction, parallel};

/// UVs for the corners origin, +u, +u+v, +v: Mitsuba's rectangle puts uv (s, t) at
/// origin + s·eu + t·ev and reads t = 0 from a texture's top row; candela reads v = 1 there
/// (texel row = (1 − v)·height), so the stored v is 1 − t.
const QUAD_UVS: [Vec2; 4] = [
    Vec2::new(0.0, 1.0),
    Vec2::new(1.0, 1.0),
    Vec2::new(1.0, 0.0),
    Vec2::new(0.0, 0.0),
];

/// Appends the parallelogram origin + s·eu + t·ev as two triangles facing eu × ev.
fn push_parallelogram(mesh: &mut RawMesh, origin: DVec3, eu: DVec3, ev: DVec3) {
    let base = mesh.positions.len() as u32;
    mesh.positions
        .extend([origin, origin + eu, origin + eu + ev, origin + ev]);
    if let Some(uvs) = &mut mesh.uvs {
        uvs.extend(QUAD_UVS);
    }
    // cross(eu, eu + ev) = eu × ev and cross(eu + ev, ev) = eu × ev: both face the front.
    mesh.indices.push([base, base + 1, base + 2]);
    mesh.indices.push([base, base + 2, base + 3]);
}

/// A `quad` object at `path`.
pub(crate) fn quad(d: &QuadDesc, path: &str) -> Result<RawMesh, SceneError> {
    let eu = DVec3::from_array(d.edge_u);
    let ev = DVec3::from_array(d.edge_v);
    direction(eu, &join_path(path, "edge_u"))?;
    direction(ev, &join_path(path, "edge_v"))?;
    if parallel(eu, ev) {
        return Err(SceneError::invalid(
            join_path(path, "edge_v"),
            "must not be parallel to edge_u",
        ));
    }
    let mut mesh = RawMesh {
        uvs: Some(Vec::with_capacity(4)),
        ..Default::default()
    };
    push_parallelogram(&mut mesh, DVec3::from_array(d.origin), eu, ev);
    Ok(mesh)
}

/// The corners of Mitsuba 3's cube (shapes/cube.cpp), four per face in the order of
/// `CUBE_UVS`, faces −y, +y, +x, +z, −x, −z; the triangles of a face are (0, 1, 2) and (3, 0, 2),
/// wound outward.
const CUBE_FACES: [[[i8; 3]; 4]; 6] = [
    [[1, -1, -1], [1, -1, 1], [-1, -1, 1], [-1, -1, -1]],
    [[1, 1, -1], [-1, 1, -1], [-1, 1, 1], [1, 1, 1]],
    [[1, -1, -1], [1, 1, -1], [1, 1, 1], [1, -1, 1]],
    [[1, -1, 1], [1, 1, 1], [-1, 1, 1], [-1, -1, 1]],
    [[-1, -1, 1], [-1, 1, 1], [-1, 1, -1], [-1, -1, -1]],
    [[1, 1, -1], [1, -1, -1], [-1, -1, -1], [-1, 1, -1]],
];

/// Mitsuba's uvs of each face's four corners (Mitsuba's v: 0 on a texture's top row).
const CUBE_UVS: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];

/// A `box` object at `path`: 6 faces × 2 triangles, per-face UVs, normals outward, exactly
/// Mitsuba's `cube` scaled and moved onto [min, max].
pub(crate) fn cube(d: &BoxDesc, path: &str) -> Result<RawMesh, SceneError> {
    let min = DVec3::from_array(d.min);
    let max = DVec3::from_array(d.max);
    for axis in 0..3 {
        if min[axis] >= max[axis] {
            return Err(SceneError::invalid(
                join_path(path, "max"),
                format!(
                    "must be greater than min on every axis, got min [{}, {}, {}], max [{}, {}, {}]",
                    min.x, min.y, min.z, max.x, max.y, max.z
                ),
            ));
        }
    }
    // Mitsuba's cube (shapes/cube.cpp) on [−1, 1]³ mapped onto [min, max]: its corners,
    // uvs and triangles face by face, so that textures and anisotropic tangents (dp/du) agree.
    let extent = max - min;
    let mut mesh = RawMesh {
        uvs: Some(Vec::with_capacity(24)),
        ..Default::default()
    };
    for face in CUBE_FACES {
        let base = mesh.positions.len() as u32;
        for (corner, uv) in face.iter().zip(CUBE_UVS) {
            let unit = DVec3::from_array(corner.map(|c| c as f64));
            mesh.positions.push(min + (unit + 1.0) * 0.5 * extent);
            if let Some(uvs) = &mut mesh.uvs {
                // candela reads v = 1 on a texture's top row, Mitsuba v = 0 (see QUAD_UVS).
                uvs.push(Vec2::new(uv[0], 1.0 - uv[1]));
            }
        }
        mesh.indices.push([base, base + 1, base + 2]);
        mesh.indices.push([base + 3, base, base + 2]);
    }
    Ok(mesh)
}

/// Reads a list of `arity`-tuples written flat or nested; `what` describes one element.
fn tuples(list: &NumList, arity: usize, path: &str, what: &str) -> Result<usize, SceneError> {
    match list.nested {
        Some(n) if n != arity => Err(SceneError::invalid(
            path,
            format!("expected {what} ({arity} numbers each), got arrays of {n}"),
        )),
        None if !list.values.len().is_multiple_of(arity) => Err(SceneError::invalid(
            path,
            format!(
                "expected a multiple of {arity} numbers ({what}), got {}",
                list.values.len()
            ),
        )),
        _ => Ok(list.values.len() / arity),
    }
}

/// The JSON path of component `k` of tuple `t` in a flat or nested list of triples.
fn element_path(path: &str, list: &NumList, t: usize, k: usize) -> String {
    match list.nested {
        Some(_) => format!("{path}[{t}][{k}]"),
        None => format!("{path}[{}]", t * 3 + k),
    }
}

/// A `triangles` object at `path`; `max_triangles` bounds the index count.
pub(crate) fn triangles(
    d: &TrianglesDesc,
    path: &str,
    max_triangles: usize,
) -> Result<RawMesh, SceneError> {
    let p_path = join_path(path, "positions");
    let n = tuples(&d.positions, 3, &p_path, "[x,y,z] positions")?;
    if n > u32::MAX as usize {
        return Err(SceneError::invalid(p_path, "too many vertices"));
    }
    let positions: Vec<DVec3> = d
        .positions
        .values
        .chunks_exact(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect();

    let i_path = join_path(path, "indices");
    let count = tuples(&d.indices, 3, &i_path, "[i,j,k] triangles")?;
    if count > max_triangles {
        return Err(SceneError::invalid(
            i_path,
            format!("{count} triangles exceeds the limit of {max_triangles}"),
        ));
    }
    let mut indices = Vec::with_capacity(count);
    for (t, c) in d.indices.values.chunks_exact(3).enumerate() {
        let mut tri = [0u32; 3];
        for (k, (slot, &x)) in tri.iter_mut().zip(c).enumerate() {
            if !(x >= 0.0 && x.fract() == 0.0 && x < n as f64) {
                return Err(SceneError::invalid(
                    element_path(&i_path, &d.indices, t, k),
                    format!("index {x} is not a vertex index in [0, {n})"),
                ));
            }
            *slot = x as u32;
        }
        indices.push(tri);
    }

    let normals = match &d.normals {
        None => None,
        Some(list) => {
            let np = join_path(path, "normals");
            let m = tuples(list, 3, &np, "[x,y,z] normals")?;
            if m != n {
                return Err(SceneError::invalid(
                    np,
                    format!("expected {n} normals (one per position), got {m}"),
                ));
            }
            let v: Vec<DVec3> = list
                .values
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2]))
                .collect();
            if let Some(i) = v.iter().position(|n| n.length() == 0.0) {
                return Err(SceneError::invalid(
                    element_path(&np, list, i, 0),
                    "normals must be non-zero",
                ));
            }
            Some(v)
        }
    };
    let uvs = match &d.uvs {
        None => None,
        Some(list) => {
            let up = join_path(path, "uvs");
            let m = tuples(list, 2, &up, "[u,v] pairs")?;
            if m != n {
                return Err(SceneError::invalid(
                    up,
                    format!("expected {n} uvs (one per position), got {m}"),
                ));
            }
            let v: Vec<Vec2> = list
                .values
                .chunks_exact(2)
                .map(|c| Vec2::new(c[0] as f32, c[1] as f32))
                .collect();
            if let Some(i) = v.iter().position(|t| !t.is_finite()) {
                return Err(SceneError::invalid(
                    match list.nested {
                        Some(_) => format!("{up}[{i}]"),
                        None => format!("{up}[{}]", 2 * i),
                    },
                    "texture coordinates must fit in a 32-bit float",
                ));
            }
            Some(v)
        }
    };
    Ok(RawMesh {
        positions,
        normals,
        uvs,
        indices,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mesh::{geometric_normal, to_world, Materials, Shading};
    use crate::scene::transform::Transform;

    fn world(raw: RawMesh) -> crate::scene::TriangleMesh {
        to_world(
            raw,
            &Transform::identity(),
            Shading::Flat,
            "t".into(),
            Materials::All(0),
            "p",
        )
        .unwrap()
    }

    #[test]
    fn quad_faces_edge_u_cross_edge_v() {
        let d: QuadDesc = serde_json::from_str(
            r#"{"origin": [0, 0, 0], "edge_u": [0, 0, 2], "edge_v": [3, 0, 0]}"#,
        )
        .unwrap();
        let m = world(quad(&d, "q").unwrap());
        let front = DVec3::new(0.0, 0.0, 2.0)
            .cross(DVec3::new(3.0, 0.0, 0.0))
            .normalize();
        assert_eq!(front, DVec3::Y);
        for t in 0..2 {
            assert!((geometric_normal(&m, t) - front).length() < 1e-12);
        }
        assert_eq!(
            m.uvs.as_ref().unwrap()[2],
            Vec2::X,
            "Mitsuba's t = 1 is candela's v = 0"
        );
        assert_eq!(m.positions[2], DVec3::new(3.0, 0.0, 2.0));
        let d: QuadDesc = serde_json::from_str(
            r#"{"origin": [0, 0, 0], "edge_u": [1, 0, 0], "edge_v": [-2, 0, 0]}"#,
        )
        .unwrap();
        assert_eq!(
            quad(&d, "objects[1]").unwrap_err().path(),
            Some("objects[1].edge_v")
        );
    }

    #[test]
    fn box_normals_point_outward() {
        let d: BoxDesc = serde_json::from_str(r#"{"min": [-1, 0, 2], "max": [1, 3, 5]}"#).unwrap();
        let m = world(cube(&d, "b").unwrap());
        assert_eq!(m.indices.len(), 12);
        let center = DVec3::new(0.0, 1.5, 3.5);
        let mut seen = Vec::new();
        for t in 0..12 {
            let n = geometric_normal(&m, t);
            let [a, b, c] = m.indices[t].map(|i| m.positions[i as usize]);
            let centroid = (a + b + c) / 3.0;
            assert!(n.dot(centroid - center) > 0.0, "triangle {t} faces inward");
            // Axis-aligned and lying on the face it claims.
            assert!((n.abs().max_element() - 1.0).abs() < 1e-12);
            seen.push(n);
        }
        for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
            assert_eq!(seen.iter().filter(|&&n| n == axis || n == -axis).count(), 4);
        }
        let bad: BoxDesc = serde_json::from_str(r#"{"min": [0, 0, 0], "max": [1, 0, 1]}"#).unwrap();
        assert_eq!(
            cube(&bad, "objects[4]").unwrap_err().path(),
            Some("objects[4].max")
        );
    }

    #[test]
    fn box_has_mitsubas_cube_uvs_and_tangents() {
        // Mitsuba 3.9.1 scalar_rgb, `cube`: the direction of dp/du (the anisotropic tangent) on
        // each face, by outward normal, and uv (0.565, 0.565) where a ray up from (0.13, −5, 0.13)
        // meets the −y face.
        let want = [
            (-DVec3::Y, DVec3::Z),
            (DVec3::Y, -DVec3::X),
            (DVec3::X, DVec3::Y),
            (DVec3::Z, DVec3::Y),
            (-DVec3::X, DVec3::Y),
            (-DVec3::Z, -DVec3::Y),
        ];
        let d: BoxDesc =
            serde_json::from_str(r#"{"min": [-1, -1, -1], "max": [1, 1, 1]}"#).unwrap();
        let m = cube(&d, "b").unwrap();
        let uvs = m.uvs.as_ref().unwrap();
        for t in 0..12 {
            let [i0, i1, i2] = m.indices[t].map(|i| i as usize);
            let (dp1, dp2) = (
                m.positions[i1] - m.positions[i0],
                m.positions[i2] - m.positions[i0],
            );
            let (d1, d2) = (
                (uvs[i1] - uvs[i0]).as_dvec2(),
                (uvs[i2] - uvs[i0]).as_dvec2(),
            );
            let dp_du = (dp1 * d2.y - dp2 * d1.y) / (d1.x * d2.y - d2.x * d1.y);
            let n = dp1.cross(dp2).normalize();
            let (_, axis) = want
                .iter()
                .find(|(w, _)| (*w - n).length() < 1e-12)
                .unwrap();
            assert!(
                (dp_du.normalize() - *axis).length() < 1e-12,
                "triangle {t}: dp/du {dp_du}"
            );
        }
        // The −y face's point (0.13, −1, 0.13): uv by barycentric interpolation on its triangle.
        let p = DVec3::new(0.13, -1.0, 0.13);
        let uv = (0..2)
            .find_map(|t| {
                let [a, b, c] = m.indices[t].map(|i| i as usize);
                let (pa, pb, pc) = (m.positions[a], m.positions[b], m.positions[c]);
                let area = (pb - pa).cross(pc - pa).length();
                let wa = (pb - p).cross(pc - p).length() / area;
                let wb = (pc - p).cross(pa - p).length() / area;
                let wc = (pa - p).cross(pb - p).length() / area;
                ((wa + wb + wc - 1.0).abs() < 1e-9).then(|| {
                    uvs[a].as_dvec2() * wa + uvs[b].as_dvec2() * wb + uvs[c].as_dvec2() * wc
                })
            })
            .unwrap();
        // candela's v is 1 − Mitsuba's.
        assert!(
            (uv - glam::DVec2::new(0.565, 0.435)).length() < 1e-9,
            "{uv}"
        );
    }

    #[test]
    fn triangles_flat_and_nested_agree() {
        let flat: TrianglesDesc = serde_json::from_str(
            r#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1, 2], "uvs": [0,0, 1,0, 0,1]}"#,
        )
        .unwrap();
        let nested: TrianglesDesc = serde_json::from_str(
            r#"{"positions": [[0,0,0], [1,0,0], [0,1,0]], "indices": [[0, 1, 2]], "uvs": [[0,0], [1,0], [0,1]]}"#,
        )
        .unwrap();
        assert_eq!(
            triangles(&flat, "o", 10).unwrap(),
            triangles(&nested, "o", 10).unwrap()
        );
    }

    #[test]
    fn triangles_errors_name_the_field() {
        let check = |json: &str, path: &str| {
            let d: TrianglesDesc = serde_json::from_str(json).unwrap();
            let e = triangles(&d, "objects[1]", 10).unwrap_err();
            assert_eq!(e.path(), Some(path), "{e}");
        };
        check(
            r#"{"positions": [0,0,0, 1,0], "indices": []}"#,
            "objects[1].positions",
        );
        check(
            r#"{"positions": [[0,0], [1,0]], "indices": []}"#,
            "objects[1].positions",
        );
        check(
            r#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1]}"#,
            "objects[1].indices",
        );
        check(
            r#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1, 3]}"#,
            "objects[1].indices[2]",
        );
        check(
            r#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1, 1.5]}"#,
            "objects[1].indices[2]",
        );
        check(
            r#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1, 2], "normals": [0,0,1]}"#,
            "objects[1].normals",
        );
        check(
            r#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0, 1, 2], "uvs": [0,0, 1,0]}"#,
            "objects[1].uvs",
        );
        let d: TrianglesDesc = serde_json::from_str(
            r#"{"positions": [0,0,0, 1,0,0, 0,1,0], "indices": [0,1,2, 0,2,1]}"#,
        )
        .unwrap();
        assert!(triangles(&d, "o", 1).is_err());
    }
}
