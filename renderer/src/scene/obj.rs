//! Wavefront OBJ meshes through `tobj` (triangulated, single index), with `usemtl` names kept per
//! triangle so they can pick scene materials.
//!
//! tobj only reports `usemtl` names found in an MTL library, and its errors carry no line number.
//! So the text is first scanned here: the scan checks every statement tobj parses (numbers, face
//! indices in range, `usemtl` names), reporting `file:line`, counts triangles against the limit
//! before anything is built, and collects the `usemtl` names. tobj is then handed one synthetic MTL
//! library declaring exactly those names (real `mtllib` files are ignored: scene materials replace
//! them), so every face's `material_id` maps back to its name.

use std::io::Cursor;
use std::path::Path;

use glam::{DVec3, Vec2};

use super::mesh::{FileError, RawMesh};

/// An OBJ mesh: geometry plus, per triangle, an index into `names` (None: no `usemtl` applied).
#[derive(Debug, Clone, Default)]
pub(crate) struct ObjMesh {
    pub raw: RawMesh,
    pub names: Vec<String>,
    pub triangle_names: Vec<Option<u32>>,
}

/// What the pre-scan learned.
struct Scan {
    names: Vec<String>,
    triangles: usize,
}

/// The material library name given to tobj for the collected `usemtl` names.
const SYNTHETIC_MTL: &str = "\u{1}candela-usemtl-names.mtl";

/// Parses `n` leading floats (as tobj does, with its float type f32).
fn floats(words: &mut std::str::SplitWhitespace, n: usize) -> bool {
    (0..n).all(|_| words.next().is_some_and(|w| w.parse::<f32>().is_ok()))
}

/// Resolves one OBJ index (1-based, or negative = relative) against `count` elements.
fn resolve_index(text: &str, count: usize) -> Result<usize, String> {
    let x: isize = text
        .parse()
        .map_err(|_| format!("\"{text}\" is not an integer index"))?;
    let i = if x < 0 { count as isize + x } else { x - 1 };
    if x == 0 || i < 0 || i as usize >= count {
        return Err(format!("index {x} out of range ({count} defined so far)"));
    }
    Ok(i as usize)
}

/// Checks every statement tobj reads; errors are (line, message).
fn scan(text: &str, max_triangles: usize) -> Result<Scan, FileError> {
    let (mut v, mut vt, mut vn) = (0usize, 0usize, 0usize);
    let mut names: Vec<String> = Vec::new();
    let mut triangles = 0usize;
    for (i, line) in text.lines().enumerate() {
        let at = |msg: String| FileError::at(i + 1, msg);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                if !floats(&mut words, 3) {
                    return Err(at("expected 3 numbers after \"v\"".into()));
                }
                let rest: Vec<&str> = words.collect();
                match rest.len() {
                    0 | 3 => {}
                    1 => match rest[0].parse::<f32>() {
                        Ok(w) if w != 0.0 => {}
                        _ => return Err(at("the w coordinate must be a non-zero number".into())),
                    },
                    _ => return Err(at("expected x y z [w] or x y z r g b after \"v\"".into())),
                }
                v += 1;
            }
            Some("vt") => {
                if !floats(&mut words, 2) {
                    return Err(at("expected 2 numbers after \"vt\"".into()));
                }
                vt += 1;
            }
            Some("vn") => {
                if !floats(&mut words, 3) {
                    return Err(at("expected 3 numbers after \"vn\"".into()));
                }
                vn += 1;
            }
            Some("f") | Some("l") => {
                let mut n = 0usize;
                for corner in words {
                    let parts: Vec<&str> = corner.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(at(format!("bad face vertex \"{corner}\"")));
                    }
                    for (part, count, what) in [
                        (parts[0], v, "vertex"),
                        (parts.get(1).copied().unwrap_or(""), vt, "texture"),
                        (parts.get(2).copied().unwrap_or(""), vn, "normal"),
                    ] {
                        if !part.is_empty() {
                            resolve_index(part, count).map_err(|e| at(format!("{what} {e}")))?;
                        }
                    }
                    n += 1;
                }
                if n >= 3 {
                    triangles += n - 2;
                    if triangles > max_triangles {
                        return Err(at(format!(
                            "more than the limit of {max_triangles} triangles"
                        )));
                    }
                }
            }
            Some("usemtl") => {
                // Exactly tobj's reading of the name, so the names match.
                let name = line.split_once(' ').unwrap_or_default().1.trim();
                if name.is_empty() {
                    return Err(at("\"usemtl\" without a material name".into()));
                }
                if !names.iter().any(|n| n == name) {
                    names.push(name.to_string());
                }
            }
            _ => {}
        }
    }
    Ok(Scan { names, triangles })
}

