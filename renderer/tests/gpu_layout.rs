//! The Rust GPU structs (compile/layout.rs) and their GLSL mirror (shaders/common/types.glsl)
//! agree field by field: each struct is filled with the words 1, 2, 3, ... in Rust's layout, and
//! shaders/tests/layout_check.comp writes the fields back in declaration order. Any offset,
//! size or order mismatch shows up as a wrong word.

use std::mem::size_of;
use std::sync::Arc;

use bytemuck::Pod;
use renderer::gpu::{
    compile_glsl, Binding, Buffer, BufferUsage, ComputePipeline, GpuContext, GpuOptions,
};
use renderer::layout::*;

/// A T whose 32-bit words are start, start+1, ...
fn counting<T: Pod>(start: u32) -> T {
    let words: Vec<u32> = (0..(size_of::<T>() / 4) as u32)
        .map(|i| start + i)
        .collect();
    bytemuck::pod_read_unaligned(bytemuck::cast_slice(&words))
}

fn buffer<T: Pod>(ctx: &Arc<GpuContext>, name: &str, start: u32) -> Buffer {
    Buffer::from_slice(ctx, name, &[counting::<T>(start)]).unwrap()
}

#[test]
fn glsl_mirror_matches_rust_layout() {
    let ctx = Arc::new(
        GpuContext::new(&GpuOptions {
            device: None,
            validation: true,
            ..Default::default()
        })
        .unwrap(),
    );
    let spirv = compile_glsl("tests/layout_check.comp", &vec![]).unwrap();
    // (binding, buffer, words, first output word)
    let structs: Vec<(u32, Buffer, usize, usize)> = vec![
        (
            0,
            buffer::<GpuGlobals>(&ctx, "globals", 1000),
            size_of::<GpuGlobals>() / 4,
            0,
        ),
        (
            1,
            buffer::<GpuBvhNode>(&ctx, "node", 2000),
            size_of::<GpuBvhNode>() / 4,
            128,
        ),
        (
            2,
            buffer::<GpuPrim>(&ctx, "prim", 3000),
            size_of::<GpuPrim>() / 4,
            192,
        ),
        (
            3,
            buffer::<GpuTriShading>(&ctx, "shading", 4000),
            size_of::<GpuTriShading>() / 4,
            256,
        ),
        (
            4,
            buffer::<GpuMaterial>(&ctx, "material", 5000),
            size_of::<GpuMaterial>() / 4,
            320,
        ),
        (
            5,
            buffer::<GpuTexture>(&ctx, "texture", 6000),
            size_of::<GpuTexture>() / 4,
            384,
        ),
        (
            6,
            buffer::<GpuLight>(&ctx, "light", 7000),
            size_of::<GpuLight>() / 4,
            448,
        ),
        (
            7,
            buffer::<GpuAlias>(&ctx, "alias", 8000),
            size_of::<GpuAlias>() / 4,
            512,
        ),
        (
            8,
            buffer::<GpuStats>(&ctx, "stats", 9000),
            size_of::<GpuStats>() / 4,
            576,
        ),
        (
            10,
            buffer::<GpuInstance>(&ctx, "instance", 11000),
            size_of::<GpuInstance>() / 4,
            704,
        ),
    ];
    let out = Buffer::new(&ctx, "out", 768 * 4, BufferUsage::Storage).unwrap();
    ctx.fill_zero(&out).unwrap();
    let mut bindings: Vec<Binding<'_>> = structs
        .iter()
        .map(|(i, b, _, _)| Binding {
            index: *i,
            buffer: b,
        })
        .collect();
    bindings.push(Binding {
        index: 9,
        buffer: &out,
    });
    let pipeline = ComputePipeline::new(
        &ctx,
        "layout check",
        &spirv,
        &bindings,
        size_of::<GpuPush>() as u32,
    )
    .unwrap();
    let push: GpuPush = counting(10000);
    ctx.record(1, |rec| {
        rec.dispatch(
            &pipeline,
            bytemuck::bytes_of(&push),
            [1, 1, 1],
            "layout check",
        )
    })
    .unwrap();
    let words: Vec<u32> = ctx.download_vec(&out, 768).unwrap();
    let mut checks = structs
        .iter()
        // Globals (1000) take words 0..128; every other struct starts at 1000 × its 64-word slot.
        .map(|(_, b, n, at)| (b.name.clone(), *n, *at, 1000 * (*at as u32 / 64).max(1)))
        .collect::<Vec<_>>();
    checks.push((
        "push constants".into(),
        size_of::<GpuPush>() / 4,
        640,
        10000,
    ));
    for (name, n, at, start) in checks {
        let got = &words[at..at + n];
        let want: Vec<u32> = (start..start + n as u32).collect();
        assert_eq!(
            got,
            &want[..],
            "{name}: GLSL fields read back in the wrong order or place"
        );
    }
    ctx.check_validation().unwrap();
}
