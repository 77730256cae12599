//! Blue-noise dither arrays by void-and-cluster (R. Ulichney, *The void-and-cluster method for
//! dither array generation*, SPIE 1913, 1993), on a 64×64 torus.
//!
//! A dither array is a permutation of the ranks 0…4095 over the 4096 texels such that, for every
//! threshold k, the k texels of smallest rank are spread as evenly as possible (no clusters, no
//! voids): the array's power spectrum has almost no energy at low frequencies. "Evenly" is
//! measured by the energy E(p) = Σ_q∈ones g(p − q) of a toroidal Gaussian g (σ = 1.5 texels):
//! the tightest cluster is the one with the largest E among the ones, the largest void the zero
//! with the smallest E. With a symmetric g on a torus, Σ_all g(p − q) is the same for every p, so
//! "the tightest cluster of zeros" of Ulichney's third phase is the largest void of the ones, and
//! phases 2 and 3 are one loop.
//!
//! Determinism: energies are integers (g scaled by 2¹⁶ and rounded, which cuts g off beyond
//! r ≈ 7.3 texels where g < 2⁻¹⁷), so every add and subtract is exact and the array depends on
//! nothing but the seed — not on the platform's libm, the thread count or the order of
//! generation. g itself comes from f64 arithmetic with a series exp (no libm). Ties go to the
//! lowest texel index.
//!
//! Cost: per row the largest one and the smallest zero are kept and updated from the 15×15
//! window a flip changes, so a step costs a few hundred operations instead of a scan of 4096
//! texels: ~4 CPU-ms per array, ~1.2 CPU-s for the 256 arrays of the table.

use crate::philox::philox4x32_10;

/// Side of the dither arrays.
pub const SIDE: usize = 64;
/// Texels of one array.
pub const TEXELS: usize = SIDE * SIDE;
/// Width of the Gaussian energy filter, in texels (Ulichney's choice).
pub const SIGMA: f64 = 1.5;
/// Fraction of ones in the initial binary pattern.
const INITIAL_DENSITY: f64 = 0.1;
/// Radius (in texels along each axis) beyond which the scaled filter rounds to 0.
const RADIUS: usize = 7;
/// Scale of the integer filter.
const SCALE: f64 = 65_536.0;

/// e^x for x ≤ 0 by argument halving and a Taylor series: plain f64 arithmetic, the same on
/// every IEEE platform (libm's exp may differ in the last bit between platforms).
fn exp_neg(x: f64) -> f64 {
    debug_assert!(x <= 0.0);
    let mut halvings = 0;
    let mut y = x;
    while y < -0.5 {
        y *= 0.5;
        halvings += 1;
    }
    let (mut term, mut sum) = (1.0f64, 1.0f64);
    for k in 1..30 {
        term *= y / k as f64;
        sum += term;
    }
    for _ in 0..halvings {
        sum *= sum;
    }
    sum
}

/// The integer filter g(dx, dy) for |dx|, |dy| ≤ RADIUS, row-major over (dy + RADIUS, dx + RADIUS).
fn filter() -> Vec<u32> {
    let side = 2 * RADIUS + 1;
    let mut g = vec![0u32; side * side];
    for dy in 0..side {
        for dx in 0..side {
            let (x, y) = (dx as f64 - RADIUS as f64, dy as f64 - RADIUS as f64);
            let v = exp_neg(-(x * x + y * y) / (2.0 * SIGMA * SIGMA));
            g[dy * side + dx] = (v * SCALE).round() as u32;
        }
    }
    g
}

/// Energy field of a binary pattern with per-row extrema.
#[derive(Clone)]
struct Field {
    ones: Vec<bool>,
    energy: Vec<u32>,
    g: Vec<u32>,
    /// Per row, packed so that one integer comparison orders by energy, then by index:
    /// the largest (energy << 32 | (0xFFFF − p)) over the row's ones (0: none), and the smallest
    /// (energy << 32 | p) over its zeros (u64::MAX: none).
    row_extrema: Vec<(u64, u64)>,
}

