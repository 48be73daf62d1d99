//! Tests of the mesh-file readers: PLY in its three encodings (identical meshes, extra elements
//! and properties skipped, header errors, truncation, absurd counts, ASCII line numbers) and OBJ
//! (`usemtl` names per triangle, line-numbered errors, triangle limit).

use glam::{DVec3, Vec2};

use super::mesh::{FileError, RawMesh};
use super::{obj, ply};

/// One test vertex: position, normal, (s, t), an unused byte and an unused list.
struct V {
    p: [f32; 3],
    n: [f32; 3],
    st: [f32; 2],
    red: u8,
    junk: Vec<i32>,
}

fn vertices() -> Vec<V> {
    let v = |p: [f32; 3], st: [f32; 2], junk: Vec<i32>| V {
        p,
        n: [0.0, 0.0, 2.0],
        st,
        red: 200,
        junk,
    };
    vec![
        v([0.0, 0.0, 0.0], [0.0, 0.0], vec![]),
        v([1.5, 0.0, 0.0], [1.0, 0.0], vec![7, -8]),
        v([1.5, 1.25, 0.0], [1.0, 1.0], vec![1]),
        v([0.0, 1.25, -0.5], [0.0, 1.0], vec![]),
        v([-1.0, 0.5, 0.25], [0.5, 0.5], vec![3, 4, 5]),
    ]
}

/// A quad and a triangle, with an unused `flags` property after the list.
const FACES: &[&[i32]] = &[&[0, 1, 2, 3], &[0, 3, 4]];

/// Writes the test mesh as PLY in `format`, with a `material` element between vertices and faces.
fn ply_bytes(format: &str) -> Vec<u8> {
    let vs = vertices();
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment made by a test\nelement vertex {}\n\
         property float x\nproperty float32 y\nproperty float z\nproperty list uchar int junk\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n\
         property float s\nproperty float t\n\
         element material 2\nproperty double shininess\nproperty list ushort uint16 tags\n\
         element face {}\nproperty list uchar int vertex_indices\nproperty short flags\nend_header\n",
        vs.len(),
        FACES.len()
    )
    .into_bytes();
    let big = format == "binary_big_endian";
    macro_rules! put {
        ($x:expr) => {
            if big {
                out.extend_from_slice(&$x.to_be_bytes())
            } else {
                out.extend_from_slice(&$x.to_le_bytes())
            }
        };
    }
    if format == "ascii" {
        let mut text = String::new();
        for v in &vs {
            let junk: Vec<String> = v.junk.iter().map(|j| j.to_string()).collect();
            text += &format!(
                "{} {} {} {} {} {} {} {} {} {} {}\n",
                v.p[0],
                v.p[1],
                v.p[2],
                v.junk.len(),
                junk.join(" "),
                v.n[0],
                v.n[1],
                v.n[2],
                v.red,
                v.st[0],
                v.st[1]
            )
            .replace("  ", " ");
        }
        text += "0.5 2 1 2\n\n30 0\n";
        for f in FACES {
            let idx: Vec<String> = f.iter().map(|i| i.to_string()).collect();
            text += &format!("{} {} -1\n", f.len(), idx.join(" "));
        }
        out.extend_from_slice(text.as_bytes());
        return out;
    }
    for v in &vs {
        for x in v.p {
            put!(x);
        }
        out.push(v.junk.len() as u8);
        for j in &v.junk {
            put!(*j);
        }
        for x in v.n {
            put!(x);
        }
        out.push(v.red);
        for x in v.st {
            put!(x);
        }
    }
    for (shininess, tags) in [(0.5f64, vec![1u16, 2]), (30.0, vec![])] {
        put!(shininess);
        put!(tags.len() as u16);
        for t in tags {
            put!(t);
        }
    }
    for f in FACES {
        out.push(f.len() as u8);
        for i in *f {
            put!(*i);
        }
        put!(-1i16);
    }
    out
}

fn parse_ply(data: &[u8]) -> Result<RawMesh, FileError> {
    ply::parse(data, 1000)
}

