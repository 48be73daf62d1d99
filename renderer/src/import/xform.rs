//! Transforms shared by the importers: 4×4 f64 matrices (glam `DMat4`, column vectors) written
//! as candela's `{"matrix": [16 numbers, row-major]}`, composed onto objects (groups.rs places them), and a
//! source camera's camera-to-world matrix turned into candela's position / look_at / up.

use glam::{DMat4, DVec3, DVec4};
use serde_json::{json, Value};

/// Row-major numbers of `m` (candela's `"matrix"` order).
pub fn row_major(m: &DMat4) -> [f64; 16] {
    m.transpose().to_cols_array()
}

/// The matrix of a row-major 16-number list.
pub fn from_row_major(v: &[f64; 16]) -> DMat4 {
    DMat4::from_cols_array(v).transpose()
}

/// `{"matrix": [...]}`, or None for the identity.
pub fn transform_value(m: &DMat4) -> Option<Value> {
    (*m != DMat4::IDENTITY).then(|| json!({ "matrix": row_major(m).to_vec() }))
}

/// The matrix of an object's `"transform"` as the importers write it (`matrix` or absent).
pub fn object_matrix(o: &Value) -> DMat4 {
    o.get("transform")
        .and_then(|t| t.get("matrix"))
        .and_then(Value::as_array)
        .and_then(|a| {
            let v: Vec<f64> = a.iter().filter_map(Value::as_f64).collect();
            <[f64; 16]>::try_from(v).ok()
        })
        .map(|v| from_row_major(&v))
        .unwrap_or(DMat4::IDENTITY)
}

/// `o` with `to_world` applied after its own transform.
pub fn place(o: &Value, to_world: &DMat4) -> Value {
    let mut o = o.clone();
    let m = *to_world * object_matrix(&o);
    if let Some(map) = o.as_object_mut() {
        match transform_value(&m) {
            Some(t) => map.insert("transform".into(), t),
            None => map.remove("transform"),
        };
    }
    o
}

/// A camera in candela's terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraFrame {
    pub position: DVec3,
    pub look_at: DVec3,
    pub up: DVec3,
}

/// Why a camera matrix cannot be a candela camera.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameError {
    /// Not finite, or forward / up degenerate or not orthogonal.
    NotRigid,
}

/// Reads a camera-to-world matrix whose local `forward` and `up` axes are given; the image's
/// right is then `forward × up` when `right_is_cross` (candela's and Mitsuba's convention) —
/// the caller checks handedness separately with [`mirrors_image`].
pub fn camera_frame(m: &DMat4, forward: DVec3, up: DVec3) -> Result<CameraFrame, FrameError> {
    let position = m.transform_point3(DVec3::ZERO);
    let f = m.transform_vector3(forward);
    let u = m.transform_vector3(up);
    let (lf, lu) = (f.length(), u.length());
    if !(position.is_finite() && lf > 0.0 && lu > 0.0 && lf.is_finite() && lu.is_finite()) {
        return Err(FrameError::NotRigid);
    }
    if (f.dot(u) / (lf * lu)).abs() > 1e-4 || m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
        return Err(FrameError::NotRigid);
    }
    Ok(CameraFrame {
        position,
        look_at: position + f / lf,
        up: u / lu,
    })
}

/// Whether the image of a camera whose local `right` axis is given is the mirror image of the
/// image candela draws from the same position / look_at / up (candela's right is forward × up).
pub fn mirrors_image(m: &DMat4, right: DVec3, forward: DVec3, up: DVec3) -> bool {
    let r = m.transform_vector3(right);
    let cross = m.transform_vector3(forward).cross(m.transform_vector3(up));
    r.dot(cross) < 0.0
}

/// `{"position", "look_at", "up"}` of a frame.
pub fn camera_value(c: &CameraFrame) -> serde_json::Map<String, Value> {
    let mut m = serde_json::Map::new();
    m.insert("position".into(), json!(c.position.to_array()));
    m.insert("look_at".into(), json!(c.look_at.to_array()));
    m.insert("up".into(), json!(c.up.to_array()));
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_major_round_trip_and_place() {
        let m = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0));
        let r = row_major(&m);
        assert_eq!(&r[..4], &[1.0, 0.0, 0.0, 1.0]);
        assert_eq!(from_row_major(&r), m);
        assert_eq!(transform_value(&DMat4::IDENTITY), None);
        let o = json!({"type": "sphere", "center": [0, 0, 0], "radius": 1,
                       "transform": {"matrix": row_major(&DMat4::from_scale(DVec3::splat(2.0)))}});
        let placed = [place(&o, &m)];
        let got = object_matrix(&placed[0]);
        assert_eq!(got, m * DMat4::from_scale(DVec3::splat(2.0)));
        let back = place(&placed[0], &m.inverse());
        assert_eq!(object_matrix(&back), DMat4::from_scale(DVec3::splat(2.0)));
    }

    #[test]
    fn camera_frames() {
        // Mitsuba's look_at: columns (left, up, dir, origin), left = up × dir.
        let (origin, dir, up) = (DVec3::new(0.0, 0.0, 5.0), -DVec3::Z, DVec3::Y);
        let left = up.cross(dir);
        let m = DMat4::from_cols(
            left.extend(0.0),
            up.extend(0.0),
            dir.extend(0.0),
            origin.extend(1.0),
        );
        let c = camera_frame(&m, DVec3::Z, DVec3::Y).unwrap();
        assert_eq!(c.position, origin);
        assert_eq!(
            c.look_at,
            DVec3::new(0.0, 0.0, 4.0),
            "one unit along the view"
        );
        // Mitsuba's image right is local −x.
        assert!(!mirrors_image(&m, -DVec3::X, DVec3::Z, DVec3::Y));
        let mirrored = m * DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        assert!(mirrors_image(&mirrored, -DVec3::X, DVec3::Z, DVec3::Y));
        let sheared =
            DMat4::from_cols(DVec4::X, DVec4::new(0.0, 1.0, 1.0, 0.0), DVec4::Z, DVec4::W);
        assert_eq!(
            camera_frame(&sheared, DVec3::Z, DVec3::Y),
            Err(FrameError::NotRigid)
        );
    }
}