impl Field {
    fn new() -> Self {
        Self {
            ones: vec![false; TEXELS],
            energy: vec![0; TEXELS],
            g: filter(),
            row_extrema: vec![(0, u64::MAX); SIDE],
        }
    }

    /// Set texel `p` to `one` and update the energies around it (exact integer arithmetic).
    fn set(&mut self, p: usize, one: bool) {
        debug_assert_ne!(self.ones[p], one);
        self.ones[p] = one;
        let (px, py) = (p % SIDE, p / SIDE);
        let side = 2 * RADIUS + 1;
        for dy in 0..side {
            let y = (py + SIDE + dy - RADIUS) % SIDE;
            let row = &mut self.energy[y * SIDE..(y + 1) * SIDE];
            let g = &self.g[dy * side..(dy + 1) * side];
            for (dx, &gv) in g.iter().enumerate() {
                let x = (px + SIDE + dx - RADIUS) % SIDE;
                if one {
                    row[x] += gv;
                } else {
                    row[x] -= gv;
                }
            }
        }
        // Row extrema: energies rose (fell) only in the window's columns, so the largest one
        // (smallest zero) is the old one or a window texel; the other extremum changes only if
        // it lay in the window, and then the row is scanned again.
        let x0 = (px + SIDE - RADIUS) % SIDE;
        let in_window = |q: usize| (q % SIDE + SIDE - x0) % SIDE < side;
        for dy in 0..side {
            let y = (py + SIDE + dy - RADIUS) % SIDE;
            let (hi, lo) = self.row_extrema[y];
            let rescan = if one {
                lo == u64::MAX || in_window((lo & 0xFFFF) as usize)
            } else {
                hi == 0 || in_window(0xFFFF - (hi & 0xFFFF) as usize)
            };
            if rescan {
                self.update_row(y);
                continue;
            }
            let (mut whi, mut wlo) = (hi, lo);
            for dx in 0..side {
                let q = y * SIDE + (x0 + dx) % SIDE;
                let (e, p) = ((self.energy[q] as u64) << 32, q as u64);
                if self.ones[q] {
                    whi = whi.max(e | (0xFFFF - p));
                } else {
                    wlo = wlo.min(e | p);
                }
            }
            self.row_extrema[y] = if one { (whi, lo) } else { (hi, wlo) };
        }
    }

    /// Branch-free extrema of one row (vectorises).
    fn update_row(&mut self, y: usize) {
        let (mut hi, mut lo) = (0u64, u64::MAX);
        let base = y * SIDE;
        for (i, (&e, &one)) in self.energy[base..base + SIDE]
            .iter()
            .zip(&self.ones[base..base + SIDE])
            .enumerate()
        {
            let p = (base + i) as u64;
            let e = (e as u64) << 32;
            let as_one = if one { e | (0xFFFF - p) } else { 0 };
            let as_zero = if one { u64::MAX } else { e | p };
            hi = hi.max(as_one);
            lo = lo.min(as_zero);
        }
        self.row_extrema[y] = (hi, lo);
    }

    /// Every row's extrema (rows no flip has touched yet still hold zeros).
    fn refresh(&mut self) {
        for y in 0..SIDE {
            self.update_row(y);
        }
    }

    /// The one with the largest energy (lowest index among equals).
    fn tightest_cluster(&self) -> Option<usize> {
        let hi = self.row_extrema.iter().map(|r| r.0).max()?;
        (hi != 0).then(|| 0xFFFF - (hi & 0xFFFF) as usize)
    }

    /// The zero with the smallest energy (lowest index among equals).
    fn largest_void(&self) -> Option<usize> {
        let lo = self.row_extrema.iter().map(|r| r.1).min()?;
        (lo != u64::MAX).then_some((lo & 0xFFFF) as usize)
    }
}

