//! A session's report ([`RenderStats`]): its counters, its scene's figures and its kernels'.

use super::RenderSession;
use crate::render::RenderStats;

impl RenderSession {
    /// Millions of pixel samples and rays per second of render time so far: a progress
    /// report's figures, without [`Self::stats`]'s driver queries and integrator details (the
    /// deferred integrator reads its counters back from the device there: a wait for every
    /// queued pass, which would leave the GPU idle at each progress event).
    pub fn rates(&self) -> (f64, f64) {
        let t = self.elapsed.as_secs_f64();
        if t <= 0.0 {
            return (0.0, 0.0);
        }
        let samples = self.spp as f64 * self.width as f64 * self.height as f64;
        (samples / t * 1e-6, self.rays as f64 / t)
    }

    /// What the session did so far (the render's report; [`crate::render::render_until`] and
    /// the server add the estimate and why it stopped).
    pub fn stats(&self) -> RenderStats {
        let t = self.elapsed.as_secs_f64();
        let (msamples_per_s, rays_per_s) = self.rates();
        RenderStats {
            device: self.ctx.info.clone(),
            integrator: self.entry.name.to_string(),
            width: self.width,
            height: self.height,
            spp: self.spp,
            passes: self.passes,
            max_depth: self.integrator.max_depth(),
            seed: self.seed,
            time_s: t,
            gpu_time_s: self.gpu_time.as_secs_f64(),
            msamples_per_s,
            rays_per_s,
            rays: self.rays,
            dropped_samples: self.dropped,
            triangles: self.info.triangles,
            primitives: self.info.primitives,
            lights: self.info.lights,
            bvh_nodes: self.info.bvh_nodes,
            bvh_depth: self.info.bvh_depth,
            bvh_build_s: self.info.bvh_build.as_secs_f64(),
            setup_s: self.setup.as_secs_f64(),
            kernel_s: self.kernel_time.as_secs_f64(),
            kernel_stats: self.pipeline.statistics().into_iter().collect(),
            features: self.info.features.names(),
            kernels: self.info.kernels,
            kernel_defines: self.info.kernel_defines.clone(),
            accel: self.info.accel.kind.name().to_string(),
            accel_build_s: self.info.accel.build_time.as_secs_f64(),
            accel_bytes: self.info.bytes.accel,
            accel_phases: (self.info.accel.phases.0.iter())
                .map(|&(n, s)| (n.to_string(), s))
                .collect(),
            accel_estimate: self.info.accel.estimate,
            geometry_bytes: self.info.bytes.geometry,
            scene_gpu_bytes: self.info.bytes.total(),
            gpu_bytes_per_triangle: if self.info.triangles > 0 {
                (self.info.bytes.geometry + self.info.bytes.accel) as f64
                    / self.info.triangles as f64
            } else {
                0.0
            },
            instances: self.info.accel.instances,
            instanced_triangles: self.info.accel.instanced_triangles,
            gpu_bytes_per_instance: if self.info.accel.instances > 0 {
                self.info.accel.instance_bytes as f64 / self.info.accel.instances as f64
            } else {
                0.0
            },
            peak_rss_bytes: crate::memory::peak_rss_bytes(),
            load_s: self.info.load_time.as_secs_f64(),
            compile_s: self.info.compile_time.as_secs_f64(),
            accel_cache: self.info.accel.cache,
            grid_resolution: self.info.accel.grid_resolution,
            grid_refs: self.info.accel.grid_refs,
            kernel_build: self.kernel_build,
            first_pass: self.first_pass.map(|p| crate::render::FirstPass {
                spp: p.spp,
                gpu_ms: p.gpu.as_secs_f64() * 1e3,
                wall_ms: p.wall.as_secs_f64() * 1e3,
            }),
            details: self.integrator.details(),
            rel_mse_estimate: None,
            estimate_checks: self.estimates.report(),
            stopped_by: None,
            light_sampler: self.info.light_sampler,
            auto: None,
        }
    }
}
