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
    /// One light per light sample, chosen by a tree over the lights with probability
    /// p_j(x, n) from the shading point (their power and a bound of their projected solid
    /// angle, [`crate::light_tree`]) and divided by it: the work of `one`, for scenes with many
    /// lights.
    Tree,
}

impl LightSelection {
    pub const ALL: [LightSelection; 3] = [
        LightSelection::One,
        LightSelection::Every,
        LightSelection::Tree,
    ];

    /// Name on the command line and in image headers (`light_selection`).
    pub fn name(self) -> &'static str {
        match self {
            LightSelection::One => "one",
            LightSelection::Every => "every",
            LightSelection::Tree => "tree",
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
            .ok_or_else(|| format!("unknown light selection '{s}' (expected one, every or tree)"))
    }
}

/// Lattice points of the renderer's uniforms: ξ = k·2⁻²⁴, k < 2²⁴.
const LATTICE: u32 = 1 << 24;

/// The most lights [`LightChoice::pick_rows`] chooses among with selects over the lanes (cost
/// ∝ lights × values per lane); more are looked up lane by lane.
pub const SELECT_LIGHTS: usize = 4;

/// T·2⁻²⁴ (exact: T ≤ 2²⁴).
#[inline(always)]
fn threshold_f32(t: u32) -> f32 {
    t as f32 * (1.0 / LATTICE as f32)
}

/// The discrete distribution of [`LightSelection::One`] over a scene's lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightChoice {
    /// T_j: light j is chosen for k ∈ [T_{j−1}, T_j) (T_{−1} = 0, last T = 2²⁴).
    thresholds: Vec<u32>,
    /// 1/p_j = 2²⁴/(T_j − T_{j−1}), rounded to f32.
    inverse_probability: Vec<f32>,
    /// The lookup of [`LightChoice::pick_lanes`]: the lattice cut into equal buckets.
    buckets: Buckets,
}

/// The lattice [0, 2²⁴) cut into B = 2^`log2` equal buckets, so that a ξ finds its light from
/// its bucket's first light and at most `steps` comparisons (each bucket holds at most `steps`
/// thresholds T_0 … T_{N−2} strictly inside it), whatever the number of lights.
#[derive(Clone, Debug, Default, PartialEq)]
struct Buckets {
    log2: u32,
    /// Per bucket b: the light of ξ = b/B, the number of thresholds T_0 … T_{N−2} ≤ b·2²⁴/B.
    first: Vec<u32>,
    /// T_j·2⁻²⁴ (exact in f32) for j < N − 1, then NaN (no ξ is at or above it).
    threshold: Vec<f32>,
    steps: u32,
}

/// The most buckets of a [`Buckets`] (a table of 256 KiB).
const MAX_BUCKETS_LOG2: u32 = 16;

