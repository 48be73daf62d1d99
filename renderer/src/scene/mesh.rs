//! Object-space triangle meshes (`RawMesh`, what every shape and file reader produces) and their
//! move to world space: positions through the transform in f64, winding swapped when the
//! transform mirrors, normals through the inverse transpose, or computed angle-weighted (as
//! Mitsuba 3's `Mesh::recompute_vertex_normals`, Thürmer & Wüthrich 1998).
//!
//! Convention (every shape): the geometric normal of triangle [i0, i1, i2] is
//! normalize(cross(p1 − p0, p2 − p0)).

use glam::{DVec3, Vec2, Vec3};

use super::error::SceneError;
use super::transform::{in_f32_range, Transform};
use super::TriangleMesh;

/// An error inside a mesh file, at a line (`None` inside binary data or when unknown).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FileError {
    pub line: Option<usize>,
    pub msg: String,
}

impl FileError {
    /// An error at `line` (1-based).
    pub(crate) fn at(line: usize, msg: impl Into<String>) -> Self {
        FileError {
            line: Some(line),
            msg: msg.into(),
        }
    }
    /// An error without a line.
    pub(crate) fn whole(msg: impl Into<String>) -> Self {
        FileError {
            line: None,
            msg: msg.into(),
        }
    }
}

/// A triangle mesh in object space, before transform and material assignment.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct RawMesh {
    pub positions: Vec<DVec3>,
    /// Per-vertex normals from the source, if any (not necessarily normalised).
    pub normals: Option<Vec<DVec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
}

impl RawMesh {
    /// Checks the invariants the readers guarantee (used by tests and debug builds).
    pub fn is_consistent(&self) -> bool {
        let n = self.positions.len();
        self.normals.as_ref().is_none_or(|v| v.len() == n)
            && self.uvs.as_ref().is_none_or(|v| v.len() == n)
            && self
                .indices
                .iter()
                .all(|t| t.iter().all(|&i| (i as usize) < n))
    }
}

/// How shading normals are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Shading {
    /// No per-vertex normals.
    Flat,
    /// The source's normals if it has them, else none.
    SourceOnly,
    /// The source's normals if it has them (invalid ones recomputed), else angle-weighted ones.
    Smooth,
}

/// Angle-weighted vertex normals, as Mitsuba 3 computes them for a mesh without normals: each
/// non-degenerate face's unit normal, weighted by the face's interior angle at the vertex, summed
/// per vertex and normalised (Thürmer & Wüthrich 1998). Unlike area weighting, the result does not
/// change when a face is split into several. A vertex touched only by degenerate faces gets +Y.
pub(crate) fn angle_weighted_normals(positions: &[DVec3], indices: &[[u32; 3]]) -> Vec<DVec3> {
    let mut acc = vec![DVec3::ZERO; positions.len()];
    for t in indices {
        let [a, b, c] = t.map(|i| i as usize);
        let (Some(&p0), Some(&p1), Some(&p2)) =
            (positions.get(a), positions.get(b), positions.get(c))
        else {
            continue;
        };
        // Step 1: the face's unit normal; degenerate faces add nothing.
        let n = (p1 - p0).cross(p2 - p0);
        let len = n.length();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let n = n / len;
        // Step 2: the interior angle at each corner weights the normal there.
        let corners = [(a, p0, p1, p2), (b, p1, p2, p0), (c, p2, p0, p1)];
        for (i, p, next, prev) in corners {
            let angle = unit_angle((next - p).normalize(), (prev - p).normalize());
            if angle.is_finite() {
                acc[i] += n * angle;
            }
        }
    }
    acc.into_iter()
        .map(|n| {
            let len = n.length();
            if len > 0.0 && len.is_finite() {
                n / len
            } else {
                DVec3::Y
            }
        })
        .collect()
}

/// The angle between two unit vectors, accurate near 0 and π (Mitsuba's `unit_angle`).
fn unit_angle(a: DVec3, b: DVec3) -> f64 {
    if a.dot(b) < 0.0 {
        std::f64::consts::PI - 2.0 * ((a + b).length() * 0.5).asin()
    } else {
        2.0 * ((b - a).length() * 0.5).asin()
    }
}

/// Moves `raw` to world space and assigns materials (one per triangle, or one for all).
pub(crate) fn to_world(
    raw: RawMesh,
    transform: &Transform,
    shading: Shading,
    name: String,
    materials: Materials,
    path: &str,
) -> Result<TriangleMesh, SceneError> {
    if !raw.is_consistent() {
        // The readers guarantee this; an error beats an out-of-bounds index later.
        return Err(SceneError::invalid(
            path,
            "inconsistent mesh (attribute counts or indices)",
        ));
    }
    // Step 1: positions through the full transform, in f64; they must stay finite.
    let positions: Vec<DVec3> = raw.positions.iter().map(|&p| transform.point(p)).collect();
    if !positions.iter().all(|p| p.is_finite()) {
        return Err(SceneError::invalid(
            path,
            "the transform produces non-finite positions",
        ));
    }
    if !positions.iter().all(|&p| in_f32_range(p)) {
        return Err(SceneError::invalid(
            path,
            "a position lies beyond the range of 32-bit floats",
        ));
    }
    // Step 2: a mirroring transform reverses the winding; swap two indices to keep facing.
    let mut indices = raw.indices;
    if transform.flips() {
        for t in &mut indices {
            t.swap(1, 2);
        }
    }
    // Step 3: shading normals.
    let normals = match (shading, raw.normals) {
        (Shading::Flat, _) | (Shading::SourceOnly, None) => None,
        (_, Some(source)) => {
            let mut computed: Option<Vec<DVec3>> = None;
            let mut out = Vec::with_capacity(source.len());
            for (i, n) in source.iter().enumerate() {
                let n = match transform.normal(*n) {
                    Some(n) => n,
                    None => {
                        let c = computed
                            .get_or_insert_with(|| angle_weighted_normals(&positions, &indices));
                        c.get(i).copied().unwrap_or(DVec3::Y)
                    }
                };
                out.push(n.as_vec3());
            }
            Some(out)
        }
        (Shading::Smooth, None) => Some(
            angle_weighted_normals(&positions, &indices)
                .into_iter()
                .map(|n| n.as_vec3())
                .collect::<Vec<Vec3>>(),
        ),
    };
    let materials = match materials {
        Materials::All(m) => vec![m; indices.len()],
        Materials::PerTriangle(v) => v,
    };
    Ok(TriangleMesh {
        name,
        positions,
        normals,
        uvs: raw.uvs,
        indices,
        materials,
    })
}

