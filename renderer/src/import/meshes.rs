//! Meshes an importer builds in memory (`RawMesh`, the loader's own object-space mesh): written as
//! binary little-endian PLY, which candela's PLY reader reads back exactly (positions as `float`
//! when every coordinate is an f32, else `double`), plus the edits importers need: reversed
//! winding, mirrored texture v, and winding turned to face the shading normals.

use std::path::Path;

use glam::DVec3;

use crate::scene::mesh::{FileError, RawMesh};

/// The bytes of a mesh file the scene names (`rel` inside `dir`), or a message naming it as
/// `shown`.
pub fn read_file(dir: &Path, rel: &str, shown: &str) -> Result<Vec<u8>, String> {
    std::fs::read(dir.join(rel))
        .map_err(|e| format!("cannot read \"{shown}\": {}", crate::scene::io_message(&e)))
}

/// An error inside mesh file `shown`: `shown:LINE: msg` (no line inside binary data).
pub fn file_error(shown: &str, e: FileError) -> String {
    match e.line {
        Some(l) => format!("{shown}:{l}: {}", e.msg),
        None => format!("{shown}: {}", e.msg),
    }
}

/// The mesh as a binary little-endian PLY file.
pub fn to_ply(mesh: &RawMesh) -> Vec<u8> {
    let exact_f32 = mesh
        .positions
        .iter()
        .all(|p| p.to_array().iter().all(|&c| (c as f32) as f64 == c));
    let pos_type = if exact_f32 { "float" } else { "double" };
    let mut head = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by candela's importer\nelement vertex {}\n",
        mesh.positions.len()
    );
    for axis in ["x", "y", "z"] {
        head += &format!("property {pos_type} {axis}\n");
    }
    if mesh.normals.is_some() {
        head += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if mesh.uvs.is_some() {
        head += "property float u\nproperty float v\n";
    }
    head += &format!(
        "element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.indices.len()
    );
    let per_vertex = 3 * if exact_f32 { 4 } else { 8 }
        + mesh.normals.as_ref().map_or(0, |_| 12)
        + mesh.uvs.as_ref().map_or(0, |_| 8);
    let mut out = Vec::with_capacity(
        head.len() + mesh.positions.len() * per_vertex + mesh.indices.len() * 13,
    );
    out.extend_from_slice(head.as_bytes());
    for (i, p) in mesh.positions.iter().enumerate() {
        for c in p.to_array() {
            if exact_f32 {
                out.extend_from_slice(&(c as f32).to_le_bytes());
            } else {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        if let Some(n) = &mesh.normals {
            for c in n[i].to_array() {
                out.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        if let Some(uv) = &mesh.uvs {
            out.extend_from_slice(&uv[i].x.to_le_bytes());
            out.extend_from_slice(&uv[i].y.to_le_bytes());
        }
    }
    for t in &mesh.indices {
        out.push(3);
        for i in t {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

/// Reverses every triangle's winding (its second and third vertices swapped), normals untouched.
pub fn reverse_winding(mesh: &mut RawMesh) {
    for t in &mut mesh.indices {
        t.swap(1, 2);
    }
}

/// Reverses every triangle's winding and negates the normals (the other side becomes the front).
pub fn flip_orientation(mesh: &mut RawMesh) {
    reverse_winding(mesh);
    if let Some(n) = &mut mesh.normals {
        for v in n {
            *v = -*v;
        }
    }
}

/// `v → 1 − v` (between a top-row-is-v=0 convention and candela's, where v = 1 is the top row).
pub fn flip_v(mesh: &mut RawMesh) {
    if let Some(uvs) = &mut mesh.uvs {
        for uv in uvs {
            uv.y = 1.0 - uv.y;
        }
    }
}

/// Turns each triangle so its geometric normal lies on the side of the mean of its vertices'
/// shading normals (pbrt's rule for meshes with normals); no-op without normals.
pub fn face_shading_normals(mesh: &mut RawMesh) {
    let Some(normals) = &mesh.normals else {
        return;
    };
    for t in &mut mesh.indices {
        let [a, b, c] = t.map(|i| i as usize);
        let (Some(&p0), Some(&p1), Some(&p2)) = (
            mesh.positions.get(a),
            mesh.positions.get(b),
            mesh.positions.get(c),
        ) else {
            continue;
        };
        let ng = (p1 - p0).cross(p2 - p0);
        let ns: DVec3 = [a, b, c]
            .iter()
            .filter_map(|&i| normals.get(i))
            .copied()
            .sum();
        if ng.dot(ns) < 0.0 {
            t.swap(1, 2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::ply;
    use glam::Vec2;

    fn tri() -> RawMesh {
        RawMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            normals: Some(vec![DVec3::Z; 3]),
            uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::Y]),
            indices: vec![[0, 1, 2]],
        }
    }

    #[test]
    fn ply_round_trips_through_the_reader() {
        let mut m = tri();
        assert_eq!(ply::parse(&to_ply(&m), 10).unwrap(), m);
        m.positions[1] = DVec3::new(0.1, 0.0, 1e-30);
        m.normals = None;
        let back = ply::parse(&to_ply(&m), 10).unwrap();
        assert_eq!(back, m, "double positions when f32 would round");
    }

    #[test]
    fn edits() {
        let mut m = tri();
        flip_orientation(&mut m);
        assert_eq!(m.indices[0], [0, 2, 1]);
        assert_eq!(m.normals.as_ref().unwrap()[0], -DVec3::Z);
        face_shading_normals(&mut m);
        assert_eq!(m.indices[0], [0, 2, 1], "already facing its normals");
        m.normals = Some(vec![DVec3::Z; 3]);
        face_shading_normals(&mut m);
        assert_eq!(m.indices[0], [0, 1, 2], "turned back to face the normals");
        flip_v(&mut m);
        assert_eq!(m.uvs.as_ref().unwrap()[0], Vec2::new(0.0, 1.0));
    }
}
