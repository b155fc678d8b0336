//! The sheen lobe (KHR_materials_sheen) under an environment in the Whitted model: its split
//! sum against a host quadrature of its directional albedo under a constant map, against the
//! converged distributed model under a shared map, and the BRDF table's sheen channel.

use crate::environment::{each_path, hit, render, settings, sphere_scene};
use crate::support;

use glam::{Vec3, Vec4};
use rqr::environment::gpu::EnvTexture;
use rqr::environment::{EnvironmentMap, GpuEnvironment};
use rqr::render::{RenderSettings, SamplerKind, Shading};
use rqr::scene::{Material, MaterialLayers};

/// Sheen alone: a black base without specular (KHR_materials_specular factor 0), white sheen.
fn sheen_only(sheen_roughness: f32) -> Material {
    Material {
        base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
        metallic: 0.0,
        roughness: 1.0,
        layers: Some(Box::new(MaterialLayers {
            specular: 0.0,
            sheen_color: Vec3::ONE,
            sheen_roughness,
            ..Default::default()
        })),
        ..Default::default()
    }
}

/// The host's E_sheen(μ) at μ = k / 256, for interpolation.
fn albedo_table(sheen_roughness: f64) -> Vec<f64> {
    (0..=256)
        .map(|k| support::optics::sheen_albedo((k as f64 / 256.0).max(1e-4), sheen_roughness))
        .collect()
}

fn interpolate(table: &[f64], mu: f64) -> f64 {
    let x = mu.clamp(0.0, 1.0) * 256.0;
    let i = (x as usize).min(255);
    let t = x - i as f64;
    table[i] * (1.0 - t) + table[i + 1] * t
}

