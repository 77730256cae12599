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

use linlight_imagefile::Image;
use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::z_score::{
    normal_two_sided_quantile, normal_upper_tail, sidak, t_to_z, t_two_sided_p,
    t_two_sided_quantile, welch_dof,
};

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

/// A grid of t×t tiles whose interior boundaries lie at x ≡ offset (mod t): offset = t is the
/// aligned grid, offset = t/2 the half-shifted one. Border tiles are clipped to the image.
#[derive(Clone, Copy, Debug)]
struct TileGrid {
    t: usize,
    offset: usize,
    nx: usize,
    ny: usize,
}

impl TileGrid {
    fn new(t: usize, offset: usize, w: usize, h: usize) -> Self {
        let shift = t - offset;
        Self {
            t,
            offset,
            nx: (w + shift).div_ceil(t),
            ny: (h + shift).div_ceil(t),
        }
    }
    fn len(&self) -> usize {
        self.nx * self.ny
    }
    fn index(&self, x: usize, y: usize) -> usize {
        let shift = self.t - self.offset;
        ((y + shift) / self.t) * self.nx + (x + shift) / self.t
    }
    fn region(&self, k: usize, w: usize, h: usize) -> Region {
        let shift = self.t - self.offset;
        let span = |i: usize, size: usize| {
            let start = (i * self.t).saturating_sub(shift);
            let end = ((i + 1) * self.t - shift).min(size);
            (start, end - start)
        };
        let (x, width) = span(k % self.nx, w);
        let (y, height) = span(k / self.nx, h);
        Region {
            x,
            y,
            width,
            height,
        }
    }
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

/// Running sums of a set of pixels of one channel.
#[derive(Clone, Copy, Default)]
struct Sums {
    n: usize,
    ma: f64,
    mb: f64,
    va: f64,
    vb: f64,
    /// Σ v_A² and Σ v_B² (Welch–Satterthwaite denominators).
    va2: f64,
    vb2: f64,
}

impl Sums {
    fn add(&mut self, ma: f64, mb: f64, va: f64, vb: f64) {
        self.n += 1;
        self.ma += ma;
        self.mb += mb;
        self.va += va;
        self.vb += vb;
        self.va2 += va * va;
        self.vb2 += vb * vb;
    }

    /// Welch–Satterthwaite dof of Σ v_A + k·Σ v_B over independent pixels:
    /// (Σ v_A + k Σ v_B)² / (Σ v_A²/ν_A + k² Σ v_B²/ν_B). Infinite if nothing is uncertain.
    fn dof(&self, k: f64, nu_a: f64, nu_b: f64) -> f64 {
        let mut denom = 0.0;
        if self.va2 > 0.0 {
            denom += self.va2 / nu_a;
        }
        if self.vb2 > 0.0 {
            denom += k * k * self.vb2 / nu_b;
        }
        let s = self.va + k * self.vb;
        let nu = s * s / denom;
        if nu.is_finite() && nu > 0.0 {
            nu
        } else {
            f64::INFINITY
        }
    }

    /// Welch t of the difference of the two means of this set, its dof and the standard error
    /// of the mean difference; None if the set carries no variance.
    fn welch(&self, nu_a: f64, nu_b: f64) -> Option<(f64, f64, f64)> {
        let s = self.va + self.vb;
        if !(s > 0.0) {
            return None;
        }
        let n = self.n as f64;
        let se = s.sqrt() / n;
        let diff = (self.ma - self.mb) / n;
        Some((diff / se, self.dof(1.0, nu_a, nu_b), se))
    }
}

/// Holm step-down adjusted p-values (same order as the input).
pub fn holm_adjust(p: &[f64]) -> Vec<f64> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&i, &j| p[i].total_cmp(&p[j]));
    let mut adj = vec![1.0; m];
    let mut running = 0.0f64;
    for (rank, &i) in order.iter().enumerate() {
        let v = ((m - rank) as f64 * p[i]).min(1.0);
        running = running.max(v);
        adj[i] = running;
    }
    adj
}

