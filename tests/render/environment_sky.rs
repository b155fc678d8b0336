//! The physical sky (`--environment sky:…`): the Hosek–Wilkie model against an independent
//! evaluation of the published dataset, the bake and rqr's lookups against the model, the sun's
//! direction and irradiance under the map convention, a white plane lit (and shadowed by the
//! sun) in the Whitted model, and the built-in environment of scenes without lights.

use crate::support;

use glam::{Mat4, Vec3, Vec4};
use rqr::accel::Backend;
use rqr::environment::sky::{
    SkyModel, SkySpec, SKY_MAP_WIDTH, SKY_RADIANCE_SCALE, SUN_ANGULAR_RADIUS_DEG,
};
use rqr::environment::{direction_to_uv, rotate_into_map, GpuEnvironment};
use rqr::render::passes::draw_list;
use rqr::render::{RenderOutput, RenderSettings, Renderer};
use rqr::scene::procedural::{assemble, cube, look_at, quad, sphere};
use rqr::scene::{Instance, LightKind, Material, MaterialLayers, Scene};

const TURBIDITIES: [f32; 3] = [2.0, 3.0, 6.0];
const ELEVATIONS: [f32; 3] = [5.0, 30.0, 60.0];

fn sky(elevation_deg: f32, azimuth_deg: f32, turbidity: f32) -> SkyModel {
    SkySpec {
        elevation_deg,
        azimuth_deg,
        turbidity,
    }
    .model()
    .unwrap()
}

fn rel(a: f32, b: f32) -> f32 {
    (a - b).abs() / b.abs().max(1e-6)
}

/// (turbidity, sun elevation°, zenith angle θ°, azimuth from the sun°, RGB radiance): printed
/// by `scripts/sky-reference.py` from the authors' RGB dataset and C code
/// (`ArHosekSkyModelData_RGB.h`, `ArHosekSkyModel.c`, as shipped in pbrt-v4's
/// `src/ext/skymodel/`) in double precision, ground albedo 0.3 — independent of the crate's
/// binary dataset and its f32 port.
const PUBLISHED: [(f32, f32, f32, f32, [f32; 3]); 36] = [
    (2.0, 5.0, 0.0, 0.0, [0.716451, 1.27413, 1.94882]),
    (2.0, 5.0, 80.0, 180.0, [7.59338, 8.52537, 6.85195]),
    (2.0, 5.0, 60.0, 0.0, [4.1516, 4.96425, 5.26305]),
    (2.0, 5.0, 45.0, 90.0, [1.3849, 2.20037, 3.05418]),
    (2.0, 30.0, 0.0, 0.0, [1.52791, 3.13529, 6.55551]),
    (2.0, 30.0, 80.0, 180.0, [10.3636, 16.5624, 22.938]),
    (2.0, 30.0, 60.0, 0.0, [12.6716, 16.3151, 20.4326]),
    (2.0, 30.0, 45.0, 90.0, [2.38328, 4.69047, 8.98659]),
    (2.0, 60.0, 0.0, 0.0, [2.82483, 4.93039, 10.5092]),
    (2.0, 60.0, 80.0, 180.0, [9.63057, 15.8758, 25.3105]),
    (2.0, 60.0, 60.0, 0.0, [6.8028, 11.279, 19.8382]),
    (2.0, 60.0, 45.0, 90.0, [3.18286, 6.10722, 12.6211]),
    (3.0, 5.0, 0.0, 0.0, [0.719898, 1.30659, 1.96999]),
    (3.0, 5.0, 80.0, 180.0, [7.3442, 8.1636, 6.62363]),
    (3.0, 5.0, 60.0, 0.0, [5.79008, 5.85601, 5.39432]),
    (3.0, 5.0, 45.0, 90.0, [1.46111, 2.30559, 3.0745]),
    (3.0, 30.0, 0.0, 0.0, [1.75774, 3.34541, 6.67623]),
    (3.0, 30.0, 80.0, 180.0, [10.3041, 16.1062, 22.038]),
    (3.0, 30.0, 60.0, 0.0, [25.4648, 27.4041, 27.2452]),
    (3.0, 30.0, 45.0, 90.0, [2.68851, 4.93904, 9.06182]),
    (3.0, 60.0, 0.0, 0.0, [3.89673, 6.05157, 11.4052]),
    (3.0, 60.0, 80.0, 180.0, [9.87245, 15.8103, 25.081]),
    (3.0, 60.0, 60.0, 0.0, [9.24943, 13.6986, 21.6299]),
    (3.0, 60.0, 45.0, 90.0, [3.64152, 6.6037, 13.0268]),
    (6.0, 5.0, 0.0, 0.0, [0.897751, 1.43687, 2.05193]),
    (6.0, 5.0, 80.0, 180.0, [6.5216, 7.02398, 5.7177]),
    (6.0, 5.0, 60.0, 0.0, [10.8072, 8.72106, 5.89738]),
    (6.0, 5.0, 45.0, 90.0, [1.90868, 2.63426, 3.15625]),
    (6.0, 30.0, 0.0, 0.0, [2.89103, 4.45865, 7.27059]),
    (6.0, 30.0, 80.0, 180.0, [10.5584, 14.0907, 18.632]),
    (6.0, 30.0, 60.0, 0.0, [77.8139, 73.4291, 53.6881]),
    (6.0, 30.0, 45.0, 90.0, [3.83152, 5.9075, 9.34743]),
    (6.0, 60.0, 0.0, 0.0, [8.94923, 11.0397, 15.6944]),
    (6.0, 60.0, 80.0, 180.0, [10.7458, 15.5813, 23.9664]),
    (6.0, 60.0, 60.0, 0.0, [20.1981, 24.3185, 29.8556]),
    (6.0, 60.0, 45.0, 90.0, [6.03489, 8.89646, 14.9391]),
];

