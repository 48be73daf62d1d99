//! GPU unit test of the pixel filter, `shaders/common/filter.glsl`, run through
//! `shaders/tests/filter_check.comp` on the default device (lavapipe in CI) with the validation
//! layer on. bdpt's light-tracing splats weight a contribution by `filter_eval` while its camera
//! paths start at offsets drawn by `filter_sample`; the two agree only if `filter_eval` is the
//! density that `filter_sample` draws from, which image comparisons see only through noise.
//!
//! For a pixel of a film (globals compiled from a one-quad scene with a Gaussian filter), the
//! filter is constant on cells: per axis, the steps [c + k·h, c + (k+1)·h] (h = r/31, k = −31..30,
//! centre c) cut to the film. Checked, for interior pixels (the alias table), pixels near one or
//! two edges (the CDF inversion) and a filter wider than the film (cut on both sides):
//! - ∫ filter_eval over the film, summed exactly over the cells, is 1 within 1e-5;
//! - filter_eval is 0 off the film and past the radius;
//! - N = 2^18 offsets from filter_sample (host uniforms, fixed seed) all land on the film within
//!   the radius, and their cell counts match filter_eval × cell area: Pearson's chi-square with
//!   p > 1e-4 (bins expected below 5 pooled).

mod common;
use common::stats::{chi_square, SplitMix64};
use common::{context, run_check_kernel};

use std::sync::Arc;

use renderer::gpu::{Binding, Buffer, GpuContext};
use renderer::layout::{binding, GpuGlobals, GpuPush};

const MODE_SAMPLE: u32 = 0;
const MODE_EVAL: u32 = 1;
const BINDING_INPUTS: u32 = 60;
const BINDING_OUTPUTS: u32 = 61;
/// Samples per pixel tested.
const N: usize = 1 << 18;
/// Significance: a fixed-seed chi-square test must give p above this.
const MIN_P: f64 = 1e-4;

/// The globals of a `width` × `height` film with a Gaussian filter of standard deviation σ.
fn globals(width: u32, height: u32, stddev: f32) -> GpuGlobals {
    let json = format!(
        r#"{{"version": 1, "camera": {{"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 40}},
            "film": {{"width": {width}, "height": {height},
                      "filter": {{"type": "gaussian", "stddev": {stddev}}}}},
            "materials": {{"e": {{"type": "diffuse", "reflectance": 0, "emission": [1, 1, 1]}}}},
            "objects": [{{"type": "quad", "origin": [-1, -1, 0], "edge_u": [2, 0, 0],
                          "edge_v": [0, 2, 0], "material": "e"}}]}}"#
    );
    let scene = renderer::scene::load_str(&json, None).expect("scene");
    renderer::compile::compile(&scene, width, height)
        .expect("compile")
        .globals
}

/// Runs `mode` of filter_check.comp for `pixel` over `inputs`.
fn run(
    ctx: &Arc<GpuContext>,
    globals: &GpuGlobals,
    mode: u32,
    pixel: [u32; 2],
    inputs: &[[f32; 4]],
) -> Vec<[f32; 4]> {
    let g = Buffer::from_slice(ctx, "globals", std::slice::from_ref(globals)).expect("globals");
    let globals_binding = Binding {
        index: binding::GLOBALS,
        buffer: &g,
    };
    // The kernels' push constants, read by filter_check.comp as mode, count and pixel.
    let push = GpuPush {
        flags: mode,
        spp: inputs.len() as u32,
        seed_lo: pixel[0],
        seed_hi: pixel[1],
        ..bytemuck::Zeroable::zeroed()
    };
    let out = run_check_kernel(
        ctx,
        "tests/filter_check.comp",
        [BINDING_INPUTS, BINDING_OUTPUTS],
        &[globals_binding],
        bytemuck::bytes_of(&push),
        std::mem::size_of::<GpuPush>() as u32,
        inputs.len() as u32,
        inputs,
        inputs.len(),
    );
    if let Err(e) = ctx.check_validation() {
        panic!("validation layer: {e}");
    }
    out
}

/// The cells of one axis, as offsets from the centre c of a pixel on an axis of n pixels: the
/// filter's steps of width h cut to the film, those of positive length.
fn axis_cells(c: f64, n: f64, h: f64) -> Vec<(f64, f64)> {
    (-31..31)
        .map(|k| {
            let lo = (k as f64 * h).max(-c);
            let hi = ((k + 1) as f64 * h).min(n - c);
            (lo, hi)
        })
        .filter(|(lo, hi)| hi > lo)
        .collect()
}

