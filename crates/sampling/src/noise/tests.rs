//! The noise's spectrum, determinism and unbiasedness. Statistical tests at fixed seeds, each at
//! α = 0.01/6 (Šidák-free Bonferroni over the six statistical assertions of this module).

use super::spectrum::{low_frequency_share, power_spectrum, radial_average};
use super::*;
use statrs::distribution::{ChiSquared, ContinuousCDF};

const ALPHA: f64 = 0.01 / 6.0;
/// Frequencies |k| ≤ 8 of 32: the lowest quarter of the band, where blue noise has (almost) no
/// energy.
const LOW_CUTOFF: f64 = 8.0;

fn ranks_as_values(ranks: &[u16]) -> Vec<f64> {
    ranks
        .iter()
        .map(|&r| (r as f64 + 0.5) / TEXELS as f64)
        .collect()
}

fn chi2_uniform_p(values: impl Iterator<Item = f32>, bins: usize) -> f64 {
    let mut counts = vec![0u64; bins];
    let mut n = 0u64;
    for v in values {
        assert!((0.0..1.0).contains(&v), "{v} outside [0, 1)");
        counts[(v * bins as f32) as usize] += 1;
        n += 1;
    }
    let e = n as f64 / bins as f64;
    let stat: f64 = counts.iter().map(|&o| (o as f64 - e).powi(2) / e).sum();
    ChiSquared::new(bins as f64 - 1.0).unwrap().sf(stat)
}

/// The dither arrays' low-frequency energy is far below white noise's: over 16 arrays of the
/// table, the mean power at 0 < |k| ≤ 8 is < 5 % of the variance (white noise: 100 % in
/// expectation; 16 Philox arrays measured here for comparison must lie within 0.8…1.2).
#[test]
fn blue_noise_has_little_low_frequency_energy() {
    let table = blue_noise_table();
    let blue: f64 = (0..16)
        .map(|a| low_frequency_share(&ranks_as_values(table.array(a * 16)), SIDE, LOW_CUTOFF))
        .sum::<f64>()
        / 16.0;
    let white: f64 = (0..16u32)
        .map(|a| {
            let v: Vec<f64> = (0..TEXELS as u64)
                .map(|i| crate::philox::unit_f32(CounterRng::at(5, [a, 0, 0], i)) as f64)
                .collect();
            low_frequency_share(&v, SIDE, LOW_CUTOFF)
        })
        .sum::<f64>()
        / 16.0;
    eprintln!("low-frequency share (|k| ≤ {LOW_CUTOFF}): blue {blue:.4}, white {white:.4}");
    assert!((0.8..1.2).contains(&white), "white {white}");
    assert!(blue < 0.05, "blue {blue}");
    // The radial spectrum rises from near 0 to above the white level at high frequencies.
    let radial = radial_average(
        &power_spectrum(&ranks_as_values(table.array(0)), SIDE),
        SIDE,
    );
    let var = 1.0 / 12.0;
    assert!(radial[2] < 0.05 * var, "{radial:?}");
    assert!(radial[28] > var, "{radial:?}");
}

/// The table is the same in every run and on every platform: a hash of all 2²⁰ ranks.
#[test]
fn blue_noise_table_is_deterministic() {
    let table = blue_noise_table();
    for a in [0, 1, 100, ARRAYS - 1] {
        assert_eq!(table.array(a), &dither_array(array_seed(a))[..]);
    }
    // FNV-1a over the little-endian ranks.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &r in &table.ranks {
        for b in r.to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    eprintln!("table hash {h:#018x}");
    assert_eq!(h, TABLE_HASH, "the blue-noise table changed");
}

/// FNV-1a hash of the generated table (update only with a deliberate change of the generator).
const TABLE_HASH: u64 = 0xf5e3_49b6_a1be_40b1;

/// Why a random toroidal shift keeps a pixel unbiased: over the 4096 shifts of any array, the
/// pixel sees every rank exactly once (each array is a permutation of 0 … 4095), so with the
/// 12-bit sub-rank offset the 24-bit value is uniform.
#[test]
fn every_shift_of_every_array_visits_each_rank_once() {
    let table = blue_noise_table();
    for a in 0..ARRAYS {
        let mut seen = vec![false; TEXELS];
        for oy in 0..SIDE as u32 {
            for ox in 0..SIDE as u32 {
                let r = table.rank(a, 17 + ox, 41 + oy) as usize;
                assert!(!seen[r]);
                seen[r] = true;
            }
        }
    }
}

