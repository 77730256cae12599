//! How many samples per pixel the Rust render of a subject gets (derivation: docs/budget.md).
//!
//! A pilot render of `pilot_spp` samples (own seed, never reused) estimates the variance of one
//! sample per pixel and channel, σ̂²_i = pilot_spp · v̂_pilot,i; a render of N samples then has
//! the variance of the mean σ²_i/N. Two targets:
//!
//! - [`Target::Tests`] (certify's default): the smallest N at which the comparison's own tests
//!   have the stated power (1 − β, default 0.99) against the biases certify promises to catch,
//!   and at which ±δ equivalence of an unbiased render is shown with that probability. Per
//!   channel, with the relative variance of a set P of pixels V_A = Σ_P σ̂²/(Σ_P m_B)² (one
//!   sample) and V_B = Σ_P v_B/(Σ_P m_B)²:
//!
//!   N_P = V_A / (T − V_B),  T = (b/k)²,
//!
//!   for the whole image (b = δ, k = max(z_{1−α_t/2} + z_{1−β}, z_{1−α_e/2} + z_{1−β/2}): the
//!   global difference test at its level α_t and the equivalence interval at α_e) and for every
//!   full t×t tile of the comparison's two grids (b = `tile_bias`, k = z_{1−α_t/(2M)} + z_{1−β},
//!   M tiles per channel: Holm's first step). The budget is the largest N_P, rounded up to the
//!   granularity and clamped to [min_spp, max_spp]. A set whose reference alone uses more than
//!   80 % of T (V_B > 0.8·T) is *reference-limited*: more Rust samples cannot buy the power
//!   there; such a tile is not covered (and counted), the whole image then gets 4·V_A/V_B (A
//!   contributes a fifth of the variance). Pixels near a light–surface contact are left out,
//!   as the comparison leaves them out of the global and tile tests.
//! - [`Target::Parity`] (`certify --full`, `render --match-variance`): N is the `quantile`
//!   (0.99) over pixels and channels of σ̂²_i/v_B,i — the render is at least as precise as the
//!   reference in 99 % of the pixels. Exhaustive: it spends samples where the reference is far
//!   more precise than any test needs.

use linlight_imagefile::Image;
use linlight_verify::image_stats::{compare, CompareConfig, CompareError, Region};
use linlight_verify::z_score::normal_two_sided_quantile;
use serde::{Deserialize, Serialize};

/// Share of the variance target T the reference may use before a constraint is reference-limited.
pub const REFERENCE_SHARE_LIMIT: f64 = 0.8;

/// What the budget aims at.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "kebab-case")]
pub enum Target {
    /// The power of the comparison's tests (docs/budget.md).
    Tests {
        /// Probability 1 − β with which each targeted bias is rejected (and equivalence of an
        /// unbiased render shown).
        power: f64,
        /// Relative bias of one full tile that must be rejected.
        tile_bias: f64,
        /// Every pixel gets what the global test needs, and the pixels of a tile that needs
        /// more get that tile's need (rendered again at that count, [`super::planned`]);
        /// false: the whole image gets the largest need.
        #[serde(default)]
        per_tile: bool,
    },
    /// At least as precise as the reference in the `quantile` of the pixels.
    Parity { quantile: f64 },
}

/// K: what a camera sample costs besides its light samples (ray, shading point, BSDF and
/// sampler preparation), in light samples of one light, on the scalar path where certify takes
/// several light samples (scenes without a Lambertian surface; the packet renderer takes one),
/// with the tubes as lines. A camera sample of N light samples of L lights each then costs
/// (K + N·L)/(K + L) camera samples of one light sample. Measured there (callgrind,
/// instructions per camera sample at N = 1 and 8): K = 2.4 for area sampling, 2.1 for Hart's
/// linear and for solid angle on `glossy-conductor-sharp` (one light), 2.6 for area sampling
/// on `glossy-principled` (two lights: K/L = 1.3); the model takes the smallest, rounded down,
/// so that it never understates the cost of N light samples.
pub const CAMERA_SAMPLE_IN_LIGHT_SAMPLES: f64 = 2.0;