/// Compares A against the reference B. Errors only on unusable input.
pub fn compare(a: &Image, b: &Image, cfg: &CompareConfig) -> Result<Comparison, CompareError> {
    check_inputs(a, b, cfg)?;
    let (w, h) = (a.width, a.height);
    let n = w * h;
    let (nu_a, nu_b) = (a.meta.dof, b.meta.dof);
    let alpha_test = sidak(cfg.alpha, TESTS_PER_CHANNEL * CHANNELS.len());
    let alpha_eq = sidak(cfg.alpha, CHANNELS.len());
    let t = cfg.tile;
    // The aligned grid, plus (if enabled) the grid shifted by half a tile in x and y: every
    // t×t region then overlaps one tile of one grid by at least (3t/4)², instead of possibly
    // only (t/2)² of four tiles.
    let mut grids = vec![TileGrid::new(t, t, w, h)];
    if cfg.shifted_tiles && t >= 2 {
        grids.push(TileGrid::new(t, t / 2, w, h));
    }
    let grid_base: Vec<usize> = grids
        .iter()
        .scan(0, |acc, g| Some(std::mem::replace(acc, *acc + g.len())))
        .collect();
    let tile_count: usize = grids.iter().map(TileGrid::len).sum();
    let tile_regions: Vec<Region> = grids
        .iter()
        .flat_map(|g| (0..g.len()).map(move |k| g.region(k, w, h)))
        .collect();

    let mut maps = Maps {
        z: vec![[0.0; 3]; n],
        state: vec![[PixelState::Tested; 3]; n],
        tiles: tile_regions.iter().map(|r| (*r, [None; 3])).collect(),
    };
    let mut zero = ZeroVarianceReport {
        count: 0,
        mismatched: 0,
        one_sided: 0,
        worst: None,
    };
    let mut worst_zero_gap = -1.0f64;
    let mut failures = Vec::new();
    let mut channels = Vec::new();

    for (c, &cname) in CHANNELS.iter().enumerate() {
        let mut global = Sums::default();
        let mut tiles = vec![Sums::default(); tile_count];
        let (mut sum_z2, mut tested, mut max_abs_z, mut max_at) = (0.0f64, 0usize, 0.0f64, None);

        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let (ma, mb) = (a.mean[i][c] as f64, b.mean[i][c] as f64);
                let (va, vb) = (a.var[i][c] as f64, b.var[i][c] as f64);
                global.add(ma, mb, va, vb);
                for (g, base) in grids.iter().zip(&grid_base) {
                    tiles[base + g.index(x, y)].add(ma, mb, va, vb);
                }
                let s = va + vb;
                if s > 0.0 {
                    zero.one_sided += (va == 0.0 || vb == 0.0) as usize;
                    let nu = welch_dof([(va, nu_a), (vb, nu_b)]).unwrap_or(f64::INFINITY);
                    let z = t_to_z((ma - mb) / s.sqrt(), nu);
                    maps.z[i][c] = z as f32;
                    sum_z2 += z * z;
                    tested += 1;
                    if z.abs() > max_abs_z || max_at.is_none() {
                        max_abs_z = z.abs();
                        max_at = Some(Region {
                            x,
                            y,
                            width: 1,
                            height: 1,
                        });
                    }
                } else {
                    zero.count += 1;
                    let gap = (ma - mb).abs();
                    let allowed = cfg.zero_var_abs + cfg.zero_var_rel * ma.abs().max(mb.abs());
                    if gap > allowed {
                        zero.mismatched += 1;
                        maps.state[i][c] = PixelState::ZeroVarMismatch;
                        if gap > worst_zero_gap {
                            worst_zero_gap = gap;
                            zero.worst = Some((
                                Region {
                                    x,
                                    y,
                                    width: 1,
                                    height: 1,
                                },
                                cname,
                                ma,
                                mb,
                            ));
                        }
                    } else {
                        maps.state[i][c] = PixelState::ZeroVarAgree;
                    }
                }
            }
        }

        // a. Global mean and equivalence.
        let nf = n as f64;
        let (mean_a, mean_b) = (global.ma / nf, global.mb / nf);
        let welch = global.welch(nu_a, nu_b);
        let (p, dof, std_err) = match welch {
            Some((tg, nu, se)) => (Some(t_two_sided_p(tg, nu)), Some(nu), se),
            None => (None, None, 0.0),
        };
        let significant = p.is_some_and(|p| p <= alpha_test);
        let (rel_diff, rel_ci) = relative_ci(&global, nu_a, nu_b, alpha_eq);
        let equivalent = rel_ci.is_some_and(|[lo, hi]| lo >= -cfg.tolerance && hi <= cfg.tolerance);
        let global_report = GlobalReport {
            mean_a,
            mean_b,
            diff: mean_a - mean_b,
            std_err,
            dof,
            p,
            significant,
            rel_diff,
            rel_ci,
            equivalent,
        };
        if significant {
            failures.push(Failure {
                test: TestKind::GlobalMean,
                channel: cname,
                region: None,
                detail: format!(
                    "global mean differs: {:+.4e} ± {:.2e} (p = {:.3e} ≤ {:.3e})",
                    mean_a - mean_b,
                    std_err,
                    p.unwrap_or(0.0),
                    alpha_test
                ),
            });
        }
        if !equivalent {
            let detail = match (rel_diff, rel_ci) {
                (Some(r), Some([lo, hi])) => format!(
                    "relative difference {:+.3}% with {:.2}% CI [{:+.3}%, {:+.3}%] not within ±{:.3}%",
                    100.0 * r,
                    100.0 * (1.0 - alpha_eq),
                    100.0 * lo,
                    100.0 * hi,
                    100.0 * cfg.tolerance
                ),
                _ => format!("reference mean is {mean_b:e}: relative difference undefined"),
            };
            failures.push(Failure {
                test: TestKind::Equivalence,
                channel: cname,
                region: None,
                detail,
            });
        }

        // b. Tiles, Holm over the tested tiles of this channel.
        let mut tile_idx = Vec::new();
        let mut tile_res = Vec::new();
        for (k, s) in tiles.iter().enumerate() {
            if let Some((tt, nu, se)) = s.welch(nu_a, nu_b) {
                tile_idx.push(k);
                let region = tile_regions[k];
                let mean_diff = (s.ma - s.mb) / s.n as f64;
                let p = t_two_sided_p(tt, nu);
                tile_res.push(TileResult {
                    region,
                    mean_diff,
                    std_err: se,
                    dof: nu,
                    p,
                    p_holm: p,
                });
            }
        }
        let raw: Vec<f64> = tile_res.iter().map(|r| r.p).collect();
        for ((r, adj), &k) in tile_res.iter_mut().zip(holm_adjust(&raw)).zip(&tile_idx) {
            r.p_holm = adj;
            maps.tiles[k].1[c] = Some(adj);
        }
        let rejected = tile_res.iter().filter(|r| r.p_holm <= alpha_test).count();
        let worst = tile_res
            .iter()
            .min_by(|x, y| x.p_holm.total_cmp(&y.p_holm).then(x.p.total_cmp(&y.p)))
            .cloned();
        if rejected > 0 {
            let wt = worst.as_ref().expect("a rejected tile exists");
            failures.push(Failure {
                test: TestKind::Tile,
                channel: cname,
                region: Some(wt.region),
                detail: format!(
                    "{rejected} tile(s) differ; worst at ({}, {}): mean difference {:+.4e} ± {:.2e}, Holm p = {:.3e} ≤ {:.3e}",
                    wt.region.x, wt.region.y, wt.mean_diff, wt.std_err, wt.p_holm, alpha_test
                ),
            });
        }
        let tile_report = TileReport {
            tiles_total: tiles.len(),
            tiles_tested: tile_res.len(),
            rejected,
            worst,
        };

        // c. Pixels.
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
        if let Some(p) = chi2_p.filter(|&p| p <= alpha_test) {
            failures.push(Failure {
                test: TestKind::PixelChiSquare,
                channel: cname,
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
                channel: cname,
                region: Some(at),
                detail: format!(
                    "|z| = {max_abs_z:.2} at ({}, {}) exceeds the Šidák threshold {z_threshold:.2}",
                    at.x, at.y
                ),
            });
        }
        let pixel_report = PixelReport {
            tested,
            sum_z2,
            chi2_p,
            max_abs_z,
            max_at,
            z_threshold,
            max_p,
        };

        channels.push(ChannelReport {
            channel: cname,
            global: global_report,
            tiles: tile_report,
            pixels: pixel_report,
        });
    }

    if zero.mismatched > 0 {
        let (region, cname, ma, mb) = zero.worst.expect("a mismatch was recorded");
        failures.insert(
            0,
            Failure {
                test: TestKind::ZeroVariance,
                channel: cname,
                region: Some(region),
                detail: format!(
                    "{} zero-variance pixel value(s) disagree; worst at ({}, {}): {ma:e} vs {mb:e}",
                    zero.mismatched, region.x, region.y
                ),
            },
        );
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
        alpha_equivalence: alpha_eq,
        dof_a: nu_a,
        dof_b: nu_b,
        channels,
        zero_variance: zero,
        maps,
    })
}

