//! Statistical comparison of two images with per-pixel variance of the mean (STATISTICS.md §2).
//!
//! Model: every pixel and channel of image X holds a mean m_X and an unbiased estimate v_X of
//! the variance of that mean, with ν_X degrees of freedom (header `dof`). Pixels are independent
//! (box reconstruction filter, independent samples). B is the reference (the oracle): relative
//! differences are (Ḡ_A − Ḡ_B)/Ḡ_B.
//!
//! Null hypothesis of the difference tests: E[m_A] = E[m_B] everywhere. They run on three
//! scales, four tests per channel, twelve families in all:
//!   a. global mean per channel (Welch t-test on the image mean),
//!   b. tile means (Welch t-tests, Holm over the tiles of a channel; two grids, the second
//!      shifted by half a tile, so that an unaligned t×t region is still mostly in one tile),
//!   c. pixels: Σz² against χ²(N), and max|z| against its Šidák threshold,
//! each at the Šidák level α_test = 1 − (1 − α)^(1/12), so the family-wise false-alarm rate is
//! α for independent tests (and at most about α for the positively dependent ones here).
//!
//! Equivalence (a different null: |relative difference| ≥ δ): the simultaneous (1 − α)
//! confidence intervals of the three channels' relative global difference — each at level
//! 1 − α_eq, α_eq = 1 − (1 − α)^(1/3) — must lie within [−δ, δ]. A render too noisy to resolve
//! a difference of δ fails here, so noise alone can never earn "Consistent".
//!
//! Pixels with v_A + v_B = 0 carry no uncertainty: they must agree to
//! |m_A − m_B| ≤ ε_abs + ε_rel·max(|m_A|, |m_B|) and are counted apart; they take no part in
//! the z-scores (their mean does enter the global and tile means, with zero variance).

// `!(x > 0.0)` is deliberate throughout: it treats NaN as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod global;
mod pixels;
mod sums;
mod tiles;

use linlight_imagefile::Image;
use serde::Serialize;

use crate::z_score::sidak;
use global::{global_tests, GlobalLevels};
use pixels::{exact_values_agree, pixel_tests, pixel_z, ZTally};
use sums::Sums;
use tiles::{tile_tests, TileGrids};

pub use tiles::holm_adjust;

/// Channel names in RGB order.
pub const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Number of difference tests per channel (global, tiles, Σz², max|z|).
pub const TESTS_PER_CHANNEL: usize = 4;

/// Parameters of [`compare`].
#[derive(Clone, Debug, Serialize)]
pub struct CompareConfig {
    /// Family-wise significance level of the whole comparison.
    pub alpha: f64,
    /// Equivalence margin δ on the relative global difference.
    pub tolerance: f64,
    /// Tile edge length in pixels.
    pub tile: usize,
    /// Also test the tile grid shifted by half a tile (Holm then runs over both grids).
    pub shifted_tiles: bool,
    /// Absolute agreement required of zero-variance pixels.
    pub zero_var_abs: f64,
    /// Relative agreement required of zero-variance pixels.
    pub zero_var_rel: f64,
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

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Verdict {
    Consistent,
    Different,
}

/// Which test rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum TestKind {
    /// A zero-variance pixel disagrees beyond ε.
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
}

/// A pixel (width = height = 1) or a tile rectangle; x to the right, y down, (0, 0) top left.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Region {
    pub x: usize,
    pub y: usize,
    pub width: usize,
    pub height: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct Failure {
    pub test: TestKind,
    pub channel: &'static str,
    pub region: Option<Region>,
    pub detail: String,
}