/// Direction at zenith angle `theta_deg` and azimuth `dphi_deg` from the sun's azimuth.
fn direction(sun_azimuth_deg: f32, theta_deg: f32, dphi_deg: f32) -> Vec3 {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    let (sp, cp) = (sun_azimuth_deg + dphi_deg).to_radians().sin_cos();
    Vec3::new(st * sp, ct, -st * cp)
}

#[test]
fn the_model_matches_an_independent_evaluation_of_the_published_dataset() {
    for (t, e, theta, dphi, expected) in PUBLISHED {
        // Through rqr's direction-based lookup, with the sun at an azimuth of its own.
        let azimuth = 37.0;
        let model = sky(e, azimuth, t);
        let d = direction(azimuth, theta, dphi);
        if theta == 0.0 || dphi == 0.0 {
            // θ = 0 or the sun's own azimuth: γ = |90° - e - θ|; the model at (θ, γ) directly.
            let gamma = (90.0 - e - theta).abs().to_radians();
            let direct = model.model_radiance(theta.to_radians(), gamma);
            for c in 0..3 {
                assert!(rel(direct[c], expected[c]) < 1e-3, "{t} {e} {theta} {dphi}");
            }
        }
        let got = model.sky_radiance(d);
        for c in 0..3 {
            let g = got[c] / SKY_RADIANCE_SCALE;
            assert!(
                rel(g, expected[c]) < 1e-3,
                "turbidity {t}, elevation {e}, θ {theta}, Δφ {dphi}, channel {c}: {g} against {}",
                expected[c]
            );
        }
    }
}