/// K of [`CAMERA_SAMPLE_IN_LIGHT_SAMPLES`] for exact tubes (`--cylinders exact`), whose light
/// samples cost more: measured on `finite-tube-glossy` with MIS (balance), K = 0.36 for area
/// sampling of the cylinder, 4.8 for solid angle; the smallest, rounded down.
pub const CAMERA_SAMPLE_IN_EXACT_TUBE_SAMPLES: f64 = 0.25;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BudgetRule {
    pub pilot_spp: u32,
    pub min_spp: u32,
    pub max_spp: u32,
    /// The budget is a multiple of this.
    pub granularity: u32,
    pub target: Target,
    /// Most light samples per light and camera sample ([`Self::light_samples`]); 1: always one.
    #[serde(default = "one_light_sample")]
    pub max_light_samples: u32,
}

/// What reports written before light samples were chosen used: one (serde's default of
/// `BudgetRule::max_light_samples` and of a row's `light_samples`).
pub(crate) fn one_light_sample() -> u32 {
    1
}

impl Default for BudgetRule {
    /// Certify's rule: the tests' power.
    fn default() -> Self {
        Self {
            pilot_spp: 256,
            min_spp: 256,
            max_spp: 65_536,
            granularity: 64,
            target: Target::Tests {
                power: 0.99,
                tile_bias: 0.01,
                per_tile: true,
            },
            max_light_samples: 8,
        }
    }
}

impl BudgetRule {
    /// The exhaustive per-pixel rule (`certify --full`, `render --match-variance`).
    pub fn parity() -> Self {
        Self {
            target: Target::Parity { quantile: 0.99 },
            ..Self::default()
        }
    }

    /// Light samples per light and camera sample to try for a subject whose budget at one light
    /// sample is `spp` (docs/budget.md, "Light samples"): the largest power of two N ≤
    /// `max_light_samples` with N·`min_spp` ≤ `spp`, or 1 when the subject renders in packets
    /// (the packet renderer takes one light sample). On the scalar path a camera sample's ray,
    /// shading point and sampler preparation serve its N light samples, so where the light
    /// sample's variance dominates (a glossy lobe sampled by a diffuse technique) N light
    /// samples cost far less than N camera samples. The budget at N is planned again from its
    /// own pilot ([`Self::light_sample_pilot`]), so the tests keep their power whatever the
    /// variance split, and kept only if it is cheaper ([`Self::light_samples_pay`]).
    pub fn light_samples(&self, spp: u32, packets: bool) -> u32 {
        if packets {
            return 1;
        }
        let mut n = 1;
        while 2 * n <= self.max_light_samples && 2 * n * self.min_spp.max(1) <= spp {
            n *= 2;
        }
        n
    }

    /// The rule of the pilot at N light samples per camera sample: as many light samples as
    /// the first pilot (`pilot_spp`/N camera samples, at least 32).
    pub fn light_sample_pilot(&self, n: u32) -> Self {
        Self {
            pilot_spp: (self.pilot_spp / n.max(1)).max(32),
            ..*self
        }
    }

    /// Whether the budget `at_n` (N light samples per camera sample) costs less than `at_one`
    /// (one), a camera sample of N light samples of `lights` lights each costing
    /// (K + N·L)/(K + L) camera samples of one (K = [`CAMERA_SAMPLE_IN_LIGHT_SAMPLES`], or
    /// [`CAMERA_SAMPLE_IN_EXACT_TUBE_SAMPLES`] for `exact_tubes`; L = `lights` at least 1, and
    /// L larger than the lights a light sample takes overstates the cost of N). Compares the
    /// mean samples per pixel (per-tile budgets).
    pub fn light_samples_pay(
        at_one: &Budget,
        at_n: &Budget,
        n: u32,
        lights: usize,
        exact_tubes: bool,
    ) -> bool {
        let cost = |b: &Budget| b.pixel_spp_mean.max(b.spp as f64);
        let k = if exact_tubes {
            CAMERA_SAMPLE_IN_EXACT_TUBE_SAMPLES
        } else {
            CAMERA_SAMPLE_IN_LIGHT_SAMPLES
        };
        let l = lights.max(1) as f64;
        // cost(at_n)·(K + N·L)/(K + L) < cost(at_one), without the rounding of the quotient.
        cost(at_n) * (k + n as f64 * l) < cost(at_one) * (k + l)
    }