/// One 64×64 dither array: the rank (0…4095) of every texel, row-major. Deterministic in
/// `seed` (the initial random pattern is Philox of (seed; texel)).
pub fn dither_array(seed: u64) -> Vec<u16> {
    let mut field = Field::new();
    // Initial binary pattern: the INITIAL_DENSITY·N texels of smallest random key.
    let key = [seed as u32, (seed >> 32) as u32];
    let mut order: Vec<(u32, usize)> = (0..TEXELS)
        .map(|p| (philox4x32_10([p as u32, 0x766f_6964, 0, 0], key)[0], p))
        .collect();
    order.sort_unstable();
    let initial = (INITIAL_DENSITY * TEXELS as f64).round() as usize;
    for &(_, p) in &order[..initial] {
        field.set(p, true);
    }
    field.refresh();
    // Relax it: move the tightest cluster into the largest void until that changes nothing.
    // Every move lowers the total pair energy, so this ends; the cap only guards the proof.
    for _ in 0..TEXELS * 4 {
        let cluster = field.tightest_cluster().expect("the pattern has ones");
        field.set(cluster, false);
        let void = field.largest_void().expect("the pattern has zeros");
        field.set(void, true);
        if void == cluster {
            break;
        }
    }
    let mut filling = field.clone();
    let mut rank = vec![0u16; TEXELS];
    // Phase 1: remove the tightest cluster, ranks initial − 1 down to 0.
    for r in (0..initial).rev() {
        let p = field.tightest_cluster().expect("ones left");
        field.set(p, false);
        rank[p] = r as u16;
    }
    // Phases 2 and 3: from the relaxed pattern, fill the largest void, ranks initial … N − 1.
    for r in initial..TEXELS {
        let p = filling.largest_void().expect("zeros left");
        filling.set(p, true);
        rank[p] = r as u16;
    }
    rank
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_exp_matches_std() {
        for x in [0.0, -0.1, -0.5, -1.0, -3.7, -10.0, -21.8] {
            let (a, b) = (exp_neg(x), f64::exp(x));
            assert!((a - b).abs() <= 1e-14 * b, "{x}: {a} vs {b}");
        }
    }

    #[test]
    fn filter_is_cut_where_it_rounds_to_zero() {
        let g = filter();
        let side = 2 * RADIUS + 1;
        assert_eq!(g[RADIUS * side + RADIUS], 65_536);
        // Symmetric, and the corner of the window is 0 (so the window loses nothing).
        assert_eq!(g[0], 0);
        assert!(g[RADIUS * side] > 0, "g(7, 0) = {}", g[RADIUS * side]);
        for dy in 0..side {
            for dx in 0..side {
                assert_eq!(g[dy * side + dx], g[dx * side + dy]);
                assert_eq!(g[dy * side + dx], g[(side - 1 - dy) * side + dx]);
            }
        }
    }

    #[test]
    fn a_dither_array_is_a_permutation_and_deterministic() {
        let a = dither_array(7);
        let mut seen = vec![false; TEXELS];
        for &r in &a {
            assert!(!seen[r as usize], "rank {r} twice");
            seen[r as usize] = true;
        }
        assert_eq!(a, dither_array(7));
        assert_ne!(a, dither_array(8));
    }

    /// Every threshold pattern is spread out: the k texels of smallest rank never sit next to
    /// each other (8-neighbourhood) for k up to 1/9 of the texels (a dense square packing at
    /// spacing 3 holds 1/9). White noise at that density has ~30 % of its points with a
    /// neighbour.
    #[test]
    fn sparse_thresholds_have_no_adjacent_points() {
        let a = dither_array(3);
        let k = TEXELS / 12;
        let on = |x: usize, y: usize| (a[(y % SIDE) * SIDE + x % SIDE] as usize) < k;
        let mut adjacent = 0;
        for y in 0..SIDE {
            for x in 0..SIDE {
                if on(x, y)
                    && [(1, 0), (1, 1), (0, 1), (SIDE - 1, 1)]
                        .iter()
                        .any(|&(dx, dy)| on(x + dx, y + dy))
                {
                    adjacent += 1;
                }
            }
        }
        assert_eq!(adjacent, 0, "{adjacent} adjacent pairs at k = {k}");
    }
}
