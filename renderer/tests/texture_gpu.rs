//! GPU unit test of texture lookups, `shaders/common/texture.glsl`, run through
//! `shaders/tests/texture_check.comp` on the default device (lavapipe in CI) with the validation
//! layer on. `texture_eval` wraps the bilinear footprint by selects that rely on its uv lying in
//! [0, 1) after `uv − floor(uv)`; this checks that against a host reference written the plain
//! way (Euclidean remainders for repeat, clamps for rows of environment maps), at the places
//! where wrapping happens: uvs on and next to 0 and 1, negative and large uvs, uv scales (also
//! negative), textures one texel wide or high, and rows clamped (flag bit 0). Values must agree
//! within 1e-5. Non-finite uvs must read inside the texture (the validation layer and the
//! outputs: NaN or a value within the texels' range).

mod common;
use common::stats::SplitMix64;
use common::{context, run_check_kernel};

use renderer::gpu::{Binding, Buffer};
use renderer::layout::{binding, GpuPush, GpuTexture};

const BINDING_INPUTS: u32 = 60;
const BINDING_OUTPUTS: u32 = 61;

/// A texture of the test: size, flags, uv scale.
struct Tex {
    width: u32,
    height: u32,
    flags: u32,
    scale: [f32; 2],
}

/// A texture of `width` × `height` texels with flags and uv scale.
const fn tex(width: u32, height: u32, flags: u32, scale: [f32; 2]) -> Tex {
    Tex {
        width,
        height,
        flags,
        scale,
    }
}

const TEXTURES: [Tex; 6] = [
    tex(5, 4, 0, [1.0, 1.0]),
    tex(1, 1, 0, [1.0, 1.0]),
    tex(1, 3, 0, [3.0, 0.5]),
    tex(7, 2, 0, [-1.5, 2.25]),
    tex(6, 3, 1, [1.0, 1.0]),
    tex(2, 1, 1, [1.0, 1.0]),
];

/// The host reference: bilinear over texel centres, columns repeating, rows repeating or
/// clamped (flag bit 0), row 0 at the top; the float steps as texture.glsl takes them (f32).
fn reference(t: &Tex, texels: &[[f32; 4]], uv: [f32; 2]) -> [f32; 4] {
    let (w, h) = (t.width as i64, t.height as i64);
    let u = uv[0] * t.scale[0];
    let v = uv[1] * t.scale[1];
    let (u, v) = (u - u.floor(), v - v.floor());
    let fx = u * t.width as f32 - 0.5;
    let fy = (1.0 - v) * t.height as f32 - 0.5;
    let (x0, y0) = (fx.floor(), fy.floor());
    let (ax, ay) = (fx - x0, fy - y0);
    let fetch = |x: i64, y: i64| {
        let x = x.rem_euclid(w);
        let y = if t.flags & 1 != 0 {
            y.clamp(0, h - 1)
        } else {
            y.rem_euclid(h)
        };
        texels[(y * w + x) as usize]
    };
    let (ix, iy) = (x0 as i64, y0 as i64);
    let (c00, c10) = (fetch(ix, iy), fetch(ix + 1, iy));
    let (c01, c11) = (fetch(ix, iy + 1), fetch(ix + 1, iy + 1));
    let mix = |a: f32, b: f32, s: f32| a + (b - a) * s;
    [0, 1, 2, 3].map(|c| mix(mix(c00[c], c10[c], ax), mix(c01[c], c11[c], ax), ay))
}

#[test]
fn texture_eval_wraps_and_clamps_like_the_reference() {
    let ctx = context();
    let mut rng = SplitMix64(7);
    // Step 1: the textures, random texels in [0, 1).
    let mut headers = Vec::new();
    let mut texels: Vec<[f32; 4]> = Vec::new();
    let mut per_texture = Vec::new();
    for t in &TEXTURES {
        let n = (t.width * t.height) as usize;
        let own: Vec<[f32; 4]> = (0..n).map(|_| [0; 4].map(|_| rng.next_f32())).collect();
        headers.push(GpuTexture {
            offset: texels.len() as u32,
            width: t.width,
            height: t.height,
            flags: t.flags,
            scale: t.scale,
            pad: [0.0; 2],
        });
        texels.extend_from_slice(&own);
        per_texture.push(own);
    }
    // Step 2: the uvs: edges, texel centres and boundaries, random ones, non-finite ones.
    let tiny = f32::EPSILON;
    let mut edges = vec![
        0.0f32,
        1.0,
        -1.0,
        2.0,
        tiny,
        1.0 - tiny,
        -tiny,
        1.0 + tiny,
        0.5,
        -0.25,
    ];
    edges.extend([1e-9, -1e-9, 1e7, -1e7 + 0.3, 12345.678]);
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    for &a in &edges {
        for &b in &edges {
            uvs.push([a, b]);
        }
    }
    for k in 0..=28 {
        uvs.push([k as f32 / 28.0, 1.0 - k as f32 / 28.0]);
    }
    for _ in 0..2000 {
        uvs.push([0; 2].map(|_| rng.next_f32() * 8.0 - 4.0));
    }
    let finite = uvs.len();
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        uvs.push([bad, 0.3]);
        uvs.push([0.3, bad]);
    }
    let inputs: Vec<[f32; 4]> = (0..TEXTURES.len())
        .flat_map(|t| uvs.iter().map(move |uv| [uv[0], uv[1], t as f32, 0.0]))
        .collect();
    // Step 3: the lookups on the GPU.
    let tex_buf = Buffer::from_slice(&ctx, "textures", &headers).expect("textures");
    let texel_buf = Buffer::from_slice(&ctx, "texels", &texels).expect("texels");
    let extra = [
        Binding {
            index: binding::TEXTURES,
            buffer: &tex_buf,
        },
        Binding {
            index: binding::TEXELS,
            buffer: &texel_buf,
        },
    ];
    let push = GpuPush {
        spp: inputs.len() as u32,
        ..bytemuck::Zeroable::zeroed()
    };
    let out = run_check_kernel(
        &ctx,
        "tests/texture_check.comp",
        [BINDING_INPUTS, BINDING_OUTPUTS],
        &extra,
        bytemuck::bytes_of(&push),
        std::mem::size_of::<GpuPush>() as u32,
        inputs.len() as u32,
        &inputs,
        inputs.len(),
    );
    if let Err(e) = ctx.check_validation() {
        panic!("validation layer: {e}");
    }
    // Step 4: against the reference; non-finite uvs give NaN or a value within the texels.
    let mut worst = 0f32;
    for (i, (input, got)) in inputs.iter().zip(&out).enumerate() {
        let t = input[2] as usize;
        let k = i % uvs.len();
        let uv = [input[0], input[1]];
        if k < finite {
            let want = reference(&TEXTURES[t], &per_texture[t], uv);
            for c in 0..4 {
                let d = (got[c] - want[c]).abs();
                worst = worst.max(d);
                assert!(
                    d < 1e-5,
                    "texture {t} ({}×{}, flags {}, scale {:?}) at uv {uv:?}: GPU {got:?}, reference {want:?}",
                    TEXTURES[t].width,
                    TEXTURES[t].height,
                    TEXTURES[t].flags,
                    TEXTURES[t].scale
                );
            }
        } else {
            for c in 0..4 {
                let x = got[c];
                assert!(
                    x.is_nan() || (-1e-6..=1.0 + 1e-6).contains(&x),
                    "texture {t} at non-finite uv {uv:?}: {got:?}"
                );
            }
        }
    }
    println!(
        "{} lookups on {} textures: largest difference from the reference {worst:.2e}",
        inputs.len(),
        TEXTURES.len()
    );
}
