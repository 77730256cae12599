use super::*;
use linlight_verify::image_stats::Verdict;

fn flat(var: f32) -> Image {
    let mut img = Image::new(4, 4);
    img.mean.iter_mut().for_each(|m| *m = [1.0; 3]);
    img.var.iter_mut().for_each(|v| *v = [var; 3]);
    img.meta.dof = 31.0;
    img
}

#[test]
fn parity_matches_the_reference_variance() {
    // σ² = 256 · 1e-4 = 0.0256 per sample, reference 1e-6 → 25 600 spp.
    let rule = BudgetRule::parity();
    let cfg = CompareConfig::default();
    let b = rule.choose(&flat(1e-4), &flat(1e-6), &cfg).unwrap();
    assert_eq!(b.spp, 25_600);
    assert!(!b.capped);
    assert_eq!(b.bound, Bound::Parity);
    let capped = BudgetRule {
        max_spp: 1024,
        ..rule
    }
    .choose(&flat(1e-4), &flat(1e-6), &cfg)
    .unwrap();
    assert_eq!((capped.spp, capped.capped), (1024, true));
    // Nothing to match (all black): the minimum.
    assert_eq!(
        rule.choose(&flat(0.0), &flat(1e-6), &cfg).unwrap().spp,
        rule.min_spp
    );
}

#[test]
fn quantile_ignores_rare_outliers() {
    let mut v = vec![1.0; 999];
    v.push(1e9);
    assert_eq!(quantile(v.clone(), 0.99), Some(1.0));
    assert_eq!(quantile(v, 1.0), Some(1e9));
    assert_eq!(quantile(vec![], 0.5), None);
}

#[test]
fn precision_counts_pixels() {
    let p = precision(&flat(1e-6), &flat(2e-6));
    assert_eq!(p.at_least_as_precise, 1.0);
    assert_eq!(p.median_variance_ratio, Some(0.5));
}

#[test]
fn one_constraint() {
    // V_A = 4/100² = 4e-4, V_B = 1e-6/1e4 = 1e-10... with T = (0.005/5)² = 1e-6.
    let s = SetSums {
        sigma2_a: 4.0,
        var_b: 1e-2,
        mean_b: 100.0,
    };
    let (va, vb) = (4e-4, 1e-6);
    let t: f64 = 1e-6 * 4.0;
    // T = (0.01/5)² = 4e-6: N = V_A/(T − V_B) = 4e-4/3e-6.
    match need(&s, 0.01, 5.0) {
        Need::Spp(n) => assert!((n - va / (t - vb)).abs() < 1e-6 * n, "{n}"),
        other => panic!("{other:?}"),
    }
    // T = (0.005/5)² = 1e-6 ≤ V_B/0.8: reference-limited, A gets 4·V_A/V_B.
    match need(&s, 0.005, 5.0) {
        Need::ReferenceLimited(n) => assert!((n - 4.0 * va / vb).abs() < 1e-6 * n, "{n}"),
        other => panic!("{other:?}"),
    }
    // No signal, or no variance: nothing to ask.
    let dark = SetSums { mean_b: 0.0, ..s };
    assert_eq!(need(&dark, 0.05, 5.0), Need::Nothing);
    let exact = SetSums { sigma2_a: 0.0, ..s };
    assert_eq!(need(&exact, 0.05, 5.0), Need::Nothing);
}

/// Deterministic normal variates (SplitMix64 + Box–Muller).
struct Normal(u64);

impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn next(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * self.uniform()).cos()
    }
}

const SIZE: usize = 64;
/// The dark tile of the synthetic scene (a tile of the grid shifted by half a tile).
const DARK: Region = Region {
    x: 24,
    y: 24,
    width: 16,
    height: 16,
};

fn in_dark(i: usize) -> bool {
    let (x, y) = (i % SIZE, i / SIZE);
    (DARK.x..DARK.x + 16).contains(&x) && (DARK.y..DARK.y + 16).contains(&y)
}

/// True mean and per-sample variance of pixel i: 1 and 4 (CV² = 4) everywhere, 0.1 and 0.4
/// (CV² = 40) in the dark tile when `dark`.
fn truth(i: usize, dark: bool) -> (f64, f64) {
    if dark && in_dark(i) {
        (0.1, 0.4)
    } else {
        (1.0, 4.0)
    }
}

