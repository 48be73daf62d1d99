//! A PLY reader (Greg Turk's format, as written by Stanford scanners, Blender and Meshlab).
//!
//! Supports `format ascii 1.0`, `binary_little_endian 1.0` and `binary_big_endian 1.0`; every
//! scalar type (char/uchar/short/ushort/int/uint/float/double and the int8..float64 aliases);
//! vertex properties x, y, z, nx, ny, nz and u,v / s,t / texture_u,texture_v / texture_s,texture_t;
//! faces as a `vertex_indices` (or `vertex_index`) list, fan-triangulated. Other elements and
//! properties, lists included, are skipped. Every count in the header is checked against the bytes
//! that follow it before anything is allocated, so a header claiming 10^12 vertices is an error.

use glam::{DVec3, Vec2};

use super::mesh::{FileError, RawMesh};
use super::ply_body::{Ascii, Binary, Source};

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    /// Size in bytes in binary files.
    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
    pub(crate) fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    /// Header line declaring it.
    line: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the body.
    body: usize,
    /// Number of header lines (the body's first line is `lines + 1`).
    lines: usize,
}

/// Parses the header, up to and including `end_header`.
fn parse_header(data: &[u8]) -> Result<Header, FileError> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(rel_end) = data[pos..].iter().position(|&b| b == b'\n') else {
            return Err(FileError::at(line_no.max(1), "missing \"end_header\""));
        };
        let raw = &data[pos..pos + rel_end];
        pos += rel_end + 1;
        line_no += 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let Ok(line) = std::str::from_utf8(raw) else {
            return Err(FileError::at(line_no, "the header is not text"));
        };
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        if line_no == 1 {
            if words != ["ply"] {
                return Err(FileError::at(
                    1,
                    "not a PLY file (the first line must be \"ply\")",
                ));
            }
            continue;
        }
        match words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                if format.is_some() {
                    return Err(FileError::at(line_no, "a second \"format\" line"));
                }
                let f = match words.get(1).copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLe,
                    Some("binary_big_endian") => Format::BinaryBe,
                    _ => {
                        return Err(FileError::at(
                            line_no,
                            format!("unknown format \"{line}\" (expected ascii, binary_little_endian or binary_big_endian)"),
                        ))
                    }
                };
                if words.get(2) != Some(&"1.0") || words.len() != 3 {
                    return Err(FileError::at(line_no, "only PLY version 1.0 is supported"));
                }
                format = Some(f);
            }
            Some("element") => {
                let (Some(name), Some(count), 3) = (words.get(1), words.get(2), words.len()) else {
                    return Err(FileError::at(
                        line_no,
                        "expected \"element <name> <count>\"",
                    ));
                };
                let Ok(count) = count.parse::<u64>() else {
                    return Err(FileError::at(
                        line_no,
                        format!("element count \"{count}\" is not a non-negative integer"),
                    ));
                };
                if elements.iter().any(|e| e.name == *name) {
                    return Err(FileError::at(
                        line_no,
                        format!("element \"{name}\" declared twice"),
                    ));
                }
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                    line: line_no,
                });
            }
            Some("property") => {
                let Some(element) = elements.last_mut() else {
                    return Err(FileError::at(
                        line_no,
                        "\"property\" before any \"element\"",
                    ));
                };
                let bad_type =
                    |t: &str| FileError::at(line_no, format!("unknown property type \"{t}\""));
                let (kind, name) = match words.as_slice() {
                    ["property", "list", c, i, name] => {
                        let count = Scalar::parse(c).ok_or_else(|| bad_type(c))?;
                        let item = Scalar::parse(i).ok_or_else(|| bad_type(i))?;
                        if !count.is_integer() {
                            return Err(FileError::at(line_no, "a list count must have an integer type"));
                        }
                        (Kind::List { count, item }, name)
                    }
                    ["property", t, name] if *t != "list" => {
                        (Kind::Scalar(Scalar::parse(t).ok_or_else(|| bad_type(t))?), name)
                    }
                    _ => {
                        return Err(FileError::at(
                            line_no,
                            "expected \"property <type> <name>\" or \"property list <count type> <item type> <name>\"",
                        ))
                    }
                };
                if element.props.iter().any(|p| p.name == *name) {
                    return Err(FileError::at(
                        line_no,
                        format!("property \"{name}\" declared twice"),
                    ));
                }
                element.props.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            Some("end_header") => break,
            Some(other) => {
                return Err(FileError::at(
                    line_no,
                    format!("unknown header keyword \"{other}\""),
                ));
            }
        }
    }
    let Some(format) = format else {
        return Err(FileError::at(line_no, "the header has no \"format\" line"));
    };
    Ok(Header {
        format,
        elements,
        body: pos,
        lines: line_no,
    })
}

