//! Per-pixel statistics of one channel: what a pixel's evidence allows (its class and the
//! variances the tile and global tests may use), its normal score z, and the two pixel-level
//! tests (Σz² against χ²(N), max|z| against its Šidák threshold).

// `!(x > 0.0)` is deliberate: it treats NaN as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use linlight_imagefile::Image;
use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

use super::{is_exact, CompareConfig, Failure, PixelReport, PixelState, Region, TestKind};
use crate::z_score::{normal_two_sided_quantile, normal_upper_tail, sidak, t_to_z, welch_dof};

/// What the classification needs to know of one image.
#[derive(Clone, Copy, Debug)]
pub(super) struct Side {
    /// Zero variances are exact (header `variance = exact`).
    pub exact: bool,
    /// Rule-of-three factor of its zero-sample-variance bound: 1/3 − 1/n for n samples per
    /// pixel (1/3 when n is unknown), never negative.
    pub zero_bound: f64,
    /// Critical value of the tail share (None: no tail channel, or too few terms).
    pub tail_critical: Option<f64>,
    /// Samples per pixel (header `spp`; 0 if unknown).
    pub samples: f64,
}

impl Side {
    pub fn of(img: &Image, heavy_tail_alpha: f64) -> Self {
        // The tail share is over dof + 1 terms (samples of one pass, or pass means).
        Self::with(img, img.meta.spp, img.meta.dof + 1.0, heavy_tail_alpha)
    }

    /// The side of an image with `n` samples per pixel whose tail share is over `terms` terms.
    fn with(img: &Image, n: u64, terms: f64, heavy_tail_alpha: f64) -> Self {
        let zero_bound = if n == 0 {
            1.0 / 3.0
        } else {
            (1.0 / 3.0 - 1.0 / n as f64).max(0.0)
        };
        Self {
            exact: is_exact(img),
            samples: n as f64,
            zero_bound,
            tail_critical: img
                .tail
                .as_ref()
                .and_then(|_| tail_share_critical(terms, heavy_tail_alpha)),
        }
    }
}

/// The side and dof of every pixel of an image. Without per-pixel sample counts
/// ([`Image::pixel_spp`]) every pixel has the image's; with them, a pixel of n samples has
/// n samples, and in a one-pass image n − 1 dof and a tail share over n terms (a multi-pass
/// image keeps its passes − 1 dof and terms).
pub(super) struct PixelSides {
    base: (Side, f64),
    /// Per distinct count: its side and dof (few distinct counts: one per budget level).
    by_count: Vec<(u32, Side, f64)>,
}

impl PixelSides {
    pub fn of(img: &Image, heavy_tail_alpha: f64) -> Self {
        let base = (Side::of(img, heavy_tail_alpha), img.meta.dof);
        let mut counts: Vec<u32> = img.pixel_spp.clone().unwrap_or_default();
        counts.sort_unstable();
        counts.dedup();
        let one_pass = img.meta.passes <= 1;
        let by_count = counts
            .into_iter()
            .map(|n| {
                let (terms, dof) = if one_pass {
                    (n as f64, n.saturating_sub(1) as f64)
                } else {
                    (img.meta.dof + 1.0, img.meta.dof)
                };
                (n, Side::with(img, n as u64, terms, heavy_tail_alpha), dof)
            })
            .collect();
        Self { base, by_count }
    }

    /// The image-wide side (the header's).
    pub fn base(&self) -> &Side {
        &self.base.0
    }

    /// Side and dof of pixel `i` of `img` (the image this was made of).
    pub fn at(&self, img: &Image, i: usize) -> (Side, f64) {
        let Some(n) = img.pixel_spp.as_ref().and_then(|s| s.get(i)) else {
            return self.base;
        };
        match self.by_count.binary_search_by_key(n, |e| e.0) {
            Ok(k) => (self.by_count[k].1, self.by_count[k].2),
            Err(_) => self.base,
        }
    }
}