    /// One sentence for reports.
    pub fn describe(&self) -> String {
        let common = format!(
            "a pilot of {} spp (own seed) estimates the per-sample variance of every pixel",
            self.pilot_spp
        );
        let light = if self.max_light_samples > 1 {
            format!(
                "; a subject on the scalar path whose budget allows N·{} spp takes N ≤ {} light \
                 samples per camera sample (N a power of two) where a budget planned again from \
                 a pilot at N costs less (docs/budget.md)",
                self.min_spp, self.max_light_samples
            )
        } else {
            String::new()
        };
        let clamp = format!(
            "rounded up to {}, within [{}, {}]{light}",
            self.granularity, self.min_spp, self.max_spp
        );
        match self.target {
            Target::Tests {
                power,
                tile_bias,
                per_tile,
            } => {
                let (who, tiles) = if per_tile {
                    (
                        "every pixel gets",
                        "and the pixels of each full tile as many as the tile",
                    )
                } else {
                    ("the render gets", "and at which the tile")
                };
                let which = if per_tile {
                    "that tile"
                } else {
                    "any full tile"
                };
                format!(
                    "{common}; {who} the smallest spp at which the global test rejects a \
                     bias of ±δ and ±δ equivalence of an unbiased render is shown, {tiles} \
                     test rejects a {}% bias of {which}, each with probability {power} \
                     (docs/budget.md), {clamp}",
                    100.0 * tile_bias,
                )
            }
            Target::Parity { quantile } => format!(
                "{common}; the render gets the {quantile}-quantile over pixels of σ̂²/v_B spp \
                 (as precise as the reference in that share of the pixels), {clamp}"
            ),
        }
    }
}

/// What set the budget.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Bound {
    /// Power of the global test / the equivalence interval.
    Global,
    /// Power of the tile test on this tile.
    Tile(Region),
    /// The per-pixel parity quantile.
    Parity,
    /// Nothing asked for more than `min_spp`.
    Minimum,
}

/// The test-power part of a budget: what each constraint asked for, and what the chosen spp
/// delivers (all relative to the reference's means; worst channel).
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct TestBudget {
    /// k of the global constraint and of the tile constraint (z quantile + power quantile).
    pub k_global: f64,
    pub k_tile: f64,
    /// spp asked for by the global test and equivalence (N_g).
    pub global_spp: f64,
    /// The reference alone uses more than 80 % of the global variance target.
    pub global_reference_limited: bool,
    /// Largest spp asked for by a covered tile (0 without covered tiles) and that tile.
    pub tile_spp: f64,
    pub hardest_tile: Option<Region>,
    /// Full tiles of both grids, and those covered (not reference-limited in every channel).
    pub tiles: usize,
    pub tiles_covered: usize,
    /// At the chosen spp: relative standard error of the global difference, the global bias and
    /// the tile bias (worst covered tile) rejected with the target power.
    pub predicted_rel_se: f64,
    pub detectable_global_bias: f64,
    pub detectable_tile_bias: Option<f64>,
}

/// Why a budget came out as it did.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct Budget {
    /// Samples of every pixel (with a per-tile budget, the pixels of tiles that need more get
    /// more: `pixel_spp_max`, `pixel_spp_mean`).
    pub spp: u32,
    /// Largest and mean samples per pixel (= `spp` for a uniform budget).
    #[serde(default)]
    pub pixel_spp_max: u32,
    #[serde(default)]
    pub pixel_spp_mean: f64,
    /// The spp the rule asked for before rounding and clamping (None: nothing to match).
    pub required_spp: Option<f64>,
    /// The rule asked for more than `max_spp`.
    pub capped: bool,
    pub bound: Bound,
    /// The constraints of [`Target::Tests`] (None for parity).
    pub tests: Option<TestBudget>,
}

/// The q-quantile (nearest rank) of unsorted values; None for an empty slice.
pub fn quantile(mut values: Vec<f64>, q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let k = ((values.len() as f64 * q).ceil() as usize).clamp(1, values.len()) - 1;
    Some(values[k])
}

/// Ratios σ̂²_i / v_B,i over pixels and channels where both are positive (σ̂² from an image of
/// `spp` samples per pixel in one pass: σ̂² = spp · v).
fn parity_ratios(pilot: &Image, spp: u32, reference: &Image) -> Vec<f64> {
    pilot
        .var
        .iter()
        .zip(&reference.var)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] as f64 * spp as f64, b[c] as f64)))
        .filter(|&(s2, vb)| s2 > 0.0 && vb > 0.0)
        .map(|(s2, vb)| s2 / vb)
        .collect()
}