/// Parses an OBJ file's bytes.
pub(crate) fn parse(data: &[u8], max_triangles: usize) -> Result<ObjMesh, FileError> {
    // tobj reads lines as UTF-8; find the first one that is not.
    let text = match std::str::from_utf8(data) {
        Ok(t) => t,
        Err(e) => {
            let line = data[..e.valid_up_to()]
                .iter()
                .filter(|&&b| b == b'\n')
                .count()
                + 1;
            return Err(FileError::at(line, "the line is not valid UTF-8 text"));
        }
    };
    let scan = scan(text, max_triangles)?;

    // tobj with the synthetic library first, so every usemtl name is known to it.
    let mut input = format!("mtllib {SYNTHETIC_MTL}\n").into_bytes();
    input.extend_from_slice(data);
    let names = scan.names.clone();
    let loader = move |p: &Path| -> tobj::MTLLoadResult {
        // The map type is tobj's (an ahash map), so build it through the result type.
        let mut result: tobj::MTLLoadResult = Ok((Vec::new(), Default::default()));
        if p == Path::new(SYNTHETIC_MTL) {
            if let Ok((mats, map)) = &mut result {
                for (i, n) in names.iter().enumerate() {
                    map.insert(n.clone(), i);
                    mats.push(tobj::Material {
                        name: n.clone(),
                        ..Default::default()
                    });
                }
            }
        }
        result
    };
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // The scan has checked what tobj indexes with; catching a panic is a last guard only.
    let loaded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        tobj::load_obj_buf(&mut Cursor::new(input), &options, loader)
    }));
    let models = match loaded {
        Ok(Ok((models, _))) => models,
        Ok(Err(e)) => return Err(FileError::whole(format!("{e}"))),
        Err(_) => return Err(FileError::whole("the OBJ reader failed on this file")),
    };

    // Merge the models into one mesh, remembering each triangle's usemtl name.
    let mut out = ObjMesh {
        names: scan.names,
        ..Default::default()
    };
    out.raw.indices.reserve(scan.triangles);
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut any_uvs = false;
    // Models without normals get zero ones, which `mesh::to_world` replaces by computed normals.
    let mut any_normals = false;
    for model in &models {
        let m = &model.mesh;
        let n = m.positions.len() / 3;
        let base = out.raw.positions.len();
        if base + n > u32::MAX as usize {
            return Err(FileError::whole("too many vertices"));
        }
        out.raw.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)),
        );
        if m.normals.len() == n * 3 {
            any_normals = true;
            normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|c| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)),
            );
        } else {
            normals.resize(base + n, DVec3::ZERO);
        }
        if m.texcoords.len() == n * 2 {
            any_uvs = true;
            uvs.extend(m.texcoords.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])));
        } else {
            uvs.resize(base + n, Vec2::ZERO);
        }
        let material = m
            .material_id
            .and_then(|id| u32::try_from(id).ok())
            .filter(|&id| (id as usize) < out.names.len());
        for t in m.indices.chunks_exact(3) {
            let tri = [t[0], t[1], t[2]];
            if tri.iter().any(|&i| i as usize >= n) {
                return Err(FileError::whole("a face refers to a missing vertex"));
            }
            out.raw.indices.push(tri.map(|i| i + base as u32));
            out.triangle_names.push(material);
        }
    }
    if !out.raw.positions.iter().all(|p| p.is_finite()) {
        return Err(FileError::whole("a vertex position is not finite"));
    }
    if !uvs.iter().all(|t| t.is_finite()) {
        return Err(FileError::whole("a texture coordinate is not finite"));
    }
    out.raw.normals = any_normals.then_some(normals);
    out.raw.uvs = any_uvs.then_some(uvs);
    Ok(out)
}