/// Critical value of the tail share max_i (x_i − x̄)²/Σ(x_i − x̄)² of n normal terms at level
/// α, from Grubbs' two-sided outlier test: share = G²/(n − 1) and
/// G_crit = (n − 1)/√n · √(t²/(n − 2 + t²)), t the upper α/(2n) quantile of Student's t with
/// n − 2 dof. Under normality the share is independent of the mean (Basu), so leaving out
/// flagged pixels does not bias the z tests. None for n < 3 (no outlier test possible).
pub fn tail_share_critical(n: f64, alpha: f64) -> Option<f64> {
    if !(n >= 3.0 && n.is_finite()) {
        return None;
    }
    let t = StudentsT::new(0.0, 1.0, n - 2.0)
        .ok()?
        .inverse_cdf(1.0 - alpha / (2.0 * n));
    let t2 = t * t;
    let share = (n - 1.0) / n * t2 / (n - 2.0 + t2);
    share.is_finite().then_some(share)
}

/// Which sides have too few samples for the spread a pixel shows, for the normal approximation
/// of its mean: a sample mean of n values is close to normal only when n·p is large for the
/// rarest values that carry it, and for a rare value of probability p, CV² = σ²/μ² ≈ 1/p. Under
/// the null both images average the same pixel integrand, so the larger per-sample CV² that
/// either image shows (σ̂² = v·n, n its samples per pixel) must be resolved by both:
/// side X is undersampled if n_X < k·CV² (k = 10: n·p ≥ 10). A side with unknown n (spp = 0)
/// or exact values is never undersampled.
///
/// μ is the inverse-variance weighted mean (m_A·v_B + m_B·v_A)/(v_A + v_B), which under the
/// null is independent of the difference m_A − m_B.
pub(super) fn undersampled(
    (ma, mb): (f64, f64),
    (va, vb): (f64, f64),
    (sa, sb): (&Side, &Side),
    k: f64,
) -> (bool, bool) {
    let s = va + vb;
    if !(s > 0.0) {
        return (false, false);
    }
    let mu = (ma * vb + mb * va) / s;
    if mu == 0.0 || !mu.is_finite() {
        return (false, false);
    }
    let known = |side: &Side| side.samples > 0.0 && !side.exact;
    let cv2 = |v: f64, side: &Side| known(side).then(|| v * side.samples / (mu * mu));
    let Some(worst) = [cv2(va, sa), cv2(vb, sb)]
        .into_iter()
        .flatten()
        .max_by(f64::total_cmp)
    else {
        return (false, false);
    };
    let under = |side: &Side| known(side) && side.samples < k * worst;
    (under(sa), under(sb))
}

/// Rule of three for samples a render did not see below its bulk: n samples do not exclude an
/// event of probability p ≤ 3/n, and for non-negative radiance an event below the bulk lies at
/// most |m| below it. Such an event adds up to p·m² per sample, 3·m²/n² to the variance of the
/// mean — a floor that matters only at low sample counts (relative standard error √3/n: 0.7 %
/// at 256 spp, 0.005 % at 32 768). Typical case: a lit pixel with a small shadowed sliver that
/// 256 samples missed — its mean is high and its sample variance far too small. Exact images
/// and images of unknown n are left alone.
fn unseen_floor(v: f64, m: f64, side: &Side) -> f64 {
    if side.exact || !(side.samples > 0.0) {
        return v;
    }
    v.max(3.0 * m * m / (side.samples * side.samples))
}

/// The variance of the lower side under the null. A pixel mean of non-negative samples carried
/// by rare bright values is compound-Poisson-like: its variance grows with its mean, so a side
/// that came out low (it met few of them) also estimated a variance too small for the null
/// mean, and its t has a heavy lower tail (measured: an unbiased 256-spp render at 46 % of the
/// reference at one pixel, |z| = 5.3). As in a score test, the lower side's variance is taken
/// at the null mean, v·(m_high/m_low) — where that side's samples are in that regime: per-sample
/// CV² = v·n/m_low² ≥ 1 (σ ≥ μ, for non-negative samples a strong right skew), n known. Both
/// means must be positive. Only ever raises; near-normal pixels are left as they are.
fn null_variances(
    (ma, mb): (f64, f64),
    (va, vb): (f64, f64),
    (sa, sb): (&Side, &Side),
) -> (f64, f64) {
    if !(ma > 0.0 && mb > 0.0) {
        return (va, vb);
    }
    let skewed = |v: f64, m: f64, s: &Side| !s.exact && s.samples > 0.0 && v * s.samples >= m * m;
    if ma < mb && skewed(va, ma, sa) {
        (va * (mb / ma), vb)
    } else if mb < ma && skewed(vb, mb, sb) {
        (va, vb * (ma / mb))
    } else {
        (va, vb)
    }
}

