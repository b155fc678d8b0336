//! GPU skinning and morphing (`shaders/skin.comp`): one compute dispatch per deformed
//! geometry writes this frame's positions, normals and tangents from the rest vertices, the
//! joint matrices and the morph weights. The CPU reference is [`crate::scene::deform::deform`].

use std::sync::Arc;

use ash::vk;
use glam::{Mat4, Vec3, Vec4};

use crate::interface::{
    bindings, push_bytes, SkinPush, BINDING_SKIN_DELTAS, BINDING_SKIN_JOINTS,
    BINDING_SKIN_JOINT_MATRICES, BINDING_SKIN_MORPH_WEIGHTS, BINDING_SKIN_OUT_NORMALS,
    BINDING_SKIN_OUT_POSITIONS, BINDING_SKIN_OUT_TANGENTS, BINDING_SKIN_REST_NORMALS,
    BINDING_SKIN_REST_POSITIONS, BINDING_SKIN_REST_TANGENTS, BINDING_SKIN_WEIGHTS, SKIN_SKINNED,
    SKIN_TANGENTS,
};
use crate::scene::deform::Deformed;
use crate::scene::Geometry;
use crate::vk::{
    Binding, Buffer, ComputePipeline, Context, DescriptorSet, GpuProfiler, MemoryLocation, VkError,
    VkResult,
};

/// Name of the pass in GPU timings.
pub const PASS_NAME: &str = "skin";

/// Bindings of the rest data, in the order of `SkinningPass::_rest`.
const REST_BINDINGS: [u32; 6] = [
    BINDING_SKIN_REST_POSITIONS,
    BINDING_SKIN_REST_NORMALS,
    BINDING_SKIN_REST_TANGENTS,
    BINDING_SKIN_JOINTS,
    BINDING_SKIN_WEIGHTS,
    BINDING_SKIN_DELTAS,
];

/// Rest data, per-frame inputs and output vertex buffer of one deformed geometry.
pub struct SkinningPass {
    pipeline: Arc<ComputePipeline>,
    set: DescriptorSet,
    // Rest data, uploaded once; kept alive for the descriptor set.
    _rest: [Buffer; 6],
    joint_matrices: Buffer,
    morph_weights: Buffer,
    /// Deformed positions (`vec3` per vertex, tightly packed).
    pub positions: Buffer,
    /// Deformed unit normals (`vec3` per vertex).
    pub normals: Buffer,
    /// Deformed tangents (`vec4` per vertex; a 16-byte placeholder without tangents).
    pub tangents: Buffer,
    count: u32,
    targets: u32,
    joint_count: u32,
    flags: u32,
}

/// A GPU-only buffer with `data`, or a 16-byte placeholder when `data` is empty (Vulkan has
/// no empty buffers).
fn upload<T: bytemuck::Pod>(ctx: &Context, name: &str, data: &[T]) -> VkResult<Buffer> {
    if data.is_empty() {
        return Buffer::from_slice(ctx, name, &[0u32; 4], vk::BufferUsageFlags::empty());
    }
    Buffer::from_slice(ctx, name, data, vk::BufferUsageFlags::empty())
}

fn output(ctx: &Context, name: &str, bytes: u64) -> VkResult<Buffer> {
    Buffer::new(
        ctx,
        name,
        bytes.max(16),
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )
}

