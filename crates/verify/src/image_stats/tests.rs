use super::*;
use linlight_sampling::rng::Pcg32;

const W: usize = 128;
const H: usize = 128;
const PASSES: usize = 32;

/// A smooth, strictly positive "true" image.
fn truth(x: usize, y: usize) -> [f64; 3] {
    let (u, v) = ((x as f64 + 0.5) / W as f64, (y as f64 + 0.5) / H as f64);
    [
        0.2 + 0.6 * u * v + 0.1 * (6.0 * u).sin().powi(2),
        0.5 + 0.3 * (3.0 * v).cos(),
        0.1 + 0.8 * u * (1.0 - v),
    ]
}

fn normal(rng: &mut Pcg32) -> f64 {
    let u1 = 1.0 - rng.next_f64();
    let u2 = rng.next_f64();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Gamma(a, 1) for a ≥ 1 (Marsaglia–Tsang squeeze/rejection).
fn gamma(rng: &mut Pcg32, a: f64) -> f64 {
    let d = a - 1.0 / 3.0;
    let c = 1.0 / (9.0 * d).sqrt();
    loop {
        let x = normal(rng);
        let v = (1.0 + c * x).powi(3);
        if v <= 0.0 {
            continue;
        }
        let u = 1.0 - rng.next_f64();
        if u.ln() < 0.5 * x * x + d - d * v + d * v.ln() {
            return d * v;
        }
    }
}

/// A "render" of `truth` scaled by `scale(x, y)`: per pixel and channel PASSES independent
/// pass values T + σ g with σ = noise·T, g ~ N(0, 1); the image holds their mean and the
/// unbiased variance of that mean, dof = PASSES − 1, so t statistics are exactly t.
/// Drawn directly from the joint law of (mean, S²) of P normal samples — independent,
/// mean ~ N(μ, σ²/P), (P − 1) S²/σ² ~ χ²(P − 1) = 2·Gamma((P − 1)/2) — which is the same
/// distribution as simulating the passes, at 3 instead of 32 draws.
#[allow(clippy::needless_range_loop)]
fn render(seed: u64, noise: f64, scale: impl Fn(usize, usize) -> f64) -> Image {
    let mut rng = Pcg32::new(seed, 0x1ab);
    let mut img = Image::new(W, H);
    let p = PASSES as f64;
    img.meta.dof = p - 1.0;
    img.meta.passes = PASSES as u64;
    for y in 0..H {
        for x in 0..W {
            let t = truth(x, y);
            let k = scale(x, y);
            for c in 0..3 {
                let sigma = noise * t[c];
                let mean = t[c] * k + sigma / p.sqrt() * normal(&mut rng);
                let s2 = sigma * sigma * 2.0 * gamma(&mut rng, 0.5 * (p - 1.0)) / (p - 1.0);
                img.mean[y * W + x][c] = mean as f32;
                img.var[y * W + x][c] = (s2 / p) as f32;
            }
        }
    }
    img
}

/// The literal simulation the fast `render` replaces: same moments of mean and variance.
#[test]
fn fast_render_matches_pass_simulation_in_distribution() {
    let mut rng = Pcg32::new(77, 3);
    let n = 20_000;
    let p = PASSES as f64;
    let (mut m1, mut v1, mut m2, mut v2) = (0.0, 0.0, 0.0, 0.0);
    let mut xs = [0.0f64; PASSES];
    for _ in 0..n {
        xs.iter_mut().for_each(|v| *v = normal(&mut rng));
        let mean = xs.iter().sum::<f64>() / p;
        let s2 = xs.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (p - 1.0);
        m1 += mean * mean;
        v1 += s2;
        let mean_fast = normal(&mut rng) / p.sqrt();
        let s2_fast = 2.0 * gamma(&mut rng, 0.5 * (p - 1.0)) / (p - 1.0);
        m2 += mean_fast * mean_fast;
        v2 += s2_fast;
    }
    let nf = n as f64;
    // E[mean²] = 1/P (sd ≈ √2/P/√n), E[S²] = 1 (sd ≈ √(2/(P−1))/√n).
    let (sd_m, sd_v) = (2f64.sqrt() / p / nf.sqrt(), (2.0 / (p - 1.0) / nf).sqrt());
    for (m, v) in [(m1 / nf, v1 / nf), (m2 / nf, v2 / nf)] {
        assert!((m - 1.0 / p).abs() < 5.0 * sd_m, "{m}");
        assert!((v - 1.0).abs() < 5.0 * sd_v, "{v}");
    }
}

fn failed(cmp: &Comparison, test: TestKind) -> bool {
    cmp.failures
        .iter()
        .chain(&cmp.not_equivalent)
        .any(|f| f.test == test)
}

/// Rejection by the difference tests at family level `alpha`, recomputed from the reported
/// p-values (the equivalence test has a different null and is excluded).
fn rejects_at(cmp: &Comparison, alpha: f64) -> bool {
    let a = alpha / cmp.tests as f64;
    cmp.channels.iter().any(|ch| {
        ch.global.p.is_some_and(|p| p <= a)
            || ch.tiles.worst.as_ref().is_some_and(|t| t.p_holm <= a)
            || ch.pixels.chi2_p.is_some_and(|p| p <= a)
            || ch.pixels.max_p.is_some_and(|p| p <= a)
    })
}

/// Smallest k with P(X ≥ k) ≤ tail and largest k with P(X ≤ k) ≤ tail, X ~ Bin(n, p).
fn binomial_bounds(n: u64, p: f64, tail: f64) -> (u64, u64) {
    use statrs::distribution::{Binomial, DiscreteCDF};
    let d = Binomial::new(p, n).unwrap();
    let hi = (0..=n)
        .find(|&k| k > 0 && d.sf(k - 1) <= tail)
        .unwrap_or(n + 1);
    let lo = (0..=n).take_while(|&k| d.cdf(k) <= tail).last();
    (lo.map_or(0, |k| k + 1), hi)
}

const NOISE: f64 = 0.3;

#[test]
fn seed_only_differences_are_consistent_and_calibrated() {
    let seeds = 50u64;
    let cfg = CompareConfig::default();
    let (mut rejected_01, mut rejected_20) = (0u64, 0u64);
    let (mut sum_z2, mut sum_t2, mut count) = (0.0f64, 0.0f64, 0usize);
    for s in 0..seeds {
        let a = render(1000 + 2 * s, NOISE, |_, _| 1.0);
        let b = render(1001 + 2 * s, NOISE, |_, _| 1.0);
        let cmp = compare(&a, &b, &cfg).unwrap();
        // Equivalence always holds here (CI half-width ≈ 0.2 % < δ = 0.5 %).
        assert!(
            !failed(&cmp, TestKind::Equivalence),
            "seed {s}: {:?}",
            cmp.failures
        );
        if cmp.verdict != Verdict::Consistent {
            rejected_01 += 1;
            eprintln!("seed {s} rejected at α = 0.01: {:?}", cmp.failures);
        }
        assert_eq!(cmp.verdict == Verdict::Different, rejects_at(&cmp, 0.01));
        rejected_20 += rejects_at(&cmp, 0.2) as u64;
        for ch in &cmp.channels {
            sum_z2 += ch.pixels.sum_z2;
            count += ch.pixels.tested;
        }
        for (i, (ma, mb)) in a.mean.iter().zip(&b.mean).enumerate() {
            for c in 0..3 {
                let d = ma[c] as f64 - mb[c] as f64;
                sum_t2 += d * d / (a.var[i][c] as f64 + b.var[i][c] as f64);
            }
        }
    }
    let mean_z2 = sum_z2 / count as f64;
    let mean_t2 = sum_t2 / count as f64;
    let sd = (2.0 / count as f64).sqrt();
    eprintln!(
            "false alarms over {seeds} seed pairs: {rejected_01} at α = 0.01, {rejected_20} at α = 0.2; \
             mean z² = {mean_z2:.5} (sd {sd:.5}), mean raw t² = {mean_t2:.5}"
        );
    // Family-wise false-alarm rate: binomial bounds at 0.1 % tail probability.
    let (_, hi) = binomial_bounds(seeds, 0.01, 1e-3);
    assert!(
        rejected_01 < hi,
        "{rejected_01} false alarms at α = 0.01 (bound {hi})"
    );
    let (lo, hi) = binomial_bounds(seeds, 0.2, 1e-3);
    assert!(
        (lo..hi).contains(&rejected_20),
        "{rejected_20} rejections at α = 0.2 outside [{lo}, {hi})"
    );
    // The z scores are standard normal (within 5 sd), while raw t² is inflated by about
    // ν/(ν − 2) for the Welch dof ν ∈ [31, 62] — the reason for the z transform.
    assert!((mean_z2 - 1.0).abs() < 5.0 * sd, "mean z² = {mean_z2}");
    assert!(mean_t2 > 1.0 + 10.0 * sd, "mean t² = {mean_t2}");
}

#[test]
fn one_percent_global_scale_error_is_rejected() {
    let cfg = CompareConfig::default();
    for s in 0..10 {
        let a = render(2000 + 2 * s, NOISE, |_, _| 1.01);
        let b = render(2001 + 2 * s, NOISE, |_, _| 1.0);
        let cmp = compare(&a, &b, &cfg).unwrap();
        assert_eq!(cmp.verdict, Verdict::Different);
        for ch in &cmp.channels {
            let g = &ch.global;
            let [lo, hi] = g.rel_ci.unwrap();
            if s == 0 {
                eprintln!(
                        "1 % scale, channel {}: rel diff {:+.4} % CI [{:+.4} %, {:+.4} %], t = {:.1}, p = {:.2e}",
                        ch.channel,
                        100.0 * g.rel_diff.unwrap(),
                        100.0 * lo,
                        100.0 * hi,
                        g.diff / g.std_err,
                        g.p.unwrap()
                    );
            }
            assert!(g.significant, "seed {s} channel {}", ch.channel);
            assert!(!g.equivalent);
            assert!(
                lo < 0.01 && hi > 0.01,
                "CI must cover the true 1 %: [{lo}, {hi}]"
            );
        }
    }
}

#[test]
fn five_percent_error_in_one_tile_is_caught_by_the_tile_test() {
    let cfg = CompareConfig::default();
    let region = Region {
        x: 48,
        y: 32,
        width: 16,
        height: 16,
    };
    let inside = |x: usize, y: usize| {
        (region.x..region.x + 16).contains(&x) && (region.y..region.y + 16).contains(&y)
    };
    let mut global_hits = 0;
    for s in 0..10 {
        let a = render(
            3000 + 2 * s,
            NOISE,
            |x, y| if inside(x, y) { 1.05 } else { 1.0 },
        );
        let b = render(3001 + 2 * s, NOISE, |_, _| 1.0);
        let cmp = compare(&a, &b, &cfg).unwrap();
        assert_eq!(cmp.verdict, Verdict::Different, "seed {s}");
        let tile_failures: Vec<_> = cmp
            .failures
            .iter()
            .filter(|f| f.test == TestKind::Tile)
            .collect();
        assert!(!tile_failures.is_empty(), "seed {s}: {:?}", cmp.failures);
        for f in &tile_failures {
            assert_eq!(f.region, Some(region), "worst tile is the modified one");
        }
        // Globally it is 256 of 16384 pixels, 0.08 % of the mean (≈ 1.3 standard errors):
        // the global test mostly misses it, and equivalence (±0.5 %) must still hold.
        global_hits += failed(&cmp, TestKind::GlobalMean) as usize;
        assert!(!failed(&cmp, TestKind::Equivalence));
        if s == 0 {
            for ch in &cmp.channels {
                let t = ch.tiles.worst.as_ref().unwrap();
                eprintln!(
                        "5 % tile, channel {}: worst tile ({}, {}) Holm p = {:.2e}, rejected {}; global p = {:.3}",
                        ch.channel, t.region.x, t.region.y, t.p_holm, ch.tiles.rejected,
                        ch.global.p.unwrap()
                    );
            }
        }
    }
    eprintln!("5 % tile: tile test rejected 10/10 seeds, global test {global_hits}/10");
}

/// Tile-test rejections over 10 seed pairs of a 5 % error in the 16×16 region at (x0, y0).
fn unaligned_region_hits(x0: usize, y0: usize, cfg: &CompareConfig, seed: u64) -> usize {
    let inside = |x: usize, y: usize| (x0..x0 + 16).contains(&x) && (y0..y0 + 16).contains(&y);
    let mut hits = 0;
    for s in 0..10 {
        let a = render(
            seed + 2 * s,
            NOISE,
            |x, y| if inside(x, y) { 1.05 } else { 1.0 },
        );
        let b = render(seed + 1 + 2 * s, NOISE, |_, _| 1.0);
        let cmp = compare(&a, &b, cfg).unwrap();
        if let Some(f) = cmp.failures.iter().find(|f| f.test == TestKind::Tile) {
            hits += 1;
            let r = f.region.unwrap();
            assert!(
                r.x < x0 + 16 && x0 < r.x + r.width && r.y < y0 + 16 && y0 < r.y + r.height,
                "worst tile {r:?} must overlap the region"
            );
        }
    }
    hits
}

#[test]
fn five_percent_error_in_an_unaligned_region_is_caught_by_the_shifted_grid() {
    let both = CompareConfig::default();
    let aligned_only = CompareConfig {
        shifted_tiles: false,
        ..CompareConfig::default()
    };
    // Region half a tile off the aligned grid: there it is split 8×8 into four tiles, the
    // shifted grid holds it whole.
    let half_both = unaligned_region_hits(40, 24, &both, 5000);
    let half_aligned = unaligned_region_hits(40, 24, &aligned_only, 5000);
    // Worst case for two grids: 4 px off one and 12 px off the other in x and y, the best
    // tile holds 12×12 of its pixels.
    let quarter_both = unaligned_region_hits(44, 28, &both, 6000);
    eprintln!(
        "unaligned 5 % region, tile-test rejections out of 10: half-tile offset {half_both} \
             (aligned grid only: {half_aligned}), quarter-tile offset {quarter_both}"
    );
    assert_eq!(half_both, 10);
    assert_eq!(quarter_both, 10);
}

#[test]
fn noisy_render_of_a_one_percent_off_truth_is_inconclusive_not_consistent() {
    let cfg = CompareConfig::default();
    for s in 0..5 {
        // 60× the noise: the difference tests cannot resolve 1 %, equivalence is not shown.
        let a = render(4000 + 2 * s, 60.0 * NOISE, |_, _| 1.01);
        let b = render(4001 + 2 * s, NOISE, |_, _| 1.0);
        let cmp = compare(&a, &b, &cfg).unwrap();
        assert_eq!(cmp.verdict, Verdict::Inconclusive, "{:?}", cmp.failures);
        assert!(cmp.failures.is_empty());
        assert!(failed(&cmp, TestKind::Equivalence));
        let hint = cmp.precision.as_ref().expect("a samples-needed hint");
        assert_eq!(hint.limiting, "A", "{}", hint.text);
        // A holds 3600× the variance of B: A alone can make it decidable, B alone cannot.
        assert!(hint.factor_a.is_some_and(|f| f > 1.0), "{}", hint.text);
        assert_eq!(hint.factor_b, None, "{}", hint.text);
        if s == 0 {
            eprintln!("noisy 1 %: {}", hint.text);
        }
    }
    // Noise alone is enough to withhold "consistent": a noisy render of the exact truth.
    let a = render(4100, 60.0 * NOISE, |_, _| 1.0);
    let b = render(4101, NOISE, |_, _| 1.0);
    let cmp = compare(&a, &b, &cfg).unwrap();
    assert!(failed(&cmp, TestKind::Equivalence));
    assert_eq!(cmp.verdict, Verdict::Inconclusive);
    assert_eq!(cmp.verdict.exit_code(), 3);
}

#[test]
fn a_noisy_reference_is_named_as_the_limit_with_the_samples_it_needs() {
    let cfg = CompareConfig::default();
    // Same technique: B has 5.5² ≈ 30× fewer samples than A, so 30× its variance (per-pixel
    // relative standard error 0.29, still resolved by its own samples: n ≥ 10·CV²).
    let mut a = render(4200, NOISE, |_, _| 1.0);
    let mut b = render(4201, 5.5 * NOISE, |_, _| 1.0);
    a.meta.spp = 4096;
    b.meta.spp = 136;
    let cmp = compare(&a, &b, &cfg).unwrap();
    assert_eq!(cmp.verdict, Verdict::Inconclusive, "{:?}", cmp.failures);
    let hint = cmp.precision.as_ref().unwrap();
    assert_eq!(hint.limiting, "B", "{}", hint.text);
    assert_eq!(
        hint.factor_a, None,
        "more samples of A cannot help: {}",
        hint.text
    );
    let f = hint.factor_b.unwrap();
    assert!(f > 1.0 && hint.spp_b == Some((136.0 * f).ceil() as u64));
    assert!(
        hint.text.contains("more samples of A alone cannot"),
        "{}",
        hint.text
    );
    // Taking the hint: B with f× the samples (variance / f) makes the comparison decidable.
    let mut b2 = render(4203, 5.5 * NOISE / (1.2 * f).sqrt(), |_, _| 1.0);
    b2.meta.spp = hint.spp_b.unwrap();
    let cmp = compare(&a, &b2, &cfg).unwrap();
    assert_eq!(cmp.verdict, Verdict::Consistent, "{:?}", cmp.not_equivalent);
}

fn flat(w: usize, h: usize, m: f32, v: f32) -> Image {
    let mut img = Image::new(w, h);
    img.mean.iter_mut().for_each(|p| *p = [m; 3]);
    img.var.iter_mut().for_each(|p| *p = [v; 3]);
    img.meta.dof = 15.0;
    img
}

fn exact(mut img: Image) -> Image {
    img.meta.extra.insert(KEY_VARIANCE.into(), "exact".into());
    img
}

#[test]
fn exact_zero_variance_values_are_counted_apart_and_must_agree() {
    let mut a = exact(flat(20, 10, 0.5, 1e-4));
    let mut b = exact(flat(20, 10, 0.5, 1e-4));
    for i in 0..20 {
        a.var[i] = [0.0; 3];
        b.var[i] = [0.0; 3];
        a.mean[i] = [3.0; 3];
        b.mean[i] = [3.0 * (1.0 + 2e-6); 3]; // within ε_rel = 1e-5
    }
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.zero_variance.count, 60);
    assert_eq!(cmp.zero_variance.mismatched, 0);
    assert_eq!(cmp.channels[0].pixels.tested, 180);
    assert_eq!(cmp.pixel_classes.zero_variance_agree, 60);
    assert_eq!(cmp.verdict, Verdict::Consistent, "{:?}", cmp.failures);

    b.mean[7][1] = 3.001;
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.verdict, Verdict::Different);
    assert_eq!(cmp.zero_variance.mismatched, 1);
    let f = &cmp.failures[0];
    assert_eq!((f.test, f.channel), (TestKind::ZeroVariance, "G"));
    assert_eq!(f.region, Some(Region::pixel(7, 0)));
}

