//! The `Frame` uniform ([`GpuFrame`], shared with `shaders/common/frame.glsl` through
//! [`crate::interface`]) and the camera matrices it is filled from ([`CameraSetup`]).

use glam::{Mat4, Vec4};

use crate::scene::{Camera, Projection};

// Settings as `targets.rs` imports them from here (until it moves).
pub use super::settings::RenderPath;
pub(crate) use super::settings::{FilterKind, RenderSettings};

pub use crate::interface::{
    GpuFrame, FLAG_ADAPTIVE_CORNERS, FLAG_DIFFUSE_LIGHT_SAMPLED, FLAG_ENV_BACKGROUND,
    FLAG_NO_SPECULAR, FLAG_SKY, FLAG_WRITE_AOV,
};

/// What the frame uniform needs to know of the scene it renders.
#[derive(Clone, Copy, Debug)]
pub struct SceneTraits {
    /// Diagonal of the scene bounds (ray offsets).
    pub scale: f32,
    /// Whether an instanced triangle emits ([`crate::scene::gpu::GpuScene::emissive_geometry`]).
    pub emissive_geometry: bool,
}

/// Near plane used when the camera has none that fits.
const DEFAULT_ZNEAR: f32 = 0.01;

/// Camera matrices for a render of `width`×`height`.
#[derive(Clone, Copy, Debug)]
pub struct CameraSetup {
    /// Camera to world.
    pub camera_to_world: Mat4,
    /// Projection (Vulkan clip space, y down, depth 0..1).
    pub proj: Mat4,
    /// tan(yfov/2) (perspective).
    pub tan_half_fov_y: f32,
    /// Orthographic half extents, if orthographic.
    pub ortho_half: Option<[f32; 2]>,
}

impl CameraSetup {
    /// Builds the matrices. The render's aspect ratio always wins over the file's; an
    /// orthographic camera keeps its ymag and derives xmag from the aspect.
    pub fn new(camera: &Camera, width: u32, height: u32, scene_scale: f32) -> Self {
        let aspect = width as f32 / height as f32;
        match camera.projection {
            Projection::Perspective {
                yfov, znear, zfar, ..
            } => {
                let t = (yfov * 0.5).tan();
                let zn = if znear > 0.0 { znear } else { DEFAULT_ZNEAR };
                let zf = zfar.unwrap_or(scene_scale.max(1.0) * 100.0).max(zn * 2.0);
                let proj = Mat4::from_cols(
                    Vec4::new(1.0 / (aspect * t), 0.0, 0.0, 0.0),
                    Vec4::new(0.0, -1.0 / t, 0.0, 0.0),
                    Vec4::new(0.0, 0.0, zf / (zn - zf), -1.0),
                    Vec4::new(0.0, 0.0, zn * zf / (zn - zf), 0.0),
                );
                Self {
                    camera_to_world: camera.camera_to_world,
                    proj,
                    tan_half_fov_y: t,
                    ortho_half: None,
                }
            }
            Projection::Orthographic {
                ymag, znear, zfar, ..
            } => {
                let half = [ymag * aspect, ymag];
                let (zn, zf) = (znear, zfar.max(znear + 1e-3));
                let proj = Mat4::from_cols(
                    Vec4::new(1.0 / half[0], 0.0, 0.0, 0.0),
                    Vec4::new(0.0, -1.0 / half[1], 0.0, 0.0),
                    Vec4::new(0.0, 0.0, 1.0 / (zn - zf), 0.0),
                    Vec4::new(0.0, 0.0, zn / (zn - zf), 1.0),
                );
                Self {
                    camera_to_world: camera.camera_to_world,
                    proj,
                    tan_half_fov_y: 1.0,
                    ortho_half: Some(half),
                }
            }
        }
    }

    /// World to camera.
    pub fn view(&self) -> Mat4 {
        self.camera_to_world.inverse()
    }
}

impl GpuFrame {
    /// Fills the uniform for `settings` seen through `camera`, in a scene of `scene`'s traits.
    pub fn new(settings: &RenderSettings, camera: &CameraSetup, scene: SceneTraits) -> Self {
        let scene_scale = scene.scale;
        let view = camera.view();
        let mut flags = 0;
        // Without emissive triangles every emitter is light-sampled, so a diffuse lobe with no
        // bounces left needs no ray of its own (unless the settings ask for one).
        if !scene.emissive_geometry && !settings.trace_spent_diffuse {
            flags |= FLAG_DIFFUSE_LIGHT_SAMPLED;
        }
        if settings.no_specular {
            flags |= FLAG_NO_SPECULAR;
        }
        if settings.sky {
            flags |= FLAG_SKY;
        }
        if settings.environment_background {
            flags |= FLAG_ENV_BACKGROUND;
        }
        if settings.denoise.enabled() && settings.sampler.sequence_indexed() {
            flags |= crate::interface::FLAG_SEQUENCE_JITTER;
        }
        let rotation = settings.environment_rotation.to_radians();
        Self {
            camera_to_world: camera.camera_to_world.to_cols_array(),
            view: view.to_cols_array(),
            proj: camera.proj.to_cols_array(),
            view_proj: (camera.proj * view).to_cols_array(),
            prev_view_proj: (camera.proj * view).to_cols_array(),
            jitter: [0.0; 2],
            env_rotation: [rotation.cos(), rotation.sin()],
            camera_pos: camera.camera_to_world.w_axis.truncate().to_array(),
            tan_half_fov_y: camera.tan_half_fov_y,
            aspect: settings.width as f32 / settings.height as f32,
            ortho: u32::from(camera.ortho_half.is_some()),
            ortho_half: camera.ortho_half.unwrap_or([1.0, 1.0]),
            width: settings.width,
            height: settings.height,
            spp: settings.spp,
            sampler_kind: settings.sampler.code(),
            filter_kind: settings.filter.code(),
            max_depth: settings.max_depth,
            flags,
            seed: settings.seed,
            min_weight: settings.min_weight,
            epsilon: settings.epsilon.unwrap_or(scene_scale * 1e-4),
            adaptive_threshold: settings.adaptive_threshold,
            adaptive_depth: settings.adaptive_depth,
            ambient: settings.ambient.to_array(),
            pixel_spread: if camera.ortho_half.is_some() {
                0.0
            } else {
                (2.0 * camera.tan_half_fov_y / settings.height as f32).atan()
            },
            background: settings.background.to_array(),
            env_intensity: settings.environment_intensity,
            sample_base: 0,
            diffuse_bounces: settings.diffuse_bounces,
        }
    }
}
