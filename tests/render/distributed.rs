//! The distributed shading model against closed-form expectations and against itself, on every
//! backend the device has and both paths: punctual lights keep the Whitted model's hard
//! shadows, a sphere light's penumbra follows the visible fraction of its disc, estimates
//! converge at the Monte Carlo rate to a converged reference, furnaces keep their energy, the
//! hybrid path equals the ray-traced one at equal samples and seed, and a seed fixes the image.

use crate::support;

use glam::{Mat4, Vec3, Vec4};
use rqr::accel::Backend;
use rqr::environment::{EnvironmentMap, GpuEnvironment};
use rqr::render::image::metrics;
use rqr::render::passes::draw_list;
use rqr::render::{RenderOutput, RenderSettings, Renderer, SamplerKind, Shading};
use rqr::scene::procedural::{assemble, cornell, look_at, quad, sphere};
use rqr::scene::{Camera, Instance, Light, LightKind, Material, MaterialLayers, Scene};
use rqr::vk::Context;

pub(super) fn backends(ctx: &Context) -> Vec<Backend> {
    let mut b = vec![Backend::Bvh];
    if ctx.features().ray_query {
        b.push(Backend::Hw);
    }
    b
}

/// Renders `scene` through `camera` on `backend`, ray traced or hybrid, under `env` if any.
pub(super) fn render(
    ctx: &Context,
    scene: &Scene,
    camera: &Camera,
    env: Option<&EnvironmentMap>,
    backend: Backend,
    hybrid: bool,
    settings: &RenderSettings,
) -> RenderOutput {
    let mut renderer = Renderer::new(ctx, scene, backend).unwrap();
    if let Some(map) = env {
        let prepared = GpuEnvironment::prepare(ctx, map).unwrap();
        renderer.set_environment(ctx, Some(prepared)).unwrap();
    }
    if hybrid {
        renderer
            .render_hybrid(ctx, &draw_list::draws(scene), settings, camera, true)
            .unwrap()
    } else {
        renderer.render_rt(ctx, settings, camera, true).unwrap()
    }
}

/// Lambert only (KHR_materials_specular with factor 0): no specular lobe to blur a profile.
pub(super) fn lambert(albedo: f32) -> Material {
    Material {
        base_color: Vec4::new(albedo, albedo, albedo, 1.0),
        metallic: 0.0,
        roughness: 1.0,
        layers: Some(Box::new(MaterialLayers {
            specular: 0.0,
            ..Default::default()
        })),
        ..Default::default()
    }
}

// The penumbra scene: a white Lambert floor (y = 0), an occluding half-plane at height
// EDGE_H covering x < 0, a sphere light of radius LIGHT_R centred at (LIGHT_X, LIGHT_D, 0),
// and a camera looking straight down at the penumbra around x = 0.75.
const EDGE_H: f32 = 1.0;
const LIGHT_D: f32 = 3.0;
const LIGHT_X: f32 = -1.5;
const LIGHT_R: f32 = 0.25;
const PENUMBRA_EYE_X: f32 = 0.75;
const PENUMBRA_EYE_H: f32 = 6.0;
const PENUMBRA_FOV: f32 = 3.0;
const PENUMBRA_WIDTH: u32 = 64;
const PENUMBRA_HEIGHT: u32 = 16;

/// World x of the floor under the centre of pixel column `column` (the camera looks straight
/// down, image right = +X).
fn column_x(column: usize) -> f64 {
    let ndc = (column as f64 + 0.5) / f64::from(PENUMBRA_WIDTH) * 2.0 - 1.0;
    let half = (f64::from(PENUMBRA_FOV).to_radians() / 2.0).tan() * f64::from(PENUMBRA_EYE_H);
    f64::from(PENUMBRA_EYE_X) + ndc * half * f64::from(PENUMBRA_WIDTH) / f64::from(PENUMBRA_HEIGHT)
}

