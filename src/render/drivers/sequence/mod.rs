//! Camera sequences: camera paths (orbit, dolly, glTF camera animation) and the
//! driver that renders frame after frame, with or without reuse between frames
//! ([`crate::render::temporal`]), and optionally compares each frame with a full render.
//!
//! Frame numbers are global: frame `k` of a path is the same camera whichever range is
//! rendered, so a scheduler can spread a sequence over machines. The sample cache starts
//! empty at the first frame of every range (and whenever frames are not rendered in order),
//! so a range's first frame is a full render and a range never depends on frames before it.

mod camera_path;
mod plot;
mod summary;

pub use camera_path::{CameraAnimation, CameraAnimationError, CameraPath, CameraPathSpec};
pub use plot::plot;
pub use summary::{
    pass_spreads, FrameSummary, PassSpread, ReferenceComparison, ReferenceSummary, SequenceFrame,
    SequenceOptions, SequenceSummary, Spread,
};

use serde::Serialize;

use crate::render::drivers::targets::FrameTargets;
use crate::render::image::metrics;
use crate::render::passes::draw_list::{self, Draw};
use crate::render::passes::gbuffer;
use crate::render::readback::{FrameRing, RingContents};
use crate::render::settings::SettingsError;
use crate::render::temporal::{PixelSource, ReprojectedFrame, Reprojector, ReuseStats};
use crate::render::{merge_scopes, RenderOutput, RenderSettings, Renderer};
use crate::scene::{Camera, Scene};
use crate::vk::{Context, FrameTiming, GpuProfiler, VkError};

/// Renders the frames of a camera path.
///
/// Every resource is allocated once, in [`Sequence::new`] (and [`Sequence::prepare_bursts`]):
/// the reprojection cache, the full-render targets and the host-visible ring that frames copy
/// their images and counters into. Frames are recorded in bursts, back to back in one
/// submission ([`Sequence::render_burst`]); [`Sequence::render_frame`] is a burst of one.
///
/// It does not borrow the renderer (whose buffers its descriptor sets point at: the renderer
/// must outlive it), so an animated scene updated in place between frames keeps one sequence,
/// and its sample cache, across them ([`Sequence::update_scene`]).
pub struct Sequence {
    draws: Vec<Draw>,
    settings: RenderSettings,
    base: Camera,
    path: CameraPath,
    options: SequenceOptions,
    reprojector: Option<Reprojector>,
    /// Full renders: every frame of a sequence without reuse, and the references.
    full: FrameTargets,
    burst: BurstResources,
    next: Option<u32>,
}

/// What the full render of a frame keeps for its comparison and for callers.
const REFERENCE_CONTENTS: RingContents = RingContents {
    rgba8: true,
    color: true,
    aov: false,
    states: false,
};

/// What a burst's frames copy their outputs into, and its timestamps.
struct BurstResources {
    frames: FrameRing,
    references: Option<FrameRing>,
    profiler: Option<GpuProfiler>,
}

impl BurstResources {
    fn new(
        ctx: &Context,
        settings: &RenderSettings,
        frames: u32,
        contents: RingContents,
        reference: bool,
    ) -> crate::Result<Self> {
        let pixels = settings.pixels();
        let ring = FrameRing::new(ctx, "sequence frames", frames, pixels, contents)?;
        let references = reference
            .then(|| {
                FrameRing::new(
                    ctx,
                    "sequence references",
                    frames,
                    pixels,
                    REFERENCE_CONTENTS,
                )
            })
            .transpose()?;
        // Each frame (and its reference) is one profiler frame plus its scopes.
        let scopes =
            (crate::render::temporal::SCOPES_PER_FRAME + 8 + crate::render::denoise::SCOPES)
                * frames
                * 2;
        Ok(Self {
            frames: ring,
            references,
            profiler: GpuProfiler::new(ctx, scopes).ok(),
        })
    }
}

/// How the warm-up before timed bursts went ([`Sequence::warm_up`]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct WarmUp {
    /// Warm-up bursts rendered.
    pub bursts: u32,
    /// Frames per warm-up burst.
    pub frames_per_burst: u32,
    /// Mean GPU milliseconds per frame of each warm-up burst.
    pub burst_mean_ms: Vec<f64>,
    /// Whether the last two bursts agreed within [`WARM_UP_TOLERANCE`].
    pub settled: bool,
}

pub use crate::render::drivers::burst::{WARM_UP_MAX_BURSTS, WARM_UP_TOLERANCE};

