//! The image-wide tests of one channel: the Welch t-test of the global mean difference, and
//! the equivalence test of the relative global difference against the margin ±δ.

// `!(x > 0.0)` is deliberate: it treats NaN as "not positive".
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::sums::Sums;
use super::{Failure, GlobalReport, TestKind};
use crate::z_score::{t_two_sided_p, t_two_sided_quantile};

/// Levels and margin of the global tests.
pub(super) struct GlobalLevels {
    /// Level of the difference test.
    pub alpha_test: f64,
    /// Level of each channel's equivalence interval.
    pub alpha_eq: f64,
    /// Equivalence margin δ.
    pub tolerance: f64,
}

/// Global mean difference and equivalence of one channel; failures of either test.
pub(super) fn global_tests(
    global: &Sums,
    nu: (f64, f64),
    levels: &GlobalLevels,
    channel: &'static str,
) -> (GlobalReport, Vec<Failure>) {
    let nf = global.n as f64;
    let (mean_a, mean_b) = (global.ma / nf, global.mb / nf);
    let (p, dof, std_err) = match global.welch(nu.0, nu.1) {
        Some((t, dof, se)) => (Some(t_two_sided_p(t, dof)), Some(dof), se),
        None => (None, None, 0.0),
    };
    let significant = p.is_some_and(|p| p <= levels.alpha_test);
    let (rel_diff, rel_ci) = relative_ci(global, nu.0, nu.1, levels.alpha_eq);
    let (rel_var_a, rel_var_b) = relative_variances(global);
    let tol = levels.tolerance;
    let equivalent = rel_ci.is_some_and(|[lo, hi]| lo >= -tol && hi <= tol);
    let mut failures = Vec::new();
    if significant {
        failures.push(Failure {
            test: TestKind::GlobalMean,
            channel,
            region: None,
            detail: format!(
                "global mean differs: {:+.4e} ± {:.2e} (p = {:.3e} ≤ {:.3e})",
                mean_a - mean_b,
                std_err,
                p.unwrap_or(0.0),
                levels.alpha_test
            ),
        });
    }
    if !equivalent {
        let detail = match (rel_diff, rel_ci) {
            (Some(r), Some([lo, hi])) => format!(
                "relative difference {:+.3}% with {:.2}% CI [{:+.3}%, {:+.3}%] not within ±{:.3}%",
                100.0 * r,
                100.0 * (1.0 - levels.alpha_eq),
                100.0 * lo,
                100.0 * hi,
                100.0 * tol
            ),
            _ => format!("reference mean is {mean_b:e}: relative difference undefined"),
        };
        failures.push(Failure {
            test: TestKind::Equivalence,
            channel,
            region: None,
            detail,
        });
    }
    let report = GlobalReport {
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
        rel_var_a,
        rel_var_b,
    };
    (report, failures)
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

/// The two terms of Var r (delta method): Var Ḡ_A/Ḡ_B² and R²·Var Ḡ_B/Ḡ_B², R = Ḡ_A/Ḡ_B; what
/// each image contributes to the uncertainty of the relative difference. (0, 0) if Ḡ_B = 0.
fn relative_variances(s: &Sums) -> (f64, f64) {
    let n = s.n as f64;
    let (ga, gb) = (s.ma / n, s.mb / n);
    if gb == 0.0 || !gb.is_finite() {
        return (0.0, 0.0);
    }
    let ratio = ga / gb;
    let d = (n * gb) * (n * gb);
    (s.va / d, ratio * ratio * s.vb / d)
}
