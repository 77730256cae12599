//! Statistical comparison of two images with per-pixel variance of the mean. The method, its
//! assumptions and every rule below are documented for users in `docs/statistics.md`.
//!
//! Model: every pixel and channel of image X holds a mean m_X and an unbiased estimate v_X of
//! the variance of that mean, with ν_X degrees of freedom (header `dof`). Pixels are independent
//! (box reconstruction filter, independent samples); the channels R, G, B of a pixel are *not*
//! (they come from the same samples), so nothing here combines channels as independent: the
//! tests of the three channels are joined by Bonferroni, which holds under any dependence.
//! B is the reference (the oracle): relative differences are (Ḡ_A − Ḡ_B)/Ḡ_B.
//!
//! Null hypothesis of the difference tests: E\[m_A\] = E\[m_B\] everywhere. They run on three
//! scales, four tests per channel (five with light–surface contacts):
//!   a. global mean per channel (Welch t-test on the image mean),
//!   b. tile means (Welch t-tests, Holm over the tiles of a channel; two grids, the second
//!      shifted by half a tile, so that an unaligned t×t region is still mostly in one tile),
//!   c. pixels: Σz² against χ²(N), and max|z| against its Šidák threshold (pixels are
//!      independent, so Šidák is exact over pixels),
//!   d. contact pixels (within ~2 px of where a light touches a surface): the relative
//!      difference may exceed the oracle's finite-radius allowance c·R·ln(1/R) only by noise,
//! each at the Bonferroni level α_test = α/(tests · 3).
//!
//! Equivalence (a different null: |relative difference| ≥ δ): the confidence intervals of the
//! three channels' relative global difference, each at level 1 − α/3, must lie within [−δ, δ].
//! If no difference test rejects but equivalence is not shown, the verdict is INCONCLUSIVE (too
//! noisy to tell), with the side that limits the precision and the samples needed.
//!
//! Pixels whose evidence the per-pixel tests cannot use are classified, counted and left out
//! of those tests (never silently trusted):
//! - zero sample variance in a sampled (not exact) image with values that differ: a variance of
//!   0 from n samples does not exclude rare samples of probability ≤ 3/n (rule of three); under
//!   the null they can carry the whole difference Δ, which bounds the variance of that mean
//!   below by Δ²·(1/3 − 1/n). The tile and global tests use this bound; the pixel is
//!   undecidable on its own (|z| ≤ √3 with the bound).
//! - undersampled: a side with fewer than k·CV² samples per pixel (CV² the larger per-sample
//!   squared coefficient of variation either image shows) may have missed the rare samples that
//!   carry the mean; its variance is floored at the other side's per-sample variance over its
//!   sample count, and the pixel stays in every test (only ever more conservative).
//! - unseen dark samples: n samples do not exclude an event of probability ≤ 3/n below the
//!   bulk, at most |m| deep for non-negative radiance: every sampled variance is floored at
//!   3·m²/n² (only relevant at low n).
//! - the lower side's variance at the null mean: v·(m_high/m_low) (compound-Poisson-like
//!   pixel means have a variance that grows with the mean).
//! - heavy tails: the image's `tail` channel (share of the sum of squares from its largest
//!   term) above the Grubbs critical value of a normal sample of the same size at level
//!   `heavy_tail_alpha`: the variance rests on a few terms and is not trusted pixel by pixel.
//! - contact pixels: tested apart (d.), left out of a–c.
//!
//! Exact images (header `variance = exact`, e.g. the closed form) have true zero variances;
//! two exact values must agree to ε.

// `!(x > 0.0)` is deliberate throughout: it treats NaN as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod contacts;
mod global;
mod metrics;
mod pixels;
mod precision;
mod sums;
mod tiles;

use linlight_imagefile::Image;
use serde::{Deserialize, Serialize};

use contacts::{contact_allowance, contact_pixels, contact_tests, ContactTally};
use global::{global_tests, GlobalLevels};
use pixels::{classify, pixel_tests, PixelSides, ZTally};
use sums::Sums;
use tiles::{tile_tests, TileGrids};

pub use contacts::ContactReport;
pub use metrics::{error_metrics, ErrorMetrics};
pub use precision::PrecisionHint;
pub use tiles::holm_adjust;