impl Sequence {
    /// Prepares a sequence of `scene` (already uploaded into `renderer`) along `path`, where
    /// `base` is frame 0's camera. Fails before allocating anything when the frames, and with
    /// reuse the sample cache ([`Reprojector::check_device`]), do not fit the device.
    pub fn new(
        ctx: &Context,
        renderer: &Renderer,
        scene: &Scene,
        settings: &RenderSettings,
        base: Camera,
        path: CameraPath,
        options: SequenceOptions,
    ) -> crate::Result<Self> {
        if options.reuse.any() && settings.denoise.enabled() {
            return Err(crate::SettingsError::new(
                "--denoise",
                format!(
                    "--denoise {} filters full renders; it cannot be combined with temporal reuse (--reproject, --frameless, --subsample)",
                    settings.denoise.as_str()
                ),
            )
            .into());
        }
        // Before anything is allocated: the frame's buffers, and with reuse the sample cache
        // and its per-pixel buffers on top, against the device's limits and heap.
        let in_use = ctx.allocated_bytes();
        if options.reuse.any() {
            Reprojector::check_device(
                settings,
                ctx.info(),
                options.path,
                options.reuse.moving_geometry,
                in_use,
            )
        } else {
            settings.check_device(ctx.info(), options.path, false, in_use)
        }?;
        let reprojector = if options.reuse.any() {
            Some(Reprojector::new(
                ctx,
                renderer,
                options.path,
                settings,
                options.reuse,
            )?)
        } else {
            None
        };
        // Reprojection reads positions and motion from the full G-buffer; full renders of a
        // reusing sequence (first frame, references) rasterize the same layout so that a static
        // camera reproduces them exactly.
        let mut settings = settings.clone();
        if options.reuse.any() {
            settings.gbuffer = gbuffer::GbufferLayout::Full;
        }
        let draws = draw_list::draws(scene);
        let full = FrameTargets::new(ctx, renderer, options.path, &settings, &draws, false)?;
        let burst = BurstResources::new(
            ctx,
            &settings,
            1,
            RingContents {
                rgba8: true,
                // Reprojected frames hold linear colour only when asked to.
                color: !options.reuse.any() || options.reuse.linear_color,
                aov: false,
                states: true,
            },
            options.reference && options.reuse.any(),
        )?;
        Ok(Self {
            draws,
            settings,
            base,
            path,
            options,
            reprojector,
            full,
            burst,
            next: None,
        })
    }

    /// Makes room for bursts of up to `frames` frames whose ring slots hold `contents` (one
    /// allocation, before the first burst). Returns the burst length actually prepared: at
    /// most `frames`, fewer when the ring would exceed `max_ring_bytes`.
    pub fn prepare_bursts(
        &mut self,
        ctx: &Context,
        frames: u32,
        contents: RingContents,
        max_ring_bytes: u64,
    ) -> crate::Result<u32> {
        let slot = FrameRing::slot_bytes(self.settings.pixels(), contents)
            + if self.separate_references() {
                FrameRing::slot_bytes(self.settings.pixels(), REFERENCE_CONTENTS)
            } else {
                0
            };
        let frames = frames.clamp(1, (max_ring_bytes / slot.max(1)).clamp(1, 4096) as u32);
        ctx.check_memory("the burst's readback slots", slot * u64::from(frames))?;
        self.burst = BurstResources::new(
            ctx,
            &self.settings,
            frames,
            contents,
            self.separate_references(),
        )?;
        Ok(frames)
    }

    /// Reprojection scatters with two 32-bit atomic passes, as on devices without 64-bit
    /// atomics ([`Reprojector::use_two_pass_scatter`]).
    pub fn use_two_pass_scatter(&mut self) {
        if let Some(r) = self.reprojector.as_mut() {
            r.use_two_pass_scatter();
        }
    }

    /// Whether references are rendered apart from the frames (with reuse; without, a frame is
    /// its own full render and needs no reference slots).
    fn separate_references(&self) -> bool {
        self.options.reference && self.reprojector.is_some()
    }

    /// Makes reprojected samples move with their objects, for a scene whose geometry moves
    /// between frames ([`Reprojector::track_moving_geometry`]; nothing without reuse).
    pub fn track_moving_geometry(&mut self, ctx: &Context) -> crate::Result<()> {
        if let Some(r) = self.reprojector.as_mut() {
            r.track_moving_geometry(ctx)?;
        }
        self.next = None;
        Ok(())
    }