/// Sums of one channel over a set of pixels: per-sample variance of A (from the pilot), the
/// reference's variance of the mean and its signal.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SetSums {
    pub sigma2_a: f64,
    pub var_b: f64,
    pub mean_b: f64,
}

impl SetSums {
    /// The relative variances (V_A of one sample, V_B); None without positive signal.
    fn relative(&self) -> Option<(f64, f64)> {
        let s2 = self.mean_b * self.mean_b;
        (self.mean_b > 0.0 && s2.is_finite()).then(|| (self.sigma2_a / s2, self.var_b / s2))
    }
}

/// One power constraint: rejecting a relative bias `bias` of a set of pixels with the factor k
/// (quantile of the test's level + quantile of the power) on its standard error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Need {
    /// The set has no signal in this channel (or no variance at all): nothing to ask.
    Nothing,
    /// spp needed: V_A/(T − V_B), T = (bias/k)².
    Spp(f64),
    /// The reference alone uses more than 80 % of T: what A would need to contribute a fifth
    /// of the variance (4·V_A/V_B).
    ReferenceLimited(f64),
}

/// The constraint of one channel of one set (docs/budget.md, "one constraint").
pub fn need(sums: &SetSums, bias: f64, k: f64) -> Need {
    let Some((va, vb)) = sums.relative() else {
        return Need::Nothing;
    };
    if !(va > 0.0) || !va.is_finite() {
        return Need::Nothing;
    }
    let target = (bias / k) * (bias / k);
    if vb > REFERENCE_SHARE_LIMIT * target {
        Need::ReferenceLimited(4.0 * va / vb)
    } else {
        Need::Spp(va / (target - vb))
    }
}

/// The bias rejected with the target power at `spp` (k·√(V_A/N + V_B)); None without signal.
fn detectable(sums: &SetSums, spp: f64, k: f64) -> Option<f64> {
    let (va, vb) = sums.relative()?;
    Some(k * (va / spp + vb).sqrt())
}

/// Per channel sums of the pixels of `region` (all pixels if None) that are not excluded.
fn sums(
    pilot: &Image,
    pilot_spp: f64,
    reference: &Image,
    region: Option<Region>,
    excluded: &[bool],
) -> [SetSums; 3] {
    let w = reference.width;
    let r = region.unwrap_or(Region {
        x: 0,
        y: 0,
        width: w,
        height: reference.height,
    });
    let mut s = [SetSums::default(); 3];
    for y in r.y..r.y + r.height {
        for x in r.x..r.x + r.width {
            let i = y * w + x;
            if excluded[i] {
                continue;
            }
            for (c, sc) in s.iter_mut().enumerate() {
                sc.sigma2_a += pilot.var[i][c] as f64 * pilot_spp;
                sc.var_b += reference.var[i][c] as f64;
                sc.mean_b += reference.mean[i][c] as f64;
            }
        }
    }
    s
}

/// The constraints of [`Target::Tests`] measured on a pilot.
struct Constraints {
    /// Largest spp asked for (before rounding and clamping) and what asked for it.
    required: f64,
    bound: Bound,
    plan: TestBudget,
    /// Per channel sums of the whole image (contacts left out) and of every covered tile,
    /// with the tile's region and need.
    global: [SetSums; 3],
    covered: Vec<([SetSums; 3], Region, f64)>,
    tile_bias: f64,
}

