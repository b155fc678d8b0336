//! [`Reprojector::record`]: one reprojected frame's passes, in order, into a command buffer.

use ash::vk;

use super::*;

impl Reprojector {
    /// Records one frame through `camera` into `cmd`, reusing what the cache allows and
    /// caching its samples for the next frame, then, with `out`, copies its counters, image and
    /// pixel states into that ring slot. Frames recorded back to back into one command buffer
    /// give the same images as frames submitted one by one: every per-frame input (camera,
    /// parameters) is written by the frame's own commands. `draws` are the scene's raster
    /// draws (hybrid path; ignored by the rt path). Timestamp scopes go to `profiler`.
    pub fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        draws: &[draw_list::Draw],
        camera: &Camera,
        mut profiler: Option<&mut GpuProfiler>,
        out: Option<(&FrameRing, u32)>,
    ) {
        let s = &self.settings;
        let scale = self.scene_scale;
        let setup = CameraSetup::new(camera, s.width, s.height, scale);
        let scene = crate::render::SceneTraits {
            scale,
            emissive_geometry: self.emissive_geometry,
        };
        let mut frame = GpuFrame::new(s, &setup, scene);
        frame.sample_base = self.frames_recorded;
        self.frames_recorded = self.frames_recorded.wrapping_add(1);
        if let Some(prev) = self.prev_view_proj {
            frame.prev_view_proj = prev;
        }
        let o = &self.options;
        let reuse = o.reuses() && self.has_history;
        let mut flags = 0;
        if reuse {
            flags |= RP_REUSE;
        }
        if self.path == RenderPath::Hybrid {
            flags |= RP_GBUFFER;
        } else if o.rt_visibility == PrimaryRayCheck::Full {
            flags |= RP_VERIFY_ALL;
        }
        if o.frameless_percent.is_some() {
            flags |= RP_FRAMELESS;
        }
        if o.adaptive_subsample {
            flags |= RP_ADAPTIVE;
        }
        if o.linear_color {
            flags |= RP_LINEAR_COLOR;
        }
        if self.moving {
            flags |= RP_MOVING;
        }
        let params = GpuParams {
            flags,
            max_age: o.max_age.unwrap_or(u32::MAX),
            frameless_fraction: o.frameless_percent.unwrap_or(0.0) / 100.0,
            subsample_threshold: o.subsample_threshold,
            tonemap_op: crate::render::passes::tonemap::operator_code(s.tonemap),
            plane_threshold: PLANE_DISTANCE_THRESHOLD,
            normal_threshold: NORMAL_DOT_THRESHOLD,
            edge_threshold: EDGE_PLANE_THRESHOLD,
            specular_metallic: SPECULAR_METALLIC,
            specular_roughness: SPECULAR_ROUGHNESS,
            fill_radius: FILL_RADIUS,
            max_hops: MAX_FILL_HOPS,
            tonemap_scale: s.exposure.exp2(),
            pad0: 0,
            cache_prev: self.res.caches[self.parity].address(),
            cache_next: self.res.caches[1 - self.parity].address(),
            key_winner: self.res.key_winner.address(),
            states: self.res.state.address(),
            colors: self.res.color.address(),
            display: self.res.display.address(),
            shown: self.res.shown.address(),
            jobs: self.res.jobs.address(),
            anchors_prev: self.res.anchors[self.parity].address(),
            anchors_next: self.res.anchors[1 - self.parity].address(),
        };
        let tiles = [s.width.div_ceil(TILE), s.height.div_ceil(TILE), 1];
        let pipes = &self.pipes;
        let device = ctx.device();
        // One pass of a stage; `gather` names the level whose pixels to trace it lists.
        let stage = |cmd: vk::CommandBuffer, stage: Stage, level: u32, gather: u32| {
            let push = ReprojectPush { level, gather };
            let groups = if stage == Stage::Threshold {
                [1, 1, 1]
            } else {
                tiles
            };
            pipes.stages[stage as usize].dispatch(
                cmd,
                Some(&pipes.stages_set),
                push_bytes(&push),
                groups,
            );
            memory_barrier(device, cmd);
        };
        // A tracing pass over job list `list`, sized by the list's length (written by the last
        // subgroup of the pass that appended to it), so its cost follows its jobs.
        let traced = |cmd: vk::CommandBuffer,
                      pipeline: &ComputePipeline,
                      set: &DescriptorSet,
                      name: &str,
                      push: &[u8],
                      list: u32,
                      profiler: Option<&mut GpuProfiler>| {
            let mut profiler = profiler;
            if let Some(p) = profiler.as_deref_mut() {
                p.begin(cmd, name);
            }
            pipeline.dispatch_indirect_at(
                cmd,
                Some(set),
                push,
                &self.res.args,
                16 * u64::from(list),
            );
            memory_barrier(device, cmd);
            if let Some(p) = profiler {
                p.end(cmd);
            }
        };
        let levels: &[u32] = if o.adaptive_subsample {
            &[4, 2, 1]
        } else {
            &[1]
        };
        let rt_verify = (reuse || o.adaptive_subsample) && self.path == RenderPath::RayTraced;
        let frameless = flags & RP_FRAMELESS != 0;

        // Write-after-read against the previous frame in the same command buffer.
        memory_barrier(device, cmd);
        self.res
            .frame
            .record_update(device, cmd, bytemuck::bytes_of(&frame));
        self.res
            .params
            .record_update(device, cmd, bytemuck::bytes_of(&params));
        // SAFETY: recording command buffer; the buffers are ours.
        unsafe {
            device.cmd_fill_buffer(cmd, self.res.key_winner.raw(), 0, vk::WHOLE_SIZE, !0);
            // The frameless sweep's position (C_SWEEP, the last slot) carries over from the
            // previous frame of the sequence.
            let cleared = if self.has_history {
                u64::from(C_SWEEP) * 4
            } else {
                vk::WHOLE_SIZE
            };
            device.cmd_fill_buffer(cmd, self.res.counters.raw(), 0, cleared, 0);
            // Most pixels reuse their sample; the passes write the state of the others only
            // (a CPU device stores words lane by lane, and fills buffers with memset).
            device.cmd_fill_buffer(cmd, self.res.state.raw(), 0, vk::WHOLE_SIZE, PX_REUSE);
        }
        memory_barrier(device, cmd);
        match &self.res.gbuffer {
            Gbuffer::Raster(g) => {
                g.record(ctx, cmd, draws, camera.position(), profiler.as_deref_mut())
            }
            Gbuffer::Traced(images) => {
                if !self.gbuffer_in_general {
                    for image in images {
                        image.transition(cmd, vk::ImageLayout::UNDEFINED, vk::ImageLayout::GENERAL);
                    }
                }
                self.gbuffer_in_general = true;
            }
        }
        // Every stage is its own timestamp scope, so the JSON and the reports show where a
        // reprojected frame's time goes.
        let scope = |profiler: &mut Option<&mut GpuProfiler>, name: &str| {
            if let Some(p) = profiler.as_deref_mut() {
                p.begin(cmd, name);
            }
        };
        if reuse {
            scope(&mut profiler, "scatter");
            match &pipes.scatter64 {
                Some((pipeline, set)) => {
                    pipeline.dispatch(cmd, Some(set), &[], tiles);
                    memory_barrier(device, cmd);
                }
                None => {
                    stage(cmd, Stage::Scatter, 0, GATHER_NONE);
                    stage(cmd, Stage::Resolve, 0, GATHER_NONE);
                }
            }
            scope(&mut profiler, "shown");
            stage(cmd, Stage::Shown, 0, GATHER_NONE);
        }
        // The stage that settles the pixels commits the reused ones, counts them, and lists
        // the pixels left for rays: for the verify pass (rt path) and for the first trace.
        scope(&mut profiler, "classify");
        if frameless {
            // From the shown stage's histogram of the candidates' refresh order.
            stage(cmd, Stage::Threshold, 0, GATHER_NONE);
        }
        stage(cmd, Stage::Classify, 0, levels[0]);
        if rt_verify {
            // Settles the candidates and lists the rejected ones for the first trace.
            traced(
                cmd,
                &pipes.verify.0,
                &pipes.verify.1,
                "visibility",
                push_bytes(&VerifyPush { level: levels[0] }),
                LIST_VERIFY,
                profiler.as_deref_mut(),
            );
        }
        // Each interpolation lists the next level's pixels to trace in list 0.
        for (i, &level) in levels.iter().enumerate() {
            let list = if i == 0 { LIST_TRACE } else { LIST_VERIFY };
            traced(
                cmd,
                &pipes.trace.0,
                &pipes.trace.1,
                "trace",
                push_bytes(&TracePush { list }),
                list,
                profiler.as_deref_mut(),
            );
            if let Some(&next) = levels.get(i + 1) {
                // Over the pending pixels' list, sized by its length like the tracing passes.
                traced(
                    cmd,
                    &pipes.stages[Stage::Interpolate as usize],
                    &pipes.stages_set,
                    "interpolate",
                    push_bytes(&ReprojectPush {
                        level,
                        gather: next,
                    }),
                    LIST_PENDING,
                    profiler.as_deref_mut(),
                );
            }
        }
        if let Some(p) = profiler {
            p.end(cmd);
        }
        if let Some((ring, slot)) = out {
            memory_barrier(device, cmd);
            ring.record_copy(
                device,
                cmd,
                slot,
                &RingSources {
                    counters: &self.res.counters,
                    rgba8: &self.res.display,
                    color: &self.res.color,
                    aov: None,
                    states: Some(&self.res.state),
                },
            );
        }
        self.parity = 1 - self.parity;
        self.has_history = true;
        self.prev_view_proj = Some(frame.view_proj);
    }
}