/// Channel names in RGB order.
pub const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Number of difference tests per channel without contact pixels (global, tiles, Σz², max|z|).
pub const TESTS_PER_CHANNEL: usize = 4;

/// Header key (string) of an image whose variances are exact: value `exact`.
pub const KEY_VARIANCE: &str = "variance";

/// Parameters of [`compare`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CompareConfig {
    /// Family-wise significance level of the whole comparison.
    pub alpha: f64,
    /// Equivalence margin δ on the relative global difference.
    pub tolerance: f64,
    /// Tile edge length in pixels.
    pub tile: usize,
    /// Also test the tile grid shifted by half a tile (Holm then runs over both grids).
    pub shifted_tiles: bool,
    /// Absolute agreement required of two exact zero-variance values.
    pub zero_var_abs: f64,
    /// Relative agreement required of two exact zero-variance values.
    pub zero_var_rel: f64,
    /// Per-pixel level of the heavy-tail flag (Grubbs critical value of the tail share).
    pub heavy_tail_alpha: f64,
    /// c of the contact allowance c·R·ln(1/R) on the relative difference of contact pixels.
    pub contact_coefficient: f64,
    /// k of the sample-count rule: a pixel is tested only if both images have at least
    /// k·CV² samples, CV² the larger per-sample squared coefficient of variation either shows.
    pub samples_per_cv2: f64,
    /// Compare images whose `scene_sha256` differ (refused otherwise).
    pub allow_different_scenes: bool,
}

impl Default for CompareConfig {
    fn default() -> Self {
        Self {
            alpha: 0.01,
            tolerance: 0.005,
            tile: 16,
            shifted_tiles: true,
            zero_var_abs: 1e-6,
            zero_var_rel: 1e-5,
            heavy_tail_alpha: 1e-3,
            contact_coefficient: 20.0,
            samples_per_cv2: 10.0,
            allow_different_scenes: false,
        }
    }
}

/// The inputs cannot be compared (exit code 2 territory).
#[derive(Debug, Clone, PartialEq)]
pub enum CompareError {
    Unusable(String),
}

impl std::fmt::Display for CompareError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CompareError::Unusable(m) => f.write_str(m),
        }
    }
}
impl std::error::Error for CompareError {}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Verdict {
    /// No difference test rejects and equivalence within ±δ is shown.
    Consistent,
    /// A difference test rejects.
    Different,
    /// No difference test rejects, but the images are too noisy to show equivalence.
    Inconclusive,
}

impl Verdict {
    /// Upper-case name as printed (CONSISTENT, DIFFERENT, INCONCLUSIVE).
    pub fn label(self) -> &'static str {
        match self {
            Verdict::Consistent => "CONSISTENT",
            Verdict::Different => "DIFFERENT",
            Verdict::Inconclusive => "INCONCLUSIVE",
        }
    }

    /// Exit code of `linlight compare` (and of certify's worst row): 0, 1, or 3.
    pub fn exit_code(self) -> u8 {
        match self {
            Verdict::Consistent => 0,
            Verdict::Different => 1,
            Verdict::Inconclusive => 3,
        }
    }
}

/// Which test rejected (or, for `Equivalence`, was not shown).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TestKind {
    /// Two exact zero-variance values disagree beyond ε.
    ZeroVariance,
    /// Global mean difference is significant.
    GlobalMean,
    /// The confidence interval of the relative difference is not within ±δ.
    Equivalence,
    /// At least one tile mean differs (Holm).
    Tile,
    /// Σz² too large for χ²(N).
    PixelChiSquare,
    /// max|z| beyond the Šidák threshold.
    PixelMax,
    /// A contact pixel differs beyond the finite-radius allowance.
    Contact,
}

/// A pixel (width = height = 1) or a tile rectangle; x to the right, y down, (0, 0) top left.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Region {
    pub x: usize,
    pub y: usize,
    pub width: usize,
    pub height: usize,
}