#[derive(Clone, Debug, Serialize)]
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
    /// Simultaneous confidence interval of rel_diff (delta method, t quantile).
    pub rel_ci: Option<[f64; 2]>,
    pub equivalent: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct TileResult {
    pub region: Region,
    pub mean_diff: f64,
    pub std_err: f64,
    pub dof: f64,
    pub p: f64,
    /// Holm-adjusted p over the tested tiles of this channel.
    pub p_holm: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct TileReport {
    pub tiles_total: usize,
    /// Tiles with positive variance (the others hold only zero-variance pixels).
    pub tiles_tested: usize,
    pub rejected: usize,
    /// The tile with the smallest Holm-adjusted p.
    pub worst: Option<TileResult>,
}

#[derive(Clone, Debug, Serialize)]
pub struct PixelReport {
    /// Pixels of this channel with v_A + v_B > 0.
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

#[derive(Clone, Debug, Serialize)]
pub struct ChannelReport {
    pub channel: &'static str,
    pub global: GlobalReport,
    pub tiles: TileReport,
    pub pixels: PixelReport,
}

#[derive(Clone, Debug, Serialize)]
pub struct ZeroVarianceReport {
    /// Pixel-channels with v_A + v_B = 0.
    pub count: usize,
    pub mismatched: usize,
    /// Pixel-channels where exactly one image has zero variance (tested with the other's
    /// variance alone). Many of these in dark regions hint at too few passes: a variance
    /// estimate of 0 from passes that all returned 0 understates the true variance.
    pub one_sided: usize,
    /// The worst mismatch: region, channel, both means.
    pub worst: Option<(Region, &'static str, f64, f64)>,
}

/// Per pixel and channel: what was done with it (for heat maps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelState {
    Tested,
    ZeroVarAgree,
    ZeroVarMismatch,
}

/// Full-resolution maps behind the report (not serialised).
#[derive(Clone, Debug, Default)]
pub struct Maps {
    /// Normal score per pixel and channel (0 for zero-variance pixels), |z| ≤ Z_MAX.
    pub z: Vec<[f32; 3]>,
    pub state: Vec<[PixelState; 3]>,
    /// Every tile of both grids with its Holm-adjusted p per channel (None: not tested).
    pub tiles: Vec<(Region, [Option<f64>; 3])>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub verdict: Verdict,
    pub failures: Vec<Failure>,
    pub width: usize,
    pub height: usize,
    pub config: CompareConfig,
    /// Level of each of the 12 difference tests: 1 − (1 − α)^(1/12).
    pub alpha_test: f64,
    /// Per-channel level of the equivalence intervals: 1 − (1 − α)^(1/3).
    pub alpha_equivalence: f64,
    pub dof_a: f64,
    pub dof_b: f64,
    pub channels: Vec<ChannelReport>,
    pub zero_variance: ZeroVarianceReport,
    #[serde(skip)]
    pub maps: Maps,
}

fn unusable(msg: impl Into<String>) -> CompareError {
    CompareError::Unusable(msg.into())
}

fn check_inputs(a: &Image, b: &Image, cfg: &CompareConfig) -> Result<(), CompareError> {
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
        let has_var = img.var.iter().any(|v| v.iter().any(|&x| x > 0.0));
        if has_var && !(img.meta.dof > 0.0) {
            return Err(unusable(format!(
                "image {name} has positive variances but dof = {}",
                img.meta.dof
            )));
        }
    }
    Ok(())
}

/// Per channel: the sums over the whole image and over every tile, and the z tally.
struct ChannelScan {
    global: Sums,
    tiles: Vec<Sums>,
    z: ZTally,
}

/// One pass over the pixels of channel `c`: sums for the global and tile tests, a normal score
/// per pixel with variance (into `maps`), the zero-variance check of the others (into `zero`).
fn scan_channel(
    a: &Image,
    b: &Image,
    c: usize,
    cfg: &CompareConfig,
    grids: &TileGrids,
    maps: &mut Maps,
    zero: &mut ZeroVarianceTally,
) -> ChannelScan {
    let (w, h) = (a.width, a.height);
    let nu = (a.meta.dof, b.meta.dof);
    let mut scan = ChannelScan {
        global: Sums::default(),
        tiles: vec![Sums::default(); grids.len()],
        z: ZTally::default(),
    };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let (ma, mb) = (a.mean[i][c] as f64, b.mean[i][c] as f64);
            let (va, vb) = (a.var[i][c] as f64, b.var[i][c] as f64);
            scan.global.add(ma, mb, va, vb);
            for k in grids.tiles_of(x, y) {
                scan.tiles[k].add(ma, mb, va, vb);
            }
            if let Some(z) = pixel_z(ma, mb, va, vb, nu) {
                zero.report.one_sided += (va == 0.0 || vb == 0.0) as usize;
                maps.z[i][c] = z as f32;
                scan.z.add(z, x, y);
            } else {
                zero.report.count += 1;
                if exact_values_agree(ma, mb, cfg.zero_var_abs, cfg.zero_var_rel) {
                    maps.state[i][c] = PixelState::ZeroVarAgree;
                } else {
                    maps.state[i][c] = PixelState::ZeroVarMismatch;
                    zero.mismatch(x, y, CHANNELS[c], ma, mb);
                }
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
            let region = Region {
                x,
                y,
                width: 1,
                height: 1,
            };
            self.report.worst = Some((region, channel, ma, mb));
        }
    }

    /// The failure of the zero-variance check, if any value disagrees.
    fn failure(&self) -> Option<Failure> {
        let (region, channel, ma, mb) = self.report.worst?;
        Some(Failure {
            test: TestKind::ZeroVariance,
            channel,
            region: Some(region),
            detail: format!(
                "{} zero-variance pixel value(s) disagree; worst at ({}, {}): {ma:e} vs {mb:e}",
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
    let alpha_test = sidak(cfg.alpha, TESTS_PER_CHANNEL * CHANNELS.len());
    let levels = GlobalLevels {
        alpha_test,
        alpha_eq: sidak(cfg.alpha, CHANNELS.len()),
        tolerance: cfg.tolerance,
    };
    let grids = TileGrids::new(cfg.tile, cfg.shifted_tiles, w, h);
    let mut maps = Maps {
        z: vec![[0.0; 3]; w * h],
        state: vec![[PixelState::Tested; 3]; w * h],
        tiles: grids.regions.iter().map(|r| (*r, [None; 3])).collect(),
    };
    let mut zero = ZeroVarianceTally::new();
    let mut failures = Vec::new();
    let mut channels = Vec::new();
    for (c, &channel) in CHANNELS.iter().enumerate() {
        let scan = scan_channel(a, b, c, cfg, &grids, &mut maps, &mut zero);
        let (global, global_failures) = global_tests(&scan.global, nu, &levels, channel);
        let tiles = tile_tests(&scan.tiles, &grids, nu, alpha_test, channel);
        for (tile, p) in maps.tiles.iter_mut().zip(&tiles.p_holm) {
            tile.1[c] = *p;
        }
        let (pixels, pixel_failures) = pixel_tests(&scan.z, alpha_test, channel);
        failures.extend(global_failures);
        failures.extend(tiles.failure);
        failures.extend(pixel_failures);
        channels.push(ChannelReport {
            channel,
            global,
            tiles: tiles.report,
            pixels,
        });
    }
    if let Some(f) = zero.failure() {
        failures.insert(0, f);
    }
    Ok(Comparison {
        verdict: if failures.is_empty() {
            Verdict::Consistent
        } else {
            Verdict::Different
        },
        failures,
        width: w,
        height: h,
        config: cfg.clone(),
        alpha_test,
        alpha_equivalence: levels.alpha_eq,
        dof_a: nu.0,
        dof_b: nu.1,
        channels,
        zero_variance: zero.report,
        maps,
    })
}

#[cfg(test)]
mod tests;