impl Constraints {
    fn measure(
        pilot: &Image,
        pilot_spp: u32,
        reference: &Image,
        cfg: &CompareConfig,
        power: f64,
        tile_bias: f64,
    ) -> Result<Self, CompareError> {
        // The comparison itself tells its levels, its tile grids and the pixels it leaves out
        // of the global and tile sums (contacts); a pilot is a valid A for it.
        let probe = compare(pilot, reference, cfg)?;
        let beta = 1.0 - power;
        // One-sided z_{1−β} (power of a two-sided test against a bias of known sign) and
        // two-sided z_{1−β/2} (|r̂| of the equivalence interval).
        let z_power = normal_two_sided_quantile(2.0 * beta);
        let z_power_two_sided = normal_two_sided_quantile(beta);
        let k_global = (normal_two_sided_quantile(probe.alpha_test) + z_power)
            .max(normal_two_sided_quantile(probe.alpha_equivalence) + z_power_two_sided);
        // Holm over the tiles of a channel: the first step tests the smallest p at α_t/M.
        let tiles_per_channel = probe.maps.tiles.len().max(1);
        let k_tile =
            normal_two_sided_quantile(probe.alpha_test / tiles_per_channel as f64) + z_power;
        let mut excluded = vec![false; reference.width * reference.height];
        for &[x, y] in &probe.contact_pixels {
            if let Some(e) = excluded.get_mut(y * reference.width + x) {
                *e = true;
            }
        }
        let spp0 = pilot_spp as f64;
        let global = sums(pilot, spp0, reference, None, &excluded);
        let mut global_spp = 0.0f64;
        let mut global_reference_limited = false;
        for s in &global {
            match need(s, cfg.tolerance, k_global) {
                Need::Nothing => {}
                Need::Spp(n) => global_spp = global_spp.max(n),
                Need::ReferenceLimited(n) => {
                    global_reference_limited = true;
                    global_spp = global_spp.max(n);
                }
            }
        }
        let full: Vec<Region> = probe
            .maps
            .tiles
            .iter()
            .map(|(r, _)| *r)
            .filter(|r| r.width == cfg.tile && r.height == cfg.tile)
            .collect();
        let mut tile_spp = 0.0f64;
        let mut hardest_tile = None;
        let mut covered = Vec::new();
        for r in &full {
            let s = sums(pilot, spp0, reference, Some(*r), &excluded);
            // The tile's constraint: every channel in which it is resolvable.
            let n = s
                .iter()
                .filter_map(|c| match need(c, tile_bias, k_tile) {
                    Need::Spp(n) => Some(n),
                    _ => None,
                })
                .reduce(f64::max);
            let Some(n) = n else { continue };
            if hardest_tile.is_none() || n > tile_spp {
                tile_spp = n;
                hardest_tile = Some(*r);
            }
            covered.push((s, *r, n));
        }
        let (required, bound) = match hardest_tile {
            Some(r) if tile_spp > global_spp => (tile_spp, Bound::Tile(r)),
            _ => (global_spp, Bound::Global),
        };
        Ok(Self {
            required,
            bound,
            plan: TestBudget {
                k_global,
                k_tile,
                global_spp,
                global_reference_limited,
                tile_spp,
                hardest_tile,
                tiles: full.len(),
                tiles_covered: covered.len(),
                predicted_rel_se: 0.0,
                detectable_global_bias: 0.0,
                detectable_tile_bias: None,
            },
            global,
            covered,
            tile_bias,
        })
    }

    /// The plan with what `spp` (every pixel) delivers filled in; `tile_spp(region)`: the
    /// fewest samples of a pixel of that tile (≥ `spp`).
    fn delivered(&self, spp: u32, tile_spp: impl Fn(&Region) -> u32) -> TestBudget {
        let worst = |sets: &[SetSums; 3], n: u32, k: f64, only_resolvable: bool| {
            sets.iter()
                .filter(|c| !only_resolvable || matches!(need(c, self.tile_bias, k), Need::Spp(_)))
                .filter_map(|c| detectable(c, n as f64, k))
                .fold(0.0, f64::max)
        };
        TestBudget {
            predicted_rel_se: worst(&self.global, spp, 1.0, false),
            detectable_global_bias: worst(&self.global, spp, self.plan.k_global, false),
            detectable_tile_bias: self
                .covered
                .iter()
                .map(|(s, r, _)| worst(s, tile_spp(r), self.plan.k_tile, true))
                .reduce(f64::max),
            ..self.plan
        }
    }
}

impl BudgetRule {
    /// Budget from a pilot render of `self.pilot_spp` samples in one pass, for a comparison
    /// with `cfg` against `reference`. Errors when the two images cannot be compared (the
    /// comparison would refuse them too). A per-tile budget's pixel counts: [`Self::plan`].
    pub fn choose(
        &self,
        pilot: &Image,
        reference: &Image,
        cfg: &CompareConfig,
    ) -> Result<Budget, CompareError> {
        Ok(self.plan(pilot, reference, cfg)?.0)
    }