/// The variance an undersampled side is given: at least the other side's per-sample variance
/// spread over this side's samples, v_X ≥ v_Y·n_Y/n_X — "it could be as spread as the other
/// image shows, and its samples did not see it". Only ever raises a variance, so |z| only
/// shrinks: the pixel stays in every test, conservatively, and no selection on the estimated
/// variance can inflate Σz².
fn floored(v: f64, own: &Side, other_v: f64, other: &Side) -> f64 {
    if own.samples > 0.0 && other.samples > 0.0 {
        v.max(other_v * other.samples / own.samples)
    } else {
        v
    }
}

/// A pixel-channel after classification.
#[derive(Clone, Copy, Debug)]
pub(super) struct Classified {
    pub state: PixelState,
    /// Normal score (None where v_A + v_B = 0 after the bound).
    pub z: Option<f64>,
    /// Variances for the tile and global sums: always the images' own estimates. They are
    /// unbiased pixel by pixel, so their sum is unbiased for a tile's or the image's variance,
    /// and those means are close to normal over many pixels; the floors and bounds below are for
    /// single pixels only.
    pub var: (f64, f64),
    /// Heavy tail flagged in A, in B.
    pub heavy_tail: (bool, bool),
}

/// What the evidence of one pixel-channel allows (module documentation of `image_stats`).
pub(super) fn classify(
    (ma, mb): (f64, f64),
    (va, vb): (f64, f64),
    (ta, tb): (Option<f64>, Option<f64>),
    (sa, sb): &(Side, Side),
    nu: (f64, f64),
    cfg: &CompareConfig,
) -> Classified {
    let agree = exact_values_agree(ma, mb, cfg.zero_var_abs, cfg.zero_var_rel);
    let unexact_zero = |v: f64, s: &Side| v == 0.0 && !s.exact;
    if unexact_zero(va, sa) || unexact_zero(vb, sb) || (va == 0.0 && vb == 0.0) {
        if agree && va == 0.0 && vb == 0.0 {
            return Classified {
                state: PixelState::ZeroVarAgree,
                z: None,
                var: (0.0, 0.0),
                heavy_tail: (false, false),
            };
        }
        if va == 0.0 && vb == 0.0 && sa.exact && sb.exact {
            return Classified {
                state: PixelState::ZeroVarMismatch,
                z: None,
                var: (0.0, 0.0),
                heavy_tail: (false, false),
            };
        }
        // A zero sample variance: bound it from below by the rule of three.
        let d2 = (ma - mb) * (ma - mb);
        let bound = |v: f64, s: &Side| {
            if unexact_zero(v, s) {
                d2 * s.zero_bound
            } else {
                v
            }
        };
        let (ba, bb) = (bound(va, sa), bound(vb, sb));
        return Classified {
            state: PixelState::ZeroSampleVariance,
            z: pixel_z(ma, mb, ba, bb, nu),
            var: (va, vb),
            heavy_tail: (false, false),
        };
    }
    let raw = (va, vb);
    // Unseen dark samples: at least their rule-of-three variance (a floor, only ever raises).
    let (va, vb) = (unseen_floor(va, ma, sa), unseen_floor(vb, mb, sb));
    let (va, vb) = null_variances((ma, mb), (va, vb), (sa, sb));
    let under = undersampled((ma, mb), (va, vb), (sa, sb), cfg.samples_per_cv2);
    if under.0 || under.1 {
        let va2 = if under.0 { floored(va, sa, vb, sb) } else { va };
        let vb2 = if under.1 { floored(vb, sb, va, sa) } else { vb };
        return Classified {
            state: PixelState::Undersampled,
            z: pixel_z(ma, mb, va2, vb2, nu),
            var: raw,
            heavy_tail: (false, false),
        };
    }
    let z = pixel_z(ma, mb, va, vb, nu);
    let flagged = |t: Option<f64>, s: &Side| {
        t.zip(s.tail_critical)
            .is_some_and(|(share, crit)| share > crit)
    };
    let heavy_tail = (flagged(ta, sa), flagged(tb, sb));
    Classified {
        state: if heavy_tail.0 || heavy_tail.1 {
            PixelState::HeavyTail
        } else {
            PixelState::Tested
        },
        z,
        var: raw,
        heavy_tail,
    }
}

