//! Range checks beyond JSON types, and the conversions of the small sections that need nothing
//! but checks: camera, film, lights and render defaults. Every error names the JSON path of the
//! offending value and the value itself (`camera.fov_y: must be in (0, 180), got 190`).

use glam::{DVec3, Vec3};

use super::desc::*;
use super::error::{index_path, join_path, SceneError};
use super::{Camera, Film, Filter, Light, Limits, RenderDefaults, Tonemap};

/// `x` must lie in (lo, hi) (open interval).
pub(crate) fn open_range(x: f64, lo: f64, hi: f64, path: &str) -> Result<f64, SceneError> {
    if x > lo && x < hi {
        Ok(x)
    } else {
        Err(SceneError::invalid(
            path,
            format!("must be in ({lo}, {hi}), got {x}"),
        ))
    }
}

/// `x` must lie in [lo, hi].
pub(crate) fn closed_range(x: f64, lo: f64, hi: f64, path: &str) -> Result<f64, SceneError> {
    if x >= lo && x <= hi {
        Ok(x)
    } else {
        Err(SceneError::invalid(
            path,
            format!("must be in [{lo}, {hi}], got {x}"),
        ))
    }
}

/// `x` must be finite and > 0.
pub(crate) fn positive(x: f64, path: &str) -> Result<f64, SceneError> {
    if x > 0.0 && x.is_finite() {
        Ok(x)
    } else {
        Err(SceneError::invalid(path, format!("must be > 0, got {x}")))
    }
}

/// `x` must be finite and >= 0.
pub(crate) fn non_negative(x: f64, path: &str) -> Result<f64, SceneError> {
    if x >= 0.0 && x.is_finite() {
        Ok(x)
    } else {
        Err(SceneError::invalid(path, format!("must be >= 0, got {x}")))
    }
}

