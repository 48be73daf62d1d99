//! Shared by the renderer's GPU tests: one way to open the device with the validation layer on,
//! and one way to run a check kernel (shaders/tests/) over a list of items.

pub mod stats;

use std::sync::Arc;

use renderer::gpu::{
    compile_glsl, Binding, Buffer, BufferUsage, ComputePipeline, GpuContext, GpuOptions,
};

/// The default device with the Khronos validation layer enabled when installed.
pub fn context() -> Arc<GpuContext> {
    let ctx = GpuContext::new(&GpuOptions {
        device: None,
        validation: true,
        ..Default::default()
    })
    .expect("device");
    let layer = if ctx.validation_enabled {
        "on"
    } else {
        "not installed"
    };
    println!(
        "device: {} ({}), validation layer {layer}",
        ctx.info.name, ctx.info.driver
    );
    Arc::new(ctx)
}

/// Runs check kernel `shader` (64 threads a group) for `threads` items: `inputs` (vec4s; one
/// placeholder when empty) at binding `io[0]`, `out_count` zeroed vec4 outputs at `io[1]`, the
/// `extra` bindings beside them and `push` as push constants of `push_size` bytes. Returns the
/// outputs.
#[allow(clippy::too_many_arguments, dead_code)] // not every test binary runs check kernels
pub fn run_check_kernel(
    ctx: &Arc<GpuContext>,
    shader: &str,
    io: [u32; 2],
    extra: &[Binding<'_>],
    push: &[u8],
    push_size: u32,
    threads: u32,
    inputs: &[[f32; 4]],
    out_count: usize,
) -> Vec<[f32; 4]> {
    let spirv = compile_glsl(shader, &Vec::new()).expect("compile");
    let placeholder = [[0.0f32; 4]];
    let in_data = if inputs.is_empty() {
        &placeholder[..]
    } else {
        inputs
    };
    let in_buf = Buffer::from_slice(ctx, "check inputs", in_data).expect("inputs");
    let out_buf = Buffer::new(
        ctx,
        "check outputs",
        (out_count * 16) as u64,
        BufferUsage::Storage,
    )
    .expect("outputs");
    ctx.fill_zero(&out_buf).expect("fill");
    let mut bindings: Vec<Binding<'_>> = extra
        .iter()
        .map(|b| Binding {
            index: b.index,
            buffer: b.buffer,
        })
        .collect();
    bindings.push(Binding {
        index: io[0],
        buffer: &in_buf,
    });
    bindings.push(Binding {
        index: io[1],
        buffer: &out_buf,
    });
    let pipeline =
        ComputePipeline::new(ctx, shader, &spirv, &bindings, push_size).expect("pipeline");
    ctx.record(1, |rec| {
        rec.dispatch(&pipeline, push, [threads.div_ceil(64), 1, 1], shader)
    })
    .expect("dispatch");
    ctx.download_vec::<[f32; 4]>(&out_buf, out_count)
        .expect("download")
}
