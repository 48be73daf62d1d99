//! Shared by the renderer's GPU tests: one way to open the device with the validation layer on.

use std::sync::Arc;

use renderer::gpu::{GpuContext, GpuOptions};

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
