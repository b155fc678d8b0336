//! Sub-pixel sample sequences and filter weights: the host mirror of
//! `shaders/common/sampling.glsl` (unit-tested here; `tests/gpu/shader_math.rs` checks the shader).

/// lowbias32 integer hash (Chris Wellons).
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Radical inverse of `i` in `base` (Halton dimension).
pub fn radical_inverse(base: u32, mut i: u32) -> f32 {
    let inv = 1.0 / base as f32;
    let (mut f, mut r) = (inv, 0.0);
    while i > 0 {
        r += f * (i % base) as f32;
        i /= base;
        f *= inv;
    }
    r
}

/// The Halton (2,3) point of index `i` (the shader uses `i = sample + 1`).
pub fn halton_2_3(i: u32) -> [f32; 2] {
    [radical_inverse(2, i), radical_inverse(3, i)]
}

/// Second Sobol dimension as 32-bit fixed point.
pub fn sobol_dim1(mut i: u32) -> u32 {
    let (mut v, mut r) = (0x8000_0000u32, 0u32);
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        v ^= v >> 1;
        i >>= 1;
    }
    r
}

/// Unscrambled 2D Sobol point of index `i` (dimension 0 = van der Corput).
pub fn sobol_2d(i: u32) -> [f32; 2] {
    let scale = 1.0 / 4_294_967_296.0;
    [
        i.reverse_bits() as f32 * scale,
        sobol_dim1(i) as f32 * scale,
    ]
}

fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Owen scrambling by hashing (Burley 2020).
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

fn unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Owen-scrambled, shuffled Sobol point `index` for pixel seed `seed` (as the shader computes it).
pub fn sobol_owen(index: u32, seed: u32) -> [f32; 2] {
    let i = nested_uniform_scramble(index, hash_u32(seed));
    let x = nested_uniform_scramble(i.reverse_bits(), hash_u32(seed ^ 0xa511_e9b3));
    let y = nested_uniform_scramble(sobol_dim1(i), hash_u32(seed ^ 0x63d8_3595));
    [unit(x), unit(y)]
}

/// Position in [0,1)² of sample `s` of `n` for samplers that place it identically in every
/// pixel (`center`, `grid`, `halton`, `sobol`), as `sample_2d` in the shader does; `None` for
/// the per-pixel samplers (`jitter`, `bluenoise`, `adaptive`).
pub fn pixel_independent_sample(
    kind: super::SamplerKind,
    s: u32,
    n: u32,
    seed: u32,
) -> Option<[f32; 2]> {
    use super::SamplerKind as K;
    let k = ((n as f32).sqrt().round() as u32).max(1);
    match kind {
        K::Center => Some([0.5, 0.5]),
        K::Grid => Some([
            ((s % k) as f32 + 0.5) / k as f32,
            ((s / k) as f32 + 0.5) / k as f32,
        ]),
        K::Halton => Some(halton_2_3(s + 1)),
        K::Sobol => Some(sobol_owen(s, seed)),
        K::Jitter | K::Bluenoise | K::Adaptive => None,
    }
}

/// Tent filter weight of a sample at offset `(dx, dy)` pixels from the centre (radius 1).
pub fn tent_weight(dx: f32, dy: f32) -> f32 {
    (1.0 - dx.abs()).max(0.0) * (1.0 - dy.abs()).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halton_first_values() {
        let expected = [
            [0.5, 1.0 / 3.0],
            [0.25, 2.0 / 3.0],
            [0.75, 1.0 / 9.0],
            [0.125, 4.0 / 9.0],
            [0.625, 7.0 / 9.0],
        ];
        for (i, e) in expected.iter().enumerate() {
            let h = halton_2_3(i as u32 + 1);
            assert!(
                (h[0] - e[0]).abs() < 1e-6 && (h[1] - e[1]).abs() < 1e-6,
                "index {}: {h:?}",
                i + 1
            );
        }
    }

    #[test]
    fn sobol_first_values() {
        let expected = [
            [0.0, 0.0],
            [0.5, 0.5],
            [0.25, 0.75],
            [0.75, 0.25],
            [0.125, 0.625],
            [0.625, 0.125],
        ];
        for (i, e) in expected.iter().enumerate() {
            assert_eq!(sobol_2d(i as u32), *e, "index {i}");
        }
    }

    #[test]
    fn owen_scrambled_sobol_stays_stratified() {
        // Any power-of-two prefix of a scrambled (0,2)-sequence puts one point in each
        // elementary interval: 16 points → one per 4×4 cell.
        for seed in [1u32, 77, 12345] {
            let mut cells = [0u32; 16];
            for i in 0..16 {
                let [x, y] = sobol_owen(i, seed);
                assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                cells[(y * 4.0) as usize * 4 + (x * 4.0) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "seed {seed}: {cells:?}");
        }
    }

    #[test]
    fn tent_weights() {
        assert_eq!(tent_weight(0.0, 0.0), 1.0);
        assert_eq!(tent_weight(0.5, 0.0), 0.5);
        assert_eq!(tent_weight(0.5, -0.5), 0.25);
        assert_eq!(tent_weight(1.0, 0.0), 0.0);
        assert_eq!(tent_weight(1.5, 0.2), 0.0);
        // The tent integrates to 1 over its support (midpoint rule on a fine grid).
        let n = 200;
        let sum: f32 = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let x = -1.0 + (i as f32 + 0.5) * 2.0 / n as f32;
                let y = -1.0 + (j as f32 + 0.5) * 2.0 / n as f32;
                tent_weight(x, y) * (2.0 / n as f32).powi(2)
            })
            .sum();
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
    }
}
