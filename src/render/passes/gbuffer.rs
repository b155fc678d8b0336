//! G-buffer raster pass of the hybrid path: dynamic rendering, vertex pulling, depth test,
//! back-face culling honouring doubleSided, alpha MASK discard. Two layouts: a visibility
//! buffer (`shaders/gbuffer_visibility.frag`, the default) or the full G-buffer
//! (`shaders/gbuffer.frag`); see [`GbufferLayout`].

use std::sync::Arc;

use ash::vk;

use super::draw_list::Draw;
use super::raster_compute::{ComputeRaster, DepthAtomics, RasterMode};
use crate::interface::{self as io, bindings, push_bytes, DrawPush};
use crate::render::settings::SettingsError;
use crate::render::PassContext;
use crate::vk::{
    Binding, Buffer, Context, DescriptorSet, GpuProfiler, GraphicsPipeline, GraphicsTargets, Image,
    VkResult,
};

/// What the hybrid path's raster pass writes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GbufferLayout {
    /// Instance and primitive per pixel (8 bytes); the shading pass recovers the hit by
    /// intersecting the pixel's camera ray with that triangle and evaluates the material exactly
    /// like a traced hit. No material work per overdrawn fragment.
    #[default]
    Visibility,
    /// The classic deferred G-buffer (112 bytes per pixel): position, shading and geometric
    /// normals, base colour, metallic, roughness, emissive, occlusion, ids, transmission,
    /// barycentrics and motion vectors, evaluated in the fragment shader.
    Full,
}

impl GbufferLayout {
    /// Attachment formats in location order.
    pub fn formats(self) -> &'static [vk::Format] {
        match self {
            GbufferLayout::Visibility => &VISIBILITY_FORMATS,
            GbufferLayout::Full => &GBUFFER_FORMATS,
        }
    }
}

/// Visibility-buffer attachment: instance, primitive (`gbuffer_visibility.frag`).
pub const VISIBILITY_FORMATS: [vk::Format; 1] = [vk::Format::R32G32_UINT];

/// Full G-buffer attachment formats, in location order (see `gbuffer.frag` for the contents).
pub const GBUFFER_FORMATS: [vk::Format; io::GBUFFER_IMAGES as usize] = [
    vk::Format::R32G32B32A32_SFLOAT, // position, t
    vk::Format::R32G32B32A32_SFLOAT, // shading normal, roughness
    vk::Format::R32G32B32A32_SFLOAT, // geometric normal, metallic
    vk::Format::R16G16B16A16_SFLOAT, // base colour, alpha
    vk::Format::R16G16B16A16_SFLOAT, // emissive, occlusion
    vk::Format::R32G32B32A32_UINT,   // instance, primitive, material | front face, transmission
    vk::Format::R32G32B32A32_SFLOAT, // barycentrics, motion vector
];

/// The raster pass and its attachments.
pub struct GbufferPass {
    pipeline: Arc<GraphicsPipeline>,
    masked_pipeline: Arc<GraphicsPipeline>,
    set: DescriptorSet,
    masked_set: DescriptorSet,
    /// Colour attachments (also read as storage images by the shading pass).
    pub images: Vec<Image>,
    depth: Image,
    extent: vk::Extent2D,
    layout: GbufferLayout,
    /// `Some`: `record` runs the compute rasterizer instead of drawing (`--raster compute`).
    compute: Option<ComputeRaster>,
    raster: RasterMode,
}

impl GbufferPass {
    /// Creates the pipeline and attachments of `layout` at `extent`; `frame` is the Frame
    /// uniform buffer.
    pub fn new(
        ctx: &Context,
        pass: &PassContext<'_>,
        frame: &Buffer,
        extent: vk::Extent2D,
        layout: GbufferLayout,
    ) -> VkResult<Self> {
        Self::create(ctx, pass, frame, extent, layout, RasterMode::Graphics, &[])
    }