#[test]
fn sheen_sphere_under_a_constant_map_shows_its_directional_albedo() {
    // Under a constant map of radiance 1 the prefiltered sheen map is 1 everywhere, so each
    // pixel shows the lobe's directional albedo at its n·v.
    let ctx = support::gpu();
    let from = Vec3::new(0.0, 0.0, 4.0);
    let map = EnvironmentMap::constant(64, [1.0; 3]);
    for sheen_roughness in [0.5, 0.25] {
        let scene = sphere_scene(sheen_only(sheen_roughness), from);
        let table = albedo_table(f64::from(sheen_roughness));
        each_path(&ctx, |backend, hybrid, label| {
            let out = render(&ctx, &scene, &map, backend, hybrid, &settings());
            let (mut checked, mut worst) = (0, 0.0f64);
            for (i, c) in out.color.iter().enumerate() {
                if !hit(&out, i) {
                    continue;
                }
                let a = out.aov[i];
                let v = (from - a.world_position()).normalize();
                let mu = f64::from(a.shading_normal().dot(v));
                if mu < 0.1 {
                    continue; // the silhouette: n·v changes faster than a pixel there
                }
                let e = interpolate(&table, mu);
                let got = f64::from(c[0]);
                assert!(
                    (got - e).abs() <= 0.03 * e + 1e-3,
                    "{label}, sheen roughness {sheen_roughness}: pixel {i} (n·v {mu:.3}): {got:.5} against E {e:.5}"
                );
                if e > 0.02 {
                    worst = worst.max((got - e).abs() / e);
                }
                checked += 1;
            }
            eprintln!("{label}, sheen roughness {sheen_roughness}: {checked} pixels, worst relative error {worst:.4} where E > 0.02");
            assert!(checked > 200, "{label}: {checked} pixels checked");
        });
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn brdf_table_holds_the_sheen_albedo() {
    let ctx = support::gpu();
    let env = GpuEnvironment::prepare(&ctx, &EnvironmentMap::constant(16, [1.0; 3])).unwrap();
    let (w, h, table) = env.read(&ctx, EnvTexture::Brdf, 0).unwrap();
    let mut checked = 0;
    for x in [2u32, 6, 12, 20, 32, 44, 56, 63] {
        for y in [8u32, 15, 16, 24, 32, 40, 48, 63] {
            let n_dot_v = (x as f64 + 0.5) / w as f64;
            let sheen_roughness = (y as f64 + 0.5) / h as f64;
            let host = support::optics::sheen_albedo(n_dot_v, sheen_roughness);
            let gpu = f64::from(table[(y * w + x) as usize][2]);
            if host < 1e-3 {
                assert!(gpu < 2e-3, "E_sheen({n_dot_v:.3}, {sheen_roughness:.3}): table {gpu:.5}, quadrature {host:.5}");
                continue;
            }
            assert!(
                (gpu - host).abs() <= 0.01 * host,
                "E_sheen({n_dot_v:.3}, {sheen_roughness:.3}): table {gpu:.5}, quadrature {host:.5}"
            );
            checked += 1;
        }
    }
    assert!(checked > 40, "{checked} texels checked");
    support::assert_validation_clean(&ctx);
}

/// Σ |a − b| / Σ b over the pixels where the sphere covers the pixel and its 8 neighbours
/// (away from the silhouette, where a centre sample and a pixel's area differ), all channels.
fn mean_relative_difference(
    a: &rqr::render::RenderOutput,
    b: &rqr::render::RenderOutput,
    size: usize,
) -> f64 {
    let (mut diff, mut sum) = (0.0, 0.0);
    for y in 1..size - 1 {
        for x in 1..size - 1 {
            let inside = (0..9).all(|k| hit(b, (y + k / 3 - 1) * size + x + k % 3 - 1));
            if !inside {
                continue;
            }
            let i = y * size + x;
            for c in 0..3 {
                diff += f64::from((a.color[i][c] - b.color[i][c]).abs());
                sum += f64::from(b.color[i][c]);
            }
        }
    }
    diff / sum
}

#[test]
fn sheen_split_sum_follows_the_converged_distributed_model() {
    // The distributed model integrates the sheen lobe against the map (environment sampling;
    // a convex sphere does not shadow itself, so its unshadowed Whitted light is the same
    // integral). Under a constant map the two agree to the noise (measured 0.7 % at sheen
    // roughness 0.5, 2.7 % at 0.25). Under interior.hdr the split sum is an approximation: its
    // prefiltered map averages the lobe at n = v, a band at the horizon of n, while at grazing
    // views the true lobe gathers light from the horizon on the viewer's side. Measured
    // (512 spp, whose own noise is 1.8 % / 3.3 % between two seeds): 0.245 at roughness 0.5,
    // 0.403 at 0.25, looking the map up at n; at the mirror direction, as the Sample Viewer
    // does, 0.41 and 0.59; without environment sheen, 1. The bounds leave 0.05-0.07 above the
    // measurements and reject the last two.
    let ctx = support::gpu();
    let map = rqr::environment::map::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/environments/interior.hdr"
    )))
    .unwrap()
    .0;
    let constant = EnvironmentMap::constant(64, [1.0; 3]);
    let from = Vec3::new(0.0, 0.0, 4.0);
    let size = settings().width as usize;
    let distributed = RenderSettings {
        shading: Shading::Distributed,
        spp: 512,
        sampler: SamplerKind::Sobol,
        ..settings()
    };
    let backend = rqr::accel::Backend::Bvh;
    for (sheen_roughness, bound) in [(0.5, 0.30), (0.25, 0.47)] {
        let scene = sphere_scene(sheen_only(sheen_roughness), from);
        let difference = |map: &EnvironmentMap| {
            let whitted = render(&ctx, &scene, map, backend, false, &settings());
            let reference = render(&ctx, &scene, map, backend, false, &distributed);
            mean_relative_difference(&whitted, &reference, size)
        };
        let flat = difference(&constant);
        let d = difference(&map);
        eprintln!(
            "sheen roughness {sheen_roughness}: split sum against distributed: constant map {flat:.4}, interior.hdr {d:.4}"
        );
        assert!(
            flat <= 0.05,
            "sheen roughness {sheen_roughness}: constant map: {flat}"
        );
        assert!(
            d <= bound,
            "sheen roughness {sheen_roughness}: interior.hdr: {d} > {bound}"
        );
    }
    support::assert_validation_clean(&ctx);
}