#[test]
fn zero_sample_variance_is_bounded_by_the_rule_of_three_not_trusted() {
    // A dozen pixels where A (256 samples) saw only zeros while B is lit: a zero sample
    // variance, not a zero variance. Alone they must not make the comparison fail.
    let mut a = render(4300, NOISE, |_, _| 1.0);
    let b = render(4301, NOISE, |_, _| 1.0);
    a.meta.spp = 256;
    for k in 0..12 {
        let i = 37 * k + 5;
        a.mean[i] = [0.0; 3];
        a.var[i] = [0.0; 3];
    }
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.pixel_classes.zero_sample_variance, 36);
    assert_eq!(cmp.zero_variance.one_sided, 36);
    assert_eq!(cmp.verdict, Verdict::Consistent, "{:?}", cmp.failures);
    // The same pixels trusted with variance 0 would be |z| ≈ 20 or more.
    let z_naive = (b.mean[5][0] as f64) / (b.var[5][0] as f64).sqrt();
    assert!(z_naive > 20.0, "{z_naive}");
    // A whole black tile is still a difference: the bound keeps the tile test's power.
    let mut dark = a.clone();
    for y in 32..48 {
        for x in 64..80 {
            dark.mean[y * W + x] = [0.0; 3];
            dark.var[y * W + x] = [0.0; 3];
        }
    }
    let cmp = compare(&dark, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.verdict, Verdict::Different);
    assert!(failed(&cmp, TestKind::Tile), "{:?}", cmp.failures);
}