    /// Like [`Self::new`], with the visibility pass run by `raster`. The compute rasterizer
    /// writes only the visibility layout and needs the scene's `draws` up front.
    pub fn with_raster(
        ctx: &Context,
        pass: &PassContext<'_>,
        frame: &Buffer,
        extent: vk::Extent2D,
        layout: GbufferLayout,
        raster: RasterMode,
        draws: &[Draw],
    ) -> crate::Result<Self> {
        if raster != RasterMode::Graphics && layout != GbufferLayout::Visibility {
            return Err(SettingsError::new(
                "--raster",
                "--raster compute writes the visibility buffer only; use --gbuffer visibility",
            )
            .into());
        }
        Ok(Self::create(
            ctx, pass, frame, extent, layout, raster, draws,
        )?)
    }

    /// [`Self::with_raster`] once the layout and the rasterizer are known to go together.
    fn create(
        ctx: &Context,
        pass: &PassContext<'_>,
        frame: &Buffer,
        extent: vk::Extent2D,
        layout: GbufferLayout,
        raster: RasterMode,
        draws: &[Draw],
    ) -> VkResult<Self> {
        let set_layout = bindings(&[
            (io::BINDING_SCENE, Binding::UniformBuffer),
            (
                io::BINDING_TEXTURES,
                Binding::SampledImages(pass.texture_capacity()),
            ),
            (io::BINDING_FRAME, Binding::UniformBuffer),
        ]);
        let targets = GraphicsTargets {
            color_formats: layout.formats(),
            depth_format: vk::Format::D32_SFLOAT,
        };
        let make = |alpha_test: u32| {
            GraphicsPipeline::cached(
                ctx,
                crate::shaders::GBUFFER_VERT,
                match layout {
                    GbufferLayout::Visibility => crate::shaders::GBUFFER_VISIBILITY_FRAG,
                    GbufferLayout::Full => crate::shaders::GBUFFER_FRAG,
                },
                &set_layout,
                std::mem::size_of::<DrawPush>() as u32,
                &targets,
                &[alpha_test],
            )
        };
        let (pipeline, masked_pipeline) = (make(0)?, make(1)?);
        let bind = |p: &GraphicsPipeline| -> VkResult<DescriptorSet> {
            let set = p.allocate_set()?;
            pass.scene.bind(&set);
            set.sampled_images(io::BINDING_TEXTURES, pass.textures);
            set.buffer(io::BINDING_FRAME, frame, Binding::UniformBuffer);
            Ok(set)
        };
        let (set, masked_set) = (bind(&pipeline)?, bind(&masked_pipeline)?);
        let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT
            | vk::ImageUsageFlags::STORAGE
            | vk::ImageUsageFlags::TRANSFER_SRC;
        let images = layout
            .formats()
            .iter()
            .enumerate()
            .map(|(i, &f)| Image::new(ctx, &format!("gbuffer {i}"), extent, f, usage, 1))
            .collect::<VkResult<Vec<_>>>()?;
        let depth = Image::new(
            ctx,
            "gbuffer depth",
            extent,
            vk::Format::D32_SFLOAT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            1,
        )?;
        let atomics = match raster {
            RasterMode::Graphics => None,
            RasterMode::Compute => Some(DepthAtomics::best(ctx)),
            RasterMode::ComputeAtomic32 => Some(DepthAtomics::Int32),
        };
        let compute = match atomics {
            None => None,
            Some(atomics) => Some(ComputeRaster::new(
                ctx, pass, frame, extent, draws, &images[0], atomics,
            )?),
        };
        Ok(Self {
            pipeline,
            masked_pipeline,
            set,
            masked_set,
            images,
            depth,
            extent,
            layout,
            compute,
            raster,
        })
    }

    /// What runs this pass.
    pub fn raster(&self) -> RasterMode {
        self.raster
    }

    /// What this pass writes.
    pub fn layout(&self) -> GbufferLayout {
        self.layout
    }

