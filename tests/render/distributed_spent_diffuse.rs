//! The distributed model's two estimators of a diffuse lobe whose bounces are spent: light
//! sampling alone, with the continuation drawn from the other lobes (the default in scenes
//! without emissive triangles), against the diffuse ray that only collects light
//! (`RenderSettings::trace_spent_diffuse`, and every scene with emissive triangles). They
//! converge to one image, the cheaper one makes no fireflies, and the ray counts tell them apart.

use crate::support;

use super::distributed::{lambert, render, soft_cornell, spheres_on_a_floor};

use glam::{Vec3, Vec4};
use rqr::accel::Backend;
use rqr::environment::EnvironmentMap;
use rqr::render::{RenderOutput, RenderSettings, SamplerKind, Shading};
use rqr::scene::procedural::look_at;
use rqr::scene::{Camera, Material, Scene};

const SIZE: u32 = 32;
/// Side of the square blocks whose means are compared.
const BLOCK: usize = 8;

fn settings(spp: u32, seed: u32, traced: bool) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp,
        sampler: SamplerKind::Sobol,
        shading: Shading::Distributed,
        max_depth: 3,
        seed,
        trace_spent_diffuse: traced,
        ..Default::default()
    }
}

fn luminance(c: &[f32; 4]) -> f64 {
    0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2])
}

/// Per-channel means of the BLOCK² blocks, row by row.
fn block_means(out: &RenderOutput) -> Vec<[f64; 3]> {
    let side = SIZE as usize / BLOCK;
    let mut sums = vec![[0.0; 3]; side * side];
    for (i, c) in out.color.iter().enumerate() {
        let (x, y) = (i % SIZE as usize, i / SIZE as usize);
        let b = &mut sums[(y / BLOCK) * side + x / BLOCK];
        for k in 0..3 {
            b[k] += f64::from(c[k]) / (BLOCK * BLOCK) as f64;
        }
    }
    sums
}

/// The largest difference of a block's channel mean between `a` and `b`, relative to
/// `b`'s (plus 0.01, so that dark blocks count in absolute terms).
fn worst_block_error(a: &RenderOutput, b: &RenderOutput) -> f64 {
    block_means(a)
        .iter()
        .zip(&block_means(b))
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs() / (y[k] + 0.01)))
        .fold(0.0, f64::max)
}

