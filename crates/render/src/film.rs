//! Per-pixel accumulation: mean and variance of the mean from independent samples (Welford, in
//! f64), and the combination of independent passes.

/// Counts whose reciprocal is read from [`RECIPROCALS`].
const TABLED: usize = 1024;

/// `RECIPROCALS[n]` = 1/n rounded (the bits of the division `1.0 / n as f64`: IEEE division
/// is correctly rounded, in constant evaluation too); entry 0 is unused.
static RECIPROCALS: [f64; TABLED] = {
    let mut t = [0.0; TABLED];
    let mut n = 1;
    while n < TABLED {
        t[n] = 1.0 / n as f64;
        n += 1;
    }
    t
};

/// 1/n rounded, for n ≥ 1: read from a table below [`TABLED`] (the same bits as the
/// division, without one f64 division per sample on the divider that the light-sample batch's
/// divisions and square roots use).
#[inline(always)]
fn reciprocal(n: u64) -> f64 {
    if (n as usize) < TABLED {
        RECIPROCALS[n as usize]
    } else {
        // Through i64: one conversion instruction without AVX-512 (u64 → f64 takes five),
        // the same value for every count below 2^63.
        1.0 / n as i64 as f64
    }
}

/// Running mean and sum of squared deviations of independent RGB samples, and their extremes
/// (for the heavy-tail share).
///
/// The channels are stored as quads (R, G, B and a fourth lane that is never read) so that a
/// push is one 4-wide operation per step where the target has 256-bit f64 vectors: each lane
/// still runs exactly the scalar operations of the update ([`Self::push_quad`]; IEEE
/// operations, the fused multiply-add included, are lane-wise and correctly rounded), so the
/// bits are those of three scalar chains, on every target.
#[derive(Clone, Copy, Debug)]
pub struct Welford {
    n: u64,
    mean: [f64; 4],
    m2: [f64; 4],
    min: [f64; 4],
    max: [f64; 4],
}

impl Default for Welford {
    fn default() -> Self {
        Self {
            n: 0,
            mean: [0.0; 4],
            m2: [0.0; 4],
            min: [f64::INFINITY; 4],
            max: [f64::NEG_INFINITY; 4],
        }
    }
}

impl Welford {
    #[inline]
    pub fn push(&mut self, x: [f64; 3]) {
        self.push_quad([x[0], x[1], x[2], 0.0]);
    }

    /// [`Self::push`] of (R, G, B) = `x[0..3]`; `x[3]` goes into the unused lane (any value:
    /// the lanes do not mix, and the fourth is never read).
    ///
    /// Welford's update with the mean's step fused: mean ← fma(δ, 1/n, mean), δ = x − mean
    /// (one rounding instead of two: δ·(1/n) is not rounded on its own), then Welford's M2
    /// step M2 ← M2 + δ·(x − mean). The serial chain of the running mean is a subtraction and
    /// a fused multiply-add per sample instead of a subtraction, a product and a sum (1/n does
    /// not depend on it): the packet renderer pushes a packet's sixteen lanes of one pixel one
    /// after the other, so that chain bounds the push's time. Same statistic, same
    /// error bounds as the textbook step mean + δ/n (1/n rounded within u = 2⁻⁵³ relative, each
    /// step's result rounded once; M2 keeps Welford's stability, Chan, Golub & LeVeque 1983:
    /// relative error O(n·κ·u) after n samples, κ the data's condition number;
    /// `fused_mean_keeps_welfords_accuracy`), and constant samples keep an exact mean and a
    /// zero M2 (δ = 0). Images differ from the unfused update's at rounding level only. The
    /// extremes use `f64::min`/`max` (a NaN sample leaves them; the samples are finite anyway):
    /// written as compare-selects, LLVM merged min and max into one select chain longer than
    /// the mean's.
    #[inline(always)]
    pub fn push_quad(&mut self, x: [f64; 4]) {
        self.n += 1;
        let inv = reciprocal(self.n);
        // One loop over the four lanes, each step the same on every lane (vectorised).
        #[allow(clippy::needless_range_loop)] // lane c of x and of every field
        for c in 0..4 {
            let delta = x[c] - self.mean[c];
            self.mean[c] = delta.mul_add(inv, self.mean[c]);
            self.m2[c] += delta * (x[c] - self.mean[c]);
            // A compare, a min/max and a masked move each (see above).
            self.min[c] = self.min[c].min(x[c]);
            self.max[c] = self.max[c].max(x[c]);
        }
    }

    pub fn count(&self) -> u64 {
        self.n
    }

    pub fn mean(&self) -> [f64; 3] {
        [self.mean[0], self.mean[1], self.mean[2]]
    }

    /// Unbiased estimate of the variance of the mean, M2/((n − 1)·n); 0 when n < 2 (the
    /// image then reports dof = 0).
    pub fn variance_of_mean(&self) -> [f64; 3] {
        if self.n < 2 {
            return [0.0; 3];
        }
        let k = 1.0 / ((self.n - 1) as f64 * self.n as f64);
        std::array::from_fn(|c| (self.m2[c] * k).max(0.0))
    }