fn penumbra_scene(occluder: bool, radius: f32) -> (Scene, Camera) {
    let mut instances = vec![Instance {
        geometry: 0,
        transform: Mat4::from_scale(Vec3::new(20.0, 1.0, 20.0)),
        node: 0,
    }];
    if occluder {
        instances.push(Instance {
            geometry: 1,
            transform: Mat4::from_translation(Vec3::new(-5.0, EDGE_H, 0.0))
                * Mat4::from_scale(Vec3::new(10.0, 1.0, 20.0)),
            node: 1,
        });
    }
    let scene = assemble(
        vec![quad(0), quad(1)],
        instances,
        vec![lambert(0.8), lambert(0.0)],
        vec![Light {
            kind: LightKind::Point,
            color: Vec3::ONE,
            intensity: 20.0,
            range: f32::INFINITY,
            position: Vec3::new(LIGHT_X, LIGHT_D, 0.0),
            direction: -Vec3::Y,
            size: radius,
        }],
        vec![],
    );
    let camera = look_at(
        Vec3::new(PENUMBRA_EYE_X, PENUMBRA_EYE_H, 0.0),
        Vec3::new(PENUMBRA_EYE_X, 0.0, 0.0),
        PENUMBRA_FOV,
    );
    (scene, camera)
}

fn penumbra_settings(shading: Shading, spp: u32) -> RenderSettings {
    RenderSettings {
        width: PENUMBRA_WIDTH,
        height: PENUMBRA_HEIGHT,
        spp,
        sampler: if spp > 1 {
            SamplerKind::Sobol
        } else {
            SamplerKind::Center
        },
        shading,
        ambient: Vec3::ZERO,
        background: Vec3::ZERO,
        max_depth: 2,
        ..Default::default()
    }
}

/// The fraction of the sphere light's irradiance that reaches floor point (x, 0, 0) past the
/// occluder's edge: the sphere's cap of directions, integrated by solid angle with the floor's
/// cosine, each direction blocked when it crosses height EDGE_H at x < 0. (For a small light
/// this is the circular-segment area of its disc cut by the plane through the point and the
/// edge, so the penumbra is 2R·h/(D − h) wide.)
fn visible_fraction(x: f64) -> f64 {
    let (h, d, c, r) = (
        f64::from(EDGE_H),
        f64::from(LIGHT_D),
        f64::from(LIGHT_X),
        f64::from(LIGHT_R),
    );
    let to_light = glam::DVec3::new(c - x, d, 0.0);
    let dist = to_light.length();
    let axis = to_light / dist;
    let cos_max = (1.0 - (r / dist).powi(2)).sqrt();
    let helper = if axis.x.abs() < 0.9 {
        glam::DVec3::X
    } else {
        glam::DVec3::Y
    };
    let t = axis.cross(helper).normalize();
    let b = axis.cross(t);
    let (n_theta, n_phi) = (200, 200);
    let (mut lit, mut total) = (0.0, 0.0);
    for i in 0..n_theta {
        let cos_t = 1.0 - (f64::from(i) + 0.5) / f64::from(n_theta) * (1.0 - cos_max);
        let sin_t = (1.0 - cos_t * cos_t).sqrt();
        for j in 0..n_phi {
            let phi = (f64::from(j) + 0.5) / f64::from(n_phi) * std::f64::consts::TAU;
            let w = axis * cos_t + (t * phi.cos() + b * phi.sin()) * sin_t;
            let cosine = w.y.max(0.0);
            total += cosine;
            if x + w.x * (h / w.y) >= 0.0 {
                lit += cosine;
            }
        }
    }
    lit / total
}

fn floor_pixels(out: &RenderOutput) -> Vec<(usize, f64)> {
    (0..out.color.len())
        .filter(|&i| out.aov[i].hit() && out.aov[i].instance() == 0)
        .map(|i| (i, f64::from(out.aov[i].world_position().x)))
        .collect()
}

