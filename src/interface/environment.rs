//! Image-based lighting: the environment's textures in the bindless array, and the push
//! constant of its preparation passes (`shaders/environment/`, `interface_environment.glsl`).

use bytemuck::{Pod, Zeroable};

/// Bindless texture `SceneRefs::environment + ENV_TEX_RADIANCE`: the map itself with an
/// area-weighted mip chain (background, mirror rays, and the preparation passes' input).
pub const ENV_TEX_RADIANCE: u32 = 0;
/// `+ ENV_TEX_SPECULAR`: GGX-prefiltered radiance, mip `m` at roughness `m / (ENV_SPECULAR_LEVELS - 1)`.
pub const ENV_TEX_SPECULAR: u32 = 1;
/// `+ ENV_TEX_IRRADIANCE`: cosine-weighted mean radiance (irradiance / π) per normal.
pub const ENV_TEX_IRRADIANCE: u32 = 2;
/// `+ ENV_TEX_BRDF`: the split-sum BRDF table, (scale, bias) of F0 by (n·v, roughness) in
/// `.rg`, and the sheen lobe's directional albedo by (n·v, sheen roughness) in `.b`.
pub const ENV_TEX_BRDF: u32 = 3;
/// `+ ENV_TEX_SAMPLING`: the importance-sampling CDFs (R32F, (width + 1) × (height + 1):
/// each row's conditional CDF, then the rows' marginal CDF; `environment::sampling`).
pub const ENV_TEX_SAMPLING: u32 = 4;
/// `+ ENV_TEX_SHEEN`: Charlie-prefiltered radiance for the sheen lobe, mip `m` at sheen
/// roughness `m / (ENV_SPECULAR_LEVELS - 1)` (`env_sheen.comp`).
pub const ENV_TEX_SHEEN: u32 = 5;
/// Textures an environment adds to the bindless array.
pub const ENV_TEXTURES: u32 = 6;

/// Mip levels of the prefiltered specular map (roughness 0, 0.25, 0.5, 0.75, 1).
pub const ENV_SPECULAR_LEVELS: u32 = 5;
/// Width of the prefiltered specular map's mip 0 (its height is half).
pub const ENV_SPECULAR_WIDTH: u32 = 256;
/// Width of the Charlie-prefiltered sheen map's mip 0 (its height is half): half the specular
/// map's, as the sheen lobe is broad at every roughness (a band at the horizon of n).
pub const ENV_SHEEN_WIDTH: u32 = 128;
/// Width of the irradiance map (its height is half).
pub const ENV_IRRADIANCE_WIDTH: u32 = 32;
/// Side of the BRDF table.
pub const ENV_BRDF_SIZE: u32 = 64;

/// Binding of the preparation passes' input: the radiance map (a combined image sampler).
pub const BINDING_ENV_SOURCE: u32 = 0;

/// Push constant of `env_specular.comp`, `env_sheen.comp`, `env_irradiance.comp`,
/// `env_brdf.comp`, and of the sampling table's `env_sampling_rows.comp` and
/// `env_sampling_marginal.comp` (which read `texels_out` as the table's address, one float per
/// entry, and `width` × `height` as the map's size).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct EnvPreparePush {
    /// Device address of the output, `vec4` per texel, row-major.
    pub texels_out: u64,
    /// Output width.
    pub width: u32,
    /// Output height.
    pub height: u32,
    /// GGX roughness of this level (specular pass), sheen roughness (sheen pass).
    pub roughness: f32,
    /// Samples per output texel (specular, sheen and BRDF passes).
    pub samples: u32,
    /// Width of the source map's mip 0.
    pub source_width: u32,
    /// Mip levels of the source map.
    pub source_levels: u32,
    /// Source mip level the irradiance pass integrates over, texel by texel.
    pub source_level: u32,
    /// Padding.
    pub pad0: u32,
}

/// `shaders/test/env_sampling.comp` mode: draw directions (`u`, direction, pdf, pdf again,
/// and the direction's map coordinates).
pub const ENV_TEST_SAMPLE: u32 = 0;
/// `shaders/test/env_sampling.comp` mode: estimates of the irradiance at +Y, one per
/// invocation, from `samples` samples of `strategy`.
pub const ENV_TEST_IRRADIANCE: u32 = 1;
/// Irradiance estimator: cosine-weighted hemisphere sampling.
pub const ENV_STRATEGY_COSINE: u32 = 0;
/// Irradiance estimator: environment importance sampling.
pub const ENV_STRATEGY_ENVIRONMENT: u32 = 1;
/// Irradiance estimator: half of each, combined by the power heuristic.
pub const ENV_STRATEGY_MIS: u32 = 2;

/// Push constant of the sampling test shader (`shaders/test/env_sampling.comp`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct EnvSamplingTestPush {
    /// Device address of the output: 2 `vec4` per invocation (sample mode), 1 (irradiance).
    pub texels_out: u64,
    /// Invocations.
    pub count: u32,
    /// `ENV_TEST_*`.
    pub mode: u32,
    /// Samples per estimate (irradiance mode).
    pub samples: u32,
    /// `ENV_STRATEGY_*`.
    pub strategy: u32,
    /// Seed of the random numbers.
    pub seed: u32,
    /// Padding.
    pub pad0: u32,
}