/// An image of `spp` samples per pixel (None: a reference) whose pixel means are normal around
/// the truth (× `scale` where `biased`), with exact variances of the mean.
fn image(
    spp: Option<&[u32]>,
    ref_var: f64,
    dark: bool,
    rng: &mut Normal,
    scale: f64,
    biased: impl Fn(usize) -> bool,
) -> Image {
    let mut img = Image::new(SIZE, SIZE);
    for i in 0..SIZE * SIZE {
        let (mu, s2) = truth(i, dark);
        let v = spp.map_or(ref_var * mu * mu, |n| s2 / n[i] as f64);
        let k = if biased(i) { scale } else { 1.0 };
        for c in 0..3 {
            img.mean[i][c] = (k * (mu + v.sqrt() * rng.next())) as f32;
            img.var[i][c] = (k * k * v) as f32;
        }
    }
    let fewest = spp.map(|n| *n.iter().min().unwrap());
    img.meta.spp = fewest.map_or(32_768, u64::from);
    img.meta.dof = fewest.map_or(31.0, |n| n as f64 - 1.0);
    img.pixel_spp = spp
        .filter(|n| n.iter().any(|&x| Some(x) != fewest))
        .map(<[u32]>::to_vec);
    img
}

/// The samples of every pixel at a budget, scaled by `scale`.
fn counts(budget: &(Budget, Option<Vec<u32>>), scale: f64) -> Vec<u32> {
    let plan = budget.1.clone().unwrap_or(vec![budget.0.spp; SIZE * SIZE]);
    plan.iter().map(|&n| (n as f64 * scale) as u32).collect()
}

/// Verdicts of `draws` renders at the budget against fresh references.
fn verdicts(
    spp: &[u32],
    dark: bool,
    scale: f64,
    biased: impl Fn(usize) -> bool + Copy,
    draws: usize,
) -> (usize, usize) {
    let cfg = CompareConfig::default();
    let mut rng = Normal(spp.iter().map(|&n| n as u64).sum::<u64>() * 7919 + draws as u64);
    let (mut different, mut inconclusive) = (0, 0);
    for _ in 0..draws {
        let b = image(None, 1e-6, dark, &mut rng, 1.0, |_| false);
        let a = image(Some(spp), 0.0, dark, &mut rng, scale, biased);
        match compare(&a, &b, &cfg).unwrap().verdict {
            Verdict::Different => different += 1,
            Verdict::Inconclusive => inconclusive += 1,
            Verdict::Consistent => {}
        }
    }
    (different, inconclusive)
}

/// The test-power rule with a 5 % tile target (certify's default is 1 %; at 5 % the synthetic
/// scenes have a global-bound and a tile-bound case).
fn rule(per_tile: bool) -> BudgetRule {
    BudgetRule {
        min_spp: 64,
        target: Target::Tests {
            power: 0.99,
            tile_bias: 0.05,
            per_tile,
        },
        ..BudgetRule::default()
    }
}

fn plan_of(dark: bool, per_tile: bool) -> (Budget, Option<Vec<u32>>) {
    let mut rng = Normal(1);
    // Noise-free pilot and reference means (the budget's sums are then exact): the pilot's
    // variances are the per-sample variances over 256, the reference's 1e-6 relative.
    let mut reference = image(None, 1e-6, dark, &mut rng, 1.0, |_| false);
    let mut pilot = image(Some(&[256; SIZE * SIZE]), 0.0, dark, &mut rng, 1.0, |_| {
        false
    });
    for i in 0..SIZE * SIZE {
        pilot.mean[i] = [truth(i, dark).0 as f32; 3];
        reference.mean[i] = pilot.mean[i];
    }
    rule(per_tile)
        .plan(&pilot, &reference, &CompareConfig::default())
        .unwrap()
}

fn budget_of(dark: bool) -> Budget {
    plan_of(dark, true).0
}

/// The global constraint binds on a uniform image: V_A = 4/4096 per sample, V_B ≈ 1e-6/4096,
/// T = (0.5 %/k_g)² with k_g = z(α/24) + z(0.99) at α = 0.01.
#[test]
fn the_global_test_sets_the_budget_of_a_uniform_image() {
    let b = budget_of(false);
    let t = b.tests.unwrap();
    assert_eq!(b.bound, Bound::Global, "{b:?}");
    let k = normal_two_sided_quantile(0.01 / 12.0) + normal_two_sided_quantile(0.02);
    assert!((t.k_global - k).abs() < 1e-9, "{} vs {k}", t.k_global);
    let want = (4.0 / 4096.0) / ((0.005 / k).powi(2) - 1e-6 / 4096.0);
    assert!(
        (t.global_spp - want).abs() < 1e-6 * want,
        "{} vs {want}",
        t.global_spp
    );
    assert_eq!(b.spp, (want / 64.0).ceil() as u32 * 64);
    assert!(t.detectable_global_bias <= 0.005 && t.detectable_global_bias > 0.0045);
    // 16 aligned + 9 full shifted tiles, all resolvable.
    assert_eq!((t.tiles, t.tiles_covered), (25, 25));
}