    /// Takes the next frames' scene, `scene` as updated in place in `renderer` (an animated
    /// frame, [`crate::render::drivers::animated::AnimatedFrames::update`]), and `base`, the
    /// camera of frame 0 in it: the raster draws, the full render's passes (bound to the
    /// renderer's ray backend, which an update may have built again) and the reprojector's
    /// bindings. The sample cache is kept, so the next frame in order reuses this one's
    /// samples.
    pub fn update_scene(
        &mut self,
        ctx: &Context,
        renderer: &Renderer,
        scene: &Scene,
        base: Camera,
    ) -> crate::Result<()> {
        self.draws = draw_list::draws(scene);
        // The denoiser's history carries over, as the sample cache does.
        self.full.rebuild(ctx, renderer, &self.draws)?;
        if let Some(r) = self.reprojector.as_mut() {
            r.update_scene(renderer);
        }
        self.base = base;
        Ok(())
    }

    /// The longest burst [`Self::render_burst`] takes.
    pub fn burst_capacity(&self) -> u32 {
        self.burst.frames.slots()
    }

    /// The camera of frame `index`.
    pub fn camera(&self, index: u32) -> Camera {
        self.path.camera(&self.base, index)
    }

    /// Empties the sample cache and the denoiser's history: the next frame is a full render,
    /// filtered on its own.
    pub fn reset(&mut self) {
        if let Some(r) = self.reprojector.as_mut() {
            r.reset();
        }
        self.full.reset_history();
        self.next = None;
    }

    /// The full render's targets (their denoiser, for diagnostics).
    pub fn full_targets(&self) -> &FrameTargets {
        &self.full
    }

    /// Renders frame `index` in its own submission. Frames rendered in order (`index` =
    /// previous + 1) reuse the previous frame's samples; any other index starts from an empty
    /// cache.
    pub fn render_frame(&mut self, ctx: &Context, index: u32) -> crate::Result<SequenceFrame> {
        let mut frames = self.render_burst(ctx, index..index.saturating_add(1))?;
        frames
            .pop()
            .ok_or_else(|| VkError::Invalid("a one-frame burst rendered no frame".into()).into())
    }

