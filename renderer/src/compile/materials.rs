//! Materials and textures to their GPU form: each material's parameters go into the slots
//! `SurfaceParams` expects (shaders/common/bsdf/bsdf.glsl); textures are packed into one texel
//! buffer (linear RGBA f32), each with its offset and size.

use glam::Vec3;

use crate::layout::{mat, GpuMaterial, GpuTexture, NONE};
use crate::scene::{ColorParam, Material, MaterialKind, ScalarParam, Texture};

fn color(p: &ColorParam) -> [f32; 4] {
    match p {
        ColorParam::Const(c) => [c.x, c.y, c.z, f32::from_bits(NONE)],
        ColorParam::Texture(t) => [0.0, 0.0, 0.0, f32::from_bits(*t)],
    }
}

fn rgb(c: Vec3) -> [f32; 4] {
    [c.x, c.y, c.z, f32::from_bits(NONE)]
}

/// Converts one material.
pub fn gpu_material(m: &Material) -> GpuMaterial {
    let mut g = GpuMaterial {
        header: [
            0,
            if m.two_sided { mat::F_TWO_SIDED } else { 0 },
            m.alpha_mask.unwrap_or(NONE),
            0,
        ],
        emission: [m.emission.x, m.emission.y, m.emission.z, 0.0],
        colors: [rgb(Vec3::ZERO); 3],
        scalars: [0.0; 12],
        scalar_tex: [NONE; 12],
    };
    let set_scalar = |g: &mut GpuMaterial, i: usize, p: &ScalarParam| match p {
        ScalarParam::Const(v) => g.scalars[i] = *v,
        ScalarParam::Texture(t) => g.scalar_tex[i] = *t,
    };
    match &m.kind {
        MaterialKind::Diffuse { reflectance } => {
            g.header[0] = mat::DIFFUSE;
            g.colors[0] = color(reflectance);
        }
        MaterialKind::Conductor {
            reflectance,
            roughness,
            anisotropy,
            eta_k,
        } => {
            g.header[0] = mat::CONDUCTOR;
            g.colors[0] = color(reflectance);
            if let Some((eta, k)) = eta_k {
                g.header[1] |= mat::F_HAS_ETA_K;
                g.colors[1] = rgb(*eta);
                g.colors[2] = rgb(*k);
            }
            set_scalar(&mut g, 0, roughness);
            set_scalar(&mut g, 1, anisotropy);
        }
        MaterialKind::Dielectric {
            ior,
            roughness,
            transmittance,
            reflectance,
        } => {
            g.header[0] = mat::DIELECTRIC;
            g.colors[0] = color(reflectance);
            g.colors[1] = color(transmittance);
            set_scalar(&mut g, 0, roughness);
            g.scalars[1] = *ior;
        }
        MaterialKind::Principled {
            base_color,
            metallic,
            roughness,
            specular,
            spec_tint,
            anisotropic,
            sheen,
            sheen_tint,
            spec_trans,
            ior,
            subsurface,
            clearcoat,
            clearcoat_gloss,
        } => {
            g.header[0] = mat::PRINCIPLED;
            g.colors[0] = color(base_color);
            let scalars = [
                metallic,
                roughness,
                specular,
                spec_tint,
                anisotropic,
                sheen,
                sheen_tint,
                spec_trans,
            ];
            for (i, s) in scalars.into_iter().enumerate() {
                set_scalar(&mut g, i, s);
            }
            // 0 tells the BSDF to derive η from `specular` (Mitsuba's rule when no ior is given).
            g.scalars[8] = ior.unwrap_or(0.0);
            set_scalar(&mut g, 9, subsurface);
            set_scalar(&mut g, 10, clearcoat);
            set_scalar(&mut g, 11, clearcoat_gloss);
        }
        MaterialKind::Phong {
            diffuse,
            specular,
            exponent,
        } => {
            g.header[0] = mat::PHONG;
            g.colors[0] = color(diffuse);
            g.colors[1] = color(specular);
            g.scalars[0] = *exponent;
        }
    }
    g
}

/// Packs textures into (descriptors, texels). `clamp_rows[i]` marks environment maps.
pub fn pack_textures(
    textures: &[Texture],
    clamp_rows: &[bool],
) -> (Vec<GpuTexture>, Vec<[f32; 4]>) {
    let mut descs = Vec::with_capacity(textures.len());
    let mut texels = Vec::with_capacity(textures.iter().map(|t| t.texels.len()).sum());
    for (i, t) in textures.iter().enumerate() {
        descs.push(GpuTexture {
            offset: texels.len() as u32,
            width: t.width,
            height: t.height,
            flags: u32::from(clamp_rows.get(i).copied().unwrap_or(false)),
            scale: [t.scale.x, t.scale.y],
            pad: [0.0; 2],
        });
        texels.extend_from_slice(&t.texels);
    }
    (descs, texels)
}
