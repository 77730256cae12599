//! PNG pictures of a comparison: per-pixel z heat map, tile p-value map, and an
//! `A | B | difference` preview. All pictures have row 0 at the top, like the images.

use std::path::Path;

use linlight_imagefile::{srgb8, write_rgb8_png, Image, ImageError};

use crate::image_stats::{Comparison, PixelState};

/// |z| at which the diverging z colour map saturates.
pub const Z_RANGE: f64 = 5.0;
/// Tile p-values are shown on −log10 p ∈ [0, P_DECADES]; smaller p saturates.
pub const P_DECADES: f64 = 8.0;
/// Width of the white gap between panels.
const GAP: usize = 4;

/// An 8-bit RGB picture, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb8 {
    pub width: usize,
    pub height: usize,
    pub data: Vec<u8>,
}

impl Rgb8 {
    pub fn filled(width: usize, height: usize, c: [u8; 3]) -> Self {
        Self {
            width,
            height,
            data: c.repeat(width * height),
        }
    }
    pub fn get(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * self.width + x);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }
    pub fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        let i = 3 * (y * self.width + x);
        self.data[i..i + 3].copy_from_slice(&c);
    }
    pub fn write_png(&self, path: &Path) -> Result<(), ImageError> {
        write_rgb8_png(path, self.width, self.height, &self.data)
    }

    /// Panels left to right with white gaps, top-aligned.
    pub fn hstack(panels: &[&Rgb8]) -> Rgb8 {
        let height = panels.iter().map(|p| p.height).max().unwrap_or(0);
        let width =
            panels.iter().map(|p| p.width).sum::<usize>() + GAP * panels.len().saturating_sub(1);
        let mut out = Rgb8::filled(width, height, [255; 3]);
        let mut x0 = 0;
        for p in panels {
            for y in 0..p.height {
                for x in 0..p.width {
                    out.set(x0 + x, y, p.get(x, y));
                }
            }
            x0 += p.width + GAP;
        }
        out
    }
}

fn lerp(a: [f64; 3], b: [f64; 3], t: f64) -> [u8; 3] {
    let c = |i: usize| (a[i] + (b[i] - a[i]) * t).round().clamp(0.0, 255.0) as u8;
    [c(0), c(1), c(2)]
}

/// Diverging blue–white–red map of s ∈ [−1, 1] (ColorBrewer RdBu end points); NaN → white.
pub fn diverging(s: f64) -> [u8; 3] {
    const BLUE: [f64; 3] = [33.0, 102.0, 172.0];
    const WHITE: [f64; 3] = [247.0, 247.0, 247.0];
    const RED: [f64; 3] = [178.0, 24.0, 43.0];
    let s = if s.is_nan() { 0.0 } else { s.clamp(-1.0, 1.0) };
    if s < 0.0 {
        lerp(WHITE, BLUE, -s)
    } else {
        lerp(WHITE, RED, s)
    }
}

/// Sequential white–orange–dark red map of s ∈ [0, 1]; NaN → white.
pub fn sequential(s: f64) -> [u8; 3] {
    const WHITE: [f64; 3] = [255.0, 255.0, 255.0];
    const ORANGE: [f64; 3] = [253.0, 141.0, 60.0];
    const DARK: [f64; 3] = [103.0, 0.0, 13.0];
    let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, 1.0) };
    if s < 0.5 {
        lerp(WHITE, ORANGE, 2.0 * s)
    } else {
        lerp(ORANGE, DARK, 2.0 * s - 1.0)
    }
}

/// Colour of tested pixels whose both images have zero variance and agree.
pub const ZERO_VAR_AGREE: [u8; 3] = [160, 160, 160];
/// Colour of zero-variance pixels that disagree (a failure).
pub const ZERO_VAR_MISMATCH: [u8; 3] = [0, 200, 0];
/// Colour of pixels the pixel tests leave out (zero sample variance, heavy tail).
pub const UNDECIDABLE: [u8; 3] = [190, 170, 225];
/// Colour of pixels near a light–surface contact (tested apart).
pub const CONTACT: [u8; 3] = [255, 200, 0];
/// Colour of tiles that were not tested (no variance).
pub const UNTESTED_TILE: [u8; 3] = [160, 160, 160];

