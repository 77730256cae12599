//! Image measures and pictures of the figures: RMSE against a reference (with the reference's
//! own variance removed), low-pass RMSE, tone mapping, crops, a logarithmic colour map.

use linlight_imagefile::{srgb8, Image};
use linlight_verify::heatmap::{sequential, Rgb8};

/// Per-pixel luminance (Rec. 709) of a mean.
pub fn luminance(p: [f32; 3]) -> f64 {
    0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64
}

/// RMSE over pixels and RGB channels of `a` against `reference`, the reference's own variance of
/// the mean subtracted from the mean squared error (so that a noisy reference does not set a
/// floor): √max(0, mean((a − b)² − var_b)).
pub fn rmse(a: &Image, reference: &Image) -> f64 {
    assert_eq!((a.width, a.height), (reference.width, reference.height));
    let n = (a.mean.len() * 3) as f64;
    let mut sum = 0.0;
    for ((pa, pb), vb) in a.mean.iter().zip(&reference.mean).zip(&reference.var) {
        for c in 0..3 {
            sum += (pa[c] as f64 - pb[c] as f64).powi(2) - vb[c] as f64;
        }
    }
    (sum / n).max(0.0).sqrt()
}

/// Mean over pixels and channels of the reference's variance of the mean: the squared error a
/// perfect image would show against it (what [`rmse`] subtracts).
pub fn reference_mse(reference: &Image) -> f64 {
    reference
        .var
        .iter()
        .flatten()
        .map(|&v| v as f64)
        .sum::<f64>()
        / (reference.var.len() * 3) as f64
}

/// Normalised 1-D Gaussian weights of standard deviation `sigma` (pixels), radius ⌈3σ⌉.
fn gaussian(sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as i64;
    let w: Vec<f64> = (-r..=r)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = w.iter().sum();
    w.into_iter().map(|x| x / s).collect()
}

/// Separable convolution of per-pixel values with `w` (edges clamped).
fn convolve(values: &[[f64; 3]], width: usize, height: usize, w: &[f64]) -> Vec<[f64; 3]> {
    let r = (w.len() / 2) as i64;
    let pass = |src: &[[f64; 3]], horizontal: bool| -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; src.len()];
        for y in 0..height {
            for x in 0..width {
                let mut acc = [0.0; 3];
                for (k, &wk) in w.iter().enumerate() {
                    let d = k as i64 - r;
                    let (sx, sy) = if horizontal {
                        ((x as i64 + d).clamp(0, width as i64 - 1) as usize, y)
                    } else {
                        (x, (y as i64 + d).clamp(0, height as i64 - 1) as usize)
                    };
                    let v = src[sy * width + sx];
                    for c in 0..3 {
                        acc[c] += wk * v[c];
                    }
                }
                out[y * width + x] = acc;
            }
        }
        out
    };
    let h = pass(values, true);
    pass(&h, false)
}

/// RMSE after a Gaussian low-pass of standard deviation `sigma` pixels of both images (what an
/// eye at a distance, or a denoiser, sees): blue noise moves its error to high frequencies,
/// which the filter removes. The reference's variance is filtered with the squared weights and
/// subtracted as in [`rmse`].
pub fn low_pass_rmse(a: &Image, reference: &Image, sigma: f64) -> f64 {
    let (w, h) = (a.width, a.height);
    let g = gaussian(sigma);
    let g2: Vec<f64> = g.iter().map(|x| x * x).collect();
    let to64 =
        |v: &[[f32; 3]]| -> Vec<[f64; 3]> { v.iter().map(|p| p.map(|c| c as f64)).collect() };
    let fa = convolve(&to64(&a.mean), w, h, &g);
    let fb = convolve(&to64(&reference.mean), w, h, &g);
    let vb = convolve(&to64(&reference.var), w, h, &g2);
    let n = (fa.len() * 3) as f64;
    let mut sum = 0.0;
    for i in 0..fa.len() {
        for c in 0..3 {
            sum += (fa[i][c] - fb[i][c]).powi(2) - vb[i][c];
        }
    }
    (sum / n).max(0.0).sqrt()
}

/// The scale that maps the 99.5 % quantile of the reference's luminance to display white.
pub fn white_scale(reference: &Image) -> f64 {
    let mut l: Vec<f64> = reference
        .mean
        .iter()
        .map(|&p| luminance(p))
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if l.is_empty() {
        return 1.0;
    }
    l.sort_by(f64::total_cmp);
    let q = l[((l.len() - 1) as f64 * 0.995) as usize];
    if q > 0.0 {
        1.0 / q
    } else {
        1.0
    }
}

