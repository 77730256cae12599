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
/// a visibility estimate (0.5 in every experiment of the paper); v is clamped to [0, 1]. At
/// v = 0 it is [`balance`] and at v = 1 [`weighted_balance`], bit for bit (see
/// [`Heuristic::same_weights_as`]).
#[inline]
pub fn clamped_optimal(p_s: f32, p_o: f32, w_s: f32, w_o: f32, v: f32) -> f32 {
    let v = if v >= 0.0 { v.min(1.0) } else { 0.0 }; // NaN → 0
    if v == 0.0 {
        balance(p_s, p_o)
    } else if v == 1.0 {
        weighted_balance(p_s, p_o, w_s, w_o)
    } else {
        (1.0 - v) * balance(p_s, p_o) + v * weighted_balance(p_s, p_o, w_s, w_o)
    }
}

/// A heuristic of the diffuse + specular estimator, chosen at run time (`--mis`).
///
/// [`Heuristic::weight`] is the weight w_s of a sample drawn from technique s; per RGB channel
/// for the weighted heuristics (their technique weights W are per channel). For every heuristic
/// and every v, `weight(p, q, W, W') + weight(q, p, W', W) = 1` whenever p + q > 0, which is what
/// makes the combined estimator unbiased.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Heuristic {
    /// [`balance`].
    Balance,
    /// [`power`] (β = 2).
    Power,
    /// [`weighted_balance`] with the technique weights W.
    Weighted,
    /// [`clamped_optimal`] with the visibility estimate v ∈ [0, 1] (the paper: 0.5).
    ClampedOptimal(f32),
}

impl Default for Heuristic {
    /// The paper's choice: clamped optimal with v = 0.5.
    fn default() -> Self {
        Heuristic::ClampedOptimal(0.5)
    }
}

impl Heuristic {
    /// Every heuristic with its default parameters, for listings (`--help`).
    pub const ALL: [Heuristic; 4] = [
        Heuristic::Balance,
        Heuristic::Power,
        Heuristic::Weighted,
        Heuristic::ClampedOptimal(0.5),
    ];

    /// The weight of a sample of technique s: density p_s of its own technique, p_o of the
    /// other, technique weights w_s, w_o (ignored by balance and power).
    #[inline]
    pub fn weight(self, p_s: f32, p_o: f32, w_s: f32, w_o: f32) -> f32 {
        match self {
            Heuristic::Balance => balance(p_s, p_o),
            Heuristic::Power => power(p_s, p_o),
            Heuristic::Weighted => weighted_balance(p_s, p_o, w_s, w_o),
            Heuristic::ClampedOptimal(v) => clamped_optimal(p_s, p_o, w_s, w_o, v),
        }
    }

    /// The heuristic whose weights this one's are for every input, bit for bit: clamped
    /// optimal at v = 0 is [`Heuristic::Balance`], at v = 1 [`Heuristic::Weighted`]; every
    /// other heuristic is itself. Renders of the two are the same image.
    pub fn same_weights_as(self) -> Heuristic {
        match self {
            Heuristic::ClampedOptimal(v) if !(v > 0.0) => Heuristic::Balance,
            Heuristic::ClampedOptimal(v) if v >= 1.0 => Heuristic::Weighted,
            h => h,
        }
    }

    /// Whether the weight depends on the technique weights W (then it differs per channel).
    #[inline]
    pub fn uses_technique_weights(self) -> bool {
        matches!(self, Heuristic::Weighted | Heuristic::ClampedOptimal(_))
    }

    /// Name without parameter: `balance`, `power`, `weighted`, `clamped-optimal`.
    pub fn name(self) -> &'static str {
        match self {
            Heuristic::Balance => "balance",
            Heuristic::Power => "power",
            Heuristic::Weighted => "weighted",
            Heuristic::ClampedOptimal(_) => "clamped-optimal",
        }
    }

    /// The visibility estimate v of clamped optimal.
    pub fn v(self) -> Option<f32> {
        match self {
            Heuristic::ClampedOptimal(v) => Some(v),
            _ => None,
        }
    }
}

