//! Image-based lighting against closed-form expectations, on every backend the device has and
//! both paths: a white furnace, a mirror sphere, the background's orientation and rotation, a
//! rough metal's energy, and the prepared textures against host integrations.

use crate::support;

use glam::{Mat4, Vec3, Vec4};
use rqr::accel::Backend;
use rqr::environment::gpu::EnvTexture;
use rqr::environment::{direction_to_uv, rotate_into_map, EnvironmentMap, GpuEnvironment};
use rqr::render::passes::draw_list;
use rqr::render::{RenderOutput, RenderSettings, Renderer};
use rqr::scene::procedural::{assemble, look_at, sphere};
use rqr::scene::{Instance, Material, MaterialLayers, Scene};
use rqr::vk::Context;

const SIZE: u32 = 48;

fn backends(ctx: &Context) -> Vec<Backend> {
    let mut b = vec![Backend::Bvh];
    if ctx.features().ray_query {
        b.push(Backend::Hw);
    }
    b
}

/// A unit sphere of `material` at the origin, seen from +Z (the map's centre behind the
/// camera, -Z, its seam, ahead), no lights.
fn sphere_scene(material: Material, camera_from: Vec3) -> Scene {
    assemble(
        vec![sphere(0, 96, 48)],
        vec![Instance {
            geometry: 0,
            transform: Mat4::IDENTITY,
            node: 0,
        }],
        vec![material],
        vec![],
        vec![look_at(camera_from, Vec3::ZERO, 40.0)],
    )
}

/// Renders `scene` under `map` with `settings` on `backend`, ray traced or hybrid.
fn render(
    ctx: &Context,
    scene: &Scene,
    map: &EnvironmentMap,
    backend: Backend,
    hybrid: bool,
    settings: &RenderSettings,
) -> RenderOutput {
    let mut renderer = Renderer::new(ctx, scene, backend).unwrap();
    let env = GpuEnvironment::prepare(ctx, map).unwrap();
    renderer.set_environment(ctx, Some(env)).unwrap();
    let camera = &scene.cameras[0];
    if hybrid {
        renderer
            .render_hybrid(ctx, &draw_list::draws(scene), settings, camera, true)
            .unwrap()
    } else {
        renderer.render_rt(ctx, settings, camera, true).unwrap()
    }
}

fn settings() -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        ambient: Vec3::splat(0.5), // must not show: the environment replaces it
        background: Vec3::new(9.0, 0.0, 9.0),
        ..Default::default()
    }
}

fn hit(out: &RenderOutput, i: usize) -> bool {
    out.aov[i].hit()
}

/// Every combination of backend and path, with a label.
fn each_path(ctx: &Context, mut f: impl FnMut(Backend, bool, &str)) {
    for backend in backends(ctx) {
        for hybrid in [false, true] {
            let label = format!(
                "{} {}",
                backend.as_str(),
                if hybrid { "hybrid" } else { "rt" }
            );
            f(backend, hybrid, &label);
        }
    }
}

#[test]
fn white_furnace_lambert_sphere_shows_its_albedo() {
    let ctx = support::gpu();
    let albedo = 0.7;
    let material = Material {
        base_color: Vec4::new(albedo, albedo, albedo, 1.0),
        metallic: 0.0,
        roughness: 1.0,
        layers: Some(Box::new(MaterialLayers {
            specular: 0.0,
            ..Default::default()
        })),
        ..Default::default()
    };
    let scene = sphere_scene(material, Vec3::new(0.0, 0.0, 4.0));
    let map = EnvironmentMap::constant(64, [1.0; 3]);
    each_path(&ctx, |backend, hybrid, label| {
        let out = render(&ctx, &scene, &map, backend, hybrid, &settings());
        let mut hits = 0;
        for (i, c) in out.color.iter().enumerate() {
            let expected = if hit(&out, i) { albedo } else { 1.0 };
            hits += usize::from(hit(&out, i));
            for &v in &c[..3] {
                assert!(
                    (v - expected).abs() <= 0.01 * expected,
                    "{label}: pixel {i}: {v} against {expected}"
                );
            }
        }
        assert!(hits > 200, "{label}: the sphere covers {hits} pixels");
    });
    support::assert_validation_clean(&ctx);
}