#[test]
fn ply_encodings_give_identical_meshes() {
    let ascii = parse_ply(&ply_bytes("ascii")).unwrap();
    let le = parse_ply(&ply_bytes("binary_little_endian")).unwrap();
    let be = parse_ply(&ply_bytes("binary_big_endian")).unwrap();
    assert_eq!(ascii, le);
    assert_eq!(ascii, be);
    assert!(ascii.is_consistent());
    assert_eq!(ascii.positions[2], DVec3::new(1.5, 1.25, 0.0));
    assert_eq!(ascii.positions[4], DVec3::new(-1.0, 0.5, 0.25));
    assert_eq!(
        ascii.normals.as_ref().unwrap()[1],
        DVec3::new(0.0, 0.0, 2.0)
    );
    assert_eq!(ascii.uvs.as_ref().unwrap()[4], Vec2::new(0.5, 0.5));
    // The quad is fan-triangulated with its winding kept.
    assert_eq!(ascii.indices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
}

#[test]
fn ply_header_errors_have_line_numbers() {
    let err = |text: &str| parse_ply(text.as_bytes()).unwrap_err();
    assert_eq!(err("plx\n").line, Some(1));
    let e = err("ply\nformat ascii 2.0\nend_header\n");
    assert_eq!(
        (e.line, e.msg.as_str()),
        (Some(2), "only PLY version 1.0 is supported")
    );
    let e = err("ply\nformat ascii 1.0\nelement vertex 1\nproperty flaot x\nend_header\n");
    assert_eq!(
        (e.line, e.msg.as_str()),
        (Some(4), "unknown property type \"flaot\"")
    );
    let e = err("ply\nformat ascii 1.0\nelement vertex x\nend_header\n");
    assert_eq!(e.line, Some(3));
    let e = err("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
    assert!(e.msg.contains("end_header"), "{e:?}");
    let e = err("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n");
    assert!(e.msg.contains("no \"y\" property"), "{e:?}");
    let e = err("ply\nproperty float x\nend_header\n");
    assert_eq!(e.line, Some(2));
}

#[test]
fn ply_huge_declared_count_is_an_error_not_an_allocation() {
    let text = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n\
                property float x\nproperty float y\nproperty float z\nelement face 0\n\
                property list uchar int vertex_indices\nend_header\n\0\0\0\0";
    let e = parse_ply(text.as_bytes()).unwrap_err();
    assert_eq!(e.line, Some(3));
    assert!(e.msg.contains("declares 1000000000000 entries"), "{e:?}");
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nelement face 4000000000\nproperty list uchar int vertex_indices\n\
                end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    assert_eq!(parse_ply(text.as_bytes()).unwrap_err().line, Some(7));
}

#[test]
fn ply_truncated_binary_is_reported() {
    for format in ["binary_little_endian", "binary_big_endian"] {
        let mut data = ply_bytes(format);
        data.truncate(data.len() - 5);
        let e = parse_ply(&data).unwrap_err();
        assert_eq!(e.line, None);
        assert!(
            e.msg
                .contains("unexpected end of file in face 1 (the file is truncated)"),
            "{e:?}"
        );
    }
}

#[test]
fn ply_ascii_body_errors_have_line_numbers() {
    let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let err = |body: &str| parse_ply(format!("{head}{body}").as_bytes()).unwrap_err();
    let e = err("0 0 0\n1 0\n0 1 0\n3 0 1 2\n");
    assert_eq!(
        (e.line, e.msg.as_str()),
        (Some(11), "expected 3 numbers (vertex 1), got 2")
    );
    let e = err("0 0 0\n1 0 0\n0 1 zero\n3 0 1 2\n");
    assert_eq!(e.line, Some(12));
    let e = err("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
    assert_eq!(e.line, Some(13));
    assert!(e.msg.contains("vertex index 3 out of range"), "{e:?}");
    let e = err("0 0 0\n1 0 0\n0 1 0\n3 0 1\n");
    assert!(e.msg.contains("ends early"), "{e:?}");
    let e = err("0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
    assert!(e.msg.contains("at least 3"), "{e:?}");
    let e = err("0 0 0\n1 0 0\n");
    assert!(e.msg.contains("more than the 12 bytes"), "{e:?}");
    let e = err("0 0 0\n1 0 0\n                          \n");
    assert_eq!(
        (e.line, e.msg.as_str()),
        (Some(13), "unexpected end of file: vertex 2 is missing")
    );
    let e = err("0 0 0\n1 0 0\n0 1 0\n3 0 1 2 9\n");
    assert!(e.msg.contains("extra value"), "{e:?}");
    let ok = parse_ply(format!("{head}0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n").as_bytes()).unwrap();
    assert_eq!(ok.indices, vec![[0, 1, 2]]);
    assert!(ok.normals.is_none() && ok.uvs.is_none());
    let e = ply::parse(
        format!("{head}0 0 0\n1 0 0\n0 1 0\n4 0 1 2 0\n").as_bytes(),
        1,
    )
    .unwrap_err();
    assert!(e.msg.contains("limit"), "{e:?}");
}

const OBJ: &str = "# two materials, a quad and a pentagon\n\
mtllib missing.mtl\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 1\n\
vn 0 0 1\n\
o thing\n\
usemtl red\n\
f 1/1/1 2/2/1 3/3/1 4/4/1\n\
usemtl blue paint\n\
f -5/-5/1 -4/-4/1 -3/-3/1 -1/-1/1 -2/-2/1\n\
usemtl red\n\
f 1/1/1 3/3/1 4/4/1\n";

#[test]
fn obj_usemtl_names_follow_faces() {
    let m = obj::parse(OBJ.as_bytes(), 100).unwrap();
    assert_eq!(m.names, vec!["red".to_string(), "blue paint".to_string()]);
    // Quad → 2, pentagon → 3, triangle → 1.
    assert_eq!(m.raw.indices.len(), 6);
    let names: Vec<Option<u32>> = m.triangle_names.clone();
    assert_eq!(
        names,
        vec![Some(0), Some(0), Some(1), Some(1), Some(1), Some(0)]
    );
    assert!(m.raw.is_consistent());
    assert!(m
        .raw
        .normals
        .as_ref()
        .unwrap()
        .iter()
        .all(|n| *n == DVec3::Z));
    assert!(m.raw.uvs.is_some());
    // Geometry comes through: the pentagon's apex.
    assert!(m.raw.positions.contains(&DVec3::new(0.5, 1.5, 0.0)));
    let plain = obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 10).unwrap();
    assert_eq!(plain.triangle_names, vec![None]);
    assert!(plain.raw.normals.is_none() && plain.raw.uvs.is_none());
}

#[test]
fn obj_errors_have_line_numbers() {
    let err = |text: &str| obj::parse(text.as_bytes(), 100).unwrap_err();
    let e = err("v 0 0 0\nv 1 0\n");
    assert_eq!(
        (e.line, e.msg.as_str()),
        (Some(2), "expected 3 numbers after \"v\"")
    );
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
    assert_eq!(e.line, Some(4));
    assert!(e.msg.contains("vertex index 4 out of range"), "{e:?}");
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/5 2 3\n");
    assert!(e.msg.starts_with("texture index 5"), "{e:?}");
    let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n");
    assert!(e.msg.contains("out of range"), "{e:?}");
    let e = err("v 0 0 0\nf 0 1 1\n");
    assert!(e.msg.contains("index 0"), "{e:?}");
    let e = err("v 0 0 0\nusemtl\n");
    assert_eq!(e.line, Some(2));
    let e = obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3\n", 1).unwrap_err();
    assert_eq!(e.line, Some(5));
    let e = obj::parse(b"v 0 0 0\n\xff\n", 1).unwrap_err();
    assert_eq!(e.line, Some(2));
}

/// A small xorshift generator, so the mutation test is deterministic.
pub(super) fn xorshift(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

/// Mutates `data` a few times: overwrite, truncate, insert or remove bytes.
pub(super) fn mutate(data: &mut Vec<u8>, state: &mut u64) {
    const BYTES: &[u8] = b"0123456789 -./\ne\xff";
    for _ in 0..1 + xorshift(state) % 4 {
        if data.is_empty() {
            return;
        }
        let r = xorshift(state);
        let i = r as usize % data.len();
        let b = BYTES[(r >> 40) as usize % BYTES.len()];
        match (r >> 32) % 5 {
            0 => data[i] = (r >> 48) as u8,
            1 => data[i] = b,
            2 => data.truncate(i),
            3 => data.insert(i, b),
            _ => {
                data.remove(i);
            }
        }
    }
}

#[test]
fn readers_never_panic_on_mutated_input() {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let inputs = [
        ply_bytes("ascii"),
        ply_bytes("binary_little_endian"),
        ply_bytes("binary_big_endian"),
        OBJ.as_bytes().to_vec(),
    ];
    for base in &inputs {
        for _ in 0..3000 {
            let mut d = base.clone();
            mutate(&mut d, &mut state);
            if let Ok(m) = ply::parse(&d, 1000) {
                assert!(m.is_consistent());
            }
            match obj::parse(&d, 1000) {
                Ok(m) => {
                    assert!(m.raw.is_consistent());
                    assert_eq!(m.triangle_names.len(), m.raw.indices.len());
                }
                // The scan must catch everything tobj would panic on.
                Err(e) => assert_ne!(e.msg, "the OBJ reader failed on this file"),
            }
        }
    }
}