#[test]
fn rare_unseen_samples_make_a_pixel_undersampled_not_different() {
    // A pixel whose reference shows a rare bright part (per-sample CV² = v·n/m² = 400) that A's
    // 256 samples never met: A is low with a tiny variance. n_A = 256 < 10·CV².
    let mut a = flat(32, 32, 1.0, 1e-6);
    let mut b = flat(32, 32, 1.0, 1e-6);
    a.meta.spp = 256;
    b.meta.spp = 32768;
    b.meta.dof = 31.0;
    b.mean[100] = [1.6; 3];
    b.var[100] = [400.0 * 1.6 * 1.6 / 32768.0; 3];
    a.mean[100] = [1.0; 3];
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.maps.state[100][0], PixelState::Undersampled);
    assert_eq!(cmp.pixel_classes.undersampled, 3);
    assert!(!failed(&cmp, TestKind::PixelMax), "{:?}", cmp.failures);
    // Trusted as is, z = −0.6/√(v_B) ≈ −13; floored, A's variance is B's per-sample variance
    // over A's 256 samples: |z| ≈ 0.6/√(401·v_B/... ) < 1.
    assert!(cmp.maps.z[100][0].abs() < 1.5, "{}", cmp.maps.z[100][0]);
    // With the weighted mean μ ≈ m_A = 1, B shows CV² = 400·1.6² = 1024; with 64× the samples
    // A resolves it (16384 ≥ 10240) and is trusted as it is again.
    a.meta.spp = 16384;
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.maps.state[100][0], PixelState::Tested);
}