/// Per pixel the signed z of the channel with the largest |z| on a diverging map saturating at
/// |z| = Z_RANGE (for display only: the tests never merge channels); zero-variance pixels grey
/// (agree) or green (exact values that disagree, in any channel), contact pixels amber, pixels
/// the pixel tests leave out lavender.
pub fn z_heatmap(cmp: &Comparison) -> Rgb8 {
    let (w, h) = (cmp.width, cmp.height);
    let mut out = Rgb8::filled(w, h, [255; 3]);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let states = cmp.maps.state[i];
            let left_out = |s: &PixelState| {
                matches!(s, PixelState::ZeroSampleVariance | PixelState::HeavyTail)
            };
            let colour = if states.contains(&PixelState::ZeroVarMismatch) {
                ZERO_VAR_MISMATCH
            } else if states.contains(&PixelState::Contact) {
                CONTACT
            } else if states.iter().all(|s| *s == PixelState::ZeroVarAgree) {
                ZERO_VAR_AGREE
            } else if states.iter().any(left_out) {
                UNDECIDABLE
            } else {
                let z = cmp.maps.z[i]
                    .iter()
                    .copied()
                    .max_by(|a, b| a.abs().total_cmp(&b.abs()))
                    .unwrap_or(0.0);
                diverging(z as f64 / Z_RANGE)
            };
            out.set(x, y, colour);
        }
    }
    out
}

/// Per pixel the smallest Holm-adjusted p over channels and over the tiles covering it (one per
/// grid), −log10 p on a sequential map (white = 1, dark red ≤ 10^−P_DECADES); pixels in no
/// tested tile grey; every rejected tile outlined in black.
pub fn tile_heatmap(cmp: &Comparison) -> Rgb8 {
    let (w, h) = (cmp.width, cmp.height);
    let mut best: Vec<Option<f64>> = vec![None; w * h];
    let mut rejected = Vec::new();
    for (r, ps) in &cmp.maps.tiles {
        let Some(p) = ps.iter().flatten().copied().min_by(f64::total_cmp) else {
            continue;
        };
        if p <= cmp.alpha_test {
            rejected.push(*r);
        }
        for y in r.y..(r.y + r.height).min(h) {
            for x in r.x..(r.x + r.width).min(w) {
                let b = &mut best[y * w + x];
                *b = Some(b.map_or(p, |q| q.min(p)));
            }
        }
    }
    let mut out = Rgb8::filled(w, h, UNTESTED_TILE);
    for (i, p) in best.iter().enumerate() {
        if let Some(p) = p {
            let decades = -(p.max(1e-300)).log10();
            out.set(i % w, i / w, sequential(decades / P_DECADES));
        }
    }
    for r in rejected {
        let (x1, y1) = ((r.x + r.width).min(w), (r.y + r.height).min(h));
        for y in r.y..y1 {
            for x in r.x..x1 {
                if x == r.x || y == r.y || x + 1 == x1 || y + 1 == y1 {
                    out.set(x, y, [0; 3]);
                }
            }
        }
    }
    out
}

/// `z map | tile map`, the picture `linlight compare --heatmap` writes.
pub fn comparison_heatmap(cmp: &Comparison) -> Rgb8 {
    Rgb8::hstack(&[&z_heatmap(cmp), &tile_heatmap(cmp)])
}