/// z = Φ⁻¹(F_t(t; ν_W)) of the difference m_A − m_B with t = (m_A − m_B)/√(v_A + v_B) and the
/// Welch–Satterthwaite dof; None when v_A + v_B = 0.
pub(super) fn pixel_z(ma: f64, mb: f64, va: f64, vb: f64, nu: (f64, f64)) -> Option<f64> {
    let s = va + vb;
    (s > 0.0).then(|| {
        let dof = welch_dof([(va, nu.0), (vb, nu.1)]).unwrap_or(f64::INFINITY);
        t_to_z((ma - mb) / s.sqrt(), dof)
    })
}

/// Whether two exact (zero-variance) values agree: |m_A − m_B| ≤ ε_abs + ε_rel·max(|m_A|, |m_B|).
pub(super) fn exact_values_agree(ma: f64, mb: f64, eps_abs: f64, eps_rel: f64) -> bool {
    (ma - mb).abs() <= eps_abs + eps_rel * ma.abs().max(mb.abs())
}

/// Running Σz², count and max|z| of the tested pixels of one channel.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ZTally {
    pub tested: usize,
    pub sum_z2: f64,
    pub max_abs_z: f64,
    pub max_at: Option<Region>,
}

impl ZTally {
    pub fn add(&mut self, z: f64, x: usize, y: usize) {
        self.sum_z2 += z * z;
        self.tested += 1;
        if z.abs() > self.max_abs_z || self.max_at.is_none() {
            self.max_abs_z = z.abs();
            self.max_at = Some(Region {
                x,
                y,
                width: 1,
                height: 1,
            });
        }
    }
}

/// Σz² against χ²(tested) and max|z| against the Šidák threshold over the tested pixels, each
/// at level `alpha_test`.
pub(super) fn pixel_tests(
    tally: &ZTally,
    alpha_test: f64,
    channel: &'static str,
) -> (PixelReport, Vec<Failure>) {
    let ZTally {
        tested,
        sum_z2,
        max_abs_z,
        max_at,
    } = *tally;
    let z_threshold = normal_two_sided_quantile(sidak(alpha_test, tested.max(1)));
    let (chi2_p, max_p) = if tested > 0 {
        let chi2_p = ChiSquared::new(tested as f64)
            .ok()
            .map(|d| d.sf(sum_z2).clamp(0.0, 1.0));
        let p_min = (2.0 * normal_upper_tail(max_abs_z)).min(1.0);
        let max_p = -(tested as f64 * (-p_min).ln_1p()).exp_m1();
        (chi2_p, Some(max_p.clamp(0.0, 1.0)))
    } else {
        (None, None)
    };
    let mut failures = Vec::new();
    if let Some(p) = chi2_p.filter(|&p| p <= alpha_test) {
        failures.push(Failure {
            test: TestKind::PixelChiSquare,
            channel,
            region: None,
            detail: format!(
                "Σz² = {sum_z2:.1} over {tested} pixels (expected {tested} ± {:.1}), p = {p:.3e} ≤ {alpha_test:.3e}",
                (2.0 * tested as f64).sqrt()
            ),
        });
    }
    if max_p.is_some_and(|p| p <= alpha_test) {
        let at = max_at.expect("a tested pixel exists");
        failures.push(Failure {
            test: TestKind::PixelMax,
            channel,
            region: Some(at),
            detail: format!(
                "|z| = {max_abs_z:.2} at ({}, {}) exceeds the Šidák threshold {z_threshold:.2}",
                at.x, at.y
            ),
        });
    }
    let report = PixelReport {
        tested,
        sum_z2,
        chi2_p,
        max_abs_z,
        max_at,
        z_threshold,
        max_p,
    };
    (report, failures)
}
