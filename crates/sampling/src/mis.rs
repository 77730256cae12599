//! Multiple importance sampling heuristics as plain functions (docs/measures.md "MIS").
//!
//! Every function returns the MIS *weight* w_s of a sample drawn from technique s (density p_s)
//! when the other technique o has density p_o at that direction. The estimator contribution is
//! f · w_s / p_s; docs/measures.md writes the contributions directly, e.g. balance f/(p_s + p_o) =
//! f · [p_s/(p_s + p_o)] / p_s. Densities must be in the same measure (per radius here).
//!
//! Zero-safety: no function returns NaN or ∞ for finite non-negative inputs. If both densities
//! vanish the weight is 0 (such a sample cannot have been drawn by s, so its weight is
//! irrelevant); if the technique weights W vanish both, the weighted heuristics fall back to the
//! balance heuristic. With p_s + p_o > 0 the weights of the two techniques sum to 1, which keeps
//! the combined estimator unbiased.
// `!(x > 0.0)` is deliberate throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

/// Balance heuristic p_s/(p_s + p_o) (scaled by the larger density: no overflow of the sum).
#[inline]
pub fn balance(p_s: f32, p_o: f32) -> f32 {
    let m = p_s.max(p_o);
    if !(m > 0.0) {
        return 0.0;
    }
    let (a, b) = (p_s / m, p_o / m);
    ratio(a, a + b)
}

/// Power heuristic (β = 2): p_s²/(p_s² + p_o²). Scaled by the larger density first so that the
/// squares neither overflow nor underflow.
#[inline]
pub fn power(p_s: f32, p_o: f32) -> f32 {
    let m = p_s.max(p_o);
    if !(m > 0.0) {
        return 0.0;
    }
    let (a, b) = (p_s / m, p_o / m);
    ratio(a * a, a * a + b * b)
}

/// Weighted balance heuristic W_s p_s/(W_s p_s + W_o p_o) with non-negative technique weights
/// (docs/measures.md: W_d = max(ρ_diffuse, 0.01)·Ω⊥_R, W_s = ρ_LTC·Ω⊥_o/κ). Falls back to [`balance`]
/// when W_s p_s + W_o p_o = 0 while p_s + p_o > 0.
#[inline]
pub fn weighted_balance(p_s: f32, p_o: f32, w_s: f32, w_o: f32) -> f32 {
    let m = p_s.max(p_o);
    if !(m > 0.0) {
        return 0.0;
    }
    let num = w_s * (p_s / m);
    let den = num + w_o * (p_o / m);
    if den > 0.0 && den.is_finite() {
        ratio(num, den)
    } else {
        balance(p_s, p_o)
    }
}

/// Clamped optimal heuristic of the paper: (1 − v)·balance + v·weighted balance, with v ∈ [0, 1]
/// a visibility estimate (0.5 in every experiment of the paper); v is clamped to [0, 1].
#[inline]
pub fn clamped_optimal(p_s: f32, p_o: f32, w_s: f32, w_o: f32, v: f32) -> f32 {
    let v = if v >= 0.0 { v.min(1.0) } else { 0.0 }; // NaN → 0
    (1.0 - v) * balance(p_s, p_o) + v * weighted_balance(p_s, p_o, w_s, w_o)
}

/// num/den in [0, 1] for 0 ≤ num ≤ den; 0 when den is 0 or not finite.
#[inline]
fn ratio(num: f32, den: f32) -> f32 {
    if den > 0.0 && den.is_finite() {
        (num / den).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DENSITIES: [f32; 8] = [0.0, 1e-30, 1e-6, 0.3, 1.0, 7.5, 1e20, 3e38];

    #[test]
    fn weights_of_both_techniques_sum_to_one() {
        for &p in &DENSITIES {
            for &q in &DENSITIES {
                let both_zero = p == 0.0 && q == 0.0;
                let sums = [
                    balance(p, q) + balance(q, p),
                    power(p, q) + power(q, p),
                    weighted_balance(p, q, 0.2, 3.0) + weighted_balance(q, p, 3.0, 0.2),
                    weighted_balance(p, q, 0.0, 0.0) + weighted_balance(q, p, 0.0, 0.0),
                    clamped_optimal(p, q, 0.2, 3.0, 0.5) + clamped_optimal(q, p, 3.0, 0.2, 0.5),
                    clamped_optimal(p, q, 1.0, 0.0, 0.3) + clamped_optimal(q, p, 0.0, 1.0, 0.3),
                ];
                for (k, s) in sums.iter().enumerate() {
                    assert!(s.is_finite(), "heuristic {k}: p={p} q={q}");
                    if both_zero {
                        assert_eq!(*s, 0.0, "heuristic {k}");
                    } else {
                        assert!((s - 1.0).abs() < 1e-6, "heuristic {k}: p={p} q={q}: {s}");
                    }
                }
            }
        }
    }

    #[test]
    fn known_values() {
        assert_eq!(balance(1.0, 3.0), 0.25);
        assert_eq!(power(1.0, 3.0), 0.1);
        assert!((weighted_balance(1.0, 3.0, 2.0, 1.0) - 0.4).abs() < 1e-7);
        // v = 0 is balance, v = 1 weighted balance, 0.5 their mean.
        assert_eq!(clamped_optimal(1.0, 3.0, 2.0, 1.0, 0.0), 0.25);
        assert!((clamped_optimal(1.0, 3.0, 2.0, 1.0, 1.0) - 0.4).abs() < 1e-7);
        assert!((clamped_optimal(1.0, 3.0, 2.0, 1.0, 0.5) - 0.325).abs() < 1e-7);
        assert_eq!(clamped_optimal(1.0, 3.0, 2.0, 1.0, f32::NAN), 0.25);
        // A technique with zero density elsewhere gets the full weight.
        assert_eq!(balance(2.0, 0.0), 1.0);
        assert_eq!(power(0.0, 2.0), 0.0);
    }
}