/// Checks the filter of `pixel` on a `width` × `height` film with standard deviation σ.
fn check_pixel(ctx: &Arc<GpuContext>, width: u32, height: u32, stddev: f32, pixel: [u32; 2]) {
    let name = format!("{width}x{height} σ {stddev} pixel {pixel:?}");
    let g = globals(width, height, stddev);
    let (r, h) = (g.filter[1] as f64, g.filter[2] as f64);
    let c = [pixel[0] as f64 + 0.5, pixel[1] as f64 + 0.5];
    let n = [width as f64, height as f64];
    let cx = axis_cells(c[0], n[0], h);
    let cy = axis_cells(c[1], n[1], h);

    // Step 1: the density at each cell's midpoint, and a few points where it must be 0.
    let mut points: Vec<[f32; 4]> = cy
        .iter()
        .flat_map(|y| {
            cx.iter().map(move |x| {
                [
                    (0.5 * (x.0 + x.1)) as f32,
                    (0.5 * (y.0 + y.1)) as f32,
                    0.0,
                    0.0,
                ]
            })
        })
        .collect();
    let cells = points.len();
    let outside = [
        [(-c[0] - 0.01) as f32, 0.0],
        [(n[0] - c[0] + 0.01) as f32, 0.0],
        [0.0, (-c[1] - 0.01) as f32],
        [0.0, (n[1] - c[1] + 0.01) as f32],
        [(r + 0.01) as f32, 0.0],
        [0.0, (-r - 0.01) as f32],
    ];
    points.extend(outside.iter().map(|o| [o[0], o[1], 0.0, 0.0]));
    let density = run(ctx, &g, MODE_EVAL, pixel, &points);
    let prob: Vec<f64> = cy
        .iter()
        .flat_map(|y| cx.iter().map(move |x| (x.1 - x.0) * (y.1 - y.0)))
        .zip(&density)
        .map(|(area, d)| area * d[0] as f64)
        .collect();
    let total: f64 = prob.iter().sum();
    println!("{name}: {} cells, ∫ filter_eval = {total:.7}", cells);
    assert!(
        (total - 1.0).abs() < 1e-5,
        "{name}: ∫ filter_eval = {total}"
    );
    for (o, d) in outside.iter().zip(&density[cells..]) {
        assert_eq!(
            d[0], 0.0,
            "{name}: filter_eval at {o:?} (off the film or the filter)"
        );
    }

    // Step 2: samples, each on the film and within the radius, binned into the cells.
    let mut rng = SplitMix64(0x5eed ^ (pixel[0] as u64) << 16 ^ (pixel[1] as u64) << 32);
    let uniforms: Vec<[f32; 4]> = (0..N)
        .map(|_| [rng.next_f32(), rng.next_f32(), 0.0, 0.0])
        .collect();
    let samples = run(ctx, &g, MODE_SAMPLE, pixel, &uniforms);
    let cell_of = |cells: &[(f64, f64)], o: f64| {
        cells
            .partition_point(|cell| cell.1 <= o)
            .min(cells.len() - 1)
    };
    let mut counts = vec![0u64; cells];
    for s in &samples {
        let o = [s[0] as f64, s[1] as f64];
        for a in 0..2 {
            let p = c[a] + o[a];
            assert!(
                p >= 0.0 && p <= n[a] && o[a].abs() <= r + 1e-6,
                "{name}: offset {o:?} lands off the film or past the radius {r}"
            );
        }
        counts[cell_of(&cy, o[1]) * cx.len() + cell_of(&cx, o[0])] += 1;
    }
    let chi = chi_square(&counts, &prob, N as u64);
    println!(
        "{name}: chi2 {:.1} dof {} p {:.3e}, {} samples in cells of zero density",
        chi.chi2, chi.dof, chi.p, chi.impossible
    );
    assert_eq!(chi.impossible, 0, "{name}: samples where filter_eval is 0");
    assert!(
        chi.p > MIN_P,
        "{name}: samples do not follow filter_eval (p = {})",
        chi.p
    );
}

#[test]
fn filter_sample_draws_from_filter_eval() {
    let ctx = context();
    // Interior on both axes (the alias table); a corner; one axis near its low edge and the other
    // near its high edge.
    for pixel in [[6, 4], [0, 0], [1, 7]] {
        check_pixel(&ctx, 12, 9, 0.5, pixel);
    }
    // r = 5.2 on a 5 × 4 film: every axis cut on both sides.
    check_pixel(&ctx, 5, 4, 1.3, [2, 1]);
}
