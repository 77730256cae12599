//! Per-pixel statistics of one channel: the normal score z of every pixel with variance, the
//! zero-variance check of the others, and the two pixel-level tests (Σz² against χ²(N), max|z|
//! against its Šidák threshold).

use statrs::distribution::{ChiSquared, ContinuousCDF};

use super::{Failure, PixelReport, Region, TestKind};
use crate::z_score::{normal_two_sided_quantile, normal_upper_tail, sidak, t_to_z, welch_dof};

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