/// sRGB picture of the mean scaled by `scale` (clipped at white).
pub fn tone(img: &Image, scale: f64) -> Rgb8 {
    let mut out = Rgb8::filled(img.width, img.height, [0; 3]);
    for y in 0..img.height {
        for x in 0..img.width {
            let m = img.mean[y * img.width + x];
            out.set(x, y, m.map(|c| srgb8((c as f64 * scale) as f32)));
        }
    }
    out
}

/// A rectangle of a picture, enlarged `zoom` times (nearest neighbour).
pub fn crop(p: &Rgb8, x0: usize, y0: usize, w: usize, h: usize, zoom: usize) -> Rgb8 {
    let mut out = Rgb8::filled(w * zoom, h * zoom, [0; 3]);
    for y in 0..h * zoom {
        for x in 0..w * zoom {
            let (sx, sy) = (
                (x0 + x / zoom).min(p.width - 1),
                (y0 + y / zoom).min(p.height - 1),
            );
            out.set(x, y, p.get(sx, sy));
        }
    }
    out
}

/// The outline of a rectangle drawn into a picture.
pub fn outline(p: &mut Rgb8, x0: usize, y0: usize, w: usize, h: usize, colour: [u8; 3]) {
    let (x1, y1) = ((x0 + w).min(p.width) - 1, (y0 + h).min(p.height) - 1);
    for x in x0..=x1 {
        p.set(x, y0, colour);
        p.set(x, y1, colour);
    }
    for y in y0..=y1 {
        p.set(x0, y, colour);
        p.set(x1, y, colour);
    }
}

/// A picture enlarged `zoom` times (nearest neighbour).
pub fn enlarge(p: &Rgb8, zoom: usize) -> Rgb8 {
    crop(p, 0, 0, p.width, p.height, zoom)
}

/// Colour of pixels without a value on a logarithmic map (nothing to measure there).
pub const NO_VALUE: [u8; 3] = [200, 200, 215];

/// Logarithmic colour map: log10 v over [log10 lo, log10 hi] onto the verify crate's sequential
/// map (white → orange → dark red), clamped at both ends; `None` (no value) in [`NO_VALUE`].
pub fn log_colour(v: Option<f64>, lo: f64, hi: f64) -> [u8; 3] {
    match v {
        None => NO_VALUE,
        Some(v) => {
            let t = if v > 0.0 {
                (v.log10() - lo.log10()) / (hi.log10() - lo.log10())
            } else {
                0.0
            };
            sequential(t.clamp(0.0, 1.0))
        }
    }
}

/// The colour bar of [`log_colour`]: `width` × 1 pixels from lo to hi.
pub fn log_colour_bar(width: usize, lo: f64, hi: f64) -> Rgb8 {
    let mut bar = Rgb8::filled(width, 1, [0; 3]);
    for i in 0..width {
        let t = i as f64 / (width - 1).max(1) as f64;
        let v = 10f64.powf(lo.log10() + t * (hi.log10() - lo.log10()));
        bar.set(i, 0, log_colour(Some(v), lo, hi));
    }
    bar
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[f32], var: f32) -> Image {
        let mut img = Image::new(values.len(), 1);
        for (i, &v) in values.iter().enumerate() {
            img.mean[i] = [v; 3];
            img.var[i] = [var; 3];
        }
        img
    }

    #[test]
    fn rmse_subtracts_the_reference_variance() {
        let b = image(&[1.0, 1.0, 1.0, 1.0], 0.01);
        let a = image(&[1.2, 0.8, 1.2, 0.8], 0.0);
        assert!((rmse(&a, &b) - (0.04f64 - 0.01).sqrt()).abs() < 1e-6);
        // An alternating error vanishes under a wide low-pass (but for the clamped edges: 64
        // pixels, so that they weigh little); a constant one does not.
        let alternating: Vec<f32> = (0..64)
            .map(|i| if i % 2 == 0 { 1.2 } else { 0.8 })
            .collect();
        let lp = low_pass_rmse(&image(&alternating, 0.0), &image(&[1.0; 64], 0.0), 3.0);
        assert!(lp < 0.05, "{lp}");
        let c = image(&[1.1; 4], 0.0);
        assert!((low_pass_rmse(&c, &image(&[1.0; 4], 0.0), 3.0) - 0.1).abs() < 1e-6);
    }
}
