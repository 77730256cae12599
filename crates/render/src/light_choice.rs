//! Which lights a light sample samples: every light ([`LightSelection::Every`]), or one light
//! chosen at random and divided by its probability ([`LightSelection::One`], Mitsuba 3's
//! `direct` integrator: each of its `emitter_samples` picks one emitter).
//!
//! Estimator of `one`, per light sample: choose light j with probability p_j (proportional to
//! the lights' `sampling_weight`, 1 by default, as `Scene::sample_emitter` of Mitsuba 3.9 does),
//! then take the per-light estimator of light j with K_j replaced by K_j/p_j. Its expectation
//! is Σ_j p_j·E_j/p_j = Σ_j E_j, the expectation of `every`.
//!
//! The choice is one extra dimension ξ_c, drawn before the light's own numbers and only when
//! the scene has two or more lights (with one light p = 1 and nothing is drawn, so a one-light
//! scene renders the same image bit for bit under both selections). ξ_c is never stratified
//! across the samples of a pass (blue-jittered noise would otherwise stratify the choice and the
//! light's own ξ along the same diagonal: biased); the light's own ξ are not reused or rescaled,
//! so they keep the full 24-bit lattice that the samplers' guards assume
//! (`linlight_sampling::ltc::XI_LATTICE_START`/`END`).
//!
//! Exact probabilities: every uniform of the renderer is a lattice point k·2⁻²⁴ (white and blue
//! noise alike), so the choice compares k with integer thresholds T_0 < … < T_{N−1} = 2²⁴ and
//! p_j = (T_j − T_{j−1})·2⁻²⁴ exactly; the weight 1/p_j used is that probability's inverse
//! (rounded to f32 once), not w_total/w_j, so rounding the thresholds biases nothing.

/// How the lights of a scene are sampled per light sample (`linlight render --lights`).
///
/// The default is `every`: both have the expectation the scene means (Mitsuba's image), and on
/// the committed two-light room (two-tubes, 64², projected solid angle, one light sample) the
/// per-pixel variance of `one` is 720× that of `every` (median; 364–2754× from the 10th to the
/// 90th percentile) for 0.78× the instructions per sample: where each light lights its own
/// region, choosing one discards the near-zero-variance estimate of the other. `one` is there
/// for equal-work comparisons with Mitsuba (`scripts/bench-render`) and for scenes with many
/// lights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LightSelection {
    /// One light per light sample, chosen with probability p_j and divided by it (Mitsuba's
    /// estimator: the same work per sample as Mitsuba's `emitter_samples`).
    One,
    /// Every light, each sampled once per light sample (more work, far less noise per sample
    /// where the lights light different regions).
    #[default]
    Every,
}

impl LightSelection {
    pub const ALL: [LightSelection; 2] = [LightSelection::One, LightSelection::Every];

    /// Name on the command line and in image headers (`light_selection`).
    pub fn name(self) -> &'static str {
        match self {
            LightSelection::One => "one",
            LightSelection::Every => "every",
        }
    }
}

impl std::fmt::Display for LightSelection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for LightSelection {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| format!("unknown light selection '{s}' (expected one or every)"))
    }
}

/// Lattice points of the renderer's uniforms: ξ = k·2⁻²⁴, k < 2²⁴.
const LATTICE: u32 = 1 << 24;

/// The discrete distribution of [`LightSelection::One`] over a scene's lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightChoice {
    /// T_j: light j is chosen for k ∈ [T_{j−1}, T_j) (T_{−1} = 0, last T = 2²⁴).
    thresholds: Vec<u32>,
    /// 1/p_j = 2²⁴/(T_j − T_{j−1}), rounded to f32.
    inverse_probability: Vec<f32>,
}

impl LightChoice {
    /// Probabilities proportional to `weights` (each positive and finite; the loader checks
    /// `sampling_weight`), rounded to the 2⁻²⁴ lattice with every p_j ≥ 2⁻²⁴ (at most 2²⁴
    /// lights). Empty for no lights.
    pub fn new(weights: &[f32]) -> Self {
        let n = weights.len();
        assert!(n <= LATTICE as usize, "at most 2^24 lights");
        debug_assert!(weights.iter().all(|w| *w > 0.0 && w.is_finite()));
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        let mut thresholds = Vec::with_capacity(n);
        let mut cumulative = 0.0f64;
        let mut previous = 0u32;
        for (j, &w) in weights.iter().enumerate() {
            cumulative += w as f64;
            let ideal = (cumulative / total * LATTICE as f64).round() as u32;
            // Strictly increasing, and room for one lattice point per light still to come.
            let t = if j + 1 == n {
                LATTICE
            } else {
                ideal.clamp(previous + 1, LATTICE - (n - 1 - j) as u32)
            };
            thresholds.push(t);
            previous = t;
        }
        let inverse_probability = thresholds
            .iter()
            .scan(0u32, |prev, &t| {
                let count = t - std::mem::replace(prev, t);
                Some((LATTICE as f64 / count as f64) as f32)
            })
            .collect();
        Self {
            thresholds,
            inverse_probability,
        }
    }