/// Directions over the sky, away from the sun's glow (γ > 5°, where the bilinear lookup of a
/// 1024-wide map would smooth the peak) and the horizon (θ < 85°, the seam with the ground).
fn test_directions(model: &SkyModel) -> Vec<Vec3> {
    let sun = model.spec.sun_direction();
    let n = 400;
    (0..n)
        .map(|k| {
            // A Fibonacci spiral over the upper hemisphere.
            let y = (k as f32 + 0.5) / n as f32;
            let phi = k as f32 * 2.399_963;
            let r = (1.0 - y * y).sqrt();
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .filter(|d| d.y > 5f32.to_radians().sin() && d.dot(sun) < 5f32.to_radians().cos())
        .collect()
}

#[test]
fn the_baked_map_reproduces_the_model_within_one_percent() {
    for t in TURBIDITIES {
        for e in ELEVATIONS {
            let model = sky(e, 150.0, t);
            let map = model.bake(SKY_MAP_WIDTH);
            assert_eq!((map.width, map.height), (SKY_MAP_WIDTH, SKY_MAP_WIDTH / 2));
            let dirs = test_directions(&model);
            assert!(dirs.len() > 300);
            let mut worst = 0.0f32;
            for d in dirs {
                let (u, v) = direction_to_uv(d);
                let got = map.bilinear(u, v);
                let want = model.sky_radiance(d);
                for c in 0..3 {
                    worst = worst.max(rel(got[c], want[c]));
                }
            }
            assert!(worst < 0.01, "turbidity {t}, elevation {e}: worst {worst}");
            // Below the horizon: one uniform ground colour, darker than the sky above it.
            let ground = map.texels[map.texels.len() - 1];
            let (u, v) = direction_to_uv(Vec3::new(0.3, -0.5, 0.8).normalize());
            let below = map.bilinear(u, v);
            assert!(
                (0..3).all(|c| rel(below[c], ground[c]) < 1e-5),
                "{below:?} {ground:?}"
            );
            assert!(ground.iter().all(|&g| g > 0.0 && g.is_finite()));
        }
    }
}

#[test]
fn the_sun_follows_elevation_and_azimuth_under_the_map_convention() {
    for (e, a) in [(30.0f32, 0.0f32), (5.0, 90.0), (60.0, 200.0), (45.0, -30.0)] {
        let model = sky(e, a, 3.0);
        let s = model.spec.sun_direction();
        assert!((s.length() - 1.0).abs() < 1e-5);
        assert!((s.y.asin().to_degrees() - e).abs() < 1e-3, "{e} {a}");
        // The azimuth is the map's u × 360°: the sun sits at u = azimuth / 360.
        let (u, v) = direction_to_uv(s);
        assert!(
            (u * 360.0 - a.rem_euclid(360.0)).abs() < 1e-2,
            "{e} {a}: u {u}"
        );
        assert!((v * 180.0 - (90.0 - e)).abs() < 1e-2);
        // The baked sky is brightest around the sun (its circumsolar glow), so the bake and
        // the sun agree on where the sun is.
        let map = model.bake(256);
        let lum = |t: &[f32; 3]| 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2];
        let brightest = (0..map.texels.len())
            .max_by(|&i, &j| lum(&map.texels[i]).total_cmp(&lum(&map.texels[j])))
            .unwrap();
        let (bx, by) = (brightest as u32 % map.width, brightest as u32 / map.width);
        let d = rqr::environment::uv_to_direction(
            (bx as f32 + 0.5) / map.width as f32,
            (by as f32 + 0.5) / map.height as f32,
        );
        // (The brightest texel may sit on the horizon below a high sun, the model's horizon
        // glow, but always at the sun's azimuth.)
        let azimuth_of = |d: Vec3| direction_to_uv(d).0 * 360.0;
        let off = (azimuth_of(d) - azimuth_of(s)).rem_euclid(360.0);
        assert!(
            off.min(360.0 - off) < 3.0,
            "{e} {a}: brightest texel {d} vs sun {s}"
        );
        let (su, sv) = direction_to_uv(s);
        let toward = lum(&map.bilinear(su, sv));
        let away = lum(&map.bilinear(su + 0.5, sv));
        assert!(
            toward > 3.0 * away,
            "{e} {a}: {toward} towards the sun, {away} away"
        );
        // The light shines from the sun, turned with the map.
        for rotation in [0.0f32, 90.0, -35.0] {
            let light = model.sun_light(rotation, 1.0);
            assert_eq!(light.kind, LightKind::Directional);
            let towards_sun = rotate_into_map(-light.direction, rotation);
            assert!((towards_sun - s).length() < 1e-5, "rotation {rotation}");
            assert!((light.size - SUN_ANGULAR_RADIUS_DEG.to_radians()).abs() < 1e-9);
        }
    }
    // Azimuth 0 is -Z, 90 is +X, 180 is +Z.
    let at = |a: f32| sky(0.0, a, 3.0).spec.sun_direction();
    assert!((at(0.0) - Vec3::NEG_Z).length() < 1e-5);
    assert!((at(90.0) - Vec3::X).length() < 1e-5);
    assert!((at(180.0) - Vec3::Z).length() < 1e-5);
}

#[test]
fn the_sun_is_a_disc_of_the_model_sky_units_and_dims_with_the_air_mass() {
    let model = sky(45.0, 0.0, 3.0);
    let omega = SkyModel::sun_solid_angle();
    let r = SUN_ANGULAR_RADIUS_DEG.to_radians();
    assert!(rel(omega, std::f32::consts::PI * r * r) < 1e-3, "{omega}");
    // Irradiance = disc radiance × solid angle.
    assert!((model.sun_radiance() * omega - model.sun_irradiance()).length() < 1e-3);
    // The light carries that irradiance, scaled with the map.
    let light = model.sun_light(0.0, 2.0);
    assert!((light.color * light.intensity - 2.0 * model.sun_irradiance()).length() < 1e-3);
    // Lower suns and hazier skies pass less light, and bluer light more so.
    let e = |el: f32, t: f32| sky(el, 0.0, t).sun_irradiance();
    assert!(e(5.0, 3.0).y < e(30.0, 3.0).y && e(30.0, 3.0).y < e(60.0, 3.0).y);
    assert!(e(30.0, 6.0).y < e(30.0, 2.0).y);
    let low = e(5.0, 3.0);
    assert!(
        low.x > low.y && low.y > low.z,
        "a low sun is reddish: {low}"
    );
    // Direct sun at 45° is brighter than the sky's light on a horizontal plane, as on a clear
    // day (the ratio measured in daylight is about 2–5).
    let map = model.bake(256);
    let sky_e = irradiance_up(&map);
    let sun_e = model.sun_irradiance().y * 45f32.to_radians().sin();
    assert!(
        sun_e > 1.5 * sky_e && sun_e < 8.0 * sky_e,
        "sun {sun_e} sky {sky_e}"
    );
}

/// Irradiance (green) on a plane facing +Y from a map's texels.
fn irradiance_up(map: &rqr::environment::EnvironmentMap) -> f32 {
    let (w, h) = (map.width as usize, map.height as usize);
    let texel = (2.0 * std::f64::consts::PI / w as f64) * (std::f64::consts::PI / h as f64);
    let mut e = 0.0f64;
    for y in 0..h / 2 {
        let theta = std::f64::consts::PI * (y as f64 + 0.5) / h as f64;
        for t in &map.texels[y * w..(y + 1) * w] {
            e += f64::from(t[1]) * theta.cos() * theta.sin() * texel;
        }
    }
    e as f32
}

const SIZE: u32 = 64;

/// A white Lambertian floor (16 m) with a cube floating above it, seen from above.
fn floor_and_cube(albedo: f32, sun: rqr::scene::Light) -> Scene {
    let white = Material {
        base_color: Vec4::new(albedo, albedo, albedo, 1.0),
        metallic: 0.0,
        roughness: 1.0,
        layers: Some(Box::new(MaterialLayers {
            specular: 0.0,
            ..Default::default()
        })),
        ..Default::default()
    };
    assemble(
        vec![quad(0), cube(0)],
        vec![
            Instance {
                geometry: 0,
                transform: Mat4::from_scale(Vec3::splat(16.0)),
                node: 0,
            },
            Instance {
                geometry: 1,
                transform: Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0)),
                node: 1,
            },
        ],
        vec![white],
        vec![sun],
        vec![look_at(Vec3::new(0.0, 9.0, 2.0), Vec3::ZERO, 50.0)],
    )
}