/// Material assignment for a mesh.
#[derive(Debug, Clone)]
pub(crate) enum Materials {
    All(u32),
    PerTriangle(Vec<u32>),
}

/// Geometric normal of triangle `t` of a world-space mesh (the convention above).
#[cfg(test)]
pub(crate) fn geometric_normal(m: &TriangleMesh, t: usize) -> DVec3 {
    let [a, b, c] = m.indices[t].map(|i| m.positions[i as usize]);
    (b - a).cross(c - a).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::desc::{TransformDesc, Triple};

    fn tri() -> RawMesh {
        RawMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2]],
        }
    }

    #[test]
    fn mirror_keeps_facing_and_normals_follow() {
        let d = TransformDesc {
            scale: Some(Triple([-1.0, 1.0, 1.0])),
            ..Default::default()
        };
        let t = Transform::from_desc(Some(&d), "t").unwrap();
        let mut raw = tri();
        raw.normals = Some(vec![DVec3::Z; 3]);
        let m = to_world(raw, &t, Shading::Smooth, "x".into(), Materials::All(0), "p").unwrap();
        // The triangle faced +Z; mirrored in x it must still face +Z.
        assert!((geometric_normal(&m, 0) - DVec3::Z).length() < 1e-12);
        assert_eq!(m.normals.unwrap()[0], Vec3::Z);
        assert_eq!(m.materials, vec![0]);
    }

    #[test]
    fn computed_normals_are_angle_weighted() {
        let raw = RawMesh {
            positions: vec![DVec3::ZERO, DVec3::X * 2.0, DVec3::Y * 2.0, DVec3::Z],
            normals: None,
            uvs: None,
            // A big triangle facing +Z (area 2) and a small one facing +Y (area 1), sharing 0
            // and 1; both have a right angle at vertex 0, 45° at vertex 1 for the big one and
            // atan(2) at vertex 1 for the small one.
            indices: vec![[0, 1, 2], [0, 3, 1]],
        };
        assert_eq!(
            (raw.positions[3] - raw.positions[0]).cross(raw.positions[1] - raw.positions[0]),
            DVec3::Y * 2.0
        );
        let n = angle_weighted_normals(&raw.positions, &raw.indices);
        // By hand: vertex 0 has π/2 in both faces, so the weights are equal (area weighting
        // would give Z twice Y's weight).
        let half_pi = std::f64::consts::FRAC_PI_2;
        let expected0 = (DVec3::Z * half_pi + DVec3::Y * half_pi).normalize();
        assert!((n[0] - expected0).length() < 1e-12, "{:?}", n[0]);
        // Vertex 1: 45° in the +Z face, atan(1/2) (the angle between (−2,0,0) and (−2,0,1)) in
        // the +Y face.
        let a_z = std::f64::consts::FRAC_PI_4;
        let a_y = 0.5f64.atan();
        let expected1 = (DVec3::Z * a_z + DVec3::Y * a_y).normalize();
        assert!((n[1] - expected1).length() < 1e-12, "{:?}", n[1]);
        let area_weighted1 = (DVec3::Z * 4.0 + DVec3::Y * 2.0).normalize();
        assert!((n[1] - area_weighted1).length() > 1e-2);
        assert_eq!(n[2], DVec3::Z);
        let m = to_world(
            raw.clone(),
            &Transform::identity(),
            Shading::Flat,
            "x".into(),
            Materials::All(1),
            "p",
        )
        .unwrap();
        assert!(m.normals.is_none());
    }

    #[test]
    fn cube_corner_normal_is_the_diagonal_however_faces_are_split() {
        // A cube corner at the origin: the three faces x=0, y=0, z=0 seen from outside, one
        // face split into two triangles at the corner and the others into one. Angle weighting
        // gives (−1,−1,−1)/√3 (each face contributes π/2 at the corner); area weighting would not
        // (the split face's triangles carry different areas).
        let p = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::new(1.0, 0.25, 0.0),
        ];
        // z=0 face (normal −Z): split at (1, 0.25, 0) into [0,2,4] (area 1/2) and [0,4,1] (area
        // 1/8), whose angles at 0 sum to π/2. x=0 (normal −X): [0,3,2]. y=0 (normal −Y): [0,1,3].
        let idx = vec![[0, 2, 4], [0, 4, 1], [0, 3, 2], [0, 1, 3]];
        for t in &idx {
            let [a, b, c] = t.map(|i| p[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot(DVec3::ONE) < 0.0, "face {t:?} faces outward");
        }
        let n = angle_weighted_normals(&p, &idx);
        assert!(
            (n[0] + DVec3::ONE.normalize()).length() < 1e-12,
            "{:?}",
            n[0]
        );
    }
}