    /// The light chosen by ξ (a uniform in [0, 1)) and 1/p of that light.
    #[inline]
    pub fn pick(&self, xi: f32) -> (usize, f32) {
        let j = self.pick_lanes(&[xi])[0] as usize;
        (j, self.inverse_probability[j])
    }

    /// The light [`pick`](Self::pick) chooses for each ξ of `xi`, without a search: light j is
    /// the number of thresholds T_0 … T_{N−2} at or below k = ξ·2²⁴ (a loop over lanes per
    /// threshold, which vectorises).
    #[inline(always)]
    pub fn pick_lanes<const L: usize>(&self, xi: &[f32; L]) -> [u32; L] {
        debug_assert!(!self.thresholds.is_empty(), "no light to choose");
        let k: [u32; L] = xi.map(|x| (x * LATTICE as f32) as u32);
        let mut j = [0u32; L];
        for &t in &self.thresholds[..self.thresholds.len().saturating_sub(1)] {
            for (j, k) in j.iter_mut().zip(&k) {
                *j += (*k >= t) as u32;
            }
        }
        j
    }

    /// 1/p_j, rounded to f32.
    #[inline(always)]
    pub fn inverse_probability(&self, j: usize) -> f32 {
        self.inverse_probability[j]
    }

    /// p_j, exactly (the share of lattice points choosing light j).
    pub fn probability(&self, j: usize) -> f64 {
        let lo = if j == 0 { 0 } else { self.thresholds[j - 1] };
        (self.thresholds[j] - lo) as f64 / LATTICE as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_every_is_the_default() {
        for l in LightSelection::ALL {
            assert_eq!(l.name().parse::<LightSelection>(), Ok(l));
        }
        assert!("all".parse::<LightSelection>().is_err());
        assert_eq!(LightSelection::default(), LightSelection::Every);
    }

    /// Uniform choice of two lights is exact: halves of the lattice, weight 2.
    #[test]
    fn two_equal_lights_split_the_lattice_in_halves() {
        let c = LightChoice::new(&[1.0, 1.0]);
        assert_eq!(c.pick(0.0), (0, 2.0));
        assert_eq!(c.pick(0.5 - 1.0 / 16_777_216.0), (0, 2.0));
        assert_eq!(c.pick(0.5), (1, 2.0));
        assert_eq!(c.pick(1.0 - 1.0 / 16_777_216.0), (1, 2.0));
        assert_eq!((c.probability(0), c.probability(1)), (0.5, 0.5));
    }

    /// Lattice points (every 64th, and those next to each threshold) choose the light whose
    /// interval holds them; p_j is within one lattice step of w_j/Σw and positive, and 1/p_j is
    /// its inverse to f32 rounding.
    #[test]
    fn probabilities_are_the_lattice_shares_of_the_weights() {
        for weights in [
            vec![1.0, 1.0, 1.0],
            vec![3.0, 1.0],
            vec![0.25, 5.0, 1.0, 1e-9],
        ] {
            let c = LightChoice::new(&weights);
            // Every 64th lattice point, and the ones next to each threshold.
            let mut ks: Vec<u32> = (0..LATTICE).step_by(64).collect();
            for &t in &c.thresholds {
                ks.extend([t.saturating_sub(1), t.min(LATTICE - 1)]);
            }
            let xi_of = |k: u32| k as f32 / LATTICE as f32;
            let in_interval = |k: u32, j: usize| {
                let lo = if j == 0 { 0 } else { c.thresholds[j - 1] };
                assert!(lo <= k && k < c.thresholds[j], "{weights:?}: k {k} → {j}");
            };
            for &k in &ks {
                let (j, inv) = c.pick(xi_of(k));
                in_interval(k, j);
                assert_eq!(inv, (1.0 / c.probability(j)) as f32);
            }
            // Eight different ξ at once (the packet path's call).
            for chunk in ks.chunks_exact(8) {
                let picked = c.pick_lanes(&std::array::from_fn::<f32, 8, _>(|i| xi_of(chunk[i])));
                for (&k, &j) in chunk.iter().zip(&picked) {
                    in_interval(k, j as usize);
                }
            }
            let total: f64 = weights.iter().map(|&w| w as f64).sum();
            for (j, &w) in weights.iter().enumerate() {
                let p = c.probability(j);
                assert!(p > 0.0, "{weights:?}: light {j} never chosen");
                assert!(
                    (p - w as f64 / total).abs() <= 1.0 / LATTICE as f64,
                    "{weights:?}: p_{j} = {p}"
                );
            }
            assert!((0..weights.len()).map(|j| c.probability(j)).sum::<f64>() == 1.0);
        }
    }
}