#[test]
fn rough_metal_under_a_constant_map_conserves_energy() {
    // GGX with F0 = 1 at roughness 0.5: with multiple-scattering compensation its directional
    // albedo is 1, so the sphere disappears into a constant map.
    let ctx = support::gpu();
    let material = Material {
        base_color: Vec4::ONE,
        metallic: 1.0,
        roughness: 0.5,
        ..Default::default()
    };
    let scene = sphere_scene(material, Vec3::new(0.0, 0.0, 4.0));
    let map = EnvironmentMap::constant(64, [1.0; 3]);
    each_path(&ctx, |backend, hybrid, label| {
        let out = render(&ctx, &scene, &map, backend, hybrid, &settings());
        let mut sum = 0.0;
        let mut n = 0;
        for (i, c) in out.color.iter().enumerate() {
            if hit(&out, i) {
                sum += c[0] as f64;
                n += 1;
                assert!((c[0] - 1.0).abs() < 0.03, "{label}: pixel {i}: {}", c[0]);
            }
        }
        let mean = sum / n as f64;
        assert!((mean - 1.0).abs() <= 0.02, "{label}: mean {mean}");
    });
}

/// A smooth map whose colour tells the direction apart.
fn direction_map(width: u32) -> EnvironmentMap {
    EnvironmentMap::from_fn(width, |d| {
        [
            0.6 + 0.4 * d.x,
            0.6 + 0.4 * d.y,
            0.6 + 0.4 * d.z + 0.2 * (3.0 * d.x).sin(),
        ]
    })
}

fn lookup(map: &EnvironmentMap, d: Vec3, rotation: f32) -> [f32; 3] {
    let (u, v) = direction_to_uv(rotate_into_map(d.normalize(), rotation));
    map.bilinear(u, v)
}

#[test]
fn missed_camera_rays_show_the_map_under_the_convention_and_rotation() {
    let ctx = support::gpu();
    let map = direction_map(256);
    // Looking along -X, slightly up: the sphere sits in the middle, misses all around.
    let scene = sphere_scene(Material::default(), Vec3::new(6.0, 1.0, 0.5));
    for rotation in [0.0f32, 90.0] {
        let s = RenderSettings {
            environment_rotation: rotation,
            ..settings()
        };
        each_path(&ctx, |backend, hybrid, label| {
            let out = render(&ctx, &scene, &map, backend, hybrid, &s);
            let mut misses = 0;
            for y in 0..SIZE {
                for x in 0..SIZE {
                    let i = (y * SIZE + x) as usize;
                    if hit(&out, i) {
                        continue;
                    }
                    misses += 1;
                    let e = lookup(
                        &map,
                        support::optics::camera_dir(&scene, x, y, SIZE),
                        rotation,
                    );
                    for (c, &e) in e.iter().enumerate() {
                        assert!(
                            (out.color[i][c] - e).abs() <= 0.01 * e,
                            "{label} rotation {rotation}: pixel ({x}, {y}) channel {c}: {} against {}",
                            out.color[i][c],
                            e
                        );
                    }
                }
            }
            assert!(misses > 1000, "{label}: {misses} misses");
        });
    }
    // And `--background` keeps the map's light but shows its own colour to camera rays.
    let s = RenderSettings {
        environment_background: false,
        ..settings()
    };
    let out = render(&ctx, &scene, &map, Backend::Bvh, false, &s);
    assert_eq!(&out.color[0][..3], &[9.0, 0.0, 9.0]);
    support::assert_validation_clean(&ctx);
}

#[test]
fn mirror_sphere_reflects_the_map() {
    let ctx = support::gpu();
    let map = direction_map(512);
    let material = Material {
        base_color: Vec4::ONE,
        metallic: 1.0,
        roughness: 0.0,
        ..Default::default()
    };
    let from = Vec3::new(0.5, 0.8, 4.0);
    let scene = sphere_scene(material, from);
    let s = RenderSettings {
        environment_rotation: 30.0,
        ..settings()
    };
    each_path(&ctx, |backend, hybrid, label| {
        let out = render(&ctx, &scene, &map, backend, hybrid, &s);
        let mut checked = 0;
        for (i, c) in out.color.iter().enumerate() {
            if !hit(&out, i) {
                continue;
            }
            let a = out.aov[i];
            let p = a.world_position();
            let n = p.normalize();
            let v = (p - from).normalize();
            if -n.dot(v) < 0.3 {
                continue; // grazing: the tessellation's normals differ most there
            }
            let r = v - 2.0 * n.dot(v) * n;
            let e = lookup(&map, r, 30.0);
            for k in 0..3 {
                assert!(
                    (c[k] - e[k]).abs() <= 0.02 * e[k],
                    "{label}: pixel {i} channel {k}: {} against env(reflect) {}",
                    c[k],
                    e[k]
                );
            }
            checked += 1;
        }
        assert!(checked > 200, "{label}: {checked} pixels checked");
    });
    support::assert_validation_clean(&ctx);
}