/// A dark, noisy tile sets the budget when its constraint is the largest: per tile, only its
/// pixels get its need (the rest what the global test needs); uniformly, every pixel.
#[test]
fn a_dark_tile_sets_the_budget() {
    let (b, pixels) = plan_of(true, true);
    let t = b.tests.unwrap();
    assert_eq!(b.bound, Bound::Tile(DARK), "{b:?}");
    assert_eq!(t.hardest_tile, Some(DARK));
    assert!(t.tile_spp > t.global_spp);
    assert!(t.detectable_tile_bias.unwrap() <= 0.05);
    assert!(t.detectable_global_bias <= 0.005);
    let pixels = pixels.expect("per-pixel counts");
    let tile = (t.tile_spp / 64.0).ceil() as u32 * 64;
    assert_eq!(b.spp, (t.global_spp / 64.0).ceil() as u32 * 64);
    for (i, &n) in pixels.iter().enumerate() {
        assert_eq!(n, if in_dark(i) { tile } else { b.spp }, "pixel {i}");
    }
    assert_eq!(b.pixel_spp_max, tile);
    let mean = (256.0 * tile as f64 + (4096.0 - 256.0) * b.spp as f64) / 4096.0;
    assert!((b.pixel_spp_mean - mean).abs() < 1e-9);

    let (u, none) = plan_of(true, false);
    assert_eq!(none, None);
    assert_eq!((u.spp, u.pixel_spp_max), (tile, tile));
    assert_eq!(u.bound, Bound::Tile(DARK));
}

/// The budget delivers what it promises: at its spp a 0.5 % global bias and a 5 % bias of the
/// hardest tile are rejected (design power 0.99 per channel), an unbiased render is
/// consistent (false alarms ≤ α, equivalence shown with probability 0.99) — and at an eighth
/// of it the same biases mostly pass: the budget is not wasteful. At N/8 the bias is
/// k/√8 ≈ 2.0 standard errors instead of k ≈ 5.7, a per-channel power of Φ(2.0 − z_t) ≈ 9 % for
/// the global test (z_t = 3.34); the synthetic channels are independent, so about
/// 1 − 0.91³ ≈ 25 % of the renders are rejected (at N/4 it would be 1 − 0.69³ ≈ 67 %: the
/// three channels of a real render are nearly one, which is why the design is per channel).
#[test]
fn the_budget_has_the_power_it_promises() {
    let draws = 100;
    let plan = plan_of(false, true);
    let uniform = counts(&plan, 1.0);
    let spp = plan.0.spp;
    let (d, i) = verdicts(&uniform, false, 1.0, |_| false, draws);
    assert!(
        d <= 3 && i <= 4,
        "unbiased at {spp} spp: {d} different, {i} inconclusive"
    );
    let (d, _) = verdicts(&uniform, false, 1.005, |_| true, draws);
    assert!(
        d >= 96,
        "0.5 % global bias at {spp} spp: {d}/{draws} rejected"
    );
    let (d, _) = verdicts(&counts(&plan, 0.125), false, 1.005, |_| true, draws);
    assert!(
        d <= 50,
        "0.5 % global bias at an eighth: {d}/{draws} rejected"
    );

    // Per tile: the dark tile's pixels at its need, the others at the global need.
    let plan = plan_of(true, true);
    let dark = counts(&plan, 1.0);
    let (d, i) = verdicts(&dark, true, 1.0, |_| false, draws);
    assert!(
        d <= 3 && i <= 4,
        "unbiased per tile: {d} different, {i} inconclusive"
    );
    let (d, _) = verdicts(&dark, true, 1.005, |_| true, draws);
    assert!(d >= 96, "0.5 % global bias per tile: {d}/{draws} rejected");
    let (d, _) = verdicts(&dark, true, 1.05, in_dark, draws);
    assert!(
        d >= 96,
        "5 % bias of the dark tile at {} spp: {d}/{draws} rejected",
        plan.0.pixel_spp_max
    );
    let (d, _) = verdicts(&counts(&plan, 0.125), true, 1.05, in_dark, draws);
    assert!(d <= 50, "5 % tile bias at an eighth: {d}/{draws} rejected");
}

