//! When equivalence is not shown: which image limits the precision of the relative difference,
//! and how many more samples of which side would make equivalence within ±δ decidable.
//!
//! The confidence interval is r ± q·√(V_A + V_B) (V_A, V_B the delta-method variance terms of
//! A and of B). It lies within ±δ when q·√(V_A + V_B) ≤ δ − |r|. Aiming at the half-width
//! h = max(δ − |r|, δ/2) (the estimate r may move; at least half the margin is left to noise),
//! the target is T = (h/q)². Variance falls like 1/samples, so f_A = V_A/(T − V_B) more samples
//! of A alone suffice if T > V_B (otherwise no number of A samples does), likewise f_B, and
//! f = (V_A + V_B)/T of both.

use serde::{Deserialize, Serialize};

use super::ChannelReport;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PrecisionHint {
    /// The channel that needs the most samples.
    #[serde(deserialize_with = "super::static_name")]
    pub channel: super::StaticName,
    /// "A" or "B": the image with the larger share of the variance.
    #[serde(deserialize_with = "super::static_name")]
    pub limiting: super::StaticName,
    /// A's share of the variance of the relative difference.
    pub share_a: f64,
    /// Factor of more samples of A alone (None: A alone cannot make it decidable).
    pub factor_a: Option<f64>,
    /// Factor of more samples of B alone (None: B alone cannot).
    pub factor_b: Option<f64>,
    /// Factor of more samples of both.
    pub factor_both: f64,
    /// The resulting samples per pixel (header `spp` × factor; None when spp is unknown).
    pub spp_a: Option<u64>,
    pub spp_b: Option<u64>,
    /// One sentence for people.
    pub text: String,
}

fn scaled(spp: u64, f: Option<f64>) -> Option<u64> {
    f.filter(|_| spp > 0)
        .map(|f| (spp as f64 * f.max(1.0)).ceil() as u64)
}

/// The hint for the channel that needs the most samples of both (None if no channel has a
/// defined interval).
pub(super) fn samples_needed(
    channels: &[ChannelReport],
    tolerance: f64,
    (spp_a, spp_b): (u64, u64),
) -> Option<PrecisionHint> {
    let mut best: Option<PrecisionHint> = None;
    for ch in channels {
        let g = &ch.global;
        let (Some(r), Some([lo, hi])) = (g.rel_diff, g.rel_ci) else {
            continue;
        };
        if g.equivalent {
            continue;
        }
        let (va, vb) = (g.rel_var_a, g.rel_var_b);
        let se = (va + vb).sqrt();
        if !(se > 0.0) {
            continue;
        }
        let q = 0.5 * (hi - lo) / se;
        let h = (tolerance - r.abs()).max(0.5 * tolerance);
        let target = (h / q) * (h / q);
        let factor = |own: f64, other: f64| (target > other).then(|| own / (target - other));
        let factor_a = factor(va, vb);
        let factor_b = factor(vb, va);
        let factor_both = (va + vb) / target;
        let limiting = if va >= vb { "A" } else { "B" };
        let side_text = |name: &str, f: Option<f64>, spp: u64| match f {
            Some(f) => format!(
                "≈ {f:.1}× the samples of {name} alone{}",
                scaled(spp, Some(f)).map_or_else(String::new, |n| format!(" (≈ {n} spp)"))
            ),
            None => format!("more samples of {name} alone cannot"),
        };
        let text = format!(
            "{limiting} limits the precision ({:.0}% of the variance of the relative difference \
             of {} comes from {limiting}); equivalence within ±{}% needs ≈ {factor_both:.1}× the \
             samples of both; {}; {}",
            100.0 * va.max(vb) / (va + vb),
            ch.channel,
            100.0 * tolerance,
            side_text("A", factor_a, spp_a),
            side_text("B", factor_b, spp_b),
        );
        let hint = PrecisionHint {
            channel: ch.channel,
            limiting,
            share_a: va / (va + vb),
            factor_a,
            factor_b,
            factor_both,
            spp_a: scaled(spp_a, factor_a),
            spp_b: scaled(spp_b, factor_b),
            text,
        };
        if best
            .as_ref()
            .is_none_or(|b| hint.factor_both > b.factor_both)
        {
            best = Some(hint);
        }
    }
    best
}
