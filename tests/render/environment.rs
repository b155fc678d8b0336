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

pub(super) fn backends(ctx: &Context) -> Vec<Backend> {
    let mut b = vec![Backend::Bvh];
    if ctx.features().ray_query {
        b.push(Backend::Hw);
    }
    b
}

/// A unit sphere of `material` at the origin, seen from +Z (the map's centre behind the
/// camera, -Z, its seam, ahead), no lights.
pub(super) fn sphere_scene(material: Material, camera_from: Vec3) -> Scene {
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
pub(super) fn render(
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

pub(super) fn settings() -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        ambient: Vec3::splat(0.5), // must not show: the environment replaces it
        background: Vec3::new(9.0, 0.0, 9.0),
        ..Default::default()
    }
}

pub(super) fn hit(out: &RenderOutput, i: usize) -> bool {
    out.aov[i].hit()
}

/// Every combination of backend and path, with a label.
pub(super) fn each_path(ctx: &Context, mut f: impl FnMut(Backend, bool, &str)) {
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
fn a_half_metal_shades_as_the_mean_of_its_dielectric_and_its_metal() {
    // glTF's BRDF is mix(dielectric, metal, metallic): linear in `metallic`, so the half-metal's
    // radiance is the mean of the two ends' under the map and a sun alike. Darkening its diffuse
    // by the mixed F0's Fresnel (the metal's reflection taken from the dielectric's diffuse as
    // well) would make it 20-40 % darker than that mean.
    let ctx = support::gpu();
    let sun = rqr::scene::Light {
        kind: rqr::scene::LightKind::Directional,
        color: Vec3::ONE,
        intensity: 2.0,
        range: f32::INFINITY,
        position: Vec3::ZERO,
        direction: Vec3::new(-0.3, -0.8, -0.5).normalize(),
        size: 0.0,
    };
    let scene_of = |metallic: f32| {
        let mut scene = sphere_scene(
            Material {
                base_color: Vec4::new(0.9, 0.6, 0.25, 1.0),
                metallic,
                roughness: 0.45,
                ..Default::default()
            },
            Vec3::new(0.0, 0.0, 4.0),
        );
        scene.lights.push(sun);
        scene
    };
    let map = direction_map(64);
    // Every mirror ray traced, however weak: culling the dielectric's (weight 0.3 × 0.04)
    // but not the half-metal's would break the linearity by itself. (Rays of weight 0 are
    // still skipped, or they would turn pixels NaN.)
    let every_ray = RenderSettings {
        min_weight: 0.0,
        ..settings()
    };
    each_path(&ctx, |backend, hybrid, label| {
        let [dielectric, half, metal] =
            [0.0, 0.5, 1.0].map(|m| render(&ctx, &scene_of(m), &map, backend, hybrid, &every_ray));
        let mut hits = 0;
        for i in 0..half.color.len() {
            if !hit(&half, i) {
                continue;
            }
            hits += 1;
            for c in 0..3 {
                let mean = 0.5 * (dielectric.color[i][c] + metal.color[i][c]);
                let v = half.color[i][c];
                assert!(
                    (v - mean).abs() <= 0.01 * mean + 1e-4,
                    "{label}: pixel {i} channel {c}: half-metal {v}, mean of the ends {mean}"
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
            all.extend(env.read(&ctx, EnvTexture::Sheen, level).unwrap().2);
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
