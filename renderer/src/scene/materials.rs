//! Materials: defaults from docs/scene-format.md applied, ranges checked, textures loaded (through the
//! shared `TextureCache`), names kept in document order.
//!
//! Ranges: colours finite and non-negative; roughness-like scalars (roughness, anisotropy,
//! metallic, specular, tints, sheen, transmission, subsurface, clearcoat) in [0, 1]; ior > 0;
//! Phong exponent non-negative; conductor eta > 0 and k non-negative, both or neither.
//! Texture-valued parameters are not range-checked per texel.

use glam::Vec3;

use super::desc::*;
use super::error::{join_path, key_path, SceneError};
use super::texture::TextureCache;
use super::validate::{closed_range, f32_of, non_negative, non_negative3, positive};
use super::{ColorParam, Material, MaterialKind, ScalarParam};

/// Resolves one material's parameters; `path` is `materials.<name>`.
struct Params<'c, 'a> {
    textures: &'c mut TextureCache<'a>,
    path: String,
}

impl Params<'_, '_> {
    fn at(&self, field: &str) -> String {
        join_path(&self.path, field)
    }

    fn color(
        &mut self,
        field: &str,
        d: &Option<ColorDesc>,
        default: f32,
    ) -> Result<ColorParam, SceneError> {
        let path = self.at(field);
        match d {
            None => Ok(ColorParam::Const(Vec3::splat(default))),
            Some(ColorDesc::Const(c)) => Ok(ColorParam::Const(non_negative3(*c, &path)?)),
            Some(ColorDesc::Texture(t)) => {
                Ok(ColorParam::Texture(self.textures.load_ref(t, &path)?))
            }
        }
    }

    /// A scalar in [0, 1].
    fn unit(
        &mut self,
        field: &str,
        d: &Option<ScalarDesc>,
        default: f32,
    ) -> Result<ScalarParam, SceneError> {
        let path = self.at(field);
        match d {
            None => Ok(ScalarParam::Const(default)),
            Some(ScalarDesc::Const(x)) => {
                Ok(ScalarParam::Const(closed_range(*x, 0.0, 1.0, &path)? as f32))
            }
            Some(ScalarDesc::Texture(t)) => {
                Ok(ScalarParam::Texture(self.textures.load_ref(t, &path)?))
            }
        }
    }

    fn ior(&self, d: Option<f64>) -> Result<f32, SceneError> {
        let path = self.at("ior");
        f32_of(positive(d.unwrap_or(1.5), &path)?, &path)
    }
}

