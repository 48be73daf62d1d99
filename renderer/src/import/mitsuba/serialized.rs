//! Mitsuba's `serialized` mesh format (Mitsuba's `src/shapes/serialized.cpp`): a file of meshes,
//! each `u16 0x041C, u16 version (3 or 4)` then a zlib stream with `u32 flags`, (version 4) a
//! NUL-terminated name, `u64` vertex and triangle counts, positions, optional normals, uvs and
//! colours (f32 or f64 by flag), and `u32` indices (`u64` past 2³² vertices). The file ends with
//! the byte offset of every mesh (u64 in version 4, u32 in 3) and their count (u32).
//!
//! Counts are checked against the triangle limit and the bytes actually decompressed before
//! anything is allocated for them.

use std::io::Read;

use glam::{DVec3, Vec2};

use crate::scene::mesh::RawMesh;

const MAGIC: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const DOUBLE: u32 = 0x2000;

/// Reads mesh `index` of a serialized file (uvs as stored: Mitsuba's v = 0 is the top row).
pub(crate) fn parse(data: &[u8], index: i64, max_triangles: usize) -> Result<RawMesh, String> {
    // Step 1: where the mesh starts.
    let offset = if index == 0 {
        0
    } else {
        mesh_offset(data, index)?
    };
    let head = data
        .get(offset..offset + 4)
        .ok_or("truncated file (no mesh header)")?;
    let magic = u16::from_le_bytes([head[0], head[1]]);
    let version = u16::from_le_bytes([head[2], head[3]]);
    if magic != MAGIC || !(3..=4).contains(&version) {
        return Err(format!(
            "not a Mitsuba serialized mesh (header {magic:#06x}, version {version})"
        ));
    }
    // Step 2: the compressed body, read as it is needed.
    let mut z = Body(flate2::read::ZlibDecoder::new(&data[offset + 4..]));
    let flags = z.u32()?;
    if version == 4 {
        let mut n = 0;
        while z.bytes::<1>()?[0] != 0 {
            n += 1;
            if n > 4096 {
                return Err("mesh name too long".into());
            }
        }
    }
    let (nv, nt) = (z.u64()?, z.u64()?);
    if nt > max_triangles as u64 || nv > 3 * nt.max(1) + (1 << 20) {
        return Err(format!(
            "{nv} vertices and {nt} triangles exceed the limit of {max_triangles} triangles"
        ));
    }
    let (nv, nt) = (nv as usize, nt as usize);
    let double = flags & DOUBLE != 0;
    let vec3s = |z: &mut Body<'_>| -> Result<Vec<DVec3>, String> {
        let mut out = Vec::with_capacity(nv.min(1 << 20));
        for _ in 0..nv {
            out.push(DVec3::new(
                z.real(double)?,
                z.real(double)?,
                z.real(double)?,
            ));
        }
        Ok(out)
    };
    let positions = vec3s(&mut z)?;
    let normals = if flags & HAS_NORMALS != 0 {
        Some(vec3s(&mut z)?)
    } else {
        None
    };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        let mut out = Vec::with_capacity(nv.min(1 << 20));
        for _ in 0..nv {
            out.push(Vec2::new(z.real(double)? as f32, z.real(double)? as f32));
        }
        Some(out)
    } else {
        None
    };
    if flags & HAS_COLORS != 0 {
        for _ in 0..3 * nv {
            z.real(double)?;
        }
    }
    let mut indices = Vec::with_capacity(nt.min(1 << 20));
    for _ in 0..nt {
        let mut t = [0u32; 3];
        for i in &mut t {
            let v = if nv > u32::MAX as usize {
                z.u64()?
            } else {
                z.u32()? as u64
            };
            if v >= nv as u64 {
                return Err(format!("vertex index {v} out of range ({nv} vertices)"));
            }
            *i = v as u32;
        }
        indices.push(t);
    }
    Ok(RawMesh {
        positions,
        normals,
        uvs,
        indices,
    })
}