/// Every component finite, >= 0 and representable as f32 (colours, intensities).
pub(crate) fn non_negative3(v: [f64; 3], path: &str) -> Result<Vec3, SceneError> {
    let ok = v
        .iter()
        .all(|&c| c >= 0.0 && c.is_finite() && (c as f32).is_finite());
    if ok {
        Ok(Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
    } else {
        Err(SceneError::invalid(
            path,
            format!(
                "components must be finite and >= 0, got [{}, {}, {}]",
                v[0], v[1], v[2]
            ),
        ))
    }
}

/// A finite f64 that must also fit in f32.
pub(crate) fn f32_of(x: f64, path: &str) -> Result<f32, SceneError> {
    let y = x as f32;
    if y.is_finite() {
        Ok(y)
    } else {
        Err(SceneError::invalid(path, format!("too large, got {x}")))
    }
}

/// A non-zero direction, normalised.
pub(crate) fn direction(v: DVec3, path: &str) -> Result<DVec3, SceneError> {
    let len = v.length();
    if len > 0.0 && len.is_finite() {
        Ok(v / len)
    } else {
        Err(SceneError::invalid(
            path,
            format!(
                "must be a non-zero direction, got [{}, {}, {}]",
                v.x, v.y, v.z
            ),
        ))
    }
}

/// Whether two directions are (nearly) parallel.
pub(crate) fn parallel(a: DVec3, b: DVec3) -> bool {
    let (la, lb) = (a.length(), b.length());
    if la == 0.0 || lb == 0.0 {
        return true;
    }
    a.cross(b).length() <= 1e-9 * la * lb
}

/// The camera section.
pub(crate) fn camera(d: &CameraDesc) -> Result<Camera, SceneError> {
    let position = DVec3::from_array(d.position);
    let look_at = DVec3::from_array(d.look_at);
    let view = look_at - position;
    let dist = view.length();
    if !(dist > 0.0 && dist.is_finite()) {
        return Err(SceneError::invalid(
            "camera.look_at",
            "must differ from camera.position",
        ));
    }
    let up = DVec3::from_array(d.up.unwrap_or([0.0, 1.0, 0.0]));
    direction(up, "camera.up")?;
    if parallel(up, view) {
        return Err(SceneError::invalid(
            "camera.up",
            "must not be parallel to the view direction (look_at - position)",
        ));
    }
    let fov_y = open_range(d.fov_y.unwrap_or(40.0), 0.0, 180.0, "camera.fov_y")?;
    let aperture_radius = non_negative(d.aperture_radius.unwrap_or(0.0), "camera.aperture_radius")?;
    let focus_distance = match d.focus_distance {
        Some(f) => positive(f, "camera.focus_distance")?,
        None => dist,
    };
    Ok(Camera {
        position,
        look_at,
        up,
        fov_y,
        aperture_radius,
        focus_distance,
    })
}

/// The film section.
pub(crate) fn film(d: &FilmDesc, limits: &Limits) -> Result<Film, SceneError> {
    let width = d.width.unwrap_or(512);
    let height = d.height.unwrap_or(512);
    if width < 1 || width > limits.max_width {
        return Err(SceneError::invalid(
            "film.width",
            format!("must be in [1, {}], got {width}", limits.max_width),
        ));
    }
    if height < 1 || height > limits.max_height {
        return Err(SceneError::invalid(
            "film.height",
            format!("must be in [1, {}], got {height}", limits.max_height),
        ));
    }
    let filter = match d.filter.as_ref().unwrap_or(&FilterDesc::Box) {
        FilterDesc::Box => Filter::Box,
        FilterDesc::Gaussian { stddev } => {
            let s = positive(stddev.unwrap_or(0.5), "film.filter.stddev")?;
            Filter::Gaussian {
                stddev: f32_of(s, "film.filter.stddev")?,
            }
        }
    };
    let exposure = f32_of(d.exposure.unwrap_or(0.0), "film.exposure")?;
    let tonemap = match d.tonemap.unwrap_or(TonemapDesc::Clamp) {
        TonemapDesc::Clamp => Tonemap::Clamp,
        TonemapDesc::Reinhard => Tonemap::Reinhard,
        TonemapDesc::Aces => Tonemap::Aces,
    };
    Ok(Film {
        width,
        height,
        filter,
        exposure,
        tonemap,
    })
}

/// `lights[index]`.
pub(crate) fn light(d: &LightDesc, index: usize) -> Result<Light, SceneError> {
    let path = index_path("lights", index);
    let at = |field: &str| join_path(&path, field);
    Ok(match d {
        LightDesc::Point(p) => Light::Point {
            position: DVec3::from_array(p.position),
            intensity: non_negative3(p.intensity.0, &at("intensity"))?,
        },
        LightDesc::Spot(s) => {
            let position = DVec3::from_array(s.position);
            let to = DVec3::from_array(s.look_at) - position;
            if to.length() == 0.0 {
                return Err(SceneError::invalid(
                    at("look_at"),
                    "must differ from position",
                ));
            }
            let direction = direction(to, &at("look_at"))?;
            let cutoff = open_range(
                s.cutoff_angle.unwrap_or(20.0),
                0.0,
                180.0,
                &at("cutoff_angle"),
            )?;
            let beam = match s.beam_width {
                Some(b) => closed_range(b, 0.0, cutoff, &at("beam_width"))?,
                None => 0.75 * cutoff,
            };
            Light::Spot {
                position,
                direction,
                intensity: non_negative3(s.intensity.0, &at("intensity"))?,
                cutoff_angle: cutoff as f32,
                beam_width: beam as f32,
            }
        }
        LightDesc::Directional(dl) => Light::Directional {
            direction: direction(DVec3::from_array(dl.direction), &at("direction"))?,
            irradiance: non_negative3(dl.irradiance.0, &at("irradiance"))?,
        },
    })
}

/// The optional render section.
pub(crate) fn render(d: Option<&RenderDesc>) -> Result<RenderDefaults, SceneError> {
    let Some(d) = d else {
        return Ok(RenderDefaults::default());
    };
    // `integrator` names an entry of the integrator registry; it is resolved (and an unknown
    // name refused, naming render.integrator) where a render picks its integrator
    // (`IntegratorOptions::resolve`), since scenes sit below the integrators.
    let max_depth = match d.max_depth {
        None => None,
        Some(m) if m == -1 || (1..=i32::MAX as i64).contains(&m) => Some(m as i32),
        Some(m) => {
            return Err(SceneError::invalid(
                "render.max_depth",
                format!("must be -1 (unbounded) or in [1, {}], got {m}", i32::MAX),
            ))
        }
    };
    let spp = match d.spp {
        None => None,
        Some(s) if (1..=u32::MAX as u64).contains(&s) => Some(s as u32),
        Some(s) => {
            return Err(SceneError::invalid(
                "render.spp",
                format!("must be in [1, {}], got {s}", u32::MAX),
            ))
        }
    };
    let (accel, grid_resolution) = accel(d)?;
    if let Some(s) = &d.light_sampler {
        if !crate::scene::LIGHT_SAMPLERS.contains(&s.as_str()) {
            return Err(SceneError::invalid(
                "render.light_sampler",
                format!(
                    "unknown light sampler \"{s}\", expected one of {}",
                    crate::scene::LIGHT_SAMPLERS.join(", ")
                ),
            ));
        }
    }
    Ok(RenderDefaults {
        integrator: d.integrator.clone(),
        max_depth,
        spp,
        accel,
        grid_resolution,
        light_sampler: d.light_sampler.clone(),
    })
}

/// `render.accel` and `render.grid_resolution` (docs/accel.md).
fn accel(d: &RenderDesc) -> Result<(Option<String>, Option<u32>), SceneError> {
    use crate::accel::{grid::check_resolution, parse_request};
    if let Some(name) = &d.accel {
        parse_request(name).map_err(|e| SceneError::invalid("render.accel", e))?;
    }
    let res = match d.grid_resolution {
        None => None,
        Some(_) if d.accel.as_deref().is_some_and(|k| k != "grid") => {
            return Err(SceneError::invalid(
                "render.grid_resolution",
                "only applies to \"accel\": \"grid\"",
            ))
        }
        Some(r) => Some(
            check_resolution(r).map_err(|e| SceneError::invalid("render.grid_resolution", e))?,
        ),
    };
    Ok((d.accel.clone(), res))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(json: &str) -> Result<Camera, SceneError> {
        camera(&serde_json::from_str(json).unwrap())
    }

    #[test]
    fn camera_checks() {
        let c = cam(r#"{"position": [0, 0, 5], "look_at": [0, 0, 1]}"#).unwrap();
        assert_eq!((c.fov_y, c.focus_distance, c.up), (40.0, 4.0, DVec3::Y));
        let e = cam(r#"{"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 190}"#).unwrap_err();
        assert_eq!(e.to_string(), "camera.fov_y: must be in (0, 180), got 190");
        let e = cam(r#"{"position": [1, 2, 3], "look_at": [1, 2, 3]}"#).unwrap_err();
        assert_eq!(e.path(), Some("camera.look_at"));
        let e = cam(r#"{"position": [0, 5, 0], "look_at": [0, 0, 0]}"#).unwrap_err();
        assert_eq!(e.path(), Some("camera.up"));
        let e =
            cam(r#"{"position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 0, 0]}"#).unwrap_err();
        assert_eq!(e.path(), Some("camera.up"));
        let e =
            cam(r#"{"position": [0,0,5], "look_at": [0,0,0], "aperture_radius": -1}"#).unwrap_err();
        assert_eq!(
            e.to_string(),
            "camera.aperture_radius: must be >= 0, got -1"
        );
    }

    #[test]
    fn film_and_render_checks() {
        let limits = Limits::default();
        let f = film(&FilmDesc::default(), &limits).unwrap();
        assert_eq!(
            (f.width, f.height, f.filter, f.tonemap),
            (512, 512, Filter::Box, Tonemap::Clamp)
        );
        let d: FilmDesc = serde_json::from_str(r#"{"width": 0}"#).unwrap();
        assert_eq!(
            film(&d, &limits).unwrap_err().to_string(),
            "film.width: must be in [1, 16384], got 0"
        );
        let d: FilmDesc = serde_json::from_str(r#"{"height": 20000}"#).unwrap();
        assert_eq!(film(&d, &limits).unwrap_err().path(), Some("film.height"));
        let d: FilmDesc =
            serde_json::from_str(r#"{"filter": {"type": "gaussian", "stddev": 0}}"#).unwrap();
        assert_eq!(
            film(&d, &limits).unwrap_err().path(),
            Some("film.filter.stddev")
        );
        let r: RenderDesc = serde_json::from_str(r#"{"max_depth": 0}"#).unwrap();
        assert_eq!(
            render(Some(&r)).unwrap_err().path(),
            Some("render.max_depth")
        );
        let r: RenderDesc = serde_json::from_str(r#"{"max_depth": -2}"#).unwrap();
        assert!(render(Some(&r)).is_err());
        let r: RenderDesc = serde_json::from_str(r#"{"spp": 0}"#).unwrap();
        assert_eq!(render(Some(&r)).unwrap_err().path(), Some("render.spp"));
        let r: RenderDesc =
            serde_json::from_str(r#"{"integrator": "bdpt", "max_depth": -1, "spp": 64}"#).unwrap();
        let r = render(Some(&r)).unwrap();
        assert_eq!(
            (r.integrator.as_deref(), r.max_depth, r.spp),
            (Some("bdpt"), Some(-1), Some(64))
        );
    }

    #[test]
    fn light_checks() {
        let d: LightDesc =
            serde_json::from_str(r#"{"type": "spot", "position": [0, 4, 0], "look_at": [0, 0, 0], "intensity": 10, "cutoff_angle": 40}"#)
                .unwrap();
        match light(&d, 0).unwrap() {
            Light::Spot {
                direction,
                beam_width,
                ..
            } => {
                assert_eq!(direction, DVec3::new(0.0, -1.0, 0.0));
                assert_eq!(beam_width, 30.0);
            }
            other => panic!("{other:?}"),
        }
        let d: LightDesc = serde_json::from_str(
            r#"{"type": "directional", "direction": [0, -2, 0], "irradiance": [1, -1, 1]}"#,
        )
        .unwrap();
        assert_eq!(
            light(&d, 2).unwrap_err().path(),
            Some("lights[2].irradiance")
        );
        let d: LightDesc = serde_json::from_str(
            r#"{"type": "directional", "direction": [0, 0, 0], "irradiance": 1}"#,
        )
        .unwrap();
        assert_eq!(
            light(&d, 1).unwrap_err().path(),
            Some("lights[1].direction")
        );
    }
}