/// Builds `materials.<name>`.
pub(crate) fn build(
    name: &str,
    d: &MaterialDesc,
    textures: &mut TextureCache,
) -> Result<Material, SceneError> {
    let path = key_path("materials", name);
    let mut p = Params { textures, path };
    let kind = match &d.kind {
        MaterialKindDesc::Diffuse(m) => MaterialKind::Diffuse {
            reflectance: p.color("reflectance", &m.reflectance, 0.5)?,
        },
        MaterialKindDesc::Conductor(m) => {
            let eta_k = match (&m.eta, &m.k) {
                (None, None) => None,
                (Some(eta), Some(k)) => {
                    let eta_path = p.at("eta");
                    if !eta.0.iter().all(|&x| x > 0.0) {
                        return Err(SceneError::invalid(
                            eta_path,
                            format!(
                                "components must be > 0, got [{}, {}, {}]",
                                eta.0[0], eta.0[1], eta.0[2]
                            ),
                        ));
                    }
                    Some((
                        non_negative3(eta.0, &eta_path)?,
                        non_negative3(k.0, &p.at("k"))?,
                    ))
                }
                (Some(_), None) => {
                    return Err(SceneError::invalid(p.at("k"), "required when eta is given"))
                }
                (None, Some(_)) => {
                    return Err(SceneError::invalid(p.at("eta"), "required when k is given"))
                }
            };
            MaterialKind::Conductor {
                reflectance: p.color("reflectance", &m.reflectance, 1.0)?,
                roughness: p.unit("roughness", &m.roughness, 0.0)?,
                anisotropy: p.unit("anisotropy", &m.anisotropy, 0.0)?,
                eta_k,
            }
        }
        MaterialKindDesc::Dielectric(m) => {
            if d.common.two_sided == Some(false) {
                return Err(SceneError::invalid(
                    p.at("two_sided"),
                    "dielectrics are always two-sided",
                ));
            }
            MaterialKind::Dielectric {
                ior: p.ior(m.ior)?,
                roughness: p.unit("roughness", &m.roughness, 0.0)?,
                transmittance: p.color("transmittance", &m.transmittance, 1.0)?,
                reflectance: p.color("reflectance", &m.reflectance, 1.0)?,
            }
        }
        MaterialKindDesc::Principled(m) => MaterialKind::Principled {
            base_color: p.color("base_color", &m.base_color, 0.8)?,
            metallic: p.unit("metallic", &m.metallic, 0.0)?,
            roughness: p.unit("roughness", &m.roughness, 0.5)?,
            specular: p.unit("specular", &m.specular, 0.5)?,
            spec_tint: p.unit("spec_tint", &m.spec_tint, 0.0)?,
            anisotropic: p.unit("anisotropic", &m.anisotropic, 0.0)?,
            sheen: p.unit("sheen", &m.sheen, 0.0)?,
            sheen_tint: p.unit("sheen_tint", &m.sheen_tint, 0.5)?,
            spec_trans: p.unit("spec_trans", &m.spec_trans, 0.0)?,
            ior: m.ior.map(|v| p.ior(Some(v))).transpose()?,
            subsurface: p.unit("subsurface", &m.subsurface, 0.0)?,
            clearcoat: p.unit("clearcoat", &m.clearcoat, 0.0)?,
            clearcoat_gloss: p.unit("clearcoat_gloss", &m.clearcoat_gloss, 1.0)?,
        },
        MaterialKindDesc::Phong(m) => {
            let exponent_path = p.at("exponent");
            MaterialKind::Phong {
                diffuse: p.color("diffuse", &m.diffuse, 0.5)?,
                specular: p.color("specular", &m.specular, 0.0)?,
                exponent: f32_of(
                    non_negative(m.exponent.unwrap_or(30.0), &exponent_path)?,
                    &exponent_path,
                )?,
            }
        }
    };
    let emission = match &d.common.emission {
        None => Vec3::ZERO,
        Some(e) => non_negative3(e.0, &p.at("emission"))?,
    };
    let alpha_mask = match &d.common.alpha_mask {
        None => None,
        Some(t) => {
            let path = p.at("alpha_mask");
            Some(p.textures.load_ref(t, &path)?)
        }
    };
    Ok(Material {
        kind,
        emission,
        alpha_mask,
        two_sided: d.common.two_sided.unwrap_or(true),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Limits;

    fn mat(json: &str) -> Result<Material, SceneError> {
        let d: MaterialDesc = serde_json::from_str(json).unwrap();
        let limits = Limits::default();
        let mut cache = TextureCache::new(crate::scene::paths::AssetRoot::dir(None), &limits);
        build("m", &d, &mut cache)
    }

    #[test]
    fn defaults() {
        let m = mat(r#"{"type": "principled"}"#).unwrap();
        let MaterialKind::Principled {
            base_color,
            roughness,
            sheen_tint,
            ior,
            clearcoat_gloss,
            ..
        } = m.kind
        else {
            panic!()
        };
        assert_eq!(base_color, ColorParam::Const(Vec3::splat(0.8)));
        assert_eq!(
            (roughness, sheen_tint, ior, clearcoat_gloss),
            (
                ScalarParam::Const(0.5),
                ScalarParam::Const(0.5),
                None,
                ScalarParam::Const(1.0)
            )
        );
        assert!(m.two_sided);
        assert_eq!(m.emission, Vec3::ZERO);
        let m = mat(r#"{"type": "conductor"}"#).unwrap();
        assert!(matches!(
            m.kind,
            MaterialKind::Conductor { eta_k: None, .. }
        ));
        let m = mat(r#"{"type": "phong", "emission": 2}"#).unwrap();
        assert_eq!(m.emission, Vec3::splat(2.0));
        assert!(matches!(m.kind, MaterialKind::Phong { exponent: 30.0, .. }));
    }

    #[test]
    fn ranges_name_the_field() {
        let path = |json: &str| mat(json).unwrap_err().path().map(str::to_string);
        assert_eq!(
            path(r#"{"type": "diffuse", "reflectance": [0.5, -0.1, 0]}"#).as_deref(),
            Some("materials.m.reflectance")
        );
        assert_eq!(
            path(r#"{"type": "conductor", "roughness": 1.5}"#).as_deref(),
            Some("materials.m.roughness")
        );
        assert_eq!(
            path(r#"{"type": "conductor", "eta": [0.2, 0.9, 1.1]}"#).as_deref(),
            Some("materials.m.k")
        );
        assert_eq!(
            path(r#"{"type": "conductor", "eta": 0, "k": 1}"#).as_deref(),
            Some("materials.m.eta")
        );
        assert_eq!(
            path(r#"{"type": "dielectric", "ior": 0}"#).as_deref(),
            Some("materials.m.ior")
        );
        assert_eq!(
            path(r#"{"type": "dielectric", "two_sided": false}"#).as_deref(),
            Some("materials.m.two_sided")
        );
        assert_eq!(
            path(r#"{"type": "principled", "sheen": -1}"#).as_deref(),
            Some("materials.m.sheen")
        );
        assert_eq!(
            path(r#"{"type": "phong", "exponent": -3}"#).as_deref(),
            Some("materials.m.exponent")
        );
        assert_eq!(
            path(r#"{"type": "diffuse", "emission": [1, 1, -1]}"#).as_deref(),
            Some("materials.m.emission")
        );
        let e = mat(r#"{"type": "conductor", "roughness": 1.5}"#).unwrap_err();
        assert_eq!(
            e.to_string(),
            "materials.m.roughness: must be in [0, 1], got 1.5"
        );
        let e = mat(r#"{"type": "diffuse", "reflectance": {"texture": "w.png"}}"#).unwrap_err();
        assert_eq!(e.path(), Some("materials.m.reflectance.texture"));
    }
}