#[test]
fn split_sum_table_matches_the_directional_albedo() {
    let ctx = support::gpu();
    let env = GpuEnvironment::prepare(&ctx, &EnvironmentMap::constant(16, [1.0; 3])).unwrap();
    let (w, h, table) = env.read(&ctx, EnvTexture::Brdf, 0).unwrap();
    for (x, y) in [(10u32, 16u32), (32, 32), (50, 40), (60, 60), (20, 55)] {
        let n_dot_v = (x as f64 + 0.5) / w as f64;
        let roughness = (y as f64 + 0.5) / h as f64;
        let t = table[(y * w + x) as usize];
        let gpu = (t[0] + t[1]) as f64;
        let host = support::optics::ggx_albedo(n_dot_v, roughness);
        assert!(
            (gpu - host).abs() <= 0.03 * host,
            "E({n_dot_v:.3}, {roughness:.3}): table {gpu:.4}, quadrature {host:.4}"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn prepared_levels_match_brute_force_integration() {
    let ctx = support::gpu();
    // Smooth variation plus a broad bright patch (no single-texel sun: the reference
    // integrates texel by texel).
    let map = EnvironmentMap::from_fn(128, |d| {
        let patch = (-(d - Vec3::new(0.6, 0.6, 0.52).normalize()).length_squared() * 8.0).exp();
        [
            0.3 + 0.2 * d.y + 4.0 * patch,
            0.3 + 0.1 * d.x,
            0.4 + 2.0 * patch,
        ]
    });
    let env = GpuEnvironment::prepare(&ctx, &map).unwrap();
    let texel_dirs: Vec<(Vec3, f32)> = (0..map.height)
        .flat_map(|y| (0..map.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let u = (x as f32 + 0.5) / map.width as f32;
            let v = (y as f32 + 0.5) / map.height as f32;
            (
                rqr::environment::uv_to_direction(u, v),
                (std::f32::consts::PI * v).sin(),
            )
        })
        .collect();
    let reference = |weight: &dyn Fn(Vec3) -> f32| {
        let mut sum = [0.0f64; 3];
        let mut total = 0.0f64;
        for (i, (l, sin)) in texel_dirs.iter().enumerate() {
            let w = (weight(*l) * sin) as f64;
            if w > 0.0 {
                for (s, &t) in sum.iter_mut().zip(&map.texels[i]) {
                    *s += t as f64 * w;
                }
                total += w;
            }
        }
        sum.map(|s| s / total.max(1e-30))
    };
    let mean_error = |which: EnvTexture, level: u32, weight: &dyn Fn(Vec3, Vec3) -> f32| {
        let (w, h, texels) = env.read(&ctx, which, level).unwrap();
        let mut err = 0.0;
        let mut n = 0;
        for y in (0..h).step_by((h as usize / 8).max(1)) {
            for x in (0..w).step_by((w as usize / 16).max(1)) {
                let dir = rqr::environment::uv_to_direction(
                    (x as f32 + 0.5) / w as f32,
                    (y as f32 + 0.5) / h as f32,
                );
                let r = reference(&|l| weight(dir, l));
                let g = texels[(y * w + x) as usize];
                for c in 0..3 {
                    err += ((g[c] as f64 - r[c]) / r[c]).abs();
                    n += 1;
                }
            }
        }
        err / n as f64
    };
    // Irradiance / π: the cosine-weighted mean (the weights normalise to 1 over a
    // hemisphere: ∫cos dω = π).
    let e = mean_error(EnvTexture::Irradiance, 0, &|n, l| n.dot(l).max(0.0));
    eprintln!("irradiance: mean relative error {e:.4}");
    assert!(e <= 0.02, "irradiance: mean relative error {e:.4}");
    // Specular levels: the n·l-weighted GGX lobe around n = v = r (D(h) / 4 per solid angle).
    for level in 1..5u32 {
        let roughness = level as f32 / 4.0;
        let alpha = roughness * roughness;
        let e = mean_error(EnvTexture::Specular, level, &|n, l| {
            let n_dot_l = n.dot(l);
            if n_dot_l <= 0.0 {
                return 0.0;
            }
            let h = (n + l).normalize();
            let nh = n.dot(h);
            let a2 = alpha * alpha;
            let d = nh * nh * (a2 - 1.0) + 1.0;
            a2 / (d * d) * n_dot_l
        });
        eprintln!("specular level {level} (roughness {roughness}): mean relative error {e:.4}");
        assert!(
            e <= 0.02,
            "specular level {level} (roughness {roughness}): mean relative error {e:.4}"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn cli_renders_under_an_environment_file_and_reports_its_preparation() {
    let dir = std::env::temp_dir().join(format!("rqr-env-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let hdr = dir.join("map.hdr");
    std::fs::write(&hdr, rqr::environment::map::encode_hdr(&direction_map(64))).unwrap();
    let out = dir.join("out.png");
    let json = support::run_json(
        std::process::Command::new(env!("CARGO_BIN_EXE_rqr"))
            .env("RQR_VALIDATION", "1")
            .env("RQR_CACHE_DIR", dir.join("cache"))
            .args([
                "render",
                "--width",
                "32",
                "--height",
                "32",
                "--json",
                "--environment",
            ])
            .arg(&hdr)
            .args(["--environment-rotation", "-45", "-o"])
            .arg(&out),
    );
    assert!(
        json["environment_prepare"]["total_ms"].as_f64().unwrap() > 0.0,
        "{json}"
    );
    assert!(out.exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn prepared_textures_come_back_from_the_cache_and_a_corrupt_file_is_rebuilt() {
    let ctx = support::gpu();
    let dir = std::env::temp_dir().join(format!("rqr-env-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let map = direction_map(64);
    let read_all = |env: &GpuEnvironment| {
        let mut all = Vec::new();
        for level in 0..5 {
            all.extend(env.read(&ctx, EnvTexture::Specular, level).unwrap().2);
        }
        all.extend(env.read(&ctx, EnvTexture::Irradiance, 0).unwrap().2);
        all.extend(env.read(&ctx, EnvTexture::Brdf, 0).unwrap().2);
        all
    };
    let first = GpuEnvironment::prepare_cached(&ctx, &map, Some(&dir)).unwrap();
    assert!(!first.timing.cached);
    let second = GpuEnvironment::prepare_cached(&ctx, &map, Some(&dir)).unwrap();
    assert!(
        second.timing.cached,
        "the second preparation reads the cache"
    );
    assert_eq!(read_all(&first), read_all(&second));
    // Another map is another file.
    let other = GpuEnvironment::prepare_cached(&ctx, &direction_map(32), Some(&dir)).unwrap();
    assert!(!other.timing.cached);
    // A corrupt file (cut short) is prepared again, giving the same textures.
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    }
    let rebuilt = GpuEnvironment::prepare_cached(&ctx, &map, Some(&dir)).unwrap();
    assert!(!rebuilt.timing.cached);
    assert_eq!(read_all(&first), read_all(&rebuilt));
    support::assert_validation_clean(&ctx);
    std::fs::remove_dir_all(&dir).ok();
}

/// Four spheres (diffuse, mirror, rough metal, glass) on a floor, no lights.
fn spheres_on_a_floor() -> Scene {
    let m = |base: Vec3, metallic: f32, roughness: f32, transmission: f32| Material {
        base_color: base.extend(1.0),
        metallic,
        roughness,
        transmission,
        ..Default::default()
    };
    let materials = vec![
        m(Vec3::splat(0.6), 0.0, 0.8, 0.0),
        m(Vec3::new(0.8, 0.3, 0.2), 0.0, 0.6, 0.0),
        m(Vec3::ONE, 1.0, 0.0, 0.0),
        m(Vec3::new(0.9, 0.7, 0.3), 1.0, 0.45, 0.0),
        m(Vec3::ONE, 0.0, 0.0, 1.0),
    ];
    let mut instances = vec![Instance {
        geometry: 0,
        transform: Mat4::from_translation(Vec3::new(0.0, -1.0, 0.0))
            * Mat4::from_scale(Vec3::splat(8.0)),
        node: 0,
    }];
    for (k, x) in [-2.4f32, -0.8, 0.8, 2.4].into_iter().enumerate() {
        instances.push(Instance {
            geometry: k as u32 + 1,
            transform: Mat4::from_translation(Vec3::new(x, -0.25, 0.0))
                * Mat4::from_scale(Vec3::splat(0.75)),
            node: k + 1,
        });
    }
    let mut geometries = vec![rqr::scene::procedural::quad(0)];
    for k in 1..5 {
        geometries.push(sphere(k, 48, 24));
    }
    assemble(
        geometries,
        instances,
        materials,
        vec![],
        vec![look_at(
            Vec3::new(0.0, 1.5, 6.0),
            Vec3::new(0.0, -0.3, 0.0),
            45.0,
        )],
    )
}

#[test]
fn hybrid_and_ray_traced_paths_agree_under_an_environment() {
    let ctx = support::gpu();
    let scene = spheres_on_a_floor();
    let map = direction_map(256);
    let s = RenderSettings {
        width: 96,
        height: 64,
        environment_rotation: 60.0,
        ..Default::default()
    };
    let mut images = Vec::new();
    for backend in backends(&ctx) {
        let rt = render(&ctx, &scene, &map, backend, false, &s);
        let hybrid = render(&ctx, &scene, &map, backend, true, &s);
        let d = rqr::render::image::metrics::compare(96, 64, &rt.rgba8, &hybrid.rgba8);
        eprintln!(
            "{}: hybrid vs rt FLIP {:.5}, PSNR {:.1} dB",
            backend.as_str(),
            d.flip_mean,
            d.psnr_db
        );
        assert!(
            d.flip_mean <= 0.02,
            "{}: hybrid vs rt FLIP {}",
            backend.as_str(),
            d.flip_mean
        );
        images.push(rt.rgba8);
    }
    if images.len() == 2 {
        let d = rqr::render::image::metrics::compare(96, 64, &images[0], &images[1]);
        assert!(d.flip_mean <= 0.01, "hw vs bvh FLIP {}", d.flip_mean);
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn reprojected_misses_show_the_environment_under_camera_motion() {
    use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceOptions};
    use rqr::render::temporal::{PixelSource, ReuseOptions};
    use rqr::render::RenderPath;
    let ctx = support::gpu();
    let scene = spheres_on_a_floor();
    // Stripes around the vertical: 4° of orbit changes what a miss sees by up to 0.25.
    let striped = EnvironmentMap::from_fn(512, |d| {
        let s = (12.0 * d.x.atan2(-d.z)).sin();
        [0.5 + 0.3 * s, 0.5 - 0.3 * s, 0.5]
    });
    let mut renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    renderer
        .set_environment(&ctx, Some(GpuEnvironment::prepare(&ctx, &striped).unwrap()))
        .unwrap();
    let s = RenderSettings {
        width: 64,
        height: 64,
        ..Default::default()
    };
    let path = CameraPath::Orbit {
        degrees_per_frame: 4.0,
        pivot: Vec3::ZERO,
    };
    for render_path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let options = SequenceOptions {
            path: render_path,
            reuse: ReuseOptions {
                reproject: true,
                ..Default::default()
            },
            reference: true,
        };
        let mut seq = Sequence::new(
            &ctx,
            &renderer,
            &scene,
            &s,
            scene.cameras[0],
            path.clone(),
            options,
        )
        .unwrap();
        for k in 0..4 {
            let f = seq.render_frame(&ctx, k).unwrap();
            let full = f.reference_output.as_ref().unwrap();
            let misses = renderer.render_rt(&ctx, &s, &f.camera, true).unwrap().aov;
            let (mut reused, mut off, mut reused_misses) = (0, 0, 0);
            for (i, (a, b)) in f.output.color.iter().zip(&full.color).enumerate() {
                if f.sources[i] == PixelSource::Reused {
                    reused += 1;
                    let d = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max);
                    off += usize::from(d >= 0.05);
                    let (x, y) = ((i % 64) as i32, (i / 64) as i32);
                    let miss_around = (-1..=1).all(|dy| {
                        (-1..=1).all(|dx| {
                            let (nx, ny) = ((x + dx).clamp(0, 63), (y + dy).clamp(0, 63));
                            !misses[(ny * 64 + nx) as usize].hit()
                        })
                    });
                    // (Pixels next to a hit may show a reprojected hit: disocclusion.)
                    if miss_around {
                        // A reused miss shows the map along this pixel's own ray, not the
                        // sample's (a sub-pixel off on stripes this fine is ~0.03).
                        reused_misses += 1;
                        assert!(
                            d < 1e-3,
                            "{render_path:?} frame {k}: reused miss {i} off by {d}"
                        );
                    }
                }
            }
            if k > 0 {
                assert!(
                    reused_misses > 200,
                    "{render_path:?} frame {k}: {reused_misses} reused misses"
                );
            }
            if k > 0 {
                assert!(reused > 1000, "{render_path:?} frame {k}: {reused} reused");
            }
            // Reused surface samples are off only along disoccluded edges (a few dozen
            // pixels); misses that kept their old colour would all be off by the map's change
            // over 4° of orbit.
            assert!(
                off * 50 <= reused,
                "{render_path:?} frame {k}: {off} of {reused} reused pixels differ by 0.05 or more"
            );
        }
    }
    support::assert_validation_clean(&ctx);
}

/// The map at `assets/environments/NAME.hdr`.
fn shipped_map(name: &str) -> EnvironmentMap {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/environments")
        .join(format!("{name}.hdr"));
    rqr::environment::map::load(&path).unwrap().0
}

/// Runs `shaders/test/env_sampling.comp` over `count` invocations on `env`; returns its output.
fn sampling_test(
    ctx: &Context,
    env: &GpuEnvironment,
    push: rqr::interface::environment::EnvSamplingTestPush,
    words_per_invocation: u64,
) -> Vec<[f32; 4]> {
    use rqr::interface::{bindings, push_bytes};
    use rqr::vk::{vk, Binding, Buffer, ComputePipeline, MemoryLocation};
    let pipeline = ComputePipeline::cached(
        ctx,
        "environment sampling test",
        rqr::shaders::ENV_SAMPLING_COMP,
        &bindings(&[
            (0, Binding::SampledImages(1)),
            (1, Binding::SampledImages(1)),
        ]),
        std::mem::size_of_val(&push) as u32,
    )
    .unwrap();
    let d = env.descriptors();
    let set = pipeline.allocate_set().unwrap();
    set.sampled_images(
        0,
        &[d[rqr::interface::environment::ENV_TEX_SAMPLING as usize]],
    );
    set.sampled_images(1, &[d[0]]);
    let n = u64::from(push.count) * words_per_invocation;
    let out = Buffer::new(
        ctx,
        "sampling test out",
        n * 16,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuToCpu,
    )
    .unwrap();
    let push = rqr::interface::environment::EnvSamplingTestPush {
        texels_out: out.address(),
        ..push
    };
    ctx.run("environment sampling test", |cmd| {
        pipeline.dispatch(
            cmd,
            Some(&set),
            push_bytes(&push),
            [push.count.div_ceil(64), 1, 1],
        );
        rqr::vk::host_read_barrier(ctx.device(), cmd);
        Ok(())
    })
    .unwrap();
    out.mapped_read(0, n as usize).unwrap()
}

/// P(X > x) for X ~ χ²(k), by the Wilson–Hilferty normal approximation (fine for k in the
/// hundreds).
fn chi_square_p(x: f64, k: f64) -> f64 {
    let z = ((x / k).cbrt() - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    // 1 - Φ(z) = erfc(z / √2) / 2 (Abramowitz–Stegun 7.1.26).
    let t = z / std::f64::consts::SQRT_2;
    let erfc = |v: f64| {
        let s = 1.0 / (1.0 + 0.327_591_1 * v.abs());
        let y = s
            * (0.254_829_592
                + s * (-0.284_496_736
                    + s * (1.421_413_741 + s * (-1.453_152_027 + s * 1.061_405_429))));
        let e = y * (-v * v).exp();
        if v >= 0.0 {
            e
        } else {
            2.0 - e
        }
    };
    erfc(t) / 2.0
}

#[test]
fn environment_sampling_on_the_gpu_matches_its_host_twin_and_its_density() {
    use rqr::environment::sampling::SamplingTables;
    use rqr::interface::environment::{EnvSamplingTestPush, ENV_TEST_SAMPLE};
    let ctx = support::gpu();
    let map = shipped_map("sunrise");
    let env = GpuEnvironment::prepare(&ctx, &map).unwrap();
    let host = SamplingTables::new(&map);
    let count = 1u32 << 20;
    let out = sampling_test(
        &ctx,
        &env,
        EnvSamplingTestPush {
            count,
            mode: ENV_TEST_SAMPLE,
            seed: 11,
            ..Default::default()
        },
        2,
    );
    // The same u gives the same direction and density on both sides, and the density of the
    // drawn direction is the density it was drawn with.
    let (mut checked, mut off) = (0usize, 0usize);
    for k in (0..count as usize).step_by(997) {
        let (s, t) = (out[2 * k], out[2 * k + 1]);
        let (d, p) = host.sample([t[0], t[1]]);
        let g = Vec3::new(s[0], s[1], s[2]);
        assert!(
            (g - d).length() < 1e-3,
            "u {:?}: {g} vs host {d}",
            [t[0], t[1]]
        );
        assert!(
            (s[3] - p).abs() <= 1e-3 * p,
            "u {:?}: pdf {} vs host {p}",
            [t[0], t[1]],
            s[3]
        );
        // The density is discontinuous at texel edges, and the shader's trigonometry may
        // put a sample drawn right at one into its neighbour: those are left out.
        let (uu, vv) = direction_to_uv(d);
        let edge = |x: f32| (x - x.round()).abs() < 0.02;
        if edge(uu * map.width as f32) || edge(vv * map.height as f32) {
            continue;
        }
        checked += 1;
        off += usize::from((t[2] - s[3]).abs() > 1e-3 * s[3]);
    }
    assert!(
        off == 0,
        "pdf(sample(u)) differs from the drawn density for {off} of {checked} samples"
    );
    // χ² over a 32×16 grid of (u, v) cells: expected probabilities from the tables.
    let (cw, ch) = (32usize, 16usize);
    let (w, h) = (map.width as usize, map.height as usize);
    let stride = w + 1;
    let mut expected = vec![0.0f64; cw * ch];
    for y in 0..h {
        let py = f64::from(host.table[h * stride + y + 1] - host.table[h * stride + y]);
        for x in 0..w {
            let px = f64::from(host.table[y * stride + x + 1] - host.table[y * stride + x]);
            expected[(y * ch / h) * cw + x * cw / w] += py * px;
        }
    }
    let mut observed = vec![0.0f64; cw * ch];
    for k in 0..count as usize {
        let d = Vec3::new(out[2 * k][0], out[2 * k][1], out[2 * k][2]);
        let (u, v) = direction_to_uv(d);
        let cell =
            ((v * ch as f32) as usize).min(ch - 1) * cw + ((u * cw as f32) as usize).min(cw - 1);
        observed[cell] += 1.0;
    }
    let (mut chi2, mut dof, mut rest_o, mut rest_e) = (0.0, 0.0, 0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        let e = e * f64::from(count);
        if e < 5.0 {
            rest_o += o;
            rest_e += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            dof += 1.0;
        }
    }
    if rest_e >= 5.0 {
        chi2 += (rest_o - rest_e) * (rest_o - rest_e) / rest_e;
        dof += 1.0;
    }
    let p = chi_square_p(chi2, dof - 1.0);
    eprintln!("χ² {chi2:.1} over {dof} cells: p = {p:.3}");
    assert!(p > 1e-3, "χ² {chi2:.1} over {dof} cells: p = {p:.2e}");
    support::assert_validation_clean(&ctx);
}

/// Luminance irradiance at +Y of `map` as piecewise-constant texels, integrated exactly:
/// Σ L · Δφ · (sin²θ₁ − sin²θ₀) / 2 over the upper half's texels.
fn irradiance_up(map: &EnvironmentMap) -> f64 {
    let (w, h) = (map.width as usize, map.height as usize);
    let d_phi = std::f64::consts::TAU / w as f64;
    let mut e = 0.0;
    for y in 0..h / 2 {
        let t0 = std::f64::consts::PI * y as f64 / h as f64;
        let t1 = std::f64::consts::PI * (y + 1) as f64 / h as f64;
        let band = d_phi * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
        for x in 0..w {
            e += f64::from(rqr::environment::sampling::luminance(map.texels[y * w + x])) * band;
        }
    }
    e
}

/// Relative RMSE of the cosine-sampled irradiance estimate at +Y with `n` samples, exactly:
/// Var[π L] = π ∫ L² cos⁺ dω − E², per texel as in [`irradiance_up`].
fn cosine_rel_rmse(map: &EnvironmentMap, n: u32) -> f64 {
    let (w, h) = (map.width as usize, map.height as usize);
    let d_phi = std::f64::consts::TAU / w as f64;
    let (mut e, mut second) = (0.0, 0.0);
    for y in 0..h / 2 {
        let t0 = std::f64::consts::PI * y as f64 / h as f64;
        let t1 = std::f64::consts::PI * (y + 1) as f64 / h as f64;
        let band = d_phi * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
        for x in 0..w {
            let l = f64::from(rqr::environment::sampling::luminance(map.texels[y * w + x]));
            e += l * band;
            second += std::f64::consts::PI * l * l * band;
        }
    }
    ((second - e * e) / f64::from(n)).sqrt() / e
}

#[test]
fn environment_sampling_estimates_irradiance_with_low_variance() {
    use rqr::interface::environment::{
        EnvSamplingTestPush, ENV_STRATEGY_COSINE, ENV_STRATEGY_ENVIRONMENT, ENV_STRATEGY_MIS,
        ENV_TEST_IRRADIANCE,
    };
    let ctx = support::gpu();
    let estimates = |env: &GpuEnvironment, strategy: u32, trials: u32, samples: u32| -> Vec<f64> {
        let push = EnvSamplingTestPush {
            count: trials,
            mode: ENV_TEST_IRRADIANCE,
            samples,
            strategy,
            seed: 5,
            ..Default::default()
        };
        sampling_test(&ctx, env, push, 1)
            .iter()
            .map(|v| f64::from(v[0]))
            .collect()
    };
    let rel_rmse = |e: &[f64], truth: f64| {
        (e.iter().map(|x| (x - truth) * (x - truth)).sum::<f64>() / e.len() as f64).sqrt() / truth
    };
    for name in ["studio", "sunrise", "interior", "city"] {
        let map = shipped_map(name);
        let env = GpuEnvironment::prepare(&ctx, &map).unwrap();
        let truth = irradiance_up(&map);
        if name == "sunrise" {
            // 2^20 environment samples converge on the quadrature.
            let all = estimates(&env, ENV_STRATEGY_ENVIRONMENT, 1024, 1024);
            let mean = all.iter().sum::<f64>() / all.len() as f64;
            assert!(
                (mean / truth - 1.0).abs() <= 0.005,
                "{name}: {mean} vs quadrature {truth}"
            );
        }
        // Cosine sampling's error is dominated by rare hits of the sun, which a few thousand
        // trials rarely see: its exact variance comes from the map (the estimator is π L(d)
        // with d ~ cos/π), and the GPU's trials are checked against it where they can be.
        let cosine = cosine_rel_rmse(&map, 16);
        let gpu_cosine = rel_rmse(&estimates(&env, ENV_STRATEGY_COSINE, 16384, 16), truth);
        if name == "studio" {
            assert!(
                (gpu_cosine / cosine - 1.0).abs() < 0.1,
                "{name}: cosine {gpu_cosine} on the GPU, {cosine} exact"
            );
        }
        let environment = rel_rmse(&estimates(&env, ENV_STRATEGY_ENVIRONMENT, 16384, 16), truth);
        let mis = rel_rmse(&estimates(&env, ENV_STRATEGY_MIS, 16384, 16), truth);
        eprintln!("{name}: relative RMSE at 16 samples: cosine {cosine:.3} (GPU trials {gpu_cosine:.3}), environment {environment:.3}, MIS 8+8 {mis:.3}");
        if name == "sunrise" || name == "city" {
            assert!(
                environment <= 0.25,
                "{name}: environment sampling {environment}"
            );
            assert!(
                cosine > 5.0,
                "{name}: cosine sampling {cosine} (a sun should defeat it)"
            );
        }
        assert!(
            mis <= 1.5 * cosine.min(environment),
            "{name}: MIS {mis} against cosine {cosine} and environment {environment}"
        );
    }
    support::assert_validation_clean(&ctx);
}
