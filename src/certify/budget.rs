//! How many samples per pixel the Rust render of a technique gets: enough that it is at least as
//! precise as the reference in (nearly) every pixel, within a cap.
//!
//! Rule. A pilot render of `pilot_spp` samples (own seed, never reused) estimates the variance of
//! one sample per pixel and channel, σ̂²_i = pilot_spp · v̂_pilot,i. A render of N samples has a
//! variance of the mean σ²_i/N, which is ≤ the reference's v_B,i when N ≥ σ²_i/v_B,i. N is the
//! `quantile` (default 0.99) of these ratios over the pixels and channels where both are
//! positive, rounded up to a multiple of `granularity`, and clamped to [min_spp, max_spp].
//! The quantile instead of the maximum: single pixels with rare large samples (near a crossing
//! or an occluder's edge) would otherwise set the budget of the whole image, while the
//! comparison's per-pixel z-scores already account for each pixel's own variance.
//! The cap keeps the run time bounded for techniques far noisier than the oracle (area
//! sampling of lights that cross the horizon); the report states the precision achieved
//! (share of pixels with v_A ≤ v_B), so a capped render is visible as such.

use linlight_imagefile::Image;
use serde::Serialize;

#[derive(Clone, Copy, Debug, Serialize)]
pub struct BudgetRule {
    pub pilot_spp: u32,
    /// Quantile of the per-pixel required spp that the budget meets.
    pub quantile: f64,
    pub min_spp: u32,
    pub max_spp: u32,
    /// The budget is a multiple of this.
    pub granularity: u32,
}

impl Default for BudgetRule {
    fn default() -> Self {
        Self {
            pilot_spp: 256,
            quantile: 0.99,
            min_spp: 256,
            max_spp: 65_536,
            granularity: 64,
        }
    }
}

/// Why a budget came out as it did.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Budget {
    pub spp: u32,
    /// The spp the rule asked for before clamping (None: no pixel with positive variances).
    pub required_spp: Option<f64>,
    /// The rule asked for more than `max_spp`.
    pub capped: bool,
}

/// Ratios σ̂²_i / v_B,i over pixels and channels where both are positive (σ̂² from an image of
/// `spp` samples per pixel in one pass: σ̂² = spp · v).
fn required_samples(pilot: &Image, spp: u32, reference: &Image) -> Vec<f64> {
    pilot
        .var
        .iter()
        .zip(&reference.var)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] as f64 * spp as f64, b[c] as f64)))
        .filter(|&(s2, vb)| s2 > 0.0 && vb > 0.0)
        .map(|(s2, vb)| s2 / vb)
        .collect()
}

/// The q-quantile (nearest rank) of unsorted values; None for an empty slice.
pub fn quantile(mut values: Vec<f64>, q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let k = ((values.len() as f64 * q).ceil() as usize).clamp(1, values.len()) - 1;
    Some(values[k])
}

impl BudgetRule {
    /// Budget from a pilot render of `self.pilot_spp` samples in one pass.
    pub fn choose(&self, pilot: &Image, reference: &Image) -> Budget {
        let required = quantile(
            required_samples(pilot, self.pilot_spp, reference),
            self.quantile,
        );
        let g = self.granularity.max(1) as f64;
        let spp = match required {
            Some(r) if r.is_finite() => (r / g).ceil() * g,
            Some(_) => f64::INFINITY,
            None => self.min_spp as f64,
        };
        Budget {
            spp: spp.clamp(self.min_spp as f64, self.max_spp as f64) as u32,
            required_spp: required,
            capped: spp > self.max_spp as f64,
        }
    }
}

/// How precise the render A is relative to the reference B, over pixels and channels where
/// both variances are positive.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Precision {
    /// Share of pixel channels with v_A ≤ v_B.
    pub at_least_as_precise: f64,
    /// Median of v_A / v_B.
    pub median_variance_ratio: Option<f64>,
}

pub fn precision(a: &Image, b: &Image) -> Precision {
    let ratios: Vec<f64> = a
        .var
        .iter()
        .zip(&b.var)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64, y[c] as f64)))
        .filter(|&(va, vb)| va > 0.0 && vb > 0.0)
        .map(|(va, vb)| va / vb)
        .collect();
    let n = ratios.len();
    let ok = ratios.iter().filter(|&&r| r <= 1.0).count();
    Precision {
        at_least_as_precise: if n == 0 { 1.0 } else { ok as f64 / n as f64 },
        median_variance_ratio: quantile(ratios, 0.5),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(var: f32) -> Image {
        let mut img = Image::new(4, 4);
        img.var.iter_mut().for_each(|v| *v = [var; 3]);
        img
    }

    #[test]
    fn budget_matches_the_reference_variance() {
        // σ² = 256 · 1e-4 = 0.0256 per sample, reference 1e-6 → 25 600 spp.
        let rule = BudgetRule::default();
        let b = rule.choose(&flat(1e-4), &flat(1e-6));
        assert_eq!(b.spp, 25_600);
        assert!(!b.capped);
        let capped = BudgetRule {
            max_spp: 1024,
            ..rule
        }
        .choose(&flat(1e-4), &flat(1e-6));
        assert_eq!((capped.spp, capped.capped), (1024, true));
        // Nothing to match (all black): the minimum.
        assert_eq!(rule.choose(&flat(0.0), &flat(1e-6)).spp, rule.min_spp);
    }

    #[test]
    fn quantile_ignores_rare_outliers() {
        let mut v = vec![1.0; 999];
        v.push(1e9);
        assert_eq!(quantile(v.clone(), 0.99), Some(1.0));
        assert_eq!(quantile(v, 1.0), Some(1e9));
        assert_eq!(quantile(vec![], 0.5), None);
    }

    #[test]
    fn precision_counts_pixels() {
        let p = precision(&flat(1e-6), &flat(2e-6));
        assert_eq!(p.at_least_as_precise, 1.0);
        assert_eq!(p.median_variance_ratio, Some(0.5));
    }
}
