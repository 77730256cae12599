//! The contact test: pixels within ~2 px of where a light touches or pierces a surface (listed
//! by the renderer in the header `contact_pixels`). There the oracle's finite-radius bias is
//! largest (it shrinks like R·ln(1/R)), and emitter sampling by area has infinite variance, so
//! these pixels are left out of the other tests and tested here against a relative allowance
//! a = c·R·ln(1/R): a pixel differs if |m_A − m_B| exceeds a·|m_B| by more than noise
//! (one-sided Welch t on the excess, two-sided in the sign of the difference), Bonferroni over
//! the contact pixels of a channel.

// `!(x > 0.0)` is deliberate: it treats NaN as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use linlight_imagefile::{parse_pixel_list, Image, KEY_CONTACT_PIXELS, KEY_RADIUS};
use serde::{Deserialize, Serialize};

use super::{Failure, Region, TestKind};
use crate::z_score::{t_two_sided_p, welch_dof};

/// The union of both headers' contact pixels, sorted.
pub(super) fn contact_pixels(a: &Image, b: &Image) -> Result<Vec<[usize; 2]>, String> {
    let mut all = Vec::new();
    for (name, img) in [("A", a), ("B", b)] {
        if let Some(text) = img.meta.extra.get(KEY_CONTACT_PIXELS) {
            let list = parse_pixel_list(text, img.width, img.height)
                .map_err(|e| format!("image {name}: header {KEY_CONTACT_PIXELS}: {e}"))?;
            all.extend(list);
        }
    }
    all.sort_by_key(|&[x, y]| (y, x));
    all.dedup();
    Ok(all)
}

/// Largest light radius recorded in either header (0 if none).
fn largest_radius(a: &Image, b: &Image) -> f64 {
    [a, b]
        .iter()
        .filter_map(|img| img.meta.extra.get(KEY_RADIUS))
        .flat_map(|t| t.split([',', ';']).map(|v| v.trim().parse::<f64>().ok()))
        .flatten()
        .filter(|r| r.is_finite() && *r > 0.0)
        .fold(0.0, f64::max)
}

/// The relative allowance c·R·ln(1/R) of contact pixels (0 without a radius, or for R ≥ 1).
pub(super) fn contact_allowance(a: &Image, b: &Image, c: f64) -> f64 {
    let r = largest_radius(a, b);
    if r > 0.0 && r < 1.0 {
        c * r * (1.0 / r).ln()
    } else {
        0.0
    }
}

/// Per channel: the p-value of every contact pixel's excess over the allowance.
#[derive(Clone, Debug, Default)]
pub(super) struct ContactTally {
    /// (pixel, relative difference or None, p)
    pixels: Vec<(Region, Option<f64>, f64)>,
}

impl ContactTally {
    pub fn add(
        &mut self,
        x: usize,
        y: usize,
        (ma, mb): (f64, f64),
        (va, vb): (f64, f64),
        nu: (f64, f64),
        allowance: f64,
    ) {
        let excess = (ma - mb).abs() - allowance * mb.abs();
        let s = va + vb;
        let p = if excess > 0.0 && s > 0.0 {
            let dof = welch_dof([(va, nu.0), (vb, nu.1)]).unwrap_or(f64::INFINITY);
            t_two_sided_p(excess / s.sqrt(), dof)
        } else {
            1.0
        };
        let rel = (mb != 0.0).then(|| (ma - mb) / mb);
        self.pixels.push((Region::pixel(x, y), rel, p));
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ContactReport {
    /// Contact pixels of this channel.
    pub pixels: usize,
    /// Bonferroni-adjusted p of the worst contact pixel (None without contact pixels).
    pub p: Option<f64>,
    pub worst: Option<Region>,
    /// Relative difference at the worst pixel.
    pub worst_rel_diff: Option<f64>,
}

/// The contact test of one channel at level `alpha_test`.
pub(super) fn contact_tests(
    tally: &ContactTally,
    alpha_test: f64,
    channel: &'static str,
) -> (ContactReport, Option<Failure>) {
    let m = tally.pixels.len();
    let worst = tally
        .pixels
        .iter()
        .min_by(|x, y| x.2.total_cmp(&y.2))
        .copied();
    let p = worst.map(|w| (w.2 * m as f64).min(1.0));
    let failure = worst.zip(p).filter(|(_, p)| *p <= alpha_test).map(|(w, p)| Failure {
        test: TestKind::Contact,
        channel,
        region: Some(w.0),
        detail: format!(
            "contact pixel ({}, {}) differs beyond the finite-radius allowance: relative difference {}, p = {p:.3e} ≤ {alpha_test:.3e} (Bonferroni over {m} contact pixels)",
            w.0.x,
            w.0.y,
            w.1.map_or_else(|| "undefined".into(), |r| format!("{:+.3}%", 100.0 * r))
        ),
    });
    let report = ContactReport {
        pixels: m,
        p,
        worst: worst.map(|w| w.0),
        worst_rel_diff: worst.and_then(|w| w.1),
    };
    (report, failure)
}
