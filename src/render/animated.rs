//! Animated frames: the one place where a posed scene becomes the renderer of its frame.
//!
//! Today [`frame_renderer`] uploads the posed scene and builds every acceleration structure
//! again (both backends, static geometry included). It is deliberately the only call the
//! frame loop makes per animated frame, so that a per-frame update (GPU skinning into the
//! scene's vertex buffer, hw BLAS refit with `ALLOW_UPDATE`, bvh refit, TLAS rebuild) can
//! replace it without touching the callers.

use crate::accel::bvh::BvhBuild;
use crate::accel::Backend;
use crate::scene::Scene;
use crate::vk::Context;

use super::Renderer;

/// The renderer of one animated frame, from the scene posed at that frame
/// ([`Scene::posed`]).
pub fn frame_renderer(
    ctx: &Context,
    posed: &Scene,
    backend: Backend,
    bvh_build: BvhBuild,
) -> crate::Result<Renderer> {
    Renderer::with_bvh_build(ctx, posed, backend, bvh_build)
}