impl std::fmt::Display for Heuristic {
    /// `balance`, `power`, `weighted`, `clamped-optimal=<v>` (the form [`str::parse`] reads).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Heuristic::ClampedOptimal(v) => write!(f, "clamped-optimal={v}"),
            h => f.write_str(h.name()),
        }
    }
}

impl std::str::FromStr for Heuristic {
    type Err = String;
    /// `balance`, `power`, `weighted`, `clamped-optimal` (v = 0.5) or `clamped-optimal=<v>`
    /// with v ∈ [0, 1].
    fn from_str(s: &str) -> Result<Self, String> {
        let (name, value) = match s.split_once('=') {
            Some((n, v)) => (n, Some(v)),
            None => (s, None),
        };
        let h = match name {
            "balance" => Heuristic::Balance,
            "power" => Heuristic::Power,
            "weighted" => Heuristic::Weighted,
            "clamped-optimal" => {
                let v = match value {
                    None => 0.5,
                    Some(t) => match t.trim().parse::<f32>() {
                        Ok(v) if (0.0..=1.0).contains(&v) => v,
                        _ => {
                            return Err(format!(
                                "clamped-optimal={t}: v must be a number in [0, 1] (the \
                                 visibility estimate; the paper uses 0.5)"
                            ))
                        }
                    },
                };
                return Ok(Heuristic::ClampedOptimal(v));
            }
            _ => {
                return Err(format!(
                    "unknown MIS heuristic '{s}' (expected one of: balance, power, weighted, \
                     clamped-optimal[=v] with v in [0, 1])"
                ))
            }
        };
        match value {
            None => Ok(h),
            Some(_) => Err(format!(
                "MIS heuristic '{name}' takes no parameter (only clamped-optimal=v does)"
            )),
        }
    }
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

    /// Clamped optimal at v ≤ 0 (or NaN) and v ≥ 1 gives its [`Heuristic::same_weights_as`]'s
    /// bits on densities and technique weights that include ±0, subnormals, ∞ and NaN.
    #[test]
    fn clamped_optimal_ends_are_balance_and_weighted_bit_for_bit() {
        let values = [
            -0.0,
            0.0,
            1e-45,
            1e-38,
            1e-6,
            0.3,
            1.0,
            7.5,
            1e20,
            3e38,
            f32::INFINITY,
            f32::NAN,
        ];
        for v in [-1.0, -0.0, 0.0, f32::NAN, 1.0, 2.0, f32::INFINITY] {
            let h = Heuristic::ClampedOptimal(v);
            let same = h.same_weights_as();
            assert_ne!(same, h, "v = {v}");
            for &p in &values {
                for &q in &values {
                    for (w_s, w_o) in [(0.2, 3.0), (0.0, 0.0), (f32::NAN, 1.0), (1e30, 1e30)] {
                        let (a, b) = (h.weight(p, q, w_s, w_o), same.weight(p, q, w_s, w_o));
                        assert_eq!(a.to_bits(), b.to_bits(), "v={v} p={p} q={q} W={w_s},{w_o}");
                    }
                }
            }
        }
        for h in Heuristic::ALL {
            assert_eq!(h.same_weights_as(), h);
        }
    }

    #[test]
    fn heuristic_names_round_trip() {
        for h in Heuristic::ALL {
            assert_eq!(h.to_string().parse::<Heuristic>(), Ok(h));
        }
        assert_eq!(
            "clamped-optimal".parse(),
            Ok(Heuristic::ClampedOptimal(0.5))
        );
        assert_eq!(
            "clamped-optimal=0".parse(),
            Ok(Heuristic::ClampedOptimal(0.0))
        );
        assert_eq!(
            "clamped-optimal=1".parse(),
            Ok(Heuristic::ClampedOptimal(1.0))
        );
        for bad in [
            "clamped-optimal=1.5",
            "clamped-optimal=-0.1",
            "clamped-optimal=x",
            "balance=1",
            "optimal",
            "",
        ] {
            assert!(bad.parse::<Heuristic>().is_err(), "{bad}");
        }
        assert_eq!(Heuristic::default(), Heuristic::ClampedOptimal(0.5));
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