impl Buckets {
    /// The buckets for `thresholds` (T_0 < … < T_{N−1} = 2²⁴): B the smallest power of two
    /// ≥ 2N (at most 2^[`MAX_BUCKETS_LOG2`]), which puts at most one threshold in each bucket
    /// when the weights are equal.
    fn new(thresholds: &[u32]) -> Self {
        let n = thresholds.len();
        let log2 = (2 * n)
            .next_power_of_two()
            .trailing_zeros()
            .min(MAX_BUCKETS_LOG2);
        let width = LATTICE >> log2;
        let inner = &thresholds[..n.saturating_sub(1)];
        let first: Vec<u32> = (0..1u32 << log2)
            .map(|b| inner.partition_point(|&t| t <= b * width) as u32)
            .collect();
        // Thresholds strictly inside bucket b: (b·w, (b + 1)·w).
        let steps = (0..1u32 << log2)
            .map(|b| {
                let inside = inner.partition_point(|&t| t < (b + 1) * width);
                inside.saturating_sub(first[b as usize] as usize) as u32
            })
            .max()
            .unwrap_or(0);
        let mut threshold: Vec<f32> = inner.iter().map(|&t| threshold_f32(t)).collect();
        threshold.push(f32::NAN);
        Self {
            log2,
            first,
            threshold,
            steps,
        }
    }
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
        let buckets = Buckets::new(&thresholds);
        Self {
            thresholds,
            inverse_probability,
            buckets,
        }
    }

    /// The light chosen by ξ (a uniform in [0, 1)) and 1/p of that light.
    #[inline]
    pub fn pick(&self, xi: f32) -> (usize, f32) {
        let j = self.pick_lanes(&[xi])[0] as usize;
        (j, self.inverse_probability[j])
    }

    /// The light [`pick`](Self::pick) chooses for each ξ of `xi`: the number of thresholds
    /// T_0 … T_{N−2} at or below k = ξ·2²⁴, found from ξ's bucket of the lattice (its first
    /// light, then one comparison per threshold a bucket may hold): with even weights one
    /// lookup and one comparison, whatever the number of lights.
    ///
    /// Compared in f32, ξ ≥ T·2⁻²⁴: exactly the integer test ⌊ξ·2²⁴⌋ ≥ T for every f32 ξ
    /// (scaling by 2²⁴ is exact, T ≤ 2²⁴ is an f32, and ⌊y⌋ ≥ T ⇔ y ≥ T for an integer T);
    /// negative ξ and NaN fall in bucket 0 and choose light 0, ξ ≥ 1 the last bucket and the
    /// last light, as the integer test does.
    #[inline(always)]
    pub fn pick_lanes<const L: usize>(&self, xi: &[f32; L]) -> [u32; L] {
        debug_assert!(!self.thresholds.is_empty(), "no light to choose");
        let Buckets {
            log2,
            first,
            threshold,
            steps,
        } = &self.buckets;
        let last_bucket = (first.len() - 1) as f32;
        let last = threshold.len() - 1;
        // ⌊ξ·B⌋ in [0, B − 1] (exact: B is a power of two); NaN to 0 by `max`.
        let scale = (1u32 << log2) as f32;
        let mut j = xi.map(|x| first[((x * scale).max(0.0).min(last_bucket) as i32) as usize]);
        for _ in 0..*steps {
            for (j, &x) in j.iter_mut().zip(xi) {
                // The NaN after T_{N−2} stops every ξ at light N − 1.
                *j += (x >= threshold[(*j as usize).min(last)]) as u32;
            }
        }
        j
    }

    /// [`pick_lanes`](Self::pick_lanes), and for each lane the chosen light's row of `rows`
    /// (row j: light j's C values, e.g. its K/p and segment): `(light, values)` with
    /// `values[c][k] = rows[light[k]][c]`. Up to [`SELECT_LIGHTS`] lights by selects over all
    /// lanes per threshold (lanes at or above T_{l−1} take row l; the thresholds increase, so
    /// the last row taken is the chosen light's), which vectorise; more lights lane by lane.
    #[inline(always)]
    pub fn pick_rows<const C: usize, const L: usize>(
        &self,
        xi: &[f32; L],
        rows: &[[f32; C]],
    ) -> ([u32; L], [[f32; L]; C]) {
        debug_assert_eq!(rows.len(), self.thresholds.len(), "one row per light");
        if rows.len() > SELECT_LIGHTS {
            let light = self.pick_lanes(xi);
            let mut values = [[0.0; L]; C];
            for (k, &j) in light.iter().enumerate() {
                for (values, &v) in values.iter_mut().zip(&rows[j as usize]) {
                    values[k] = v;
                }
            }
            return (light, values);
        }
        let mut light = [0; L];
        let mut values = rows[0].map(|v| [v; L]);
        for (l, (&t, row)) in self.inner_thresholds().iter().zip(&rows[1..]).enumerate() {
            let t = threshold_f32(t);
            // All ones where ξ ≥ T_{l−1}; the rows are taken by bitwise selects on it (the
            // same bits). Written with `if` per value, the compiler hoists the comparison out
            // of the loop over the row and branches per lane.
            let above: [u32; L] = std::array::from_fn(|k| ((xi[k] >= t) as u32).wrapping_neg());
            for (j, &m) in light.iter_mut().zip(&above) {
                *j = (l as u32 + 1) & m | *j & !m;
            }
            for (values, &v) in values.iter_mut().zip(row) {
                let v = v.to_bits();
                for (value, &m) in values.iter_mut().zip(&above) {
                    *value = f32::from_bits(v & m | value.to_bits() & !m);
                }
            }
        }
        (light, values)
    }

    /// T_0 … T_{N−2}: the thresholds between lights (the last one, 2²⁴, bounds every ξ).
    #[inline(always)]
    fn inner_thresholds(&self) -> &[u32] {
        &self.thresholds[..self.thresholds.len().saturating_sub(1)]
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
            // Eight different ξ at once (`pick_lanes` on lanes of their own ξ, as `pick_rows`
            // calls it for more than SELECT_LIGHTS lights).
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

    /// The f32 comparison of `pick_lanes` chooses what the integer test ⌊ξ·2²⁴⌋ ≥ T chooses,
    /// for lattice points and any other f32 (off the lattice, ≥ 1, negative, NaN); and
    /// `pick_rows` returns that light and its row, by selects (≤ SELECT_LIGHTS lights) and lane
    /// by lane (more); equal weights need at most one comparison after the bucket's lookup.
    #[test]
    fn pick_rows_gives_the_chosen_light_and_its_row() {
        let integer_pick = |c: &LightChoice, x: f32| {
            let k = (x * LATTICE as f32) as u32;
            c.thresholds[..c.thresholds.len() - 1]
                .iter()
                .filter(|&&t| k >= t)
                .count() as u32
        };
        // Uneven weights; 64 even ones (one threshold per bucket at most); weights falling
        // by 2× per light (many thresholds in the last buckets).
        let uneven = |n: usize| (0..n).map(|j| 1.0 + (j * 7 % 5) as f32).collect::<Vec<_>>();
        let sets = (1..=SELECT_LIGHTS + 3)
            .map(uneven)
            .chain([vec![1.0; 64], (0..40).map(|j| 0.5f32.powi(j)).collect()]);
        assert!(LightChoice::new(&[1.0; 64]).buckets.steps <= 1);
        assert!(LightChoice::new(&[1.0; 37]).buckets.steps <= 1);
        for weights in sets {
            let n = weights.len();
            let c = LightChoice::new(&weights);
            let rows: Vec<[f32; 3]> = (0..n).map(|j| [j as f32, -(j as f32), 0.5]).collect();
            let mut xs: Vec<f32> = (0..LATTICE)
                .step_by(4099)
                .map(|k| k as f32 / LATTICE as f32)
                .collect();
            for &t in &c.thresholds {
                for k in [t.saturating_sub(1), t, t + 1] {
                    let x = k as f32 / LATTICE as f32;
                    xs.extend([
                        x,
                        f32::from_bits(x.to_bits() + 1),
                        f32::from_bits(x.to_bits().saturating_sub(1)),
                    ]);
                }
            }
            xs.extend([
                -0.0,
                -1.0,
                1.0,
                2.0,
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
                1e-30,
            ]);
            while !xs.len().is_multiple_of(16) {
                xs.push(0.25);
            }
            for chunk in xs.chunks_exact(16) {
                let xi: [f32; 16] = chunk.try_into().unwrap();
                let picked = c.pick_lanes(&xi);
                let (j, values) = c.pick_rows(&xi, &rows);
                for k in 0..16 {
                    assert_eq!(
                        picked[k],
                        integer_pick(&c, xi[k]),
                        "{n} lights, ξ {}",
                        xi[k]
                    );
                    assert_eq!(j[k], picked[k]);
                    let row = rows[j[k] as usize];
                    assert_eq!([values[0][k], values[1][k], values[2][k]], row);
                }
            }
        }
    }
}