/// Whether the ray from `p` towards `to_sun` passes through the box `[lo, hi]`.
fn hits_box(p: Vec3, to_sun: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
    for a in 0..3 {
        let inv = 1.0 / to_sun[a];
        let (mut near, mut far) = ((lo[a] - p[a]) * inv, (hi[a] - p[a]) * inv);
        if near > far {
            std::mem::swap(&mut near, &mut far);
        }
        t0 = t0.max(near);
        t1 = t1.min(far);
    }
    t0 <= t1
}

fn render(ctx: &rqr::vk::Context, scene: &Scene, model: &SkyModel, hybrid: bool) -> RenderOutput {
    let mut renderer = Renderer::new(ctx, scene, Backend::Bvh).unwrap();
    let env = GpuEnvironment::prepare(ctx, &model.bake(SKY_MAP_WIDTH)).unwrap();
    renderer.set_environment(ctx, Some(env)).unwrap();
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        ambient: Vec3::splat(0.5), // must not show: the environment replaces it
        ..Default::default()
    };
    let camera = &scene.cameras[0];
    if hybrid {
        renderer
            .render_hybrid(ctx, &draw_list::draws(scene), &settings, camera, true)
            .unwrap()
    } else {
        renderer.render_rt(ctx, &settings, camera, true).unwrap()
    }
}