impl SkinningPass {
    /// Uploads `g`'s rest vertices, skin influences and morph targets; `joint_count` is the
    /// size of the skin the geometry is bound to (0: not skinned).
    pub fn new(ctx: &Context, g: &Geometry, joint_count: usize) -> VkResult<Self> {
        let pipeline = ComputePipeline::cached(
            ctx,
            "skin",
            crate::shaders::SKIN_COMP,
            &bindings(
                &[
                    REST_BINDINGS.as_slice(),
                    &[
                        BINDING_SKIN_JOINT_MATRICES,
                        BINDING_SKIN_MORPH_WEIGHTS,
                        BINDING_SKIN_OUT_POSITIONS,
                        BINDING_SKIN_OUT_NORMALS,
                        BINDING_SKIN_OUT_TANGENTS,
                    ],
                ]
                .concat()
                .into_iter()
                .map(|b| (b, Binding::StorageBuffer))
                .collect::<Vec<_>>(),
            ),
            std::mem::size_of::<SkinPush>() as u32,
        )?;
        let n = g.positions.len();
        if g.normals.len() != n {
            return Err(VkError::Invalid(format!(
                "skinning: geometry has {} normals for {n} positions",
                g.normals.len()
            )));
        }
        let skinned = joint_count > 0 && g.joints.len() == n && g.weights.len() == n;
        let has_tangents = g.tangents.len() == n && n > 0;
        let targets = g.morph_targets.len();
        let mut deltas = vec![Vec3::ZERO; 3 * targets * n];
        for (k, t) in g.morph_targets.iter().enumerate() {
            for (a, attr) in [&t.positions, &t.normals, &t.tangents]
                .into_iter()
                .enumerate()
            {
                let start = (a * targets + k) * n;
                if attr.len() == n {
                    deltas[start..start + n].copy_from_slice(attr);
                }
            }
        }
        let flat = |v: &[Vec3]| -> Vec<f32> { v.iter().flat_map(|p| p.to_array()).collect() };
        let rest = [
            upload(ctx, "skin rest positions", &flat(&g.positions))?,
            upload(ctx, "skin rest normals", &flat(&g.normals))?,
            upload(
                ctx,
                "skin rest tangents",
                &g.tangents
                    .iter()
                    .flat_map(|t| t.to_array())
                    .collect::<Vec<f32>>(),
            )?,
            upload(
                ctx,
                "skin joints",
                &if skinned {
                    g.joints.concat()
                } else {
                    Vec::new()
                },
            )?,
            upload(
                ctx,
                "skin weights",
                &if skinned {
                    g.weights.concat()
                } else {
                    Vec::new()
                },
            )?,
            upload(ctx, "morph deltas", &flat(&deltas))?,
        ];
        let host = |name: &str, bytes: usize| {
            Buffer::new(
                ctx,
                name,
                (bytes as u64).max(16),
                vk::BufferUsageFlags::empty(),
                MemoryLocation::CpuToGpu,
            )
        };
        let joint_matrices = host("joint matrices", joint_count * 64)?;
        let morph_weights = host("morph weights", targets * 4)?;
        let positions = output(ctx, "skinned positions", n as u64 * 12)?;
        let normals = output(ctx, "skinned normals", n as u64 * 12)?;
        let tangents = output(
            ctx,
            "skinned tangents",
            if has_tangents { n as u64 * 16 } else { 0 },
        )?;
        let set = pipeline.allocate_set()?;
        for (binding, buffer) in REST_BINDINGS.into_iter().zip(&rest) {
            set.buffer(binding, buffer, Binding::StorageBuffer);
        }
        set.buffer(
            BINDING_SKIN_JOINT_MATRICES,
            &joint_matrices,
            Binding::StorageBuffer,
        )
        .buffer(
            BINDING_SKIN_MORPH_WEIGHTS,
            &morph_weights,
            Binding::StorageBuffer,
        )
        .buffer(
            BINDING_SKIN_OUT_POSITIONS,
            &positions,
            Binding::StorageBuffer,
        )
        .buffer(BINDING_SKIN_OUT_NORMALS, &normals, Binding::StorageBuffer)
        .buffer(BINDING_SKIN_OUT_TANGENTS, &tangents, Binding::StorageBuffer);
        Ok(Self {
            pipeline,
            set,
            _rest: rest,
            joint_matrices,
            morph_weights,
            positions,
            normals,
            tangents,
            count: n as u32,
            targets: targets as u32,
            joint_count: if skinned { joint_count as u32 } else { 0 },
            flags: (u32::from(skinned) * SKIN_SKINNED) | (u32::from(has_tangents) * SKIN_TANGENTS),
        })
    }

    /// Sets this frame's skinning matrices (ignored when not skinned) and morph weights;
    /// host writes, visible to the next submission.
    pub fn update(&mut self, joints: Option<&[Mat4]>, weights: &[f32]) -> VkResult<()> {
        if let Some(j) = joints.filter(|_| self.joint_count > 0) {
            let n = j.len().min(self.joint_count as usize);
            self.joint_matrices.write(bytemuck::cast_slice(&j[..n]))?;
        }
        let k = weights.len().min(self.targets as usize);
        if k > 0 {
            self.morph_weights
                .write(bytemuck::cast_slice(&weights[..k]))?;
        }
        Ok(())
    }

    /// Records the dispatch (a pass named [`PASS_NAME`] in `profiler`).
    pub fn record(&self, cmd: vk::CommandBuffer, profiler: Option<&mut GpuProfiler>) {
        let push = SkinPush {
            count: self.count,
            targets: self.targets,
            flags: self.flags,
            joint_count: self.joint_count,
        };
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, PASS_NAME);
        }
        self.pipeline.dispatch(
            cmd,
            Some(&self.set),
            push_bytes(&push),
            [self.count.div_ceil(64), 1, 1],
        );
        if let Some(p) = profiler {
            p.end(cmd);
        }
    }

    /// Reads the deformed vertices back (tests and tools).
    pub fn read(&self, ctx: &Context) -> VkResult<Deformed> {
        let n = self.count as usize;
        let vec3s = |b: &Buffer| -> VkResult<Vec<Vec3>> {
            let f: Vec<f32> = b.read(ctx)?;
            Ok(f.chunks_exact(3).take(n).map(Vec3::from_slice).collect())
        };
        let tangents = if self.flags & SKIN_TANGENTS != 0 {
            let f: Vec<f32> = self.tangents.read(ctx)?;
            f.chunks_exact(4).take(n).map(Vec4::from_slice).collect()
        } else {
            Vec::new()
        };
        Ok(Deformed {
            positions: vec3s(&self.positions)?,
            normals: vec3s(&self.normals)?,
            tangents,
        })
    }
}