/// Luminance errors against `reference` on the pixels of surfaces (reference luminance at
/// most 1; the lights seen directly are far brighter and noisy in either estimator): (RMSE,
/// 99.9th percentile, largest).
fn errors(out: &RenderOutput, reference: &RenderOutput) -> (f64, f64, f64) {
    let mut e: Vec<f64> = out
        .color
        .iter()
        .zip(&reference.color)
        .filter(|(_, b)| luminance(b) <= 1.0)
        .map(|(a, b)| (luminance(a) - luminance(b)).abs())
        .collect();
    let rmse = (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
    e.sort_by(f64::total_cmp);
    let p999 = e[(e.len() * 999 / 1000).min(e.len() - 1)];
    (rmse, p999, *e.last().unwrap())
}

/// Checks that light sampling alone converges to the traced diffuse ray's image on `scene`
/// (block means at 256 spp against a 1024-spp image of the traced estimator, no further from
/// it than an independent 256-spp traced image, with some slack), and that at 4 spp its
/// error's tail (99.9th percentile, largest pixel) is no heavier than the traced estimator's.
fn check_converges_without_fireflies(
    name: &str,
    scene: &Scene,
    camera: &Camera,
    env: Option<&EnvironmentMap>,
) {
    let ctx = support::gpu();
    let run = |spp, seed, traced| {
        render(
            &ctx,
            scene,
            camera,
            env,
            Backend::Bvh,
            false,
            &settings(spp, seed, traced),
        )
    };
    let reference = run(1024, 1000, true);
    assert!(
        reference.rays.diffuse > 0,
        "{name}: the traced estimator traced no diffuse ray: {:?}",
        reference.rays
    );
    let light_sampled = run(256, 7, false);
    assert_eq!(
        light_sampled.rays.diffuse, 0,
        "{name}: light sampling alone traced diffuse rays"
    );
    let traced = run(256, 7, true);
    let (new_bias, old_bias) = (
        worst_block_error(&light_sampled, &reference),
        worst_block_error(&traced, &reference),
    );
    eprintln!(
        "{name}: mean luminance {:.5} (light sampled) / {:.5} (traced) against {:.5}; worst block {new_bias:.4} / {old_bias:.4}",
        mean_luminance(&light_sampled),
        mean_luminance(&traced),
        mean_luminance(&reference)
    );
    assert!(
        (mean_luminance(&light_sampled) - mean_luminance(&reference)).abs()
            <= 0.01 * mean_luminance(&reference),
        "{name}: mean {} against {}",
        mean_luminance(&light_sampled),
        mean_luminance(&reference)
    );
    assert!(
        new_bias <= old_bias.max(0.01) * 1.5,
        "{name}: a block differs by {new_bias} (the traced estimator's worst: {old_bias})"
    );
    check_no_fireflies(
        name,
        &reference,
        &run(4, 3, false),
        &reference,
        &run(4, 3, true),
    );
    support::assert_validation_clean(&ctx);
}

fn mean_luminance(o: &RenderOutput) -> f64 {
    o.color.iter().map(luminance).sum::<f64>() / o.color.len() as f64
}

/// At 4 spp, light sampling alone (`new` against `new_reference`) has an error no larger, in
/// RMSE and in its tail (99.9th percentile, largest pixel), than the traced diffuse ray (`old`
/// against `old_reference`), with some slack: fireflies would multiply the tail.
fn check_no_fireflies(
    name: &str,
    new_reference: &RenderOutput,
    new: &RenderOutput,
    old_reference: &RenderOutput,
    old: &RenderOutput,
) {
    let (new_e, old_e) = (errors(new, new_reference), errors(old, old_reference));
    eprintln!(
        "{name}, 4 spp: luminance error RMSE / p99.9 / max {:.4} / {:.4} / {:.4} (light sampled) against {:.4} / {:.4} / {:.4} (traced)",
        new_e.0, new_e.1, new_e.2, old_e.0, old_e.1, old_e.2
    );
    assert!(
        new_e.0 <= 1.25 * old_e.0,
        "{name}: RMSE {} against {}",
        new_e.0,
        old_e.0
    );
    assert!(
        new_e.1 <= 1.5 * old_e.1 && new_e.2 <= 1.5 * old_e.2,
        "{name}: fireflies: p99.9 {} / max {} against {} / {}",
        new_e.1,
        new_e.2,
        old_e.1,
        old_e.2
    );
}

#[test]
fn light_sampled_diffuse_converges_to_the_traced_ray_in_a_room() {
    // Sphere lights, Lambert walls and box, a mirror and glass, and the background seen
    // through the open front (the light the cosine lobes' shadow ray finds). The diffuse
    // surfaces have no glossy lobe: where one surface has both, the traced estimator's glossy
    // draws also carried its diffuse lobe's indirect light (f / the whole mixture's density),
    // which no longer counts once diffuse inter-reflection is off for every draw.
    let mut scene = soft_cornell(0.2);
    for m in &mut scene.materials {
        if m.metallic == 0.0 && m.transmission == 0.0 {
            let albedo = m.base_color;
            *m = Material {
                base_color: albedo,
                ..lambert(1.0)
            };
        }
    }
    check_converges_without_fireflies("room", &scene, &scene.cameras[0], None);
}

#[test]
fn light_sampled_diffuse_converges_to_the_traced_ray_under_an_environment() {
    // Glossy plastic (diffuse and GGX lobes, MIS on the glossy one) and Lambert spheres on a
    // floor under sunrise.hdr.
    let map = rqr::environment::map::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/environments/sunrise.hdr"
    )))
    .unwrap()
    .0;
    let scene = spheres_on_a_floor(Material {
        base_color: Vec4::new(0.8, 0.3, 0.2, 1.0),
        metallic: 0.0,
        roughness: 0.3,
        ..Default::default()
    });
    let camera = look_at(Vec3::new(0.0, 1.5, 4.0), Vec3::new(0.0, 0.5, 0.0), 40.0);
    check_converges_without_fireflies("sunrise", &scene, &camera, Some(&map));
}

#[test]
fn emissive_triangles_keep_the_traced_diffuse_ray() {
    // Only a ray that meets an emissive triangle finds its light: such a scene traces the
    // spent diffuse lobe whatever the settings ask.
    let ctx = support::gpu();
    let mut scene = soft_cornell(0.2);
    let camera = scene.cameras[0];
    let plain = render(
        &ctx,
        &scene,
        &camera,
        None,
        Backend::Bvh,
        false,
        &settings(1, 0, false),
    );
    assert_eq!(plain.rays.diffuse, 0, "{:?}", plain.rays);
    scene.materials.push(Material {
        emissive: Vec3::splat(2.0),
        ..lambert(0.5)
    });
    scene.geometries[0].material = scene.materials.len() as u32 - 1;
    let emissive = render(
        &ctx,
        &scene,
        &camera,
        None,
        Backend::Bvh,
        false,
        &settings(1, 0, false),
    );
    assert!(emissive.rays.diffuse > 0, "{:?}", emissive.rays);
}

#[test]
fn light_sampled_diffuse_makes_no_fireflies_on_glossy_walls() {
    // Walls with a diffuse and a GGX lobe: the continuation is drawn from the GGX lobe alone
    // and carries only its part of the BSDF (the diffuse part over that density made
    // fireflies). Each estimator against its own converged image: here they differ by the
    // diffuse lobe's indirect light the traced estimator's glossy draws carried.
    let ctx = support::gpu();
    let scene = soft_cornell(0.2);
    let camera = scene.cameras[0];
    let run = |spp, seed, traced| {
        render(
            &ctx,
            &scene,
            &camera,
            None,
            Backend::Bvh,
            false,
            &settings(spp, seed, traced),
        )
    };
    let (new_reference, old_reference) = (run(1024, 1000, false), run(1024, 1000, true));
    eprintln!(
        "glossy room: mean luminance {:.5} (light sampled) against {:.5} (traced); worst block {:.4}",
        mean_luminance(&new_reference),
        mean_luminance(&old_reference),
        worst_block_error(&new_reference, &old_reference)
    );
    check_no_fireflies(
        "glossy room",
        &new_reference,
        &run(4, 3, false),
        &old_reference,
        &run(4, 3, true),
    );
    support::assert_validation_clean(&ctx);
}