    /// Records the raster pass; afterwards every colour image is in `GENERAL` layout.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        draws: &[Draw],
        camera_pos: glam::Vec3,
        profiler: Option<&mut GpuProfiler>,
    ) {
        let device = ctx.device();
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, crate::render::PassScope::Gbuffer.name());
        }
        for image in &self.images {
            image.transition(cmd, vk::ImageLayout::UNDEFINED, vk::ImageLayout::GENERAL);
        }
        if let Some(compute) = &self.compute {
            compute.record(ctx, cmd);
            crate::vk::memory_barrier(device, cmd);
            if let Some(p) = profiler {
                p.end(cmd);
            }
            return;
        }
        self.depth.transition(
            cmd,
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
        );
        let colors: Vec<_> = self
            .images
            .iter()
            .enumerate()
            .map(|(i, image)| {
                let format = self.layout.formats()[i];
                let clear = if format == vk::Format::R32G32B32A32_UINT
                    || format == vk::Format::R32G32_UINT
                {
                    vk::ClearColorValue {
                        uint32: [u32::MAX; 4],
                    }
                } else {
                    vk::ClearColorValue { float32: [0.0; 4] }
                };
                vk::RenderingAttachmentInfo::default()
                    .image_view(image.view())
                    .image_layout(vk::ImageLayout::GENERAL)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(vk::ClearValue { color: clear })
            })
            .collect();
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(self.depth.view())
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::DONT_CARE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            });
        let area = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: self.extent,
        };
        let info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&colors)
            .depth_attachment(&depth);
        // SAFETY: recording command buffer; attachments are in the layouts named above.
        unsafe {
            device.cmd_begin_rendering(cmd, &info);
            device.cmd_set_viewport(
                cmd,
                0,
                &[vk::Viewport {
                    x: 0.0,
                    y: 0.0,
                    width: self.extent.width as f32,
                    height: self.extent.height as f32,
                    min_depth: 0.0,
                    max_depth: 1.0,
                }],
            );
            device.cmd_set_scissor(cmd, 0, &[area]);
        }
        // Opaque draws first, front to back, so early depth testing skips hidden fragments;
        // alpha-tested draws last with their own pipeline.
        let mut order: Vec<&Draw> = draws.iter().collect();
        order.sort_by(|a, b| {
            let da = (a.center - camera_pos).length_squared();
            let db = (b.center - camera_pos).length_squared();
            a.alpha_test.cmp(&b.alpha_test).then(da.total_cmp(&db))
        });
        let mut bound = None;
        for d in order {
            if bound != Some(d.alpha_test) {
                let (p, set) = if d.alpha_test {
                    (&self.masked_pipeline, &self.masked_set)
                } else {
                    (&self.pipeline, &self.set)
                };
                p.bind(cmd, set);
                bound = Some(d.alpha_test);
            }
            let p = if d.alpha_test {
                &self.masked_pipeline
            } else {
                &self.pipeline
            };
            p.push(
                cmd,
                push_bytes(&DrawPush {
                    instance: d.instance,
                }),
            );
            // SAFETY: inside the rendering scope; dynamic states declared by the pipeline.
            unsafe {
                device.cmd_set_cull_mode(
                    cmd,
                    if d.cull_back {
                        vk::CullModeFlags::BACK
                    } else {
                        vk::CullModeFlags::NONE
                    },
                );
                device.cmd_set_front_face(
                    cmd,
                    if d.mirrored {
                        vk::FrontFace::CLOCKWISE
                    } else {
                        vk::FrontFace::COUNTER_CLOCKWISE
                    },
                );
                device.cmd_draw(cmd, d.vertex_count, 1, 0, 0);
            }
        }
        // SAFETY: matches cmd_begin_rendering above.
        unsafe { device.cmd_end_rendering(cmd) };
        crate::vk::memory_barrier(device, cmd);
        if let Some(p) = profiler {
            p.end(cmd);
        }
    }
}