#[test]
fn heavy_tailed_pixels_are_flagged_and_left_to_tiles() {
    // Critical shares of the Grubbs test at 1e-3: about 0.43 for 32 terms, 0.08 for 256.
    let c32 = pixels::tail_share_critical(32.0, 1e-3).unwrap();
    let c256 = pixels::tail_share_critical(256.0, 1e-3).unwrap();
    assert!(
        (0.35..0.5).contains(&c32) && (0.05..0.1).contains(&c256),
        "{c32} {c256}"
    );
    assert_eq!(pixels::tail_share_critical(2.0, 1e-3), None);
    let mut a = render(4400, NOISE, |_, _| 1.0);
    let mut b = render(4401, NOISE, |_, _| 1.0);
    b.tail = Some(vec![[0.2; 3]; W * H]);
    // One pixel whose variance rests on one pass, far off (it would fail max|z| if trusted).
    let i = 50 * W + 50;
    b.tail.as_mut().unwrap()[i] = [0.9; 3];
    a.mean[i] = [b.mean[i][0] + 10.0 * b.var[i][0].sqrt(); 3];
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.maps.state[i][1], PixelState::HeavyTail);
    assert_eq!(cmp.pixel_classes.heavy_tail_b, 3);
    assert!(!failed(&cmp, TestKind::PixelMax), "{:?}", cmp.failures);
    a.tail = None;
    b.tail = None;
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert!(failed(&cmp, TestKind::PixelMax), "trusted, it fails");
}

