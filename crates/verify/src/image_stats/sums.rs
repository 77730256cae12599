//! Running sums over a set of pixels of one channel, and the Welch t-test of their means.

// `!(x > 0.0)` is deliberate: it treats NaN as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

/// Running sums of a set of pixels of one channel: Σm_A, Σm_B, Σv_A, Σv_B and Σv² (the
/// Welch–Satterthwaite denominators). The means of the set are Σm/n, the variance of their
/// difference (Σv_A + Σv_B)/n² (pixels are independent).
#[derive(Clone, Copy, Default)]
pub(super) struct Sums {
    pub n: usize,
    pub ma: f64,
    pub mb: f64,
    pub va: f64,
    pub vb: f64,
    pub va2: f64,
    pub vb2: f64,
}

impl Sums {
    pub fn add(&mut self, ma: f64, mb: f64, va: f64, vb: f64) {
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
    pub fn dof(&self, k: f64, nu_a: f64, nu_b: f64) -> f64 {
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
    pub fn welch(&self, nu_a: f64, nu_b: f64) -> Option<(f64, f64, f64)> {
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