#[test]
fn a_white_plane_under_the_sky_is_lit_and_the_sun_casts_a_shadow() {
    let ctx = support::gpu();
    let albedo = 0.8;
    let model = sky(45.0, 150.0, 3.0);
    let sun = model.sun_light(0.0, 1.0);
    let to_sun = -sun.direction;
    let scene = floor_and_cube(albedo, sun);
    // What a Lambertian plane facing +Y reflects: albedo / π × (sun + sky irradiance).
    let map = model.bake(SKY_MAP_WIDTH);
    let sky_e = irradiance_up(&map);
    let sun_e = model.sun_irradiance().y * to_sun.y;
    let lit_expected = albedo / std::f32::consts::PI * (sun_e + sky_e);
    for hybrid in [false, true] {
        let out = render(&ctx, &scene, &model, hybrid);
        let (mut lit, mut shadow) = (Vec::new(), Vec::new());
        for (i, a) in out.aov.iter().enumerate() {
            let p = a.world_position();
            if !a.hit() || a.instance() != 0 || p.y.abs() > 1e-3 {
                continue; // not the floor
            }
            let g = out.color[i][1];
            // Margins of 0.1 m around the cube keep the penumbra and edge pixels out.
            let lo = Vec3::new(-0.5, 0.5, -0.5);
            let hi = Vec3::new(0.5, 1.5, 0.5);
            if hits_box(p, to_sun, lo + 0.1, hi - 0.1) {
                shadow.push(g);
            } else if !hits_box(p, to_sun, lo - 0.1, hi + 0.1) && p.length() < 3.0 {
                lit.push(g);
            }
        }
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len().max(1) as f32;
        let label = if hybrid { "hybrid" } else { "rt" };
        assert!(
            lit.len() > 100 && shadow.len() > 20,
            "{label}: {} lit, {} shadow",
            lit.len(),
            shadow.len()
        );
        let (l, s) = (mean(&lit), mean(&shadow));
        assert!(
            rel(l, lit_expected) < 0.05,
            "{label}: lit floor {l} against albedo/π × (sun + sky) = {lit_expected}"
        );
        // In the shadow only the sky lights the floor (unshadowed environment light, as the
        // Sample Viewer): albedo / π × sky irradiance, well under the lit level.
        let shadow_expected = albedo / std::f32::consts::PI * sky_e;
        assert!(s < 0.5 * l, "{label}: shadow {s} vs lit {l}");
        assert!(
            rel(s, shadow_expected) < 0.05,
            "{label}: shadowed floor {s} against albedo/π × sky = {shadow_expected}"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn missed_camera_rays_show_the_model_sky_through_the_gpu_lookup() {
    let ctx = support::gpu();
    let model = sky(30.0, 200.0, 3.0);
    let sun = model.spec.sun_direction();
    // A small sphere far below the view; the camera looks up at the sky, 70° wide.
    let scene = assemble(
        vec![sphere(0, 16, 8)],
        vec![Instance {
            geometry: 0,
            transform: Mat4::from_translation(Vec3::new(0.0, -50.0, 0.0)),
            node: 0,
        }],
        vec![Material::default()],
        vec![],
        vec![look_at(Vec3::ZERO, Vec3::new(0.3, 0.6, -1.0), 70.0)],
    );
    let out = render(&ctx, &scene, &model, false);
    let mut checked = 0;
    for y in 0..SIZE {
        for x in 0..SIZE {
            let d = support::optics::camera_dir(&scene, x, y, SIZE);
            if d.y < 5f32.to_radians().sin() || d.dot(sun) > 5f32.to_radians().cos() {
                continue;
            }
            let want = model.sky_radiance(d);
            let i = (y * SIZE + x) as usize;
            for (c, &w) in want.iter().enumerate() {
                assert!(
                    rel(out.color[i][c], w) < 0.01,
                    "pixel ({x}, {y}) channel {c}: {} against the model's {w}",
                    out.color[i][c],
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 2000, "{checked} pixels");
    support::assert_validation_clean(&ctx);
}

fn rqr_png(args: &[&str]) -> Vec<u8> {
    let dir = std::env::temp_dir().join(format!("rqr-sky-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let name = if args.is_empty() {
        "default".to_string()
    } else {
        args.join("_").replace([':', ',', '/', '.'], "-")
    };
    let out = dir.join(format!("{name}.png"));
    let mut all: Vec<&str> = vec![
        "render",
        "assets/gltf/Box/Box.glb",
        "--width",
        "24",
        "--height",
        "24",
        "-o",
    ];
    let out_str = out.to_str().unwrap().to_string();
    all.push(&out_str);
    all.extend_from_slice(args);
    let cache = dir.join("cache");
    let (o, _) = support::run_rqr(
        &all,
        &[
            ("RQR_VALIDATION", "1"),
            ("RQR_CACHE_DIR", cache.to_str().unwrap()),
        ],
        std::time::Duration::from_secs(300),
    );
    assert!(
        o.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::read(&out).unwrap()
}

#[test]
fn a_scene_without_lights_renders_under_the_built_in_environment_unless_told_none() {
    let default = rqr_png(&[]);
    let builtin = rqr_png(&["--environment", "sky"]);
    let none = rqr_png(&["--environment", "none"]);
    assert_eq!(default, builtin, "no --environment is the built-in sky");
    assert_ne!(
        default, none,
        "--environment none keeps the default light rig"
    );
}