/// A one-pass image whose pixels differ in sample count (certify's per-tile budget): each
/// pixel is judged with its own count — here the tail share's critical value, 0.08 for 256
/// terms but far lower for 4096, so a share of 0.05 flags a 4096-sample pixel only.
#[test]
fn pixels_are_judged_with_their_own_sample_count() {
    let mut a = render(4500, NOISE, |_, _| 1.0);
    let b = render(4501, NOISE, |_, _| 1.0);
    (a.meta.spp, a.meta.dof, a.meta.passes) = (256, 255.0, 1);
    a.tail = Some(vec![[1e-3; 3]; W * H]);
    let i = 40 * W + 40;
    a.tail.as_mut().unwrap()[i] = [0.05; 3];
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.maps.state[i][0], PixelState::Tested);
    let mut counts = vec![256; W * H];
    counts[i] = 4096;
    a.pixel_spp = Some(counts);
    let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.maps.state[i][0], PixelState::HeavyTail);
    assert_eq!(cmp.pixel_classes.heavy_tail_a, 3);
    // Every pixel at the header's count: the same comparison as without the channel.
    a.pixel_spp = Some(vec![256; W * H]);
    let same = compare(&a, &b, &CompareConfig::default()).unwrap();
    a.pixel_spp = None;
    let none = compare(&a, &b, &CompareConfig::default()).unwrap();
    assert_eq!(format!("{same:?}"), format!("{none:?}"));
}