/// White noise is the camera sample's Philox stream, number for number.
#[test]
fn white_noise_is_the_camera_stream() {
    let src = NoiseSource::new(Noise::White, 9, 4);
    let mut s = src.stream(3, 5, 5 * 100 + 3, 2, 1);
    let mut r = CounterRng::camera_sample(9, 2, 503, 1);
    let (u, v) = s.film_position();
    assert_eq!((u, v), (r.next_f32(), r.next_f32()));
    for _ in 0..10 {
        assert_eq!(s.next_f32(), r.next_f32());
    }
    assert_eq!(s.next_f64(), r.next_f64());
}

/// At a fixed pixel, blue noise across 2¹⁶ passes is uniform in each dimension (χ², 64 bins),
/// uncorrelated between dimensions and between samples; jittered blue noise puts sample i of
/// N = 3 uniformly into [i/3, (i+1)/3).
#[test]
fn blue_noise_is_uniform_across_passes_at_a_pixel() {
    let passes = 1u32 << 16;
    let blue = NoiseSource::new(Noise::Blue, 11, 2);
    let mut dim0 = Vec::new();
    let mut dim3 = Vec::new();
    let mut sample1 = Vec::new();
    for pass in 0..passes {
        let mut s = blue.stream(10, 20, 0, pass, 0);
        let _ = s.film_position();
        dim0.push(s.next_f32());
        let _ = (s.next_f32(), s.next_f32());
        dim3.push(s.next_f32());
        let mut t = blue.stream(10, 20, 0, pass, 1);
        let _ = t.film_position();
        sample1.push(t.next_f32());
    }
    let p0 = chi2_uniform_p(dim0.iter().copied(), 64);
    let p3 = chi2_uniform_p(dim3.iter().copied(), 64);
    // Pairs (dimension 0, dimension 3) and (sample 0, sample 1) on an 8×8 grid.
    let pair = |a: &[f32], b: &[f32]| {
        chi2_uniform_p(
            a.iter()
                .zip(b)
                .map(|(&x, &y)| (((x * 8.0) as u32 * 8 + (y * 8.0) as u32) as f32 + 0.5) / 64.0),
            64,
        )
    };
    let (pd, ps) = (pair(&dim0, &dim3), pair(&dim0, &sample1));
    eprintln!("blue across passes: p(dim 0) = {p0:.3}, p(dim 3) = {p3:.3}, p(pairs of dims) = {pd:.3}, p(pairs of samples) = {ps:.3}");
    for p in [p0, p3, pd, ps] {
        assert!(p >= ALPHA, "p = {p:e}");
    }

    let n = 3u32;
    let jittered = NoiseSource::new(Noise::BlueJittered, 11, n);
    // The N samples of a pass share ξ₀: test the position within the stratum of one sample,
    // and that the others sit at the same position of theirs.
    let mut within = Vec::new();
    for pass in 0..passes {
        let mut pos = [0.0f32; 3];
        for i in 0..n {
            let mut s = jittered.stream(10, 20, 0, pass, i);
            let _ = s.film_position();
            let x = s.next_f32();
            let lo = i as f32 / n as f32;
            assert!(
                x >= lo - 1e-7 && x < (i + 1) as f32 / n as f32 + 1e-7,
                "{x} not in stratum {i}"
            );
            pos[i as usize] = ((x - lo) * n as f32).clamp(0.0, 0.999_999);
        }
        assert!((pos[0] - pos[2]).abs() < 1e-5, "{pos:?}");
        within.push(pos[1]);
    }
    let pj = chi2_uniform_p(within.into_iter(), 64);
    eprintln!("jittered within strata: p = {pj:.3}");
    assert!(pj >= ALPHA, "p = {pj:e}");
}

/// The ξ of one pass over a 64×64 block of pixels is blue noise in screen space (one dimension,
/// one pass), for both blue variants; white noise is not.
#[test]
fn one_pass_is_blue_in_screen_space() {
    for (noise, blue) in [
        (Noise::White, false),
        (Noise::Blue, true),
        (Noise::BlueJittered, true),
    ] {
        let src = NoiseSource::new(noise, 3, 1);
        let v: Vec<f64> = (0..TEXELS as u32)
            .map(|p| {
                let (x, y) = (100 + p % 64, 7 + p / 64);
                let mut s = src.stream(x, y, y * 1000 + x, 5, 0);
                let _ = s.film_position();
                s.next_f32() as f64
            })
            .collect();
        let share = low_frequency_share(&v, SIDE, LOW_CUTOFF);
        eprintln!("{noise}: low-frequency share {share:.3}");
        if blue {
            assert!(share < 0.05, "{noise}: {share}");
        } else {
            assert!(share > 0.8, "{noise}: {share}");
        }
    }
}
