//! The tonemapping of `shaders/common/tonemap.glsl` on the host, for images assembled from
//! several GPU renders (a reference accumulated over batches of samples). Tested against the
//! GPU's output (`tests/render/distributed.rs`).

use crate::render::Tonemap;

fn aces(x: f32) -> f32 {
    // Narkowicz 2015 fit of the ACES filmic curve.
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

fn khronos_neutral(mut c: [f32; 3]) -> [f32; 3] {
    // Khronos PBR Neutral (2024), reference GLSL.
    const START_COMPRESSION: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let x = c[0].min(c[1]).min(c[2]);
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    c = c.map(|v| v - offset);
    let peak = c[0].max(c[1]).max(c[2]);
    if peak < START_COMPRESSION {
        return c;
    }
    let d = 1.0 - START_COMPRESSION;
    let new_peak = 1.0 - d * d / (peak + d - START_COMPRESSION);
    c = c.map(|v| v * new_peak / peak);
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.map(|v| v + (new_peak - v) * g)
}

fn srgb(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// RGBA8 (alpha 255) of linear colour `c` after 2^`exposure` and `op`, as the GPU writes it.
pub fn tonemap_rgba8(c: [f32; 3], op: Tonemap, exposure: f32) -> [u8; 4] {
    let scale = exposure.exp2();
    let mut c = c.map(|v| v.max(0.0) * scale);
    match op {
        Tonemap::None => {}
        Tonemap::Aces => c = c.map(aces),
        Tonemap::KhronosNeutral => c = khronos_neutral(c),
    }
    let b = c.map(|v| (srgb(v) * 255.0).round() as u8);
    [b[0], b[1], b[2], 255]
}