#[test]
fn punctual_lights_keep_the_whitted_hard_shadow() {
    let ctx = support::gpu();
    let (scene, camera) = penumbra_scene(true, 0.0);
    for backend in backends(&ctx) {
        for hybrid in [false, true] {
            let label = format!("{} hybrid={hybrid}", backend.as_str());
            let whitted = render(
                &ctx,
                &scene,
                &camera,
                None,
                backend,
                hybrid,
                &penumbra_settings(Shading::Whitted, 1),
            );
            let distributed = render(
                &ctx,
                &scene,
                &camera,
                None,
                backend,
                hybrid,
                &penumbra_settings(Shading::Distributed, 1),
            );
            let lit = |c: &[f32; 4]| c[0] > 0.05;
            let mut shadowed = 0;
            for (i, _) in floor_pixels(&whitted) {
                let (w, d) = (&whitted.color[i], &distributed.color[i]);
                assert_eq!(lit(w), lit(d), "{label}: pixel {i}: {w:?} against {d:?}");
                assert!(
                    (w[0] - d[0]).abs() <= 1e-3 * w[0].max(1.0),
                    "{label}: pixel {i}"
                );
                shadowed += usize::from(!lit(w));
            }
            assert!(
                shadowed > 100 && shadowed < 900,
                "{label}: {shadowed} shadowed pixels"
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn sphere_light_penumbra_follows_the_visible_fraction_of_its_disc() {
    let ctx = support::gpu();
    let (occluded, camera) = penumbra_scene(true, LIGHT_R);
    let (open, _) = penumbra_scene(false, LIGHT_R);
    let settings = penumbra_settings(Shading::Distributed, 256);
    for backend in backends(&ctx) {
        for hybrid in [false, true] {
            let label = format!("{} hybrid={hybrid}", backend.as_str());
            let a = render(&ctx, &occluded, &camera, None, backend, hybrid, &settings);
            let b = render(&ctx, &open, &camera, None, backend, hybrid, &settings);
            // Per column: mean ratio over the rows, against the fraction at the column's x.
            let width = settings.width as usize;
            let mut columns = vec![(0.0f64, 0.0f64, 0u32); width];
            for (i, _) in floor_pixels(&a) {
                let x = column_x(i % width);
                let unshadowed = f64::from(b.color[i][0]);
                assert!(
                    unshadowed > 0.05,
                    "{label}: pixel {i} unlit without the occluder"
                );
                let c = &mut columns[i % width];
                c.0 += f64::from(a.color[i][0]) / unshadowed;
                c.1 += x;
                c.2 += 1;
            }
            let mut penumbra = 0;
            let mut worst: f64 = 0.0;
            let mut failures = Vec::new();
            for (ratio, x, n) in columns.into_iter().filter(|c| c.2 > 0) {
                let (ratio, x) = (ratio / f64::from(n), x / f64::from(n));
                let expected = visible_fraction(x);
                penumbra += usize::from(expected > 0.05 && expected < 0.95);
                worst = worst.max((ratio - expected).abs());
                eprintln!("{label}: x {x:.3}: {ratio:.4} expected {expected:.4}");
                if (ratio - expected).abs() > 0.03 {
                    failures.push(format!("x {x:.3}: {ratio:.4} of the unshadowed level, the disc's visible fraction is {expected:.4}"));
                }
            }
            assert!(failures.is_empty(), "{label}: {failures:#?}");
            eprintln!("{label}: {penumbra} penumbra columns, worst deviation {worst:.4}");
            assert!(
                penumbra >= 8,
                "{label}: only {penumbra} columns in the penumbra"
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

/// A unit sphere of `material` at the origin seen from +Z, no lights.
fn sphere_scene(material: Material) -> (Scene, Camera) {
    let camera = look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 40.0);
    let scene = assemble(
        vec![sphere(0, 96, 48)],
        vec![Instance {
            geometry: 0,
            transform: Mat4::IDENTITY,
            node: 0,
        }],
        vec![material],
        vec![],
        vec![camera],
    );
    (scene, camera)
}

fn furnace_settings() -> RenderSettings {
    RenderSettings {
        width: 32,
        height: 32,
        spp: 64,
        sampler: SamplerKind::Sobol,
        shading: Shading::Distributed,
        ..Default::default()
    }
}

#[test]
fn furnace_lambert_sphere_shows_its_albedo() {
    let ctx = support::gpu();
    let albedo = 0.7;
    let (scene, camera) = sphere_scene(lambert(albedo));
    let map = EnvironmentMap::constant(64, [1.0; 3]);
    for backend in backends(&ctx) {
        for hybrid in [false, true] {
            let out = render(
                &ctx,
                &scene,
                &camera,
                Some(&map),
                backend,
                hybrid,
                &furnace_settings(),
            );
            let hits: Vec<f64> = (0..out.color.len())
                .filter(|&i| out.aov[i].hit())
                .map(|i| f64::from(out.color[i][0]))
                .collect();
            assert!(hits.len() > 200, "{} hits", hits.len());
            let mean = hits.iter().sum::<f64>() / hits.len() as f64;
            assert!(
                (mean - f64::from(albedo)).abs() <= 0.02 * f64::from(albedo),
                "{} hybrid={hybrid}: mean {mean} against {albedo}",
                backend.as_str()
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn furnace_rough_metal_reflects_its_single_scattering_albedo() {
    let ctx = support::gpu();
    let roughness = 0.5;
    let (scene, camera) = sphere_scene(Material {
        base_color: Vec4::ONE,
        metallic: 1.0,
        roughness,
        ..Default::default()
    });
    let map = EnvironmentMap::constant(64, [1.0; 3]);
    // E(μ) on a table of μ, interpolated per pixel.
    let table: Vec<f64> = (0..=32)
        .map(|k| support::optics::ggx_albedo((f64::from(k) / 32.0).max(0.02), f64::from(roughness)))
        .collect();
    let albedo_at = |mu: f64| {
        let x = mu.clamp(0.0, 1.0) * 32.0;
        let k = (x.floor() as usize).min(31);
        table[k] + (table[k + 1] - table[k]) * (x - k as f64)
    };
    let eye = Vec3::new(0.0, 0.0, 4.0);
    for backend in backends(&ctx) {
        for hybrid in [false, true] {
            let out = render(
                &ctx,
                &scene,
                &camera,
                Some(&map),
                backend,
                hybrid,
                &furnace_settings(),
            );
            let (mut sum, mut expected, mut n) = (0.0, 0.0, 0);
            for (i, c) in out.color.iter().enumerate() {
                let a = &out.aov[i];
                if !a.hit() {
                    continue;
                }
                let p = a.world_position();
                let mu = f64::from(p.normalize().dot((eye - p).normalize()));
                sum += f64::from(c[0]);
                expected += albedo_at(mu);
                n += 1;
            }
            let (mean, expected) = (sum / f64::from(n), expected / f64::from(n));
            assert!(
                (mean - expected).abs() <= 0.02 * expected,
                "{} hybrid={hybrid}: mean {mean} against E = {expected}",
                backend.as_str()
            );
        }
    }
}

/// The built-in room with sphere lights.
pub(super) fn soft_cornell(radius: f32) -> Scene {
    let mut scene = cornell();
    for l in &mut scene.lights {
        l.size = radius;
    }
    scene
}

#[test]
fn hybrid_equals_ray_traced_at_equal_samples_and_seed() {
    let ctx = support::gpu();
    let scene = soft_cornell(0.2);
    let camera = scene.cameras[0];
    let settings = RenderSettings {
        width: 64,
        height: 64,
        spp: 4,
        sampler: SamplerKind::Sobol,
        shading: Shading::Distributed,
        seed: 3,
        ..Default::default()
    };
    for backend in backends(&ctx) {
        let rt = render(&ctx, &scene, &camera, None, backend, false, &settings);
        let hybrid = render(&ctx, &scene, &camera, None, backend, true, &settings);
        let d = metrics::compare(64, 64, &rt.rgba8, &hybrid.rgba8);
        eprintln!(
            "{}: hybrid against rt: FLIP mean {:.5}, PSNR {:.2} dB",
            backend.as_str(),
            d.flip_mean,
            d.psnr_db
        );
        assert!(d.flip_mean <= 0.01, "FLIP {}", d.flip_mean);
        assert!(d.psnr_db >= 40.0, "PSNR {}", d.psnr_db);
        assert!(
            rt.rays.shadow > 0 && rt.rays.reflection > 0,
            "{:?}",
            rt.rays
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn a_seed_fixes_the_image_and_another_seed_changes_it() {
    let ctx = support::gpu();
    let scene = soft_cornell(0.2);
    let camera = scene.cameras[0];
    let mut settings = RenderSettings {
        width: 32,
        height: 32,
        spp: 2,
        sampler: SamplerKind::Sobol,
        shading: Shading::Distributed,
        diffuse_bounces: 2,
        seed: 11,
        ..Default::default()
    };
    let a = render(&ctx, &scene, &camera, None, Backend::Bvh, false, &settings);
    let b = render(&ctx, &scene, &camera, None, Backend::Bvh, false, &settings);
    assert_eq!(a.color, b.color, "two runs with one seed differ");
    assert!(
        a.rays.diffuse > 0,
        "diffuse bounces traced no diffuse ray: {:?}",
        a.rays
    );
    settings.seed = 12;
    let c = render(&ctx, &scene, &camera, None, Backend::Bvh, false, &settings);
    assert_ne!(a.color, c.color, "another seed gave the same image");
}

/// Root-mean-square difference of the red channels of `a` and `b`.
fn rmse(a: &RenderOutput, b: &RenderOutput) -> f64 {
    let sum: f64 = a
        .color
        .iter()
        .zip(&b.color)
        .map(|(x, y)| (f64::from(x[0]) - f64::from(y[0])).powi(2))
        .sum();
    (sum / a.color.len() as f64).sqrt()
}

/// The log-log slope of RMSE against a 4096-spp reference, between 4 and 256 spp.
fn convergence_slope(
    ctx: &Context,
    scene: &Scene,
    camera: &Camera,
    env: Option<&EnvironmentMap>,
    label: &str,
) -> f64 {
    let settings = |spp: u32, seed: u32| RenderSettings {
        width: 16,
        height: 16,
        spp,
        sampler: SamplerKind::Sobol,
        shading: Shading::Distributed,
        max_depth: 4,
        ambient: Vec3::ZERO,
        seed,
        ..Default::default()
    };
    let reference = render(
        ctx,
        scene,
        camera,
        env,
        Backend::Bvh,
        false,
        &settings(4096, 1000),
    );
    let points: Vec<(f64, f64)> = [4u32, 16, 64, 256]
        .iter()
        .map(|&spp| {
            let out = render(
                ctx,
                scene,
                camera,
                env,
                Backend::Bvh,
                false,
                &settings(spp, 7),
            );
            let mean = |o: &RenderOutput| {
                o.color.iter().map(|c| f64::from(c[0])).sum::<f64>() / o.color.len() as f64
            };
            let worst = out
                .color
                .iter()
                .zip(&reference.color)
                .enumerate()
                .map(|(i, (a, b))| ((a[0] - b[0]).abs(), i, a[0], b[0]))
                .fold((0.0f32, 0, 0.0, 0.0), |m, x| if x.0 > m.0 { x } else { m });
            eprintln!(
                "{label} {spp}: mean {} against {}, worst {worst:?}",
                mean(&out),
                mean(&reference)
            );
            (f64::from(spp).ln(), rmse(&out, &reference).ln())
        })
        .collect();
    let n = points.len() as f64;
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let slope = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / points.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    eprintln!("{label}: log RMSE by log spp {points:?}: slope {slope:.3}");
    slope
}

#[test]
fn estimates_converge_at_the_monte_carlo_rate() {
    let ctx = support::gpu();
    // A sphere light's penumbra.
    let (scene, _) = penumbra_scene(true, LIGHT_R);
    let camera = look_at(Vec3::new(0.75, 6.0, 0.0), Vec3::new(0.75, 0.0, 0.0), 12.0);
    let slope = convergence_slope(&ctx, &scene, &camera, None, "sphere light");
    assert!((slope + 0.5).abs() <= 0.1, "sphere light: slope {slope}");
    // Rough metal and Lambert spheres on a floor under sunrise.hdr.
    let map = rqr::environment::map::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/environments/sunrise.hdr"
    )))
    .unwrap()
    .0;
    let scene = spheres_on_a_floor(Material {
        base_color: Vec4::new(0.9, 0.6, 0.3, 1.0),
        metallic: 1.0,
        roughness: 0.4,
        ..Default::default()
    });
    let camera = look_at(Vec3::new(0.0, 1.5, 4.0), Vec3::new(0.0, 0.5, 0.0), 40.0);
    let slope = convergence_slope(&ctx, &scene, &camera, Some(&map), "sunrise");
    assert!((slope + 0.5).abs() <= 0.1, "sunrise: slope {slope}");
    // Rough transmission: frosted glass in front of a lit floor.
    let mut scene = spheres_on_a_floor(Material {
        base_color: Vec4::ONE,
        metallic: 0.0,
        roughness: 0.3,
        transmission: 1.0,
        ior: 1.5,
        ..Default::default()
    });
    scene.lights = soft_cornell(0.3).lights;
    let slope = convergence_slope(&ctx, &scene, &camera, None, "rough transmission");
    assert!(
        (slope + 0.5).abs() <= 0.1,
        "rough transmission: slope {slope}"
    );
}

/// A sphere of `material` resting on a grey Lambert floor, with a checker of a second sphere.
pub(super) fn spheres_on_a_floor(material: Material) -> Scene {
    assemble(
        vec![quad(0), sphere(1, 48, 24), sphere(2, 48, 24)],
        vec![
            Instance {
                geometry: 0,
                transform: Mat4::from_scale(Vec3::new(10.0, 1.0, 10.0)),
                node: 0,
            },
            Instance {
                geometry: 1,
                transform: Mat4::from_translation(Vec3::new(-0.3, 0.5, 0.0))
                    * Mat4::from_scale(Vec3::splat(0.5)),
                node: 1,
            },
            Instance {
                geometry: 2,
                transform: Mat4::from_translation(Vec3::new(0.8, 0.3, -0.8))
                    * Mat4::from_scale(Vec3::splat(0.3)),
                node: 2,
            },
        ],
        vec![lambert(0.5), material, lambert(0.8)],
        vec![],
        vec![],
    )
}

#[test]
fn host_tonemapping_matches_the_gpu() {
    // References accumulated over several renders are tonemapped on the host.
    use rqr::render::image::tonemap::tonemap_rgba8;
    use rqr::render::Tonemap;
    let ctx = support::gpu();
    let scene = cornell();
    let camera = scene.cameras[0];
    for (op, exposure) in [
        (Tonemap::KhronosNeutral, 0.0),
        (Tonemap::Aces, 1.0),
        (Tonemap::None, -0.5),
    ] {
        let settings = RenderSettings {
            width: 32,
            height: 32,
            tonemap: op,
            exposure,
            ..Default::default()
        };
        let out = render(&ctx, &scene, &camera, None, Backend::Bvh, false, &settings);
        for (i, c) in out.color.iter().enumerate() {
            let host = tonemap_rgba8([c[0], c[1], c[2]], op, exposure);
            for (k, (&h, &gpu)) in host.iter().zip(&out.rgba8[4 * i..4 * i + 4]).enumerate() {
                assert!(
                    h.abs_diff(gpu) <= 1,
                    "{op:?}: pixel {i} channel {k}: host {h} against GPU {gpu}"
                );
            }
        }
    }
}

#[test]
fn reprojected_sequences_keep_each_reused_sample_as_it_was() {
    use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceOptions};
    use rqr::render::temporal::{PixelSource, ReuseOptions};
    use rqr::render::RenderPath;
    let ctx = support::gpu();
    let scene = soft_cornell(0.2);
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let settings = RenderSettings {
        width: 48,
        height: 48,
        shading: Shading::Distributed,
        ..Default::default()
    };
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let mut seq = Sequence::new(
            &ctx,
            &renderer,
            &scene,
            &settings,
            scene.cameras[0],
            CameraPath::Static,
            SequenceOptions {
                path,
                reuse: ReuseOptions {
                    reproject: true,
                    ..Default::default()
                },
                reference: true,
            },
        )
        .unwrap();
        let first = seq.render_frame(&ctx, 0).unwrap();
        let second = seq.render_frame(&ctx, 1).unwrap();
        let pixel = |f: &rqr::render::drivers::sequence::SequenceFrame, i: usize| {
            f.output.rgba8[4 * i..4 * i + 4].to_vec()
        };
        let (mut reused, mut traced, mut retraced_changed) = (0, 0, 0);
        for (i, source) in second.sources.iter().enumerate() {
            match source {
                PixelSource::Reused => {
                    reused += 1;
                    assert_eq!(
                        pixel(&second, i),
                        pixel(&first, i),
                        "{path:?}: reused pixel {i} changed"
                    );
                }
                PixelSource::Traced => {
                    traced += 1;
                    retraced_changed += usize::from(pixel(&second, i) != pixel(&first, i));
                }
                PixelSource::Interpolated => {}
            }
        }
        assert!(
            reused > 48 * 48 / 2,
            "{path:?}: {reused} reused, {traced} traced"
        );
        // Traced pixels draw the next frame's random numbers: the noisy ones change.
        assert!(
            retraced_changed > 0,
            "{path:?}: none of {traced} traced pixels changed"
        );
        // The full render of frame 1 draws new numbers too.
        assert_ne!(
            second.reference_output.as_ref().unwrap().rgba8,
            first.reference_output.as_ref().unwrap().rgba8,
            "{path:?}: frame 1's full render repeats frame 0's noise"
        );
    }
    support::assert_validation_clean(&ctx);
}
