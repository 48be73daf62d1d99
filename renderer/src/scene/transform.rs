//! Object transforms, composed and applied in f64 (docs/design.md: precision).
//!
//! `{"matrix": [16 numbers, row-major]}` or any of scale, rotate (axis, degrees), translate,
//! applied in that order: M = T · R · S. Points use M, normals the inverse transpose of its linear
//! part (renormalised); a negative determinant mirrors, so callers swap two indices per triangle to
//! keep geometric normals facing as before.

use glam::{DMat3, DMat4, DVec3, DVec4};

use super::desc::TransformDesc;
use super::error::{join_path, SceneError};

/// A validated affine transform.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Transform {
    pub matrix: DMat4,
    /// Inverse transpose of the linear part, for normals.
    pub normal_matrix: DMat3,
    /// Determinant of the linear part.
    pub det: f64,
}

impl Transform {
    /// The identity.
    pub fn identity() -> Self {
        Transform {
            matrix: DMat4::IDENTITY,
            normal_matrix: DMat3::IDENTITY,
            det: 1.0,
        }
    }

    /// Builds from the description at `path` (`objects[3].transform`), checking it is finite,
    /// affine and invertible.
    pub fn from_desc(desc: Option<&TransformDesc>, path: &str) -> Result<Self, SceneError> {
        let Some(t) = desc else {
            return Ok(Self::identity());
        };
        let matrix = if let Some(m) = &t.matrix {
            if t.scale.is_some() || t.rotate.is_some() || t.translate.is_some() {
                return Err(SceneError::invalid(
                    path,
                    "give either \"matrix\" or scale/rotate/translate, not both",
                ));
            }
            let rows = DMat4::from_cols_array(m);
            let matrix = rows.transpose();
            if matrix.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
                return Err(SceneError::invalid(
                    join_path(path, "matrix"),
                    "the last row must be [0, 0, 0, 1] (projective transforms are not supported)",
                ));
            }
            matrix
        } else {
            let mut matrix = DMat4::IDENTITY;
            if let Some(s) = &t.scale {
                let s = DVec3::from_array(s.0);
                if s.x == 0.0 || s.y == 0.0 || s.z == 0.0 {
                    return Err(SceneError::invalid(
                        join_path(path, "scale"),
                        format!("must be non-zero, got [{}, {}, {}]", s.x, s.y, s.z),
                    ));
                }
                matrix = DMat4::from_scale(s);
            }
            if let Some(r) = &t.rotate {
                let axis = DVec3::from_array(r.axis);
                let len = axis.length();
                if !(len > 0.0 && len.is_finite()) {
                    return Err(SceneError::invalid(
                        join_path(path, "rotate.axis"),
                        "must be a non-zero vector",
                    ));
                }
                let rot = DMat4::from_axis_angle(axis / len, r.angle.to_radians());
                matrix = rot * matrix;
            }
            if let Some(tr) = &t.translate {
                matrix = DMat4::from_translation(DVec3::from_array(*tr)) * matrix;
            }
            matrix
        };
        Self::from_matrix(matrix, path)
    }

    /// Validates an affine matrix: finite and invertible.
    pub(crate) fn from_matrix(matrix: DMat4, path: &str) -> Result<Self, SceneError> {
        if !matrix.is_finite() {
            return Err(SceneError::invalid(path, "produces non-finite numbers"));
        }
        let linear = DMat3::from_mat4(matrix);
        let det = linear.determinant();
        let scale = linear.x_axis.length() * linear.y_axis.length() * linear.z_axis.length();
        if !(det.is_finite() && det.abs() > 1e-12 * scale && scale > 0.0) {
            return Err(SceneError::invalid(path, "is not invertible"));
        }
        let normal_matrix = linear.inverse().transpose();
        if !normal_matrix.is_finite() {
            return Err(SceneError::invalid(path, "is not invertible"));
        }
        Ok(Transform {
            matrix,
            normal_matrix,
            det,
        })
    }

    /// Transforms a point.
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.matrix.transform_point3(p)
    }

    /// Transforms a normal (inverse transpose) and renormalises it; `None` if it degenerates.
    pub fn normal(&self, n: DVec3) -> Option<DVec3> {
        let m = self.normal_matrix * n;
        let len = m.length();
        (len > 0.0 && len.is_finite()).then(|| m / len)
    }

    /// Whether the inverse (world → object, which the shader applies to rays in f32) stays
    /// well within f32: a tiny scale passes the relative invertibility check yet overflows it.
    /// A quarter of f32's range leaves room for the camera-relative translation.
    pub fn inverse_fits_f32(&self) -> bool {
        let inverse = self.matrix.inverse();
        inverse.is_finite()
            && affine_rows_f32(inverse)
                .iter()
                .flatten()
                .all(|x| x.abs() < f32::MAX / 4.0)
    }

    /// Whether the transform mirrors (winding must be swapped to keep normals facing the same).
    pub fn flips(&self) -> bool {
        self.det < 0.0
    }

    /// The uniform scale factor if the transform is a similarity (rotation, uniform scale,
    /// translation; a mirror is allowed), else `None`.
    pub fn uniform_scale(&self) -> Option<f64> {
        let linear = DMat3::from_mat4(self.matrix);
        let gram = linear.transpose() * linear;
        let s2 = (gram.x_axis.x + gram.y_axis.y + gram.z_axis.z) / 3.0;
        let tolerance = 1e-6 * s2;
        for c in 0..3 {
            for r in 0..3 {
                let expected = if c == r { s2 } else { 0.0 };
                if (gram.col(c)[r] - expected).abs() > tolerance {
                    return None;
                }
            }
        }
        Some(s2.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::desc::{RotateDesc, Triple};

    fn desc(json: &str) -> TransformDesc {
        serde_json::from_str(json).unwrap()
    }

    #[test]
    fn order_is_scale_rotate_translate() {
        let t = desc(
            r#"{"translate": [10, 0, 0], "rotate": {"axis": [0, 0, 1], "angle": 90}, "scale": [2, 3, 4]}"#,
        );
        let t = Transform::from_desc(Some(&t), "t").unwrap();
        // (1,1,1) → scale (2,3,4) → rotate 90° about z: (x,y) → (-y,x) = (-3,2,4) → +10 x.
        let p = t.point(DVec3::new(1.0, 1.0, 1.0));
        assert!((p - DVec3::new(7.0, 2.0, 4.0)).length() < 1e-12, "{p}");
        assert!(t.uniform_scale().is_none());
        assert!(!t.flips());
    }

    #[test]
    fn matrix_is_row_major() {
        let t = desc(r#"{"matrix": [1,0,0,5, 0,1,0,6, 0,0,1,7, 0,0,0,1]}"#);
        let t = Transform::from_desc(Some(&t), "t").unwrap();
        assert_eq!(t.point(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
        let bad = desc(r#"{"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 1,0,0,1]}"#);
        let e = Transform::from_desc(Some(&bad), "objects[0].transform").unwrap_err();
        assert!(e
            .to_string()
            .starts_with("objects[0].transform.matrix: the last row"));
        let singular = desc(r#"{"matrix": [1,0,0,0, 0,1,0,0, 0,0,0,0, 0,0,0,1]}"#);
        let e = Transform::from_desc(Some(&singular), "t").unwrap_err();
        assert_eq!(e.to_string(), "t: is not invertible");
        let both = TransformDesc {
            matrix: Some([0.0; 16]),
            translate: Some([0.0; 3]),
            ..Default::default()
        };
        assert!(Transform::from_desc(Some(&both), "t").is_err());
    }

    #[test]
    fn normals_use_inverse_transpose_and_mirrors_flip() {
        let t = TransformDesc {
            scale: Some(Triple([1.0, 2.0, 1.0])),
            ..Default::default()
        };
        let t = Transform::from_desc(Some(&t), "t").unwrap();
        // The plane x + y = 0 has normal (1,1,0)/√2; after y×2 it is 2x + y = 0: normal (2,1,0)/√5.
        let n = t.normal(DVec3::new(1.0, 1.0, 0.0)).unwrap();
        assert!((n - DVec3::new(2.0, 1.0, 0.0).normalize()).length() < 1e-12);
        let m = TransformDesc {
            scale: Some(Triple([-2.0, 2.0, 2.0])),
            rotate: Some(RotateDesc {
                axis: [1.0, 1.0, 0.0],
                angle: 33.0,
            }),
            ..Default::default()
        };
        let m = Transform::from_desc(Some(&m), "t").unwrap();
        assert!(m.flips());
        assert!((m.uniform_scale().unwrap() - 2.0).abs() < 1e-12);
    }
}

/// The rows of the 3×4 affine part of `m`, rounded to f32 (the GPU's instance matrices).
pub(crate) fn affine_rows_f32(m: DMat4) -> [[f32; 4]; 3] {
    std::array::from_fn(|r| {
        let row = m.row(r);
        [row.x as f32, row.y as f32, row.z as f32, row.w as f32]
    })
}

/// Whether a world-space point stays within the GPU's 32-bit floats with room for the frame
/// changes that subtract two such points (a quarter of f32's range).
pub(crate) fn in_f32_range(p: DVec3) -> bool {
    p.is_finite() && p.abs().max_element() < f32::MAX as f64 / 4.0
}

/// The eight corners of the box `lo`..`hi`.
pub(crate) fn box_corners(lo: DVec3, hi: DVec3) -> impl Iterator<Item = DVec3> {
    (0..8).map(move |k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}