/// The byte offset of mesh `index` from the table at the end of the file.
fn mesh_offset(data: &[u8], index: i64) -> Result<usize, String> {
    let n = data.len();
    let count = data
        .get(n.saturating_sub(4)..)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as i64)
        .ok_or("truncated file")?;
    if index < 0 || index >= count {
        return Err(format!(
            "shape_index {index} out of range (the file holds {count} meshes)"
        ));
    }
    let version = data
        .get(2..4)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .unwrap_or(0);
    let at = |width: usize| n.checked_sub(4 + width * (count - index) as usize);
    let offset = if version == 4 {
        let i = at(8).ok_or("truncated offset table")?;
        u64::from_le_bytes(
            data[i..i + 8]
                .try_into()
                .map_err(|_| "truncated offset table")?,
        ) as usize
    } else {
        let i = at(4).ok_or("truncated offset table")?;
        u32::from_le_bytes(
            data[i..i + 4]
                .try_into()
                .map_err(|_| "truncated offset table")?,
        ) as usize
    };
    if offset >= n {
        return Err("mesh offset beyond the end of the file".into());
    }
    Ok(offset)
}

/// The decompressed stream.
struct Body<'a>(flate2::read::ZlibDecoder<&'a [u8]>);

impl Body<'_> {
    fn bytes<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let mut b = [0u8; N];
        self.0
            .read_exact(&mut b)
            .map_err(|e| format!("truncated or corrupt mesh data ({e})"))?;
        Ok(b)
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.bytes()?))
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.bytes()?))
    }
    fn real(&mut self, double: bool) -> Result<f64, String> {
        Ok(if double {
            f64::from_le_bytes(self.bytes()?)
        } else {
            f32::from_le_bytes(self.bytes()?) as f64
        })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::io::Write;

    /// A serialized file of `meshes` (version 4, f32, uvs), as Mitsuba writes it.
    pub(crate) fn write(meshes: &[RawMesh]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for m in meshes {
            offsets.push(out.len() as u64);
            out.extend_from_slice(&MAGIC.to_le_bytes());
            out.extend_from_slice(&4u16.to_le_bytes());
            let mut body = Vec::new();
            let flags = HAS_TEXCOORDS | if m.normals.is_some() { HAS_NORMALS } else { 0 } | 0x1000;
            body.extend_from_slice(&flags.to_le_bytes());
            body.extend_from_slice(b"mesh\0");
            body.extend_from_slice(&(m.positions.len() as u64).to_le_bytes());
            body.extend_from_slice(&(m.indices.len() as u64).to_le_bytes());
            for p in &m.positions {
                for c in p.to_array() {
                    body.extend_from_slice(&(c as f32).to_le_bytes());
                }
            }
            if let Some(n) = &m.normals {
                for p in n {
                    for c in p.to_array() {
                        body.extend_from_slice(&(c as f32).to_le_bytes());
                    }
                }
            }
            for uv in m.uvs.as_ref().unwrap() {
                body.extend_from_slice(&uv.x.to_le_bytes());
                body.extend_from_slice(&uv.y.to_le_bytes());
            }
            for t in &m.indices {
                for i in t {
                    body.extend_from_slice(&i.to_le_bytes());
                }
            }
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            z.write_all(&body).unwrap();
            out.extend(z.finish().unwrap());
        }
        for o in &offsets {
            out.extend_from_slice(&o.to_le_bytes());
        }
        out.extend_from_slice(&(meshes.len() as u32).to_le_bytes());
        out
    }

    pub(crate) fn triangle(z: f64) -> RawMesh {
        RawMesh {
            positions: vec![DVec3::new(0.0, 0.0, z), DVec3::X, DVec3::Y],
            normals: None,
            uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::Y]),
            indices: vec![[0, 1, 2]],
        }
    }

    #[test]
    fn reads_each_mesh_and_refuses_bad_input() {
        let file = write(&[triangle(0.0), triangle(2.0)]);
        assert_eq!(parse(&file, 0, 10).unwrap(), triangle(0.0));
        assert_eq!(parse(&file, 1, 10).unwrap(), triangle(2.0));
        assert!(parse(&file, 2, 10).unwrap_err().contains("out of range"));
        assert!(parse(&file[..20], 0, 10).unwrap_err().contains("truncated"));
        assert!(parse(&file, 0, 0).unwrap_err().contains("exceed the limit"));
        assert!(parse(b"nope", 0, 10)
            .unwrap_err()
            .contains("not a Mitsuba serialized"));
    }
}