impl Region {
    pub fn pixel(x: usize, y: usize) -> Self {
        Self {
            x,
            y,
            width: 1,
            height: 1,
        }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Failure {
    pub test: TestKind,
    #[serde(deserialize_with = "static_name")]
    pub channel: StaticName,
    pub region: Option<Region>,
    pub detail: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GlobalReport {
    pub mean_a: f64,
    pub mean_b: f64,
    /// mean_a − mean_b and its standard error.
    pub diff: f64,
    pub std_err: f64,
    /// Welch–Satterthwaite dof of the standard error (None if it is 0).
    pub dof: Option<f64>,
    /// Two-sided p of the difference (None if std_err = 0: then only the zero-variance check).
    pub p: Option<f64>,
    pub significant: bool,
    /// (mean_a − mean_b) / mean_b; None if mean_b = 0 and the means differ.
    pub rel_diff: Option<f64>,
    /// Confidence interval of rel_diff at level 1 − α/3 (delta method, t quantile).
    pub rel_ci: Option<[f64; 2]>,
    pub equivalent: bool,
    /// Variance of rel_diff from A and from B (delta method); what limits the precision.
    pub rel_var_a: f64,
    pub rel_var_b: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TileResult {
    pub region: Region,
    pub mean_diff: f64,
    pub std_err: f64,
    pub dof: f64,
    pub p: f64,
    /// Holm-adjusted p over the tested tiles of this channel.
    pub p_holm: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TileReport {
    pub tiles_total: usize,
    /// Tiles with positive variance (the others hold only zero-variance pixels).
    pub tiles_tested: usize,
    pub rejected: usize,
    /// The tile with the smallest Holm-adjusted p.
    pub worst: Option<TileResult>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PixelReport {
    /// Pixels of this channel in the pixel tests (state `Tested`).
    pub tested: usize,
    pub sum_z2: f64,
    /// P(χ²(tested) ≥ sum_z2).
    pub chi2_p: Option<f64>,
    pub max_abs_z: f64,
    pub max_at: Option<Region>,
    /// The Šidák threshold on max|z| at α_test.
    pub z_threshold: f64,
    /// Šidák-adjusted p of max|z|: 1 − (1 − p_min)^tested.
    pub max_p: Option<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ChannelReport {
    #[serde(deserialize_with = "static_name")]
    pub channel: StaticName,
    pub global: GlobalReport,
    pub tiles: TileReport,
    pub pixels: PixelReport,
    pub contacts: ContactReport,
}

/// Pixel-channels by what was done with them (they add up to 3 × pixels).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct PixelClasses {
    /// In every test.
    pub tested: usize,
    /// Zero variance on both sides and equal values: no information, no test.
    pub zero_variance_agree: usize,
    /// Two exact values that disagree (a failure).
    pub exact_mismatch: usize,
    /// Zero sample variance in a sampled image with differing values: rule-of-three bound in
    /// tiles and global, undecidable on its own.
    pub zero_sample_variance: usize,
    /// Too few samples for the pixel's spread (n < k·CV² in A or B): tested with that side's
    /// variance floored at the other side's per-sample variance over its samples.
    pub undersampled: usize,
    /// Heavy-tailed (tail share above its critical value in A or B): tiles and global only.
    pub heavy_tail_a: usize,
    pub heavy_tail_b: usize,
    /// Within ~2 px of a light–surface contact: the contact test only.
    pub contact: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ZeroVarianceReport {
    /// Pixel-channels with v_A + v_B = 0.
    pub count: usize,
    /// Exact values that disagree.
    pub mismatched: usize,
    /// Pixel-channels where exactly one sampled image has zero variance.
    pub one_sided: usize,
    /// The worst mismatch: region, channel, both means.
    #[serde(deserialize_with = "static_name_in_mismatch")]
    pub worst: Option<(Region, &'static str, f64, f64)>,
}

/// Per pixel and channel: what was done with it (for heat maps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelState {
    Tested,
    ZeroVarAgree,
    ZeroVarMismatch,
    /// Zero sample variance with differing values (rule-of-three bound, undecidable).
    ZeroSampleVariance,
    /// Heavy tail flagged in A or B.
    HeavyTail,
    /// Too few samples for the spread the pixel shows (n < k·CV² in A or B): tested with a
    /// floored variance.
    Undersampled,
    /// Near a light–surface contact.
    Contact,
}

/// Full-resolution maps behind the report (not serialised).
#[derive(Clone, Debug, Default)]
pub struct Maps {
    /// Normal score per pixel and channel (0 where v_A + v_B = 0), |z| ≤ Z_MAX.
    pub z: Vec<[f32; 3]>,
    pub state: Vec<[PixelState; 3]>,
    /// Every tile of both grids with its Holm-adjusted p per channel (None: not tested).
    pub tiles: Vec<(Region, [Option<f64>; 3])>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Comparison {
    pub verdict: Verdict,
    /// Difference tests that rejected (the verdict is DIFFERENT iff there is one).
    pub failures: Vec<Failure>,
    /// Channels whose equivalence within ±δ was not shown (TestKind::Equivalence).
    pub not_equivalent: Vec<Failure>,
    /// When equivalence was not shown: which image limits the precision, samples needed.
    pub precision: Option<PrecisionHint>,
    pub width: usize,
    pub height: usize,
    pub config: CompareConfig,
    /// Number of difference tests (per channel × 3 channels).
    pub tests: usize,
    /// Level of each difference test: α / tests (Bonferroni).
    pub alpha_test: f64,
    /// Per-channel level of the equivalence intervals: α/3.
    pub alpha_equivalence: f64,
    pub dof_a: f64,
    pub dof_b: f64,
    pub spp_a: u64,
    pub spp_b: u64,
    pub channels: Vec<ChannelReport>,
    pub pixel_classes: PixelClasses,
    pub zero_variance: ZeroVarianceReport,
    /// Contact pixels (union of both headers' `contact_pixels`) and their relative allowance
    /// (0 when there are none: no pixel is then judged with an allowance).
    pub contact_pixels: Vec<[usize; 2]>,
    pub contact_allowance: f64,
    /// Plain error metrics (MSE, relMSE, MAPE) of A against B.
    pub metrics: ErrorMetrics,
    #[serde(skip)]
    pub maps: Maps,
}

/// A channel or image name (`&'static str`; the alias keeps serde from borrowing it from the
/// input when a comparison is read back).
pub type StaticName = &'static str;

/// The names a comparison writes as `&'static str` (channels, the limiting image).
const STATIC_NAMES: [&str; 4] = ["R", "G", "B", "A"];

fn static_str<E: serde::de::Error>(s: &str) -> Result<&'static str, E> {
    STATIC_NAMES
        .iter()
        .find(|n| **n == s)
        .copied()
        .ok_or_else(|| E::custom(format!("unknown channel or image name '{s}'")))
}

/// Reads back a channel or image name of a serialised comparison (`linlight certify --merge`).
pub(crate) fn static_name<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<&'static str, D::Error> {
    static_str(&String::deserialize(d)?)
}

#[allow(clippy::type_complexity)]
fn static_name_in_mismatch<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Option<(Region, &'static str, f64, f64)>, D::Error> {
    Option::<(Region, String, f64, f64)>::deserialize(d)?
        .map(|(r, c, a, b)| Ok((r, static_str(&c)?, a, b)))
        .transpose()
}

fn unusable(msg: impl Into<String>) -> CompareError {
    CompareError::Unusable(msg.into())
}

/// Whether an image declares exact variances (header `variance = exact`).
pub fn is_exact(img: &Image) -> bool {
    img.meta
        .extra
        .get(KEY_VARIANCE)
        .is_some_and(|v| v.trim() == "exact")
}

fn check_config(cfg: &CompareConfig) -> Result<(), CompareError> {
    if !(cfg.alpha > 0.0 && cfg.alpha < 1.0) {
        return Err(unusable(format!(
            "alpha must lie in (0, 1), is {}",
            cfg.alpha
        )));
    }
    if !(cfg.tolerance > 0.0 && cfg.tolerance.is_finite()) {
        return Err(unusable(format!(
            "tolerance must be positive, is {}",
            cfg.tolerance
        )));
    }
    if cfg.tile == 0 {
        return Err(unusable("tile size must be at least 1"));
    }
    if !(cfg.zero_var_abs >= 0.0 && cfg.zero_var_rel >= 0.0) {
        return Err(unusable("zero-variance tolerances must be non-negative"));
    }
    if !(cfg.heavy_tail_alpha > 0.0 && cfg.heavy_tail_alpha < 1.0) {
        return Err(unusable("heavy-tail level must lie in (0, 1)"));
    }
    if !(cfg.samples_per_cv2 >= 0.0 && cfg.samples_per_cv2.is_finite()) {
        return Err(unusable("samples per CV² must be finite and non-negative"));
    }
    if !(cfg.contact_coefficient >= 0.0 && cfg.contact_coefficient.is_finite()) {
        return Err(unusable(
            "contact coefficient must be finite and non-negative",
        ));
    }
    Ok(())
}

/// Everything that makes a pair of images unusable (exit 2), checked before any statistics.
pub fn check_inputs(a: &Image, b: &Image, cfg: &CompareConfig) -> Result<(), CompareError> {
    check_config(cfg)?;
    a.validate()
        .map_err(|e| unusable(format!("image A: {e}")))?;
    b.validate()
        .map_err(|e| unusable(format!("image B: {e}")))?;
    if (a.width, a.height) != (b.width, b.height) {
        return Err(unusable(format!(
            "size mismatch: A is {}×{}, B is {}×{}",
            a.width, a.height, b.width, b.height
        )));
    }
    for (name, img) in [("A", a), ("B", b)] {
        if !is_exact(img) && !(img.meta.dof > 0.0) {
            return Err(unusable(format!(
                "image {name} has no variance estimate (dof = {}, e.g. one pass of one sample \
                 per pixel): render it with --spp ≥ 2 or --passes ≥ 2",
                img.meta.dof
            )));
        }
    }
    let (ha, hb) = (&a.meta.scene_sha256, &b.meta.scene_sha256);
    if !cfg.allow_different_scenes && !ha.is_empty() && !hb.is_empty() && ha != hb {
        let name = |img: &Image| {
            img.meta
                .extra
                .get("scene")
                .map_or_else(String::new, |s| format!(" ({s})"))
        };
        return Err(unusable(format!(
            "the images come from different scene files: A {}{}, B {}{} (scene_sha256); \
             compare renders of the same scene, or pass --allow-different-scenes",
            short(ha),
            name(a),
            short(hb),
            name(b)
        )));
    }
    contact_pixels(a, b).map_err(unusable)?;
    Ok(())
}

fn short(hash: &str) -> &str {
    &hash[..hash.len().min(12)]
}

/// Per channel: the sums over the whole image and over every tile, and the tallies of the
/// pixel and contact tests.
struct ChannelScan {
    global: Sums,
    tiles: Vec<Sums>,
    z: ZTally,
    contacts: ContactTally,
}

/// What the channel scan needs besides the images.
struct ScanContext<'a> {
    cfg: &'a CompareConfig,
    grids: &'a TileGrids,
    sides: (PixelSides, PixelSides),
    /// Per pixel: near a contact.
    contact: &'a [bool],
    allowance: f64,
}

/// One pass over the pixels of channel `c`: classify every pixel (into `maps` and `classes`),
/// feed the sums of the global and tile tests with the variances the classification allows,
/// tally z of the tested pixels and the contact pixels.
fn scan_channel(
    a: &Image,
    b: &Image,
    c: usize,
    ctx: &ScanContext,
    maps: &mut Maps,
    classes: &mut PixelClasses,
    zero: &mut ZeroVarianceTally,
) -> ChannelScan {
    let (w, h) = (a.width, a.height);
    let nu = (a.meta.dof, b.meta.dof);
    let mut scan = ChannelScan {
        global: Sums::default(),
        tiles: vec![Sums::default(); ctx.grids.len()],
        z: ZTally::default(),
        contacts: ContactTally::default(),
    };
    let tail = |img: &Image, i: usize| img.tail.as_ref().map(|t| t[i][c] as f64);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let (ma, mb) = (a.mean[i][c] as f64, b.mean[i][c] as f64);
            let (va, vb) = (a.var[i][c] as f64, b.var[i][c] as f64);
            let ((sa, nu_a), (sb, nu_b)) = (ctx.sides.0.at(a, i), ctx.sides.1.at(b, i));
            let k = classify(
                (ma, mb),
                (va, vb),
                (tail(a, i), tail(b, i)),
                &(sa, sb),
                (nu_a, nu_b),
                ctx.cfg,
            );
            if let Some(z) = k.z {
                maps.z[i][c] = z as f32;
            }
            if va == 0.0 && vb == 0.0 {
                zero.report.count += 1;
            } else if va == 0.0 || vb == 0.0 {
                zero.report.one_sided += usize::from(
                    (va == 0.0 && !ctx.sides.0.base().exact)
                        || (vb == 0.0 && !ctx.sides.1.base().exact),
                );
            }
            if ctx.contact[i] {
                maps.state[i][c] = PixelState::Contact;
                classes.contact += 1;
                scan.contacts.add(x, y, (ma, mb), k.var, nu, ctx.allowance);
                continue;
            }
            maps.state[i][c] = k.state;
            scan.global.add(ma, mb, k.var.0, k.var.1);
            for t in ctx.grids.tiles_of(x, y) {
                scan.tiles[t].add(ma, mb, k.var.0, k.var.1);
            }
            match k.state {
                PixelState::Tested => {
                    classes.tested += 1;
                    scan.z.add(k.z.unwrap_or(0.0), x, y);
                }
                PixelState::ZeroVarAgree => classes.zero_variance_agree += 1,
                PixelState::ZeroVarMismatch => {
                    classes.exact_mismatch += 1;
                    zero.mismatch(x, y, CHANNELS[c], ma, mb);
                }
                PixelState::ZeroSampleVariance => classes.zero_sample_variance += 1,
                PixelState::HeavyTail => {
                    classes.heavy_tail_a += usize::from(k.heavy_tail.0);
                    classes.heavy_tail_b += usize::from(k.heavy_tail.1);
                }
                PixelState::Undersampled => {
                    // Tested, with the floored variance (conservative).
                    classes.undersampled += 1;
                    scan.z.add(k.z.unwrap_or(0.0), x, y);
                }
                PixelState::Contact => {}
            }
        }
    }
    scan
}

/// The zero-variance report while it is being filled, with the size of its worst gap.
struct ZeroVarianceTally {
    report: ZeroVarianceReport,
    worst_gap: f64,
}

impl ZeroVarianceTally {
    fn new() -> Self {
        Self {
            report: ZeroVarianceReport {
                count: 0,
                mismatched: 0,
                one_sided: 0,
                worst: None,
            },
            worst_gap: -1.0,
        }
    }

    fn mismatch(&mut self, x: usize, y: usize, channel: &'static str, ma: f64, mb: f64) {
        self.report.mismatched += 1;
        let gap = (ma - mb).abs();
        if gap > self.worst_gap {
            self.worst_gap = gap;
            self.report.worst = Some((Region::pixel(x, y), channel, ma, mb));
        }
    }

    /// The failure of the exact zero-variance check, if any value disagrees.
    fn failure(&self) -> Option<Failure> {
        let (region, channel, ma, mb) = self.report.worst?;
        Some(Failure {
            test: TestKind::ZeroVariance,
            channel,
            region: Some(region),
            detail: format!(
                "{} exact zero-variance pixel value(s) disagree; worst at ({}, {}): {ma:e} vs {mb:e}",
                self.report.mismatched, region.x, region.y
            ),
        })
    }
}

/// Compares A against the reference B. Errors only on unusable input.
pub fn compare(a: &Image, b: &Image, cfg: &CompareConfig) -> Result<Comparison, CompareError> {
    check_inputs(a, b, cfg)?;
    let (w, h) = (a.width, a.height);
    let nu = (a.meta.dof, b.meta.dof);
    let contact_list = contact_pixels(a, b).map_err(unusable)?;
    let mut contact = vec![false; w * h];
    for &[x, y] in &contact_list {
        contact[y * w + x] = true;
    }
    let allowance = if contact_list.is_empty() {
        0.0
    } else {
        contact_allowance(a, b, cfg.contact_coefficient)
    };
    let tests = CHANNELS.len() * (TESTS_PER_CHANNEL + usize::from(!contact_list.is_empty()));
    let alpha_test = cfg.alpha / tests as f64;
    let levels = GlobalLevels {
        alpha_test,
        alpha_eq: cfg.alpha / CHANNELS.len() as f64,
        tolerance: cfg.tolerance,
    };
    let grids = TileGrids::new(cfg.tile, cfg.shifted_tiles, w, h);
    let ctx = ScanContext {
        cfg,
        grids: &grids,
        sides: (
            PixelSides::of(a, cfg.heavy_tail_alpha),
            PixelSides::of(b, cfg.heavy_tail_alpha),
        ),
        contact: &contact,
        allowance,
    };
    let found = test_channels(a, b, &ctx, nu, &levels);
    let precision = (!found.not_equivalent.is_empty())
        .then(|| {
            precision::samples_needed(&found.channels, cfg.tolerance, (a.meta.spp, b.meta.spp))
        })
        .flatten();
    Ok(Comparison {
        verdict: found.verdict(),
        failures: found.failures,
        not_equivalent: found.not_equivalent,
        precision,
        width: w,
        height: h,
        config: cfg.clone(),
        tests,
        alpha_test,
        alpha_equivalence: levels.alpha_eq,
        dof_a: nu.0,
        dof_b: nu.1,
        spp_a: a.meta.spp,
        spp_b: b.meta.spp,
        channels: found.channels,
        pixel_classes: found.classes,
        zero_variance: found.zero_variance,
        contact_pixels: contact_list,
        contact_allowance: allowance,
        metrics: error_metrics(a, b),
        maps: found.maps,
    })
}

/// What the tests of every channel found.
struct ChannelFindings {
    channels: Vec<ChannelReport>,
    /// Difference tests that rejected, the zero-variance check first.
    failures: Vec<Failure>,
    /// Equivalence intervals that did not show equivalence.
    not_equivalent: Vec<Failure>,
    classes: PixelClasses,
    zero_variance: ZeroVarianceReport,
    maps: Maps,
}

impl ChannelFindings {
    /// DIFFERENT on any failure, else INCONCLUSIVE while equivalence is not shown.
    fn verdict(&self) -> Verdict {
        if !self.failures.is_empty() {
            Verdict::Different
        } else if !self.not_equivalent.is_empty() {
            Verdict::Inconclusive
        } else {
            Verdict::Consistent
        }
    }
}

/// Scans each channel and runs its global, tile, pixel and contact tests at the levels of
/// `levels` (difference tests at `levels.alpha_test` each).
fn test_channels(
    a: &Image,
    b: &Image,
    ctx: &ScanContext,
    nu: (f64, f64),
    levels: &GlobalLevels,
) -> ChannelFindings {
    let (w, h) = (a.width, a.height);
    let alpha_test = levels.alpha_test;
    let mut maps = Maps {
        z: vec![[0.0; 3]; w * h],
        state: vec![[PixelState::Tested; 3]; w * h],
        tiles: ctx.grids.regions.iter().map(|r| (*r, [None; 3])).collect(),
    };
    let mut classes = PixelClasses::default();
    let mut zero = ZeroVarianceTally::new();
    let mut failures = Vec::new();
    let mut not_equivalent = Vec::new();
    let mut channels = Vec::new();
    for (c, &channel) in CHANNELS.iter().enumerate() {
        let scan = scan_channel(a, b, c, ctx, &mut maps, &mut classes, &mut zero);
        let (global, global_failures) = global_tests(&scan.global, nu, levels, channel);
        let tiles = tile_tests(&scan.tiles, ctx.grids, nu, alpha_test, channel);
        for (tile, p) in maps.tiles.iter_mut().zip(&tiles.p_holm) {
            tile.1[c] = *p;
        }
        let (pixels, pixel_failures) = pixel_tests(&scan.z, alpha_test, channel);
        let (contacts, contact_failure) = contact_tests(&scan.contacts, alpha_test, channel);
        for f in global_failures {
            if f.test == TestKind::Equivalence {
                not_equivalent.push(f);
            } else {
                failures.push(f);
            }
        }
        failures.extend(tiles.failure);
        failures.extend(pixel_failures);
        failures.extend(contact_failure);
        channels.push(ChannelReport {
            channel,
            global,
            tiles: tiles.report,
            pixels,
            contacts,
        });
    }
    if let Some(f) = zero.failure() {
        failures.insert(0, f);
    }
    ChannelFindings {
        channels,
        failures,
        not_equivalent,
        classes,
        zero_variance: zero.report,
        maps,
    }
}

#[cfg(test)]
mod tests;