#[test]
fn contact_pixels_are_tested_apart_against_the_finite_radius_allowance() {
    let a0 = render(4500, NOISE, |_, _| 1.0);
    let mut b = render(4501, NOISE, |_, _| 1.0);
    b.meta.extra.insert("radius".into(), "0.0001".into());
    // A radius without contact pixels: no pixel has an allowance, none is reported.
    let plain = compare(&a0, &b, &CompareConfig::default()).unwrap();
    assert!(plain.contact_pixels.is_empty());
    assert_eq!(plain.contact_allowance, 0.0);
    // A 1 % difference at 9 contact pixels: within c·R·ln(1/R) = 20·1e-4·9.21 = 1.84 %.
    let contact: Vec<(usize, usize)> = (60..63)
        .flat_map(|y| (60..63).map(move |x| (x, y)))
        .collect();
    let list = contact
        .iter()
        .map(|(x, y)| format!("{x},{y}"))
        .collect::<Vec<_>>()
        .join(";");
    let mut a = a0.clone();
    a.meta.extra.insert("contact_pixels".into(), list);
    // Contact pixels: B's value times k, both nearly exact (variance 1e-10).
    let scaled = |img: &Image, k: f32| {
        let mut out = img.clone();
        for &(x, y) in &contact {
            out.mean[y * W + x] = b.mean[y * W + x].map(|m| m * k);
            out.var[y * W + x] = [1e-10; 3];
        }
        out
    };
    let mut b_tight = scaled(&b, 1.0);
    b_tight.meta = b.meta.clone();
    let cmp = compare(&scaled(&a, 1.01), &b_tight, &CompareConfig::default()).unwrap();
    assert_eq!(cmp.contact_pixels.len(), 9);
    assert!((cmp.contact_allowance - 20.0 * 1e-4 * 1e4f64.ln()).abs() < 1e-12);
    assert_eq!(cmp.tests, 15, "a fifth test per channel");
    assert_eq!(cmp.pixel_classes.contact, 27);
    assert_eq!(cmp.verdict, Verdict::Consistent, "{:?}", cmp.failures);
    // 10 % is beyond the allowance.
    let cmp = compare(&scaled(&a, 1.10), &b_tight, &CompareConfig::default()).unwrap();
    assert!(failed(&cmp, TestKind::Contact), "{:?}", cmp.failures);
    // A malformed list is unusable input.
    a.meta.extra.insert("contact_pixels".into(), "3;4".into());
    assert!(compare(&a, &b, &CompareConfig::default()).is_err());
}

