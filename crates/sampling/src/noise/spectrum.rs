//! Power spectrum of a square array of values on a torus (a dither array, or the error of an
//! image tile): how the array's variance is distributed over spatial frequencies. White noise
//! spreads it evenly; blue noise has almost none at low frequencies.

use std::f64::consts::TAU;

/// |F(k)|²/side² of the mean-free array for every frequency k = (kx, ky), row-major over
/// (ky, kx) ∈ [0, side)², by a separable DFT (O(side³)). Normalised so that the sum over all k
/// is side² × the population variance, and white noise of variance v has expected power v at
/// every k ≠ 0.
pub fn power_spectrum(values: &[f64], side: usize) -> Vec<f64> {
    assert_eq!(values.len(), side * side, "the array must be side × side");
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let twiddle: Vec<(f64, f64)> = (0..side)
        .map(|k| {
            let a = -TAU * k as f64 / side as f64;
            (a.cos(), a.sin())
        })
        .collect();
    // Rows first: R[y][kx] = Σ_x v[y][x] e^{−2πi kx x/side}.
    let mut rows = vec![(0.0f64, 0.0f64); side * side];
    for y in 0..side {
        for kx in 0..side {
            let (mut re, mut im) = (0.0, 0.0);
            for x in 0..side {
                let v = values[y * side + x] - mean;
                let (c, s) = twiddle[(kx * x) % side];
                re += v * c;
                im += v * s;
            }
            rows[y * side + kx] = (re, im);
        }
    }
    let mut power = vec![0.0; side * side];
    for ky in 0..side {
        for kx in 0..side {
            let (mut re, mut im) = (0.0, 0.0);
            for y in 0..side {
                let (a, b) = rows[y * side + kx];
                let (c, s) = twiddle[(ky * y) % side];
                re += a * c - b * s;
                im += a * s + b * c;
            }
            power[ky * side + kx] = (re * re + im * im) / (side * side) as f64;
        }
    }
    power
}

/// Radius |k| of frequency index (kx, ky) (indices above side/2 are negative frequencies).
pub fn frequency_radius(kx: usize, ky: usize, side: usize) -> f64 {
    let f = |k: usize| {
        let k = k as f64;
        if k > side as f64 / 2.0 {
            k - side as f64
        } else {
            k
        }
    };
    f(kx).hypot(f(ky))
}

/// Radially averaged power: entry r is the mean power over the frequencies with
/// round(|k|) = r, r = 0 … side/2 (DC, r = 0, is 0 for a mean-free array).
pub fn radial_average(power: &[f64], side: usize) -> Vec<f64> {
    let bins = side / 2 + 1;
    let (mut sum, mut count) = (vec![0.0; bins], vec![0usize; bins]);
    for ky in 0..side {
        for kx in 0..side {
            let r = frequency_radius(kx, ky, side).round() as usize;
            if r < bins {
                sum[r] += power[ky * side + kx];
                count[r] += 1;
            }
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(s, &c)| if c > 0 { s / c as f64 } else { 0.0 })
        .collect()
}

/// Mean power over the frequencies 0 < |k| ≤ `cutoff`, divided by the array's variance: 1 in
/// expectation for white noise, ≪ 1 for blue noise.
pub fn low_frequency_share(values: &[f64], side: usize, cutoff: f64) -> f64 {
    let power = power_spectrum(values, side);
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    let (mut sum, mut count) = (0.0, 0usize);
    for ky in 0..side {
        for kx in 0..side {
            let r = frequency_radius(kx, ky, side);
            if r > 0.0 && r <= cutoff {
                sum += power[ky * side + kx];
                count += 1;
            }
        }
    }
    if count == 0 || var.is_nan() || var <= 0.0 {
        return 0.0;
    }
    sum / count as f64 / var
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parseval_and_a_pure_wave() {
        let side = 16;
        let v: Vec<f64> = (0..side * side)
            .map(|p| (TAU * 3.0 * (p % side) as f64 / side as f64).cos())
            .collect();
        let power = power_spectrum(&v, side);
        let total: f64 = power.iter().sum();
        let var = v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64;
        assert!((total - var * (side * side) as f64).abs() < 1e-9);
        // All the power at kx = ±3, ky = 0.
        assert!((power[3] + power[side - 3] - total).abs() < 1e-9);
        assert_eq!(frequency_radius(side - 3, 0, side), 3.0);
    }
}