    /// [`Self::choose`], with the samples of every pixel (row-major) where they differ between
    /// pixels (None: every pixel gets the budget's spp).
    pub fn plan(
        &self,
        pilot: &Image,
        reference: &Image,
        cfg: &CompareConfig,
    ) -> Result<(Budget, Option<Vec<u32>>), CompareError> {
        let g = self.granularity.max(1) as f64;
        let clamp = |required: Option<f64>| {
            let spp = match required {
                Some(r) if r.is_finite() => (r / g).ceil() * g,
                Some(_) => f64::INFINITY,
                None => self.min_spp as f64,
            };
            (
                spp.clamp(self.min_spp as f64, self.max_spp as f64) as u32,
                spp > self.max_spp as f64,
            )
        };
        match self.target {
            Target::Parity { quantile: q } => {
                let required = quantile(parity_ratios(pilot, self.pilot_spp, reference), q);
                let (spp, capped) = clamp(required);
                Ok((
                    Budget {
                        spp,
                        pixel_spp_max: spp,
                        pixel_spp_mean: spp as f64,
                        required_spp: required,
                        capped,
                        bound: Bound::Parity,
                        tests: None,
                    },
                    None,
                ))
            }
            Target::Tests {
                power,
                tile_bias,
                per_tile,
            } => {
                let c =
                    Constraints::measure(pilot, self.pilot_spp, reference, cfg, power, tile_bias)?;
                let at_minimum = clamp(Some(c.required)).0 == self.min_spp
                    && (self.min_spp as f64) >= c.required;
                let bound = if at_minimum { Bound::Minimum } else { c.bound };
                if !per_tile {
                    let (spp, capped) = clamp(Some(c.required));
                    let budget = Budget {
                        spp,
                        pixel_spp_max: spp,
                        pixel_spp_mean: spp as f64,
                        required_spp: Some(c.required),
                        capped,
                        bound,
                        tests: Some(c.delivered(spp, |_| spp)),
                    };
                    return Ok((budget, None));
                }
                // Every pixel: the global need; the pixels of a covered tile: at least its own.
                let (spp, global_capped) = clamp(Some(c.plan.global_spp));
                let (w, h) = (reference.width, reference.height);
                let mut pixels = vec![spp; w * h];
                let mut capped = global_capped;
                for (_, r, n) in &c.covered {
                    let (n, tile_capped) = clamp(Some(*n));
                    capped |= tile_capped;
                    for y in r.y..(r.y + r.height).min(h) {
                        for p in &mut pixels[y * w + r.x..y * w + (r.x + r.width).min(w)] {
                            *p = (*p).max(n);
                        }
                    }
                }
                let tile_spp = |r: &Region| {
                    (r.y..(r.y + r.height).min(h))
                        .flat_map(|y| (r.x..(r.x + r.width).min(w)).map(move |x| y * w + x))
                        .map(|i| pixels[i])
                        .min()
                        .unwrap_or(spp)
                };
                let tests = c.delivered(spp, tile_spp);
                let max = pixels.iter().copied().max().unwrap_or(spp);
                let mean = pixels.iter().map(|&n| n as f64).sum::<f64>() / pixels.len() as f64;
                let budget = Budget {
                    spp,
                    pixel_spp_max: max,
                    pixel_spp_mean: mean,
                    required_spp: Some(c.required),
                    capped,
                    bound,
                    tests: Some(tests),
                };
                Ok((budget, (max > spp).then_some(pixels)))
            }
        }
    }
}

/// How precise the render A is relative to the reference B, over pixels and channels where
/// both variances are positive.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct Precision {
    /// Share of pixel channels with v_A ≤ v_B.
    pub at_least_as_precise: f64,
    /// Median of v_A / v_B.
    pub median_variance_ratio: Option<f64>,
}

pub fn precision(a: &Image, b: &Image) -> Precision {
    let ratios: Vec<f64> = a
        .var
        .iter()
        .zip(&b.var)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64, y[c] as f64)))
        .filter(|&(va, vb)| va > 0.0 && vb > 0.0)
        .map(|(va, vb)| va / vb)
        .collect();
    let n = ratios.len();
    let ok = ratios.iter().filter(|&&r| r <= 1.0).count();
    Precision {
        at_least_as_precise: if n == 0 { 1.0 } else { ok as f64 / n as f64 },
        median_variance_ratio: quantile(ratios, 0.5),
    }
}

#[cfg(test)]
mod tests;