#[test]
fn different_scenes_are_refused_unless_allowed() {
    let mut a = flat(4, 4, 1.0, 0.1);
    let mut b = a.clone();
    a.meta.scene_sha256 = "aa".repeat(32);
    b.meta.scene_sha256 = "bb".repeat(32);
    b.meta
        .extra
        .insert("scene".into(), "cornell-tube.xml".into());
    let err = compare(&a, &b, &CompareConfig::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("different scene files") && err.contains("cornell-tube.xml"),
        "{err}"
    );
    let allow = CompareConfig {
        allow_different_scenes: true,
        ..CompareConfig::default()
    };
    assert!(compare(&a, &b, &allow).is_ok());
    // One side without a hash (a foreign image) is not refused.
    a.meta.scene_sha256.clear();
    assert!(compare(&a, &b, &CompareConfig::default()).is_ok());
}

#[test]
fn exact_images_compare_exactly() {
    // No variance anywhere: only the zero-variance check and exact equivalence apply.
    let a = exact(flat(5, 5, 0.25, 0.0));
    let cmp = compare(&a, &a.clone(), &CompareConfig::default()).unwrap();
    assert_eq!(cmp.verdict, Verdict::Consistent);
    assert_eq!(cmp.channels[2].global.rel_ci, Some([0.0, 0.0]));
    // An all-black channel in both is equivalent; black reference vs non-black is not.
    let mut black = exact(flat(5, 5, 0.0, 0.0));
    let cmp = compare(&black, &black.clone(), &CompareConfig::default()).unwrap();
    assert_eq!(cmp.verdict, Verdict::Consistent);
    black.var[3] = [1e-3; 3];
    let mut other = black.clone();
    other.mean[3] = [0.01; 3];
    let cmp = compare(&other, &black, &CompareConfig::default()).unwrap();
    assert!(failed(&cmp, TestKind::Equivalence));
    assert_eq!(cmp.channels[0].global.rel_diff, None);
}