/// Checks every declared count against the bytes after the header (before any allocation).
fn check_counts(h: &Header, body_len: usize) -> Result<(), FileError> {
    let mut needed: u128 = 0;
    for e in &h.elements {
        if e.count > 0 && e.props.is_empty() {
            return Err(FileError::at(
                e.line,
                format!("element \"{}\" has entries but no properties", e.name),
            ));
        }
        // The fewest bytes one entry can take: binary, each scalar or list count; ASCII, one
        // character and one separator per value.
        let per_entry: u128 = match h.format {
            Format::Ascii => 2 * e.props.len() as u128,
            _ => e
                .props
                .iter()
                .map(|p| match p.kind {
                    Kind::Scalar(s) => s.size() as u128,
                    Kind::List { count, .. } => count.size() as u128,
                })
                .sum(),
        };
        needed += e.count as u128 * per_entry;
        let available = body_len as u128 + u128::from(h.format == Format::Ascii);
        if needed > available {
            return Err(FileError::at(
                e.line,
                format!(
                    "element \"{}\" declares {} entries, more than the {body_len} bytes after the header can hold",
                    e.name, e.count
                ),
            ));
        }
    }
    Ok(())
}

/// Parses a whole PLY file into an object-space mesh with at most `max_triangles` triangles.
pub(crate) fn parse(data: &[u8], max_triangles: usize) -> Result<RawMesh, FileError> {
    let h = parse_header(data)?;
    let body = &data[h.body..];
    check_counts(&h, body.len())?;
    let Some(vertex) = h.elements.iter().find(|e| e.name == "vertex") else {
        return Err(FileError::at(h.lines, "no \"vertex\" element"));
    };
    let vertex_count = vertex.count;
    if vertex_count > u32::MAX as u64 {
        return Err(FileError::at(vertex.line, "too many vertices"));
    }
    let mut src: Box<dyn Source> = match h.format {
        Format::Ascii => Box::new(Ascii::new(body, h.lines + 1)),
        Format::BinaryLe => Box::new(Binary::new(body, h.body, false)),
        Format::BinaryBe => Box::new(Binary::new(body, h.body, true)),
    };
    let mut mesh = RawMesh::default();
    let mut saw_face = false;
    for e in &h.elements {
        match e.name.as_str() {
            "vertex" => read_vertices(e, src.as_mut(), &mut mesh)?,
            "face" => {
                saw_face = true;
                read_faces(
                    e,
                    src.as_mut(),
                    vertex_count,
                    max_triangles,
                    &mut mesh.indices,
                )?
            }
            _ => {
                for i in 0..e.count {
                    src.begin(&e.name, i, e.props.len(), !has_list(e))?;
                    for p in &e.props {
                        skip_property(src.as_mut(), p)?;
                    }
                    src.end()?;
                }
            }
        }
    }
    if !saw_face {
        return Err(FileError::at(
            h.lines,
            "no \"face\" element (point clouds are not supported)",
        ));
    }
    Ok(mesh)
}

fn has_list(e: &Element) -> bool {
    e.props.iter().any(|p| matches!(p.kind, Kind::List { .. }))
}

/// Reads a list count as a non-negative integer.
fn list_len(src: &mut dyn Source, count: Scalar, name: &str) -> Result<u64, FileError> {
    let n = src.scalar(count, name)?;
    if n < 0.0 {
        return Err(src.error(&format!("negative list length {n} for \"{name}\"")));
    }
    Ok(n as u64)
}

fn skip_property(src: &mut dyn Source, p: &Property) -> Result<(), FileError> {
    match p.kind {
        Kind::Scalar(s) => src.scalar(s, &p.name).map(|_| ()),
        Kind::List { count, item } => {
            let n = list_len(src, count, &p.name)?;
            src.skip(item, n, &p.name)
        }
    }
}

/// Index of the scalar property `name` in `e`, if present.
fn scalar_prop(e: &Element, name: &str) -> Result<Option<usize>, FileError> {
    match e.props.iter().position(|p| p.name == name) {
        Some(i) if matches!(e.props[i].kind, Kind::List { .. }) => Err(FileError::at(
            e.line,
            format!("vertex property \"{name}\" must be a scalar, not a list"),
        )),
        other => Ok(other),
    }
}

