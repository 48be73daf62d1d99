//! Lighting the volume: injection of direct light into every voxel (inject.comp), the filtered
//! levels (dense: one anisotropic mip level per dispatch, dense_mip.comp; octree: leaf bricks,
//! then per depth the inner samples from the children and the border transfer from the
//! neighbours, brick.comp) and, for `bounces: 2`, the first bounce re-injected (bounce.comp) and
//! filtered again. Runs after a build and again whenever the lights change.

use std::sync::Arc;

use super::gpu::{bindings, groups_1d, pipeline, push, Set};
use super::options::{Settings, VctStorage};
use super::volume::{StageTimes, Volume};
use crate::error::RenderError;
use crate::gpu::{
    Binding, Buffer, BufferUsage, ComputePipeline, GpuContext, Recorder, ShaderDefines,
};

fn sum_ms(t: &[crate::gpu::DispatchTiming]) -> f64 {
    t.iter().map(|d| d.gpu_ms).sum()
}

impl Volume {
    /// The buffers every kernel after the build binds.
    pub fn set(&self) -> Set<'_> {
        Set {
            nodes: Some(&self.nodes),
            attr: Some(&self.attr),
            emit: Some(&self.emit),
            rad: Some(&self.rad),
            mip: Some(&self.mip),
            leaf: Some(&self.leaf),
            bounce: self.bounce.as_ref(),
            ..Default::default()
        }
    }

    /// Records the filtering of every level above 0.
    fn record_filter(
        &self,
        rec: &mut Recorder<'_>,
        pipe: &ComputePipeline,
    ) -> crate::gpu::GpuResult<()> {
        let d = self.levels;
        match self.storage {
            VctStorage::Dense => {
                for m in 1..d {
                    let n = (self.resolution >> m).pow(3);
                    rec.dispatch(
                        pipe,
                        bytemuck::bytes_of(&push(m, n, 0)),
                        groups_1d(n as u64),
                        "vct filter dense",
                    )?;
                }
            }
            VctStorage::Octree => {
                let count =
                    |k: u32| self.info.level_end[k as usize] - self.info.level_start[k as usize];
                let leaves = count(d - 1) * 27;
                rec.dispatch(
                    pipe,
                    bytemuck::bytes_of(&push(d - 1, leaves, 0)),
                    groups_1d(leaves as u64),
                    "vct filter leaf bricks",
                )?;
                for m in 1..d {
                    let k = d - 1 - m;
                    let inner = count(k) * 8;
                    rec.dispatch(
                        pipe,
                        bytemuck::bytes_of(&push(k, inner, 1)),
                        groups_1d(inner as u64),
                        "vct filter bricks",
                    )?;
                    let border = count(k) * 27;
                    rec.dispatch(
                        pipe,
                        bytemuck::bytes_of(&push(k, border, 2)),
                        groups_1d(border as u64),
                        "vct border transfer",
                    )?;
                }
            }
        }
        Ok(())
    }

    fn filter_dispatches(&self) -> u32 {
        1 + 2 * self.levels
    }

    /// Writes the render options (cones, step, AO, shadows, injection samples) into the
    /// parameters the kernels read.
    pub fn apply_options(
        &mut self,
        ctx: &Arc<GpuContext>,
        s: &Settings,
    ) -> Result<(), RenderError> {
        let voxel = self.params.grid[3];
        let side = voxel * self.resolution as f32;
        self.params.cone = [
            (0.5 * s.cone_aperture_deg).to_radians().tan(),
            s.cones as f32,
            s.step,
            s.ao_distance.unwrap_or(side / 8.0) / voxel,
        ];
        self.params.dims[3] = s.max_level;
        self.params.mode = [
            s.ao as u32,
            (s.shadows == super::VctShadows::Cone) as u32,
            s.inject_samples,
            s.cones_per_sample,
        ];
        ctx.upload(&self.params_buf, 0, bytemuck::bytes_of(&self.params))?;
        Ok(())
    }

    /// Injects the scene's lights, filters, and adds the second bounce where asked.
    pub fn light(
        &mut self,
        ctx: &Arc<GpuContext>,
        shared: &[Binding<'_>],
        defines: &ShaderDefines,
        s: &Settings,
        lights_key: u64,
    ) -> Result<(), RenderError> {
        let mut times = StageTimes::default();
        if s.bounces == 2 && self.bounce.is_none() {
            self.bounce = Some(Buffer::new(
                ctx,
                "vct bounce",
                self.slots as u64 * 16,
                BufferUsage::Storage,
            )?);
        }
        self.apply_options(ctx, s)?;
        let set = self.set();
        let b = bindings(shared, &self.params_buf, &self.info_buf, &self.dummy, &set);
        let inject = pipeline(ctx, "vct/inject.comp", defines, &b)?;
        let filter_kernel = match self.storage {
            VctStorage::Dense => "vct/dense_mip.comp",
            VctStorage::Octree => "vct/brick.comp",
        };
        let filter = pipeline(ctx, filter_kernel, defines, &b)?;
        let slots = self.slots;
        // Step 1: injection.
        let t = ctx.record(1, |rec| {
            rec.dispatch(
                &inject,
                bytemuck::bytes_of(&push(0, slots, 0)),
                groups_1d(slots as u64),
                "vct inject",
            )
        })?;
        times.inject_ms += sum_ms(&t);
        // Step 2: filtering.
        let t = ctx.record(self.filter_dispatches(), |rec| {
            self.record_filter(rec, &filter)
        })?;
        times.filter_ms += sum_ms(&t);
        // Step 3: the second bounce, gathered from the filtered first one, added and refiltered.
        if s.bounces == 2 {
            let bounce = pipeline(ctx, "vct/bounce.comp", defines, &b)?;
            let t = ctx.record(2, |rec| {
                rec.dispatch(
                    &bounce,
                    bytemuck::bytes_of(&push(0, slots, 0)),
                    groups_1d(slots as u64),
                    "vct bounce gather",
                )?;
                rec.dispatch(
                    &bounce,
                    bytemuck::bytes_of(&push(0, slots, 1)),
                    groups_1d(slots as u64),
                    "vct bounce add",
                )
            })?;
            times.bounce_ms += sum_ms(&t);
            let t = ctx.record(self.filter_dispatches(), |rec| {
                self.record_filter(rec, &filter)
            })?;
            times.filter_ms += sum_ms(&t);
        }
        drop(b);
        self.light_times = times;
        self.lights_key = Some(lights_key);
        Ok(())
    }

    /// Debug: samples the filtered volume at `probes` = (grid position, level or −(m+1) for
    /// exactly level m, direction) and returns the values (see shaders/vct/probe.comp).
    pub fn probe(
        &self,
        ctx: &Arc<GpuContext>,
        shared: &[Binding<'_>],
        defines: &ShaderDefines,
        probes: &[([f32; 4], [f32; 4])],
    ) -> Result<Vec<[f32; 4]>, RenderError> {
        let mut data: Vec<[f32; 4]> = Vec::with_capacity(probes.len() * 3);
        for (p, d) in probes {
            data.extend([*p, *d, [0.0; 4]]);
        }
        let buf = Buffer::from_slice(ctx, "vct probes", &data)?;
        let mut set = self.set();
        set.probe = Some(&buf);
        let b = bindings(shared, &self.params_buf, &self.info_buf, &self.dummy, &set);
        let pipe = pipeline(ctx, "vct/probe.comp", defines, &b)?;
        let n = probes.len() as u32;
        ctx.record(1, |rec| {
            rec.dispatch(
                &pipe,
                bytemuck::bytes_of(&push(0, n, 0)),
                groups_1d(n as u64),
                "vct probe",
            )
        })?;
        let out: Vec<[f32; 4]> = ctx.download_vec(&buf, data.len())?;
        Ok(out.chunks(3).map(|c| c[2]).collect())
    }
}
