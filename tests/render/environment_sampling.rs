//! Environment importance sampling: the table built on the GPU against the host's, the GPU
//! sampler against its host twin and its density (normalisation, pdf consistency under
//! rotation, a χ² test), and the variance of irradiance estimates against cosine sampling on
//! the shipped maps.

use crate::support;

use glam::Vec3;
use rqr::environment::{direction_to_uv, EnvironmentMap, GpuEnvironment};
use rqr::vk::Context;

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

/// A `width` × `width / 2` map: a smooth pattern, one all-black row (the uniform fallback),
/// and one texel 10⁴ times brighter than the rest (a sun).
fn crafted_map(width: u32) -> EnvironmentMap {
    let (w, h) = (width as usize, width as usize / 2);
    let mut texels: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let g = 0.05 + (x * 0.37 + y * 1.3).sin().abs();
            [g, 0.5 * g, 0.2 + 0.1 * (y * 0.1).cos()]
        })
        .collect();
    let black = h / 7;
    texels[black * w..(black + 1) * w].fill([0.0; 3]);
    texels[(h * 2 / 5) * w + w / 7] = [2e4, 1.5e4, 1e4];
    EnvironmentMap {
        width,
        height: width / 2,
        texels,
    }
}

/// Builds the sampling table of `map` on the GPU, checks its conventions exactly (each CDF
/// starts at 0, ends at exactly 1 and never decreases; the marginal row is zero after its
/// `height + 1` entries) and returns it with its largest absolute difference from the host's.
fn gpu_table(ctx: &Context, map: &EnvironmentMap) -> (Vec<f32>, f64) {
    use rqr::environment::gpu::EnvTexture;
    use rqr::environment::sampling::SamplingTables;
    let env = GpuEnvironment::prepare(ctx, map).unwrap();
    let (tw, th, texels) = env.read(ctx, EnvTexture::Sampling, 0).unwrap();
    assert_eq!((tw, th), (map.width + 1, map.height + 1));
    let gpu: Vec<f32> = texels.iter().map(|t| t[0]).collect();
    let (w, h) = (map.width as usize, map.height as usize);
    for (row, cdf) in gpu.chunks_exact(w + 1).enumerate() {
        let n = if row < h { w } else { h };
        assert_eq!((cdf[0], cdf[n]), (0.0, 1.0), "row {row} of {w}x{h}");
        if let Some(x) = (0..n).find(|&x| cdf[x] > cdf[x + 1]) {
            panic!(
                "row {row} of {w}x{h} decreases at {x}: {} {}",
                cdf[x],
                cdf[x + 1]
            );
        }
        assert!(cdf[n + 1..].iter().all(|&v| v == 0.0), "row {row}");
    }
    let host = SamplingTables::new(map);
    let error = gpu
        .iter()
        .zip(&host.table)
        .map(|(g, h)| f64::from((g - h).abs()))
        .fold(0.0, f64::max);
    (gpu, error)
}

#[test]
fn environment_sampling_table_built_on_the_gpu_equals_the_host_table() {
    let ctx = support::gpu();
    // The shipped maps (1024×512: rows of 4 texels an invocation, a marginal of 2), crafted
    // maps narrower than a workgroup and with invocations left without texels.
    let mut maps: Vec<(String, EnvironmentMap)> = ["studio", "sunrise", "interior", "city"]
        .iter()
        .map(|n| (n.to_string(), shipped_map(n)))
        .collect();
    for width in [16, 600] {
        maps.push((format!("crafted {width}"), crafted_map(width)));
    }
    for (name, map) in &maps {
        let (table, error) = gpu_table(&ctx, map);
        eprintln!("{name}: GPU table within {error:.2e} of the host's");
        assert!(
            error <= 2e-6,
            "{name}: GPU table {error:.2e} from the host's"
        );
        if name.starts_with("crafted") {
            // The black row's CDF is the uniform one, exactly.
            let (w, h) = (map.width as usize, map.height as usize);
            let row = &table[(h / 7) * (w + 1)..][..w + 1];
            assert!(
                (0..=w).all(|x| row[x] == x as f32 / w as f32),
                "{name}: black row"
            );
        }
    }
    // A black map samples uniformly: every row and the marginal are the uniform CDF.
    let black = EnvironmentMap::constant(64, [0.0; 3]);
    let (table, error) = gpu_table(&ctx, &black);
    assert_eq!(error, 0.0, "black map");
    for (row, cdf) in table.chunks_exact(65).enumerate() {
        let n = if row < 32 { 64 } else { 32 };
        assert!(
            (0..=n).all(|x| cdf[x] == x as f32 / n as f32),
            "black map row {row}"
        );
    }
    support::assert_validation_clean(&ctx);
}

#[test]
fn environment_sampling_on_the_gpu_matches_its_host_twin_and_its_density() {
    use rqr::environment::sampling::SamplingTables;
    use rqr::interface::environment::{EnvSamplingTestPush, ENV_TEST_SAMPLE};
    let ctx = support::gpu();
    let map = shipped_map("sunrise");
    let env = GpuEnvironment::prepare(&ctx, &map).unwrap();
    let host = SamplingTables::new(&map);
    // The host twin samples the GPU's own table: the two builds differ by a few ulp of 1
    // (`gpu_table`), which is a relative difference of up to a percent in the probability of
    // a row near the end of the marginal CDF, where entries are close to 1 (a row at a pole,
    // of probability ~1e-5). Here the sampling code is compared, on one table.
    let twin = SamplingTables {
        table: env
            .read(&ctx, rqr::environment::gpu::EnvTexture::Sampling, 0)
            .unwrap()
            .2
            .iter()
            .map(|t| t[0])
            .collect(),
        ..host.clone()
    };
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
        3,
    );
    // The same u gives the same direction and density on both sides, and the density of the
    // drawn direction is the density it was drawn with.
    let (mut checked, mut off) = (0usize, 0usize);
    for k in (0..count as usize).step_by(997) {
        let (s, t) = (out[3 * k], out[3 * k + 1]);
        let (d, p) = twin.sample([t[0], t[1]]);
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
    // The shaders' map coordinates (env_uv: polynomial atan and acos) against the mapping in
    // f64, at every drawn direction: within 2e-6 in u and 2.2e-5 in v (1.2e-5 and 6.8e-5 rad).
    let mut worst = 0.0f64;
    for k in 0..count as usize {
        let (s, m) = (out[3 * k], out[3 * k + 2]);
        let d = glam::DVec3::new(s[0].into(), s[1].into(), s[2].into()).normalize();
        let u = (d.x.atan2(-d.z) / std::f64::consts::TAU).rem_euclid(1.0);
        let v = d.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
        let du = (f64::from(m[0]) - u).abs();
        let (du, dv) = (du.min(1.0 - du), (f64::from(m[1]) - v).abs());
        assert!(
            du <= 2.5e-6 && dv <= 2.5e-5,
            "env_uv({d}) is ({du:e}, {dv:e}) away from the mapping in f64"
        );
        worst = worst.max(du.max(dv));
    }
    println!("map coordinates off the f64 mapping by at most {worst:e}");
    // χ² over a 32×16 grid of (u, v) cells: expected probabilities from the host's table
    // (the reference).
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
        let d = Vec3::new(out[3 * k][0], out[3 * k][1], out[3 * k][2]);
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