fn read_vertices(e: &Element, src: &mut dyn Source, mesh: &mut RawMesh) -> Result<(), FileError> {
    let need = |name: &str| {
        scalar_prop(e, name)?.ok_or_else(|| {
            FileError::at(
                e.line,
                format!("the vertex element has no \"{name}\" property"),
            )
        })
    };
    let xyz = [need("x")?, need("y")?, need("z")?];
    let normal = match (
        scalar_prop(e, "nx")?,
        scalar_prop(e, "ny")?,
        scalar_prop(e, "nz")?,
    ) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let mut uv = None;
    for (u, v) in [
        ("u", "v"),
        ("s", "t"),
        ("texture_u", "texture_v"),
        ("texture_s", "texture_t"),
    ] {
        if let (Some(a), Some(b)) = (scalar_prop(e, u)?, scalar_prop(e, v)?) {
            uv = Some([a, b]);
            break;
        }
    }
    let reserve = (e.count as usize).min(1 << 20);
    mesh.positions.reserve(reserve);
    let mut normals = normal.map(|_| Vec::with_capacity(reserve));
    let mut uvs = uv.map(|_| Vec::with_capacity(reserve));
    let mut values = vec![0.0f64; e.props.len()];
    let simple = !has_list(e);
    for i in 0..e.count {
        src.begin("vertex", i, e.props.len(), simple)?;
        for (slot, p) in values.iter_mut().zip(&e.props) {
            match p.kind {
                Kind::Scalar(s) => *slot = src.scalar(s, &p.name)?,
                Kind::List { .. } => skip_property(src, p)?,
            }
        }
        src.end()?;
        let p = DVec3::new(values[xyz[0]], values[xyz[1]], values[xyz[2]]);
        if !p.is_finite() {
            return Err(src.error(&format!("vertex {i} has a non-finite position")));
        }
        mesh.positions.push(p);
        if let (Some([a, b, c]), Some(out)) = (normal, normals.as_mut()) {
            out.push(DVec3::new(values[a], values[b], values[c]));
        }
        if let (Some([a, b]), Some(out)) = (uv, uvs.as_mut()) {
            let t = Vec2::new(values[a] as f32, values[b] as f32);
            if !t.is_finite() {
                return Err(src.error(&format!("vertex {i} has a non-finite texture coordinate")));
            }
            out.push(t);
        }
    }
    mesh.normals = normals;
    mesh.uvs = uvs;
    Ok(())
}

fn read_faces(
    e: &Element,
    src: &mut dyn Source,
    vertex_count: u64,
    max_triangles: usize,
    indices: &mut Vec<[u32; 3]>,
) -> Result<(), FileError> {
    let list = e.props.iter().position(|p| {
        matches!(p.kind, Kind::List { .. })
            && (p.name == "vertex_indices" || p.name == "vertex_index")
    });
    let Some(list) = list else {
        return Err(FileError::at(
            e.line,
            "the face element has no \"vertex_indices\" list property",
        ));
    };
    if e.count > max_triangles as u64 {
        return Err(FileError::at(
            e.line,
            format!(
                "{} faces exceed the limit of {max_triangles} triangles",
                e.count
            ),
        ));
    }
    indices.reserve((e.count as usize).min(1 << 20));
    let mut polygon: Vec<u32> = Vec::new();
    for f in 0..e.count {
        src.begin("face", f, e.props.len(), false)?;
        for (k, p) in e.props.iter().enumerate() {
            let Kind::List { count, item } = p.kind else {
                skip_property(src, p)?;
                continue;
            };
            if k != list {
                skip_property(src, p)?;
                continue;
            }
            let n = list_len(src, count, &p.name)?;
            if n < 3 {
                return Err(src.error(&format!("face {f} has {n} vertices (at least 3 needed)")));
            }
            src.check_room(item, n, &p.name)?;
            polygon.clear();
            for _ in 0..n {
                let x = src.scalar(item, &p.name)?;
                if !(x >= 0.0 && x.fract() == 0.0 && x < vertex_count as f64) {
                    return Err(src.error(&format!(
                        "face {f}: vertex index {x} out of range ({vertex_count} vertices)"
                    )));
                }
                polygon.push(x as u32);
            }
            // Fan triangulation keeps the polygon's winding.
            if indices.len() + polygon.len() - 2 > max_triangles {
                return Err(src.error(&format!("more than the limit of {max_triangles} triangles")));
            }
            for w in 1..polygon.len() - 1 {
                indices.push([polygon[0], polygon[w], polygon[w + 1]]);
            }
        }
        src.end()?;
    }
    Ok(())
}