/// `A | B | difference`: A and B tone-mapped (exposure 1, clamp, sRGB); the difference is the
/// signed luminance difference Y_A − Y_B on the diverging map, saturating at `scale`. If
/// `scale` is None it is the 99th percentile of |Y_A − Y_B| (so a few outliers do not wash out
/// the picture). Returns the picture and the scale used. Sizes must match.
pub fn side_by_side(a: &Image, b: &Image, scale: Option<f64>) -> Result<(Rgb8, f64), ImageError> {
    if (a.width, a.height) != (b.width, b.height) || a.width == 0 || a.height == 0 {
        return Err(ImageError::Format(format!(
            "side-by-side needs equal non-empty sizes, got {}×{} and {}×{}",
            a.width, a.height, b.width, b.height
        )));
    }
    a.validate()?;
    b.validate()?;
    let (w, h) = (a.width, a.height);
    let lum = |p: [f32; 3]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
    let diff: Vec<f64> = a
        .mean
        .iter()
        .zip(&b.mean)
        .map(|(x, y)| lum(*x) - lum(*y))
        .collect();
    let scale = scale
        .filter(|s| *s > 0.0 && s.is_finite())
        .unwrap_or_else(|| {
            let mut mags: Vec<f64> = diff.iter().map(|d| d.abs()).collect();
            mags.sort_by(f64::total_cmp);
            let q = mags[((mags.len() - 1) as f64 * 0.99).round() as usize];
            if q > 0.0 {
                q
            } else {
                mags.last().copied().filter(|m| *m > 0.0).unwrap_or(1.0)
            }
        });
    let tone = |img: &Image| {
        let mut p = Rgb8::filled(w, h, [0; 3]);
        for (i, m) in img.mean.iter().enumerate() {
            p.set(i % w, i / w, [srgb8(m[0]), srgb8(m[1]), srgb8(m[2])]);
        }
        p
    };
    let mut d = Rgb8::filled(w, h, [0; 3]);
    for (i, v) in diff.iter().enumerate() {
        d.set(i % w, i / w, diverging(v / scale));
    }
    Ok((Rgb8::hstack(&[&tone(a), &tone(b), &d]), scale))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_stats::{compare, CompareConfig};

    fn flat(w: usize, h: usize, m: f32, v: f32) -> Image {
        let mut img = Image::new(w, h);
        img.mean.iter_mut().for_each(|p| *p = [m; 3]);
        img.var.iter_mut().for_each(|p| *p = [v; 3]);
        img.meta.dof = 31.0;
        img
    }

    #[test]
    fn colour_maps_hit_their_end_points() {
        assert_eq!(diverging(0.0), [247, 247, 247]);
        assert_eq!(diverging(-7.0), [33, 102, 172]);
        assert_eq!(diverging(1.0), [178, 24, 43]);
        assert_eq!(diverging(f64::NAN), [247, 247, 247]);
        assert_eq!(sequential(0.0), [255, 255, 255]);
        assert_eq!(sequential(1.0), [103, 0, 13]);
    }

    #[test]
    fn heat_maps_mark_the_differing_region() {
        let a = flat(40, 20, 1.0, 1e-4);
        let mut b = flat(40, 20, 1.0, 1e-4);
        // The second tile 1 σ off (tile t = 16), one pixel in it 30 σ off, and a
        // zero-variance pixel that disagrees.
        let sigma = (2e-4f32).sqrt();
        for y in 0..16 {
            for x in 16..32 {
                b.mean[y * 40 + x] = [1.0 + sigma; 3];
            }
        }
        b.mean[5 * 40 + 20] = [1.0 + 30.0 * sigma; 3];
        let mut a2 = a.clone();
        a2.var[0] = [0.0; 3];
        b.var[0] = [0.0; 3];
        b.mean[0] = [2.0; 3];
        // Zero variances are exact only in exact images.
        for img in [&mut a2, &mut b] {
            img.meta.extra.insert("variance".into(), "exact".into());
        }
        let cmp = compare(&a2, &b, &CompareConfig::default()).unwrap();
        let z = z_heatmap(&cmp);
        assert_eq!((z.width, z.height), (40, 20));
        assert_eq!(z.get(0, 0), ZERO_VAR_MISMATCH);
        assert_eq!(z.get(20, 5), diverging(-1.0)); // A − B < 0: saturated blue
        let tiles = tile_heatmap(&cmp);
        assert_eq!(tiles.get(16, 0), [0; 3], "rejected tile is outlined");
        // (0, 0) is the mismatching zero-variance pixel, which also shifts its tiles' means;
        // (5, 18) lies in untouched tiles of both grids.
        assert_ne!(tiles.get(5, 18), tiles.get(20, 5));
        assert_eq!(
            tiles.get(5, 18)[0],
            255,
            "untouched tiles stay light: {:?}",
            tiles.get(5, 18)
        );
        let both = comparison_heatmap(&cmp);
        assert_eq!((both.width, both.height), (84, 20));
        let path = std::env::temp_dir().join(format!("linlight-heat-{}.png", std::process::id()));
        both.write_png(&path).unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() > 8);
    }

    #[test]
    fn side_by_side_layout_and_scale() {
        let a = flat(8, 4, 0.5, 0.0);
        let mut b = flat(8, 4, 0.5, 0.0);
        b.mean[3] = [0.25; 3];
        let (pic, scale) = side_by_side(&a, &b, None).unwrap();
        assert_eq!((pic.width, pic.height), (3 * 8 + 2 * GAP, 4));
        assert_eq!(pic.get(0, 0), [188; 3]);
        assert!((scale - 0.25).abs() < 1e-6, "{scale}");
        assert_eq!(pic.get(2 * (8 + GAP) + 3, 0), diverging(1.0));
        assert!(side_by_side(&a, &flat(4, 4, 0.5, 0.0), None).is_err());
    }
}