#[test]
fn unusable_inputs_are_errors() {
    let cfg = CompareConfig::default();
    let a = flat(4, 4, 1.0, 0.1);
    assert!(compare(&a, &flat(4, 5, 1.0, 0.1), &cfg).is_err());
    let mut no_dof = a.clone();
    no_dof.meta.dof = 0.0;
    let err = compare(&a, &no_dof, &cfg).unwrap_err();
    assert!(
        err.to_string()
            .contains("image B has no variance estimate (dof = 0"),
        "{err}"
    );
    // An exact image needs no dof.
    assert!(compare(&a, &exact(no_dof), &cfg).is_ok());
    let mut nan = a.clone();
    nan.mean[5][2] = f32::NAN;
    assert!(compare(&nan, &a, &cfg).is_err());
    let bad = CompareConfig {
        alpha: 1.5,
        ..cfg.clone()
    };
    assert!(compare(&a, &a, &bad).is_err());
    let bad = CompareConfig { tile: 0, ..cfg };
    assert!(compare(&a, &a, &bad).is_err());
}

#[test]
fn holm_adjustment() {
    let adj = holm_adjust(&[0.01, 0.04, 0.03, 0.5]);
    // Sorted: 0.01·4 = 0.04, 0.03·3 = 0.09, 0.04·2 = 0.08 → max 0.09, 0.5·1 = 0.5.
    let expect = [0.04, 0.09, 0.09, 0.5];
    for (x, e) in adj.iter().zip(expect) {
        assert!((x - e).abs() < 1e-12, "{adj:?}");
    }
    assert!(holm_adjust(&[]).is_empty());
}

#[test]
fn report_serialises_without_nulls_for_tested_values() {
    let a = flat(33, 17, 1.0, 0.01);
    let mut b = a.clone();
    b.mean[40] = [1.2; 3];
    let cmp = compare(
        &a,
        &b,
        &CompareConfig {
            tile: 8,
            ..Default::default()
        },
    )
    .unwrap();
    let json = serde_json::to_value(&cmp).unwrap();
    // v = 0.01 per pixel: the ±0.5 % margin cannot be resolved, nothing differs.
    assert_eq!(json["verdict"], "Inconclusive");
    assert!(json["precision"]["text"].is_string());
    assert!(json["metrics"]["mse"].is_number());
    assert_eq!(json["channels"][1]["channel"], "G");
    assert!(json["channels"][0]["pixels"]["chi2_p"].is_number());
    assert!(json["channels"][0]["tiles"]["worst"]["p_holm"].is_number());
    // Aligned grid 5 × 3 tiles, half-shifted grid (boundaries at 4, 12, ...) also 5 × 3.
    assert_eq!(json["channels"][0]["tiles"]["tiles_total"], 5 * 3 + 5 * 3);
    // The edge tile is clipped to the image.
    let w = &cmp.channels[0].tiles.worst.as_ref().unwrap().region;
    assert!(w.x + w.width <= 33 && w.y + w.height <= 17);
}

#[test]
fn leaving_out_undersampled_pixels_does_not_bias_the_z_scores() {
    // Relative standard error ≈ 1.8/√32 = 0.32 per pixel: about half the pixels fall under the
    // rule μ² < k·v (k = 10) and get a floored variance. Floors only raise variances: the z²
    // of all tested pixels must not average above 1.
    let (mut sum_z2, mut n, mut floored) = (0.0, 0usize, 0usize);
    for s in 0..4 {
        let mut a = render(4600 + 2 * s, 1.8, |_, _| 1.0);
        let mut b = render(4601 + 2 * s, 1.8, |_, _| 1.0);
        a.meta.spp = 32 * 64;
        b.meta.spp = 32 * 64;
        let cmp = compare(&a, &b, &CompareConfig::default()).unwrap();
        for ch in &cmp.channels {
            sum_z2 += ch.pixels.sum_z2;
            n += ch.pixels.tested;
        }
        floored += cmp.pixel_classes.undersampled;
    }
    let mean = sum_z2 / n as f64;
    let sd = (2.0 / n as f64).sqrt();
    eprintln!(
        "undersampled rule: {floored} floored of {n} tested, mean z² = {mean:.4} (sd {sd:.4})"
    );
    assert!(floored > n / 4 && floored < n, "{floored} of {n}");
    assert!(mean < 1.0 + 3.0 * sd, "mean z² = {mean}");
}
