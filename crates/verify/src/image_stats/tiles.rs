//! Tile tests: Welch t-tests of t×t tile means, Holm-corrected over the tiles of a channel, on
//! the aligned grid and (optionally) the grid shifted by half a tile.

use super::sums::Sums;
use super::{Failure, Region, TestKind, TileReport, TileResult};
use crate::z_score::t_two_sided_p;

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

/// The tiles of all grids, numbered grid after grid.
pub(super) struct TileGrids {
    grids: Vec<(TileGrid, usize)>,
    /// Region of every tile, by number.
    pub regions: Vec<Region>,
}

impl TileGrids {
    /// The aligned grid, plus (if `shifted`) the grid shifted by half a tile in x and y: every
    /// t×t region then overlaps one tile of one grid by at least (3t/4)², instead of possibly
    /// only (t/2)² of four tiles.
    pub fn new(t: usize, shifted: bool, w: usize, h: usize) -> Self {
        let mut list = vec![TileGrid::new(t, t, w, h)];
        if shifted && t >= 2 {
            list.push(TileGrid::new(t, t / 2, w, h));
        }
        let mut grids = Vec::new();
        let mut base = 0;
        for g in list {
            grids.push((g, base));
            base += g.len();
        }
        let regions = grids
            .iter()
            .flat_map(|(g, _)| (0..g.len()).map(move |k| g.region(k, w, h)))
            .collect();
        Self { grids, regions }
    }

    pub fn len(&self) -> usize {
        self.regions.len()
    }

    /// Numbers of the tiles (one per grid) that contain pixel (x, y).
    pub fn tiles_of(&self, x: usize, y: usize) -> impl Iterator<Item = usize> + '_ {
        self.grids.iter().map(move |(g, base)| base + g.index(x, y))
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

/// Outcome of the tile tests of one channel.
pub(super) struct TileTests {
    pub report: TileReport,
    /// Holm-adjusted p of every tile by number (None: not tested, no variance).
    pub p_holm: Vec<Option<f64>>,
    pub failure: Option<Failure>,
}

/// Welch t-test of every tile with variance, Holm over them, rejection at `alpha_test`.
pub(super) fn tile_tests(
    sums: &[Sums],
    grids: &TileGrids,
    nu: (f64, f64),
    alpha_test: f64,
    channel: &'static str,
) -> TileTests {
    let mut tested = Vec::new();
    let mut results = Vec::new();
    for (k, s) in sums.iter().enumerate() {
        if let Some((t, dof, se)) = s.welch(nu.0, nu.1) {
            tested.push(k);
            let p = t_two_sided_p(t, dof);
            results.push(TileResult {
                region: grids.regions[k],
                mean_diff: (s.ma - s.mb) / s.n as f64,
                std_err: se,
                dof,
                p,
                p_holm: p,
            });
        }
    }
    let raw: Vec<f64> = results.iter().map(|r| r.p).collect();
    let mut p_holm = vec![None; sums.len()];
    for ((r, adj), &k) in results.iter_mut().zip(holm_adjust(&raw)).zip(&tested) {
        r.p_holm = adj;
        p_holm[k] = Some(adj);
    }
    let rejected = results.iter().filter(|r| r.p_holm <= alpha_test).count();
    let worst = results
        .iter()
        .min_by(|x, y| x.p_holm.total_cmp(&y.p_holm).then(x.p.total_cmp(&y.p)))
        .cloned();
    let failure = worst.as_ref().filter(|_| rejected > 0).map(|wt| Failure {
        test: TestKind::Tile,
        channel,
        region: Some(wt.region),
        detail: format!(
            "{rejected} tile(s) differ; worst at ({}, {}): mean difference {:+.4e} ± {:.2e}, Holm p = {:.3e} ≤ {:.3e}",
            wt.region.x, wt.region.y, wt.mean_diff, wt.std_err, wt.p_holm, alpha_test
        ),
    });
    TileTests {
        report: TileReport {
            tiles_total: sums.len(),
            tiles_tested: results.len(),
            rejected,
            worst,
        },
        p_holm,
        failure,
    }
}