    /// Renders frames `frames` back to back in one submission, no host work between them
    /// (with references, each frame's full render follows it in the same submission), then
    /// reads every frame's image, statistics and GPU times from the ring. The images are
    /// identical to rendering the frames one by one. At most [`Self::burst_capacity`] frames.
    pub fn render_burst(
        &mut self,
        ctx: &Context,
        frames: std::ops::Range<u32>,
    ) -> crate::Result<Vec<SequenceFrame>> {
        let count = frames.end.saturating_sub(frames.start);
        if count == 0 || count > self.burst_capacity() {
            return Err(SettingsError::new(
                "--burst",
                format!(
                    "a burst of {count} frames does not fit the prepared {} (Sequence::prepare_bursts)",
                    self.burst_capacity()
                ),
            )
            .into());
        }
        if self.next != Some(frames.start) {
            self.reset();
        }
        let cameras: Vec<Camera> = frames.clone().map(|k| self.camera(k)).collect();
        let mut history = Vec::with_capacity(cameras.len());
        let reference = self.separate_references();
        let Self {
            draws,
            reprojector,
            full,
            burst,
            ..
        } = self;
        let mut profiler = burst.profiler.take();
        let recorded = ctx.run("sequence frames", |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            for (slot, camera) in cameras.iter().enumerate() {
                let slot = slot as u32;
                let number = frames.start + slot;
                if let Some(p) = profiler.as_mut() {
                    p.begin_frame(cmd);
                }
                match reprojector.as_mut() {
                    Some(r) => {
                        history.push(r.has_history() && r.options().reuses());
                        r.record(
                            ctx,
                            cmd,
                            draws,
                            camera,
                            profiler.as_mut(),
                            Some((&burst.frames, slot)),
                        );
                    }
                    None => {
                        history.push(false);
                        full.record(
                            ctx,
                            cmd,
                            &full.sequence_frame(camera, number),
                            profiler.as_mut(),
                            Some((&burst.frames, slot)),
                        );
                    }
                }
                if let Some(p) = profiler.as_mut() {
                    p.end_frame(cmd);
                }
                if let (true, Some(ring)) = (reference, burst.references.as_ref()) {
                    if let Some(p) = profiler.as_mut() {
                        p.begin_frame(cmd);
                    }
                    full.record(
                        ctx,
                        cmd,
                        &full.sequence_frame(camera, number),
                        profiler.as_mut(),
                        Some((ring, slot)),
                    );
                    if let Some(p) = profiler.as_mut() {
                        p.end_frame(cmd);
                    }
                }
            }
            Ok(())
        });
        let timings = match (&recorded, profiler.as_ref()) {
            (Ok(()), Some(p)) => p.frame_results(),
            _ => Ok(Vec::new()),
        };
        burst.profiler = profiler;
        recorded?;
        let timings = timings?;
        self.next = Some(frames.end);
        let per_frame = if reference { 2 } else { 1 };
        let mut out = Vec::with_capacity(cameras.len());
        for (slot, (index, camera)) in frames.zip(cameras).enumerate() {
            let timing = timings.get(slot * per_frame).cloned().unwrap_or_default();
            let ref_timing = reference.then(|| {
                timings
                    .get(slot * per_frame + 1)
                    .cloned()
                    .unwrap_or_default()
            });
            out.push(self.frame_from_ring(
                slot as u32,
                index,
                camera,
                timing,
                ref_timing,
                history[slot],
            )?);
        }
        Ok(out)
    }

    fn frame_from_ring(
        &self,
        slot: u32,
        index: u32,
        camera: Camera,
        timing: FrameTiming,
        ref_timing: Option<FrameTiming>,
        reused_history: bool,
    ) -> crate::Result<SequenceFrame> {
        let ring = &self.burst.frames;
        let (mut output, sources, stats) = match self.reprojector.as_ref() {
            Some(r) => {
                let ReprojectedFrame {
                    output,
                    sources,
                    stats,
                } = r.output(ring, slot)?;
                (output, sources, stats)
            }
            None => {
                let output = self.full.output(ring, slot)?;
                let pixels = u64::from(output.width) * u64::from(output.height);
                let stats = ReuseStats {
                    pixels,
                    traced: pixels,
                    ..Default::default()
                };
                let sources = if ring.contents().states {
                    vec![PixelSource::Traced; pixels as usize]
                } else {
                    Vec::new()
                };
                (output, sources, stats)
            }
        };
        output.gpu_ms = merge_scopes(timing.passes);
        let (reference, reference_output) = if self.options.reference {
            // Without reuse the frame is itself the full render.
            let (full, full_ms) = match (self.burst.references.as_ref(), ref_timing) {
                (Some(refs), Some(t)) if self.reprojector.is_some() => {
                    let mut full = self.full.output(refs, slot)?;
                    full.gpu_ms = merge_scopes(t.passes);
                    (full, t.total_ms)
                }
                _ => (
                    RenderOutput {
                        width: output.width,
                        height: output.height,
                        color: output.color.clone(),
                        rgba8: output.rgba8.clone(),
                        aov: Vec::new(),
                        rays: output.rays,
                        samples: output.samples,
                        gpu_ms: output.gpu_ms.clone(),
                    },
                    timing.total_ms,
                ),
            };
            let diff = metrics::compare(output.width, output.height, &full.rgba8, &output.rgba8);
            (
                Some(ReferenceComparison {
                    rays: full.rays,
                    ray_fraction: output.rays.total() as f64 / full.rays.total().max(1) as f64,
                    diff,
                    total_gpu_ms: full_ms,
                }),
                Some(full),
            )
        } else {
            (None, None)
        };
        Ok(SequenceFrame {
            index,
            camera,
            output,
            sources,
            stats,
            reference,
            reference_output,
            frame_gpu_ms: timing.total_ms,
            reused_history,
        })
    }

    /// Warms the GPU (and lavapipe's shader JIT) up before timed bursts: renders bursts of
    /// `frames` frames from `start` (cache emptied before each) until two consecutive bursts'
    /// mean frame times agree within [`WARM_UP_TOLERANCE`], at most [`WARM_UP_MAX_BURSTS`];
    /// then empties the cache again, so the timed run starts exactly as an untimed one would.
    pub fn warm_up(&mut self, ctx: &Context, start: u32, frames: u32) -> crate::Result<WarmUp> {
        let frames = frames.clamp(1, self.burst_capacity());
        let mut w = WarmUp {
            frames_per_burst: frames,
            ..Default::default()
        };
        while w.bursts < WARM_UP_MAX_BURSTS {
            self.reset();
            let burst = self.render_burst(ctx, start..start.saturating_add(frames))?;
            w.bursts += 1;
            let mean =
                burst.iter().map(|f| f.frame_gpu_ms).sum::<f64>() / burst.len().max(1) as f64;
            w.burst_mean_ms.push(mean);
            if let [.., a, b] = w.burst_mean_ms[..] {
                if crate::render::drivers::burst::bursts_agree(&[a], &[b]) {
                    w.settled = true;
                    break;
                }
            }
        }
        self.reset();
        Ok(w)
    }
}