/// Relative difference r = Ḡ_A/Ḡ_B − 1 and its (1 − α_eq) confidence interval by the delta
/// method: Var r ≈ (Var Ḡ_A + R² Var Ḡ_B)/Ḡ_B² with R = Ḡ_A/Ḡ_B, t quantile with the
/// Welch–Satterthwaite dof of that combination. A zero reference mean gives (None, None) unless
/// both means are exactly 0 with no variance (then r = 0 exactly).
fn relative_ci(s: &Sums, nu_a: f64, nu_b: f64, alpha_eq: f64) -> (Option<f64>, Option<[f64; 2]>) {
    let n = s.n as f64;
    let (ga, gb) = (s.ma / n, s.mb / n);
    if gb == 0.0 || !gb.is_finite() {
        let exact_zero = ga == 0.0 && s.va == 0.0 && s.vb == 0.0;
        return if exact_zero {
            (Some(0.0), Some([0.0, 0.0]))
        } else {
            (None, None)
        };
    }
    let ratio = ga / gb;
    let r = ratio - 1.0;
    let k = ratio * ratio;
    let var_sum = s.va + k * s.vb;
    if !(var_sum > 0.0) {
        return (Some(r), Some([r, r]));
    }
    let se = var_sum.sqrt() / (n * gb.abs());
    let q = t_two_sided_quantile(alpha_eq, s.dof(k, nu_a, nu_b));
    (Some(r), Some([r - q * se, r + q * se]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use linlight_sampling::rng::Pcg32;

    const W: usize = 128;
    const H: usize = 128;
    const PASSES: usize = 32;

    /// A smooth, strictly positive "true" image.
    fn truth(x: usize, y: usize) -> [f64; 3] {
        let (u, v) = ((x as f64 + 0.5) / W as f64, (y as f64 + 0.5) / H as f64);
        [
            0.2 + 0.6 * u * v + 0.1 * (6.0 * u).sin().powi(2),
            0.5 + 0.3 * (3.0 * v).cos(),
            0.1 + 0.8 * u * (1.0 - v),
        ]
    }

    fn normal(rng: &mut Pcg32) -> f64 {
        let u1 = 1.0 - rng.next_f64();
        let u2 = rng.next_f64();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// Gamma(a, 1) for a ≥ 1 (Marsaglia–Tsang squeeze/rejection).
    fn gamma(rng: &mut Pcg32, a: f64) -> f64 {
        let d = a - 1.0 / 3.0;
        let c = 1.0 / (9.0 * d).sqrt();
        loop {
            let x = normal(rng);
            let v = (1.0 + c * x).powi(3);
            if v <= 0.0 {
                continue;
            }
            let u = 1.0 - rng.next_f64();
            if u.ln() < 0.5 * x * x + d - d * v + d * v.ln() {
                return d * v;
            }
        }
    }

    /// A "render" of `truth` scaled by `scale(x, y)`: per pixel and channel PASSES independent
    /// pass values T + σ g with σ = noise·T, g ~ N(0, 1); the image holds their mean and the
    /// unbiased variance of that mean, dof = PASSES − 1, so t statistics are exactly t.
    /// Drawn directly from the joint law of (mean, S²) of P normal samples — independent,
    /// mean ~ N(μ, σ²/P), (P − 1) S²/σ² ~ χ²(P − 1) = 2·Gamma((P − 1)/2) — which is the same
    /// distribution as simulating the passes, at 3 instead of 32 draws.
    #[allow(clippy::needless_range_loop)]
    fn render(seed: u64, noise: f64, scale: impl Fn(usize, usize) -> f64) -> Image {
        let mut rng = Pcg32::new(seed, 0x1ab);
        let mut img = Image::new(W, H);
        let p = PASSES as f64;
        img.meta.dof = p - 1.0;
        img.meta.passes = PASSES as u64;
        for y in 0..H {
            for x in 0..W {
                let t = truth(x, y);
                let k = scale(x, y);
                for c in 0..3 {
                    let sigma = noise * t[c];
                    let mean = t[c] * k + sigma / p.sqrt() * normal(&mut rng);
                    let s2 = sigma * sigma * 2.0 * gamma(&mut rng, 0.5 * (p - 1.0)) / (p - 1.0);
                    img.mean[y * W + x][c] = mean as f32;
                    img.var[y * W + x][c] = (s2 / p) as f32;
                }
            }
        }
        img
    }

    /// The literal simulation the fast `render` replaces: same moments of mean and variance.
    #[test]
    fn fast_render_matches_pass_simulation_in_distribution() {
        let mut rng = Pcg32::new(77, 3);
        let n = 20_000;
        let p = PASSES as f64;
        let (mut m1, mut v1, mut m2, mut v2) = (0.0, 0.0, 0.0, 0.0);
        let mut xs = [0.0f64; PASSES];
        for _ in 0..n {
            xs.iter_mut().for_each(|v| *v = normal(&mut rng));
            let mean = xs.iter().sum::<f64>() / p;
            let s2 = xs.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (p - 1.0);
            m1 += mean * mean;
            v1 += s2;
            let mean_fast = normal(&mut rng) / p.sqrt();
            let s2_fast = 2.0 * gamma(&mut rng, 0.5 * (p - 1.0)) / (p - 1.0);
            m2 += mean_fast * mean_fast;
            v2 += s2_fast;
        }
        let nf = n as f64;
        // E[mean²] = 1/P (sd ≈ √2/P/√n), E[S²] = 1 (sd ≈ √(2/(P−1))/√n).
        let (sd_m, sd_v) = (2f64.sqrt() / p / nf.sqrt(), (2.0 / (p - 1.0) / nf).sqrt());
        for (m, v) in [(m1 / nf, v1 / nf), (m2 / nf, v2 / nf)] {
            assert!((m - 1.0 / p).abs() < 5.0 * sd_m, "{m}");
            assert!((v - 1.0).abs() < 5.0 * sd_v, "{v}");
        }
    }

    fn failed(cmp: &Comparison, test: TestKind) -> bool {
        cmp.failures.iter().any(|f| f.test == test)
    }

    /// Rejection by the difference tests at family level `alpha`, recomputed from the reported
    /// p-values (the equivalence test has a different null and is excluded).
    fn rejects_at(cmp: &Comparison, alpha: f64) -> bool {
        let a = sidak(alpha, TESTS_PER_CHANNEL * CHANNELS.len());
        cmp.channels.iter().any(|ch| {
            ch.global.p.is_some_and(|p| p <= a)
                || ch.tiles.worst.as_ref().is_some_and(|t| t.p_holm <= a)
                || ch.pixels.chi2_p.is_some_and(|p| p <= a)
                || ch.pixels.max_p.is_some_and(|p| p <= a)
        })
    }

    /// Smallest k with P(X ≥ k) ≤ tail and largest k with P(X ≤ k) ≤ tail, X ~ Bin(n, p).
    fn binomial_bounds(n: u64, p: f64, tail: f64) -> (u64, u64) {
        use statrs::distribution::{Binomial, DiscreteCDF};
        let d = Binomial::new(p, n).unwrap();
        let hi = (0..=n)
            .find(|&k| k > 0 && d.sf(k - 1) <= tail)
            .unwrap_or(n + 1);
        let lo = (0..=n).take_while(|&k| d.cdf(k) <= tail).last();
        (lo.map_or(0, |k| k + 1), hi)
    }

    const NOISE: f64 = 0.3;

    #[test]
    fn seed_only_differences_are_consistent_and_calibrated() {
        let seeds = 50u64;
        let cfg = CompareConfig::default();
        let (mut rejected_01, mut rejected_20) = (0u64, 0u64);
        let (mut sum_z2, mut sum_t2, mut count) = (0.0f64, 0.0f64, 0usize);
        for s in 0..seeds {
            let a = render(1000 + 2 * s, NOISE, |_, _| 1.0);
            let b = render(1001 + 2 * s, NOISE, |_, _| 1.0);
            let cmp = compare(&a, &b, &cfg).unwrap();
            // Equivalence always holds here (CI half-width ≈ 0.2 % < δ = 0.5 %).
            assert!(
                !failed(&cmp, TestKind::Equivalence),
                "seed {s}: {:?}",
                cmp.failures
            );
            if cmp.verdict != Verdict::Consistent {
                rejected_01 += 1;
                eprintln!("seed {s} rejected at α = 0.01: {:?}", cmp.failures);
            }
            assert_eq!(cmp.verdict == Verdict::Different, rejects_at(&cmp, 0.01));
            rejected_20 += rejects_at(&cmp, 0.2) as u64;
            for ch in &cmp.channels {
                sum_z2 += ch.pixels.sum_z2;
                count += ch.pixels.tested;
            }
            for (i, (ma, mb)) in a.mean.iter().zip(&b.mean).enumerate() {
                for c in 0..3 {
                    let d = ma[c] as f64 - mb[c] as f64;
                    sum_t2 += d * d / (a.var[i][c] as f64 + b.var[i][c] as f64);
                }
            }
        }
        let mean_z2 = sum_z2 / count as f64;
        let mean_t2 = sum_t2 / count as f64;
        let sd = (2.0 / count as f64).sqrt();
        eprintln!(
            "false alarms over {seeds} seed pairs: {rejected_01} at α = 0.01, {rejected_20} at α = 0.2; \
             mean z² = {mean_z2:.5} (sd {sd:.5}), mean raw t² = {mean_t2:.5}"
        );
        // Family-wise false-alarm rate: binomial bounds at 0.1 % tail probability.
        let (_, hi) = binomial_bounds(seeds, 0.01, 1e-3);
        assert!(
            rejected_01 < hi,
            "{rejected_01} false alarms at α = 0.01 (bound {hi})"
        );
        let (lo, hi) = binomial_bounds(seeds, 0.2, 1e-3);
        assert!(
            (lo..hi).contains(&rejected_20),
            "{rejected_20} rejections at α = 0.2 outside [{lo}, {hi})"
        );
        // The z scores are standard normal (within 5 sd), while raw t² is inflated by about
        // ν/(ν − 2) for the Welch dof ν ∈ [31, 62] — the reason for the z transform.
        assert!((mean_z2 - 1.0).abs() < 5.0 * sd, "mean z² = {mean_z2}");
        assert!(mean_t2 > 1.0 + 10.0 * sd, "mean t² = {mean_t2}");
    }

    #[test]
    fn one_percent_global_scale_error_is_rejected() {
        let cfg = CompareConfig::default();
        for s in 0..10 {
            let a = render(2000 + 2 * s, NOISE, |_, _| 1.01);
            let b = render(2001 + 2 * s, NOISE, |_, _| 1.0);
            let cmp = compare(&a, &b, &cfg).unwrap();
            assert_eq!(cmp.verdict, Verdict::Different);
            for ch in &cmp.channels {
                let g = &ch.global;
                let [lo, hi] = g.rel_ci.unwrap();
                if s == 0 {
                    eprintln!(
                        "1 % scale, channel {}: rel diff {:+.4} % CI [{:+.4} %, {:+.4} %], t = {:.1}, p = {:.2e}",
                        ch.channel,
                        100.0 * g.rel_diff.unwrap(),
                        100.0 * lo,
                        100.0 * hi,
                        g.diff / g.std_err,
                        g.p.unwrap()
                    );
                }
                assert!(g.significant, "seed {s} channel {}", ch.channel);
                assert!(!g.equivalent);
                assert!(
                    lo < 0.01 && hi > 0.01,
                    "CI must cover the true 1 %: [{lo}, {hi}]"
                );
            }
        }
    }

    #[test]
    fn five_percent_error_in_one_tile_is_caught_by_the_tile_test() {
        let cfg = CompareConfig::default();
        let region = Region {
            x: 48,
            y: 32,
            width: 16,
            height: 16,
        };
        let inside = |x: usize, y: usize| {
            (region.x..region.x + 16).contains(&x) && (region.y..region.y + 16).contains(&y)
        };
        let mut global_hits = 0;
        for s in 0..10 {
            let a = render(
                3000 + 2 * s,
                NOISE,
                |x, y| if inside(x, y) { 1.05 } else { 1.0 },
            );
            let b = render(3001 + 2 * s, NOISE, |_, _| 1.0);
            let cmp = compare(&a, &b, &cfg).unwrap();
            assert_eq!(cmp.verdict, Verdict::Different, "seed {s}");
            let tile_failures: Vec<_> = cmp
                .failures
                .iter()
                .filter(|f| f.test == TestKind::Tile)
                .collect();
            assert!(!tile_failures.is_empty(), "seed {s}: {:?}", cmp.failures);
            for f in &tile_failures {
                assert_eq!(f.region, Some(region), "worst tile is the modified one");
            }
            // Globally it is 256 of 16384 pixels, 0.08 % of the mean (≈ 1.3 standard errors):
            // the global test mostly misses it, and equivalence (±0.5 %) must still hold.
            global_hits += failed(&cmp, TestKind::GlobalMean) as usize;
            assert!(!failed(&cmp, TestKind::Equivalence));
            if s == 0 {
                for ch in &cmp.channels {
                    let t = ch.tiles.worst.as_ref().unwrap();
                    eprintln!(
                        "5 % tile, channel {}: worst tile ({}, {}) Holm p = {:.2e}, rejected {}; global p = {:.3}",
                        ch.channel, t.region.x, t.region.y, t.p_holm, ch.tiles.rejected,
                        ch.global.p.unwrap()
                    );
                }
            }
        }
        eprintln!("5 % tile: tile test rejected 10/10 seeds, global test {global_hits}/10");
    }

    /// Tile-test rejections over 10 seed pairs of a 5 % error in the 16×16 region at (x0, y0).
    fn unaligned_region_hits(x0: usize, y0: usize, cfg: &CompareConfig, seed: u64) -> usize {
        let inside = |x: usize, y: usize| (x0..x0 + 16).contains(&x) && (y0..y0 + 16).contains(&y);
        let mut hits = 0;
        for s in 0..10 {
            let a = render(
                seed + 2 * s,
                NOISE,
                |x, y| if inside(x, y) { 1.05 } else { 1.0 },
            );
            let b = render(seed + 1 + 2 * s, NOISE, |_, _| 1.0);
            let cmp = compare(&a, &b, cfg).unwrap();
            if let Some(f) = cmp.failures.iter().find(|f| f.test == TestKind::Tile) {
                hits += 1;
                let r = f.region.unwrap();
                assert!(
                    r.x < x0 + 16 && x0 < r.x + r.width && r.y < y0 + 16 && y0 < r.y + r.height,
                    "worst tile {r:?} must overlap the region"
                );
            }
        }
        hits
    }

    #[test]
    fn five_percent_error_in_an_unaligned_region_is_caught_by_the_shifted_grid() {
        let both = CompareConfig::default();
        let aligned_only = CompareConfig {
            shifted_tiles: false,
            ..CompareConfig::default()
        };
        // Region half a tile off the aligned grid: there it is split 8×8 into four tiles, the
        // shifted grid holds it whole.
        let half_both = unaligned_region_hits(40, 24, &both, 5000);
        let half_aligned = unaligned_region_hits(40, 24, &aligned_only, 5000);
        // Worst case for two grids: 4 px off one and 12 px off the other in x and y, the best
        // tile holds 12×12 of its pixels.
        let quarter_both = unaligned_region_hits(44, 28, &both, 6000);
        eprintln!(
            "unaligned 5 % region, tile-test rejections out of 10: half-tile offset {half_both} \
             (aligned grid only: {half_aligned}), quarter-tile offset {quarter_both}"
        );
        assert_eq!(half_both, 10);
        assert_eq!(quarter_both, 10);
    }

    #[test]
    fn noisy_render_of_a_one_percent_off_truth_is_not_consistent() {
        let cfg = CompareConfig::default();
        for s in 0..5 {
            // 60× the noise: the difference tests cannot resolve 1 %, equivalence must fail.
            let a = render(4000 + 2 * s, 60.0 * NOISE, |_, _| 1.01);
            let b = render(4001 + 2 * s, NOISE, |_, _| 1.0);
            let cmp = compare(&a, &b, &cfg).unwrap();
            assert_eq!(cmp.verdict, Verdict::Different);
            assert!(failed(&cmp, TestKind::Equivalence), "{:?}", cmp.failures);
            if s == 0 {
                let g = &cmp.channels[0].global;
                eprintln!(
                    "noisy 1 %: failures {:?}, R rel CI {:?}, global p = {:.3}",
                    cmp.failures.iter().map(|f| f.test).collect::<Vec<_>>(),
                    g.rel_ci,
                    g.p.unwrap()
                );
            }
        }
        // Noise alone is enough to fail: a noisy render of the exact truth is not certified.
        let a = render(4100, 60.0 * NOISE, |_, _| 1.0);
        let b = render(4101, NOISE, |_, _| 1.0);
        let cmp = compare(&a, &b, &cfg).unwrap();
        assert!(failed(&cmp, TestKind::Equivalence));
        assert_eq!(cmp.verdict, Verdict::Different);
    }

    fn flat(w: usize, h: usize, m: f32, v: f32) -> Image {
        let mut img = Image::new(w, h);
        img.mean.iter_mut().for_each(|p| *p = [m; 3]);
        img.var.iter_mut().for_each(|p| *p = [v; 3]);
        img.meta.dof = 15.0;
        img
    }

    #[test]
    fn zero_variance_pixels_are_counted_apart_and_must_agree() {
        let mut a = flat(20, 10, 0.5, 1e-4);
        let mut b = flat(20, 10, 0.5, 1e-4);
        for i in 0..20 {
            a.var[i] = [0.0; 3];
            b.var[i] = [0.0; 3];
            a.mean[i] = [3.0; 3];
            b.mean[i] = [3.0 * (1.0 + 2e-6); 3]; // within ε_rel = 1e-5
        }
        let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
        assert_eq!(cmp.zero_variance.count, 60);
        assert_eq!(cmp.zero_variance.mismatched, 0);
        assert_eq!(cmp.zero_variance.one_sided, 0);
        assert_eq!(cmp.channels[0].pixels.tested, 180);
        assert_eq!(cmp.verdict, Verdict::Consistent, "{:?}", cmp.failures);

        b.mean[7][1] = 3.001;
        b.var[30][2] = 0.0;
        let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
        assert_eq!(cmp.verdict, Verdict::Different);
        assert_eq!(cmp.zero_variance.mismatched, 1);
        assert_eq!(cmp.zero_variance.one_sided, 1);
        let f = &cmp.failures[0];
        assert_eq!((f.test, f.channel), (TestKind::ZeroVariance, "G"));
        assert_eq!(
            f.region,
            Some(Region {
                x: 7,
                y: 0,
                width: 1,
                height: 1
            })
        );
    }

    #[test]
    fn exact_images_compare_exactly() {
        // No variance anywhere: only the zero-variance check and exact equivalence apply.
        let a = flat(5, 5, 0.25, 0.0);
        let cmp = compare(&a, &a.clone(), &CompareConfig::default()).unwrap();
        assert_eq!(cmp.verdict, Verdict::Consistent);
        assert_eq!(cmp.channels[2].global.rel_ci, Some([0.0, 0.0]));
        // An all-black channel in both is equivalent; black reference vs non-black is not.
        let mut black = flat(5, 5, 0.0, 0.0);
        let cmp = compare(&black, &black.clone(), &CompareConfig::default()).unwrap();
        assert_eq!(cmp.verdict, Verdict::Consistent);
        black.var[3] = [1e-3; 3];
        let mut other = black.clone();
        other.mean[3] = [0.01; 3];
        let cmp = compare(&other, &black, &CompareConfig::default()).unwrap();
        assert!(failed(&cmp, TestKind::Equivalence));
        assert_eq!(cmp.channels[0].global.rel_diff, None);
    }

    #[test]
    fn unusable_inputs_are_errors() {
        let cfg = CompareConfig::default();
        let a = flat(4, 4, 1.0, 0.1);
        assert!(compare(&a, &flat(4, 5, 1.0, 0.1), &cfg).is_err());
        let mut no_dof = a.clone();
        no_dof.meta.dof = 0.0;
        let err = compare(&a, &no_dof, &cfg).unwrap_err();
        assert!(err.to_string().contains("dof"), "{err}");
        let mut nan = a.clone();
        nan.mean[5][2] = f32::NAN;
        assert!(compare(&nan, &a, &cfg).is_err());
        let bad = CompareConfig {
            alpha: 1.5,
            ..cfg.clone()
        };
        assert!(compare(&a, &a, &bad).is_err());
        let bad = CompareConfig { tile: 0, ..cfg };
        assert!(compare(&a, &a, &bad).is_err());
    }

    #[test]
    fn holm_adjustment() {
        let adj = holm_adjust(&[0.01, 0.04, 0.03, 0.5]);
        // Sorted: 0.01·4 = 0.04, 0.03·3 = 0.09, 0.04·2 = 0.08 → max 0.09, 0.5·1 = 0.5.
        let expect = [0.04, 0.09, 0.09, 0.5];
        for (x, e) in adj.iter().zip(expect) {
            assert!((x - e).abs() < 1e-12, "{adj:?}");
        }
        assert!(holm_adjust(&[]).is_empty());
    }

    #[test]
    fn report_serialises_without_nulls_for_tested_values() {
        let a = flat(33, 17, 1.0, 0.01);
        let mut b = a.clone();
        b.mean[40] = [1.2; 3];
        let cmp = compare(
            &a,
            &b,
            &CompareConfig {
                tile: 8,
                ..Default::default()
            },
        )
        .unwrap();
        let json = serde_json::to_value(&cmp).unwrap();
        assert_eq!(json["verdict"], "Different");
        assert_eq!(json["channels"][1]["channel"], "G");
        assert!(json["channels"][0]["pixels"]["chi2_p"].is_number());
        assert!(json["channels"][0]["tiles"]["worst"]["p_holm"].is_number());
        // Aligned grid 5 × 3 tiles, half-shifted grid (boundaries at 4, 12, ...) also 5 × 3.
        assert_eq!(json["channels"][0]["tiles"]["tiles_total"], 5 * 3 + 5 * 3);
        // The edge tile is clipped to the image.
        let w = &cmp.channels[0].tiles.worst.as_ref().unwrap().region;
        assert!(w.x + w.width <= 33 && w.y + w.height <= 17);
    }
}