    /// Heavy-tail share: max_i (x_i − x̄)² / Σ_i (x_i − x̄)², the part of the sum of squares
    /// that the most extreme term contributes (the largest deviation is at the minimum or the
    /// maximum). 0 when the sum is 0. For n normal terms it is about 2 ln n / n; near 1 it says
    /// the variance estimate rests on one term.
    pub fn tail_share(&self) -> [f64; 3] {
        std::array::from_fn(|c| {
            let dev = (self.max[c] - self.mean[c]).max(self.mean[c] - self.min[c]);
            if self.m2[c] > 0.0 && dev.is_finite() {
                (dev * dev / self.m2[c]).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_two_pass_formulas() {
        let xs = [1.0, 2.5, -0.5, 4.0, 3.25];
        let mut w = Welford::default();
        for &x in &xs {
            w.push([x, 2.0 * x, 0.0]);
        }
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) / n;
        assert!((w.mean()[0] - mean).abs() < 1e-12);
        assert!((w.variance_of_mean()[0] - var).abs() < 1e-12);
        assert!((w.variance_of_mean()[1] - 4.0 * var).abs() < 1e-12);
        assert_eq!(w.variance_of_mean()[2], 0.0);
        let mut one = Welford::default();
        one.push([1.0; 3]);
        assert_eq!(one.variance_of_mean(), [0.0; 3]);
        assert_eq!(one.tail_share(), [0.0; 3]);
        // Tail share: the largest squared deviation over their sum.
        let dev2: Vec<f64> = xs.iter().map(|x| (x - mean).powi(2)).collect();
        let share = dev2.iter().cloned().fold(0.0, f64::max) / dev2.iter().sum::<f64>();
        assert!((w.tail_share()[0] - share).abs() < 1e-12);
        assert_eq!(w.tail_share()[2], 0.0);
        // One outlier among zeros carries (n − 1)/n of the sum of squares.
        let mut rare = Welford::default();
        for i in 0..100 {
            rare.push([if i == 37 { 50.0 } else { 0.0 }; 3]);
        }
        assert!((rare.tail_share()[1] - 0.99).abs() < 1e-12);
    }

    /// The quad push gives the bits of three independent scalar chains of the update written
    /// out here as the reference (the mean's step by one fused multiply-add, Welford's M2
    /// step), and the fourth lane does not reach the three channels, whatever it holds (NaN,
    /// 1e300).
    #[test]
    fn quad_pushes_are_the_scalar_pushes() {
        let (mut a, mut b) = (Welford::default(), Welford::default());
        // Reference: per channel, mean and M2 updated one scalar at a time.
        let (mut mean, mut m2) = ([0.0f64; 3], [0.0f64; 3]);
        for i in 0..50 {
            let x = [
                0.1 * i as f64,
                (i as f64).sin() * 1e3,
                1.0 / (1.0 + i as f64),
            ];
            a.push(x);
            b.push_quad([x[0], x[1], x[2], if i % 2 == 0 { f64::NAN } else { 1e300 }]);
            let inv = 1.0 / (i + 1) as f64;
            for c in 0..3 {
                let delta = x[c] - mean[c];
                mean[c] = delta.mul_add(inv, mean[c]);
                m2[c] += delta * (x[c] - mean[c]);
            }
        }
        let bits = |w: &Welford| {
            [w.mean(), w.variance_of_mean(), w.tail_share()].map(|v| v.map(f64::to_bits))
        };
        assert_eq!(bits(&a), bits(&b));
        assert_eq!(a.count(), b.count());
        let k = 1.0 / (49.0 * 50.0);
        assert_eq!(a.mean().map(f64::to_bits), mean.map(f64::to_bits));
        assert_eq!(
            a.variance_of_mean().map(f64::to_bits),
            m2.map(|m| (m * k).max(0.0).to_bits())
        );
    }

    /// The table holds the division's bits, and counts past it divide.
    #[test]
    fn reciprocals_are_the_divisions() {
        for n in 1..TABLED as u64 + 5 {
            assert_eq!(
                reciprocal(n).to_bits(),
                (1.0 / n as f64).to_bits(),
                "n = {n}"
            );
        }
    }

    /// The fused mean stays within rounding of the exact mean, as the unfused update
    /// (mean + δ/n) does, and M2 of the two-pass sum, on data far from zero (mean 1e6, spread
    /// 1: condition number ≈ 3.5e6), where the naive Σx² − (Σx)²/n would lose ≈ 13 digits.
    #[test]
    fn fused_mean_keeps_welfords_accuracy() {
        let mut w = Welford::default();
        let (mut mean, mut m2) = (0.0f64, 0.0f64);
        let xs: Vec<f64> = (0..10_000)
            .map(|i| 1e6 + ((i as f64) * 0.618_033_988_749_895).fract() - 0.5)
            .collect();
        for (i, &x) in xs.iter().enumerate() {
            w.push([x; 3]);
            let delta = x - mean;
            mean += delta / (i + 1) as f64;
            m2 += delta * (x - mean);
        }
        let n = xs.len() as f64;
        let exact = xs.iter().sum::<f64>() / n;
        let two_pass = xs.iter().map(|x| (x - exact).powi(2)).sum::<f64>();
        // Rounding errors of about ε·|mean| per step, as a random walk: √n·ε·|mean| (seen: 8.4
        // for both).
        let walk = (n.sqrt() * f64::EPSILON * exact).abs();
        assert!(
            (w.mean()[0] - exact).abs() <= walk,
            "{} vs {exact}",
            w.mean()[0]
        );
        assert!((mean - exact).abs() <= walk);
        // M2 within 1e-10 relative of the two-pass sum (seen: 8.3e-13, the textbook 7.5e-13).
        let m2_fused = w.variance_of_mean()[0] * (n - 1.0) * n;
        assert!(
            (m2_fused - two_pass).abs() <= 1e-10 * two_pass,
            "{m2_fused} vs {two_pass}"
        );
        assert!((m2 - two_pass).abs() <= 1e-10 * two_pass);
    }
}