#[test]
fn a_reference_limited_tile_is_not_covered() {
    let mut rng = Normal(3);
    let mut reference = image(None, 1e-6, true, &mut rng, 1.0, |_| false);
    // The dark tile's reference is so noisy that a 5 % bias there is beyond its resolution.
    for i in (0..SIZE * SIZE).filter(|&i| in_dark(i)) {
        reference.var[i] = [1e-2; 3];
    }
    let pilot = image(Some(&[256; SIZE * SIZE]), 0.0, true, &mut rng, 1.0, |_| {
        false
    });
    let b = rule(true)
        .choose(&pilot, &reference, &CompareConfig::default())
        .unwrap();
    let t = b.tests.unwrap();
    assert_eq!(t.tiles_covered, t.tiles - 1, "{t:?}");
    assert_ne!(t.hardest_tile, Some(DARK));
}

/// Light samples per camera sample: the largest power of two up to the rule's maximum that
/// leaves at least `min_spp` camera samples; one in packets or when the rule says so.
#[test]
fn light_samples_leave_min_spp_camera_samples() {
    let rule = BudgetRule::default();
    assert_eq!((rule.min_spp, rule.max_light_samples), (256, 8));
    for (spp, n) in [
        (0, 1),
        (256, 1),
        (511, 1),
        (512, 2),
        (1023, 2),
        (1024, 4),
        (2048, 8),
    ] {
        assert_eq!(rule.light_samples(spp, false), n, "{spp} spp");
    }
    assert_eq!(rule.light_samples(65_536, false), 8);
    assert_eq!(rule.light_samples(65_536, true), 1, "packets take one");
    let single = BudgetRule {
        max_light_samples: 1,
        ..rule
    };
    assert_eq!(single.light_samples(65_536, false), 1);
    // The pilot at N has as many light samples as the first, at least 32 camera samples.
    assert_eq!(rule.light_sample_pilot(8).pilot_spp, 32);
    assert_eq!(rule.light_sample_pilot(4).pilot_spp, 64);
    let small = BudgetRule {
        pilot_spp: 64,
        ..rule
    };
    assert_eq!(small.light_sample_pilot(8).pilot_spp, 32);
    // Old reports without the field read as one light sample.
    let json = serde_json::to_value(rule).unwrap();
    let mut old = json.clone();
    old.as_object_mut().unwrap().remove("max_light_samples");
    let read: BudgetRule = serde_json::from_value(old).unwrap();
    assert_eq!(read.max_light_samples, 1);
}

/// N light samples are kept only when their budget, at (2 + N·L)/(2 + L) the cost per camera
/// sample with L lights, costs less than one light sample's: not where the pixel footprint's
/// variance dominates.
#[test]
fn light_samples_are_kept_only_where_they_pay() {
    assert_eq!(CAMERA_SAMPLE_IN_LIGHT_SAMPLES, 2.0);
    assert_eq!(CAMERA_SAMPLE_IN_EXACT_TUBE_SAMPLES, 0.25);
    let at = |mean: f64| {
        let mut b = budget_of(false);
        (b.spp, b.pixel_spp_mean) = (256, mean);
        b
    };
    // Whether N light samples of L lights at a mean of `mean` spp pay against `one`.
    let pays = |one: f64, mean: f64, n: u32, lights: usize, exact_tubes: bool| {
        BudgetRule::light_samples_pay(&at(one), &at(mean), n, lights, exact_tubes)
    };
    let one = 27_776.0;
    // Light-sample variance only: N = 8 needs 1/8 of the camera samples (cost 10/3 / 8).
    assert!(pays(one, 3_472.0, 8, 1, false));
    // Half of the variance from the pixel footprint: 8 light samples cut it to 9/16 (cost 15/8).
    assert!(!pays(one, 15_624.0, 8, 1, false));
    // A sixth of it: 8 light samples cut it to 13/48 (cost 0.90; (1 + N)/2 would say 1.22).
    assert!(pays(one, 7_523.0, 8, 1, false));
    // Break-even at N = 2: 4/3 × the camera samples' cost (operands exact in f64:
    // 20 250 × 4 = 27 000 × 3).
    assert!(!pays(27_000.0, 20_250.0, 2, 1, false));
    assert!(pays(27_000.0, 20_250.0 - 64.0, 2, 1, false));
    // Two lights: (2 + 8·2)/(2 + 2) = 4.5 at N = 8, where the sixth above does not pay, and
    // no lights count as one.
    assert!(!pays(one, 7_523.0, 8, 2, false));
    assert!(pays(one, 3_472.0, 8, 2, false));
    assert!(pays(one, 7_523.0, 8, 0, false));
    // Exact tubes: (1/4 + 8)/(1/4 + 1) = 6.6 at N = 8: light-sample variance only pays, the
    // sixth does not.
    assert!(pays(one, 3_472.0, 8, 1, true));
    assert!(!pays(one, 7_523.0, 8, 1, true));
}
